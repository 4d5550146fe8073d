//! [`SegmentIndex`]: closest-point queries on a set of line segments (one
//! feature line, or an edge soup), a client of [`Bvh`]; and the exact
//! segment routines it refines leaves with ([`closest_point_on_segment`],
//! [`lerp_exact`]).
//!
//! Of equally close segments the lowest-numbered wins, so an answer depends
//! only on the segments, not on the tree: a query seeded with any segment's
//! own answer ([`SegmentIndex::closest_from`]) returns the same bits.

use glam::DVec3;

use super::tree::{Bvh, LeafShape};

/// A segment test is cheap next to a node visit, so leaves hold a few.
const LEAF: LeafShape = LeafShape {
    max_primitives: 4,
    traversal_cost: 1.0,
};

/// `a + t (b − a)`, returning the end points exactly at t = 0 and t = 1 so
/// that the shared vertex of two segments has one position.
#[inline]
pub fn lerp_exact(a: DVec3, b: DVec3, t: f64) -> DVec3 {
    if t <= 0.0 {
        a
    } else if t >= 1.0 {
        b
    } else {
        a + (b - a) * t
    }
}

/// The point of segment [`a`, `b`] closest to `p`: (t, point, squared
/// distance), the point being [`lerp_exact`]`(a, b, t)` with t in [0, 1]. A
/// zero-length segment gives t = 0.
#[inline]
pub fn closest_point_on_segment(p: DVec3, a: DVec3, b: DVec3) -> (f64, DVec3, f64) {
    let d = b - a;
    let dd = d.length_squared();
    let t = if dd > 0.0 {
        ((p - a).dot(d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = lerp_exact(a, b, t);
    (t, q, (p - q).length_squared())
}

/// The closest point of a segment set to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentPoint {
    /// Index of the segment (as numbered for [`SegmentIndex::new`]).
    pub segment: u32,
    /// Parameter on the segment in [0, 1]: 0 at its first end, 1 at its second.
    pub t: f64,
    /// The closest point; exactly an end point when `t` is 0 or 1.
    pub point: DVec3,
    /// Squared distance from the query point.
    pub distance_squared: f64,
}

impl SegmentPoint {
    /// The answer of segment `segment` = [`a`, `b`] alone.
    #[inline]
    pub fn on_segment(p: DVec3, segment: u32, a: DVec3, b: DVec3) -> Self {
        let (t, point, distance_squared) = closest_point_on_segment(p, a, b);
        Self {
            segment,
            t,
            point,
            distance_squared,
        }
    }

    /// The tie rule: lexicographic (distance, segment) order.
    #[inline]
    pub fn better_than(&self, other: &SegmentPoint) -> bool {
        self.distance_squared < other.distance_squared
            || (self.distance_squared == other.distance_squared && self.segment < other.segment)
    }
}

/// A spatial index over line segments for closest-point queries.
///
/// Plain data (`Send + Sync`). Segments with a non-finite end point are kept
/// in the numbering but never returned.
#[derive(Clone, Debug, Default)]
pub struct SegmentIndex {
    /// The tree; its primitives are segments.
    tree: Bvh,
    /// End points per slot.
    ends: Vec<[DVec3; 2]>,
}

impl SegmentIndex {
    /// Builds the index over segments `0..count`, segment `i` running from
    /// `ends(i)[0]` to `ends(i)[1]`.
    pub fn new(count: usize, ends: impl Fn(usize) -> [DVec3; 2] + Sync) -> Self {
        let tree = Bvh::new(count, |i| Some(ends(i)), LEAF);
        let ends = tree
            .slot_primitives()
            .iter()
            .map(|&s| ends(s as usize))
            .collect();
        Self { tree, ends }
    }

    /// Number of segments that queries can return.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    /// Whether no segment can be returned.
    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// The closest point of the segments to `p`, ties to the lowest segment.
    /// `None` when there is no segment or `p` is not finite.
    #[inline]
    pub fn closest(&self, p: DVec3) -> Option<SegmentPoint> {
        self.closest_from(p, None)
    }

    /// The better (by [`SegmentPoint::better_than`]) of `init` and the
    /// closest point of the segments to `p`. A tight `init`, such as the
    /// answer of a segment next to the expected one, bounds the walk from
    /// the start. Returns `init` for a non-finite `p`.
    #[inline]
    pub fn closest_from(&self, p: DVec3, init: Option<SegmentPoint>) -> Option<SegmentPoint> {
        let mut best = init;
        let bound = init.map_or(f64::INFINITY, |c| c.distance_squared);
        self.tree.closest(p, bound, |slot, _| {
            let [a, b] = self.ends[slot];
            let c = SegmentPoint::on_segment(p, self.tree.primitive(slot), a, b);
            // With no best yet any comparable distance is taken, ∞ included.
            if best.map_or(!c.distance_squared.is_nan(), |b| c.better_than(&b)) {
                best = Some(c);
            }
            c.distance_squared
        });
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_regions() {
        let (a, b) = (DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0));
        let (t, q, d2) = closest_point_on_segment(DVec3::new(1.0, 1.0, 0.0), a, b);
        assert_eq!((t, q, d2), (0.5, DVec3::X, 1.0));
        let (t, q, _) = closest_point_on_segment(DVec3::new(5.0, 1.0, 0.0), a, b);
        assert_eq!((t, q), (1.0, b));
        let (t, q, d2) = closest_point_on_segment(DVec3::ONE, a, a);
        assert_eq!((t, q, d2), (0.0, a, 3.0));
    }

    #[test]
    fn ties_go_to_the_lowest_segment() {
        // Four segments meeting at the origin, queried there.
        let dirs = [DVec3::X, DVec3::Y, -DVec3::X, -DVec3::Y];
        let idx = SegmentIndex::new(4, |i| [dirs[3 - i], DVec3::ZERO]);
        let c = idx.closest(DVec3::ZERO).unwrap();
        assert_eq!(
            (c.segment, c.t, c.point, c.distance_squared),
            (0, 1.0, DVec3::ZERO, 0.0)
        );
        let seed = SegmentPoint::on_segment(DVec3::ZERO, 3, dirs[0], DVec3::ZERO);
        assert_eq!(idx.closest_from(DVec3::ZERO, Some(seed)), Some(c));
    }

    #[test]
    fn non_finite_segments_and_queries() {
        let idx = SegmentIndex::new(2, |i| {
            [
                DVec3::splat(if i == 0 { f64::NAN } else { 1.0 }),
                DVec3::ZERO,
            ]
        });
        assert_eq!(idx.len(), 1);
        assert_eq!(idx.closest(DVec3::X).unwrap().segment, 1);
        assert!(idx.closest(DVec3::NAN).is_none());
        assert!(SegmentIndex::default().closest(DVec3::X).is_none());
    }
}
