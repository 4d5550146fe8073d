//! Passes 4 and 5: tangential relaxation and projection onto the input,
//! sharing one guarded, parallel move.
//!
//! Relaxation moves each smooth vertex to the area-weighted centroid of its
//! one-ring, projected onto its tangent plane (Botsch & Kobbelt 2004), or,
//! where two of its ring faces meet at more than 60° (a rounded ridge with
//! no feature edge), onto the ridge direction only, so that it stays on
//! the crest that the deviation split put it on (uniform sizing only, like
//! the split; adaptive sizing refines such crests itself); a
//! feature-line vertex moves only along its line, toward the midpoint of its
//! two line neighbours; corners stay. Projection sends smooth vertices to
//! their closest point on the input surface (BVH query seeded with the face
//! found last time) and line vertices to their closest point on their own
//! input feature line; corners keep their exact input position.
//!
//! Both compute every target from the old positions (a Jacobi step, so the
//! result does not depend on the thread count), then apply the moves: a move
//! that would invert, degenerate or turn a face away from the input is
//! halved, up to five times, and then dropped. With both passes on, each
//! vertex's relaxed point is projected first and the vertex makes a single
//! guarded move there: one check of the mesh per step instead of two.
//!
//! The sliver repair after the last iteration (`repair.rs`) moves vertices
//! one at a time under the same guard thresholds.

use glam::DVec3;
use rayon::prelude::*;

use super::guards::{MOVE_MAX_NORMAL_TURN_COS, MOVE_MIN_QUALITY};
use super::state::{State, CORNER, SMOOTH};
use crate::bvh::{closest_point_on_triangle, ClosestPoint};
use crate::geometry::{triangle_cross, triangle_quality};
use crate::mesh::{FaceId, Handle, VertexId};

/// How often a guarded move is halved before it is dropped.
const MAX_HALVINGS: u32 = 5;
/// 2·√3: quality q = 2·√3·|cross| / Σ edge².
const SQRT_12: f64 = 3.464_101_615_137_754_6;
/// Ring faces whose normals [`ridge_direction`] compares, at most: the
/// largest valence the collapses create (`docs/tuning.md`).
const RIDGE_RING: usize = 12;
/// Two ring face normals further apart than this (60°), as a cosine, make
/// a vertex a ridge vertex that relaxes only along the ridge. At 40° the
/// constraint also catches the folds of scans and costs triangle shape; at
/// 80° it misses rounded ridges.
const RIDGE_NORMAL_COS: f64 = 0.5;
/// Cosine of 30° (half of [`RIDGE_NORMAL_COS`]'s angle), raised by about
/// 1e-9 so that rounding cannot let a pair pass the half-angle test and
/// fail the full one: ring normals all this close to their mean are never
/// a ridge, and the pairwise test is skipped.
const RIDGE_HALF_COS: f64 = 0.866_025_405;
/// Face-to-face steps of the projection walk before it gives up and asks
/// the BVH.
const WALK_STEPS: usize = 16;

/// Where a vertex projects: the point, the new face and segment hints, and
/// the surface face and barycentric coordinates under it (for sizing).
type Projected = (DVec3, u32, u32, Option<(u32, DVec3)>);

/// One step of tangential relaxation; returns the number of limited moves.
pub(super) fn relax_tangentially(st: &mut State) -> u64 {
    let targets = relax_targets(st);
    guarded_move(st, &targets, false)
}

/// The direction of a rounded ridge through a smooth vertex, from the unit
/// normals of its ring faces: when two of them are more than
/// [`RIDGE_NORMAL_COS`] apart, the ring folds over a crest (or into a
/// valley) that runs along their cross product. Relaxing across it would
/// slide the vertex off the crest, and the edges over it would then cut the
/// input (a crest without a feature edge has no line to keep it).
///
/// When every normal lies within 30° of `mean` (the ring's unit normal),
/// every pair lies within 60°: no ridge, without the pairwise test.
fn ridge_direction(normals: &[DVec3], mean: DVec3) -> Option<DVec3> {
    if normals.iter().all(|a| a.dot(mean) >= RIDGE_HALF_COS) {
        return None;
    }
    let mut worst = (RIDGE_NORMAL_COS, DVec3::ZERO);
    for (i, a) in normals.iter().enumerate() {
        for b in &normals[i + 1..] {
            let c = a.dot(*b);
            if c < worst.0 {
                worst = (c, a.cross(*b));
            }
        }
    }
    let t = worst.1.normalize_or_zero();
    (t != DVec3::ZERO).then_some(t)
}

