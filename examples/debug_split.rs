use isoremesh::io::ReadOptions;
use isoremesh::remesh::{remesh, NoObserver, RemeshOptions};
fn main() {
    let path = std::env::args().nth(1).unwrap();
    let l: f64 = std::env::args().nth(2).unwrap().parse().unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let input =
        isoremesh::pipeline::load(&bytes, Some(&path), None, &ReadOptions::default()).unwrap();
    let tm = input.mesh.to_trimesh();
    eprintln!("area {} faces {}", tm.area(), tm.triangles.len());
    let mut o = RemeshOptions::default()
        .with_target_edge_length(l)
        .with_iterations(1);
    o.collapse = false;
    o.flip = false;
    o.relax = false;
    o.project = false;
    let out = remesh(&input.mesh, &o, &mut NoObserver).unwrap();
    let t = out.mesh.to_trimesh();
    eprintln!("after split: faces {} area {}", t.triangles.len(), t.area());
    // long-edge count per input triangle size
    let mut lens: Vec<f64> = out.mesh.edges().map(|e| out.mesh.edge_length(e)).collect();
    lens.sort_by(|a, b| a.partial_cmp(b).unwrap());
    eprintln!(
        "edge len quantiles {:?}",
        [0.0, 0.01, 0.1, 0.5, 0.9, 1.0].map(|q| lens[((lens.len() - 1) as f64 * q) as usize] / l)
    );
}
