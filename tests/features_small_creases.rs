//! The small-crease filter (`min_crease_length`): noise creases smaller than
//! the target go, real creases and everything structural stay, and the
//! remesher's triangles around noise improve because of it.

#[path = "data_support/mod.rs"]
mod data_support;

use glam::DVec3;
use isoremesh::features::{detect_features, EdgeFlags, FeatureOptions};
use isoremesh::mesh::Mesh;
use isoremesh::remesh::{remesh, NoObserver, RemeshOptions};
use isoremesh::{shapes, TriMesh};

/// A unit cube (n×n quads a face) with `bumps` interior vertices of its top
/// face pushed out by `height`: each bump is a little pyramid whose creases
/// form a small component of the feature graph, like the noise of a scan.
fn bumpy_cube(n: u32, bumps: &[(u32, u32)], height: f64) -> TriMesh {
    let mut m = shapes::cube(n, DVec3::ZERO, DVec3::ONE);
    let h = 1.0 / n as f64;
    for &(i, j) in bumps {
        let target = DVec3::new(i as f64 * h, j as f64 * h, 1.0);
        let v = m
            .positions
            .iter()
            .position(|p| p.distance(target) < 1e-12)
            .expect("lattice vertex on the top face");
        m.positions[v].z += height;
    }
    m
}

fn opts(min_crease_length: f64) -> FeatureOptions {
    FeatureOptions {
        min_crease_length,
        ..Default::default()
    }
}

/// [`opts`] with a threshold of its own for bridges between junctions.
fn bridged(min_crease_length: f64, min_bridge_length: f64) -> FeatureOptions {
    FeatureOptions {
        min_bridge_length,
        ..opts(min_crease_length)
    }
}

#[test]
fn bumps_make_small_crease_components_that_the_filter_drops() {
    let n = 16;
    let plain = detect_features(&shapes::cube(n, DVec3::ZERO, DVec3::ONE), &opts(0.0));
    assert_eq!(plain.edges().len(), 12 * n as usize);
    assert_eq!(plain.corners().len(), 8);

    let m = bumpy_cube(n, &[(4, 4), (8, 11), (12, 5)], 1.5 / n as f64);
    let all = detect_features(&m, &opts(0.0));
    // Each pyramid of height 1.5·h over an h grid creases along its ring.
    assert!(
        all.edges().len() >= 12 * n as usize + 3 * 4,
        "the bumps must crease: {} edges",
        all.edges().len()
    );
    assert!(all.corners().len() > 8);

    // A bump's ring is 4 to 6 edges of length about h: under 8h in total.
    let filtered = detect_features(&m, &opts(8.0 / n as f64));
    assert_eq!(
        filtered.edges(),
        plain.edges(),
        "only the cube's creases stay"
    );
    assert_eq!(filtered.corners(), plain.corners());
    assert!(filtered
        .edges()
        .iter()
        .enumerate()
        .all(|(i, _)| filtered.edge_flags(i as u32) == EdgeFlags::SHARP));
}

#[test]
fn boundaries_are_never_dropped_however_short() {
    // An open grid: its boundary is four feature lines of length 1; a
    // threshold far above that must keep every one of them.
    let m = shapes::grid(1.0, 4);
    let all = detect_features(&m, &opts(0.0));
    let filtered = detect_features(&m, &opts(10.0));
    assert!(!all.edges().is_empty());
    assert_eq!(filtered.edges(), all.edges());
    assert_eq!(filtered.corners(), all.corners());
}

#[test]
fn fandisk_keeps_every_crease_and_corner_at_the_bench_length() {
    // A CAD part: its creases are long lines, so the filter at the bench's
    // L (0.75 % of the diagonal) and the remesher's defaults (1.5·L, bridges
    // 0.8·L) changes nothing.
    let m = data_support::plain_obj("fandisk.obj");
    let l = 0.0075 * m.bbox_diagonal();
    let all = detect_features(&m, &opts(0.0));
    let d = RemeshOptions::default().min_crease_length;
    let filtered = detect_features(&m, &bridged(d * l, 0.8 * l));
    assert_eq!(all.edges().len(), 706);
    assert_eq!(filtered.edges(), all.edges());
    assert_eq!(filtered.corners(), all.corners());
    assert_eq!(filtered.lines(), all.lines());
}

