//! Quality statistics of a triangle mesh, reported for the input and the
//! output of every job: counts and topology, edge lengths against the target
//! length, valence, angles, triangle shape quality and, given a reference,
//! the two-sided distance to it.
//!
//! Every figure follows the definition of the benchmark script
//! `bench/quality.py` (and the mesh it sees is the welded mesh of its
//! `meshload.py`), so the numbers the service reports are the numbers the
//! benchmark measures: the edge band [4/5·L, 4/3·L] is the split/collapse
//! band of Botsch & Kobbelt (2004); triangle quality is
//! q = 4√3·area/(a²+b²+c²); distances are sampled as in Metro (Cignoni,
//! Rocchini & Scopigno 1998) with exact point-to-mesh distances; the
//! `features` section follows the bench's `features` metric.

mod distance;
mod features;
mod rng;
mod topology;

pub use features::{FeatureFidelity, FeatureStats, CORNER_TOLERANCE, ON_LINE_TOLERANCE};

use std::collections::BTreeMap;
use std::fmt::Write as _;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::bvh::SurfaceIndex;
use crate::geometry::{triangle_angles, triangle_area, triangle_quality};
use crate::mesh::RepairReport;
use crate::trimesh::TriMesh;

use topology::{count_sets, EdgeTable, UnionFind};

/// Number of edge-length histogram bins below 2·L, each 0.1·L wide; one
/// overflow bin follows.
const EDGE_BINS: usize = 20;
/// Width of an edge-length bin in units of the target length.
const EDGE_BIN_WIDTH: f64 = 0.1;
/// Angle histogram: 36 bins of 5° over [0°, 180°].
const ANGLE_BINS: usize = 36;
const ANGLE_BIN_WIDTH: f64 = 5.0;
/// Faces per parallel task in the per-face and per-edge loops.
const CHUNK: usize = 16 * 1024;

/// Inputs of [`compute`] besides the mesh.
#[derive(Clone, Copy, Debug)]
pub struct StatsOptions<'a> {
    /// Target edge length L for the band and histogram; default (and when
    /// not finite and positive): the per-vertex targets' mean if given,
    /// otherwise the mean edge length.
    pub target_edge_length: Option<f64>,
    /// Surface to measure the distance to (the job's input, for its output).
    pub reference: Option<&'a TriMesh>,
    /// A prebuilt index of `reference`, reused instead of building one.
    pub reference_index: Option<&'a SurfaceIndex>,
    /// Area-uniform samples per side for the distance (vertices are added);
    /// default 200,000, as `quality.py`.
    pub samples_per_side: usize,
    /// Seed of the sample stream (NumPy's `default_rng(seed)`); default 0,
    /// as `quality.py`'s `--seed`.
    pub sample_seed: u64,
    /// What the mesh builder repaired, copied into the statistics.
    pub repairs: Option<RepairReport>,
    /// Per-vertex target edge length (adaptive sizing), one per position;
    /// ignored when its length differs from the vertex count.
    pub vertex_target: Option<&'a [f64]>,
    /// Detect features with these options and report the `features`
    /// section (with its fidelity to `reference`, if given).
    pub features: Option<crate::features::FeatureOptions>,
}

impl Default for StatsOptions<'_> {
    fn default() -> Self {
        Self {
            target_edge_length: None,
            reference: None,
            reference_index: None,
            samples_per_side: 200_000,
            sample_seed: distance::DEFAULT_SEED,
            repairs: None,
            vertex_target: None,
            features: None,
        }
    }
}

/// A histogram with equal-width bins starting at 0.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Histogram {
    /// Width of every bin, in the unit of the histogram (see the field that holds it).
    pub bin_width: f64,
    /// Count per bin; bin k holds values in [k·bin_width, (k+1)·bin_width).
    pub counts: Vec<u64>,
}

/// Edge lengths relative to the per-vertex target size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RelativeEdgeLengths {
    /// Histogram of length / local target, where the local target of an
    /// edge is the mean of its endpoints' targets: 20 bins of 0.1 over
    /// [0, 2) and a last bin for ratios ≥ 2.
    pub histogram: Histogram,
    /// Fraction of edges whose ratio lies in [4/5, 4/3] (inclusive).
    pub within_band: f64,
}

