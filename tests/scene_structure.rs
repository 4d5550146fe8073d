//! Scenes survive a remesh: glTF nodes with their names, hierarchy,
//! transforms, cameras and extras, meshes with their names, a mesh that two
//! nodes use written once, each mesh in its own space (also under a
//! non-uniform and a mirroring scale) with edges of length L in world
//! units; OBJ objects kept as objects.

use base64::Engine;
use glam::{DMat4, DQuat, DVec3};
use isoremesh::io::{self, Format, ReadOptions};
use isoremesh::pipeline;
use isoremesh::remesh::{NoObserver, RemeshOptions};
use isoremesh::{shapes, TriMesh};
use serde_json::{json, Value};

/// A `.gltf` document with the given meshes (one primitive each, in a
/// `data:` buffer) and the given nodes, scenes and cameras.
fn scene_gltf(meshes: &[(&str, TriMesh)], graph: Value) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut out_meshes) = (vec![], vec![], vec![]);
    for (name, m) in meshes {
        let at = bin.len();
        for p in &m.positions {
            for c in [p.x, p.y, p.z] {
                bin.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        views.push(json!({"buffer": 0, "byteOffset": at, "byteLength": bin.len() - at}));
        let (lo, hi) = m.bounds().unwrap();
        accessors.push(json!({
            "bufferView": views.len() - 1, "componentType": 5126, "type": "VEC3",
            "count": m.positions.len(),
            "min": [lo.x as f32, lo.y as f32, lo.z as f32],
            "max": [hi.x as f32, hi.y as f32, hi.z as f32],
        }));
        let at = bin.len();
        for t in &m.triangles {
            for i in t {
                bin.extend_from_slice(&i.to_le_bytes());
            }
        }
        views.push(json!({"buffer": 0, "byteOffset": at, "byteLength": bin.len() - at}));
        accessors.push(json!({
            "bufferView": views.len() - 1, "componentType": 5125, "type": "SCALAR",
            "count": m.triangles.len() * 3,
        }));
        out_meshes.push(json!({
            "name": name,
            "extras": {"part_number": format!("PN-{name}")},
            "primitives": [{"attributes": {"POSITION": accessors.len() - 2}, "indices": accessors.len() - 1}],
        }));
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": bin.len(), "uri": uri}],
        "bufferViews": views,
        "accessors": accessors,
        "meshes": out_meshes,
    });
    for (k, v) in graph.as_object().unwrap() {
        doc[k] = v.clone();
    }
    serde_json::to_vec(&doc).unwrap()
}

/// The scene tree of a glTF document: per node its name, children,
/// transform keys and values, camera and extras, and its mesh's name.
fn tree(doc: &Value) -> Vec<Value> {
    doc["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| {
            let mesh = n["mesh"]
                .as_u64()
                .map(|m| doc["meshes"][m as usize]["name"].clone());
            json!({
                "name": n["name"], "children": n["children"], "matrix": n["matrix"],
                "translation": n["translation"], "rotation": n["rotation"], "scale": n["scale"],
                "camera": n["camera"], "extras": n["extras"], "mesh": mesh,
            })
        })
        .collect()
}

fn document(bytes: &[u8]) -> Value {
    serde_json::from_slice(bytes).unwrap()
}

/// Remeshes `bytes` at edge length `l` and returns the glTF output.
fn remesh_gltf(bytes: &[u8], name: &str, l: f64) -> Vec<u8> {
    let input = pipeline::load(bytes, Some(name), None, &ReadOptions::default()).unwrap();
    let options = RemeshOptions {
        target_edge_length: Some(l),
        ..Default::default()
    };
    let out = pipeline::run(&input, &options, &mut NoObserver).unwrap();
    pipeline::encode(&out.mesh, Format::Gltf).unwrap()
}

