//! Hostile and broken input: every case must give a typed error with a
//! one-line message, never a panic. The hostile glTFs are small valid files
//! from tests/data with their JSON or buffer edited here.

mod data_support;

use base64::Engine;
use isoremesh::io::{self, Format, IoError, ReadOptions};

fn read(bytes: &[u8], format: Format) -> Result<io::Imported, IoError> {
    let r = io::read(bytes, format, &ReadOptions::default());
    if let Err(e) = &r {
        let msg = e.to_string();
        assert!(!msg.contains('\n'), "multi-line message: {msg:?}");
        // A saturated count or offset must never read as a real number.
        assert!(
            !msg.contains("18446744073709551615"),
            "saturated value in: {msg}"
        );
        assert!(
            !matches!(e, IoError::Panic { .. }),
            "a parser panicked: {msg}"
        );
    }
    r
}

/// BoxTexturedEmbedded as JSON, for editing.
fn box_json() -> serde_json::Value {
    serde_json::from_slice(&data_support::bytes(
        "gltf/BoxTexturedEmbedded/BoxTextured.gltf",
    ))
    .unwrap()
}

fn box_read(doc: &serde_json::Value) -> Result<io::Imported, IoError> {
    read(&serde_json::to_vec(doc).unwrap(), Format::Gltf)
}

/// Replaces the embedded buffer of `doc` after `edit` changed its bytes.
fn edit_buffer(doc: &mut serde_json::Value, edit: impl FnOnce(&mut Vec<u8>)) {
    let engine = base64::engine::general_purpose::STANDARD;
    let uri = doc["buffers"][0]["uri"].as_str().unwrap().to_string();
    let (head, payload) = uri.split_once(',').unwrap();
    let mut bytes = engine.decode(payload).unwrap();
    edit(&mut bytes);
    doc["buffers"][0]["uri"] = format!("{head},{}", engine.encode(&bytes)).into();
}

#[test]
fn box_json_is_valid_before_editing() {
    // The edits below each break exactly one thing in this file.
    let r = box_read(&box_json()).unwrap();
    assert_eq!(r.mesh.face_count(), 12);
}

#[test]
fn glb_container_errors() {
    let duck = data_support::bytes("gltf/Duck.glb");
    // Truncated body: the header declares more bytes than present.
    match read(&duck[..duck.len() / 2], Format::Glb) {
        Err(IoError::Truncated {
            needed, available, ..
        }) => {
            assert_eq!(needed, duck.len() as u64);
            assert_eq!(available, duck.len() as u64 / 2);
        }
        r => panic!("expected Truncated, got {:?}", r.err()),
    }
    // Short header.
    for n in [0, 2, 4, 8, 11] {
        assert!(
            matches!(
                read(&duck[..n], Format::Glb),
                Err(IoError::Truncated { .. })
            ),
            "header cut at {n}"
        );
    }
    // Wrong magic.
    let mut bad = duck.clone();
    bad[..4].copy_from_slice(b"glTX");
    assert!(matches!(
        read(&bad, Format::Glb),
        Err(IoError::BadMagic {
            format: Format::Glb,
            ..
        })
    ));
    // Version 1 container.
    let mut v1 = duck.clone();
    v1[4] = 1;
    assert!(matches!(
        read(&v1, Format::Glb),
        Err(IoError::Unsupported { .. })
    ));
    // Chunk length running past the declared total.
    let mut chunk = duck.clone();
    chunk[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        read(&chunk, Format::Glb),
        Err(IoError::Truncated { .. })
    ));
    // BIN chunk shorter than the buffer's byteLength: cut the file and fix
    // up the header so that only the buffer check can catch it.
    let mut short = duck[..duck.len() - 1000].to_vec();
    let total = short.len() as u32;
    short[8..12].copy_from_slice(&total.to_le_bytes());
    let json_len = u32::from_le_bytes(short[12..16].try_into().unwrap()) as usize;
    let bin_at = 20 + json_len;
    let bin_len = u32::from_le_bytes(short[bin_at..bin_at + 4].try_into().unwrap()) - 1000;
    short[bin_at..bin_at + 4].copy_from_slice(&bin_len.to_le_bytes());
    match read(&short, Format::Glb) {
        Err(IoError::Truncated { what, .. }) => assert!(what.contains("buffer 0"), "{what}"),
        r => panic!("expected Truncated buffer, got {:?}", r.err()),
    }
}

