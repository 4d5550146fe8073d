//! Passes 4 and 5: tangential relaxation and projection onto the input,
//! sharing one guarded, parallel move.
//!
//! Relaxation moves each smooth vertex to the area-weighted centroid of its
//! one-ring, projected onto its tangent plane (Botsch & Kobbelt 2004); a
//! feature-line vertex moves only along its line, toward the midpoint of its
//! two line neighbours; corners stay. Projection sends smooth vertices to
//! their closest point on the input surface (BVH query seeded with the face
//! found last time) and line vertices to their closest point on their own
//! input feature line; corners keep their exact input position.
//!
//! Both compute every target from the old positions (a Jacobi step, so the
//! result does not depend on the thread count), then apply the moves: a move
//! that would invert, degenerate or turn a face away from the input is
//! halved, up to five times, and then dropped.

use glam::DVec3;
use rayon::prelude::*;

use super::state::{State, CORNER, SMOOTH};
use crate::bvh::{closest_point_on_triangle, ClosestPoint};
use crate::geometry::{triangle_cross, triangle_quality};
use crate::mesh::{FaceId, Handle, VertexId};

/// How often a guarded move is halved before it is dropped.
const MAX_HALVINGS: u32 = 5;
/// A move may not leave a face with quality below this unless it was already worse.
const MIN_QUALITY: f64 = 0.05;
/// Largest normal change of a face caused by one move step (60°), as a cosine.
const MAX_NORMAL_CHANGE_COS: f64 = 0.5;

/// Where a vertex projects: the point, the new face and segment hints, and
/// the surface face and barycentric coordinates under it (for sizing).
type Projected = (DVec3, u32, u32, Option<(u32, DVec3)>);

/// One step of tangential relaxation; returns the number of limited moves.
pub(super) fn relax_tangentially(st: &mut State) -> u64 {
    let m = &st.mesh;
    let kind = &st.kind;
    let edge_line = &st.edge_line;
    let size = &st.size;
    let adaptive = st.sizing.is_some();
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
                        for h in m.outgoing(v) {
                            let f = m.face(h);
                            if !f.is_valid() {
                                continue;
                            }
                            let tri = m.face_positions(f);
                            let cross = triangle_cross(tri);
                            normal += cross;
                            let mut w = cross.length();
                            if adaptive {
                                let [a, b, c] = m.face_vertices(f);
                                let hf = (size[a.idx()] + size[b.idx()] + size[c.idx()]) / 3.0;
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
                        p + d - n * n.dot(d)
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
    guarded_move(st, &targets, false)
}

/// Projects every vertex onto the input; returns the number of limited moves.
pub(super) fn project_to_input(st: &mut State) -> u64 {
    let m = &st.mesh;
    let kind = &st.kind;
    let index = &st.index;
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
                let p = m.position(v);
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
                        let face = index
                            .closest_point_with_hint(lp.point, hf)
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

/// Closest point on the input from a hint face: walk across the faces around
/// the current best face while that gets closer (vertices move little
/// between steps, so this usually ends in one or two rounds), and fall back
/// to the global BVH query, bounded by the walk's result, when the point is
/// not close to the surface relative to the local target size or the walk
/// does not settle.
fn walk_closest(st: &State, p: DVec3, hint: u32, size: f64) -> Option<ClosestPoint> {
    let tris = st.index.triangles();
    let pos = st.index.positions();
    if hint as usize >= tris.len() {
        return st.index.closest_point(p);
    }
    let eval = |f: u32| {
        let [a, b, c] = tris[f as usize];
        let (q, bary) =
            closest_point_on_triangle(p, pos[a as usize], pos[b as usize], pos[c as usize]);
        (q.distance_squared(p), q, bary)
    };
    let (mut best_d, mut best_q, mut best_b) = eval(hint);
    let mut best_f = hint;
    let mut settled = false;
    for _ in 0..8 {
        let f = best_f;
        for &v in &tris[f as usize] {
            let (s, e) = (
                st.vertex_face_start[v as usize] as usize,
                st.vertex_face_start[v as usize + 1] as usize,
            );
            for &g in &st.vertex_faces[s..e] {
                if g == f {
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
    if settled && best_d.is_finite() && best_d <= (0.25 * size) * (0.25 * size) {
        return Some(ClosestPoint {
            face: best_f,
            point: best_q,
            barycentric: best_b,
            distance_squared: best_d,
        });
    }
    st.index.closest_point_with_hint(p, best_f)
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
    let old_normals: Vec<(DVec3, f64)> = (0..st.mesh.face_capacity() as u32)
        .into_par_iter()
        .map(|f| {
            let f = FaceId(f);
            if st.mesh.is_face_deleted(f) {
                (DVec3::ZERO, 0.0)
            } else {
                let t = st.mesh.face_positions(f);
                (triangle_cross(t), triangle_quality(t))
            }
        })
        .collect();
    let mut scale = vec![1.0f64; nv];
    let mut limited = vec![false; nv];
    for round in 0..=MAX_HALVINGS + 1 {
        {
            let pos = st.mesh.positions_mut();
            pos.par_iter_mut().enumerate().for_each(|(i, p)| {
                if moving[i] {
                    *p = old[i] + scale[i] * (targets[i] - old[i]);
                }
            });
        }
        if round == MAX_HALVINGS + 1 {
            break;
        }
        let m = &st.mesh;
        let input_normals = &st.input_normals;
        let hint_face = &st.hint_face;
        let bad: Vec<FaceId> = (0..m.face_capacity() as u32)
            .into_par_iter()
            .map(FaceId)
            .filter(|&f| {
                if m.is_face_deleted(f) {
                    return false;
                }
                let vs = m.face_vertices(f);
                if !vs.iter().any(|v| moving[v.idx()] && scale[v.idx()] > 0.0) {
                    return false;
                }
                let t = m.face_positions(f);
                let n = triangle_cross(t);
                let (n0, q0) = old_normals[f.idx()];
                let ln = n.length();
                if ln <= 0.0 || n.dot(n0) <= MAX_NORMAL_CHANGE_COS * ln * n0.length() {
                    return true;
                }
                let q = triangle_quality(t);
                if q < MIN_QUALITY && q < q0 {
                    return true;
                }
                if check_input {
                    let r: DVec3 = vs
                        .iter()
                        .map(|v| input_normals[hint_face[v.idx()] as usize])
                        .sum();
                    if n.dot(r) <= 0.0 {
                        return true;
                    }
                }
                false
            })
            .collect();
        if bad.is_empty() {
            break;
        }
        let mut touched = vec![false; nv];
        for f in bad {
            for v in st.mesh.face_vertices(f) {
                let i = v.idx();
                if moving[i] && !touched[i] {
                    touched[i] = true;
                    limited[i] = true;
                    scale[i] = if round + 1 >= MAX_HALVINGS {
                        0.0
                    } else {
                        scale[i] * 0.5
                    };
                }
            }
        }
    }
    limited.iter().filter(|&&l| l).count() as u64
}
