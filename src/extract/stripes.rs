//! Stripes (N = 2): the integer iso-lines of u as polylines.

use std::collections::HashMap;

use glam::{DVec2, DVec3};

use super::Remesh;
use super::lattice::{Param, cross, dv};

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
            list.push((DVec2::new(kf, x.y), positions.len() as u32 - 1));
        }
    }
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); positions.len()];
    let mut patched = 0;
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
        for (_, ids) in by_level {
            if ids.len() == 2 {
                adj[ids[0] as usize].push(ids[1]);
                adj[ids[1] as usize].push(ids[0]);
            } else {
                patched += 1;
            }
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
            if pass == 1 && adj[cur].contains(&(s as u32)) && line.len() > 2 {
                line.push(s as u32);
            }
            if line.len() >= 2 {
                polylines.push(line);
            }
        }
    }
    // Stripe points are iso-line crossings of input edges.
    let mut origins = vec![super::Origin::Unknown; positions.len()];
    for (e, list) in on_edge.iter().enumerate() {
        for &(_, id) in list {
            origins[id as usize] = super::Origin::Edge(e as u32);
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
