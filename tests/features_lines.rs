//! Closest-point queries on feature lines: against brute force, and the
//! hinted query against the global one.

use glam::DVec3;
use isoremesh::features::{detect_features, FeatureOptions, FeatureSet, LinePoint};
use isoremesh::{shapes, TriMesh};
use std::f64::consts::TAU;
use std::time::Instant;

/// A ribbon along a tight helix: `n` quads, 20 turns whose pitch (0.05) is
/// smaller than the ribbon width (0.2), so parts of the same boundary line
/// that are far apart along the line are close in space.
fn helix_ribbon(n: u32) -> TriMesh {
    let turns = 20.0;
    let mut positions = Vec::new();
    for i in 0..=n {
        let a = TAU * turns * i as f64 / n as f64;
        let z = 0.05 * a / TAU;
        positions.push(DVec3::new(a.cos(), a.sin(), z));
        positions.push(DVec3::new(0.8 * a.cos(), 0.8 * a.sin(), z + 0.01));
    }
    let mut triangles = Vec::new();
    for i in 0..n {
        let (a, b, c, d) = (2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1);
        triangles.push([a, b, c]);
        triangles.push([a, c, d]);
    }
    TriMesh::new(positions, triangles)
}

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f()
    }
    fn below(&mut self, n: u32) -> u32 {
        ((self.f() * n as f64) as u32).min(n - 1)
    }
}

/// Independent brute force: smallest squared distance over all segments.
fn brute(fs: &FeatureSet, line: u32, p: DVec3) -> (f64, u32) {
    let pts = fs.line_points(line);
    let mut best = (f64::INFINITY, u32::MAX);
    for s in 0..pts.len() - 1 {
        let (a, b) = (pts[s], pts[s + 1]);
        let d = b - a;
        let t = if d.length_squared() > 0.0 {
            ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d2 = (p - (a + d * t)).length_squared();
        if d2 < best.0 {
            best = (d2, s as u32);
        }
    }
    best
}

fn check_against_brute(fs: &FeatureSet, line: u32, p: DVec3) -> LinePoint {
    let got = fs.closest_on_line(line, p);
    let (d2, _) = brute(fs, line, p);
    assert!(
        (got.dist2 - d2).abs() <= 1e-12 * (1.0 + d2),
        "line {line} p {p:?}: {} vs brute {d2}",
        got.dist2
    );
    // The reported point is on the reported segment at t, at the reported distance.
    let pts = fs.line_points(line);
    let (a, b) = (pts[got.segment as usize], pts[got.segment as usize + 1]);
    assert!((0.0..=1.0).contains(&got.t));
    assert!((got.point - (a + (b - a) * got.t)).length() <= 1e-12 * (1.0 + a.length()));
    assert_eq!(got.point, fs.line_point(line, got.segment, got.t));
    assert!(((p - got.point).length_squared() - got.dist2).abs() <= 1e-15);
    got
}

#[test]
fn closest_on_line_matches_brute_force_on_a_tight_helix() {
    let m = helix_ribbon(4000);
    let fs = detect_features(&m, &FeatureOptions::default());
    assert_eq!(fs.corners().len(), 4);
    assert_eq!(fs.lines().len(), 4);
    let long: Vec<u32> = (0..fs.lines().len() as u32)
        .filter(|&l| fs.lines()[l as usize].segment_count() == 4000)
        .collect();
    assert_eq!(long.len(), 2);
    let mut rng = Rng(0x9e3779b97f4a7c15);
    for i in 0..3000 {
        let line = long[i % 2];
        let p = if i % 3 == 0 {
            // Anywhere in (and a bit beyond) the helix's box.
            DVec3::new(
                rng.range(-1.5, 1.5),
                rng.range(-1.5, 1.5),
                rng.range(-0.3, 1.3),
            )
        } else {
            // Close to the surface, where neighbouring turns compete.
            let v = rng.below(m.positions.len() as u32);
            m.positions[v as usize]
                + DVec3::new(
                    rng.range(-0.06, 0.06),
                    rng.range(-0.06, 0.06),
                    rng.range(-0.06, 0.06),
                )
        };
        check_against_brute(&fs, line, p);
    }
    // The short end lines too.
    for line in 0..fs.lines().len() as u32 {
        for _ in 0..50 {
            let p = DVec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-1.0, 2.0),
            );
            check_against_brute(&fs, line, p);
        }
    }
}

#[test]
fn closest_on_line_ties_go_to_the_lowest_segment() {
    let m = shapes::open_cylinder(1.0, 1.0, 64, 1);
    let fs = detect_features(&m, &FeatureOptions::default());
    for line in 0..fs.lines().len() as u32 {
        let l = &fs.lines()[line as usize];
        // At an interior line vertex both segments give distance 0 at the
        // same (exact) point; the earlier segment, at t = 1, wins.
        for i in 1..l.segment_count() {
            let v = fs.line_points(line)[i];
            let got = fs.closest_on_line(line, v);
            assert_eq!(got.segment, i as u32 - 1);
            assert_eq!((got.t, got.point, got.dist2), (1.0, v, 0.0));
            for hint in [0, i as u32, i as u32 + 3, 63] {
                assert_eq!(fs.closest_on_line_near(line, v, hint), got);
            }
        }
    }
}

