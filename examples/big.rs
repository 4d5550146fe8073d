fn main() {
    let torus = isoremesh::shapes::torus(3.0, 1.0, 2000, 250);
    let t = std::time::Instant::now();
    let (mesh, _) = isoremesh::mesh::Mesh::from_trimesh(&torus).unwrap();
    eprintln!("build {:?}", t.elapsed());
    let t = std::time::Instant::now();
    let out = isoremesh::remesh::remesh(
        &mesh,
        &isoremesh::remesh::RemeshOptions::default(),
        &mut isoremesh::remesh::NoObserver,
    )
    .unwrap();
    eprintln!(
        "remesh {:?} faces {} {:?}",
        t.elapsed(),
        out.mesh.face_count(),
        out.report.seconds
    );
}
