//! API keys and resource limits over real HTTP: every `/v1` route needs a
//! valid key once keys are configured, each key sees only its own jobs and
//! its own idempotency keys, per-key rate limits and quotas answer 429 with
//! a problem, the global upload bounds answer 503 while real sockets hold
//! slow uploads open, and a running binary re-reads its key file on SIGHUP
//! after `isoremesh keys new` appended to it.

#![cfg(feature = "service")]

mod service_support;

use std::io::Write;
use std::net::TcpStream;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use isoremesh::io::Format;
use reqwest::blocking::{multipart, Client};
use serde_json::{json, Value};
use service_support::*;

/// Runs `isoremesh keys new NAME --file FILE ARGS` and returns the key.
fn new_key(file: &Path, name: &str, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_isoremesh"))
        .args(["keys", "new", name, "--file"])
        .arg(file)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap().trim().to_string()
}

/// A client that sends `key` as a bearer token.
fn keyed(key: &str) -> Client {
    let mut h = reqwest::header::HeaderMap::new();
    h.insert(
        reqwest::header::AUTHORIZATION,
        format!("Bearer {key}").parse().unwrap(),
    );
    Client::builder()
        .default_headers(h)
        .timeout(Duration::from_secs(60))
        .build()
        .unwrap()
}

fn form(name: &str, mesh: Vec<u8>, params: &Value) -> multipart::Form {
    multipart::Form::new()
        .part(
            "mesh",
            multipart::Part::bytes(mesh).file_name(name.to_string()),
        )
        .text("params", params.to_string())
}

fn submit(s: &Server, c: &Client, idem: Option<&str>) -> reqwest::blocking::Response {
    let mut r = c.post(s.url("/v1/jobs")).multipart(form(
        "cube.obj",
        data("cube.obj"),
        &json!({"iterations": 1}),
    ));
    if let Some(k) = idem {
        r = r.header("idempotency-key", k);
    }
    r.send().unwrap()
}

fn id_of(r: reqwest::blocking::Response) -> String {
    let status = r.status().as_u16();
    let body: Value = r.json().unwrap();
    assert_eq!(status, 202, "{body}");
    body["id"].as_str().unwrap().to_string()
}

fn metric(s: &Server, line_start: &str) -> u64 {
    let text = s.get("/metrics").text().unwrap();
    text.lines()
        .find_map(|l| l.strip_prefix(line_start))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("{line_start} not in /metrics"))
}

/// A server whose key file holds `alice` and `bob` (with `bob_args`).
fn two_keys(dir: &Path, bob_args: &[&str]) -> (Server, String, String) {
    let file = dir.join("keys.jsonl");
    let alice = new_key(&file, "alice", &[]);
    let bob = new_key(&file, "bob", bob_args);
    let mut c = config(&dir.join("data"));
    c.api_keys = Some(file);
    (Server::start(c), alice, bob)
}

#[test]
fn every_v1_route_needs_a_valid_key_and_the_rest_stay_open() {
    let dir = tempfile::tempdir().unwrap();
    let (s, alice, _) = two_keys(dir.path(), &[]);
    let anonymous = Client::new();
    let id = "00000000-0000-4000-8000-000000000000";
    for (method, path) in [
        ("GET", "/v1/jobs".to_string()),
        ("POST", "/v1/jobs".to_string()),
        ("GET", format!("/v1/jobs/{id}")),
        ("DELETE", format!("/v1/jobs/{id}")),
        ("GET", format!("/v1/jobs/{id}/result")),
        ("POST", format!("/v1/jobs/{id}/cancel")),
    ] {
        for auth in [
            None,
            Some("Basic YTpi"),
            Some("Bearer"),
            Some("Bearer irk_0"),
        ] {
            let mut r = anonymous.request(method.parse().unwrap(), s.url(&path));
            if let Some(a) = auth {
                r = r.header("authorization", a);
            }
            let resp = r.send().unwrap();
            assert_eq!(
                resp.headers()["www-authenticate"],
                "Bearer realm=\"isoremesh\""
            );
            let p = assert_problem(resp, 401, Some("Authorization"));
            assert_eq!(
                p["type"], "urn:isoremesh:problem:unauthorized",
                "{method} {path}"
            );
        }
    }
    // A near miss of a real key is refused like any other.
    let last = if alice.ends_with('0') { '1' } else { '0' };
    let near = format!("{}{last}", &alice[..alice.len() - 1]);
    let r = keyed(&near).get(s.url("/v1/jobs")).send().unwrap();
    assert_problem(r, 401, Some("Authorization"));
    for path in ["/healthz", "/readyz", "/metrics", "/openapi.yaml", "/"] {
        assert_eq!(
            anonymous.get(s.url(path)).send().unwrap().status(),
            200,
            "{path}"
        );
    }
    let r = keyed(&alice).get(s.url("/v1/jobs")).send().unwrap();
    assert_eq!(r.status(), 200);
    assert!(metric(&s, "isoremesh_refusals_total{reason=\"unauthorized\"}") >= 24);
}

