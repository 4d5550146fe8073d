//! The contract test: `openapi.yaml` against the running service.
//! (a) The router's routes and the spec's operations are the same set, and
//! every documented operation is routed by the live server.
//! (b) Real response bodies, collected from a scenario that reaches every
//! documented JSON response, validate against the spec's schemas, and every
//! response's status and media type is documented.
//!
//! The schema checker is a small JSON Schema subset written here (type with
//! arrays, enum, required, properties, additionalProperties, items, oneOf,
//! $ref, minimum/maximum/exclusiveMinimum, minLength/maxLength); it refuses
//! any keyword it does not know, so the spec cannot silently outgrow it.

#![cfg(feature = "service")]

mod service_support;

use std::collections::BTreeSet;
use std::time::Duration;

use isoremesh::io::Format;
use isoremesh::service::routes::route_table;
use serde_json::{json, Value};
use service_support::*;

fn spec() -> Value {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/openapi.yaml")).unwrap();
    serde_yaml_ng::from_str(&text).unwrap()
}

const METHODS: [&str; 5] = ["get", "post", "put", "patch", "delete"];

fn spec_operations(spec: &Value) -> BTreeSet<(String, String)> {
    let mut ops = BTreeSet::new();
    for (path, item) in spec["paths"].as_object().unwrap() {
        for m in METHODS {
            if item.get(m).is_some() {
                ops.insert((m.to_uppercase(), path.clone()));
            }
        }
    }
    ops
}

fn resolve<'a>(spec: &'a Value, v: &'a Value) -> &'a Value {
    match v.get("$ref").and_then(Value::as_str) {
        Some(r) => {
            let mut cur = spec;
            for seg in r.trim_start_matches("#/").split('/') {
                cur = &cur[seg];
            }
            assert!(!cur.is_null(), "dangling $ref {r}");
            resolve(spec, cur)
        }
        None => v,
    }
}

const KEYWORDS: [&str; 16] = [
    "type",
    "enum",
    "required",
    "properties",
    "additionalProperties",
    "items",
    "oneOf",
    "$ref",
    "description",
    "format",
    "minimum",
    "maximum",
    "exclusiveMinimum",
    "minLength",
    "maxLength",
    "default",
];

fn type_matches(t: &str, v: &Value) -> bool {
    match t {
        "null" => v.is_null(),
        "boolean" => v.is_boolean(),
        "integer" => v.is_i64() || v.is_u64(),
        "number" => v.is_number(),
        "string" => v.is_string(),
        "array" => v.is_array(),
        "object" => v.is_object(),
        other => panic!("unknown type {other}"),
    }
}