#[test]
fn closest_on_line_near_equals_closest_on_line() {
    let helix = helix_ribbon(3000);
    let cyl = shapes::open_cylinder(1.0, 1.0, 2000, 3);
    let cube = shapes::cube(5, DVec3::ZERO, DVec3::ONE);
    let mut rng = Rng(42);
    for m in [&helix, &cyl, &cube] {
        let fs = detect_features(m, &FeatureOptions::default());
        let (lo, hi) = m.bounds().unwrap();
        let pad = (hi - lo) * 0.2;
        for i in 0..4000 {
            let line = rng.below(fs.lines().len() as u32);
            let n = fs.lines()[line as usize].segment_count() as u32;
            let p = DVec3::new(
                rng.range(lo.x - pad.x, hi.x + pad.x),
                rng.range(lo.y - pad.y, hi.y + pad.y),
                rng.range(lo.z - pad.z, hi.z + pad.z),
            );
            let want = fs.closest_on_line(line, p);
            let hint = match i % 4 {
                0 => rng.below(n),                                 // anywhere
                1 => want.segment,                                 // exact
                2 => (want.segment + 1 + rng.below(3)).min(n - 1), // close by
                _ => u32::MAX,                                     // out of range
            };
            assert_eq!(fs.closest_on_line_near(line, p, hint), want, "hint {hint}");
        }
        // Points on the cylinder axis are (nearly) equidistant from the whole rim.
        if std::ptr::eq(m, &cyl) {
            for line in 0..fs.lines().len() as u32 {
                let p = DVec3::new(0.0, 0.0, fs.line_points(line)[0].z);
                let want = fs.closest_on_line(line, p);
                for hint in [0, 1, 999, 1999] {
                    assert_eq!(fs.closest_on_line_near(line, p, hint), want);
                }
            }
        }
    }
}

#[test]
fn closed_loop_hint_walk_wraps_around() {
    let m = shapes::open_cylinder(1.0, 1.0, 100, 1);
    let fs = detect_features(&m, &FeatureOptions::default());
    let line = 0;
    assert!(fs.lines()[line as usize].is_closed());
    let pts = fs.line_points(line);
    // Just outside the middle of the last segment, hinted at segment 0.
    let mid = (pts[99] + pts[100]) * 0.5;
    let p = mid * 1.01;
    let got = fs.closest_on_line_near(line, p, 0);
    assert_eq!(got.segment, 99);
    assert_eq!(got, fs.closest_on_line(line, p));
}

#[test]
fn non_finite_query_points_do_not_panic() {
    let m = shapes::grid(1.0, 3);
    let fs = detect_features(&m, &FeatureOptions::default());
    for p in [DVec3::NAN, DVec3::INFINITY, DVec3::new(0.0, f64::NAN, 0.0)] {
        let a = fs.closest_on_line(0, p);
        let b = fs.closest_on_line_near(0, p, 2);
        assert_eq!(a.segment, b.segment);
        assert_eq!(a.segment, 0);
    }
}

#[test]
fn line_queries_scale_to_long_lines() {
    // 20k-segment lines; timings are printed, not asserted (shared machine).
    let m = helix_ribbon(20_000);
    let fs = detect_features(&m, &FeatureOptions::default());
    let line = (0..fs.lines().len() as u32)
        .find(|&l| fs.lines()[l as usize].segment_count() == 20_000)
        .unwrap();
    let pts = fs.line_points(line).to_vec();
    let mut rng = Rng(7);
    let queries: Vec<(DVec3, u32)> = (0..20_000)
        .map(|_| {
            let s = rng.below(20_000);
            let p = (pts[s as usize] + pts[s as usize + 1]) * 0.5
                + DVec3::new(
                    rng.range(-0.01, 0.01),
                    rng.range(-0.01, 0.01),
                    rng.range(-0.01, 0.01),
                );
            (p, s)
        })
        .collect();
    let t = Instant::now();
    let global: Vec<LinePoint> = queries
        .iter()
        .map(|&(p, _)| fs.closest_on_line(line, p))
        .collect();
    let t_global = t.elapsed();
    let t = Instant::now();
    let near: Vec<LinePoint> = queries
        .iter()
        .map(|&(p, s)| fs.closest_on_line_near(line, p, s))
        .collect();
    let t_near = t.elapsed();
    assert_eq!(global, near);
    // Each query point is within 0.01·√3 of its segment's midpoint.
    assert!(global.iter().all(|g| g.dist2 <= 3e-4));
    println!(
        "20k queries on a 20k-segment line: global {:?} ({:.0} ns/q), near {:?} ({:.0} ns/q)",
        t_global,
        t_global.as_nanos() as f64 / 2e4,
        t_near,
        t_near.as_nanos() as f64 / 2e4
    );
}
