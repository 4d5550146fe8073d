//! The remesher's guarantees on generated shapes and real meshes: the output
//! is valid, manifold and oriented, keeps the Euler characteristic and the
//! boundary-loop count, has no degenerate face and no face turned away from
//! the input surface, and is identical whatever the thread count.

mod data_support;

use glam::DVec3;
use isoremesh::bvh::SurfaceIndex;
use isoremesh::geometry::{triangle_area, triangle_normal};
use isoremesh::mesh::Mesh;
use isoremesh::remesh::{remesh, NoObserver, Observer, Progress, RemeshError, RemeshOptions};
use isoremesh::stats::{self, StatsOptions};
use isoremesh::{shapes, TriMesh};

fn build(m: &TriMesh) -> Mesh {
    Mesh::from_trimesh(m).unwrap().0
}

/// Checks every guarantee of the remesher on one input; returns the output.
fn check(input: &Mesh, options: &RemeshOptions) -> TriMesh {
    let out = remesh(input, options, &mut NoObserver).expect("remesh");
    out.mesh.validate().expect("valid output");
    assert_eq!(
        out.mesh.euler_characteristic(),
        input.euler_characteristic()
    );
    assert_eq!(out.mesh.boundary_loop_count(), input.boundary_loop_count());
    let inp = input.to_trimesh();
    let res = out.mesh.to_trimesh();
    let diag = inp.bbox_diagonal();
    let index = SurfaceIndex::from_trimesh(&inp);
    for t in &res.triangles {
        let p = res.corner_positions(t);
        assert!(
            triangle_area(p) > 1e-12 * diag * diag,
            "degenerate output face {p:?}"
        );
        let c = (p[0] + p[1] + p[2]) / 3.0;
        let cp = index.closest_point(c).unwrap();
        let n_in = index.face_normal(cp.face);
        // Near sharp creases the closest input face can be the other side;
        // only faces well inside a smooth region must agree.
        if cp.distance_squared.sqrt() < 1e-3 * diag {
            let n_out = triangle_normal(p);
            assert!(
                n_out.dot(n_in) > -0.5,
                "output face turned away from the input: {n_out:?} vs {n_in:?}"
            );
        }
    }
    let s = stats::compute(&res, &StatsOptions::default());
    assert!(s.manifold && s.consistently_oriented);
    assert_eq!(s.degenerate_faces, 0);
    res
}

#[test]
fn generated_shapes_keep_every_invariant() {
    let cases: Vec<(&str, TriMesh, f64)> = vec![
        ("icosphere", shapes::icosphere(3), 0.15),
        ("torus", shapes::torus(2.0, 0.6, 40, 16), 0.2),
        (
            "open cylinder",
            shapes::open_cylinder(1.0, 3.0, 24, 8),
            0.25,
        ),
        ("cube", shapes::cube(1, DVec3::ZERO, DVec3::ONE), 0.1),
        ("thin plate", shapes::thin_plate(2.0, 0.05, 4), 0.12),
        (
            "three components",
            shapes::union(&[
                shapes::icosphere(2),
                shapes::translated(shapes::torus(1.0, 0.3, 24, 10), DVec3::new(4.0, 0.0, 0.0)),
                shapes::translated(shapes::grid(1.5, 6), DVec3::new(0.0, 4.0, 0.0)),
            ]),
            0.2,
        ),
    ];
    for (name, shape, l) in cases {
        let input = build(&shape);
        let out = check(&input, &RemeshOptions::default().with_target_edge_length(l));
        assert!(!out.triangles.is_empty(), "{name}");
    }
}

#[test]
fn real_meshes_keep_every_invariant() {
    for name in ["spot.obj", "fandisk.obj", "fertility.off"] {
        let input = data_support::mesh(name);
        let diag = input.to_trimesh().bbox_diagonal();
        check(
            &input,
            &RemeshOptions::default().with_target_edge_ratio(0.01),
        );
        let _ = diag;
    }
}

#[test]
fn uniform_remeshing_of_spot_meets_the_quality_goals() {
    // A regression test: the statistics of spot at the bench defaults, pinned to ranges.
    let input = data_support::mesh("spot.obj");
    let inp = input.to_trimesh();
    let l = 0.0075 * inp.bbox_diagonal();
    let res = check(&input, &RemeshOptions::default().with_target_edge_length(l));
    let s = stats::compute(
        &res,
        &StatsOptions {
            target_edge_length: Some(l),
            reference: Some(&inp),
            samples_per_side: 20_000,
            ..Default::default()
        },
    );
    let e = s.edge_length.as_ref().unwrap();
    assert!(e.within_band >= 0.97, "band {}", e.within_band);
    assert!((0.95..1.1).contains(&(e.mean / l)), "mean {}", e.mean / l);
    let a = s.angles.as_ref().unwrap();
    assert!(a.min_deg >= 15.0, "min angle {}", a.min_deg);
    assert!(
        a.below_30_fraction <= 0.005,
        "below 30 {}",
        a.below_30_fraction
    );
    let v = s.valence.regular_fraction.unwrap();
    // 84.3 % since the valence-driven collapses (80.9 % before).
    assert!(v >= 0.83, "regular {v}");
    let d = s.distance.as_ref().unwrap();
    assert!(
        d.hausdorff_relative <= 0.0018,
        "hausdorff {}",
        d.hausdorff_relative
    );
    assert!((28_000..42_000).contains(&s.faces), "faces {}", s.faces);
}

