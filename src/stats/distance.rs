//! Two-sided surface distance between a mesh and a reference, as the
//! benchmark's `quality.py` (`fidelity`) defines it: each side is sampled
//! with N area-uniform points plus its vertices, every sample's exact
//! distance to the other triangle mesh is taken (here with
//! [`SurfaceIndex`]), the Hausdorff distance is the larger of the two
//! maxima, and mean and RMS pool both sides.
//!
//! The samples are the ones `quality.py` draws: one NumPy-compatible
//! PCG64 stream (see [`super::rng`]) from a seed (its default is 0) gives,
//! for the reference side first and then for the mesh, N uniforms that pick
//! faces by inverse transform over the normalised cumulative area (NumPy's
//! `Generator.choice` with probabilities), then N for `r1 = sqrt(u)`, then N
//! for `r2`, and the sample is `(1 − r1)·A + r1(1 − r2)·B + r1·r2·C`. On the
//! same welded meshes both tools therefore measure at the same points and
//! report the same distances. The stream is drawn sequentially (a few
//! milliseconds); the distance queries are parallel and summed in a fixed
//! order, so the result does not depend on the thread count.

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::rng::Pcg64;
use super::StatsOptions;
use crate::bvh::SurfaceIndex;
use crate::trimesh::TriMesh;

/// Points per parallel task; consecutive points chain their answers as hints.
const CHUNK: usize = 2048;

/// The default seed of the sample stream: `quality.py`'s default `--seed`.
pub const DEFAULT_SEED: u64 = 0;

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

