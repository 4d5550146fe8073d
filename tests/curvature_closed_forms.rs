//! Curvature estimates against closed forms: spheres, a cylinder and tori,
//! with the error statistics asserted (median and max relative error).

use glam::DVec3;
use isoremesh::curvature::{principal_curvatures, Curvature, CurvatureOptions};
use isoremesh::{shapes, TriMesh};

fn estimate(mesh: &TriMesh) -> Vec<Curvature> {
    principal_curvatures(mesh, &CurvatureOptions::default(), None).expect("valid mesh")
}

/// (median, max) of the values.
fn median_max(mut errs: Vec<f64>) -> (f64, f64) {
    assert!(!errs.is_empty());
    errs.sort_by(f64::total_cmp);
    (errs[errs.len() / 2], *errs.last().unwrap())
}

fn scaled(mut m: TriMesh, s: f64) -> TriMesh {
    for p in &mut m.positions {
        *p *= s;
    }
    m
}

#[test]
fn icosphere_has_k1_equal_k2_equal_one_over_r() {
    let r = 2.5;
    let mesh = scaled(shapes::icosphere(4), r);
    let curv = estimate(&mesh);
    let mut errs = Vec::new();
    for c in &curv {
        assert!(c.k1 >= c.k2);
        errs.push((c.k1 * r - 1.0).abs());
        errs.push((c.k2 * r - 1.0).abs());
    }
    let (med, max) = median_max(errs);
    eprintln!("icosphere(4) r={r}: median rel err {med:.2e}, max {max:.2e}");
    assert!(med < 0.01, "median {med}");
    assert!(max < 0.03, "max {max}");
}

#[test]
fn uv_sphere_has_k1_equal_k2_equal_one_over_r() {
    let r = 1.5;
    let mesh = shapes::uv_sphere(r, 48, 96);
    let curv = estimate(&mesh);
    let mut errs = Vec::new();
    for c in &curv {
        errs.push((c.k1 * r - 1.0).abs());
        errs.push((c.k2 * r - 1.0).abs());
    }
    let (med, max) = median_max(errs);
    eprintln!("uv_sphere(48x96) r={r}: median rel err {med:.2e}, max {max:.2e}");
    assert!(med < 0.02, "median {med}");
    // The poles are fans of 96 needles.
    assert!(max < 0.10, "max {max}");
}

#[test]
fn cylinder_has_one_over_r_around_and_zero_along_the_axis() {
    let (r, h, rows) = (0.8, 3.0, 24u32);
    let mesh = shapes::open_cylinder(r, h, 64, rows);
    let curv = estimate(&mesh);
    let dz = h / rows as f64;
    let (mut e1, mut e2, mut dir_err) = (Vec::new(), Vec::new(), 0.0f64);
    let mut boundary = Vec::new();
    for (p, c) in mesh.positions.iter().zip(&curv) {
        if p.z < 2.5 * dz || p.z > h - 2.5 * dz {
            boundary.push((c.k1 * r - 1.0).abs());
            continue;
        }
        e1.push((c.k1 * r - 1.0).abs());
        e2.push((c.k2 * r).abs());
        // dir2 (k = 0) runs along the axis; dir1 is tangent to the circle.
        dir_err = dir_err.max(1.0 - c.dir2.z.abs());
        let radial = DVec3::new(p.x, p.y, 0.0).normalize();
        dir_err = dir_err.max(c.dir1.dot(radial).abs()).max(c.dir1.z.abs());
    }
    let (m1, x1) = median_max(e1);
    let (m2, x2) = median_max(e2);
    let (mb, xb) = median_max(boundary);
    eprintln!(
        "cylinder: k1 median {m1:.2e} max {x1:.2e}; |k2|·r median {m2:.2e} max {x2:.2e}; \
         direction err {dir_err:.2e}; boundary rows k1 median {mb:.2e} max {xb:.2e}"
    );
    assert!(m1 < 0.01 && x1 < 0.02, "k1 {m1} {x1}");
    assert!(m2 < 0.01 && x2 < 0.02, "k2 {m2} {x2}");
    assert!(dir_err < 1e-3, "directions {dir_err}");
    // Near the boundary the estimate stays sane, if less exact.
    assert!(xb < 0.15, "boundary max {xb}");
}

/// Torus around z with major radius `big`, tube radius `r`: along the tube
/// k = 1/r, around the axis k = cos v / (R + r cos v).
fn check_torus(big: f64, r: f64) -> (f64, f64) {
    let mesh = shapes::torus(big, r, 192, 96);
    let curv = estimate(&mesh);
    let mut errs = Vec::new();
    let mut sign_ok = true;
    for (p, c) in mesh.positions.iter().zip(&curv) {
        let rho = (p.x * p.x + p.y * p.y).sqrt();
        let cos_v = (rho - big) / r;
        let tube = 1.0 / r;
        let other = cos_v / (big + r * cos_v);
        let (e1, e2) = (tube.max(other), tube.min(other));
        // Relative to the largest curvature so that the zero crossing of the
        // second curvature does not blow the ratio up.
        let scale = tube.abs().max(other.abs());
        errs.push((c.k1 - e1).abs() / scale);
        errs.push((c.k2 - e2).abs() / scale);
        sign_ok &= c.k2.signum() == e2.signum() || e2.abs() < 0.05 * scale;
    }
    assert!(sign_ok, "k2 sign differs from cos v");
    median_max(errs)
}

#[test]
fn torus_matches_closed_form() {
    for (big, r) in [(3.0, 1.0), (1.5, 1.0)] {
        let (med, max) = check_torus(big, r);
        eprintln!("torus R={big} r={r}: median rel err {med:.2e}, max {max:.2e}");
        assert!(med < 0.01, "median {med}");
        assert!(max < 0.03, "max {max}");
    }
}

#[test]
fn irregular_mesh_stays_accurate_with_smoothing() {
    // Jitter an icosphere tangentially and reproject: irregular valences are
    // already there, this adds irregular edge lengths and angles.
    let r = 1.0;
    let mut mesh = shapes::icosphere(5);
    let mut seed = 0x9e3779b97f4a7c15u64;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let h = 0.02; // about the edge length of icosphere(5)
    for p in &mut mesh.positions {
        let d = DVec3::new(rnd(), rnd(), rnd()) * 0.5 * h;
        *p = (*p + d).normalize() * r;
    }
    let rough = principal_curvatures(
        &mesh,
        &CurvatureOptions {
            smoothing_passes: 0,
        },
        None,
    )
    .expect("valid");
    let smooth = estimate(&mesh);
    let err = |curv: &[Curvature]| {
        median_max(
            curv.iter()
                .flat_map(|c| [(c.k1 * r - 1.0).abs(), (c.k2 * r - 1.0).abs()])
                .collect(),
        )
    };
    let (m0, x0) = err(&rough);
    let (m1, x1) = err(&smooth);
    eprintln!("jittered icosphere(5): raw median {m0:.2e} max {x0:.2e}; smoothed median {m1:.2e} max {x1:.2e}");
    assert!(m1 < 0.05, "smoothed median {m1}");
    assert!(m1 < m0, "smoothing should reduce the median error");
    assert!(x1 < x0, "smoothing should reduce the max error");
}
