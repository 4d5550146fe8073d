//! Feature preservation on the remaining cases of the feature contract: a
//! disk's boundary, a two-material glTF whose border comes back crack-free,
//! a thin feature (two creases closer than the target length), and random
//! boxes that keep their corners.

use glam::DVec3;
use isoremesh::features::{self, FeatureOptions};
use isoremesh::io::{self, Format, ReadOptions, WriteOptions};
use isoremesh::mesh::Mesh;
use isoremesh::pipeline;
use isoremesh::remesh::{remesh, NoObserver, RemeshOptions};
use isoremesh::stats::{self, polyline, StatsOptions};
use isoremesh::trimesh::{Label, Material};
use isoremesh::{shapes, TriMesh};
use proptest::prelude::*;

/// A flat disk of radius 1 in the xy plane: `rings` rings of `segments`
/// vertices around a centre vertex.
fn disk(segments: u32, rings: u32) -> TriMesh {
    let mut positions = vec![DVec3::ZERO];
    for r in 1..=rings {
        let rad = r as f64 / rings as f64;
        for s in 0..segments {
            let a = std::f64::consts::TAU * s as f64 / segments as f64;
            positions.push(DVec3::new(rad * a.cos(), rad * a.sin(), 0.0));
        }
    }
    let id = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, id(1, s), id(1, s + 1)]);
    }
    for r in 1..rings {
        for s in 0..segments {
            triangles.push([id(r, s), id(r + 1, s), id(r + 1, s + 1)]);
            triangles.push([id(r, s), id(r + 1, s + 1), id(r, s + 1)]);
        }
    }
    TriMesh::new(positions, triangles)
}

fn remeshed(input: &TriMesh, l: f64) -> TriMesh {
    let (mesh, _) = Mesh::from_trimesh(input).unwrap();
    let out = remesh(
        &mesh,
        &RemeshOptions::default().with_target_edge_length(l),
        &mut NoObserver,
    )
    .unwrap();
    out.mesh.validate().unwrap();
    assert_eq!(out.mesh.euler_characteristic(), mesh.euler_characteristic());
    out.mesh.to_trimesh()
}

fn boundary_edges(m: &TriMesh) -> Vec<[u32; 2]> {
    features::boundary_edges(m)
}

#[test]
fn a_disk_keeps_its_rim_resampled_in_the_band() {
    let input = disk(48, 8);
    let l = 0.12;
    let out = remeshed(&input, l);
    let s = stats::compute(&out, &StatsOptions::default());
    assert_eq!(s.boundary_loops, 1);
    let inner = (std::f64::consts::PI / 48.0).cos();
    let rim = boundary_edges(&out);
    assert!(rim.len() >= 40, "{} rim edges", rim.len());
    for &[a, b] in &rim {
        let (pa, pb) = (out.positions[a as usize], out.positions[b as usize]);
        for p in [pa, pb] {
            // On the input's 48-gon: in the plane, between its inscribed and
            // circumscribed circles.
            assert!(p.z.abs() < 1e-12);
            let r = p.truncate().length();
            assert!(r <= 1.0 + 1e-12 && r >= inner - 1e-12, "radius {r}");
        }
        let len = (pb - pa).length();
        assert!((0.8 * l..=4.0 / 3.0 * l).contains(&len), "rim edge {len}");
    }
    let d = polyline::boundary_distance(&input, &out, l / 4.0).unwrap();
    assert!(d.max <= 0.01 * l, "rim distance {} L", d.max / l);
}

/// A 1×1 grid whose left and right halves carry two named materials.
fn two_material_grid() -> TriMesh {
    let mut m = shapes::grid(1.0, 8);
    m.face_labels = m
        .triangles
        .iter()
        .map(|t| u32::from(m.corner_positions(t).iter().map(|p| p.x).sum::<f64>() > 1.5))
        .collect();
    m.labels = ["left", "right"]
        .iter()
        .map(|name| Label {
            name: Some(name.to_string()),
            material: Some(Material {
                name: Some(name.to_string()),
                base_color_factor: [0.5, 0.25, 1.0, 1.0],
                metallic_factor: 0.0,
                roughness_factor: 0.5,
                emissive_factor: [0.0; 3],
                double_sided: false,
                gltf: None,
            }),
            part: None,
            texcoord_sets: None,
        })
        .collect();
    m
}

