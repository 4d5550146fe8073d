//! What the command line prints, and the headline block every report
//! opens with: the edge-length histogram against the remesh's reference and
//! the valence deviation, small and in a fixed order, before the full
//! statistics.

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use super::histogram::{Band, Histogram, Unit};
use super::MeshStats;

/// The edge-length half of the headline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EdgeHeadline {
    /// The reference the band and histogram use (see
    /// [`super::EdgeLengthStats::reference`]).
    pub reference: Unit,
    /// The reference length L (the mean per-vertex target under a local
    /// reference).
    pub target: f64,
    /// The band, in the histogram's unit.
    pub band: Band,
    /// Fraction of edges in the band: did the remesh hit its target?
    pub within_band: f64,
    /// The edge-length histogram against the reference.
    pub histogram: Histogram,
    /// A remesh output's band over free and forced edges (see
    /// [`super::forced`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub split: Option<super::forced::BandSplit>,
}

/// The valence half of the headline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ValenceHeadline {
    /// Mean |valence − ideal| over all used vertices (6 inside, 4 on the
    /// boundary); null without vertices.
    pub mean_abs_deviation: Option<f64>,
    /// Mean |valence − 6| over interior vertices (null without any).
    pub interior_mean_abs_deviation: Option<f64>,
    /// Mean |valence − 4| over boundary vertices (null without any).
    pub boundary_mean_abs_deviation: Option<f64>,
}

/// The two headline figures of a mesh.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Headline {
    /// Edge lengths against the reference (null for a mesh without edges).
    pub edge_length: Option<EdgeHeadline>,
    /// Valence deviation from the ideal.
    pub valence: ValenceHeadline,
}

impl Headline {
    /// The block as the command line prints it: three or four lines.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let opt = |x: Option<f64>| x.map_or_else(|| "-".to_string(), |v| format!("{v:.3}"));
        if let Some(e) = &self.edge_length {
            let against = match e.reference {
                Unit::LocalTarget => "of the local target".to_string(),
                _ => format!("of L = {:.6}", e.target),
            };
            let _ = writeln!(
                s,
                "headline  {:.1}% of edges in the band [{:.2}, {:.2}] {against}",
                100.0 * e.within_band,
                e.band.lower,
                e.band.upper,
            );
            if let Some(sp) = &e.split {
                let _ = writeln!(
                    s,
                    "          free edges {:.1}% in the band ({}); edges the input forces {:.1}% ({})",
                    100.0 * sp.free_within_band,
                    sp.free_edges,
                    100.0 * sp.forced_within_band,
                    sp.forced_edges,
                );
            }
            let h = &e.histogram;
            let last = h.bin_edges.last().copied().unwrap_or(0.0);
            let counts: Vec<String> = h.counts.iter().map(u64::to_string).collect();
            let _ = writeln!(
                s,
                "          {}: bins of {} from {}{}: {}",
                h.unit.describe(),
                h.bin_width,
                h.origin,
                if h.open_last_bin {
                    format!(", the last for ≥ {last}")
                } else {
                    String::new()
                },
                counts.join(" "),
            );
        }
        let v = &self.valence;
        let _ = writeln!(
            s,
            "          valence deviation {} (interior |v-6| {}, boundary |v-4| {})",
            opt(v.mean_abs_deviation),
            opt(v.interior_mean_abs_deviation),
            opt(v.boundary_mean_abs_deviation),
        );
        s
    }
}

impl MeshStats {
    /// The headline figures of these statistics.
    pub fn headline(&self) -> Headline {
        Headline {
            edge_length: self.edge_length.as_ref().map(|e| EdgeHeadline {
                reference: e.reference,
                target: e.target,
                band: e.band.clone(),
                within_band: e.within_band,
                histogram: e.histogram.clone(),
                split: e.split,
            }),
            valence: ValenceHeadline {
                mean_abs_deviation: self.valence.mean_abs_deviation,
                interior_mean_abs_deviation: self.valence.interior_mean_abs_deviation,
                boundary_mean_abs_deviation: self.valence.boundary_mean_abs_deviation,
            },
        }
    }

    /// A readable multi-line summary for the command line: the headline
    /// block first, then every section.
    pub fn summary(&self) -> String {
        let mut s = self.headline().render();
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
                "edges     L = {:.6}: length min {:.3} L, mean {:.3} L, max {:.3} L, std {:.3} L",
                e.target,
                e.min / e.target,
                e.mean / e.target,
                e.max / e.target,
                e.std / e.target,
            );
            if let (Some(lo), Some(hi), Some(g)) =
                (e.target_min, e.target_max, &e.against_mean_target)
            {
                let _ = writeln!(
                    s,
                    "sizing    local target {lo:.6} .. {hi:.6}; against the mean target alone {:.1}% would be in [0.8 L, 4/3 L]",
                    100.0 * g.within_band
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
                    "fidelity  crease distance max {} L, mean {} L; corners kept {}/{} (within {:.0e} L); feature edges on input lines {}/{}, max offset {} L; input feature samples off the output's feature edges {}/{}",
                    opt(x.sharp_distance_max_over_l, 4),
                    opt(x.sharp_distance_mean_over_l, 5),
                    x.corners_kept,
                    x.reference_corners,
                    super::CORNER_TOLERANCE,
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
