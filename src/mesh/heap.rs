//! The entry of the Dijkstra-like searches over mesh elements (the cut graph's shortest-path
//! forest, the thin-part search): in a `BinaryHeap` (a max-heap) the smallest distance comes
//! first, and of equal distances the smallest index, so the searches are deterministic.

use std::cmp::Ordering;

/// (distance, element index).
#[derive(PartialEq)]
pub(crate) struct Nearest(pub f64, pub u32);

impl Eq for Nearest {}

impl PartialOrd for Nearest {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for Nearest {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}
