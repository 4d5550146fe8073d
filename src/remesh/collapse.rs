//! Pass 2: collapse every edge shorter than 4/5 of its target length.
//!
//! A collapse must pass, in order: the feature rules (corners never go; a
//! feature vertex only slides along its own line; a smooth vertex may fall
//! onto a feature vertex; an edge joining two feature vertices that is not
//! itself a feature is never collapsed), the topological guard
//! ([`crate::mesh::Mesh::can_collapse`]: link condition, boundary rules), the
//! length guard (no resulting edge longer than 4/3 of its target, or up to
//! [`VERY_SHORT_STRETCH`] times that for a smooth interior edge under half
//! its target, under uniform sizing), the shape guard (no face of the
//! one-ring flips or degenerates, and the one-ring's worst face, the two
//! removed faces included, does not get worse below [`COLLAPSE_MIN_QUALITY`](super::guards::COLLAPSE_MIN_QUALITY)) and
//! the deviation guard (the new one-ring passes within
//! [`DEVIATION_FACTOR`] times the target of where the removed vertex, and a
//! moved kept vertex, were: vertices lie on the input, so a collapse that
//! leaves one farther cuts the input there, as across the crest of a rounded
//! ridge that [`super::split::split_deviating_edges`] put a vertex on;
//! uniform sizing only). Both directions are tried and the one leaving the better worst
//! triangle wins.
//!
//! A second, valence-driven sweep ([`collapse_for_valence`]) runs after the
//! flips: it collapses an edge between two smooth interior vertices when that
//! lowers the flip pass's energy (the sum of squared valence deviations of
//! the two end points and the two opposite corners). Flips cannot remove a
//! pair of adjacent valence-5 vertices whose opposite corners have valence 7
//! (flipping makes it worse); merging the pair can. These collapses pass the
//! same guards, except that the length guard allows resulting edges up to
//! [`VALENCE_COLLAPSE_STRETCH`] times the split length: the merged vertex's
//! ring spans two old rings, and the next relaxation evens the lengths out.

use glam::DVec3;
use rayon::prelude::*;

use super::flip::Valences;
use super::guards::{COLLAPSE_MAX_NORMAL_TURN_COS, COLLAPSE_MIN_QUALITY};
use super::split::DEVIATION_FACTOR;
use super::state::{State, COLLAPSE_FACTOR, CORNER, SMOOTH, SPLIT_FACTOR};
use super::RemeshError;
use crate::bvh::closest_point_on_triangle;
use crate::geometry::{triangle_cross, triangle_quality};
use crate::mesh::{EdgeId, FaceId, HalfedgeId, Handle, VertexId};

/// A collapse may not create a vertex with more edges than this. Besides
/// keeping valences near 6, this bounds the cost of every check around the
/// high-valence fan centres that CAD tessellations contain.
const MAX_VALENCE_AFTER: usize = 12;
/// A valence-driven collapse may leave edges up to this factor times the
/// split length (4/3 of the target), about 1.47 times the target. At 1 almost
/// every candidate is refused; 1.1 keeps the edge-length band (relaxation
/// shortens them again) while most candidates pass.
const VALENCE_COLLAPSE_STRETCH: f64 = 1.1;
/// A smooth interior edge shorter than this fraction of its target, with
/// no feature or boundary vertex around it, may collapse leaving edges up to
/// [`VERY_SHORT_STRETCH`] times the split length (uniform sizing).
const VERY_SHORT: f64 = 0.5;
/// How far the length guard stretches for a [`VERY_SHORT`] edge (up to
/// about 1.53 times the target), so that rows of short edges between long
/// ones merge instead of surviving as needles; left out near features,
/// whose narrow sectors it would squeeze. Measurements: `docs/tuning.md`.
const VERY_SHORT_STRETCH: f64 = 1.15;

