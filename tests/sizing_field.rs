//! The sizing field against closed forms, clamping, gradation and
//! evaluation.

use glam::DVec3;
use isoremesh::curvature::{principal_curvatures, CurvatureOptions};
use isoremesh::sizing::{
    cone_target_length, crease_target_length, target_length, SizingError, SizingField,
    SizingOptions, DEFAULT_GRADATION, DEFAULT_MAX_EDGE_FRACTION, DEFAULT_RELATIVE_TOLERANCE,
};
use isoremesh::{shapes, TriMesh};

fn field(mesh: &TriMesh, opts: &SizingOptions) -> SizingField {
    SizingField::from_mesh(mesh, opts, &CurvatureOptions::default(), None).expect("valid")
}

fn wide(tolerance: f64) -> SizingOptions {
    SizingOptions {
        tolerance,
        min_edge_length: 1e-6,
        max_edge_length: 1e3,
        gradation: DEFAULT_GRADATION,
        // The closed forms are those of the smooth surface the mesh samples.
        crease_bound: false,
    }
}

fn scaled(mut m: TriMesh, s: f64) -> TriMesh {
    for p in &mut m.positions {
        *p *= s;
    }
    m
}

fn edges(mesh: &TriMesh) -> impl Iterator<Item = (usize, usize)> + '_ {
    mesh.triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k] as usize, t[(k + 1) % 3] as usize)))
}

#[test]
fn sphere_sizes_follow_the_dunyach_formula() {
    let r = 2.0;
    let mesh = scaled(shapes::icosphere(5), r);
    let eps = 1e-3;
    let f = field(&mesh, &wide(eps));
    let expected = (6.0 * eps * r - 3.0 * eps * eps).sqrt();
    let mut errs: Vec<f64> = f
        .vertex_sizes()
        .iter()
        .map(|h| (h / expected - 1.0).abs())
        .collect();
    errs.sort_by(f64::total_cmp);
    let (med, max) = (errs[errs.len() / 2], errs[errs.len() - 1]);
    eprintln!(
        "sphere r={r} eps={eps}: expected {expected:.4}, median rel err {med:.2e}, max {max:.2e}"
    );
    // Curvature errors enter the size as a square root: half as large.
    assert!(med < 0.005 && max < 0.02, "{med} {max}");
}

#[test]
fn cylinder_side_is_sized_by_its_radius() {
    let r = 0.5;
    let mesh = shapes::open_cylinder(r, 2.0, 96, 32);
    let eps = 2e-4;
    let f = field(&mesh, &wide(eps));
    let expected = (6.0 * eps * r - 3.0 * eps * eps).sqrt();
    for h in f.vertex_sizes() {
        // The boundary circles' chord bound sqrt(8εr − 4ε²) is looser, so the
        // surface bound governs every vertex.
        assert!((h / expected - 1.0).abs() < 1e-3, "{h} vs {expected}");
    }
}

#[test]
fn coarse_input_creases_bound_the_size() {
    use std::f64::consts::PI;
    // A 12-sided prism: neighbouring side faces meet at 30°, everything else
    // is flat. A chord across a side edge cuts it by (ℓ/2)·tan(15°).
    let n = 12;
    let mesh = shapes::open_cylinder(0.5, 1.0, n, 4);
    let eps = 2e-3;
    let expected = 2.0 * eps / (PI / n as f64).tan();
    assert!((crease_target_length(2.0 * PI / n as f64, eps) / expected - 1.0).abs() < 1e-12);
    let on = SizingOptions {
        crease_bound: true,
        ..wide(eps)
    };
    for h in field(&mesh, &on).vertex_sizes() {
        assert!((h / expected - 1.0).abs() < 1e-9, "{h} vs {expected}");
    }
    // Without it, the smooth bound of the cylinder the prism samples gives
    // edges whose crossing of a side edge exceeds 2ε.
    for h in field(&mesh, &wide(eps)).vertex_sizes() {
        assert!(0.5 * h * (PI / n as f64).tan() > 2.0 * eps, "{h}");
    }
    // A fine tessellation of the same cylinder: the bound does not bind.
    let fine = shapes::open_cylinder(0.5, 1.0, 96, 32);
    let on = SizingOptions {
        crease_bound: true,
        ..wide(eps)
    };
    assert_eq!(
        field(&fine, &on).vertex_sizes(),
        field(&fine, &wide(eps)).vertex_sizes()
    );
    assert_eq!(crease_target_length(0.0, eps), f64::INFINITY);
    assert_eq!(crease_target_length(PI, eps), 0.0);
}

