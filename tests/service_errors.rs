//! Every documented submission error over real HTTP: each answers with an
//! `application/problem+json` of the documented status naming the field, and
//! none leaves a job behind.

#![cfg(feature = "service")]

mod service_support;

use std::io::Read;
use std::time::Duration;

use isoremesh::io::Format;
use serde_json::{json, Value};
use service_support::*;

fn job_dirs(s: &Server) -> usize {
    std::fs::read_dir(s.data_dir.join("jobs")).unwrap().count()
}

#[test]
fn bad_inputs_are_refused_before_queueing() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.max_input_triangles = 1000;
    let s = Server::start(cfg);
    let p = Some(json!({"iterations": 1}));

    // Unknown format: neither the name nor the content identifies it.
    let r = s.submit(
        "notes.txt",
        b"hello world\nthis is not a mesh\n".to_vec(),
        p.clone(),
        vec![],
    );
    let pr = assert_problem(r, 415, Some("mesh"));
    assert!(pr["type"].as_str().unwrap().ends_with("unsupported-format"));
    let r = s.submit_raw(
        "application/octet-stream",
        vec![0u8, 1, 2, 3, 4, 5, 6, 7],
        "",
    );
    assert_problem(r, 415, Some("mesh"));

    // Truncated files.
    let duck = data("gltf/Duck.glb");
    let r = s.submit(
        "Duck.glb",
        duck[..duck.len() / 2].to_vec(),
        p.clone(),
        vec![],
    );
    let pr = assert_problem(r, 422, Some("mesh"));
    assert!(
        pr["type"].as_str().unwrap().ends_with("invalid-mesh"),
        "{pr}"
    );
    let stl = sphere(1, Format::Stl);
    let r = s.submit_raw("model/stl", stl[..stl.len() - 30].to_vec(), "");
    assert_problem(r, 422, Some("mesh"));

    // NaN coordinates.
    let nan = b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec();
    let pr = assert_problem(
        s.submit("nan.obj", nan, p.clone(), vec![]),
        422,
        Some("mesh"),
    );
    assert!(
        pr["detail"].as_str().unwrap().contains("non-finite"),
        "{pr}"
    );

    // Input over the triangle limit (1000): a 1280-face sphere.
    let r = s.submit("ball.off", sphere(3, Format::Off), p.clone(), vec![]);
    let pr = assert_problem(r, 413, Some("mesh"));
    assert!(pr["type"].as_str().unwrap().ends_with("mesh-too-large"));

    // A glTF whose external buffer was not sent names the missing uri.
    let r = s.submit(
        "BoxTextured.gltf",
        data("gltf/BoxTextured/BoxTextured.gltf"),
        p.clone(),
        vec![],
    );
    assert_problem(r, 422, Some("BoxTextured0.bin"));
    // Buffer parts with a mesh that is not glTF.
    let r = s.submit(
        "cube.obj",
        data("cube.obj"),
        p.clone(),
        vec![("extra.bin".into(), vec![1, 2, 3])],
    );
    assert_problem(r, 400, Some("extra.bin"));

    // Malformed requests.
    let form = reqwest::blocking::multipart::Form::new().text("params", "{}");
    let r = s
        .client
        .post(s.url("/v1/jobs"))
        .multipart(form)
        .send()
        .unwrap();
    assert_problem(r, 400, Some("mesh"));
    let form = reqwest::blocking::multipart::Form::new()
        .part(
            "mesh",
            reqwest::blocking::multipart::Part::bytes(data("cube.obj")).file_name("cube.obj"),
        )
        .text("params", "{not json");
    let r = s
        .client
        .post(s.url("/v1/jobs"))
        .multipart(form)
        .send()
        .unwrap();
    assert_problem(r, 400, Some("params"));
    assert_problem(s.submit_raw("model/obj", vec![], ""), 400, Some("mesh"));

    assert_eq!(job_dirs(&s), 0, "a refused submission left files behind");
    let (_, list) = s.get_json("/v1/jobs");
    assert_eq!(list["jobs"], json!([]));
}

