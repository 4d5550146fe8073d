//! Building a half-edge mesh from about one million indexed triangles
//! (an icosphere with 8 subdivisions has 1,310,720), with and without seams
//! to weld (the triangle-soup case, as STL stores it).

use criterion::{criterion_group, criterion_main, Criterion};
use isoremesh::mesh::Mesh;
use isoremesh::{shapes, TriMesh};
use std::hint::black_box;

fn bench_build(c: &mut Criterion) {
    let indexed = shapes::icosphere(8);
    let mut soup = TriMesh::default();
    soup.positions.reserve(indexed.triangles.len() * 3);
    for t in &indexed.triangles {
        let base = soup.positions.len() as u32;
        soup.positions.extend(indexed.corner_positions(t));
        soup.triangles.push([base, base + 1, base + 2]);
    }
    let mut group = c.benchmark_group("build");
    group.sample_size(10);
    group.bench_function("indexed_1.3M_triangles", |b| {
        b.iter(|| Mesh::from_trimesh(black_box(&indexed)).unwrap())
    });
    group.bench_function("soup_1.3M_triangles", |b| {
        b.iter(|| Mesh::from_trimesh(black_box(&soup)).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_build);
criterion_main!(benches);