#[test]
fn accessor_out_of_bounds() {
    let mut doc = box_json();
    doc["accessors"][2]["byteOffset"] = 10_000.into();
    assert!(matches!(
        box_read(&doc),
        Err(IoError::AccessorOutOfBounds { accessor: 2, .. })
    ));
    // A buffer view reaching past its buffer.
    let mut doc = box_json();
    doc["bufferViews"][1]["byteLength"] = 100_000.into();
    assert!(matches!(
        box_read(&doc),
        Err(IoError::AccessorOutOfBounds { .. })
    ));
    // Offsets near u64::MAX must not wrap around.
    let mut doc = box_json();
    doc["bufferViews"][1]["byteOffset"] = u64::MAX.into();
    assert!(matches!(
        box_read(&doc),
        Err(IoError::AccessorOutOfBounds { .. })
    ));
}

#[test]
fn accessor_counts_zero_and_huge() {
    let mut doc = box_json();
    doc["accessors"][2]["count"] = 0.into();
    assert!(matches!(
        box_read(&doc),
        Err(IoError::ZeroCount { accessor: 2 })
    ));
    let mut doc = box_json();
    doc["accessors"][2]["count"] = (1u64 << 62).into();
    let e = box_read(&doc).unwrap_err();
    assert!(
        matches!(e, IoError::AccessorOutOfBounds { accessor: 2, .. }),
        "{e}"
    );
    // Same for the index accessor (u16 elements).
    let mut doc = box_json();
    doc["accessors"][0]["count"] = (1u64 << 62).into();
    assert!(matches!(
        box_read(&doc),
        Err(IoError::AccessorOutOfBounds { accessor: 0, .. }) | Err(IoError::TooLarge { .. })
    ));
    // Without a buffer view the accessor is zero-filled: the count is bounded
    // by the triangle limit instead.
    let mut doc = box_json();
    doc["accessors"][2]
        .as_object_mut()
        .unwrap()
        .remove("bufferView");
    doc["accessors"][2]["count"] = (1u64 << 62).into();
    assert!(matches!(box_read(&doc), Err(IoError::TooLarge { .. })));
}

#[test]
fn short_byte_stride() {
    let mut doc = box_json();
    doc["bufferViews"][1]["byteStride"] = 4.into();
    match box_read(&doc) {
        Err(IoError::BadStride {
            stride,
            element_size,
            ..
        }) => assert_eq!((stride, element_size), (4, 12)),
        r => panic!("expected BadStride, got {:?}", r.err()),
    }
}

#[test]
fn gltf_index_out_of_range_and_nan() {
    // Indices are u16 at byte 768 of the buffer; 24 vertices.
    let mut doc = box_json();
    edit_buffer(&mut doc, |b| {
        b[770..772].copy_from_slice(&999u16.to_le_bytes())
    });
    match box_read(&doc) {
        Err(IoError::IndexOutOfRange {
            face,
            index,
            vertex_count,
        }) => assert_eq!((face, index, vertex_count), (0, 999, 24)),
        r => panic!("expected IndexOutOfRange, got {:?}", r.err()),
    }
    // POSITION starts at byte 288: vertex 0's y becomes NaN.
    let mut doc = box_json();
    edit_buffer(&mut doc, |b| {
        b[292..296].copy_from_slice(&f32::NAN.to_le_bytes())
    });
    assert!(matches!(
        box_read(&doc),
        Err(IoError::NonFinite { vertex: 0 })
    ));
    // A huge coordinate times the node matrix overflows to infinity.
    let mut doc = box_json();
    doc["nodes"][0]["matrix"][0] = 1e38.into();
    edit_buffer(&mut doc, |b| {
        b[288..292].copy_from_slice(&f32::MAX.to_le_bytes())
    });
    let m = box_read(&doc);
    // f64 arithmetic does not overflow here (1e38 * 3.4e38 < 1.8e308), so
    // the file is valid; what matters is that nothing panics.
    assert!(m.is_ok());
}

