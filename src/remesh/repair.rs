//! The sliver repair after the last iteration: triangles whose smallest
//! angle is still below 30° get their longest edge flipped when that raises
//! the pair's smallest angle, whatever the valence ([`repair_slivers`]),
//! and their vertices moved to where their one-ring's smallest angle is
//! largest ([`improve_slivers`]), then flipped once more. The flips take
//! the flip pass's guards, plus a thin-tetrahedron exception
//! ([`sliver_geometry_ok`]); the moves take the guarded move's thresholds.
//! Both walk faces in index order, so the result is deterministic.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;
use rayon::prelude::*;

use super::flip::{geometry_ok, quad, quad_triangles, MAX_SWEEPS};
use super::guards::{
    MOVE_MAX_NORMAL_TURN_COS, MOVE_MIN_QUALITY, SHAPE_BAND_SLACK, SHAPE_ROUNDS, SLIVER_ANGLE_COS,
    SLIVER_SAG,
};
use super::relax::{settle, walk_closest};
use super::state::{State, COLLAPSE_FACTOR, CORNER, SMOOTH, SPLIT_FACTOR};
use super::RemeshError;
use crate::geometry::{triangle_cross, triangle_min_angle_cos, triangle_quality};
use crate::mesh::{EdgeId, FaceId, Handle, VertexId, EDGE_FROZEN};

/// The sliver repair after the last iteration: flips, shape moves, and
/// flips again around what the moves changed. Returns (flips, moves).
pub(super) fn final_repair(st: &mut State) -> Result<(u64, u64), RemeshError> {
    let first = repair_slivers(st)?;
    let moves = improve_slivers(st)?;
    Ok((first + repair_slivers(st)?, moves))
}

/// Final sweep after the last iteration: a triangle whose smallest angle is
/// below 30° gets its longest edge flipped when that raises the
/// smallest angle of the two faces, whatever it does to the valence (the
/// valence flips only accept shape repairs that keep the valence, and a
/// single obtuse triangle beside a feature line can survive them). The same
/// guards as every flip apply: no feature or boundary edge, nearly coplanar
/// faces, no fold, no worse quality. Faces are visited in index order, so
/// the result is deterministic. Returns the number of flips.
pub(super) fn repair_slivers(st: &mut State) -> Result<u64, RemeshError> {
    // Only a flip changes a face or the quad across its longest edge, so a
    // sweep visits the faces below 30° at the start and, after that, only
    // the faces of flipped quads and their neighbours, in index order (a
    // face queued behind the cursor waits for the next sweep): the same
    // visits that matter as a full scan, without the scan.
    let mut work: Vec<u32> = {
        let m = &st.mesh;
        st.pool.install(|| {
            (0..m.face_capacity() as u32)
                .into_par_iter()
                .filter(|&fi| {
                    let f = FaceId(fi);
                    !m.is_face_deleted(f)
                        && triangle_min_angle_cos(m.face_positions(f)) > SLIVER_ANGLE_COS
                })
                .collect()
        })
    };
    let mut in_heap = vec![false; st.mesh.face_capacity()];
    let mut in_next = vec![false; st.mesh.face_capacity()];
    let mut count = 0u64;
    let mut visited = 0u64;
    for _ in 0..MAX_SWEEPS {
        if work.is_empty() {
            break;
        }
        for &f in &work {
            in_next[f as usize] = false;
            in_heap[f as usize] = true;
        }
        let mut heap: BinaryHeap<Reverse<u32>> = work.iter().map(|&f| Reverse(f)).collect();
        let mut next: Vec<u32> = Vec::new();
        let mut flipped = 0u64;
        while let Some(Reverse(fi)) = heap.pop() {
            in_heap[fi as usize] = false;
            visited += 1;
            st.cancel.every(visited)?;
            let Some(e) = sliver_flip(st, FaceId(fi)) else {
                continue;
            };
            st.mesh.flip_edge(e);
            flipped += 1;
            let m = &st.mesh;
            let h = e.halfedge(0);
            for g in [h, h.twin()] {
                let mut k = g;
                for _ in 0..3 {
                    for f in [m.face(k), m.face(k.twin())] {
                        if !f.is_valid() {
                            continue;
                        }
                        let j = f.0;
                        if j > fi {
                            if !in_heap[j as usize] {
                                in_heap[j as usize] = true;
                                heap.push(Reverse(j));
                            }
                        } else if !in_next[j as usize] {
                            in_next[j as usize] = true;
                            next.push(j);
                        }
                    }
                    k = m.next(k);
                }
            }
        }
        count += flipped;
        if flipped == 0 {
            break;
        }
        next.sort_unstable();
        work = next;
    }
    Ok(count)
}

