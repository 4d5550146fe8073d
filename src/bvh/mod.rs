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
use rayon::prelude::*;

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
    /// The tree as sibling pairs in depth-first order; pair 0 holds the
    /// root (slot 0). Leaf ranges index `corners` / `slot_face` ("slots").
    pairs: Vec<NodePair>,
    /// Corner positions per slot, in leaf order, so a leaf's triangles are contiguous.
    corners: Vec<[DVec3; 3]>,
    /// Face index per slot.
    slot_face: Vec<u32>,
    /// Slot per face (`u32::MAX` for faces not in the tree).
    face_slot: Vec<u32>,
    /// Origin of the local frame the f32 boxes are expressed in.
    center: DVec3,
    /// Scale of the local frame (a power of two): local = (p − center)·scale.
    scale: f64,
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
            .field("node_pairs", &self.pairs.len())
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
        // Faces that take part in queries: valid indices, finite corners.
        let corners_of = |t: &[u32; 3]| -> Option<[DVec3; 3]> {
            if t.iter().any(|&v| v as usize >= n) {
                return None;
            }
            let c = [
                positions[t[0] as usize],
                positions[t[1] as usize],
                positions[t[2] as usize],
            ];
            c.iter().all(|p| p.is_finite()).then_some(c)
        };
        let normals: Vec<DVec3> = triangles
            .par_iter()
            .map(|t| corners_of(t).map_or(DVec3::ZERO, crate::geometry::triangle_normal))
            .collect();
        let empty = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let (lo, hi) = triangles
            .par_iter()
            .filter_map(corners_of)
            .fold(
                || empty,
                |(lo, hi), c| {
                    (
                        lo.min(c[0].min(c[1]).min(c[2])),
                        hi.max(c[0].max(c[1]).max(c[2])),
                    )
                },
            )
            .reduce(|| empty, |a, b| (a.0.min(b.0), a.1.max(b.1)));
        let center = if lo.x <= hi.x {
            (lo + hi) * 0.5
        } else {
            DVec3::ZERO
        };
        let radius = triangles
            .par_iter()
            .filter_map(corners_of)
            .map(|c| c.iter().map(|p| (*p - center).length()).fold(0.0, f64::max))
            .reduce(|| 0.0, f64::max);
        // A power of two brings the frame to about unit size: exact in f64,
        // and f32 boxes can neither overflow nor lose small meshes to underflow.
        let exponent = if radius > 0.0 {
            radius.log2().ceil().clamp(-1000.0, 1000.0) as i32
        } else {
            0
        };
        let scale = 2f64.powi(-exponent);

        // Boxes in the scaled local frame, rounded outward so that each
        // contains its f64 triangle exactly. A face whose box is not finite
        // (coordinates near the f64 limit) is left out.
        let (usable, boxes): (Vec<u32>, Vec<Aabb>) = triangles
            .par_iter()
            .enumerate()
            .filter_map(|(f, t)| {
                let c = corners_of(t)?;
                let mut bmin = Vec3A::splat(f32::INFINITY);
                let mut bmax = Vec3A::splat(f32::NEG_INFINITY);
                for p in c {
                    let l = (p - center) * scale;
                    bmin = bmin.min(Vec3A::new(f32_below(l.x), f32_below(l.y), f32_below(l.z)));
                    bmax = bmax.max(Vec3A::new(f32_above(l.x), f32_above(l.y), f32_above(l.z)));
                }
                (bmin.is_finite() && bmax.is_finite()).then(|| (f as u32, Aabb::new(bmin, bmax)))
            })
            .unzip();

        let bvh = build_tree(&boxes);
        drop(boxes);
        let (pairs, slot_prim, depth) = flatten(&bvh);
        drop(bvh);

        let slot_face: Vec<u32> = slot_prim.par_iter().map(|&p| usable[p as usize]).collect();
        let corners: Vec<[DVec3; 3]> = slot_face
            .par_iter()
            .map(|&f| {
                let t = triangles[f as usize];
                [
                    positions[t[0] as usize],
                    positions[t[1] as usize],
                    positions[t[2] as usize],
                ]
            })
            .collect();
        let mut face_slot = vec![u32::MAX; triangles.len()];
        for (slot, &f) in slot_face.iter().enumerate() {
            face_slot[f as usize] = slot as u32;
        }

        Self {
            positions: positions.to_vec(),
            triangles: triangles.to_vec(),
            normals,
            pairs,
            corners,
            slot_face,
            face_slot,
            center,
            scale,
            radius: radius * scale,
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
            let r = d2.sqrt() * self.scale + pad;
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
        if self.pairs.is_empty() || !p.is_finite() {
            return None;
        }
        let local = (p - self.center) * self.scale;
        let q = Vec3A::new(local.x as f32, local.y as f32, local.z as f32);
        // Distance (in the local frame) a box must be allowed to exceed the
        // best distance by: the rounding of p to f32 (exact in f64) plus f64
        // rounding in the frame and in the triangle routine.
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
        let pairs = &self.pairs;
        stack[0] = Entry {
            node: 0,
            d2: pairs[0].0[0].distance2(q),
        };
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let Entry { node, d2 } = stack[sp];
            if d2 > best.limit {
                continue;
            }
            let node = &pairs[(node >> 1) as usize].0[(node & 1) as usize];
            if node.count > 0 {
                let first = node.index as usize;
                for slot in first..first + node.count as usize {
                    if accept(self.slot_face[slot]) {
                        self.test_slot(p, slot, best, pad);
                    }
                }
            } else {
                let children = &pairs[node.index as usize].0;
                let dl = children[0].distance2(q);
                let dr = children[1].distance2(q);
                let l = node.index << 1;
                let (near, dn, far, df) = if dl <= dr {
                    (l, dl, l | 1, dr)
                } else {
                    (l | 1, dr, l, dl)
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

/// A tree node in 32 bytes: an f32 box and either a leaf's slot range
/// (`count > 0`) or an inner node's child pair (`count == 0`).
#[derive(Clone, Copy, Default)]
#[repr(C, align(32))]
struct Node {
    min: [f32; 3],
    count: u32,
    max: [f32; 3],
    /// First slot (leaf) or index of the child pair (inner node).
    index: u32,
}

impl Node {
    /// Squared f32 distance from `q` to the box (0 inside).
    #[inline(always)]
    fn distance2(&self, q: Vec3A) -> f32 {
        let d = (Vec3A::from_array(self.min) - q)
            .max(q - Vec3A::from_array(self.max))
            .max(Vec3A::ZERO);
        d.dot(d)
    }

    fn from_aabb(b: &Aabb, count: u32, index: u32) -> Self {
        Self {
            min: b.min.to_array(),
            count,
            max: b.max.to_array(),
            index,
        }
    }
}

/// Two siblings in one 64-byte cache line: the traversal always reads both.
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
struct NodePair([Node; 2]);

/// Converts obvhs's tree into sibling pairs in depth-first order (a subtree
/// occupies a contiguous run of memory, and leaves visited together have
/// adjacent slots). Returns the pairs, the primitive of every slot, and the
/// depth.
fn flatten(bvh: &Bvh2) -> (Vec<NodePair>, Vec<u32>, usize) {
    if bvh.nodes.is_empty() {
        return (Vec::new(), Vec::new(), 0);
    }
    let mut pairs = Vec::with_capacity(bvh.nodes.len() / 2 + 1);
    let mut slot_prim = Vec::with_capacity(bvh.primitive_indices.len());
    pairs.push(NodePair::default());
    // (obvhs node, our node id = pair·2 + side, depth)
    let mut todo = vec![(0usize, 0u32, 1usize)];
    let mut depth = 0;
    while let Some((src, dst, d)) = todo.pop() {
        depth = depth.max(d);
        let n = &bvh.nodes[src];
        let node = if n.is_leaf() {
            let first = slot_prim.len() as u32;
            let range = n.first_index as usize..(n.first_index + n.prim_count) as usize;
            slot_prim.extend_from_slice(&bvh.primitive_indices[range]);
            Node::from_aabb(n.aabb(), n.prim_count, first)
        } else {
            let pair = pairs.len() as u32;
            pairs.push(NodePair::default());
            let l = n.first_index as usize;
            // Right pushed first so the left subtree is laid out next.
            todo.push((l + 1, (pair << 1) | 1, d + 1));
            todo.push((l, pair << 1, d + 1));
            Node::from_aabb(n.aabb(), 0, pair)
        };
        pairs[(dst >> 1) as usize].0[(dst & 1) as usize] = node;
    }
    (pairs, slot_prim, depth)
}

/// PLOC build, SAH reinsertion and SAH leaf collapsing, as obvhs's
/// `build_bvh2` does. Leaves of up to 8 triangles with a traversal cost of
/// 2 triangle tests measured fastest for closest-point queries (and halve
/// the node count against one triangle per leaf).
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
    collapse(&mut bvh, 8, 2.0);
    bvh
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
