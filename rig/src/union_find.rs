//! Disjoint sets over `0..n` (union by smaller root, path halving): connected components of meshes,
//! clusters of converged samples.

/// A union–find structure.
#[derive(Debug, Clone)]
pub struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    /// `n` singleton sets.
    pub fn new(n: usize) -> Self {
        assert!(n <= u32::MAX as usize, "at most 2³² elements");
        UnionFind { parent: (0..n as u32).collect() }
    }

    /// The representative of `i`'s set: the smallest element merged into it so far is not promised,
    /// only that all members share one.
    pub fn find(&mut self, mut i: usize) -> usize {
        while self.parent[i] as usize != i {
            self.parent[i] = self.parent[self.parent[i] as usize];
            i = self.parent[i] as usize;
        }
        i
    }

    /// Merges the sets of `a` and `b`; returns whether they were apart.
    pub fn union(&mut self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        self.parent[ra.max(rb)] = ra.min(rb) as u32;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chains_merge_and_strangers_stay_apart() {
        let mut u = UnionFind::new(6);
        assert!(u.union(0, 1) && u.union(2, 1) && u.union(4, 5));
        assert!(!u.union(0, 2));
        assert_eq!(u.find(2), u.find(0));
        assert_ne!(u.find(3), u.find(0));
        assert_ne!(u.find(4), u.find(0));
        assert_eq!(u.find(5), u.find(4));
    }
}