#[test]
fn output_is_identical_whatever_the_thread_count() {
    let input = data_support::mesh("fandisk.obj");
    let run = |threads| {
        let o = RemeshOptions::default()
            .with_target_edge_ratio(0.012)
            .with_iterations(4)
            .with_threads(threads);
        let out = remesh(&input, &o, &mut NoObserver).unwrap();
        let t = out.mesh.to_trimesh();
        let bits: Vec<[u64; 3]> = t
            .positions
            .iter()
            .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
            .collect();
        (bits, t.triangles)
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
}

struct CancelAfter {
    calls: u32,
    limit: u32,
    seen: Vec<Progress>,
}

impl Observer for CancelAfter {
    fn progress(&mut self, p: &Progress) {
        self.calls += 1;
        self.seen.push(*p);
    }
    fn is_cancelled(&self) -> bool {
        self.calls >= self.limit
    }
}

#[test]
fn progress_is_reported_and_cancellation_stops_the_run() {
    let input = build(&shapes::icosphere(3));
    let o = RemeshOptions::default()
        .with_target_edge_length(0.1)
        .with_iterations(3);
    let mut all = CancelAfter {
        calls: 0,
        limit: u32::MAX,
        seen: Vec::new(),
    };
    remesh(&input, &o, &mut all).unwrap();
    assert_eq!(all.seen.first().unwrap().iteration, 0);
    assert_eq!(all.seen.last().unwrap().iteration, 3);
    assert!(all.seen.windows(2).all(|w| w[0].fraction <= w[1].fraction));
    let mut cancel = CancelAfter {
        calls: 0,
        limit: 4,
        seen: Vec::new(),
    };
    assert_eq!(
        remesh(&input, &o, &mut cancel).unwrap_err(),
        RemeshError::Cancelled
    );
    assert_eq!(cancel.calls, 4);
}

/// Cancels from its `n`-th check on, counting every check.
struct CancelAtCheck {
    checks: std::sync::atomic::AtomicU32,
    n: u32,
    seen: Vec<Progress>,
}

impl Observer for CancelAtCheck {
    fn progress(&mut self, p: &Progress) {
        self.seen.push(*p);
    }
    fn is_cancelled(&self) -> bool {
        self.checks
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed)
            + 1
            >= self.n
    }
}

#[test]
fn a_cancel_during_preparation_stops_before_the_first_pass() {
    let input = build(&shapes::icosphere(4));
    let o = RemeshOptions::default().with_target_edge_length(0.05);
    // The first check follows the Prepare report; the second is inside
    // preparation, before any pass has run.
    let mut obs = CancelAtCheck {
        checks: 0.into(),
        n: 2,
        seen: Vec::new(),
    };
    assert_eq!(
        remesh(&input, &o, &mut obs).unwrap_err(),
        RemeshError::Cancelled
    );
    assert_eq!(obs.seen.len(), 1, "{:?}", obs.seen);
    assert_eq!(obs.checks.into_inner(), 2);
}

#[test]
fn invalid_options_name_their_field() {
    let input = build(&shapes::icosphere(1));
    let cases = [
        (
            RemeshOptions::default().with_target_edge_length(-1.0),
            "target_edge_length",
        ),
        (
            RemeshOptions::default()
                .with_target_edge_length(1.0)
                .with_target_faces(10),
            "target_edge_length",
        ),
        (
            RemeshOptions::default().with_target_edge_ratio(f64::NAN),
            "target_edge_ratio",
        ),
        (RemeshOptions::default().with_threads(0), "threads"),
        (
            RemeshOptions::default().with_feature_angle(200.0),
            "feature_angle",
        ),
        (
            RemeshOptions {
                min_crease_length: f64::NAN,
                ..Default::default()
            },
            "min_crease_length",
        ),
    ];
    for (o, field) in cases {
        match remesh(&input, &o, &mut NoObserver) {
            Err(RemeshError::InvalidOption { field: f, .. }) => assert_eq!(f, field),
            other => panic!("expected an error on {field}, got {:?}", other.map(|_| ())),
        }
    }
    let tiny = RemeshOptions::default().with_target_edge_length(1e-6);
    assert!(matches!(
        remesh(&input, &tiny, &mut NoObserver),
        Err(RemeshError::TooManyFaces { .. })
    ));
    // An estimate beyond u64 is reported as such, not saturated to a count.
    let tinier = RemeshOptions::default().with_target_edge_length(1e-10);
    match remesh(&input, &tinier, &mut NoObserver) {
        Err(
            e @ RemeshError::TooManyFaces {
                estimated_faces, ..
            },
        ) => {
            assert!(estimated_faces > 1e19, "{estimated_faces}");
            assert!(
                e.to_string().contains("e20 faces") || e.to_string().contains("e21 faces"),
                "{e}"
            );
        }
        other => panic!("expected TooManyFaces, got {:?}", other.map(|_| ())),
    }
}