#[test]
fn a_box_keeps_short_edges_between_corners_above_the_bridge_threshold() {
    // A 2 × 1.5 × 0.3 box: its four 0.3-long edges run between two corners
    // (junctions of three creases). Under a threshold of 0.45 they are
    // short chains, but as bridges they are held to `min_bridge_length`.
    let m = shapes::cube(4, DVec3::ZERO, DVec3::new(2.0, 1.5, 0.3));
    let all = detect_features(&m, &opts(0.0));
    assert_eq!(all.corners().len(), 8);
    let kept = detect_features(&m, &bridged(0.45, 0.2));
    assert_eq!(kept.edges(), all.edges());
    assert_eq!(kept.corners(), all.corners());
    // Without a bridge threshold of its own, the short edges go.
    let dropped = detect_features(&m, &opts(0.45));
    assert!(dropped.edges().len() < all.edges().len());
    // The short edges are split in 4 segments of 0.075: a bridge below its
    // threshold still goes.
    let below = detect_features(&m, &bridged(0.45, 0.35));
    assert_eq!(below.edges().len(), dropped.edges().len());
}

/// Fraction of faces whose smallest angle is below `deg`, and the smallest angle.
fn below(mesh: &Mesh, deg: f64) -> (f64, f64) {
    let tm = mesh.to_trimesh();
    let mut bad = 0;
    let mut min = 180.0f64;
    for t in &tm.triangles {
        let p = tm.corner_positions(t);
        let m = (0..3)
            .map(|k| {
                let a = p[(k + 1) % 3] - p[k];
                let b = p[(k + 2) % 3] - p[k];
                a.angle_between(b).to_degrees()
            })
            .fold(180.0f64, f64::min);
        min = min.min(m);
        if m < deg {
            bad += 1;
        }
    }
    (bad as f64 / tm.triangles.len() as f64, min)
}

#[test]
fn remeshing_a_bumpy_cube_keeps_its_creases_and_drops_the_noise() {
    // Bumps of an input grid cell (1/64) under a target of 1/6: each one
    // pins a cluster of corners a fraction of an edge apart when kept.
    let n = 64;
    let bumps: Vec<(u32, u32)> = (0..6).map(|k| (6 + 6 * k, 7 + 5 * (k % 3) * 3)).collect();
    let input = Mesh::from_trimesh(&bumpy_cube(n, &bumps, 1.5 / n as f64))
        .unwrap()
        .0;
    let run = |min_crease_length: f64| {
        let o = RemeshOptions {
            target_edge_length: Some(1.0 / 6.0),
            min_crease_length,
            ..Default::default()
        };
        remesh(&input, &o, &mut NoObserver).unwrap()
    };
    let kept = run(0.0);
    let dropped = run(RemeshOptions::default().min_crease_length);
    assert!(kept.report.corners > 8 && kept.report.corners > dropped.report.corners);
    assert_eq!(dropped.report.feature_lines, 12, "the cube's 12 edges");
    assert_eq!(dropped.report.corners, 8);
    let (frac_kept, min_kept) = below(&kept.mesh, 30.0);
    let (frac_dropped, min_dropped) = below(&dropped.mesh, 30.0);
    eprintln!(
        "corners kept {} / dropped {}; below 30°: {frac_kept:.4} / {frac_dropped:.4}; \
         min angle {min_kept:.1}° / {min_dropped:.1}°",
        kept.report.corners, dropped.report.corners
    );
    assert!(
        frac_dropped < frac_kept && min_dropped > min_kept,
        "dropped {frac_dropped} (min {min_dropped}°) vs kept {frac_kept} (min {min_kept}°)"
    );
    assert!(min_dropped > 20.0, "min angle {min_dropped}°");
}
