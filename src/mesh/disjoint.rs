//! Disjoint sets over `0..n` (union by smaller root, path halving): the connected pieces of
//! feature edges (`constraint::detect`) and the fans of faces around a remesh vertex
//! (`extract::pinch`). Deterministic: the root of a set is its smallest element.

pub(crate) struct Disjoint(Vec<usize>);

impl Disjoint {
    pub(crate) fn new(n: usize) -> Disjoint {
        Disjoint((0..n).collect())
    }

    /// The set's smallest element.
    pub(crate) fn find(&mut self, mut x: usize) -> usize {
        while self.0[x] != x {
            self.0[x] = self.0[self.0[x]];
            x = self.0[x];
        }
        x
    }

    pub(crate) fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.0[ra.max(rb)] = ra.min(rb);
        }
    }
}
