//! Split vertex normals for rendering: one normal per smooth fan of faces
//! around a vertex, so that creases render sharp while smooth regions stay
//! smooth. Fan normals are angle-weighted averages of face normals (Thürmer
//! & Wüthrich 1998, "Computing vertex normals from polygonal facets").
//!
//! Fans are found with a union-find over face corners: across every interior
//! edge that is smooth (exactly two faces, consistently oriented, dihedral
//! angle at most the crease angle, same label, not listed as sharp) the two
//! faces' corners at each end are joined. Twins are found through a
//! per-vertex list of outgoing edges, so the cost is linear in the corners
//! times the valence, without sorting. Each resulting class is one output
//! vertex. Boundary and non-manifold edges always separate fans. The input
//! is expected to share vertices (welded); an unwelded soup gets flat
//! shading, because no edge is interior.

use crate::topology::corner_fans;
use std::collections::HashSet;

use glam::DVec3;
use rayon::prelude::*;

use crate::geometry::{triangle_angles, triangle_cross};
use crate::topology::edge_key;
use crate::TriMesh;

/// Returns a copy of `mesh` whose vertices are duplicated per smooth fan and
/// whose `normals` hold one unit normal per vertex.
///
/// Fans are separated by edges whose dihedral angle exceeds
/// `crease_angle_deg`, by `extra_sharp_edges` (vertex pairs, either order),
/// by label changes and by boundary or non-manifold edges. The first fan of
/// each input vertex keeps the vertex's index, so `positions[..n]` equals
/// the input's; extra copies are appended. Triangles, face order, labels and
/// face labels are preserved, and each copy carries its vertex's texture
/// coordinates and colour. Unreferenced vertices are kept with a zero
/// normal. Any normals already on `mesh` are replaced.
///
/// # Panics
///
/// When `mesh` breaks [`TriMesh::check`] (an index out of range) or has more
/// than (2^32 - 1) / 3 triangles (corner ids are u32).
pub fn with_split_normals(
    mesh: &TriMesh,
    crease_angle_deg: f64,
    extra_sharp_edges: &[[u32; 2]],
) -> TriMesh {
    let tris = &mesh.triangles;
    let nf = tris.len();
    let corners = nf * 3;
    let n = mesh.positions.len();
    assert!(
        corners < u32::MAX as usize,
        "with_split_normals: more than 1.4 billion triangles"
    );

    // Twice-area vectors (for the degenerate fallback), unit normals and
    // corner angles, one entry per face.
    let per_face: Vec<(DVec3, DVec3, [f64; 3])> = tris
        .par_iter()
        .map(|t| {
            let p = mesh.corner_positions(t);
            let c = triangle_cross(p);
            (c, c.normalize_or_zero(), triangle_angles(p))
        })
        .collect();

    let sharp: HashSet<u64> = extra_sharp_edges
        .iter()
        .map(|&[a, b]| edge_key(a, b))
        .collect();
    let cos_crease = crease_angle_deg.to_radians().cos();
    // Corners are joined across smooth interior edges: not marked sharp,
    // between faces of one label, and bending less than the crease angle.
    let mut fans = corner_fans(tris, n, |a, b, run| {
        let [(_, h0), (_, h1)] = *run else {
            return false;
        };
        let (f1, f2) = ((h0 / 3) as usize, (h1 / 3) as usize);
        if sharp.contains(&edge_key(a, b)) || mesh.face_label(f1) != mesh.face_label(f2) {
            return false;
        }
        let (n1, n2) = (per_face[f1].1, per_face[f2].1);
        // A degenerate face has no normal to compare; it contributes no
        // weight either, so joining across it is harmless.
        n1 == DVec3::ZERO || n2 == DVec3::ZERO || n1.dot(n2) >= cos_crease
    });

    // Number the classes: the first class met at a vertex keeps its index.
    let mut class_vertex = vec![u32::MAX; corners];
    let mut taken = vec![false; n];
    let mut positions = mesh.positions.clone();
    // For each vertex of the result, the vertex of `mesh` it copies.
    let mut origin: Vec<u32> = (0..n as u32).collect();
    for c in 0..corners {
        let r = fans.find(c as u32) as usize;
        if class_vertex[r] != u32::MAX {
            continue;
        }
        let v = tris[c / 3][c % 3];
        if taken[v as usize] {
            class_vertex[r] = positions.len() as u32;
            positions.push(mesh.positions[v as usize]);
            origin.push(v);
        } else {
            taken[v as usize] = true;
            class_vertex[r] = v;
        }
    }
    let mut angle_sum = vec![DVec3::ZERO; positions.len()];
    let mut area_sum = vec![DVec3::ZERO; positions.len()];
    let mut triangles = Vec::with_capacity(nf);
    for (f, (cross, unit, angles)) in per_face.iter().enumerate() {
        let mut t = [0u32; 3];
        for (k, slot) in t.iter_mut().enumerate() {
            let r = fans.find((3 * f + k) as u32) as usize;
            let v = class_vertex[r];
            *slot = v;
            angle_sum[v as usize] += angles[k] * *unit;
            area_sum[v as usize] += *cross;
        }
        triangles.push(t);
    }
    let normals = angle_sum
        .iter()
        .zip(&area_sum)
        .enumerate()
        .map(|(v, (a, s))| {
            a.try_normalize()
                .or_else(|| s.try_normalize())
                .unwrap_or(if v < n && !taken[v] {
                    DVec3::ZERO
                } else {
                    DVec3::Z
                })
        })
        .collect();
    TriMesh {
        positions,
        triangles,
        normals,
        face_labels: mesh.face_labels.clone(),
        labels: mesh.labels.clone(),
        attributes: if mesh.attributes.is_empty() && !mesh.attributes.tangents {
            Default::default()
        } else {
            let mut a = mesh.attributes.select(&origin);
            a.dropped = mesh.attributes.dropped.clone();
            a
        },
        appearance: mesh.appearance.clone(),
        scene: mesh.scene.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    #[test]
    fn cube_corners_split_into_three_fans() {
        let cube = shapes::cube(2, DVec3::splat(-0.5), DVec3::splat(0.5));
        let out = with_split_normals(&cube, 30.0, &[]);
        assert_eq!(out.triangles.len(), cube.triangles.len());
        // Each face of the cube gets its own copy of its corner vertices.
        let count = |m: &TriMesh, pred: &dyn Fn(&DVec3) -> bool| {
            m.positions.iter().filter(|p| pred(p)).count()
        };
        let corner = |p: &DVec3| p.abs().cmpeq(DVec3::splat(0.5)).all();
        let face_centre = |p: &DVec3| p.abs().cmpeq(DVec3::ZERO).bitmask().count_ones() == 2;
        assert_eq!(count(&cube, &corner), 8);
        assert_eq!(count(&out, &corner), 24);
        // Face centres lie inside one flat side: never split.
        assert_eq!(count(&out, &face_centre), 6);
        assert_eq!(count(&cube, &face_centre), 6);
        // Every normal is the axis normal of the side it belongs to.
        for t in &out.triangles {
            let fnrm = crate::geometry::triangle_normal(out.corner_positions(t));
            for &v in t {
                assert!((out.normals[v as usize] - fnrm).length() < 1e-9);
            }
        }
        assert_eq!(&out.positions[..cube.positions.len()], &cube.positions[..]);
    }

    #[test]
    fn smooth_sphere_is_not_split_but_a_sharp_edge_list_splits_it() {
        let s = shapes::icosphere(2);
        let out = with_split_normals(&s, 45.0, &[]);
        assert_eq!(out.positions.len(), s.positions.len());
        for (p, nrm) in out.positions.iter().zip(&out.normals) {
            assert!(p.normalize().dot(*nrm) > 0.99);
        }
        // Mark a closed loop of edges (all edges of one triangle) as sharp:
        // its three vertices each split into two fans.
        let t = s.triangles[0];
        let sharp = [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]];
        let out = with_split_normals(&s, 45.0, &sharp);
        assert_eq!(out.positions.len(), s.positions.len() + 3);
        // The isolated triangle's corners are flat-shaded.
        let fnrm = crate::geometry::triangle_normal(out.corner_positions(&out.triangles[0]));
        for &v in &out.triangles[0] {
            assert!((out.normals[v as usize] - fnrm).length() < 1e-12);
        }
    }

    #[test]
    fn label_change_splits_and_labels_are_kept() {
        let mut g = shapes::grid(1.0, 4);
        let half = g.triangles.len() / 2;
        g.face_labels = (0..g.triangles.len())
            .map(|f| u32::from(f >= half))
            .collect();
        g.labels = vec![Default::default(), Default::default()];
        let plain = with_split_normals(
            &TriMesh::new(g.positions.clone(), g.triangles.clone()),
            30.0,
            &[],
        );
        assert_eq!(plain.positions.len(), g.positions.len());
        let out = with_split_normals(&g, 30.0, &[]);
        assert!(out.positions.len() > g.positions.len());
        assert_eq!(out.face_labels, g.face_labels);
        assert_eq!(out.labels, g.labels);
        out.check().unwrap();
    }
}