/// Validates `v` against `schema`; errors carry a JSON path.
fn check(spec: &Value, schema: &Value, v: &Value, path: &str, errors: &mut Vec<String>) {
    let obj = schema
        .as_object()
        .unwrap_or_else(|| panic!("schema at {path} is not an object"));
    for k in obj.keys() {
        assert!(
            KEYWORDS.contains(&k.as_str()),
            "the checker does not know keyword {k:?} (at {path})"
        );
    }
    if obj.contains_key("$ref") {
        return check(spec, resolve(spec, schema), v, path, errors);
    }
    if let Some(t) = obj.get("type") {
        let ok = match t {
            Value::String(t) => type_matches(t, v),
            Value::Array(ts) => ts.iter().any(|t| type_matches(t.as_str().unwrap(), v)),
            _ => panic!("bad type at {path}"),
        };
        if !ok {
            errors.push(format!("{path}: expected type {t}, got {v}"));
            return;
        }
    }
    if let Some(e) = obj.get("enum") {
        if !e.as_array().unwrap().contains(v) {
            errors.push(format!("{path}: {v} is not one of {e}"));
        }
    }
    if let Some(x) = v.as_f64() {
        if obj
            .get("minimum")
            .and_then(Value::as_f64)
            .is_some_and(|m| x < m)
            || obj
                .get("maximum")
                .and_then(Value::as_f64)
                .is_some_and(|m| x > m)
            || obj
                .get("exclusiveMinimum")
                .and_then(Value::as_f64)
                .is_some_and(|m| x <= m)
        {
            errors.push(format!("{path}: {x} out of range"));
        }
    }
    if let Some(s) = v.as_str() {
        let n = s.chars().count() as u64;
        if obj
            .get("minLength")
            .and_then(Value::as_u64)
            .is_some_and(|m| n < m)
            || obj
                .get("maxLength")
                .and_then(Value::as_u64)
                .is_some_and(|m| n > m)
        {
            errors.push(format!("{path}: string length {n} out of range"));
        }
    }
    if let Some(options) = obj.get("oneOf") {
        let matching = options
            .as_array()
            .unwrap()
            .iter()
            .filter(|o| {
                let mut e = vec![];
                check(spec, o, v, path, &mut e);
                e.is_empty()
            })
            .count();
        if matching != 1 {
            errors.push(format!("{path}: {matching} oneOf branches match {v}"));
        }
    }
    if let Some(o) = v.as_object() {
        if let Some(req) = obj.get("required") {
            for r in req.as_array().unwrap() {
                if !o.contains_key(r.as_str().unwrap()) {
                    errors.push(format!("{path}: missing required {r}"));
                }
            }
        }
        let props = obj.get("properties").and_then(Value::as_object);
        for (k, val) in o {
            let sub = format!("{path}.{k}");
            match props.and_then(|p| p.get(k)) {
                Some(s) => check(spec, s, val, &sub, errors),
                None => match obj.get("additionalProperties") {
                    Some(Value::Bool(false)) => errors.push(format!("{sub}: not in the schema")),
                    Some(s @ Value::Object(_)) => check(spec, s, val, &sub, errors),
                    _ => {}
                },
            }
        }
    }
    if let (Some(items), Some(a)) = (obj.get("items"), v.as_array()) {
        for (i, x) in a.iter().enumerate() {
            check(spec, items, x, &format!("{path}[{i}]"), errors);
        }
    }
}

/// One observed response.
struct Seen {
    method: &'static str,
    template: &'static str,
    status: u16,
    content_type: Option<String>,
    body: Vec<u8>,
}

fn validate(spec: &Value, seen: &Seen) -> Vec<String> {
    let op = &spec["paths"][seen.template][seen.method.to_lowercase()];
    assert!(
        op.is_object(),
        "{} {} is not in the spec",
        seen.method,
        seen.template
    );
    let resp = resolve(spec, &op["responses"][seen.status.to_string()]);
    let ctx = format!("{} {} -> {}", seen.method, seen.template, seen.status);
    assert!(resp.is_object(), "{ctx}: status not documented");
    let Some(ct) = &seen.content_type else {
        assert!(
            resp.get("content").is_none() || seen.body.is_empty(),
            "{ctx}: body without a media type"
        );
        return vec![];
    };
    let essence = ct.split(';').next().unwrap().trim();
    let media = &resp["content"][essence];
    assert!(
        media.is_object(),
        "{ctx}: media type {essence} not documented"
    );
    if !essence.ends_with("json") {
        return vec![];
    }
    let body: Value = serde_json::from_slice(&seen.body).unwrap();
    let mut errors = vec![];
    check(spec, &media["schema"], &body, &ctx, &mut errors);
    errors
}

struct Recorder<'a> {
    s: &'a Server,
    seen: Vec<Seen>,
}

impl Recorder<'_> {
    fn record(
        &mut self,
        method: &'static str,
        template: &'static str,
        r: reqwest::blocking::Response,
    ) -> Value {
        let status = r.status().as_u16();
        let content_type = r
            .headers()
            .get("content-type")
            .map(|v| v.to_str().unwrap().to_string());
        let body = r.bytes().unwrap().to_vec();
        let json = serde_json::from_slice(&body).unwrap_or(Value::Null);
        self.seen.push(Seen {
            method,
            template,
            status,
            content_type,
            body,
        });
        json
    }
    fn get(&mut self, template: &'static str, path: &str) -> Value {
        let r = self.s.get(path);
        self.record("GET", template, r)
    }
    fn post_empty(&mut self, template: &'static str, path: &str) -> Value {
        let r = self.s.client.post(self.s.url(path)).send().unwrap();
        self.record("POST", template, r)
    }
    fn submit(&mut self, name: &str, mesh: Vec<u8>, params: Value) -> Value {
        let r = self.s.submit(name, mesh, Some(params), vec![]);
        self.record("POST", "/v1/jobs", r)
    }
}

