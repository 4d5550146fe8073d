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
        prop_assert!(out.mesh.validate().is_ok());
        prop_assert_eq!(out.mesh.euler_characteristic(), input.euler_characteristic());
        prop_assert_eq!(out.mesh.boundary_loop_count(), input.boundary_loop_count());
        let t = out.mesh.to_trimesh();
        let diag = t.bbox_diagonal();
        for tri in &t.triangles {
            prop_assert!(isoremesh::geometry::triangle_area(t.corner_positions(tri)) > 1e-12 * diag * diag);
        }
    }
}
