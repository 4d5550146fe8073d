//! Feature detection on generated shapes: which edges, corners and lines.

use glam::DVec3;
use isoremesh::features::{
    detect_features, EdgeFlags, FeatureOptions, FeatureSet, VertexKind, DEFAULT_CORNER_ANGLE_DEG,
    DEFAULT_FEATURE_ANGLE_DEG,
};
use isoremesh::{shapes, TriMesh};

fn opts(angle: f64) -> FeatureOptions {
    FeatureOptions {
        feature_angle_deg: angle,
        ..Default::default()
    }
}

/// Structural invariants every feature set must satisfy, whatever the mesh.
fn check_invariants(m: &TriMesh, fs: &FeatureSet) {
    let edges = fs.edges();
    assert!(
        edges.windows(2).all(|w| w[0] < w[1]),
        "edges sorted, unique"
    );
    assert!(edges.iter().all(|e| e[0] < e[1]));
    // Each feature edge is exactly one segment of one line, and the lookups agree.
    let mut seen = vec![0u32; edges.len()];
    for (li, line) in fs.lines().iter().enumerate() {
        assert!(line.vertices.len() >= 2);
        assert_eq!(fs.line_points(li as u32).len(), line.vertices.len());
        for (s, w) in line.vertices.windows(2).enumerate() {
            let id = fs
                .edge_id(w[0], w[1])
                .expect("line segment is a feature edge");
            seen[id as usize] += 1;
            assert_eq!(fs.edge_line(w[0], w[1]), Some(li as u32));
            assert_eq!(fs.edge_segment(w[1], w[0]), Some([li as u32, s as u32]));
            assert_eq!(fs.line_points(li as u32)[s], m.positions[w[0] as usize]);
        }
        // Ends are corners, except for a corner-free closed loop.
        let (first, last) = (line.vertices[0], *line.vertices.last().unwrap());
        if fs.is_corner(first) || fs.is_corner(last) {
            assert!(fs.is_corner(first) && fs.is_corner(last));
        } else {
            assert!(line.is_closed());
        }
        // Interior vertices are line vertices of this line, at their index.
        for (i, &v) in line.vertices.iter().enumerate() {
            if !fs.is_corner(v) {
                assert_eq!(fs.vertex_kind(v), VertexKind::Line(li as u32));
                let (l, idx) = fs.vertex_line_index(v).unwrap();
                assert_eq!(l, li as u32);
                assert!(idx as usize == i || (line.is_closed() && i == line.vertices.len() - 1));
            }
        }
    }
    assert!(
        seen.iter().all(|&c| c == 1),
        "every feature edge in exactly one line"
    );
    // Vertex kinds agree with the adjacency.
    for v in 0..m.positions.len() as u32 {
        let deg = fs.feature_neighbors(v).count();
        match fs.vertex_kind(v) {
            VertexKind::Smooth => assert_eq!(deg, 0),
            VertexKind::Line(_) => assert_eq!(deg, 2),
            VertexKind::Corner => {
                assert!(deg > 0);
                assert!(fs.corners().binary_search(&v).is_ok());
            }
        }
        for n in fs.feature_neighbors(v) {
            assert!(fs.is_feature_edge(v, n) && fs.is_feature_edge(n, v));
        }
    }
    assert!(fs.corners().windows(2).all(|w| w[0] < w[1]));
}

fn on_box_edge(p: DVec3, lo: DVec3, hi: DVec3) -> bool {
    let extreme = |x: f64, a: f64, b: f64| x == a || x == b;
    [
        extreme(p.x, lo.x, hi.x),
        extreme(p.y, lo.y, hi.y),
        extreme(p.z, lo.z, hi.z),
    ]
    .iter()
    .filter(|&&b| b)
    .count()
        >= 2
}

