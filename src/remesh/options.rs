//! Remeshing options: every field documents its meaning and default, and
//! [`RemeshOptions::validate`] checks them once, at the boundary. The CLI
//! flags and the HTTP parameters convert into this type, never the reverse.

use serde::{Deserialize, Serialize};

use super::RemeshError;
use crate::features::{DEFAULT_CORNER_ANGLE_DEG, DEFAULT_FEATURE_ANGLE_DEG};
use crate::sizing::SizingOptions;

/// Default number of iterations: 10, the bench's count, at the top of the
/// 5–10 that Botsch & Kobbelt use (`docs/tuning.md`).
pub const DEFAULT_ITERATIONS: u32 = 10;
/// Default number of relaxation + projection steps per iteration.
pub const DEFAULT_RELAXATION_STEPS: u32 = 1;
/// Default [`RemeshOptions::min_crease_length`], in target lengths: 1.5,
/// just under two of the band's shortest edges (2 × 4/5), so a dropped
/// crease could carry at most one output edge. Bridges between two
/// junctions keep 4/5 of the target. Measurements: `docs/tuning.md`.
pub const DEFAULT_MIN_CREASE_LENGTH: f64 = 1.5;
/// Default gradation of adaptive sizing: h(v) ≤ h(u) + g·|uv|.
pub const DEFAULT_GRADATION: f64 = crate::sizing::DEFAULT_GRADATION;
/// Default cap on the estimated output face count, a guard against a tiny
/// target length exhausting memory.
pub const DEFAULT_MAX_OUTPUT_FACES: u64 = 50_000_000;

/// The number of equilateral triangles of edge `l` that tile `area`,
/// area / (√3/4 · l²): the output estimate that guards memory (infinite or
/// NaN for a zero or invalid length).
pub fn estimated_faces(area: f64, l: f64) -> f64 {
    area / (3f64.sqrt() / 4.0 * l * l)
}

/// How the target edge length varies over the surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Sizing {
    /// One target length everywhere.
    #[default]
    Uniform,
    /// Short edges where curvature is high, long where flat, bounded by a
    /// distance tolerance (Dunyach et al. 2013) and graded.
    Adaptive,
}

impl std::fmt::Display for Sizing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Sizing::Uniform => "uniform",
            Sizing::Adaptive => "adaptive",
        })
    }
}

impl std::str::FromStr for Sizing {
    type Err = String;

    /// Parses `uniform` or `adaptive`, case-insensitively.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "uniform" => Ok(Sizing::Uniform),
            "adaptive" => Ok(Sizing::Adaptive),
            _ => Err(format!("{s:?} is not a sizing; use uniform or adaptive")),
        }
    }
}

/// Default [`RemeshOptions::small_part_size`], in target lengths: a closed
/// part whose bounding box is under 2·L across carries only a handful of
/// band-length edges (a cube of that diagonal, 1.15·L a side, has about a
/// dozen), too few to keep its shape.
pub const DEFAULT_SMALL_PART_SIZE: f64 = 2.0;

/// What happens to a part (a connected piece of the input) smaller than
/// [`RemeshOptions::small_part_size`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SmallParts {
    /// Left exactly as it came: its triangles are copied, not remeshed.
    #[default]
    Keep,
    /// Remeshed like every other part, whatever its size.
    Remesh,
    /// Removed from the output.
    Drop,
}

impl std::fmt::Display for SmallParts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SmallParts::Keep => "keep",
            SmallParts::Remesh => "remesh",
            SmallParts::Drop => "drop",
        })
    }
}

impl std::str::FromStr for SmallParts {
    type Err = String;

    /// Parses `keep`, `remesh` or `drop`, case-insensitively.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "keep" => Ok(SmallParts::Keep),
            "remesh" => Ok(SmallParts::Remesh),
            "drop" => Ok(SmallParts::Drop),
            _ => Err(format!(
                "{s:?} is not a small-part policy; use keep, remesh or drop"
            )),
        }
    }
}

/// Which edges of the input are sharp features (besides boundaries,
/// material borders and attribute seams, which always are).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FeatureSource {
    /// Edges whose dihedral angle exceeds the feature angle.
    #[default]
    Angle,
    /// The hard edges authored into the input's normals (an edge across
    /// which the normals differ); the dihedral angle where the input has
    /// no normals, or is shaded flat.
    Normals,
    /// Both: the dihedral-angle creases and the authored hard edges.
    Both,
}

impl std::fmt::Display for FeatureSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FeatureSource::Angle => "angle",
            FeatureSource::Normals => "normals",
            FeatureSource::Both => "both",
        })
    }
}

impl std::str::FromStr for FeatureSource {
    type Err = String;

