fn main() {
    let m = isoremesh::shapes::icosphere(8);
    for _ in 0..3 {
        let t = std::time::Instant::now();
        let _ = isoremesh::mesh::Mesh::from_trimesh(&m).unwrap();
        eprintln!("total {:?}", t.elapsed());
    }
}
