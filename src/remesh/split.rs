//! Pass 1: split every edge longer than 4/3 of its target length at its
//! midpoint, longest first (as CGAL does). Longest-first order is Rivara's
//! longest-edge bisection: on needle-shaped input (CAD tessellations) it
//! refines without the explosion of new long spokes that index order causes.
//! A feature edge's new vertex is placed on the input's feature line, so
//! creases and boundaries are resampled without drifting.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use rayon::prelude::*;

use super::state::{State, SPLIT_FACTOR};
use super::RemeshError;
use crate::mesh::{EdgeId, Handle};

/// How much longer than its split limit edge `e` is (> 1 means split it).
fn excess(st: &State, e: EdgeId) -> f64 {
    let [a, b] = st.mesh.edge_vertices(e);
    let len = st.mesh.position(a).distance(st.mesh.position(b));
    len / (SPLIT_FACTOR * st.edge_target(a, b))
}

/// Splits long edges until none is left; returns the number of splits.
pub(super) fn split_long_edges(
    st: &mut State,
    cancelled: &dyn Fn() -> bool,
) -> Result<u64, RemeshError> {
    // Max-heap on the excess ratio (positive floats order like their bits);
    // ties go to the lower edge index, so the order is deterministic.
    // The long edges are found in parallel; the heap is built in O(n).
    let long: Vec<(u64, Reverse<u32>)> = {
        let st_ref: &State = st;
        let m = &st.mesh;
        st.pool.install(|| {
            (0..m.edge_capacity() as u32)
                .into_par_iter()
                .filter_map(|i| {
                    let e = EdgeId(i);
                    if m.is_edge_deleted(e) {
                        return None;
                    }
                    let r = excess(st_ref, e);
                    (r > 1.0).then_some((r.to_bits(), Reverse(i)))
                })
                .collect()
        })
    };
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
        if count % 4096 == 0 && cancelled() {
            return Err(RemeshError::Cancelled);
        }
    }
    Ok(count)
}
