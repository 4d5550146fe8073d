//! The indexed triangle mesh: the plain exchange type between the format
//! readers and writers (`io`), the half-edge builder (`mesh::build`), the
//! statistics (`stats`) and the spatial index (`bvh`).
//!
//! A [`TriMesh`] is a triangle soup with shared vertices: positions, triangles
//! as index triples, an optional per-vertex normal, and a per-face label that
//! says which glTF primitive, material or OBJ group the face came from. It has
//! no connectivity; [`crate::mesh::Mesh`] adds that.

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::appearance::{Appearance, VertexAttributes};
use crate::scene::Scene;

/// The weld key of a position: its coordinates' bit patterns with −0 folded
/// into +0, so that exactly equal positions, and only those, share a key.
#[inline]
pub(crate) fn position_key(p: DVec3) -> [u64; 3] {
    [p.x, p.y, p.z].map(|c| (c + 0.0).to_bits())
}

/// Welds bit-identical positions (−0 equals +0): for each input position the
/// index of its welded vertex, and the welded positions in coordinate order.
pub(crate) fn weld_positions(positions: &[DVec3]) -> (Vec<u32>, Vec<DVec3>) {
    // Sorting (key, id) records directly keeps the sort cache-friendly.
    let mut order: Vec<([u64; 3], u32)> = positions
        .par_iter()
        .enumerate()
        .map(|(i, &p)| (position_key(p), i as u32))
        .collect();
    order.par_sort_unstable();
    let mut weld = vec![0u32; positions.len()];
    let mut welded: Vec<DVec3> = Vec::with_capacity(positions.len());
    for k in 0..order.len() {
        let (key, i) = order[k];
        if k == 0 || key != order[k - 1].0 {
            welded.push(positions[i as usize]);
        }
        weld[i as usize] = (welded.len() - 1) as u32;
    }
    (weld, welded)
}

