//! The three local operators of incremental remeshing and their guards:
//! [`Mesh::split_edge`], [`Mesh::collapse_edge`] and [`Mesh::flip_edge`],
//! each checked by a `can_*` predicate that enforces the link condition, the
//! boundary rules, and forbids duplicate edges and non-manifold results.
//!
//! The guards here are purely topological; geometric policy (lengths, normal
//! flips, features) belongs to the remesher. Every operator returns the
//! elements it created or removed so callers never guess handles. All
//! operators are O(valence) and allocate nothing beyond element storage.

use glam::DVec3;

use super::{EdgeId, FaceId, HalfedgeId, Mesh, VertexId};
use crate::mesh::handles::Handle;

/// What [`Mesh::split_edge`] created.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SplitResult {
    /// The new vertex on the edge.
    pub vertex: VertexId,
    /// The half-edge from the new vertex to the edge's second endpoint: the
    /// new half of the split edge (the old handle keeps the first half).
    pub second_half: HalfedgeId,
    /// New edges joining the new vertex to the opposite corners (one per
    /// adjacent face; `INVALID` on a boundary side).
    pub spokes: [EdgeId; 2],
    /// New faces (one per adjacent face; `INVALID` on a boundary side).
    pub faces: [FaceId; 2],
}

/// What [`Mesh::collapse_edge`] removed and kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CollapseResult {
    /// The surviving vertex (the target of the collapsed half-edge).
    pub kept: VertexId,
    /// The removed vertex (the source of the collapsed half-edge).
    pub removed: VertexId,
    /// Removed edges: the collapsed edge, then one merged edge per removed face.
    pub removed_edges: [EdgeId; 3],
    /// Removed faces (`INVALID` on a boundary side).
    pub removed_faces: [FaceId; 2],
    /// The edges that `removed_edges[1]` and `removed_edges[2]` merged into
    /// (`INVALID` on a boundary side); they carry the union of the flags.
    pub kept_edges: [EdgeId; 2],
}

impl Mesh {
    // ---------------------------------------------------------------- split

    /// Whether `e` can be split: always, for a live edge.
    pub fn can_split(&self, e: EdgeId) -> bool {
        !self.is_edge_deleted(e)
    }

    /// Splits edge `e` at point `p`, creating one vertex, up to three edges and
    /// up to two faces. Half-edge `e.halfedge(0)` keeps its source and now ends
    /// at the new vertex. New faces copy their neighbour's label; the new half
    /// of the edge copies the edge's flags; spokes get no flags.
    pub fn split_edge(&mut self, e: EdgeId, p: DVec3) -> SplitResult {
        debug_assert!(self.can_split(e));
        let h = e.halfedge(0); // a -> b
        let o = h.twin(); // b -> a
        let a = self.to_vertex(o);
        let b = self.to_vertex(h);
        let m = self.new_vertex(p);
        let n = self.new_edge(m, b); // m -> b, twin t: b -> m
        let t = n.twin();
        self.edge_flags[n.edge()] = self.edge_flags[e];
        let mut spokes = [EdgeId::INVALID; 2];
        let mut faces = [FaceId::INVALID; 2];

        // Side of h (a -> b -> c).
        let fh = self.face(h);
        let h_next_old = self.next(h);
        self.he_to[h.idx()] = m;
        if fh.is_valid() {
            let h1 = h_next_old; // b -> c
            let h2 = self.next(h1); // c -> a
            let c = self.to_vertex(h1);
            let x = self.new_edge(m, c); // m -> c, twin c -> m
            let xt = x.twin();
            spokes[0] = x.edge();
            let f1 = self.new_face(n, self.face_label[fh]);
            faces[0] = f1;
            // F0: h (a->m), x (m->c), h2 (c->a)
            self.link(h, x);
            self.link(x, h2);
            self.link(h2, h);
            self.he_face[x.idx()] = fh;
            self.f_he[fh.idx()] = h;
            // F1: n (m->b), h1 (b->c), xt (c->m)
            self.link(n, h1);
            self.link(h1, xt);
            self.link(xt, n);
            self.he_face[n.idx()] = f1;
            self.he_face[h1.idx()] = f1;
            self.he_face[xt.idx()] = f1;
        } else {
            // Boundary: a -> m -> b along the loop.
            self.link(h, n);
            self.link(n, h_next_old);
        }

        // Side of o (b -> a -> d).
        let fo = self.face(o);
        let o_prev_old = self.prev(o);
        if fo.is_valid() {
            let o1 = self.next(o); // a -> d
            let o2 = self.next(o1); // d -> b
            let d = self.to_vertex(o1);
            let y = self.new_edge(d, m); // d -> m, twin m -> d
            let yt = y.twin();
            spokes[1] = y.edge();
            let g1 = self.new_face(t, self.face_label[fo]);
            faces[1] = g1;
            // G0: o (m->a), o1 (a->d), y (d->m)
            self.link(o, o1);
            self.link(o1, y);
            self.link(y, o);
            self.he_face[y.idx()] = fo;
            self.f_he[fo.idx()] = o;
            // G1: t (b->m), yt (m->d), o2 (d->b)
            self.link(t, yt);
            self.link(yt, o2);
            self.link(o2, t);
            self.he_face[t.idx()] = g1;
            self.he_face[yt.idx()] = g1;
            self.he_face[o2.idx()] = g1;
        } else {
            // Boundary: b -> m -> a along the loop.
            self.link(o_prev_old, t);
            self.link(t, o);
        }

        // Outgoing half-edges.
        self.v_out[m.idx()] = n;
        if self.v_out[b.idx()] == o {
            self.v_out[b.idx()] = t;
        }
        self.adjust_outgoing(m);
        debug_assert!(self.from_vertex(o) == m && self.to_vertex(o) == a);
        SplitResult {
            vertex: m,
            second_half: n,
            spokes,
            faces,
        }
    }

