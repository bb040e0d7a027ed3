//! Local patching of the holes that extraction leaves where it could not close a face (around
//! flipped or degenerate triangles): each hole loop in the interior of the surface becomes one
//! polygon, so the output is closed wherever the input was. Loops along the input's boundary are
//! real boundaries and stay open. Before that, pleats go: a face traced twice, once on each
//! sheet of a fold, with opposite orientations ([`drop_pleats`]).

use std::collections::HashMap;

/// Fills interior hole loops of a polygon mesh in place; returns how many were filled.
/// `on_input_boundary[v]` marks output vertices that lie on the input's boundary. A loop is
/// filled when none of its vertices does, it does not pass a vertex twice, and it has at least 3
/// vertices, however many (a fold's hole on fandisk, N = 6, features at 60°, had 46 sides; left
/// open under the longest face extraction closes, 32, the remesh's Euler characteristic was 1
/// instead of 2; `purify` makes the polygon pure). Two holes touching at a vertex are told apart
/// there: a hole's boundary leaves the vertex through the other face fan than the one it
/// arrived by.
pub fn fill_holes(faces: &mut Vec<Vec<u32>>, on_input_boundary: &[bool]) -> usize {
    // Directed edge -> (face, corner of its start), and how often it is used.
    let mut at: HashMap<(u32, u32), (usize, usize)> = HashMap::new();
    let mut count: HashMap<(u32, u32), usize> = HashMap::new();
    for (fi, f) in faces.iter().enumerate() {
        for k in 0..f.len() {
            let e = (f[k], f[(k + 1) % f.len()]);
            at.insert(e, (fi, k));
            *count.entry(e).or_default() += 1;
        }
    }
    // Boundary halfedges a -> b: used once and never backwards (face on the left, hole on the
    // right). Twice in one direction would be an orientation defect: left alone.
    let is_boundary = |e: &(u32, u32)| count.get(e) == Some(&1) && !count.contains_key(&(e.1, e.0));
    let mut out: HashMap<u32, Vec<u32>> = HashMap::new();
    let mut boundary: Vec<(u32, u32)> = count.keys().copied().filter(is_boundary).collect();
    boundary.sort_unstable();
    for &(a, b) in &boundary {
        out.entry(a).or_default().push(b);
    }
    // The boundary halfedge leaving v on the same face fan as the boundary halfedge (x, v).
    let same_fan_out = |x: u32, v: u32| -> Option<(u32, u32)> {
        let mut e = (x, v);
        for _ in 0..faces.len() {
            let &(fi, k) = at.get(&e)?;
            let f = &faces[fi];
            let next = (v, f[(k + 2) % f.len()]);
            if is_boundary(&next) {
                return Some(next);
            }
            e = (next.1, v); // the face across the interior edge v -> w holds w -> v
        }
        None
    };
    let next_of = |(x, v): (u32, u32)| -> Option<(u32, u32)> {
        match out.get(&v).map(Vec::as_slice) {
            Some([b]) => Some((v, *b)),
            Some([b0, b1]) => {
                let own = same_fan_out(x, v)?;
                Some(if own == (v, *b0) { (v, *b1) } else { (v, *b0) })
            }
            _ => None,
        }
    };
    let mut used: HashMap<(u32, u32), bool> = HashMap::new();
    let mut patches: Vec<Vec<u32>> = Vec::new();
    for &start in &boundary {
        if used.contains_key(&start) {
            continue;
        }
        let mut lp = vec![start.0];
        let mut ok = true;
        let mut e = start;
        loop {
            used.insert(e, true);
            let Some(next) = next_of(e) else {
                ok = false;
                break;
            };
            if next == start {
                break;
            }
            if used.contains_key(&next) {
                ok = false;
                break;
            }
            lp.push(next.0);
            e = next;
        }
        let mut distinct = lp.clone();
        distinct.sort_unstable();
        distinct.dedup();
        let interior = lp
            .iter()
            .all(|&v| !on_input_boundary.get(v as usize).copied().unwrap_or(true));
        if ok && interior && lp.len() >= 3 && distinct.len() == lp.len() {
            lp.reverse();
            patches.push(lp);
        }
    }
    let filled = patches.len();
    faces.extend(patches);
    filled
}

