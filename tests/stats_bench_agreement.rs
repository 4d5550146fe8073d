//! The statistics describe the mesh the benchmark's `quality.py` sees (its
//! `meshload.py` welding) and draw its distance samples: pinned against
//! figures quality.py printed for the same inputs.

mod data_support;

use glam::DVec3;
use isoremesh::shapes;
use isoremesh::stats::{compute, StatsOptions};
use isoremesh::TriMesh;

/// spot scaled by 1.01 about its bounding-box centre, computed as NumPy does
/// `(V - c) * 1.01 + c`.
fn scaled(m: &TriMesh) -> TriMesh {
    let (lo, hi) = m.bounds().unwrap();
    let c = (lo + hi) / 2.0;
    let mut out = m.clone();
    for p in &mut out.positions {
        *p = (*p - c) * 1.01 + c;
    }
    out
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Pinned with, in `shared/bench`:
/// ```text
/// Vi, Fi = load_mesh('tests/data/spot.obj'); c = (Vi.min(0) + Vi.max(0)) / 2
/// quality.fidelity(Vi, Fi, (Vi - c) * 1.01 + c, Fi, 20000,
///                  np.random.default_rng(seed), bbox_diag(Vi))
/// ```
#[test]
fn distances_are_the_ones_quality_py_reports() {
    let reference = data_support::load("spot.obj").source.clone();
    let mesh = scaled(&reference);
    // (seed, hausdorff, mean, rms), all relative to the diagonal.
    let cases = [
        (
            0,
            0.004190067595670987,
            0.0015819297138216662,
            0.0018309575289683615,
        ),
        (
            7,
            0.004190067595670987,
            0.001578079968005484,
            0.0018275400317652665,
        ),
    ];
    for (seed, hausdorff, mean, rms) in cases {
        let s = compute(
            &mesh,
            &StatsOptions {
                reference: Some(&reference),
                samples_per_side: 20_000,
                sample_seed: seed,
                ..Default::default()
            },
        );
        let d = s.distance.expect("distance");
        assert_eq!(d.seed, seed);
        assert!(
            rel(d.hausdorff_relative, hausdorff) < 1e-9,
            "seed {seed}: {d:?}"
        );
        // The two seeds' means differ by 2.4e-3: only the same samples agree
        // this closely.
        assert!(rel(d.mean_relative, mean) < 1e-9, "seed {seed}: {d:?}");
        assert!(rel(d.rms_relative, rms) < 1e-9, "seed {seed}: {d:?}");
    }
}

#[test]
fn a_triangle_soup_is_measured_welded() {
    let cube = shapes::cube(4, DVec3::ZERO, DVec3::ONE);
    // Every face with its own three vertices, plus a repeated face (reversed)
    // and a face with a repeated vertex.
    let mut soup = TriMesh::default();
    for t in &cube.triangles {
        let base = soup.positions.len() as u32;
        soup.positions.extend(cube.corner_positions(t));
        soup.triangles.push([base, base + 1, base + 2]);
    }
    soup.triangles.push([2, 1, 0]);
    soup.triangles.push([3, 3, 4]);
    let a = compute(&cube, &StatsOptions::default());
    let b = compute(&soup, &StatsOptions::default());
    assert_eq!(b.vertices, a.vertices);
    assert_eq!(b.faces, a.faces);
    assert_eq!(b.edges, a.edges);
    assert_eq!(b.boundary_loops, 0);
    assert_eq!(b.euler_characteristic, 2);
    assert!(b.manifold && b.consistently_oriented);
    assert_eq!(b.valence.histogram, a.valence.histogram);
    assert_eq!(b.angles, a.angles);
}

#[test]
fn welding_keeps_face_and_corner_order() {
    let p = [
        DVec3::ZERO,
        DVec3::X,
        DVec3::Y,
        DVec3::X, // same as 1
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(5.0, 5.0, 5.0), // unreferenced
    ];
    let m = TriMesh::new(
        p.to_vec(),
        vec![[3, 4, 2], [0, 1, 2], [1, 1, 2], [2, 0, 3], [0, 9, 1]],
    );
    let (w, first) = m.welded();
    // [1,1,2] has a repeated vertex, [2,0,3] repeats [0,1,2], [0,9,1] is out of range.
    assert_eq!(w.triangles.len(), 2);
    let corners: Vec<[DVec3; 3]> = w.triangles.iter().map(|t| w.corner_positions(t)).collect();
    assert_eq!(corners[0], [p[3], p[4], p[2]]);
    assert_eq!(corners[1], [p[0], p[1], p[2]]);
    assert_eq!(w.positions.len(), 4);
    for (v, &i) in first.iter().enumerate() {
        assert_eq!(w.positions[v], p[i as usize]);
    }
    // The first input vertex of a welded pair is the one named.
    assert!(first.contains(&1) && !first.contains(&3));
}