    // ------------------------------------------------------------- collapse

    /// Whether collapsing half-edge `h` (moving its source onto its target)
    /// keeps the mesh a valid manifold:
    /// - an interior edge between two boundary vertices would pinch the
    ///   surface, so it is refused;
    /// - a face whose two other edges are both boundary would leave a dangling
    ///   edge;
    /// - the link condition: the only common neighbours of the two endpoints
    ///   are the opposite corners of the edge's faces (otherwise an edge
    ///   would be duplicated);
    /// - the opposite corners must keep enough edges (an interior vertex at
    ///   least three), which also rules out collapsing a tetrahedron.
    pub fn can_collapse(&self, h: HalfedgeId) -> bool {
        if self.is_edge_deleted(h.edge()) {
            return false;
        }
        let o = h.twin();
        let v0 = self.from_vertex(h);
        let v1 = self.to_vertex(h);
        let boundary_edge = self.is_boundary_halfedge(h) || self.is_boundary_halfedge(o);
        if !boundary_edge && self.is_boundary_vertex(v0) && self.is_boundary_vertex(v1) {
            return false;
        }
        let mut vl = VertexId::INVALID;
        let mut vr = VertexId::INVALID;
        if !self.is_boundary_halfedge(h) {
            let h1 = self.next(h);
            let h2 = self.next(h1);
            if self.is_boundary_halfedge(h1.twin()) && self.is_boundary_halfedge(h2.twin()) {
                return false;
            }
            vl = self.to_vertex(h1);
        }
        if !self.is_boundary_halfedge(o) {
            let o1 = self.next(o);
            let o2 = self.next(o1);
            if self.is_boundary_halfedge(o1.twin()) && self.is_boundary_halfedge(o2.twin()) {
                return false;
            }
            vr = self.to_vertex(o1);
        }
        if vl == vr {
            return false;
        }
        for w in [vl, vr] {
            if w.is_valid() {
                let min = if self.is_boundary_vertex(w) { 2 } else { 3 };
                if self.outgoing(w).take(min + 1).count() <= min {
                    return false;
                }
            }
        }
        // Link condition: the common neighbours of v0 and v1 are only vl and
        // vr. Sorting v1's ring and searching it keeps this O(n log n) in the
        // valences, so high-valence fan centres of CAD meshes stay cheap.
        let mut small = [VertexId::INVALID; 64];
        let mut large: Vec<VertexId> = Vec::new();
        let mut n = 0usize;
        for h1 in self.outgoing(v1) {
            let w = self.to_vertex(h1);
            if n < small.len() {
                small[n] = w;
            } else {
                if large.is_empty() {
                    large.extend_from_slice(&small);
                }
                large.push(w);
            }
            n += 1;
        }
        let ring: &mut [VertexId] = if large.is_empty() {
            &mut small[..n]
        } else {
            &mut large[..]
        };
        ring.sort_unstable();
        for h0 in self.outgoing(v0) {
            let w = self.to_vertex(h0);
            if w == v1 || w == vl || w == vr {
                continue;
            }
            if ring.binary_search(&w).is_ok() {
                return false;
            }
        }
        true
    }

