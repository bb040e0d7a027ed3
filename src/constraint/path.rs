//! Shortest edge paths between picked vertices (the curve tool extends a curve by one per click).

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashSet};

use crate::mesh::TriMesh;

/// The vertices of a shortest edge path (by edge length) from `a` to `b`, both included; over
/// all edges, boundary ones too (curves may follow the boundary). `None` when `b` cannot be
/// reached (another component) or a vertex is out of range.
pub fn shortest_edge_path(mesh: &TriMesh, a: usize, b: usize) -> Option<Vec<usize>> {
    shortest_edge_path_avoiding(mesh, a, b, &HashSet::new())
}

/// An edge as its vertex pair, the smaller first (one edge per pair on a manifold mesh).
pub fn edge_key(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

/// The edges of an open vertex path, as [`edge_key`]s.
pub fn path_edges(path: &[usize]) -> HashSet<(usize, usize)> {
    path.windows(2).map(|w| edge_key(w[0], w[1])).collect()
}

/// [`shortest_edge_path`] over the edges not in `blocked` (the curve tool keeps a curve from
/// running back along its own edges); `None` when `b` cannot be reached that way.
pub fn shortest_edge_path_avoiding(
    mesh: &TriMesh,
    a: usize,
    b: usize,
    blocked: &HashSet<(usize, usize)>,
) -> Option<Vec<usize>> {
    let nv = mesh.n_vertices();
    if a >= nv || b >= nv {
        return None;
    }
    if a == b {
        return Some(vec![a]);
    }
    let mut dist = vec![f64::INFINITY; nv];
    let mut prev = vec![usize::MAX; nv];
    let mut heap = BinaryHeap::new();
    dist[a] = 0.0;
    heap.push((Reverse(OrdF64(0.0)), a));
    while let Some((Reverse(OrdF64(d)), v)) = heap.pop() {
        if d > dist[v] {
            continue;
        }
        if v == b {
            break;
        }
        let p = mesh.position(v);
        for w in mesh.one_ring(v) {
            if blocked.contains(&edge_key(v, w)) {
                continue;
            }
            let nd = d + (mesh.position(w) - p).length();
            if nd < dist[w] {
                dist[w] = nd;
                prev[w] = v;
                heap.push((Reverse(OrdF64(nd)), w));
            }
        }
    }
    if prev[b] == usize::MAX {
        return None;
    }
    let mut path = vec![b];
    while let Some(&v) = path.last()
        && v != a
    {
        path.push(prev[v]);
    }
    path.reverse();
    Some(path)
}

#[derive(Clone, Copy, PartialEq)]
struct OrdF64(f64);
impl Eq for OrdF64 {}
impl PartialOrd for OrdF64 {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for OrdF64 {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn paths_run_over_edges_and_along_the_boundary() {
        let m = generate::grid(4, 4, 1.0, 1.0);
        let p = shortest_edge_path(&m, 0, 4).unwrap();
        assert_eq!(p, vec![0, 1, 2, 3, 4]);
        let q = shortest_edge_path(&m, 0, 24).unwrap();
        assert!(super::super::check_path(&m, &q, false).is_ok());
        assert_eq!(*q.last().unwrap(), 24);
        assert_eq!(shortest_edge_path(&m, 3, 3), Some(vec![3]));
        assert_eq!(shortest_edge_path(&m, 3, 99), None);
    }

    #[test]
    fn paths_avoid_the_blocked_edges_or_are_none() {
        let m = generate::grid(4, 4, 1.0, 1.0);
        let blocked = path_edges(&[2, 1]);
        let p = shortest_edge_path_avoiding(&m, 0, 2, &blocked).unwrap();
        assert_eq!((p[0], *p.last().unwrap()), (0, 2));
        assert!(super::super::check_path(&m, &p, false).is_ok());
        assert!(
            p.windows(2)
                .all(|w| !blocked.contains(&edge_key(w[0], w[1])))
        );
        // Every edge at vertex 0 blocked: unreachable.
        let around: HashSet<_> = m.one_ring(0).into_iter().map(|w| edge_key(0, w)).collect();
        assert_eq!(shortest_edge_path_avoiding(&m, 0, 2, &around), None);
        assert_eq!(
            shortest_edge_path_avoiding(&m, 3, 3, &around),
            Some(vec![3])
        );
    }
}
