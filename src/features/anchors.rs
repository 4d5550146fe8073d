//! The remesher's anchoring policy: which input vertices stay fixed besides
//! the corners. Tips of spikes and cones keep their position, and so do the
//! feature-line vertices where the input's line turns more than an output
//! chord may cut. Both leave a candidate free when a fixed vertex is closer
//! than the collapse length, so two fixed ends never force a short edge.

use super::{FeatureSet, VertexKind};
use crate::mesh::{Handle, Mesh, VertexId};
use crate::sizing::{COLLAPSE_FACTOR, SPLIT_FACTOR};

/// Vertex kind tag: not on a feature.
pub(crate) const SMOOTH: u32 = u32::MAX;
/// Vertex kind tag: a corner, which never moves.
pub(crate) const CORNER: u32 = u32::MAX - 1;

/// Angle defect (2π minus the angles around a vertex) above which a smooth
/// interior vertex is the tip of a spike or cone and is kept as a corner.
const TIP_ANGLE_DEFECT: f64 = 0.3;

/// Keeps the tips of spikes (horns, ears, noses) where they are. An
/// isotropic mesh at length L cuts across a tip unless a vertex sits on it,
/// and that chord is where the distance to the input peaks; one fixed vertex
/// there costs nothing in triangle shape. Candidates are taken by decreasing
/// defect, and a candidate within 4/5 of its target length of a vertex
/// already fixed is left free: two fixed vertices that close force a short
/// edge and slivers around it (scan noise has clusters of such spikes).
pub(crate) fn anchor_tips(mesh: &Mesh, size: &[f64], near: &mut Neighborhood, kind: &mut [u32]) {
    let mut tips: Vec<(f64, u32)> = Vec::new();
    for v in mesh.vertices() {
        if kind[v.idx()] != SMOOTH || mesh.is_boundary_vertex(v) {
            continue;
        }
        let p = mesh.position(v);
        let mut sum = 0.0;
        for h in mesh.outgoing(v) {
            let a = mesh.position(mesh.to_vertex(h)) - p;
            let b = mesh.position(mesh.to_vertex(mesh.next(h))) - p;
            sum += a.angle_between(b);
        }
        let defect = (std::f64::consts::TAU - sum).abs();
        if defect > TIP_ANGLE_DEFECT {
            tips.push((defect, v.0));
        }
    }
    tips.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    for (_, v) in tips {
        let r = COLLAPSE_FACTOR * size[v as usize];
        if !near.any_within(mesh, VertexId(v), r, |u| kind[u as usize] == CORNER) {
            kind[v as usize] = CORNER;
        }
    }
}

/// Bounded breadth-first search over mesh edges around a vertex, for
/// "is anything of this kind within this distance" queries.
pub(crate) struct Neighborhood {
    /// Vertex count; `stamp` is allocated at the first query, so a mesh
    /// without tips or turn candidates pays nothing.
    n: usize,
    stamp: Vec<u32>,
    round: u32,
    queue: Vec<u32>,
}

impl Neighborhood {
    /// Most vertices one query visits; past it the query answers from what
    /// it saw (a far finer input than the target only loses the spacing).
    const MAX_VISITS: usize = 4096;

    pub(crate) fn new(n: usize) -> Self {
        Self {
            n,
            stamp: Vec::new(),
            round: 0,
            queue: Vec::new(),
        }
    }

    /// Whether a vertex other than `v`, connected to it through vertices
    /// within Euclidean distance `r` of it, satisfies `hit`.
    pub(crate) fn any_within(
        &mut self,
        mesh: &Mesh,
        v: VertexId,
        r: f64,
        hit: impl Fn(u32) -> bool,
    ) -> bool {
        if self.stamp.is_empty() {
            self.stamp = vec![0; self.n];
        }
        self.round += 1;
        let p = mesh.position(v);
        self.queue.clear();
        self.queue.push(v.0);
        self.stamp[v.idx()] = self.round;
        let mut i = 0;
        while i < self.queue.len() && i < Self::MAX_VISITS {
            let u = VertexId(self.queue[i]);
            i += 1;
            for h in mesh.outgoing(u) {
                let w = mesh.to_vertex(h);
                if self.stamp[w.idx()] == self.round {
                    continue;
                }
                self.stamp[w.idx()] = self.round;
                if mesh.position(w).distance(p) < r {
                    if hit(w.0) {
                        return true;
                    }
                    self.queue.push(w.0);
                }
            }
        }
        false
    }
}

