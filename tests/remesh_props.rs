//! Property test: random shapes and random options always give a valid
//! output with the input's topology.

use glam::DVec3;
use isoremesh::mesh::Mesh;
use isoremesh::remesh::{remesh, NoObserver, RemeshOptions};
use isoremesh::{shapes, TriMesh};
use proptest::prelude::*;

fn shape(k: u8, n: u32) -> TriMesh {
    match k % 6 {
        0 => shapes::icosphere(1 + n % 3),
        1 => shapes::torus(2.0, 0.5 + 0.1 * (n % 4) as f64, 12 + 4 * n, 6 + 2 * n),
        2 => shapes::open_cylinder(1.0, 2.0, 8 + 2 * n, 2 + n),
        3 => shapes::cube(1 + n % 3, DVec3::ZERO, DVec3::new(1.0, 2.0, 0.5)),
        4 => shapes::grid(1.0, 2 + n),
        _ => shapes::uv_sphere(1.0, 4 + n, 6 + n),
    }
}

/// The first invariant the remeshed `out` breaks against `input`:
/// validity, the Euler characteristic, the boundary loops, or a degenerate
/// face (area at most 1e-12 of the squared diagonal).
fn broken_invariant(input: &Mesh, out: &Mesh) -> Option<String> {
    if let Err(e) = out.validate() {
        return Some(format!("invalid output: {e:?}"));
    }
    let chi = (input.euler_characteristic(), out.euler_characteristic());
    if chi.0 != chi.1 {
        return Some(format!("Euler characteristic {} -> {}", chi.0, chi.1));
    }
    let loops = (input.boundary_loop_count(), out.boundary_loop_count());
    if loops.0 != loops.1 {
        return Some(format!("boundary loops {} -> {}", loops.0, loops.1));
    }
    let t = out.to_trimesh();
    let diag = t.bbox_diagonal();
    t.triangles
        .iter()
        .position(|tri| {
            isoremesh::geometry::triangle_area(t.corner_positions(tri)) <= 1e-12 * diag * diag
        })
        .map(|f| format!("face {f} is degenerate"))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn random_shapes_and_options_give_valid_output(
        kind in 0u8..6,
        n in 0u32..5,
        ratio in 0.02f64..0.3,
        iterations in 1u32..5,
        relax_steps in 0u32..3,
        features in any::<bool>(),
        angle in 10.0f64..80.0,
        flip in any::<bool>(),
    ) {
        let (input, _) = Mesh::from_trimesh(&shape(kind, n)).unwrap();
        let mut o = RemeshOptions::default()
            .with_target_edge_ratio(ratio)
            .with_iterations(iterations)
            .with_preserve_features(features)
            .with_feature_angle(angle);
        o.relaxation_steps = relax_steps;
        o.flip = flip;
        let out = remesh(&input, &o, &mut NoObserver).unwrap();
        let broken = broken_invariant(&input, &out.mesh);
        prop_assert!(broken.is_none(), "{}", broken.unwrap_or_default());
    }
}

/// A SplitMix64 step: the jitter's random numbers, seeded by proptest.
fn next_unit(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

/// `mesh` stretched per axis and with every vertex moved by up to
/// `amount` of the mean edge length in a random direction: rough,
/// anisotropic input with creases everywhere, unlike the clean shapes.
fn roughened(mut mesh: TriMesh, amount: f64, stretch: DVec3, seed: u64) -> TriMesh {
    let mut total = 0.0;
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            total += mesh.positions[a].distance(mesh.positions[b]);
        }
    }
    let mean = total / (3 * mesh.triangles.len()) as f64;
    let mut state = seed;
    for p in &mut mesh.positions {
        let d = DVec3::new(
            next_unit(&mut state) - 0.5,
            next_unit(&mut state) - 0.5,
            next_unit(&mut state) - 0.5,
        );
        *p = (*p + 2.0 * amount * mean * d) * stretch;
    }
    mesh
}

proptest! {
    // PROPTEST_CASES=N runs more cases (a longer local search).
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(32),
        ..ProptestConfig::default()
    })]

    #[test]
    fn rough_stretched_shapes_with_any_sizing_give_valid_output(
        kind in 0u8..6,
        n in 0u32..5,
        amount in 0.0f64..0.45,
        sx in 0.2f64..5.0,
        sz in 0.2f64..5.0,
        seed in any::<u64>(),
        ratio in 0.02f64..0.2,
        iterations in 1u32..6,
        adaptive in any::<bool>(),
        features in any::<bool>(),
        collapse in any::<bool>(),
        relax in any::<bool>(),
    ) {
        let rough = roughened(shape(kind, n), amount, DVec3::new(sx, 1.0, sz), seed);
        let (input, _) = Mesh::from_trimesh(&rough).unwrap();
        let mut o = RemeshOptions::default()
            .with_target_edge_ratio(ratio)
            .with_iterations(iterations)
            .with_preserve_features(features);
        if adaptive {
            // The lengths come from the tolerance: L ≈ √(6ε/κ).
            o.sizing = isoremesh::remesh::Sizing::Adaptive;
            o.target_edge_ratio = None;
            o.tolerance_ratio = Some(ratio * ratio);
        }
        o.collapse = collapse;
        o.relax = relax;
        let out = remesh(&input, &o, &mut NoObserver).unwrap();
        let broken = broken_invariant(&input, &out.mesh);
        prop_assert!(broken.is_none(), "{}", broken.unwrap_or_default());
    }
}
