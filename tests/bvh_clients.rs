//! The segment and point clients of the BVH against brute force: the same
//! answer bit for bit, ties included (the lowest index wins), on random
//! soups, on sets full of exact ties (shared end points, duplicates) and far
//! from the origin.

use glam::DVec3;
use isoremesh::bvh::{closest_point_on_segment, PointIndex, SegmentIndex, SegmentPoint};
use isoremesh::shapes;

/// xorshift64 in [0, 1).
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
    fn point(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    fn below(&mut self, n: usize) -> usize {
        ((self.f() * n as f64) as usize).min(n - 1)
    }
}

/// Lowest (distance², segment) over all segments, computed independently.
fn brute_segment(segs: &[[DVec3; 2]], p: DVec3) -> Option<SegmentPoint> {
    let mut best: Option<SegmentPoint> = None;
    for (i, &[a, b]) in segs.iter().enumerate() {
        let (t, point, d2) = closest_point_on_segment(p, a, b);
        if best.is_none_or(|c| d2 < c.distance_squared) {
            best = Some(SegmentPoint {
                segment: i as u32,
                t,
                point,
                distance_squared: d2,
            });
        }
    }
    best
}

fn check_segments(segs: &[[DVec3; 2]], queries: &[DVec3], rng: &mut Rng) {
    let idx = SegmentIndex::new(segs.len(), |i| segs[i]);
    assert_eq!(idx.len(), segs.len());
    for &p in queries {
        let want = brute_segment(segs, p);
        assert_eq!(idx.closest(p), want, "p {p}");
        // Seeded with any segment's own answer, the answer is the same.
        let s = rng.below(segs.len());
        let seed = SegmentPoint::on_segment(p, s as u32, segs[s][0], segs[s][1]);
        assert_eq!(idx.closest_from(p, Some(seed)), want, "p {p} seed {s}");
    }
}

#[test]
fn segment_soup_matches_brute_force() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    for n in [1usize, 2, 7, 100, 3000] {
        let segs: Vec<[DVec3; 2]> = (0..n)
            .map(|_| {
                let a = rng.point(-1.0, 1.0);
                [a, a + rng.point(-0.1, 0.1)]
            })
            .collect();
        let queries: Vec<DVec3> = (0..400).map(|_| rng.point(-1.5, 1.5)).collect();
        check_segments(&segs, &queries, &mut rng);
    }
}

#[test]
fn segment_ties_at_shared_vertices_go_to_the_lowest_segment() {
    // The edges of an icosphere, each listed twice: every vertex is the end
    // of ten segments, and every segment has a duplicate.
    let m = shapes::icosphere(2);
    let mut segs = Vec::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            segs.push([m.positions[a as usize], m.positions[b as usize]]);
        }
    }
    let mut rng = Rng(99);
    let mut queries: Vec<DVec3> = m.positions.clone();
    queries.extend((0..500).map(|_| rng.point(-1.3, 1.3)));
    queries.push(DVec3::ZERO); // equidistant from a great many segments
    check_segments(&segs, &queries, &mut rng);
    for &v in &m.positions {
        let c = SegmentIndex::new(segs.len(), |i| segs[i])
            .closest(v)
            .unwrap();
        assert_eq!((c.point, c.distance_squared), (v, 0.0));
    }
}

#[test]
fn segments_far_from_the_origin_match_brute_force() {
    let mut rng = Rng(7);
    let off = DVec3::new(1e4, -3e4, 2e4);
    let segs: Vec<[DVec3; 2]> = (0..500)
        .map(|_| {
            let a = off + rng.point(-1.0, 1.0);
            [a, a + rng.point(-0.05, 0.05)]
        })
        .collect();
    let queries: Vec<DVec3> = (0..400).map(|_| off + rng.point(-1.2, 1.2)).collect();
    check_segments(&segs, &queries, &mut rng);
}

#[test]
fn non_finite_queries_find_no_segment() {
    let idx = SegmentIndex::new(3, |i| [DVec3::splat(i as f64), DVec3::ONE]);
    for p in [DVec3::NAN, DVec3::INFINITY, DVec3::new(0.0, f64::NAN, 1.0)] {
        assert!(idx.closest(p).is_none());
    }
}

/// Lowest (distance², index) over all points.
fn brute_closest(pts: &[DVec3], p: DVec3) -> Option<(u32, f64)> {
    let mut best: Option<(u32, f64)> = None;
    for (i, v) in pts.iter().enumerate() {
        let d2 = v.distance_squared(p);
        if best.is_none_or(|(_, e)| d2 < e) {
            best = Some((i as u32, d2));
        }
    }
    best
}

fn check_points(pts: &[DVec3], queries: &[DVec3], radii: &[f64]) {
    let idx = PointIndex::new(pts);
    assert_eq!(idx.len(), pts.len());
    for &p in queries {
        assert_eq!(idx.closest(p), brute_closest(pts, p), "p {p}");
        for &r in radii {
            let want = pts.iter().any(|v| v.distance(p) <= r);
            assert_eq!(idx.any_within(p, r), want, "p {p} r {r}");
        }
        // Radii exactly at the distance of a point are inclusive.
        let (i, _) = brute_closest(pts, p).unwrap();
        assert!(idx.any_within(p, pts[i as usize].distance(p)));
        for v in pts.iter().take(20) {
            assert!(idx.any_within(p, v.distance(p)));
        }
    }
}

#[test]
fn point_cloud_matches_brute_force() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for n in [1usize, 5, 64, 5000] {
        let pts: Vec<DVec3> = (0..n).map(|_| rng.point(-1.0, 1.0)).collect();
        let mut queries: Vec<DVec3> = (0..300).map(|_| rng.point(-1.5, 1.5)).collect();
        queries.extend(pts.iter().take(50));
        check_points(&pts, &queries, &[0.0, 1e-9, 1e-3, 0.05, 0.3, 10.0]);
    }
}

#[test]
fn duplicate_points_tie_to_the_lowest_index() {
    let m = shapes::icosphere(3);
    let mut pts = m.positions.clone();
    pts.extend(m.positions.iter().rev());
    let mut rng = Rng(3);
    let mut queries: Vec<DVec3> = (0..300).map(|_| rng.point(-1.2, 1.2)).collect();
    queries.extend(m.positions.iter().step_by(7));
    queries.push(DVec3::ZERO);
    check_points(&pts, &queries, &[0.0, 1e-3, 0.1]);
}

#[test]
fn points_far_from_the_origin_match_brute_force() {
    let mut rng = Rng(11);
    let off = DVec3::new(-2e4, 5e3, 1e4);
    let pts: Vec<DVec3> = (0..2000).map(|_| off + rng.point(-1.0, 1.0)).collect();
    let queries: Vec<DVec3> = (0..300).map(|_| off + rng.point(-1.1, 1.1)).collect();
    check_points(&pts, &queries, &[0.0, 1e-4, 0.02, 0.2]);
}
