//! The closest point of a triangle to a query point, after Ericson,
//! *Real-Time Collision Detection* (2005), §5.1.5: the plane of the triangle
//! is split into the seven Voronoi regions of its three vertices, three edges
//! and the face, and the region containing the query point is found with
//! dot products that are (scaled) barycentric coordinates, without computing
//! the projection first.
//!
//! Degenerate triangles (a repeated corner, collinear corners) have no face
//! region; for those the answer is the closest point on the three edges, so
//! the routine never divides by zero and never returns NaN for finite input.

use glam::DVec3;

/// Closest point on the segment `a`–`b` to `p` and its parameter `t` in
/// [0, 1] (the point is `a + t·(b − a)`). A zero-length segment yields `a`.
#[inline]
fn closest_on_segment(p: DVec3, a: DVec3, b: DVec3) -> (DVec3, f64) {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t, t)
}

/// Fallback for triangles without a usable face region: the nearest of the
/// closest points on the three edges.
#[cold]
fn closest_on_edges(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (DVec3, DVec3) {
    let (q_ab, t_ab) = closest_on_segment(p, a, b);
    let (q_bc, t_bc) = closest_on_segment(p, b, c);
    let (q_ca, t_ca) = closest_on_segment(p, c, a);
    let mut best = (q_ab, DVec3::new(1.0 - t_ab, t_ab, 0.0));
    let mut best_d2 = (p - q_ab).length_squared();
    let d2 = (p - q_bc).length_squared();
    if d2 < best_d2 {
        best = (q_bc, DVec3::new(0.0, 1.0 - t_bc, t_bc));
        best_d2 = d2;
    }
    if (p - q_ca).length_squared() < best_d2 {
        best = (q_ca, DVec3::new(t_ca, 0.0, 1.0 - t_ca));
    }
    best
}

/// The point of triangle `(a, b, c)` closest to `p`, and its barycentric
/// coordinates: the weights of `a`, `b`, `c` (non-negative, summing to 1).
///
/// Follows the Voronoi-region tests of Ericson (2005) §5.1.5. Works for any
/// finite input, including degenerate triangles (repeated or collinear
/// corners), for which the closest point of the three edges is returned.
#[inline]
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> (DVec3, DVec3) {
    let ab = b - a;
    let ac = c - a;

    // Vertex region A: p is behind both edges leaving a.
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, DVec3::X);
    }

    // Vertex region B.
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, DVec3::Y);
    }

    // Edge region AB: the barycentric weight of c (scaled) is not positive
    // and p projects between a and b.
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let den = d1 - d3;
        if den > 0.0 {
            let v = d1 / den;
            return (a + ab * v, DVec3::new(1.0 - v, v, 0.0));
        }
        return closest_on_edges(p, a, b, c);
    }

    // Vertex region C.
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, DVec3::Z);
    }

    // Edge region AC.
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let den = d2 - d6;
        if den > 0.0 {
            let w = d2 / den;
            return (a + ac * w, DVec3::new(1.0 - w, 0.0, w));
        }
        return closest_on_edges(p, a, b, c);
    }

    // Edge region BC.
    let va = d3 * d6 - d5 * d4;
    let e43 = d4 - d3;
    let e56 = d5 - d6;
    if va <= 0.0 && e43 >= 0.0 && e56 >= 0.0 {
        let den = e43 + e56;
        if den > 0.0 {
            let w = e43 / den;
            return (b + (c - b) * w, DVec3::new(0.0, 1.0 - w, w));
        }
        return closest_on_edges(p, a, b, c);
    }

    // Face region: va, vb, vc are the barycentric weights scaled by
    // |ab × ac|². A degenerate triangle makes their sum vanish (or, after
    // rounding, leaves one negative); the edges then hold the answer.
    let denom = va + vb + vc;
    if !(denom > 0.0 && va >= 0.0 && vb >= 0.0 && vc >= 0.0) {
        return closest_on_edges(p, a, b, c);
    }
    let v = vb / denom;
    let w = vc / denom;
    let face = (a + ab * v + ac * w, DVec3::new(1.0 - v - w, v, w));
    // denom = |ab × ac|² = |ab|²·|ac|²·sin²(angle at a). For a needle or cap
    // the weights lose most of their digits to cancellation: the point is
    // still on the triangle but may not be the closest, while the edges,
    // which such a triangle hugs, are accurate. Take the nearer of the two.
    if denom < SLIVER_SIN2 * ab.length_squared() * ac.length_squared() {
        let edge = closest_on_edges(p, a, b, c);
        if (p - edge.0).length_squared() < (p - face.0).length_squared() {
            return edge;
        }
    }
    face
}

