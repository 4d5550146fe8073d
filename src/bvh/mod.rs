//! Closest-point queries on a triangle mesh: [`SurfaceIndex`] owns an f64
//! copy of the surface and a binary BVH over its triangles built with
//! obvhs's PLOC builder (Meister & Bittner, "Parallel Locally-Ordered
//! Clustering for Bounding Volume Hierarchy Construction", 2018), and answers
//! "which point of the surface is nearest to p" by branch-and-bound.
//!
//! obvhs only traverses for rays, so the query is ours: a depth-first walk
//! that visits the nearer child first and prunes every node whose box is
//! farther than the best triangle found so far (the classic nearest-neighbour
//! search of Roussopoulos, Kelley & Vincent 1995, applied to boxes of
//! triangles). Leaves are refined exactly in f64 with
//! [`closest_point_on_triangle`] (Ericson 2005, §5.1.5).
//!
//! Node boxes are f32. They are built in a frame centred on the mesh and
//! rounded outward, and the pruning bound carries an explicit margin for the
//! rounding of the query point and of the f32 box distance, so f32 can make
//! the search visit a few more nodes but never prune the triangle that the
//! exhaustive f64 search would return.

mod triangle;

pub use triangle::closest_point_on_triangle;

use glam::{DVec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::leaf_collapser::collapse;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};

use crate::trimesh::TriMesh;

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

/// Largest tree depth served by the fixed-size traversal stack; deeper trees
/// (which only pathological inputs produce) use a heap stack instead.
const STACK_DEPTH: usize = 64;

/// Relative slack on the pruning bound. It covers the f32 rounding of the
/// box-distance computation (a handful of ulps, ~1e-7) with a wide margin;
/// it only makes the search visit nodes that are within 0.001% of the bound.
const REL_SLACK: f64 = 1e-5;

/// Absolute slack on the pruning bound, relative to the size of the frame: it
/// covers f64 rounding in the local frame and in the triangle routine.
const ABS_SLACK: f64 = 1e-10;

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
    /// The tree; leaf ranges index `corners` / `slot_face` ("slots").
    bvh: Bvh2,
    /// Corner positions per slot, in leaf order, so a leaf's triangles are contiguous.
    corners: Vec<[DVec3; 3]>,
    /// Face index per slot.
    slot_face: Vec<u32>,
    /// Slot per face (`u32::MAX` for faces not in the tree).
    face_slot: Vec<u32>,
    /// Origin of the local frame the f32 boxes are expressed in.
    center: DVec3,
    /// Largest norm of a corner in the local frame.
    radius: f64,
    /// Depth of the tree (root = 1); selects the stack.
    depth: usize,
}

impl std::fmt::Debug for SurfaceIndex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SurfaceIndex")
            .field("triangles", &self.triangles.len())
            .field("indexed", &self.slot_face.len())
            .field("nodes", &self.bvh.nodes.len())
            .field("depth", &self.depth)
            .finish()
    }
}

/// One entry of the traversal stack: a node and the lower bound (squared f32
/// box distance) computed when it was pushed.
#[derive(Clone, Copy, Default)]
struct Entry {
    node: u32,
    d2: f32,
}

/// Largest f32 not above `x` (x finite or ±∞).
#[inline]
fn f32_below(x: f64) -> f32 {
    let y = x as f32;
    if (y as f64) <= x {
        y
    } else if y == 0.0 {
        -f32::from_bits(1)
    } else if y > 0.0 {
        f32::from_bits(y.to_bits() - 1)
    } else {
        f32::from_bits(y.to_bits() + 1)
    }
}

/// Smallest f32 not below `x`.
#[inline]
fn f32_above(x: f64) -> f32 {
    -f32_below(-x)
}

/// The running best of one query.
struct Best {
    found: Option<ClosestPoint>,
    /// Squared distance of `found` (∞ when none).
    d2: f64,
    /// f32 pruning threshold: a node whose f32 box distance² exceeds this
    /// cannot contain a triangle closer than `d2`.
    limit: f32,
}