/// The edge to flip for face `f` in the sliver repair: its longest edge,
/// when `f` is below 30°, the edge may flip and the flip raises the pair's
/// smallest angle under the flip guards.
fn sliver_flip(st: &State, f: FaceId) -> Option<EdgeId> {
    let m = &st.mesh;
    if m.is_face_deleted(f) {
        return None;
    }
    let h0 = m.face_halfedge(f);
    let h1 = m.next(h0);
    let h2 = m.next(h1);
    let t = m.face_vertices(f).map(|v| m.position(v));
    if triangle_min_angle_cos(t) <= SLIVER_ANGLE_COS {
        return None;
    }
    // The edge opposite the largest angle, which is the longest edge:
    // corner 0 faces h1, 1 faces h2, 2 faces h0.
    let len = [
        t[1].distance_squared(t[2]),
        t[2].distance_squared(t[0]),
        t[0].distance_squared(t[1]),
    ];
    let k = (0..3).fold(0, |k, i| if len[i] > len[k] { i } else { k });
    let h = [h1, h2, h0][k];
    let e = h.edge();
    if st.line_of(e).is_some()
        || m.is_boundary_edge(e)
        || m.edge_has_flag(e, EDGE_FROZEN)
        || !m.can_flip(e)
    {
        return None;
    }
    let q = quad(m, h);
    let (old, new) = quad_triangles(m, q);
    // Cosine of the pair's smallest angle: lower is better.
    let worst = |t: [[DVec3; 3]; 2]| triangle_min_angle_cos(t[0]).max(triangle_min_angle_cos(t[1]));
    if worst(new) >= worst(old) - 1e-12 {
        return None;
    }
    let tol = SLIVER_SAG * st.edge_target(q[0], q[1]);
    (geometry_ok(old, new) || sliver_geometry_ok(old, new, tol)).then_some(e)
}

/// The sliver repair's own geometric guard, for pairs that fail the
/// dihedral test of [`geometry_ok`]. A cap (an angle near 180°) on a bend of
/// the surface has no reliable normal, so its dihedral angle with the face
/// across its long edge says nothing about the shape; on the bunny such a
/// cap, between a feature line and its chord, kept a 6° angle. What a flip
/// changes is the tetrahedron of the four vertices, whose thickness is the
/// distance between the old edge `ab` and the new edge `cd`: the flip is
/// allowed when that distance is at most `tol`, both new faces are
/// non-degenerate and face the side of the pair's area-weighted normal (the
/// cap, nearly flat, barely counts), and the new pair's worse face is no
/// worse in quality than the old pair's.
fn sliver_geometry_ok(old: [[DVec3; 3]; 2], new: [[DVec3; 3]; 2], tol: f64) -> bool {
    let n = triangle_cross(old[0]) + triangle_cross(old[1]);
    let (m1, m2) = (triangle_cross(new[0]), triangle_cross(new[1]));
    if m1.dot(n) <= 0.0 || m2.dot(n) <= 0.0 {
        return false;
    }
    let [a, b, c] = old[0];
    let d = old[1][2];
    let w = (b - a).cross(d - c);
    let wl = w.length();
    // Parallel edges cannot occur in a quad with both new faces facing `n`;
    // refuse rather than divide by nothing.
    if wl <= 0.0 || (c - a).dot(w).abs() > tol * wl {
        return false;
    }
    let q_old = triangle_quality(old[0]).min(triangle_quality(old[1]));
    let q_new = triangle_quality(new[0]).min(triangle_quality(new[1]));
    q_new >= q_old
}

/// Relaxation puts a vertex at the centroid of its ring, which is the wrong
/// place for the apex over a short edge that cannot go away (two corners of
/// the input close together, or a crease line passing near): the triangle
/// gets a sliver angle at the apex. The candidates are the apex of the
/// equilateral triangle over each bad face's opposite edge, and the points a
/// half and a quarter of the way there; a move is kept only if every ring
/// face stays non-degenerate, turns by less than 60° and faces the same way
/// as the input under the vertex, the ring's smallest angle grows, and at
/// most [`SHAPE_BAND_SLACK`] more of the vertex's edges leave the length band.
/// Vertices are visited in face order, so the result is deterministic.
/// Returns the number of vertices moved.
pub(super) fn improve_slivers(st: &mut State) -> Result<u64, RemeshError> {
    let mut moved = 0u64;
    // Each vertex is tried once per round; after the first round only the
    // vertices next to one that moved (their rings changed) are tried again.
    let nv = st.mesh.vertex_capacity();
    let mut dirty = vec![true; nv];
    for _ in 0..SHAPE_ROUNDS {
        let mut tried = vec![false; nv];
        let mut next = vec![false; nv];
        let before = moved;
        for fi in 0..st.mesh.face_capacity() as u32 {
            st.cancel.every(fi as u64)?;
            let f = FaceId(fi);
            if st.mesh.is_face_deleted(f) {
                continue;
            }
            let t = st.mesh.face_positions(f);
            if triangle_min_angle_cos(t) <= SLIVER_ANGLE_COS {
                continue;
            }
            for v in st.mesh.face_vertices(f) {
                if tried[v.idx()] || !dirty[v.idx()] {
                    continue;
                }
                tried[v.idx()] = true;
                let improved = match st.kind[v.idx()] {
                    CORNER => false,
                    SMOOTH => !st.mesh.is_boundary_vertex(v) && improve_vertex(st, v),
                    line => improve_line_vertex(st, v, line),
                };
                if improved {
                    moved += 1;
                    next[v.idx()] = true;
                    for h in st.mesh.outgoing(v) {
                        next[st.mesh.to_vertex(h).idx()] = true;
                    }
                }
            }
        }
        if moved == before {
            break;
        }
        dirty = next;
    }
    Ok(moved)
}

