//! Boundary snapping: where the grid meets an unaligned boundary, the cells it cuts become
//! polygons of every size (a corner cut off leaves a triangle and a pentagon). Moving the grid
//! point next to a boundary crossing onto the boundary (merging the crossing into it) takes one
//! side from each of the two faces beside the crossing; a triangle that loses its sides
//! vanishes. Along each boundary loop a dynamic program picks the crossings to snap so that as
//! many boundary faces as possible get exactly the wanted number of sides, weighed against how
//! far the snapped points move (squared, in edge lengths). What is left over goes to `purify`'s
//! local steps.

use std::collections::{HashMap, HashSet};

use super::{Origin, Remesh};

/// A boundary crossing x with one interior edge to the grid point y (`None`: it cannot snap).
#[derive(Clone, Copy, Debug)]
struct Crossing {
    x: u32,
    y: Option<u32>,
}

/// A stretch of a boundary loop along one face, from the crossing `start`, with the corners
/// inside it that may be dropped (cost, vertex), cheapest first.
struct Run {
    face: usize,
    start: u32,
    dissolve: Vec<(f64, u32)>,
}

/// Corners where the boundary turns by more than this (at the remesh's scale) are kept.
const MAX_DISSOLVE_TURN: f64 = std::f64::consts::FRAC_PI_3;

/// Cost of a boundary face left with `m` sides, when `sides` are wanted (0: pure or gone).
fn face_cost(m: usize, sides: usize) -> f64 {
    const ODD: f64 = 1.0; // a vertex inserted or an edge collapsed: a 180° corner or a merge
    const CHORD: f64 = 0.6; // one more face, an irregular vertex at each chord end
    match (sides, m) {
        (_, 0..=2) => 0.0,
        (4, 4) | (3, 3) => 0.0,
        (4, m) if m % 2 == 1 => ODD + CHORD * ((m.saturating_sub(5)) / 2) as f64,
        (4, m) => CHORD * ((m - 4) / 2) as f64,
        (_, m) => CHORD * (m - 3) as f64,
    }
}

