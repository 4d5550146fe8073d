//! Incremental isotropic remeshing after Botsch & Kobbelt, "A remeshing
//! approach to multiresolution modeling" (SGP 2004), with the guards and
//! feature handling of Dunyach et al. 2013 and CGAL's implementation notes.
//!
//! [`remesh`] runs, for each iteration: split long edges and the edges whose
//! midpoint lies far off the input (a chord across a rounded ridge), collapse
//! short edges, flip toward valence 6 (4 on the boundary), collapse the irregular
//! vertex pairs flips cannot fix and flip again, tangential relaxation, and
//! projection onto the input surface or its feature lines; after the last
//! iteration a sliver repair flips the longest edge of triangles still below
//! 30° where that helps, moves their vertices to where their one-ring's
//! smallest angle is largest, and flips once more; on an input with texture
//! coordinates, a texture-space guard then mends the faces that the
//! attribute transfer would fold in UV space (`uv.rs`). Topology lives
//! in [`crate::mesh`]; this module only decides *which* edges and vertices to
//! change. One pass per file: `split.rs`, `collapse.rs`, `flip.rs`,
//! `relax.rs` (relaxation and projection share the guarded move in
//! `relax.rs`), and the final sliver repair in `repair.rs`; the guard
//! thresholds of all of them live in `guards.rs`.
//!
//! Every pass is deterministic: topological passes walk handles in index
//! order, and the parallel passes are pure per-vertex maps applied at once,
//! so the output is byte-identical whatever the thread count.

mod collapse;
mod flip;
mod guards;
mod options;
mod parts;
mod relax;
mod repair;
mod split;
mod state;
mod uv;

pub use options::{
    estimated_faces, FeatureSource, NormalSource, RemeshOptions, Sizing, SmallParts,
    DEFAULT_GRADATION, DEFAULT_ITERATIONS, DEFAULT_MAX_OUTPUT_FACES, DEFAULT_MIN_CREASE_LENGTH,
    DEFAULT_RELAXATION_STEPS, DEFAULT_SMALL_PART_SIZE,
};
pub use parts::PartsReport;

use serde::{Deserialize, Serialize};
use std::sync::Mutex;
use std::time::Instant;

use crate::mesh::Mesh;
use crate::reference::Reference;
use state::State;

/// The passes of one iteration, reported through [`Observer::progress`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Pass {
    /// Building the spatial index, features and sizing on the input.
    Prepare,
    /// Splitting long edges.
    Split,
    /// Collapsing short edges.
    Collapse,
    /// Flipping edges toward regular valence (with the valence-driven collapses).
    Flip,
    /// Tangential relaxation.
    Relax,
    /// Projection onto the input.
    Project,
}

impl Pass {
    /// The pass's index within an iteration (Prepare counts as 0).
    fn order(self) -> f64 {
        match self {
            Pass::Prepare | Pass::Split => 0.0,
            Pass::Collapse => 1.0,
            Pass::Flip => 2.0,
            Pass::Relax => 3.0,
            Pass::Project => 4.0,
        }
    }
}

/// Where a running remesh is.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    /// Current iteration, from 1 (0 while preparing).
    pub iteration: u32,
    /// Total iterations.
    pub iterations: u32,
    /// Current pass.
    pub pass: Pass,
    /// Overall fraction done, in [0, 1].
    pub fraction: f64,
}

/// Receives progress and may cancel a running remesh. Checked between passes
/// and every few thousand operations inside a pass, so cancellation takes
/// effect within a fraction of a second. `Send`, because the check may run
/// on any thread of the job's pool.
pub trait Observer: Send {
    /// Called at the start of every pass.
    fn progress(&mut self, _progress: &Progress) {}
    /// Return true to stop the remesh with [`RemeshError::Cancelled`].
    fn is_cancelled(&self) -> bool {
        false
    }
}

/// An observer that ignores progress and never cancels.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoObserver;
impl Observer for NoObserver {}

