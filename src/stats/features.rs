//! The `features` section of the statistics: the sharp features of a mesh as
//! the remesher detects them and, given a reference, how closely they follow
//! the reference's features (the bench's crease distance, kept corners, and
//! whether every feature edge lies on a reference feature line and every
//! reference feature line is followed by feature edges).

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::polyline;
use crate::bvh::PointIndex;
use crate::features::{detect_features, EdgeFlags, FeatureOptions, FeatureSet};
use crate::trimesh::TriMesh;

/// A reference corner is kept when a vertex of the mesh lies within this
/// many target lengths L of it. Relative to L and far above the rounding of
/// f32 coordinates, so a result gives the same counts written in any format
/// (`docs/tuning.md`).
pub const CORNER_TOLERANCE: f64 = 1e-3;

/// A point lies on a feature line when it is within this many target
/// lengths of one of the line's edges (see [`CORNER_TOLERANCE`]).
pub const ON_LINE_TOLERANCE: f64 = 1e-3;

/// The features of one mesh and, against a reference, their fidelity.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureStats {
    /// Dihedral angle above which an interior edge is a crease, degrees.
    pub feature_angle_deg: f64,
    /// Feature edges: creases, boundary edges, edges between faces with
    /// different labels and edges with more than two faces.
    pub edges: u64,
    /// Creases alone: two-face edges whose dihedral angle exceeds the
    /// feature angle (the bench's sharp edges; 0 with creases switched off).
    pub sharp_edges: u64,
    /// Corners: feature vertices with other than two feature edges, or where
    /// the feature line turns sharply.
    pub corners: u64,
    /// Feature lines: polylines from corner to corner, or closed loops.
    pub lines: u64,
    /// How the features follow the reference's (present only with a reference).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fidelity: Option<FeatureFidelity>,
}

/// How the features of a mesh follow those of its reference (the job's input).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureFidelity {
    /// The target length L the figures below are divided by.
    pub target: f64,
    /// The bench's crease distance: points every ≤ L/4 along the
    /// reference's sharp edges, each one's distance to the nearest edge of
    /// the mesh, largest over L (null when the reference has no sharp edge).
    pub sharp_distance_max_over_l: Option<f64>,
    /// The mean of the same distances over L (null without sharp edges).
    pub sharp_distance_mean_over_l: Option<f64>,
    /// Corners of the reference.
    pub reference_corners: u64,
    /// Reference corners with a vertex of the mesh within `corner_tolerance`.
    pub corners_kept: u64,
    /// The distance within which a vertex keeps a corner:
    /// [`CORNER_TOLERANCE`]·L, absolute.
    pub corner_tolerance: f64,
    /// The distance within which a point counts as lying on a feature line:
    /// [`ON_LINE_TOLERANCE`]·L, absolute.
    pub on_line_tolerance: f64,
    /// Feature edges of the mesh whose two end points and midpoint all lie
    /// on a feature edge of the reference: the edges that follow a
    /// reference feature line instead of cutting across a face.
    pub edges_on_reference_lines: u64,
    /// `edges_on_reference_lines` over the mesh's feature edges (null when
    /// the mesh has none).
    pub edges_on_reference_lines_fraction: Option<f64>,
    /// Largest distance of an end point or midpoint of a feature edge of the
    /// mesh to the reference's feature edges, over L (null when the mesh has
    /// no feature edge).
    pub max_offset_over_l: Option<f64>,
    /// Points every ≤ L/4 along the reference's feature edges.
    pub reference_samples: u64,
    /// Of those, the points farther than the on-line tolerance from every
    /// feature edge of the mesh: where a reference feature runs through
    /// the mesh's faces rather than along its feature edges.
    pub uncovered_samples: u64,
}