/// Snaps boundary crossings into their grid points and drops flat corners; returns how many
/// vertices went.
pub fn snap_boundary(remesh: &mut Remesh, sides: usize, h: f64) -> usize {
    if h <= 0.0 {
        return 0;
    }
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    let mut neighbours: HashMap<u32, Vec<u32>> = HashMap::new();
    for (fi, f) in remesh.faces.iter().enumerate() {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            directed.insert((a, b), fi);
            neighbours.entry(a).or_default().push(b);
        }
    }
    // Undirected neighbour sets.
    let mut adj: HashMap<u32, HashSet<u32>> = HashMap::new();
    for (&a, bs) in &neighbours {
        for &b in bs {
            adj.entry(a).or_default().insert(b);
            adj.entry(b).or_default().insert(a);
        }
    }
    let mut next: HashMap<u32, u32> = HashMap::new();
    for &(a, b) in directed.keys() {
        if !directed.contains_key(&(b, a)) && next.insert(a, b).is_some() {
            return 0; // a vertex on the boundary twice: leave it to the local steps
        }
    }
    let on_boundary = |v: u32| next.contains_key(&v);
    let mut starts: Vec<u32> = next.keys().copied().collect();
    starts.sort_unstable();
    let mut seen: HashSet<u32> = HashSet::new();
    let mut merge: HashMap<u32, u32> = HashMap::new();
    let mut moved_to: HashMap<u32, Vec<u32>> = HashMap::new(); // y -> crossings merged into it
    let mut dropped: HashSet<u32> = HashSet::new(); // valence-2 boundary corners dropped
    for s in starts {
        if seen.contains(&s) {
            continue;
        }
        let mut lp = Vec::new();
        let mut v = s;
        let mut open = false;
        while seen.insert(v) {
            lp.push(v);
            match next.get(&v) {
                Some(&w) => v = w,
                None => {
                    // The chain ends: a boundary edge in two faces or an inconsistently
                    // oriented face (a patched place); leave it to the local steps.
                    open = true;
                    break;
                }
            }
        }
        if open || v != s || lp.len() < 3 {
            continue;
        }
        // Runs: maximal stretches of the loop along one face. Between two runs lies a
        // crossing (a boundary vertex with one interior edge, which can snap); inside a run lie
        // vertices of valence 2 (input corners kept by extraction), which can be dropped from
        // their face when the boundary hardly turns there at this scale.
        let n = lp.len();
        let face_of = |i: usize| directed[&(lp[i % n], lp[(i + 1) % n])];
        let Some(first) = (0..n).find(|&i| face_of(i + n - 1) != face_of(i)) else {
            continue; // the whole loop lies along one face
        };
        let mut runs: Vec<Run> = Vec::new();
        let mut i = first;
        while i < first + n {
            let f = face_of(i);
            let mut run = Run {
                face: f,
                start: lp[i % n],
                dissolve: Vec::new(),
            };
            i += 1;
            while i < first + n && face_of(i) == f {
                let v = lp[i % n];
                let (a, b) = (lp[(i + n - 1) % n], lp[(i + 1) % n]);
                let p = &remesh.positions;
                let turn = std::f64::consts::PI
                    - (p[a as usize] - p[v as usize]).angle_between(p[b as usize] - p[v as usize]);
                // Dropping v joins a and b: not when they are joined already.
                if turn.is_finite()
                    && turn < MAX_DISSOLVE_TURN
                    && adj[&v].len() == 2
                    && !adj[&a].contains(&b)
                {
                    run.dissolve
                        .push((0.1 + 0.4 * (turn / MAX_DISSOLVE_TURN).powi(2), v));
                }
                i += 1;
            }
            run.dissolve.sort_by(|x, y| x.0.total_cmp(&y.0));
            runs.push(run);
        }
        let k = runs.len();
        if k < 2 {
            continue;
        }
        // A face with two runs (touching the boundary in two places) is left alone.
        let mut count: HashMap<usize, usize> = HashMap::new();
        for r in &runs {
            *count.entry(r.face).or_default() += 1;
        }
        // Crossing j starts run j (between run j − 1 and run j).
        let crossings: Vec<Crossing> = (0..k)
            .map(|j| {
                let x = runs[j].start;
                let prev_run = &runs[(j + k - 1) % k];
                let inner: Vec<u32> = adj[&x]
                    .iter()
                    .copied()
                    .filter(|&w| !on_boundary(w) || !(next.get(&w) == Some(&x) || next[&x] == w))
                    .collect();
                let y = match inner.as_slice() {
                    [y] if !on_boundary(*y)
                        && matches!(remesh.origins[x as usize], Origin::Edge(_))
                        && count[&prev_run.face] == 1
                        && count[&runs[j].face] == 1 =>
                    {
                        Some(*y)
                    }
                    _ => None,
                };
                Crossing { x, y }
            })
            .collect();
        let allowed: Vec<Option<f64>> = crossings
            .iter()
            .map(|c| {
                let y = c.y?;
                let d =
                    (remesh.positions[c.x as usize] - remesh.positions[y as usize]).length() / h;
                (d < 0.75).then_some(4.0 * d * d)
            })
            .collect();
        // Cost of run j's face losing `lost` sides to snaps: the best number of its corners to
        // drop as well.
        let run_cost = |j: usize, lost: usize| -> (f64, usize) {
            let r = &runs[j];
            let m = remesh.faces[r.face].len().saturating_sub(lost);
            if count[&r.face] > 1 {
                return (face_cost(remesh.faces[r.face].len(), sides), 0);
            }
            let mut best = (face_cost(m, sides), 0);
            let mut acc = 0.0;
            for (d, (c, _)) in r.dissolve.iter().enumerate() {
                acc += c;
                let total = acc + face_cost(m.saturating_sub(d + 1), sides);
                if total < best.0 {
                    best = (total, d + 1);
                }
            }
            best
        };
        // Cyclic DP over s_0..s_{k-1}: fix s_0, then the best cost with crossing j's choice.
        let mut best_total = f64::INFINITY;
        let mut best_choice: Vec<bool> = vec![false; k];
        for s0 in [false, true] {
            if s0 && allowed[0].is_none() {
                continue;
            }
            let mut cost = vec![[f64::INFINITY; 2]; k];
            let mut from = vec![[0usize; 2]; k];
            cost[0][usize::from(s0)] = if s0 { allowed[0].unwrap() } else { 0.0 };
            for j in 1..k {
                for sj in 0..2 {
                    if sj == 1 && allowed[j].is_none() {
                        continue;
                    }
                    let own = if sj == 1 { allowed[j].unwrap() } else { 0.0 };
                    for sp in 0..2 {
                        if !cost[j - 1][sp].is_finite() {
                            continue;
                        }
                        // Run j − 1 lies between crossings j − 1 and j.
                        let c = cost[j - 1][sp] + own + run_cost(j - 1, sp + sj).0;
                        if c < cost[j][sj] {
                            cost[j][sj] = c;
                            from[j][sj] = sp;
                        }
                    }
                }
            }
            for sl in 0..2 {
                if !cost[k - 1][sl].is_finite() {
                    continue;
                }
                let c = cost[k - 1][sl] + run_cost(k - 1, sl + usize::from(s0)).0;
                if c < best_total {
                    best_total = c;
                    let mut choice = vec![false; k];
                    let mut s = sl;
                    for j in (0..k).rev() {
                        choice[j] = s == 1;
                        s = from[j][s];
                    }
                    choice[0] = s0;
                    best_choice = choice;
                }
            }
        }
        for j in 0..k {
            let lost = usize::from(best_choice[j]) + usize::from(best_choice[(j + 1) % k]);
            let (_, d) = run_cost(j, lost);
            for &(_, v) in &runs[j].dissolve[..d] {
                dropped.insert(v);
            }
        }
        for j in 0..k {
            if best_choice[j] {
                let c = crossings[j];
                let y = c.y.unwrap();
                // Crossings merged into one grid point must be neighbours along the loop (a
                // triangle cut off by the boundary); otherwise the point would pinch the surface.
                let list = moved_to.entry(y).or_default();
                let ok = list.iter().all(|&x0| {
                    let i0 = crossings
                        .iter()
                        .position(|c| c.x == x0)
                        .unwrap_or(usize::MAX);
                    i0 == (j + k - 1) % k || i0 == (j + 1) % k
                });
                if ok {
                    list.push(c.x);
                    merge.insert(c.x, y);
                }
            }
        }
    }
    if merge.is_empty() && dropped.is_empty() {
        return 0;
    }
    // The grid point takes the boundary position (the mean of the crossings merged into it)
    // and the crossing's place on the input.
    for (y, xs) in &moved_to {
        if xs.is_empty() {
            continue;
        }
        let p = xs
            .iter()
            .map(|&x| remesh.positions[x as usize])
            .sum::<glam::DVec3>()
            / xs.len() as f64;
        remesh.positions[*y as usize] = p;
        remesh.origins[*y as usize] = remesh.origins[xs[0] as usize];
    }
    super::purify::remap_faces(&mut remesh.faces, |v| {
        (!dropped.contains(&v)).then(|| *merge.get(&v).unwrap_or(&v))
    });
    merge.len() + dropped.len()
}
