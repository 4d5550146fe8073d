//! Compaction ("garbage collection"): removes deleted elements and remaps
//! every handle, keeping the relative order of the survivors.

use super::{FaceId, HalfedgeId, Mesh, VertexId};
use crate::mesh::handles::Handle;

/// Old-to-new index tables produced by [`Mesh::compact`]; `u32::MAX` marks a
/// removed element. Apply them to caller-owned maps with [`super::Attr::remap`].
#[derive(Clone, Debug, Default)]
pub struct Remap {
    /// New index of each old vertex.
    pub vertices: Vec<u32>,
    /// New index of each old edge.
    pub edges: Vec<u32>,
    /// New index of each old face.
    pub faces: Vec<u32>,
}

fn table(deleted: &[bool]) -> Vec<u32> {
    let mut next = 0u32;
    deleted
        .iter()
        .map(|&d| {
            if d {
                u32::MAX
            } else {
                next += 1;
                next - 1
            }
        })
        .collect()
}

fn retain<T: Copy>(v: &mut Vec<T>, map: &[u32]) {
    let mut k = 0;
    for i in 0..v.len() {
        if map[i] != u32::MAX {
            v[k] = v[i];
            k += 1;
        }
    }
    v.truncate(k);
}

impl Mesh {
    /// Removes deleted elements and renumbers the rest in order. Returns the
    /// old-to-new tables for callers that keep their own attribute maps.
    pub fn compact(&mut self) -> Remap {
        let vmap = table(&self.v_deleted);
        let emap = table(&self.e_deleted);
        let fmap = table(&self.f_deleted);
        // Half-edge map follows the edge map (pairs stay pairs).
        let hmap = |h: HalfedgeId| -> HalfedgeId {
            if !h.is_valid() {
                return h;
            }
            let e = emap[h.idx() >> 1];
            debug_assert!(e != u32::MAX, "live element refers to a deleted edge");
            HalfedgeId((e << 1) | (h.0 & 1))
        };
        let mut hdeleted = Vec::with_capacity(self.he_to.len());
        for &d in &self.e_deleted {
            hdeleted.extend_from_slice(&[d, d]);
        }
        let hkeep = table(&hdeleted);

        for h in &mut self.v_out {
            *h = hmap(*h);
        }
        for v in &mut self.he_to {
            if v.is_valid() && vmap[v.idx()] != u32::MAX {
                *v = VertexId(vmap[v.idx()]);
            }
        }
        for h in self.he_next.iter_mut().chain(self.he_prev.iter_mut()) {
            if h.is_valid() && emap[h.idx() >> 1] != u32::MAX {
                *h = hmap(*h);
            }
        }
        for f in &mut self.he_face {
            if f.is_valid() && fmap[f.idx()] != u32::MAX {
                *f = FaceId(fmap[f.idx()]);
            }
        }
        for h in &mut self.f_he {
            if h.is_valid() && emap[h.idx() >> 1] != u32::MAX {
                *h = hmap(*h);
            }
        }
        retain(&mut self.pos, &vmap);
        retain(&mut self.v_out, &vmap);
        retain(&mut self.v_deleted, &vmap);
        retain(&mut self.he_to, &hkeep);
        retain(&mut self.he_next, &hkeep);
        retain(&mut self.he_prev, &hkeep);
        retain(&mut self.he_face, &hkeep);
        retain(&mut self.e_deleted, &emap);
        retain(&mut self.f_he, &fmap);
        retain(&mut self.f_deleted, &fmap);
        self.face_label.remap(&fmap);
        self.edge_flags.remap(&emap);
        debug_assert_eq!(self.pos.len(), self.live_vertices);
        debug_assert_eq!(self.e_deleted.len(), self.live_edges);
        debug_assert_eq!(self.f_he.len(), self.live_faces);
        Remap {
            vertices: vmap,
            edges: emap,
            faces: fmap,
        }
    }
}
