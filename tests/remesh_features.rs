//! Features kept by the remesher: corners stay exactly, creases and
//! boundaries are resampled on the input's lines, boundaries neither shrink
//! nor freeze.

mod data_support;

use glam::DVec3;
use isoremesh::features::{detect_features, FeatureOptions};
use isoremesh::mesh::Mesh;
use isoremesh::remesh::{remesh, NoObserver, RemeshOptions};
use isoremesh::stats::polyline;
use isoremesh::{shapes, TriMesh};

fn run(input: &Mesh, l: f64) -> TriMesh {
    let out = remesh(
        input,
        &RemeshOptions::default().with_target_edge_length(l),
        &mut NoObserver,
    )
    .unwrap();
    out.mesh.validate().unwrap();
    out.mesh.to_trimesh()
}

/// Every input corner has an output vertex at the same position.
fn assert_corners_kept(input: &TriMesh, output: &TriMesh) {
    let fs = detect_features(input, &FeatureOptions::default());
    let tol = 1e-9 * input.bbox_diagonal();
    assert!(!fs.corners().is_empty());
    for &c in fs.corners() {
        let p = input.positions[c as usize];
        let d = output
            .positions
            .iter()
            .map(|q| q.distance(p))
            .fold(f64::INFINITY, f64::min);
        assert!(d <= tol, "corner {c} at {p:?} moved by {d}");
    }
}

#[test]
fn cube_corners_and_edges_are_kept_exactly() {
    let input = data_support::mesh("cube.obj");
    let tin = input.to_trimesh();
    let l = 0.0075 * tin.bbox_diagonal() * 4.0;
    let out = run(&input, l);
    assert_corners_kept(&tin, &out);
    let d = polyline::sharp_edge_distance(&tin, &out, 45.0, l / 4.0).unwrap();
    assert!(d.max <= 0.01 * l, "feature distance {} L", d.max / l);
}

#[test]
fn fandisk_corners_stay_and_creases_stay_close() {
    let input = data_support::mesh("fandisk.obj");
    let tin = input.to_trimesh();
    let l = 0.0075 * tin.bbox_diagonal();
    let out = run(&input, l);
    assert_corners_kept(&tin, &out);
    let d = polyline::sharp_edge_distance(&tin, &out, 45.0, l / 4.0).unwrap();
    // The input's arcs turn by up to 22.5° at vertices 1.3–2.1 L apart;
    // without a vertex on each turn the output's chords cut it by 0.034 L.
    assert!(d.max <= 0.01 * l, "feature distance {} L", d.max / l);
    assert!(
        d.mean <= 0.002 * l,
        "mean feature distance {} L",
        d.mean / l
    );
}

#[test]
fn boundaries_are_resampled_on_the_input_boundary() {
    let cyl = shapes::open_cylinder(1.0, 2.0, 48, 6);
    let (input, _) = Mesh::from_trimesh(&cyl).unwrap();
    let tin = input.to_trimesh();
    let l = 0.12;
    let out = remesh(
        &input,
        &RemeshOptions::default().with_target_edge_length(l),
        &mut NoObserver,
    )
    .unwrap();
    assert_eq!(out.mesh.boundary_loop_count(), 2);
    let tout = out.mesh.to_trimesh();
    // Every output boundary vertex lies on the input boundary (the two rims).
    let rim = |p: DVec3| {
        let r = (p.x * p.x + p.y * p.y).sqrt();
        let dz = p.z.abs().min((p.z - 2.0).abs());
        (r, dz)
    };
    let mut boundary_lengths = Vec::new();
    for e in out.mesh.edges().filter(|&e| out.mesh.is_boundary_edge(e)) {
        boundary_lengths.push(out.mesh.edge_length(e));
        for v in out.mesh.edge_vertices(e) {
            let (r, dz) = rim(out.mesh.position(v));
            assert!(dz < 1e-12, "boundary vertex off the rim plane by {dz}");
            // On the input polygon: between its inscribed and circumscribed radii.
            let inner = (std::f64::consts::PI / 48.0).cos();
            assert!(r <= 1.0 + 1e-12 && r >= inner - 1e-12, "radius {r}");
        }
    }
    let in_band = boundary_lengths
        .iter()
        .filter(|&&x| x >= 0.8 * l && x <= 4.0 / 3.0 * l)
        .count();
    assert_eq!(
        in_band,
        boundary_lengths.len(),
        "boundary edges outside the band"
    );
    let d = polyline::boundary_distance(&tin, &tout, l / 4.0).unwrap();
    assert!(d.max <= 0.01 * l, "boundary distance {} L", d.max / l);
}

