//! Closest-point queries restricted to one feature line: the per-line
//! segment tree and the walk along a line from a hint segment.

use glam::DVec3;

use super::*;

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
        self.closest_from(line, p, Candidate::NONE)
    }

    /// Same answer as [`Self::closest_on_line`] (bit for bit), usually
    /// faster when `hint_segment` is at or next to the answer: a local walk
    /// from the hint gives a tight bound, then the segment tree only opens
    /// the nodes within that bound. Out-of-range hints are clamped.
    ///
    /// Panics if `line` is out of range.
    pub fn closest_on_line_near(&self, line: u32, p: DVec3, hint_segment: u32) -> LinePoint {
        let l = &self.lines[line as usize];
        let pts = self.line_points(line);
        let n = l.segment_count() as u32;
        let closed = l.is_closed();
        let eval = |s: u32| {
            let (t, q, d2) = closest_on_segment(pts[s as usize], pts[s as usize + 1], p);
            Candidate { d2, item: s, t, q }
        };
        if !p.is_finite() {
            return self.closest_on_line(line, p);
        }
        let mut best = eval(hint_segment.min(n - 1));
        // Walk downhill in both directions (a closed line wraps around), a
        // bounded number of steps: a far-off hint must not cost O(n).
        for dir in [1i64, -1] {
            let mut s = best.item;
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
        self.closest_from(line, p, best)
    }

    fn closest_from(&self, line: u32, p: DVec3, init: Candidate) -> LinePoint {
        let l = &self.lines[line as usize];
        let pts = self.line_points(line);
        let best = self
            .tree
            .nearest(l.root, p, init, |s| [pts[s as usize], pts[s as usize + 1]]);
        if best.item == u32::MAX {
            return LinePoint {
                segment: 0,
                t: 0.0,
                point: pts[0],
                dist2: f64::NAN,
            };
        }
        LinePoint {
            segment: best.item,
            t: best.t,
            point: best.q,
            dist2: best.d2,
        }
    }
}

/// `a + t (b − a)`, returning the end points exactly at t = 0 and t = 1 so
/// that the shared vertex of two segments has one position.
#[inline]
pub(crate) fn lerp_exact(a: DVec3, b: DVec3, t: f64) -> DVec3 {
    if t <= 0.0 {
        a
    } else if t >= 1.0 {
        b
    } else {
        a + (b - a) * t
    }
}

/// Closest point of segment [a, b] to p: (t, point, squared distance).
#[inline]
pub(crate) fn closest_on_segment(a: DVec3, b: DVec3, p: DVec3) -> (f64, DVec3, f64) {
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

#[derive(Clone, Copy, Debug)]
pub(crate) struct Candidate {
    pub(crate) d2: f64,
    pub(crate) item: u32,
    pub(crate) t: f64,
    pub(crate) q: DVec3,
}

impl Candidate {
    pub(crate) const NONE: Candidate = Candidate {
        d2: f64::INFINITY,
        item: u32::MAX,
        t: 0.0,
        q: DVec3::ZERO,
    };

    /// Lexicographic (distance, item) order: deterministic under ties.
    #[inline]
    pub(crate) fn better_than(&self, other: &Candidate) -> bool {
        self.d2 < other.d2 || (self.d2 == other.d2 && self.item < other.item)
    }
}

/// Most segments the hint walk of [`FeatureSet::closest_on_line_near`] visits per direction.
pub(crate) const NEAR_WALK_STEPS: u32 = 16;

/// Leaf size of the segment tree: a few segments per leaf amortise the box test.
pub(crate) const LEAF: usize = 4;

#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Node {
    pub(crate) min: DVec3,
    pub(crate) max: DVec3,
    /// Leaf: first item in `items`; inner: index of the right child (the
    /// left child follows the node directly).
    pub(crate) first: u32,
    /// Leaf: item count; inner: 0.
    pub(crate) count: u32,
}

