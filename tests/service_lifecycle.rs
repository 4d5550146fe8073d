//! Job lifecycle over real HTTP: cancellation of a running job, a full
//! queue, the wall-time limit, result expiry, and restarts with the same
//! data directory (graceful, and `kill -9` of a real `isoremesh serve`).

#![cfg(feature = "service")]

mod service_support;

use std::time::{Duration, Instant};

use isoremesh::io::Format;
use serde_json::{json, Value};
use service_support::*;

/// A job that runs for many seconds: ~290k output faces, 50 iterations.
fn slow_job(s: &Server) -> String {
    s.submit_ok(
        "ball.off",
        sphere(4, Format::Off),
        json!({"target_edge_length": 0.01, "iterations": 50}),
    )
}

/// A job that runs for a second or so.
fn medium_params() -> Value {
    json!({"target_edge_length": 0.03, "iterations": 6})
}

fn running_with_progress(s: &Server, id: &str) -> Value {
    s.wait_for(id, Duration::from_secs(60), |j| {
        j["status"] == "running" && j["progress"]["iteration"].as_u64().unwrap_or(0) >= 1
    })
}

#[test]
fn a_running_job_stops_quickly_when_cancelled() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    let id = slow_job(&s);
    let job = running_with_progress(&s, &id);
    assert!(job["progress"]["fraction"].as_f64().unwrap() < 0.5, "{job}");
    // Before success the result is 409.
    assert_problem(s.get(&format!("/v1/jobs/{id}/result")), 409, None);

    let t0 = Instant::now();
    let r = s
        .client
        .post(s.url(&format!("/v1/jobs/{id}/cancel")))
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 202);
    let body: Value = r.json().unwrap();
    assert_eq!(body["cancel_requested"], true);
    let job = s.wait_for(&id, Duration::from_secs(10), |j| j["status"] == "cancelled");
    let took = t0.elapsed();
    assert!(took < Duration::from_millis(1500), "cancel took {took:?}");
    assert_eq!(job["cancel_requested"], false);
    assert!(job["finished_at"].is_string() && job["result"].is_null());
    // A finished job cannot be cancelled again, and has no result.
    let r = s
        .client
        .post(s.url(&format!("/v1/jobs/{id}/cancel")))
        .send()
        .unwrap();
    assert_problem(r, 409, None);
    assert_problem(s.get(&format!("/v1/jobs/{id}/result")), 409, None);
    let metrics = s.get("/metrics").text().unwrap();
    assert!(
        metrics.contains("isoremesh_jobs_finished_total{outcome=\"cancelled\"} 1"),
        "{metrics}"
    );
}

#[test]
fn a_full_queue_answers_503_and_accepts_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.queue_capacity = 1;
    let s = Server::start(cfg);
    let a = slow_job(&s);
    running_with_progress(&s, &a);
    let b = s.submit_ok("cube.obj", data("cube.obj"), json!({"iterations": 1}));
    let (_, job_b) = s.get_json(&format!("/v1/jobs/{b}"));
    assert_eq!(job_b["status"], "queued");
    assert_problem(s.get(&format!("/v1/jobs/{b}/result")), 409, None);

    let r = s.submit(
        "cube.obj",
        data("cube.obj"),
        Some(json!({"iterations": 1})),
        vec![],
    );
    assert_eq!(r.headers()["retry-after"], "5");
    let p = assert_problem(r, 503, None);
    assert!(p["type"].as_str().unwrap().ends_with("queue-full"));
    assert_eq!(p["retry_after"], 5);
    // Nothing half-accepted: two jobs listed, two directories.
    let (_, list) = s.get_json("/v1/jobs");
    assert_eq!(list["jobs"].as_array().unwrap().len(), 2);
    assert_eq!(
        std::fs::read_dir(dir.path().join("jobs")).unwrap().count(),
        2
    );
    let metrics = s.get("/metrics").text().unwrap();
    assert!(metrics.contains("isoremesh_queue_depth 1"), "{metrics}");
    assert!(metrics.contains("isoremesh_workers_busy 1"));
    assert!(metrics.contains("isoremesh_jobs_rejected_total 1"));

    // A queued job is cancelled at once and frees its slot.
    let r = s
        .client
        .post(s.url(&format!("/v1/jobs/{b}/cancel")))
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 200);
    let job_b: Value = r.json().unwrap();
    assert_eq!(job_b["status"], "cancelled");
    let c = s.submit_ok("cube.obj", data("cube.obj"), json!({"iterations": 1}));
    // DELETE of the running job stops it and frees the worker for c.
    let r = s
        .client
        .delete(s.url(&format!("/v1/jobs/{a}")))
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 204);
    let job_c = s.wait_finished(&c);
    assert_eq!(job_c["status"], "succeeded");
    assert!(!dir.path().join("jobs").join(&a).exists());
}

