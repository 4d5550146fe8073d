//! Topology helpers shared by the mesh builder, the readers, the curvature
//! estimate, feature detection, attribute transfer and the statistics:
//! compressed rows ([`Csr`]) for every per-vertex list (faces, corners,
//! outgoing half-edges), the undirected [`EdgeTable`] of a triangle list,
//! and a disjoint-set forest over `u32` ids, for grouping vertices into
//! components or boundary loops and corners into smooth fans.

/// Rows of values in one flat array (compressed sparse rows): row `r` is
/// `values[start[r]..start[r + 1]]`. Built in two passes over the same
/// pairs, a count and a fill, so a mesh-sized list of pairs is never held
/// and no row is a separate allocation.
#[derive(Clone, Debug, Default)]
pub struct Csr<T> {
    start: Vec<u32>,
    values: Vec<T>,
}

impl<T: Copy + Default> Csr<T> {
    /// Builds `rows` rows from the `(row, value)` pairs that `pairs()`
    /// yields. `pairs` is called twice and must yield the same pairs both
    /// times; within a row, values keep the order in which they came, so
    /// the result is as deterministic as the pairs.
    ///
    /// # Panics
    /// If a row index is `>= rows`, or there are `u32::MAX` values or more.
    pub fn from_pairs<I>(rows: usize, pairs: impl Fn() -> I) -> Self
    where
        I: Iterator<Item = (u32, T)>,
    {
        let mut start = vec![0u32; rows + 1];
        for (r, _) in pairs() {
            start[r as usize + 1] += 1;
        }
        for r in 0..rows {
            start[r + 1] = start[r]
                .checked_add(start[r + 1])
                .expect("fewer than 2^32 values in compressed rows");
        }
        let mut fill: Vec<u32> = start[..rows].to_vec();
        let mut values = vec![T::default(); start[rows] as usize];
        for (r, v) in pairs() {
            let slot = &mut fill[r as usize];
            values[*slot as usize] = v;
            *slot += 1;
        }
        Self { start, values }
    }
}

impl<T> Csr<T> {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// Row `r`.
    #[inline]
    pub fn row(&self, r: u32) -> &[T] {
        &self.values[self.start[r as usize] as usize..self.start[r as usize + 1] as usize]
    }

    /// Row `r`, mutable.
    #[inline]
    pub fn row_mut(&mut self, r: u32) -> &mut [T] {
        &mut self.values[self.start[r as usize] as usize..self.start[r as usize + 1] as usize]
    }

    /// The row offsets, `rows() + 1` of them.
    pub fn starts(&self) -> &[u32] {
        &self.start
    }

    /// All values, row after row.
    pub fn values(&self) -> &[T] {
        &self.values
    }

    /// Sorts every row.
    pub fn sort_rows(&mut self)
    where
        T: Ord,
    {
        for r in 0..self.rows() as u32 {
            let row = self.row_mut(r);
            if row.len() > 1 {
                row.sort_unstable();
            }
        }
    }

    /// The offsets and the values.
    pub fn into_parts(self) -> (Vec<u32>, Vec<T>) {
        (self.start, self.values)
    }
}

/// The key of the undirected edge `a`–`b`: the smaller index in the high
/// half, so that both orders give the same key and keys sort by their
/// first vertex.
#[inline]
pub fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// Is `t` a face with three in-range, distinct corners?
#[inline]
pub fn is_proper(t: &[u32; 3], vertex_count: usize) -> bool {
    t.iter().all(|&v| (v as usize) < vertex_count) && t[0] != t[1] && t[1] != t[2] && t[2] != t[0]
}

/// The undirected edges of a triangle list with the half-edges on each.
/// A half-edge is `3·face + k`, the side from corner `k` to corner `k + 1`.
/// Faces with a repeated or out-of-range corner are left out. Half-edges
/// are bucketed by the edge's smaller end point (rows of a [`Csr`]) and
/// sorted by the larger one and then by half-edge, so edges come in
/// increasing (a, b) order without a global sort.
#[derive(Clone, Debug, Default)]
pub struct EdgeTable {
    rows: Csr<(u32, u32)>,
}

impl EdgeTable {
    /// Builds the table of `triangles` over `vertex_count` vertices.
    pub fn new(triangles: &[[u32; 3]], vertex_count: usize) -> Self {
        let mut rows = Csr::from_pairs(vertex_count, || {
            triangles
                .iter()
                .enumerate()
                .filter(|(_, t)| is_proper(t, vertex_count))
                .flat_map(|(f, t)| {
                    (0..3).map(move |k| {
                        let (a, b) = (t[k], t[(k + 1) % 3]);
                        (a.min(b), (a.max(b), 3 * f as u32 + k as u32))
                    })
                })
        });
        rows.sort_rows();
        Self { rows }
    }

    /// Calls `f(a, b, half_edges)` for every undirected edge `a < b` in
    /// increasing order; `half_edges` are its `(b, half-edge)` pairs.
    pub fn for_each(&self, mut f: impl FnMut(u32, u32, &[(u32, u32)])) {
        for a in 0..self.rows.rows() as u32 {
            for run in self.rows.row(a).chunk_by(|x, y| x.0 == y.0) {
                f(a, run[0].0, run);
            }
        }
    }
}

