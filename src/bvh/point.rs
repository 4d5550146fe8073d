//! [`PointIndex`]: radius and nearest-point queries on a point set (a
//! mesh's vertices), a client of [`Bvh`].

use glam::DVec3;

use super::tree::{Bvh, LeafShape};

/// A point test is a few flops: leaves hold several.
const LEAF: LeafShape = LeafShape {
    max_primitives: 8,
    traversal_cost: 1.0,
};

/// A spatial index over points.
///
/// Plain data (`Send + Sync`). Non-finite points are kept in the numbering
/// but never returned.
#[derive(Clone, Debug, Default)]
pub struct PointIndex {
    /// The tree; its primitives are the points.
    tree: Bvh,
    /// The points per slot.
    points: Vec<DVec3>,
}

impl PointIndex {
    /// Builds the index over `points`.
    pub fn new(points: &[DVec3]) -> Self {
        let tree = Bvh::new(points.len(), |i| Some([points[i]]), LEAF);
        let points = tree
            .slot_primitives()
            .iter()
            .map(|&i| points[i as usize])
            .collect();
        Self { tree, points }
    }

    /// Number of points that queries can return.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether no point can be returned.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Whether some point `v` has `v.distance(p) <= radius` (that exact f64
    /// test). False for a non-finite `p` or a negative or NaN `radius`.
    #[inline]
    pub fn any_within(&self, p: DVec3, radius: f64) -> bool {
        self.tree
            .any_within(p, radius, |slot| self.points[slot].distance(p) <= radius)
    }

    /// Calls `f(index)` for every point `v` with `v.distance(p) <= radius`
    /// (that exact f64 test), in no particular order. Nothing for a
    /// non-finite `p` or a negative or NaN `radius`.
    #[inline]
    pub fn for_each_within(&self, p: DVec3, radius: f64, mut f: impl FnMut(u32)) {
        self.tree.any_within(p, radius, |slot| {
            if self.points[slot].distance(p) <= radius {
                f(self.tree.primitive(slot));
            }
            false
        });
    }

    /// The point nearest to `p` and its squared distance, ties to the lowest
    /// index. `None` when there is no point or `p` is not finite.
    #[inline]
    pub fn closest(&self, p: DVec3) -> Option<(u32, f64)> {
        let mut best: Option<(u32, f64)> = None;
        self.tree.closest(p, f64::INFINITY, |slot, _| {
            let d2 = self.points[slot].distance_squared(p);
            let i = self.tree.primitive(slot);
            if best.map_or(!d2.is_nan(), |(j, e)| d2 < e || (d2 == e && i < j)) {
                best = Some((i, d2));
            }
            d2
        });
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radius_is_inclusive_and_ties_go_low() {
        let pts = [DVec3::X, DVec3::NAN, -DVec3::X, DVec3::X];
        let idx = PointIndex::new(&pts);
        assert_eq!(idx.len(), 3);
        assert!(idx.any_within(DVec3::ZERO, 1.0));
        assert!(!idx.any_within(DVec3::ZERO, 0.999));
        assert!(!idx.any_within(DVec3::NAN, 10.0));
        assert!(!idx.any_within(DVec3::ZERO, f64::NAN));
        assert_eq!(idx.closest(DVec3::ZERO), Some((0, 1.0)));
        assert_eq!(idx.closest(DVec3::new(2.0, 0.0, 0.0)), Some((0, 1.0)));
        assert!(PointIndex::default().closest(DVec3::ZERO).is_none());
        let mut found = Vec::new();
        idx.for_each_within(DVec3::new(0.5, 0.0, 0.0), 0.5, |i| found.push(i));
        found.sort_unstable();
        assert_eq!(found, [0, 3]);
        idx.for_each_within(DVec3::ZERO, f64::NAN, |_| unreachable!());
    }
}
