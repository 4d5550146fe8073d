//! Mesh statistics on shapes whose answers are known in closed form.

use glam::DVec3;
use isoremesh::mesh::RepairReport;
use isoremesh::shapes;
use isoremesh::stats::{compute, MeshStats, StatsOptions};
use isoremesh::TriMesh;

fn stats(m: &TriMesh) -> MeshStats {
    compute(m, &StatsOptions::default())
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

/// Histogram totals and valence sums that hold for every mesh.
fn check_consistency(s: &MeshStats) {
    let v = &s.valence;
    let used: u64 = v.histogram.values().sum();
    assert_eq!(used, v.interior_vertices + v.boundary_vertices);
    assert_eq!(
        v.interior_histogram.values().sum::<u64>(),
        v.interior_vertices
    );
    assert_eq!(
        v.boundary_histogram.values().sum::<u64>(),
        v.boundary_vertices
    );
    // Every edge has two ends (the handshake lemma).
    let ends: u64 = v.histogram.iter().map(|(k, c)| *k as u64 * c).sum();
    assert_eq!(ends, 2 * s.edges);
    if let Some(e) = &s.edge_length {
        assert_eq!(e.histogram.counts.len(), 21);
        assert_eq!(e.histogram.counts.iter().sum::<u64>(), s.edges);
        assert!(e.min <= e.mean && e.mean <= e.max);
    }
    if let Some(a) = &s.angles {
        assert_eq!(a.histogram.counts.len(), 36);
        assert_eq!(a.histogram.counts.iter().sum::<u64>(), 3 * s.faces);
        assert!(a.min_deg <= a.mean_min_deg && a.mean_min_deg <= 60.0 + 1e-9);
    }
    assert_eq!(
        s.euler_characteristic,
        s.vertices as i64 - s.edges as i64 + s.faces as i64
    );
}

#[test]
fn icosphere_is_a_regular_closed_sphere() {
    let m = shapes::icosphere(3);
    let s = stats(&m);
    check_consistency(&s);
    assert_eq!((s.vertices, s.faces, s.edges), (642, 1280, 1920));
    assert_eq!(s.euler_characteristic, 2);
    assert_eq!(
        (s.components, s.boundary_loops, s.boundary_edges),
        (1, 0, 0)
    );
    assert!(s.manifold && s.consistently_oriented);
    assert_eq!((s.non_manifold_edges, s.degenerate_faces), (0, 0));
    let v = &s.valence;
    // The 12 original icosahedron vertices keep valence 5; all others have 6.
    assert_eq!(v.histogram.get(&5), Some(&12));
    assert_eq!(v.histogram.get(&6), Some(&630));
    assert_eq!(v.histogram.len(), 2);
    assert!(close(v.regular_fraction.unwrap(), 630.0 / 642.0, 1e-15));
    assert!(close(
        v.interior_mean_abs_deviation.unwrap(),
        12.0 / 642.0,
        1e-15
    ));
    assert_eq!(v.boundary_mean_abs_deviation, None);
    assert!(close(v.mean_abs_deviation.unwrap(), 12.0 / 642.0, 1e-15));
    // Near-equilateral triangles.
    let q = s.triangle_quality.unwrap();
    assert!(q.min > 0.85 && q.mean > 0.95 && q.mean <= 1.0);
    let a = s.angles.unwrap();
    assert!(a.min_deg > 45.0 && a.max_deg < 80.0);
    assert_eq!(a.below_30_fraction, 0.0);
}

#[test]
fn flat_grid_has_one_boundary_loop_and_known_valences() {
    let n = 8u32;
    let m = shapes::grid(1.0, n);
    let h = 1.0 / n as f64;
    // An explicit target a little below the grid spacing keeps every ratio
    // away from bin edges: h → 1.05 L, h√2 → 1.485 L.
    let l = h / 1.05;
    let s = compute(
        &m,
        &StatsOptions {
            target_edge_length: Some(l),
            ..Default::default()
        },
    );
    check_consistency(&s);
    let nn = n as u64;
    assert_eq!(s.vertices, (nn + 1) * (nn + 1));
    assert_eq!(s.faces, 2 * nn * nn);
    let axis_edges = 2 * nn * (nn + 1);
    let diagonals = nn * nn;
    assert_eq!(s.edges, axis_edges + diagonals);
    assert_eq!(s.euler_characteristic, 1);
    assert_eq!((s.boundary_loops, s.components), (1, 1));
    assert_eq!(s.boundary_edges, 4 * nn);
    assert!(s.manifold && s.consistently_oriented);

    let v = &s.valence;
    assert_eq!(v.boundary_vertices, 4 * nn);
    assert_eq!(v.interior_vertices, (nn - 1) * (nn - 1));
    assert_eq!(v.regular_fraction, Some(1.0));
    assert_eq!(v.interior_mean_abs_deviation, Some(0.0));
    // Corners on the diagonal have valence 3, the other two corners 2, every
    // other boundary vertex 4: total deviation 1 + 1 + 2 + 2.
    assert!(close(
        v.boundary_mean_abs_deviation.unwrap(),
        6.0 / (4 * nn) as f64,
        1e-15
    ));
    assert_eq!(v.boundary_histogram.get(&2), Some(&2));
    assert_eq!(v.boundary_histogram.get(&3), Some(&2));
    assert!(close(
        v.mean_abs_deviation.unwrap(),
        6.0 / s.vertices as f64,
        1e-15
    ));

    let e = s.edge_length.as_ref().unwrap();
    assert_eq!(e.target, l);
    let total = (axis_edges + diagonals) as f64;
    let mean = (axis_edges as f64 * h + diagonals as f64 * h * 2f64.sqrt()) / total;
    assert!(close(e.mean, mean, 1e-12));
    assert!(close(e.min, h, 1e-12) && close(e.max, h * 2f64.sqrt(), 1e-12));
    let var = (axis_edges as f64 * (h - mean).powi(2)
        + diagonals as f64 * (h * 2f64.sqrt() - mean).powi(2))
        / total;
    assert!(close(e.std, var.sqrt(), 1e-9));
    assert!(close(e.within_band, axis_edges as f64 / total, 1e-15));
    assert_eq!(e.histogram.counts[10], axis_edges);
    assert_eq!(e.histogram.counts[14], diagonals);
    assert!(e.against_mean_target.is_none() && e.target_min.is_none());
    assert_eq!(e.reference, isoremesh::stats::Unit::TargetLength);

    // Right isosceles triangles: two 45° and one 90° angle each.
    let a = s.angles.as_ref().unwrap();
    assert!(close(a.min_deg, 45.0, 1e-12) && close(a.max_deg, 90.0, 1e-12));
    assert_eq!(a.below_30_fraction, 0.0);
    let c = &a.histogram.counts;
    assert_eq!(c[8] + c[9], 2 * s.faces);
    assert_eq!(c[17] + c[18], s.faces);
    let q = s.triangle_quality.as_ref().unwrap();
    // q = 4√3·(h²/2) / (4h²) = √3/2.
    assert!(close(q.min, 3f64.sqrt() / 2.0, 1e-12) && close(q.mean, 3f64.sqrt() / 2.0, 1e-12));
}

#[test]
fn cube_torus_cylinder_topology() {
    let cube = stats(&shapes::cube(4, DVec3::ZERO, DVec3::ONE));
    check_consistency(&cube);
    assert_eq!(
        (
            cube.euler_characteristic,
            cube.components,
            cube.boundary_loops
        ),
        (2, 1, 0)
    );
    assert!(cube.manifold && cube.consistently_oriented);

    let torus = stats(&shapes::torus(2.0, 0.5, 32, 12));
    check_consistency(&torus);
    assert_eq!(
        (
            torus.euler_characteristic,
            torus.components,
            torus.boundary_loops
        ),
        (0, 1, 0)
    );
    // A uniform quad grid with one diagonal direction: valence 6 everywhere.
    assert_eq!(torus.valence.regular_fraction, Some(1.0));
    assert_eq!(torus.valence.histogram.len(), 1);

    let cyl = stats(&shapes::open_cylinder(1.0, 2.0, 24, 6));
    check_consistency(&cyl);
    assert_eq!(
        (cyl.euler_characteristic, cyl.components, cyl.boundary_loops),
        (0, 1, 2)
    );
    assert_eq!(cyl.boundary_edges, 48);
}

#[test]
fn two_components_are_counted() {
    let a = shapes::icosphere(2);
    let b = shapes::translated(shapes::icosphere(2), DVec3::new(5.0, 0.0, 0.0));
    let g = shapes::translated(shapes::grid(1.0, 3), DVec3::new(0.0, 9.0, 0.0));
    let s = stats(&shapes::union(&[a, b, g]));
    check_consistency(&s);
    assert_eq!(s.components, 3);
    assert_eq!(s.boundary_loops, 1);
    assert_eq!(s.euler_characteristic, 2 + 2 + 1);
}

#[test]
fn components_touching_at_a_vertex_are_one() {
    // Two triangles sharing only vertex 0: one component (connected through
    // a shared vertex), and their boundaries form one loop graph.
    let m = TriMesh::new(
        vec![DVec3::ZERO, DVec3::X, DVec3::Y, -DVec3::X, -DVec3::Y],
        vec![[0, 1, 2], [0, 3, 4]],
    );
    let s = stats(&m);
    assert_eq!(s.components, 1);
    assert_eq!(s.boundary_loops, 1);
    assert_eq!(s.boundary_edges, 6);
}

#[test]
fn orientation_and_manifoldness_are_detected() {
    let mut m = shapes::icosphere(2);
    m.triangles[7].swap(1, 2);
    let s = stats(&m);
    assert!(s.manifold);
    assert!(!s.consistently_oriented);

    // A fin: a third face on an existing edge.
    let mut m = shapes::icosphere(1);
    let [a, b, _] = m.triangles[0];
    m.positions.push(DVec3::new(3.0, 3.0, 3.0));
    let apex = m.positions.len() as u32 - 1;
    m.triangles.push([a, b, apex]);
    let s = stats(&m);
    assert!(!s.manifold && !s.consistently_oriented);
    assert_eq!(s.non_manifold_edges, 1);
    check_consistency(&s);
}

#[test]
fn degenerate_and_invalid_faces_do_not_break_anything() {
    let mut m = shapes::icosphere(1);
    let [a, b, _] = m.triangles[0];
    let pa = m.positions[a as usize];
    let pb = m.positions[b as usize];
    m.positions.push((pa + pb) * 0.5);
    let mid = m.positions.len() as u32 - 1;
    m.triangles.push([a, mid, b]); // zero area, collinear
    m.triangles.push([a, 1000, b]); // out of range: ignored
    let s = stats(&m);
    assert_eq!(s.faces, 81);
    assert_eq!(s.degenerate_faces, 1);
    let a = s.angles.as_ref().unwrap();
    assert!(a.min_deg.abs() < 1e-6 && (a.max_deg - 180.0).abs() < 1e-6);
    assert!(s.triangle_quality.as_ref().unwrap().min.abs() < 1e-9);
    check_consistency(&s);
    // And the JSON has no NaN (which serde_json would write as null).
    let json = serde_json::to_string(&s).unwrap();
    assert!(!json.contains("NaN"));
    // It reads back (serde_json's default float parser may differ in the last ulp).
    let back: MeshStats = serde_json::from_str(&json).unwrap();
    assert_eq!(back.valence, s.valence);
    assert_eq!(back.angles.unwrap().histogram, a.histogram);
    assert!(close(
        back.triangle_quality.unwrap().mean,
        s.triangle_quality.as_ref().unwrap().mean,
        1e-15
    ));
}

#[test]
fn empty_mesh_has_no_element_statistics() {
    let s = stats(&TriMesh::default());
    assert_eq!((s.vertices, s.faces, s.edges, s.components), (0, 0, 0, 0));
    assert!(s.edge_length.is_none() && s.angles.is_none() && s.triangle_quality.is_none());
    assert_eq!(s.valence.regular_fraction, None);
    assert_eq!(s.valence.mean_abs_deviation, None);
    let with_ref = compute(
        &TriMesh::default(),
        &StatsOptions {
            reference: Some(&shapes::icosphere(1)),
            ..Default::default()
        },
    );
    assert!(with_ref.distance.is_none());
    assert!(!s.summary().is_empty());
}

#[test]
fn per_vertex_targets_give_relative_lengths() {
    let n = 6u32;
    let m = shapes::grid(1.0, n);
    let h = 1.0 / n as f64;
    // Left half targets h, right half 2h: edges on the left sit at ratio 1
    // (axis) or √2; edges of the right half at ratio 0.5 or 0.707.
    let targets: Vec<f64> = m
        .positions
        .iter()
        .map(|p| {
            if p.x < 0.5 - 1e-9 {
                h / 1.05
            } else {
                2.0 * h / 1.05
            }
        })
        .collect();
    let s = compute(
        &m,
        &StatsOptions {
            vertex_target: Some(&targets),
            ..Default::default()
        },
    );
    let e = s.edge_length.as_ref().unwrap();
    let mean_target = targets.iter().sum::<f64>() / targets.len() as f64;
    assert!(close(e.target, mean_target, 1e-15));
    assert!(close(e.target_min.unwrap(), h / 1.05, 1e-15));
    assert!(close(e.target_max.unwrap(), 2.0 * h / 1.05, 1e-15));
    // With per-vertex targets the top-level band and histogram are
    // against the local target; the mean target is a named second view.
    assert_eq!(e.reference, isoremesh::stats::Unit::LocalTarget);
    let rel = e;
    assert_eq!(rel.histogram.counts.iter().sum::<u64>(), s.edges);
    let global = e.against_mean_target.as_ref().unwrap();
    assert_eq!(
        global.histogram.unit,
        isoremesh::stats::Unit::MeanLocalTarget
    );
    assert_eq!(global.histogram.reference_length, Some(e.target));
    // Count by hand.
    let mut in_band = 0u64;
    let mut hist = [0u64; 21];
    let mut seen = std::collections::HashSet::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
            if !seen.insert((a, b)) {
                continue;
            }
            let len = (m.positions[a as usize] - m.positions[b as usize]).length();
            let local = 0.5 * (targets[a as usize] + targets[b as usize]);
            let r = len / local;
            if (0.8..=4.0 / 3.0).contains(&r) {
                in_band += 1;
            }
            hist[((r * 10.0) as usize).min(20)] += 1;
        }
    }
    assert!(close(
        rel.within_band,
        in_band as f64 / s.edges as f64,
        1e-15
    ));
    assert_eq!(rel.histogram.counts, hist.to_vec());
    // A slice of the wrong length is ignored.
    let s2 = compute(
        &m,
        &StatsOptions {
            vertex_target: Some(&targets[1..]),
            ..Default::default()
        },
    );
    assert!(s2.edge_length.unwrap().against_mean_target.is_none());
}

