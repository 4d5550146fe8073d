//! The remesh parameters as callers give them, declared once: the CLI's long
//! flags (clap), the service's `params` part and query string (serde, read
//! strictly in `service::params`), and the job record on disk all use
//! [`Params`] and its [`PARAM_NAMES`]. They convert into
//! [`RemeshOptions`], never the reverse.

use clap::ArgAction;
use serde::{Deserialize, Serialize};

use crate::features::DEFAULT_FEATURE_ANGLE_DEG;
use crate::io::Format;
use crate::remesh::{
    FeatureSource, NormalSource, RemeshError, RemeshOptions, Sizing, SmallParts, DEFAULT_GRADATION,
    DEFAULT_ITERATIONS, DEFAULT_MIN_CREASE_LENGTH, DEFAULT_RELAXATION_STEPS,
    DEFAULT_SMALL_PART_SIZE,
};

/// Every parameter name, in the order of [`Params`]' fields.
pub const PARAM_NAMES: [&str; 21] = [
    "target_edge_length",
    "target_edge_ratio",
    "target_faces",
    "iterations",
    "relaxation_steps",
    "preserve_features",
    "feature_angle",
    "features",
    "normals",
    "min_crease_length",
    "sizing",
    "refine_curved",
    "small_parts",
    "small_part_size",
    "tolerance",
    "tolerance_ratio",
    "min_edge_length",
    "max_edge_length",
    "gradation",
    "output_format",
    "quality_attributes",
];

/// The parameters of one remesh, with the defaults filled in. The doc
/// comments are the CLI's help text.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, clap::Args)]
#[serde(default)]
pub struct Params {
    /// Absolute target edge length L.
    #[arg(long, group = "target")]
    pub target_edge_length: Option<f64>,
    /// Target edge length as a fraction of the bounding-box diagonal.
    #[arg(long, group = "target")]
    pub target_edge_ratio: Option<f64>,
    /// Approximate output face count (L from the surface area).
    #[arg(long, group = "target")]
    pub target_faces: Option<u64>,
    /// Outer iterations of split, collapse, flip, relax and project.
    #[arg(long, default_value_t = DEFAULT_ITERATIONS)]
    pub iterations: u32,
    /// Relaxation + projection steps per iteration.
    #[arg(long, default_value_t = DEFAULT_RELAXATION_STEPS)]
    pub relaxation_steps: u32,
    /// Keep sharp creases and corners (boundaries and material borders are
    /// always kept).
    #[arg(long, default_value_t = true, action = ArgAction::Set)]
    pub preserve_features: bool,
    /// Dihedral angle in degrees above which an edge is a sharp feature.
    #[arg(long, default_value_t = DEFAULT_FEATURE_ANGLE_DEG)]
    pub feature_angle: f64,
    /// Where creases come from: `angle` (dihedral angle above
    /// feature_angle), `normals` (hard edges authored into the input's
    /// normals) or `both`.
    #[arg(long, default_value_t = FeatureSource::Angle)]
    pub features: FeatureSource,
    /// Output normals: `recompute` them from the new surface, split at
    /// features, or `transfer` the input's authored normals.
    #[arg(long, default_value_t = NormalSource::Recompute)]
    pub normals: NormalSource,
    /// Drop creases smaller than this many target lengths: isolated crease
    /// fragments, short chains between free ends and junctions, and turns
    /// that only wiggle next to another corner (0 keeps all).
    #[arg(long, default_value_t = DEFAULT_MIN_CREASE_LENGTH)]
    pub min_crease_length: f64,
    /// `uniform` (one target length) or `adaptive` (from an approximation
    /// tolerance).
    #[arg(long, default_value_t = Sizing::Uniform)]
    pub sizing: Sizing,
    /// Uniform sizing: shorten edges down to 9/10·L where the surface bends
    /// too tightly for edges of L.
    #[arg(long, default_value_t = true, action = ArgAction::Set)]
    pub refine_curved: bool,
    /// Parts smaller than `small_part_size`: `keep` them as they are,
    /// `remesh` them like the rest, or `drop` them.
    #[arg(long, default_value_t = SmallParts::Keep)]
    pub small_parts: SmallParts,
    /// The bounding-box diagonal, in target lengths, under which a part is
    /// small.
    #[arg(long, default_value_t = DEFAULT_SMALL_PART_SIZE)]
    pub small_part_size: f64,
    /// Adaptive sizing: absolute tolerance (default 0.1 % of the diagonal).
    #[arg(long, conflicts_with = "tolerance_ratio")]
    pub tolerance: Option<f64>,
    /// Adaptive sizing: tolerance as a fraction of the bounding-box diagonal.
    #[arg(long)]
    pub tolerance_ratio: Option<f64>,
    /// Adaptive sizing: smallest target length.
    #[arg(long)]
    pub min_edge_length: Option<f64>,
    /// Adaptive sizing: largest target length.
    #[arg(long)]
    pub max_edge_length: Option<f64>,
    /// Adaptive sizing: gradation g in h(v) ≤ h(u) + g·|uv|.
    #[arg(long, default_value_t = DEFAULT_GRADATION)]
    pub gradation: f64,
    /// Output format (default: the input's in the service, the output
    /// file's extension in the CLI).
    #[arg(long)]
    #[serde(deserialize_with = "format_any_case")]
    pub output_format: Option<Format>,
    /// Write per-element quality into the output (glTF, GLB or PLY only):
    /// per face the smallest angle and the edge-length ratio to the local
    /// target, per vertex the valence.
    #[arg(long)]
    pub quality_attributes: bool,
}