    /// Parses `angle`, `normals` or `both`, case-insensitively.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "angle" => Ok(FeatureSource::Angle),
            "normals" => Ok(FeatureSource::Normals),
            "both" => Ok(FeatureSource::Both),
            _ => Err(format!(
                "{s:?} is not a feature source; use angle, normals or both"
            )),
        }
    }
}

/// Where the output's shading normals come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NormalSource {
    /// Computed from the new surface, split at its feature edges.
    #[default]
    Recompute,
    /// The input's own normals, sampled like texture coordinates: each
    /// output corner takes the input's normal at its closest point, on its
    /// side of the input's hard edges, which are kept as seams. For
    /// low-poly art whose normals were authored; an input without normals
    /// gets them recomputed, and the statistics say so.
    Transfer,
}

impl std::fmt::Display for NormalSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NormalSource::Recompute => "recompute",
            NormalSource::Transfer => "transfer",
        })
    }
}

impl std::str::FromStr for NormalSource {
    type Err = String;

    /// Parses `recompute` or `transfer`, case-insensitively.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "recompute" => Ok(NormalSource::Recompute),
            "transfer" => Ok(NormalSource::Transfer),
            _ => Err(format!(
                "{s:?} is not a normal source; use recompute or transfer"
            )),
        }
    }
}

/// Options of [`super::remesh`]. Construct with `Default` and the `with_*`
/// builders, or fill the public fields; [`RemeshOptions::validate`] runs
/// before any work.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RemeshOptions {
    /// Absolute target edge length L. At most one of the three target fields
    /// may be set. When none is, L is the input's mean edge length: the mesh
    /// keeps its resolution and becomes isotropic.
    pub target_edge_length: Option<f64>,
    /// Target edge length as a fraction of the input's bounding-box diagonal
    /// (the bench uses 0.0075).
    pub target_edge_ratio: Option<f64>,
    /// Approximate number of output faces; L follows from the surface area A
    /// as L = sqrt(A / (F · √3/4)).
    pub target_faces: Option<u64>,
    /// Outer iterations of split, collapse, flip, relax, project. Default 10.
    pub iterations: u32,
    /// Relaxation + projection steps per iteration. Default 1.
    pub relaxation_steps: u32,
    /// Run the split pass (edges longer than 4/3·L). Default true.
    pub split: bool,
    /// Run the collapse pass (edges shorter than 4/5·L). Default true.
    pub collapse: bool,
    /// Run the valence-improving flip pass. Default true.
    pub flip: bool,
    /// Run tangential relaxation. Default true.
    pub relax: bool,
    /// Project vertices back onto the input surface. Default true.
    pub project: bool,
    /// Keep sharp creases and corners (boundaries and material borders are
    /// always kept). Default true.
    pub preserve_features: bool,
    /// Dihedral angle in degrees above which an edge is a sharp feature.
    /// Default 45° (see [`crate::features::DEFAULT_FEATURE_ANGLE_DEG`]).
    pub feature_angle: f64,
    /// Where sharp features come from: the dihedral angle, the hard edges
    /// of the input's normals, or both. Default [`FeatureSource::Angle`].
    pub features: FeatureSource,
    /// Where the output's normals come from. Default
    /// [`NormalSource::Recompute`].
    pub normals: NormalSource,
    /// Turning angle in degrees above which a feature-line vertex is a corner.
    pub corner_angle: f64,
    /// Creases smaller than this many target lengths are dropped (see
    /// [`crate::features::FeatureOptions::min_crease_length`]): an isolated
    /// crease fragment, or a crease spur ending in a free end, shorter than
    /// it cannot be resampled by edges in the band and only pins corners a
    /// fraction of an edge apart. A chain between two junctions goes only
    /// below the smaller of this and 4/5 of the target. Under adaptive
    /// sizing the unit is the smallest allowed target. 0 keeps every crease.
    /// Default [`DEFAULT_MIN_CREASE_LENGTH`].
    pub min_crease_length: f64,
    /// Uniform or adaptive sizing. Default uniform.
    pub sizing: Sizing,
    /// Uniform sizing: shorten edges, down to 9/10·L, where the surface bends
    /// so tightly that edges of length L would cut it by more than 2/15·L
    /// (curvature, sub-feature creases and cones, as in adaptive sizing),
    /// graded by `gradation`. Edges stay in the band [4/5·L, 4/3·L] nearly
    /// everywhere while tight curves are followed more closely. Default true.
    pub refine_curved: bool,
    /// What to do with a part whose bounding-box diagonal is under
    /// `small_part_size` target lengths. Default keep.
    pub small_parts: SmallParts,
    /// The size, in target lengths (under adaptive sizing the smallest
    /// allowed target), below which a part is small. Default
    /// [`DEFAULT_SMALL_PART_SIZE`].
    pub small_part_size: f64,
    /// Adaptive sizing: absolute approximation tolerance ε.
    pub tolerance: Option<f64>,
    /// Adaptive sizing: tolerance as a fraction of the bounding-box diagonal
    /// (default [`crate::sizing::DEFAULT_RELATIVE_TOLERANCE`] when neither
    /// tolerance is given).
    pub tolerance_ratio: Option<f64>,
    /// Adaptive sizing: smallest allowed target length.
    pub min_edge_length: Option<f64>,
    /// Adaptive sizing: largest allowed target length.
    pub max_edge_length: Option<f64>,
    /// Adaptive sizing: gradation g in h(v) ≤ h(u) + g·|uv|.
    pub gradation: f64,
    /// Worker threads for the parallel passes; `None` uses every core. The
    /// output does not depend on it.
    pub threads: Option<usize>,
    /// Refuse inputs whose estimated output exceeds this many faces.
    pub max_output_faces: u64,
    /// Write per-element quality into the output file (glTF, GLB or PLY):
    /// per face the smallest angle and the edge-length ratio to the local
    /// target, per vertex the valence (see
    /// [`crate::pipeline::quality_attributes`]). The remesh itself does not
    /// change. Default false.
    pub quality_attributes: bool,
}

