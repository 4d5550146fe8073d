//! Authored hard edges: where an input carries vertex normals, an edge
//! across which the normals differ (its end vertices are split with a
//! normal on each side) is an edge the author shaded hard. They become
//! features beside, or instead of, the dihedral-angle creases
//! ([`crate::remesh::FeatureSource`]).
//!
//! A file shaded flat (every face its own normal) marks every edge hard and
//! says nothing about intent: when more than [`FLAT_SHADED_FRACTION`] of
//! the interior edges are hard, none is taken.

use glam::DVec3;

use crate::topology::EdgeTable;
use crate::trimesh::{position_key, weld_positions, TriMesh};

/// Cosine of the angle (1°) by which the normals on the two sides of an
/// edge must differ, at one of its ends, for the edge to be hard: authored
/// normals are either shared (bit-equal) or deliberately different, and
/// 1° is far above the f32 rounding of a normal written twice.
pub const HARD_EDGE_COS: f64 = 0.999_847_695_156_391_2;

/// The fraction of hard interior edges above which the normals are taken
/// for flat shading and ignored.
pub const FLAT_SHADED_FRACTION: f64 = 0.5;

/// The hard edges of `source` as vertex pairs of `surface`, a mesh with
/// the same positions (the repaired input); empty when `source` has no
/// normals or is shaded flat.
pub fn hard_edges(source: &TriMesh, surface: &TriMesh) -> Vec<[u32; 2]> {
    let Some((hard, interior, welded)) = welded_hard_edges(source) else {
        return Vec::new();
    };
    if interior == 0 || hard.len() as f64 > FLAT_SHADED_FRACTION * interior as f64 {
        return Vec::new();
    }
    // Welded vertex pairs to the surface's vertex pairs, by position.
    let by_position: std::collections::HashMap<[u64; 3], u32> = surface
        .positions
        .iter()
        .enumerate()
        .map(|(i, &p)| (position_key(p), i as u32))
        .collect();
    hard.into_iter()
        .filter_map(|[a, b]| {
            let a = *by_position.get(&position_key(welded[a as usize]))?;
            let b = *by_position.get(&position_key(welded[b as usize]))?;
            Some([a, b])
        })
        .collect()
}

/// Whether `source` carries normals and is shaded flat: more than
/// [`FLAT_SHADED_FRACTION`] of its interior edges hard.
pub fn shaded_flat(source: &TriMesh) -> bool {
    welded_hard_edges(source).is_some_and(|(hard, interior, _)| {
        interior > 0 && hard.len() as f64 > FLAT_SHADED_FRACTION * interior as f64
    })
}

/// The hard edges of `source` as pairs of its welded positions, the number
/// of interior edges, and the welded positions; `None` without normals.
fn welded_hard_edges(source: &TriMesh) -> Option<(Vec<[u32; 2]>, usize, Vec<DVec3>)> {
    let n = source.positions.len();
    if source.normals.len() != n || n == 0 {
        return None;
    }
    let (weld, welded) = weld_positions(&source.positions);
    let tris: Vec<[u32; 3]> = source
        .triangles
        .iter()
        .map(|t| t.map(|v| weld[v as usize]))
        .collect();
    let normal_at = |h: u32, w: u32| -> DVec3 {
        let f = (h / 3) as usize;
        let k = (0..3).find(|&k| tris[f][k] == w).unwrap_or(0);
        source.normals[source.triangles[f][k] as usize]
    };
    let differ = |a: DVec3, b: DVec3| a.dot(b) < HARD_EDGE_COS * a.length() * b.length();
    let mut hard = Vec::new();
    let mut interior = 0usize;
    EdgeTable::new(&tris, welded.len()).for_each(|a, b, run| {
        if let [(_, h0), (_, h1)] = *run {
            interior += 1;
            if differ(normal_at(h0, a), normal_at(h1, a))
                || differ(normal_at(h0, b), normal_at(h1, b))
            {
                hard.push([a, b]);
            }
        }
    });
    Some((hard, interior, welded))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube of 8 corners whose faces are split per side (24 vertices),
    /// each side with its own normal, but smooth normals across one seam.
    #[test]
    fn split_normals_mark_hard_edges_and_flat_shading_marks_none() {
        // Two quads folded at 90° along x = 0, plus a flat continuation.
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let positions = vec![
            // Floor, normal +z: 0..4
            p(0., 0., 0.),
            p(1., 0., 0.),
            p(1., 1., 0.),
            p(0., 1., 0.),
            // Wall at x = 0, normal +x: 4..8 (shares 0 and 3 by position)
            p(0., 0., 0.),
            p(0., 1., 0.),
            p(0., 1., 1.),
            p(0., 0., 1.),
            // Floor continued, normal +z, sharing vertices 1 and 2: 8..10
            p(2., 0., 0.),
            p(2., 1., 0.),
        ];
        let up = DVec3::Z;
        let normals = vec![
            up,
            up,
            up,
            up,
            DVec3::X,
            DVec3::X,
            DVec3::X,
            DVec3::X,
            up,
            up,
        ];
        let triangles = vec![
            [0, 1, 2],
            [0, 2, 3],
            [4, 5, 6],
            [4, 6, 7],
            [1, 8, 9],
            [1, 9, 2],
        ];
        let mut m = TriMesh::new(positions, triangles);
        m.normals = normals;
        let surface = m.welded().0;
        let hard = hard_edges(&m, &surface);
        assert_eq!(hard.len(), 1, "only the fold is hard: {hard:?}");
        let [a, b] = hard[0];
        let (pa, pb) = (surface.positions[a as usize], surface.positions[b as usize]);
        assert!(pa.x == 0.0 && pb.x == 0.0 && pa.z == 0.0 && pb.z == 0.0);
        // Every vertex split per face with its face normal: flat shading.
        let mut flat = crate::shapes::icosphere(1);
        let tris = flat.triangles.clone();
        let pos: Vec<DVec3> = tris
            .iter()
            .flat_map(|t| t.map(|v| flat.positions[v as usize]))
            .collect();
        flat.normals = tris
            .iter()
            .flat_map(|t| {
                let [a, b, c] = t.map(|v| flat.positions[v as usize]);
                [(b - a).cross(c - a).normalize(); 3]
            })
            .collect();
        flat.triangles = (0..tris.len() as u32)
            .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
            .collect();
        flat.positions = pos;
        let surface = flat.welded().0;
        assert!(hard_edges(&flat, &surface).is_empty());
    }
}
