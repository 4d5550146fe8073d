//! The `quality_attributes` option: per-face smallest angle and edge-length
//! ratio, per-vertex valence, written as PLY properties and glTF `_NAME`
//! attributes; without the option the bytes do not change.

mod data_support;

use std::collections::{BTreeMap, HashMap};

use isoremesh::io::{self, Format, ReadOptions};
use isoremesh::pipeline::{self, JobOutput};
use isoremesh::remesh::{NoObserver, RemeshOptions};

fn job(quality: bool) -> JobOutput {
    let input = data_support::load("fandisk.obj");
    let l = 0.02 * input.mesh.to_trimesh().bbox_diagonal();
    let options = RemeshOptions {
        quality_attributes: quality,
        ..RemeshOptions::default()
            .with_target_edge_length(l)
            .with_iterations(3)
    };
    pipeline::run(&input, &options, &mut NoObserver).unwrap()
}

/// The float property values of a binary little-endian PLY written by us:
/// (vertex values per property, face values per property).
type Columns = BTreeMap<String, Vec<f32>>;

/// A PLY element: name, count, and its properties as (name, type).
type Element = (String, usize, Vec<(String, String)>);

fn ply_columns(bytes: &[u8]) -> (Columns, Columns) {
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    let mut elements: Vec<Element> = Vec::new();
    for line in header.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["element", name, n] => elements.push((name.to_string(), n.parse().unwrap(), vec![])),
            ["property", "list", _, _, name] => elements
                .last_mut()
                .unwrap()
                .2
                .push((name.to_string(), "list".into())),
            ["property", ty, name] => elements
                .last_mut()
                .unwrap()
                .2
                .push((name.to_string(), ty.to_string())),
            _ => {}
        }
    }
    let mut at = end;
    let mut out = vec![Columns::new(), Columns::new()];
    for (k, (_, n, props)) in elements.iter().enumerate() {
        for _ in 0..*n {
            for (name, ty) in props {
                match ty.as_str() {
                    "double" => at += 8,
                    "list" => at += 1 + 4 * bytes[at] as usize,
                    "float" => {
                        let x = f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
                        out[k].entry(name.clone()).or_default().push(x);
                        at += 4;
                    }
                    t => panic!("unexpected type {t}"),
                }
            }
        }
    }
    assert_eq!(at, bytes.len());
    let faces = out.pop().unwrap();
    (out.pop().unwrap(), faces)
}

#[test]
fn without_the_option_nothing_changes() {
    let out = job(false);
    assert!(out.attributes.is_empty());
    for f in [Format::Ply, Format::Glb] {
        assert_eq!(
            pipeline::encode_with(&out.mesh, f, &out.attributes).unwrap(),
            pipeline::encode(&out.mesh, f).unwrap()
        );
    }
}

#[test]
fn ply_carries_face_and_vertex_quality_that_match_the_statistics() {
    let out = job(true);
    let bytes = pipeline::encode_with(&out.mesh, Format::Ply, &out.attributes).unwrap();
    let (vertex, face) = ply_columns(&bytes);
    let nf = out.mesh.triangles.len();
    assert_eq!(face["quality_min_angle"].len(), nf);
    assert_eq!(face["quality_edge_ratio"].len(), nf);
    // The smallest angle per face agrees with the statistics.
    let s = &out.stats.output;
    let angles = s.angles.as_ref().unwrap();
    let min = face["quality_min_angle"]
        .iter()
        .fold(f32::MAX, |a, &b| a.min(b));
    let mean = face["quality_min_angle"]
        .iter()
        .map(|&x| x as f64)
        .sum::<f64>()
        / nf as f64;
    assert!((min as f64 - angles.min_deg).abs() < 1e-4, "{min}");
    assert!((mean - angles.mean_min_deg).abs() < 1e-4, "{mean}");
    // Ratios to the target sit around 1, as the edges sit in the band.
    let ratios = &face["quality_edge_ratio"];
    let inside = ratios
        .iter()
        .filter(|&&r| (0.8..=4.0 / 3.0).contains(&r))
        .count();
    assert!(inside as f64 > 0.9 * nf as f64, "{inside} of {nf}");
    // Valence per welded vertex is the statistics' valence histogram.
    let mut seen = HashMap::new();
    for (p, &v) in out.mesh.positions.iter().zip(&vertex["valence"]) {
        let key = [p.x, p.y, p.z].map(f64::to_bits);
        if let Some(old) = seen.insert(key, v) {
            assert_eq!(old, v, "split copies of a vertex disagree");
        }
    }
    let mut hist: BTreeMap<u32, u64> = BTreeMap::new();
    for v in seen.values() {
        *hist.entry(*v as u32).or_default() += 1;
    }
    assert_eq!(hist, s.valence.histogram);
    // The geometry reads back as before.
    let back = io::read(&bytes, Format::Ply, &ReadOptions::default()).unwrap();
    assert_eq!(back.mesh.triangles, out.mesh.triangles);
}

#[test]
fn gltf_gives_every_face_its_corners_and_underscore_attributes() {
    let out = job(true);
    for f in [Format::Glb, Format::Gltf] {
        let bytes = pipeline::encode_with(&out.mesh, f, &out.attributes).unwrap();
        let json: serde_json::Value = if f == Format::Glb {
            let n = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
            serde_json::from_slice(&bytes[20..20 + n]).unwrap()
        } else {
            serde_json::from_slice(&bytes).unwrap()
        };
        let corners = 3 * out.mesh.triangles.len();
        for prim in json["meshes"][0]["primitives"].as_array().unwrap() {
            let attrs = prim["attributes"].as_object().unwrap();
            for name in ["_QUALITY_MIN_ANGLE", "_QUALITY_EDGE_RATIO", "_VALENCE"] {
                let acc = &json["accessors"][attrs[name].as_u64().unwrap() as usize];
                assert_eq!(acc["count"].as_u64(), Some(corners as u64), "{f} {name}");
                assert_eq!(acc["type"], "SCALAR");
                assert_eq!(acc["componentType"], 5126);
            }
        }
        // Read back and welded, it is the same surface.
        let back = io::read(&bytes, f, &ReadOptions::default()).unwrap().mesh;
        assert_eq!(back.positions.len(), corners);
        let s = isoremesh::stats::compute(&back, &Default::default());
        assert_eq!(
            (s.faces, s.edges, s.valence.histogram.clone()),
            (
                out.stats.output.faces,
                out.stats.output.edges,
                out.stats.output.valence.histogram.clone()
            ),
            "{f}"
        );
    }
    // Formats without a place for them refuse.
    for f in [Format::Obj, Format::Stl, Format::Off] {
        let e = pipeline::encode_with(&out.mesh, f, &out.attributes).unwrap_err();
        assert!(e.to_string().contains("glTF, GLB or PLY"), "{e}");
    }
}