/// Face areas as `quality.py` computes them: half the norm of
/// (B − A) × (C − A).
fn face_areas(side: &Side) -> Vec<f64> {
    side.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| side.positions[v as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .collect()
}

/// `n` area-uniform samples of `side` drawn from `rng` as `quality.py`'s
/// `sample_surface` draws them, each with the face it lies on, sorted by
/// face (so that consecutive queries are near each other). Empty when the
/// side has no area.
fn draw_samples(side: &Side, n: usize, rng: &mut Pcg64) -> Vec<(u32, DVec3)> {
    let areas = face_areas(side);
    let total: f64 = areas.iter().sum();
    if side.triangles.is_empty() || !(total > 0.0 && total.is_finite()) {
        return Vec::new();
    }
    // cdf = cumsum(area / total) / cdf[-1], then searchsorted(u, 'right').
    let mut cdf = Vec::with_capacity(areas.len());
    let mut running = 0.0;
    for a in &areas {
        running += a / total;
        cdf.push(running);
    }
    let last = running;
    for c in &mut cdf {
        *c /= last;
    }
    let last_face = side.triangles.len() - 1;
    let faces: Vec<u32> = (0..n)
        .map(|_| {
            let u = rng.next_f64();
            cdf.partition_point(|&c| c <= u).min(last_face) as u32
        })
        .collect();
    let r1: Vec<f64> = (0..n).map(|_| rng.next_f64().sqrt()).collect();
    let r2: Vec<f64> = (0..n).map(|_| rng.next_f64()).collect();
    let mut samples: Vec<(u32, DVec3)> = (0..n)
        .into_par_iter()
        .map(|k| {
            let f = faces[k];
            let [a, b, c] = side.triangles[f as usize].map(|v| side.positions[v as usize]);
            let (s, t) = (r1[k], r2[k]);
            (f, a * (1.0 - s) + b * (s * (1.0 - t)) + c * (s * t))
        })
        .collect();
    // Stable, so equal faces keep their draw order: the same on every run.
    samples.par_sort_by_key(|&(f, _)| f);
    samples
}

/// Distances from `samples` of `side`, then its used vertices, to the
/// surface of `target`.
fn side_distances(side: &Side, samples: &[(u32, DVec3)], target: &SurfaceIndex) -> SideDistances {
    let vertices: Vec<u32> = (0..side.positions.len() as u32)
        .filter(|&v| side.used[v as usize])
        .collect();
    let total = samples.len() + vertices.len();
    let point = |k: usize| -> DVec3 {
        if k < samples.len() {
            samples[k].1
        } else {
            side.positions[vertices[k - samples.len()] as usize]
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

/// Both directions: (mesh samples → reference, reference samples → mesh),
/// with `n` area samples per side drawn from the stream of `seed`, the
/// reference's first, as `quality.py` orders them.
pub(crate) fn two_sided(
    mesh: &Side,
    mesh_index: &SurfaceIndex,
    reference: &Side,
    reference_index: &SurfaceIndex,
    n: usize,
    seed: u64,
) -> (SideDistances, SideDistances) {
    let mut rng = Pcg64::from_seed(seed);
    let reference_samples = draw_samples(reference, n, &mut rng);
    let mesh_samples = draw_samples(mesh, n, &mut rng);
    rayon::join(
        || side_distances(mesh, &mesh_samples, reference_index),
        || side_distances(reference, &reference_samples, mesh_index),
    )
}

/// Two-sided distance between the mesh and the reference surface. Each side
/// is sampled with `samples_per_side` area-uniform points plus its vertices
/// and each sample's exact distance to the other surface is taken.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DistanceStats {
    /// Symmetric Hausdorff distance: the larger of the two one-sided maxima.
    pub hausdorff: f64,
    /// Mean distance, pooled over the samples of both sides.
    pub mean: f64,
    /// Root mean square distance, pooled over the samples of both sides.
    pub rms: f64,
    /// `hausdorff` divided by the reference's bounding-box diagonal.
    pub hausdorff_relative: f64,
    /// `mean` divided by the reference's bounding-box diagonal.
    pub mean_relative: f64,
    /// `rms` divided by the reference's bounding-box diagonal.
    pub rms_relative: f64,
    /// Largest distance from a sample of the mesh to the reference.
    pub to_reference_max: f64,
    /// Largest distance from a sample of the reference to the mesh.
    pub from_reference_max: f64,
    /// The reference's bounding-box diagonal.
    pub reference_diagonal: f64,
    /// Area-uniform samples taken on each side (vertices come on top).
    pub samples_per_side: u64,
    /// Seed of the sample stream: with the same seed and sample count,
    /// `quality.py` draws the same points and reports the same distances.
    pub seed: u64,
}

/// The `distance` section of `mesh` (faces `tris`, vertices `used`)
/// against `reference`, or `None` when either has no valid face.
pub(super) fn distance_stats(
    mesh: &TriMesh,
    tris: &[[u32; 3]],
    used: &[bool],
    reference: &TriMesh,
    opts: &StatsOptions,
) -> Option<DistanceStats> {
    let ref_nv = reference.positions.len();
    let ref_tris: Vec<[u32; 3]> = reference
        .triangles
        .iter()
        .copied()
        .filter(|t| t.iter().all(|&v| (v as usize) < ref_nv))
        .collect();
    if tris.is_empty() || ref_tris.is_empty() {
        return None;
    }
    let mut ref_used = vec![false; ref_nv];
    for t in &ref_tris {
        for &v in t {
            ref_used[v as usize] = true;
        }
    }
    let built;
    let (mesh_index, ref_index) = match opts.reference_index {
        Some(r) => (SurfaceIndex::new(&mesh.positions, tris), r),
        None => {
            let (m, r) = rayon::join(
                || SurfaceIndex::new(&mesh.positions, tris),
                || SurfaceIndex::new(&reference.positions, &ref_tris),
            );
            built = r;
            (m, &built)
        }
    };
    let n = opts.samples_per_side;
    let (to_ref, from_ref) = two_sided(
        &Side {
            positions: &mesh.positions,
            triangles: tris,
            used,
        },
        &mesh_index,
        &Side {
            positions: &reference.positions,
            triangles: &ref_tris,
            used: &ref_used,
        },
        ref_index,
        n,
        opts.sample_seed,
    );
    let count = (to_ref.count + from_ref.count).max(1) as f64;
    let hausdorff = to_ref.max.max(from_ref.max);
    let mean = (to_ref.sum + from_ref.sum) / count;
    let rms = ((to_ref.sum_sq + from_ref.sum_sq) / count).sqrt();
    let diag = reference.bbox_diagonal();
    let rel = |x: f64| if diag > 0.0 { x / diag } else { 0.0 };
    Some(DistanceStats {
        hausdorff,
        mean,
        rms,
        hausdorff_relative: rel(hausdorff),
        mean_relative: rel(mean),
        rms_relative: rel(rms),
        to_reference_max: to_ref.max,
        from_reference_max: from_ref.max,
        reference_diagonal: diag,
        samples_per_side: n as u64,
        seed: opts.sample_seed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_triangles() -> ([DVec3; 6], [[u32; 3]; 2]) {
        (
            [
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                DVec3::new(10.0, 0.0, 0.0),
                DVec3::new(13.0, 0.0, 0.0),
                DVec3::new(10.0, 1.0, 0.5),
            ],
            [[0, 1, 2], [3, 4, 5]],
        )
    }

    #[test]
    fn samples_are_the_ones_quality_py_draws() {
        // quality.sample_surface(V, F, 4, rng) and then, on the first
        // triangle alone, sample_surface(V[:3], F[:1], 2, rng), with
        // rng = numpy.random.default_rng(0), printed by NumPy 2.4.
        let (positions, triangles) = two_triangles();
        let used = [true; 6];
        let side = Side {
            positions: &positions,
            triangles: &triangles,
            used: &used,
        };
        let first = Side {
            positions: &positions[..3],
            triangles: &triangles[..1],
            used: &used[..3],
        };
        let mut rng = Pcg64::from_seed(0);
        let a = draw_samples(&side, 4, &mut rng);
        let b = draw_samples(&first, 2, &mut rng);
        let expected_a = [
            (0, DVec3::new(0.14342582298969125, 0.6354424430008931, 0.0)),
            (0, DVec3::new(0.851766739691968, 0.00233896862755748, 0.0)),
            (
                1,
                DVec3::new(11.234697443195877, 0.49024915509360434, 0.24512457754680217),
            ),
            (
                1,
                DVec3::new(10.186091995559527, 0.8933517594360716, 0.4466758797180358),
            ),
        ];
        let expected_b = [
            (0, DVec3::new(0.11687238885157603, 0.7373263271565575, 0.0)),
            (0, DVec3::new(0.19217951646169612, 0.22693338074209912, 0.0)),
        ];
        for (got, want) in a.iter().zip(&expected_a).chain(b.iter().zip(&expected_b)) {
            assert_eq!(got.0, want.0);
            assert!(
                (got.1 - want.1).length() <= 1e-14 * want.1.length(),
                "{got:?} {want:?}"
            );
        }
    }

    #[test]
    fn area_sampling_follows_area() {
        // Two triangles; the second has 3·√1.25 times the area of the first.
        let (positions, triangles) = two_triangles();
        let used = [true; 6];
        let side = Side {
            positions: &positions,
            triangles: &triangles,
            used: &used,
        };
        let samples = draw_samples(&side, 40_000, &mut Pcg64::from_seed(3));
        let share = samples.iter().filter(|s| s.0 == 1).count() as f64 / 40_000.0;
        let expected = 3.0 * 1.25f64.sqrt() / (1.0 + 3.0 * 1.25f64.sqrt());
        assert!((share - expected).abs() < 0.01, "{share} vs {expected}");
        assert!(samples.windows(2).all(|w| w[0].0 <= w[1].0));
    }

    #[test]
    fn no_area_no_samples() {
        let positions = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        let side = Side {
            positions: &positions,
            triangles: &[[0, 1, 2]],
            used: &[true; 3],
        };
        assert!(draw_samples(&side, 10, &mut Pcg64::from_seed(0)).is_empty());
    }
}
