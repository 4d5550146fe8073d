//! The whole flow through a real server for every input format: submit,
//! poll, download, statistics; plus result re-encoding, ETags, listing and
//! deletion.

#![cfg(feature = "service")]

mod service_support;

use isoremesh::io::{self, Format, ReadOptions};
use serde_json::{json, Value};
use service_support::*;
use sha2::{Digest, Sha256};

fn check_succeeded(s: &Server, id: &str, input_format: &str) -> Value {
    let job = s.wait_finished(id);
    assert_eq!(job["status"], "succeeded", "{job}");
    assert_eq!(job["input"]["format"], input_format);
    assert_eq!(job["params"]["output_format"], input_format);
    assert_eq!(job["progress"]["fraction"], 1.0);
    for side in ["input", "output"] {
        let st = &job["stats"][side];
        assert!(st["faces"].as_u64().unwrap() > 0, "{st}");
        assert!(st["edge_length"]["histogram"]["counts"].is_array());
        assert!(st["valence"]["mean_abs_deviation"].is_number());
        assert!(st["angles"]["min_deg"].is_number());
    }
    assert!(job["stats"]["output"]["distance"]["hausdorff"].is_number());
    assert!(job["finished_at"].is_string() && job["expires_at"].is_string());
    let href = job["result"]["href"].as_str().unwrap();
    assert_eq!(href, format!("/v1/jobs/{id}/result"));

    let r = s.get(href);
    assert_eq!(r.status().as_u16(), 200);
    let format: Format = input_format.parse().unwrap();
    assert_eq!(r.headers()["content-type"], format.mime());
    let disposition = r.headers()["content-disposition"]
        .to_str()
        .unwrap()
        .to_string();
    assert!(
        disposition.starts_with("attachment; filename="),
        "{disposition}"
    );
    assert!(
        disposition.ends_with(&format!(".{input_format}\"")),
        "{disposition}"
    );
    let tag = r.headers()["etag"].to_str().unwrap().to_string();
    let bytes = r.bytes().unwrap();
    assert_eq!(tag, format!("\"{}\"", hex::encode(Sha256::digest(&bytes))));
    assert_eq!(tag, job["result"]["etag"]);
    let back = io::read(&bytes, format, &ReadOptions::default()).unwrap();
    assert_eq!(
        back.mesh.triangles.len() as u64,
        job["result"]["triangles"].as_u64().unwrap()
    );
    assert_eq!(
        back.mesh.triangles.len() as u64,
        job["stats"]["output"]["faces"].as_u64().unwrap()
    );
    job
}

