//! The undirected edge table of a triangle list and the counts derived from
//! it, with the definitions of the benchmark's `quality.py` (`edge_table`,
//! `topology`, valence in `element_quality`): an edge is an unordered vertex
//! pair used by at least one face; its face count is the number of face
//! sides on it; a boundary edge has one face; valence counts distinct edges.
//!
//! The table is built by sorting one packed `u64` key per face side, so it
//! costs one radix-friendly sort and no hashing.

use rayon::prelude::*;

pub(crate) use crate::topology::UnionFind;

/// One undirected edge `a < b` and the number of face sides on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Edge {
    pub a: u32,
    pub b: u32,
    pub faces: u32,
}

/// The unique edges of a mesh and the flags found while building them.
pub(crate) struct EdgeTable {
    /// Unique edges in increasing (a, b) order.
    pub edges: Vec<Edge>,
    /// Edges with more than two faces.
    pub non_manifold_edges: usize,
    /// Some two-face edge is used twice in the same direction.
    pub misoriented: bool,
}

impl EdgeTable {
    /// Builds the table of `triangles`, each of whose indices must be
    /// `< vertex_count`; faces with an out-of-range index or a repeated
    /// corner are skipped by the caller, not here.
    pub fn new(triangles: &[[u32; 3]], vertex_count: usize) -> Self {
        if vertex_count < (1usize << 31) {
            Self::packed(triangles)
        } else {
            Self::wide(triangles)
        }
    }

    /// Key = min·2³³ + max·2 + forward bit, fitting u64 while indices are < 2³¹.
    fn packed(triangles: &[[u32; 3]]) -> Self {
        let mut keys: Vec<u64> = Vec::with_capacity(triangles.len() * 3);
        keys.par_extend(triangles.par_iter().flat_map_iter(|t| {
            (0..3).map(move |k| {
                let (u, v) = (t[k] as u64, t[(k + 1) % 3] as u64);
                if u < v {
                    (u << 33) | (v << 1) | 1
                } else {
                    (v << 33) | (u << 1)
                }
            })
        }));
        keys.par_sort_unstable();
        Self::from_sorted(keys.iter().map(|&k| (k >> 1, k & 1 == 1)), |e| {
            ((e >> 32) as u32, (e & 0xFFFF_FFFF) as u32)
        })
    }

    /// Fallback for ≥ 2³¹ vertices: (edge, forward) pairs.
    fn wide(triangles: &[[u32; 3]]) -> Self {
        let mut keys: Vec<(u64, bool)> = Vec::with_capacity(triangles.len() * 3);
        for t in triangles {
            for k in 0..3 {
                let (u, v) = (t[k] as u64, t[(k + 1) % 3] as u64);
                keys.push(((u.min(v) << 32) | u.max(v), u < v));
            }
        }
        keys.par_sort_unstable();
        Self::from_sorted(keys.into_iter(), |e| {
            ((e >> 32) as u32, (e & 0xFFFF_FFFF) as u32)
        })
    }

    /// Run-length pass over sorted (edge key, forward) pairs.
    fn from_sorted(
        sorted: impl Iterator<Item = (u64, bool)>,
        decode: impl Fn(u64) -> (u32, u32),
    ) -> Self {
        let mut edges = Vec::new();
        let mut non_manifold_edges = 0;
        let mut misoriented = false;
        let mut current: Option<(u64, u32, u32)> = None; // key, faces, forward
        let mut flush = |key: u64, faces: u32, forward: u32, edges: &mut Vec<Edge>| {
            let (a, b) = decode(key);
            edges.push(Edge { a, b, faces });
            if faces > 2 {
                non_manifold_edges += 1;
            } else if faces == 2 && forward != 1 {
                misoriented = true;
            }
        };
        for (key, fwd) in sorted {
            match &mut current {
                Some((k, faces, forward)) if *k == key => {
                    *faces += 1;
                    *forward += fwd as u32;
                }
                _ => {
                    if let Some((k, faces, forward)) = current {
                        flush(k, faces, forward, &mut edges);
                    }
                    current = Some((key, 1, fwd as u32));
                }
            }
        }
        if let Some((k, faces, forward)) = current {
            flush(k, faces, forward, &mut edges);
        }
        Self {
            edges,
            non_manifold_edges,
            misoriented,
        }
    }
}

/// Number of distinct sets among the vertices for which `member` is true.
pub(crate) fn count_sets(uf: &mut UnionFind, member: &[bool]) -> usize {
    (0..member.len() as u32)
        .filter(|&v| member[v as usize] && uf.find(v) == v)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_and_wide_tables_agree() {
        let tris = [[0, 1, 2], [2, 1, 3], [1, 0, 4], [0, 1, 5], [3, 2, 1]];
        let p = EdgeTable::packed(&tris);
        let w = EdgeTable::wide(&tris);
        assert_eq!(p.edges, w.edges);
        assert_eq!(p.non_manifold_edges, w.non_manifold_edges);
        assert_eq!(p.misoriented, w.misoriented);
        // Edges 0-1 and 1-2 carry three faces; 2-3 and 1-3 carry two, but
        // [3,2,1] runs along them in the same directions as [2,1,3].
        assert_eq!(p.non_manifold_edges, 2);
        let e23 = p.edges.iter().find(|e| (e.a, e.b) == (2, 3)).unwrap();
        assert_eq!(e23.faces, 2);
        assert!(p.misoriented);
        let e01 = p.edges.iter().find(|e| (e.a, e.b) == (0, 1)).unwrap();
        assert_eq!(e01.faces, 3);
    }

    #[test]
    fn union_find_counts_sets() {
        let mut uf = UnionFind::new(6);
        uf.union(0, 1);
        uf.union(4, 3);
        uf.union(1, 3);
        assert_eq!(uf.find(4), uf.find(0));
        assert_eq!(count_sets(&mut uf, &[true; 6]), 3);
        assert_eq!(
            count_sets(&mut uf, &[true, true, false, true, true, false]),
            1
        );
    }
}
