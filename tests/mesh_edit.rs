//! Property tests of the guarded operators: random sequences of split,
//! collapse and flip on generated shapes keep the mesh valid and the Euler
//! characteristic unchanged; compaction, in order or in any vertex order,
//! keeps the geometry, the face labels and the feature flags.

use glam::DVec3;
use isoremesh::mesh::{EdgeId, HalfedgeId, Handle, Mesh, EDGE_FEATURE};
use isoremesh::{shapes, TriMesh};
use proptest::prelude::*;

fn shape(k: u8) -> TriMesh {
    match k % 5 {
        0 => shapes::icosphere(1),
        1 => shapes::torus(2.0, 0.7, 9, 6),
        2 => shapes::open_cylinder(1.0, 2.0, 8, 3),
        3 => shapes::cube(2, DVec3::ZERO, DVec3::ONE),
        _ => shapes::grid(1.0, 3),
    }
}

#[derive(Debug, Clone)]
enum Op {
    Split(u32, f64),
    Collapse(u32, bool),
    Flip(u32),
    Compact,
    Reorder(u64),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => (any::<u32>(), 0.05f64..0.95).prop_map(|(e, t)| Op::Split(e, t)),
        3 => (any::<u32>(), any::<bool>()).prop_map(|(e, d)| Op::Collapse(e, d)),
        3 => any::<u32>().prop_map(Op::Flip),
        1 => Just(Op::Compact),
        1 => any::<u64>().prop_map(Op::Reorder),
    ]
}

fn live_edge(mesh: &Mesh, pick: u32) -> Option<EdgeId> {
    let n = mesh.edge_capacity() as u32;
    (0..n)
        .map(|i| EdgeId((pick.wrapping_add(i)) % n))
        .find(|&e| !mesh.is_edge_deleted(e))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn guarded_operations_keep_the_mesh_valid(kind in 0u8..5, ops in prop::collection::vec(op(), 1..120)) {
        let (mut mesh, _) = Mesh::from_trimesh(&shape(kind)).unwrap();
        let chi = mesh.euler_characteristic();
        let loops = mesh.boundary_loop_count();
        for op in ops {
            match op {
                Op::Split(e, t) => {
                    let Some(e) = live_edge(&mesh, e) else { continue };
                    prop_assert!(mesh.can_split(e));
                    let [a, b] = mesh.edge_vertices(e);
                    let p = mesh.position(a).lerp(mesh.position(b), t);
                    let faces_before = mesh.face_count();
                    let r = mesh.split_edge(e, p);
                    prop_assert_eq!(mesh.position(r.vertex), p);
                    prop_assert_eq!(mesh.to_vertex(r.second_half), b);
                    let new_faces = r.faces.iter().filter(|f| f.is_valid()).count();
                    prop_assert_eq!(mesh.face_count(), faces_before + new_faces);
                    prop_assert_eq!(r.spokes.iter().filter(|s| s.is_valid()).count(), new_faces);
                }
                Op::Collapse(e, dir) => {
                    let Some(e) = live_edge(&mesh, e) else { continue };
                    let h: HalfedgeId = e.halfedge(dir as u32);
                    if mesh.can_collapse(h) {
                        let v0 = mesh.from_vertex(h);
                        let v1 = mesh.to_vertex(h);
                        let r = mesh.collapse_edge(h);
                        prop_assert_eq!(r.kept, v1);
                        prop_assert_eq!(r.removed, v0);
                        prop_assert!(mesh.is_vertex_deleted(v0));
                        for f in r.removed_faces.iter().filter(|f| f.is_valid()) {
                            prop_assert!(mesh.is_face_deleted(*f));
                        }
                    }
                }
                Op::Flip(e) => {
                    let Some(e) = live_edge(&mesh, e) else { continue };
                    if mesh.can_flip(e) {
                        mesh.flip_edge(e);
                    } else {
                        let refused_for_a_reason = mesh.is_boundary_edge(e) || {
                            let h = e.halfedge(0);
                            let c = mesh.to_vertex(mesh.next(h));
                            let d = mesh.to_vertex(mesh.next(h.twin()));
                            mesh.find_halfedge(c, d).is_some()
                                || mesh.edge_vertices(e).iter().any(|&v| mesh.valence(v) <= 3)
                        };
                        prop_assert!(refused_for_a_reason);
                    }
                }
                Op::Compact => {
                    let before = mesh.to_trimesh();
                    mesh.compact();
                    prop_assert!(!mesh.has_garbage());
                    prop_assert_eq!(mesh.to_trimesh(), before);
                }
                Op::Reorder(seed) => {
                    let before = canonical(&mesh);
                    let mut order: Vec<_> = mesh.vertices().collect();
                    // A seeded shuffle (xorshift), so any order is exercised.
                    let mut x = seed | 1;
                    for i in (1..order.len()).rev() {
                        x ^= x << 13;
                        x ^= x >> 7;
                        x ^= x << 17;
                        order.swap(i, (x % (i as u64 + 1)) as usize);
                    }
                    let remap = mesh.compact_in_order(&order);
                    prop_assert!(!mesh.has_garbage());
                    for (k, v) in order.iter().enumerate() {
                        prop_assert_eq!(remap.vertices[v.idx()], k as u32);
                    }
                    prop_assert_eq!(canonical(&mesh), before);
                }
            }
            if let Err(err) = mesh.validate() {
                return Err(TestCaseError::fail(format!("{err} after {op:?}")));
            }
            prop_assert_eq!(mesh.euler_characteristic(), chi);
            prop_assert_eq!(mesh.boundary_loop_count(), loops);
        }
    }
}