/// For each triangle, whether it is the first with its set of vertices
/// (later ones repeat a face, whatever their orientation), and how many
/// repeats there are.
pub(crate) fn first_occurrences(tris: &[[u32; 3]]) -> (Vec<bool>, usize) {
    let mut by_key: Vec<(u128, u32)> = tris
        .par_iter()
        .enumerate()
        .map(|(f, t)| {
            let mut t = *t;
            t.sort_unstable();
            (
                ((t[0] as u128) << 64) | ((t[1] as u128) << 32) | t[2] as u128,
                f as u32,
            )
        })
        .collect();
    // (key, face) pairs: equal keys come in face order, so the first is kept.
    by_key.par_sort_unstable();
    let mut keep = vec![true; tris.len()];
    let mut repeats = 0;
    for w in by_key.windows(2) {
        if w[0].0 == w[1].0 {
            keep[w[1].1 as usize] = false;
            repeats += 1;
        }
    }
    (keep, repeats)
}

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
    /// The material object as a glTF document writes it, texture
    /// references included (their indices point into the mesh's
    /// [`crate::appearance::Appearance`]), when the source had textures or
    /// extensions that the factors above do not carry. Writers emit it
    /// verbatim in place of the factors.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gltf: Option<serde_json::Value>,
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
            gltf: None,
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
    /// The part of the mesh's [`crate::scene::Scene`] the faces belong to
    /// (a glTF mesh, an OBJ object or group), when the input had parts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part: Option<u32>,
    /// How many of the mesh's texture coordinate sets these faces really
    /// carry, when fewer than the mesh has (a glTF primitive without
    /// `TEXCOORD_0` in a scene whose other primitives have one): the
    /// readers pad the missing sets with zeros so that every vertex has a
    /// value, and the writers leave them out again. `None`: all of them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texcoord_sets: Option<u32>,
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
    /// Per-vertex texture coordinates and colours (empty when absent).
    pub attributes: VertexAttributes,
    /// The textures and images that the labels' materials use, shared
    /// between the copies of a mesh that a job makes.
    pub appearance: Option<Arc<Appearance>>,
    /// The parts and node hierarchy the mesh came from, shared like the
    /// appearance; `None` for a mesh of one anonymous part.
    pub scene: Option<Arc<Scene>>,
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

    /// The part of the mesh's scene that label `l`'s faces belong to: the
    /// label's own, or the only part; `None` without a scene, or for a
    /// label of no part.
    pub fn label_part(&self, l: usize) -> Option<usize> {
        let scene = self.scene.as_deref()?;
        self.labels
            .get(l)
            .and_then(|lab| lab.part)
            .map(|p| p as usize)
            .filter(|&p| p < scene.parts.len())
            .or((scene.parts.len() == 1).then_some(0))
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

    /// A mesh over copies of this mesh's vertices: vertex `i` of the result
    /// copies vertex `origin[i]` (position, normal, texture coordinates,
    /// colour), `triangles` index the result and `face_labels` label them
    /// (pass them empty when this mesh has none). Labels and appearance are
    /// shared. The writers use it to split vertices per corner, per
    /// tangent or per primitive.
    pub(crate) fn with_vertices(
        &self,
        origin: &[u32],
        triangles: Vec<[u32; 3]>,
        face_labels: Vec<u32>,
    ) -> TriMesh {
        let pick = |v: &[DVec3]| -> Vec<DVec3> {
            if v.is_empty() {
                Vec::new()
            } else {
                origin.iter().map(|&o| v[o as usize]).collect()
            }
        };
        let mut attributes = self.attributes.select(origin);
        attributes.dropped = self.attributes.dropped.clone();
        TriMesh {
            positions: pick(&self.positions),
            triangles,
            normals: pick(&self.normals),
            face_labels,
            labels: self.labels.clone(),
            attributes,
            appearance: self.appearance.clone(),
            scene: self.scene.clone(),
        }
    }

    /// The mesh as the benchmark's `meshload.py` canonicalises it, which is
    /// the mesh the statistics describe: bit-identical positions merged,
    /// faces with an out-of-range or repeated vertex and repeats of an
    /// earlier face dropped, unreferenced vertices dropped. Faces keep their
    /// order and their corner order (so area samples drawn over them are
    /// the benchmark's). Also returns, for each vertex of the result, the
    /// first input vertex welded into it.
    pub fn welded(&self) -> (TriMesh, Vec<u32>) {
        let n = self.positions.len();
        let (weld, welded) = weld_positions(&self.positions);
        let mut triangles = Vec::with_capacity(self.triangles.len());
        let mut face_labels = Vec::new();
        for (f, t) in self.triangles.iter().enumerate() {
            if t.iter().any(|&v| v as usize >= n) {
                continue;
            }
            let t = t.map(|v| weld[v as usize]);
            if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
                continue;
            }
            triangles.push(t);
            if !self.face_labels.is_empty() {
                face_labels.push(self.face_label(f));
            }
        }
        let (keep, repeats) = first_occurrences(&triangles);
        if repeats > 0 {
            let mut k = 0;
            triangles.retain(|_| {
                k += 1;
                keep[k - 1]
            });
            if !face_labels.is_empty() {
                let mut k = 0;
                face_labels.retain(|_| {
                    k += 1;
                    keep[k - 1]
                });
            }
        }
        // First input vertex of each welded vertex, then compaction in
        // welded order (unreferenced ones dropped).
        let mut origin = vec![u32::MAX; welded.len()];
        for (i, &w) in weld.iter().enumerate() {
            if origin[w as usize] == u32::MAX {
                origin[w as usize] = i as u32;
            }
        }
        let mut used = vec![false; welded.len()];
        for t in &triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let mut remap = vec![u32::MAX; welded.len()];
        let mut positions = Vec::with_capacity(welded.len());
        let mut first = Vec::with_capacity(welded.len());
        for w in 0..welded.len() {
            if used[w] {
                remap[w] = positions.len() as u32;
                positions.push(welded[w]);
                first.push(origin[w]);
            }
        }
        for t in &mut triangles {
            *t = t.map(|v| remap[v as usize]);
        }
        let normals = if self.normals.len() == n {
            first.iter().map(|&i| self.normals[i as usize]).collect()
        } else {
            Vec::new()
        };
        let mesh = TriMesh {
            positions,
            triangles,
            normals,
            face_labels,
            labels: self.labels.clone(),
            ..Default::default()
        };
        (mesh, first)
    }

    /// Reorders the faces into one contiguous block per label, in label
    /// order and, within a label, in their present order. Writers then emit
    /// one group or primitive per label, and whoever reads the file back
    /// sees the faces in this order (OBJ readers regroup faces by material).
    pub fn group_faces_by_label(&mut self) {
        if self.face_labels.len() != self.triangles.len()
            || self.face_labels.windows(2).all(|w| w[0] <= w[1])
        {
            return;
        }
        let mut order: Vec<u32> = (0..self.triangles.len() as u32).collect();
        order.sort_by_key(|&f| self.face_labels[f as usize]);
        self.triangles = order.iter().map(|&f| self.triangles[f as usize]).collect();
        self.face_labels = order
            .iter()
            .map(|&f| self.face_labels[f as usize])
            .collect();
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
        self.attributes.check(n)
    }
}
