//! Pinched vertices: a remesh vertex whose faces form more than one fan (two boundary loops,
//! or two sides of one loop, meeting at a single grid point; measured on the bunny with its
//! boundary aligned, where the sides of a narrow hole round onto one lattice point). Such a
//! vertex is not a manifold vertex even when every edge is, and it lowers the Euler
//! characteristic by one per extra fan. Each extra fan gets a copy of the vertex (same
//! position and origin): the remesh stays a manifold with the input's topology, and the copies
//! are boundary vertices that relaxation moves along their own pieces of boundary.

use std::collections::{HashMap, HashSet};

use super::Remesh;
use crate::mesh::disjoint::Disjoint;

/// The corners of one fan: (face, position in the face).
type Fan = Vec<(usize, usize)>;

/// Per vertex: the fans its faces form (each a list of (face, corner)), one entry per vertex
/// with more than one fan. Faces are joined into a fan when they share an edge at the vertex.
fn fans(remesh: &Remesh) -> Vec<(u32, Vec<Fan>)> {
    let mut corners: HashMap<u32, Vec<(usize, usize)>> = HashMap::new();
    for (fi, f) in remesh.faces.iter().enumerate() {
        for k in 0..f.len() {
            corners.entry(f[k]).or_default().push((fi, k));
        }
    }
    let mut out = Vec::new();
    let mut vertices: Vec<u32> = corners.keys().copied().collect();
    vertices.sort_unstable();
    for v in vertices {
        let list = &corners[&v];
        let mut fan = Disjoint::new(list.len());
        // Corners sharing a neighbour of v (the other end of an edge at v) are in one fan.
        let mut by_neighbour: HashMap<u32, usize> = HashMap::new();
        for (i, &(fi, k)) in list.iter().enumerate() {
            let f = &remesh.faces[fi];
            let n = f.len();
            for w in [f[(k + n - 1) % n], f[(k + 1) % n]] {
                match by_neighbour.get(&w) {
                    Some(&j) => fan.union(i, j),
                    None => {
                        by_neighbour.insert(w, i);
                    }
                }
            }
        }
        let mut groups: Vec<Fan> = Vec::new();
        let mut index: HashMap<usize, usize> = HashMap::new();
        for (i, &c) in list.iter().enumerate() {
            let r = fan.find(i);
            let g = *index.entry(r).or_insert_with(|| {
                groups.push(Vec::new());
                groups.len() - 1
            });
            groups[g].push(c);
        }
        if groups.len() > 1 {
            out.push((v, groups));
        }
    }
    out
}

/// Vertices whose faces form more than one fan.
pub fn pinched_vertices(remesh: &Remesh) -> usize {
    fans(remesh).len()
}

/// Gives every fan after the first of a pinched vertex its own copy of the vertex; returns
/// the (vertex, copy) pairs made.
pub fn split_pinched_vertices(remesh: &mut Remesh) -> Vec<[u32; 2]> {
    let pinched = fans(remesh);
    let mut made = Vec::new();
    for (v, groups) in pinched {
        for group in groups.into_iter().skip(1) {
            let copy = remesh.positions.len() as u32;
            remesh.positions.push(remesh.positions[v as usize]);
            if let Some(&o) = remesh.origins.get(v as usize) {
                remesh.origins.resize(copy as usize, super::Origin::Unknown);
                remesh.origins.push(o);
            }
            for (fi, k) in group {
                remesh.faces[fi][k] = copy;
            }
            made.push([v, copy]);
        }
    }
    made
}