#[test]
fn distance_to_itself_is_zero() {
    let m = shapes::torus(2.0, 0.5, 40, 16);
    let s = compute(
        &m,
        &StatsOptions {
            reference: Some(&m),
            samples_per_side: 20_000,
            ..Default::default()
        },
    );
    let d = s.distance.unwrap();
    assert!(d.hausdorff < 1e-12, "{d:?}");
    assert!(d.mean < 1e-13 && d.rms < 1e-13);
    assert_eq!(d.samples_per_side, 20_000);
    assert!(close(d.reference_diagonal, m.bbox_diagonal(), 1e-15));
}

#[test]
fn concentric_spheres_are_half_a_unit_apart() {
    let inner = shapes::icosphere(5);
    let mut outer = shapes::icosphere(4);
    for p in &mut outer.positions {
        *p *= 1.5;
    }
    let s = compute(
        &inner,
        &StatsOptions {
            reference: Some(&outer),
            samples_per_side: 50_000,
            ..Default::default()
        },
    );
    let d = s.distance.unwrap();
    // Flat faces are chords: points lie between r·cos(θ) and r of the
    // centre. For these resolutions that moves distances by < 0.01.
    assert!((d.mean - 0.5).abs() < 0.01, "{d:?}");
    assert!((d.rms - 0.5).abs() < 0.01, "{d:?}");
    assert!(d.hausdorff >= 0.5 && d.hausdorff < 0.51, "{d:?}");
    assert!((d.hausdorff_relative - d.hausdorff / d.reference_diagonal).abs() < 1e-15);
    assert!(close(d.reference_diagonal, outer.bbox_diagonal(), 1e-15));
    // Deterministic: the same figures on a second run.
    let again = compute(
        &inner,
        &StatsOptions {
            reference: Some(&outer),
            samples_per_side: 50_000,
            ..Default::default()
        },
    );
    assert_eq!(again.distance.unwrap(), d);
}

