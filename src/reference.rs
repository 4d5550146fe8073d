//! The per-job reference: the input as read, the repaired half-edge mesh and
//! its triangles, the spatial index over them, the welded view that the
//! statistics measure, and the input's measured feature set. A job builds it
//! once; the remesher and the statistics both read it, so the input's
//! geometry is parsed, repaired, welded, indexed and detected once. Texture
//! coordinates and colours add their own weld and index
//! ([`SourceAttributes`]: its faces keep the source's attribute corners),
//! and the `attributes` statistics weld the input once more.
//!
//! The derived parts are built on first use (thread-safely), because not
//! every caller needs every part: the remesher needs the index but not the
//! welded view, a statistics-only run the reverse.

use std::sync::{Arc, Mutex, OnceLock};

use crate::bvh::SurfaceIndex;
use crate::features::{detect_features, FeatureOptions, FeatureSet};
use crate::mesh::{BuildError, Mesh, RepairReport};
use crate::transfer::SourceAttributes;
use crate::trimesh::TriMesh;

/// The input of a job, built once and shared.
pub struct Reference {
    /// The triangles as read, before repair.
    pub source: TriMesh,
    /// The half-edge mesh after repair, compact (no deleted elements).
    pub mesh: Mesh,
    /// What the repair changed.
    pub repairs: RepairReport,
    surface: OnceLock<TriMesh>,
    index: OnceLock<Arc<SurfaceIndex>>,
    welded: OnceLock<(TriMesh, Vec<u32>)>,
    attributes: OnceLock<Option<Arc<SourceAttributes>>>,
    seams: OnceLock<Vec<[u32; 2]>>,
    hard_edges: OnceLock<Vec<[u32; 2]>>,
    mean_edge: OnceLock<f64>,
    /// The last measured feature set and the options it was detected with:
    /// a job measures the input and the output's fidelity with one set of
    /// options, so one entry serves both.
    features: Mutex<Option<(FeatureOptions, Arc<FeatureSet>)>>,
}

impl Reference {
    /// Repairs `source` into a half-edge mesh and keeps both.
    pub fn new(source: TriMesh) -> Result<Self, BuildError> {
        let (mesh, repairs) = Mesh::from_trimesh(&source)?;
        Ok(Self::from_parts(source, mesh, repairs))
    }

    /// A reference from an already repaired `mesh` whose source is its own
    /// triangles (for callers that start from a [`Mesh`]).
    pub fn from_mesh(mesh: Mesh) -> Self {
        let mut mesh = mesh;
        if mesh.has_garbage() {
            mesh.compact();
        }
        let surface = mesh.to_trimesh();
        let r = Self::from_parts(surface.clone(), mesh, RepairReport::default());
        let _ = r.surface.set(surface);
        r
    }

    /// A reference from its parts: `mesh` repaired from `source` with
    /// `repairs`.
    pub fn from_parts(source: TriMesh, mut mesh: Mesh, repairs: RepairReport) -> Self {
        if mesh.has_garbage() {
            mesh.compact();
        }
        Self {
            source,
            mesh,
            repairs,
            surface: OnceLock::new(),
            index: OnceLock::new(),
            welded: OnceLock::new(),
            attributes: OnceLock::new(),
            seams: OnceLock::new(),
            hard_edges: OnceLock::new(),
            mean_edge: OnceLock::new(),
            features: Mutex::new(None),
        }
    }

    /// The repaired triangles ([`Mesh::to_trimesh`] of [`Self::mesh`]): the
    /// surface that projection and the distance statistics query.
    pub fn surface(&self) -> &TriMesh {
        self.surface.get_or_init(|| self.mesh.to_trimesh())
    }

    /// The mean edge length of [`Self::mesh`]: the uniform target when the
    /// caller names none.
    pub fn mean_edge_length(&self) -> f64 {
        *self.mean_edge.get_or_init(|| {
            let m = &self.mesh;
            let (sum, n) = m
                .edges()
                .fold((0.0, 0usize), |(s, n), e| (s + m.edge_length(e), n + 1));
            sum / n.max(1) as f64
        })
    }

    /// The closest-point index over [`Self::surface`].
    pub fn index(&self) -> &Arc<SurfaceIndex> {
        self.index
            .get_or_init(|| Arc::new(SurfaceIndex::from_trimesh(self.surface())))
    }

    /// The source with bit-identical positions merged and degenerate or
    /// repeated faces dropped ([`TriMesh::welded`]), and for each welded
    /// position the source position it came from: the input as the
    /// statistics (and the benchmark) see it.
    pub fn welded(&self) -> (&TriMesh, &[u32]) {
        let (m, origin) = self.welded.get_or_init(|| self.source.welded());
        (m, origin)
    }

    /// The source's texture coordinates and colours prepared for transfer
    /// onto the output; `None` when the source has none.
    pub fn source_attributes(&self) -> Option<&Arc<SourceAttributes>> {
        self.attributes
            .get_or_init(|| SourceAttributes::new(&self.source).map(Arc::new))
            .as_ref()
    }

    /// The attribute seams of [`Self::surface`], as vertex pairs: the
    /// features that the remesher keeps besides creases, boundaries and
    /// label borders. Empty without attributes.
    pub fn surface_seams(&self) -> &[[u32; 2]] {
        self.seams.get_or_init(|| {
            self.source_attributes()
                .map_or_else(Vec::new, |a| a.seams_on(self.surface()))
        })
    }

    /// The hard edges authored into the source's normals, as vertex pairs
    /// of [`Self::surface`] (see [`crate::features::normals`]).
    pub fn surface_hard_edges(&self) -> &[[u32; 2]] {
        self.hard_edges
            .get_or_init(|| crate::features::normals::hard_edges(&self.source, self.surface()))
    }

    /// The features of the welded view detected with `opts`, detected once
    /// per distinct options.
    pub fn measured_features(&self, opts: &FeatureOptions) -> Arc<FeatureSet> {
        let mut cache = self.features.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((o, fs)) = cache.as_ref() {
            if o == opts {
                return Arc::clone(fs);
            }
        }
        let fs = Arc::new(detect_features(self.welded().0, opts));
        *cache = Some((*opts, Arc::clone(&fs)));
        fs
    }
}

impl Reference {
    /// An estimate of the heap bytes of the source and the repaired mesh
    /// (the parts every job builds; the derived parts come later, in the
    /// worker): what a queued input costs to keep.
    pub fn heap_bytes(&self) -> usize {
        let s = &self.source;
        let source = s.positions.len() * 24
            + s.normals.len() * 24
            + s.triangles.len() * 12
            + s.face_labels.len() * 4;
        // Per vertex: position, outgoing half-edge, deleted flag; per edge:
        // two half-edges (target, next, prev, face), deleted flag and
        // feature flags; per face: half-edge, deleted flag, label.
        let m = &self.mesh;
        let mesh = m.vertex_capacity() * 29 + m.edge_capacity() * 34 + m.face_capacity() * 9;
        source + mesh
    }
}

impl std::fmt::Debug for Reference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reference")
            .field("source_vertices", &self.source.positions.len())
            .field("source_faces", &self.source.triangles.len())
            .field("faces", &self.mesh.face_count())
            .field("repairs", &self.repairs)
            .finish_non_exhaustive()
    }
}
