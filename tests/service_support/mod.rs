//! A real server for the service tests: the service runs in its own tokio
//! runtime on 127.0.0.1:0 and the tests talk to it over HTTP with reqwest's
//! blocking client, from the test thread.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use isoremesh::service::{self, ServiceConfig};
use reqwest::blocking::{multipart, Client, Response};
use serde_json::Value;

/// A running server.
pub struct Server {
    pub base: String,
    pub client: Client,
    pub data_dir: PathBuf,
    rt: Option<tokio::runtime::Runtime>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    handle: Option<tokio::task::JoinHandle<Result<(), service::StartError>>>,
}

/// The test defaults: one worker, small TTL-free limits.
pub fn config(dir: &Path) -> ServiceConfig {
    let mut c = ServiceConfig::for_data_dir(dir);
    c.workers = Some(1);
    c.shutdown_grace_secs = 10;
    c
}

impl Server {
    pub fn start(config: ServiceConfig) -> Server {
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .unwrap();
        let listener = rt
            .block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))
            .unwrap();
        let addr = listener.local_addr().unwrap();
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let data_dir = config.data_dir.clone();
        let handle = rt.spawn(service::run(listener, config, async move {
            let _ = rx.await;
        }));
        let client = Client::builder()
            .timeout(Duration::from_secs(60))
            .build()
            .unwrap();
        let base = format!("http://{addr}");
        let s = Server {
            base,
            client,
            data_dir,
            rt: Some(rt),
            stop: Some(tx),
            handle: Some(handle),
        };
        // Wait until the service has opened its data directory.
        let t0 = Instant::now();
        while s
            .client
            .get(s.url("/healthz"))
            .send()
            .map(|r| r.status().as_u16())
            .ok()
            != Some(200)
        {
            assert!(
                t0.elapsed() < Duration::from_secs(30),
                "server did not start"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        s
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{}", self.base, path)
    }

    /// Graceful stop: waits for the server to drain.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        if let (Some(rt), Some(h)) = (self.rt.take(), self.handle.take()) {
            rt.block_on(async {
                let _ = tokio::time::timeout(Duration::from_secs(60), h).await;
            });
            rt.shutdown_timeout(Duration::from_secs(5));
        }
    }

    pub fn get(&self, path: &str) -> Response {
        self.client.get(self.url(path)).send().unwrap()
    }

    pub fn get_json(&self, path: &str) -> (u16, Value) {
        let r = self.get(path);
        let status = r.status().as_u16();
        (status, r.json().unwrap())
    }

    /// Multipart submission: the mesh part, optional params, extra parts.
    pub fn submit(
        &self,
        file_name: &str,
        mesh: Vec<u8>,
        params: Option<Value>,
        extra: Vec<(String, Vec<u8>)>,
    ) -> Response {
        let mut form = multipart::Form::new().part(
            "mesh",
            multipart::Part::bytes(mesh).file_name(file_name.to_string()),
        );
        if let Some(p) = params {
            form = form.part(
                "params",
                multipart::Part::text(p.to_string())
                    .mime_str("application/json")
                    .unwrap(),
            );
        }
        for (name, bytes) in extra {
            form = form.part(name.clone(), multipart::Part::bytes(bytes).file_name(name));
        }
        self.client
            .post(self.url("/v1/jobs"))
            .multipart(form)
            .send()
            .unwrap()
    }

    /// Raw-body submission with a content type and a query string.
    pub fn submit_raw(&self, content_type: &str, body: Vec<u8>, query: &str) -> Response {
        self.client
            .post(self.url(&format!("/v1/jobs{query}")))
            .header("content-type", content_type)
            .body(body)
            .send()
            .unwrap()
    }

    /// Submits and returns the job id, asserting 202.
    pub fn submit_ok(&self, file_name: &str, mesh: Vec<u8>, params: Value) -> String {
        let r = self.submit(file_name, mesh, Some(params), vec![]);
        let status = r.status().as_u16();
        let body: Value = r.json().unwrap();
        assert_eq!(status, 202, "{body}");
        body["id"].as_str().unwrap().to_string()
    }

    /// Polls a job until `pred` holds.
    pub fn wait_for(&self, id: &str, timeout: Duration, pred: impl Fn(&Value) -> bool) -> Value {
        let t0 = Instant::now();
        loop {
            let (status, job) = self.get_json(&format!("/v1/jobs/{id}"));
            assert_eq!(status, 200, "{job}");
            if pred(&job) {
                return job;
            }
            assert!(
                t0.elapsed() < timeout,
                "job {id} did not reach the expected state in {timeout:?}: {job}"
            );
            std::thread::sleep(Duration::from_millis(25));
        }
    }

    /// Polls a job until it is finished.
    pub fn wait_finished(&self, id: &str) -> Value {
        self.wait_for(id, Duration::from_secs(300), |j| {
            matches!(
                j["status"].as_str(),
                Some("succeeded" | "failed" | "cancelled")
            )
        })
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// A file from tests/data.
pub fn data(name: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data")
            .join(name),
    )
    .unwrap()
}

