//! How well an output mesh keeps a set of input edges: distances from
//! points sampled along one edge set to the nearest segment of another, the
//! `features` / `boundary` metric of `bench/quality.py`.

use glam::DVec3;
use rayon::prelude::*;

use crate::bvh::{lerp_exact, SegmentIndex};
use crate::features::{boundary_edges, mesh_edges, sharp_edges};
use crate::trimesh::TriMesh;

/// Distances from points sampled along one edge set to the nearest segment
/// of another, in absolute units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolylineDistance {
    /// Largest sample distance.
    pub max: f64,
    /// Mean sample distance.
    pub mean: f64,
    /// Number of samples.
    pub samples: usize,
}

/// Samples every edge of (`from_points`, `from_edges`) at both end points and
/// every ≤ `step` in between (the bench's `sample_polyline`), and measures
/// each sample's exact distance to the nearest segment of (`to_points`,
/// `to_edges`). This is the bench's `features` metric (with the input's
/// [`sharp_edges`] against the output's [`mesh_edges`], `step` = L/4) and its
/// `boundary` metric (with [`boundary_edges`] on both sides), before dividing
/// by L.
///
/// Returns `None` when `from_edges` is empty; `max` and `mean` are infinite
/// when `to_edges` is empty. Edges with out-of-range indices are skipped. A
/// non-positive or non-finite `step` samples the end points only.
pub fn polyline_distance(
    from_points: &[DVec3],
    from_edges: &[[u32; 2]],
    step: f64,
    to_points: &[DVec3],
    to_edges: &[[u32; 2]],
) -> Option<PolylineDistance> {
    let samples = edge_samples(from_points, from_edges, step);
    if samples.is_empty() {
        return None;
    }
    let d = point_edge_distances(&samples, to_points, to_edges);
    Some(PolylineDistance {
        max: d.iter().copied().fold(0.0, f64::max),
        mean: d.iter().sum::<f64>() / d.len() as f64,
        samples: d.len(),
    })
}

/// Points along every edge of (`points`, `edges`): both end points and
/// every ≤ `step` in between, as [`polyline_distance`] samples them. Edges
/// with out-of-range indices are skipped; a non-positive or non-finite
/// `step` gives the end points only.
pub fn edge_samples(points: &[DVec3], edges: &[[u32; 2]], step: f64) -> Vec<DVec3> {
    let mut out = Vec::new();
    for &[a, b] in edges {
        let (Some(&pa), Some(&pb)) = (points.get(a as usize), points.get(b as usize)) else {
            continue;
        };
        let len = (pb - pa).length();
        let k = if step > 0.0 && step.is_finite() && len.is_finite() {
            (len / step).ceil().clamp(1.0, u32::MAX as f64) as u64
        } else {
            1
        };
        out.extend((0..=k).map(|j| lerp_exact(pa, pb, j as f64 / k as f64)));
    }
    out
}

/// The exact distance of every query point to the nearest edge of
/// (`to_points`, `to_edges`), in query order; infinite when there is no
/// edge. Edges with out-of-range indices are skipped.
pub fn point_edge_distances(
    queries: &[DVec3],
    to_points: &[DVec3],
    to_edges: &[[u32; 2]],
) -> Vec<f64> {
    let to: Vec<[u32; 2]> = to_edges
        .iter()
        .filter(|e| e.iter().all(|&v| (v as usize) < to_points.len()))
        .copied()
        .collect();
    if to.is_empty() {
        return vec![f64::INFINITY; queries.len()];
    }
    let tree = SegmentIndex::new(to.len(), |s| to[s].map(|v| to_points[v as usize]));
    queries
        .par_iter()
        .map(|&q| {
            tree.closest(q)
                .map_or(f64::INFINITY, |c| c.distance_squared.sqrt())
        })
        .collect()
}

/// The bench's `features` metric before dividing by L: distances from the
/// `input`'s [`sharp_edges`] at `angle_deg`, sampled every ≤ `step` (the bench
/// uses L/4), to the nearest edge of `output`. `None` when the input has no
/// sharp edge.
pub fn sharp_edge_distance(
    input: &TriMesh,
    output: &TriMesh,
    angle_deg: f64,
    step: f64,
) -> Option<PolylineDistance> {
    polyline_distance(
        &input.positions,
        &sharp_edges(input, angle_deg),
        step,
        &output.positions,
        &mesh_edges(output),
    )
}

/// [`sharp_edge_distance`] with the input's sharp edges already found.
pub fn sharp_edge_distance_of(
    input: &TriMesh,
    sharp: &[[u32; 2]],
    output: &TriMesh,
    step: f64,
) -> Option<PolylineDistance> {
    polyline_distance(
        &input.positions,
        sharp,
        step,
        &output.positions,
        &mesh_edges(output),
    )
}

/// The bench's `boundary` metric before dividing by L: distances from the
/// `input`'s boundary edges, sampled every ≤ `step`, to the nearest boundary
/// edge of `output`. `None` when the input is closed.
pub fn boundary_distance(input: &TriMesh, output: &TriMesh, step: f64) -> Option<PolylineDistance> {
    polyline_distance(
        &input.positions,
        &boundary_edges(input),
        step,
        &output.positions,
        &boundary_edges(output),
    )
}
