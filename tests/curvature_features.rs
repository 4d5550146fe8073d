//! Feature handling and robustness of the curvature estimator: marked creases
//! do not read as curvature and do not diffuse; degenerate input is survived.

use glam::DVec3;
use isoremesh::curvature::{
    feature_curve_curvature, principal_curvatures, Curvature, CurvatureError, CurvatureOptions,
};
use isoremesh::{shapes, TriMesh};
use std::f64::consts::TAU;

fn on_bound(x: f64) -> bool {
    x.abs() < 1e-12 || (x - 1.0).abs() < 1e-12
}

/// Unit-cube crease predicate: both endpoints on the same cube edge line,
/// i.e. sharing two coordinates that sit on the box bounds.
fn cube_crease(mesh: &TriMesh) -> impl Fn(u32, u32) -> bool + Sync + '_ {
    move |a, b| {
        let (p, q) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        (0..3)
            .filter(|&i| on_bound(p[i]) && (p[i] - q[i]).abs() < 1e-12)
            .count()
            >= 2
    }
}

fn on_cube_edge(p: DVec3) -> bool {
    (0..3).filter(|&i| on_bound(p[i])).count() >= 2
}

#[test]
fn cube_with_marked_creases_is_flat_everywhere() {
    let mesh = shapes::cube(8, DVec3::ZERO, DVec3::ONE);
    let pred = cube_crease(&mesh);
    let curv = principal_curvatures(&mesh, &CurvatureOptions::default(), Some(&pred)).unwrap();
    let worst = curv.iter().map(Curvature::max_abs).fold(0.0, f64::max);
    assert!(worst < 1e-9, "max |k| {worst}");

    // Without the predicate the crease reads as tight curvature (which is
    // what an unpreserved crease should do), proving the predicate matters.
    let raw = principal_curvatures(&mesh, &CurvatureOptions::default(), None).unwrap();
    let crease_min = mesh
        .positions
        .iter()
        .zip(&raw)
        .filter(|(p, _)| on_cube_edge(**p))
        .map(|(_, c)| c.max_abs())
        .fold(f64::INFINITY, f64::min);
    assert!(crease_min > 2.0, "unmarked crease |k| {crease_min}");
}

/// Cylinder of radius r, height h, with flat caps made of `cap_rings`
/// concentric rings; all shared vertices welded. Returns the mesh and the
/// number of side vertices (the side rows come first).
fn capped_cylinder(r: f64, h: f64, segs: u32, rows: u32, cap_rings: u32) -> TriMesh {
    let mut mesh = shapes::open_cylinder(r, h, segs, rows);
    for (z, top) in [(0.0, false), (h, true)] {
        let rim_row = if top { rows } else { 0 };
        let mut ring: Vec<u32> = (0..segs).map(|j| rim_row * segs + j).collect();
        for i in 1..=cap_rings {
            let rr = r * (cap_rings - i) as f64 / cap_rings as f64;
            let inner: Vec<u32> = if i == cap_rings {
                mesh.positions.push(DVec3::new(0.0, 0.0, z));
                vec![(mesh.positions.len() - 1) as u32; segs as usize]
            } else {
                (0..segs)
                    .map(|j| {
                        let a = TAU * (j as f64 + 0.5 * i as f64) / segs as f64;
                        mesh.positions
                            .push(DVec3::new(rr * a.cos(), rr * a.sin(), z));
                        (mesh.positions.len() - 1) as u32
                    })
                    .collect()
            };
            for j in 0..segs as usize {
                let k = (j + 1) % segs as usize;
                let mut tris = vec![[ring[j], ring[k], inner[j]]];
                if inner[j] != inner[k] {
                    tris.push([ring[k], inner[k], inner[j]]);
                }
                for mut t in tris {
                    let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
                    let n = (b - a).cross(c - a);
                    if (n.z > 0.0) != top {
                        t.swap(1, 2);
                    }
                    mesh.triangles.push(t);
                }
            }
            ring = inner;
        }
    }
    mesh
}

