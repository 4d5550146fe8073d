//! Self-describing histograms and the edge-length band: every histogram
//! carries its unit, its origin, bin width and bin edges, and (for lengths)
//! the absolute length one unit stands for, so a reader of the JSON needs no
//! other document to interpret the counts.

use serde::{Deserialize, Serialize};

/// Lower bound of the Botsch–Kobbelt band, in units of the reference length.
pub const BAND_LOWER: f64 = crate::sizing::COLLAPSE_FACTOR;
/// Upper bound of the Botsch–Kobbelt band, in units of the reference length.
pub const BAND_UPPER: f64 = crate::sizing::SPLIT_FACTOR;

/// What one unit of a histogram's axis (and of a band's bounds) stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Unit {
    /// Edge length over the job's target length L (uniform sizing, or an
    /// explicit `--target-edge-length`).
    TargetLength,
    /// Edge length over the mesh's own mean edge length (no target given).
    MeanEdgeLength,
    /// Edge length over the edge's local target: the mean of its two end
    /// points' targets in the adaptive size field.
    LocalTarget,
    /// Edge length over the mean of the per-vertex targets of the size
    /// field: one global length, not what adaptive sizing aims at per edge.
    MeanLocalTarget,
    /// Degrees.
    Degrees,
}

impl Unit {
    /// The unit as the command line prints it.
    pub fn describe(self) -> &'static str {
        match self {
            Unit::TargetLength => "edge length / target L",
            Unit::MeanEdgeLength => "edge length / mean edge length",
            Unit::LocalTarget => "edge length / local target",
            Unit::MeanLocalTarget => "edge length / mean local target",
            Unit::Degrees => "degrees",
        }
    }
}

/// A histogram with equal-width bins from `origin`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Histogram {
    /// The unit of the axis and of `origin`, `bin_width` and `bin_edges`.
    pub unit: Unit,
    /// The absolute length one unit stands for, when the unit is one length
    /// (`target_length`, `mean_edge_length`, `mean_local_target`); null for
    /// `local_target` (a different length per edge) and for `degrees`.
    pub reference_length: Option<f64>,
    /// Lower edge of the first bin.
    pub origin: f64,
    /// Width of every bin.
    pub bin_width: f64,
    /// Bin edges: bin k holds values in [bin_edges[k], bin_edges[k+1]).
    /// With `open_last_bin`, there is one edge per bin and the last bin
    /// holds every value from its lower edge up; otherwise there is one
    /// edge more than bins and the last bin includes its upper edge.
    pub bin_edges: Vec<f64>,
    /// Whether the last bin is an overflow bin without upper edge.
    pub open_last_bin: bool,
    /// Count per bin.
    pub counts: Vec<u64>,
}

impl Histogram {
    /// A histogram of `counts` with bins of `bin_width` from 0.
    pub(crate) fn new(
        unit: Unit,
        reference_length: Option<f64>,
        bin_width: f64,
        open_last_bin: bool,
        counts: Vec<u64>,
    ) -> Self {
        let edges = counts.len() + usize::from(!open_last_bin);
        Self {
            unit,
            reference_length,
            origin: 0.0,
            bin_width,
            bin_edges: (0..edges)
                .map(|k| round_edge(k as f64 * bin_width))
                .collect(),
            open_last_bin,
            counts,
        }
    }
}

/// `k·width` without the binary noise of the product (0.30000000000000004).
fn round_edge(x: f64) -> f64 {
    (x * 1e9).round() / 1e9
}

/// The band an edge counts as "in", in the unit of its histogram.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Band {
    /// The unit of `lower` and `upper` (the histogram's).
    pub unit: Unit,
    /// Lower bound, inclusive: 4/5.
    pub lower: f64,
    /// Upper bound, inclusive: 4/3.
    pub upper: f64,
    /// The bounds as absolute lengths, when the unit is one length.
    pub lower_length: Option<f64>,
    /// See `lower_length`.
    pub upper_length: Option<f64>,
}

impl Band {
    /// The Botsch–Kobbelt band [4/5, 4/3] in `unit`, of absolute length
    /// `length` when the unit is one length.
    pub(crate) fn new(unit: Unit, length: Option<f64>) -> Self {
        Self {
            unit,
            lower: BAND_LOWER,
            upper: BAND_UPPER,
            lower_length: length.map(|l| BAND_LOWER * l),
            upper_length: length.map(|l| BAND_UPPER * l),
        }
    }
}

/// Bin of `x` (in units of the bin width) among `n` bins, the last one
/// taking everything above; NaN lands in bin 0.
#[inline]
pub(crate) fn bin(x: f64, n: usize) -> usize {
    // `as usize` saturates: negative and NaN give 0.
    (x.floor() as usize).min(n - 1)
}

/// Length inside the band around `l`, with quality.py's bounds.
#[inline]
pub(crate) fn in_band(len: f64, l: f64) -> bool {
    len >= BAND_LOWER * l && len <= BAND_UPPER * l
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_follow_the_bins() {
        let h = Histogram::new(Unit::TargetLength, Some(2.0), 0.1, true, vec![0; 21]);
        assert_eq!(h.bin_edges.len(), 21);
        assert_eq!(h.bin_edges[3], 0.3);
        assert_eq!(h.bin_edges[20], 2.0);
        let a = Histogram::new(Unit::Degrees, None, 5.0, false, vec![0; 36]);
        assert_eq!(a.bin_edges.len(), 37);
        assert_eq!(a.bin_edges[36], 180.0);
        let b = Band::new(Unit::TargetLength, Some(3.0));
        assert_eq!(b.lower_length, Some(BAND_LOWER * 3.0));
        assert_eq!(b.upper_length, Some(4.0));
    }
}