#[test]
fn gltf_structural_errors() {
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "missing accessor",
            Box::new(|d| d["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 99.into()),
        ),
        (
            "missing buffer view",
            Box::new(|d| d["accessors"][2]["bufferView"] = 99.into()),
        ),
        (
            "missing buffer",
            Box::new(|d| d["bufferViews"][1]["buffer"] = 5.into()),
        ),
        (
            "missing node",
            Box::new(|d| d["scenes"][0]["nodes"][0] = 42.into()),
        ),
        (
            "missing child",
            Box::new(|d| d["nodes"][0]["children"][0] = 42.into()),
        ),
        (
            "missing mesh",
            Box::new(|d| d["nodes"][1]["mesh"] = 7.into()),
        ),
        (
            "missing material",
            Box::new(|d| d["meshes"][0]["primitives"][0]["material"] = 3.into()),
        ),
        ("missing scene", Box::new(|d| d["scene"] = 3.into())),
        (
            "bad mode",
            Box::new(|d| d["meshes"][0]["primitives"][0]["mode"] = 99.into()),
        ),
        (
            "bad component type",
            Box::new(|d| d["accessors"][2]["componentType"] = 1.into()),
        ),
        (
            "float indices",
            Box::new(|d| d["accessors"][0]["componentType"] = 5126.into()),
        ),
        (
            "VEC2 positions",
            Box::new(|d| d["accessors"][2]["type"] = "VEC2".into()),
        ),
        (
            "normal count mismatch",
            Box::new(|d| d["accessors"][1]["count"] = 23.into()),
        ),
        (
            "bad data uri",
            Box::new(|d| {
                d["buffers"][0]["uri"] = "data:application/octet-stream;base64,@@@".into()
            }),
        ),
        (
            "non-base64 data uri",
            Box::new(|d| d["buffers"][0]["uri"] = "data:text/plain,hello".into()),
        ),
        (
            "glTF 1.0",
            Box::new(|d| d["asset"]["version"] = "1.0".into()),
        ),
        (
            "no asset",
            Box::new(|d| {
                d.as_object_mut().unwrap().remove("asset");
            }),
        ),
        (
            "draco required",
            Box::new(|d| {
                d["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"])
            }),
        ),
    ];
    for (what, edit) in cases {
        let mut doc = box_json();
        edit(&mut doc);
        match box_read(&doc) {
            Ok(_) => panic!("{what}: accepted"),
            Err(e) => assert!(
                matches!(e, IoError::Parse { .. } | IoError::Unsupported { .. }),
                "{what}: {e}"
            ),
        }
    }
}

#[test]
fn node_cycles_and_deep_hierarchies_terminate() {
    let mut doc = box_json();
    doc["nodes"][1]["children"] = serde_json::json!([0, 1]);
    let r = box_read(&doc).unwrap();
    assert_eq!(r.mesh.face_count(), 12);
    // A chain of 100 000 nodes: no recursion, no stack overflow.
    let mut doc = box_json();
    let n = 100_000;
    let mut nodes: Vec<serde_json::Value> = (0..n)
        .map(|i| serde_json::json!({"children": [i + 1], "translation": [0.0, 0.0, 0.0009765625]}))
        .collect();
    nodes.push(serde_json::json!({"mesh": 0}));
    doc["nodes"] = nodes.into();
    let r = box_read(&doc).unwrap();
    let z = r.mesh.bounds().unwrap().1.z;
    // 1/1024 is exact in f32 and f64: the sum is exact.
    assert_eq!(z, 0.5 + 100_000.0 / 1024.0);
}