/// Edge-length statistics over the unique undirected edges.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EdgeLengthStats {
    /// Shortest edge.
    pub min: f64,
    /// Longest edge.
    pub max: f64,
    /// Mean edge length.
    pub mean: f64,
    /// Population standard deviation of the edge lengths.
    pub std: f64,
    /// The target length L the band and histogram use: the explicit target
    /// if given, otherwise the mean per-vertex target if given, otherwise
    /// the mean edge length.
    pub target: f64,
    /// Smallest per-vertex target (present only with per-vertex targets).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_min: Option<f64>,
    /// Largest per-vertex target (present only with per-vertex targets).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_max: Option<f64>,
    /// Fraction of edges with length in [4/5·L, 4/3·L] (inclusive), the
    /// band that split and collapse leave alone.
    pub within_band: f64,
    /// Histogram of length / L: 20 bins of width 0.1 (in units of L) over
    /// [0, 2·L), then one overflow bin for lengths ≥ 2·L (21 counts).
    pub histogram: Histogram,
    /// The same band and histogram against the per-vertex targets (present
    /// only when per-vertex targets are given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relative_to_size: Option<RelativeEdgeLengths>,
}

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

/// Quality statistics of one mesh. Faces with an out-of-range vertex index
/// are left out of every figure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshStats {
    /// Number of vertex positions.
    pub vertices: u64,
    /// Number of faces (with valid indices).
    pub faces: u64,
    /// Number of unique undirected edges.
    pub edges: u64,
    /// Edges with exactly one face.
    pub boundary_edges: u64,
    /// Connected components of the graph of boundary edges.
    pub boundary_loops: u64,
    /// Connected components of faces, where faces sharing a vertex connect.
    pub components: u64,
    /// V − E + F.
    pub euler_characteristic: i64,
    /// Edge-manifold: no edge has more than two faces (vertex fans are not checked).
    pub manifold: bool,
    /// Manifold and, on every two-face edge, the two faces traverse the edge
    /// in opposite directions.
    pub consistently_oriented: bool,
    /// Edges with more than two faces.
    pub non_manifold_edges: u64,
    /// Faces with area below 1e-12·d², d the bounding-box diagonal of the
    /// reference if given, otherwise of the mesh.
    pub degenerate_faces: u64,
    /// Edge lengths (null for a mesh without edges).
    pub edge_length: Option<EdgeLengthStats>,
    /// Valences.
    pub valence: ValenceStats,
    /// Angles (null for a mesh without faces).
    pub angles: Option<AngleStats>,
    /// Shape quality (null for a mesh without faces).
    pub triangle_quality: Option<TriangleQualityStats>,
    /// Distance to the reference (present only when a reference with faces was given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance: Option<DistanceStats>,
    /// What the builder repaired (present only when given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub repairs: Option<RepairReport>,
    /// Sharp features and their fidelity to the reference (present only
    /// when feature options were given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub features: Option<FeatureStats>,
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

/// Per-edge figures of one chunk.
#[derive(Clone, Copy)]
struct EdgeAcc {
    min: f64,
    max: f64,
    /// Sum of squared deviations from the mean.
    dev2: f64,
    in_band: u64,
    hist: [u64; EDGE_BINS + 1],
    rel_in_band: u64,
    rel_hist: [u64; EDGE_BINS + 1],
}

impl EdgeAcc {
    fn new() -> Self {
        Self {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            dev2: 0.0,
            in_band: 0,
            hist: [0; EDGE_BINS + 1],
            rel_in_band: 0,
            rel_hist: [0; EDGE_BINS + 1],
        }
    }

    fn merge(mut self, o: &Self) -> Self {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
        self.dev2 += o.dev2;
        self.in_band += o.in_band;
        self.rel_in_band += o.rel_in_band;
        for (a, b) in self.hist.iter_mut().zip(&o.hist) {
            *a += b;
        }
        for (a, b) in self.rel_hist.iter_mut().zip(&o.rel_hist) {
            *a += b;
        }
        self
    }
}

/// Bin of `x` (in units of the bin width) among `n` bins, the last one
/// taking everything above; NaN lands in bin 0.
#[inline]
fn bin(x: f64, n: usize) -> usize {
    // `as usize` saturates: negative and NaN give 0.
    (x.floor() as usize).min(n - 1)
}

/// Length ratio inside the Botsch–Kobbelt band, with quality.py's bounds.
#[inline]
fn in_band(len: f64, l: f64) -> bool {
    len >= 0.8 * l && len <= 4.0 / 3.0 * l
}

