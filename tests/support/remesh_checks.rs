//! Checks of polygon remeshes shared by the extraction tests (included with `#[path]`).
#![allow(dead_code)] // each test file uses what it needs

use std::collections::{HashMap, HashSet};

use quadcover::extract::Remesh;

/// Faces of three or more distinct vertices, directed edges used once, undirected at most twice, and one fan of faces around each vertex.
pub fn assert_manifold(r: &Remesh, what: &str) {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for f in &r.faces {
        assert!(
            f.len() >= 3,
            "{what}: face {f:?} has fewer than three vertices"
        );
        let mut seen = HashSet::new();
        for k in 0..f.len() {
            assert!(seen.insert(f[k]), "{what}: face {f:?} repeats a vertex");
            *directed.entry((f[k], f[(k + 1) % f.len()])).or_default() += 1;
        }
    }
    let twice: Vec<_> = directed.iter().filter(|e| *e.1 > 1).collect();
    assert!(
        twice.is_empty(),
        "{what}: directed edges used twice: {twice:?}"
    );
    // Vertex fans: around v, the faces linked through shared edges (v, w) form one component.
    let mut corners: HashMap<u32, Vec<(u32, u32)>> = HashMap::new(); // v -> (prev, next)
    for f in &r.faces {
        let n = f.len();
        for k in 0..n {
            corners
                .entry(f[k])
                .or_default()
                .push((f[(k + n - 1) % n], f[(k + 1) % n]));
        }
    }
    for (v, cs) in &corners {
        // Union the corners that share a neighbour w (corner i's next == corner j's prev).
        let mut parent: Vec<usize> = (0..cs.len()).collect();
        fn find(p: &mut [usize], i: usize) -> usize {
            if p[i] != i {
                p[i] = find(p, p[i]);
            }
            p[i]
        }
        for i in 0..cs.len() {
            for j in 0..cs.len() {
                if cs[i].1 == cs[j].0 {
                    let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                    parent[a] = b;
                }
            }
        }
        let roots: HashSet<usize> = (0..cs.len()).map(|i| find(&mut parent, i)).collect();
        assert_eq!(
            roots.len(),
            1,
            "{what}: vertex {v} has {} fans",
            roots.len()
        );
    }
}

/// Per vertex: whether it lies on an edge used by one face only.
pub fn boundary_vertices(r: &Remesh) -> Vec<bool> {
    let mut count: HashMap<(u32, u32), usize> = HashMap::new();
    for f in &r.faces {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut out = vec![false; r.positions.len()];
    for (&(a, b), &c) in &count {
        if c == 1 {
            out[a as usize] = true;
            out[b as usize] = true;
        }
    }
    out
}

/// Boundary loops of a polygon mesh: the cycles of directed edges without a twin.
pub fn boundary_loops(r: &Remesh) -> usize {
    let directed: HashSet<(u32, u32)> = r
        .faces
        .iter()
        .flat_map(|f| (0..f.len()).map(move |k| (f[k], f[(k + 1) % f.len()])))
        .collect();
    let mut next: HashMap<u32, u32> = HashMap::new();
    for &(a, b) in &directed {
        if !directed.contains(&(b, a)) {
            next.insert(a, b);
        }
    }
    let mut seen = HashSet::new();
    let mut loops = 0;
    let mut starts: Vec<u32> = next.keys().copied().collect();
    starts.sort_unstable();
    for s in starts {
        if seen.contains(&s) {
            continue;
        }
        loops += 1;
        let mut v = s;
        while seen.insert(v) {
            v = next[&v];
        }
    }
    loops
}
