//! The whole job as the CLI and the service run it, on bytes: detect the
//! format, read, build with repair, remesh, measure input and output, and
//! encode the result with split normals. Pure and synchronous, like the rest
//! of the core; the callers own files, sockets and threads.

use serde::{Deserialize, Serialize};

use std::sync::Arc;

use crate::features::FeatureOptions;
use crate::io::{self, Attribute, Attributes, Format, ReadOptions, WriteOptions};
use crate::mesh::{BuildError, Mesh, EDGE_FEATURE, EDGE_SEAM};
use crate::reference::Reference;
use crate::remesh::{self, Observer, RemeshError, RemeshOptions, RemeshReport};
use crate::stats::attributes::AttributeStats;
use crate::stats::{self, Headline, MeshStats, StatsOptions};
use crate::transfer::split_by_values;
use crate::trimesh::{position_key, TriMesh};

/// Area samples per side for the distance statistics of a job: the
/// benchmark's default, so that its `quality.py` measures at the same points.
pub const DISTANCE_SAMPLES: usize = 200_000;

/// Any failure of a job, layered by where it happened.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// Reading or writing the file failed.
    #[error(transparent)]
    Io(#[from] io::IoError),
    /// The triangles cannot form a mesh.
    #[error(transparent)]
    Build(#[from] BuildError),
    /// Remeshing failed or was cancelled.
    #[error(transparent)]
    Remesh(#[from] RemeshError),
}

/// A parsed and repaired input: its format and the job's [`Reference`],
/// which the remesher and the statistics share. It dereferences to the
/// reference (`input.mesh`, `input.source`, `input.repairs`).
#[derive(Clone, Debug)]
pub struct LoadedInput {
    /// The detected (or given) format.
    pub format: Format,
    /// The input as read, repaired, and (on first use) indexed, welded and
    /// feature-detected.
    pub reference: Arc<Reference>,
}

impl std::ops::Deref for LoadedInput {
    type Target = Reference;
    fn deref(&self) -> &Reference {
        &self.reference
    }
}

/// The input as a job with `options` uses it: under
/// [`remesh::NormalSource::Transfer`], an input with normals carries them as
/// an attribute too, so that the remesh samples them chart by chart and
/// keeps their hard edges as seams. Otherwise (also for an input shaded
/// flat, whose per-face normals say nothing a new surface could keep) the
/// input itself.
pub fn prepare(input: &LoadedInput, options: &RemeshOptions) -> LoadedInput {
    let source = &input.source;
    let carry = options.normals == remesh::NormalSource::Transfer
        && !source.normals.is_empty()
        && source.normals.len() == source.positions.len()
        && source.attributes.normals.is_empty()
        && !crate::features::normals::shaded_flat(source);
    if !carry {
        return input.clone();
    }
    let mut source = source.clone();
    source.attributes.normals = source
        .normals
        .iter()
        .map(|n| n.as_vec3().to_array())
        .collect();
    LoadedInput {
        format: input.format,
        reference: Arc::new(Reference::from_parts(
            source,
            input.mesh.clone(),
            input.repairs,
        )),
    }
}

/// Reads `bytes` (named `file_name` if known) and builds the repaired mesh.
pub fn load(
    bytes: &[u8],
    file_name: Option<&str>,
    format: Option<Format>,
    read: &ReadOptions,
) -> Result<LoadedInput, JobError> {
    let format = Format::detect(file_name, bytes, format)?;
    let imported = io::read(bytes, format, read)?;
    let (mesh, mut repairs) = Mesh::from_trimesh(&imported.mesh)?;
    repairs.ignored_primitives = imported.ignored_primitives;
    Ok(LoadedInput {
        format,
        reference: Arc::new(Reference::from_parts(imported.mesh, mesh, repairs)),
    })
}

/// Input and output statistics of a job.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobStats {
    /// The output's headline figures (edge-length histogram against the
    /// job's reference, valence deviation): the same figures as in
    /// `output`, first and in a small fixed block.
    pub headline: Headline,
    /// The input as read (welded, as the benchmark sees it; `repairs` says
    /// what was fixed before remeshing), measured against the same
    /// reference as the output: the target length L under uniform sizing,
    /// the local size field under adaptive sizing.
    pub input: MeshStats,
    /// The output, with its distance to the input.
    pub output: MeshStats,
    /// Texture coordinates and colours: what was kept or dropped, and how
    /// well seams, charts and the texture survived.
    #[serde(default)]
    pub attributes: AttributeStats,
    /// The input's connected parts and what became of them: remeshed, or,
    /// when smaller than `small_part_size` target lengths, kept as they
    /// were or dropped.
    #[serde(default)]
    pub parts: crate::remesh::PartsReport,
}

/// The result of [`run`].
#[derive(Clone, Debug)]
pub struct JobOutput {
    /// The remeshed surface, with per-vertex normals split along features.
    pub mesh: TriMesh,
    /// Per-element quality of `mesh` to write with it (empty unless the
    /// options ask for `quality_attributes`).
    pub attributes: Attributes,
    /// Input and output statistics.
    pub stats: JobStats,
    /// What the remesher did.
    pub report: RemeshReport,
}

/// Remeshes a loaded input and measures both sides.
pub fn run(
    input: &LoadedInput,
    options: &RemeshOptions,
    observer: &mut impl Observer,
) -> Result<JobOutput, JobError> {
    let input = &prepare(input, options);
    let remeshed = remesh_only(input, options, observer)?;
    let stats = measure(input, &remeshed, options);
    let attributes = if options.quality_attributes {
        quality_attributes(&remeshed, options)
    } else {
        Attributes::default()
    };
    Ok(JobOutput {
        mesh: remeshed.written,
        attributes,
        stats,
        report: remeshed.out.report,
    })
}

/// A remesh before measurement: the engine's output and the two triangle
/// forms of it that a job uses.
#[derive(Clone, Debug)]
pub struct Remeshed {
    /// The output as written: normals split along its feature edges.
    pub written: TriMesh,
    /// The output's triangles grouped by label, without normals: what the
    /// statistics measure (the faces in the order a reader of the file sees
    /// them).
    pub surface: TriMesh,
    /// The engine's output.
    pub out: remesh::RemeshOutput,
}

/// Remeshes a loaded input without measuring it.
pub fn remesh_only(
    input: &LoadedInput,
    options: &RemeshOptions,
    observer: &mut impl Observer,
) -> Result<Remeshed, JobError> {
    let out = remesh::remesh_reference(&input.reference, options, observer)?;
    let mut surface = out.mesh.to_trimesh();
    surface.group_faces_by_label();
    let features: Vec<[u32; 2]> = out
        .mesh
        .edges()
        .filter(|&e| out.mesh.edge_has_flag(e, EDGE_FEATURE))
        .map(|e| {
            let [a, b] = out.mesh.edge_vertices(e);
            [a.0, b.0]
        })
        .collect();
    let carried = !input.source.attributes.normals.is_empty();
    let mut written = if carried {
        surface.clone()
    } else {
        io::with_split_normals(&surface, options.feature_angle, &features)
    };
    if let Some(attrs) = input.source_attributes() {
        let seams: Vec<[u32; 2]> = out
            .mesh
            .edges()
            .filter(|&e| out.mesh.edge_has_flag(e, EDGE_SEAM))
            .map(|e| {
                let [a, b] = out.mesh.edge_vertices(e);
                [a.0, b.0]
            })
            .collect();
        let values = attrs.sample(&surface, &seams);
        let has_color = !input.source.attributes.colors.is_empty();
        written = split_by_values(&written, &values, attrs.layout(), has_color, carried);
        if carried {
            take_carried_normals(&mut written);
        }
    }
    written.appearance = input.source.appearance.clone();
    written.scene = input.source.scene.clone();
    Ok(Remeshed {
        written,
        surface,
        out,
    })
}

/// Moves the normals that `mesh` carries as an attribute into its
/// `normals`, unit length; a vertex whose sampled normal vanished (opposite
/// normals averaged) takes the normal of a face around it.
fn take_carried_normals(mesh: &mut TriMesh) {
    let carried = std::mem::take(&mut mesh.attributes.normals);
    let mut normals: Vec<glam::DVec3> = carried
        .iter()
        .map(|n| glam::Vec3::from_array(*n).as_dvec3().normalize_or_zero())
        .collect();
    for t in &mesh.triangles {
        let p = t.map(|v| mesh.positions[v as usize]);
        let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for &v in t {
            if normals[v as usize] == glam::DVec3::ZERO {
                normals[v as usize] = face;
            }
        }
    }
    mesh.normals = normals;
}

/// Input and output statistics of a finished remesh, both against the
/// job's reference (the target length L under uniform sizing, the size
/// field under adaptive sizing), the output with its distance to the input.
/// The input's welded view, spatial index and features come from its
/// [`Reference`], built once for both sides.
pub fn measure(input: &LoadedInput, remeshed: &Remeshed, options: &RemeshOptions) -> JobStats {
    let out = &remeshed.out;
    let adaptive = options.sizing == remesh::Sizing::Adaptive;
    let l = out.report.target_edge_length;
    let features = Some(FeatureOptions {
        preserve_features: options.preserve_features,
        feature_angle_deg: options.feature_angle,
        corner_angle_deg: options.corner_angle,
        // Fidelity is measured against every input crease, as the bench does.
        min_crease_length: 0.0,
        ..FeatureOptions::default()
    });
    let input_target =
        adaptive.then(|| source_targets(&input.source, input.surface(), &out.input_vertex_target));
    let input_stats = stats::compute_input(
        &input.reference,
        &StatsOptions {
            target_edge_length: (!adaptive).then_some(l),
            vertex_target: input_target.as_deref(),
            repairs: Some(input.repairs),
            features,
            ..Default::default()
        },
    );
    let output_stats = stats::compute(
        &remeshed.surface,
        &StatsOptions {
            target_edge_length: (!adaptive).then_some(l),
            prepared: Some(&input.reference),
            samples_per_side: DISTANCE_SAMPLES,
            vertex_target: adaptive.then_some(out.vertex_target.as_slice()),
            features,
            ..Default::default()
        },
    );
    let mut output_stats = output_stats;
    if let Some(e) = output_stats.edge_length.as_mut() {
        // Against L under uniform sizing, as the band itself.
        let target = |v: crate::mesh::VertexId| {
            if adaptive {
                out.vertex_target
                    .get(v.0 as usize)
                    .copied()
                    .unwrap_or(f64::NAN)
            } else {
                l
            }
        };
        e.split = Some(stats::forced::band_split(
            &out.mesh,
            target,
            options.corner_angle,
        ));
    }
    let mut attributes = stats::attributes::compute(
        &input.source,
        input.source_attributes().map(|a| &**a),
        &remeshed.written,
        l,
    );
    attributes.normals = if !input.source.attributes.normals.is_empty() {
        "transferred".into()
    } else if options.normals == remesh::NormalSource::Transfer {
        if input.source.normals.is_empty() {
            "recomputed: the input has no normals to transfer".into()
        } else {
            "recomputed: the input is shaded flat (each face its own normal), which a new surface cannot keep".into()
        }
    } else {
        "recomputed".into()
    };
    JobStats {
        attributes,
        parts: out.report.parts,
        headline: output_stats.headline(),
        input: input_stats,
        output: output_stats,
    }
}

/// The target at each position of `source`, from `targets` given per
/// position of `repaired`, matched by coordinates: the repaired input keeps
/// the positions it read, and the written output keeps the remesher's
/// (normals only split them). Positions without a match (used by no face
/// the repair kept) get the mean target, so that they shift no figure.
fn source_targets(source: &TriMesh, repaired: &TriMesh, targets: &[f64]) -> Vec<f64> {
    let by_position: std::collections::HashMap<[u64; 3], f64> = repaired
        .positions
        .iter()
        .zip(targets)
        .map(|(&p, &t)| (position_key(p), t))
        .collect();
    let mean = targets.iter().sum::<f64>() / targets.len().max(1) as f64;
    source
        .positions
        .iter()
        .map(|&p| by_position.get(&position_key(p)).copied().unwrap_or(mean))
        .collect()
}

/// Encodes a result mesh in `format`, with normals.
pub fn encode(mesh: &TriMesh, format: Format) -> Result<Vec<u8>, JobError> {
    Ok(io::write(mesh, format, &WriteOptions::default())?)
}

/// Encodes a result mesh in `format`, with normals and `attributes` (glTF,
/// GLB and PLY only, when there are any).
pub fn encode_with(
    mesh: &TriMesh,
    format: Format,
    attributes: &Attributes,
) -> Result<Vec<u8>, JobError> {
    Ok(io::write_with_attributes(
        mesh,
        format,
        &WriteOptions::default(),
        attributes,
    )?)
}

/// Encodes a result mesh as the files `format` needs, named after `stem`:
/// the model first, then its companions (an OBJ's `.mtl` and images).
pub fn encode_files(
    mesh: &TriMesh,
    format: Format,
    attributes: &Attributes,
    stem: &str,
) -> Result<Vec<(String, Vec<u8>)>, JobError> {
    Ok(io::write_files(
        mesh,
        format,
        &WriteOptions::default(),
        attributes,
        stem,
    )?)
}

/// The `quality_attributes` of a remesh's written mesh: per face `quality_min_angle` (smallest
/// angle, degrees) and `quality_edge_ratio` (mean edge length over the
/// mean target of its corners: L under uniform sizing, the size field
/// under adaptive sizing, as the statistics measure), per vertex `valence`.
pub fn quality_attributes(remeshed: &Remeshed, options: &RemeshOptions) -> Attributes {
    let (mesh, out) = (&remeshed.written, &remeshed.out);
    // The grouped surface keeps the engine's positions in order: only the
    // faces are regrouped.
    let targets = (options.sizing == remesh::Sizing::Adaptive)
        .then(|| source_targets(mesh, &remeshed.surface, &out.vertex_target));
    let q = stats::element_quality(mesh, out.report.target_edge_length, targets.as_deref());
    let named = |name: &str, values: Vec<f32>| Attribute {
        name: name.to_string(),
        values,
    };
    Attributes {
        vertex: vec![named("valence", q.vertex_valence)],
        face: vec![
            named("quality_min_angle", q.face_min_angle),
            named("quality_edge_ratio", q.face_edge_ratio),
        ],
    }
}
