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
//!
//! Edge lengths are measured against one reference, named in the JSON (see
//! `edges`); every histogram carries its unit and bin edges (see
//! `histogram`); [`Headline`] is the small block every report opens with.
//! Submodules: `topology` (edge table), `shape` (valence, angles, quality),
//! `edges`, `histogram`, `distance`, `rng` (the bench's random stream, for
//! the distance and colour samples), `features` (with `polyline`, the
//! distance between two edge sets), `attributes` (texture coordinates and
//! colours), `elements` (per-element quality for the `quality_attributes`
//! option) and `summary` (the headline and the text the command line
//! prints).

pub mod attributes;
mod distance;
mod edges;
mod elements;
mod features;
pub mod forced;
mod histogram;
pub mod polyline;
mod rng;
mod shape;
mod summary;
mod topology;

pub use distance::DistanceStats;
pub use edges::{EdgeLengthStats, EdgeLengthView};
pub use elements::{element_quality, ElementQuality};
pub use features::{FeatureFidelity, FeatureStats, CORNER_TOLERANCE, ON_LINE_TOLERANCE};
pub use histogram::{Band, Histogram, Unit, BAND_LOWER, BAND_UPPER};
pub use shape::{AngleStats, TriangleQualityStats, ValenceStats};
pub use summary::{EdgeHeadline, Headline, ValenceHeadline};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::bvh::SurfaceIndex;
use crate::features::FeatureSet;
use crate::mesh::RepairReport;
use crate::reference::Reference;
use crate::trimesh::TriMesh;

use topology::{count_sets, EdgeCounts, UnionFind};

/// Faces per parallel task in the per-face and per-edge loops.
const CHUNK: usize = 16 * 1024;

/// Inputs of [`compute`] besides the mesh.
#[derive(Clone, Copy, Debug)]
pub struct StatsOptions<'a> {
    /// Target edge length L: the reference of the band and histogram
    /// unless `vertex_target` is given (then L is only the unit of the
    /// `against_mean_target` view and of the length figures). Default (and
    /// when not finite and positive): the per-vertex targets' mean if
    /// given, otherwise the mean edge length.
    pub target_edge_length: Option<f64>,
    /// Surface to measure the distance to (the job's input, for its output).
    pub reference: Option<&'a TriMesh>,
    /// A prebuilt index of `reference`, reused instead of building one.
    pub reference_index: Option<&'a SurfaceIndex>,
    /// The job's prepared reference: when given, it stands for `reference`
    /// and `reference_index`, and its welded view, spatial index and
    /// measured features are reused instead of built again.
    pub prepared: Option<&'a Reference>,
    /// Area-uniform samples per side for the distance (vertices are added);
    /// default 200,000, as `quality.py`.
    pub samples_per_side: usize,
    /// Seed of the sample stream (NumPy's `default_rng(seed)`); default 0,
    /// as `quality.py`'s `--seed`.
    pub sample_seed: u64,
    /// What the mesh builder repaired, copied into the statistics.
    pub repairs: Option<RepairReport>,
    /// Per-vertex target edge length (adaptive sizing), one per position;
    /// when given, the band and histogram measure each edge against the
    /// mean of its end points' targets (`local_target`). Ignored when its
    /// length differs from the vertex count.
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
            prepared: None,
            samples_per_side: 200_000,
            sample_seed: distance::DEFAULT_SEED,
            repairs: None,
            vertex_target: None,
            features: None,
        }
    }
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
    let targets = welded_targets(opts.vertex_target, mesh.positions.len(), &origin);
    let owned_reference;
    let (reference, reference_index) = match opts.prepared {
        Some(r) => (Some(r.welded().0), Some(&**r.index())),
        None => {
            owned_reference = opts.reference.map(|r| r.welded().0);
            (owned_reference.as_ref(), opts.reference_index)
        }
    };
    compute_welded(
        &welded,
        &StatsOptions {
            reference,
            reference_index,
            vertex_target: targets.as_deref(),
            ..*opts
        },
        None,
    )
}

/// [`compute`] of a job's input itself: the reference's welded view and
/// measured features are reused, not built again. `opts.vertex_target` is
/// per position of the reference's source.
pub fn compute_input(input: &Reference, opts: &StatsOptions) -> MeshStats {
    let (welded, origin) = input.welded();
    let targets = welded_targets(opts.vertex_target, input.source.positions.len(), origin);
    let own = opts.features.map(|fo| input.measured_features(&fo));
    compute_welded(
        welded,
        &StatsOptions {
            reference: None,
            reference_index: None,
            prepared: None,
            vertex_target: targets.as_deref(),
            ..*opts
        },
        own.as_deref(),
    )
}

/// Per-position targets carried to the welded positions (`origin` maps
/// each welded position to the position it came from); ignored when their
/// count is not `positions`.
fn welded_targets(targets: Option<&[f64]>, positions: usize, origin: &[u32]) -> Option<Vec<f64>> {
    targets
        .filter(|t| t.len() == positions)
        .map(|t| origin.iter().map(|&i| t[i as usize]).collect())
}

/// [`compute`] on a mesh that is already welded; `own_features` are the
/// mesh's features for `opts.features`, when already detected.
fn compute_welded(
    mesh: &TriMesh,
    opts: &StatsOptions,
    own_features: Option<&FeatureSet>,
) -> MeshStats {
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
    let table = EdgeCounts::new(tris, nv);
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
    let valence_stats = shape::valence_stats(&valence, &used, &boundary);

    // --- per face ----------------------------------------------------------
    let diag = opts
        .reference
        .map_or_else(|| mesh.bbox_diagonal(), |r| r.bbox_diagonal());
    let (angles, triangle_quality, degenerate_faces) =
        shape::face_stats(pos, tris, 1e-12 * diag * diag);

    // --- edge lengths ---------------------------------------------------------
    let edge_length =
        edges::edge_length_stats(mesh, edges, opts.target_edge_length, opts.vertex_target);

    // --- distance ---------------------------------------------------------------
    let distance = opts
        .reference
        .and_then(|r| distance::distance_stats(mesh, tris, &used, r, opts));

    // --- features ---------------------------------------------------------------
    let features = opts.features.map(|fo| {
        let reference_features = opts.prepared.map(|r| r.measured_features(&fo));
        features::feature_stats(
            mesh,
            &fo,
            own_features,
            opts.reference.map(|r| (r, reference_features.as_deref())),
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
        degenerate_faces,
        edge_length,
        valence: valence_stats,
        angles,
        triangle_quality,
        distance,
        repairs: opts.repairs,
        features,
    }
}
