//! Uniform sizing's curvature refinement (`refine_curved`): on a real scan it
//! follows tight curves more closely while edges stay in the length band, and
//! switched off it gives one target everywhere.

mod data_support;

use isoremesh::remesh::{remesh, NoObserver, RemeshOptions};
use isoremesh::stats::{self, StatsOptions};

#[test]
fn refinement_lowers_the_distance_and_keeps_the_band() {
    let input = data_support::mesh("spot.obj");
    let inp = input.to_trimesh();
    let l = 0.0075 * inp.bbox_diagonal();
    let run = |refine: bool| {
        let o = RemeshOptions {
            refine_curved: refine,
            ..RemeshOptions::default().with_target_edge_length(l)
        };
        let out = remesh(&input, &o, &mut NoObserver).unwrap();
        assert_eq!(
            out.report.target_edge_length, l,
            "the report keeps the nominal L"
        );
        let s = stats::compute(
            &out.mesh.to_trimesh(),
            &StatsOptions {
                target_edge_length: Some(l),
                reference: Some(&inp),
                samples_per_side: 50_000,
                ..Default::default()
            },
        );
        (out.report.target_range, s)
    };
    let (range_off, off) = run(false);
    let (range_on, on) = run(true);
    assert_eq!(range_off, [l, l]);
    // Refinement lowers the target, but never to the collapse bound 4/5·L.
    assert!(
        range_on[0] >= 0.9 * l - 1e-12 && range_on[0] < l,
        "{range_on:?}"
    );
    assert_eq!(range_on[1], l);
    let band = |s: &stats::MeshStats| s.edge_length.as_ref().unwrap().within_band;
    let h = |s: &stats::MeshStats| s.distance.as_ref().unwrap().hausdorff_relative;
    assert!(band(&on) >= 0.97, "band with refinement {}", band(&on));
    assert!(
        band(&off) - band(&on) < 0.03,
        "band {} -> {}",
        band(&off),
        band(&on)
    );
    let rms = |s: &stats::MeshStats| s.distance.as_ref().unwrap().rms_relative;
    eprintln!(
        "spot: hausdorff {} -> {}, rms {} -> {}, band {} -> {}",
        h(&off),
        h(&on),
        rms(&off),
        rms(&on),
        band(&off),
        band(&on)
    );
    assert!(h(&on) < h(&off), "hausdorff {} -> {}", h(&off), h(&on));
    assert!(
        rms(&on) < 0.98 * rms(&off),
        "rms {} -> {}",
        rms(&off),
        rms(&on)
    );
    assert!(on.faces > off.faces && (on.faces as f64) < 1.1 * off.faces as f64);
}
