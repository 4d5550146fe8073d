//! Build time of curvature + sizing on a 330k-triangle sphere. Ignored by
//! default; run in release:
//! `cargo test --release --test sizing_perf -- --ignored --nocapture`.

use isoremesh::curvature::{principal_curvatures, CurvatureOptions};
use isoremesh::shapes;
use isoremesh::sizing::{target_length, SizingField, SizingOptions};
use std::time::Instant;

#[test]
#[ignore = "timing; run in release"]
fn icosphere7_curvature_and_sizing_build_time() {
    let mesh = shapes::icosphere(7);
    assert_eq!(mesh.triangles.len(), 327_680);
    let opts = SizingOptions::relative(&mesh, 1e-4);
    let copts = CurvatureOptions::default();
    let mut best = [f64::INFINITY; 3];
    let mut sizes = Vec::new();
    for _ in 0..5 {
        let t = Instant::now();
        let curv = principal_curvatures(&mesh, &copts, None).unwrap();
        let t_curv = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let field = SizingField::build(&mesh, &curv, &opts, None).unwrap();
        let t_size = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let both = SizingField::from_mesh(&mesh, &opts, &copts, None).unwrap();
        let t_both = t.elapsed().as_secs_f64();
        assert_eq!(field.vertex_sizes(), both.vertex_sizes());
        best = [
            best[0].min(t_curv),
            best[1].min(t_size),
            best[2].min(t_both),
        ];
        sizes = both.vertex_sizes().to_vec();
    }
    eprintln!(
        "icosphere(7), {} vertices, {} triangles, {} threads: curvature {:.1} ms, \
         sizing build {:.1} ms, from_mesh (both, shared topology) {:.1} ms",
        mesh.positions.len(),
        mesh.triangles.len(),
        rayon::current_num_threads(),
        best[0] * 1e3,
        best[1] * 1e3,
        best[2] * 1e3
    );
    let expected = target_length(1.0, opts.tolerance);
    assert!(sizes.iter().all(|h| (h / expected - 1.0).abs() < 0.01));
}