/// The one-ring of a vertex as it stands, against which the shape pass
/// scores candidate positions. A score is the ring's smallest angle as minus
/// its cosine (monotone in the angle, no `acos`).
pub(super) struct Probe {
    v: VertexId,
    /// The ring faces as (a, b) with (v, a, b) counter-clockwise.
    ring: Vec<(VertexId, VertexId)>,
    /// Their normals (unnormalised) with `v` where it is.
    normals: Vec<DVec3>,
    /// The score where `v` is.
    current: f64,
    /// Edges at `v` outside the length band where `v` is.
    out_of_band: usize,
}

impl Probe {
    /// The probe of `v`, or `None` when its ring already fails the checks
    /// (see [`Probe::score`]) where it is.
    pub(super) fn new(st: &State, v: VertexId, up: Option<DVec3>) -> Option<Self> {
        let m = &st.mesh;
        let p = m.position(v);
        let ring: Vec<(VertexId, VertexId)> = m
            .outgoing(v)
            .filter(|&h| !m.is_boundary_halfedge(h))
            .map(|h| (m.to_vertex(h), m.to_vertex(m.next(h))))
            .collect();
        let normals = ring
            .iter()
            .map(|&(a, b)| triangle_cross([p, m.position(a), m.position(b)]))
            .collect();
        let mut probe = Self {
            v,
            ring,
            normals,
            current: f64::NEG_INFINITY,
            out_of_band: out_of_band(st, v, p),
        };
        probe.current = probe.score(st, p, up)?;
        Some(probe)
    }

    /// The score with `v` at `p`, or `None` when a ring face degenerates,
    /// turns by 60° or more, or faces away from `up`.
    pub(super) fn score(&self, st: &State, p: DVec3, up: Option<DVec3>) -> Option<f64> {
        self.score_above(st, p, up, f64::NEG_INFINITY)
    }

    /// [`Probe::score`], or `None` as soon as one ring face scores `floor`
    /// or less (the move cannot beat a score of `floor`).
    fn score_above(&self, st: &State, p: DVec3, up: Option<DVec3>, floor: f64) -> Option<f64> {
        let m = &st.mesh;
        let mut worst = f64::INFINITY;
        for (&(a, b), &n0) in self.ring.iter().zip(&self.normals) {
            let t = [p, m.position(a), m.position(b)];
            let n = triangle_cross(t);
            let ln = n.length();
            if ln <= 0.0
                || n.dot(n0) <= MOVE_MAX_NORMAL_TURN_COS * ln * n0.length()
                || up.is_some_and(|u| n.dot(u) <= 0.0)
                || triangle_quality(t) < MOVE_MIN_QUALITY
            {
                return None;
            }
            worst = worst.min(-triangle_min_angle_cos(t));
            if worst <= floor {
                return None;
            }
        }
        Some(worst)
    }

    /// The score at `p` when it beats the current one and `beat` (the best
    /// candidate so far) and at most [`SHAPE_BAND_SLACK`] more edges leave
    /// the band.
    fn gain(&self, st: &State, p: DVec3, up: Option<DVec3>, beat: Option<f64>) -> Option<f64> {
        if out_of_band(st, self.v, p) > self.out_of_band + SHAPE_BAND_SLACK {
            return None;
        }
        let floor = self.current + 1e-9;
        self.score_above(st, p, up, beat.map_or(floor, |b| b.max(floor)))
    }
}

/// How many edges at `v` (placed at `p`) leave the band [4/5, 4/3] of their
/// target.
pub(super) fn out_of_band(st: &State, v: VertexId, p: DVec3) -> usize {
    let m = &st.mesh;
    m.outgoing(v)
        .filter(|&h| {
            let w = m.to_vertex(h);
            let l = p.distance(m.position(w)) / st.edge_target(v, w);
            !(COLLAPSE_FACTOR..=SPLIT_FACTOR).contains(&l)
        })
        .count()
}