#[test]
fn a_key_sees_lists_downloads_cancels_and_deletes_only_its_own_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let (mut s, alice, bob) = two_keys(dir.path(), &[]);
    let (a, b) = (keyed(&alice), keyed(&bob));
    let job = id_of(submit(&s, &a, None));
    s.client = a.clone();
    assert_eq!(s.wait_finished(&job)["status"], "succeeded");
    // Bob gets 404 for every route of Alice's job, as for an unknown id.
    for (method, path) in [
        ("GET", format!("/v1/jobs/{job}")),
        ("GET", format!("/v1/jobs/{job}/result")),
        ("POST", format!("/v1/jobs/{job}/cancel")),
        ("DELETE", format!("/v1/jobs/{job}")),
    ] {
        let r = b
            .request(method.parse().unwrap(), s.url(&path))
            .send()
            .unwrap();
        let p = assert_problem(r, 404, Some("id"));
        assert_eq!(p["type"], "urn:isoremesh:problem:job-not-found");
    }
    let listed = |c: &Client| -> Vec<String> {
        let v: Value = c.get(s.url("/v1/jobs")).send().unwrap().json().unwrap();
        v["jobs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|j| j["id"].as_str().unwrap().to_string())
            .collect()
    };
    assert!(listed(&b).is_empty());
    assert_eq!(listed(&a), vec![job.clone()]);
    // Bob's DELETE did nothing: Alice still downloads her result.
    let r = a
        .get(s.url(&format!("/v1/jobs/{job}/result")))
        .send()
        .unwrap();
    assert_eq!(r.status(), 200);
    assert!(!r.bytes().unwrap().is_empty());
    let r = a.delete(s.url(&format!("/v1/jobs/{job}"))).send().unwrap();
    assert_eq!(r.status(), 204);
    // The owner is kept across a restart.
    let job2 = id_of(submit(&s, &a, None));
    s.wait_finished(&job2);
    let mut c = config(&dir.path().join("data"));
    c.api_keys = Some(dir.path().join("keys.jsonl"));
    s.stop();
    let s = Server::start(c);
    let r = b.get(s.url(&format!("/v1/jobs/{job2}"))).send().unwrap();
    assert_eq!(r.status(), 404);
    let r = a.get(s.url(&format!("/v1/jobs/{job2}"))).send().unwrap();
    assert_eq!(r.status(), 200);
}

#[test]
fn idempotency_keys_are_scoped_per_api_key() {
    let dir = tempfile::tempdir().unwrap();
    let (s, alice, bob) = two_keys(dir.path(), &[]);
    let (a, b) = (keyed(&alice), keyed(&bob));
    let first = id_of(submit(&s, &a, Some("order-1")));
    let again = submit(&s, &a, Some("order-1"));
    assert_eq!(again.status(), 200);
    assert_eq!(again.json::<Value>().unwrap()["id"], first.as_str());
    // Bob's request with the same key is his own new job, not Alice's.
    let bobs = id_of(submit(&s, &b, Some("order-1")));
    assert_ne!(bobs, first);
}

#[test]
fn the_rate_limit_answers_429_with_retry_after() {
    let dir = tempfile::tempdir().unwrap();
    let (s, alice, bob) = two_keys(
        dir.path(),
        &["--requests-per-second", "0.5", "--burst", "3"],
    );
    let b = keyed(&bob);
    for _ in 0..3 {
        assert_eq!(b.get(s.url("/v1/jobs")).send().unwrap().status(), 200);
    }
    let r = b.get(s.url("/v1/jobs")).send().unwrap();
    let retry: u64 = r.headers()["retry-after"]
        .to_str()
        .unwrap()
        .parse()
        .unwrap();
    assert!((1..=2).contains(&retry), "Retry-After {retry}");
    let p = assert_problem(r, 429, None);
    assert_eq!(p["type"], "urn:isoremesh:problem:rate-limited");
    assert!(p["detail"].as_str().unwrap().contains("\"bob\""), "{p}");
    // Alice's bucket is her own.
    assert_eq!(
        keyed(&alice)
            .get(s.url("/v1/jobs"))
            .send()
            .unwrap()
            .status(),
        200
    );
    assert_eq!(
        metric(&s, "isoremesh_refusals_total{reason=\"rate_limited\"}"),
        1
    );
}

