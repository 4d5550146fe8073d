//! Pass 2: collapse every edge shorter than 4/5 of its target length.
//!
//! A collapse must pass, in order: the feature rules (corners never go; a
//! feature vertex only slides along its own line; a smooth vertex may fall
//! onto a feature vertex; an edge joining two feature vertices that is not
//! itself a feature is never collapsed), the topological guard
//! ([`crate::mesh::Mesh::can_collapse`]: link condition, boundary rules), the
//! length guard (no resulting edge longer than 4/3 of its target), and the
//! shape guard (no face of the one-ring flips, degenerates or becomes a
//! needle). Both directions are tried and the one leaving the better worst
//! triangle wins.

use glam::DVec3;
use rayon::prelude::*;

use super::state::{State, COLLAPSE_FACTOR, CORNER, SMOOTH, SPLIT_FACTOR};
use super::RemeshError;
use crate::geometry::{triangle_cross, triangle_quality};
use crate::mesh::{EdgeId, HalfedgeId, Handle};

/// Largest normal change of a one-ring face caused by a collapse, as a cosine (≈ 45°).
const MAX_NORMAL_CHANGE_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;
/// A collapse may not leave a face with quality below this unless the face was already worse.
const MIN_QUALITY: f64 = 0.2;
/// A collapse may not create a vertex with more edges than this. Besides
/// keeping valences near 6, this bounds the cost of every check around the
/// high-valence fan centres that CAD tessellations contain.
const MAX_VALENCE_AFTER: usize = 12;

/// Collapses short edges in one sweep; returns the number of collapses.
pub(super) fn collapse_short_edges(
    st: &mut State,
    cancelled: &dyn Fn() -> bool,
) -> Result<u64, RemeshError> {
    let mut count = 0u64;
    // Find the short edges in parallel (a pure scan), then collapse them in
    // index order, re-checking each one, so the result stays deterministic.
    let candidates: Vec<u32> = {
        let m = &st.mesh;
        let st_ref: &State = st;
        st.pool.install(|| {
            (0..m.edge_capacity() as u32)
                .into_par_iter()
                .filter(|&i| {
                    let e = EdgeId(i);
                    if m.is_edge_deleted(e) {
                        return false;
                    }
                    let [a, b] = m.edge_vertices(e);
                    m.position(a).distance(m.position(b))
                        < COLLAPSE_FACTOR * st_ref.edge_target(a, b)
                })
                .collect()
        })
    };
    for (k, &i) in candidates.iter().enumerate() {
        if k % 4096 == 0 && cancelled() {
            return Err(RemeshError::Cancelled);
        }
        let e = EdgeId(i);
        if st.mesh.is_edge_deleted(e) {
            continue;
        }
        let [a, b] = st.mesh.edge_vertices(e);
        let len = st.mesh.position(a).distance(st.mesh.position(b));
        if len >= COLLAPSE_FACTOR * st.edge_target(a, b) {
            continue;
        }
        let mut best: Option<(f64, HalfedgeId, DVec3)> = None;
        for k in 0..2 {
            let h = e.halfedge(k);
            if let Some(p) = allowed_position(st, h) {
                if !valence_ok(st, h) || !st.mesh.can_collapse(h) {
                    continue;
                }
                if let Some(q) = collapse_quality(st, h, p) {
                    if best.is_none_or(|(bq, _, _)| q > bq) {
                        best = Some((q, h, p));
                    }
                }
            }
        }
        if let Some((_, h, p)) = best {
            let r = st.collapse(h, p);
            let kept = r.kept.idx();
            let removed = r.removed.idx();
            // The kept vertex inherits the smaller target so sizes do not drift up.
            st.size[kept] = st.size[kept].min(st.size[removed]);
            count += 1;
        }
    }
    Ok(count)
}

/// Whether the merged vertex stays at most [`MAX_VALENCE_AFTER`]; counts
/// stop early, so a fan centre costs O(1).
fn valence_ok(st: &State, h: HalfedgeId) -> bool {
    let m = &st.mesh;
    let cap = MAX_VALENCE_AFTER + 4;
    let v0 = m.outgoing(m.from_vertex(h)).take(cap).count();
    let v1 = m.outgoing(m.to_vertex(h)).take(cap).count();
    // The edge itself and the two merged pairs disappear (one fewer per boundary side).
    let shared = if m.is_boundary_edge(h.edge()) { 3 } else { 4 };
    v0 + v1 <= MAX_VALENCE_AFTER + shared
}

/// The feature rules: where the kept vertex goes if `h` (removing its
/// source) may collapse at all.
fn allowed_position(st: &State, h: HalfedgeId) -> Option<DVec3> {
    let v0 = st.mesh.from_vertex(h);
    let v1 = st.mesh.to_vertex(h);
    let (k0, k1) = (st.kind[v0.idx()], st.kind[v1.idx()]);
    let (p0, p1) = (st.mesh.position(v0), st.mesh.position(v1));
    match k0 {
        CORNER => None,
        SMOOTH => Some(if k1 == SMOOTH { 0.5 * (p0 + p1) } else { p1 }),
        line => {
            // v0 slides along its own line only: the edge must be a segment of it.
            if st.line_of(h.edge()) != Some(line) {
                return None;
            }
            Some(if k1 == line { 0.5 * (p0 + p1) } else { p1 })
        }
    }
}

/// The worst quality of the one-ring faces after collapsing `h` with the
/// kept vertex at `p`, or `None` if a guard fails.
fn collapse_quality(st: &State, h: HalfedgeId, p: DVec3) -> Option<f64> {
    let m = &st.mesh;
    let v0 = m.from_vertex(h);
    let v1 = m.to_vertex(h);
    let moved_v1 = p != m.position(v1);
    let removed = [m.face(h), m.face(h.twin())];
    let mut worst = f64::INFINITY;
    let size_after = st.size[v1.idx()].min(st.size[v0.idx()]);
    for (v, other) in [(v0, v1), (v1, v0)] {
        if v == v1 && !moved_v1 {
            continue;
        }
        for g in m.outgoing(v) {
            let w = m.to_vertex(g);
            if w != other {
                let limit = SPLIT_FACTOR * 0.5 * (size_after + st.size[w.idx()]);
                if p.distance_squared(m.position(w)) > limit * limit {
                    return None;
                }
            }
            let f = m.face(g);
            if !f.is_valid() || removed.contains(&f) {
                continue;
            }
            let old = m.face_positions(f);
            let mut new = old;
            for (k, c) in m.face_vertices(f).iter().enumerate() {
                if *c == v0 || *c == v1 {
                    new[k] = p;
                }
            }
            let (n_old, n_new) = (triangle_cross(old), triangle_cross(new));
            let (l_old, l_new) = (n_old.length(), n_new.length());
            if l_new <= 0.0 || n_old.dot(n_new) <= MAX_NORMAL_CHANGE_COS * l_old * l_new {
                return None;
            }
            let q_new = triangle_quality(new);
            if q_new < MIN_QUALITY && q_new < triangle_quality(old) {
                return None;
            }
            worst = worst.min(q_new);
        }
    }
    Some(worst)
}
