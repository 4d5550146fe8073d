//! [`SurfaceIndex`]: closest-point queries on a triangle mesh, the
//! remesher's projection. A client of [`Bvh`]: it owns an f64 copy of the
//! surface, the triangles' corners in slot order, and refines each leaf
//! exactly with [`closest_point_on_triangle`] (Ericson 2005, §5.1.5).
//!
//! Of equally close triangles the first one the walk reaches is kept (the
//! comparison is strict), so answers depend on the tree's layout and visit
//! order; both are deterministic.

use glam::DVec3;
use rayon::prelude::*;

use super::tree::{Bvh, LeafShape};
use super::triangle::closest_point_on_triangle;
use crate::trimesh::TriMesh;

/// Leaves of up to 8 triangles with a node visit costing 2 triangle tests
/// measured fastest for closest-point queries (and halve the node count
/// against one triangle per leaf).
const LEAF: LeafShape = LeafShape {
    max_primitives: 8,
    traversal_cost: 2.0,
};

/// The answer to a closest-point query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    /// Index of the face (in the triangle list given to [`SurfaceIndex::new`]).
    pub face: u32,
    /// The closest point of the surface.
    pub point: DVec3,
    /// Barycentric coordinates of `point`: the weights of the face's corners 0, 1, 2.
    pub barycentric: DVec3,
    /// Squared distance from the query point to `point`.
    pub distance_squared: f64,
}

impl ClosestPoint {
    /// Distance from the query point to `point`.
    #[inline]
    pub fn distance(&self) -> f64 {
        self.distance_squared.sqrt()
    }
}

/// A spatial index for closest-point queries on a triangle mesh.
///
/// Owns copies of the positions and triangles, so it can outlive the mesh it
/// was built from and be shared between threads (`Send + Sync`). Faces whose
/// indices are out of range or whose corners are not finite are kept in the
/// numbering but never returned by a query.
#[derive(Clone)]
pub struct SurfaceIndex {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    /// Unit normal per face (zero for degenerate or unindexed faces).
    normals: Vec<DVec3>,
    /// The tree; its primitives are faces.
    tree: Bvh,
    /// Corner positions per slot, so a leaf's triangles are contiguous.
    corners: Vec<[DVec3; 3]>,
    /// Slot per face (`u32::MAX` for faces not in the tree).
    face_slot: Vec<u32>,
}

impl std::fmt::Debug for SurfaceIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceIndex")
            .field("triangles", &self.triangles.len())
            .field("tree", &self.tree)
            .finish()
    }
}

impl SurfaceIndex {
    /// Builds the index over `triangles` (indices into `positions`). An empty
    /// mesh is allowed; its queries return `None`.
    pub fn new(positions: &[DVec3], triangles: &[[u32; 3]]) -> Self {
        let n = positions.len();
        let corners_of = |t: &[u32; 3]| -> Option<[DVec3; 3]> {
            if t.iter().any(|&v| v as usize >= n) {
                return None;
            }
            Some(t.map(|v| positions[v as usize]))
        };
        let normals: Vec<DVec3> = triangles
            .par_iter()
            .map(|t| {
                corners_of(t)
                    .filter(|c| c.iter().all(|p| p.is_finite()))
                    .map_or(DVec3::ZERO, crate::geometry::triangle_normal)
            })
            .collect();
        let tree = Bvh::new(triangles.len(), |f| corners_of(&triangles[f]), LEAF);
        let corners: Vec<[DVec3; 3]> = tree
            .slot_primitives()
            .par_iter()
            .map(|&f| triangles[f as usize].map(|v| positions[v as usize]))
            .collect();
        let mut face_slot = vec![u32::MAX; triangles.len()];
        for (slot, &f) in tree.slot_primitives().iter().enumerate() {
            face_slot[f as usize] = slot as u32;
        }
        Self {
            positions: positions.to_vec(),
            triangles: triangles.to_vec(),
            normals,
            tree,
            corners,
            face_slot,
        }
    }

    /// Builds the index over the positions and triangles of `m`.
    pub fn from_trimesh(m: &TriMesh) -> Self {
        Self::new(&m.positions, &m.triangles)
    }

    /// Number of triangles given at construction (including any that are
    /// never returned because they were invalid).
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The vertex positions the index was built from.
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// The triangles the index was built from.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Unit normal of face `f` (counter-clockwise); zero for a degenerate or
    /// invalid face and for `f` out of range.
    #[inline]
    pub fn face_normal(&self, f: u32) -> DVec3 {
        self.normals.get(f as usize).copied().unwrap_or(DVec3::ZERO)
    }

    /// The point of the surface closest to `p`. `None` for an empty mesh or a
    /// non-finite `p`.
    #[inline]
    pub fn closest_point(&self, p: DVec3) -> Option<ClosestPoint> {
        self.search(p, None, |_| true)
    }

