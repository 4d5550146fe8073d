//! Pass 3: flip edges toward regular valence (6 inside, 4 on the boundary),
//! minimising the sum of squared valence deviations of the four vertices
//! involved (Botsch & Kobbelt 2004), and flip non-Delaunay edges whose flip
//! does not worsen valence, as CGAL does to repair badly shaped triangles.
//!
//! Guards: never a feature or boundary edge; the two faces must be nearly
//! coplanar, so a flip never changes the shape; both new faces must keep the
//! orientation and must not be degenerate or much worse than before. The
//! sliver repair after the last iteration (`repair.rs`) reuses these guards.

use glam::DVec3;
use rayon::prelude::*;

use super::guards::{FLIP_MAX_DIHEDRAL_COS, FLIP_MIN_QUALITY};
use super::state::State;
use super::RemeshError;
use crate::geometry::{triangle_cross, triangle_quality};
use crate::mesh::{EdgeId, HalfedgeId, Handle, Mesh, VertexId, EDGE_FROZEN};

/// Sweeps over the edges per pass at most.
pub(super) const MAX_SWEEPS: usize = 6;

/// Every vertex's valence and valence target (4 on the boundary, 6
/// elsewhere; a deleted vertex counts as 0 of 6), computed once per
/// iteration and kept current by the flip sweeps and the valence-driven
/// collapses between them, instead of being counted again by each.
pub(super) struct Valences {
    /// Per vertex: the number of edges at it.
    pub valence: Vec<i32>,
    /// Per vertex: 4 on the boundary, 6 elsewhere.
    pub target: Vec<i32>,
}

impl Valences {
    /// Counts every vertex's valence, in parallel.
    pub fn of(st: &State) -> Self {
        let m = &st.mesh;
        let (valence, target) = st.pool.install(|| {
            (0..m.vertex_capacity() as u32)
                .into_par_iter()
                .map(|i| {
                    let v = VertexId(i);
                    if m.is_vertex_deleted(v) {
                        (0, 6)
                    } else {
                        let t = if m.is_boundary_vertex(v) { 4 } else { 6 };
                        (m.valence(v) as i32, t)
                    }
                })
                .unzip()
        });
        Self { valence, target }
    }
}

/// Flips edges; returns the number of flips. The first sweep visits every
/// edge, or only the edges of `seed` (ascending edge indices) when given.
/// `valences` must be current on entry and is kept current.
pub(super) fn flip_edges(
    st: &mut State,
    valences: &mut Valences,
    seed: Option<Vec<u32>>,
) -> Result<u64, RemeshError> {
    debug_assert!(
        {
            let fresh = Valences::of(st);
            fresh.valence == valences.valence && fresh.target == valences.target
        },
        "the valence table is stale"
    );
    let (valence, target) = (&mut valences.valence, &valences.target);
    let mut count = 0u64;
    // The first sweep visits every edge (or the seed); later sweeps only the
    // edges around the quads that changed, in index order (deterministic).
    // The first sweep's candidates, and whether each should flip, are found
    // in parallel with the valences at the start. A flip changes only the
    // valences and faces of its own quad's four vertices (marked dirty), so
    // a decision made in advance still holds when none of the candidate's
    // quad vertices is dirty; the others are decided again in turn. The
    // result is the same as deciding every candidate in turn.
    let mut work: Vec<(u32, Option<bool>)> = {
        let valence: &[i32] = valence;
        match seed {
            Some(seed) => st.pool.install(|| {
                seed.par_iter()
                    .map(|&i| (i, Some(flip_wanted(st, valence, target, EdgeId(i)))))
                    .collect()
            }),
            None => st.par_edges(|e| {
                let m = &st.mesh;
                if m.is_boundary_edge(e) {
                    return None;
                }
                let q = quad(m, e.halfedge(0));
                let change = deviation_change(valence, target, q);
                (change.1 <= change.0).then(|| (e.0, Some(flip_wanted_quad(st, e, q, change))))
            }),
        }
    };
    let mut dirty = vec![false; st.mesh.vertex_capacity()];
    let mut queued = vec![false; st.mesh.edge_capacity()];
    for _ in 0..MAX_SWEEPS {
        let mut flipped = 0u64;
        let mut next: Vec<u32> = Vec::new();
        for (k, &(i, decided)) in work.iter().enumerate() {
            st.cancel.every(k as u64)?;
            let e = EdgeId(i);
            if st.mesh.is_edge_deleted(e) {
                continue;
            }
            let q = quad(&st.mesh, e.halfedge(0));
            let wanted = match decided {
                Some(w) if !q.iter().any(|v| dirty[v.idx()]) => w,
                _ => flip_wanted_quad(st, e, q, deviation_change(valence, target, q)),
            };
            if !wanted {
                continue;
            }
            st.mesh.flip_edge(e);
            // The valences of a, b, c and d changed: every edge at them may
            // now profit from a flip.
            for v in q {
                dirty[v.idx()] = true;
                for g in st.mesh.outgoing(v) {
                    let j = g.edge().idx();
                    if !queued[j] {
                        queued[j] = true;
                        next.push(j as u32);
                    }
                }
            }
            let [a, b, c, d] = q;
            valence[a.idx()] -= 1;
            valence[b.idx()] -= 1;
            valence[c.idx()] += 1;
            valence[d.idx()] += 1;
            flipped += 1;
        }
        count += flipped;
        if flipped == 0 {
            break;
        }
        next.sort_unstable();
        for &j in &next {
            queued[j as usize] = false;
        }
        work = next.into_iter().map(|j| (j, None)).collect();
    }
    Ok(count)
}

