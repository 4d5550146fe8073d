//! Storage faults over real HTTP, injected into a real data directory: a
//! directory that cannot be written makes `/readyz` answer 503 and
//! submissions 503 `storage-unavailable` (never 500), a free-space reserve
//! that the disk does not meet gives 507, nothing half-written is left
//! behind, and a corrupt job record is moved to the quarantine folder at
//! start instead of being skipped at every start.

#![cfg(feature = "service")]

mod service_support;

use serde_json::json;
use service_support::*;

#[test]
fn an_unwritable_data_directory_fails_readyz_and_submissions_with_503() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    assert_eq!(s.get("/readyz").status(), 200);
    // The jobs folder becomes a file: nothing can be created inside it.
    let jobs = dir.path().join("jobs");
    std::fs::remove_dir_all(&jobs).unwrap();
    std::fs::write(&jobs, b"in the way").unwrap();
    let (status, body) = s.get_json("/readyz");
    assert_eq!(status, 503, "{body}");
    assert_eq!(body["status"], "storage_unavailable");
    assert!(
        body["detail"].as_str().unwrap().contains("not writable"),
        "{body}"
    );
    let r = s.submit(
        "cube.obj",
        data("cube.obj"),
        Some(json!({"iterations": 1})),
        vec![],
    );
    assert!(r.headers().contains_key("retry-after"));
    let p = assert_problem(r, 503, None);
    assert_eq!(p["type"], "urn:isoremesh:problem:storage-unavailable");
    // Repaired, the service is ready again and takes the job.
    std::fs::remove_file(&jobs).unwrap();
    std::fs::create_dir(&jobs).unwrap();
    assert_eq!(s.get("/readyz").status(), 200);
    let id = s.submit_ok("cube.obj", data("cube.obj"), json!({"iterations": 1}));
    assert_eq!(s.wait_finished(&id)["status"], "succeeded");
    // No probe or temporary file is left behind.
    let stray: Vec<_> = std::fs::read_dir(&jobs)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(stray.is_empty(), "{stray:?}");
}

#[test]
fn a_free_space_reserve_the_disk_does_not_meet_gives_507_and_not_ready() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = config(dir.path());
    c.min_free_bytes = u64::MAX / 4;
    let s = Server::start(c);
    let (status, body) = s.get_json("/readyz");
    assert_eq!(status, 503, "{body}");
    assert!(
        body["detail"]
            .as_str()
            .unwrap()
            .contains("under the reserve"),
        "{body}"
    );
    let r = s.submit(
        "cube.obj",
        data("cube.obj"),
        Some(json!({"iterations": 1})),
        vec![],
    );
    let p = assert_problem(r, 507, None);
    assert_eq!(p["type"], "urn:isoremesh:problem:insufficient-storage");
    assert_eq!(
        std::fs::read_dir(dir.path().join("jobs")).unwrap().count(),
        0
    );
}

#[test]
fn a_corrupt_record_is_moved_to_quarantine_at_start() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    let id = s.submit_ok("cube.obj", data("cube.obj"), json!({"iterations": 1}));
    s.wait_finished(&id);
    s.stop();
    let record = dir.path().join("jobs").join(&id).join("job.json");
    std::fs::write(&record, b"{ truncated").unwrap();
    let s = Server::start(config(dir.path()));
    assert_eq!(s.get(&format!("/v1/jobs/{id}")).status(), 404);
    let moved = dir.path().join("quarantine").join(&id);
    assert_eq!(
        std::fs::read(moved.join("job.json")).unwrap(),
        b"{ truncated"
    );
    assert!(moved.join("input").exists(), "the upload is kept with it");
    assert!(!dir.path().join("jobs").join(&id).exists());
    s.stop();
    // The next start finds nothing to skip.
    let s = Server::start(config(dir.path()));
    assert_eq!(s.get("/readyz").status(), 200);
}
