//! Per-element scalar attributes written beside the geometry (the job
//! option `quality_attributes`): one value per vertex or per face, under a
//! lower-case name.
//!
//! PLY stores them as they are: `property float NAME` on the `vertex` or
//! the `face` element. glTF has per-vertex attributes only, and
//! application-specific ones must start with an underscore, so the glTF
//! writer names them `_NAME` in upper case and gives every face its own
//! three corners: a per-face value then colours exactly its face, and a
//! per-vertex value is copied to each corner of the vertex. Positions stay
//! the same, so a reader that welds coincident vertices (ours does) sees the
//! same surface. OBJ, STL and OFF have no place for them.

use super::{Format, IoError};
use crate::TriMesh;

/// One named scalar per element.
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    /// Lower-case name, `[a-z0-9_]`, e.g. `quality_min_angle`.
    pub name: String,
    /// One value per element.
    pub values: Vec<f32>,
}

/// The extra attributes of a mesh to write.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Attributes {
    /// One value per position.
    pub vertex: Vec<Attribute>,
    /// One value per triangle.
    pub face: Vec<Attribute>,
}

impl Attributes {
    /// No attribute at all.
    pub fn is_empty(&self) -> bool {
        self.vertex.is_empty() && self.face.is_empty()
    }

    /// Fails unless every attribute has one value per element of `mesh`
    /// and a name of `[a-z0-9_]`, and `format` can store them.
    pub(super) fn check(&self, mesh: &TriMesh, format: Format) -> Result<(), IoError> {
        if self.is_empty() {
            return Ok(());
        }
        if !format.stores_attributes() {
            return Err(IoError::unsupported(
                format,
                "per-element attributes need glTF, GLB or PLY output",
            ));
        }
        let lists = [
            (&self.vertex, mesh.positions.len(), "vertex"),
            (&self.face, mesh.triangles.len(), "face"),
        ];
        for (list, n, what) in lists {
            for a in list {
                let named = !a.name.is_empty()
                    && a.name
                        .bytes()
                        .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == b'_');
                if !named || a.values.len() != n {
                    return Err(IoError::InvalidMesh {
                        message: format!(
                            "{what} attribute {:?} has {} values for {n} elements",
                            a.name,
                            a.values.len()
                        ),
                    });
                }
            }
        }
        Ok(())
    }
}

/// The glTF form: every face with its own three corners (positions and
/// normals copied), and every attribute as one value per corner, named
/// `_NAME`.
pub(super) fn per_corner(mesh: &TriMesh, attrs: &Attributes) -> (TriMesh, Vec<Attribute>) {
    let corners: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    let triangles = (0..mesh.triangles.len() as u32)
        .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
        .collect();
    let out = mesh.with_vertices(&corners, triangles, mesh.face_labels.clone());
    let gltf_name = |n: &str| format!("_{}", n.to_ascii_uppercase());
    let mut extra: Vec<Attribute> = attrs
        .vertex
        .iter()
        .map(|a| Attribute {
            name: gltf_name(&a.name),
            values: corners.iter().map(|&v| a.values[v as usize]).collect(),
        })
        .collect();
    extra.extend(attrs.face.iter().map(|a| Attribute {
        name: gltf_name(&a.name),
        values: a.values.iter().flat_map(|&x| [x; 3]).collect(),
    }));
    (out, extra)
}
