//! The statistics' `features` section: feature counts of a mesh, and against
//! the input, the crease distance, kept corners, and whether the output's
//! feature edges lie on the input's feature lines and cover them.

mod data_support;

use glam::DVec3;
use isoremesh::features::FeatureOptions;
use isoremesh::pipeline;
use isoremesh::remesh::{remesh, NoObserver, RemeshOptions};
use isoremesh::shapes;
use isoremesh::stats::{self, FeatureFidelity, StatsOptions};

/// The job's output fidelity at the bench's default L (0.75% of the diagonal).
fn job_fidelity(name: &str) -> (u64, FeatureFidelity) {
    let input = data_support::load(name);
    let l = 0.0075 * input.mesh.to_trimesh().bbox_diagonal();
    let out = pipeline::run(
        &input,
        &RemeshOptions::default().with_target_edge_length(l),
        &mut NoObserver,
    )
    .unwrap();
    let f = out.stats.output.features.unwrap();
    assert!(out.stats.input.features.unwrap().fidelity.is_none());
    (f.edges, f.fidelity.unwrap())
}

fn assert_features_follow_the_input(edges: u64, f: &FeatureFidelity) {
    assert!(edges > 0);
    assert!(f.reference_corners > 0);
    assert_eq!(f.corners_kept, f.reference_corners);
    assert_eq!(f.edges_on_reference_lines, edges, "{f:?}");
    assert_eq!(f.edges_on_reference_lines_fraction, Some(1.0));
    assert!(f.reference_samples > 0);
    assert_eq!(f.uncovered_samples, 0, "{f:?}");
    assert!(f.max_offset_over_l.unwrap() <= 1e-3);
    assert!(f.sharp_distance_max_over_l.unwrap() <= 0.01, "{f:?}");
}

#[test]
fn a_cube_has_twelve_lines_and_eight_corners() {
    let m = shapes::cube(4, DVec3::ZERO, DVec3::ONE);
    let s = stats::compute(
        &m,
        &StatsOptions {
            features: Some(FeatureOptions::default()),
            ..Default::default()
        },
    );
    let f = s.features.unwrap();
    assert_eq!(
        (f.edges, f.sharp_edges, f.corners, f.lines),
        (48, 48, 8, 12)
    );
    assert!(f.fidelity.is_none());
    // Without feature options there is no section.
    assert!(stats::compute(&m, &StatsOptions::default())
        .features
        .is_none());
}

#[test]
fn fandisk_output_feature_edges_lie_on_the_input_lines() {
    let (edges, f) = job_fidelity("fandisk.obj");
    assert_eq!(f.reference_corners, 25);
    assert_features_follow_the_input(edges, &f);
}

#[test]
fn cube_output_feature_edges_lie_on_the_input_lines() {
    let (edges, f) = job_fidelity("cube.obj");
    assert_eq!(f.reference_corners, 8);
    assert_features_follow_the_input(edges, &f);
    assert!(f.sharp_distance_max_over_l.unwrap() <= 1e-9);
}

#[test]
fn a_remesh_without_features_is_measured_as_cutting_across_them() {
    let input = data_support::load("fandisk.obj");
    let tin = input.mesh.to_trimesh();
    let l = 0.0075 * tin.bbox_diagonal();
    let out = remesh(
        &input.mesh,
        &RemeshOptions {
            preserve_features: false,
            ..RemeshOptions::default().with_target_edge_length(l)
        },
        &mut NoObserver,
    )
    .unwrap();
    let s = stats::compute(
        &out.mesh.to_trimesh(),
        &StatsOptions {
            target_edge_length: Some(l),
            reference: Some(&tin),
            samples_per_side: 1000,
            features: Some(FeatureOptions::default()),
            ..Default::default()
        },
    );
    let f = s.features.unwrap().fidelity.unwrap();
    assert!(f.corners_kept < f.reference_corners, "{f:?}");
    assert!(f.uncovered_samples > f.reference_samples / 10, "{f:?}");
    assert!(
        f.edges_on_reference_lines_fraction.unwrap_or(0.0) < 0.5,
        "{f:?}"
    );
    assert!(f.sharp_distance_max_over_l.unwrap() > 0.05, "{f:?}");
}