#[test]
fn a_job_past_its_time_limit_fails_with_a_clear_reason() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.job_timeout_secs = 1;
    let s = Server::start(cfg);
    let id = slow_job(&s);
    let job = s.wait_for(&id, Duration::from_secs(20), |j| j["status"] == "failed");
    let e = &job["error"];
    assert!(e["type"].as_str().unwrap().ends_with("job-timeout"), "{e}");
    assert!(
        e["detail"].as_str().unwrap().contains("limit of 1 s"),
        "{e}"
    );
    let started = job["started_at"].as_str().unwrap();
    let finished = job["finished_at"].as_str().unwrap();
    assert!(started < finished);
}

#[test]
fn results_expire_after_the_ttl() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.result_ttl_secs = 1;
    let s = Server::start(cfg);
    let id = s.submit_ok("cube.obj", data("cube.obj"), json!({"iterations": 1}));
    let job = s.wait_finished(&id);
    assert_eq!(job["status"], "succeeded");
    let r = s.get(&format!("/v1/jobs/{id}/result"));
    // Fetched right after success it is normally still there; once the TTL
    // has passed it is 410 whether or not the sweeper ran.
    let early = r.status().as_u16();
    assert!(early == 200 || early == 410);
    std::thread::sleep(Duration::from_millis(1100));
    let p = assert_problem(s.get(&format!("/v1/jobs/{id}/result")), 410, None);
    assert!(p["type"].as_str().unwrap().ends_with("result-expired"));
    // The sweeper removes the files and marks the job expired.
    let job = s.wait_for(&id, Duration::from_secs(10), |j| j["expired"] == true);
    assert_eq!(job["status"], "succeeded");
    // The record is rewritten through a temporary file and a rename, which
    // can still be in flight when the expired flag is first served: wait
    // for the directory to settle.
    let job_dir = dir.path().join("jobs").join(&id);
    let list = || -> Vec<String> {
        std::fs::read_dir(&job_dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect()
    };
    let deadline = std::time::Instant::now() + Duration::from_secs(5);
    while list() != ["job.json"] && std::time::Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(list(), vec!["job.json".to_string()]);
    assert_problem(
        s.get(&format!("/v1/jobs/{id}/result?format=obj")),
        410,
        None,
    );
}

#[test]
fn a_finished_result_survives_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    let send = |s: &Server| {
        let form = reqwest::blocking::multipart::Form::new()
            .part(
                "mesh",
                reqwest::blocking::multipart::Part::bytes(data("cube.obj")).file_name("cube.obj"),
            )
            .text(
                "params",
                json!({"iterations": 2, "output_format": "glb"}).to_string(),
            );
        s.client
            .post(s.url("/v1/jobs"))
            .header("idempotency-key", "restart-key")
            .multipart(form)
            .send()
            .unwrap()
    };
    let first: Value = send(&s).json().unwrap();
    let id = first["id"].as_str().unwrap().to_string();
    let before = s.wait_finished(&id);
    let bytes_before = s.get(&format!("/v1/jobs/{id}/result")).bytes().unwrap();
    s.stop();

    let s = Server::start(config(dir.path()));
    let (st, after) = s.get_json(&format!("/v1/jobs/{id}"));
    assert_eq!(st, 200);
    assert_eq!(after["status"], "succeeded");
    assert_eq!(after["stats"], before["stats"]);
    let r = s.get(&format!("/v1/jobs/{id}/result"));
    assert_eq!(r.status().as_u16(), 200);
    assert_eq!(
        r.headers()["etag"],
        before["result"]["etag"].as_str().unwrap()
    );
    assert_eq!(r.bytes().unwrap(), bytes_before);
    // The idempotency key was kept too.
    let r = send(&s);
    assert_eq!(r.status().as_u16(), 200);
    let again: Value = r.json().unwrap();
    assert_eq!(again["id"], id.as_str());
}

