//! [`Bvh`]: the one bounding-volume hierarchy of the crate. It knows boxes,
//! not primitives: it is built from each primitive's vertices (the
//! primitive must lie in their convex hull: a triangle's three corners, a
//! segment's two ends, a point), and its queries hand the primitives that
//! survive pruning to a closure that does the exact test, as parry's
//! `project_point` does. [`SurfaceIndex`](super::SurfaceIndex),
//! [`SegmentIndex`](super::SegmentIndex) and [`PointIndex`](super::PointIndex)
//! are thin clients that own their primitives' data in slot order.
//!
//! The tree is built with obvhs's PLOC builder (Meister & Bittner, "Parallel
//! Locally-Ordered Clustering for Bounding Volume Hierarchy Construction",
//! 2018), SAH reinsertion and SAH leaf collapsing, then flattened into
//! sibling pairs in depth-first order. obvhs only traverses for rays, so the
//! queries are ours: [`Bvh::closest`] is the branch-and-bound nearest-
//! neighbour search of Roussopoulos, Kelley & Vincent (1995), depth first
//! with the nearer child first; [`Bvh::any_within`] is a pruned walk that
//! stops at the first hit.
//!
//! Node boxes are f32. They are built in a frame centred on the primitives
//! and scaled by a power of two to about unit size, rounded outward, and
//! every pruning bound carries an explicit margin for the rounding of the
//! query point and of the f32 box distance. So f32 can make a query visit a
//! few more nodes, but never skip a primitive whose computed distance could
//! be at or below the bound: a client that breaks ties by index sees every
//! tie. The margin assumes the primitives lie within about 10⁶ of their own
//! size of the origin, which keeps the f64 rounding of a leaf test below it.
//!
//! Queries allocate nothing: the traversal stack lives on the call stack for
//! trees up to [`STACK_DEPTH`] deep (deeper ones only come from
//! pathological inputs and use a heap stack).

use glam::{DVec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::leaf_collapser::collapse;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};
use rayon::prelude::*;

/// Largest tree depth served by the fixed-size traversal stack.
const STACK_DEPTH: usize = 64;

/// Relative slack on a pruning bound. It covers the f32 rounding of the
/// box-distance computation (a handful of ulps, ~1e-7) with a wide margin;
/// it only makes a query visit nodes that are within 0.001% of the bound.
const REL_SLACK: f64 = 1e-5;

/// Absolute slack on a pruning bound, relative to the size of the frame: it
/// covers f64 rounding in the local frame and in the clients' leaf tests.
const ABS_SLACK: f64 = 1e-10;

/// Below this many primitives the build's passes run serially: rayon's
/// hand-off costs more than the work (feature lines build many small trees).
const PARALLEL_MIN: usize = 4096;

/// How leaves are formed: SAH leaf collapsing merges subtrees of up to
/// `max_primitives` when their SAH cost, with one node visit costing
/// `traversal_cost` primitive tests, is lower as one leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafShape {
    /// Most primitives per leaf.
    pub max_primitives: u32,
    /// Cost of visiting a node, in leaf tests.
    pub traversal_cost: f32,
}

/// A binary BVH over primitives' boxes; see the module documentation.
///
/// The primitives kept in the tree are numbered by *slot* in leaf order (a
/// leaf's primitives are contiguous, and leaves visited together are near
/// each other); queries pass slots to their closure, and
/// [`primitive`](Self::primitive) maps a slot back to the primitive index
/// given to [`new`](Self::new). Clients keep their per-primitive data in slot
/// order so that a leaf reads one run of memory.
#[derive(Clone, Default)]
pub struct Bvh {
    /// The tree as sibling pairs in depth-first order; pair 0 holds the
    /// root (node 0). Leaves hold slot ranges.
    pairs: Vec<NodePair>,
    /// Primitive index per slot.
    slot_prim: Vec<u32>,
    /// Origin of the local frame the f32 boxes are expressed in.
    center: DVec3,
    /// Scale of the local frame (a power of two): local = (p − center)·scale.
    scale: f64,
    /// Largest norm of a primitive vertex in the local frame.
    radius: f64,
    /// Depth of the tree (root = 1); selects the stack.
    depth: usize,
}

impl std::fmt::Debug for Bvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bvh")
            .field("slots", &self.slot_prim.len())
            .field("node_pairs", &self.pairs.len())
            .field("depth", &self.depth)
            .finish()
    }
}

