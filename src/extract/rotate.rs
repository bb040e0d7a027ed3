//! Edge rotations along the boundary of a pure quad remesh: where the grid crosses an unaligned
//! boundary, boundary vertices are left with one face too few (a flat 180° corner) or one too
//! many (two thin corners), and the interior vertices next to them with five or three edges.
//! Rotating an interior edge between two quads (re-splitting the hexagon they make along one of
//! its other two diagonals) moves one edge end at each of its two vertices to the hexagon's
//! next corners, so a deficit and an excess next to each other cancel.
//!
//! The target valence of an interior vertex is 4; that of a boundary vertex follows from its
//! angle on the surface, round(θ / 90°) + 1 (a straight boundary 3, a convex corner 2, a concave
//! one 4). A rotation is made when it lowers Σ (valence − target)² over the four vertices it
//! changes, changes at least one boundary vertex, and leaves both new quads convex; the
//! rotations repeat until none lowers the sum. Deterministic: edges are visited in order.

use std::collections::HashMap;

use glam::DVec3;

use super::Remesh;
use super::quality::edge_incidence;

/// Passes over the candidate edges at most (each pass that rotates nothing ends the loop).
const MAX_PASSES: usize = 8;

/// Rotates interior edges near the boundary of the quads of `remesh` (faces that are not quads
/// are left alone) and returns how many were rotated.
pub fn rotate_boundary_edges(remesh: &mut Remesh) -> usize {
    let n = remesh.positions.len();
    if remesh.faces.iter().flatten().any(|&v| v as usize >= n) {
        return 0;
    }
    let (_, valence, boundary) = edge_incidence(remesh);
    let mut valence: Vec<i64> = valence.into_iter().map(|k| k as i64).collect();
    let faces = &mut remesh.faces;
    let pos = &remesh.positions;
    // directed edges → (face, corner)
    let mut half: HashMap<(u32, u32), (usize, usize)> = HashMap::new();
    for (fi, f) in faces.iter().enumerate() {
        for k in 0..f.len() {
            half.insert((f[k], f[(k + 1) % f.len()]), (fi, k));
        }
    }
    // boundary vertices' angles on the surface: the sum of their corners (rotations keep it)
    let mut angle = vec![0.0f64; n];
    for f in faces.iter() {
        let m = f.len();
        for k in 0..m {
            let v = f[k] as usize;
            if boundary[v] {
                let (a, c) = (
                    pos[f[(k + 1) % m] as usize],
                    pos[f[(k + m - 1) % m] as usize],
                );
                let t = (a - pos[v]).angle_between(c - pos[v]);
                if t.is_finite() {
                    angle[v] += t;
                }
            }
        }
    }
    let target: Vec<i64> = (0..n)
        .map(|v| {
            if boundary[v] {
                ((angle[v] / std::f64::consts::FRAC_PI_2).round() as i64 + 1).max(2)
            } else {
                4
            }
        })
        .collect();
    let cost = |valence: &[i64], v: u32| {
        let d = valence[v as usize] - target[v as usize];
        d * d
    };
    let mut rotated = 0;
    for _ in 0..MAX_PASSES {
        let mut changed = false;
        let mut edges: Vec<(u32, u32)> = half
            .keys()
            .copied()
            .filter(|&(a, b)| a < b && half.contains_key(&(b, a)))
            .filter(|&(a, b)| near_boundary(faces, &half, &boundary, a, b))
            .collect();
        edges.sort_unstable();
        for (x, y) in edges {
            let (Some(&(fi, k)), Some(&(gi, l))) = (half.get(&(x, y)), half.get(&(y, x))) else {
                continue; // rotated away earlier in this pass
            };
            if fi == gi || faces[fi].len() != 4 || faces[gi].len() != 4 {
                continue;
            }
            // F = (x, y, p, q), G = (y, x, r, s): the hexagon y p q x r s
            let fv = |i: usize| faces[fi][(k + i) % 4];
            let gv = |i: usize| faces[gi][(l + i) % 4];
            let (p, q, r, s) = (fv(2), fv(3), gv(2), gv(3));
            let hex = [y, p, q, x, r, s];
            let mut distinct = hex.to_vec();
            distinct.sort_unstable();
            distinct.dedup();
            if distinct.len() != 6 {
                continue;
            }
            let before: i64 = hex.iter().map(|&v| cost(&valence, v)).sum();
            let mut best: Option<(i64, [u32; 2], [[u32; 4]; 2])> = None;
            // the other two diagonals: (p, r) and (q, s)
            for (d, quads) in [
                ([p, r], [[p, q, x, r], [r, s, y, p]]),
                ([q, s], [[q, x, r, s], [s, y, p, q]]),
            ] {
                if half.contains_key(&(d[0], d[1])) || half.contains_key(&(d[1], d[0])) {
                    continue; // the diagonal is an edge already
                }
                if !boundary[x as usize]
                    && !boundary[y as usize]
                    && !boundary[d[0] as usize]
                    && !boundary[d[1] as usize]
                {
                    continue;
                }
                let mut val = [valence[x as usize], valence[y as usize], 0, 0];
                val[0] -= 1;
                val[1] -= 1;
                val[2] = valence[d[0] as usize] + 1;
                val[3] = valence[d[1] as usize] + 1;
                let after_changed: i64 = [x, y, d[0], d[1]]
                    .iter()
                    .zip(val)
                    .map(|(&v, nv)| (nv - target[v as usize]).pow(2))
                    .sum();
                let unchanged: i64 = hex
                    .iter()
                    .filter(|v| ![x, y, d[0], d[1]].contains(v))
                    .map(|&v| cost(&valence, v))
                    .sum();
                let after = after_changed + unchanged;
                if after < before
                    && best.is_none_or(|b| after < b.0)
                    && quads.iter().all(|qd| convex(pos, qd))
                {
                    best = Some((after, d, quads));
                }
            }
            let Some((_, d, quads)) = best else { continue };
            // apply: remove the old faces' half edges, write the new ones
            for fidx in [fi, gi] {
                let f = &faces[fidx];
                for i in 0..4 {
                    half.remove(&(f[i], f[(i + 1) % 4]));
                }
            }
            for (fidx, qd) in [fi, gi].into_iter().zip(quads) {
                faces[fidx] = qd.to_vec();
                for i in 0..4 {
                    half.insert((qd[i], qd[(i + 1) % 4]), (fidx, i));
                }
            }
            valence[x as usize] -= 1;
            valence[y as usize] -= 1;
            valence[d[0] as usize] += 1;
            valence[d[1] as usize] += 1;
            rotated += 1;
            changed = true;
        }
        if !changed {
            break;
        }
    }
    rotated
}

