//! Two-sided surface distance between a mesh and a reference, as the
//! benchmark's `quality.py` (`fidelity`) defines it: each side is sampled
//! with N area-uniform points plus its vertices, every sample's exact
//! distance to the other triangle mesh is taken (here with
//! [`SurfaceIndex`]), the Hausdorff distance is the larger of the two
//! maxima, and mean and RMS pool both sides.
//!
//! Sampling is deterministic: sample i of a side draws its numbers from a
//! splitmix64 stream (Steele, Lea & Flood, "Fast splittable pseudorandom
//! number generators", 2014) at counters 3i, 3i+1, 3i+2 of a fixed seed, so
//! the samples are the same however rayon splits the work.

use glam::DVec3;
use rayon::prelude::*;

use crate::bvh::SurfaceIndex;
use crate::geometry::triangle_area;

/// Points per parallel task; consecutive points chain their answers as hints.
const CHUNK: usize = 2048;

/// Seeds of the two sides' sample streams.
const SEED_MESH: u64 = 0x1503_E5A3_0000_0001;
const SEED_REFERENCE: u64 = 0x1503_E5A3_0000_0002;

/// The splitmix64 output for `counter` of stream `seed`.
#[inline]
fn splitmix64(seed: u64, counter: u64) -> u64 {
    let mut z = seed.wrapping_add(counter.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in [0, 1) with 53 random bits.
#[inline]
fn unit(seed: u64, counter: u64) -> f64 {
    (splitmix64(seed, counter) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// One side of the comparison: the surface whose samples are measured.
pub(crate) struct Side<'a> {
    pub positions: &'a [DVec3],
    /// Faces with valid indices.
    pub triangles: &'a [[u32; 3]],
    /// Vertices referenced by some face (these are sampled too).
    pub used: &'a [bool],
}

/// Max, sum and sum of squares of the distances of one side's samples.
#[derive(Clone, Copy, Default)]
pub(crate) struct SideDistances {
    pub max: f64,
    pub sum: f64,
    pub sum_sq: f64,
    pub count: u64,
}

impl SideDistances {
    fn merge(mut self, o: Self) -> Self {
        self.max = self.max.max(o.max);
        self.sum += o.sum;
        self.sum_sq += o.sum_sq;
        self.count += o.count;
        self
    }
}

/// Faces of `n` area-uniform samples of `side`, sorted (so that consecutive
/// samples are near each other, as far as the face order is coherent).
fn sample_faces(side: &Side, n: usize, seed: u64) -> Vec<u32> {
    let mut cumulative = Vec::with_capacity(side.triangles.len());
    let mut total = 0.0;
    for t in side.triangles {
        let p = [
            side.positions[t[0] as usize],
            side.positions[t[1] as usize],
            side.positions[t[2] as usize],
        ];
        let a = triangle_area(p);
        if a.is_finite() {
            total += a;
        }
        cumulative.push(total);
    }
    if !(total > 0.0 && total.is_finite()) {
        return Vec::new();
    }
    let last = side.triangles.len() - 1;
    let mut faces: Vec<u32> = (0..n as u64)
        .into_par_iter()
        .map(|i| {
            let x = unit(seed, 3 * i) * total;
            // First face whose cumulative area exceeds x: zero-area faces are never chosen.
            cumulative.partition_point(|&c| c <= x).min(last) as u32
        })
        .collect();
    faces.par_sort_unstable();
    faces
}

/// Distances from the samples of `side` (area samples on `faces`, then the
/// used vertices) to the surface of `target`.
pub(crate) fn side_distances(
    side: &Side,
    n: usize,
    seed: u64,
    target: &SurfaceIndex,
) -> SideDistances {
    let faces = sample_faces(side, n, seed);
    let vertices: Vec<u32> = (0..side.positions.len() as u32)
        .filter(|&v| side.used[v as usize])
        .collect();
    let total = faces.len() + vertices.len();
    let point = |k: usize| -> DVec3 {
        if k < faces.len() {
            let t = side.triangles[faces[k] as usize];
            let (a, b, c) = (
                side.positions[t[0] as usize],
                side.positions[t[1] as usize],
                side.positions[t[2] as usize],
            );
            let r1 = unit(seed, 3 * k as u64 + 1).sqrt();
            let r2 = unit(seed, 3 * k as u64 + 2);
            a * (1.0 - r1) + b * (r1 * (1.0 - r2)) + c * (r1 * r2)
        } else {
            side.positions[vertices[k - faces.len()] as usize]
        }
    };
    let parts: Vec<SideDistances> = (0..total.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut acc = SideDistances::default();
            let mut hint = None;
            for k in c * CHUNK..((c + 1) * CHUNK).min(total) {
                let p = point(k);
                let found = match hint {
                    Some(h) => target.closest_point_with_hint(p, h),
                    None => target.closest_point(p),
                };
                if let Some(cp) = found {
                    hint = Some(cp.face);
                    let d = cp.distance_squared.sqrt();
                    acc.max = acc.max.max(d);
                    acc.sum += d;
                    acc.sum_sq += cp.distance_squared;
                    acc.count += 1;
                }
            }
            acc
        })
        .collect();
    // Sequential merge in chunk order: the same sums on every run.
    parts
        .into_iter()
        .fold(SideDistances::default(), SideDistances::merge)
}

/// Both directions: (mesh samples → reference, reference samples → mesh).
pub(crate) fn two_sided(
    mesh: &Side,
    mesh_index: &SurfaceIndex,
    reference: &Side,
    reference_index: &SurfaceIndex,
    n: usize,
) -> (SideDistances, SideDistances) {
    rayon::join(
        || side_distances(mesh, n, SEED_MESH, reference_index),
        || side_distances(reference, n, SEED_REFERENCE, mesh_index),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix_stream_is_uniform_enough() {
        let n = 100_000u64;
        let mut bins = [0u32; 10];
        let mut sum = 0.0;
        for i in 0..n {
            let u = unit(7, i);
            assert!((0.0..1.0).contains(&u));
            bins[(u * 10.0) as usize] += 1;
            sum += u;
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.005);
        for b in bins {
            assert!((b as f64 - 10_000.0).abs() < 500.0, "{bins:?}");
        }
        assert_ne!(splitmix64(1, 0), splitmix64(2, 0));
    }

    #[test]
    fn area_sampling_follows_area() {
        // Two triangles, the second three times larger.
        let positions = [
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::new(10.0, 0.0, 0.0),
            DVec3::new(13.0, 0.0, 0.0),
            DVec3::new(10.0, 1.0, 0.0),
        ];
        let triangles = [[0, 1, 2], [3, 4, 5]];
        let used = [true; 6];
        let side = Side {
            positions: &positions,
            triangles: &triangles,
            used: &used,
        };
        let faces = sample_faces(&side, 40_000, 3);
        let second = faces.iter().filter(|&&f| f == 1).count() as f64 / 40_000.0;
        assert!((second - 0.75).abs() < 0.01, "{second}");
        assert!(faces.windows(2).all(|w| w[0] <= w[1]));
    }
}