fn improve_vertex(st: &mut State, v: VertexId) -> bool {
    let up = st.input_normals[st.hint_face[v.idx()] as usize];
    let Some(probe) = Probe::new(st, v, Some(up)) else {
        return false;
    };
    let m = &st.mesh;
    let p = m.position(v);
    let mut best: Option<(f64, DVec3)> = None;
    for &(a, b) in &probe.ring {
        let (pa, pb) = (m.position(a), m.position(b));
        if triangle_min_angle_cos([p, pa, pb]) <= SLIVER_ANGLE_COS {
            continue;
        }
        let ab = pb - pa;
        let mid = 0.5 * (pa + pb);
        let off = p - mid;
        let perp = (off - ab * (off.dot(ab) / ab.length_squared())).normalize_or_zero();
        if perp == DVec3::ZERO {
            continue;
        }
        let apex = mid + perp * (0.5 * 3f64.sqrt() * ab.length());
        for t in [1.0, 0.5, 0.25] {
            // Scored where it is, off the surface by a fraction of the
            // chord sag; only the winner pays for a projection.
            let q = p + t * (apex - p);
            if let Some(score) = probe.gain(st, q, Some(up), best.map(|b| b.0)) {
                best = Some((score, q));
            }
        }
    }
    let Some((_, q)) = best else {
        return false;
    };
    let Some(cp) = walk_closest(st, q, st.hint_face[v.idx()], st.size[v.idx()]) else {
        return false;
    };
    let up = st.input_normals[cp.face as usize];
    if probe.gain(st, cp.point, Some(up), None).is_none() {
        return false;
    }
    st.mesh.set_position(v, cp.point);
    settle(st, v, &cp);
    true
}

/// [`improve_vertex`] for a vertex on feature line `line`: it slides along
/// the line, toward either line neighbour by 15, 30 or 45 % of the way, and
/// is projected back onto the input's line. A vertex whose ring has faces
/// on both sides of a crease has no single "up" direction; the 60° turn
/// limit per face keeps the move from folding either side.
fn improve_line_vertex(st: &mut State, v: VertexId, line: u32) -> bool {
    let m = &st.mesh;
    let p = m.position(v);
    let neighbours: Vec<DVec3> = m
        .outgoing(v)
        .filter(|h| st.edge_line[h.edge().idx()] == line)
        .map(|h| m.position(m.to_vertex(h)))
        .collect();
    if neighbours.len() != 2 {
        return false;
    }
    let Some(probe) = Probe::new(st, v, None) else {
        return false;
    };
    let hint = st.hint_seg[v.idx()];
    let mut best: Option<(f64, DVec3, u32)> = None;
    for &n in &neighbours {
        for t in [0.15, 0.3, 0.45] {
            let lp = st
                .features
                .closest_on_line_near(line, p + t * (n - p), hint);
            if let Some(score) = probe.gain(st, lp.point, None, best.map(|b| b.0)) {
                best = Some((score, lp.point, lp.segment));
            }
        }
    }
    let Some((_, q, seg)) = best else {
        return false;
    };
    st.mesh.set_position(v, q);
    st.hint_seg[v.idx()] = seg;
    if let Some(cp) = st.closest_on_part(q, st.hint_face[v.idx()]) {
        settle(st, v, &cp);
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quad `ab` (the x-axis), `c` a cap apex bent up off the plane
    /// of the face across `ab`, `d` in that plane; old and new pairs as
    /// [`quad_triangles`] orders them.
    fn cap_pair(c: DVec3) -> ([[DVec3; 3]; 2], [[DVec3; 3]; 2]) {
        let (a, b, d) = (DVec3::ZERO, DVec3::X, DVec3::new(0.5, -0.8, 0.0));
        ([[a, b, c], [b, a, d]], [[c, a, d], [d, b, c]])
    }

    #[test]
    fn a_thin_cap_on_a_bend_may_flip_a_thick_one_may_not() {
        // 34° between the cap and its neighbour: the dihedral guard refuses,
        // but the new edge passes 0.019 from the old one.
        let (old, new) = cap_pair(DVec3::new(0.5, 0.03, 0.02));
        assert!(!geometry_ok(old, new));
        assert!(sliver_geometry_ok(old, new, 0.1));
        assert!(!sliver_geometry_ok(old, new, 0.01));
        // The same cap raised to 0.3: the flip would cut 0.27 off the shape.
        let (old, new) = cap_pair(DVec3::new(0.5, 0.03, 0.3));
        assert!(!sliver_geometry_ok(old, new, 0.1));
        // Folded under the neighbour's plane the other way round: the new
        // faces would face away from the pair.
        let (old, new) = cap_pair(DVec3::new(0.5, -0.9, 0.05));
        assert!(!sliver_geometry_ok(old, new, 10.0));
    }
}
