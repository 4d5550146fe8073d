//! Remeshing a generated one-million-triangle surface (an anisotropically
//! tessellated torus, 2000 × 250 quads) at its mean edge length for 10
//! iterations: the large-mesh speed target of the engine.

use criterion::{criterion_group, criterion_main, Criterion};
use isoremesh::mesh::Mesh;
use isoremesh::remesh::{remesh, NoObserver, RemeshOptions};
use isoremesh::shapes;
use std::hint::black_box;

// The shipped binary's allocator (src/main.rs), so the bench measures what
// the CLI and the service run. The binary also turns transparent huge
// pages off; at this size that made no difference beyond the noise (the
// CLI on this torus: 7.5–8.7 s with them, 7.8–8.6 s without), so the bench,
// a library caller, keeps the system's setting.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn bench_remesh(c: &mut Criterion) {
    let torus = shapes::torus(3.0, 1.0, 2000, 250);
    let (mesh, _) = Mesh::from_trimesh(&torus).unwrap();
    let options = RemeshOptions::default().with_iterations(10);
    let mut group = c.benchmark_group("remesh");
    group.sample_size(10);
    group.bench_function("torus_1M_triangles_10_iterations", |b| {
        b.iter(|| remesh(black_box(&mesh), &options, &mut NoObserver).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_remesh);
criterion_main!(benches);
