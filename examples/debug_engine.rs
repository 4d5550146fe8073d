use isoremesh::io::ReadOptions;
use isoremesh::remesh::{remesh, Observer, Progress, RemeshOptions};
struct P(std::time::Instant);
impl Observer for P {
    fn progress(&mut self, p: &Progress) {
        eprintln!("{:?} it {} {:?}", self.0.elapsed(), p.iteration, p.pass);
    }
}
fn main() {
    let path = std::env::args().nth(1).unwrap();
    let l: f64 = std::env::args().nth(2).unwrap().parse().unwrap();
    let iters: u32 = std::env::args()
        .nth(3)
        .map(|s| s.parse().unwrap())
        .unwrap_or(10);
    let bytes = std::fs::read(&path).unwrap();
    let input =
        isoremesh::pipeline::load(&bytes, Some(&path), None, &ReadOptions::default()).unwrap();
    eprintln!("repairs {:?}", input.repairs);
    let o = RemeshOptions::default()
        .with_target_edge_length(l)
        .with_iterations(iters);
    let out = remesh(&input.mesh, &o, &mut P(std::time::Instant::now())).unwrap();
    let nan = out
        .mesh
        .positions()
        .iter()
        .filter(|p| !p.is_finite())
        .count();
    eprintln!(
        "faces {} nan {nan} {:?}",
        out.mesh.face_count(),
        out.report.iterations
    );
}
