//! The `isoremesh` binary end to end: `stats` and `remesh` on real files,
//! and one clear line with a non-zero exit for every kind of bad input.

mod data_support;

use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_isoremesh"))
}

/// Runs the binary and expects failure with one stderr line naming `file` and containing `needle`.
fn expect_failure(args: &[&str], file: &str, needle: &str) {
    let out = bin().args(args).output().unwrap();
    assert!(!out.status.success(), "{args:?} succeeded");
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "expected one line, got {err:?}");
    assert!(lines[0].contains(file), "{err:?} does not name {file}");
    assert!(
        lines[0].to_lowercase().contains(needle),
        "{err:?} does not mention {needle}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn stats_json_is_the_only_stdout_and_has_the_documented_fields() {
    let out = bin()
        .args([
            "stats",
            data_support::path("spot.obj").to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stdout is JSON");
    for k in [
        "vertices",
        "faces",
        "edges",
        "boundary_loops",
        "components",
        "euler_characteristic",
    ] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    assert_eq!(v["vertices"], 2930);
    assert_eq!(v["faces"], 5856);
    assert_eq!(v["euler_characteristic"], 2);
    assert!(v["edge_length"]["histogram"]["counts"].is_array());
    assert!(v["valence"]["regular_fraction"].is_number());
    assert!(v["angles"]["below_30_fraction"].is_number());
    assert!(v["triangle_quality"]["mean"].is_number());
    assert!(v["repairs"]["welded_vertices"].is_number());
}

#[test]
fn stats_with_a_reference_reports_distances() {
    let spot = data_support::path("spot.obj");
    let out = bin()
        .args([
            "stats",
            spot.to_str().unwrap(),
            "--reference",
            spot.to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["distance"]["hausdorff"].as_f64().unwrap() < 1e-9);
}

#[test]
fn remesh_writes_the_output_format_of_its_extension_and_stats() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["glb", "obj", "ply", "stl", "off", "gltf"] {
        let out_path = dir.path().join(format!("out.{ext}"));
        let stats_path = dir.path().join("stats.json");
        let st = bin()
            .args([
                "remesh",
                data_support::path("cube.obj").to_str().unwrap(),
                out_path.to_str().unwrap(),
                "--target-edge-ratio",
                "0.1",
                "--iterations",
                "3",
                "--stats",
                stats_path.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        assert!(
            st.status.success(),
            "{}",
            String::from_utf8_lossy(&st.stderr)
        );
        assert!(st.stderr.is_empty(), "not quiet without a terminal");
        let back = bin()
            .args(["stats", out_path.to_str().unwrap(), "--json"])
            .output()
            .unwrap();
        assert!(back.status.success());
        let v: serde_json::Value = serde_json::from_slice(&back.stdout).unwrap();
        assert_eq!(v["euler_characteristic"], 2, "{ext}");
        let s: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&stats_path).unwrap()).unwrap();
        assert!(s["output"]["distance"]["hausdorff_relative"].is_number());
        assert!(s["input"]["faces"] == 12);
        // The headline block leads the JSON and is what stdout shows.
        assert_eq!(s["headline"], s_headline_of(&s["output"]), "{ext}");
        let text = String::from_utf8_lossy(&st.stdout);
        assert!(text.starts_with("headline  "), "{text}");
        assert!(text.contains("valence deviation"), "{text}");
    }
}

/// The headline block as the output statistics' own figures give it.
fn s_headline_of(out: &serde_json::Value) -> serde_json::Value {
    let e = &out["edge_length"];
    let v = &out["valence"];
    serde_json::json!({
        "edge_length": {
            "reference": e["reference"],
            "target": e["target"],
            "band": e["band"],
            "within_band": e["within_band"],
            "histogram": e["histogram"],
            "split": e["split"],
        },
        "valence": {
            "mean_abs_deviation": v["mean_abs_deviation"],
            "interior_mean_abs_deviation": v["interior_mean_abs_deviation"],
            "boundary_mean_abs_deviation": v["boundary_mean_abs_deviation"],
        },
    })
}

#[test]
fn stats_text_opens_with_the_headline_block() {
    let out = bin()
        .args(["stats", data_support::path("spot.obj").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[1].starts_with("headline  "), "{text}");
    assert!(
        lines[1].contains("% of edges in the band [0.80, 1.33]"),
        "{text}"
    );
    assert!(lines[2].contains("bins of 0.1 from 0"), "{text}");
    assert!(lines[3].contains("valence deviation"), "{text}");
}

#[test]
fn quality_attributes_go_into_ply_and_not_into_obj() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("q.ply");
    let st = bin()
        .args([
            "remesh",
            data_support::path("cube.obj").to_str().unwrap(),
            ply.to_str().unwrap(),
            "--target-edge-ratio",
            "0.1",
            "--quality-attributes",
        ])
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let bytes = std::fs::read(&ply).unwrap();
    let head = String::from_utf8_lossy(&bytes[..400]);
    assert!(head.contains("property float quality_min_angle"), "{head}");
    let obj = dir.path().join("q.obj");
    expect_failure(
        &[
            "remesh",
            data_support::path("cube.obj").to_str().unwrap(),
            obj.to_str().unwrap(),
            "--quality-attributes",
        ],
        "q.obj",
        "gltf, glb or ply",
    );
    assert!(!obj.exists());
}

#[test]
fn every_bad_input_gives_one_line_and_a_non_zero_exit() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p.to_str().unwrap().to_string()
    };
    let missing = dir.path().join("missing.obj");
    expect_failure(
        &["stats", missing.to_str().unwrap()],
        "missing.obj",
        "no such file",
    );
    let unknown = write("mesh.xyz", b"\x00\x01\x02 not a mesh at all");
    expect_failure(&["stats", &unknown], "mesh.xyz", "unknown");
    let duck = std::fs::read(data_support::path("gltf/Duck.glb")).unwrap();
    let truncated = write("truncated.glb", &duck[..duck.len() / 2]);
    expect_failure(&["stats", &truncated], "truncated.glb", "");
    let bad_index = write("bad_index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    // In the file's own numbering: line 4, face 1, vertex 9 of 1 to 3.
    expect_failure(
        &["stats", &bad_index],
        "bad_index.obj",
        "line 4: face 1 refers to vertex 9, but the file has 3 vertices, numbered 1 to 3",
    );
    let nan = write("nan.obj", b"v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
    expect_failure(&["stats", &nan], "nan.obj", "");
    let empty = write("empty.obj", b"# nothing here\n");
    expect_failure(&["stats", &empty], "empty.obj", "");
    let out = dir.path().join("out.obj");
    expect_failure(&["remesh", &empty, out.to_str().unwrap()], "empty.obj", "");
    let bad_ext = dir.path().join("out.xyz");
    expect_failure(
        &[
            "remesh",
            data_support::path("cube.obj").to_str().unwrap(),
            bad_ext.to_str().unwrap(),
        ],
        "out.xyz",
        "format",
    );
}

/// A `.gltf` whose buffer and texture are separate files beside it: the CLI
/// reads both, and the output carries the texture.
#[test]
fn a_gltf_with_an_external_buffer_and_image_remeshes_textured() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("box.glb");
    let input = data_support::path("gltf/BoxTextured/BoxTextured.gltf");
    let run = bin().arg("remesh").arg(&input).arg(&out).output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let (doc, _, images) = gltf::import(&out).unwrap();
    assert_eq!(images.len(), 1);
    assert!(doc.textures().count() >= 1);
}

#[test]
fn a_textured_obj_result_comes_with_its_library_and_images_and_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("out/box.obj");
    std::fs::create_dir_all(obj.parent().unwrap()).unwrap();
    let input = data_support::path("gltf/BoxTextured/BoxTextured.gltf");
    let run = |args: &[&std::path::Path]| {
        let r = bin().arg("remesh").args(args).output().unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    run(&[&input, &obj]);
    let text = std::fs::read_to_string(&obj).unwrap();
    assert!(text.contains("mtllib box.mtl") && text.contains("\nvt "));
    let mtl = std::fs::read_to_string(dir.path().join("out/box.mtl")).unwrap();
    let map = mtl
        .lines()
        .find_map(|l| l.strip_prefix("map_Kd "))
        .expect("a base-colour map");
    let png = data_support::bytes("gltf/BoxTextured/CesiumLogoFlat.png");
    assert_eq!(
        std::fs::read(dir.path().join("out").join(map)).unwrap(),
        png
    );
    // The OBJ, its library and its image are read back from beside it.
    let glb = dir.path().join("back.glb");
    run(&[&obj, &glb]);
    let (doc, _, images) = gltf::import(&glb).unwrap();
    assert_eq!(images.len(), 1);
    assert!(doc
        .meshes()
        .next()
        .unwrap()
        .primitives()
        .all(|p| p.get(&gltf::Semantic::TexCoords(0)).is_some()));
}

#[test]
fn a_model_naming_a_file_outside_its_directory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("m.obj");
    std::fs::write(
        &obj,
        "mtllib ../secret.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let out = dir.path().join("o.obj");
    expect_failure(
        &["remesh", obj.to_str().unwrap(), out.to_str().unwrap()],
        "m.obj",
        "refusing",
    );
}
