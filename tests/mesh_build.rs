//! Building half-edge meshes from indexed triangles: welding, repair of
//! degenerate, duplicate, non-manifold and mis-oriented input, typed errors.

use glam::DVec3;
use isoremesh::mesh::{BuildError, Mesh};
use isoremesh::{shapes, TriMesh};

fn build(m: &TriMesh) -> (Mesh, isoremesh::mesh::RepairReport) {
    let (mesh, report) = Mesh::from_trimesh(m).expect("builds");
    mesh.validate().expect("valid");
    (mesh, report)
}

#[test]
fn generated_shapes_build_clean_with_expected_euler_characteristic() {
    for (m, chi, loops) in [
        (shapes::icosphere(3), 2, 0),
        (shapes::torus(2.0, 0.6, 30, 14), 0, 0),
        (shapes::open_cylinder(1.0, 3.0, 20, 6), 0, 2),
        (shapes::cube(4, DVec3::ZERO, DVec3::ONE), 2, 0),
        (shapes::grid(1.0, 5), 1, 1),
    ] {
        let (mesh, report) = build(&m);
        assert!(report.is_clean(), "{report:?}");
        assert_eq!(mesh.euler_characteristic(), chi);
        assert_eq!(mesh.boundary_loop_count(), loops);
        assert_eq!(mesh.face_count(), m.triangles.len());
        assert_eq!(mesh.vertex_count(), m.positions.len());
    }
}

#[test]
fn seams_are_welded_so_they_do_not_become_boundaries() {
    // Every triangle with its own three vertices, as STL or a glTF with hard normals stores it.
    let src = shapes::icosphere(2);
    let mut soup = TriMesh::default();
    for t in &src.triangles {
        let base = soup.positions.len() as u32;
        soup.positions.extend(src.corner_positions(t));
        soup.triangles.push([base, base + 1, base + 2]);
    }
    let (mesh, report) = build(&soup);
    assert_eq!(
        report.welded_vertices as usize,
        soup.positions.len() - src.positions.len()
    );
    assert_eq!(mesh.boundary_loop_count(), 0);
    assert_eq!(mesh.euler_characteristic(), 2);
}

#[test]
fn degenerate_duplicate_and_unreferenced_elements_are_dropped_and_counted() {
    let mut m = shapes::grid(1.0, 2);
    let n = m.positions.len() as u32;
    m.positions.push(DVec3::new(5.0, 5.0, 5.0)); // unreferenced
    m.positions.push(DVec3::new(0.25, 0.0, 0.0)); // collinear with vertices 0 and 1
    m.triangles.push([0, 0, 1]); // repeated index
    m.triangles.push([0, 1, n + 1]); // zero area (three collinear points)
    m.triangles.push(m.triangles[0]); // duplicate
    let t = m.triangles[1];
    m.triangles.push([t[1], t[2], t[0]]); // duplicate, rotated
    let (mesh, report) = build(&m);
    assert_eq!(report.degenerate_faces, 2);
    assert_eq!(report.duplicate_faces, 2);
    assert_eq!(report.unreferenced_vertices, 2);
    assert_eq!(mesh.face_count(), 8);
    assert_eq!(mesh.vertex_count(), 9);
}

#[test]
fn edge_shared_by_three_faces_becomes_boundary_edges() {
    // Three fins around the z axis sharing the edge (0,0,0)-(0,0,1).
    let positions = vec![
        DVec3::ZERO,
        DVec3::Z,
        DVec3::X,
        DVec3::Y,
        DVec3::new(-1.0, -1.0, 0.0),
    ];
    let triangles = vec![[0, 2, 1], [0, 3, 1], [0, 4, 1]];
    let (mesh, report) = build(&TriMesh::new(positions, triangles));
    assert_eq!(report.non_manifold_edges, 1);
    assert_eq!(mesh.face_count(), 3);
    assert!(report.non_manifold_vertices >= 2, "{report:?}");
    assert_eq!(mesh.boundary_loop_count(), 3);
}

/// A closed sphere with one extra face (a fin) hanging on one of its edges:
/// the fin is cut free, and the sphere's two faces on that edge are glued
/// back, so the sphere stays closed and no two edges join the same vertices.
#[test]
fn fin_on_a_closed_surface_is_cut_free_and_the_surface_stays_closed() {
    let mut m = shapes::icosphere(2);
    let sphere_faces = m.triangles.len();
    let [a, b, _] = m.triangles[0];
    let tip = m.positions.len() as u32;
    let mid = (m.positions[a as usize] + m.positions[b as usize]) * 0.5;
    m.positions.push(mid * 1.5);
    m.triangles.push([a, b, tip]);
    let (mesh, report) = build(&m);
    assert_eq!(report.non_manifold_edges, 1);
    assert_eq!(mesh.face_count(), sphere_faces + 1);
    // The fin alone is one boundary loop; the sphere part is closed again.
    assert_eq!(mesh.boundary_loop_count(), 1);
    // Sphere (χ = 2) plus a separate triangle (χ = 1).
    assert_eq!(mesh.euler_characteristic(), 3);
    // Twice over the same edge: two fins on one edge of the sphere.
    let mut m2 = m.clone();
    let tip2 = m2.positions.len() as u32;
    m2.positions.push(mid * 1.3 + DVec3::new(0.0, 0.0, 0.2));
    m2.triangles.push([b, a, tip2]);
    let (mesh2, report2) = build(&m2);
    assert_eq!(report2.non_manifold_edges, 1);
    assert_eq!(mesh2.face_count(), sphere_faces + 2);
    assert_eq!(mesh2.boundary_loop_count(), 2);
}