#[test]
fn every_input_format_runs_the_whole_flow() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    let p = json!({"iterations": 2});

    let mut ids = vec![];
    // Multipart uploads.
    for (name, file, fmt) in [
        ("cube.obj", "cube.obj", "obj"),
        ("Duck.glb", "gltf/Duck.glb", "glb"),
        (
            "BoxTextured.gltf",
            "gltf/BoxTexturedEmbedded/BoxTextured.gltf",
            "gltf",
        ),
        ("cube.ply", "cube_ascii.ply", "ply"),
    ] {
        let r = s.submit(name, data(file), Some(p.clone()), vec![]);
        assert_eq!(r.status().as_u16(), 202);
        let id = r.headers()["location"]
            .to_str()
            .unwrap()
            .rsplit('/')
            .next()
            .unwrap()
            .to_string();
        assert!(r.headers().contains_key("retry-after"));
        let body: Value = r.json().unwrap();
        assert_eq!(body["id"], id.as_str());
        assert!(matches!(
            body["status"].as_str(),
            Some("queued" | "running")
        ));
        ids.push((id, fmt));
    }
    // glTF with its buffer and its texture as parts named by their uri.
    let png = data("gltf/BoxTextured/CesiumLogoFlat.png");
    let bin = data("gltf/BoxTextured/BoxTextured0.bin");
    let gltf = data("gltf/BoxTextured/BoxTextured.gltf");
    let r = s.submit(
        "BoxTextured.gltf",
        gltf.clone(),
        Some(p.clone()),
        vec![("BoxTextured0.bin".into(), bin.clone())],
    );
    let missing = assert_problem(r, 422, Some("CesiumLogoFlat.png"));
    assert!(
        missing["detail"]
            .as_str()
            .unwrap()
            .contains("CesiumLogoFlat.png"),
        "{missing}"
    );
    let r = s.submit(
        "BoxTextured.gltf",
        gltf,
        Some(p.clone()),
        vec![
            ("BoxTextured0.bin".into(), bin),
            ("CesiumLogoFlat.png".into(), png.clone()),
        ],
    );
    let body: Value = r.json().unwrap();
    assert_eq!(
        body["input"]["buffers"],
        json!(["BoxTextured0.bin", "CesiumLogoFlat.png"]),
        "{body}"
    );
    let box_id = body["id"].as_str().unwrap().to_string();
    ids.push((box_id.clone(), "gltf"));
    // Raw bodies: format from Content-Type, then from magic bytes; params in the query.
    let r = s.submit_raw(
        "model/stl",
        data("cube_ascii.stl"),
        "?iterations=2&preserve_features=true",
    );
    assert_eq!(r.status().as_u16(), 202);
    let body: Value = r.json().unwrap();
    assert_eq!(body["params"]["iterations"], 2);
    ids.push((body["id"].as_str().unwrap().to_string(), "stl"));
    let r = s.submit_raw(
        "application/octet-stream",
        sphere(2, Format::Off),
        "?iterations=2&target_edge_ratio=0.1",
    );
    let body: Value = r.json().unwrap();
    assert_eq!(body["params"]["target_edge_ratio"], 0.1, "{body}");
    ids.push((body["id"].as_str().unwrap().to_string(), "off"));

    let mut jobs = vec![];
    for (id, fmt) in &ids {
        jobs.push(check_succeeded(&s, id, fmt));
    }
    // The textured box comes back textured, in GLB too, its image byte for byte.
    let r = s.get(&format!("/v1/jobs/{box_id}/result?format=glb"));
    assert_eq!(r.status().as_u16(), 200);
    let back = io::read(&r.bytes().unwrap(), Format::Glb, &ReadOptions::default()).unwrap();
    assert_eq!(back.mesh.attributes.texcoords.len(), 1);
    assert_eq!(back.mesh.appearance.as_ref().unwrap().images[0].bytes, png);
    let box_job = s.wait_finished(&box_id);
    let uv = &box_job["stats"]["attributes"]["texcoords"][0];
    assert_eq!(uv["uv_flipped"], 0, "{uv}");
    assert_eq!(uv["uv_degenerate"], 0, "{uv}");
    assert!(
        uv["color_error"]["mean"][0].as_f64().unwrap() <= 3.0,
        "{uv}"
    );
    // Duck: 4212 input faces, read as GLB.
    assert_eq!(
        jobs[1]["stats"]["input"]["faces"],
        jobs[1]["input"]["triangles"]
    );

    // Another format is re-encoded from the stored mesh.
    let (id, _) = &ids[1];
    let r = s.get(&format!("/v1/jobs/{id}/result?format=obj"));
    assert_eq!(r.status().as_u16(), 200);
    assert_eq!(r.headers()["content-type"], "model/obj");
    let tag = r.headers()["etag"].to_str().unwrap().to_string();
    let bytes = r.bytes().unwrap();
    assert_eq!(tag, format!("\"{}\"", hex::encode(Sha256::digest(&bytes))));
    let obj = io::read(&bytes, Format::Obj, &ReadOptions::default()).unwrap();
    assert_eq!(
        obj.mesh.triangles.len() as u64,
        jobs[1]["result"]["triangles"].as_u64().unwrap()
    );
    // A conditional request with the ETag answers 304.
    let r = s
        .client
        .get(s.url(&format!("/v1/jobs/{id}/result")))
        .header("if-none-match", jobs[1]["result"]["etag"].as_str().unwrap())
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 304);

    // Listing: filtered, paginated, newest first, no duplicates.
    let (st, page) = s.get_json("/v1/jobs?status=succeeded&limit=3");
    assert_eq!(st, 200);
    assert_eq!(page["jobs"].as_array().unwrap().len(), 3);
    let mut seen: Vec<String> = page["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j["id"].as_str().unwrap().to_string())
        .collect();
    let mut cursor = page["next_cursor"].as_str().unwrap().to_string();
    loop {
        let (_, page) = s.get_json(&format!(
            "/v1/jobs?status=succeeded&limit=3&cursor={cursor}"
        ));
        for j in page["jobs"].as_array().unwrap() {
            assert_eq!(j["status"], "succeeded");
            seen.push(j["id"].as_str().unwrap().to_string());
        }
        match page["next_cursor"].as_str() {
            Some(c) => cursor = c.to_string(),
            None => break,
        }
    }
    let mut all: Vec<String> = ids.iter().map(|(i, _)| i.clone()).collect();
    assert_eq!(seen.len(), all.len());
    seen.sort();
    all.sort();
    assert_eq!(seen, all);
    let (_, none) = s.get_json("/v1/jobs?status=running");
    assert_eq!(none["jobs"], json!([]));

    // Metrics count what happened.
    let text = s.get("/metrics").text().unwrap();
    assert!(
        text.contains(&format!(
            "isoremesh_jobs{{status=\"succeeded\"}} {}",
            ids.len()
        )),
        "{text}"
    );
    assert!(text.contains(&format!(
        "isoremesh_job_duration_seconds_count {}",
        ids.len()
    )));
    assert!(text.contains("isoremesh_queue_depth 0"));

    // DELETE removes the job and its files.
    let r = s
        .client
        .delete(s.url(&format!("/v1/jobs/{id}")))
        .send()
        .unwrap();
    assert_eq!(r.status().as_u16(), 204);
    assert_problem(s.get(&format!("/v1/jobs/{id}")), 404, Some("id"));
    assert!(!dir.path().join("jobs").join(id).exists());
    s.stop();
}

