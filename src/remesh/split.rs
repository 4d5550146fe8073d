//! Pass 1: split every edge longer than 4/3 of its target length at its
//! midpoint, longest first (as CGAL does). Longest-first order is Rivara's
//! longest-edge bisection: on needle-shaped input (CAD tessellations) it
//! refines without the explosion of new long spokes that index order causes.
//! A feature edge's new vertex is placed on the input's feature line, so
//! creases and boundaries are resampled without drifting.
//!
//! A second sweep ([`split_deviating_edges`]) splits the in-band edges that
//! cut the input: those whose midpoint lies farther than
//! [`DEVIATION_FACTOR`] times their target from the surface.

use glam::DVec3;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::state::{State, SPLIT_FACTOR};
use super::RemeshError;
use crate::geometry::triangle_cross;
use crate::mesh::{EdgeId, Handle, EDGE_FROZEN};

/// How much longer than its split limit edge `e` is (> 1 means split it).
fn excess(st: &State, e: EdgeId) -> f64 {
    if st.mesh.edge_has_flag(e, EDGE_FROZEN) {
        return 0.0;
    }
    let [a, b] = st.mesh.edge_vertices(e);
    let len = st.mesh.position(a).distance(st.mesh.position(b));
    len / (SPLIT_FACTOR * st.edge_target(a, b))
}

/// Splits long edges until none is left; returns the number of splits.
pub(super) fn split_long_edges(st: &mut State) -> Result<u64, RemeshError> {
    // Max-heap on the excess ratio (positive floats order like their bits);
    // ties go to the lower edge index, so the order is deterministic.
    // The long edges are found in parallel; the heap is built in O(n).
    let long = st.par_edges(|e| {
        let r = excess(st, e);
        (r > 1.0).then_some((r.to_bits(), Reverse(e.0)))
    });
    let mut heap = BinaryHeap::from(long);
    let mut count = 0u64;
    while let Some((key, Reverse(i))) = heap.pop() {
        let e = EdgeId(i);
        if st.mesh.is_edge_deleted(e) {
            continue;
        }
        let r = excess(st, e);
        if r.is_nan() || r <= 1.0 {
            continue;
        }
        if r.to_bits() != key {
            heap.push((r.to_bits(), Reverse(i)));
            continue;
        }
        let [a, b] = st.mesh.edge_vertices(e);
        let (pa, pb) = (st.mesh.position(a), st.mesh.position(b));
        let len = pa.distance(pb);
        let mid = 0.5 * (pa + pb);
        let (mut p, mut seg) = (mid, 0u32);
        if let Some(line) = st.line_of(e) {
            let hint = if st.kind[a.idx()] == line {
                st.hint_seg[a.idx()]
            } else {
                st.hint_seg[b.idx()]
            };
            let lp = st.features.closest_on_line_near(line, mid, hint);
            seg = lp.segment;
            // Take the line point only when it lies near the midpoint: a line
            // that bends sharply between a and b can pull the closest point
            // toward an end, and coincident parts elsewhere on the same line
            // must never attract it.
            if lp.point.distance(mid) <= 0.25 * len {
                p = lp.point;
            }
        }
        let s = st.split(e, p, seg);
        count += 1;
        for f in [e, s.second_half.edge(), s.spokes[0], s.spokes[1]] {
            if f.is_valid() {
                let r = excess(st, f);
                if r > 1.0 {
                    heap.push((r.to_bits(), Reverse(f.0)));
                }
            }
        }
        st.cancel.every(count)?;
    }
    Ok(count)
}

/// An edge whose midpoint lies farther than this fraction of its target
/// from the input is split at its closest input point (see
/// [`split_deviating_edges`]); the collapse pass keeps a vertex whose
/// removal would leave its position this far from the surface.
pub(super) const DEVIATION_FACTOR: f64 = 0.25;

/// Cosine of the angle (30°) between the input normals under an edge's end
/// points below which [`split_deviating_edges`] measures the edge: between
/// closer normals, an edge the split pass leaves stays within 0.18 of its
/// target of the surface, below [`DEVIATION_FACTOR`] (`docs/tuning.md`).
const DEVIATION_NORMAL_COS: f64 = 0.866_025_403_784_438_6;

/// Splits every non-feature edge whose midpoint lies farther than
/// [`DEVIATION_FACTOR`] times its target from the input, at the input point
/// closest to the midpoint; returns the number of splits.
///
/// Where the input turns by 90° or more within one target length without a
/// feature edge (a rounded ridge of a coarse model, its normal turning over
/// several creases of 10–35°), uniform sampling leaves edges whose two ends
/// lie on the two flanks, and the ridge's crest is then over half a target
/// length from the output. Nothing in the length rules sees this: the edges
/// are in the band. The new vertex sits on the crest, and the collapse
/// pass's deviation guard keeps it there.
///
/// Uniform sizing only (with or without `refine_curved`): adaptive sizing
/// derives its lengths from a distance tolerance of its own, against which
/// a fraction of the local target means nothing.
pub(super) fn split_deviating_edges(st: &mut State) -> Result<u64, RemeshError> {
    if st.uniform.is_none() {
        return Ok(0);
    }
    let candidates: Vec<(u32, [u32; 2], DVec3, u32)> = st.par_edges(|e| {
        let m = &st.mesh;
        if m.is_boundary_edge(e) || st.line_of(e).is_some() || m.edge_has_flag(e, EDGE_FROZEN) {
            return None;
        }
        let [a, b] = m.edge_vertices(e);
        let (na, nb) = (
            st.input_normals[st.hint_face[a.idx()] as usize],
            st.input_normals[st.hint_face[b.idx()] as usize],
        );
        if na.dot(nb) >= DEVIATION_NORMAL_COS {
            return None;
        }
        let mid = 0.5 * (m.position(a) + m.position(b));
        let tol = DEVIATION_FACTOR * st.edge_target(a, b);
        let cp = st.closest_on_part(mid, st.hint_face[a.idx()])?;
        (cp.distance_squared > tol * tol).then_some((e.0, [a.0, b.0], cp.point, cp.face))
    });
    let mut count = 0u64;
    for (k, &(i, ends, p, face)) in candidates.iter().enumerate() {
        st.cancel.every(k as u64)?;
        let e = EdgeId(i);
        if st.mesh.is_edge_deleted(e) {
            continue;
        }
        let [a, b] = st.mesh.edge_vertices(e);
        if [a.0, b.0] != ends || !split_keeps_orientation(st, e, p) {
            continue;
        }
        let s = st.split(e, p, 0);
        st.hint_face[s.vertex.idx()] = face;
        count += 1;
    }
    Ok(count)
}

/// Whether splitting interior edge `e` with the new vertex at `p` leaves
/// each of the four new faces turned by less than 90° from the face it
/// replaces part of.
pub(super) fn split_keeps_orientation(st: &State, e: EdgeId, p: DVec3) -> bool {
    let m = &st.mesh;
    [e.halfedge(0), e.halfedge(1)].into_iter().all(|h| {
        let (a, b) = (m.position(m.from_vertex(h)), m.position(m.to_vertex(h)));
        let c = m.position(m.to_vertex(m.next(h)));
        let n = triangle_cross([a, b, c]);
        n.dot(triangle_cross([a, p, c])) > 0.0 && n.dot(triangle_cross([p, b, c])) > 0.0
    })
}
