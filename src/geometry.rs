//! Small geometric primitives on `DVec3`: triangle area, normal, angles and
//! shape quality. Pure functions with no allocation, shared by every layer.

use glam::DVec3;

/// Twice-area vector of triangle `p` (cross product of two edges); its
/// direction is the counter-clockwise normal.
#[inline]
pub fn triangle_cross(p: [DVec3; 3]) -> DVec3 {
    (p[1] - p[0]).cross(p[2] - p[0])
}

/// Area of triangle `p`.
#[inline]
pub fn triangle_area(p: [DVec3; 3]) -> f64 {
    0.5 * triangle_cross(p).length()
}

/// Unit normal of triangle `p`, or zero for a degenerate triangle.
#[inline]
pub fn triangle_normal(p: [DVec3; 3]) -> DVec3 {
    triangle_cross(p).normalize_or_zero()
}

/// Shape quality q = 4·√3·area / (a² + b² + c²): 1 for an equilateral
/// triangle, 0 for a degenerate one.
#[inline]
pub fn triangle_quality(p: [DVec3; 3]) -> f64 {
    let ss = (p[1] - p[0]).length_squared()
        + (p[2] - p[1]).length_squared()
        + (p[0] - p[2]).length_squared();
    if ss > 0.0 {
        4.0 * 3f64.sqrt() * triangle_area(p) / ss
    } else {
        0.0
    }
}

/// The three interior angles of triangle `p` in radians, at corners 0, 1, 2.
/// Computed from the law of cosines, the same definition as the bench.
#[inline]
pub fn triangle_angles(p: [DVec3; 3]) -> [f64; 3] {
    let a = (p[1] - p[2]).length(); // opposite corner 0
    let b = (p[2] - p[0]).length(); // opposite corner 1
    let c = (p[0] - p[1]).length(); // opposite corner 2
    let angle = |opp: f64, s1: f64, s2: f64| {
        let d = 2.0 * s1 * s2;
        let x = if d > 0.0 {
            (s1 * s1 + s2 * s2 - opp * opp) / d
        } else {
            1.0
        };
        x.clamp(-1.0, 1.0).acos()
    };
    [angle(a, b, c), angle(b, c, a), angle(c, a, b)]
}

/// Smallest interior angle of triangle `p` in radians.
#[inline]
pub fn triangle_min_angle(p: [DVec3; 3]) -> f64 {
    let [a, b, c] = triangle_angles(p);
    a.min(b).min(c)
}

/// Cosine of the smallest interior angle of triangle `p`: the largest of
/// its three corner cosines, without a single `acos` (the smallest angle is
/// the one with the largest cosine). 1 for a degenerate triangle.
#[inline]
pub fn triangle_min_angle_cos(p: [DVec3; 3]) -> f64 {
    let mut worst = f64::NEG_INFINITY;
    for k in 0..3 {
        let u = p[(k + 1) % 3] - p[k];
        let w = p[(k + 2) % 3] - p[k];
        let d = (u.length_squared() * w.length_squared()).sqrt();
        worst = worst.max(if d > 0.0 { u.dot(w) / d } else { 1.0 });
    }
    worst.min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_angle_cosine_matches_the_angles() {
        let t = [
            DVec3::ZERO,
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(0.4, 1.1, 0.2),
        ];
        let want = triangle_min_angle(t).cos();
        assert!((triangle_min_angle_cos(t) - want).abs() < 1e-12);
        assert_eq!(triangle_min_angle_cos([DVec3::ZERO; 3]), 1.0);
    }

    #[test]
    fn equilateral_triangle_has_quality_one_and_sixty_degree_angles() {
        let p = [
            DVec3::ZERO,
            DVec3::X,
            DVec3::new(0.5, 3f64.sqrt() / 2.0, 0.0),
        ];
        assert!((triangle_quality(p) - 1.0).abs() < 1e-12);
        for a in triangle_angles(p) {
            assert!((a.to_degrees() - 60.0).abs() < 1e-9);
        }
        assert!((triangle_area(p) - 3f64.sqrt() / 4.0).abs() < 1e-12);
        assert!((triangle_normal(p) - DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn degenerate_triangle_has_zero_quality_and_normal() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert_eq!(triangle_quality(p), 0.0);
        assert_eq!(triangle_normal(p), DVec3::ZERO);
    }
}
