//! The working state of a remesh: the mesh being changed, the reference
//! (input surface index, feature set, sizing field) and the per-element data
//! that follows the operators: each vertex's feature kind, its projection
//! hints and target size, and each edge's feature line, all carried along
//! when the mesh is renumbered for locality. Uniform sizing with
//! `refine_curved` builds the adaptive field of [`crate::sizing`] at the
//! chord tolerance [`CURVED_TOLERANCE`]·L, clamped to [`CURVED_MIN_EDGE`]·L, L].
//! Under uniform sizing the collapse threshold stays at 4/5·L whatever the
//! local target ([`State::collapse_target`]): refinement may shorten edges,
//! but never below the band's lower bound; finer is adaptive sizing.

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use super::parts::PartsReport;
use super::{Cancel, FeatureSource, RemeshError, RemeshOptions, Sizing};
use crate::bvh::SurfaceIndex;
use crate::curvature;
use crate::features::anchors::{anchor_tips, anchor_turns, Neighborhood};
use crate::features::{
    detect_features_with_seams, EdgeFlags, FeatureOptions, FeatureSet, VertexKind,
};
use crate::mesh::{
    scatter, CollapseResult, EdgeId, HalfedgeId, Handle, Mesh, SplitResult, VertexId, EDGE_FEATURE,
    EDGE_SEAM,
};
use crate::reference::Reference;
use crate::sizing::{SizingField, SizingOptions};
use crate::topology::Csr;
use crate::trimesh::TriMesh;

pub(super) use crate::features::anchors::{CORNER, SMOOTH};
/// Edge line tag: not a feature edge.
pub(super) const NO_LINE: u32 = u32::MAX;

pub(super) use crate::sizing::{COLLAPSE_FACTOR, SPLIT_FACTOR};

pub(super) struct State<'c> {
    pub mesh: Mesh,
    /// The closest-point index over the input, shared with the job's
    /// [`Reference`].
    pub index: Arc<SurfaceIndex>,
    pub features: FeatureSet,
    pub sizing: Option<SizingField>,
    /// Per vertex: [`SMOOTH`], [`CORNER`] or the feature line id.
    pub kind: Vec<u32>,
    /// Per vertex: the input face its projection last landed on.
    pub hint_face: Vec<u32>,
    /// Per vertex on a line: the line segment its projection last landed on.
    pub hint_seg: Vec<u32>,
    /// Per vertex: the target edge length there.
    pub size: Vec<f64>,
    /// The uniform target L, when sizing is uniform.
    pub uniform: Option<f64>,
    /// Per edge: the feature line it lies on, or [`NO_LINE`].
    pub edge_line: Vec<u32>,
    /// Per input face: unit normal.
    pub input_normals: Vec<DVec3>,
    /// Faces around each input vertex (CSR offsets into `vertex_faces`).
    pub vertex_face_start: Vec<u32>,
    /// Faces around each input vertex, grouped by vertex.
    pub vertex_faces: Vec<u32>,
    /// Per input face `[a, b, c]`: the faces across its edges `ab`, `bc` and
    /// `ca`, or `u32::MAX` on a boundary (one of them where the edge is
    /// non-manifold).
    pub face_neighbors: Vec<[u32; 3]>,
    /// Per input face: its part, the faces connected to it across edges
    /// (across label borders only when features are off), so that a vertex
    /// is projected only onto the part it came from, never onto another
    /// part passing through it. `None` when the input is one part.
    pub face_part: Option<Vec<u32>>,
    /// The input's parts and what became of the small ones.
    pub parts: PartsReport,
    /// Feature-line vertices kept fixed where the input's line turns.
    pub fixed_turns: u64,
    /// The worker pool of the parallel passes.
    pub pool: std::sync::Arc<rayon::ThreadPool>,
    /// The one cancellation check the passes share.
    pub cancel: Cancel<'c>,
}