/// Runs `f` over `CHUNK`-sized index ranges of `0..n` in parallel and
/// merges the results in range order, so float sums are reproducible.
fn chunked<A: Send + Clone>(
    n: usize,
    init: A,
    f: impl Fn(std::ops::Range<usize>) -> A + Sync,
    merge: impl Fn(A, &A) -> A,
) -> A {
    let parts: Vec<A> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| f(c * CHUNK..((c + 1) * CHUNK).min(n)))
        .collect();
    parts.iter().fold(init, merge)
}

/// Computes the statistics of `mesh` (see [`MeshStats`] for the
/// definitions). Like the benchmark, it describes the welded mesh
/// ([`TriMesh::welded`]): coincident vertices count once, and repeated or
/// index-degenerate faces are left out; the reference is welded the same
/// way, so distance samples fall where `quality.py` puts them.
pub fn compute(mesh: &TriMesh, opts: &StatsOptions) -> MeshStats {
    let (welded, origin) = mesh.welded();
    let targets: Option<Vec<f64>> = opts
        .vertex_target
        .filter(|t| t.len() == mesh.positions.len())
        .map(|t| origin.iter().map(|&i| t[i as usize]).collect());
    let reference = opts.reference.map(|r| r.welded().0);
    compute_welded(
        &welded,
        &StatsOptions {
            reference: reference.as_ref(),
            vertex_target: targets.as_deref(),
            ..*opts
        },
    )
}

/// [`compute`] on a mesh that is already welded.
fn compute_welded(mesh: &TriMesh, opts: &StatsOptions) -> MeshStats {
    let pos = &mesh.positions;
    let nv = pos.len();
    let valid: Vec<[u32; 3]>;
    let tris: &[[u32; 3]] = if mesh
        .triangles
        .iter()
        .all(|t| t.iter().all(|&v| (v as usize) < nv))
    {
        &mesh.triangles
    } else {
        valid = mesh
            .triangles
            .iter()
            .copied()
            .filter(|t| t.iter().all(|&v| (v as usize) < nv))
            .collect();
        &valid
    };
    let nf = tris.len();

    // --- topology -------------------------------------------------------
    let table = EdgeTable::new(tris, nv);
    let edges = &table.edges;
    let mut valence = vec![0u32; nv];
    let mut boundary = vec![false; nv];
    let mut used = vec![false; nv];
    let mut loops = UnionFind::new(nv);
    let mut boundary_edges = 0u64;
    for e in edges {
        valence[e.a as usize] += 1;
        valence[e.b as usize] += 1;
        if e.faces == 1 {
            boundary_edges += 1;
            boundary[e.a as usize] = true;
            boundary[e.b as usize] = true;
            loops.union(e.a, e.b);
        }
    }
    let boundary_loops = count_sets(&mut loops, &boundary) as u64;
    drop(loops);
    let mut comps = UnionFind::new(nv);
    for t in tris {
        used[t[0] as usize] = true;
        used[t[1] as usize] = true;
        used[t[2] as usize] = true;
        comps.union(t[0], t[1]);
        comps.union(t[0], t[2]);
    }
    let components = count_sets(&mut comps, &used) as u64;
    drop(comps);
    let manifold = table.non_manifold_edges == 0;

    // --- valence ----------------------------------------------------------
    let valence_stats = valence_stats(&valence, &used, &boundary);

    // --- per face ----------------------------------------------------------
    let diag = opts
        .reference
        .map_or_else(|| mesh.bbox_diagonal(), |r| r.bbox_diagonal());
    let degenerate_area = 1e-12 * diag * diag;
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
    let (angles, triangle_quality) = if nf > 0 {
        (
            Some(AngleStats {
                min_deg: faces.min_angle,
                max_deg: faces.max_angle,
                mean_min_deg: faces.sum_min_angle / nf as f64,
                below_30_fraction: faces.below_30 as f64 / nf as f64,
                histogram: Histogram {
                    bin_width: ANGLE_BIN_WIDTH,
                    counts: faces.hist.to_vec(),
                },
            }),
            Some(TriangleQualityStats {
                min: faces.q_min,
                mean: faces.q_sum / nf as f64,
            }),
        )
    } else {
        (None, None)
    };

    // --- edge lengths ---------------------------------------------------------
    let edge_length = edge_length_stats(mesh, edges, opts);

    // --- distance ---------------------------------------------------------------
    let distance = opts
        .reference
        .and_then(|r| distance_stats(mesh, tris, &used, r, opts));

    // --- features ---------------------------------------------------------------
    let features = opts.features.map(|fo| {
        features::feature_stats(
            mesh,
            &fo,
            opts.reference,
            edge_length.as_ref().map(|e| e.target),
        )
    });

    MeshStats {
        vertices: nv as u64,
        faces: nf as u64,
        edges: edges.len() as u64,
        boundary_edges,
        boundary_loops,
        components,
        euler_characteristic: nv as i64 - edges.len() as i64 + nf as i64,
        manifold,
        consistently_oriented: manifold && !table.misoriented,
        non_manifold_edges: table.non_manifold_edges as u64,
        degenerate_faces: faces.degenerate,
        edge_length,
        valence: valence_stats,
        angles,
        triangle_quality,
        distance,
        repairs: opts.repairs,
        features,
    }
}