/// Where relaxation sends every vertex (see the module docs).
pub(super) fn relax_targets(st: &State) -> Vec<DVec3> {
    let m = &st.mesh;
    let kind = &st.kind;
    let edge_line = &st.edge_line;
    let size = &st.size;
    let adaptive = st.sizing.is_some();
    let ridges = st.uniform.is_some();
    let targets: Vec<DVec3> = st.pool.install(|| {
        (0..m.vertex_capacity() as u32)
            .into_par_iter()
            .map(|i| {
                let v = VertexId(i);
                let p = m.position(v);
                if m.is_vertex_deleted(v) || m.is_isolated(v) {
                    return p;
                }
                match kind[v.idx()] {
                    CORNER => p,
                    SMOOTH => {
                        // Area-weighted centroid of the one-ring faces; under
                        // adaptive sizing each face is weighted by area / h²
                        // so vertices drift toward small targets (as CGAL does).
                        let mut sum = DVec3::ZERO;
                        let mut wsum = 0.0;
                        let mut normal = DVec3::ZERO;
                        let mut normals = [DVec3::ZERO; RIDGE_RING];
                        let mut k = 0;
                        for h in m.outgoing(v) {
                            if !m.face(h).is_valid() {
                                continue;
                            }
                            // The face (v, a, b) read off the ring.
                            let (a, b) = (m.to_vertex(h), m.to_vertex(m.next(h)));
                            let tri = [p, m.position(a), m.position(b)];
                            let cross = triangle_cross(tri);
                            normal += cross;
                            if k < RIDGE_RING {
                                normals[k] = cross.normalize_or_zero();
                                k += 1;
                            }
                            let mut w = cross.length();
                            if adaptive {
                                let hf = (size[i as usize] + size[a.idx()] + size[b.idx()]) / 3.0;
                                w /= hf * hf;
                            }
                            sum += w * (tri[0] + tri[1] + tri[2]) / 3.0;
                            wsum += w;
                        }
                        let n = normal.normalize_or_zero();
                        if wsum <= 0.0 || n == DVec3::ZERO {
                            return p;
                        }
                        let c = sum / wsum;
                        let d = c - p;
                        match ridge_direction(&normals[..if ridges { k } else { 0 }], n) {
                            // On a rounded ridge: slide along it only.
                            Some(t) => p + t * t.dot(d),
                            None => p + d - n * n.dot(d),
                        }
                    }
                    line => {
                        // Slide along the line toward the midpoint of the two
                        // neighbours on the same line.
                        let mut nb = [DVec3::ZERO; 2];
                        let mut k = 0;
                        for h in m.outgoing(v) {
                            if edge_line[h.edge().idx()] == line {
                                if k < 2 {
                                    nb[k] = m.position(m.to_vertex(h));
                                }
                                k += 1;
                            }
                        }
                        if k != 2 {
                            return p;
                        }
                        let t = (nb[1] - nb[0]).normalize_or_zero();
                        let mid = 0.5 * (nb[0] + nb[1]);
                        p + t * t.dot(mid - p)
                    }
                }
            })
            .collect()
    });
    targets
}

/// Projects every vertex onto the input; returns the number of limited moves.
pub(super) fn project_to_input(st: &mut State) -> u64 {
    let from = st.mesh.positions().to_vec();
    project_points(st, &from)
}

/// Moves every vertex to the projection onto the input of its point in
/// `from` (a guarded move from its current position), updating the hints and
/// sizes. Returns the number of limited moves.
pub(super) fn project_points(st: &mut State, from: &[DVec3]) -> u64 {
    let m = &st.mesh;
    let kind = &st.kind;
    let features = &st.features;
    let hint_face = &st.hint_face;
    let hint_seg = &st.hint_seg;
    let size = &st.size;
    let st_ref: &State = st;
    let results: Vec<Projected> = st.pool.install(|| {
        (0..m.vertex_capacity() as u32)
            .into_par_iter()
            .map(|i| {
                let v = VertexId(i);
                let p = from[i as usize];
                let (hf, hs) = (hint_face[i as usize], hint_seg[i as usize]);
                if m.is_vertex_deleted(v) || m.is_isolated(v) {
                    return (p, hf, hs, None);
                }
                match kind[v.idx()] {
                    CORNER => (p, hf, hs, None),
                    SMOOTH => match walk_closest(st_ref, p, hf, size[i as usize]) {
                        Some(cp) => (cp.point, cp.face, hs, Some((cp.face, cp.barycentric))),
                        None => (p, hf, hs, None),
                    },
                    line => {
                        let lp = features.closest_on_line_near(line, p, hs);
                        // The surface face under the line point, for sizing and the orientation check.
                        let face = st_ref
                            .closest_on_part(lp.point, hf)
                            .map(|cp| (cp.face, cp.barycentric));
                        (lp.point, face.map_or(hf, |f| f.0), lp.segment, face)
                    }
                }
            })
            .collect()
    });
    let targets: Vec<DVec3> = results.iter().map(|r| r.0).collect();
    for (i, r) in results.iter().enumerate() {
        st.hint_face[i] = r.1;
        st.hint_seg[i] = r.2;
    }
    if let Some(field) = &st.sizing {
        for (i, r) in results.iter().enumerate() {
            if let Some((f, bary)) = r.3 {
                st.size[i] = field.size_at(f, bary);
            }
        }
    }
    guarded_move(st, &targets, true)
}

