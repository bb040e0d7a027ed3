//! Stripes (N = 2): the integer iso-lines of u as polylines; stripes on the level of a branch
//! point meet there (one runs into a +1/2 singularity, three meet at a −1/2).

use std::collections::HashMap;

use glam::{DVec2, DVec3};

use super::Remesh;
use super::lattice::{Param, cross, dv};

const NONE: u32 = u32::MAX;

/// Side of corner `c` against the iso-line `u = level` (direction (0, 1) in the corner's chart),
/// vertices on the line perturbed symbolically (consistently across charts).
fn left(p: &Param, c: usize, level: f64) -> bool {
    let d = [0, 1];
    let q = DVec2::new(level, 0.0);
    let val = cross(dv(d), p.lat[c] - q);
    if val.abs() > 1e-9 {
        val > 0.0
    } else {
        cross(dv(d), p.perturbation(c)) > 0.0
    }
}

pub fn extract_stripes(p: &Param) -> Remesh {
    let mesh = p.mesh;
    let mut positions: Vec<DVec3> = Vec::new();
    // Per point: the vertex it lies on (a crossing at an end of its edge), if any.
    let mut on_vertex: Vec<Option<usize>> = Vec::new();
    // Per edge: crossings (u level in h0's chart, point id).
    let mut on_edge: Vec<Vec<(DVec2, u32)>> = vec![Vec::new(); mesh.n_edges()];
    for (e, list) in on_edge.iter_mut().enumerate() {
        let (h0, _) = mesh.edge_halfedges(e);
        let (c0, c1) = (h0, mesh.next(h0));
        let (a, b) = (p.lat[c0], p.lat[c1]);
        let (lo, hi) = (a.x.min(b.x), a.x.max(b.x));
        for k in (lo - 1e-9).ceil() as i64..=(hi + 1e-9).floor() as i64 {
            let kf = k as f64;
            if left(p, c0, kf) == left(p, c1, kf) {
                continue;
            }
            let t = if (b.x - a.x).abs() > 1e-15 {
                ((kf - a.x) / (b.x - a.x)).clamp(0.0, 1.0)
            } else {
                0.5
            };
            let x = a + (b - a) * t;
            positions.push(
                mesh.position(mesh.from(h0))
                    .lerp(mesh.position(mesh.to(h0)), t),
            );
            on_vertex.push(if t == 0.0 {
                Some(mesh.from(h0))
            } else if t == 1.0 {
                Some(mesh.to(h0))
            } else {
                None
            });
            list.push((DVec2::new(kf, x.y), positions.len() as u32 - 1));
        }
    }
    let mut links: Vec<(u32, u32)> = Vec::new();
    let mut patched = 0;
    // Stripes that end at a vertex on their level: (crossing, vertex).
    let mut ends: Vec<(u32, usize)> = Vec::new();
    for f in 0..mesh.n_faces() {
        let mut by_level: HashMap<i64, Vec<u32>> = HashMap::new();
        for k in 0..3 {
            let h = 3 * f + k;
            let e = mesh.edge(h);
            let (h0, _) = mesh.edge_halfedges(e);
            for &(x, id) in &on_edge[e] {
                let xf = if h0 == h { x } else { p.map_point(h0, x) };
                by_level.entry(xf.x.round() as i64).or_default().push(id);
            }
        }
        // In level order: the links' order decides how the polylines are chained, and a
        // hash map's order differs between runs.
        let mut levels: Vec<(i64, Vec<u32>)> = by_level.into_iter().collect();
        levels.sort_unstable_by_key(|x| x.0);
        for (level, ids) in levels {
            if ids.len() == 2 {
                links.push((ids[0], ids[1]));
                continue;
            }
            // An odd count where a corner lies on the level: the stripe ends at that vertex, a
            // branch point, whose charts differ by the half turn, so that no perturbation is
            // the same in all of them.
            let on_level = (3 * f..3 * f + 3).find(|&c| (p.lat[c].x - level as f64).abs() <= 1e-9);
            match on_level {
                Some(c) if ids.len() % 2 == 1 => {
                    ends.extend(ids.iter().map(|&id| (id, mesh.from(c))))
                }
                _ => patched += 1,
            }
        }
    }
    // One point per such branch point, which the crossings on it (at an end of an edge of its
    // fan) join: the stripes on its level meet there, one at a +1/2 singularity, three at a
    // −1/2.
    let mut at_vertex: HashMap<usize, u32> = HashMap::new();
    for &(_, v) in &ends {
        let next = at_vertex.len() as u32;
        at_vertex.entry(v).or_insert(next);
    }
    let mut point: Vec<u32> = (0..positions.len() as u32).collect();
    let mut keep = vec![true; positions.len()];
    let mut junction = vec![NONE; at_vertex.len()];
    for (id, v) in on_vertex.iter().enumerate() {
        if let Some(&j) = v.and_then(|v| at_vertex.get(&v)) {
            if junction[j as usize] == NONE {
                junction[j as usize] = id as u32;
            } else {
                point[id] = junction[j as usize];
                keep[id] = false;
            }
        }
    }
    let mut vertex_of_junction: Vec<usize> = vec![0; at_vertex.len()];
    for (&v, &j) in &at_vertex {
        vertex_of_junction[j as usize] = v;
    }
    for (j, &v) in vertex_of_junction.iter().enumerate() {
        if junction[j] == NONE {
            positions.push(mesh.position(v));
            on_vertex.push(Some(v));
            point.push(positions.len() as u32 - 1);
            keep.push(true);
            junction[j] = positions.len() as u32 - 1;
        }
    }
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); positions.len()];
    let ends = ends
        .into_iter()
        .map(|(id, v)| (id, junction[at_vertex[&v] as usize]));
    for (a, b) in links.into_iter().chain(ends) {
        let (a, b) = (point[a as usize], point[b as usize]);
        if a != b && !adj[a as usize].contains(&b) {
            adj[a as usize].push(b);
            adj[b as usize].push(a);
        }
    }
    // Chain into polylines: start at ends (degree 1), then the remaining closed loops.
    let mut used = vec![false; positions.len()];
    let mut polylines = Vec::new();
    for pass in 0..2 {
        for s in 0..positions.len() {
            if used[s] || adj[s].is_empty() || (pass == 0 && adj[s].len() != 1) {
                continue;
            }
            let mut line = vec![s as u32];
            used[s] = true;
            let mut cur = s;
            while let Some(&nx) = adj[cur].iter().find(|&&n| !used[n as usize]) {
                used[nx as usize] = true;
                line.push(nx);
                cur = nx as usize;
            }
            // A stripe after the first through a junction (three stripes meeting at a −1/2
            // singularity) ends on it.
            let before = line.len().checked_sub(2).map(|i| line[i]);
            if let Some(&j) = adj[cur]
                .iter()
                .find(|&&n| adj[n as usize].len() >= 3 && Some(n) != before && n != line[0])
            {
                line.push(j);
            }
            if pass == 1 && adj[cur].contains(&(s as u32)) && line.len() > 2 {
                line.push(s as u32);
            }
            if line.len() >= 2 {
                polylines.push(line);
            }
        }
    }
    // Stripe points are iso-line crossings of input edges, or the branch points they meet at.
    let mut origins = vec![super::Origin::Unknown; positions.len()];
    for (e, list) in on_edge.iter().enumerate() {
        for &(_, id) in list {
            origins[id as usize] = super::Origin::Edge(e as u32);
        }
    }
    for (&j, &v) in junction.iter().zip(&vertex_of_junction) {
        origins[j as usize] = super::Origin::Vertex(v as u32);
    }
    // The crossings merged into a junction go.
    let mut new_id = vec![NONE; positions.len()];
    let mut kept = 0;
    for (id, &k) in keep.iter().enumerate() {
        if k {
            new_id[id] = kept;
            kept += 1;
        }
    }
    let positions: Vec<DVec3> = (0..positions.len())
        .filter(|&i| keep[i])
        .map(|i| positions[i])
        .collect();
    let origins: Vec<super::Origin> = (0..origins.len())
        .filter(|&i| keep[i])
        .map(|i| origins[i])
        .collect();
    for l in &mut polylines {
        for v in l.iter_mut() {
            *v = new_id[*v as usize];
        }
    }
    Remesh {
        positions,
        origins,
        faces: Vec::new(),
        polylines,
        patched_places: patched,
        purified: Default::default(),
        relaxed: None,
    }
}
