//! Pass 1: split every edge longer than 4/3 of its target length at its
//! midpoint. A feature edge's new vertex is placed on the input's feature
//! line, so creases and boundaries are resampled without drifting.

use super::state::{State, SPLIT_FACTOR};
use super::RemeshError;
use crate::mesh::{EdgeId, Handle};

/// Splits long edges until none is left; returns the number of splits.
pub(super) fn split_long_edges(
    st: &mut State,
    cancelled: &dyn Fn() -> bool,
) -> Result<u64, RemeshError> {
    let mut count = 0u64;
    let mut i = 0u32;
    while (i as usize) < st.mesh.edge_capacity() {
        let e = EdgeId(i);
        if st.mesh.is_edge_deleted(e) {
            i += 1;
            continue;
        }
        let [a, b] = st.mesh.edge_vertices(e);
        let (pa, pb) = (st.mesh.position(a), st.mesh.position(b));
        let len = pa.distance(pb);
        let limit = SPLIT_FACTOR * st.edge_target(a, b);
        if len <= limit {
            i += 1;
            if i % 4096 == 0 && cancelled() {
                return Err(RemeshError::Cancelled);
            }
            continue;
        }
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
            // Keep the new vertex well inside the edge; a line that bends
            // sharply between a and b can pull the closest point to an end.
            if lp.point.distance(pa) > 0.25 * len && lp.point.distance(pb) > 0.25 * len {
                p = lp.point;
            }
        }
        st.split(e, p, seg);
        count += 1;
        // Re-examine `e` (now the first half) before moving on.
    }
    Ok(count)
}
