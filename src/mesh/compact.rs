//! Compaction ("garbage collection"): removes deleted elements and remaps
//! every handle, keeping the relative order of the survivors
//! ([`Mesh::compact`]) or renumbering them in a caller's vertex order for
//! memory locality ([`Mesh::compact_in_order`]).

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

/// Scatters the live entries of `v` to their new places (`map[i]` is the
/// new index of entry `i`; `u32::MAX`, or no entry in `map`, drops it) in a
/// table of `len` entries, the rest `fill`. Callers with their own
/// per-element tables apply a [`Remap`] with it.
pub fn scatter<T: Copy>(v: &mut Vec<T>, map: &[u32], len: usize, fill: T) {
    let mut out = vec![fill; len];
    for (i, &x) in v.iter().enumerate() {
        match map.get(i) {
            Some(&j) if j != u32::MAX => out[j as usize] = x,
            _ => {}
        }
    }
    *v = out;
}

impl Mesh {
    /// Removes deleted elements and renumbers the rest in order. Returns the
    /// old-to-new tables for callers that keep their own attribute maps.
    pub fn compact(&mut self) -> Remap {
        let vmap = table(&self.v_deleted);
        let emap = table(&self.e_deleted);
        let fmap = table(&self.f_deleted);
        self.apply_remap(vmap, emap, fmap)
    }

    /// Removes deleted elements and renumbers the rest for memory locality:
    /// vertices in the order of `order` (every live vertex exactly once),
    /// and each edge and face when it is first met around those vertices,
    /// so that neighbours in the mesh are mostly neighbours in memory.
    /// Returns the old-to-new tables, as [`Mesh::compact`] does.
    ///
    /// # Panics
    /// If `order` does not list every live vertex exactly once.
    pub fn compact_in_order(&mut self, order: &[VertexId]) -> Remap {
        assert_eq!(
            order.len(),
            self.live_vertices,
            "order must list every live vertex"
        );
        let mut vmap = vec![u32::MAX; self.pos.len()];
        let mut emap = vec![u32::MAX; self.e_deleted.len()];
        let mut fmap = vec![u32::MAX; self.f_deleted.len()];
        let (mut ne, mut nf) = (0u32, 0u32);
        for (k, &v) in order.iter().enumerate() {
            assert!(
                !self.v_deleted[v.idx()] && vmap[v.idx()] == u32::MAX,
                "order must list live vertices once"
            );
            vmap[v.idx()] = k as u32;
            for h in self.outgoing(v) {
                let e = h.idx() >> 1;
                if emap[e] == u32::MAX {
                    emap[e] = ne;
                    ne += 1;
                }
                let f = self.he_face[h.idx()];
                if f.is_valid() && fmap[f.idx()] == u32::MAX {
                    fmap[f.idx()] = nf;
                    nf += 1;
                }
            }
        }
        assert_eq!(
            ne as usize, self.live_edges,
            "every live edge has a live end"
        );
        assert_eq!(
            nf as usize, self.live_faces,
            "every live face has a live corner"
        );
        self.apply_remap(vmap, emap, fmap)
    }

    /// Moves every live element to its new index and rewrites every handle.
    fn apply_remap(&mut self, vmap: Vec<u32>, emap: Vec<u32>, fmap: Vec<u32>) -> Remap {
        // Half-edge map follows the edge map (pairs stay pairs).
        let hmap_table: Vec<u32> = (0..self.he_to.len())
            .map(|h| {
                let e = emap[h >> 1];
                if e == u32::MAX {
                    u32::MAX
                } else {
                    (e << 1) | (h as u32 & 1)
                }
            })
            .collect();
        let hmap = |h: HalfedgeId| -> HalfedgeId {
            if !h.is_valid() {
                return h;
            }
            debug_assert!(
                hmap_table[h.idx()] != u32::MAX,
                "live element refers to a deleted edge"
            );
            HalfedgeId(hmap_table[h.idx()])
        };
        let (nv, ne, nf) = (self.live_vertices, self.live_edges, self.live_faces);

        for (i, h) in self.v_out.iter_mut().enumerate() {
            if vmap[i] != u32::MAX {
                *h = hmap(*h);
            }
        }
        for (i, v) in self.he_to.iter_mut().enumerate() {
            if hmap_table[i] != u32::MAX && v.is_valid() {
                *v = VertexId(vmap[v.idx()]);
            }
        }
        for links in [&mut self.he_next, &mut self.he_prev] {
            for (i, h) in links.iter_mut().enumerate() {
                if hmap_table[i] != u32::MAX {
                    *h = hmap(*h);
                }
            }
        }
        for (i, f) in self.he_face.iter_mut().enumerate() {
            if hmap_table[i] != u32::MAX && f.is_valid() {
                *f = FaceId(fmap[f.idx()]);
            }
        }
        for (i, h) in self.f_he.iter_mut().enumerate() {
            if fmap[i] != u32::MAX {
                *h = hmap(*h);
            }
        }
        scatter(&mut self.pos, &vmap, nv, Default::default());
        scatter(&mut self.v_out, &vmap, nv, HalfedgeId::INVALID);
        scatter(&mut self.v_deleted, &vmap, nv, false);
        scatter(&mut self.he_to, &hmap_table, 2 * ne, VertexId::INVALID);
        scatter(&mut self.he_next, &hmap_table, 2 * ne, HalfedgeId::INVALID);
        scatter(&mut self.he_prev, &hmap_table, 2 * ne, HalfedgeId::INVALID);
        scatter(&mut self.he_face, &hmap_table, 2 * ne, FaceId::INVALID);
        scatter(&mut self.e_deleted, &emap, ne, false);
        scatter(&mut self.f_he, &fmap, nf, HalfedgeId::INVALID);
        scatter(&mut self.f_deleted, &fmap, nf, false);
        self.face_label.remap(&fmap);
        self.edge_flags.remap(&emap);
        Remap {
            vertices: vmap,
            edges: emap,
            faces: fmap,
        }
    }
}