#[test]
fn router_and_spec_have_the_same_routes() {
    let spec = spec();
    assert!(spec["openapi"].as_str().unwrap().starts_with("3.1"));
    let routes: BTreeSet<(String, String)> = route_table()
        .into_iter()
        .map(|(m, p)| (m.as_str().to_string(), p.to_string()))
        .collect();
    assert_eq!(routes, spec_operations(&spec));

    // And the live router answers every documented operation (no fallback
    // 404 "not-found" or 405), with a well-formed job id.
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    for (m, p) in spec_operations(&spec) {
        let url = s.url(&p.replace("{id}", "0f8fad5b-d9cb-469f-a165-70867728950e"));
        let r = s.client.request(m.parse().unwrap(), url).send().unwrap();
        let status = r.status().as_u16();
        let body: Value = r.json().unwrap_or(Value::Null);
        let kind = body["type"].as_str().unwrap_or("");
        assert!(
            status != 405 && !kind.ends_with(":not-found"),
            "{m} {p} is documented but not routed ({status} {body})"
        );
    }
}

#[test]
fn the_checker_rejects_what_it_should() {
    let spec = spec();
    let schema = json!({"$ref": "#/components/schemas/Problem"});
    let good = json!({"type": "urn:isoremesh:problem:internal", "title": "t", "status": 500, "detail": "d"});
    let mut e = vec![];
    check(&spec, &schema, &good, "p", &mut e);
    assert!(e.is_empty(), "{e:?}");
    for bad in [
        json!({"type": "urn:isoremesh:problem:internal", "title": "t", "status": 500}),
        json!({"type": "urn:isoremesh:problem:nope", "title": "t", "status": 500, "detail": "d"}),
        json!({"type": "urn:isoremesh:problem:internal", "title": "t", "status": "500", "detail": "d"}),
        json!({"type": "urn:isoremesh:problem:internal", "title": "t", "status": 500, "detail": "d", "extra": 1}),
    ] {
        let mut e = vec![];
        check(&spec, &schema, &bad, "p", &mut e);
        assert!(!e.is_empty(), "accepted {bad}");
    }
    let mut e = vec![];
    let job = json!({"$ref": "#/components/schemas/Progress"});
    check(
        &spec,
        &job,
        &json!({"iteration": 1, "iterations": 2, "pass": "split", "fraction": 1.5}),
        "p",
        &mut e,
    );
    assert!(!e.is_empty());
}