#[test]
fn reference_index_is_reused() {
    let a = shapes::icosphere(3);
    let b = shapes::uv_sphere(1.0, 24, 48);
    let idx = isoremesh::bvh::SurfaceIndex::from_trimesh(&b);
    let opts = StatsOptions {
        reference: Some(&b),
        samples_per_side: 5_000,
        ..Default::default()
    };
    let with = compute(
        &a,
        &StatsOptions {
            reference_index: Some(&idx),
            ..opts
        },
    );
    let without = compute(&a, &opts);
    assert_eq!(with.distance, without.distance);
}

#[test]
fn json_field_names() {
    let m = shapes::open_cylinder(1.0, 1.0, 12, 3);
    let targets = vec![0.3; m.positions.len()];
    let s = compute(
        &m,
        &StatsOptions {
            reference: Some(&m),
            samples_per_side: 1000,
            vertex_target: Some(&targets),
            repairs: Some(RepairReport {
                welded_vertices: 3,
                ..Default::default()
            }),
            ..Default::default()
        },
    );
    let v = serde_json::to_value(&s).unwrap();
    for k in [
        "vertices",
        "faces",
        "edges",
        "boundary_loops",
        "components",
        "euler_characteristic",
        "edge_length",
        "valence",
        "angles",
        "triangle_quality",
        "distance",
        "repairs",
        "degenerate_faces",
        "manifold",
        "consistently_oriented",
        "non_manifold_edges",
    ] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    let e = &v["edge_length"];
    for k in [
        "min",
        "max",
        "mean",
        "std",
        "target",
        "target_min",
        "target_max",
        "reference",
        "band",
        "within_band",
        "histogram",
        "against_mean_target",
    ] {
        assert!(e.get(k).is_some(), "missing edge_length.{k}");
    }
    assert!(e["histogram"]["bin_width"].is_f64());
    assert_eq!(e["histogram"]["counts"].as_array().unwrap().len(), 21);
    for k in [
        "unit",
        "reference_length",
        "origin",
        "bin_edges",
        "open_last_bin",
    ] {
        assert!(e["histogram"].get(k).is_some(), "missing histogram.{k}");
    }
    assert_eq!(e["histogram"]["bin_edges"].as_array().unwrap().len(), 21);
    assert_eq!(e["band"]["unit"], e["histogram"]["unit"]);
    assert!(e["against_mean_target"]["histogram"]["counts"].is_array());
    assert!(e["against_mean_target"]["within_band"].is_f64());
    let val = &v["valence"];
    for k in [
        "histogram",
        "regular_fraction",
        "interior_mean_abs_deviation",
        "boundary_mean_abs_deviation",
        "mean_abs_deviation",
    ] {
        assert!(val.get(k).is_some(), "missing valence.{k}");
    }
    // Valence histogram keys are strings of integers.
    assert!(val["histogram"]
        .as_object()
        .unwrap()
        .keys()
        .all(|k| k.parse::<u32>().is_ok()));
    let a = &v["angles"];
    for k in [
        "min_deg",
        "max_deg",
        "below_30_fraction",
        "histogram",
        "mean_min_deg",
    ] {
        assert!(a.get(k).is_some(), "missing angles.{k}");
    }
    assert_eq!(a["histogram"]["counts"].as_array().unwrap().len(), 36);
    assert_eq!(a["histogram"]["bin_width"].as_f64(), Some(5.0));
    let q = &v["triangle_quality"];
    assert!(q.get("min").is_some() && q.get("mean").is_some());
    let d = &v["distance"];
    for k in [
        "hausdorff",
        "mean",
        "rms",
        "hausdorff_relative",
        "mean_relative",
        "rms_relative",
        "samples_per_side",
        "seed",
    ] {
        assert!(d.get(k).is_some(), "missing distance.{k}");
    }
    assert_eq!(v["repairs"]["welded_vertices"], 3);
    // Without reference and targets these keys are absent.
    let plain = serde_json::to_value(stats(&m)).unwrap();
    assert!(plain.get("distance").is_none() && plain.get("repairs").is_none());
    assert!(plain["edge_length"].get("against_mean_target").is_none());
    // And the summary mentions every group.
    let text = s.summary();
    for word in [
        "vertices", "edges", "valence", "angles", "quality", "distance", "repairs",
    ] {
        assert!(text.contains(word), "summary lacks {word}:\n{text}");
    }
}