/// The `features` section of `mesh` (detected with `opts`, unless `own`
/// gives them already), with its fidelity to `reference` at target length
/// `target` when both are given. The reference comes with its features
/// for `opts` when they are already detected.
pub fn feature_stats(
    mesh: &TriMesh,
    opts: &FeatureOptions,
    own: Option<&FeatureSet>,
    reference: Option<(&TriMesh, Option<&FeatureSet>)>,
    target: Option<f64>,
) -> FeatureStats {
    let detected;
    let fs = match own {
        Some(fs) => fs,
        None => {
            detected = detect_features(mesh, opts);
            &detected
        }
    };
    let fidelity = match (reference, target) {
        (Some((r, rfs)), Some(l)) if l > 0.0 && l.is_finite() && !r.triangles.is_empty() => {
            Some(fidelity(mesh, fs, r, rfs, opts, l))
        }
        _ => None,
    };
    FeatureStats {
        feature_angle_deg: opts.feature_angle_deg,
        edges: fs.edges().len() as u64,
        sharp_edges: fs.count_edges_with(EdgeFlags::SHARP) as u64,
        corners: fs.corners().len() as u64,
        lines: fs.lines().len() as u64,
        fidelity,
    }
}

fn fidelity(
    mesh: &TriMesh,
    fs: &FeatureSet,
    reference: &TriMesh,
    reference_features: Option<&FeatureSet>,
    opts: &FeatureOptions,
    l: f64,
) -> FeatureFidelity {
    let detected;
    let rfs = match reference_features {
        Some(rfs) => rfs,
        None => {
            detected = detect_features(reference, opts);
            &detected
        }
    };
    let step = l / 4.0;
    // The reference's sharp edges are its feature set's when that set was
    // detected with sharp edges on, at a finite angle and unfiltered (the
    // same classification); otherwise they are classified on their own.
    let sharp = if opts.preserve_features
        && opts.feature_angle_deg.is_finite()
        && opts.min_crease_length <= 0.0
    {
        polyline::sharp_edge_distance_of(reference, &rfs.edges_with(EdgeFlags::SHARP), mesh, step)
    } else {
        polyline::sharp_edge_distance(reference, mesh, opts.feature_angle_deg, step)
    };
    let tol = ON_LINE_TOLERANCE * l;

    // Feature edges of the mesh: end points and midpoints against the
    // reference's feature edges.
    let pos = &mesh.positions;
    let queries: Vec<DVec3> = fs
        .edges()
        .iter()
        .flat_map(|&[a, b]| {
            let (pa, pb) = (pos[a as usize], pos[b as usize]);
            [pa, pb, 0.5 * (pa + pb)]
        })
        .collect();
    let offsets = polyline::point_edge_distances(&queries, &reference.positions, rfs.edges());
    let on_line = offsets
        .chunks(3)
        .filter(|d| d.iter().all(|&x| x <= tol))
        .count() as u64;
    let max_offset = offsets
        .iter()
        .copied()
        .fold(None, |m: Option<f64>, d| Some(m.map_or(d, |m| m.max(d))));

    // The reference's feature lines, sampled, against the mesh's feature edges.
    let samples = polyline::edge_samples(&reference.positions, rfs.edges(), step);
    let uncovered = polyline::point_edge_distances(&samples, pos, fs.edges())
        .iter()
        .filter(|&&d| d.is_nan() || d > tol)
        .count() as u64;

    let corner_tol = CORNER_TOLERANCE * l;
    // The index holds the few reference corners and every mesh vertex asks
    // it: cheaper than indexing all vertices for a handful of questions.
    let corner_points: Vec<DVec3> = rfs
        .corners()
        .iter()
        .map(|&c| reference.positions[c as usize])
        .collect();
    let corners = PointIndex::new(&corner_points);
    let mut kept = vec![false; corner_points.len()];
    for &v in pos {
        corners.for_each_within(v, corner_tol, |c| kept[c as usize] = true);
    }
    let corners_kept = kept.iter().filter(|&&k| k).count() as u64;

    let n = fs.edges().len();
    FeatureFidelity {
        target: l,
        sharp_distance_max_over_l: sharp.map(|d| d.max / l),
        sharp_distance_mean_over_l: sharp.map(|d| d.mean / l),
        reference_corners: rfs.corners().len() as u64,
        corners_kept,
        corner_tolerance: corner_tol,
        on_line_tolerance: tol,
        edges_on_reference_lines: on_line,
        edges_on_reference_lines_fraction: (n > 0).then(|| on_line as f64 / n as f64),
        max_offset_over_l: max_offset.map(|d| d / l),
        reference_samples: samples.len() as u64,
        uncovered_samples: uncovered,
    }
}