/// Why a remesh did not produce a mesh.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RemeshError {
    /// An option is out of range or contradicts another.
    #[error("invalid option `{field}`: {message}")]
    InvalidOption {
        /// The offending field, by its public name.
        field: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// The input has no faces.
    #[error("the input mesh has no faces")]
    EmptyInput,
    /// The target length would create more faces than allowed.
    #[error("the target edge length {target_edge_length} would create about {} faces, more than the limit of {limit}", face_count_text(*.estimated_faces))]
    TooManyFaces {
        /// The resolved target length.
        target_edge_length: f64,
        /// Estimated faces, area / (√3/4 · L²) (infinite for a zero length).
        estimated_faces: f64,
        /// The configured limit.
        limit: u64,
    },
    /// The observer asked to stop.
    #[error("remeshing was cancelled")]
    Cancelled,
    /// A bug: an invariant broke. Please report it with the input.
    #[error("internal error (a bug): {0}")]
    Internal(String),
}

/// A face estimate for a message: whole below 10¹⁵, in scientific notation
/// above (a `u64` would saturate at 1.8·10¹⁹ and read as a real count),
/// and "unboundedly many" when not finite (a zero length).
pub fn face_count_text(n: f64) -> String {
    if !n.is_finite() {
        "unboundedly many".to_string()
    } else if n < 1e15 {
        format!("{}", n.round())
    } else {
        format!("{n:.2e}")
    }
}

/// Operation counts and pass times of one iteration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct IterationReport {
    /// Edges split.
    pub splits: u64,
    /// Edges collapsed, for length and for valence.
    pub collapses: u64,
    /// Edges flipped.
    pub flips: u64,
    /// Vertex moves in relaxation that were halved at least once by the
    /// guard, when relaxation runs without projection.
    pub relax_moves_limited: u64,
    /// Vertex moves in projection that were halved at least once by the
    /// guard. With both passes on (the default), each vertex makes one
    /// guarded move to the projection of its relaxed position, counted here.
    pub project_moves_limited: u64,
    /// Faces at the end of the iteration.
    pub faces: u64,
    /// Seconds per pass in this iteration (`prepare` and `repair` are 0:
    /// they run before the first and after the last iteration, and count
    /// only in the report's [`RemeshReport::seconds`]).
    #[serde(default)]
    pub seconds: PassTimes,
}

/// Seconds spent in each pass: per iteration in [`IterationReport::seconds`],
/// summed over the run in [`RemeshReport::seconds`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PassTimes {
    /// Building the index, features and sizing.
    pub prepare: f64,
    /// Splitting.
    pub split: f64,
    /// Collapsing.
    pub collapse: f64,
    /// Flipping, including the valence-driven collapses.
    pub flip: f64,
    /// Relaxation.
    pub relax: f64,
    /// Projection.
    pub project: f64,
    /// The sliver repair after the last iteration (0 in every iteration's
    /// own times).
    #[serde(default)]
    pub repair: f64,
}

impl PassTimes {
    /// The time spent in each pass since `earlier` was taken.
    fn since(&self, earlier: &PassTimes) -> PassTimes {
        PassTimes {
            prepare: self.prepare - earlier.prepare,
            split: self.split - earlier.split,
            collapse: self.collapse - earlier.collapse,
            flip: self.flip - earlier.flip,
            relax: self.relax - earlier.relax,
            project: self.project - earlier.project,
            repair: self.repair - earlier.repair,
        }
    }
}