#[test]
fn quotas_on_active_jobs_and_stored_bytes_answer_429() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("keys.jsonl");
    let one = new_key(&file, "one-at-a-time", &["--max-active-jobs", "1"]);
    let small = new_key(&file, "small", &["--max-stored-bytes", "100"]);
    let mut c = config(&dir.path().join("data"));
    c.api_keys = Some(file);
    let mut s = Server::start(c);
    let k = keyed(&one);
    // A job of several seconds holds the only slot of its key.
    let slow = k
        .post(s.url("/v1/jobs"))
        .multipart(form(
            "ball.off",
            sphere(4, Format::Off),
            &json!({"target_edge_length": 0.01, "iterations": 50}),
        ))
        .send()
        .unwrap();
    let slow = id_of(slow);
    let r = submit(&s, &k, None);
    assert!(r.headers().contains_key("retry-after"));
    let p = assert_problem(r, 429, None);
    assert_eq!(p["type"], "urn:isoremesh:problem:quota-exceeded");
    assert!(
        p["detail"].as_str().unwrap().contains("max_active_jobs"),
        "{p}"
    );
    // Once it is cancelled the key may submit again.
    let r = k
        .post(s.url(&format!("/v1/jobs/{slow}/cancel")))
        .send()
        .unwrap();
    assert!(r.status().is_success());
    s.client = k.clone();
    s.wait_finished(&slow);
    let quick = id_of(submit(&s, &k, None));
    s.wait_finished(&quick);
    // cube.obj is larger than 100 bytes: the small key cannot store it.
    let r = submit(&s, &keyed(&small), None);
    let p = assert_problem(r, 429, None);
    assert!(
        p["detail"].as_str().unwrap().contains("max_stored_bytes"),
        "{p}"
    );
    assert_eq!(
        metric(&s, "isoremesh_refusals_total{reason=\"active_jobs\"}"),
        1
    );
    assert_eq!(
        metric(&s, "isoremesh_refusals_total{reason=\"stored_bytes\"}"),
        1
    );
}

/// Opens a raw connection that starts a multipart-less upload of
/// `declared` bytes, sends `sent` of them and then stalls.
fn stalled_upload(s: &Server, declared: usize, sent: usize) -> TcpStream {
    let mut c = TcpStream::connect(s.base.trim_start_matches("http://")).unwrap();
    write!(
        c,
        "POST /v1/jobs HTTP/1.1\r\nhost: x\r\ncontent-type: model/obj\r\ncontent-length: {declared}\r\n\r\n"
    )
    .unwrap();
    c.write_all(&vec![b'#'; sent]).unwrap();
    c.flush().unwrap();
    c
}