    /// Collapses half-edge `h`: its source vertex is removed and every edge of
    /// it moves to the target vertex (whose position is not changed; set it
    /// before or after as the policy requires). The two faces of the edge and
    /// one of each pair of merged edges are removed. Merged edges keep the
    /// union of their flags.
    pub fn collapse_edge(&mut self, h: HalfedgeId) -> CollapseResult {
        debug_assert!(self.can_collapse(h));
        let o = h.twin();
        let v0 = self.from_vertex(h);
        let v1 = self.to_vertex(h);
        let mut removed_edges = [h.edge(), EdgeId::INVALID, EdgeId::INVALID];
        let mut removed_faces = [FaceId::INVALID; 2];
        let mut kept_edges = [EdgeId::INVALID; 2];

        // Every half-edge arriving at v0 now arrives at v1.
        // Rotation reads only prev/twin, so retargeting while rotating is safe.
        let start = self.v_out[v0.idx()];
        let mut hh = start;
        loop {
            self.he_to[hh.twin().idx()] = v1;
            hh = self.ccw_rotated(hh);
            if hh == start {
                break;
            }
        }

        let hn = self.next(h);
        let hp = self.prev(h);
        let on = self.next(o);
        let op = self.prev(o);

        // Side of h: face (v0, v1, vl) with h1 = v1 -> vl, h2 = vl -> v0.
        let fh = self.face(h);
        if fh.is_valid() {
            let h1 = hn;
            let h2 = hp;
            let vl = self.to_vertex(h1);
            // Keep edge of h1; h1 replaces b = twin(h2) (now v1 -> vl) in b's cycle.
            let b = h2.twin();
            let (bp, bn, bf) = (self.prev(b), self.next(b), self.face(b));
            self.link(bp, h1);
            self.link(h1, bn);
            self.he_face[h1.idx()] = bf;
            if bf.is_valid() && self.f_he[bf.idx()] == b {
                self.f_he[bf.idx()] = h1;
            }
            let flags = self.edge_flags[h2.edge()];
            self.edge_flags[h1.edge()] |= flags;
            if self.v_out[vl.idx()] == h2 {
                self.v_out[vl.idx()] = h1.twin();
            }
            if self.v_out[v1.idx()] == b || self.v_out[v1.idx()] == o {
                self.v_out[v1.idx()] = h1;
            }
            self.delete_edge(h2.edge());
            self.delete_face(fh);
            removed_edges[1] = h2.edge();
            removed_faces[0] = fh;
            kept_edges[0] = h1.edge();
            self.adjust_outgoing(vl);
        } else {
            // Boundary side: drop h from its loop.
            self.link(hp, hn);
            if self.v_out[v1.idx()] == o {
                self.v_out[v1.idx()] = hn;
            }
        }

        // Side of o: face (v1, v0, vr) with o1 = v0 -> vr, o2 = vr -> v1.
        let fo = self.face(o);
        if fo.is_valid() {
            let o1 = on;
            let o2 = op;
            let vr = self.to_vertex(o1);
            // Keep edge of o2; o2 (vr -> v1) replaces c = twin(o1) (vr -> v0, now vr -> v1).
            let c = o1.twin();
            let (cp, cn, cf) = (self.prev(c), self.next(c), self.face(c));
            self.link(cp, o2);
            self.link(o2, cn);
            self.he_face[o2.idx()] = cf;
            if cf.is_valid() && self.f_he[cf.idx()] == c {
                self.f_he[cf.idx()] = o2;
            }
            let flags = self.edge_flags[o1.edge()];
            self.edge_flags[o2.edge()] |= flags;
            if self.v_out[vr.idx()] == c {
                self.v_out[vr.idx()] = o2;
            }
            if self.v_out[v1.idx()] == o || self.v_out[v1.idx()] == o1 {
                self.v_out[v1.idx()] = o2.twin();
            }
            self.delete_edge(o1.edge());
            self.delete_face(fo);
            removed_edges[2] = o1.edge();
            removed_faces[1] = fo;
            kept_edges[1] = o2.edge();
            self.adjust_outgoing(vr);
        } else {
            // Read the loop neighbours now: the other side may have relinked them.
            let (op, on) = (self.prev(o), self.next(o));
            self.link(op, on);
            if self.v_out[v1.idx()] == o {
                self.v_out[v1.idx()] = on;
            }
        }

        // v1 needs a live outgoing half-edge; v0's old ones now start at v1.
        let cur = self.v_out[v1.idx()];
        if !cur.is_valid() || self.e_deleted[cur.idx() >> 1] || cur.edge() == h.edge() {
            let mut pick = HalfedgeId::INVALID;
            for cand in [hn, on, hp.twin(), op.twin()] {
                if !self.e_deleted[cand.idx() >> 1]
                    && cand.edge() != h.edge()
                    && self.from_vertex(cand) == v1
                {
                    pick = cand;
                    break;
                }
            }
            self.v_out[v1.idx()] = pick;
        }
        self.delete_edge(h.edge());
        self.v_deleted[v0.idx()] = true;
        self.v_out[v0.idx()] = HalfedgeId::INVALID;
        self.live_vertices -= 1;
        self.adjust_outgoing(v1);
        CollapseResult {
            kept: v1,
            removed: v0,
            removed_edges,
            removed_faces,
            kept_edges,
        }
    }