#[test]
fn defaults_are_documented_values() {
    let o = FeatureOptions::default();
    assert!(o.preserve_features);
    assert_eq!(o.feature_angle_deg, DEFAULT_FEATURE_ANGLE_DEG);
    assert_eq!(o.corner_angle_deg, DEFAULT_CORNER_ANGLE_DEG);
    assert_eq!(DEFAULT_FEATURE_ANGLE_DEG, 45.0);
    assert_eq!(DEFAULT_CORNER_ANGLE_DEG, 45.0);
}

#[test]
fn cube_has_its_twelve_box_edges_eight_corners_and_twelve_lines() {
    let (lo, hi) = (DVec3::new(-1.0, 0.0, 2.0), DVec3::new(1.0, 3.0, 2.5));
    for n in [1u32, 3] {
        let m = shapes::cube(n, lo, hi);
        for angle in [30.0, 45.0, 89.0] {
            let fs = detect_features(&m, &opts(angle));
            check_invariants(&m, &fs);
            assert_eq!(fs.edges().len(), 12 * n as usize, "n={n} angle={angle}");
            assert_eq!(fs.count_edges_with(EdgeFlags::SHARP), 12 * n as usize);
            for e in fs.edges() {
                assert!(on_box_edge(m.positions[e[0] as usize], lo, hi));
                assert!(on_box_edge(m.positions[e[1] as usize], lo, hi));
            }
            assert_eq!(fs.corners().len(), 8);
            for &c in fs.corners() {
                let p = m.positions[c as usize];
                assert!([
                    p.x == lo.x || p.x == hi.x,
                    p.y == lo.y || p.y == hi.y,
                    p.z == lo.z || p.z == hi.z
                ]
                .iter()
                .all(|&b| b));
                assert_eq!(fs.feature_neighbors(c).count(), 3);
            }
            assert_eq!(fs.lines().len(), 12);
            for l in fs.lines() {
                assert_eq!(l.flags(), EdgeFlags::SHARP);
                assert_eq!(l.segment_count(), n as usize);
                assert!(!l.is_closed());
            }
        }
        // 90° creases are not above 91°: nothing is a feature.
        let fs = detect_features(&m, &opts(91.0));
        assert!(fs.edges().is_empty() && fs.corners().is_empty() && fs.lines().is_empty());
        assert!((0..m.positions.len() as u32).all(|v| fs.vertex_kind(v) == VertexKind::Smooth));
        // Without feature preservation a closed unlabelled box has none.
        let fs = detect_features(
            &m,
            &FeatureOptions {
                preserve_features: false,
                ..Default::default()
            },
        );
        assert!(fs.edges().is_empty());
    }
}