/// Closest point on the input from a hint face: walk from face to face
/// while that gets closer, and fall back to the global BVH query, bounded by
/// the walk's result, when the point is not close to the surface relative to
/// the local target size or the walk does not settle.
///
/// Each step tries the three faces across the current face's edges (which
/// also catches a closer face folded up toward the point in a concave
/// region) and, when the closest point is a corner of the current face, the
/// faces around that corner. Vertices move little between iterations, so the
/// walk usually ends after one or two steps of three or four triangle tests.
pub(super) fn walk_closest(st: &State, p: DVec3, hint: u32, size: f64) -> Option<ClosestPoint> {
    let tris = st.index.triangles();
    let pos = st.index.positions();
    if hint as usize >= tris.len() {
        return st.index.closest_point(p);
    }
    // The walk stays on the hint's part, as the fallback query does.
    let part = st
        .face_part
        .as_deref()
        .map(|parts| (parts, parts[hint as usize]));
    let off_part = |g: u32| part.is_some_and(|(parts, p)| parts[g as usize] != p);
    let eval = |f: u32| {
        let [a, b, c] = tris[f as usize];
        let (q, bary) =
            closest_point_on_triangle(p, pos[a as usize], pos[b as usize], pos[c as usize]);
        (q.distance_squared(p), q, bary)
    };
    let (mut best_d, mut best_q, mut best_b) = eval(hint);
    let mut best_f = hint;
    let mut prev = u32::MAX;
    let mut settled = false;
    for _ in 0..WALK_STEPS {
        let f = best_f;
        if best_b.min_element() > 0.0 {
            // Inside the face: the foot point is on the surface and no
            // neighbour's Voronoi region is nearer along the walk.
            settled = true;
            break;
        }
        for (k, g) in st.face_neighbors[f as usize].into_iter().enumerate() {
            // Only across the edge the foot point lies on (edge k is
            // opposite barycentric coordinate k + 2 mod 3).
            if g == u32::MAX || g == prev || best_b[(k + 2) % 3] > 0.0 || off_part(g) {
                continue;
            }
            let (d, q, b) = eval(g);
            if d < best_d || (d == best_d && g < best_f) {
                (best_d, best_q, best_b, best_f) = (d, q, b, g);
            }
        }
        if best_f == f {
            // At a corner of f, the closer face may share only that corner.
            let corner = (0..3).find(|&k| best_b[k] == 1.0);
            if let Some(k) = corner {
                let v = tris[f as usize][k] as usize;
                let (s, e) = (
                    st.vertex_face_start[v] as usize,
                    st.vertex_face_start[v + 1] as usize,
                );
                for &g in &st.vertex_faces[s..e] {
                    if g == f || st.face_neighbors[f as usize].contains(&g) || off_part(g) {
                        continue;
                    }
                    let (d, q, b) = eval(g);
                    if d < best_d || (d == best_d && g < best_f) {
                        (best_d, best_q, best_b, best_f) = (d, q, b, g);
                    }
                }
            }
            if best_f == f {
                settled = true;
                break;
            }
        }
        prev = f;
    }
    if settled && best_d.is_finite() && best_d <= (0.25 * size) * (0.25 * size) {
        return Some(ClosestPoint {
            face: best_f,
            point: best_q,
            barycentric: best_b,
            distance_squared: best_d,
        });
    }
    st.closest_on_part(p, best_f)
}

/// Moves every vertex toward `targets`, halving moves that break a face (see
/// the module docs). With `check_input`, a face must also face the same way
/// as the input surface under its corners. Returns the number of vertices
/// whose move was limited.
fn guarded_move(st: &mut State, targets: &[DVec3], check_input: bool) -> u64 {
    let pool = st.pool.clone();
    pool.install(|| guarded_move_in_pool(st, targets, check_input))
}