#[test]
fn real_responses_validate_against_the_spec() {
    let spec = spec();
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    let mut rec = Recorder {
        s: &s,
        seen: vec![],
    };
    let cube = data("cube.obj");

    // A successful job through every state, with statistics.
    let job = rec.submit("cube.obj", cube.clone(), json!({"iterations": 2}));
    let id = job["id"].as_str().unwrap().to_string();
    rec.get("/v1/jobs/{id}", &format!("/v1/jobs/{id}"));
    s.wait_finished(&id);
    let done = rec.get("/v1/jobs/{id}", &format!("/v1/jobs/{id}"));
    assert_eq!(done["status"], "succeeded");
    // Adaptive sizing adds the optional statistics fields.
    let adaptive = rec.submit(
        "ball.off",
        sphere(2, Format::Off),
        json!({"iterations": 1, "sizing": "adaptive", "tolerance": 0.01}),
    );
    let aid = adaptive["id"].as_str().unwrap().to_string();
    s.wait_finished(&aid);
    let a = rec.get("/v1/jobs/{id}", &format!("/v1/jobs/{aid}"));
    assert!(
        a["stats"]["output"]["edge_length"]["against_mean_target"].is_object(),
        "{a}"
    );
    // One reference on both sides, named; the headline leads.
    for side in ["input", "output"] {
        assert_eq!(
            a["stats"][side]["edge_length"]["reference"], "local_target",
            "{a}"
        );
    }
    assert_eq!(
        a["stats"]["headline"]["edge_length"]["within_band"],
        a["stats"]["output"]["edge_length"]["within_band"]
    );
    assert!(done["stats"]["output"]["features"]["fidelity"]["corner_tolerance"].is_f64());
    assert_eq!(
        done["stats"]["headline"]["edge_length"]["histogram"]["unit"],
        "target_length"
    );
    // Per-element quality in a PLY result.
    let q = rec.submit(
        "cube.obj",
        cube.clone(),
        json!({"iterations": 1, "output_format": "ply", "quality_attributes": true}),
    );
    let qid = q["id"].as_str().unwrap().to_string();
    s.wait_finished(&qid);
    let qd = rec.get("/v1/jobs/{id}", &format!("/v1/jobs/{qid}"));
    assert_eq!(qd["params"]["quality_attributes"], true, "{qd}");
    let body = s
        .client
        .get(s.url(&format!("/v1/jobs/{qid}/result")))
        .send()
        .unwrap()
        .bytes()
        .unwrap();
    let header = String::from_utf8_lossy(&body[..body.len().min(600)]).to_string();
    for line in [
        "property float valence",
        "property float quality_min_angle",
        "property float quality_edge_ratio",
    ] {
        assert!(header.contains(line), "{header}");
    }
    // ... which OBJ cannot carry, and a name given twice.
    rec.submit(
        "cube.obj",
        cube.clone(),
        json!({"output_format": "obj", "quality_attributes": true}),
    );
    rec.get("/v1/jobs/{id}/result", &format!("/v1/jobs/{id}/result"));
    rec.get(
        "/v1/jobs/{id}/result",
        &format!("/v1/jobs/{id}/result?format=stl"),
    );
    rec.get(
        "/v1/jobs/{id}/result",
        &format!("/v1/jobs/{id}/result?format=fbx"),
    );
    rec.get("/v1/jobs", "/v1/jobs?limit=1");
    rec.get("/v1/jobs", "/v1/jobs?status=nope");
    rec.post_empty("/v1/jobs/{id}/cancel", &format!("/v1/jobs/{id}/cancel"));
    // Replay and conflict of an idempotency key.
    for params in [
        json!({"iterations": 1}),
        json!({"iterations": 1}),
        json!({"iterations": 3}),
    ] {
        let form = reqwest::blocking::multipart::Form::new()
            .part(
                "mesh",
                reqwest::blocking::multipart::Part::bytes(cube.clone()).file_name("cube.obj"),
            )
            .text("params", params.to_string());
        let r = s
            .client
            .post(s.url("/v1/jobs"))
            .header("idempotency-key", "c")
            .multipart(form)
            .send()
            .unwrap();
        rec.record("POST", "/v1/jobs", r);
    }
    // Submission errors.
    rec.submit("x.txt", b"nothing to see".to_vec(), json!({}));
    rec.submit("cube.obj", cube[..cube.len() / 3].to_vec(), json!({}));
    rec.submit("cube.obj", cube.clone(), json!({"nope": 1}));
    rec.submit(
        "cube.obj",
        cube.clone(),
        json!({"target_edge_length": 1e-6}),
    );
    let r = s
        .client
        .post(s.url("/v1/jobs"))
        .header("content-type", "multipart/form-data; boundary=x")
        .body("garbage")
        .send()
        .unwrap();
    rec.record("POST", "/v1/jobs", r);
    // Unknown job, deletion.
    let unknown = "0f8fad5b-d9cb-469f-a165-70867728950e";
    rec.get("/v1/jobs/{id}", &format!("/v1/jobs/{unknown}"));
    rec.get(
        "/v1/jobs/{id}/result",
        &format!("/v1/jobs/{unknown}/result"),
    );
    rec.post_empty(
        "/v1/jobs/{id}/cancel",
        &format!("/v1/jobs/{unknown}/cancel"),
    );
    let r = s
        .client
        .delete(s.url(&format!("/v1/jobs/{aid}")))
        .send()
        .unwrap();
    rec.record("DELETE", "/v1/jobs/{id}", r);
    let r = s
        .client
        .delete(s.url(&format!("/v1/jobs/{aid}")))
        .send()
        .unwrap();
    rec.record("DELETE", "/v1/jobs/{id}", r);
    // Service endpoints.
    rec.get("/healthz", "/healthz");
    rec.get("/readyz", "/readyz");
    rec.get("/metrics", "/metrics");
    rec.get("/openapi.yaml", "/openapi.yaml");
    let mut seen = std::mem::take(&mut rec.seen);
    drop(rec);
    drop(s);

    // A second server for running, queued, failed, full and expired states.
    let dir2 = tempfile::tempdir().unwrap();
    let mut cfg = config(dir2.path());
    cfg.queue_capacity = 1;
    cfg.job_timeout_secs = 2;
    cfg.result_ttl_secs = 1;
    cfg.max_body_bytes = 1_000_000;
    let s = Server::start(cfg);
    let mut rec = Recorder {
        s: &s,
        seen: vec![],
    };
    let slow = rec.submit(
        "ball.off",
        sphere(4, Format::Off),
        json!({"target_edge_length": 0.01, "iterations": 50}),
    );
    let slow = slow["id"].as_str().unwrap().to_string();
    s.wait_for(&slow, Duration::from_secs(60), |j| {
        j["status"] == "running" && !j["progress"].is_null()
    });
    rec.get("/v1/jobs/{id}", &format!("/v1/jobs/{slow}"));
    rec.get("/v1/jobs/{id}/result", &format!("/v1/jobs/{slow}/result"));
    let queued = rec.submit("cube.obj", cube.clone(), json!({"iterations": 1}));
    let queued = queued["id"].as_str().unwrap().to_string();
    rec.submit("cube.obj", cube.clone(), json!({"iterations": 1})); // 503
    rec.get("/v1/jobs", "/v1/jobs?status=queued");
    rec.post_empty("/v1/jobs/{id}/cancel", &format!("/v1/jobs/{queued}/cancel"));
    let r = s.submit_raw("model/obj", vec![b' '; 1_100_000], "");
    rec.record("POST", "/v1/jobs", r); // 413
    let failed = s.wait_finished(&slow);
    assert_eq!(failed["status"], "failed");
    rec.get("/v1/jobs/{id}", &format!("/v1/jobs/{slow}"));
    let quick = rec.submit("cube.obj", cube.clone(), json!({"iterations": 1}));
    let quick = quick["id"].as_str().unwrap().to_string();
    s.wait_finished(&quick);
    std::thread::sleep(Duration::from_millis(1100));
    rec.get("/v1/jobs/{id}/result", &format!("/v1/jobs/{quick}/result")); // 410
                                                                          // A running job's cancel (202).
    let running = rec.submit(
        "ball.off",
        sphere(4, Format::Off),
        json!({"target_edge_length": 0.01, "iterations": 50}),
    );
    let running = running["id"].as_str().unwrap().to_string();
    s.wait_for(&running, Duration::from_secs(60), |j| {
        j["status"] == "running"
    });
    rec.post_empty(
        "/v1/jobs/{id}/cancel",
        &format!("/v1/jobs/{running}/cancel"),
    );
    seen.append(&mut rec.seen);
    drop(rec);
    s.stop();

    // A third server with API keys: every /v1 operation without a key
    // (401), and past a key's rate (429).
    let dir3 = tempfile::tempdir().unwrap();
    let keys = dir3.path().join("keys.jsonl");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_isoremesh"))
        .args([
            "keys",
            "new",
            "tight",
            "--requests-per-second",
            "0.01",
            "--burst",
            "1",
            "--file",
        ])
        .arg(&keys)
        .output()
        .unwrap();
    assert!(out.status.success());
    let key = String::from_utf8(out.stdout).unwrap().trim().to_string();
    let mut cfg = config(&dir3.path().join("data"));
    cfg.api_keys = Some(keys);
    let s = Server::start(cfg);
    let mut rec = Recorder {
        s: &s,
        seen: vec![],
    };
    let any = "00000000-0000-4000-8000-000000000000";
    for (method, template) in [
        ("GET", "/v1/jobs"),
        ("POST", "/v1/jobs"),
        ("GET", "/v1/jobs/{id}"),
        ("DELETE", "/v1/jobs/{id}"),
        ("GET", "/v1/jobs/{id}/result"),
        ("POST", "/v1/jobs/{id}/cancel"),
    ] {
        let url = s.url(&template.replace("{id}", any));
        let m: reqwest::Method = method.parse().unwrap();
        let r = s.client.request(m.clone(), &url).send().unwrap();
        rec.record(method, template, r);
        for _ in 0..2 {
            let r = s
                .client
                .request(m.clone(), &url)
                .bearer_auth(&key)
                .send()
                .unwrap();
            rec.record(method, template, r);
        }
    }
    seen.append(&mut rec.seen);
    drop(rec);
    s.stop();

    // A fourth server whose job directory turns into a file: DELETE cannot
    // remove it (503) and the job stays.
    let dir5 = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir5.path()));
    let mut rec = Recorder {
        s: &s,
        seen: vec![],
    };
    let job = rec.submit("cube.obj", cube.clone(), json!({"iterations": 1}));
    let job = job["id"].as_str().unwrap().to_string();
    s.wait_finished(&job);
    let jd = dir5.path().join("jobs").join(&job);
    std::fs::remove_dir_all(&jd).unwrap();
    std::fs::write(&jd, b"not a directory").unwrap();
    let r = s
        .client
        .delete(s.url(&format!("/v1/jobs/{job}")))
        .send()
        .unwrap();
    rec.record("DELETE", "/v1/jobs/{id}", r);
    assert_eq!(rec.seen.last().unwrap().status, 503);
    assert_eq!(s.get(&format!("/v1/jobs/{job}")).status(), 200);
    std::fs::remove_file(&jd).unwrap();
    assert_eq!(
        s.client
            .delete(s.url(&format!("/v1/jobs/{job}")))
            .send()
            .unwrap()
            .status(),
        204
    );
    seen.append(&mut rec.seen);
    drop(rec);
    s.stop();

    // A fifth server whose free-space reserve no disk meets (507).
    let dir4 = tempfile::tempdir().unwrap();
    let mut cfg = config(dir4.path());
    cfg.min_free_bytes = u64::MAX / 4;
    let s = Server::start(cfg);
    let mut rec = Recorder {
        s: &s,
        seen: vec![],
    };
    rec.submit("cube.obj", cube.clone(), json!({"iterations": 1}));
    seen.append(&mut rec.seen);
    drop(rec);
    s.stop();

    let mut statuses = BTreeSet::new();
    let mut errors = vec![];
    for r in &seen {
        statuses.insert((r.method, r.template, r.status));
        errors.extend(validate(&spec, r));
    }
    assert!(
        errors.is_empty(),
        "responses that break the spec:\n{}",
        errors.join("\n")
    );
    // The scenario reached every documented JSON response except 408 (its
    // own test in service_errors) and readyz's 503 (only while shutting down).
    for (path, item) in spec["paths"].as_object().unwrap() {
        for m in METHODS {
            let Some(op) = item.get(m) else { continue };
            for (code, resp) in op["responses"].as_object().unwrap() {
                let resp = resolve(&spec, resp);
                let json_body = resp["content"]
                    .as_object()
                    .is_some_and(|c| c.keys().any(|k| k.ends_with("json")));
                let code: u16 = code.parse().unwrap();
                if !json_body || code == 408 || (path == "/readyz" && code == 503) {
                    continue;
                }
                assert!(
                    seen.iter().any(|r| r.method.eq_ignore_ascii_case(m)
                        && r.template == path
                        && r.status == code),
                    "no response seen for {m} {path} {code}"
                );
            }
        }
    }
}