/// Per triangle `[a, b, c]`, the triangles across its edges `ab`, `bc`
/// and `ca`, or `u32::MAX` where there is none (a boundary); across a
/// non-manifold edge, the lowest-numbered other triangle on it.
pub fn face_neighbors(triangles: &[[u32; 3]], vertex_count: usize) -> Vec<[u32; 3]> {
    let mut nb = vec![[u32::MAX; 3]; triangles.len()];
    EdgeTable::new(triangles, vertex_count).for_each(|_, _, run| {
        if run.len() < 2 {
            return;
        }
        // A run is in half-edge order, so in face order.
        for &(_, h) in run {
            let f = h / 3;
            if let Some(&(_, g)) = run.iter().find(|&&(_, g)| g / 3 != f) {
                nb[f as usize][(h % 3) as usize] = g / 3;
            }
        }
    });
    nb
}

/// Groups the corners of `triangles` (corner `3·face + k`) into fans: the
/// corners at one vertex, joined across edges. `visit(a, b, half_edges)` sees
/// every edge of the [`EdgeTable`] once, in order, and says whether to join
/// across it; the join happens only where the edge has exactly two faces
/// running it in opposite directions (an interior, consistently oriented
/// edge), since only then does each end have one corner on either side.
/// A fan is then one union-find class.
pub fn corner_fans(
    triangles: &[[u32; 3]],
    vertex_count: usize,
    mut visit: impl FnMut(u32, u32, &[(u32, u32)]) -> bool,
) -> UnionFind {
    let from = |h: u32| triangles[(h / 3) as usize][(h % 3) as usize];
    let next = |c: u32| 3 * (c / 3) + (c % 3 + 1) % 3;
    let mut fans = UnionFind::new(triangles.len() * 3);
    EdgeTable::new(triangles, vertex_count).for_each(|a, b, run| {
        if !visit(a, b, run) {
            return;
        }
        if let [(_, h0), (_, h1)] = *run {
            if from(h0) != from(h1) {
                // h0 and h1 start at opposite ends; the corner after each
                // is the other's start.
                fans.union(h0, next(h1));
                fans.union(next(h0), h1);
            }
        }
    });
    fans
}

/// Disjoint-set forest with path halving; a union keeps the smaller root,
/// so every class's root is its smallest member whatever the order of the
/// unions, and results built from roots are deterministic.
#[derive(Clone, Debug)]
pub struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    /// `n` singleton sets, `0..n`.
    pub fn new(n: usize) -> Self {
        Self {
            parent: (0..n as u32).collect(),
        }
    }

    /// The root of `x`'s set.
    #[inline]
    pub fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let grand = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = grand;
            x = grand;
        }
        x
    }

    /// Merges the sets of `a` and `b`.
    #[inline]
    pub fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            self.parent[hi as usize] = lo;
        }
    }

    /// Every element's root, in element order.
    pub fn into_roots(mut self) -> Vec<u32> {
        for x in 0..self.parent.len() as u32 {
            let r = self.find(x);
            self.parent[x as usize] = r;
        }
        self.parent
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_keep_the_order_of_their_pairs() {
        let pairs = [(2u32, 'a'), (0, 'b'), (2, 'c'), (0, 'd'), (3, 'e')];
        let csr = Csr::from_pairs(4, || pairs.iter().copied());
        assert_eq!(csr.rows(), 4);
        assert_eq!(csr.row(0), &['b', 'd']);
        assert_eq!(csr.row(1), &[] as &[char]);
        assert_eq!(csr.row(2), &['a', 'c']);
        assert_eq!(csr.row(3), &['e']);
        assert_eq!(csr.starts(), &[0, 2, 2, 4, 5]);
    }

    #[test]
    fn edges_come_sorted_with_their_half_edges() {
        // Two faces on 0-1-2 / 2-1-3, and one face with a repeated corner.
        let tris = [[0, 1, 2], [2, 1, 3], [3, 3, 0]];
        let mut seen = Vec::new();
        EdgeTable::new(&tris, 4).for_each(|a, b, hs| {
            seen.push((a, b, hs.iter().map(|h| h.1).collect::<Vec<_>>()));
        });
        assert_eq!(
            seen,
            vec![
                (0, 1, vec![0]),
                (0, 2, vec![2]),
                (1, 2, vec![1, 3]),
                (1, 3, vec![4]),
                (2, 3, vec![5]),
            ]
        );
    }

    #[test]
    fn the_smallest_member_is_the_root() {
        let mut uf = UnionFind::new(6);
        uf.union(4, 3);
        uf.union(5, 4);
        uf.union(1, 0);
        assert_eq!(uf.find(5), 3);
        assert_eq!(uf.into_roots(), vec![0, 0, 2, 3, 3, 3]);
    }

    #[test]
    fn face_neighbors_cross_the_named_edge() {
        for (tm, open) in [
            (crate::shapes::icosphere(2), false),
            (crate::shapes::grid(1.0, 6), true),
        ] {
            let nb = face_neighbors(&tm.triangles, tm.positions.len());
            let mut missing = 0;
            for (f, t) in tm.triangles.iter().enumerate() {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    let g = nb[f][k];
                    if g == u32::MAX {
                        missing += 1;
                        continue;
                    }
                    let u = tm.triangles[g as usize];
                    assert_ne!(g as usize, f);
                    assert!((0..3).any(|j| u[j] == b && u[(j + 1) % 3] == a));
                }
            }
            assert_eq!(missing > 0, open);
        }
    }
}