/// An icosphere encoded in `format`.
pub fn sphere(subdivisions: u32, format: isoremesh::io::Format) -> Vec<u8> {
    let m = isoremesh::shapes::icosphere(subdivisions);
    isoremesh::io::write(&m, format, &Default::default()).unwrap()
}

/// A problem body: checks the media type, status and field.
pub fn assert_problem(r: Response, status: u16, field: Option<&str>) -> Value {
    assert_eq!(r.status().as_u16(), status);
    assert_eq!(
        r.headers()["content-type"].to_str().unwrap(),
        "application/problem+json"
    );
    let p: Value = r.json().unwrap();
    assert_eq!(p["status"].as_u64(), Some(u64::from(status)), "{p}");
    assert!(p["type"]
        .as_str()
        .unwrap()
        .starts_with("urn:isoremesh:problem:"));
    assert!(!p["title"].as_str().unwrap().is_empty());
    assert!(!p["detail"].as_str().unwrap().is_empty());
    if let Some(f) = field {
        assert_eq!(p["field"].as_str(), Some(f), "{p}");
    }
    p
}

/// Starts the real binary (`serve` on port 0, one worker, `data_dir`, then
/// `extra` flags) and returns it with its base URL.
pub fn spawn_binary(data_dir: &Path, extra: &[&str]) -> (std::process::Child, String) {
    let (child, base, _) = spawn_binary_logged(data_dir, extra);
    (child, base)
}

/// The lines a spawned binary wrote to stderr so far.
pub type Log = std::sync::Arc<std::sync::Mutex<Vec<String>>>;

/// [`spawn_binary`], also keeping every line of the server's stderr.
pub fn spawn_binary_logged(data_dir: &Path, extra: &[&str]) -> (std::process::Child, String, Log) {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_isoremesh"))
        .args([
            "serve",
            "--listen",
            "127.0.0.1:0",
            "--workers",
            "1",
            "--data-dir",
        ])
        .arg(data_dir)
        .args(extra)
        .env("RUST_LOG", "info")
        .env_remove("ISOREMESH_LOG_JSON")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let log = Log::default();
    let lines = log.clone();
    std::thread::spawn(move || {
        let mut sent = false;
        for line in std::io::BufRead::lines(std::io::BufReader::new(stderr)) {
            let Ok(line) = line else { break };
            lines.lock().unwrap().push(line.clone());
            if !sent {
                if let Some(i) = line.find("listening on http://") {
                    let addr = line[i + "listening on ".len()..]
                        .split_whitespace()
                        .next()
                        .unwrap()
                        .to_string();
                    let _ = tx.send(addr);
                    sent = true;
                }
            }
        }
    });
    let base = rx
        .recv_timeout(Duration::from_secs(60))
        .expect("server did not start");
    (child, base, log)
}
