//! The indexed triangle mesh: the plain exchange type between the format
//! readers and writers (`io`), the half-edge builder (`mesh::build`), the
//! statistics (`stats`) and the spatial index (`bvh`).
//!
//! A [`TriMesh`] is a triangle soup with shared vertices: positions, triangles
//! as index triples, an optional per-vertex normal, and a per-face label that
//! says which glTF primitive, material or OBJ group the face came from. It has
//! no connectivity; [`crate::mesh::Mesh`] adds that.

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// A material as far as isoremesh carries it: name and the scalar factors of
/// glTF's metallic-roughness model. Textures are not carried.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Material name, if the source had one.
    pub name: Option<String>,
    /// Linear RGBA base colour factor.
    pub base_color_factor: [f32; 4],
    /// Metallic factor in [0, 1].
    pub metallic_factor: f32,
    /// Roughness factor in [0, 1].
    pub roughness_factor: f32,
    /// Linear RGB emissive factor.
    pub emissive_factor: [f32; 3],
    /// Whether back faces are rendered.
    pub double_sided: bool,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: None,
            base_color_factor: [1.0, 1.0, 1.0, 1.0],
            metallic_factor: 1.0,
            roughness_factor: 1.0,
            emissive_factor: [0.0, 0.0, 0.0],
            double_sided: false,
        }
    }
}

/// What a face label stands for: a glTF primitive / material or an OBJ group.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Label {
    /// Human-readable name (mesh/primitive name, material name or OBJ group).
    pub name: Option<String>,
    /// The material the faces with this label use, if any.
    pub material: Option<Material>,
}

/// An indexed triangle mesh with optional per-vertex normals and per-face labels.
///
/// Invariants expected by consumers (checked by [`TriMesh::check`]):
/// every index is `< positions.len()`, `face_labels` is empty or has one entry
/// per triangle, each label index is `< labels.len()`, and `normals` is empty
/// or has one entry per position.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Triangles as counter-clockwise index triples.
    pub triangles: Vec<[u32; 3]>,
    /// Optional per-vertex normals (empty when absent).
    pub normals: Vec<DVec3>,
    /// Per-face label index into `labels` (empty means every face has label 0).
    pub face_labels: Vec<u32>,
    /// The label table. May be empty when `face_labels` is empty.
    pub labels: Vec<Label>,
}

impl TriMesh {
    /// A mesh from positions and triangles, without normals or labels.
    pub fn new(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Self {
        Self {
            positions,
            triangles,
            ..Default::default()
        }
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn face_count(&self) -> usize {
        self.triangles.len()
    }

    /// The label of face `f` (0 when the mesh carries no labels).
    pub fn face_label(&self, f: usize) -> u32 {
        self.face_labels.get(f).copied().unwrap_or(0)
    }

    /// Number of distinct labels (at least 1 for a non-empty mesh).
    pub fn label_count(&self) -> usize {
        self.labels.len().max(1)
    }

    /// Axis-aligned bounding box `(min, max)`; `None` for a mesh without vertices.
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
        )
    }

    /// Length of the bounding-box diagonal (0 for an empty mesh).
    pub fn bbox_diagonal(&self) -> f64 {
        self.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length())
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| crate::geometry::triangle_area(self.corner_positions(t)))
            .sum()
    }

    /// Positions of the three corners of triangle `t`.
    #[inline]
    pub fn corner_positions(&self, t: &[u32; 3]) -> [DVec3; 3] {
        [
            self.positions[t[0] as usize],
            self.positions[t[1] as usize],
            self.positions[t[2] as usize],
        ]
    }

    /// Checks the structural invariants listed on the type.
    pub fn check(&self) -> Result<(), String> {
        let n = self.positions.len();
        if let Some((i, t)) = self
            .triangles
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&v| v as usize >= n))
        {
            return Err(format!(
                "triangle {i} has an index out of range: {t:?} with {n} vertices"
            ));
        }
        if !self.face_labels.is_empty() && self.face_labels.len() != self.triangles.len() {
            return Err("face_labels length differs from the triangle count".into());
        }
        if let Some(l) = self
            .face_labels
            .iter()
            .find(|&&l| l as usize >= self.label_count())
        {
            return Err(format!("face label {l} is out of range"));
        }
        if !self.normals.is_empty() && self.normals.len() != n {
            return Err("normals length differs from the vertex count".into());
        }
        Ok(())
    }
}
