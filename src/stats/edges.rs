//! The `edge_length` section: lengths over the unique undirected edges,
//! and the band and histogram against one reference, named in the JSON.
//!
//! The reference is what the remesher aimed at: the target length L under
//! uniform sizing (or the mean edge length when no target is given), and
//! the local size field, edge by edge, when per-vertex targets are given
//! (adaptive sizing). So the top-level `within_band` always answers "did
//! the remesh hit its target?", and a job measures its input and its output
//! against the same reference. Under a local reference, the view against
//! one global length is kept as `against_mean_target`, named for what it is.

use serde::{Deserialize, Serialize};

use super::histogram::{bin, in_band, Band, Histogram, Unit};
use super::{chunked, topology};
use crate::trimesh::TriMesh;

/// Number of edge-length histogram bins below 2 units, each 0.1 wide; one
/// overflow bin follows.
const EDGE_BINS: usize = 20;
/// Width of an edge-length bin, in units of the reference.
const EDGE_BIN_WIDTH: f64 = 0.1;

/// The band and histogram of the edge lengths against one reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EdgeLengthView {
    /// The band [4/5, 4/3] in the histogram's unit.
    pub band: Band,
    /// Fraction of edges whose length lies in the band (inclusive).
    pub within_band: f64,
    /// 20 bins of 0.1 over [0, 2) and an overflow bin (21 counts).
    pub histogram: Histogram,
}

/// Edge-length statistics over the unique undirected edges.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EdgeLengthStats {
    /// Shortest edge (absolute).
    pub min: f64,
    /// Longest edge (absolute).
    pub max: f64,
    /// Mean edge length (absolute).
    pub mean: f64,
    /// Population standard deviation of the edge lengths (absolute).
    pub std: f64,
    /// What `within_band` and `histogram` measure against: `target_length`,
    /// `mean_edge_length` or `local_target` (the histogram's unit).
    pub reference: Unit,
    /// One reference length L: the explicit target if given, otherwise the
    /// mean per-vertex target if given, otherwise the mean edge length.
    /// `min`, `mean`, `max` and `std` over L are the bench's figures.
    pub target: f64,
    /// Smallest per-vertex target (present only with per-vertex targets).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_min: Option<f64>,
    /// Largest per-vertex target (present only with per-vertex targets).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_max: Option<f64>,
    /// The band [4/5, 4/3] in the unit of `reference`: the band that split
    /// and collapse leave alone.
    pub band: Band,
    /// Fraction of edges in the band, against `reference`: for
    /// `local_target` each edge against the mean of its end points' targets.
    pub within_band: f64,
    /// Histogram of length over the reference: 20 bins of 0.1 over [0, 2)
    /// and an overflow bin for ratios ≥ 2 (21 counts).
    pub histogram: Histogram,
    /// Under a local reference only: the same band and histogram against
    /// the single length `target` (unit `mean_local_target`, or
    /// `target_length` when an explicit target was also given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub against_mean_target: Option<EdgeLengthView>,
    /// A remesh output's band split into the edges the input forces
    /// (features too short for the band, kept small parts) and the free
    /// ones (see [`super::forced`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split: Option<super::forced::BandSplit>,
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

/// The `edge_length` section of `mesh` over its unique `edges`, against
/// `explicit` L or, when given (one per position), the per-vertex `targets`.
pub(super) fn edge_length_stats(
    mesh: &TriMesh,
    edges: &[topology::Edge],
    explicit: Option<f64>,
    targets: Option<&[f64]>,
) -> Option<EdgeLengthStats> {
    if edges.is_empty() {
        return None;
    }
    let pos = &mesh.positions;
    let len = |e: &topology::Edge| (pos[e.a as usize] - pos[e.b as usize]).length();
    let n = edges.len() as f64;
    let targets = targets.filter(|t| t.len() == pos.len());
    let explicit = explicit.filter(|l| l.is_finite() && *l > 0.0);
    let mean = chunked(
        edges.len(),
        0.0,
        |r| edges[r].iter().map(len).sum::<f64>(),
        |a, b| a + b,
    ) / n;
    let l = explicit
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
    let global_unit = match (explicit, targets) {
        (Some(_), _) => Unit::TargetLength,
        (None, Some(_)) => Unit::MeanLocalTarget,
        (None, None) => Unit::MeanEdgeLength,
    };
    let global = EdgeLengthView {
        band: Band::new(global_unit, Some(l)),
        within_band: acc.in_band as f64 / n,
        histogram: Histogram::new(
            global_unit,
            Some(l),
            EDGE_BIN_WIDTH,
            true,
            acc.hist.to_vec(),
        ),
    };
    let (reference, main, against_mean_target, target_min, target_max) = match targets {
        Some(t) => {
            let local = EdgeLengthView {
                band: Band::new(Unit::LocalTarget, None),
                within_band: acc.rel_in_band as f64 / n,
                histogram: Histogram::new(
                    Unit::LocalTarget,
                    None,
                    EDGE_BIN_WIDTH,
                    true,
                    acc.rel_hist.to_vec(),
                ),
            };
            (
                Unit::LocalTarget,
                local,
                Some(global),
                Some(t.iter().copied().fold(f64::INFINITY, f64::min)),
                Some(t.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
            )
        }
        None => (global_unit, global, None, None, None),
    };
    Some(EdgeLengthStats {
        min: acc.min,
        max: acc.max,
        mean,
        std: (acc.dev2 / n).sqrt(),
        reference,
        target: l,
        target_min,
        target_max,
        band: main.band,
        within_band: main.within_band,
        histogram: main.histogram,
        against_mean_target,
        split: None,
    })
}
