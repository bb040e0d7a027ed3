//! Singularities (branch points), the cut graph and the per-edge transitions of the cut surface.
//!
//! Construction (a practical Erickson–Whittlesey greedy system of loops, sec. 2.4.5): all boundary
//! vertices and branch points form the root set S (conceptually one identified root point R).
//! A shortest-path forest T grows from S (Dijkstra on edge lengths; one basepoint per component
//! without any root). The dual spanning forest T* is a *maximum* spanning forest of the remaining
//! interior edges weighted by the length of the loop each edge closes. Every interior edge in
//! neither T nor T* is a *generator* e_k; its loop (T-path, e_k, T-path) is cut path γ_k.
//! Count: per component with b boundary loops and s branch points, 2g + b + s − 1 generators
//! when b + s ≥ 1, else 2g. T-edges on no loop end up with the identity transition (pruned).

use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};

use crate::mesh::TriMesh;

use super::rot::{Aff, Lin, Rots};

pub(crate) const NONE: u32 = u32::MAX;

#[derive(Clone, Debug)]
pub(crate) struct CutGraph {
    /// Per edge the matching normalised to 0..N (0 on boundary edges).
    pub matching: Vec<u8>,
    /// Per vertex the holonomy Σ r around its fan (mod N); 0 on the boundary.
    pub holonomy: Vec<u8>,
    pub singular: Vec<bool>,
    /// Per vertex its tree parent towards the root set (NONE for roots).
    pub parent_vertex: Vec<u32>,
    /// Faces in dual-tree BFS order with the edge through which each was reached (NONE: root).
    pub face_order: Vec<(u32, u32)>,
    /// Per face the rotation from the component's root face frame (disk frame = R^{-ρ} face frame).
    pub rho: Vec<u8>,
    pub generators: Vec<u32>,
    /// Per edge the transition ψ_j = R^t ψ_i + τ(W) in disk frames, i = face(h0), j = face(h1).
    pub transitions: Vec<Aff>,
    /// Per face component: does a global translation leave the energy invariant (no branch
    /// point and all transition rotations zero)?
    pub comp_of_face: Vec<u32>,
    pub translation_kernel: Vec<bool>,
    pub closed_comp: Vec<bool>,
}

/// Rotation from face `from` to the other face across interior edge e: φ_other = R^r φ_from.
pub(crate) fn crossing(mesh: &TriMesh, matching: &[u8], n: usize, e: usize, from: usize) -> i64 {
    let (h0, _) = mesh.edge_halfedges(e);
    let r = matching[e] as i64;
    if mesh.face_of(h0) == from {
        r
    } else {
        (n as i64 - r) % n as i64
    }
}