#[test]
fn an_instancing_bomb_reads_its_mesh_once() {
    // 10 000 nodes instancing the box: read once (12 triangles, within a
    // limit of 50 000 that 120 000 instanced triangles would exceed), and
    // written once, every node using it.
    let mut doc = box_json();
    let nodes: Vec<serde_json::Value> = (0..10_000)
        .map(|_| serde_json::json!({"mesh": 0}))
        .collect();
    doc["nodes"] = nodes.into();
    doc["scenes"][0]["nodes"] = (0..10_000).collect::<Vec<u32>>().into();
    let opts = ReadOptions {
        max_triangles: 50_000,
        ..Default::default()
    };
    let bytes = serde_json::to_vec(&doc).unwrap();
    let read = io::read(&bytes, Format::Gltf, &opts).unwrap().mesh;
    assert_eq!(read.face_count(), 12);
    let written = io::write(&read, Format::Gltf, &Default::default()).unwrap();
    let out: serde_json::Value = serde_json::from_slice(&written).unwrap();
    assert_eq!(out["meshes"].as_array().unwrap().len(), 1);
    let nodes = out["nodes"].as_array().unwrap();
    assert_eq!(nodes.len(), 10_000);
    assert!(nodes.iter().all(|n| n["mesh"] == 0));
}