/// sin² of the angle at corner a below which a triangle counts as a sliver
/// (angle below ~0.06°).
const SLIVER_SIN2: f64 = 1e-6;

#[cfg(test)]
mod tests {
    use super::*;

    const A: DVec3 = DVec3::new(0.0, 0.0, 0.0);
    const B: DVec3 = DVec3::new(4.0, 0.0, 0.0);
    const C: DVec3 = DVec3::new(0.0, 3.0, 0.0);

    fn check(p: DVec3, want_q: DVec3, want_bary: DVec3) {
        let (q, bary) = closest_point_on_triangle(p, A, B, C);
        assert!((q - want_q).length() < 1e-12, "p={p} q={q} want {want_q}");
        assert!(
            (bary - want_bary).length() < 1e-12,
            "p={p} bary={bary} want {want_bary}"
        );
        let recon = A * bary.x + B * bary.y + C * bary.z;
        assert!((recon - q).length() < 1e-12);
    }

    #[test]
    fn vertex_region_a() {
        check(DVec3::new(-1.0, -2.0, 5.0), A, DVec3::X);
    }

    #[test]
    fn vertex_region_b() {
        check(DVec3::new(6.0, -1.0, -2.0), B, DVec3::Y);
    }

    #[test]
    fn vertex_region_c() {
        check(DVec3::new(-0.5, 5.0, 1.0), C, DVec3::Z);
    }

    #[test]
    fn edge_region_ab() {
        check(
            DVec3::new(1.0, -2.0, 3.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.75, 0.25, 0.0),
        );
    }

    #[test]
    fn edge_region_ac() {
        check(
            DVec3::new(-3.0, 1.5, -1.0),
            DVec3::new(0.0, 1.5, 0.0),
            DVec3::new(0.5, 0.0, 0.5),
        );
    }

    #[test]
    fn edge_region_bc() {
        // The midpoint of bc is (2, 1.5); the edge normal in-plane is (3, 4)/5.
        let mid = DVec3::new(2.0, 1.5, 0.0);
        let p = mid + DVec3::new(3.0, 4.0, 0.0) * 0.4 + DVec3::Z * 2.0;
        check(p, mid, DVec3::new(0.0, 0.5, 0.5));
    }

    #[test]
    fn face_region() {
        check(
            DVec3::new(1.0, 1.0, -7.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(1.0 - 0.25 - 1.0 / 3.0, 0.25, 1.0 / 3.0),
        );
    }

    #[test]
    fn point_on_the_triangle_is_its_own_closest_point() {
        let p = DVec3::new(0.5, 0.5, 0.0);
        let (q, _) = closest_point_on_triangle(p, A, B, C);
        assert_eq!((q - p).length(), 0.0);
    }

    #[test]
    fn repeated_corner_is_a_segment() {
        let (q, bary) = closest_point_on_triangle(DVec3::new(1.0, 1.0, 0.0), A, A, B);
        assert!((q - DVec3::new(1.0, 0.0, 0.0)).length() < 1e-12);
        assert!(bary.is_finite() && (bary.element_sum() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn collinear_corners_are_a_segment() {
        let m = DVec3::new(2.0, 0.0, 0.0);
        for p in [
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(3.0, -1.0, 2.0),
            DVec3::new(-1.0, 0.0, 0.0),
            DVec3::new(9.0, 0.0, 0.0),
        ] {
            let (q, bary) = closest_point_on_triangle(p, A, m, B);
            let want = DVec3::new(p.x.clamp(0.0, 4.0), 0.0, 0.0);
            assert!((q - want).length() < 1e-12, "p={p} q={q}");
            assert!(bary.is_finite());
            let recon = A * bary.x + m * bary.y + B * bary.z;
            assert!((recon - q).length() < 1e-12);
        }
    }

    #[test]
    fn all_corners_equal_is_a_point() {
        let (q, bary) = closest_point_on_triangle(DVec3::ONE, B, B, B);
        assert_eq!(q, B);
        assert!(bary.is_finite() && (bary.element_sum() - 1.0).abs() < 1e-12);
    }
}