#[derive(PartialEq)]
struct Item(f64, u32);
impl Eq for Item {}
impl PartialOrd for Item {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Item {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}

fn find(p: &mut [u32], mut x: u32) -> u32 {
    while p[x as usize] != x {
        p[x as usize] = p[p[x as usize] as usize];
        x = p[x as usize];
    }
    x
}

impl CutGraph {
    pub fn new(mesh: &TriMesh, rots: &Rots, matchings: &[i32]) -> CutGraph {
        let n = rots.n;
        let (nv, ne, nf) = (mesh.n_vertices(), mesh.n_edges(), mesh.n_faces());
        let matching: Vec<u8> = (0..ne)
            .map(|e| {
                if mesh.is_boundary_edge(e) {
                    0
                } else {
                    rots.norm(matchings[e] as i64)
                }
            })
            .collect();
        // Holonomy and branch points.
        let mut holonomy = vec![0u8; nv];
        let mut singular = vec![false; nv];
        for v in 0..nv {
            if mesh.is_boundary_vertex(v) {
                continue;
            }
            let s: i64 = mesh
                .outgoing(v)
                .map(|h| crossing(mesh, &matching, n, mesh.edge(mesh.prev(h)), mesh.face_of(h)))
                .sum();
            holonomy[v] = rots.norm(s);
            singular[v] = holonomy[v] != 0;
        }
        let (comp_of_face, ncomp) = mesh.face_components();
        let vcomp = |v: usize| comp_of_face[mesh.face_of(mesh.vertex_halfedge(v))] as usize;
        // Root set S and Dijkstra forest.
        let mut dist = vec![f64::INFINITY; nv];
        let mut heap = BinaryHeap::new();
        let mut comp_has_root = vec![false; ncomp];
        let mut closed_comp = vec![true; ncomp];
        for v in 0..nv {
            if mesh.is_boundary_vertex(v) {
                closed_comp[vcomp(v)] = false;
            }
            if mesh.is_boundary_vertex(v) || singular[v] {
                dist[v] = 0.0;
                heap.push(Item(0.0, v as u32));
                comp_has_root[vcomp(v)] = true;
            }
        }
        for v in 0..nv {
            let c = vcomp(v);
            if !comp_has_root[c] {
                comp_has_root[c] = true;
                dist[v] = 0.0;
                heap.push(Item(0.0, v as u32));
            }
        }
        // Vertex adjacency (CSR) over edges.
        let mut deg = vec![0u32; nv + 1];
        for e in 0..ne {
            let [a, b] = mesh.edge_vertices(e);
            deg[a + 1] += 1;
            deg[b + 1] += 1;
        }
        for i in 0..nv {
            deg[i + 1] += deg[i];
        }
        let mut fill = deg.clone();
        let mut adj = vec![0u32; 2 * ne];
        for e in 0..ne {
            let [a, b] = mesh.edge_vertices(e);
            adj[fill[a] as usize] = e as u32;
            fill[a] += 1;
            adj[fill[b] as usize] = e as u32;
            fill[b] += 1;
        }
        let mut parent_edge = vec![NONE; nv];
        let mut parent_vertex = vec![NONE; nv];
        let mut done = vec![false; nv];
        let mut vertex_order = Vec::with_capacity(nv);
        let pos = mesh.positions();
        // Each edge's length once (Dijkstra relaxes every edge from both ends).
        let length: Vec<f64> = (0..ne)
            .map(|e| {
                let [a, b] = mesh.edge_vertices(e);
                (pos[a] - pos[b]).length()
            })
            .collect();
        while let Some(Item(d, v)) = heap.pop() {
            let v = v as usize;
            if done[v] || d > dist[v] {
                continue;
            }
            done[v] = true;
            vertex_order.push(v as u32);
            for &e in &adj[deg[v] as usize..deg[v + 1] as usize] {
                let [a, b] = mesh.edge_vertices(e as usize);
                let w = if a == v { b } else { a };
                let nd = d + length[e as usize];
                if !done[w] && nd < dist[w] {
                    dist[w] = nd;
                    parent_edge[w] = e;
                    parent_vertex[w] = v as u32;
                    heap.push(Item(nd, w as u32));
                }
            }
        }
        let mut in_t = vec![false; ne];
        for v in 0..nv {
            if parent_edge[v] != NONE {
                in_t[parent_edge[v] as usize] = true;
            }
        }
        // Dual maximum spanning forest by loop length.
        let mut cand: Vec<(f64, u32)> = (0..ne)
            .filter(|&e| !in_t[e] && !mesh.is_boundary_edge(e))
            .map(|e| {
                let [a, b] = mesh.edge_vertices(e);
                (dist[a] + dist[b] + length[e], e as u32)
            })
            .collect();
        // A total order (ties by edge): the unstable sort gives the stable one's result.
        cand.sort_unstable_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
        let mut uf: Vec<u32> = (0..nf as u32).collect();
        let mut in_dual = vec![false; ne];
        let mut generators = Vec::new();
        for &(_, e) in &cand {
            let (h0, h1) = mesh.edge_halfedges(e as usize);
            let (a, b) = (
                find(&mut uf, mesh.face_of(h0) as u32),
                find(&mut uf, mesh.face_of(h1.unwrap()) as u32),
            );
            if a != b {
                uf[a as usize] = b;
                in_dual[e as usize] = true;
            } else {
                generators.push(e);
            }
        }
        generators.sort_unstable();
        // ρ by BFS over the dual forest.
        let mut rho = vec![0u8; nf];
        let mut seen = vec![false; nf];
        let mut face_order = Vec::with_capacity(nf);
        let mut queue = VecDeque::new();
        for root in 0..nf {
            if seen[root] {
                continue;
            }
            seen[root] = true;
            face_order.push((root as u32, NONE));
            queue.push_back(root);
            while let Some(f) = queue.pop_front() {
                for k in 0..3 {
                    let h = 3 * f + k;
                    let e = mesh.edge(h);
                    if !in_dual[e] {
                        continue;
                    }
                    let g = mesh.face_of(mesh.twin(h).unwrap());
                    if !seen[g] {
                        seen[g] = true;
                        rho[g] = rots.norm(rho[f] as i64 + crossing(mesh, &matching, n, e, f));
                        face_order.push((g as u32, e as u32));
                        queue.push_back(g);
                    }
                }
            }
        }
        // Transitions: generators carry their loop gap, tree edges bottom-up by vertex closure.
        let mut transitions = vec![Aff::default(); ne];
        let edge_rot = |e: usize| -> u8 {
            let (h0, h1) = mesh.edge_halfedges(e);
            let (i, j) = (mesh.face_of(h0), mesh.face_of(h1.unwrap()));
            rots.norm(crossing(mesh, &matching, n, e, i) + rho[i] as i64 - rho[j] as i64)
        };
        for (k, &e) in generators.iter().enumerate() {
            transitions[e as usize] = Aff {
                rot: edge_rot(e as usize),
                lin: Lin::single(k),
            };
        }
        for &v in vertex_order.iter().rev() {
            let v = v as usize;
            let p = parent_edge[v];
            if p == NONE {
                continue;
            }
            let p = p as usize;
            let any = adj[deg[v] as usize..deg[v + 1] as usize]
                .iter()
                .any(|&e| e as usize != p && !transitions[e as usize].is_identity());
            if !any {
                // Closure around v forces the identity (ρ is consistent on pruned tree edges).
                transitions[p] = Aff::default();
                continue;
            }
            // Walk the fan starting at the outgoing halfedge along p.
            let h_start = mesh.outgoing(v).find(|&h| mesh.edge(h) == p).unwrap();
            let mut acc = Aff::default();
            let mut h = h_start;
            let f_start = mesh.face_of(h_start);
            let mut last_face = f_start;
            loop {
                let c = mesh.edge(mesh.prev(h));
                let hn = mesh.twin(mesh.prev(h)).unwrap();
                if hn == h_start {
                    break;
                }
                let t = step(mesh, &transitions[c], c, mesh.face_of(h), rots);
                acc = t.after(&acc, rots);
                h = hn;
                last_face = mesh.face_of(h);
            }
            // Crossing p from last_face back to f_start must be acc^{-1}.
            let (h0, _) = mesh.edge_halfedges(p);
            transitions[p] = if mesh.face_of(h0) == last_face {
                acc.inverse(rots)
            } else {
                acc
            };
        }
        let mut translation_kernel = vec![true; ncomp];
        for v in 0..nv {
            if singular[v] {
                translation_kernel[vcomp(v)] = false;
            }
        }
        for e in 0..ne {
            if !mesh.is_boundary_edge(e) && transitions[e].rot != 0 {
                translation_kernel[comp_of_face[mesh.face_of(mesh.edge_halfedges(e).0)] as usize] =
                    false;
            }
        }
        CutGraph {
            matching,
            holonomy,
            singular,
            parent_vertex,
            face_order,
            rho,
            generators,
            transitions,
            comp_of_face,
            translation_kernel,
            closed_comp,
        }
    }