/// Whether edge `e` should flip now: not a feature or boundary edge, the
/// flip does not raise the valence deviation (and lowers it, or repairs a
/// non-Delaunay pair), and it passes the geometric and topological guards.
fn flip_wanted(st: &State, valence: &[i32], target: &[i32], e: EdgeId) -> bool {
    // A deleted edge's half-edges lead nowhere: no quad to read.
    if st.mesh.is_edge_deleted(e) {
        return false;
    }
    let q = quad(&st.mesh, e.halfedge(0));
    flip_wanted_quad(st, e, q, deviation_change(valence, target, q))
}

/// [`flip_wanted`] for a caller that already has live edge `e`'s quad `q`
/// and its [`deviation_change`] `(before, after)`.
fn flip_wanted_quad(st: &State, e: EdgeId, q: [VertexId; 4], (before, after): (i32, i32)) -> bool {
    let m = &st.mesh;
    debug_assert!(!m.is_edge_deleted(e), "no quad for a deleted edge");
    if st.line_of(e).is_some() || m.is_boundary_edge(e) || m.edge_has_flag(e, EDGE_FROZEN) {
        return false;
    }
    if after > before {
        return false;
    }
    let (old, new) = quad_triangles(m, q);
    if after == before && !improves_delaunay(old) {
        return false;
    }
    geometry_ok(old, new) && m.can_flip(e)
}

/// The quad around the edge of `h`: its ends `a` (tail) and `b` (head),
/// then `c` opposite it in `h`'s face and `d` in the twin's. A flip replaces
/// `ab` by `cd`.
pub(super) fn quad(m: &Mesh, h: HalfedgeId) -> [VertexId; 4] {
    let o = h.twin();
    [
        m.to_vertex(o),
        m.to_vertex(h),
        m.to_vertex(m.next(h)),
        m.to_vertex(m.next(o)),
    ]
}

/// The two faces of `quad` before and after the flip, counter-clockwise.
pub(super) fn quad_triangles(
    m: &Mesh,
    [a, b, c, d]: [VertexId; 4],
) -> ([[DVec3; 3]; 2], [[DVec3; 3]; 2]) {
    let [pa, pb, pc, pd] = [a, b, c, d].map(|v| m.position(v));
    ([[pa, pb, pc], [pb, pa, pd]], [[pc, pa, pd], [pd, pb, pc]])
}