impl Default for Params {
    fn default() -> Self {
        let o = RemeshOptions::default();
        Self {
            target_edge_length: None,
            target_edge_ratio: None,
            target_faces: None,
            iterations: o.iterations,
            relaxation_steps: o.relaxation_steps,
            preserve_features: o.preserve_features,
            feature_angle: o.feature_angle,
            features: o.features,
            normals: o.normals,
            min_crease_length: o.min_crease_length,
            sizing: o.sizing,
            refine_curved: o.refine_curved,
            small_parts: o.small_parts,
            small_part_size: o.small_part_size,
            tolerance: None,
            tolerance_ratio: None,
            min_edge_length: None,
            max_edge_length: None,
            gradation: o.gradation,
            output_format: None,
            quality_attributes: false,
        }
    }
}

/// Reads a format name as [`Format`]'s `FromStr` does, in any case
/// (`"STL"`, `"glb"`).
fn format_any_case<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Format>, D::Error> {
    Option::<String>::deserialize(d)?
        .map(|s| s.parse().map_err(serde::de::Error::custom))
        .transpose()
}

impl Params {
    /// The engine's options, validated. `threads` (`None`: every core) and
    /// `max_output_faces` belong to whoever runs the job, not to the caller.
    pub fn to_options(
        &self,
        threads: Option<usize>,
        max_output_faces: u64,
    ) -> Result<RemeshOptions, RemeshError> {
        let o = RemeshOptions {
            target_edge_length: self.target_edge_length,
            target_edge_ratio: self.target_edge_ratio,
            target_faces: self.target_faces,
            iterations: self.iterations,
            relaxation_steps: self.relaxation_steps,
            preserve_features: self.preserve_features,
            feature_angle: self.feature_angle,
            features: self.features,
            normals: self.normals,
            min_crease_length: self.min_crease_length,
            sizing: self.sizing,
            refine_curved: self.refine_curved,
            small_parts: self.small_parts,
            small_part_size: self.small_part_size,
            tolerance: self.tolerance,
            tolerance_ratio: self.tolerance_ratio,
            min_edge_length: self.min_edge_length,
            max_edge_length: self.max_edge_length,
            gradation: self.gradation,
            quality_attributes: self.quality_attributes,
            threads,
            max_output_faces,
            ..RemeshOptions::default()
        };
        o.validate()?;
        Ok(o)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        params: Params,
    }

    #[test]
    fn the_cli_defaults_are_the_engine_defaults() {
        let cli = Cli::try_parse_from(["x"]).unwrap();
        assert_eq!(cli.params, Params::default());
        let o = cli.params.to_options(None, 7).unwrap();
        assert_eq!(
            o,
            RemeshOptions {
                max_output_faces: 7,
                ..RemeshOptions::default()
            }
        );
    }

    #[test]
    fn every_name_is_a_flag_and_a_serde_field() {
        let json = serde_json::to_value(Params::default()).unwrap();
        let keys: Vec<&str> = json
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        let mut names = PARAM_NAMES.to_vec();
        names.sort_unstable();
        let mut sorted = keys.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, names);
        let cli = Cli::try_parse_from([
            "x",
            "--target-faces",
            "900",
            "--preserve-features",
            "false",
            "--sizing",
            "Adaptive",
            "--refine-curved",
            "false",
            "--output-format",
            "glb",
            "--quality-attributes",
        ])
        .unwrap();
        let p = cli.params;
        assert_eq!(p.target_faces, Some(900));
        assert!(!p.preserve_features && !p.refine_curved && p.quality_attributes);
        assert_eq!(p.sizing, Sizing::Adaptive);
        assert_eq!(p.output_format, Some(Format::Glb));
        assert!(
            Cli::try_parse_from(["x", "--target-faces", "9", "--target-edge-ratio", "0.1"])
                .is_err()
        );
    }

    #[test]
    fn an_option_the_engine_refuses_names_its_field() {
        let p = Params {
            gradation: -1.0,
            ..Params::default()
        };
        match p.to_options(Some(1), 100) {
            Err(RemeshError::InvalidOption { field, .. }) => assert_eq!(field, "gradation"),
            other => panic!("{other:?}"),
        }
    }
}
