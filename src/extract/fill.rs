//! Local patching of the holes that extraction leaves where it could not close a face (around
//! flipped or degenerate triangles): each hole loop in the interior of the surface becomes one
//! polygon, so the output is closed wherever the input was. Loops along the input's boundary are
//! real boundaries and stay open.

use std::collections::HashMap;

/// Fills interior hole loops of a polygon mesh in place; returns how many were filled.
/// `on_input_boundary[v]` marks output vertices that lie on the input's boundary. A loop is
/// filled when none of its vertices does, it does not pass a vertex twice, and it has at least 3
/// and at most `max_sides` vertices. Two holes touching at a vertex are told apart there: a
/// hole's boundary leaves the vertex through the other face fan than the one it arrived by.
pub fn fill_holes(
    faces: &mut Vec<Vec<u32>>,
    on_input_boundary: &[bool],
    max_sides: usize,
) -> usize {
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
            if used.contains_key(&next) || lp.len() >= max_sides {
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
        assert_eq!(fill_holes(&mut faces, &on_boundary, 32), 1);
        assert_eq!(faces.len(), 16);
        let f = faces.last().unwrap();
        let k = f.iter().position(|&v| v == 6).unwrap();
        assert_eq!((f.len(), f[(k + 1) % 4]), (4, 7));
        assert_eq!(fill_holes(&mut faces, &on_boundary, 32), 0);
    }

    /// Two holes touching diagonally at vertex 12 (a figure-8 boundary): both are filled.
    #[test]
    fn holes_touching_at_a_vertex_are_filled_separately() {
        let mut on_boundary = Vec::new();
        let mut faces = grid_without(&[(1, 1), (2, 2)], &mut on_boundary);
        assert_eq!(fill_holes(&mut faces, &on_boundary, 32), 2);
        assert_eq!(faces.len(), 16);
        assert!(faces[14..].iter().all(|f| f.len() == 4 && f.contains(&12)));
    }
}