/// Everything of [`State`] but the pool, built inside the pool.
pub(super) struct PartialState {
    mesh: Mesh,
    index: Arc<SurfaceIndex>,
    features: FeatureSet,
    sizing: Option<SizingField>,
    kind: Vec<u32>,
    hint_face: Vec<u32>,
    hint_seg: Vec<u32>,
    size: Vec<f64>,
    uniform: Option<f64>,
    edge_line: Vec<u32>,
    input_normals: Vec<DVec3>,
    vertex_face_start: Vec<u32>,
    vertex_faces: Vec<u32>,
    face_neighbors: Vec<[u32; 3]>,
    face_part: Option<Vec<u32>>,
    parts: PartsReport,
    fixed_turns: u64,
}

impl<'c> State<'c> {
    pub fn new(
        input: &Reference,
        options: &RemeshOptions,
        pool: rayon::ThreadPool,
        cancel: Cancel<'c>,
    ) -> Result<Self, RemeshError> {
        let p = pool.install(|| Self::prepare(input, options, &cancel))?;
        Ok(Self {
            mesh: p.mesh,
            index: p.index,
            features: p.features,
            sizing: p.sizing,
            kind: p.kind,
            hint_face: p.hint_face,
            hint_seg: p.hint_seg,
            size: p.size,
            uniform: p.uniform,
            edge_line: p.edge_line,
            input_normals: p.input_normals,
            vertex_face_start: p.vertex_face_start,
            vertex_faces: p.vertex_faces,
            face_neighbors: p.face_neighbors,
            face_part: p.face_part,
            parts: p.parts,
            fixed_turns: p.fixed_turns,
            pool: std::sync::Arc::new(pool),
            cancel,
        })
    }

    fn prepare(
        input: &Reference,
        options: &RemeshOptions,
        cancel: &Cancel,
    ) -> Result<PartialState, RemeshError> {
        // The reference's mesh is compact, so its surface is `mesh`'s
        // triangles, vertex for vertex.
        let mut mesh = input.mesh.clone();
        let tm = input.surface();
        let diag = tm.bbox_diagonal();
        let area = tm.area();
        let uniform_l = (options.sizing == Sizing::Uniform).then(|| {
            options
                .uniform_target(diag, area, || input.mean_edge_length())
                .0
        });
        // A uniform target's estimate needs no field: refuse before any work.
        if let Some(l) = uniform_l {
            check_estimate(area, l, options.max_output_faces)?;
        }
        // The spatial index and the input's face adjacency need nothing of
        // the features or the sizing, so they are built beside them: the BVH
        // build is serial, and the other side's loops fill the second core.
        // Authored hard edges join the attribute seams as features that no
        // crease filter drops; `normals` alone turns the dihedral test off
        // where the input has hard edges to go by.
        let hard = if options.preserve_features && options.features != FeatureSource::Angle {
            input.surface_hard_edges()
        } else {
            &[]
        };
        let seams: std::borrow::Cow<[[u32; 2]]> = if hard.is_empty() {
            std::borrow::Cow::Borrowed(input.surface_seams())
        } else {
            std::borrow::Cow::Owned([input.surface_seams(), hard].concat())
        };
        let normals_only = options.features == FeatureSource::Normals && !hard.is_empty();
        let feature_options = normals_only.then(|| RemeshOptions {
            feature_angle: 180.0,
            ..options.clone()
        });
        let feature_options = feature_options.as_ref().unwrap_or(options);
        let ((index, (vertex_face_start, vertex_faces), face_neighbors), reference) = rayon::join(
            || {
                let index = Arc::clone(input.index());
                let csr = vertex_face_csr(tm);
                let neighbors = crate::topology::face_neighbors(&tm.triangles, tm.positions.len());
                (index, csr, neighbors)
            },
            || {
                Derived::build(
                    &mesh,
                    tm,
                    &seams,
                    feature_options,
                    Scale {
                        uniform_l,
                        diag,
                        area,
                    },
                    cancel,
                )
            },
        );
        let Derived {
            features,
            sizing,
            size,
            kind,
            hint_seg,
            fixed_turns,
        } = reference?;
        cancel.now()?;
        let mut kind = kind;
        let unit = uniform_l.unwrap_or_else(|| options.adaptive_sizing(diag).min_edge_length);
        let parts = super::parts::apply(&mut mesh, &mut kind, unit, options);
        let nv = mesh.vertex_capacity();
        let mut hint_face = vec![0u32; nv];
        for f in mesh.faces() {
            for v in mesh.face_vertices(f) {
                hint_face[v.idx()] = f.0;
            }
        }
        let mut edge_line = vec![NO_LINE; mesh.edge_capacity()];
        for (e, line) in edge_line.iter_mut().enumerate() {
            let [a, b] = mesh.edge_vertices(EdgeId(e as u32));
            if let Some(l) = features.edge_line(a.0, b.0) {
                *line = l;
                mesh.edge_flags[EdgeId(e as u32)] |= EDGE_FEATURE;
                let seam = features
                    .edge_id(a.0, b.0)
                    .is_some_and(|id| features.edge_flags(id).contains(EdgeFlags::SEAM));
                if seam {
                    mesh.edge_flags[EdgeId(e as u32)] |= EDGE_SEAM;
                }
            }
        }
        let input_normals = (0..index.triangle_count() as u32)
            .into_par_iter()
            .map(|f| index.face_normal(f))
            .collect();
        let face_part = face_parts(tm, &face_neighbors, options.preserve_features);
        Ok(PartialState {
            parts,
            face_part,
            face_neighbors,
            fixed_turns,
            vertex_face_start,
            vertex_faces,
            mesh,
            index,
            features,
            sizing,
            kind,
            hint_face,
            hint_seg,
            size,
            uniform: uniform_l,
            edge_line,
            input_normals,
        })
    }