#[test]
fn icosahedron_vertices_get_the_cone_bound() {
    // Defect π/3 at every vertex: cos α = 5/6, tan α = √11/5, so the cone
    // bound √3·ε·5/√11 ≈ 2.61ε is below the crease bound 2ε/tan(20.9°) ≈ 5.24ε.
    let mesh = shapes::icosphere(0);
    let eps = 1e-3;
    let expected = 3f64.sqrt() * eps * 5.0 / 11f64.sqrt();
    assert!((cone_target_length(std::f64::consts::FRAC_PI_3, eps) / expected - 1.0).abs() < 1e-12);
    assert!((cone_target_length(-std::f64::consts::FRAC_PI_3, eps) / expected - 1.0).abs() < 1e-12);
    assert_eq!(cone_target_length(0.0, eps), f64::INFINITY);
    let on = SizingOptions {
        crease_bound: true,
        ..wide(eps)
    };
    for h in field(&mesh, &on).vertex_sizes() {
        assert!((h / expected - 1.0).abs() < 1e-9, "{h} vs {expected}");
    }
    for h in field(&mesh, &wide(eps)).vertex_sizes() {
        assert!(*h > 10.0 * expected, "{h}");
    }
}

#[test]
fn sizes_are_clamped_to_min_and_max() {
    let mesh = shapes::icosphere(3);
    // κ = 1 ≥ 2/ε: the sphere is smaller than the tolerance.
    let opts = SizingOptions {
        tolerance: 2.5,
        min_edge_length: 0.07,
        max_edge_length: 1.0,
        gradation: 0.3,
        crease_bound: true,
    };
    assert_eq!(target_length(1.0, 2.5), 0.0);
    assert!(field(&mesh, &opts)
        .vertex_sizes()
        .iter()
        .all(|&h| h == 0.07));
    // A coarse tolerance whose formula exceeds the maximum.
    let opts = SizingOptions {
        tolerance: 0.1,
        min_edge_length: 0.01,
        max_edge_length: 0.2,
        gradation: 0.3,
        crease_bound: true,
    };
    assert!(target_length(1.0, 0.1) > 0.7);
    assert!(field(&mesh, &opts).vertex_sizes().iter().all(|&h| h == 0.2));
    // Flat: κ = 0 everywhere, straight boundary, corners → maximum.
    let grid = shapes::grid(1.0, 8);
    let f = field(
        &grid,
        &SizingOptions::for_tolerance(1e-3, grid.bbox_diagonal()),
    );
    let max = DEFAULT_MAX_EDGE_FRACTION * grid.bbox_diagonal();
    assert!(f.vertex_sizes().iter().all(|&h| h == max));
}