#[test]
fn bowtie_vertex_is_split_into_one_vertex_per_fan() {
    let positions = vec![
        DVec3::ZERO,
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(-1.0, 1.0, 0.0),
        DVec3::new(1.0, -1.0, 0.0),
        DVec3::new(-1.0, -1.0, 0.0),
    ];
    let triangles = vec![[0, 1, 2], [0, 4, 3]];
    let (mesh, report) = build(&TriMesh::new(positions, triangles));
    assert_eq!(report.non_manifold_vertices, 1);
    assert_eq!(mesh.vertex_count(), 6);
    assert_eq!(mesh.boundary_loop_count(), 2);
}

#[test]
fn inconsistent_orientation_is_fixed_by_flipping_the_minority() {
    let mut m = shapes::icosphere(2);
    for t in m.triangles.iter_mut().take(7) {
        t.swap(1, 2);
    }
    let (mesh, report) = build(&m);
    assert_eq!(report.flipped_faces, 7);
    // Outward orientation is kept: positive signed volume.
    let t = mesh.to_trimesh();
    let vol: f64 = t
        .triangles
        .iter()
        .map(|tri| {
            let [a, b, c] = t.corner_positions(tri);
            a.dot(b.cross(c))
        })
        .sum();
    assert!(vol > 0.0);
}

#[test]
fn moebius_strip_is_reported_non_orientable_and_still_builds() {
    let n = 12u32;
    let mut positions = Vec::new();
    for i in 0..n {
        let u = std::f64::consts::TAU * i as f64 / n as f64;
        for s in [-0.3, 0.3] {
            let w = s * (u / 2.0).cos();
            let r = 1.0 + s * (u / 2.0).cos() * 0.0 + w;
            positions.push(DVec3::new(r * u.cos(), r * u.sin(), s * (u / 2.0).sin()));
        }
    }
    let mut triangles = Vec::new();
    for i in 0..n {
        let (a, b) = (2 * i, 2 * i + 1);
        let (c, d) = if i + 1 < n {
            (2 * (i + 1), 2 * (i + 1) + 1)
        } else {
            (1, 0) // the half twist
        };
        triangles.push([a, c, d]);
        triangles.push([a, d, b]);
    }
    let (_, report) = build(&TriMesh::new(positions, triangles));
    assert_eq!(report.non_orientable_components, 1);
}

#[test]
fn bad_input_gives_typed_errors() {
    let mut m = shapes::icosphere(1);
    m.positions[3].y = f64::NAN;
    assert!(matches!(
        Mesh::from_trimesh(&m),
        Err(BuildError::NonFinite { vertex: 3, .. })
    ));
    let mut m = shapes::icosphere(1);
    m.positions[5].x = f64::INFINITY;
    assert!(matches!(
        Mesh::from_trimesh(&m),
        Err(BuildError::NonFinite { vertex: 5, .. })
    ));
    // Coordinates whose areas overflow, and a mesh whose areas underflow,
    // are refused by name rather than reported as degenerate or remeshed
    // with an infinite target.
    let mut m = shapes::icosphere(1);
    m.positions[4].z = -1e70;
    assert!(matches!(
        Mesh::from_trimesh(&m),
        Err(BuildError::CoordinateTooLarge { vertex: 4, value }) if value == -1e70
    ));
    let mut m = shapes::icosphere(1);
    for p in &mut m.positions {
        *p *= 1e-70;
    }
    let err = Mesh::from_trimesh(&m).unwrap_err();
    assert!(matches!(err, BuildError::TooSmall { diagonal } if diagonal < 1e-69));
    assert!(err.to_string().contains("scale the mesh up"), "{err}");
    // The limits leave the sizes users have alone: 1e-50 and 1e50 build.
    for s in [1e-50, 1e50] {
        let mut m = shapes::icosphere(1);
        for p in &mut m.positions {
            *p *= s;
        }
        let (mesh, report) = Mesh::from_trimesh(&m).unwrap();
        assert_eq!((mesh.face_count(), report.degenerate_faces), (80, 0));
    }
    let mut m = shapes::icosphere(1);
    m.triangles[2][1] = 1000;
    assert!(matches!(
        Mesh::from_trimesh(&m),
        Err(BuildError::IndexOutOfRange {
            face: 2,
            index: 1000,
            ..
        })
    ));
    assert_eq!(
        Mesh::from_trimesh(&TriMesh::default()).unwrap_err(),
        BuildError::Empty
    );
    let only_degenerate = TriMesh::new(vec![DVec3::ZERO, DVec3::X], vec![[0, 1, 1]]);
    assert_eq!(
        Mesh::from_trimesh(&only_degenerate).unwrap_err(),
        BuildError::Empty
    );
}

#[test]
fn labels_survive_build_and_export() {
    let mut m = shapes::cube(2, DVec3::ZERO, DVec3::ONE);
    m.face_labels = (0..m.triangles.len() as u32).map(|f| f % 3).collect();
    m.labels = vec![Default::default(); 3];
    let (mesh, _) = build(&m);
    let back = mesh.to_trimesh();
    assert_eq!(back.face_labels, m.face_labels);
    assert_eq!(back.triangles, m.triangles);
}