fn guarded_move_in_pool(st: &mut State, targets: &[DVec3], check_input: bool) -> u64 {
    let nv = st.mesh.vertex_capacity();
    let old: Vec<DVec3> = st.mesh.positions().to_vec();
    let moving: Vec<bool> = (0..nv).map(|i| targets[i] != old[i]).collect();
    let mut scale = vec![1.0f64; nv];
    let mut limited = vec![false; nv];
    {
        let pos = st.mesh.positions_mut();
        pos.par_iter_mut().enumerate().for_each(|(i, p)| {
            if moving[i] {
                *p = old[i] + (targets[i] - old[i]);
            }
        });
    }
    // The first round checks every face; a later round only the faces
    // around the vertices whose move was just cut back, since every other
    // face kept its corners and passed the round before.
    let mut candidates: Option<Vec<FaceId>> = None;
    let mut mark = vec![false; st.mesh.face_capacity()];
    for round in 0..=MAX_HALVINGS {
        let m = &st.mesh;
        let check = |f: FaceId| -> bool {
            if m.is_face_deleted(f) {
                return false;
            }
            let vs = m.face_vertices(f);
            if !vs.iter().any(|v| moving[v.idx()] && scale[v.idx()] > 0.0) {
                return false;
            }
            face_breaks(st, vs, &old, check_input)
        };
        let bad: Vec<FaceId> = match &candidates {
            None => (0..m.face_capacity() as u32)
                .into_par_iter()
                .map(FaceId)
                .filter(|&f| check(f))
                .collect(),
            Some(list) => list.par_iter().copied().filter(|&f| check(f)).collect(),
        };
        if bad.is_empty() {
            break;
        }
        let mut touched: Vec<VertexId> = Vec::new();
        for f in bad {
            for v in m.face_vertices(f) {
                if moving[v.idx()] {
                    touched.push(v);
                }
            }
        }
        touched.sort_unstable_by_key(|v| v.0);
        touched.dedup();
        let mut next = Vec::new();
        for &v in &touched {
            let i = v.idx();
            limited[i] = true;
            scale[i] = if round + 1 >= MAX_HALVINGS {
                0.0
            } else {
                scale[i] * 0.5
            };
            for h in m.outgoing(v) {
                let f = m.face(h);
                if f.is_valid() && !mark[f.idx()] {
                    mark[f.idx()] = true;
                    next.push(f);
                }
            }
        }
        for f in &next {
            mark[f.idx()] = false;
        }
        next.sort_unstable_by_key(|f| f.0);
        let pos = st.mesh.positions_mut();
        for &v in &touched {
            let i = v.idx();
            pos[i] = old[i] + scale[i] * (targets[i] - old[i]);
        }
        candidates = Some(next);
    }
    limited.iter().filter(|&&l| l).count() as u64
}

/// Whether the face with corners `vs` is broken by the move from `old`: it
/// degenerates, turns by more than 60°, falls below the quality floor while
/// getting worse, or (with `check_input`) faces away from the input under
/// its corners.
#[inline]
fn face_breaks(st: &State, vs: [VertexId; 3], old: &[DVec3], check_input: bool) -> bool {
    let m = &st.mesh;
    let t = vs.map(|v| m.position(v));
    let t0 = vs.map(|v| old[v.idx()]);
    let n = triangle_cross(t);
    let n0 = triangle_cross(t0);
    let ln = n.length();
    if ln <= 0.0 || n.dot(n0) <= MOVE_MAX_NORMAL_TURN_COS * ln * n0.length() {
        return true;
    }
    // Quality 2·√3·|n| / Σ edge² below the floor, and worse than before.
    if SQRT_12 * ln < MOVE_MIN_QUALITY * squared_edge_sum(t)
        && triangle_quality(t) < triangle_quality(t0)
    {
        return true;
    }
    if check_input {
        let r: DVec3 = vs
            .iter()
            .map(|v| st.input_normals[st.hint_face[v.idx()] as usize])
            .sum();
        if n.dot(r) <= 0.0 {
            return true;
        }
    }
    false
}

/// Sum of the squared edge lengths of triangle `t`.
#[inline]
fn squared_edge_sum(t: [DVec3; 3]) -> f64 {
    (t[1] - t[0]).length_squared() + (t[2] - t[1]).length_squared() + (t[0] - t[2]).length_squared()
}

/// Final shape pass: every smooth vertex of a triangle whose smallest angle
/// is below 30° tries a few positions and keeps the one, projected
/// onto the input, that gives its one-ring the largest smallest angle.
///
/// Records that `v` now sits over `cp`: its hint face and, under a sizing
/// field, its target.
pub(super) fn settle(st: &mut State, v: VertexId, cp: &ClosestPoint) {
    st.hint_face[v.idx()] = cp.face;
    if let Some(field) = &st.sizing {
        st.size[v.idx()] = field.size_at(cp.face, cp.barycentric);
    }
}