/// What a remesh did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RemeshReport {
    /// The resolved target edge length L under uniform sizing (the nominal
    /// length, also with `refine_curved`); the mean target under adaptive sizing.
    pub target_edge_length: f64,
    /// Smallest and largest target length. Under uniform sizing they are L
    /// and L, or down to 9/10·L where `refine_curved` shortens edges on tight
    /// curves.
    pub target_range: [f64; 2],
    /// Feature edges found on the input.
    pub feature_edges: u64,
    /// Corners found on the input.
    pub corners: u64,
    /// Feature lines found on the input.
    pub feature_lines: u64,
    /// Feature-line vertices of the input kept fixed, like corners, because
    /// the line turns there by more than an output chord may cut (see the
    /// turn rule in the remesher's state).
    #[serde(default)]
    pub fixed_turns: u64,
    /// Flips of the final sliver repair (see the flip pass), after the last
    /// iteration.
    #[serde(default)]
    pub repair_flips: u64,
    /// Vertices moved by the final shape pass (see the relaxation pass).
    #[serde(default)]
    pub repair_moves: u64,
    /// The texture-space guard after the last iteration (inputs with
    /// texture coordinates only).
    #[serde(default)]
    pub uv_repair: UvRepairReport,
    /// The input's connected parts, and which were remeshed, kept as they
    /// were or dropped (see [`RemeshOptions::small_parts`]).
    #[serde(default)]
    pub parts: PartsReport,
    /// Counts per iteration.
    pub iterations: Vec<IterationReport>,
    /// Time per pass.
    pub seconds: PassTimes,
    /// Total wall time in seconds.
    pub total_seconds: f64,
}

/// What the texture-space guard found and did: output faces flipped or
/// degenerate in texture space, as the attribute transfer samples them,
/// before and after its local edits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct UvRepairReport {
    /// Faces invalid in texture space before the guard.
    pub found: u64,
    /// Of those, faces over input that is itself degenerate in texture
    /// space (a region mapped to a point or a line), left alone.
    #[serde(default)]
    pub inherited: u64,
    /// Moves, flips and collapses it made.
    pub edits: u64,
    /// Faces still invalid after it, the inherited ones included.
    pub left: u64,
}

/// The remeshed surface and its report.
#[derive(Clone, Debug)]
pub struct RemeshOutput {
    /// The new mesh, compacted.
    pub mesh: Mesh,
    /// Per-vertex target edge length of the output (constant when uniform).
    pub vertex_target: Vec<f64>,
    /// The target edge length at each input vertex, as the sizing field
    /// assigned it before the first pass, in the vertex order of the
    /// input's [`Mesh::to_trimesh`]: what the input is measured against.
    /// Adaptive sizing only; empty under uniform sizing, whose reference is L.
    pub input_vertex_target: Vec<f64>,
    /// What was done.
    pub report: RemeshReport,
}

/// Remeshes `input` toward the target edge length of `options`.
///
/// The output is manifold, oriented like the input, has the input's Euler
/// characteristic and boundary-loop count, and has no degenerate or inverted
/// faces. Features (creases, corners, boundaries, label borders) are kept
/// and resampled.
pub fn remesh(
    input: &Mesh,
    options: &RemeshOptions,
    observer: &mut impl Observer,
) -> Result<RemeshOutput, RemeshError> {
    options.validate()?;
    if input.face_count() == 0 {
        return Err(RemeshError::EmptyInput);
    }
    remesh_reference(&Reference::from_mesh(input.clone()), options, observer)
}

/// [`remesh`] of a job's [`Reference`]: the remesher uses its repaired mesh
/// and its spatial index (building the index if nobody has yet), so that the
/// statistics that follow reuse them.
pub fn remesh_reference(
    input: &Reference,
    options: &RemeshOptions,
    observer: &mut impl Observer,
) -> Result<RemeshOutput, RemeshError> {
    options.validate()?;
    if input.mesh.face_count() == 0 {
        return Err(RemeshError::EmptyInput);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads.unwrap_or(0))
        .build()
        .map_err(|e| RemeshError::Internal(format!("thread pool: {e}")))?;
    run(input, options, observer, pool)
}