    /// Mean target length over the vertices.
    pub fn mean_target(&self) -> f64 {
        if let Some(l) = self.uniform {
            return l;
        }
        self.size.iter().sum::<f64>() / self.size.len().max(1) as f64
    }

    /// Smallest and largest target length.
    pub fn target_range(&self) -> [f64; 2] {
        self.size
            .iter()
            .fold([f64::INFINITY, 0.0f64], |[lo, hi], &s| {
                [lo.min(s), hi.max(s)]
            })
    }

    /// The target length for edge `a`–`b`: the mean of the endpoint sizes.
    #[inline]
    pub fn edge_target(&self, a: VertexId, b: VertexId) -> f64 {
        0.5 * (self.size[a.idx()] + self.size[b.idx()])
    }

    /// The length below which edge `a`–`b` is collapsed, over
    /// [`COLLAPSE_FACTOR`]: L under uniform sizing (a uniform remesh gives
    /// edges of at least 4/5·L, also where curvature refinement lowered the
    /// target), the local target under adaptive sizing.
    #[inline]
    pub fn collapse_target(&self, a: VertexId, b: VertexId) -> f64 {
        self.uniform.unwrap_or_else(|| self.edge_target(a, b))
    }

    /// Runs `f` on every live edge in parallel, in the worker pool, and
    /// returns the `Some` results in edge order (the candidate scans of the
    /// topological passes).
    pub fn par_edges<T: Send>(&self, f: impl Fn(EdgeId) -> Option<T> + Sync + Send) -> Vec<T> {
        let m = &self.mesh;
        self.pool.install(|| {
            (0..m.edge_capacity() as u32)
                .into_par_iter()
                .map(EdgeId)
                .filter(|&e| !m.is_edge_deleted(e))
                .filter_map(&f)
                .collect()
        })
    }

    /// The feature line of edge `e`, if it is a feature edge.
    #[inline]
    pub fn line_of(&self, e: EdgeId) -> Option<u32> {
        let l = self.edge_line[e.idx()];
        (l != NO_LINE).then_some(l)
    }

