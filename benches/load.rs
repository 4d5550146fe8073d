//! A bounded load test of the HTTP service on loopback (plain `main`, no
//! harness): the server runs in-process on 127.0.0.1:0.
//!
//! 1. Peak memory with a large mesh in flight: one job on a 1.3M-triangle
//!    sphere, VmHWM from /proc/self/status before and after.
//! 2. Status polling while every worker is busy remeshing a medium mesh:
//!    N concurrent clients poll `GET /v1/jobs/{id}` for a bounded count and
//!    time; p50 / p99 / max latency.
//! 3. Throughput for small meshes: a bounded batch of small jobs, jobs/s.
//!
//! Run: `cargo bench --bench load` (knobs: LOAD_CLIENTS, LOAD_POLLS,
//! LOAD_SMALL_JOBS).

use std::time::{Duration, Instant};

use isoremesh::io::{self, Format};
use isoremesh::service::{self, ServiceConfig};
use reqwest::blocking::{multipart, Client};
use serde_json::{json, Value};

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn vm_kib(key: &str) -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with(key))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse().ok())
        })
        .unwrap_or(0)
}

fn submit(client: &Client, base: &str, name: &str, mesh: Vec<u8>, params: Value) -> String {
    let form = multipart::Form::new()
        .part(
            "mesh",
            multipart::Part::bytes(mesh).file_name(name.to_string()),
        )
        .text("params", params.to_string());
    let r = client
        .post(format!("{base}/v1/jobs"))
        .multipart(form)
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 202, "{:?}", r.text());
    r.json::<Value>().unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string()
}

fn status(client: &Client, base: &str, id: &str) -> Value {
    client
        .get(format!("{base}/v1/jobs/{id}"))
        .send()
        .unwrap()
        .json()
        .unwrap()
}

fn wait(client: &Client, base: &str, id: &str, pred: impl Fn(&Value) -> bool) -> Value {
    let t0 = Instant::now();
    loop {
        let j = status(client, base, id);
        if pred(&j) {
            return j;
        }
        assert!(t0.elapsed() < Duration::from_secs(600), "timeout: {j}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    sorted[((sorted.len() as f64 - 1.0) * p).round() as usize]
}

fn main() {
    let clients = env("LOAD_CLIENTS", 16);
    let polls = env("LOAD_POLLS", 2000);
    let small_jobs = env("LOAD_SMALL_JOBS", 60);
    let workers = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);

    let dir = tempfile::tempdir().unwrap();
    let mut cfg = ServiceConfig::for_data_dir(dir.path());
    cfg.workers = Some(workers);
    cfg.queue_capacity = 256;
    cfg.shutdown_grace_secs = 0;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    let listener = rt
        .block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))
        .unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let server = rt.spawn(service::run(listener, cfg, async move {
        let _ = rx.await;
    }));
    let client = Client::builder()
        .timeout(Duration::from_secs(600))
        .build()
        .unwrap();
    while client.get(format!("{base}/healthz")).send().is_err() {
        std::thread::sleep(Duration::from_millis(10));
    }
    println!("isoremesh load test: {workers} workers, loopback {base}");

    // 1. Peak memory with a large mesh in flight.
    let rss0 = vm_kib("VmRSS:");
    let large = io::write(
        &isoremesh::shapes::icosphere(8),
        Format::Glb,
        &Default::default(),
    )
    .unwrap();
    let t0 = Instant::now();
    let id = submit(&client, &base, "large.glb", large, json!({"iterations": 3}));
    let job = wait(&client, &base, &id, |j| {
        j["status"] != "queued" && j["status"] != "running"
    });
    println!(
        "large job: {} -> {} triangles, {} in {:.1} s; RSS before {:.0} MiB, peak (VmHWM) {:.0} MiB",
        job["input"]["triangles"],
        job["result"]["triangles"],
        job["status"],
        t0.elapsed().as_secs_f64(),
        rss0 as f64 / 1024.0,
        vm_kib("VmHWM:") as f64 / 1024.0
    );

    // 2. Status polling while every worker remeshes a medium mesh.
    let medium = io::write(
        &isoremesh::shapes::icosphere(5),
        Format::Glb,
        &Default::default(),
    )
    .unwrap();
    let busy: Vec<String> = (0..workers)
        .map(|_| {
            submit(
                &client,
                &base,
                "medium.glb",
                medium.clone(),
                json!({"target_edge_length": 0.004, "iterations": 30}),
            )
        })
        .collect();
    for id in &busy {
        wait(&client, &base, id, |j| j["status"] == "running");
    }
    let deadline = Instant::now() + Duration::from_secs(30);
    let t0 = Instant::now();
    let mut lat: Vec<Duration> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..clients)
            .map(|c| {
                let base = &base;
                let id = &busy[c % busy.len()];
                s.spawn(move || {
                    let client = Client::new();
                    let mut out = Vec::with_capacity(polls);
                    for _ in 0..polls {
                        if Instant::now() > deadline {
                            break;
                        }
                        let t = Instant::now();
                        let r = client.get(format!("{base}/v1/jobs/{id}")).send().unwrap();
                        assert_eq!(r.status().as_u16(), 200);
                        let _ = r.bytes().unwrap();
                        out.push(t.elapsed());
                    }
                    out
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    let wall = t0.elapsed();
    let still_busy = busy
        .iter()
        .filter(|id| status(&client, &base, id)["status"] == "running")
        .count();
    lat.sort();
    println!(
        "status polling: {} requests from {clients} clients in {:.1} s ({:.0} req/s) with {still_busy}/{workers} workers still remeshing: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
        lat.len(),
        wall.as_secs_f64(),
        lat.len() as f64 / wall.as_secs_f64(),
        percentile(&lat, 0.5).as_secs_f64() * 1e3,
        percentile(&lat, 0.99).as_secs_f64() * 1e3,
        lat.last().unwrap().as_secs_f64() * 1e3,
    );
    for id in &busy {
        client
            .post(format!("{base}/v1/jobs/{id}/cancel"))
            .send()
            .unwrap();
        wait(&client, &base, id, |j| {
            j["status"] == "cancelled" || j["status"] == "succeeded"
        });
    }

    // 3. Throughput for small meshes (320-triangle spheres, 3 iterations).
    let small = io::write(
        &isoremesh::shapes::icosphere(2),
        Format::Obj,
        &Default::default(),
    )
    .unwrap();
    let t0 = Instant::now();
    let ids: Vec<String> = (0..small_jobs)
        .map(|_| {
            submit(
                &client,
                &base,
                "small.obj",
                small.clone(),
                json!({"iterations": 3}),
            )
        })
        .collect();
    for id in &ids {
        let j = wait(&client, &base, id, |j| {
            j["status"] == "succeeded" || j["status"] == "failed"
        });
        assert_eq!(j["status"], "succeeded");
    }
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "small jobs: {small_jobs} submitted and finished in {secs:.2} s: {:.1} jobs/s",
        small_jobs as f64 / secs
    );
    println!(
        "peak RSS over the run (VmHWM): {:.0} MiB",
        vm_kib("VmHWM:") as f64 / 1024.0
    );

    let _ = tx.send(());
    rt.block_on(async {
        let _ = tokio::time::timeout(Duration::from_secs(30), server).await;
    });
}