fn run(
    input: &Reference,
    options: &RemeshOptions,
    observer: &mut impl Observer,
    pool: rayon::ThreadPool,
) -> Result<RemeshOutput, RemeshError> {
    let start = Instant::now();
    let iterations = options.iterations;
    // Behind a mutex so that the cancellation check is `Sync` and can be
    // shared with the pool; it is taken between units of work only.
    let observer = Mutex::new(observer);
    let lock = || observer.lock().unwrap_or_else(|p| p.into_inner());
    let is_cancelled = || lock().is_cancelled();
    let cancel = Cancel {
        asked: &is_cancelled,
    };
    // Reports the pass about to run, then honours a cancel request.
    let enter = |iteration: u32, pass: Pass| -> Result<(), RemeshError> {
        lock().progress(&Progress::at(iteration, iterations, pass));
        cancel.now()
    };

    enter(0, Pass::Prepare)?;
    let mut st = State::new(input, options, pool, cancel)?;
    // Only adaptive jobs measure their input against the size field; uniform
    // ones measure against L and need no copy.
    let input_vertex_target = if options.sizing == Sizing::Adaptive {
        st.size.clone()
    } else {
        Vec::new()
    };
    let mut report = RemeshReport::of_input(&st);
    report.seconds.prepare = start.elapsed().as_secs_f64();

    // Renumbered in the first iteration at the latest (see State::renumber).
    let mut renumbered = false;
    for it in 1..=iterations {
        let before = report.seconds;
        let (mut ir, split_renumbered) =
            iteration(&mut st, options, &mut report.seconds, &|pass| {
                enter(it, pass)
            })?;
        renumbered |= split_renumbered;
        if it == 1 && !renumbered {
            st.renumber();
            renumbered = true;
        }
        ir.seconds = report.seconds.since(&before);
        report.iterations.push(ir);
        debug_assert!(st.mesh.validate().is_ok(), "{:?}", st.mesh.validate());
    }
    if options.flip && iterations > 0 {
        // Part of the last iteration's progress: no new report, so the
        // fraction stays monotone.
        cancel.now()?;
        (report.repair_flips, report.repair_moves) =
            timed(&mut report.seconds.repair, || repair::final_repair(&mut st))?;
    }
    if let Some(attrs) = input.source_attributes().filter(|_| iterations > 0) {
        cancel.now()?;
        let r = timed(&mut report.seconds.repair, || uv::untangle(&mut st, attrs))?;
        report.uv_repair = UvRepairReport {
            found: r.found,
            inherited: r.inherited,
            edits: r.edits,
            left: r.left,
        };
    }
    let (mesh, vertex_target) = st.finish();
    mesh.validate()
        .map_err(|e| RemeshError::Internal(e.to_string()))?;
    report.total_seconds = start.elapsed().as_secs_f64();
    Ok(RemeshOutput {
        mesh,
        vertex_target,
        input_vertex_target,
        report,
    })
}

/// One iteration of Botsch & Kobbelt: split long edges, collapse short
/// ones, flip toward valence 6, then relax and project. A split pass that
/// adds more than a quarter of the faces renumbers the mesh at once; the
/// second value says whether it did.
fn iteration(
    st: &mut State,
    options: &RemeshOptions,
    t: &mut PassTimes,
    enter: &dyn Fn(Pass) -> Result<(), RemeshError>,
) -> Result<(IterationReport, bool), RemeshError> {
    let mut ir = IterationReport::default();
    let mut renumbered = false;
    if options.split {
        enter(Pass::Split)?;
        ir.splits = timed(&mut t.split, || {
            let n = split::split_long_edges(st)? + split::split_deviating_edges(st)?;
            if n as usize * 4 > st.mesh.face_count() {
                st.renumber();
                renumbered = true;
            }
            Ok(n)
        })?;
    }
    if options.collapse {
        enter(Pass::Collapse)?;
        ir.collapses = timed(&mut t.collapse, || collapse::collapse_short_edges(st))?;
    }
    if options.flip {
        enter(Pass::Flip)?;
        let (flips, collapses) = timed(&mut t.flip, || equalize_valences(st, options))?;
        ir.flips = flips;
        ir.collapses += collapses;
    }
    smooth(st, options, &mut ir, t, enter)?;
    ir.faces = st.mesh.face_count() as u64;
    Ok((ir, renumbered))
}

/// Runs `pass` and adds its wall time to `seconds`.
fn timed<T>(
    seconds: &mut f64,
    pass: impl FnOnce() -> Result<T, RemeshError>,
) -> Result<T, RemeshError> {
    let t = Instant::now();
    let out = pass();
    *seconds += t.elapsed().as_secs_f64();
    out
}