/// Sum of squared valence deviations of `quad`'s vertices before and after
/// its flip (`a`, `b` lose an edge, `c`, `d` gain one).
fn deviation_change(valence: &[i32], target: &[i32], quad: [VertexId; 4]) -> (i32, i32) {
    let dev = |v: VertexId, delta: i32| {
        let x = valence[v.idx()] + delta - target[v.idx()];
        x * x
    };
    let [a, b, c, d] = quad;
    (
        dev(a, 0) + dev(b, 0) + dev(c, 0) + dev(d, 0),
        dev(a, -1) + dev(b, -1) + dev(c, 1) + dev(d, 1),
    )
}

/// Whether the edge shared by `old` violates the Delaunay condition: the
/// angles opposite it sum to more than π.
///
/// With α, β in (0, π), α + β > π exactly when sin(α + β) < 0, and
/// sin(α + β)·|u₁||v₁||u₂||v₂| = (u₁·v₁)|u₂×v₂| + (u₂·v₂)|u₁×v₁| for the edge
/// vectors u, v at the opposite corners: no `acos`. The margin of 1e-9 keeps
/// co-circular quads (α + β = π, as in every rectangle of a CAD grid) as
/// they are.
fn improves_delaunay(old: [[DVec3; 3]; 2]) -> bool {
    let corner = |t: [DVec3; 3]| {
        let (u, v) = (t[0] - t[2], t[1] - t[2]);
        (
            u.dot(v),
            u.cross(v).length(),
            u.length_squared() * v.length_squared(),
        )
    };
    let (d1, c1, l1) = corner(old[0]);
    let (d2, c2, l2) = corner(old[1]);
    d1 * c2 + d2 * c1 < -1e-9 * (l1 * l2).sqrt()
}

pub(super) fn geometry_ok(old: [[DVec3; 3]; 2], new: [[DVec3; 3]; 2]) -> bool {
    let n1 = triangle_cross(old[0]);
    let n2 = triangle_cross(old[1]);
    let (l1, l2) = (n1.length(), n2.length());
    if l1 <= 0.0 || l2 <= 0.0 || n1.dot(n2) < FLIP_MAX_DIHEDRAL_COS * l1 * l2 {
        return false;
    }
    let avg = n1 / l1 + n2 / l2;
    let m1 = triangle_cross(new[0]);
    let m2 = triangle_cross(new[1]);
    let (k1, k2) = (m1.length(), m2.length());
    if k1 <= 0.0 || k2 <= 0.0 || m1.dot(avg) <= 0.0 || m2.dot(avg) <= 0.0 {
        return false;
    }
    if m1.dot(m2) < FLIP_MAX_DIHEDRAL_COS * k1 * k2 {
        return false;
    }
    let q_old = triangle_quality(old[0]).min(triangle_quality(old[1]));
    let q_new = triangle_quality(new[0]).min(triangle_quality(new[1]));
    q_new >= q_old.min(FLIP_MIN_QUALITY)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle_angles;

    /// The acos-free test agrees with summing the two opposite angles, and
    /// leaves co-circular quads alone.
    #[test]
    fn delaunay_test_matches_the_angle_sum() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let (a, b) = (DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0));
        for _ in 0..10_000 {
            let c = DVec3::new(next(), 0.05 + next().abs(), 0.3 * next());
            let d = DVec3::new(next(), -0.05 - next().abs(), 0.3 * next());
            let old = [[a, b, c], [b, a, d]];
            let sum = triangle_angles(old[0])[2] + triangle_angles(old[1])[2];
            let pi = std::f64::consts::PI;
            if (sum - pi).abs() > 1e-6 {
                assert_eq!(improves_delaunay(old), sum > pi, "{c} {d}");
            }
        }
        // A rectangle split along its diagonal: α + β = π exactly.
        let rect = [
            [
                DVec3::ZERO,
                DVec3::new(2.0, 1.0, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
            ],
            [
                DVec3::new(2.0, 1.0, 0.0),
                DVec3::ZERO,
                DVec3::new(2.0, 0.0, 0.0),
            ],
        ];
        assert!(!improves_delaunay(rect));
    }
}