/// Whether the two faces at interior edge (a, b) have a boundary vertex.
fn near_boundary(
    faces: &[Vec<u32>],
    half: &HashMap<(u32, u32), (usize, usize)>,
    boundary: &[bool],
    a: u32,
    b: u32,
) -> bool {
    [(a, b), (b, a)].iter().any(|e| {
        half.get(e)
            .is_some_and(|&(f, _)| faces[f].iter().any(|&v| boundary[v as usize]))
    })
}

/// Whether quad `q` turns the same way at all four corners (about its Newell normal).
fn convex(pos: &[DVec3], q: &[u32; 4]) -> bool {
    let p = q.map(|v| pos[v as usize]);
    let mut nrm = DVec3::ZERO;
    for i in 0..4 {
        nrm += p[i].cross(p[(i + 1) % 4]);
    }
    let nrm = nrm.normalize_or_zero();
    if nrm == DVec3::ZERO {
        return false;
    }
    (0..4).all(|i| {
        let (a, b, c) = (p[i], p[(i + 1) % 4], p[(i + 2) % 4]);
        (b - a).cross(c - b).dot(nrm) > 0.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::Origin;

    /// A strip of quads along a straight boundary where the first boundary vertex has one edge
    /// too few and the next one too many: one rotation makes both regular.
    #[test]
    fn a_deficit_and_an_excess_on_the_boundary_cancel() {
        // boundary row y = 0: vertices 0..=4; inner row y = 1: 5..=9; top row y = 2: 10..=14.
        let mut positions = Vec::new();
        for j in 0..3 {
            for i in 0..5 {
                positions.push(DVec3::new(i as f64, j as f64, 0.0));
            }
        }
        // a regular grid, except that the quads at boundary vertices 1 and 2 are split along
        // the other diagonal of their hexagon: 1 has no interior edge, 2 has two.
        let mut faces: Vec<Vec<u32>> = vec![
            vec![0, 1, 2, 5],
            vec![2, 7, 6, 5],
            vec![2, 3, 8, 7],
            vec![3, 4, 9, 8],
        ];
        for i in 0..4u32 {
            faces.push(vec![5 + i, 6 + i, 11 + i, 10 + i]);
        }
        let n = positions.len();
        let mut r = Remesh {
            positions,
            origins: vec![Origin::Unknown; n],
            faces,
            ..Default::default()
        };
        let before = r.faces.clone();
        assert_eq!(rotate_boundary_edges(&mut r), 1);
        assert_ne!(r.faces, before);
        let mut valence = vec![0; n];
        let mut seen = std::collections::HashSet::new();
        for f in &r.faces {
            for k in 0..4 {
                let (a, b) = (f[k], f[(k + 1) % 4]);
                if seen.insert((a.min(b), a.max(b))) {
                    valence[a as usize] += 1;
                    valence[b as usize] += 1;
                }
            }
        }
        assert_eq!(&valence[0..5], &[2, 3, 3, 3, 2], "boundary row");
        assert_eq!(&valence[5..10], &[3, 4, 4, 4, 3], "inner row");
        // a second call finds nothing more to do
        assert_eq!(rotate_boundary_edges(&mut r), 0);
    }
}