impl SurfaceIndex {
    /// Builds the index over `triangles` (indices into `positions`). An empty
    /// mesh is allowed; its queries return `None`.
    pub fn new(positions: &[DVec3], triangles: &[[u32; 3]]) -> Self {
        let n = positions.len();
        let mut normals = vec![DVec3::ZERO; triangles.len()];
        // Faces that take part in queries: valid indices, finite corners.
        let mut usable: Vec<u32> = Vec::with_capacity(triangles.len());
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for (f, t) in triangles.iter().enumerate() {
            if t.iter().any(|&v| v as usize >= n) {
                continue;
            }
            let c = [
                positions[t[0] as usize],
                positions[t[1] as usize],
                positions[t[2] as usize],
            ];
            if !c.iter().all(|p| p.is_finite()) {
                continue;
            }
            for p in c {
                lo = lo.min(p);
                hi = hi.max(p);
            }
            normals[f] = crate::geometry::triangle_normal(c);
            usable.push(f as u32);
        }
        let center = if usable.is_empty() {
            DVec3::ZERO
        } else {
            (lo + hi) * 0.5
        };

        // Boxes in the local frame, rounded outward so that each contains its
        // f64 triangle exactly.
        let mut radius: f64 = 0.0;
        let boxes: Vec<Aabb> = usable
            .iter()
            .map(|&f| {
                let t = triangles[f as usize];
                let mut bmin = Vec3A::splat(f32::INFINITY);
                let mut bmax = Vec3A::splat(f32::NEG_INFINITY);
                for &v in &t {
                    let l = positions[v as usize] - center;
                    radius = radius.max(l.length());
                    let down = Vec3A::new(f32_below(l.x), f32_below(l.y), f32_below(l.z));
                    let up = Vec3A::new(f32_above(l.x), f32_above(l.y), f32_above(l.z));
                    bmin = bmin.min(down);
                    bmax = bmax.max(up);
                }
                Aabb::new(bmin, bmax)
            })
            .collect();

        let bvh = build_tree(&boxes);
        drop(boxes);

        let mut corners = Vec::with_capacity(bvh.primitive_indices.len());
        let mut slot_face = Vec::with_capacity(bvh.primitive_indices.len());
        let mut face_slot = vec![u32::MAX; triangles.len()];
        for (slot, &prim) in bvh.primitive_indices.iter().enumerate() {
            let f = usable[prim as usize];
            let t = triangles[f as usize];
            corners.push([
                positions[t[0] as usize],
                positions[t[1] as usize],
                positions[t[2] as usize],
            ]);
            slot_face.push(f);
            face_slot[f as usize] = slot as u32;
        }
        let depth = tree_depth(&bvh);

        Self {
            positions: positions.to_vec(),
            triangles: triangles.to_vec(),
            normals,
            bvh,
            corners,
            slot_face,
            face_slot,
            center,
            radius,
            depth,
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

    /// Refines face `face` at `slot` against the current best.
    #[inline(always)]
    fn test_slot(&self, p: DVec3, slot: usize, best: &mut Best, pad: f64) {
        let [a, b, c] = self.corners[slot];
        let (q, bary) = closest_point_on_triangle(p, a, b, c);
        let d2 = (p - q).length_squared();
        if d2 < best.d2 {
            best.d2 = d2;
            best.found = Some(ClosestPoint {
                face: self.slot_face[slot],
                point: q,
                barycentric: bary,
                distance_squared: d2,
            });
            let r = d2.sqrt() + pad;
            best.limit = f32_above(r * r * (1.0 + REL_SLACK));
        }
    }

    #[inline]
    fn search(
        &self,
        p: DVec3,
        hint: Option<u32>,
        accept: impl Fn(u32) -> bool,
    ) -> Option<ClosestPoint> {
        if self.bvh.nodes.is_empty() || !p.is_finite() {
            return None;
        }
        let local = p - self.center;
        let q = Vec3A::new(local.x as f32, local.y as f32, local.z as f32);
        // Distance a box must be allowed to exceed the best distance by: the
        // rounding of p to f32 (exact in f64) plus f64 rounding in the frame.
        let pad = (local - q.as_dvec3()).length()
            + ABS_SLACK * (self.radius + local.length())
            + f64::MIN_POSITIVE;
        let mut best = Best {
            found: None,
            d2: f64::INFINITY,
            limit: f32::INFINITY,
        };
        if let Some(h) = hint {
            if let Some(&slot) = self.face_slot.get(h as usize) {
                if slot != u32::MAX && accept(h) {
                    self.test_slot(p, slot as usize, &mut best, pad);
                }
            }
        }
        if self.depth < STACK_DEPTH {
            let mut stack = [Entry::default(); STACK_DEPTH];
            self.traverse(p, q, &mut stack, &mut best, pad, &accept);
        } else {
            let mut stack = vec![Entry::default(); self.depth + 1];
            self.traverse(p, q, &mut stack, &mut best, pad, &accept);
        }
        best.found
    }

    /// Branch-and-bound over the tree. `stack` must hold depth + 1 entries:
    /// each pop pushes at most two children, one of which is popped next.
    #[inline(always)]
    fn traverse(
        &self,
        p: DVec3,
        q: Vec3A,
        stack: &mut [Entry],
        best: &mut Best,
        pad: f64,
        accept: &impl Fn(u32) -> bool,
    ) {
        let nodes = &self.bvh.nodes;
        stack[0] = Entry {
            node: 0,
            d2: box_distance2(nodes[0].aabb(), q),
        };
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let Entry { node, d2 } = stack[sp];
            if d2 > best.limit {
                continue;
            }
            let node = &nodes[node as usize];
            if node.prim_count > 0 {
                let first = node.first_index as usize;
                for slot in first..first + node.prim_count as usize {
                    if accept(self.slot_face[slot]) {
                        self.test_slot(p, slot, best, pad);
                    }
                }
            } else {
                let l = node.first_index;
                let r = l + 1;
                let dl = box_distance2(nodes[l as usize].aabb(), q);
                let dr = box_distance2(nodes[r as usize].aabb(), q);
                let (near, dn, far, df) = if dl <= dr {
                    (l, dl, r, dr)
                } else {
                    (r, dr, l, dl)
                };
                if df <= best.limit {
                    stack[sp] = Entry { node: far, d2: df };
                    sp += 1;
                }
                if dn <= best.limit {
                    stack[sp] = Entry { node: near, d2: dn };
                    sp += 1;
                }
            }
        }
    }
}

/// Squared distance from `q` to box `b` in f32 (0 inside).
#[inline(always)]
fn box_distance2(b: &Aabb, q: Vec3A) -> f32 {
    let d = (b.min - q).max(q - b.max).max(Vec3A::ZERO);
    d.dot(d)
}

/// PLOC build, SAH reinsertion and leaf collapsing, as obvhs's
/// `build_bvh2` does, with settings tuned for closest-point queries: small
/// leaves, since a triangle test in f64 costs a few box tests.
fn build_tree(boxes: &[Aabb]) -> Bvh2 {
    let indices: Vec<u32> = (0..boxes.len() as u32).collect();
    let mut bvh = PlocBuilder::with_capacity(boxes.len()).build(
        PlocSearchDistance::Low,
        boxes,
        indices,
        SortPrecision::U64,
        2,
    );
    let mut reinsertion = ReinsertionOptimizer::default();
    reinsertion.run(&mut bvh, 0.02, None);
    collapse(&mut bvh, 4, 1.0);
    bvh
}

/// Depth of the tree (number of nodes on the longest root-to-leaf path).
fn tree_depth(bvh: &Bvh2) -> usize {
    if bvh.nodes.is_empty() {
        return 0;
    }
    let mut max_depth = 0;
    let mut todo = vec![(0usize, 1usize)];
    while let Some((n, d)) = todo.pop() {
        max_depth = max_depth.max(d);
        let node = &bvh.nodes[n];
        if node.prim_count == 0 {
            let l = node.first_index as usize;
            todo.push((l, d + 1));
            todo.push((l + 1, d + 1));
        }
    }
    max_depth
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outward_rounding_brackets_the_value() {
        for x in [
            0.1f64,
            -0.1,
            1e-50,
            -1e-50,
            0.0,
            1e39,
            -1e39,
            3.0,
            std::f64::consts::PI * 1e6,
        ] {
            let lo = f32_below(x);
            let hi = f32_above(x);
            assert!((lo as f64) <= x && x <= (hi as f64), "{x}: {lo} {hi}");
        }
        assert_eq!(f32_below(3.0), 3.0);
        assert_eq!(f32_above(3.0), 3.0);
    }

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