#[test]
fn target_faces_gives_about_that_many_faces() {
    let input = build(&shapes::icosphere(4));
    let out = remesh(
        &input,
        &RemeshOptions::default().with_target_faces(2000),
        &mut NoObserver,
    )
    .unwrap();
    let f = out.mesh.face_count() as f64;
    assert!((1500.0..2600.0).contains(&f), "faces {f}");
}

#[test]
fn fertility_keeps_every_angle_above_20_degrees() {
    // fertility's features force no small angle (its narrowest feature
    // sector is 59°), so the goal of 20° applies in full. Before the final
    // sliver repair one obtuse triangle beside a crease had 18.6°.
    let input = data_support::mesh("fertility.off");
    let l = 0.0075 * input.to_trimesh().bbox_diagonal();
    let res = check(&input, &RemeshOptions::default().with_target_edge_length(l));
    let s = stats::compute(
        &res,
        &StatsOptions {
            target_edge_length: Some(l),
            ..Default::default()
        },
    );
    let a = s.angles.as_ref().unwrap();
    assert!(a.min_deg >= 20.0, "min angle {}", a.min_deg);
    assert!(
        a.below_30_fraction <= 0.0005,
        "below 30 {}",
        a.below_30_fraction
    );
}

#[test]
fn the_final_shape_pass_leaves_fandisk_almost_no_triangle_below_30_degrees() {
    // Measured with quality.py at the bench defaults: 0.06 % of pymeshlab's
    // triangles are below 30° (the best peer); ours were 0.08 % before the
    // final repair, 0.02 % after its flips alone (10 triangles), and about
    // 0.01 % with the vertex moves as well.
    let input = data_support::mesh("fandisk.obj");
    let l = 0.0075 * input.to_trimesh().bbox_diagonal();
    let out = remesh(
        &input,
        &RemeshOptions::default().with_target_edge_length(l),
        &mut NoObserver,
    )
    .unwrap();
    out.mesh.validate().unwrap();
    assert!(out.report.repair_flips > 0 && out.report.repair_moves > 0);
    let s = stats::compute(
        &out.mesh.to_trimesh(),
        &StatsOptions {
            target_edge_length: Some(l),
            ..Default::default()
        },
    );
    let a = s.angles.as_ref().unwrap();
    let below = (a.below_30_fraction * s.faces as f64).round() as u64;
    assert!(below <= 7, "{below} triangles below 30°");
    // fandisk's narrowest feature sector is 19.38° (an input line turning
    // sharply); line vertices sliding to better places reach it.
    assert!(a.min_deg >= 19.0, "min angle {}", a.min_deg);
    assert!(s.edge_length.as_ref().unwrap().within_band >= 0.98);
}

#[test]
fn the_report_counts_and_times_every_iteration() {
    let input = data_support::mesh("spot.obj");
    let l = 0.0075 * input.to_trimesh().bbox_diagonal();
    let options = RemeshOptions::default()
        .with_target_edge_length(l)
        .with_iterations(4);
    let out = remesh(&input, &options, &mut NoObserver).unwrap();
    let r = &out.report;
    assert_eq!(r.iterations.len(), 4);
    // spot's 5,856 input faces are coarse for this L: the first iteration
    // splits most, and the face count settles.
    assert!(r.iterations[0].splits > 10 * r.iterations[3].splits.max(1));
    assert_eq!(r.iterations[3].faces, out.mesh.face_count() as u64);
    // Per-iteration times are differences of the running totals: they are
    // non-negative and add up to the totals; the final sliver repair runs
    // after the last iteration and has its own total.
    let sum = |f: fn(&isoremesh::remesh::PassTimes) -> f64| {
        r.iterations.iter().map(|i| f(&i.seconds)).sum::<f64>()
    };
    for (name, per, total) in [
        ("split", sum(|t| t.split), r.seconds.split),
        ("collapse", sum(|t| t.collapse), r.seconds.collapse),
        ("relax", sum(|t| t.relax), r.seconds.relax),
        ("project", sum(|t| t.project), r.seconds.project),
        ("flip", sum(|t| t.flip), r.seconds.flip),
    ] {
        assert!(
            (per - total).abs() <= 1e-9 * total.max(1.0),
            "{name}: {per} vs {total}"
        );
    }
    assert!(r.seconds.repair > 0.0);
    assert!(r.iterations.iter().all(|i| {
        let t = i.seconds;
        t.prepare == 0.0
            && t.repair == 0.0
            && [t.split, t.collapse, t.flip, t.relax, t.project]
                .iter()
                .all(|&x| x >= 0.0)
    }));
    assert!(r
        .iterations
        .iter()
        .all(|i| i.seconds.split > 0.0 && i.seconds.project > 0.0));
}
