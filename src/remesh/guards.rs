//! The guard thresholds of every pass, in one place: what a split,
//! collapse, flip or vertex move may do to the faces around it. Each pass
//! has its own names because each has its own job; `docs/tuning.md` says
//! why each value is what it is.

/// A collapse may turn a one-ring face's normal by at most 45° (as a cosine):
/// a collapse moves a vertex by up to an edge, so it may bend more than a
/// relaxation step, but not enough to fold a ridge.
pub(super) const COLLAPSE_MAX_NORMAL_TURN_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;
/// A collapse may not leave a face with quality below this unless the
/// one-ring's worst face (the two removed faces included) was already worse:
/// it keeps collapses from trading short edges for needles.
pub(super) const COLLAPSE_MIN_QUALITY: f64 = 0.2;

/// Largest dihedral angle between the two faces of a flippable edge (20°),
/// as a cosine: a flip must not change the shape of the surface.
pub(super) const FLIP_MAX_DIHEDRAL_COS: f64 = 0.939_692_620_785_908_4;
/// A valence flip may not create a face worse than this unless the old pair
/// was already worse: valence is never bought with a bad triangle.
pub(super) const FLIP_MIN_QUALITY: f64 = 0.3;

/// A vertex move (relaxation, projection, sliver repair) may turn a face's
/// normal by at most 60° per step (as a cosine); larger turns are folds.
pub(super) const MOVE_MAX_NORMAL_TURN_COS: f64 = 0.5;
/// A vertex move may not leave a face with quality below this unless it was
/// already worse: the loosest quality guard, because moves are what repairs
/// quality, and a tight guard would freeze them.
pub(super) const MOVE_MIN_QUALITY: f64 = 0.05;

/// Cosine of the smallest angle (30°) below which the sliver repair works
/// on a triangle.
pub(super) const SLIVER_ANGLE_COS: f64 = 0.866_025_403_784_438_6;
/// Largest distance, in units of the local target, between the old and the
/// new edge of a sliver-repair flip that fails the dihedral test: a tenth
/// of an edge, below the typical distance of the output to the input.
pub(super) const SLIVER_SAG: f64 = 0.1;
/// Edges at a vertex that a sliver-repair move may push out of the length band.
pub(super) const SHAPE_BAND_SLACK: usize = 1;
/// Sweeps of the sliver repair's moves at most.
pub(super) const SHAPE_ROUNDS: usize = 3;