/// A bounding-box tree over segments, median split on the widest centroid
/// axis. Several trees share one node arena; each is addressed by its root.
#[derive(Clone, Debug, Default)]
pub(crate) struct SegTree {
    pub(crate) nodes: Vec<Node>,
    pub(crate) items: Vec<u32>,
}

impl SegTree {
    /// Adds a tree over segments `0..n` (endpoints from `seg`) and returns
    /// its root. `n` must be at least 1.
    pub(crate) fn build(&mut self, n: u32, seg: impl Fn(u32) -> [DVec3; 2]) -> u32 {
        let base = self.items.len();
        self.items.extend(0..n);
        let centroids: Vec<DVec3> = (0..n)
            .map(|s| {
                let [a, b] = seg(s);
                (a + b) * 0.5
            })
            .collect();
        let root = self.nodes.len() as u32;
        self.build_node(base, base + n as usize, &centroids, &seg);
        root
    }

    pub(crate) fn build_node(
        &mut self,
        lo: usize,
        hi: usize,
        centroids: &[DVec3],
        seg: &impl Fn(u32) -> [DVec3; 2],
    ) {
        let mut min = DVec3::INFINITY;
        let mut max = DVec3::NEG_INFINITY;
        let mut cmin = DVec3::INFINITY;
        let mut cmax = DVec3::NEG_INFINITY;
        for &s in &self.items[lo..hi] {
            let [a, b] = seg(s);
            min = min.min(a).min(b);
            max = max.max(a).max(b);
            let c = centroids[s as usize];
            cmin = cmin.min(c);
            cmax = cmax.max(c);
        }
        let id = self.nodes.len();
        self.nodes.push(Node {
            min,
            max,
            first: lo as u32,
            count: (hi - lo) as u32,
        });
        if hi - lo <= LEAF {
            return;
        }
        let ext = cmax - cmin;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = (lo + hi) / 2;
        self.items[lo..hi].select_nth_unstable_by(mid - lo, |&x, &y| {
            centroids[x as usize][axis].total_cmp(&centroids[y as usize][axis])
        });
        self.build_node(lo, mid, centroids, seg);
        let right = self.nodes.len() as u32;
        self.build_node(mid, hi, centroids, seg);
        self.nodes[id].first = right;
        self.nodes[id].count = 0;
    }

    /// The best candidate among `init` and the segments of the tree at `root`.
    pub(crate) fn nearest(
        &self,
        root: u32,
        p: DVec3,
        init: Candidate,
        seg: impl Fn(u32) -> [DVec3; 2],
    ) -> Candidate {
        let mut best = init;
        let mut stack = [0u32; 96];
        stack[0] = root;
        let mut sp = 1;
        // Nodes at exactly the best distance are still opened: they may hold
        // an equally close segment with a lower index (the tie rule).
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if box_dist2(node, p) > best.d2 {
                continue;
            }
            if node.count > 0 {
                for &s in &self.items[node.first as usize..][..node.count as usize] {
                    let [a, b] = seg(s);
                    let (t, q, d2) = closest_on_segment(a, b, p);
                    let c = Candidate { d2, item: s, t, q };
                    if c.better_than(&best) {
                        best = c;
                    }
                }
            } else {
                let left = stack[sp] + 1;
                let right = node.first;
                let dl = box_dist2(&self.nodes[left as usize], p);
                let dr = box_dist2(&self.nodes[right as usize], p);
                // Push the farther child first so the nearer one is opened next.
                let (near, far, dfar) = if dl <= dr {
                    (left, right, dr)
                } else {
                    (right, left, dl)
                };
                if dfar <= best.d2 {
                    stack[sp] = far;
                    sp += 1;
                }
                stack[sp] = near;
                sp += 1;
            }
        }
        best
    }
}

#[inline]
pub(crate) fn box_dist2(n: &Node, p: DVec3) -> f64 {
    let d = (n.min - p).max(p - n.max).max(DVec3::ZERO);
    d.length_squared()
}
