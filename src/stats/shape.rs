//! Per-vertex and per-face shape figures: valence against the ideal (6
//! inside, 4 on the boundary), interior angles and triangle quality
//! q = 4√3·area/(a²+b²+c²), with the definitions of the bench's
//! `quality.py` (`element_quality`).

use std::collections::BTreeMap;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::chunked;
use super::histogram::{bin, Histogram, Unit};
use crate::geometry::{triangle_angles, triangle_area, triangle_quality};

/// Angle histogram: 36 bins of 5° over [0°, 180°].
const ANGLE_BINS: usize = 36;
/// Width of an angle bin, degrees.
const ANGLE_BIN_WIDTH: f64 = 5.0;

/// Vertex valence statistics over the vertices used by some face.
/// Valence is the number of distinct edges at a vertex; a boundary vertex is
/// an endpoint of an edge with exactly one face. Ideal valence is 6 inside
/// and 4 on the boundary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValenceStats {
    /// Valence → number of used vertices with that valence.
    pub histogram: BTreeMap<u32, u64>,
    /// Valence → number of interior vertices with that valence.
    pub interior_histogram: BTreeMap<u32, u64>,
    /// Valence → number of boundary vertices with that valence.
    pub boundary_histogram: BTreeMap<u32, u64>,
    /// Number of interior (non-boundary) used vertices.
    pub interior_vertices: u64,
    /// Number of boundary vertices.
    pub boundary_vertices: u64,
    /// Fraction of interior vertices with valence 6 (null without interior vertices).
    pub regular_fraction: Option<f64>,
    /// Mean |valence − 6| over interior vertices (null without interior vertices).
    pub interior_mean_abs_deviation: Option<f64>,
    /// Mean |valence − 4| over boundary vertices (null without boundary vertices).
    pub boundary_mean_abs_deviation: Option<f64>,
    /// Mean deviation from the ideal valence (6 inside, 4 on the boundary)
    /// over all used vertices (null without vertices).
    pub mean_abs_deviation: Option<f64>,
}

/// Interior angle statistics (law-of-cosines angles, degrees).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AngleStats {
    /// Smallest angle of any triangle.
    pub min_deg: f64,
    /// Largest angle of any triangle.
    pub max_deg: f64,
    /// Mean over triangles of the triangle's smallest angle.
    pub mean_min_deg: f64,
    /// Fraction of triangles whose smallest angle is below 30°.
    pub below_30_fraction: f64,
    /// Histogram of all three angles of every triangle: 36 bins of 5° over
    /// [0°, 180°] (180° itself falls in the last bin).
    pub histogram: Histogram,
}

/// Triangle shape quality q = 4√3·area/(a²+b²+c²): 1 equilateral, 0 degenerate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TriangleQualityStats {
    /// Worst triangle.
    pub min: f64,
    /// Mean over triangles.
    pub mean: f64,
}

/// Per-face figures of one chunk, merged in chunk order.
#[derive(Clone, Copy)]
struct FaceAcc {
    min_angle: f64,
    max_angle: f64,
    sum_min_angle: f64,
    below_30: u64,
    q_min: f64,
    q_sum: f64,
    degenerate: u64,
    hist: [u64; ANGLE_BINS],
}

impl FaceAcc {
    fn new() -> Self {
        Self {
            min_angle: f64::INFINITY,
            max_angle: f64::NEG_INFINITY,
            sum_min_angle: 0.0,
            below_30: 0,
            q_min: f64::INFINITY,
            q_sum: 0.0,
            degenerate: 0,
            hist: [0; ANGLE_BINS],
        }
    }

    fn merge(mut self, o: &Self) -> Self {
        self.min_angle = self.min_angle.min(o.min_angle);
        self.max_angle = self.max_angle.max(o.max_angle);
        self.sum_min_angle += o.sum_min_angle;
        self.below_30 += o.below_30;
        self.q_min = self.q_min.min(o.q_min);
        self.q_sum += o.q_sum;
        self.degenerate += o.degenerate;
        for (a, b) in self.hist.iter_mut().zip(&o.hist) {
            *a += b;
        }
        self
    }
}

/// Valence figures of the used vertices.
pub(super) fn valence_stats(valence: &[u32], used: &[bool], boundary: &[bool]) -> ValenceStats {
    let mut histogram = BTreeMap::new();
    let mut interior_histogram = BTreeMap::new();
    let mut boundary_histogram = BTreeMap::new();
    let (mut ni, mut nb, mut regular) = (0u64, 0u64, 0u64);
    let (mut dev_i, mut dev_b) = (0u64, 0u64);
    for v in 0..valence.len() {
        if !used[v] {
            continue;
        }
        let val = valence[v];
        *histogram.entry(val).or_insert(0) += 1;
        if boundary[v] {
            nb += 1;
            dev_b += val.abs_diff(4) as u64;
            *boundary_histogram.entry(val).or_insert(0) += 1;
        } else {
            ni += 1;
            dev_i += val.abs_diff(6) as u64;
            regular += (val == 6) as u64;
            *interior_histogram.entry(val).or_insert(0) += 1;
        }
    }
    let frac = |num: u64, den: u64| (den > 0).then(|| num as f64 / den as f64);
    ValenceStats {
        histogram,
        interior_histogram,
        boundary_histogram,
        interior_vertices: ni,
        boundary_vertices: nb,
        regular_fraction: frac(regular, ni),
        interior_mean_abs_deviation: frac(dev_i, ni),
        boundary_mean_abs_deviation: frac(dev_b, nb),
        mean_abs_deviation: frac(dev_i + dev_b, ni + nb),
    }
}

/// Angle and quality figures of `tris`, and how many faces have an area
/// below `degenerate_area`.
pub(super) fn face_stats(
    pos: &[DVec3],
    tris: &[[u32; 3]],
    degenerate_area: f64,
) -> (Option<AngleStats>, Option<TriangleQualityStats>, u64) {
    let nf = tris.len();
    let faces = chunked(
        nf,
        FaceAcc::new(),
        |range| {
            let mut acc = FaceAcc::new();
            for t in &tris[range] {
                let p = [pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]];
                let angles = triangle_angles(p).map(f64::to_degrees);
                let min = angles[0].min(angles[1]).min(angles[2]);
                let max = angles[0].max(angles[1]).max(angles[2]);
                acc.min_angle = acc.min_angle.min(min);
                acc.max_angle = acc.max_angle.max(max);
                acc.sum_min_angle += min;
                acc.below_30 += (min < 30.0) as u64;
                for a in angles {
                    acc.hist[bin(a / ANGLE_BIN_WIDTH, ANGLE_BINS)] += 1;
                }
                let q = triangle_quality(p);
                acc.q_min = acc.q_min.min(q);
                acc.q_sum += q;
                acc.degenerate += (triangle_area(p) < degenerate_area) as u64;
            }
            acc
        },
        FaceAcc::merge,
    );
    if nf == 0 {
        return (None, None, 0);
    }
    (
        Some(AngleStats {
            min_deg: faces.min_angle,
            max_deg: faces.max_angle,
            mean_min_deg: faces.sum_min_angle / nf as f64,
            below_30_fraction: faces.below_30 as f64 / nf as f64,
            histogram: Histogram::new(
                Unit::Degrees,
                None,
                ANGLE_BIN_WIDTH,
                false,
                faces.hist.to_vec(),
            ),
        }),
        Some(TriangleQualityStats {
            min: faces.q_min,
            mean: faces.q_sum / nf as f64,
        }),
        faces.degenerate,
    )
}