/// Keeps the feature-line vertices where the input's polyline turns enough
/// that an output chord across them would cut the turn by more than
/// `turn_sag`·L (the remesher passes the statistics' on-line tolerance, so
/// an output feature line covers the input's within the tolerance it is
/// measured with).
///
/// Output feature vertices lie on the input's polyline, so between two of
/// them the output runs straight while the input may bend at an input vertex
/// (a tessellated arc turns by a few degrees at each vertex, fandisk's by up
/// to 22.5°). The worst chord across a vertex `v` has its end points on the
/// two segments at `v`, at most 2/3·L from `v` each (an output edge is at most
/// 4/3·L long); when its distance from `v` exceeds the tolerance, `v` keeps
/// its input position. Because the chord's end points are capped by the
/// segment lengths, a finely tessellated curve never pins its vertices: the
/// rule only fires where the input's segments are long enough for the
/// output to cut the turn. Candidates are taken by decreasing sag over all
/// lines, and a vertex closer than 4/5·L (the collapse length) along its
/// line to a kept vertex or a corner, or in space to a corner or kept tip
/// off its line, is left free, so no feature edge is forced below the
/// collapse length by two fixed ends. Returns the number of vertices kept.
pub(crate) fn anchor_turns(
    mesh: &Mesh,
    features: &FeatureSet,
    size: &[f64],
    turn_sag: f64,
    nbhd: &mut Neighborhood,
    kind: &mut [u32],
) -> u64 {
    use std::collections::BTreeSet;
    /// Per line: arc length at each vertex, total length, whether the loop
    /// start is free, and the arc positions already fixed.
    struct LineArc {
        arc: Vec<f64>,
        total: f64,
        closed: bool,
        fixed: BTreeSet<u64>,
    }
    let mut arcs: Vec<LineArc> = Vec::with_capacity(features.lines().len());
    // (sag / L, line, index on the line), over every line.
    let mut candidates: Vec<(f64, u32, u32)> = Vec::new();
    for (id, line) in features.lines().iter().enumerate() {
        let pts = features.line_points(id as u32);
        let n = line.vertices.len();
        let mut arc = vec![0.0f64; n];
        for i in 1..n {
            arc[i] = arc[i - 1] + pts[i].distance(pts[i - 1]);
        }
        let total = arc[n - 1];
        let closed = line.is_closed();
        // Interior vertices, plus the loop's start when the loop has no corner.
        let start_free = closed && kind[line.vertices[0] as usize] == id as u32;
        let mut fixed: BTreeSet<u64> = BTreeSet::new();
        if !start_free {
            fixed.insert(0f64.to_bits());
            fixed.insert(total.to_bits());
        }
        arcs.push(LineArc {
            arc,
            total,
            closed,
            fixed,
        });
        if n < 3 {
            continue;
        }
        for i in (if start_free { 0 } else { 1 })..n - 1 {
            let v = line.vertices[i] as usize;
            if kind[v] != id as u32 {
                continue;
            }
            let prev = if i == 0 { pts[n - 2] } else { pts[i - 1] };
            let (p, next) = (pts[i], pts[i + 1]);
            let cap = 0.5 * SPLIT_FACTOR * size[v];
            let (din, dout) = (p - prev, next - p);
            let (lin, lout) = (din.length(), dout.length());
            if lin <= 0.0 || lout <= 0.0 {
                continue;
            }
            let a = p - din * (lin.min(cap) / lin);
            let b = p + dout * (lout.min(cap) / lout);
            let ab = b - a;
            let sag = (p - a).cross(ab).length() / ab.length();
            if sag > turn_sag * size[v] {
                candidates.push((sag / size[v], id as u32, i as u32));
            }
        }
    }
    // Largest sag first over all lines, so a shallow turn never displaces a
    // deep one on a neighbouring line.
    candidates.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let near = |la: &LineArc, lo: f64, hi: f64| {
        // `+ 0.0` turns −0 into +0 so the bits order like the values;
        // `range` panics on an empty interval (NaN from non-finite input).
        let (lo, hi) = (lo.max(0.0) + 0.0, hi.min(la.total));
        lo <= hi && la.fixed.range(lo.to_bits()..=hi.to_bits()).next().is_some()
    };
    let mut count = 0;
    for (_, id, i) in candidates {
        let line = &features.lines()[id as usize];
        let la = &arcs[id as usize];
        let v = line.vertices[i as usize] as usize;
        let (s, r) = (la.arc[i as usize], COLLAPSE_FACTOR * size[v]);
        let mut taken = near(la, s - r, s + r);
        if la.closed {
            taken |= s - r < 0.0 && near(la, s - r + la.total, la.total);
            taken |= s + r > la.total && near(la, 0.0, s + r - la.total);
        }
        // Nor within that distance in space of a corner or a kept tip off
        // this line: two fixed vertices that close force a short edge
        // between them (noisy creases end and cross next to each other).
        // Another line's kept turns do not count: on fandisk two creases
        // turn 0.57·L apart, and leaving one turn free narrows the
        // triangle in its feature sector below what the sector forces.
        let (first, last) = (line.vertices[0], line.vertices[line.vertices.len() - 1]);
        let fixed_off_line = |u: u32| {
            kind[u as usize] == CORNER
                && u != first
                && u != last
                && !matches!(features.vertex_kind(u), VertexKind::Line(_))
        };
        taken = taken || nbhd.any_within(mesh, VertexId(v as u32), r, fixed_off_line);
        if !taken {
            arcs[id as usize].fixed.insert(s.to_bits());
            kind[v] = CORNER;
            count += 1;
        }
    }
    count
}