/// Waits until the server counts `n` uploads in flight.
fn wait_in_flight(s: &Server, n: u64, bytes: u64) {
    let t0 = Instant::now();
    while metric(s, "isoremesh_uploads_in_flight ") < n
        || metric(s, "isoremesh_upload_bytes_in_flight ") < bytes
    {
        assert!(t0.elapsed() < Duration::from_secs(20), "upload not counted");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn global_upload_bounds_refuse_the_excess_with_503_while_uploads_stall() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = config(dir.path());
    c.max_uploads_in_flight = 2;
    c.max_body_bytes = 1 << 20;
    c.max_upload_bytes_in_flight = 1 << 20;
    let s = Server::start(c);
    // One stalled upload of 900 KB holds that much of the 1 MiB budget
    // (its declared length is reserved up front): a second upload of
    // 400 KB would pass it and is refused while the first holds on.
    let first = stalled_upload(&s, 900_000, 700_000);
    wait_in_flight(&s, 1, 900_000);
    let r = s.submit_raw("model/obj", vec![b'#'; 400_000], "");
    assert!(r.headers().contains_key("retry-after"));
    let p = assert_problem(r, 503, None);
    assert_eq!(p["type"], "urn:isoremesh:problem:uploads-busy");
    assert!(
        p["detail"].as_str().unwrap().contains("1048576 bytes"),
        "{p}"
    );
    // Two stalled uploads take both slots: the next is refused at once.
    let second = stalled_upload(&s, 50_000, 10);
    wait_in_flight(&s, 2, 0);
    let r = s.submit("cube.obj", data("cube.obj"), None, vec![]);
    let p = assert_problem(r, 503, None);
    assert!(p["detail"].as_str().unwrap().contains("2 uploads"), "{p}");
    assert_eq!(
        metric(&s, "isoremesh_refusals_total{reason=\"uploads_in_flight\"}"),
        1
    );
    assert_eq!(
        metric(
            &s,
            "isoremesh_refusals_total{reason=\"upload_bytes_in_flight\"}"
        ),
        1
    );
    // Closing them returns their share: a normal submission passes again.
    drop(first);
    drop(second);
    let t0 = Instant::now();
    while metric(&s, "isoremesh_uploads_in_flight ") > 0 {
        assert!(t0.elapsed() < Duration::from_secs(20));
        std::thread::sleep(Duration::from_millis(20));
    }
    let id = s.submit_ok("cube.obj", data("cube.obj"), json!({"iterations": 1}));
    assert_eq!(s.wait_finished(&id)["status"], "succeeded");
    assert_eq!(metric(&s, "isoremesh_upload_bytes_in_flight "), 0);
}

#[cfg(target_os = "linux")]
#[test]
fn a_running_binary_reads_a_new_key_on_sighup() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("keys.jsonl");
    let alice = new_key(&file, "alice", &[]);
    let (mut child, base) = spawn_binary(
        &dir.path().join("data"),
        &["--api-keys", file.to_str().unwrap()],
    );
    let status = |key: &str| {
        keyed(key)
            .get(format!("{base}/v1/jobs"))
            .send()
            .map(|r| r.status().as_u16())
            .unwrap_or(0)
    };
    let t0 = Instant::now();
    while status(&alice) != 200 {
        assert!(t0.elapsed() < Duration::from_secs(30), "server not ready");
        std::thread::sleep(Duration::from_millis(20));
    }
    let bob = new_key(&file, "bob", &[]);
    assert_eq!(status(&bob), 401);
    // SAFETY: kill(2) with a child's pid and a signal number touches no memory.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGHUP) }, 0);
    let t0 = Instant::now();
    while status(&bob) != 200 {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "bob's key not read on SIGHUP"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(status(&alice), 200);
    // A broken file is refused and the keys in use stay.
    std::fs::write(&file, "not json\n").unwrap();
    // SAFETY: as above.
    unsafe { libc::kill(child.id() as i32, libc::SIGHUP) };
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(status(&bob), 200);
    assert!(
        child.try_wait().unwrap().is_none(),
        "the server is still up"
    );
    child.kill().unwrap();
    let _ = child.wait();
}

/// The access log of the real binary: a refusal names its problem type,
/// its field and the peer; a client's request id is quoted, so it cannot
/// forge fields; a log written to a pipe has no colours.
#[test]
fn refusals_are_logged_with_type_field_and_peer_and_client_values_quoted() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("keys.jsonl");
    new_key(&file, "alice", &[]);
    let (mut child, base, log) = spawn_binary_logged(
        &dir.path().join("data"),
        &["--api-keys", file.to_str().unwrap()],
    );
    let forged = "x\" problem=forged peer=\"10.0.0.1";
    let r = Client::new()
        .get(format!("{base}/v1/jobs"))
        .header("x-request-id", forged)
        .send()
        .unwrap();
    assert_eq!(r.status(), 401);
    let t0 = Instant::now();
    let line = loop {
        let found = log
            .lock()
            .unwrap()
            .iter()
            .find(|l| l.contains("request refused"))
            .cloned();
        if let Some(l) = found {
            break l;
        }
        assert!(t0.elapsed() < Duration::from_secs(10), "no refusal logged");
        std::thread::sleep(Duration::from_millis(20));
    };
    child.kill().unwrap();
    let _ = child.wait();
    assert!(line.contains("problem=unauthorized"), "{line}");
    assert!(line.contains("field=\"Authorization\""), "{line}");
    assert!(line.contains("peer=127.0.0.1:"), "{line}");
    assert!(line.contains("status=401"), "{line}");
    assert!(
        line.contains(r#"request_id="x\" problem=forged peer=\"10.0.0.1""#),
        "the request id is not quoted: {line}"
    );
    assert!(!line.contains('\u{1b}'), "colours in a piped log: {line:?}");
}

#[test]
fn keys_new_refuses_a_second_key_of_one_name_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("keys.jsonl");
    new_key(&file, "alice", &[]);
    let out = Command::new(env!("CARGO_BIN_EXE_isoremesh"))
        .args(["keys", "new", "alice", "--file"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("a key named \"alice\" exists"), "{err}");
    // The service refuses to start on a key file that holds no key.
    let empty = dir.path().join("empty.jsonl");
    std::fs::write(&empty, "# nothing yet\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_isoremesh"))
        .args(["serve", "--listen", "127.0.0.1:0", "--api-keys"])
        .arg(&empty)
        .arg("--data-dir")
        .arg(dir.path().join("data"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("holds no key"), "{err}");
}