#[test]
fn capped_cylinder_rim_takes_the_curved_side_and_caps_stay_flat() {
    let (r, h) = (1.0, 2.0);
    let mesh = capped_cylinder(r, h, 64, 16, 6);
    let on_rim = |p: DVec3| {
        ((p.x * p.x + p.y * p.y).sqrt() - r).abs() < 1e-9
            && (p.z.abs() < 1e-12 || (p.z - h).abs() < 1e-12)
    };
    let rim =
        |a: u32, b: u32| on_rim(mesh.positions[a as usize]) && on_rim(mesh.positions[b as usize]);
    let curv = principal_curvatures(&mesh, &CurvatureOptions::default(), Some(&rim)).unwrap();
    let (mut cap_max, mut rim_err, mut side_err) = (0.0f64, 0.0f64, 0.0f64);
    for (p, c) in mesh.positions.iter().zip(&curv) {
        let rho = (p.x * p.x + p.y * p.y).sqrt();
        if on_rim(*p) {
            rim_err = rim_err.max((c.max_abs() * r - 1.0).abs());
        } else if rho < r - 1e-9 {
            cap_max = cap_max.max(c.max_abs());
        } else {
            side_err = side_err.max((c.k1 * r - 1.0).abs()).max((c.k2 * r).abs());
        }
    }
    eprintln!("capped cylinder: cap max |k| {cap_max:.2e}, rim err {rim_err:.2e}, side err {side_err:.2e}");
    assert!(cap_max < 1e-9, "cap interior reads {cap_max}");
    assert!(rim_err < 0.05, "rim {rim_err}");
    assert!(side_err < 0.05, "side {side_err}");

    // The rim polyline is a circle of radius r.
    let kc = feature_curve_curvature(&mesh, Some(&rim)).unwrap();
    for (p, k) in mesh.positions.iter().zip(&kc) {
        if on_rim(*p) {
            assert!((k * r - 1.0).abs() < 1e-9, "rim curve curvature {k}");
        } else {
            assert_eq!(*k, 0.0);
        }
    }

    // Unmarked, the 90° rim bleeds into the cap.
    let raw = principal_curvatures(&mesh, &CurvatureOptions::default(), None).unwrap();
    let cap_raw = mesh
        .positions
        .iter()
        .zip(&raw)
        .filter(|(p, _)| (p.x * p.x + p.y * p.y).sqrt() < r - 1e-9)
        .map(|(_, c)| c.max_abs())
        .fold(0.0, f64::max);
    assert!(cap_raw > 1.0, "unmarked rim should spread, got {cap_raw}");
}

#[test]
fn polyline_corners_and_straight_boundaries_have_zero_curve_curvature() {
    let grid = shapes::grid(2.0, 6);
    let kc = feature_curve_curvature(&grid, None).unwrap();
    assert!(kc.iter().all(|&k| k == 0.0));
    let cube = shapes::cube(4, DVec3::ZERO, DVec3::ONE);
    let pred = cube_crease(&cube);
    let kc = feature_curve_curvature(&cube, Some(&pred)).unwrap();
    assert!(kc.iter().all(|&k| k.abs() < 1e-12));
    // The open cylinder's boundary loops are circles.
    let cyl = shapes::open_cylinder(0.5, 1.0, 40, 3);
    let kc = feature_curve_curvature(&cyl, None).unwrap();
    for (p, k) in cyl.positions.iter().zip(&kc) {
        let boundary = p.z.abs() < 1e-12 || (p.z - 1.0).abs() < 1e-12;
        let expected = if boundary { 2.0 } else { 0.0 };
        assert!((k - expected).abs() < 1e-9, "{p} {k}");
    }
}