    /// Deletes whole parts: every vertex for which `remove` is true, with
    /// its edges and faces. `remove` must hold on whole connected parts
    /// (every neighbour of a removed vertex is removed), so that no kept
    /// element loses a neighbour.
    pub fn remove_parts(&mut self, remove: impl Fn(VertexId) -> bool) {
        let doomed: Vec<VertexId> = self.vertices().filter(|&v| remove(v)).collect();
        for &v in &doomed {
            if !self.is_isolated(v) {
                let out: Vec<HalfedgeId> = self.outgoing(v).collect();
                for h in out {
                    debug_assert!(remove(self.to_vertex(h)), "a part is removed whole");
                    if !self.e_deleted[h.edge().idx()] {
                        self.delete_edge(h.edge());
                    }
                    let f = self.face(h);
                    if f.is_valid() && !self.f_deleted[f.idx()] {
                        self.delete_face(f);
                    }
                }
            }
            self.v_deleted[v.idx()] = true;
            self.v_out[v.idx()] = HalfedgeId::INVALID;
            self.live_vertices -= 1;
        }
    }

    fn delete_edge(&mut self, e: EdgeId) {
        debug_assert!(!self.e_deleted[e.idx()]);
        self.e_deleted[e.idx()] = true;
        self.live_edges -= 1;
    }

    fn delete_face(&mut self, f: FaceId) {
        debug_assert!(!self.f_deleted[f.idx()]);
        self.f_deleted[f.idx()] = true;
        self.live_faces -= 1;
    }

    // ----------------------------------------------------------------- flip

    /// Whether edge `e` can be flipped: it is interior, the two opposite
    /// corners differ and are not already joined (no duplicate edge), and both
    /// endpoints keep at least three edges (two on the boundary).
    pub fn can_flip(&self, e: EdgeId) -> bool {
        if self.is_edge_deleted(e) || self.is_boundary_edge(e) {
            return false;
        }
        let h = e.halfedge(0);
        let o = h.twin();
        let c = self.to_vertex(self.next(h));
        let d = self.to_vertex(self.next(o));
        if c == d {
            return false;
        }
        for v in [self.to_vertex(h), self.to_vertex(o)] {
            let min = if self.is_boundary_vertex(v) { 2 } else { 3 };
            if self.outgoing(v).take(min + 1).count() <= min {
                return false;
            }
        }
        // Walk both rings in step: O(min valence) even at a fan centre.
        let (mut rc, mut rd) = (self.outgoing(c), self.outgoing(d));
        loop {
            match (rc.next(), rd.next()) {
                (None, _) | (_, None) => return true,
                (Some(x), Some(y)) => {
                    if self.to_vertex(x) == d || self.to_vertex(y) == c {
                        return false;
                    }
                }
            }
        }
    }

    /// Flips interior edge `e` so that it joins the two opposite corners.
    /// Afterwards `e.halfedge(0)` runs from `d` to `c` where `c` was the corner
    /// opposite it before; faces keep their labels.
    pub fn flip_edge(&mut self, e: EdgeId) {
        debug_assert!(self.can_flip(e));
        let h = e.halfedge(0); // a -> b
        let o = h.twin(); // b -> a
        let h1 = self.next(h); // b -> c
        let h2 = self.next(h1); // c -> a
        let o1 = self.next(o); // a -> d
        let o2 = self.next(o1); // d -> b
        let a = self.to_vertex(o);
        let b = self.to_vertex(h);
        let c = self.to_vertex(h1);
        let d = self.to_vertex(o1);
        let fh = self.face(h);
        let fo = self.face(o);
        // F: h2 (c->a), o1 (a->d), h (d->c);  G: o2 (d->b), h1 (b->c), o (c->d)
        self.he_to[h.idx()] = c;
        self.he_to[o.idx()] = d;
        self.link(h, h2);
        self.link(h2, o1);
        self.link(o1, h);
        self.link(o, o2);
        self.link(o2, h1);
        self.link(h1, o);
        self.he_face[o1.idx()] = fh;
        self.he_face[h1.idx()] = fo;
        self.f_he[fh.idx()] = h;
        self.f_he[fo.idx()] = o;
        if self.v_out[a.idx()] == h {
            self.v_out[a.idx()] = o1;
        }
        if self.v_out[b.idx()] == o {
            self.v_out[b.idx()] = h1;
        }
    }
}