#[test]
fn gradation_is_exact_on_every_edge() {
    // An unmarked cube: the creases read tight curvature (→ min), the flat
    // faces none (→ max), so the raw field violates any gradation.
    let mesh = shapes::cube(16, DVec3::ZERO, DVec3::ONE);
    let g = 0.25;
    let opts = SizingOptions {
        tolerance: 1e-3,
        min_edge_length: 1e-3,
        max_edge_length: 0.5,
        gradation: g,
        crease_bound: true,
    };
    let raw = field(
        &mesh,
        &SizingOptions {
            gradation: f64::INFINITY,
            ..opts
        },
    );
    let graded = field(&mesh, &opts);
    let (h0, h) = (raw.vertex_sizes(), graded.vertex_sizes());
    let len = |a: usize, b: usize| (mesh.positions[a] - mesh.positions[b]).length();
    assert!(
        edges(&mesh).any(|(a, b)| h0[b] > h0[a] + g * len(a, b) * (1.0 + 1e-9)),
        "the raw field should violate the bound"
    );
    for (a, b) in edges(&mesh) {
        let bound = g * len(a, b);
        assert!(h[b] <= h[a] + bound * (1.0 + 1e-12), "edge {a}-{b}");
        assert!(h[a] <= h[b] + bound * (1.0 + 1e-12), "edge {b}-{a}");
    }
    // Exactness: the result is the largest graded field below the raw one —
    // every vertex keeps its raw size or is tight against a neighbour.
    let mut nbrs = vec![Vec::new(); mesh.positions.len()];
    for (a, b) in edges(&mesh) {
        nbrs[a].push(b);
        nbrs[b].push(a);
    }
    for v in 0..h.len() {
        assert!(h[v] <= h0[v]);
        let tight = h[v] == h0[v]
            || nbrs[v]
                .iter()
                .any(|&u| (h[v] - (h[u] + g * len(u, v))).abs() <= 1e-12 * h[v]);
        assert!(tight, "vertex {v} is below what gradation requires");
    }
    // Creases stay at the minimum, face centres grow away from them.
    let centre = mesh
        .positions
        .iter()
        .position(|p| (*p - DVec3::new(0.5, 0.5, 0.0)).length() < 1e-12)
        .unwrap();
    assert!(h[centre] > 0.1 && h[centre] < 0.5, "{}", h[centre]);
}

#[test]
fn gradation_is_a_no_op_when_already_satisfied() {
    // Sizes vary smoothly from the inner to the outer equator.
    let mesh = shapes::torus(1.5, 1.0, 96, 48);
    let opts = wide(1e-3);
    let raw = field(
        &mesh,
        &SizingOptions {
            gradation: f64::INFINITY,
            ..opts
        },
    );
    let graded = field(&mesh, &opts);
    let h0 = raw.vertex_sizes();
    let (lo, hi) = h0
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &h| (a.min(h), b.max(h)));
    assert!(hi > 1.3 * lo, "the field should vary: {lo} {hi}");
    for (a, b) in edges(&mesh) {
        let l = (mesh.positions[a] - mesh.positions[b]).length();
        assert!(h0[b] <= h0[a] + opts.gradation * l);
    }
    assert_eq!(h0, graded.vertex_sizes());
}