#[test]
fn cube_interior_vertices_on_box_edges_are_line_vertices() {
    let m = shapes::cube(4, DVec3::ZERO, DVec3::ONE);
    let fs = detect_features(&m, &FeatureOptions::default());
    let mut line_vertices = 0;
    for (v, p) in m.positions.iter().enumerate() {
        let kind = fs.vertex_kind(v as u32);
        let on_edge = on_box_edge(*p, DVec3::ZERO, DVec3::ONE);
        match kind {
            VertexKind::Smooth => assert!(!on_edge),
            VertexKind::Line(_) => {
                assert!(on_edge);
                line_vertices += 1;
            }
            VertexKind::Corner => assert!(on_edge),
        }
    }
    assert_eq!(line_vertices, 12 * 3);
    // A line's tangent is along one axis.
    for li in 0..fs.lines().len() as u32 {
        let t = fs.line_tangent(li, 0);
        assert!((t.abs().max_element() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn icosphere_has_no_features_at_45_degrees() {
    let m = shapes::icosphere(3);
    let fs = detect_features(&m, &FeatureOptions::default());
    assert!(fs.edges().is_empty());
    assert!(fs.corners().is_empty());
    assert!(fs.lines().is_empty());
    // The dihedral test is live: below the sphere's ~4° dihedrals every edge is a crease.
    let fs = detect_features(&m, &opts(1.0));
    assert_eq!(fs.edges().len(), m.triangles.len() * 3 / 2);
    check_invariants(&m, &fs);
}

#[test]
fn open_cylinder_has_two_closed_boundary_loops_without_corners() {
    let m = shapes::open_cylinder(1.0, 2.0, 16, 4);
    let fs = detect_features(&m, &FeatureOptions::default());
    check_invariants(&m, &fs);
    assert_eq!(fs.edges().len(), 32);
    assert_eq!(fs.count_edges_with(EdgeFlags::BOUNDARY), 32);
    assert!(fs.corners().is_empty());
    assert_eq!(fs.lines().len(), 2);
    for l in fs.lines() {
        assert!(l.is_closed());
        assert_eq!(l.flags(), EdgeFlags::BOUNDARY);
        assert_eq!(l.segment_count(), 16);
        let z = m.positions[l.vertices[0] as usize].z;
        assert!(l.vertices.iter().all(|&v| m.positions[v as usize].z == z));
    }
    // Boundaries survive preserve_features = false.
    let off = detect_features(
        &m,
        &FeatureOptions {
            preserve_features: false,
            ..Default::default()
        },
    );
    assert_eq!(off.edges(), fs.edges());

    // A hexagonal rim turns by 60° at each vertex: all rim vertices are
    // corners. (The prism's 60° vertical creases are switched off here so
    // that only the turning angle decides.)
    let m = shapes::open_cylinder(1.0, 2.0, 6, 2);
    let boundary_only = FeatureOptions {
        preserve_features: false,
        ..Default::default()
    };
    let fs = detect_features(&m, &boundary_only);
    check_invariants(&m, &fs);
    assert_eq!(fs.corners().len(), 12);
    assert_eq!(fs.lines().len(), 12);
    // With the creases, the rim corners also start the six vertical lines.
    let fs = detect_features(&m, &FeatureOptions::default());
    check_invariants(&m, &fs);
    assert_eq!(fs.corners().len(), 12);
    assert_eq!(fs.lines().len(), 12 + 6);
    // No corners with a corner angle above 60°.
    let fs = detect_features(
        &m,
        &FeatureOptions {
            corner_angle_deg: 61.0,
            ..boundary_only
        },
    );
    assert!(fs.corners().is_empty());
    assert_eq!(fs.lines().len(), 2);
}

#[test]
fn grid_boundary_has_four_corners_at_the_square_corners() {
    let m = shapes::grid(2.0, 5);
    let fs = detect_features(&m, &FeatureOptions::default());
    check_invariants(&m, &fs);
    assert_eq!(fs.edges().len(), 20);
    assert_eq!(fs.count_edges_with(EdgeFlags::BOUNDARY), 20);
    let mut corners: Vec<DVec3> = fs
        .corners()
        .iter()
        .map(|&c| m.positions[c as usize])
        .collect();
    corners.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    assert_eq!(
        corners,
        vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 2.0, 0.0)
        ]
    );
    // The one boundary loop is cut into the four sides.
    assert_eq!(fs.lines().len(), 4);
    assert!(fs.lines().iter().all(|l| l.segment_count() == 5));
    // Interior grid vertices are smooth.
    let inner = (0..m.positions.len() as u32)
        .filter(|&v| fs.vertex_kind(v) == VertexKind::Smooth)
        .count();
    assert_eq!(inner, 4 * 4);
}

fn two_label_grid() -> TriMesh {
    let mut m = shapes::grid(1.0, 4);
    // Left half (x < 0.5) label 0, right half label 1.
    m.face_labels = m
        .triangles
        .iter()
        .map(|t| {
            let c = m.corner_positions(t).iter().sum::<DVec3>() / 3.0;
            u32::from(c.x > 0.5)
        })
        .collect();
    m.labels = vec![Default::default(), Default::default()];
    m
}

#[test]
fn label_border_is_a_feature_even_without_feature_preservation() {
    let m = two_label_grid();
    m.check().unwrap();
    for preserve in [true, false] {
        let fs = detect_features(
            &m,
            &FeatureOptions {
                preserve_features: preserve,
                ..Default::default()
            },
        );
        check_invariants(&m, &fs);
        assert_eq!(fs.count_edges_with(EdgeFlags::LABEL_BORDER), 4);
        for (i, e) in fs.edges().iter().enumerate() {
            let f = fs.edge_flags(i as u32);
            let (p, q) = (m.positions[e[0] as usize], m.positions[e[1] as usize]);
            if f.contains(EdgeFlags::LABEL_BORDER) {
                assert!(p.x == 0.5 && q.x == 0.5);
                assert!(!f.contains(EdgeFlags::BOUNDARY));
            }
        }
        assert_eq!(fs.edges().len(), 16 + 4);
        // The border meets the boundary in two T-junctions, which are corners.
        assert_eq!(fs.corners().len(), 6);
        let border_line = &fs.lines()[fs.edge_line(2, 7).unwrap() as usize];
        assert_eq!(border_line.segment_count(), 4);
        assert_eq!(border_line.flags(), EdgeFlags::LABEL_BORDER);
    }
    // Unlabelled, the same grid has no interior features.
    let mut plain = m.clone();
    plain.face_labels.clear();
    plain.labels.clear();
    let fs = detect_features(&plain, &FeatureOptions::default());
    assert_eq!(fs.count_edges_with(EdgeFlags::LABEL_BORDER), 0);
    assert_eq!(fs.edges().len(), 16);
}

#[test]
fn non_manifold_edges_are_features_and_their_ends_corners() {
    // Three flat fins sharing the edge (0, 1).
    let m = TriMesh::new(
        vec![
            DVec3::ZERO,
            DVec3::Z,
            DVec3::X,
            DVec3::Y,
            DVec3::new(-1.0, -1.0, 0.0),
        ],
        vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
    );
    let fs = detect_features(&m, &FeatureOptions::default());
    check_invariants(&m, &fs);
    let id = fs.edge_id(1, 0).unwrap();
    assert!(fs.edge_flags(id).contains(EdgeFlags::NON_MANIFOLD));
    assert!(fs.is_corner(0) && fs.is_corner(1));
}

#[test]
fn disjoint_components_and_unused_vertices_are_handled() {
    let mut m = shapes::union(&[
        shapes::cube(2, DVec3::ZERO, DVec3::ONE),
        shapes::translated(shapes::icosphere(2), DVec3::splat(5.0)),
        shapes::translated(shapes::grid(1.0, 3), DVec3::new(-5.0, 0.0, 0.0)),
    ]);
    m.positions.push(DVec3::splat(100.0)); // unreferenced
    let fs = detect_features(&m, &FeatureOptions::default());
    check_invariants(&m, &fs);
    assert_eq!(fs.edges().len(), 24 + 12);
    assert_eq!(fs.corners().len(), 8 + 4);
    assert_eq!(fs.lines().len(), 12 + 4);
    assert_eq!(
        fs.vertex_kind(m.positions.len() as u32 - 1),
        VertexKind::Smooth
    );
    assert_eq!(fs.vertex_kind(u32::MAX), VertexKind::Smooth);
    assert!(!fs.is_feature_edge(u32::MAX, 0));
}

#[test]
fn empty_mesh_and_non_finite_options_do_not_panic() {
    let fs = detect_features(&TriMesh::default(), &FeatureOptions::default());
    assert!(fs.edges().is_empty() && fs.lines().is_empty());
    let m = shapes::cube(1, DVec3::ZERO, DVec3::ONE);
    let fs = detect_features(
        &m,
        &FeatureOptions {
            preserve_features: true,
            feature_angle_deg: f64::NAN,
            corner_angle_deg: f64::INFINITY,
            min_crease_length: 0.0,
            min_bridge_length: f64::NAN,
        },
    );
    // Non-finite angles fall back to the defaults.
    assert_eq!(fs.edges().len(), 12);
    assert_eq!(fs.corners().len(), 8);
}

#[test]
fn feature_set_is_send_and_sync() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<FeatureSet>();
}