    /// Same answer as [`closest_point`](Self::closest_point), faster when
    /// face `hint_face` is at or near the answer: its distance bounds the
    /// search from the start, so only nodes nearer than it are visited. An
    /// invalid hint is ignored.
    #[inline]
    pub fn closest_point_with_hint(&self, p: DVec3, hint_face: u32) -> Option<ClosestPoint> {
        self.search(p, Some(hint_face), |_| true)
    }

    /// The closest point among the faces for which `accept(face)` is true
    /// (e.g. one face-label region). `None` when no face is accepted.
    #[inline]
    pub fn closest_point_filtered(
        &self,
        p: DVec3,
        accept: impl Fn(u32) -> bool,
    ) -> Option<ClosestPoint> {
        self.search(p, None, accept)
    }

    /// [`closest_point_filtered`](Self::closest_point_filtered) seeded with a
    /// hint face (ignored unless it passes the filter).
    #[inline]
    pub fn closest_point_with_hint_filtered(
        &self,
        p: DVec3,
        hint_face: u32,
        accept: impl Fn(u32) -> bool,
    ) -> Option<ClosestPoint> {
        self.search(p, Some(hint_face), accept)
    }

    /// The hint's face is tested first so that its distance bounds the walk.
    #[inline]
    fn search(
        &self,
        p: DVec3,
        hint: Option<u32>,
        accept: impl Fn(u32) -> bool,
    ) -> Option<ClosestPoint> {
        if self.tree.is_empty() || !p.is_finite() {
            return None;
        }
        let mut found: Option<ClosestPoint> = None;
        let mut bound = f64::INFINITY;
        if let Some(&slot) = hint.and_then(|h| self.face_slot.get(h as usize)) {
            if slot != u32::MAX {
                let d2 = self.test_slot(p, slot as usize, bound, &mut found, &accept);
                if d2 < bound {
                    bound = d2;
                }
            }
        }
        let test = |slot: usize, best: f64| self.test_slot(p, slot, best, &mut found, &accept);
        self.tree.closest(p, bound, test);
        found
    }

    /// The leaf test: the squared distance from `p` to the face at `slot`
    /// (∞ when `accept` rejects it), recorded in `found` when below `best`,
    /// the distance of `found` (∞ when none). Forced inline: it runs for
    /// every triangle of every leaf opened.
    #[inline(always)]
    fn test_slot(
        &self,
        p: DVec3,
        slot: usize,
        best: f64,
        found: &mut Option<ClosestPoint>,
        accept: &impl Fn(u32) -> bool,
    ) -> f64 {
        let face = self.tree.primitive(slot);
        if !accept(face) {
            return f64::INFINITY;
        }
        let [a, b, c] = self.corners[slot];
        let (q, barycentric) = closest_point_on_triangle(p, a, b, c);
        let d2 = (p - q).length_squared();
        if d2 < best {
            *found = Some(ClosestPoint {
                face,
                point: q,
                barycentric,
                distance_squared: d2,
            });
        }
        d2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_index_answers_none() {
        let idx = SurfaceIndex::new(&[], &[]);
        assert!(idx.closest_point(DVec3::ZERO).is_none());
        assert_eq!(idx.triangle_count(), 0);
        assert_eq!(idx.face_normal(0), DVec3::ZERO);
    }

    #[test]
    fn single_triangle() {
        let pos = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let idx = SurfaceIndex::new(&pos, &[[0, 1, 2]]);
        let cp = idx.closest_point(DVec3::new(0.25, 0.25, 2.0)).unwrap();
        assert_eq!(cp.face, 0);
        assert!((cp.point - DVec3::new(0.25, 0.25, 0.0)).length() < 1e-15);
        assert!((cp.distance_squared - 4.0).abs() < 1e-12);
        assert!((idx.face_normal(0) - DVec3::Z).length() < 1e-15);
    }

    #[test]
    fn invalid_faces_are_skipped() {
        let pos = [
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::new(f64::NAN, 0.0, 0.0),
        ];
        let idx = SurfaceIndex::new(&pos, &[[0, 1, 9], [0, 1, 3], [0, 1, 2]]);
        assert_eq!(idx.triangle_count(), 3);
        let cp = idx.closest_point(DVec3::new(0.1, 0.1, 1.0)).unwrap();
        assert_eq!(cp.face, 2);
        assert!(idx.closest_point(DVec3::new(f64::NAN, 0.0, 0.0)).is_none());
        // A hint naming an invalid face is ignored.
        let cp = idx
            .closest_point_with_hint(DVec3::new(0.1, 0.1, 1.0), 1)
            .unwrap();
        assert_eq!(cp.face, 2);
    }
}
