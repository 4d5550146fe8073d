//! Queries on the feature set: edge and vertex lookups, and closest-point
//! queries restricted to one feature line (each line's
//! [`SegmentIndex`](crate::bvh::SegmentIndex), seeded by a short walk along
//! the line from a hint segment).

use glam::DVec3;

use super::*;
use crate::bvh::{lerp_exact, SegmentPoint};

impl FeatureSet {
    /// The feature edge id of input edge (a, b), in either order.
    #[inline]
    pub fn edge_id(&self, a: u32, b: u32) -> Option<u32> {
        let a = a as usize;
        if a + 1 >= self.adj_offset.len() {
            return None;
        }
        self.adj[self.adj_offset[a] as usize..self.adj_offset[a + 1] as usize]
            .iter()
            .find(|n| n[0] == b)
            .map(|n| n[1])
    }

    /// Whether input edge (a, b) is a feature edge.
    #[inline]
    pub fn is_feature_edge(&self, a: u32, b: u32) -> bool {
        self.edge_id(a, b).is_some()
    }

    /// All feature edges as (a, b) with a < b, sorted.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// Why feature edge `id` (an index into [`Self::edges`]) is a feature.
    pub fn edge_flags(&self, id: u32) -> EdgeFlags {
        self.edge_flags[id as usize]
    }

    /// Number of feature edges having all reasons in `flags`.
    pub fn count_edges_with(&self, flags: EdgeFlags) -> usize {
        self.edge_flags.iter().filter(|f| f.contains(flags)).count()
    }

    /// The feature edges having all reasons in `flags`, in edge order.
    pub fn edges_with(&self, flags: EdgeFlags) -> Vec<[u32; 2]> {
        self.edges
            .iter()
            .zip(&self.edge_flags)
            .filter(|(_, f)| f.contains(flags))
            .map(|(&e, _)| e)
            .collect()
    }

    /// Whether input vertex `v` is a corner.
    #[inline]
    pub fn is_corner(&self, v: u32) -> bool {
        self.vertex_kind(v) == VertexKind::Corner
    }

    /// The corners, ascending.
    pub fn corners(&self) -> &[u32] {
        &self.corners
    }

    /// What input vertex `v` is ([`VertexKind::Smooth`] for unknown ids).
    #[inline]
    pub fn vertex_kind(&self, v: u32) -> VertexKind {
        self.kind
            .get(v as usize)
            .copied()
            .unwrap_or(VertexKind::Smooth)
    }

    /// For a [`VertexKind::Line`] vertex, its index in its line's vertex list.
    pub fn vertex_line_index(&self, v: u32) -> Option<(u32, u32)> {
        match self.vertex_kind(v) {
            VertexKind::Line(l) => Some((l, self.line_index[v as usize])),
            _ => None,
        }
    }

    /// The feature neighbours of input vertex `v`, ascending.
    pub fn feature_neighbors(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        let v = v as usize;
        let row: &[[u32; 2]] = if v + 1 < self.adj_offset.len() {
            &self.adj[self.adj_offset[v] as usize..self.adj_offset[v + 1] as usize]
        } else {
            &[]
        };
        row.iter().map(|n| n[0])
    }

    /// The feature lines. Every feature edge is a segment of exactly one line.
    pub fn lines(&self) -> &[FeatureLine] {
        &self.lines
    }

    /// The positions of line `line`'s vertices (as in the input mesh).
    ///
    /// Panics if `line` is out of range.
    pub fn line_points(&self, line: u32) -> &[DVec3] {
        let l = &self.lines[line as usize];
        &self.points[l.point_offset as usize..][..l.vertices.len()]
    }

    /// The line that input feature edge (a, b) belongs to.
    #[inline]
    pub fn edge_line(&self, a: u32, b: u32) -> Option<u32> {
        self.edge_segment(a, b).map(|s| s[0])
    }

    /// (line, segment) of input feature edge (a, b).
    #[inline]
    pub fn edge_segment(&self, a: u32, b: u32) -> Option<[u32; 2]> {
        self.edge_id(a, b).map(|e| self.edge_segment[e as usize])
    }

    /// Unit direction of segment `segment` of line `line` (from
    /// `vertices[segment]` to `vertices[segment + 1]`); zero if degenerate.
    ///
    /// Panics if `line` or `segment` is out of range.
    pub fn line_tangent(&self, line: u32, segment: u32) -> DVec3 {
        let p = self.line_points(line);
        (p[segment as usize + 1] - p[segment as usize]).normalize_or_zero()
    }

    /// The point at parameter `t` on segment `segment` of line `line`.
    ///
    /// Panics if `line` or `segment` is out of range.
    pub fn line_point(&self, line: u32, segment: u32, t: f64) -> DVec3 {
        let p = self.line_points(line);
        lerp_exact(p[segment as usize], p[segment as usize + 1], t)
    }

    /// The closest point to `p` on line `line`. Ties in distance go to the
    /// lowest segment index, so the answer is deterministic. A non-finite
    /// `p` gives segment 0, t = 0 and a NaN distance.
    ///
    /// Panics if `line` is out of range.
    pub fn closest_on_line(&self, line: u32, p: DVec3) -> LinePoint {
        self.closest_from(line, p, None)
    }

    /// Same answer as [`Self::closest_on_line`] (bit for bit), usually
    /// faster when `hint_segment` is at or next to the answer: a local walk
    /// from the hint gives a tight bound, then the line's segment index only
    /// opens the nodes within that bound. Out-of-range hints are clamped.
    ///
    /// Panics if `line` is out of range.
    pub fn closest_on_line_near(&self, line: u32, p: DVec3, hint_segment: u32) -> LinePoint {
        let l = &self.lines[line as usize];
        let pts = self.line_points(line);
        let n = l.segment_count() as u32;
        let closed = l.is_closed();
        let eval = |s: u32| SegmentPoint::on_segment(p, s, pts[s as usize], pts[s as usize + 1]);
        if !p.is_finite() {
            return self.closest_on_line(line, p);
        }
        let mut best = eval(hint_segment.min(n - 1));
        // Walk downhill in both directions (a closed line wraps around), a
        // bounded number of steps: a far-off hint must not cost O(n).
        for dir in [1i64, -1] {
            let mut s = best.segment;
            for _ in 0..n.min(NEAR_WALK_STEPS) {
                let next = s as i64 + dir;
                let next = if closed {
                    next.rem_euclid(n as i64) as u32
                } else if (0..n as i64).contains(&next) {
                    next as u32
                } else {
                    break;
                };
                let c = eval(next);
                if !c.better_than(&best) {
                    break;
                }
                best = c;
                s = next;
            }
        }
        self.closest_from(line, p, Some(best))
    }

    fn closest_from(&self, line: u32, p: DVec3, init: Option<SegmentPoint>) -> LinePoint {
        match self.line_trees[line as usize].closest_from(p, init) {
            Some(c) => LinePoint {
                segment: c.segment,
                t: c.t,
                point: c.point,
                dist2: c.distance_squared,
            },
            None => LinePoint {
                segment: 0,
                t: 0.0,
                point: self.line_points(line)[0],
                dist2: f64::NAN,
            },
        }
    }
}

/// Most segments the hint walk of [`FeatureSet::closest_on_line_near`] visits per direction.
const NEAR_WALK_STEPS: u32 = 16;
