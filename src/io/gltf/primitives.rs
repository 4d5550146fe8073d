//! One compact vertex range per primitive: the written mesh reordered so
//! that the vertices each label's faces use are contiguous, a vertex on a
//! material border copied into every label that uses it. Each primitive's
//! accessors then cover exactly its own vertices, so a renderer's bounds,
//! culling and picking per primitive are right and an importer that copies
//! a primitive's vertices copies only those.

use std::ops::Range;

use crate::io::Attribute;
use crate::TriMesh;

/// The mesh regrouped by label, with what goes along with its vertices.
pub(super) struct ByLabel {
    /// The regrouped mesh: faces in label order, vertices per label.
    pub mesh: TriMesh,
    /// Per-vertex extra attributes, in the new vertex order.
    pub extra: Vec<Attribute>,
    /// Tangents in the new vertex order, if any.
    pub tangents: Option<Vec<[f32; 4]>>,
    /// Per label: its vertex range and its face range in `mesh`.
    pub ranges: Vec<(Range<usize>, Range<usize>)>,
}

/// Regroups `mesh` (and its per-vertex `extra` and `tangents`) by label.
pub(super) fn by_label(
    mesh: &TriMesh,
    extra: &[Attribute],
    tangents: Option<&[[f32; 4]]>,
) -> ByLabel {
    let nl = mesh.label_count();
    let mut faces_of: Vec<Vec<u32>> = vec![Vec::new(); nl];
    for f in 0..mesh.triangles.len() {
        faces_of[mesh.face_label(f) as usize].push(f as u32);
    }
    let mut origin: Vec<u32> = Vec::with_capacity(mesh.positions.len());
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(mesh.triangles.len());
    let mut face_labels: Vec<u32> = Vec::with_capacity(mesh.triangles.len());
    let mut ranges = Vec::with_capacity(nl);
    // The new index of each old vertex within the label being written.
    let mut local = vec![u32::MAX; mesh.positions.len()];
    for (l, faces) in faces_of.iter().enumerate() {
        let (v0, f0) = (origin.len(), triangles.len());
        for &f in faces {
            let t = mesh.triangles[f as usize].map(|v| {
                let slot = &mut local[v as usize];
                if *slot == u32::MAX || (*slot as usize) < v0 {
                    *slot = origin.len() as u32;
                    origin.push(v);
                }
                *slot
            });
            triangles.push(t);
            face_labels.push(l as u32);
        }
        ranges.push((v0..origin.len(), f0..triangles.len()));
    }
    let pick = |values: &[f32]| origin.iter().map(|&o| values[o as usize]).collect();
    ByLabel {
        mesh: mesh.with_vertices(
            &origin,
            triangles,
            if mesh.face_labels.is_empty() {
                Vec::new()
            } else {
                face_labels
            },
        ),
        extra: extra
            .iter()
            .map(|a| Attribute {
                name: a.name.clone(),
                values: pick(&a.values),
            })
            .collect(),
        tangents: tangents.map(|t| origin.iter().map(|&o| t[o as usize]).collect()),
        ranges,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_border_vertex_is_copied_into_each_label() {
        // Two triangles sharing the edge 1-2, with different labels.
        let mut m = TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)],
            vec![[0, 1, 2], [1, 3, 2]],
        );
        m.face_labels = vec![1, 0];
        m.labels = vec![Default::default(), Default::default()];
        let b = by_label(&m, &[], None);
        assert_eq!(b.ranges, [(0..3, 0..1), (3..6, 1..2)]);
        assert_eq!(b.mesh.triangles, [[0, 1, 2], [3, 4, 5]]);
        assert_eq!(b.mesh.positions[0], DVec3::X);
        assert_eq!(b.mesh.face_labels, [0, 1]);
    }
}