impl Default for RemeshOptions {
    fn default() -> Self {
        Self {
            target_edge_length: None,
            target_edge_ratio: None,
            target_faces: None,
            iterations: DEFAULT_ITERATIONS,
            relaxation_steps: DEFAULT_RELAXATION_STEPS,
            split: true,
            collapse: true,
            flip: true,
            relax: true,
            project: true,
            preserve_features: true,
            feature_angle: DEFAULT_FEATURE_ANGLE_DEG,
            features: FeatureSource::Angle,
            normals: NormalSource::Recompute,
            corner_angle: DEFAULT_CORNER_ANGLE_DEG,
            min_crease_length: DEFAULT_MIN_CREASE_LENGTH,
            sizing: Sizing::Uniform,
            refine_curved: true,
            small_parts: SmallParts::Keep,
            small_part_size: DEFAULT_SMALL_PART_SIZE,
            tolerance: None,
            tolerance_ratio: None,
            min_edge_length: None,
            max_edge_length: None,
            gradation: DEFAULT_GRADATION,
            threads: None,
            max_output_faces: DEFAULT_MAX_OUTPUT_FACES,
            quality_attributes: false,
        }
    }
}

fn invalid(field: &'static str, message: impl Into<String>) -> RemeshError {
    RemeshError::InvalidOption {
        field,
        message: message.into(),
    }
}

fn positive(field: &'static str, v: Option<f64>) -> Result<(), RemeshError> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(invalid(
            field,
            format!("must be a positive finite number, got {x}"),
        )),
        _ => Ok(()),
    }
}

impl RemeshOptions {
    /// The uniform target length L and the parameter that sets it: an
    /// explicit length, the ratio times the diagonal, the length whose
    /// equilateral triangles tile `area` in `target_faces`, or else the
    /// input's mean edge length (`mean_edge`, evaluated only then). The
    /// engine and the service's pre-queue estimate both resolve L here.
    pub fn uniform_target(
        &self,
        diagonal: f64,
        area: f64,
        mean_edge: impl FnOnce() -> f64,
    ) -> (f64, &'static str) {
        if let Some(l) = self.target_edge_length {
            (l, "target_edge_length")
        } else if let Some(r) = self.target_edge_ratio {
            (r * diagonal, "target_edge_ratio")
        } else if let Some(f) = self.target_faces {
            (
                (area / (f as f64 * 3f64.sqrt() / 4.0)).sqrt(),
                "target_faces",
            )
        } else {
            (mean_edge(), "target_edge_length")
        }
    }

    /// The adaptive tolerance ε: `tolerance`, else `tolerance_ratio` (default
    /// [`crate::sizing::DEFAULT_RELATIVE_TOLERANCE`]) of `diagonal`.
    pub fn tolerance_for(&self, diagonal: f64) -> f64 {
        self.tolerance.unwrap_or_else(|| {
            self.tolerance_ratio
                .unwrap_or(crate::sizing::DEFAULT_RELATIVE_TOLERANCE)
                * diagonal
        })
    }

    /// The size-field options of adaptive sizing for an input of bounding-box
    /// `diagonal`: the tolerance's defaults ([`SizingOptions::for_tolerance`])
    /// with the caller's bounds and gradation. The engine builds its field
    /// from them, and the service's estimate takes their smallest target.
    pub fn adaptive_sizing(&self, diagonal: f64) -> SizingOptions {
        let mut so = SizingOptions::for_tolerance(self.tolerance_for(diagonal), diagonal);
        if let Some(a) = self.min_edge_length {
            so.min_edge_length = a;
        }
        if let Some(b) = self.max_edge_length {
            so.max_edge_length = b;
        }
        so.max_edge_length = so.max_edge_length.max(so.min_edge_length);
        so.gradation = self.gradation;
        so
    }