    /// Cut paths as vertex sequences (one per generator): root … a, b … root.
    pub fn paths(&self, mesh: &TriMesh) -> Vec<Vec<usize>> {
        let up = |mut v: usize| {
            let mut p = vec![v];
            while self.parent_vertex[v] != NONE {
                v = self.parent_vertex[v] as usize;
                p.push(v);
            }
            p
        };
        self.generators
            .iter()
            .map(|&e| {
                let [a, b] = mesh.edge_vertices(e as usize);
                let (mut pa, mut pb) = (up(a), up(b));
                while pa.len() >= 2
                    && pb.len() >= 2
                    && pa[pa.len() - 2] == pb[pb.len() - 2]
                    && pa.last() == pb.last()
                {
                    pa.pop();
                    pb.pop();
                }
                pa.reverse();
                pa.extend(pb);
                pa
            })
            .collect()
    }

    /// Edges whose transition is not the identity (the effective, pruned cut graph).
    pub fn cut_edges(&self) -> Vec<usize> {
        (0..self.transitions.len())
            .filter(|&e| !self.transitions[e].is_identity())
            .collect()
    }
}

/// The map ψ_to = T(ψ_from) when crossing edge `c` out of face `from`.
pub(crate) fn step(mesh: &TriMesh, t: &Aff, c: usize, from: usize, rots: &Rots) -> Aff {
    let (h0, _) = mesh.edge_halfedges(c);
    if mesh.face_of(h0) == from {
        t.clone()
    } else {
        t.inverse(rots)
    }
}
