//! Topology helpers shared by the readers, the curvature estimate and the
//! statistics: a disjoint-set forest over `u32` ids, for grouping vertices
//! into components or boundary loops and corners into smooth fans.

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
    fn the_smallest_member_is_the_root() {
        let mut uf = UnionFind::new(6);
        uf.union(4, 3);
        uf.union(5, 4);
        uf.union(1, 0);
        assert_eq!(uf.find(5), 3);
        assert_eq!(uf.into_roots(), vec![0, 0, 2, 3, 3, 3]);
    }
}
