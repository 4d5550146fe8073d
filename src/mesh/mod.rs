//! The half-edge triangle mesh at the heart of isoremesh.
//!
//! Index-based and array-of-structs-free: every element kind lives in flat
//! vectors addressed by `u32` handles ([`VertexId`], [`HalfedgeId`],
//! [`EdgeId`], [`FaceId`]). Half-edges come in twin pairs (`h ^ 1`), so an
//! edge is simply `h >> 1`. Boundary half-edges have no face and are linked
//! into boundary loops, so every half-edge has a valid `next`/`prev`.
//! A boundary vertex's outgoing half-edge is always its boundary half-edge,
//! which makes "is this a boundary vertex" O(1).
//!
//! Removal marks elements deleted; [`Mesh::compact`] (`compact.rs`) removes
//! them and remaps handles. The topological operators and their guards are
//! in [`edit`], construction with repair in `build.rs`, the invariant checker
//! in `validate.rs`, the typed handles and per-element maps in `handles.rs`.
//! The design follows the half-edge structure of OpenMesh and pmp-library
//! (Sieger & Botsch), written anew here.

mod build;
mod compact;
pub mod edit;
mod handles;
mod validate;

pub use build::{BuildError, RepairReport, MAX_COORDINATE, MIN_EXTENT};
pub use compact::{scatter, Remap};
pub use edit::{CollapseResult, SplitResult};
pub use handles::{
    Attr, EdgeId, EdgeMap, FaceId, FaceMap, HalfedgeId, Handle, VertexId, VertexMap,
};
pub use validate::ValidationError;

use glam::DVec3;

use crate::trimesh::{Label, TriMesh};

/// Edge flag bit: the edge is a feature (sharp crease, boundary or label border).
pub const EDGE_FEATURE: u8 = 1;

/// Edge flag bit: the edge is an attribute seam (a texture coordinate or a
/// colour differs across it); always set together with [`EDGE_FEATURE`].
pub const EDGE_SEAM: u8 = 2;

/// Edge flag bit: the edge belongs to a part the remesher leaves as it is
/// (a small part kept): no pass splits or flips it.
pub const EDGE_FROZEN: u8 = 4;

/// A manifold, consistently oriented triangle mesh in half-edge form.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pos: Vec<DVec3>,
    v_out: Vec<HalfedgeId>,
    v_deleted: Vec<bool>,
    he_to: Vec<VertexId>,
    he_next: Vec<HalfedgeId>,
    he_prev: Vec<HalfedgeId>,
    he_face: Vec<FaceId>,
    e_deleted: Vec<bool>,
    f_he: Vec<HalfedgeId>,
    f_deleted: Vec<bool>,
    live_vertices: usize,
    live_edges: usize,
    live_faces: usize,
    /// Per-face label (index into [`Mesh::labels`]); kept by every operator.
    pub face_label: FaceMap<u32>,
    /// Per-edge flags such as [`EDGE_FEATURE`]; split halves inherit them.
    pub edge_flags: EdgeMap<u8>,
    /// The label table carried from the input (materials, primitives).
    pub labels: Vec<Label>,
}

impl Mesh {
    // ---- sizes -------------------------------------------------------------

    /// Number of live (non-deleted) vertices.
    pub fn vertex_count(&self) -> usize {
        self.live_vertices
    }
    /// Number of live edges.
    pub fn edge_count(&self) -> usize {
        self.live_edges
    }
    /// Number of live faces.
    pub fn face_count(&self) -> usize {
        self.live_faces
    }
    /// Number of vertex slots, deleted ones included (the bound for handle indices).
    pub fn vertex_capacity(&self) -> usize {
        self.pos.len()
    }
    /// Number of edge slots, deleted ones included.
    pub fn edge_capacity(&self) -> usize {
        self.e_deleted.len()
    }
    /// Number of face slots, deleted ones included.
    pub fn face_capacity(&self) -> usize {
        self.f_he.len()
    }
    /// Whether there are deleted elements that [`Mesh::compact`] would remove.
    pub fn has_garbage(&self) -> bool {
        self.live_vertices != self.pos.len()
            || self.live_edges != self.e_deleted.len()
            || self.live_faces != self.f_he.len()
    }

    // ---- iteration ---------------------------------------------------------

