//! Properties of `closest_point_on_triangle` on random triangles (including
//! near-degenerate ones): the answer lies on the triangle, its barycentric
//! coordinates reproduce it, and no point of the triangle is closer.

use glam::DVec3;
use isoremesh::bvh::closest_point_on_triangle;
use proptest::prelude::*;

fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -10.0f64..10.0,
        1 => (-3i32..=3).prop_map(|i| i as f64), // lattice values make exact ties and degeneracies
    ]
}

fn point() -> impl Strategy<Value = DVec3> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

/// Distance from `p` to the closest of a dense set of points of the triangle.
fn sampled_min_distance(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    const N: usize = 60;
    let mut best = f64::INFINITY;
    for i in 0..=N {
        for j in 0..=(N - i) {
            let (u, v) = (i as f64 / N as f64, j as f64 / N as f64);
            let s = a * (1.0 - u - v) + b * u + c * v;
            best = best.min((p - s).length());
        }
    }
    best
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn closest_point_is_on_the_triangle_and_optimal(
        a in point(), b in point(), c in point(), p in point(),
        squash in prop_oneof![3 => Just(1.0f64), 1 => Just(0.0f64), 1 => Just(1e-9f64)],
    ) {
        // `squash` flattens c onto the line ab to produce (near-)degenerate triangles.
        let c = a + (b - a) * 0.37 + (c - a - (b - a) * 0.37) * squash;
        let (q, w) = closest_point_on_triangle(p, a, b, c);
        prop_assert!(q.is_finite() && w.is_finite());
        prop_assert!(w.min_element() >= -1e-12, "negative weight {w}");
        prop_assert!((w.element_sum() - 1.0).abs() < 1e-9, "weights {w}");
        let scale = 1.0 + a.abs().max(b.abs()).max(c.abs()).max(p.abs()).max_element();
        let recon = a * w.x + b * w.y + c * w.z;
        prop_assert!((recon - q).length() <= 1e-9 * scale, "q={q} recon={recon}");
        let d = (p - q).length();
        // Every vertex, and every sample of the triangle, is at least as far.
        for v in [a, b, c] {
            prop_assert!(d <= (p - v).length() + 1e-9 * scale);
        }
        prop_assert!(d <= sampled_min_distance(p, a, b, c) + 1e-9 * scale);
        // And the sampled distance is not much larger (sample spacing bound).
        let longest = (b - a).length().max((c - b).length()).max((a - c).length());
        prop_assert!(sampled_min_distance(p, a, b, c) <= d + longest / 60.0 + 1e-9 * scale);
    }

    #[test]
    fn face_region_answer_is_the_orthogonal_projection(
        a in point(), b in point(), c in point(), u in 0.01f64..0.97, frac in 0.01f64..0.99, h in -5.0f64..5.0,
    ) {
        let n = (b - a).cross(c - a);
        prop_assume!(n.length() > 1e-3 * (b - a).length() * (c - a).length() && n.length() > 1e-6);
        // A point strictly inside: u, v > 0 and u + v < 0.98.
        let v = (0.98 - u) * frac;
        let inside = a + (b - a) * u + (c - a) * v;
        let p = inside + n.normalize() * h;
        let (q, w) = closest_point_on_triangle(p, a, b, c);
        let scale = 1.0 + a.abs().max(b.abs()).max(c.abs()).max(p.abs()).max_element();
        prop_assert!((q - inside).length() <= 1e-9 * scale, "q={q} inside={inside}");
        prop_assert!((w - DVec3::new(1.0 - u - v, u, v)).length() <= 1e-6, "w={w}");
    }
}