    /// Splits `e` at `p`, placing the new vertex on `e`'s feature line when it
    /// has one, and extends the per-element data.
    pub fn split(&mut self, e: EdgeId, p: DVec3, seg: u32) -> SplitResult {
        let [a, b] = self.mesh.edge_vertices(e);
        let line = self.edge_line[e.idx()];
        let r = self.mesh.split_edge(e, p);
        let size = 0.5 * (self.size[a.idx()] + self.size[b.idx()]);
        let hint = self.hint_face[a.idx()];
        debug_assert_eq!(r.vertex.idx(), self.kind.len());
        self.kind.push(if line == NO_LINE { SMOOTH } else { line });
        self.hint_face.push(hint);
        self.hint_seg.push(seg);
        self.size.push(size);
        self.edge_line.resize(self.mesh.edge_capacity(), NO_LINE);
        self.edge_line[r.second_half.edge().idx()] = line;
        r
    }

    /// Collapses `h` and moves the kept vertex to `p`; merged edges keep a
    /// feature line if either had one.
    pub fn collapse(&mut self, h: HalfedgeId, p: DVec3) -> CollapseResult {
        let r = self.mesh.collapse_edge(h);
        self.mesh.set_position(r.kept, p);
        for k in 0..2 {
            let (gone, kept) = (r.removed_edges[k + 1], r.kept_edges[k]);
            if gone.is_valid() && self.edge_line[kept.idx()] == NO_LINE {
                self.edge_line[kept.idx()] = self.edge_line[gone.idx()];
            }
        }
        r
    }

    /// Drops deleted elements and renumbers the mesh along a Morton curve
    /// through the vertex positions (ties by index, so the order does not
    /// depend on the thread count), carrying the per-vertex and per-edge
    /// state along. Splits append vertices wherever edges are long, so after
    /// a pass with many of them ring neighbours are scattered in memory;
    /// renumbering keeps them close for every later pass.
    pub fn renumber(&mut self) {
        let m = &self.mesh;
        let live: Vec<u32> = m.vertices().map(|v| v.0).collect();
        let (lo, hi) = live.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &i| {
                let p = m.position(VertexId(i));
                (lo.min(p), hi.max(p))
            },
        );
        let scale = 2_097_151.0 / (hi - lo).max_element().max(f64::MIN_POSITIVE);
        let mut keyed: Vec<(u64, u32)> = self.pool.install(|| {
            live.par_iter()
                .map(|&i| {
                    let q = ((m.position(VertexId(i)) - lo) * scale).round();
                    (morton3(q.x as u64, q.y as u64, q.z as u64), i)
                })
                .collect()
        });
        self.pool.install(|| keyed.par_sort_unstable());
        let order: Vec<VertexId> = keyed.iter().map(|&(_, i)| VertexId(i)).collect();
        let remap = self.mesh.compact_in_order(&order);
        let nv = self.mesh.vertex_capacity();
        let ne = self.mesh.edge_capacity();
        scatter(&mut self.kind, &remap.vertices, nv, SMOOTH);
        scatter(&mut self.hint_face, &remap.vertices, nv, 0);
        scatter(&mut self.hint_seg, &remap.vertices, nv, 0);
        scatter(&mut self.size, &remap.vertices, nv, 0.0);
        scatter(&mut self.edge_line, &remap.edges, ne, NO_LINE);
    }

    /// Compacts the mesh and returns it with per-vertex target sizes.
    pub fn finish(mut self) -> (Mesh, Vec<f64>) {
        let remap = self.mesh.compact();
        let mut sizes = Vec::with_capacity(self.mesh.vertex_count());
        for (old, &new) in remap.vertices.iter().enumerate() {
            if new != u32::MAX {
                sizes.push(self.size[old]);
            }
        }
        (self.mesh, sizes)
    }
}

