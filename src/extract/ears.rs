//! Slivers on the boundary of a triangle remesh (N = 6). Where the grid crosses an unaligned
//! boundary, grid lines cross it close to each other and purification's chords join what is
//! there, which leaves two kinds of slivers:
//! - *flat ears*: a triangle of three consecutive boundary vertices whose middle one lies
//!   almost on the segment between the other two (corners of about 0°, 0° and 180°). The ear is
//!   cut off: the triangle and its middle vertex go, the boundary runs straight from one
//!   neighbour to the other (moving it by at most the ear's height);
//! - *short boundary edges* (shorter than a quarter of the mean edge): collapsed into one of
//!   their ends (the one at an input vertex, which may be a boundary corner), so the boundary
//!   stays on the input's boundary; the triangle at the edge goes.
//!
//! Either keeps the Euler characteristic (one vertex, two edges and one face fewer), the
//! boundary loops and manifoldness (a collapse only where the two ends share no neighbour but
//! the triangle's third corner).

use std::collections::{HashMap, HashSet};

use super::purify::{compact, drop_faces};
use super::quality::{edge_incidence, edge_lengths};
use super::{Origin, Remesh};

/// The middle corner (degrees) from which an ear counts as flat.
const FLAT_DEG: f64 = 150.0;
/// Boundary edges shorter than this fraction of the mean edge length are collapsed.
const SHORT_EDGE: f64 = 0.25;

/// Cuts the flat ears off the triangles of `remesh` (other faces are left alone), repeatedly,
/// and returns how many were cut. Unused vertices are dropped.
pub fn cut_flat_ears(remesh: &mut Remesh) -> usize {
    let n = remesh.positions.len();
    if remesh.faces.iter().flatten().any(|&v| v as usize >= n) {
        return 0;
    }
    let mut cut = 0;
    loop {
        let (edge_faces, valence, _) = edge_incidence(remesh);
        let count = |a: u32, b: u32| edge_faces.get(&(a.min(b), a.max(b))).copied().unwrap_or(0);
        let pos = &remesh.positions;
        let mut gone = vec![false; remesh.faces.len()];
        let mut touched = vec![false; n];
        for (fi, f) in remesh.faces.iter().enumerate() {
            if f.len() != 3 {
                continue;
            }
            for k in 0..3 {
                let (a, v, b) = (f[(k + 2) % 3], f[k], f[(k + 1) % 3]);
                let middle = (pos[a as usize] - pos[v as usize])
                    .angle_between(pos[b as usize] - pos[v as usize])
                    .to_degrees();
                // v's only edges are the two boundary edges: it is in this triangle only
                let ear = valence[v as usize] == 2
                    && count(a, v) == 1
                    && count(v, b) == 1
                    && count(a, b) == 2
                    && middle.is_finite()
                    && middle > FLAT_DEG
                    && ![a, v, b].iter().any(|&x| touched[x as usize]);
                if ear {
                    gone[fi] = true;
                    for x in [a, v, b] {
                        touched[x as usize] = true;
                    }
                    break;
                }
            }
        }
        let now = gone.iter().filter(|&&g| g).count();
        if now == 0 {
            break;
        }
        cut += now;
        drop_faces(remesh, &gone);
    }
    if cut > 0 {
        compact(remesh);
    }
    cut
}