/// The mesh as index-free sets: each face as its corner positions (bits),
/// rotated to start at the smallest and tagged with its label, and each
/// flagged edge as its sorted end positions.
type Canonical = (Vec<([[u64; 3]; 3], u32)>, Vec<([[u64; 3]; 2], u8)>);

fn canonical(mesh: &Mesh) -> Canonical {
    let bits = |v| {
        let p: DVec3 = mesh.position(v);
        [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
    };
    let mut faces: Vec<_> = mesh
        .faces()
        .map(|f| {
            let c = mesh.face_vertices(f).map(bits);
            let k = (0..3).min_by_key(|&k| c[k]).unwrap();
            ([c[k], c[(k + 1) % 3], c[(k + 2) % 3]], mesh.face_label[f])
        })
        .collect();
    faces.sort();
    let mut edges: Vec<_> = mesh
        .edges()
        .filter(|&e| mesh.edge_flags[e] != 0)
        .map(|e| {
            let mut ends = mesh.edge_vertices(e).map(bits);
            ends.sort();
            (ends, mesh.edge_flags[e])
        })
        .collect();
    edges.sort();
    (faces, edges)
}

#[test]
fn split_halves_inherit_feature_flags_and_collapse_merges_them() {
    let (mut mesh, _) = Mesh::from_trimesh(&shapes::grid(1.0, 2)).unwrap();
    let e = mesh.edges().find(|&e| mesh.is_boundary_edge(e)).unwrap();
    mesh.edge_flags[e] = EDGE_FEATURE;
    let [a, b] = mesh.edge_vertices(e);
    let r = mesh.split_edge(e, (mesh.position(a) + mesh.position(b)) * 0.5);
    assert!(mesh.edge_has_flag(r.second_half.edge(), EDGE_FEATURE));
    assert!(mesh.edge_has_flag(e, EDGE_FEATURE));
    assert_eq!(r.faces.iter().filter(|f| f.is_valid()).count(), 1);
    mesh.validate().unwrap();
    // Collapse the new vertex back along the boundary.
    let h = mesh.find_halfedge(r.vertex, b).unwrap();
    assert!(mesh.can_collapse(h));
    mesh.collapse_edge(h);
    mesh.validate().unwrap();
    let e2 = mesh.find_halfedge(a, b).unwrap().edge();
    assert!(mesh.edge_has_flag(e2, EDGE_FEATURE));
}

#[test]
fn link_condition_refuses_collapses_that_would_duplicate_edges() {
    // A tetrahedron: every collapse would leave two faces on three vertices.
    let positions = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
    let triangles = vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
    let (mesh, _) = Mesh::from_trimesh(&TriMesh::new(positions, triangles)).unwrap();
    for e in mesh.edges() {
        assert!(!mesh.can_collapse(e.halfedge(0)));
        assert!(!mesh.can_collapse(e.halfedge(1)));
        assert!(!mesh.can_flip(e));
    }
    // An interior edge joining two boundary vertices would pinch a strip.
    let (mesh, _) = Mesh::from_trimesh(&shapes::grid(1.0, 1)).unwrap();
    let diag = mesh.edges().find(|&e| !mesh.is_boundary_edge(e)).unwrap();
    assert!(!mesh.can_collapse(diag.halfedge(0)));
}

#[test]
fn flip_rotates_the_diagonal_of_a_quad() {
    let (mut mesh, _) = Mesh::from_trimesh(&shapes::icosphere(1)).unwrap();
    let e = mesh.edges().next().unwrap();
    let h = e.halfedge(0);
    let c = mesh.to_vertex(mesh.next(h));
    let d = mesh.to_vertex(mesh.next(h.twin()));
    assert!(mesh.can_flip(e));
    mesh.flip_edge(e);
    mesh.validate().unwrap();
    let [x, y] = mesh.edge_vertices(e);
    assert_eq!([x, y], [d, c]);
}
