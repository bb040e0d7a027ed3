//! Cancelling close singularity pairs of opposite index (thesis sec. 3.3, "Singularity
//! Movement": moving a singularity of index k/N along an edge path γ changes the matching of
//! every edge on γ by k; moved onto a singularity of index −k/N, both vanish). Rounding the
//! matchings all at once (sec. 3.2) leaves such pairs a grid cell or less apart on scanned
//! meshes; each costs the parameterization a fold-prone spot and the remesh two irregular
//! vertices, while the field barely changes when they go.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};

use super::index::{Singularity, index_k_at, indices_from_angles};
use super::reduce_matchings;
use super::transport::EdgeTransport;
use crate::mesh::TriMesh;

/// Rounds of pairing: cancelling a pair can leave another singularity without its nearest
/// partner, so pairing is repeated a few times.
const ROUNDS: usize = 5;

/// New per-edge turns (same convention as the smoothing's: from the face of the edge's first
/// halfedge to the other) with opposite-index singularities closer than `radius` (3-D distance)
/// cancelled pairwise, nearest pairs first, and the faces around the changed edges (whose
/// alignment must give way so the field can turn smoothly there); `None` when there is no such
/// pair or nothing could be cancelled.
pub(crate) fn cancel_close_pairs(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    theta: &[f64],
    turns: &[i64],
    n: u32,
    radius: f64,
) -> Option<(Vec<i64>, Vec<usize>)> {
    if radius <= 0.0 {
        return None;
    }
    // Indices are computed once; a moved pair changes matchings only along its path, so only
    // the path's vertices are re-evaluated (a full pass costs 0.4 s at a million faces).
    let rep = indices_from_angles(mesh, tr, theta, &reduce_matchings(tr, turns, n), n);
    let mut singular: BTreeMap<usize, i32> =
        rep.singularities.iter().map(|s| (s.vertex, s.k)).collect();
    let before = singular.len();
    let mut r = turns.to_vec();
    let mut sign: Option<i64> = None;
    let mut released = Vec::new();
    let mut search = PathSearch::new(mesh.n_vertices());
    for _ in 0..ROUNDS {
        let pairs = close_pairs(mesh, &singular, radius);
        let mut changed = false;
        for (a, b, k) in pairs {
            let Some(path) = search.shortest_interior_path(mesh, a, b, 3.0 * radius) else {
                continue;
            };
            let s = match sign {
                Some(s) => s,
                None => {
                    // The sign that makes the pair vanish (a sign error would double it instead).
                    apply(mesh, &mut r, &path, k, 1);
                    let vanishes = index_k_at(mesh, tr, theta, a, n, |e| r[e]) == Some(0);
                    apply(mesh, &mut r, &path, k, -1);
                    let s = if vanishes { 1 } else { -1 };
                    sign = Some(s);
                    s
                }
            };
            apply(mesh, &mut r, &path, k, s);
            for &h in &path {
                for v in [mesh.from(h), mesh.to(h)] {
                    match index_k_at(mesh, tr, theta, v, n, |e| r[e]) {
                        Some(k) if k != 0 => singular.insert(v, k),
                        _ => singular.remove(&v),
                    };
                    released.extend(mesh.outgoing(v).map(|g| mesh.face_of(g)));
                }
            }
            changed = true;
        }
        if !changed {
            break;
        }
    }
    released.sort_unstable();
    released.dedup();
    (singular.len() < before).then_some((r, released))
}

/// Disjoint pairs (a, b, k_a) with k_a + k_b = 0 and |p_a − p_b| < radius, nearest first.
fn close_pairs(
    mesh: &TriMesh,
    singular: &BTreeMap<usize, i32>,
    radius: f64,
) -> Vec<(usize, usize, i32)> {
    let s: Vec<Singularity> = singular
        .iter()
        .map(|(&vertex, &k)| Singularity { vertex, k })
        .collect();
    let mut candidates = Vec::new();
    for i in 0..s.len() {
        for j in i + 1..s.len() {
            if s[i].k + s[j].k != 0 {
                continue;
            }
            let d = (mesh.position(s[i].vertex) - mesh.position(s[j].vertex)).length();
            if d < radius {
                candidates.push((d, i, j));
            }
        }
    }
    candidates.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut used = vec![false; s.len()];
    let mut pairs = Vec::new();
    for (_, i, j) in candidates {
        if !used[i] && !used[j] {
            used[i] = true;
            used[j] = true;
            pairs.push((s[i].vertex, s[j].vertex, s[i].k));
        }
    }
    pairs
}

/// Dijkstra buffers kept across searches: each search touches only the vertices within its
/// length bound, and only those are reset (allocating per pair cost more than the searches).
pub(crate) struct PathSearch {
    dist: Vec<f64>,
    via: Vec<usize>,
    touched: Vec<usize>,
}

impl PathSearch {
    pub(crate) fn new(nv: usize) -> PathSearch {
        PathSearch {
            dist: vec![f64::INFINITY; nv],
            via: vec![usize::MAX; nv],
            touched: Vec::new(),
        }
    }

    /// Halfedges of a shortest edge path from `a` to `b` through interior vertices and interior
    /// edges (matchings live on interior edges only), no longer than `max_length`.
    pub(crate) fn shortest_interior_path(
        &mut self,
        mesh: &TriMesh,
        a: usize,
        b: usize,
        max_length: f64,
    ) -> Option<Vec<usize>> {
        for &v in &self.touched {
            self.dist[v] = f64::INFINITY;
            self.via[v] = usize::MAX;
        }
        self.touched.clear();
        let (dist, via) = (&mut self.dist, &mut self.via);
        let mut heap = BinaryHeap::new();
        dist[a] = 0.0;
        self.touched.push(a);
        heap.push(Reverse((Ordered(0.0), a)));
        while let Some(Reverse((Ordered(d), v))) = heap.pop() {
            if v == b {
                break;
            }
            if d > dist[v] || d > max_length {
                continue;
            }
            for h in mesh.outgoing(v) {
                let w = mesh.to(h);
                if mesh.twin(h).is_none() || (mesh.is_boundary_vertex(w) && w != b) {
                    continue;
                }
                let nd = d + mesh.vector(h).length();
                if nd < dist[w] {
                    if dist[w] == f64::INFINITY {
                        self.touched.push(w);
                    }
                    dist[w] = nd;
                    via[w] = h;
                    heap.push(Reverse((Ordered(nd), w)));
                }
            }
        }
        if via[b] == usize::MAX {
            return None;
        }
        let mut path = Vec::new();
        let mut v = b;
        while v != a {
            let h = via[v];
            path.push(h);
            v = mesh.from(h);
        }
        path.reverse();
        Some(path)
    }
}

/// Moves the singularity of index k/N at the start of `path` to its end: on each edge, the
/// matching from the face right of the path to the face left of it changes by −s·k.
pub(crate) fn apply(mesh: &TriMesh, r: &mut [i64], path: &[usize], k: i32, s: i64) {
    for &h in path {
        let e = mesh.edge(h);
        let first_face = mesh.face_of(mesh.edge_halfedges(e).0);
        let left = mesh.face_of(h);
        if first_face == left {
            r[e] += s * k as i64;
        } else {
            r[e] -= s * k as i64;
        }
    }
}

/// f64 with a total order, for the Dijkstra heap.
#[derive(Clone, Copy, PartialEq)]
struct Ordered(f64);
impl Eq for Ordered {}
impl PartialOrd for Ordered {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Ordered {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}
