//! The undirected edge table of a triangle list and the counts derived from
//! it, with the definitions of the benchmark's `quality.py` (`edge_table`,
//! `topology`, valence in `element_quality`): an edge is an unordered vertex
//! pair used by at least one face; its face count is the number of face
//! sides on it; a boundary edge has one face; valence counts distinct edges.
//!
//! The table is read off [`crate::topology::EdgeTable`], the one edge
//! table of the crate.

use crate::topology;
pub(crate) use crate::topology::UnionFind;

/// One undirected edge `a < b` and the number of face sides on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Edge {
    pub a: u32,
    pub b: u32,
    pub faces: u32,
}

/// The unique edges of a mesh with their face counts, and the flags found
/// while counting them.
pub(crate) struct EdgeCounts {
    /// Unique edges in increasing (a, b) order.
    pub edges: Vec<Edge>,
    /// Edges with more than two faces.
    pub non_manifold_edges: usize,
    /// Some two-face edge is used twice in the same direction.
    pub misoriented: bool,
}

impl EdgeCounts {
    /// Builds the table of `triangles`, each of whose indices must be
    /// `< vertex_count`; faces with an out-of-range index or a repeated
    /// corner are skipped by the caller, and left out here too. A side
    /// runs forward when it goes from the smaller end point to the larger.
    pub fn new(triangles: &[[u32; 3]], vertex_count: usize) -> Self {
        let mut edges = Vec::new();
        let mut non_manifold_edges = 0;
        let mut misoriented = false;
        topology::EdgeTable::new(triangles, vertex_count).for_each(|a, _, hs| {
            let faces = hs.len() as u32;
            edges.push(Edge {
                a,
                b: hs[0].0,
                faces,
            });
            if faces > 2 {
                non_manifold_edges += 1;
            } else if faces == 2 {
                let from = |h: u32| triangles[(h / 3) as usize][(h % 3) as usize];
                let forward = hs.iter().filter(|&&(_, h)| from(h) == a).count();
                misoriented |= forward != 1;
            }
        });
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
    fn face_counts_and_orientation() {
        let tris = [[0, 1, 2], [2, 1, 3], [1, 0, 4], [0, 1, 5], [3, 2, 1]];
        let p = EdgeCounts::new(&tris, 6);
        assert_eq!(p.edges.len(), 9);
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
