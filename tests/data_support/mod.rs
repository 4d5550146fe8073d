//! The test meshes in `tests/data` (see its README for sources): their paths,
//! their bytes, and the meshes loaded from them, for the integration tests.

use std::path::PathBuf;

use glam::DVec3;
use isoremesh::io::ReadOptions;
use isoremesh::mesh::Mesh;
use isoremesh::pipeline::{self, LoadedInput};
use isoremesh::TriMesh;

/// The path of `name` (e.g. `"spot.obj"` or `"gltf/Duck/Duck.gltf"`) under
/// `tests/data`.
pub fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The raw bytes of `name` under `tests/data`; panics naming the path if it
/// cannot be read.
#[allow(dead_code)]
pub fn bytes(name: &str) -> Vec<u8> {
    let p = path(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// `name` loaded as a job loads it: `pipeline::load` with the file name as
/// the format hint and the default read options; panics if it fails.
#[allow(dead_code)]
pub fn load(name: &str) -> LoadedInput {
    pipeline::load(&bytes(name), Some(name), None, &ReadOptions::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The repaired half-edge mesh of [`load`].
#[allow(dead_code)]
pub fn mesh(name: &str) -> Mesh {
    load(name).mesh.clone()
}

/// The triangles of an OBJ file with only `v x y z` and `f a b c` lines
/// (1-based indices), exactly as written: parsed here, without the
/// library's reader, welding or repair. Other lines are ignored.
#[allow(dead_code)]
pub fn plain_obj(name: &str) -> TriMesh {
    let text = String::from_utf8(bytes(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for line in text.lines() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let c: Vec<f64> = w.map(|x| x.parse().unwrap()).collect();
                positions.push(DVec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let c: Vec<u32> = w.map(|x| x.parse::<u32>().unwrap() - 1).collect();
                assert_eq!(c.len(), 3);
                triangles.push([c[0], c[1], c[2]]);
            }
            _ => {}
        }
    }
    TriMesh::new(positions, triangles)
}