#[test]
fn empty_meshes() {
    let cases: [(&[u8], Format); 6] = [
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\n", Format::Obj),
        (b"OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", Format::Off),
        (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n", Format::Ply),
        (&[0u8; 84], Format::Stl),
        (b"solid empty\nendsolid empty\n", Format::Stl),
        (b"", Format::Obj),
    ];
    for (bytes, format) in cases {
        assert!(
            matches!(read(bytes, format), Err(IoError::Empty)),
            "{format}: {:?}",
            read(bytes, format).err()
        );
    }
    // glTF with only a points primitive.
    let mut doc = box_json();
    doc["meshes"][0]["primitives"][0]["mode"] = 0.into();
    assert!(matches!(box_read(&doc), Err(IoError::Empty)));
}

#[test]
fn non_finite_coordinates() {
    for text in [
        "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n",
    ] {
        assert!(
            matches!(
                read(text.as_bytes(), Format::Obj),
                Err(IoError::NonFinite { .. })
            ),
            "{text}"
        );
    }
    assert!(matches!(
        read(b"OFF\n3 1 0\n0 0 0\n1 NaN 0\n0 1 0\n3 0 1 2\n", Format::Off),
        Err(IoError::NonFinite { vertex: 1 })
    ));
    let ascii = "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n";
    assert!(matches!(
        read(ascii.as_bytes(), Format::Stl),
        Err(IoError::NonFinite { .. })
    ));
    let mut stl = data_support::bytes("spot_binary.stl");
    let at = 84 + 50 * 7 + 12 + 4; // triangle 7, vertex 0, y
    stl[at..at + 4].copy_from_slice(&f32::INFINITY.to_le_bytes());
    assert!(matches!(
        read(&stl, Format::Stl),
        Err(IoError::NonFinite { vertex: 21 })
    ));
}

#[test]
fn overflowing_sizes_are_not_reported_as_saturated_numbers() {
    // A buffer view whose offset + length overflows u64.
    let mut doc = box_json();
    doc["bufferViews"][0]["byteOffset"] = serde_json::json!(18_000_000_000_000_000_000u64);
    doc["bufferViews"][0]["byteLength"] = serde_json::json!(1_000_000_000_000_000_000u64);
    let e = box_read(&doc).unwrap_err();
    assert!(e.to_string().contains("more than 2^64"), "{e}");
    // An OFF count whose byte bound overflows u64.
    let e = read(b"OFF\n10000000000000000000 1 0\n", Format::Off).unwrap_err();
    assert!(
        matches!(e, IoError::Truncated { .. }) && e.to_string().contains("more than 2^64"),
        "{e}"
    );
}

#[test]
fn indices_out_of_range() {
    match read(
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n",
        Format::Obj,
    ) {
        // OBJ errors speak the file's numbering: line 5, the second face,
        // vertex 9 as written, of vertices 1 to 3.
        Err(e @ IoError::ObjIndexOutOfRange { .. }) => {
            assert!(matches!(
                e,
                IoError::ObjIndexOutOfRange {
                    line: 5,
                    face: 2,
                    index: 9,
                    declared: 3,
                    vertex_count: 3
                }
            ));
            assert_eq!(
                e.to_string(),
                "line 5: face 2 refers to vertex 9, but the file has 3 vertices, numbered 1 to 3"
            );
        }
        r => panic!("OBJ: {:?}", r.err()),
    }
    // A malformed statement is named by its line, with an excerpt.
    for (text, line) in [
        ("v 0 0 0\nv np.float64(1.0) 0 0\nv 0 1 0\nf 1 2 3\n", 2),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0\nf 1 2 3\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 x\nf 1/1 2/1 3/1\n", 4),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 three\n", 5),
    ] {
        let e = read(text.as_bytes(), Format::Obj).unwrap_err();
        assert!(
            e.to_string().contains(&format!("line {line}:")),
            "{text:?}: {e}"
        );
    }
    for (text, index) in [("f 0 1 2", 0), ("f -4 1 2", -4)] {
        let obj = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\n{text}\n");
        match read(obj.as_bytes(), Format::Obj) {
            Err(e @ IoError::ObjIndexOutOfRange { .. }) => {
                let IoError::ObjIndexOutOfRange { index: i, line, .. } = e else {
                    unreachable!()
                };
                assert_eq!((i, line), (index, 4), "{text}");
                assert!(e.to_string().contains(&format!("vertex {index}")), "{e}");
            }
            r => panic!("OBJ {text}: {:?}", r.err()),
        }
    }
    assert!(matches!(
        read(b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", Format::Off),
        Err(IoError::IndexOutOfRange {
            face: 0,
            index: 3,
            vertex_count: 3
        })
    ));
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n";
    assert!(matches!(
        read(ply.as_bytes(), Format::Ply),
        Err(IoError::IndexOutOfRange { index: -2, .. })
    ));
}

#[test]
fn lying_counts_and_truncation_in_text_and_binary_formats() {
    // PLY declaring far more elements than bytes.
    let ply = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    assert!(matches!(
        read(ply.as_bytes(), Format::Ply),
        Err(IoError::Truncated { .. })
    ));
    // Binary PLY cut short.
    let p = data_support::bytes("cube_quads_double_le.ply");
    assert!(matches!(
        read(&p[..p.len() - 5], Format::Ply),
        Err(IoError::Parse { .. })
    ));
    // Binary STL with more triangles declared than present.
    let s = data_support::bytes("spot_binary.stl");
    assert!(matches!(
        read(&s[..s.len() - 10], Format::Stl),
        Err(IoError::Truncated { .. })
    ));
    assert!(matches!(
        read(&s[..50], Format::Stl),
        Err(IoError::Truncated { needed: 84, .. })
    ));
    // OFF counts larger than the file.
    assert!(matches!(
        read(b"OFF\n999999999 1 0\n", Format::Off),
        Err(IoError::Truncated { .. })
    ));
    assert!(matches!(
        read(b"OFF\n3 1 0\n0 0 0\n1 0 0\n", Format::Off),
        Err(IoError::Parse { .. })
    ));
    assert!(matches!(
        read(b"OFF BINARY\n3 1 0\n", Format::Off),
        Err(IoError::Unsupported { .. })
    ));
}

#[test]
fn garbage_for_every_format() {
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut garbage = Vec::new();
    for _ in 0..4096 {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        garbage.push(seed as u8);
    }
    let samples: [&[u8]; 6] = [
        &garbage,
        &garbage[..100],
        b"",
        b"\xff\xfe\x00\x01",
        b"hello world\n",
        b"{\"not\": \"gltf\"}",
    ];
    for format in Format::ALL {
        for s in samples {
            assert!(
                read(s, format).is_err(),
                "{format} accepted {:?}",
                &s[..s.len().min(16)]
            );
        }
    }
}

#[test]
fn writers_refuse_invalid_meshes() {
    use glam::DVec3;
    use isoremesh::TriMesh;
    let opts = io::WriteOptions::default();
    let bad = TriMesh::new(vec![DVec3::ZERO], vec![[0, 0, 1]]);
    let empty = TriMesh::new(vec![DVec3::ZERO], vec![]);
    let nan = TriMesh::new(vec![DVec3::NAN, DVec3::X, DVec3::Y], vec![[0, 1, 2]]);
    let huge = TriMesh::new(
        vec![DVec3::splat(1e300), DVec3::X, DVec3::Y],
        vec![[0, 1, 2]],
    );
    for f in Format::ALL {
        assert!(matches!(
            io::write(&bad, f, &opts),
            Err(IoError::InvalidMesh { .. })
        ));
        assert!(matches!(io::write(&empty, f, &opts), Err(IoError::Empty)));
        assert!(matches!(
            io::write(&nan, f, &opts),
            Err(IoError::NonFinite { vertex: 0 })
        ));
    }
    // glTF stores f32: 1e300 does not fit.
    assert!(matches!(
        io::write(&huge, Format::Glb, &opts),
        Err(IoError::NonFinite { vertex: 0 })
    ));
}

/// A regular polygon of `n` corners on the unit circle, as one face in
/// OBJ, OFF and PLY.
fn polygon_files(n: usize) -> [(Format, Vec<u8>); 3] {
    use std::fmt::Write;
    let (mut obj, mut off, mut ply) = (String::new(), format!("OFF\n{n} 1 0\n"), String::new());
    write!(ply, "ply\nformat ascii 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n").unwrap();
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        let (x, y) = (a.cos(), a.sin());
        writeln!(obj, "v {x} {y} 0").unwrap();
        writeln!(off, "{x} {y} 0").unwrap();
        writeln!(ply, "{x} {y} 0").unwrap();
    }
    let ids = |from: usize| {
        (0..n)
            .map(|i| (i + from).to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    writeln!(obj, "f {}", ids(1)).unwrap();
    writeln!(off, "{n} {}", ids(0)).unwrap();
    writeln!(ply, "{n} {}", ids(0)).unwrap();
    [
        (Format::Obj, obj.into_bytes()),
        (Format::Off, off.into_bytes()),
        (Format::Ply, ply.into_bytes()),
    ]
}

/// A huge polygon is triangulated in linear time with bounded valence (no
/// fan that puts every triangle on one corner), and one above the limit is
/// refused by name.
#[test]
fn huge_polygons_are_stripped_or_refused() {
    let n = 20_000;
    for (format, bytes) in polygon_files(n) {
        let mesh = read(&bytes, format).expect("reads").mesh;
        assert_eq!(mesh.triangles.len(), n - 2, "{format:?}");
        let mut uses = vec![0u32; mesh.positions.len()];
        for t in &mesh.triangles {
            for &v in t {
                uses[v as usize] += 1;
            }
        }
        assert!(
            uses.iter().all(|&u| u <= 4),
            "{format:?}: max valence {:?}",
            uses.iter().max()
        );
    }
    let too_many = io::polygon::MAX_POLYGON_CORNERS + 1;
    for (format, bytes) in polygon_files(too_many) {
        let err = read(&bytes, format).expect_err("refused");
        assert!(matches!(err, IoError::TooLarge { .. }), "{format:?}: {err}");
        assert!(
            err.to_string().contains(&format!("{too_many} corners")),
            "{err}"
        );
    }
}