#[test]
fn bad_parameters_name_their_field() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    let cube = data("cube.obj");
    let cases: Vec<(Value, &str)> = vec![
        (json!({"iterations": "many"}), "iterations"),
        (json!({"iterations": -1}), "iterations"),
        (json!({"iterations": 5000}), "iterations"),
        (json!({"threads": 4}), "threads"),
        (json!({"split": false}), "split"),
        (json!({"gradation": -1.0}), "gradation"),
        (json!({"feature_angle": 270}), "feature_angle"),
        (json!({"min_crease_length": -0.5}), "min_crease_length"),
        (json!({"min_crease_length": "short"}), "min_crease_length"),
        (json!({"target_edge_length": 0}), "target_edge_length"),
        (
            json!({"target_edge_length": 0.1, "target_faces": 10}),
            "target_edge_length",
        ),
        (json!({"target_faces": 0}), "target_faces"),
        (json!({"sizing": "fancy"}), "sizing"),
        (json!({"tolerance": 0.01}), "sizing"),
        (
            json!({"sizing": "adaptive", "min_edge_length": 2, "max_edge_length": 1}),
            "min_edge_length",
        ),
        (json!({"output_format": "fbx"}), "output_format"),
        (json!({"preserve_features": "yes"}), "preserve_features"),
        (json!([1, 2]), "params"),
    ];
    for (params, field) in cases {
        let r = s.submit("cube.obj", cube.clone(), Some(params.clone()), vec![]);
        let p = assert_problem(r, 422, Some(field));
        assert!(
            p["type"].as_str().unwrap().ends_with("invalid-parameter"),
            "{params}: {p}"
        );
    }
    // A huge value is not echoed back: the detail is an excerpt.
    let long = "x".repeat(50_000);
    let r = s.submit(
        "cube.obj",
        cube.clone(),
        Some(json!({"sizing": long})),
        vec![],
    );
    let p = assert_problem(r, 422, Some("sizing"));
    let detail = p["detail"].as_str().unwrap();
    assert!(
        detail.len() <= 1024 && detail.contains("bytes in all"),
        "{detail}"
    );
    // A `params` part beyond 64 KiB is refused before it is parsed.
    let big = json!({"iterations": 3, "padding": "y".repeat(70_000)});
    let r = s.submit("cube.obj", cube.clone(), Some(big), vec![]);
    assert_problem(r, 413, Some("params"));
    // The same names in the query string of a raw upload.
    assert_problem(
        s.submit_raw("model/obj", cube.clone(), "?bogus=1"),
        422,
        Some("bogus"),
    );
    assert_problem(
        s.submit_raw("model/obj", cube.clone(), "?iterations=x"),
        422,
        Some("iterations"),
    );
    assert_problem(
        s.submit_raw("model/obj", cube.clone(), "?iterations=1&iterations=2"),
        422,
        Some("iterations"),
    );
    // Query parameters with a multipart body are refused, not ignored.
    let form = reqwest::blocking::multipart::Form::new().part(
        "mesh",
        reqwest::blocking::multipart::Part::bytes(cube.clone()).file_name("cube.obj"),
    );
    let r = s
        .client
        .post(s.url("/v1/jobs?iterations=2"))
        .multipart(form)
        .send()
        .unwrap();
    assert_problem(r, 400, Some("params"));

    // Output estimate too large: area / (√3/4·L²) over the 20M default.
    let r = s.submit(
        "cube.obj",
        cube.clone(),
        Some(json!({"target_edge_length": 1e-5})),
        vec![],
    );
    let p = assert_problem(r, 422, Some("target_edge_length"));
    assert!(
        p["type"].as_str().unwrap().ends_with("output-too-large"),
        "{p}"
    );
    let r = s.submit(
        "cube.obj",
        cube.clone(),
        Some(json!({"target_faces": 100_000_000u64})),
        vec![],
    );
    assert_problem(r, 422, Some("target_faces"));
    // An estimate beyond u64 is quoted as it is, never as a saturated
    // 18446744073709551615.
    for (l, expect) in [(1e-12, "e2"), (1e-300, "unboundedly many")] {
        let r = s.submit(
            "cube.obj",
            cube.clone(),
            Some(json!({ "target_edge_length": l })),
            vec![],
        );
        let p = assert_problem(r, 422, Some("target_edge_length"));
        let detail = p["detail"].as_str().unwrap();
        assert!(!detail.contains("18446744073709551615"), "{detail}");
        assert!(detail.contains(expect), "{detail}");
    }
    let r = s.submit_raw(
        "model/obj",
        cube.clone(),
        "?sizing=adaptive&min_edge_length=1e-6",
    );
    assert_problem(r, 422, Some("min_edge_length"));
    let r = s.submit_raw("model/obj", cube.clone(), "?sizing=adaptive&tolerance=1e-7");
    assert_problem(r, 422, Some("tolerance"));

    // A name given twice in the params JSON is refused, naming it.
    let form = reqwest::blocking::multipart::Form::new()
        .part(
            "mesh",
            reqwest::blocking::multipart::Part::bytes(cube.clone()).file_name("cube.obj"),
        )
        .text("params", r#"{"iterations": 2, "iterations": 3}"#);
    let r = s
        .client
        .post(s.url("/v1/jobs"))
        .multipart(form)
        .send()
        .unwrap();
    let p = assert_problem(r, 422, Some("iterations"));
    assert!(
        p["detail"].as_str().unwrap().contains("more than once"),
        "{p}"
    );

    // Listing and download parameters.
    assert_problem(s.get("/v1/jobs?status=done"), 422, Some("status"));
    assert_problem(s.get("/v1/jobs?limit=0"), 422, Some("limit"));
    assert_problem(s.get("/v1/jobs?cursor=zzz"), 422, Some("cursor"));
    assert_problem(s.get("/v1/jobs?sort=asc"), 422, Some("sort"));
    assert_eq!(job_dirs(&s), 0);
}