/// Pass 3: flips toward regular valence, then, when collapses are on, the
/// valence-driven collapses of the irregular pairs flips cannot fix, and
/// flips again around the merged vertices. Returns (flips, collapses).
fn equalize_valences(st: &mut State, options: &RemeshOptions) -> Result<(u64, u64), RemeshError> {
    let mut valences = flip::Valences::of(st);
    let mut flips = flip::flip_edges(st, &mut valences, None)?;
    let mut collapses = 0;
    if options.collapse {
        let (n, seed) = collapse::collapse_for_valence(st, &mut valences)?;
        collapses = n;
        if n > 0 {
            flips += flip::flip_edges(st, &mut valences, Some(seed))?;
        }
    }
    Ok((flips, collapses))
}

/// Passes 4 and 5, `relaxation_steps` times: with both on, one guarded move
/// to the projection of the relaxed point; otherwise whichever is on.
fn smooth(
    st: &mut State,
    options: &RemeshOptions,
    ir: &mut IterationReport,
    t: &mut PassTimes,
    enter: &dyn Fn(Pass) -> Result<(), RemeshError>,
) -> Result<(), RemeshError> {
    let relax = options.relax && options.relaxation_steps > 0;
    for _ in 0..options.relaxation_steps.max(1) {
        if relax && options.project {
            enter(Pass::Relax)?;
            enter(Pass::Project)?;
            let relaxed = timed(&mut t.relax, || Ok(relax::relax_targets(st)))?;
            ir.project_moves_limited +=
                timed(&mut t.project, || Ok(relax::project_points(st, &relaxed)))?;
            continue;
        }
        if relax {
            enter(Pass::Relax)?;
            ir.relax_moves_limited += timed(&mut t.relax, || Ok(relax::relax_tangentially(st)))?;
        }
        if options.project {
            enter(Pass::Project)?;
            ir.project_moves_limited += timed(&mut t.project, || Ok(relax::project_to_input(st)))?;
        }
    }
    Ok(())
}

/// How often the passes ask the observer whether to stop: once per this
/// many units of work (edges, faces or vertices visited), a fraction of a
/// millisecond apart, so that a cancel takes effect well within a second
/// without the check costing anything measurable.
const CANCEL_STRIDE: u64 = 4096;

/// The one cancellation check every pass shares.
#[derive(Clone, Copy)]
pub(super) struct Cancel<'a> {
    asked: &'a (dyn Fn() -> bool + Sync),
}

impl Cancel<'_> {
    /// Asks now: `Err(Cancelled)` when the observer wants to stop.
    pub(super) fn now(&self) -> Result<(), RemeshError> {
        if (self.asked)() {
            Err(RemeshError::Cancelled)
        } else {
            Ok(())
        }
    }

    /// Asks when `work` (a pass's running count) is a multiple of the stride.
    pub(super) fn every(&self, work: u64) -> Result<(), RemeshError> {
        if work % CANCEL_STRIDE == 0 {
            self.now()
        } else {
            Ok(())
        }
    }
}

impl Progress {
    /// The progress at the start of `pass` in `iteration` (0 while preparing).
    fn at(iteration: u32, iterations: u32, pass: Pass) -> Progress {
        let fraction = if pass == Pass::Prepare {
            0.0
        } else if iterations == 0 {
            1.0
        } else {
            ((iteration.max(1) - 1) as f64 + pass.order() / 5.0) / iterations as f64
        };
        Progress {
            iteration,
            iterations,
            pass,
            fraction,
        }
    }
}

impl RemeshReport {
    /// A report holding what preparation found on the input.
    fn of_input(st: &State) -> RemeshReport {
        RemeshReport {
            target_edge_length: st.mean_target(),
            target_range: st.target_range(),
            feature_edges: st.features.edges().len() as u64,
            corners: st.features.corners().len() as u64,
            feature_lines: st.features.lines().len() as u64,
            fixed_turns: st.fixed_turns,
            parts: st.parts,
            ..Default::default()
        }
    }
}
