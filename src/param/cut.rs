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
use std::sync::Arc;

use crate::mesh::TriMesh;
use crate::mesh::heap::Nearest;

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
    graph: Arc<MeshGraph>,
    forest: Arc<Forest>,
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

fn find(p: &mut [u32], mut x: u32) -> u32 {
    while p[x as usize] != x {
        p[x as usize] = p[p[x as usize] as usize];
        x = p[x as usize];
    }
    x
}

/// What building a cut graph needs of the mesh alone: built once per mesh and shared by every
/// cut graph an update derives from it.
#[derive(Debug)]
pub(crate) struct MeshGraph {
    /// Per vertex its edges with their other ends, `adj[start[v]..start[v + 1]]`.
    start: Vec<u32>,
    adj: Vec<(u32, u32)>,
    length: Vec<f64>,
    comp_of_face: Vec<u32>,
    vcomp: Vec<u32>,
    ncomp: usize,
    closed_comp: Vec<bool>,
}

impl MeshGraph {
    pub fn new(mesh: &TriMesh) -> MeshGraph {
        let (nv, ne) = (mesh.n_vertices(), mesh.n_edges());
        let (comp_of_face, ncomp) = mesh.face_components();
        let vcomp: Vec<u32> = (0..nv)
            .map(|v| comp_of_face[mesh.face_of(mesh.vertex_halfedge(v))])
            .collect();
        let mut closed_comp = vec![true; ncomp];
        for v in 0..nv {
            if mesh.is_boundary_vertex(v) {
                closed_comp[vcomp[v] as usize] = false;
            }
        }
        let mut start = vec![0u32; nv + 1];
        let ends: Vec<[usize; 2]> = (0..ne).map(|e| mesh.edge_vertices(e)).collect();
        for &[a, b] in &ends {
            start[a + 1] += 1;
            start[b + 1] += 1;
        }
        for i in 0..nv {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut adj = vec![(0u32, 0u32); 2 * ne];
        for (e, &[a, b]) in ends.iter().enumerate() {
            adj[fill[a] as usize] = (e as u32, b as u32);
            fill[a] += 1;
            adj[fill[b] as usize] = (e as u32, a as u32);
            fill[b] += 1;
        }
        let pos = mesh.positions();
        let length = ends
            .iter()
            .map(|&[a, b]| (pos[a] - pos[b]).length())
            .collect();
        MeshGraph {
            start,
            adj,
            length,
            comp_of_face,
            vcomp,
            ncomp,
            closed_comp,
        }
    }

    fn edges(&self, v: usize) -> &[(u32, u32)] {
        &self.adj[self.start[v] as usize..self.start[v + 1] as usize]
    }
}

/// The shortest-path forest T and T*'s candidate order, kept so that an update regrows only
/// the part of T that its changed roots reach.
#[derive(Debug)]
pub(crate) struct Forest {
    dist: Vec<f64>,
    parent_edge: Vec<u32>,
    /// Per vertex the root its tree path ends at.
    root: Vec<u32>,
    /// Interior edges outside T by descending loop length, ties by edge (Kruskal's order).
    candidates: Vec<(f64, u32)>,
    /// Per component: grown from a basepoint (no boundary, no branch point)?
    based: Vec<bool>,
}

/// Per edge the matching normalised to 0..N (0 on boundary edges).
fn normalised(mesh: &TriMesh, rots: &Rots, matchings: &[i32]) -> Vec<u8> {
    (0..mesh.n_edges())
        .map(|e| {
            if mesh.is_boundary_edge(e) {
                0
            } else {
                rots.norm(matchings[e] as i64)
            }
        })
        .collect()
}

/// The holonomy Σ r around interior vertex v's fan, mod N.
fn holonomy_at(mesh: &TriMesh, rots: &Rots, matching: &[u8], v: usize) -> u8 {
    let s: i64 = mesh
        .outgoing(v)
        .map(|h| {
            crossing(
                mesh,
                matching,
                rots.n,
                mesh.edge(mesh.prev(h)),
                mesh.face_of(h),
            )
        })
        .sum();
    rots.norm(s)
}

/// A loop candidate: an interior edge outside T, weighted by the length of the loop it closes.
fn candidate(
    mesh: &TriMesh,
    graph: &MeshGraph,
    dist: &[f64],
    in_t: &[bool],
    e: usize,
) -> Option<(f64, u32)> {
    if in_t[e] || mesh.is_boundary_edge(e) {
        return None;
    }
    let [a, b] = mesh.edge_vertices(e);
    Some((dist[a] + dist[b] + graph.length[e], e as u32))
}

/// Kruskal's order for the maximum spanning forest: descending weight, ties by edge.
fn kruskal_order(x: &(f64, u32), y: &(f64, u32)) -> Ordering {
    y.0.total_cmp(&x.0).then(x.1.cmp(&y.1))
}

fn tree_edges(nedges: usize, parent_edge: &[u32]) -> Vec<bool> {
    let mut in_t = vec![false; nedges];
    for &p in parent_edge {
        if p != NONE {
            in_t[p as usize] = true;
        }
    }
    in_t
}

/// Dijkstra from the queued vertices: improves `dist` (strictly, so ties keep what is there),
/// with the parents and roots that go with it; `touched` (if any) marks every vertex it changed.
fn grow(
    graph: &MeshGraph,
    heap: &mut BinaryHeap<Nearest>,
    forest: (&mut [f64], &mut [u32], &mut [u32]),
    mut touched: Option<&mut Touched>,
) {
    let (dist, parent_edge, root) = forest;
    while let Some(Nearest(d, v)) = heap.pop() {
        let v = v as usize;
        if d > dist[v] {
            continue;
        }
        for &(e, w) in graph.edges(v) {
            let w = w as usize;
            let nd = d + graph.length[e as usize];
            if nd < dist[w] {
                dist[w] = nd;
                parent_edge[w] = e;
                root[w] = root[v];
                if let Some(t) = touched.as_mut() {
                    t.mark(w);
                }
                heap.push(Nearest(nd, w as u32));
            }
        }
    }
}

/// A set of vertices with its members in order of insertion.
struct Touched {
    on: Vec<bool>,
    list: Vec<u32>,
}

impl Touched {
    fn new(n: usize) -> Touched {
        Touched {
            on: vec![false; n],
            list: Vec::new(),
        }
    }
    fn mark(&mut self, v: usize) {
        if !self.on[v] {
            self.on[v] = true;
            self.list.push(v as u32);
        }
    }
}

/// Vertices parents first (BFS over the forest from its roots, in vertex order).
fn tree_order(parent_vertex: &[u32]) -> Vec<u32> {
    let nv = parent_vertex.len();
    let mut start = vec![0u32; nv + 1];
    for &p in parent_vertex {
        if p != NONE {
            start[p as usize + 1] += 1;
        }
    }
    for i in 0..nv {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut children = vec![0u32; start[nv] as usize];
    for (v, &p) in parent_vertex.iter().enumerate() {
        if p != NONE {
            children[fill[p as usize] as usize] = v as u32;
            fill[p as usize] += 1;
        }
    }
    let mut order: Vec<u32> = (0..nv as u32)
        .filter(|&v| parent_vertex[v as usize] == NONE)
        .collect();
    let mut i = 0;
    while i < order.len() {
        let v = order[i] as usize;
        order.extend_from_slice(&children[start[v] as usize..start[v + 1] as usize]);
        i += 1;
    }
    order
}

impl CutGraph {
    pub fn new(mesh: &TriMesh, rots: &Rots, matchings: &[i32]) -> CutGraph {
        Self::grown(mesh, rots, matchings, Arc::new(MeshGraph::new(mesh)))
    }

    /// The cut graph of `matchings`, grown from scratch on a mesh whose graph is known.
    fn grown(mesh: &TriMesh, rots: &Rots, matchings: &[i32], graph: Arc<MeshGraph>) -> CutGraph {
        let nv = mesh.n_vertices();
        let matching = normalised(mesh, rots, matchings);
        // Holonomy and branch points.
        let mut holonomy = vec![0u8; nv];
        for (v, h) in holonomy.iter_mut().enumerate() {
            if !mesh.is_boundary_vertex(v) {
                *h = holonomy_at(mesh, rots, &matching, v);
            }
        }
        let singular: Vec<bool> = holonomy.iter().map(|&h| h != 0).collect();
        // Root set S (boundary and branch points; one basepoint where a component has neither)
        // and the Dijkstra forest.
        let mut dist = vec![f64::INFINITY; nv];
        let mut root = vec![NONE; nv];
        let mut heap = BinaryHeap::new();
        let mut based = vec![true; graph.ncomp];
        for v in 0..nv {
            if mesh.is_boundary_vertex(v) || singular[v] {
                dist[v] = 0.0;
                root[v] = v as u32;
                heap.push(Nearest(0.0, v as u32));
                based[graph.vcomp[v] as usize] = false;
            }
        }
        let mut has_root: Vec<bool> = based.iter().map(|&b| !b).collect();
        for v in 0..nv {
            let c = graph.vcomp[v] as usize;
            if !has_root[c] {
                has_root[c] = true;
                dist[v] = 0.0;
                root[v] = v as u32;
                heap.push(Nearest(0.0, v as u32));
            }
        }
        let mut parent_edge = vec![NONE; nv];
        grow(
            &graph,
            &mut heap,
            (&mut dist, &mut parent_edge, &mut root),
            None,
        );
        let in_t = tree_edges(mesh.n_edges(), &parent_edge);
        let mut candidates: Vec<(f64, u32)> = (0..mesh.n_edges())
            .filter_map(|e| candidate(mesh, &graph, &dist, &in_t, e))
            .collect();
        // A total order: the unstable sort gives the stable one's result.
        candidates.sort_unstable_by(kruskal_order);
        let forest = Forest {
            dist,
            parent_edge,
            root,
            candidates,
            based,
        };
        Self::finish(mesh, rots, graph, forest, matching, holonomy, singular)
    }

    /// The cut graph of `matchings`, derived from `base`'s (of the same mesh): only the part of
    /// the shortest-path forest that the changed branch points reach is regrown, and T*'s
    /// candidates are `base`'s with the changed edges re-sorted in. The result is a valid cut
    /// graph of `matchings` and a function of (`base`, `matchings`) alone; it is the one
    /// [`CutGraph::new`] builds unless equal path lengths let the regrowth pick another of the
    /// shortest paths. Where a component gains or loses its last branch point it is built anew.
    pub fn updated(mesh: &TriMesh, rots: &Rots, matchings: &[i32], base: &CutGraph) -> CutGraph {
        let graph = base.graph.clone();
        let nv = mesh.n_vertices();
        let matching = normalised(mesh, rots, matchings);
        // Holonomy: base's, recomputed around the edges whose matching changed.
        let mut around: Vec<u32> = Vec::new();
        for e in 0..mesh.n_edges() {
            if matching[e] != base.matching[e] {
                let [a, b] = mesh.edge_vertices(e);
                around.extend([a as u32, b as u32]);
            }
        }
        around.sort_unstable();
        around.dedup();
        let mut holonomy = base.holonomy.clone();
        for &v in &around {
            let v = v as usize;
            if !mesh.is_boundary_vertex(v) {
                holonomy[v] = holonomy_at(mesh, rots, &matching, v);
            }
        }
        let singular: Vec<bool> = holonomy.iter().map(|&h| h != 0).collect();
        let removed: Vec<u32> = around
            .iter()
            .copied()
            .filter(|&v| base.singular[v as usize] && !singular[v as usize])
            .collect();
        let added: Vec<u32> = around
            .iter()
            .copied()
            .filter(|&v| !base.singular[v as usize] && singular[v as usize])
            .collect();
        let f = &base.forest;
        // A component that gains its first root or loses its last one: grow it all anew.
        let mut rooted = vec![false; graph.ncomp];
        for v in 0..nv {
            if mesh.is_boundary_vertex(v) || singular[v] {
                rooted[graph.vcomp[v] as usize] = true;
            }
        }
        if rooted.iter().zip(&f.based).any(|(&r, &b)| r == b) {
            return Self::grown(mesh, rots, matchings, graph);
        }
        let mut dist = f.dist.clone();
        let mut parent_edge = f.parent_edge.clone();
        let mut root = f.root.clone();
        let mut touched = Touched::new(nv);
        // Trees of removed roots are cleared and regrown from the vertices around them ...
        let mut gone = vec![false; nv];
        for &r in &removed {
            gone[r as usize] = true;
        }
        for v in 0..nv {
            if root[v] != NONE && gone[root[v] as usize] {
                dist[v] = f64::INFINITY;
                parent_edge[v] = NONE;
                root[v] = NONE;
                touched.mark(v);
            }
        }
        let mut heap = BinaryHeap::new();
        let mut source = vec![false; nv];
        for &v in &touched.list {
            for &(_, w) in graph.edges(v as usize) {
                let w = w as usize;
                if !touched.on[w] && !source[w] {
                    source[w] = true;
                    heap.push(Nearest(dist[w], w as u32));
                }
            }
        }
        // ... and new roots grow over whatever they are closer to.
        for &q in &added {
            let q = q as usize;
            dist[q] = 0.0;
            parent_edge[q] = NONE;
            root[q] = q as u32;
            touched.mark(q);
            heap.push(Nearest(0.0, q as u32));
        }
        grow(
            &graph,
            &mut heap,
            (&mut dist, &mut parent_edge, &mut root),
            Some(&mut touched),
        );
        let in_t = tree_edges(mesh.n_edges(), &parent_edge);
        // Candidates: base's where neither end changed, the others re-weighed and merged in.
        let mut stale = vec![false; mesh.n_edges()];
        let mut fresh: Vec<(f64, u32)> = Vec::new();
        for &v in &touched.list {
            for &(e, _) in graph.edges(v as usize) {
                let e = e as usize;
                if !stale[e] {
                    stale[e] = true;
                    fresh.extend(candidate(mesh, &graph, &dist, &in_t, e));
                }
            }
        }
        fresh.sort_unstable_by(kruskal_order);
        let mut candidates = Vec::with_capacity(f.candidates.len() + fresh.len());
        let mut kept = f
            .candidates
            .iter()
            .filter(|c| !stale[c.1 as usize])
            .peekable();
        let mut fresh = fresh.into_iter().peekable();
        loop {
            let take_fresh = match (kept.peek(), fresh.peek()) {
                (Some(k), Some(n)) => kruskal_order(n, k) == Ordering::Less,
                (None, Some(_)) => true,
                (Some(_), None) => false,
                (None, None) => break,
            };
            if take_fresh {
                candidates.extend(fresh.next());
            } else {
                candidates.extend(kept.next().copied());
            }
        }
        let forest = Forest {
            dist,
            parent_edge,
            root,
            candidates,
            based: f.based.clone(),
        };
        Self::finish(mesh, rots, graph, forest, matching, holonomy, singular)
    }

    /// T*, the generators, ρ and the transitions of a grown forest T.
    #[allow(clippy::too_many_arguments)]
    fn finish(
        mesh: &TriMesh,
        rots: &Rots,
        graph: Arc<MeshGraph>,
        forest: Forest,
        matching: Vec<u8>,
        holonomy: Vec<u8>,
        singular: Vec<bool>,
    ) -> CutGraph {
        let n = rots.n;
        let (nv, ne, nf) = (mesh.n_vertices(), mesh.n_edges(), mesh.n_faces());
        let parent_edge = &forest.parent_edge;
        let parent_vertex: Vec<u32> = (0..nv)
            .map(|v| {
                let p = parent_edge[v];
                if p == NONE {
                    return NONE;
                }
                let [a, b] = mesh.edge_vertices(p as usize);
                (if a == v { b } else { a }) as u32
            })
            .collect();
        // Dual maximum spanning forest by loop length.
        let mut uf: Vec<u32> = (0..nf as u32).collect();
        let mut in_dual = vec![false; ne];
        let mut generators = Vec::new();
        for &(_, e) in &forest.candidates {
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
        for &v in tree_order(&parent_vertex).iter().rev() {
            let v = v as usize;
            let p = parent_edge[v];
            if p == NONE {
                continue;
            }
            let p = p as usize;
            let any = graph
                .edges(v)
                .iter()
                .any(|&(e, _)| e as usize != p && !transitions[e as usize].is_identity());
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
        let mut translation_kernel = vec![true; graph.ncomp];
        for v in 0..nv {
            if singular[v] {
                translation_kernel[graph.vcomp[v] as usize] = false;
            }
        }
        for e in 0..ne {
            if !mesh.is_boundary_edge(e) && transitions[e].rot != 0 {
                translation_kernel
                    [graph.comp_of_face[mesh.face_of(mesh.edge_halfedges(e).0)] as usize] = false;
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
            comp_of_face: graph.comp_of_face.clone(),
            translation_kernel,
            closed_comp: graph.closed_comp.clone(),
            graph,
            forest: Arc::new(forest),
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

    /// Per generator the holonomies at the two ends of its loop (the roots its T-paths reach; 0
    /// at a boundary vertex). Only loops ending at a branch point enter the monodromy around it
    /// (a small loop around it crosses just the T-edges that end there), so only their gaps
    /// decide where it lands (eq. 2.40).
    pub fn loop_end_holonomies(&self, mesh: &TriMesh) -> Vec<[u8; 2]> {
        let root = |mut v: usize| {
            while self.parent_vertex[v] != NONE {
                v = self.parent_vertex[v] as usize;
            }
            v
        };
        self.generators
            .iter()
            .map(|&e| {
                let [a, b] = mesh.edge_vertices(e as usize);
                [self.holonomy[root(a)], self.holonomy[root(b)]]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::cancel::{PathSearch, apply};
    use crate::mesh::generate;

    /// Changes the matchings along a shortest interior path from `a` to `b` by `k`: creates a
    /// pair of branch points there, or moves one that sits at `a`.
    fn along(mesh: &TriMesh, r: &mut [i64], a: usize, b: usize, k: i32) {
        let path = PathSearch::new(mesh.n_vertices())
            .shortest_interior_path(mesh, a, b, f64::INFINITY)
            .unwrap_or_else(|| panic!("no interior path {a} -> {b}"));
        apply(mesh, r, &path, k, 1);
    }

    fn as_i32(r: &[i64]) -> Vec<i32> {
        r.iter().map(|&x| x as i32).collect()
    }

    /// Vertices away from the boundary spread over the mesh (every `step`-th).
    fn interior(mesh: &TriMesh, step: usize) -> Vec<usize> {
        (0..mesh.n_vertices())
            .filter(|&v| {
                !mesh.is_boundary_vertex(v)
                    && mesh
                        .one_ring(v)
                        .iter()
                        .all(|&w| !mesh.is_boundary_vertex(w))
            })
            .step_by(step)
            .collect()
    }

    /// The closure of the transitions: around every interior vertex they compose to a pure
    /// rotation by its holonomy (the identity where regular), so the cut surface is a disk
    /// per component whose branch points all lie on the cut.
    fn check_closure(mesh: &TriMesh, rots: &Rots, cut: &CutGraph) {
        for v in 0..mesh.n_vertices() {
            if mesh.is_boundary_vertex(v) {
                continue;
            }
            let mut acc = Aff::default();
            for h in mesh.outgoing(v) {
                let c = mesh.edge(mesh.prev(h));
                acc = step(mesh, &cut.transitions[c], c, mesh.face_of(h), rots).after(&acc, rots);
            }
            assert!(
                acc.lin.is_zero() || cut.singular[v],
                "vertex {v}: a gap around it"
            );
            if !cut.singular[v] {
                assert_eq!(acc.rot, 0, "vertex {v}: regular but turns");
            }
        }
    }

    /// Moves, a cancelled pair, a new pair and an exit through the boundary: the updated cut
    /// graph is the one built from scratch (no ties on a scanned mesh), field by field.
    #[test]
    fn updated_cut_graphs_are_the_ones_built_anew() {
        let Some(mesh) = crate::load::shared_test_mesh("bunny.obj") else {
            return;
        };
        let rots = Rots::new(4);
        let inner = interior(&mesh, 97);
        let mut r = vec![0i64; mesh.n_edges()];
        // Six pairs of ±1/4 branch points.
        for i in 0..6 {
            along(&mesh, &mut r, inner[7 * i], inner[7 * i + 3], 1);
        }
        let base = CutGraph::new(&mesh, &rots, &as_i32(&r));
        let singular: Vec<usize> = (0..mesh.n_vertices())
            .filter(|&v| base.singular[v])
            .collect();
        assert_eq!(singular.len(), 12);
        let boundary = (0..mesh.n_vertices())
            .find(|&v| {
                mesh.is_boundary_vertex(v)
                    && mesh
                        .one_ring(v)
                        .iter()
                        .any(|&w| !mesh.is_boundary_vertex(w))
            })
            .unwrap();
        let (p, q) = (inner[0], inner[3]);
        type Case<'a> = (&'static str, Box<dyn Fn(&mut [i64]) + 'a>);
        let cases: Vec<Case> = vec![
            ("move", Box::new(|r| along(&mesh, r, p, inner[50], 1))),
            ("cancel a pair", Box::new(|r| along(&mesh, r, p, q, -1))),
            (
                "a new pair",
                Box::new(|r| along(&mesh, r, inner[60], inner[61], 1)),
            ),
            (
                "leave through the boundary",
                Box::new(|r| {
                    // The sign that leaves q regular.
                    along(&mesh, r, q, boundary, 1);
                    if CutGraph::new(&mesh, &rots, &as_i32(r)).singular[q] {
                        along(&mesh, r, q, boundary, -2);
                    }
                }),
            ),
            ("nothing", Box::new(|_| ())),
        ];
        for (what, edit) in &cases {
            let mut moved = r.clone();
            edit(&mut moved);
            let m = as_i32(&moved);
            let fresh = CutGraph::new(&mesh, &rots, &m);
            let updated = CutGraph::updated(&mesh, &rots, &m, &base);
            if *what != "nothing" {
                let changed = (0..mesh.n_vertices())
                    .filter(|&v| fresh.singular[v] != base.singular[v])
                    .count();
                assert!(changed > 0, "{what}: no branch point changed");
            }
            assert_eq!(updated.holonomy, fresh.holonomy, "{what}");
            assert_eq!(updated.forest.dist, fresh.forest.dist, "{what}");
            assert_eq!(updated.parent_vertex, fresh.parent_vertex, "{what}");
            assert_eq!(updated.forest.candidates, fresh.forest.candidates, "{what}");
            assert_eq!(updated.generators, fresh.generators, "{what}");
            assert_eq!(updated.face_order, fresh.face_order, "{what}");
            assert_eq!(updated.rho, fresh.rho, "{what}");
            assert_eq!(updated.transitions, fresh.transitions, "{what}");
            assert_eq!(
                updated.translation_kernel, fresh.translation_kernel,
                "{what}"
            );
            check_closure(&mesh, &rots, &updated);
        }
        let mut gone = r.clone();
        cases[3].1(&mut gone);
        assert!(!CutGraph::new(&mesh, &rots, &as_i32(&gone)).singular[q]);
    }

    /// On a regular torus equal path lengths abound, so the regrown forest may pick other
    /// shortest paths than a fresh one: its distances are the same, and the cut graph is still
    /// one (closure everywhere, 2g + s − 1 generators, branch points on the cut).
    #[test]
    fn updated_cut_graphs_on_a_regular_mesh_are_cut_graphs() {
        let mesh = generate::torus(2.0, 0.7, 40, 20);
        let rots = Rots::new(4);
        let inner = interior(&mesh, 37);
        let mut r = vec![0i64; mesh.n_edges()];
        along(&mesh, &mut r, inner[2], inner[9], 1);
        along(&mesh, &mut r, inner[4], inner[15], -1);
        let base = CutGraph::new(&mesh, &rots, &as_i32(&r));
        for (a, b) in [
            (inner[2], inner[5]),
            (inner[9], inner[15]),
            (inner[20], inner[7]),
        ] {
            let mut moved = r.clone();
            along(&mesh, &mut moved, a, b, 1);
            let m = as_i32(&moved);
            let fresh = CutGraph::new(&mesh, &rots, &m);
            let updated = CutGraph::updated(&mesh, &rots, &m, &base);
            assert_eq!(updated.singular, fresh.singular);
            assert_eq!(updated.forest.dist, fresh.forest.dist);
            let s = updated.singular.iter().filter(|&&x| x).count();
            assert!(s >= 2);
            assert_eq!(updated.generators.len(), 2 + s - 1);
            check_closure(&mesh, &rots, &updated);
            for (v, &sing) in updated.singular.iter().enumerate() {
                if sing {
                    assert_eq!(updated.parent_vertex[v], NONE, "branch point {v} is a root");
                }
            }
        }
    }
}