#[test]
fn unknown_jobs_are_404() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    for id in [
        "0f8fad5b-d9cb-469f-a165-70867728950e",
        "not-a-job",
        "..%2F..%2Fetc",
    ] {
        assert_problem(s.get(&format!("/v1/jobs/{id}")), 404, Some("id"));
        assert_problem(s.get(&format!("/v1/jobs/{id}/result")), 404, Some("id"));
        let r = s
            .client
            .post(s.url(&format!("/v1/jobs/{id}/cancel")))
            .send()
            .unwrap();
        assert_problem(r, 404, Some("id"));
        let r = s
            .client
            .delete(s.url(&format!("/v1/jobs/{id}")))
            .send()
            .unwrap();
        assert_problem(r, 404, Some("id"));
    }
}

/// A reader that sends a little, then stalls.
struct Stalling {
    sent: bool,
}

impl Read for Stalling {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if !self.sent {
            self.sent = true;
            let head = b"v 0 0 0\n";
            buf[..head.len()].copy_from_slice(head);
            return Ok(head.len());
        }
        std::thread::sleep(Duration::from_secs(3));
        Ok(0)
    }
}

#[test]
fn body_limits_and_the_upload_deadline_hold() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.max_body_bytes = 50_000;
    cfg.upload_timeout_secs = 1;
    let s = Server::start(cfg);
    // Declared too large (Content-Length).
    let big = vec![b' '; 60_000];
    let p = assert_problem(
        s.submit_raw("model/obj", big.clone(), ""),
        413,
        Some("body"),
    );
    assert!(p["type"].as_str().unwrap().ends_with("body-too-large"));
    // Too large without a declared length (chunked).
    let r = s
        .client
        .post(s.url("/v1/jobs"))
        .header("content-type", "model/obj")
        .body(reqwest::blocking::Body::new(std::io::Cursor::new(big)))
        .send()
        .unwrap();
    assert_problem(r, 413, Some("body"));
    let r = s.submit("big.obj", vec![b'#'; 60_000], None, vec![]);
    assert_problem(r, 413, Some("body"));
    // Too slow.
    let r = s
        .client
        .post(s.url("/v1/jobs"))
        .header("content-type", "model/obj")
        .body(reqwest::blocking::Body::new(Stalling { sent: false }))
        .send()
        .unwrap();
    let p = assert_problem(r, 408, None);
    assert!(p["type"].as_str().unwrap().ends_with("upload-timeout"));
    assert_eq!(job_dirs(&s), 0);
}

#[test]
fn idempotency_key_binds_one_request() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    let send = |key: &str, mesh: Vec<u8>, params: Value| {
        let form = reqwest::blocking::multipart::Form::new()
            .part(
                "mesh",
                reqwest::blocking::multipart::Part::bytes(mesh).file_name("cube.obj"),
            )
            .text("params", params.to_string());
        s.client
            .post(s.url("/v1/jobs"))
            .header("idempotency-key", key)
            .multipart(form)
            .send()
            .unwrap()
    };
    let r = send("k-1", data("cube.obj"), json!({"iterations": 1}));
    assert_eq!(r.status().as_u16(), 202);
    let first: Value = r.json().unwrap();
    // Same key, same request (new multipart boundary): the same job.
    let r = send("k-1", data("cube.obj"), json!({"iterations": 1}));
    assert_eq!(r.status().as_u16(), 200);
    assert_eq!(r.headers()["idempotent-replayed"], "true");
    let again: Value = r.json().unwrap();
    assert_eq!(again["id"], first["id"]);
    // Same key, different params or mesh: 422 naming the header.
    let p = assert_problem(
        send("k-1", data("cube.obj"), json!({"iterations": 2})),
        422,
        Some("Idempotency-Key"),
    );
    assert!(p["type"]
        .as_str()
        .unwrap()
        .ends_with("idempotency-conflict"));
    assert_problem(
        send("k-1", data("cube_ascii.ply"), json!({"iterations": 1})),
        422,
        Some("Idempotency-Key"),
    );
    // Another key: another job.
    let r = send("k-2", data("cube.obj"), json!({"iterations": 1}));
    assert_eq!(r.status().as_u16(), 202);
    let other: Value = r.json().unwrap();
    assert_ne!(other["id"], first["id"]);
    let (_, list) = s.get_json("/v1/jobs");
    assert_eq!(list["jobs"].as_array().unwrap().len(), 2);
    for id in [&first["id"], &other["id"]] {
        s.wait_finished(id.as_str().unwrap());
    }
}