    /// Live vertices.
    pub fn vertices(&self) -> impl Iterator<Item = VertexId> + '_ {
        (0..self.pos.len() as u32)
            .map(VertexId)
            .filter(|v| !self.v_deleted[v.idx()])
    }
    /// Live edges.
    pub fn edges(&self) -> impl Iterator<Item = EdgeId> + '_ {
        (0..self.e_deleted.len() as u32)
            .map(EdgeId)
            .filter(|e| !self.e_deleted[e.idx()])
    }
    /// Live faces.
    pub fn faces(&self) -> impl Iterator<Item = FaceId> + '_ {
        (0..self.f_he.len() as u32)
            .map(FaceId)
            .filter(|f| !self.f_deleted[f.idx()])
    }

    // ---- element state -----------------------------------------------------

    /// Whether vertex `v` was deleted.
    #[inline]
    pub fn is_vertex_deleted(&self, v: VertexId) -> bool {
        self.v_deleted[v.idx()]
    }
    /// Whether edge `e` was deleted.
    #[inline]
    pub fn is_edge_deleted(&self, e: EdgeId) -> bool {
        self.e_deleted[e.idx()]
    }
    /// Whether face `f` was deleted.
    #[inline]
    pub fn is_face_deleted(&self, f: FaceId) -> bool {
        self.f_deleted[f.idx()]
    }

    // ---- geometry ----------------------------------------------------------

    /// Position of `v`.
    #[inline]
    pub fn position(&self, v: VertexId) -> DVec3 {
        self.pos[v.idx()]
    }
    /// Moves `v` to `p`.
    #[inline]
    pub fn set_position(&mut self, v: VertexId, p: DVec3) {
        self.pos[v.idx()] = p;
    }
    /// All vertex positions, indexed by vertex index (deleted slots included).
    pub fn positions(&self) -> &[DVec3] {
        &self.pos
    }
    /// Mutable access to all positions (deleted slots included).
    pub fn positions_mut(&mut self) -> &mut [DVec3] {
        &mut self.pos
    }

    // ---- connectivity ------------------------------------------------------

    /// The vertex `h` points to.
    #[inline]
    pub fn to_vertex(&self, h: HalfedgeId) -> VertexId {
        self.he_to[h.idx()]
    }
    /// The vertex `h` starts from.
    #[inline]
    pub fn from_vertex(&self, h: HalfedgeId) -> VertexId {
        self.he_to[h.twin().idx()]
    }
    /// The next half-edge around `h`'s face (or boundary loop).
    #[inline]
    pub fn next(&self, h: HalfedgeId) -> HalfedgeId {
        self.he_next[h.idx()]
    }
    /// The previous half-edge around `h`'s face (or boundary loop).
    #[inline]
    pub fn prev(&self, h: HalfedgeId) -> HalfedgeId {
        self.he_prev[h.idx()]
    }
    /// The face of `h`, or [`FaceId::INVALID`] for a boundary half-edge.
    #[inline]
    pub fn face(&self, h: HalfedgeId) -> FaceId {
        self.he_face[h.idx()]
    }
    /// Whether `h` lies on the boundary (has no face).
    #[inline]
    pub fn is_boundary_halfedge(&self, h: HalfedgeId) -> bool {
        !self.he_face[h.idx()].is_valid()
    }
    /// Whether edge `e` lies on the boundary.
    #[inline]
    pub fn is_boundary_edge(&self, e: EdgeId) -> bool {
        self.is_boundary_halfedge(e.halfedge(0)) || self.is_boundary_halfedge(e.halfedge(1))
    }
    /// An outgoing half-edge of `v`; the boundary one if `v` is on the boundary.
    #[inline]
    pub fn halfedge(&self, v: VertexId) -> HalfedgeId {
        self.v_out[v.idx()]
    }
    /// One half-edge of face `f`.
    #[inline]
    pub fn face_halfedge(&self, f: FaceId) -> HalfedgeId {
        self.f_he[f.idx()]
    }
    /// Whether `v` is on the boundary (or isolated).
    #[inline]
    pub fn is_boundary_vertex(&self, v: VertexId) -> bool {
        let h = self.v_out[v.idx()];
        !h.is_valid() || self.is_boundary_halfedge(h)
    }
    /// Whether `v` has no incident edge.
    #[inline]
    pub fn is_isolated(&self, v: VertexId) -> bool {
        !self.v_out[v.idx()].is_valid()
    }
    /// The two end vertices of edge `e`.
    #[inline]
    pub fn edge_vertices(&self, e: EdgeId) -> [VertexId; 2] {
        [self.to_vertex(e.halfedge(1)), self.to_vertex(e.halfedge(0))]
    }
    /// Length of edge `e`.
    #[inline]
    pub fn edge_length(&self, e: EdgeId) -> f64 {
        let [a, b] = self.edge_vertices(e);
        self.pos[a.idx()].distance(self.pos[b.idx()])
    }
    /// Whether edge `e` carries `flag`.
    #[inline]
    pub fn edge_has_flag(&self, e: EdgeId, flag: u8) -> bool {
        self.edge_flags[e] & flag != 0
    }
    /// Rotates `h` (outgoing from a vertex) clockwise to the next outgoing half-edge.
    #[inline]
    pub fn cw_rotated(&self, h: HalfedgeId) -> HalfedgeId {
        self.next(h.twin())
    }
    /// Rotates `h` (outgoing from a vertex) counter-clockwise.
    #[inline]
    pub fn ccw_rotated(&self, h: HalfedgeId) -> HalfedgeId {
        self.prev(h).twin()
    }
    /// The three vertices of face `f` in counter-clockwise order.
    #[inline]
    pub fn face_vertices(&self, f: FaceId) -> [VertexId; 3] {
        let h = self.f_he[f.idx()];
        let h1 = self.next(h);
        [
            self.to_vertex(self.next(h1)),
            self.to_vertex(h),
            self.to_vertex(h1),
        ]
    }
    /// The three corner positions of face `f`.
    #[inline]
    pub fn face_positions(&self, f: FaceId) -> [DVec3; 3] {
        let [a, b, c] = self.face_vertices(f);
        [self.pos[a.idx()], self.pos[b.idx()], self.pos[c.idx()]]
    }
    /// Iterates the outgoing half-edges of `v` (counter-clockwise).
    #[inline]
    pub fn outgoing(&self, v: VertexId) -> Outgoing<'_> {
        let start = self.v_out[v.idx()];
        Outgoing {
            mesh: self,
            start,
            cur: start,
            done: !start.is_valid(),
        }
    }
    /// Number of edges incident to `v`.
    #[inline]
    pub fn valence(&self, v: VertexId) -> usize {
        self.outgoing(v).count()
    }
    /// The half-edge from `a` to `b`, if the edge exists.
    pub fn find_halfedge(&self, a: VertexId, b: VertexId) -> Option<HalfedgeId> {
        self.outgoing(a).find(|&h| self.to_vertex(h) == b)
    }
    /// Unit normal of face `f` (zero when degenerate).
    #[inline]
    pub fn face_normal(&self, f: FaceId) -> DVec3 {
        crate::geometry::triangle_normal(self.face_positions(f))
    }
    /// Area-weighted unit normal at `v` (zero for isolated vertices).
    pub fn vertex_normal(&self, v: VertexId) -> DVec3 {
        let mut n = DVec3::ZERO;
        for h in self.outgoing(v) {
            let f = self.face(h);
            if f.is_valid() {
                n += crate::geometry::triangle_cross(self.face_positions(f));
            }
        }
        n.normalize_or_zero()
    }
    /// Number of boundary loops.
    pub fn boundary_loop_count(&self) -> usize {
        let mut seen = vec![false; self.he_to.len()];
        let mut loops = 0;
        for e in self.edges() {
            for i in 0..2 {
                let h = e.halfedge(i);
                if self.is_boundary_halfedge(h) && !seen[h.idx()] {
                    loops += 1;
                    let mut c = h;
                    while !seen[c.idx()] {
                        seen[c.idx()] = true;
                        c = self.next(c);
                    }
                }
            }
        }
        loops
    }
    /// Euler characteristic V − E + F of the live elements.
    pub fn euler_characteristic(&self) -> i64 {
        self.live_vertices as i64 - self.live_edges as i64 + self.live_faces as i64
    }

    /// Exports the live mesh as indexed triangles with labels, in handle order.
    pub fn to_trimesh(&self) -> TriMesh {
        let mut index = vec![u32::MAX; self.pos.len()];
        let mut positions = Vec::with_capacity(self.live_vertices);
        for v in self.vertices() {
            index[v.idx()] = positions.len() as u32;
            positions.push(self.pos[v.idx()]);
        }
        let mut triangles = Vec::with_capacity(self.live_faces);
        let mut face_labels = Vec::with_capacity(self.live_faces);
        for f in self.faces() {
            let [a, b, c] = self.face_vertices(f);
            triangles.push([index[a.idx()], index[b.idx()], index[c.idx()]]);
            face_labels.push(self.face_label[f]);
        }
        let has_labels = self.labels.len() > 1 || face_labels.iter().any(|&l| l != 0);
        TriMesh {
            positions,
            triangles,
            normals: Vec::new(),
            face_labels: if has_labels { face_labels } else { Vec::new() },
            labels: self.labels.clone(),
            ..Default::default()
        }
    }

    // ---- low-level construction (used by build and edit) -------------------

    /// Reserves room for `vertices`, `edges` and `faces` more elements.
    pub fn reserve(&mut self, vertices: usize, edges: usize, faces: usize) {
        self.pos.reserve(vertices);
        self.v_out.reserve(vertices);
        self.v_deleted.reserve(vertices);
        for v in [&mut self.he_next, &mut self.he_prev] {
            v.reserve(2 * edges);
        }
        self.he_to.reserve(2 * edges);
        self.he_face.reserve(2 * edges);
        self.e_deleted.reserve(edges);
        self.f_he.reserve(faces);
        self.f_deleted.reserve(faces);
    }

    fn new_vertex(&mut self, p: DVec3) -> VertexId {
        self.pos.push(p);
        self.v_out.push(HalfedgeId::INVALID);
        self.v_deleted.push(false);
        self.live_vertices += 1;
        VertexId((self.pos.len() - 1) as u32)
    }

    /// Adds an edge from `a` to `b`; returns the half-edge `a → b` (its twin is `b → a`).
    fn new_edge(&mut self, a: VertexId, b: VertexId) -> HalfedgeId {
        let h = HalfedgeId(self.he_to.len() as u32);
        self.he_to.extend_from_slice(&[b, a]);
        self.he_next
            .extend_from_slice(&[HalfedgeId::INVALID, HalfedgeId::INVALID]);
        self.he_prev
            .extend_from_slice(&[HalfedgeId::INVALID, HalfedgeId::INVALID]);
        self.he_face
            .extend_from_slice(&[FaceId::INVALID, FaceId::INVALID]);
        self.e_deleted.push(false);
        self.edge_flags.push(0);
        self.live_edges += 1;
        h
    }

    fn new_face(&mut self, h: HalfedgeId, label: u32) -> FaceId {
        self.f_he.push(h);
        self.f_deleted.push(false);
        self.face_label.push(label);
        self.live_faces += 1;
        FaceId((self.f_he.len() - 1) as u32)
    }

    #[inline]
    fn link(&mut self, a: HalfedgeId, b: HalfedgeId) {
        self.he_next[a.idx()] = b;
        self.he_prev[b.idx()] = a;
    }

    /// Makes the outgoing half-edge of `v` its boundary one, if it has one.
    fn adjust_outgoing(&mut self, v: VertexId) {
        let start = self.v_out[v.idx()];
        if !start.is_valid() {
            return;
        }
        let mut h = start;
        loop {
            if self.is_boundary_halfedge(h) {
                self.v_out[v.idx()] = h;
                return;
            }
            h = self.cw_rotated(h);
            if h == start {
                return;
            }
        }
    }
}

/// Iterator over the outgoing half-edges of a vertex; see [`Mesh::outgoing`].
pub struct Outgoing<'a> {
    mesh: &'a Mesh,
    start: HalfedgeId,
    cur: HalfedgeId,
    done: bool,
}

impl Iterator for Outgoing<'_> {
    type Item = HalfedgeId;
    #[inline]
    fn next(&mut self) -> Option<HalfedgeId> {
        if self.done {
            return None;
        }
        let h = self.cur;
        self.cur = self.mesh.ccw_rotated(h);
        if self.cur == self.start {
            self.done = true;
        }
        Some(h)
    }
}