/// Drops faces that share no edge with any other face and have a vertex of `split` (the pairs
/// [`split_pinched_vertices`] made) among their corners: a cell that met the rest of the
/// remesh only at corners, where the grid crossed a narrow part of a hole (the bunny at 1500
/// vertices: one quad beside its bottom hole). Kept, it would be a component of its own and
/// raise the Euler characteristic by one. Returns the number dropped; unused vertices are
/// removed.
pub fn drop_detached_cells(remesh: &mut Remesh, split: &[[u32; 2]]) -> usize {
    if split.is_empty() {
        return 0;
    }
    let was_split: HashSet<u32> = split.iter().flatten().copied().collect();
    let (uses, _, _) = super::quality::edge_incidence(remesh);
    let detached: Vec<bool> = remesh
        .faces
        .iter()
        .map(|f| {
            let alone = (0..f.len()).all(|k| {
                let (a, b) = (f[k], f[(k + 1) % f.len()]);
                uses[&(a.min(b), a.max(b))] == 1
            });
            alone && f.iter().any(|v| was_split.contains(v))
        })
        .collect();
    let dropped = detached.iter().filter(|&&d| d).count();
    if dropped > 0 {
        let mut i = 0;
        remesh.faces.retain(|_| {
            i += 1;
            !detached[i - 1]
        });
        super::purify::compact(remesh);
    }
    dropped
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::Origin;
    use glam::DVec3;

    /// Two quads touching at one corner (a bow tie), and a quad strip beside them.
    fn bow_tie() -> Remesh {
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        Remesh {
            positions: vec![
                p(0.0, 0.0),
                p(1.0, 0.0),
                p(1.0, 1.0),
                p(0.0, 1.0),
                p(2.0, 1.0),
                p(2.0, 2.0),
                p(1.0, 2.0),
                p(3.0, 1.0),
                p(3.0, 2.0),
            ],
            origins: (0..9).map(Origin::Vertex).collect(),
            faces: vec![vec![0, 1, 2, 3], vec![2, 4, 5, 6], vec![4, 7, 8, 5]],
            ..Default::default()
        }
    }

    fn euler(r: &Remesh) -> i64 {
        let mut edges = std::collections::BTreeSet::new();
        for f in &r.faces {
            for k in 0..f.len() {
                let (a, b) = (f[k], f[(k + 1) % f.len()]);
                edges.insert((a.min(b), a.max(b)));
            }
        }
        let used: std::collections::BTreeSet<u32> = r.faces.iter().flatten().copied().collect();
        used.len() as i64 - edges.len() as i64 + r.faces.len() as i64
    }

    #[test]
    fn a_bow_tie_vertex_is_split_into_one_per_fan() {
        let mut r = bow_tie();
        // Two discs glued at a point: χ = 1 instead of 2.
        assert_eq!(euler(&r), 1);
        assert_eq!(pinched_vertices(&r), 1);
        assert_eq!(split_pinched_vertices(&mut r), vec![[2, 9]]);
        assert_eq!(pinched_vertices(&r), 0);
        assert_eq!(euler(&r), 2);
        assert_eq!(r.positions.len(), 10);
        assert_eq!(r.positions[9], r.positions[2]);
        assert_eq!(r.origins[9], Origin::Vertex(2));
        // The first fan keeps the vertex, the second takes the copy; the faces keep their
        // orientation and the strip beside them its shared edge.
        assert_eq!(r.faces[0], vec![0, 1, 2, 3]);
        assert_eq!(r.faces[1], vec![9, 4, 5, 6]);
        assert_eq!(r.faces[2], vec![4, 7, 8, 5]);
        // Nothing to split a second time, and a manifold mesh is left alone.
        assert!(split_pinched_vertices(&mut r).is_empty());
    }

    #[test]
    fn a_cell_the_split_leaves_alone_is_dropped_and_nothing_else() {
        let mut r = bow_tie();
        // Nothing split yet: the lone quad touches the strip at a corner, nothing is dropped.
        assert_eq!(drop_detached_cells(&mut r, &[]), 0);
        let split = split_pinched_vertices(&mut r);
        assert_eq!(split.len(), 1);
        // Quad 0 now meets nothing: dropped, with its four vertices (the strip has the copy).
        assert_eq!(drop_detached_cells(&mut r, &split), 1);
        assert_eq!(r.faces.len(), 2);
        assert_eq!(r.positions.len(), 6);
        assert_eq!(euler(&r), 1);
        // The strip is left as it was (renumbered), and its faces, which share an edge, are
        // kept even with the copy among their corners.
        let copy = r.faces[0][0];
        assert_eq!(r.positions[copy as usize], DVec3::new(1.0, 1.0, 0.0));
        assert_eq!(drop_detached_cells(&mut r, &[[copy, copy]]), 0);
        assert_eq!(r.faces.len(), 2);
    }

    #[test]
    fn a_closed_fan_and_a_boundary_fan_are_one_fan_each() {
        // A vertex inside four quads (one closed fan) and a boundary vertex with two.
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        let mut positions = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                positions.push(p(i as f64, j as f64));
            }
        }
        let id = |i: u32, j: u32| j * 3 + i;
        let faces = (0..2)
            .flat_map(|j| {
                (0..2).map(move |i| vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)])
            })
            .collect();
        let mut r = Remesh {
            positions,
            faces,
            ..Default::default()
        };
        assert_eq!(pinched_vertices(&r), 0);
        assert!(split_pinched_vertices(&mut r).is_empty());
    }
}