#[test]
fn material_borders_stay_crack_free() {
    let mut m = shapes::grid(1.0, 8);
    m.face_labels = m
        .triangles
        .iter()
        .map(|t| {
            let c = (m.positions[t[0] as usize]
                + m.positions[t[1] as usize]
                + m.positions[t[2] as usize])
                / 3.0;
            u32::from(c.x > 0.5)
        })
        .collect();
    m.labels = vec![Default::default(); 2];
    let (input, _) = Mesh::from_trimesh(&m).unwrap();
    let out = remesh(
        &input,
        &RemeshOptions::default().with_target_edge_length(0.05),
        &mut NoObserver,
    )
    .unwrap();
    let t = out.mesh.to_trimesh();
    // Both labels survive and every border edge still lies on x = 0.5.
    assert!(t.face_labels.contains(&0) && t.face_labels.contains(&1));
    for e in out.mesh.edges() {
        let h = e.halfedge(0);
        let (f, g) = (out.mesh.face(h), out.mesh.face(h.twin()));
        if f.is_valid() && g.is_valid() && out.mesh.face_label[f] != out.mesh.face_label[g] {
            for v in out.mesh.edge_vertices(e) {
                assert!((out.mesh.position(v).x - 0.5).abs() < 1e-12);
            }
        }
    }
}

#[test]
fn line_vertices_are_fixed_only_where_a_chord_would_cut_the_turn() {
    let l = 0.12;
    let run_cylinder = |segments: u32| {
        let (input, _) = Mesh::from_trimesh(&shapes::open_cylinder(1.0, 2.0, segments, 6)).unwrap();
        let out = remesh(
            &input,
            &RemeshOptions::default().with_target_edge_length(l),
            &mut NoObserver,
        )
        .unwrap();
        out.mesh.validate().unwrap();
        (input.to_trimesh(), out)
    };
    // A 48-gon of radius 1 has 0.13-long sides turning by 7.5°: a 4/3·L chord
    // across a rim vertex would pass 0.044 L from it, so all 96 rim vertices
    // stay (they are 1.09 L apart, more than the collapse length).
    let (tin, out) = run_cylinder(48);
    assert_eq!(out.report.fixed_turns, 96);
    let d = polyline::boundary_distance(&tin, &out.mesh.to_trimesh(), l / 4.0).unwrap();
    assert!(d.max <= 1e-9, "boundary distance {} L", d.max / l);
    // A 480-gon turns by 0.75° every 0.11 L: a chord across one vertex cuts
    // the turn by 0.0007 L, so the rim is free to be resampled.
    let (_, out) = run_cylinder(480);
    assert_eq!(out.report.fixed_turns, 0);
}

/// A gable roof folded by 20° along y = 0 (far below the 45° feature
/// angle), its vertices split along the ridge with one normal per slope:
/// an authored hard edge.
fn shallow_gable() -> TriMesh {
    let n = 12;
    let tilt = 10f64.to_radians();
    let mut m = TriMesh::default();
    for side in [-1.0f64, 1.0] {
        let base = m.positions.len() as u32;
        let normal = DVec3::new(0.0, -side * tilt.sin(), tilt.cos());
        for i in 0..=n {
            for j in 0..=n {
                let x = i as f64 / n as f64;
                let s = side * j as f64 / n as f64;
                m.positions
                    .push(DVec3::new(x, s * tilt.cos(), -s.abs() * tilt.sin()));
                m.normals.push(normal);
            }
        }
        for i in 0..n as u32 {
            for j in 0..n as u32 {
                let v = |a: u32, b: u32| base + a * (n as u32 + 1) + b;
                let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
                if side > 0.0 {
                    m.triangles.extend([[a, b, c], [a, c, d]]);
                } else {
                    m.triangles.extend([[a, c, b], [a, d, c]]);
                }
            }
        }
    }
    m
}

#[test]
fn authored_hard_edges_are_features_when_asked() {
    use isoremesh::reference::Reference;
    use isoremesh::remesh::{remesh_reference, FeatureSource};
    let source = shallow_gable();
    for (features, kept) in [
        (FeatureSource::Angle, false),
        (FeatureSource::Normals, true),
        (FeatureSource::Both, true),
    ] {
        let reference = Reference::new(source.clone()).unwrap();
        let options = RemeshOptions {
            target_edge_length: Some(0.07),
            features,
            ..Default::default()
        };
        let out = remesh_reference(&reference, &options, &mut NoObserver).unwrap();
        // The ridge (y = 0) carries output vertices exactly when it is kept.
        let tm = out.mesh.to_trimesh();
        let on_ridge = tm
            .positions
            .iter()
            .filter(|p| p.y.abs() < 1e-12 && p.z.abs() < 1e-12 && p.x > 0.01 && p.x < 0.99)
            .count();
        assert_eq!(
            on_ridge >= 10,
            kept,
            "{features}: {on_ridge} vertices on the ridge"
        );
        // The ridge's ends are on the boundary, so only the ridge counts.
        let ridge_edges =
            out.report.feature_edges - detect_boundary_edge_count(&reference.mesh.to_trimesh());
        assert_eq!(
            ridge_edges > 0,
            kept,
            "{features}: {ridge_edges} ridge edges"
        );
    }
}

fn detect_boundary_edge_count(m: &TriMesh) -> u64 {
    let fs = detect_features(
        m,
        &FeatureOptions {
            preserve_features: false,
            ..Default::default()
        },
    );
    fs.edges().len() as u64
}
