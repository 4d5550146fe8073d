//! Statistics a user can trust at a glance: a job measures its input and its
//! output against one reference, named in the JSON; histograms describe
//! themselves; the feature checks give the same counts in every output
//! format; the headline block leads.

mod data_support;

use isoremesh::io::{self, Format, ReadOptions};
use isoremesh::pipeline;
use isoremesh::remesh::{NoObserver, RemeshOptions, Sizing};
use isoremesh::stats::{self, MeshStats, StatsOptions, Unit};

#[test]
fn an_adaptive_job_measures_input_and_output_against_the_size_field() {
    let input = data_support::load("spot.obj");
    let options = RemeshOptions {
        sizing: Sizing::Adaptive,
        ..Default::default()
    };
    let out = pipeline::run(&input, &options, &mut NoObserver).unwrap();
    let (i, o) = (
        out.stats.input.edge_length.as_ref().unwrap(),
        out.stats.output.edge_length.as_ref().unwrap(),
    );
    assert_eq!(i.reference, Unit::LocalTarget);
    assert_eq!(o.reference, Unit::LocalTarget);
    assert_eq!(i.histogram.unit, Unit::LocalTarget);
    assert_eq!(o.band.unit, Unit::LocalTarget);
    // The top-level figure answers "did the remesh hit its target?".
    assert!(o.within_band > 0.9, "output within_band {}", o.within_band);
    assert!(
        o.within_band > i.within_band,
        "{} vs {}",
        o.within_band,
        i.within_band
    );
    // The view against one global length is there, and named so.
    let g = o.against_mean_target.as_ref().unwrap();
    assert_eq!(g.histogram.unit, Unit::MeanLocalTarget);
    assert!(g.within_band < o.within_band);
    // The headline repeats the output's figures.
    let h = out.stats.headline.edge_length.as_ref().unwrap();
    assert_eq!(h.within_band, o.within_band);
    assert_eq!(h.histogram, o.histogram);
    assert_eq!(
        out.stats.headline.valence.interior_mean_abs_deviation,
        out.stats.output.valence.interior_mean_abs_deviation
    );
    // The headline opens the document as written.
    let json = serde_json::to_string(&out.stats).unwrap();
    assert!(json.starts_with("{\"headline\":"), "{}", &json[..40]);
}

#[test]
fn a_uniform_job_measures_both_sides_against_the_target_length() {
    let input = data_support::load("spot.obj");
    let l = 0.01 * input.mesh.to_trimesh().bbox_diagonal();
    let options = RemeshOptions::default()
        .with_target_edge_length(l)
        .with_iterations(2);
    let out = pipeline::run(&input, &options, &mut NoObserver).unwrap();
    for s in [&out.stats.input, &out.stats.output] {
        let e = s.edge_length.as_ref().unwrap();
        assert_eq!(e.reference, Unit::TargetLength);
        assert_eq!(e.target, l);
        assert_eq!(e.histogram.reference_length, Some(l));
        assert_eq!(e.band.lower_length, Some(0.8 * l));
        assert!(e.against_mean_target.is_none());
    }
}

/// Remeshes `name` at `ratio` of its diagonal, writes the result in every
/// format, reads each back and measures it against the input at the same L.
fn stats_in_every_format(name: &str, ratio: f64) -> Vec<(Format, MeshStats)> {
    let input = data_support::load(name);
    let l = ratio * input.mesh.to_trimesh().bbox_diagonal();
    let out = pipeline::run(
        &input,
        &RemeshOptions::default().with_target_edge_length(l),
        &mut NoObserver,
    )
    .unwrap();
    [
        Format::Obj,
        Format::Ply,
        Format::Off,
        Format::Gltf,
        Format::Glb,
        Format::Stl,
    ]
    .into_iter()
    .map(|f| {
        let bytes = pipeline::encode(&out.mesh, f).unwrap();
        let back = io::read(&bytes, f, &ReadOptions::default()).unwrap().mesh;
        let s = stats::compute(
            &back,
            &StatsOptions {
                target_edge_length: Some(l),
                reference: Some(&input.source),
                samples_per_side: 2000,
                features: Some(Default::default()),
                ..Default::default()
            },
        );
        (f, s)
    })
    .collect()
}

fn assert_same_counts(name: &str, ratio: f64) {
    let all = stats_in_every_format(name, ratio);
    let (f0, s0) = &all[0];
    let feat0 = s0.features.as_ref().unwrap();
    let fid0 = feat0.fidelity.as_ref().unwrap();
    assert!(fid0.reference_corners > 0);
    assert_eq!(fid0.corners_kept, fid0.reference_corners, "{name} {fid0:?}");
    for (f, s) in &all[1..] {
        let feat = s.features.as_ref().unwrap();
        let fid = feat.fidelity.as_ref().unwrap();
        let counts = |s: &MeshStats| {
            (
                s.vertices,
                s.faces,
                s.edges,
                s.boundary_edges,
                s.valence.clone(),
            )
        };
        assert_eq!(counts(s), counts(s0), "{name}: {f} against {f0}");
        assert_eq!(
            (feat.edges, feat.sharp_edges, feat.corners, feat.lines),
            (feat0.edges, feat0.sharp_edges, feat0.corners, feat0.lines),
            "{name}: {f} against {f0}"
        );
        assert_eq!(
            (
                fid.reference_corners,
                fid.corners_kept,
                fid.edges_on_reference_lines,
                fid.reference_samples,
                fid.uncovered_samples,
            ),
            (
                fid0.reference_corners,
                fid0.corners_kept,
                fid0.edges_on_reference_lines,
                fid0.reference_samples,
                fid0.uncovered_samples,
            ),
            "{name}: {f} against {f0}"
        );
        // Distances in units of L agree to well within the tolerances.
        for (a, b) in [
            (
                fid.sharp_distance_max_over_l,
                fid0.sharp_distance_max_over_l,
            ),
            (fid.max_offset_over_l, fid0.max_offset_over_l),
        ] {
            let (a, b) = (a.unwrap_or(0.0), b.unwrap_or(0.0));
            assert!((a - b).abs() < 1e-4, "{name}: {f} {a} against {f0} {b}");
        }
    }
}

#[test]
fn feature_counts_are_the_same_in_every_format_for_fandisk() {
    assert_same_counts("fandisk.obj", 0.0075);
}

#[test]
fn feature_counts_are_the_same_in_every_format_for_the_cube() {
    assert_same_counts("cube.obj", 0.05);
}
