//! The BVH closest-point query against an exhaustive search over every face,
//! on closed meshes, a random soup and degenerate triangles, for points
//! inside, outside, far away, on the surface and near vertices and edges.

use glam::DVec3;
use isoremesh::bvh::{closest_point_on_triangle, ClosestPoint, SurfaceIndex};
use isoremesh::{shapes, TriMesh};

/// splitmix64: a tiny deterministic generator for test inputs.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    fn vec(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    fn direction(&mut self) -> DVec3 {
        loop {
            let v = self.vec(-1.0, 1.0);
            let l = v.length();
            if l > 1e-3 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

fn brute_force(m: &TriMesh, p: DVec3, accept: impl Fn(u32) -> bool) -> Option<ClosestPoint> {
    let mut best: Option<ClosestPoint> = None;
    for (f, t) in m.triangles.iter().enumerate() {
        if !accept(f as u32) {
            continue;
        }
        let [a, b, c] = m.corner_positions(t);
        let (q, bary) = closest_point_on_triangle(p, a, b, c);
        let d2 = (p - q).length_squared();
        if best.is_none_or(|b| d2 < b.distance_squared) {
            best = Some(ClosestPoint {
                face: f as u32,
                point: q,
                barycentric: bary,
                distance_squared: d2,
            });
        }
    }
    best
}

/// Query points of every kind around `m`.
fn query_points(m: &TriMesh, rng: &mut Rng, n: usize) -> Vec<DVec3> {
    let (lo, hi) = m.bounds().unwrap();
    let diag = (hi - lo).length();
    let mut pts = Vec::with_capacity(n);
    for i in 0..n {
        let t = m.triangles[rng.below(m.triangles.len())];
        let [a, b, c] = m.corner_positions(&t);
        let p = match i % 8 {
            // Anywhere in (a slightly enlarged) bounding box: inside and outside.
            0 => {
                lo + (hi - lo) * DVec3::new(rng.unit(), rng.unit(), rng.unit()) * 1.2
                    - (hi - lo) * 0.1
            }
            // Far away.
            1 => (lo + hi) * 0.5 + rng.direction() * diag * rng.range(2.0, 1e4),
            // Exactly on the surface (up to rounding).
            2 => {
                let (u, v) = (rng.unit(), rng.unit());
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                a + (b - a) * u + (c - a) * v
            }
            // Near a vertex.
            3 => a + rng.direction() * diag * 1e-6 * rng.unit(),
            // Near an edge.
            4 => a + (b - a) * rng.unit() + rng.direction() * diag * 1e-5 * rng.unit(),
            // Exactly at a vertex.
            5 => b,
            // Just off the surface along the normal, both sides.
            6 => {
                let n = (b - a).cross(c - a).normalize_or_zero();
                (a + b + c) / 3.0 + n * rng.range(-0.05, 0.05) * diag
            }
            // Moderately near.
            _ => a + rng.direction() * diag * rng.range(0.0, 0.3),
        };
        pts.push(p);
    }
    pts
}

fn assert_same(got: Option<ClosestPoint>, want: Option<ClosestPoint>, p: DVec3, what: &str) {
    match (got, want) {
        (None, None) => {}
        (Some(g), Some(w)) => {
            assert!(
                g.point.is_finite() && g.barycentric.is_finite() && g.distance_squared.is_finite(),
                "{what}: non-finite answer at {p}: {g:?}"
            );
            let scale = w.distance_squared.max(f64::MIN_POSITIVE);
            assert!(
                (g.distance_squared - w.distance_squared).abs() <= 1e-12 * scale,
                "{what}: at {p} got {g:?}, brute force {w:?}"
            );
            if g.face == w.face {
                assert_eq!(
                    g.point, w.point,
                    "{what}: same face, different point at {p}"
                );
            }
        }
        _ => panic!("{what}: at {p} got {got:?}, brute force {want:?}"),
    }
}

fn check_mesh(m: &TriMesh, seed: u64, n: usize) {
    let idx = SurfaceIndex::from_trimesh(m);
    assert_eq!(idx.triangle_count(), m.triangles.len());
    let mut rng = Rng(seed);
    let pts = query_points(m, &mut rng, n);
    let nf = m.triangles.len();
    for (i, &p) in pts.iter().enumerate() {
        let want = brute_force(m, p, |_| true);
        assert_same(idx.closest_point(p), want, p, "plain");
        // Any hint gives the same answer: a good one (the answer), a random one.
        if let Some(w) = want {
            assert_same(idx.closest_point_with_hint(p, w.face), want, p, "good hint");
        }
        let hint = rng.below(nf) as u32;
        assert_same(idx.closest_point_with_hint(p, hint), want, p, "random hint");
        assert_same(
            idx.closest_point_with_hint(p, u32::MAX),
            want,
            p,
            "invalid hint",
        );
        if i % 4 == 0 {
            let k = 2 + (i % 5) as u32;
            let accept = |f: u32| f % k == 1;
            assert_same(
                idx.closest_point_filtered(p, accept),
                brute_force(m, p, accept),
                p,
                "filtered",
            );
            assert_same(
                idx.closest_point_with_hint_filtered(p, hint, accept),
                brute_force(m, p, accept),
                p,
                "filtered with hint",
            );
        }
    }
}

#[test]
fn icosphere_matches_brute_force() {
    check_mesh(&shapes::icosphere(4), 1, 3000);
}

#[test]
fn torus_matches_brute_force() {
    check_mesh(&shapes::torus(2.0, 0.5, 64, 24), 2, 3000);
}

#[test]
fn far_from_origin_matches_brute_force() {
    // Large coordinates with small features stress the f32 frame.
    let m = shapes::translated(
        shapes::torus(2.0, 0.5, 48, 16),
        DVec3::new(1e6, -3e6, 2.5e5),
    );
    check_mesh(&m, 3, 2000);
}

#[test]
fn huge_and_tiny_meshes_match_brute_force() {
    // Beyond the f32 range and below its normal range: the index works in a
    // rescaled frame.
    for scale in [1e30, 1e-30] {
        let mut m = shapes::torus(2.0, 0.5, 32, 12);
        for p in &mut m.positions {
            *p = (*p + DVec3::new(3.0, -1.0, 0.5)) * scale;
        }
        check_mesh(&m, 9, 1000);
    }
}

#[test]
fn random_soup_matches_brute_force() {
    let mut rng = Rng(4);
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..3000u32 {
        let c = rng.vec(-10.0, 10.0);
        let s = rng.range(0.01, 2.0);
        positions.push(c + rng.vec(-s, s));
        positions.push(c + rng.vec(-s, s));
        positions.push(c + rng.vec(-s, s));
        triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    check_mesh(&TriMesh::new(positions, triangles), 5, 3000);
}

#[test]
fn degenerate_triangles_match_brute_force() {
    // A grid of zero-area triangles of every kind, mixed with normal ones.
    let mut rng = Rng(6);
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..1500u32 {
        let a = rng.vec(-5.0, 5.0);
        let d = rng.vec(-1.0, 1.0);
        let (b, c) = match i % 5 {
            0 => (a, a),                          // a point
            1 => (a, a + d),                      // a repeated corner
            2 => (a + d * 0.3, a + d),            // collinear
            3 => (a + d, a + d * -0.7),           // collinear, a in the middle
            _ => (a + d, a + rng.vec(-1.0, 1.0)), // ordinary
        };
        let k = positions.len() as u32;
        positions.extend_from_slice(&[a, b, c]);
        triangles.push([k, k + 1, k + 2]);
    }
    check_mesh(&TriMesh::new(positions, triangles), 7, 3000);
}

#[test]
fn shared_vertices_produce_ties_with_equal_distance() {
    // Points at vertices of a closed mesh are equidistant (0) to several
    // faces; any of them is a correct answer, at distance exactly 0.
    let m = shapes::cube(3, DVec3::ZERO, DVec3::ONE);
    let idx = SurfaceIndex::from_trimesh(&m);
    for &p in &m.positions {
        let cp = idx.closest_point(p).unwrap();
        assert_eq!(cp.distance_squared, 0.0);
        assert_eq!(cp.point, p);
        let t = m.triangles[cp.face as usize];
        assert!(t.iter().any(|&v| m.positions[v as usize] == p));
    }
}

#[test]
fn barycentric_reconstructs_the_point_on_the_reported_face() {
    let m = shapes::icosphere(3);
    let idx = SurfaceIndex::from_trimesh(&m);
    let mut rng = Rng(8);
    for p in query_points(&m, &mut rng, 500) {
        let cp = idx.closest_point(p).unwrap();
        let [a, b, c] = m.corner_positions(&m.triangles[cp.face as usize]);
        let w = cp.barycentric;
        assert!(w.min_element() >= 0.0 && (w.element_sum() - 1.0).abs() < 1e-12);
        assert!((a * w.x + b * w.y + c * w.z - cp.point).length() < 1e-12);
        assert!((cp.distance_squared - (p - cp.point).length_squared()).abs() < 1e-15);
    }
}

#[test]
fn face_normals_are_cached_unit_normals() {
    let m = shapes::icosphere(2);
    let idx = SurfaceIndex::from_trimesh(&m);
    for (f, t) in m.triangles.iter().enumerate() {
        let [a, b, c] = m.corner_positions(t);
        let n = idx.face_normal(f as u32);
        assert!((n.length() - 1.0).abs() < 1e-12);
        assert!((n - (b - a).cross(c - a).normalize()).length() < 1e-12);
        // Outward on the sphere.
        assert!(n.dot(a + b + c) > 0.0);
    }
    assert_eq!(idx.face_normal(m.triangles.len() as u32), DVec3::ZERO);
}

#[test]
fn index_is_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<SurfaceIndex>();
}