/// Per node of `doc` with a mesh: its world matrix and its mesh read back
/// in the mesh's own space.
fn node_meshes(bytes: &[u8]) -> Vec<(String, DMat4, TriMesh)> {
    let doc = document(bytes);
    let nodes = doc["nodes"].as_array().unwrap();
    let local = |n: &Value| -> DMat4 {
        let v = |k: &str, d: [f64; 4]| -> [f64; 4] {
            n[k].as_array().map_or(d, |a| {
                let mut o = d;
                for (i, x) in a.iter().enumerate() {
                    o[i] = x.as_f64().unwrap();
                }
                o
            })
        };
        let t = v("translation", [0.0; 4]);
        let r = v("rotation", [0.0, 0.0, 0.0, 1.0]);
        let s = v("scale", [1.0; 4]);
        DMat4::from_scale_rotation_translation(
            DVec3::new(s[0], s[1], s[2]),
            DQuat::from_xyzw(r[0], r[1], r[2], r[3]),
            DVec3::new(t[0], t[1], t[2]),
        )
    };
    let mut world = vec![DMat4::IDENTITY; nodes.len()];
    let mut stack: Vec<(usize, DMat4)> = doc["scenes"][0]["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| (n.as_u64().unwrap() as usize, DMat4::IDENTITY))
        .collect();
    while let Some((n, parent)) = stack.pop() {
        world[n] = parent * local(&nodes[n]);
        for c in nodes[n]["children"].as_array().into_iter().flatten() {
            stack.push((c.as_u64().unwrap() as usize, world[n]));
        }
    }
    let mut out = Vec::new();
    for (i, n) in nodes.iter().enumerate() {
        let Some(m) = n["mesh"].as_u64() else {
            continue;
        };
        // A document of that one mesh under one plain node.
        let mut one = doc.clone();
        one["meshes"] = json!([doc["meshes"][m as usize]]);
        one["nodes"] = json!([{"mesh": 0}]);
        one["scenes"] = json!([{"nodes": [0]}]);
        one["scene"] = json!(0);
        let bytes = serde_json::to_vec(&one).unwrap();
        let mesh = io::read(&bytes, Format::Gltf, &ReadOptions::default())
            .unwrap()
            .mesh;
        out.push((n["name"].as_str().unwrap_or("").to_string(), world[i], mesh));
    }
    out
}

fn mean_world_edge(world: DMat4, m: &TriMesh) -> f64 {
    let mut sum = 0.0;
    for t in &m.triangles {
        for k in 0..3 {
            let a = world.transform_point3(m.positions[t[k] as usize]);
            let b = world.transform_point3(m.positions[t[(k + 1) % 3] as usize]);
            sum += (a - b).length();
        }
    }
    sum / (3 * m.triangles.len()) as f64
}

fn signed_volume(m: &TriMesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = m.corner_positions(t);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

fn furniture() -> Vec<u8> {
    let ball = shapes::icosphere(3);
    let leg = shapes::cube(4, DVec3::new(-0.1, -0.1, -0.5), DVec3::new(0.1, 0.1, 0.5));
    scene_gltf(
        &[("Cushion", ball), ("Leg", leg)],
        json!({
            "nodes": [
                {"name": "Sofa", "children": [1, 2, 3], "translation": [1.0, 0.0, 0.0],
                 "scale": [2.0, 1.0, 0.5], "extras": {"sku": "S-1"}},
                {"name": "Cushion", "mesh": 0, "translation": [0.0, 0.0, 1.0]},
                {"name": "Leg", "mesh": 1, "translation": [1.0, 0.0, -1.0]},
                {"name": "Leg.001", "mesh": 1, "translation": [-1.0, 0.0, -1.0],
                 "rotation": [0.0, 0.0, 0.38268343, 0.92387953]},
                {"name": "View", "camera": 0, "translation": [0.0, -5.0, 0.0]},
            ],
            "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
            "scenes": [{"name": "Room", "nodes": [0, 4]}],
            "scene": 0,
        }),
    )
}

#[test]
fn a_scene_keeps_its_nodes_meshes_and_transforms() {
    let input = furniture();
    let out = remesh_gltf(&input, "sofa.gltf", 0.08);
    let (a, b) = (document(&input), document(&out));
    assert_eq!(tree(&a), tree(&b), "the scene tree");
    assert_eq!(b["scenes"], a["scenes"]);
    assert_eq!(b["cameras"], a["cameras"]);
    let names: Vec<_> = b["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| (m["name"].clone(), m["extras"].clone()))
        .collect();
    assert_eq!(
        names,
        [
            (json!("Cushion"), json!({"part_number": "PN-Cushion"})),
            (json!("Leg"), json!({"part_number": "PN-Leg"}))
        ]
    );
    // The mesh two nodes use is written once, and both use it.
    assert_eq!(b["nodes"][2]["mesh"], b["nodes"][3]["mesh"]);
    assert_eq!(b["meshes"].as_array().unwrap().len(), 2);
    // The same tree in a GLB's JSON chunk, and again after reading the GLB
    // back and writing it as glTF.
    let loaded = pipeline::load(&input, Some("sofa.gltf"), None, &ReadOptions::default()).unwrap();
    let options = RemeshOptions {
        target_edge_length: Some(0.08),
        ..Default::default()
    };
    let mesh = pipeline::run(&loaded, &options, &mut NoObserver)
        .unwrap()
        .mesh;
    let glb = pipeline::encode(&mesh, Format::Glb).unwrap();
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let g = document(&glb[20..20 + json_len]);
    assert_eq!(tree(&g), tree(&a), "the GLB's scene tree");
    let again = io::read(&glb, Format::Glb, &ReadOptions::default())
        .unwrap()
        .mesh;
    let c = document(&pipeline::encode(&again, Format::Gltf).unwrap());
    assert_eq!(tree(&c), tree(&a), "read back and written again");
}

#[test]
fn each_mesh_comes_back_in_its_own_space_with_world_lengths() {
    let l = 0.08;
    let out = remesh_gltf(&furniture(), "sofa.gltf", l);
    let parts = node_meshes(&out);
    assert_eq!(parts.len(), 3);
    for (name, world, mesh) in &parts {
        // Under the parent's scale (2, 1, 0.5) the world edges are L long.
        let mean = mean_world_edge(*world, mesh) / l;
        assert!(
            (0.9..1.2).contains(&mean),
            "{name}: mean world edge {mean}·L"
        );
        assert!(signed_volume(mesh) > 0.0, "{name}: faces point outwards");
    }
    let (_, _, cushion) = &parts[0];
    for p in &cushion.positions {
        let r = p.length();
        // On the unit icosphere (its facets dip to about 0.995).
        assert!(
            (0.99..1.0 + 1e-6).contains(&r),
            "cushion vertex at radius {r}"
        );
    }
    let (_, _, leg) = &parts[1];
    let (lo, hi) = leg.bounds().unwrap();
    assert!((lo - DVec3::new(-0.1, -0.1, -0.5)).abs().max_element() < 1e-6);
    assert!((hi - DVec3::new(0.1, 0.1, 0.5)).abs().max_element() < 1e-6);
}

#[test]
fn a_mirrored_node_keeps_its_faces_outward() {
    let input = scene_gltf(
        &[("Ball", shapes::icosphere(3))],
        json!({
            "nodes": [{"name": "Mirror", "mesh": 0, "scale": [-1.0, 3.0, 1.0]}],
            "scenes": [{"nodes": [0]}],
        }),
    );
    let out = remesh_gltf(&input, "mirror.gltf", 0.1);
    let parts = node_meshes(&out);
    assert_eq!(parts.len(), 1);
    let (_, world, ball) = &parts[0];
    assert!(signed_volume(ball) > 0.0, "outward in its own space");
    let mean = mean_world_edge(*world, ball) / 0.1;
    assert!((0.9..1.2).contains(&mean), "mean world edge {mean}·L");
    assert_eq!(document(&out)["nodes"][0]["scale"], json!([-1.0, 3.0, 1.0]));
}

#[test]
fn obj_objects_stay_objects() {
    let a = shapes::icosphere(2);
    let b = shapes::translated(shapes::icosphere(2), DVec3::new(3.0, 0.0, 0.0));
    let mut text = String::new();
    let mut base = 1;
    for (name, m) in [("Left ball", &a), ("Right", &b)] {
        text += &format!("o {name}\n");
        for p in &m.positions {
            text += &format!("v {} {} {}\n", p.x, p.y, p.z);
        }
        for t in &m.triangles {
            text += &format!("f {} {} {}\n", t[0] + base, t[1] + base, t[2] + base);
        }
        base += m.positions.len() as u32;
    }
    let input = pipeline::load(
        text.as_bytes(),
        Some("balls.obj"),
        None,
        &ReadOptions::default(),
    )
    .unwrap();
    let options = RemeshOptions {
        target_edge_length: Some(0.2),
        ..Default::default()
    };
    let out = pipeline::run(&input, &options, &mut NoObserver).unwrap();
    let obj = String::from_utf8(pipeline::encode(&out.mesh, Format::Obj).unwrap()).unwrap();
    let objects: Vec<&str> = obj.lines().filter(|l| l.starts_with("o ")).collect();
    assert_eq!(objects, ["o Left ball", "o Right"]);
    let gltf = document(&pipeline::encode(&out.mesh, Format::Gltf).unwrap());
    let nodes: Vec<_> = gltf["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| (n["name"].clone(), n["mesh"].clone()))
        .collect();
    assert_eq!(
        nodes,
        [(json!("Left ball"), json!(0)), (json!("Right"), json!(1))]
    );
    // Each object's faces stay in its own mesh.
    for (m, centre) in [(0usize, 0.0), (1, 3.0)] {
        let mut one = gltf.clone();
        one["meshes"] = json!([gltf["meshes"][m]]);
        one["nodes"] = json!([{"mesh": 0}]);
        one["scenes"] = json!([{"nodes": [0]}]);
        let mesh = io::read(
            &serde_json::to_vec(&one).unwrap(),
            Format::Gltf,
            &ReadOptions::default(),
        )
        .unwrap()
        .mesh;
        assert!(mesh.positions.iter().all(|p| (p.x - centre).abs() < 1.01));
    }
}

#[test]
fn a_singular_node_transform_flattens_and_says_so() {
    let input = scene_gltf(
        &[("Flat", shapes::icosphere(2))],
        json!({
            "nodes": [{"name": "Flat", "mesh": 0, "scale": [1.0, 1.0, 0.0]}],
            "scenes": [{"nodes": [0]}],
        }),
    );
    let read = io::read(&input, Format::Gltf, &ReadOptions::default())
        .unwrap()
        .mesh;
    assert!(read.scene.is_none());
    assert!(read.attributes.dropped.iter().any(|d| d.name == "scene"));
}

/// Distance from `p` to the surface of the box `[lo, hi]`.
fn box_surface_distance(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let inside = p.cmpge(lo).all() && p.cmple(hi).all();
    if inside {
        (p - lo).min(hi - p).min_element()
    } else {
        (p.clamp(lo, hi) - p).length()
    }
}

#[test]
fn interpenetrating_parts_stay_on_their_own_surfaces() {
    // A thin slab pushed through a box: its faces cross the box's faces.
    let boxes = [
        (DVec3::ZERO, DVec3::ONE),
        (DVec3::new(0.3, -0.4, 0.45), DVec3::new(0.7, 1.4, 0.55)),
    ];
    let parts: Vec<TriMesh> = boxes
        .iter()
        .map(|&(lo, hi)| shapes::cube(3, lo, hi))
        .collect();
    let soup = shapes::union(&parts);
    let bytes = io::write(&soup, Format::Obj, &Default::default()).unwrap();
    for preserve_features in [true, false] {
        let input =
            pipeline::load(&bytes, Some("boxes.obj"), None, &ReadOptions::default()).unwrap();
        let options = RemeshOptions {
            target_edge_length: Some(0.04),
            preserve_features,
            ..Default::default()
        };
        let out = pipeline::run(&input, &options, &mut NoObserver)
            .unwrap()
            .mesh;
        // Which box each output vertex belongs to: its component's.
        let mut uf: Vec<usize> = (0..out.positions.len()).collect();
        fn find(uf: &mut [usize], mut x: usize) -> usize {
            while uf[x] != x {
                uf[x] = uf[uf[x]];
                x = uf[x];
            }
            x
        }
        for t in &out.triangles {
            for k in 0..3 {
                let (a, b) = (
                    find(&mut uf, t[k] as usize),
                    find(&mut uf, t[(k + 1) % 3] as usize),
                );
                uf[a] = b;
            }
        }
        let mut owner = std::collections::HashMap::new();
        let mut off = 0;
        for v in 0..out.positions.len() {
            let root = find(&mut uf, v);
            let p = out.positions[v];
            let own = *owner.entry(root).or_insert_with(|| {
                // A component's first vertex decides: it lies on one box only
                // unless it sits exactly on both.
                let d: Vec<f64> = boxes
                    .iter()
                    .map(|&(lo, hi)| box_surface_distance(p, lo, hi))
                    .collect();
                usize::from(d[1] < d[0])
            });
            let (lo, hi) = boxes[own];
            if box_surface_distance(p, lo, hi) > 1e-9 {
                off += 1;
            }
        }
        assert_eq!(
            off, 0,
            "vertices off their own box (features {preserve_features})"
        );
    }
}

#[test]
fn a_part_smaller_than_its_limit_is_kept_remeshed_or_dropped() {
    use isoremesh::remesh::SmallParts;
    // A sphere of radius 1 and, beside it, a bead 0.1 across: under L = 0.1
    // the bead is small (its diagonal, about 0.17, is under 2·L).
    let bead = shapes::translated(
        {
            let mut b = shapes::icosphere(2);
            b.positions.iter_mut().for_each(|p| *p *= 0.05);
            b
        },
        DVec3::new(2.0, 0.0, 0.0),
    );
    let soup = shapes::union(&[shapes::icosphere(3), bead.clone()]);
    let bytes = io::write(&soup, Format::Obj, &Default::default()).unwrap();
    let input = pipeline::load(&bytes, Some("bead.obj"), None, &ReadOptions::default()).unwrap();
    let near_bead = |m: &TriMesh| m.positions.iter().filter(|p| p.x > 1.5).count();
    let faces_near_bead = |m: &TriMesh| {
        m.triangles
            .iter()
            .filter(|t| m.positions[t[0] as usize].x > 1.5)
            .count()
    };
    for policy in [SmallParts::Keep, SmallParts::Remesh, SmallParts::Drop] {
        let options = RemeshOptions {
            target_edge_length: Some(0.1),
            small_parts: policy,
            ..Default::default()
        };
        let out = pipeline::run(&input, &options, &mut NoObserver).unwrap();
        let parts = out.report.parts;
        assert_eq!(parts.total, 2, "{policy}");
        let m = &out.mesh;
        match policy {
            SmallParts::Keep => {
                assert_eq!((parts.kept, parts.remeshed, parts.dropped), (1, 1, 0));
                // The bead's triangles, exactly as they came.
                assert_eq!(faces_near_bead(m), bead.triangles.len());
                let mut got: Vec<[u64; 3]> = m
                    .positions
                    .iter()
                    .filter(|p| p.x > 1.5)
                    .map(|p| p.to_array().map(f64::to_bits))
                    .collect();
                let mut want: Vec<[u64; 3]> = bead
                    .positions
                    .iter()
                    .map(|p| p.to_array().map(f64::to_bits))
                    .collect();
                got.sort_unstable();
                want.sort_unstable();
                assert_eq!(got, want, "kept vertices are the input's");
                // Its edges are the input's: forced, counted apart.
                let split = out
                    .stats
                    .output
                    .edge_length
                    .as_ref()
                    .unwrap()
                    .split
                    .unwrap();
                assert_eq!(split.forced_edges as usize, bead.triangles.len() * 3 / 2);
                assert_eq!(split.forced_within_band, 0.0);
                assert!(split.free_within_band > 0.9);
            }
            SmallParts::Remesh => {
                assert_eq!((parts.kept, parts.remeshed, parts.dropped), (0, 2, 0));
                assert!(near_bead(m) > 0 && faces_near_bead(m) != bead.triangles.len());
            }
            SmallParts::Drop => {
                assert_eq!((parts.kept, parts.remeshed, parts.dropped), (0, 1, 1));
                assert_eq!(near_bead(m), 0);
            }
        }
    }
    // A lone part is never small, whatever L.
    let lone = io::write(&bead, Format::Obj, &Default::default()).unwrap();
    let input = pipeline::load(&lone, Some("lone.obj"), None, &ReadOptions::default()).unwrap();
    let options = RemeshOptions {
        target_edge_length: Some(0.1),
        ..Default::default()
    };
    let out = pipeline::run(&input, &options, &mut NoObserver).unwrap();
    assert_eq!(out.report.parts.remeshed, 1);
}

#[test]
fn formats_without_instancing_get_one_copy_per_node() {
    let input = furniture();
    let loaded = pipeline::load(&input, Some("sofa.gltf"), None, &ReadOptions::default()).unwrap();
    let options = RemeshOptions {
        target_edge_length: Some(0.08),
        ..Default::default()
    };
    let out = pipeline::run(&loaded, &options, &mut NoObserver)
        .unwrap()
        .mesh;
    let obj = pipeline::encode(&out, Format::Obj).unwrap();
    let back = io::read(&obj, Format::Obj, &ReadOptions::default())
        .unwrap()
        .mesh;
    // The legs stand under the cushion (z < -0.2 in world space), at
    // x = 1 ± 2 under the sofa's scale 2.
    let leg_faces = |m: &TriMesh, x: f64| {
        m.triangles
            .iter()
            .filter(|t| {
                let p = m.positions[t[0] as usize];
                p.z < -0.2 && (p.x - x).abs() < 0.6
            })
            .count()
    };
    let one_leg = leg_faces(&back, 3.0);
    assert!(one_leg > 0, "the first leg is written");
    assert_eq!(leg_faces(&back, -1.0), one_leg, "so is its copy");
    assert_eq!(leg_faces(&out, -1.0), 0, "the result holds the leg once");
    assert_eq!(back.triangles.len(), out.triangles.len() + one_leg);
}
