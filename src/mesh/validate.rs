//! The invariant checker: every structural promise of [`Mesh`] verified in
//! O(n). Tests call it after every edit; debug builds assert it after each
//! remeshing pass.

use super::{Mesh, VertexId};
use crate::mesh::handles::Handle;

/// The first broken invariant found by [`Mesh::validate`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("invalid mesh: {0}")]
pub struct ValidationError(pub String);

macro_rules! ensure {
    ($cond:expr, $($arg:tt)*) => {
        if !$cond {
            return Err(ValidationError(format!($($arg)*)));
        }
    };
}

impl Mesh {
    /// Checks the twin involution, next/prev inverses, face cycles of length
    /// three, boundary loops, vertex fans (manifoldness), outgoing half-edge
    /// rules, the absence of duplicate edges and of references to deleted
    /// elements, and the live-element counters.
    pub fn validate(&self) -> Result<(), ValidationError> {
        let nh = self.he_to.len();
        ensure!(
            nh == 2 * self.e_deleted.len(),
            "half-edge/edge count mismatch"
        );
        ensure!(
            self.face_label.len() == self.f_he.len()
                && self.edge_flags.len() == self.e_deleted.len(),
            "attribute sizes differ from element counts"
        );
        let live_v = self.v_deleted.iter().filter(|d| !**d).count();
        let live_e = self.e_deleted.iter().filter(|d| !**d).count();
        let live_f = self.f_deleted.iter().filter(|d| !**d).count();
        ensure!(
            (live_v, live_e, live_f) == (self.live_vertices, self.live_edges, self.live_faces),
            "live counters are stale"
        );
        // Half-edges.
        let mut outgoing_count = vec![0u32; self.pos.len()];
        for e in self.edges() {
            for i in 0..2 {
                let h = e.halfedge(i);
                let (to, from) = (self.to_vertex(h), self.from_vertex(h));
                ensure!(
                    to.is_valid() && to.idx() < self.pos.len(),
                    "{h:?} has a bad target"
                );
                ensure!(
                    !self.is_vertex_deleted(to),
                    "{h:?} points to deleted {to:?}"
                );
                ensure!(to != from, "{h:?} is a loop at {to:?}");
                let (n, p) = (self.next(h), self.prev(h));
                ensure!(n.is_valid() && p.is_valid(), "{h:?} has no next/prev");
                ensure!(!self.is_edge_deleted(n.edge()), "{h:?}.next is deleted");
                ensure!(
                    self.prev(n) == h && self.next(p) == h,
                    "next/prev not inverse at {h:?}"
                );
                ensure!(
                    self.from_vertex(n) == to,
                    "{h:?}.next does not start at its target"
                );
                let f = self.face(h);
                ensure!(
                    self.face(n) == f,
                    "{h:?} and its next lie in different faces"
                );
                if f.is_valid() {
                    ensure!(!self.is_face_deleted(f), "{h:?} lies in deleted {f:?}");
                    ensure!(self.next(self.next(n)) == h, "face {f:?} is not a triangle");
                } else {
                    ensure!(
                        !self.is_boundary_halfedge(h.twin()),
                        "edge {e:?} has no face on either side"
                    );
                }
                outgoing_count[from.idx()] += 1;
            }
        }
        // Faces.
        for f in self.faces() {
            let h = self.face_halfedge(f);
            ensure!(
                !self.is_edge_deleted(h.edge()),
                "{f:?} refers to a deleted edge"
            );
            ensure!(self.face(h) == f, "{f:?}'s half-edge lies elsewhere");
            let [a, b, c] = self.face_vertices(f);
            ensure!(a != b && b != c && c != a, "{f:?} repeats a vertex");
        }
        // Vertices: the fan reached by rotation is every outgoing half-edge
        // (manifold), at most one is a boundary half-edge, and that one is the
        // stored outgoing half-edge; no two outgoing half-edges share a target.
        let mut mark = vec![VertexId::INVALID; self.pos.len()];
        for v in self.vertices() {
            let h0 = self.halfedge(v);
            if !h0.is_valid() {
                ensure!(
                    outgoing_count[v.idx()] == 0,
                    "{v:?} has edges but no outgoing half-edge"
                );
                continue;
            }
            ensure!(
                !self.is_edge_deleted(h0.edge()),
                "{v:?} refers to a deleted edge"
            );
            ensure!(
                self.from_vertex(h0) == v,
                "{v:?}'s half-edge starts elsewhere"
            );
            let mut n = 0u32;
            let mut boundary = 0;
            let mut h = h0;
            loop {
                ensure!(
                    self.from_vertex(h) == v,
                    "rotation around {v:?} left the vertex"
                );
                let to = self.to_vertex(h);
                ensure!(mark[to.idx()] != v, "duplicate edge {v:?}-{to:?}");
                mark[to.idx()] = v;
                if self.is_boundary_halfedge(h) {
                    boundary += 1;
                }
                n += 1;
                ensure!(
                    n <= outgoing_count[v.idx()],
                    "rotation around {v:?} does not close"
                );
                h = self.ccw_rotated(h);
                if h == h0 {
                    break;
                }
            }
            ensure!(
                n == outgoing_count[v.idx()],
                "{v:?} is non-manifold: its fan has {n} of {} edges",
                outgoing_count[v.idx()]
            );
            ensure!(boundary <= 1, "{v:?} has {boundary} boundary half-edges");
            ensure!(
                boundary == 0 || self.is_boundary_halfedge(h0),
                "boundary {v:?} does not start at its boundary half-edge"
            );
        }
        Ok(())
    }
}