#[test]
fn a_textured_obj_with_its_parts_comes_back_whole_as_a_zip() {
    use std::io::Read;
    // BoxTextured as OBJ files: model, library and image.
    let opts = ReadOptions {
        external_buffers: [
            ("BoxTextured0.bin", "gltf/BoxTextured/BoxTextured0.bin"),
            ("CesiumLogoFlat.png", "gltf/BoxTextured/CesiumLogoFlat.png"),
        ]
        .into_iter()
        .map(|(k, f)| (k.to_string(), data(f)))
        .collect(),
        ..ReadOptions::default()
    };
    let gltf = data("gltf/BoxTextured/BoxTextured.gltf");
    let boxed = io::read(&gltf, Format::Gltf, &opts).unwrap().mesh;
    let mut files = io::write_files(
        &boxed,
        Format::Obj,
        &io::WriteOptions::default(),
        &io::Attributes::default(),
        "box",
    )
    .unwrap();
    let (_, obj) = files.remove(0);
    let png = data("gltf/BoxTextured/CesiumLogoFlat.png");
    assert_eq!(files[1].1, png);

    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    let p = json!({"iterations": 3});
    let r = s.submit(
        "box.obj",
        obj.clone(),
        Some(p.clone()),
        vec![files[0].clone()],
    );
    let missing = assert_problem(r, 422, Some(files[1].0.as_str()));
    assert!(
        missing["detail"].as_str().unwrap().contains(&files[1].0),
        "{missing}"
    );
    let mut typo = files.clone();
    typo.push(("box-normal.png".into(), png.clone()));
    let r = s.submit("box.obj", obj.clone(), Some(p.clone()), typo);
    assert_problem(r, 400, Some("box-normal.png"));
    let r = s.submit("box.obj", obj, Some(p), files.clone());
    let status = r.status().as_u16();
    let body: Value = r.json().unwrap();
    assert_eq!(status, 202, "{body}");
    let id = body["id"].as_str().unwrap().to_string();
    let job = s.wait_finished(&id);
    assert_eq!(job["status"], "succeeded", "{job}");
    assert_eq!(
        job["stats"]["attributes"]["output"],
        json!(["TEXCOORD_0"]),
        "{job}"
    );

    let plain = s.get(&format!("/v1/jobs/{id}/result"));
    let text = plain.text().unwrap();
    assert!(text.contains("mtllib box-remeshed.mtl\n") && text.contains("\nvt "));

    let r = s.get(&format!("/v1/jobs/{id}/result?format=obj&bundle=zip"));
    assert_eq!(r.status().as_u16(), 200);
    assert_eq!(r.headers()["content-type"], "application/zip");
    let zip = r.bytes().unwrap().to_vec();
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(zip)).unwrap();
    let mut member = |name: &str| {
        let mut out = Vec::new();
        archive
            .by_name(name)
            .unwrap()
            .read_to_end(&mut out)
            .unwrap();
        out
    };
    assert_eq!(String::from_utf8(member("box-remeshed.obj")).unwrap(), text);
    let mtl = String::from_utf8(member("box-remeshed.mtl")).unwrap();
    let map = mtl
        .lines()
        .find_map(|l| l.strip_prefix("map_Kd "))
        .unwrap()
        .to_string();
    assert_eq!(member(&map), png);

    let r = s.get(&format!("/v1/jobs/{id}/result?bundle=tar"));
    assert_problem(r, 422, Some("bundle"));
    s.stop();
}

