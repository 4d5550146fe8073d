//! SurfaceIndex build time and closest-point throughput on a 1.3M-triangle
//! icosphere (`shapes::icosphere(8)`), with and without a hint face.
//!
//! The near-surface set imitates the remesher: points a fraction of an edge
//! off the surface, in random order (every query a cache miss), whose hint
//! is the face found for the same point before it moved. The face-order
//! set visits jittered face centroids in (spatially coherent) face order
//! with the previous answer as hint, as a sweep over a mesh does. The off-surface set has points up to
//! 20 % of the radius away, where many more boxes tie with the answer.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::DVec3;
use isoremesh::bvh::SurfaceIndex;
use isoremesh::shapes;
use std::hint::black_box;

/// splitmix64, for reproducible query points.
fn splitmix(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

fn bench(c: &mut Criterion) {
    let mesh = shapes::icosphere(8);
    let n_tris = mesh.triangles.len();
    let edge = (mesh.positions[mesh.triangles[0][0] as usize]
        - mesh.positions[mesh.triangles[0][1] as usize])
        .length();

    let mut g = c.benchmark_group("bvh_build");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n_tris as u64));
    g.bench_function(format!("icosphere8_{n_tris}_tris"), |b| {
        b.iter(|| black_box(SurfaceIndex::from_trimesh(black_box(&mesh))))
    });
    g.finish();

    let index = SurfaceIndex::from_trimesh(&mesh);
    let mut s = 12345u64;
    const N: usize = 100_000;
    let mut moved = Vec::with_capacity(N);
    let mut hints = Vec::with_capacity(N);
    let mut off = Vec::with_capacity(N);
    for _ in 0..N {
        let t = mesh.triangles[(splitmix(&mut s) * n_tris as f64) as usize % n_tris];
        let [a, b, c] = mesh.corner_positions(&t);
        let (u, v) = (splitmix(&mut s), splitmix(&mut s));
        let (u, v) = if u + v > 1.0 {
            (1.0 - u, 1.0 - v)
        } else {
            (u, v)
        };
        let on = a + (b - a) * u + (c - a) * v;
        let hint = index.closest_point(on).map_or(0, |cp| cp.face);
        let jitter = DVec3::new(
            splitmix(&mut s) - 0.5,
            splitmix(&mut s) - 0.5,
            splitmix(&mut s) - 0.5,
        ) * (0.5 * edge);
        moved.push(on + jitter);
        hints.push(hint);
        let dir = DVec3::new(
            splitmix(&mut s) - 0.5,
            splitmix(&mut s) - 0.5,
            splitmix(&mut s) - 0.5,
        )
        .normalize_or(DVec3::X);
        off.push(on + dir * (0.2 * (2.0 * splitmix(&mut s) - 1.0)));
    }

    // icosphere faces are numbered hierarchically (face i splits into
    // 4i..4i+3), so face order is spatially coherent; a stride covers the
    // whole sphere.
    let stride = n_tris / N;
    let sweep: Vec<DVec3> = (0..N)
        .map(|i| {
            let [a, b, c] = mesh.corner_positions(&mesh.triangles[i * stride]);
            (a + b + c) / 3.0
                + DVec3::new(
                    splitmix(&mut s) - 0.5,
                    splitmix(&mut s) - 0.5,
                    splitmix(&mut s) - 0.5,
                ) * (0.5 * edge)
        })
        .collect();

    let mut g = c.benchmark_group("bvh_query");
    g.throughput(Throughput::Elements(N as u64));
    g.sample_size(20);
    g.bench_function("near_surface_no_hint", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for &p in &moved {
                acc += index.closest_point(p).map_or(0.0, |cp| cp.distance_squared);
            }
            black_box(acc)
        })
    });
    g.bench_function("near_surface_with_hint", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for (&p, &h) in moved.iter().zip(&hints) {
                acc += index
                    .closest_point_with_hint(p, h)
                    .map_or(0.0, |cp| cp.distance_squared);
            }
            black_box(acc)
        })
    });
    g.bench_function("face_order_previous_hint", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            let mut hint = 0;
            for &p in &sweep {
                if let Some(cp) = index.closest_point_with_hint(p, hint) {
                    hint = cp.face;
                    acc += cp.distance_squared;
                }
            }
            black_box(acc)
        })
    });
    g.bench_function("off_surface_no_hint", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for &p in &off {
                acc += index.closest_point(p).map_or(0.0, |cp| cp.distance_squared);
            }
            black_box(acc)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