fn valence_stats(valence: &[u32], used: &[bool], boundary: &[bool]) -> ValenceStats {
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

fn edge_length_stats(
    mesh: &TriMesh,
    edges: &[topology::Edge],
    opts: &StatsOptions,
) -> Option<EdgeLengthStats> {
    if edges.is_empty() {
        return None;
    }
    let pos = &mesh.positions;
    let len = |e: &topology::Edge| (pos[e.a as usize] - pos[e.b as usize]).length();
    let n = edges.len() as f64;
    let targets = opts.vertex_target.filter(|t| t.len() == pos.len());
    let mean = chunked(
        edges.len(),
        0.0,
        |r| edges[r].iter().map(len).sum::<f64>(),
        |a, b| a + b,
    ) / n;
    let l = opts
        .target_edge_length
        .filter(|l| l.is_finite() && *l > 0.0)
        .or_else(|| targets.map(|t| t.iter().sum::<f64>() / t.len() as f64))
        .unwrap_or(mean);

    let acc = chunked(
        edges.len(),
        EdgeAcc::new(),
        |r| {
            let mut acc = EdgeAcc::new();
            for e in &edges[r] {
                let d = len(e);
                acc.min = acc.min.min(d);
                acc.max = acc.max.max(d);
                acc.dev2 += (d - mean) * (d - mean);
                acc.in_band += in_band(d, l) as u64;
                acc.hist[bin(d / l / EDGE_BIN_WIDTH, EDGE_BINS + 1)] += 1;
                if let Some(t) = targets {
                    let local = 0.5 * (t[e.a as usize] + t[e.b as usize]);
                    acc.rel_in_band += in_band(d, local) as u64;
                    acc.rel_hist[bin(d / local / EDGE_BIN_WIDTH, EDGE_BINS + 1)] += 1;
                }
            }
            acc
        },
        EdgeAcc::merge,
    );
    let (target_min, target_max) = match targets {
        Some(t) => (
            Some(t.iter().copied().fold(f64::INFINITY, f64::min)),
            Some(t.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
        ),
        None => (None, None),
    };
    Some(EdgeLengthStats {
        min: acc.min,
        max: acc.max,
        mean,
        std: (acc.dev2 / n).sqrt(),
        target: l,
        target_min,
        target_max,
        within_band: acc.in_band as f64 / n,
        histogram: Histogram {
            bin_width: EDGE_BIN_WIDTH,
            counts: acc.hist.to_vec(),
        },
        relative_to_size: targets.map(|_| RelativeEdgeLengths {
            histogram: Histogram {
                bin_width: EDGE_BIN_WIDTH,
                counts: acc.rel_hist.to_vec(),
            },
            within_band: acc.rel_in_band as f64 / n,
        }),
    })
}

fn distance_stats(
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
    let (to_ref, from_ref) = distance::two_sided(
        &distance::Side {
            positions: &mesh.positions,
            triangles: tris,
            used,
        },
        &mesh_index,
        &distance::Side {
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

impl MeshStats {
    /// A readable multi-line summary for the command line.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let opt = |x: Option<f64>, digits: usize| match x {
            Some(v) => format!("{v:.digits$}"),
            None => "-".to_string(),
        };
        let _ = writeln!(
            s,
            "mesh      {} vertices, {} faces, {} edges; Euler characteristic {}, {} component{}, {} boundary loop{}",
            self.vertices,
            self.faces,
            self.edges,
            self.euler_characteristic,
            self.components,
            if self.components == 1 { "" } else { "s" },
            self.boundary_loops,
            if self.boundary_loops == 1 { "" } else { "s" },
        );
        let _ = writeln!(
            s,
            "topology  {}, {}; {} non-manifold edge{}, {} degenerate face{}",
            if self.manifold {
                "edge-manifold"
            } else {
                "NOT edge-manifold"
            },
            if self.consistently_oriented {
                "consistently oriented"
            } else {
                "NOT consistently oriented"
            },
            self.non_manifold_edges,
            if self.non_manifold_edges == 1 {
                ""
            } else {
                "s"
            },
            self.degenerate_faces,
            if self.degenerate_faces == 1 { "" } else { "s" },
        );
        if let Some(e) = &self.edge_length {
            let _ = writeln!(
                s,
                "edges     L = {:.6}: length min {:.3} L, mean {:.3} L, max {:.3} L, std {:.3} L; {:.1}% in [0.8 L, 4/3 L]",
                e.target,
                e.min / e.target,
                e.mean / e.target,
                e.max / e.target,
                e.std / e.target,
                100.0 * e.within_band,
            );
            if let (Some(lo), Some(hi), Some(rel)) =
                (e.target_min, e.target_max, &e.relative_to_size)
            {
                let _ = writeln!(
                    s,
                    "sizing    local target {lo:.6} .. {hi:.6}; {:.1}% of edges within [0.8, 4/3] of their local target",
                    100.0 * rel.within_band
                );
            }
        }
        let v = &self.valence;
        let _ = writeln!(
            s,
            "valence   {:} interior vertices: {} regular (valence 6), mean |v-6| {}; {} boundary vertices: mean |v-4| {}",
            v.interior_vertices,
            match v.regular_fraction {
                Some(f) => format!("{:.1}%", 100.0 * f),
                None => "-".to_string(),
            },
            opt(v.interior_mean_abs_deviation, 3),
            v.boundary_vertices,
            opt(v.boundary_mean_abs_deviation, 3),
        );
        if let Some(a) = &self.angles {
            let _ = writeln!(
                s,
                "angles    min {:.2}°, max {:.2}°, mean smallest {:.2}°; {:.2}% of triangles have an angle below 30°",
                a.min_deg,
                a.max_deg,
                a.mean_min_deg,
                100.0 * a.below_30_fraction,
            );
        }
        if let Some(q) = &self.triangle_quality {
            let _ = writeln!(s, "quality   min {:.4}, mean {:.4}", q.min, q.mean);
        }
        if let Some(d) = &self.distance {
            let _ = writeln!(
                s,
                "distance  Hausdorff {:.3e} ({:.4}% of diagonal), mean {:.3e} ({:.4}%), rms {:.3e} ({:.4}%); {} samples per side",
                d.hausdorff,
                100.0 * d.hausdorff_relative,
                d.mean,
                100.0 * d.mean_relative,
                d.rms,
                100.0 * d.rms_relative,
                d.samples_per_side,
            );
        }
        if let Some(f) = &self.features {
            let _ = writeln!(
                s,
                "features  {} feature edges ({} sharp at {}°), {} corners, {} lines",
                f.edges, f.sharp_edges, f.feature_angle_deg, f.corners, f.lines,
            );
            if let Some(x) = &f.fidelity {
                let _ = writeln!(
                    s,
                    "fidelity  crease distance max {} L, mean {} L; corners kept {}/{}; feature edges on input lines {}/{}, max offset {} L; input feature samples off the output's feature edges {}/{}",
                    opt(x.sharp_distance_max_over_l, 4),
                    opt(x.sharp_distance_mean_over_l, 5),
                    x.corners_kept,
                    x.reference_corners,
                    x.edges_on_reference_lines,
                    f.edges,
                    opt(x.max_offset_over_l, 4),
                    x.uncovered_samples,
                    x.reference_samples,
                );
            }
        }
        if let Some(r) = &self.repairs {
            let _ = writeln!(
                s,
                "repairs   welded {}, unreferenced {}, degenerate {}, duplicate {}, non-manifold edges {}, non-manifold vertices {}, flipped {}, non-orientable components {}, ignored primitives {}",
                r.welded_vertices,
                r.unreferenced_vertices,
                r.degenerate_faces,
                r.duplicate_faces,
                r.non_manifold_edges,
                r.non_manifold_vertices,
                r.flipped_faces,
                r.non_orientable_components,
                r.ignored_primitives,
            );
        }
        s
    }
}