/// Per undirected edge (smaller vertex first) the number of faces using it.
fn edge_uses(faces: &[Vec<u32>]) -> HashMap<(u32, u32), usize> {
    let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
    for f in faces {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    uses
}

/// A face and its reverse both present where one of their edges is in more than two faces and
/// one of their vertices is in no other face: a pleat, the same grid cell traced on both sheets
/// of a fold in the map (that vertex is a grid point inside the fold whose two traced edges
/// bound the cell on either side). Both copies are dropped, leaving the edge they hang from with
/// its two real faces; whatever else they leave open is a hole for [`fill_holes`]. Left alone:
/// two reversed faces making a closed surface on their own (a pillow: every edge in exactly two
/// faces), and a tube two cells around (every quad has its reverse, every vertex is in four
/// faces: a grid too coarse, which is reported, not a fold). Repeated while it drops any: a
/// pleat two cells wide has its inner vertex in both pairs, and only the outer pair's vertex is
/// in no other face until that pair is gone (a T-shaped prism, N = 6: two non-manifold edges
/// left, 2026-12-06). Returns how many pairs were dropped.
pub fn drop_pleats(faces: &mut Vec<Vec<u32>>) -> usize {
    let mut pairs = 0;
    loop {
        let dropped = drop_pleats_once(faces);
        if dropped == 0 {
            return pairs;
        }
        pairs += dropped;
    }
}

/// One pass of [`drop_pleats`].
fn drop_pleats_once(faces: &mut Vec<Vec<u32>>) -> usize {
    // The cycle rotated to start at its smallest vertex: equal for the same face.
    let canonical = |f: &[u32]| -> Vec<u32> {
        let k = (0..f.len()).min_by_key(|&i| f[i]).unwrap_or(0);
        f[k..].iter().chain(&f[..k]).copied().collect()
    };
    let edge_faces = edge_uses(faces);
    let mut vertex_faces: HashMap<u32, usize> = HashMap::new();
    for f in faces.iter() {
        for &v in f {
            *vertex_faces.entry(v).or_default() += 1;
        }
    }
    let pleat = |f: &[u32]| {
        (0..f.len()).any(|k| {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            edge_faces[&(a.min(b), a.max(b))] > 2
        }) && f.iter().any(|v| vertex_faces[v] == 2)
    };
    let mut index: HashMap<Vec<u32>, Vec<usize>> = HashMap::new();
    for (i, f) in faces.iter().enumerate() {
        index.entry(canonical(f)).or_default().push(i);
    }
    let mut drop = vec![false; faces.len()];
    let mut pairs = 0;
    for (i, f) in faces.iter().enumerate() {
        if drop[i] || !pleat(f) {
            continue;
        }
        let reversed: Vec<u32> = f.iter().rev().copied().collect();
        let partner = index
            .get(&canonical(&reversed))
            .and_then(|js| js.iter().copied().find(|&j| j != i && !drop[j]));
        if let Some(j) = partner {
            drop[i] = true;
            drop[j] = true;
            pairs += 1;
        }
    }
    if pairs > 0 {
        let mut k = 0;
        faces.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
    }
    pairs
}

/// Faces that share no edge with any other face and touch no input boundary: fragments of a
/// fold, left standing in a hole (often touching its rim at one vertex, so that the rim passes
/// that vertex twice and [`fill_holes`] could not close it). Dropped; returns how many.
pub fn drop_stray_faces(faces: &mut Vec<Vec<u32>>, on_input_boundary: &[bool]) -> usize {
    let uses = edge_uses(faces);
    let stray = |f: &Vec<u32>| {
        (0..f.len()).all(|k| {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            uses[&(a.min(b), a.max(b))] == 1
        }) && f
            .iter()
            .all(|&v| !on_input_boundary.get(v as usize).copied().unwrap_or(true))
    };
    let before = faces.len();
    faces.retain(|f| !stray(f));
    before - faces.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_without(holes: &[(u32, u32)], on_boundary: &mut Vec<bool>) -> Vec<Vec<u32>> {
        let id = |i: u32, j: u32| j * 5 + i;
        let mut faces = Vec::new();
        for j in 0..4 {
            for i in 0..4 {
                if !holes.contains(&(i, j)) {
                    faces.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
                }
            }
        }
        *on_boundary = (0..25)
            .map(|v| v % 5 == 0 || v % 5 == 4 || !(5..20).contains(&v))
            .collect();
        faces
    }

    /// A 4 × 4 grid of quads without one interior quad: the hole becomes one quad again, with
    /// the orientation of its neighbours.
    #[test]
    fn hole_in_a_grid_is_filled_and_outer_boundary_kept() {
        let mut on_boundary = Vec::new();
        let mut faces = grid_without(&[(1, 1)], &mut on_boundary);
        assert_eq!(fill_holes(&mut faces, &on_boundary), 1);
        assert_eq!(faces.len(), 16);
        let f = faces.last().unwrap();
        let k = f.iter().position(|&v| v == 6).unwrap();
        assert_eq!((f.len(), f[(k + 1) % 4]), (4, 7));
        assert_eq!(fill_holes(&mut faces, &on_boundary), 0);
    }

    /// A hole of 36 sides (9 × 9 cells missing from a 12 × 12 grid) is one polygon too.
    #[test]
    fn a_long_hole_is_filled() {
        let id = |i: u32, j: u32| j * 13 + i;
        let mut faces = Vec::new();
        for j in 0..12 {
            for i in 0..12 {
                if !((2..11).contains(&i) && (2..11).contains(&j)) {
                    faces.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
                }
            }
        }
        let on_boundary: Vec<bool> = (0..169)
            .map(|v| v % 13 == 0 || v % 13 == 12 || !(13..156).contains(&v))
            .collect();
        assert_eq!(fill_holes(&mut faces, &on_boundary), 1);
        assert_eq!(faces.last().map(Vec::len), Some(36));
    }

    /// Two holes touching diagonally at vertex 12 (a figure-8 boundary): both are filled.
    #[test]
    fn holes_touching_at_a_vertex_are_filled_separately() {
        let mut on_boundary = Vec::new();
        let mut faces = grid_without(&[(1, 1), (2, 2)], &mut on_boundary);
        assert_eq!(fill_holes(&mut faces, &on_boundary), 2);
        assert_eq!(faces.len(), 16);
        assert!(faces[14..].iter().all(|f| f.len() == 4 && f.contains(&12)));
    }

    /// A 3 × 3 grid of quads with a pleat hanging from the edge 5–6 (a point 16 inside a fold,
    /// the triangle 5, 6, 16 traced once per sheet): both copies go, the grid is left as it
    /// was. Two reversed quads on their own (a pillow) stay, and so does a tube two cells around.
    #[test]
    fn pleats_are_dropped_and_pillows_kept() {
        let id = |i: u32, j: u32| j * 4 + i;
        let mut faces: Vec<Vec<u32>> = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                faces.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let grid = faces.clone();
        faces.insert(4, vec![5, 6, 16]);
        faces.push(vec![16, 6, 5]);
        assert_eq!(drop_pleats(&mut faces), 1);
        assert_eq!(faces, grid);
        assert_eq!(drop_pleats(&mut faces), 0);
        // Two cells wide: 5, 6, 16 and 6, 17, 16 traced on both sheets; 16 is in both pairs.
        faces.insert(4, vec![5, 6, 16]);
        faces.push(vec![16, 6, 5]);
        faces.push(vec![6, 17, 16]);
        faces.insert(2, vec![16, 17, 6]);
        assert_eq!(drop_pleats(&mut faces), 2);
        assert_eq!(faces, grid);
        let mut pillow = vec![vec![0, 1, 2, 3], vec![3, 2, 1, 0]];
        assert_eq!(drop_pleats(&mut pillow), 0);
        assert_eq!(pillow.len(), 2);
        // A tube two cells around: rings (0, 1), (2, 3), (4, 5), each ring's quads reversed.
        let mut tube: Vec<Vec<u32>> = (0..3)
            .flat_map(|r| {
                let (a0, a1, b0, b1) = (2 * r, 2 * r + 1, (2 * r + 2) % 6, (2 * r + 3) % 6);
                [vec![a0, a1, b1, b0], vec![a1, a0, b0, b1]]
            })
            .collect();
        assert_eq!(drop_pleats(&mut tube), 0);
        assert_eq!(tube.len(), 6);
    }

    /// A triangle left in a hole, touching its rim at one vertex: the rim passes that vertex
    /// twice, so nothing is filled until the triangle goes; then the hole is one quad again.
    #[test]
    fn a_stray_face_in_a_hole_is_dropped_and_the_hole_filled() {
        let mut on_boundary = Vec::new();
        let mut faces = grid_without(&[(1, 1)], &mut on_boundary);
        on_boundary.resize(27, false);
        faces.push(vec![6, 25, 26]);
        let grid = faces.len() - 1;
        assert_eq!(fill_holes(&mut faces, &on_boundary), 0);
        assert_eq!(drop_stray_faces(&mut faces, &on_boundary), 1);
        assert_eq!(faces.len(), grid);
        assert_eq!(fill_holes(&mut faces, &on_boundary), 1);
        // A lone quad on the input boundary (a small part of its own) stays.
        let mut lone = vec![vec![0, 1, 2, 3]];
        assert_eq!(drop_stray_faces(&mut lone, &[true; 4]), 0);
    }
}