#[test]
fn torus_inner_side_is_finer_than_outer() {
    // With R < 2r the inner equator's |k2| = 1/(R − r) = 2 exceeds the
    // tube's 1/r = 1, while the outer equator is governed by the tube.
    let (big, r) = (1.5, 1.0);
    let mesh = shapes::torus(big, r, 128, 64);
    let eps = 1e-3;
    let f = field(&mesh, &wide(eps));
    let (mut inner, mut outer) = (Vec::new(), Vec::new());
    for (p, &h) in mesh.positions.iter().zip(f.vertex_sizes()) {
        let rho = (p.x * p.x + p.y * p.y).sqrt();
        if p.z.abs() < 1e-9 && rho < big {
            inner.push(h);
        } else if p.z.abs() < 1e-9 {
            outer.push(h);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (hi, ho) = (mean(&inner), mean(&outer));
    let (ei, eo) = (target_length(2.0, eps), target_length(1.0, eps));
    eprintln!("torus: inner {hi:.4} (expected {ei:.4}), outer {ho:.4} (expected {eo:.4})");
    assert!(hi < 0.8 * ho);
    assert!((hi / ei - 1.0).abs() < 0.02 && (ho / eo - 1.0).abs() < 0.02);
}

#[test]
fn marked_cube_is_coarse_everywhere() {
    let mesh = shapes::cube(6, DVec3::ZERO, DVec3::ONE);
    let on = |x: f64| x.abs() < 1e-12 || (x - 1.0).abs() < 1e-12;
    let pred = |a: u32, b: u32| {
        let (p, q) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        (0..3).filter(|&i| on(p[i]) && p[i] == q[i]).count() >= 2
    };
    let opts = SizingOptions::relative(&mesh, DEFAULT_RELATIVE_TOLERANCE);
    let f =
        SizingField::from_mesh(&mesh, &opts, &CurvatureOptions::default(), Some(&pred)).unwrap();
    assert!(f.vertex_sizes().iter().all(|&h| h == opts.max_edge_length));
}

#[test]
fn size_at_interpolates_and_guards() {
    let mesh = shapes::torus(1.5, 1.0, 32, 16);
    let f = field(&mesh, &wide(1e-3));
    let h = f.vertex_sizes();
    for (i, t) in mesh.triangles.iter().enumerate() {
        let i = i as u32;
        assert_eq!(f.size_at(i, DVec3::X), h[t[0] as usize]);
        assert_eq!(f.size_at(i, DVec3::Z), h[t[2] as usize]);
        let c = f.size_at(i, DVec3::splat(1.0 / 3.0));
        let m = (h[t[0] as usize] + h[t[1] as usize] + h[t[2] as usize]) / 3.0;
        assert!((c - m).abs() < 1e-12);
        // Slightly outside: clamped to the edge.
        let e = f.size_at(i, DVec3::new(0.5, 0.5, -1e-3));
        assert!((e - 0.5 * (h[t[0] as usize] + h[t[1] as usize])).abs() < 1e-12);
    }
    assert_eq!(f.size_at(u32::MAX, DVec3::X), f.min_size());
    assert_eq!(
        f.size_at(0, DVec3::NAN),
        f.size_at(0, DVec3::splat(1.0 / 3.0))
    );
    let min = h.iter().copied().fold(f64::INFINITY, f64::min);
    assert_eq!(f.min_size(), min);
    assert_eq!(f.size_at_vertex(3), Some(h[3]));
    assert_eq!(f.size_at_vertex(u32::MAX), None);
}

#[test]
fn build_matches_from_mesh_and_rejects_bad_input() {
    let mesh = shapes::uv_sphere(1.0, 16, 32);
    let opts = SizingOptions::relative(&mesh, 2e-3);
    let curv = principal_curvatures(&mesh, &CurvatureOptions::default(), None).unwrap();
    let a = SizingField::build(&mesh, &curv, &opts, None).unwrap();
    let b = field(&mesh, &opts);
    assert_eq!(a.vertex_sizes(), b.vertex_sizes());

    assert!(matches!(
        SizingField::build(&mesh, &curv[1..], &opts, None),
        Err(SizingError::CurvatureLength { .. })
    ));
    for bad in [
        SizingOptions {
            tolerance: 0.0,
            ..opts
        },
        SizingOptions {
            tolerance: f64::NAN,
            ..opts
        },
        SizingOptions {
            min_edge_length: -1.0,
            ..opts
        },
        SizingOptions {
            max_edge_length: opts.min_edge_length * 0.5,
            ..opts
        },
        SizingOptions {
            max_edge_length: f64::INFINITY,
            ..opts
        },
        SizingOptions {
            gradation: -0.1,
            ..opts
        },
    ] {
        assert!(matches!(
            SizingField::build(&mesh, &curv, &bad, None),
            Err(SizingError::InvalidOptions(_))
        ));
    }
    let broken = TriMesh::new(vec![DVec3::ZERO], vec![[0, 1, 2]]);
    assert!(matches!(
        SizingField::build(&broken, &[], &opts, None),
        Err(SizingError::CurvatureLength { .. })
    ));
    assert!(matches!(
        SizingField::from_mesh(&broken, &opts, &CurvatureOptions::default(), None),
        Err(SizingError::Mesh(_))
    ));
}

#[test]
fn default_options_follow_the_documented_rules() {
    let mesh = scaled(shapes::icosphere(2), 3.0);
    let d = mesh.bbox_diagonal();
    let o = SizingOptions::relative(&mesh, DEFAULT_RELATIVE_TOLERANCE);
    assert!((o.tolerance - 1e-3 * d).abs() < 1e-15);
    assert_eq!(o.min_edge_length, o.tolerance);
    assert!((o.max_edge_length - 0.05 * d).abs() < 1e-15);
    assert_eq!(o.gradation, DEFAULT_GRADATION);
    assert!(o.validate().is_ok());
    // A tolerance coarser than the max fraction keeps max ≥ min.
    let o = SizingOptions::for_tolerance(1.0, 2.0);
    assert!(o.max_edge_length >= o.min_edge_length && o.validate().is_ok());
}
