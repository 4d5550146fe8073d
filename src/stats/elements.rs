//! Per-element quality, for writing beside the geometry (the
//! `quality_attributes` option): each face's smallest angle and the ratio
//! of its edge lengths to the local target, and each vertex's valence, so
//! that a viewer can colour the mesh by them. The figures are those of the
//! statistics: valence counts the distinct edges of the welded mesh (copies
//! of a vertex split for normals share it), the target is the one the
//! `edge_length` section measures against.

use rayon::prelude::*;

use super::topology::EdgeCounts;
use crate::geometry::triangle_angles;
use crate::trimesh::{weld_positions, TriMesh};

/// Per-face and per-vertex quality of one mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementQuality {
    /// Per triangle: its smallest interior angle, degrees (60 is ideal).
    pub face_min_angle: Vec<f32>,
    /// Per triangle: the mean of its three edge lengths over the mean
    /// target of its three corners (1 is ideal; the band is [0.8, 4/3]).
    pub face_edge_ratio: Vec<f32>,
    /// Per position: the valence of its welded vertex (6 is ideal inside,
    /// 4 on the boundary).
    pub vertex_valence: Vec<f32>,
}

/// The quality of every face and vertex of `mesh`. The target at each
/// position is `targets[i]` when `targets` has one entry per position,
/// otherwise `target` everywhere.
pub fn element_quality(mesh: &TriMesh, target: f64, targets: Option<&[f64]>) -> ElementQuality {
    let pos = &mesh.positions;
    let targets = targets.filter(|t| t.len() == pos.len());
    let at = |v: u32| targets.map_or(target, |t| t[v as usize]);
    let (face_min_angle, face_edge_ratio): (Vec<f32>, Vec<f32>) = mesh
        .triangles
        .par_iter()
        .map(|t| {
            let p = mesh.corner_positions(t);
            let angles = triangle_angles(p);
            let min = angles[0].min(angles[1]).min(angles[2]).to_degrees();
            let mean_len =
                ((p[1] - p[0]).length() + (p[2] - p[1]).length() + (p[0] - p[2]).length()) / 3.0;
            let local = (at(t[0]) + at(t[1]) + at(t[2])) / 3.0;
            (min as f32, (mean_len / local) as f32)
        })
        .unzip();

    // Valence on the welded mesh, without index-degenerate faces.
    let (weld, welded) = weld_positions(pos);
    let tris: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|v| weld[v as usize]))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
        .collect();
    let table = EdgeCounts::new(&tris, welded.len());
    let mut valence = vec![0u32; welded.len()];
    for e in &table.edges {
        valence[e.a as usize] += 1;
        valence[e.b as usize] += 1;
    }
    ElementQuality {
        face_min_angle,
        face_edge_ratio,
        vertex_valence: weld.iter().map(|&w| valence[w as usize] as f32).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_split_vertex_keeps_its_valence() {
        // Two triangles sharing edge 0-1; vertex 1 appears twice (split).
        let m = TriMesh::new(
            vec![
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                DVec3::X,
                DVec3::new(1.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [2, 3, 4]],
        );
        let q = element_quality(&m, 1.0, None);
        // Welded: 0-1, 1-2, 2-0, 1-4, 4-2 → valences 2, 3, 3, 3, 2.
        assert_eq!(q.vertex_valence, vec![2.0, 3.0, 3.0, 3.0, 2.0]);
        assert!((q.face_min_angle[0] - 45.0).abs() < 1e-4);
        let mean = (2.0 + 2f64.sqrt()) / 3.0;
        assert!((q.face_edge_ratio[0] as f64 - mean).abs() < 1e-6);
        let half = element_quality(&m, 1.0, Some(&[2.0; 5]));
        assert!((half.face_edge_ratio[0] as f64 - mean / 2.0).abs() < 1e-6);
    }
}