#[test]
fn health_readiness_and_openapi_are_served() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(config(dir.path()));
    let (st, h) = s.get_json("/healthz");
    assert_eq!((st, h["status"].as_str()), (200, Some("ok")));
    let (st, h) = s.get_json("/readyz");
    assert_eq!((st, h["status"].as_str()), (200, Some("ready")));
    let r = s.get("/openapi.yaml");
    assert_eq!(r.headers()["content-type"], "application/yaml");
    assert!(r.text().unwrap().starts_with("openapi: 3.1"));
    let r = s.get("/x-request-id-check");
    assert!(r.headers().contains_key("x-request-id"));
    assert_problem(r, 404, None);
    let r = s.client.put(s.url("/v1/jobs")).send().unwrap();
    assert_problem(r, 405, None);
}

/// Submit parses the upload and hands it to the worker; with no budget for
/// held inputs the worker parses the stored upload again. Both give the
/// same result and the same statistics.
#[test]
fn the_worker_reuses_the_parsed_upload_or_parses_it_again_with_the_same_result() {
    let mut results = Vec::new();
    for budget in [isoremesh::service::config::DEFAULT_MAX_PREPARED_BYTES, 0] {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = config(dir.path());
        cfg.max_prepared_bytes = budget;
        let s = Server::start(cfg);
        let id = s.submit_ok(
            "spot.obj",
            data("spot.obj"),
            json!({"target_edge_ratio": 0.02, "iterations": 3}),
        );
        let job = s.wait_finished(&id);
        assert_eq!(job["status"], "succeeded", "{job}");
        results.push((job["result"]["etag"].clone(), job["stats"].clone()));
        let metrics = s.get("/metrics").text().unwrap();
        let how = if budget > 0 { "reused" } else { "parsed" };
        assert!(
            metrics.contains(&format!("isoremesh_job_inputs_total{{how=\"{how}\"}} 1")),
            "{metrics}"
        );
        assert!(
            metrics.contains("isoremesh_prepared_input_bytes 0"),
            "{metrics}"
        );
        s.stop();
    }
    assert_eq!(results[0].0, results[1].0, "the result files differ");
    assert_eq!(results[0].1, results[1].1, "the statistics differ");
}