/// Collapses the boundary edges of the triangles of `remesh` shorter than [`SHORT_EDGE`] of the
/// mean edge length, shortest first, in rounds of edges whose neighbourhoods do not overlap,
/// and returns how many were collapsed. Unused vertices are dropped.
pub fn collapse_short_boundary_edges(remesh: &mut Remesh) -> usize {
    let n = remesh.positions.len();
    if remesh.faces.iter().flatten().any(|&v| v as usize >= n)
        || remesh.faces.iter().any(|f| f.len() != 3)
    {
        return 0;
    }
    let lengths = edge_lengths(remesh);
    let mean = lengths.iter().sum::<f64>() / lengths.len().max(1) as f64;
    let limit = SHORT_EDGE * mean;
    let mut collapsed = 0;
    loop {
        let mut edge_faces: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
        let mut ring: Vec<HashSet<u32>> = vec![HashSet::new(); n];
        for (fi, f) in remesh.faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                edge_faces.entry((a.min(b), a.max(b))).or_default().push(fi);
                ring[a as usize].insert(b);
                ring[b as usize].insert(a);
            }
        }
        let pos = &remesh.positions;
        let mut short: Vec<(f64, u32, u32, usize)> = edge_faces
            .iter()
            .filter(|(_, fs)| fs.len() == 1)
            .map(|(&(a, b), fs)| ((pos[a as usize] - pos[b as usize]).length(), a, b, fs[0]))
            .filter(|e| e.0 < limit)
            .collect();
        short.sort_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))));
        let mut touched = vec![false; n];
        let mut merge: Vec<(u32, u32, usize)> = Vec::new();
        for (_, a, b, fi) in short {
            let f = &remesh.faces[fi];
            let Some(&c) = f.iter().find(|&&x| x != a && x != b) else {
                continue;
            };
            let common = ring[a as usize].intersection(&ring[b as usize]).count();
            let near = |v: u32| {
                touched[v as usize] || ring[v as usize].iter().any(|&w| touched[w as usize])
            };
            if common != 1 || !ring[a as usize].contains(&c) || near(a) || near(b) {
                continue;
            }
            // keep the end at an input vertex (it may be a boundary corner)
            let at_vertex =
                |v: u32| matches!(remesh.origins.get(v as usize), Some(Origin::Vertex(_)));
            let (keep, drop) = if at_vertex(b) && !at_vertex(a) {
                (b, a)
            } else {
                (a, b)
            };
            for v in [a, b] {
                touched[v as usize] = true;
            }
            merge.push((keep, drop, fi));
        }
        if merge.is_empty() {
            break;
        }
        let mut into: Vec<u32> = (0..n as u32).collect();
        let mut gone = vec![false; remesh.faces.len()];
        for &(keep, drop, fi) in &merge {
            into[drop as usize] = keep;
            gone[fi] = true;
        }
        drop_faces(remesh, &gone);
        for v in remesh.faces.iter_mut().flatten() {
            *v = into[*v as usize];
        }
        collapsed += merge.len();
    }
    if collapsed > 0 {
        compact(remesh);
    }
    collapsed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::Origin;
    use glam::DVec3;

    /// Two triangles on a strip, one of them a flat ear along the bottom: the ear goes, the
    /// other triangle and the boundary loop stay.
    #[test]
    fn a_flat_ear_is_cut_and_nothing_else() {
        let positions = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.01, 0.0), // almost on the segment 0–2
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(1.0, -1.0, 0.0),
        ];
        // ear (0, 1, 2) above the edge 0–2, triangle (0, 2, 3)... oriented consistently
        let faces = vec![vec![0, 2, 1], vec![0, 3, 2]];
        let mut r = Remesh {
            origins: vec![Origin::Unknown; positions.len()],
            positions,
            faces,
            ..Default::default()
        };
        assert_eq!(cut_flat_ears(&mut r), 1);
        assert_eq!(r.faces.len(), 1);
        assert_eq!(r.positions.len(), 3, "the ear's middle vertex is dropped");
        assert_eq!(r.origins.len(), 3);
        assert!(!r.positions.contains(&DVec3::new(1.0, 0.01, 0.0)));
        // nothing left to cut: the remaining triangle's edges are all on the boundary
        assert_eq!(cut_flat_ears(&mut r), 0);
    }

    /// A fan of four triangles around an interior vertex of a square, with one boundary edge
    /// split by a vertex a hair from its end: that short edge is collapsed into the corner.
    #[test]
    fn a_short_boundary_edge_is_collapsed_into_its_end() {
        let positions = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::new(0.99, 0.0, 0.0), // a hair from corner 1
        ];
        let faces = vec![
            vec![0, 5, 4],
            vec![5, 1, 4],
            vec![1, 2, 4],
            vec![2, 3, 4],
            vec![3, 0, 4],
        ];
        let mut origins = vec![Origin::Vertex(0); 6];
        origins[5] = Origin::Edge(0);
        let mut r = Remesh {
            origins,
            positions,
            faces,
            ..Default::default()
        };
        assert_eq!(collapse_short_boundary_edges(&mut r), 1);
        assert_eq!(r.faces.len(), 4);
        assert_eq!(r.positions.len(), 5);
        assert!(
            r.positions.contains(&DVec3::new(1.0, 0.0, 0.0)),
            "the corner is kept"
        );
        assert_eq!(r.euler_characteristic(), 1);
        assert_eq!(collapse_short_boundary_edges(&mut r), 0);
    }
}