#[test]
fn degenerate_input_is_survived() {
    let r = 1.0;
    let mut mesh = shapes::icosphere(3);
    let n = mesh.positions.len() as u32;
    // A repeated-index face, a zero-area face on existing vertices, an
    // isolated vertex, a non-manifold fin and a flipped face.
    mesh.triangles.push([0, 0, 1]);
    let t0 = mesh.triangles[0];
    mesh.positions.push(mesh.positions[t0[0] as usize]);
    mesh.triangles.push([t0[0], t0[1], n]);
    mesh.positions.push(DVec3::new(5.0, 5.0, 5.0));
    let isolated = n + 1;
    mesh.positions.push(DVec3::new(0.0, 0.0, 3.0));
    mesh.triangles.push([t0[0], t0[1], n + 2]);
    let flipped = 100;
    mesh.triangles[flipped].swap(1, 2);
    let curv = principal_curvatures(&mesh, &CurvatureOptions::default(), None).unwrap();
    assert_eq!(curv.len(), mesh.positions.len());
    assert!(curv
        .iter()
        .all(|c| c.k1.is_finite() && c.k2.is_finite() && c.dir1.is_finite()));
    assert_eq!(curv[isolated as usize], Curvature::FLAT);
    // Vertices away from the damage keep their curvature.
    let damaged: Vec<DVec3> = [t0[0], t0[1], t0[2], 0, 1]
        .iter()
        .chain(&mesh.triangles[flipped])
        .map(|&v| mesh.positions[v as usize])
        .collect();
    let mut checked = 0;
    for (v, c) in curv.iter().enumerate().take(n as usize) {
        let p = mesh.positions[v];
        if damaged.iter().all(|d| (*d - p).length() > 0.5) {
            assert!((c.k1 * r - 1.0).abs() < 0.05 && (c.k2 * r - 1.0).abs() < 0.05);
            checked += 1;
        }
    }
    assert!(checked > 100);

    // A NaN position poisons nothing else.
    let mut nan = shapes::icosphere(2);
    nan.positions[0] = DVec3::NAN;
    let curv = principal_curvatures(&nan, &CurvatureOptions::default(), None).unwrap();
    assert!(curv.iter().all(|c| c.k1.is_finite() && c.k2.is_finite()));
}

#[test]
fn bad_indices_are_an_error_and_empty_is_fine() {
    let mesh = TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y], vec![[0, 1, 3]]);
    assert_eq!(
        principal_curvatures(&mesh, &CurvatureOptions::default(), None),
        Err(CurvatureError::IndexOutOfRange {
            face: 0,
            vertex_count: 3
        })
    );
    let empty = TriMesh::default();
    assert!(
        principal_curvatures(&empty, &CurvatureOptions::default(), None)
            .unwrap()
            .is_empty()
    );
}

mod random_soup {
    use super::*;
    use isoremesh::sizing::{SizingField, SizingOptions};
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Arbitrary soups (duplicates, repeated indices, non-manifold fans,
        /// mixed orientation) give finite curvature and a valid sizing field.
        #[test]
        fn soups_never_break_the_estimator(
            pts in prop::collection::vec((0i32..4, 0i32..4, 0i32..4), 3..30),
            tris in prop::collection::vec((0usize..30, 0usize..30, 0usize..30), 0..60),
        ) {
            let positions: Vec<DVec3> = pts
                .iter()
                .map(|&(x, y, z)| DVec3::new(x as f64, y as f64, z as f64))
                .collect();
            let n = positions.len();
            let triangles = tris
                .iter()
                .map(|&(a, b, c)| [(a % n) as u32, (b % n) as u32, (c % n) as u32])
                .collect();
            let mesh = TriMesh::new(positions, triangles);
            let feature = |a: u32, b: u32| (a + b) % 3 == 0;
            let curv = principal_curvatures(&mesh, &CurvatureOptions::default(), Some(&feature))
                .unwrap();
            prop_assert_eq!(curv.len(), n);
            for c in &curv {
                prop_assert!(c.k1.is_finite() && c.k2.is_finite() && c.k1 >= c.k2);
                prop_assert!(c.dir1.is_finite() && c.dir2.is_finite());
            }
            let opts = SizingOptions::for_tolerance(0.01, 5.0);
            let field = SizingField::build(&mesh, &curv, &opts, Some(&feature)).unwrap();
            for &h in field.vertex_sizes() {
                prop_assert!(h >= opts.min_edge_length && h <= opts.max_edge_length);
            }
        }
    }
}