/// Chord tolerance of uniform sizing's curvature refinement, in units of L:
/// 2/15, which is 0.1 % of the diagonal at the bench's L = 0.75 %.
pub(super) const CURVED_TOLERANCE: f64 = 2.0 / 15.0;
/// Shortest target of the curvature refinement, in units of L: between the
/// collapse bound 4/5·L and L, with room above the bound so that relaxation
/// does not push refined edges under it (see `docs/tuning.md`).
pub(super) const CURVED_MIN_EDGE: f64 = 0.9;

/// What prepare derives from the input beside the spatial index: the
/// features to keep, the sizing and the per-vertex kinds and hints.
struct Derived {
    features: FeatureSet,
    sizing: Option<SizingField>,
    size: Vec<f64>,
    kind: Vec<u32>,
    hint_seg: Vec<u32>,
    fixed_turns: u64,
}

impl Derived {
    /// Detects the features, builds the sizing and anchors the feature
    /// vertices that must not move.
    ///
    /// `uniform_l` is the target under uniform sizing, already checked
    /// against the output limit.
    fn build(
        mesh: &Mesh,
        tm: &TriMesh,
        seams: &[[u32; 2]],
        options: &RemeshOptions,
        scale: Scale,
        cancel: &Cancel,
    ) -> Result<Self, RemeshError> {
        let Scale {
            uniform_l,
            diag,
            area,
        } = scale;
        // The unit of min_crease_length: L, or the smallest adaptive target.
        let unit = uniform_l.unwrap_or_else(|| options.adaptive_sizing(diag).min_edge_length);
        let features = detect_features_with_seams(
            tm,
            &FeatureOptions {
                preserve_features: options.preserve_features,
                feature_angle_deg: options.feature_angle,
                corner_angle_deg: options.corner_angle,
                min_crease_length: options.min_crease_length * unit,
                min_bridge_length: COLLAPSE_FACTOR * unit,
            },
            seams,
        );
        cancel.now()?;
        let nv = mesh.vertex_capacity();
        let is_feature = |a: u32, b: u32| features.is_feature_edge(a, b);
        let (sizing, size) = match options.sizing {
            Sizing::Uniform => {
                let l = uniform_l.expect("computed by the caller for uniform sizing");
                if options.refine_curved {
                    let so = SizingOptions {
                        tolerance: CURVED_TOLERANCE * l,
                        min_edge_length: CURVED_MIN_EDGE * l,
                        max_edge_length: l,
                        gradation: options.gradation,
                        crease_bound: true,
                    };
                    let field = SizingField::from_mesh(
                        tm,
                        &so,
                        &curvature::CurvatureOptions::default(),
                        Some(&is_feature),
                    )
                    .map_err(|e| RemeshError::Internal(format!("sizing: {e}")))?;
                    let sizes = field.vertex_sizes().to_vec();
                    (Some(field), sizes)
                } else {
                    (None, vec![l; nv])
                }
            }
            Sizing::Adaptive => {
                let so = options.adaptive_sizing(diag);
                let field = SizingField::from_mesh(
                    tm,
                    &so,
                    &curvature::CurvatureOptions::default(),
                    Some(&is_feature),
                )
                .map_err(|e| RemeshError::InvalidOption {
                    field: "tolerance",
                    message: e.to_string(),
                })?;
                let sizes = field.vertex_sizes().to_vec();
                let min = sizes.iter().cloned().fold(f64::INFINITY, f64::min);
                check_estimate(area, min.max(so.min_edge_length), options.max_output_faces)?;
                (Some(field), sizes)
            }
        };
        cancel.now()?;
        let mut kind = vec![SMOOTH; nv];
        let mut hint_seg = vec![0u32; nv];
        for v in 0..nv as u32 {
            kind[v as usize] = match features.vertex_kind(v) {
                VertexKind::Smooth => SMOOTH,
                VertexKind::Corner => CORNER,
                VertexKind::Line(l) => {
                    if let Some((_, i)) = features.vertex_line_index(v) {
                        hint_seg[v as usize] = i.saturating_sub(1);
                    }
                    l
                }
            };
        }
        let mut nbhd = Neighborhood::new(nv);
        if options.preserve_features {
            anchor_tips(mesh, &size, &mut nbhd, &mut kind);
        }
        let fixed_turns = anchor_turns(
            mesh,
            &features,
            &size,
            crate::stats::ON_LINE_TOLERANCE,
            &mut nbhd,
            &mut kind,
        );
        Ok(Self {
            features,
            sizing,
            size,
            kind,
            hint_seg,
            fixed_turns,
        })
    }
}

