//! Building a half-edge mesh from indexed triangles, with repair.

use serde::{Deserialize, Serialize};

/// What the builder repaired while turning indexed triangles into a valid
/// half-edge mesh. Every field is a count; all zero means the input was clean.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RepairReport {
    /// Vertices merged into another vertex at the same position.
    pub welded_vertices: u64,
    /// Vertices referenced by no face, removed.
    pub unreferenced_vertices: u64,
    /// Faces dropped because two corners were the same vertex or the area was zero.
    pub degenerate_faces: u64,
    /// Faces dropped because another face had the same three vertices.
    pub duplicate_faces: u64,
    /// Edges shared by three or more faces, cut into boundary edges.
    pub non_manifold_edges: u64,
    /// Vertices where separate fans met, split into one vertex per fan.
    pub non_manifold_vertices: u64,
    /// Faces whose orientation was reversed to agree with their component.
    pub flipped_faces: u64,
    /// Connected components that cannot be oriented consistently (Möbius-like).
    pub non_orientable_components: u64,
    /// Non-triangle primitives (points, lines) in the input that were ignored.
    pub ignored_primitives: u64,
}
