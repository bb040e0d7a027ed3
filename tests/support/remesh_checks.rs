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

/// Distance from `p` to the segment `a`–`b`.
pub fn segment_distance(p: glam::DVec3, a: glam::DVec3, b: glam::DVec3) -> f64 {
    let d = b - a;
    let t = if d.length_squared() > 0.0 {
        ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + t * d - p).length()
}

/// How well the remesh's edges run along the polyline edges `along` (input positions): every
/// input edge is sampled at 9 points, and each sample's distance is taken to the nearest remesh
/// edge whose two ends both lie within `tol` of `along` (a remesh edge that only crosses a
/// crease does not count). Returns the fraction of samples within `tol`, the worst distance and
/// the samples farther than `tol`.
pub fn edges_along(
    r: &Remesh,
    along: &[(glam::DVec3, glam::DVec3)],
    tol: f64,
) -> (f64, f64, Vec<glam::DVec3>) {
    let near = |p: glam::DVec3| along.iter().any(|&(a, b)| segment_distance(p, a, b) <= tol);
    let on: Vec<bool> = r.positions.iter().map(|&p| near(p)).collect();
    let mut edges = HashSet::new();
    for f in &r.faces {
        for k in 0..f.len() {
            let (a, b) = (f[k] as usize, f[(k + 1) % f.len()] as usize);
            if on[a] && on[b] {
                edges.insert((a.min(b), a.max(b)));
            }
        }
    }
    let edges: Vec<(glam::DVec3, glam::DVec3)> = edges
        .into_iter()
        .map(|(a, b)| (r.positions[a], r.positions[b]))
        .collect();
    let (mut within, mut total, mut worst, mut misses) = (0usize, 0usize, 0.0f64, Vec::new());
    for &(a, b) in along {
        for k in 0..9 {
            let p = a + (b - a) * (k as f64 / 8.0);
            let d = edges
                .iter()
                .map(|&(x, y)| segment_distance(p, x, y))
                .fold(f64::INFINITY, f64::min);
            total += 1;
            if d <= tol {
                within += 1;
            } else {
                misses.push(p);
            }
            worst = worst.max(d);
        }
    }
    (within as f64 / total.max(1) as f64, worst, misses)
}
