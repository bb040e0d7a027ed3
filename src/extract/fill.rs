//! Local patching of the holes that extraction leaves where it could not close a face (around
//! flipped or degenerate triangles): each hole loop in the interior of the surface becomes one
//! polygon, so the output is closed wherever the input was. Loops along the input's boundary are
//! real boundaries and stay open.

use std::collections::HashMap;

/// Fills interior hole loops of a polygon mesh in place; returns how many were filled.
/// `on_input_boundary[v]` marks output vertices that lie on the input's boundary. A loop is
/// filled when none of its vertices does, it does not pass a vertex twice, it has at least 3
/// and at most `max_sides` vertices, and no vertex on it has more than one boundary edge out.
pub fn fill_holes(
    faces: &mut Vec<Vec<u32>>,
    on_input_boundary: &[bool],
    max_sides: usize,
) -> usize {
    let mut directed: HashMap<(u32, u32), usize> = HashMap::new();
    for f in faces.iter() {
        for k in 0..f.len() {
            *directed.entry((f[k], f[(k + 1) % f.len()])).or_default() += 1;
        }
    }
    // Boundary halfedges a -> b (face on the left, hole on the right), by start vertex.
    let mut out: HashMap<u32, Vec<u32>> = HashMap::new();
    for (&(a, b), &count) in &directed {
        // Used once, never backwards: a boundary edge. (Twice in one direction would be an
        // orientation defect; a third face there would make it non-manifold.)
        if count == 1 && !directed.contains_key(&(b, a)) {
            out.entry(a).or_default().push(b);
        }
    }
    let mut used: HashMap<u32, bool> = HashMap::new();
    let mut starts: Vec<u32> = out.keys().copied().collect();
    starts.sort_unstable();
    let mut filled = 0;
    for start in starts {
        if used.contains_key(&start) {
            continue;
        }
        let mut lp = vec![start];
        let mut ok = true;
        let mut cur = start;
        loop {
            used.insert(cur, true);
            let next = match out.get(&cur).map(Vec::as_slice) {
                Some([b]) => *b,
                _ => {
                    ok = false;
                    break;
                }
            };
            if next == start {
                break;
            }
            if used.contains_key(&next) || lp.len() >= max_sides {
                ok = false;
                break;
            }
            lp.push(next);
            cur = next;
        }
        let interior = lp
            .iter()
            .all(|&v| !on_input_boundary.get(v as usize).copied().unwrap_or(true));
        if ok && interior && lp.len() >= 3 {
            lp.reverse();
            faces.push(lp);
            filled += 1;
        }
    }
    filled
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3 × 3 grid of quads without its centre quad: the hole becomes one quad again.
    #[test]
    fn hole_in_a_grid_is_filled_and_outer_boundary_kept() {
        let id = |i: u32, j: u32| j * 4 + i;
        let mut faces = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                if (i, j) != (1, 1) {
                    faces.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
                }
            }
        }
        let on_boundary: Vec<bool> = (0..16)
            .map(|v| v % 4 == 0 || v % 4 == 3 || !(4..12).contains(&v))
            .collect();
        assert_eq!(fill_holes(&mut faces, &on_boundary, 32), 1);
        assert_eq!(faces.len(), 9);
        // Same orientation as the neighbours: the new face runs 5 -> 6 -> 10 -> 9.
        let f = faces.last().unwrap();
        let k = f.iter().position(|&v| v == 5).unwrap();
        assert_eq!(f[(k + 1) % 4], 6);
        assert_eq!(f.len(), 4);
        // Filling again finds nothing: only the input boundary is left.
        assert_eq!(fill_holes(&mut faces, &on_boundary, 32), 0);
    }
}