    /// Sets an absolute target edge length.
    pub fn with_target_edge_length(mut self, l: f64) -> Self {
        self.target_edge_length = Some(l);
        self
    }
    /// Sets the target edge length relative to the bounding-box diagonal.
    pub fn with_target_edge_ratio(mut self, r: f64) -> Self {
        self.target_edge_ratio = Some(r);
        self
    }
    /// Sets the approximate output face count.
    pub fn with_target_faces(mut self, f: u64) -> Self {
        self.target_faces = Some(f);
        self
    }
    /// Sets the iteration count.
    pub fn with_iterations(mut self, n: u32) -> Self {
        self.iterations = n;
        self
    }
    /// Sets the worker thread count.
    pub fn with_threads(mut self, n: usize) -> Self {
        self.threads = Some(n);
        self
    }
    /// Sets the feature angle in degrees.
    pub fn with_feature_angle(mut self, deg: f64) -> Self {
        self.feature_angle = deg;
        self
    }
    /// Switches sharp-feature preservation on or off.
    pub fn with_preserve_features(mut self, on: bool) -> Self {
        self.preserve_features = on;
        self
    }

    /// Checks every field; the first problem names its field.
    pub fn validate(&self) -> Result<(), RemeshError> {
        let targets = [
            self.target_edge_length.is_some(),
            self.target_edge_ratio.is_some(),
            self.target_faces.is_some(),
        ];
        if targets.iter().filter(|&&t| t).count() > 1 {
            return Err(invalid(
                "target_edge_length",
                "give at most one of target_edge_length, target_edge_ratio and target_faces",
            ));
        }
        positive("target_edge_length", self.target_edge_length)?;
        positive("target_edge_ratio", self.target_edge_ratio)?;
        if self.target_faces == Some(0) {
            return Err(invalid("target_faces", "must be at least 1"));
        }
        if self.iterations > 1000 {
            return Err(invalid("iterations", "must be at most 1000"));
        }
        if !(self.small_part_size.is_finite() && self.small_part_size >= 0.0) {
            return Err(invalid(
                "small_part_size",
                "must be a finite number of target lengths, 0 or more",
            ));
        }
        if self.relaxation_steps > 100 {
            return Err(invalid("relaxation_steps", "must be at most 100"));
        }
        if !(self.feature_angle.is_finite() && (0.0..=180.0).contains(&self.feature_angle)) {
            return Err(invalid(
                "feature_angle",
                "must be between 0 and 180 degrees",
            ));
        }
        if !(self.corner_angle.is_finite() && (0.0..=180.0).contains(&self.corner_angle)) {
            return Err(invalid("corner_angle", "must be between 0 and 180 degrees"));
        }
        if !(self.min_crease_length.is_finite() && (0.0..=100.0).contains(&self.min_crease_length))
        {
            return Err(invalid(
                "min_crease_length",
                "must be between 0 and 100 target lengths",
            ));
        }
        positive("tolerance", self.tolerance)?;
        positive("tolerance_ratio", self.tolerance_ratio)?;
        positive("min_edge_length", self.min_edge_length)?;
        positive("max_edge_length", self.max_edge_length)?;
        if let (Some(a), Some(b)) = (self.min_edge_length, self.max_edge_length) {
            if a > b {
                return Err(invalid(
                    "min_edge_length",
                    "must not exceed max_edge_length",
                ));
            }
        }
        if self.tolerance.is_some() && self.tolerance_ratio.is_some() {
            return Err(invalid(
                "tolerance",
                "give tolerance or tolerance_ratio, not both",
            ));
        }
        if !(self.gradation.is_finite() && self.gradation > 0.0) {
            return Err(invalid("gradation", "must be a positive finite number"));
        }
        if self.sizing == Sizing::Uniform
            && (self.tolerance.is_some()
                || self.tolerance_ratio.is_some()
                || self.min_edge_length.is_some()
                || self.max_edge_length.is_some())
        {
            return Err(invalid(
                "sizing",
                "tolerance, min_edge_length and max_edge_length need sizing = adaptive",
            ));
        }
        if self.sizing == Sizing::Adaptive && targets.iter().any(|&t| t) {
            return Err(invalid(
                "sizing",
                "adaptive sizing derives the length from the tolerance; drop the target_* option",
            ));
        }
        if let Some(t) = self.threads {
            if t == 0 || t > 1024 {
                return Err(invalid("threads", "must be between 1 and 1024"));
            }
        }
        if self.max_output_faces == 0 {
            return Err(invalid("max_output_faces", "must be at least 1"));
        }
        Ok(())
    }
}