/// Faces around each vertex of `tm`, in compressed rows.
fn vertex_face_csr(tm: &TriMesh) -> (Vec<u32>, Vec<u32>) {
    Csr::from_pairs(tm.positions.len(), || {
        tm.triangles
            .iter()
            .enumerate()
            .flat_map(|(f, t)| t.iter().map(move |&v| (v, f as u32)))
    })
    .into_parts()
}

/// The part of every input face (see [`State::face_part`]): faces joined
/// across their shared edges, across label borders too unless
/// `split_labels`; `None` when there is one part.
fn face_parts(tm: &TriMesh, neighbors: &[[u32; 3]], split_labels: bool) -> Option<Vec<u32>> {
    let mut uf = crate::topology::UnionFind::new(neighbors.len());
    for (f, nb) in neighbors.iter().enumerate() {
        for &g in nb {
            let same = !split_labels || tm.face_label(f) == tm.face_label(g as usize);
            if g != u32::MAX && same {
                uf.union(f as u32, g);
            }
        }
    }
    let roots = uf.into_roots();
    let first = *roots.first()?;
    roots.iter().any(|&r| r != first).then_some(roots)
}

impl State<'_> {
    /// The closest point of the input to `p` on the part of face `hint`
    /// (the whole input when it is one part or the hint is not a face).
    pub fn closest_on_part(&self, p: DVec3, hint: u32) -> Option<crate::bvh::ClosestPoint> {
        match self.face_part.as_deref() {
            Some(parts) if (hint as usize) < parts.len() => {
                let part = parts[hint as usize];
                self.index
                    .closest_point_with_hint_filtered(p, hint, |f| parts[f as usize] == part)
            }
            _ => self.index.closest_point_with_hint(p, hint),
        }
    }
}

/// The input's scale as preparation measured it.
struct Scale {
    /// The target under uniform sizing (already checked against the
    /// output limit), `None` under adaptive sizing.
    uniform_l: Option<f64>,
    /// The bounding-box diagonal.
    diag: f64,
    /// The surface area.
    area: f64,
}

fn check_estimate(area: f64, l: f64, limit: u64) -> Result<(), RemeshError> {
    let est = super::estimated_faces(area, l);
    if !(l > 0.0 && l.is_finite()) || est > limit as f64 {
        return Err(RemeshError::TooManyFaces {
            target_edge_length: l,
            estimated_faces: if est.is_nan() { f64::INFINITY } else { est },
            limit,
        });
    }
    Ok(())
}

/// Spreads the bits of a 21-bit value three apart.
fn spread3(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

/// Morton code of a point quantised to 21 bits per axis.
fn morton3(x: u64, y: u64, z: u64) -> u64 {
    spread3(x) | spread3(y) << 1 | spread3(z) << 2
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every face's neighbour across edge `k` holds that edge reversed, and
    /// only boundary edges of an open grid have none.
    #[test]
    fn morton_codes_interleave_the_axes() {
        assert_eq!(morton3(1, 0, 0), 1);
        assert_eq!(morton3(0, 1, 0), 2);
        assert_eq!(morton3(0, 0, 1), 4);
        assert_eq!(morton3(3, 0, 0), 0b1001);
        let max = 0x1f_ffff;
        assert_eq!(morton3(max, max, max), (1u64 << 63) - 1);
        assert_eq!(morton3(max, 0, 0), 0x1249_2492_4924_9249);
        // Order along x alone is kept.
        assert!(morton3(5, 7, 2) < morton3(6, 7, 2));
    }
}