#[test]
fn a_job_interrupted_by_shutdown_runs_after_restart() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.shutdown_grace_secs = 0;
    let s = Server::start(cfg);
    let a = s.submit_ok("ball.off", sphere(3, Format::Off), medium_params());
    let b = s.submit_ok("cube.obj", data("cube.obj"), json!({"iterations": 1}));
    running_with_progress(&s, &a);
    s.stop();
    for id in [&a, &b] {
        let rec: Value = serde_json::from_slice(
            &std::fs::read(dir.path().join("jobs").join(id).join("job.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(rec["status"], "queued", "{id}");
    }
    let s = Server::start(config(dir.path()));
    for id in [&a, &b] {
        let job = s.wait_finished(id);
        assert_eq!(job["status"], "succeeded", "{job}");
    }
    let (_, job_a) = s.get_json(&format!("/v1/jobs/{a}"));
    assert_eq!(job_a["attempts"], 2);
}

/// A job that was running when the process died as often as the attempt
/// limit allows fails at the next start with a problem that says so, and
/// stays failed across further restarts; the other jobs still run.
#[test]
fn a_job_interrupted_too_often_fails_instead_of_running_again() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = kill_9_while_running(dir.path());
    let mut cfg = config(dir.path());
    cfg.max_attempts = 1;
    let s = Server::start(cfg);
    let job_a = s.wait_finished(&a);
    assert_eq!(job_a["status"], "failed", "{job_a}");
    assert_eq!(job_a["attempts"], 1);
    let e = &job_a["error"];
    assert!(
        e["type"].as_str().unwrap().ends_with("too-many-attempts"),
        "{e}"
    );
    assert!(
        e["detail"]
            .as_str()
            .unwrap()
            .contains("interrupted 1 times"),
        "{e}"
    );
    assert_eq!(s.wait_finished(&b)["status"], "succeeded");
    s.stop();
    let s = Server::start(config(dir.path()));
    let (_, again) = s.get_json(&format!("/v1/jobs/{a}"));
    assert_eq!(again["status"], "failed", "{again}");
    assert_eq!(again["attempts"], 1);
}

/// Runs the binary on `dir`, submits a slow job `a` and a quick job `b`,
/// and kills the process with SIGKILL while `a` runs; returns (a, b).
fn kill_9_while_running(dir: &std::path::Path) -> (String, String) {
    let (mut child, base) = spawn_binary(dir, &[]);
    let client = reqwest::blocking::Client::new();
    let t0 = Instant::now();
    while client.get(format!("{base}/readyz")).send().is_err() {
        assert!(t0.elapsed() < Duration::from_secs(30));
        std::thread::sleep(Duration::from_millis(20));
    }
    let submit = |mesh: Vec<u8>, name: &str, params: Value| -> String {
        let form = reqwest::blocking::multipart::Form::new()
            .part(
                "mesh",
                reqwest::blocking::multipart::Part::bytes(mesh).file_name(name.to_string()),
            )
            .text("params", params.to_string());
        let r = client
            .post(format!("{base}/v1/jobs"))
            .multipart(form)
            .send()
            .unwrap();
        assert_eq!(r.status().as_u16(), 202);
        r.json::<Value>().unwrap()["id"]
            .as_str()
            .unwrap()
            .to_string()
    };
    let a = submit(sphere(3, Format::Off), "ball.off", medium_params());
    let b = submit(data("cube.obj"), "cube.obj", json!({"iterations": 1}));
    let t0 = Instant::now();
    loop {
        let j: Value = client
            .get(format!("{base}/v1/jobs/{a}"))
            .send()
            .unwrap()
            .json()
            .unwrap();
        if j["status"] == "running" && j["progress"]["iteration"].as_u64().unwrap_or(0) >= 1 {
            break;
        }
        assert_ne!(
            j["status"], "succeeded",
            "the job finished before it could be killed"
        );
        assert!(t0.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(10));
    }
    child.kill().unwrap(); // SIGKILL: no graceful shutdown
    child.wait().unwrap();
    let status_on_disk = |id: &str| -> Value {
        let rec: Value = serde_json::from_slice(
            &std::fs::read(dir.join("jobs").join(id).join("job.json")).unwrap(),
        )
        .unwrap();
        rec["status"].clone()
    };
    assert_eq!(status_on_disk(&a), "running");
    assert_eq!(status_on_disk(&b), "queued");
    (a, b)
}

#[test]
fn jobs_interrupted_by_kill_9_complete_after_restart() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = kill_9_while_running(dir.path());
    let s = Server::start(config(dir.path()));
    for id in [&a, &b] {
        let job = s.wait_finished(id);
        assert_eq!(job["status"], "succeeded", "{job}");
        assert_eq!(
            s.get(&format!("/v1/jobs/{id}/result")).status().as_u16(),
            200
        );
    }
    let (_, job_a) = s.get_json(&format!("/v1/jobs/{a}"));
    assert_eq!(job_a["attempts"], 2);
}