#[test]
fn a_two_material_gltf_comes_back_as_two_primitives_that_meet_exactly() {
    let glb = io::write(&two_material_grid(), Format::Glb, &WriteOptions::default()).unwrap();
    let input = pipeline::load(&glb, Some("two.glb"), None, &ReadOptions::default()).unwrap();
    let job = pipeline::run(
        &input,
        &RemeshOptions::default().with_target_edge_length(0.05),
        &mut NoObserver,
    )
    .unwrap();
    let bytes = pipeline::encode(&job.mesh, Format::Glb).unwrap();
    let back = io::read(&bytes, Format::Glb, &ReadOptions::default())
        .unwrap()
        .mesh;
    assert_eq!(back.labels.len(), 2);
    let names: Vec<_> = back.labels.iter().map(|l| l.name.clone()).collect();
    assert!(names.contains(&Some("left".into())) && names.contains(&Some("right".into())));
    // The border vertices of each side, as bit patterns: each primitive has
    // its own vertex array, so the border is crack-free exactly when both
    // sides name the same positions.
    let side = |label: u32| {
        let mut pts: Vec<[u64; 3]> = back
            .triangles
            .iter()
            .enumerate()
            .filter(|(f, _)| back.face_label(*f) == label)
            .flat_map(|(_, t)| back.corner_positions(t))
            .filter(|p| (p.x - 0.5).abs() < 1e-9)
            .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
            .collect();
        pts.sort_unstable();
        pts.dedup();
        pts
    };
    let (left, right) = (side(0), side(1));
    assert!(left.len() >= 10, "{} border vertices", left.len());
    assert_eq!(left, right);
    // The two primitives weld into one surface with the square's single rim.
    let s = stats::compute(&back, &StatsOptions::default());
    assert_eq!((s.boundary_loops, s.components), (1, 1));
    assert!(s.manifold);
}

#[test]
fn a_thin_plate_keeps_both_close_creases() {
    // Creases 0.03 apart, target length 0.1: the side strips are a third of
    // an edge tall.
    let input = shapes::thin_plate(1.0, 0.03, 12);
    let l = 0.1;
    let out = remeshed(&input, l);
    let s = stats::compute(
        &out,
        &StatsOptions {
            target_edge_length: Some(l),
            reference: Some(&input),
            features: Some(FeatureOptions::default()),
            ..Default::default()
        },
    );
    let f = s.features.unwrap().fidelity.unwrap();
    assert_eq!(f.reference_corners, 8);
    assert_eq!(f.corners_kept, 8);
    assert_eq!(f.edges_on_reference_lines_fraction, Some(1.0), "{f:?}");
    assert_eq!(f.uncovered_samples, 0, "{f:?}");
    assert!(f.sharp_distance_max_over_l.unwrap() <= 0.01, "{f:?}");
    assert_eq!(s.degenerate_faces, 0);
    assert!(s.distance.unwrap().hausdorff < 1e-9);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, .. ProptestConfig::default() })]

    /// Random boxes at random target lengths keep their eight corners
    /// exactly and their twelve edges on the box's edges.
    #[test]
    fn random_boxes_keep_their_corners(
        sx in 0.3f64..2.0, sy in 0.3f64..2.0, sz in 0.3f64..2.0,
        n in 2u32..6, ratio in 0.04f64..0.15,
        ox in -5.0f64..5.0,
    ) {
        let lo = DVec3::new(ox, -ox, 0.5 * ox);
        let hi = lo + DVec3::new(sx, sy, sz);
        let input = shapes::cube(n, lo, hi);
        let l = ratio * (hi - lo).length();
        let out = remeshed(&input, l);
        let tol = 1e-9 * (hi - lo).length();
        for corner in 0..8u32 {
            let c = DVec3::new(
                if corner & 1 == 0 { lo.x } else { hi.x },
                if corner & 2 == 0 { lo.y } else { hi.y },
                if corner & 4 == 0 { lo.z } else { hi.z },
            );
            let nearest = out
                .positions
                .iter()
                .map(|p| (*p - c).length())
                .fold(f64::INFINITY, f64::min);
            prop_assert!(nearest <= tol, "corner {c} missed by {nearest}");
        }
        let d = polyline::sharp_edge_distance(&input, &out, 45.0, l / 4.0).unwrap();
        prop_assert!(d.max <= 1e-9 * l.max(1.0), "box edges off by {} L", d.max / l);
    }
}