/// The pruning state of one query, in the frame's units.
struct Bound {
    /// Squared distance (world units) of the best primitive so far.
    d2: f64,
    /// f32 threshold: a node whose f32 box distance² exceeds this cannot
    /// hold a primitive at or below `d2`.
    limit: f32,
}

/// A query point in the local frame.
struct Local {
    q: Vec3A,
    /// How far (local units) a box may exceed a distance bound and still be
    /// visited: the rounding of the point to f32 (exact in f64) plus f64
    /// rounding in the frame and in the leaf test.
    pad: f64,
}

impl Bvh {
    /// Builds the tree over primitives `0..count`. `vertices(i)` gives the
    /// points whose convex hull contains primitive `i`, or `None` to leave it
    /// out; primitives with a non-finite vertex, or whose box does not fit
    /// in f32 in the local frame, are left out too (no query returns them).
    pub fn new<const K: usize>(
        count: usize,
        vertices: impl Fn(usize) -> Option<[DVec3; K]> + Sync,
        leaf: LeafShape,
    ) -> Self {
        let hull = |i: usize| vertices(i).filter(|v| v.iter().all(|p| p.is_finite()));
        let empty = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let (lo, hi) = fold_reduce(
            count,
            empty,
            |(lo, hi), i| match hull(i) {
                Some(v) => v
                    .iter()
                    .fold((lo, hi), |(lo, hi), p| (lo.min(*p), hi.max(*p))),
                None => (lo, hi),
            },
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
        let center = if lo.x <= hi.x {
            (lo + hi) * 0.5
        } else {
            DVec3::ZERO
        };
        let radius = fold_reduce(
            count,
            0.0,
            |r, i| match hull(i) {
                Some(v) => v.iter().map(|p| (*p - center).length()).fold(r, f64::max),
                None => r,
            },
            f64::max,
        );
        // A power of two brings the frame to about unit size: exact in f64,
        // and f32 boxes can neither overflow nor lose small inputs to underflow.
        let exponent = if radius > 0.0 {
            radius.log2().ceil().clamp(-1000.0, 1000.0) as i32
        } else {
            0
        };
        let scale = 2f64.powi(-exponent);

        // Boxes in the scaled local frame, rounded outward so that each
        // contains its f64 primitive exactly.
        let local_box = |i: usize| -> Option<(u32, Aabb)> {
            let v = hull(i)?;
            let mut bmin = Vec3A::splat(f32::INFINITY);
            let mut bmax = Vec3A::splat(f32::NEG_INFINITY);
            for p in v {
                let l = (p - center) * scale;
                bmin = bmin.min(Vec3A::new(f32_below(l.x), f32_below(l.y), f32_below(l.z)));
                bmax = bmax.max(Vec3A::new(f32_above(l.x), f32_above(l.y), f32_above(l.z)));
            }
            (bmin.is_finite() && bmax.is_finite()).then(|| (i as u32, Aabb::new(bmin, bmax)))
        };
        let (usable, boxes): (Vec<u32>, Vec<Aabb>) = if count < PARALLEL_MIN {
            (0..count).filter_map(local_box).unzip()
        } else {
            (0..count).into_par_iter().filter_map(local_box).unzip()
        };

        let bvh = build_tree(&boxes, leaf);
        drop(boxes);
        let (pairs, mut slot_prim, depth) = flatten(&bvh);
        drop(bvh);
        for p in &mut slot_prim {
            *p = usable[*p as usize];
        }
        Self {
            pairs,
            slot_prim,
            center,
            scale,
            radius: radius * scale,
            depth,
        }
    }

    /// Whether the tree holds no primitive (every query then finds nothing).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// Number of slots: the primitives kept in the tree.
    #[inline]
    pub fn len(&self) -> usize {
        self.slot_prim.len()
    }

    /// The primitive index (as numbered for [`new`](Self::new)) of every slot.
    #[inline]
    pub fn slot_primitives(&self) -> &[u32] {
        &self.slot_prim
    }

    /// The primitive index of slot `slot`.
    #[inline]
    pub fn primitive(&self, slot: usize) -> u32 {
        self.slot_prim[slot]
    }

    /// Branch-and-bound search for the primitive nearest to `p`.
    ///
    /// `leaf(slot, best)` must return the squared distance (world units)
    /// from `p` to that slot's primitive, or ∞ to pass over it; `best` is
    /// the smallest value so far, so a client that keeps the first of equal
    /// distances records exactly when the result is below it (and the two
    /// comparisons fold into one). The client keeps whatever else it needs
    /// (the point, the primitive) in the closure.
    /// Nodes are opened nearer child first, and a node is skipped only when
    /// its box is farther than the smallest value returned so far (initially
    /// `bound_d2`, ∞ for none) by more than the rounding margin: every
    /// primitive whose distance can equal or beat the running best is
    /// offered, so the client may keep the first or the lowest-numbered of
    /// equal distances. Returns the smallest value seen (`bound_d2` if none
    /// was smaller). Nothing is offered for an empty tree or a non-finite `p`.
    #[inline(always)]
    pub fn closest<F: FnMut(usize, f64) -> f64>(
        &self,
        p: DVec3,
        bound_d2: f64,
        mut leaf: F,
    ) -> f64 {
        if self.is_empty() || !p.is_finite() {
            return bound_d2;
        }
        let local = self.local(p);
        let mut bound = Bound {
            d2: bound_d2,
            limit: self.limit(bound_d2, local.pad),
        };
        if self.depth < STACK_DEPTH {
            // With the array's length known the stack needs no bounds checks.
            let mut stack = [Entry::default(); STACK_DEPTH];
            self.descend(&local, &mut stack, &mut bound, &mut leaf);
        } else {
            self.descend_deep(&local, &mut bound, &mut leaf);
        }
        bound.d2
    }

    /// Offers `hit(slot)` every primitive whose box may lie within `radius`
    /// of `p` (with the rounding margin), until `hit` returns true; returns
    /// whether one did. `hit` makes the exact test. False for an empty tree,
    /// a non-finite `p` or a negative or NaN `radius`.
    #[inline]
    pub fn any_within<F: FnMut(usize) -> bool>(&self, p: DVec3, radius: f64, mut hit: F) -> bool {
        if self.is_empty() || !p.is_finite() || radius.is_nan() || radius < 0.0 {
            return false;
        }
        let local = self.local(p);
        let limit = self.limit(radius * radius, local.pad);
        if self.depth < STACK_DEPTH {
            let mut stack = [Entry::default(); STACK_DEPTH];
            self.find(&local, limit, &mut stack, &mut hit)
        } else {
            let mut stack = vec![Entry::default(); self.depth + 1];
            self.find(&local, limit, &mut stack, &mut hit)
        }
    }

    /// `p` in the local frame, rounded to f32, with its pruning pad.
    #[inline(always)]
    fn local(&self, p: DVec3) -> Local {
        let local = (p - self.center) * self.scale;
        let q = Vec3A::new(local.x as f32, local.y as f32, local.z as f32);
        let pad = (local - q.as_dvec3()).length()
            + ABS_SLACK * (self.radius + local.length())
            + f64::MIN_POSITIVE;
        Local { q, pad }
    }

    /// The f32 pruning threshold for a squared world distance `d2` (∞ for
    /// ∞, without the arithmetic: most queries start unbounded).
    #[inline(always)]
    fn limit(&self, d2: f64, pad: f64) -> f32 {
        if d2 == f64::INFINITY {
            return f32::INFINITY;
        }
        let r = d2.sqrt() * self.scale + pad;
        f32_above(r * r * (1.0 + REL_SLACK))
    }

    /// [`descend`](Self::descend) with a heap stack, for trees deeper than
    /// [`STACK_DEPTH`]. Kept out of line so that the usual walk is the only
    /// hot call of the client's closure, which can then be inlined into it.
    #[cold]
    #[inline(never)]
    fn descend_deep<F: FnMut(usize, f64) -> f64>(
        &self,
        local: &Local,
        bound: &mut Bound,
        leaf: &mut F,
    ) {
        let mut stack = vec![Entry::default(); self.depth + 1];
        self.descend(local, &mut stack, bound, leaf);
    }

    /// The walk of [`closest`](Self::closest). `stack` must hold depth + 1
    /// entries: each pop pushes at most two children, one of which is
    /// popped next.
    #[inline(always)]
    fn descend<F: FnMut(usize, f64) -> f64>(
        &self,
        local: &Local,
        stack: &mut [Entry],
        bound: &mut Bound,
        leaf: &mut F,
    ) {
        let pairs = &self.pairs;
        let q = local.q;
        stack[0] = Entry {
            node: 0,
            d2: pairs[0].0[0].distance2(q),
        };
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let Entry { node, d2 } = stack[sp];
            if d2 > bound.limit {
                continue;
            }
            let node = &pairs[(node >> 1) as usize].0[(node & 1) as usize];
            if node.count > 0 {
                let first = node.index as usize;
                for slot in first..first + node.count as usize {
                    let d = leaf(slot, bound.d2);
                    if d < bound.d2 {
                        bound.d2 = d;
                        bound.limit = self.limit(d, local.pad);
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
                // The farther child goes below the nearer one, which is opened next.
                if df <= bound.limit {
                    stack[sp] = Entry { node: far, d2: df };
                    sp += 1;
                }
                if dn <= bound.limit {
                    stack[sp] = Entry { node: near, d2: dn };
                    sp += 1;
                }
            }
        }
    }

    /// The walk of [`any_within`](Self::any_within); `stack` as for
    /// [`descend`](Self::descend).
    #[inline(always)]
    fn find<F: FnMut(usize) -> bool>(
        &self,
        local: &Local,
        limit: f32,
        stack: &mut [Entry],
        hit: &mut F,
    ) -> bool {
        let pairs = &self.pairs;
        let q = local.q;
        if pairs[0].0[0].distance2(q) > limit {
            return false;
        }
        stack[0] = Entry::default();
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let node = stack[sp].node;
            let node = &pairs[(node >> 1) as usize].0[(node & 1) as usize];
            if node.count > 0 {
                let first = node.index as usize;
                if (first..first + node.count as usize).any(&mut *hit) {
                    return true;
                }
            } else {
                let children = &pairs[node.index as usize].0;
                for (side, child) in children.iter().enumerate() {
                    if child.distance2(q) <= limit {
                        stack[sp] = Entry {
                            node: (node.index << 1) | side as u32,
                            d2: 0.0,
                        };
                        sp += 1;
                    }
                }
            }
        }
        false
    }
}

/// One entry of the traversal stack: a node and the lower bound (squared f32
/// box distance) computed when it was pushed.
#[derive(Clone, Copy, Default)]
struct Entry {
    node: u32,
    d2: f32,
}

/// `(0..n)` folded with `f` and combined with `combine`, serially for small
/// `n`. Only for exact, order-free reductions (min, max), so both paths agree.
fn fold_reduce<T: Copy + Send + Sync>(
    n: usize,
    identity: T,
    f: impl Fn(T, usize) -> T + Sync,
    combine: impl Fn(T, T) -> T + Sync,
) -> T {
    if n < PARALLEL_MIN {
        (0..n).fold(identity, f)
    } else {
        (0..n)
            .into_par_iter()
            .fold(|| identity, &f)
            .reduce(|| identity, &combine)
    }
}

/// Largest f32 not above `x` (x finite or ±∞).
#[inline]
pub(crate) fn f32_below(x: f64) -> f32 {
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
pub(crate) fn f32_above(x: f64) -> f32 {
    -f32_below(-x)
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
/// adjacent slots). Returns the pairs, the box index of every slot, and the
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
/// `build_bvh2` does.
fn build_tree(boxes: &[Aabb], leaf: LeafShape) -> Bvh2 {
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
    collapse(&mut bvh, leaf.max_primitives, leaf.traversal_cost);
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

    const SHAPE: LeafShape = LeafShape {
        max_primitives: 4,
        traversal_cost: 1.0,
    };

    #[test]
    fn an_empty_tree_offers_nothing() {
        let t = Bvh::new::<1>(0, |_| None, SHAPE);
        assert!(t.is_empty() && t.slot_primitives().is_empty());
        assert_eq!(t.closest(DVec3::ZERO, 5.0, |_, _| unreachable!()), 5.0);
        assert!(!t.any_within(DVec3::ZERO, 1.0, |_| unreachable!()));
    }

    #[test]
    fn left_out_primitives_keep_their_numbers() {
        let pts = [DVec3::X, DVec3::NAN, DVec3::Y, DVec3::Z];
        let t = Bvh::new(4, |i| (i != 3).then_some([pts[i]]), SHAPE);
        let mut kept: Vec<u32> = t.slot_primitives().to_vec();
        kept.sort_unstable();
        assert_eq!(kept, [0, 2]);
        let d = t.closest(DVec3::ZERO, f64::INFINITY, |s, _| {
            pts[t.primitive(s) as usize].length_squared()
        });
        assert_eq!(d, 1.0);
    }
}