/// Collapses short edges in one sweep; returns the number of collapses.
pub(super) fn collapse_short_edges(st: &mut State) -> Result<u64, RemeshError> {
    let mut count = 0u64;
    // Find the short edges in parallel (a pure scan), then collapse them in
    // index order, re-checking each one, so the result stays deterministic.
    let candidates: Vec<u32> = st.par_edges(|e| {
        let [a, b] = st.mesh.edge_vertices(e);
        (st.mesh.position(a).distance(st.mesh.position(b))
            < COLLAPSE_FACTOR * st.collapse_target(a, b))
        .then_some(e.0)
    });
    for (k, &i) in candidates.iter().enumerate() {
        st.cancel.every(k as u64)?;
        let e = EdgeId(i);
        if st.mesh.is_edge_deleted(e) {
            continue;
        }
        let [a, b] = st.mesh.edge_vertices(e);
        let len = st.mesh.position(a).distance(st.mesh.position(b));
        if len >= COLLAPSE_FACTOR * st.collapse_target(a, b) {
            continue;
        }
        let mut best: Option<(f64, HalfedgeId, DVec3)> = None;
        // Between two smooth interior vertices both directions give the same
        // midpoint and the same one-ring: one test decides.
        let symmetric = st.kind[a.idx()] == SMOOTH
            && st.kind[b.idx()] == SMOOTH
            && !st.mesh.is_boundary_edge(e);
        // Only there may a very short edge stretch the length guard (a
        // feature vertex that stays put would pull its new edges longer),
        // and only under uniform sizing, whose target is a shape goal: an
        // adaptive target bounds the chord error, which grows with the
        // square of the length (1.15² ≈ 1.32).
        let stretch = if symmetric
            && st.uniform.is_some()
            && len < VERY_SHORT * st.collapse_target(a, b)
            && away_from_features(st, a, b)
        {
            VERY_SHORT_STRETCH
        } else {
            1.0
        };
        for k in 0..if symmetric { 1 } else { 2 } {
            let h = e.halfedge(k);
            if let Some(p) = allowed_position(st, h) {
                if !valence_ok(st, h) || !st.mesh.can_collapse(h) {
                    continue;
                }
                if let Some(q) = collapse_quality(st, h, p, stretch) {
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

/// Collapses `h` (removing its source) under this pass's guards, with no
/// length stretch, when `accept` also holds for the faces around the kept
/// vertex as they would be: the kept vertex (first corner of each face) at
/// the collapse position, each with the face it replaces. Returns the kept
/// vertex.
pub(super) fn collapse_guarded(
    st: &mut State,
    h: HalfedgeId,
    accept: impl Fn(&State, VertexId, DVec3, &[([VertexId; 3], FaceId)]) -> bool,
) -> Option<VertexId> {
    let p = allowed_position(st, h)?;
    if !valence_ok(st, h) || !st.mesh.can_collapse(h) {
        return None;
    }
    collapse_quality(st, h, p, 1.0)?;
    let m = &st.mesh;
    let (v0, v1) = (m.from_vertex(h), m.to_vertex(h));
    let removed = [m.face(h), m.face(h.twin())];
    let moved = p != m.position(v1);
    let mut faces = Vec::new();
    for v in [v0, v1] {
        if v == v1 && !moved {
            continue;
        }
        for g in m.outgoing(v) {
            let f = m.face(g);
            if f.is_valid() && !removed.contains(&f) {
                faces.push(([v1, m.to_vertex(g), m.to_vertex(m.next(g))], f));
            }
        }
    }
    if !accept(st, v1, p, &faces) {
        return None;
    }
    let r = st.collapse(h, p);
    st.size[r.kept.idx()] = st.size[r.kept.idx()].min(st.size[r.removed.idx()]);
    Some(r.kept)
}

/// Whether no neighbour of `a` or `b` is a feature or boundary vertex.
fn away_from_features(st: &State, a: VertexId, b: VertexId) -> bool {
    let m = &st.mesh;
    [a, b].into_iter().all(|v| {
        m.outgoing(v).all(|g| {
            let w = m.to_vertex(g);
            st.kind[w.idx()] == SMOOTH && !m.is_boundary_vertex(w)
        })
    })
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
/// kept vertex at `p`, or `None` if a guard fails. Resulting edges may be
/// up to `stretch` times the split length.
fn collapse_quality(st: &State, h: HalfedgeId, p: DVec3, stretch: f64) -> Option<f64> {
    let m = &st.mesh;
    let v0 = m.from_vertex(h);
    let v1 = m.to_vertex(h);
    let moved_v1 = p != m.position(v1);
    let removed = [m.face(h), m.face(h.twin())];
    let mut worst = f64::INFINITY;
    let size_after = st.size[v1.idx()].min(st.size[v0.idx()]);
    // How close the new fan comes to the old positions of the removed vertex
    // and (when it moves) the kept one; see the deviation guard in the module docs.
    let (p0, p1) = (m.position(v0), m.position(v1));
    // Uniform sizing only, like the deviation split.
    let guard = st.uniform.is_some();
    let tol = DEVIATION_FACTOR * 0.5 * (st.size[v0.idx()] + st.size[v1.idx()]);
    let tol2 = tol * tol;
    let mut near = [
        if guard { f64::INFINITY } else { 0.0 },
        if guard && moved_v1 {
            f64::INFINITY
        } else {
            0.0
        },
    ];
    for (v, other) in [(v0, v1), (v1, v0)] {
        if v == v1 && !moved_v1 {
            continue;
        }
        let pv = m.position(v);
        for g in m.outgoing(v) {
            let w = m.to_vertex(g);
            let pw = m.position(w);
            if w != other {
                let limit = stretch * SPLIT_FACTOR * 0.5 * (size_after + st.size[w.idx()]);
                if p.distance_squared(pw) > limit * limit {
                    return None;
                }
            }
            let f = m.face(g);
            if !f.is_valid() || removed.contains(&f) {
                continue;
            }
            // Face (v, w, x) in its own order; only the two removed faces
            // hold both ends of the edge, so only v moves to p.
            let x = m.to_vertex(m.next(g));
            let old = [pv, pw, m.position(x)];
            let new = [p, old[1], old[2]];
            let (n_old, n_new) = (triangle_cross(old), triangle_cross(new));
            let (l_old, l_new) = (n_old.length(), n_new.length());
            if l_new <= 0.0 || n_old.dot(n_new) <= COLLAPSE_MAX_NORMAL_TURN_COS * l_old * l_new {
                return None;
            }
            worst = worst.min(triangle_quality(new));
            for (d, q) in near.iter_mut().zip([p0, p1]) {
                // Once within the tolerance, a point needs no more faces.
                if *d > tol2 {
                    let (c, _) = closest_point_on_triangle(q, new[0], new[1], new[2]);
                    *d = d.min(c.distance_squared(q));
                }
            }
        }
    }
    if near.iter().any(|&d| d.is_finite() && d > tol2) {
        return None;
    }
    // The shape guard compares the worst face of the one-ring before (the
    // two faces that go away included) and after, not face by face: in a
    // field of needles (the skinny strips of a CAD tessellation after their
    // long edges are split) a collapse that removes the two worst faces
    // narrows some neighbour a little, and a per-face test then refused
    // nearly every collapse there. The faces before are scored only when the
    // guard can fail; the ring of the removed vertex holds both removed faces.
    // A kept face is read from `v` and a removed one in its own order (the
    // quality's rounding depends on the corner order; this is the order the
    // README's figures were measured with).
    if worst < COLLAPSE_MIN_QUALITY {
        let ring_worst = |v: VertexId| {
            m.outgoing(v)
                .filter(|&g| m.face(g).is_valid())
                .map(|g| {
                    let f = m.face(g);
                    if removed.contains(&f) {
                        triangle_quality(m.face_positions(f))
                    } else {
                        let (w, x) = (m.to_vertex(g), m.to_vertex(m.next(g)));
                        triangle_quality([m.position(v), m.position(w), m.position(x)])
                    }
                })
                .fold(f64::INFINITY, f64::min)
        };
        let mut before = ring_worst(v0);
        if moved_v1 {
            before = before.min(ring_worst(v1));
        }
        if worst < before {
            return None;
        }
    }
    Some(worst)
}

/// Valence (capped at 16: past that a vertex fails [`valence_ok`] anyway)
/// and valence target (4 on the boundary, 6 elsewhere) of a vertex, read
/// off the iteration's valence table.
#[derive(Clone, Copy)]
struct Regularity {
    valence: i32,
    target: i32,
}

fn regularity(valences: &Valences, v: VertexId) -> Regularity {
    Regularity {
        valence: valences.valence[v.idx()].min(16),
        target: valences.target[v.idx()],
    }
}

/// The drop in valence energy (sum of squared deviations from the targets
/// over the end points and opposite corners) if interior edge `e` between
/// two smooth interior vertices were collapsed; `None` for any other edge.
/// `valences` must be current.
fn valence_collapse_gain(st: &State, e: EdgeId, valences: &Valences) -> Option<i32> {
    let m = &st.mesh;
    if m.is_edge_deleted(e) || m.is_boundary_edge(e) {
        return None;
    }
    let h = e.halfedge(0);
    let o = h.twin();
    let (a, b) = (m.to_vertex(o), m.to_vertex(h));
    if st.kind[a.idx()] != SMOOTH || st.kind[b.idx()] != SMOOTH {
        return None;
    }
    let (ra, rb) = (regularity(valences, a), regularity(valences, b));
    if ra.target != 6 || rb.target != 6 {
        return None;
    }
    let (rc, rd) = (
        regularity(valences, m.to_vertex(m.next(h))),
        regularity(valences, m.to_vertex(m.next(o))),
    );
    let sq = |x: i32| x * x;
    let before = sq(ra.valence - 6)
        + sq(rb.valence - 6)
        + sq(rc.valence - rc.target)
        + sq(rd.valence - rd.target);
    // The merged vertex keeps both rings minus the edge and the two merged pairs.
    let after = sq(ra.valence + rb.valence - 4 - 6)
        + sq(rc.valence - 1 - rc.target)
        + sq(rd.valence - 1 - rd.target);
    Some(before - after)
}

/// Collapses, in index order, every edge whose collapse lowers the valence
/// energy (see the module docs), at its midpoint and under the length-pass
/// guards. Returns the number of collapses and the edges at the vertices
/// whose valence changed (ascending), for a following flip sweep.
pub(super) fn collapse_for_valence(
    st: &mut State,
    valences: &mut Valences,
) -> Result<(u64, Vec<u32>), RemeshError> {
    // Candidates from the valences at the start, found in parallel.
    let candidates: Vec<u32> = {
        let (st_ref, table): (&State, &Valences) = (st, valences);
        st.pool.install(|| {
            (0..st_ref.mesh.edge_capacity() as u32)
                .into_par_iter()
                .filter(|&i| valence_collapse_gain(st_ref, EdgeId(i), table).is_some_and(|g| g > 0))
                .collect()
        })
    };
    let mut count = 0u64;
    let mut touched: Vec<u32> = Vec::new();
    for (k, &i) in candidates.iter().enumerate() {
        st.cancel.every(k as u64)?;
        // Earlier collapses change valences nearby: check again.
        let e = EdgeId(i);
        if valence_collapse_gain(st, e, valences).is_none_or(|g| g <= 0) {
            continue;
        }
        let h = e.halfedge(0);
        let [a, b] = st.mesh.edge_vertices(e);
        let p = 0.5 * (st.mesh.position(a) + st.mesh.position(b));
        if !valence_ok(st, h)
            || !st.mesh.can_collapse(h)
            || collapse_quality(st, h, p, VALENCE_COLLAPSE_STRETCH).is_none()
        {
            continue;
        }
        let c = st.mesh.to_vertex(st.mesh.next(h));
        let d = st.mesh.to_vertex(st.mesh.next(h.twin()));
        let r = st.collapse(h, p);
        let (kept, removed) = (r.kept.idx(), r.removed.idx());
        st.size[kept] = st.size[kept].min(st.size[removed]);
        count += 1;
        // An interior collapse: c and d each lose the edge to the removed
        // vertex, which merges with their edge to the kept one.
        valences.valence[kept] = st.mesh.valence(r.kept) as i32;
        valences.valence[removed] = 0;
        valences.target[removed] = 6;
        valences.valence[c.idx()] -= 1;
        valences.valence[d.idx()] -= 1;
        for v in [r.kept, c, d] {
            touched.extend(st.mesh.outgoing(v).map(|g| g.edge().0));
        }
    }
    // Edges removed by later collapses stay listed; the flip pass skips them.
    touched.sort_unstable();
    touched.dedup();
    Ok((count, touched))
}
