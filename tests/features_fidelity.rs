//! The feature-fidelity metric: distances from sampled input edges to the
//! nearest edge of another mesh, against brute force and known geometry.

use glam::DVec3;
use isoremesh::features::{boundary_edges, mesh_edges, sharp_edges};
use isoremesh::shapes;
use isoremesh::stats::polyline::{boundary_distance, polyline_distance, sharp_edge_distance};

fn seg_dist(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let d = b - a;
    let t = if d.length_squared() > 0.0 {
        ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + d * t)).length()
}

/// Straightforward reimplementation: explicit samples, linear scan.
fn brute(
    fp: &[DVec3],
    fe: &[[u32; 2]],
    step: f64,
    tp: &[DVec3],
    te: &[[u32; 2]],
) -> (f64, f64, usize) {
    let mut samples = Vec::new();
    for &[a, b] in fe {
        let (pa, pb) = (fp[a as usize], fp[b as usize]);
        let k = ((pb - pa).length() / step).ceil().max(1.0) as usize;
        for j in 0..=k {
            samples.push(pa + (pb - pa) * (j as f64 / k as f64));
        }
    }
    let d: Vec<f64> = samples
        .iter()
        .map(|&p| {
            te.iter()
                .map(|&[a, b]| seg_dist(p, tp[a as usize], tp[b as usize]))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let max = d.iter().copied().fold(0.0, f64::max);
    (max, d.iter().sum::<f64>() / d.len() as f64, d.len())
}

#[test]
fn polyline_distance_matches_brute_force() {
    let cube = shapes::cube(1, DVec3::ZERO, DVec3::ONE);
    let sphere = shapes::translated(shapes::icosphere(2), DVec3::splat(0.3));
    let torus = shapes::torus(0.8, 0.3, 20, 10);
    for (from, to) in [(&cube, &sphere), (&cube, &torus), (&torus, &sphere)] {
        let fe = sharp_edges(from, 20.0);
        assert!(!fe.is_empty());
        let te = mesh_edges(to);
        for step in [0.05, 0.3] {
            let got = polyline_distance(&from.positions, &fe, step, &to.positions, &te).unwrap();
            let (max, mean, n) = brute(&from.positions, &fe, step, &to.positions, &te);
            assert_eq!(got.samples, n);
            assert!((got.max - max).abs() < 1e-12, "{} vs {max}", got.max);
            assert!((got.mean - mean).abs() < 1e-9, "{} vs {mean}", got.mean);
            assert!(got.max > 0.01);
        }
    }
}

#[test]
fn a_finer_cube_keeps_the_coarse_cubes_edges_exactly() {
    let coarse = shapes::cube(1, DVec3::ZERO, DVec3::ONE);
    let fine = shapes::cube(7, DVec3::ZERO, DVec3::ONE);
    let l = 1.0 / 7.0;
    let d = sharp_edge_distance(&coarse, &fine, 45.0, l / 4.0).unwrap();
    assert!(d.max < 1e-12, "{d:?}");
    // 12 edges of length 1 sampled every ≤ L/4: 28 pieces, 29 points each.
    assert_eq!(d.samples, 12 * 29);
    // A rounded output (a sphere around the cube) misses them by a lot.
    let sphere = shapes::translated(shapes::icosphere(3), DVec3::splat(0.5));
    let d = sharp_edge_distance(&coarse, &sphere, 45.0, l / 4.0).unwrap();
    assert!(d.max > 0.1, "{d:?}");
}

#[test]
fn shifted_boundary_is_measured_in_absolute_units() {
    let a = shapes::grid(1.0, 4);
    let b = shapes::translated(shapes::grid(1.0, 9), DVec3::new(0.0, 0.0, 0.25));
    let d = boundary_distance(&a, &b, 0.01).unwrap();
    assert!(
        (d.max - 0.25).abs() < 1e-12 && (d.mean - 0.25).abs() < 1e-12,
        "{d:?}"
    );
    assert_eq!(boundary_edges(&a).len(), 16);
}

#[test]
fn empty_and_degenerate_inputs() {
    let closed = shapes::icosphere(1);
    let grid = shapes::grid(1.0, 2);
    // No source edges: no measurement.
    assert!(boundary_distance(&closed, &grid, 0.1).is_none());
    assert!(sharp_edge_distance(&closed, &grid, 45.0, 0.1).is_none());
    // No target edges: infinitely far.
    let d = boundary_distance(&grid, &closed, 0.1).unwrap();
    assert!(d.max.is_infinite());
    // Out-of-range edges are skipped; a bad step samples end points only.
    let pts = [DVec3::ZERO, DVec3::X];
    let d = polyline_distance(&pts, &[[0, 1], [0, 9]], f64::NAN, &pts, &[[0, 1]]).unwrap();
    assert_eq!(d.samples, 2);
    assert_eq!(d.max, 0.0);
    assert!(polyline_distance(&pts, &[[5, 9]], 0.1, &pts, &[[0, 1]]).is_none());
}
