//! glTF `TANGENT` for meshes with a normal map: generated on the written
//! surface with MikkTSpace (through `bevy_mikktspace`), the tangent basis
//! that glTF prescribes and that bakers use, so a normal map keeps reading
//! the same after the remesh. Tangents are never transferred from the
//! input: the surface under them is new.
//!
//! MikkTSpace gives one tangent per face corner. A vertex whose corners get
//! different tangents (a mirrored UV island meeting its twin, a degenerate
//! UV spot) is split, one copy per distinct tangent, like any other corner
//! attribute.

use bevy_mikktspace::{Geometry, TangentSpace};
use glam::DVec3;

use crate::TriMesh;

/// Whether `mesh` should carry tangents: its input had `TANGENT`, or one of
/// its materials has a normal texture. Either way it needs normals and a
/// first texture coordinate set to define them.
pub(crate) fn wanted(mesh: &TriMesh) -> bool {
    let normal_map = mesh.labels.iter().any(|l| {
        l.material
            .as_ref()
            .and_then(|m| m.gltf.as_ref())
            .is_some_and(|g| g.get("normalTexture").is_some())
    });
    (normal_map || mesh.attributes.tangents)
        && mesh.normals.len() == mesh.positions.len()
        && mesh
            .attributes
            .texcoords
            .first()
            .is_some_and(|t| t.len() == mesh.positions.len())
}

/// The MikkTSpace view of a mesh: corners read through the triangles,
/// tangents written per corner.
struct Corners<'a> {
    mesh: &'a TriMesh,
    tangents: Vec<[f32; 4]>,
}

impl Geometry for Corners<'_> {
    fn num_faces(&self) -> usize {
        self.mesh.triangles.len()
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        let p = self.mesh.positions[self.mesh.triangles[face][vert] as usize];
        p.as_vec3().to_array()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        let n = self.mesh.normals[self.mesh.triangles[face][vert] as usize];
        n.normalize_or_zero().as_vec3().to_array()
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.mesh.attributes.texcoords[0][self.mesh.triangles[face][vert] as usize]
    }
    fn set_tangent(&mut self, space: Option<TangentSpace>, face: usize, vert: usize) {
        // A corner MikkTSpace cannot define (zero-area in UV or 3D) gets a
        // tangent perpendicular to its normal, so the basis stays valid.
        let t = space.map(|s| s.tangent_encoded()).unwrap_or_else(|| {
            let n = DVec3::from_array(self.normal(face, vert).map(f64::from));
            let t = n.any_orthonormal_vector();
            [t.x as f32, t.y as f32, t.z as f32, 1.0]
        });
        self.tangents[3 * face + vert] = t;
    }
}

/// `mesh` with one MikkTSpace tangent per vertex, splitting vertices whose
/// corners disagree: the new mesh (copies appended after the original
/// vertices) and its tangents (xyz unit, w = ±1, the bitangent's sign).
pub(crate) fn with_tangents(mesh: &TriMesh) -> (TriMesh, Vec<[f32; 4]>) {
    let mut corners = Corners {
        mesh,
        tangents: vec![[0.0; 4]; 3 * mesh.triangles.len()],
    };
    // The error type has no values: generation always completes.
    let _ = bevy_mikktspace::generate_tangents(&mut corners);
    let per_corner = corners.tangents;

    // Per vertex, the distinct tangents of its corners; the first keeps
    // the vertex's index, further ones become copies at the end.
    let nv = mesh.positions.len();
    let mut first: Vec<Option<[f32; 4]>> = vec![None; nv];
    let mut copies: Vec<(u32, [f32; 4])> = Vec::new();
    let mut triangles = mesh.triangles.clone();
    let same =
        |a: &[f32; 4], b: &[f32; 4]| a[3] == b[3] && (0..3).all(|k| (a[k] - b[k]).abs() <= 1e-4);
    for (f, t) in triangles.iter_mut().enumerate() {
        for (k, v) in t.iter_mut().enumerate() {
            let tan = per_corner[3 * f + k];
            let slot = &mut first[*v as usize];
            match slot {
                None => *slot = Some(tan),
                Some(prev) if same(prev, &tan) => {}
                Some(_) => {
                    let found = copies.iter().position(|(o, c)| *o == *v && same(c, &tan));
                    let i = found.unwrap_or_else(|| {
                        copies.push((*v, tan));
                        copies.len() - 1
                    });
                    *v = (nv + i) as u32;
                }
            }
        }
    }
    let mut origin: Vec<u32> = (0..nv as u32).collect();
    origin.extend(copies.iter().map(|(o, _)| *o));
    let mut tangents: Vec<[f32; 4]> = first
        .iter()
        .map(|t| t.unwrap_or([1.0, 0.0, 0.0, 1.0]))
        .collect();
    tangents.extend(copies.iter().map(|(_, t)| *t));
    let out = if copies.is_empty() {
        mesh.clone()
    } else {
        mesh.with_vertices(&origin, triangles, mesh.face_labels.clone())
    };
    (out, tangents)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_planar_grid_gets_the_u_direction() {
        // Two triangles in the xy plane, u along x and v along y: the
        // tangent is +x everywhere, with a consistent sign.
        let mut m = TriMesh::new(
            vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)],
            vec![[0, 1, 2], [1, 3, 2]],
        );
        m.normals = vec![DVec3::Z; 4];
        m.attributes.texcoords = vec![vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]];
        let (out, t) = with_tangents(&m);
        assert_eq!(out.positions.len(), 4);
        for x in &t {
            assert!((x[0] - 1.0).abs() < 1e-5 && x[1].abs() < 1e-5, "{x:?}");
            assert_eq!(x[3], t[0][3]);
        }
    }
}
