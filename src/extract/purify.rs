//! Pure output: every face of a quad extraction a quad, every face of a triangle extraction a
//! triangle, without changing the density.
//!
//! Extraction leaves other polygons where the grid does not close into cells: cells cut by an
//! unaligned boundary, singularities off the lattice, fold patches. They are made pure locally:
//! - Quads (N = 4). A polygon with an even number of sides splits into quads along chords. An
//!   odd one needs one vertex more or less, and the handshake lemma (sides sum to twice the
//!   edges) says that odd faces come in pairs on a closed surface:
//!   1. an odd face on the boundary collapses its shortest boundary edge (a corner cut off by
//!      the boundary becomes a full cell; a triangle cut off vanishes) when the collapse keeps
//!      the mesh manifold, otherwise it gains a vertex on its longest boundary edge;
//!   2. the remaining odd faces are joined pairwise (or to the boundary) by the shortest path of
//!      faces in the dual graph, and every edge the path crosses gains its midpoint: the two
//!      ends become even, every face between gains two vertices and stays even;
//!   3. every polygon with more than four sides is split into quads by chords, each chosen to
//!      make the quad cut off closest to a rectangle.
//! - Triangles (N = 6): every other polygon is triangulated by the same greedy choice of ears.
//!
//! Relaxation (`relax`) afterwards evens the shapes of the faces this makes.

use std::collections::{HashMap, HashSet, VecDeque};

use glam::DVec3;

use super::{Origin, Remesh};

/// What [`purify`] changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PurifyStats {
    /// Faces that were not pure before.
    pub impure_faces: usize,
    /// Boundary crossings merged into the grid point beside them (`snap`).
    pub snapped: usize,
    pub collapsed_edges: usize,
    pub inserted_vertices: usize,
    pub chords: usize,
    /// Pairs of adjacent triangles joined into a quad (their common edge removed).
    pub joined_triangles: usize,
    /// Interior edges rotated near the boundary to even out valences (`rotate.rs`; N = 4).
    pub rotated_edges: usize,
    /// Flat boundary ears cut off (`ears.rs`; N = 6).
    pub cut_ears: usize,
    /// Copies made of pinched vertices, one per fan after the first (`pinch.rs`; pure or not).
    pub split_vertices: usize,
    /// Single cells the split left hanging on their own (a quad or triangle that met the rest
    /// only at pinched corners, beside a hole), dropped (`pinch.rs`).
    pub dropped_cells: usize,
}

/// Makes every face a quad (`sides = 4`) or a triangle (`sides = 3`).
pub fn purify(remesh: &mut Remesh, sides: usize) -> PurifyStats {
    let mut stats = PurifyStats {
        impure_faces: remesh.faces.iter().filter(|f| f.len() != sides).count(),
        ..Default::default()
    };
    if stats.impure_faces == 0 {
        return stats;
    }
    remesh
        .origins
        .resize(remesh.positions.len(), Origin::Unknown);
    let h = mean_edge_length(remesh);
    stats.snapped = super::snap::snap_boundary(remesh, sides, h);
    if sides == 4 {
        collapse_or_extend_boundary_odd_faces(remesh, &mut stats);
        join_triangle_pairs(remesh, &mut stats);
        pair_odd_faces(remesh, &mut stats);
    }
    split_faces(remesh, sides, &mut stats);
    compact(remesh);
    stats
}

/// Directed edge (a, b) -> the face holding it.
fn edge_faces(faces: &[Vec<u32>]) -> HashMap<(u32, u32), usize> {
    let mut m = HashMap::with_capacity(faces.iter().map(Vec::len).sum());
    for (fi, f) in faces.iter().enumerate() {
        for k in 0..f.len() {
            m.insert((f[k], f[(k + 1) % f.len()]), fi);
        }
    }
    m
}

fn is_odd(f: &[u32]) -> bool {
    f.len() % 2 == 1
}

/// Inserts vertex `m` between `a` and `b` in face `f` (which holds the directed edge a -> b).
fn insert_after(f: &mut Vec<u32>, a: u32, b: u32, m: u32) {
    let n = f.len();
    if let Some(k) = (0..n).find(|&k| f[k] == a && f[(k + 1) % n] == b) {
        f.insert(k + 1, m);
    }
}

/// The midpoint vertex of edge (a, b); on the boundary it keeps an input edge of its ends.
fn add_midpoint(remesh: &mut Remesh, a: u32, b: u32, boundary: bool) -> u32 {
    let p = 0.5 * (remesh.positions[a as usize] + remesh.positions[b as usize]);
    let origin = if boundary {
        match (remesh.origins[a as usize], remesh.origins[b as usize]) {
            (Origin::Edge(e), _) | (_, Origin::Edge(e)) => Origin::Edge(e),
            _ => Origin::Unknown,
        }
    } else {
        Origin::Unknown
    };
    remesh.positions.push(p);
    remesh.origins.push(origin);
    remesh.positions.len() as u32 - 1
}

/// Step 1: odd faces with a boundary edge.
fn collapse_or_extend_boundary_odd_faces(remesh: &mut Remesh, stats: &mut PurifyStats) {
    // Passes until no odd boundary face is left: a collapse changes its neighbours' vertex
    // lists (never their side counts), so each pass takes only collapses whose vertices no
    // other collapse of the pass touches.
    let mean_len = mean_edge_length(remesh);
    for _pass in 0..8 {
        let he = edge_faces(&remesh.faces);
        let mut neighbours: HashMap<u32, HashSet<u32>> = HashMap::new();
        for &(a, b) in he.keys() {
            neighbours.entry(a).or_default().insert(b);
            neighbours.entry(b).or_default().insert(a);
        }
        let mut touched: HashSet<u32> = HashSet::new();
        let mut merge: HashMap<u32, u32> = HashMap::new();
        let mut removed = vec![false; remesh.faces.len()];
        let mut progress = false;
        let mut deferred = false;
        for fi in 0..remesh.faces.len() {
            let f = remesh.faces[fi].clone();
            if !is_odd(&f) {
                continue;
            }
            let n = f.len();
            let bedges: Vec<(u32, u32)> = (0..n)
                .map(|k| (f[k], f[(k + 1) % n]))
                .filter(|&(a, b)| !he.contains_key(&(b, a)))
                .collect();
            if bedges.is_empty() {
                continue;
            }
            let len = |(a, b): (u32, u32)| {
                (remesh.positions[a as usize] - remesh.positions[b as usize]).length()
            };
            let shortest = *bedges
                .iter()
                .min_by(|x, y| len(**x).total_cmp(&len(**y)))
                .unwrap();
            let (a, b) = shortest;
            let corner = |v: u32| matches!(remesh.origins[v as usize], Origin::Vertex(_));
            let can_collapse = len(shortest) < 0.75 * mean_len
                && !(corner(a) && corner(b))
                && collapse_keeps_manifold(&f, a, b, &he, &neighbours);
            if can_collapse {
                if touched.contains(&a) || touched.contains(&b) {
                    deferred = true;
                    continue;
                }
                // Every vertex of the faces around a and b is touched: their lists change.
                for v in [a, b] {
                    touched.insert(v);
                    touched.extend(neighbours[&v].iter().copied());
                }
                let keep = if corner(b) { b } else { a };
                let gone = if keep == a { b } else { a };
                if !corner(keep) {
                    remesh.positions[keep as usize] =
                        0.5 * (remesh.positions[a as usize] + remesh.positions[b as usize]);
                }
                merge.insert(gone, keep);
                if n == 3 {
                    removed[fi] = true;
                }
                stats.collapsed_edges += 1;
            } else {
                let (a, b) = *bedges
                    .iter()
                    .max_by(|x, y| len(**x).total_cmp(&len(**y)))
                    .unwrap();
                let m = add_midpoint(remesh, a, b, true);
                insert_after(&mut remesh.faces[fi], a, b, m);
                stats.inserted_vertices += 1;
            }
            progress = true;
        }
        if !merge.is_empty() {
            drop_faces(remesh, &removed);
            remap_faces(&mut remesh.faces, |v| Some(*merge.get(&v).unwrap_or(&v)));
        }
        if !progress || !deferred {
            break;
        }
    }
}

/// Whether collapsing the boundary edge a -> b of face `f` keeps the mesh a manifold: a and b
/// have no common neighbour except, for a triangle, its third corner, and share no other face.
fn collapse_keeps_manifold(
    f: &[u32],
    a: u32,
    b: u32,
    he: &HashMap<(u32, u32), usize>,
    neighbours: &HashMap<u32, HashSet<u32>>,
) -> bool {
    let (Some(na), Some(nb)) = (neighbours.get(&a), neighbours.get(&b)) else {
        return false;
    };
    let allowed: Vec<u32> = if f.len() == 3 {
        f.iter().copied().filter(|&v| v != a && v != b).collect()
    } else {
        Vec::new()
    };
    if na
        .intersection(nb)
        .any(|v| !allowed.contains(v) && *v != a && *v != b)
    {
        return false;
    }
    // Both must lie on the boundary (the edge is a boundary edge, so they do), and a triangle's
    // third corner must not end up with two boundary edges meeting from both sides.
    if f.len() == 3 {
        let g = allowed[0];
        // Edges g-a and g-b merge; if both were boundary edges the triangle was an island.
        let ga_boundary = !he.contains_key(&(a, g));
        let bg_boundary = !he.contains_key(&(g, b));
        if ga_boundary && bg_boundary {
            return false;
        }
    }
    true
}

/// Step 2a: adjacent triangles become one quad by removing their common edge (what a midpoint
/// on it would do too, without the midpoint's valence-2 vertex). A maximal matching, taking the
/// triangles with the fewest free triangle neighbours first: on a cycle of triangles (the fan
/// around a pole) that pairs them all when there is an even number.
fn join_triangle_pairs(remesh: &mut Remesh, stats: &mut PurifyStats) {
    let he = edge_faces(&remesh.faces);
    let tri: Vec<bool> = remesh.faces.iter().map(|f| f.len() == 3).collect();
    // Triangle neighbours across interior edges: (neighbour, common edge a -> b in this face).
    let neighbours = |fi: usize| -> Vec<(usize, (u32, u32))> {
        let f = &remesh.faces[fi];
        let mut out: Vec<(usize, (u32, u32))> = (0..3)
            .filter_map(|k| {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                he.get(&(b, a))
                    .filter(|&&g| tri[g] && g != fi)
                    .map(|&g| (g, (a, b)))
            })
            .collect();
        out.sort_unstable();
        out.dedup_by_key(|x| x.0);
        out
    };
    let mut taken = vec![false; remesh.faces.len()];
    let free = |taken: &[bool], fi: usize| neighbours(fi).iter().filter(|x| !taken[x.0]).count();
    let mut joins: Vec<(usize, usize, (u32, u32))> = Vec::new();
    loop {
        let pick = (0..remesh.faces.len())
            .filter(|&fi| tri[fi] && !taken[fi])
            .map(|fi| (free(&taken, fi), fi))
            .filter(|&(c, _)| c > 0)
            .min();
        let Some((_, fi)) = pick else { break };
        let Some((g, e)) = neighbours(fi)
            .into_iter()
            .filter(|x| !taken[x.0])
            .min_by_key(|x| (free(&taken, x.0), x.0))
        else {
            break;
        };
        // The quad would repeat a vertex when the triangles share more than the edge.
        let (f, h) = (&remesh.faces[fi], &remesh.faces[g]);
        let third = |t: &[u32]| t.iter().copied().find(|&v| v != e.0 && v != e.1);
        if third(f) == third(h) {
            taken[fi] = true;
            continue;
        }
        taken[fi] = true;
        taken[g] = true;
        joins.push((fi, g, e));
    }
    let mut gone = vec![false; remesh.faces.len()];
    for &(fi, g, (a, b)) in &joins {
        // f = (a, b, c) rotated, h = (b, a, d): the quad (a, d, b, c).
        let f = &remesh.faces[fi];
        let k = (0..3).find(|&k| f[k] == a).unwrap_or(0);
        let c = f[(k + 2) % 3];
        let h = &remesh.faces[g];
        let Some(d) = h.iter().copied().find(|&v| v != a && v != b) else {
            continue;
        };
        remesh.faces[fi] = vec![a, d, b, c];
        gone[g] = true;
        stats.joined_triangles += 1;
    }
    drop_faces(remesh, &gone);
}

/// Step 2b: joins odd faces pairwise, or to the boundary, through the dual graph.
fn pair_odd_faces(remesh: &mut Remesh, stats: &mut PurifyStats) {
    // Faces no path can reach a partner from (only with inconsistent orientations, where the
    // handshake argument fails): left odd.
    let mut alone: HashSet<usize> = HashSet::new();
    // Kept up to date below: each path only splits edges.
    let mut he = edge_faces(&remesh.faces);
    loop {
        let Some(start) =
            (0..remesh.faces.len()).find(|&fi| is_odd(&remesh.faces[fi]) && !alone.contains(&fi))
        else {
            return;
        };
        // Breadth-first search over faces across interior edges, to the nearest other odd face
        // or to a face with a boundary edge. Ties go to the lowest face id (determinism).
        let mut prev: HashMap<usize, (usize, (u32, u32))> = HashMap::new();
        let mut queue = VecDeque::from([start]);
        let mut seen = HashSet::from([start]);
        let mut end: Option<(usize, Option<(u32, u32)>)> = None;
        'search: while let Some(fi) = queue.pop_front() {
            let f = &remesh.faces[fi];
            let n = f.len();
            if fi != start && is_odd(f) && !alone.contains(&fi) {
                end = Some((fi, None));
                break;
            }
            // A boundary edge ends the path there (the start face's own boundary edges too:
            // step 1 leaves a few when its passes run out).
            for k in 0..n {
                let (a, b) = (f[k], f[(k + 1) % n]);
                if !he.contains_key(&(b, a)) {
                    end = Some((fi, Some((a, b))));
                    break 'search;
                }
            }
            let mut next: Vec<(usize, (u32, u32))> = (0..n)
                .filter_map(|k| {
                    let (a, b) = (f[k], f[(k + 1) % n]);
                    he.get(&(b, a)).map(|&g| (g, (a, b)))
                })
                .collect();
            next.sort_unstable();
            for (g, e) in next {
                if seen.insert(g) {
                    prev.insert(g, (fi, e));
                    queue.push_back(g);
                }
            }
        }
        let Some((last, boundary_edge)) = end else {
            alone.insert(start);
            continue;
        };
        // Walk back from `last`, splitting each crossed edge at its midpoint.
        let mut fi = last;
        while let Some(&(pf, (a, b))) = prev.get(&fi) {
            // Edge a -> b is in face pf; b -> a in fi.
            let m = add_midpoint(remesh, a, b, false);
            insert_after(&mut remesh.faces[pf], a, b, m);
            insert_after(&mut remesh.faces[fi], b, a, m);
            he.remove(&(a, b));
            he.remove(&(b, a));
            he.extend([((a, m), pf), ((m, b), pf), ((b, m), fi), ((m, a), fi)]);
            stats.inserted_vertices += 1;
            fi = pf;
        }
        if let Some((a, b)) = boundary_edge {
            let m = add_midpoint(remesh, a, b, true);
            insert_after(&mut remesh.faces[last], a, b, m);
            he.remove(&(a, b));
            he.extend([((a, m), last), ((m, b), last)]);
            stats.inserted_vertices += 1;
        }
    }
}

fn mean_edge_length(remesh: &Remesh) -> f64 {
    let l = super::edge_lengths(remesh);
    if l.is_empty() {
        0.0
    } else {
        l.iter().sum::<f64>() / l.len() as f64
    }
}

/// Renames every face's vertices by `map` (`None`: the vertex is dropped), then drops repeated
/// consecutive vertices and the faces left with fewer than three.
pub(super) fn remap_faces(faces: &mut Vec<Vec<u32>>, map: impl Fn(u32) -> Option<u32>) {
    for f in faces.iter_mut() {
        let mut g: Vec<u32> = f.iter().filter_map(|&v| map(v)).collect();
        g.dedup();
        while g.len() > 1 && g.first() == g.last() {
            g.pop();
        }
        *f = g;
    }
    faces.retain(|g| g.len() >= 3);
}

/// Step 3: splits every face with more than `sides` sides (even ones for quads) into faces of
/// `sides` sides by chords; a chord that is already an edge elsewhere is never used. A chord
/// raises the valence of its two ends, so ends below their regular valence (4 / 6 inside, 3 / 4
/// on the boundary) are preferred and ends already at it are avoided: each such end makes an
/// irregular vertex.
fn split_faces(remesh: &mut Remesh, sides: usize, stats: &mut PurifyStats) {
    let (mut edges, mut valence, boundary) = super::quality::edge_incidence(remesh);
    let regular = |v: u32| match (sides, boundary[v as usize]) {
        (4, false) => 4,
        (4, true) => 3,
        (_, false) => 6,
        (_, true) => 4,
    };
    // In squared degrees, like the angle terms: one end at or above its regular valence weighs
    // as much as a corner 40° off.
    const VALENCE_WEIGHT: f64 = 1600.0;
    let ideal = if sides == 4 { 90f64 } else { 60f64 };
    let p = &remesh.positions;
    let angle = |a: u32, b: u32, c: u32| -> f64 {
        // The corner at b of the path a, b, c.
        (p[a as usize] - p[b as usize])
            .angle_between(p[c as usize] - p[b as usize])
            .to_degrees()
    };
    let mut out: Vec<Vec<u32>> = Vec::with_capacity(remesh.faces.len());
    for f in &remesh.faces {
        let mut poly = f.clone();
        while poly.len() > sides && (sides == 3 || poly.len() % 2 == 0) {
            let n = poly.len();
            let step = sides - 1;
            // Cut off the face poly[i ..= i + step] with the chord (poly[i], poly[i + step]).
            let mut best: Option<(f64, usize)> = None;
            for i in 0..n {
                let (a, z) = (poly[i], poly[(i + step) % n]);
                if edges.contains_key(&(a.min(z), a.max(z))) {
                    continue;
                }
                let piece: Vec<u32> = (0..=step).map(|k| poly[(i + k) % n]).collect();
                let mut score = 0.0;
                for k in 0..piece.len() {
                    let m = piece.len();
                    let ang = angle(piece[(k + m - 1) % m], piece[k], piece[(k + 1) % m]);
                    score += (ang - ideal).powi(2);
                }
                // The remainder's two new corners.
                let before = poly[(i + n - 1) % n];
                let after = poly[(i + step + 1) % n];
                score += (angle(before, a, z) - ideal).powi(2);
                score += (angle(a, z, after) - ideal).powi(2);
                for v in [a, z] {
                    score += if valence[v as usize] >= regular(v) {
                        VALENCE_WEIGHT
                    } else {
                        -0.5 * VALENCE_WEIGHT
                    };
                }
                if !score.is_finite() {
                    score = f64::MAX;
                }
                if best.is_none_or(|(s, _)| score < s) {
                    best = Some((score, i));
                }
            }
            let Some((_, i)) = best else {
                break; // every chord exists already: leave the polygon (counted as impure)
            };
            let (a, z) = (poly[i], poly[(i + step) % n]);
            edges.insert((a.min(z), a.max(z)), 2);
            valence[a as usize] += 1;
            valence[z as usize] += 1;
            out.push((0..=step).map(|k| poly[(i + k) % n]).collect());
            poly = (0..=(n - step)).map(|k| poly[(i + step + k) % n]).collect();
            stats.chords += 1;
        }
        out.push(poly);
    }
    remesh.faces = out;
}

/// Drops the faces marked in `gone` (one flag per face), keeping the others' order.
pub(super) fn drop_faces(remesh: &mut Remesh, gone: &[bool]) {
    let mut i = 0;
    remesh.faces.retain(|_| {
        i += 1;
        !gone[i - 1]
    });
}

/// Drops vertices no face or polyline uses any more (collapsed ones), renumbering the rest.
pub(super) fn compact(remesh: &mut Remesh) {
    let n = remesh.positions.len();
    let mut used = vec![false; n];
    for v in remesh
        .faces
        .iter()
        .flatten()
        .chain(remesh.polylines.iter().flatten())
    {
        used[*v as usize] = true;
    }
    if used.iter().all(|&u| u) {
        return;
    }
    let mut map = vec![u32::MAX; n];
    let (mut pos, mut org): (Vec<DVec3>, Vec<Origin>) = (Vec::new(), Vec::new());
    for v in 0..n {
        if used[v] {
            map[v] = pos.len() as u32;
            pos.push(remesh.positions[v]);
            org.push(remesh.origins[v]);
        }
    }
    for v in remesh.faces.iter_mut().flatten() {
        *v = map[*v as usize];
    }
    for v in remesh.polylines.iter_mut().flatten() {
        *v = map[*v as usize];
    }
    remesh.positions = pos;
    remesh.origins = org;
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    fn remesh(positions: Vec<DVec3>, faces: Vec<Vec<u32>>) -> Remesh {
        Remesh {
            origins: vec![Origin::Unknown; positions.len()],
            positions,
            faces,
            ..Default::default()
        }
    }

    fn directed_once(r: &Remesh) -> bool {
        let mut seen = HashSet::new();
        r.faces
            .iter()
            .all(|f| (0..f.len()).all(|k| seen.insert((f[k], f[(k + 1) % f.len()]))))
    }

    /// An n × n grid of unit quads (vertex (i, j) = i + (n + 1) j), counter-clockwise.
    fn grid(n: u32) -> (Vec<DVec3>, Vec<Vec<u32>>) {
        let id = |i: u32, j: u32| i + (n + 1) * j;
        let p = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| DVec3::new(i as f64, j as f64, 0.0)))
            .collect();
        let f = (0..n)
            .flat_map(|j| {
                (0..n).map(move |i| vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)])
            })
            .collect();
        (p, f)
    }

    /// Two odd faces inside a closed surface: a cube whose one edge is collapsed has two
    /// triangles; they are joined through the quads between them and everything ends as quads
    /// on the same sphere (Euler characteristic 2).
    #[test]
    fn odd_faces_of_a_closed_surface_are_paired() {
        let p = crate::mesh::generate::cube_corners();
        // Cube faces (outward, counter-clockwise), then vertex 7 merged into 6.
        let faces: Vec<Vec<u32>> = crate::mesh::generate::CUBE_QUADS
            .iter()
            .map(|f| {
                let mut g: Vec<u32> = f.iter().map(|&v| if v == 7 { 6 } else { v }).collect();
                g.dedup();
                if g.first() == g.last() {
                    g.pop();
                }
                g
            })
            .filter(|g| g.len() >= 3)
            .collect();
        let mut r = remesh(p, faces);
        assert_eq!(r.faces.iter().filter(|f| f.len() == 3).count(), 2);
        let chi = r.euler_characteristic();
        assert_eq!(chi, 2);
        let stats = purify(&mut r, 4);
        assert!(r.faces.iter().all(|f| f.len() == 4), "{:?}", r.faces);
        assert_eq!(r.euler_characteristic(), chi);
        assert!(directed_once(&r));
        assert_eq!(stats.impure_faces, 2);
        assert!(stats.inserted_vertices >= 1, "{stats:?}");
    }

    /// A hexagon (two merged cells) splits into two quads by one chord, a triangle and a
    /// pentagon on the boundary (a corner cut) become quads, and the grid's Euler
    /// characteristic (a disk: 1) stays.
    #[test]
    fn even_polygons_split_and_boundary_odd_faces_become_quads() {
        let (mut p, mut faces) = grid(4);
        // Merge cells (1, 1) and (2, 1) into a hexagon: drop their shared edge 7-12.
        let (a, b) = (faces[5].clone(), faces[6].clone());
        faces[5] = vec![a[0], a[1], b[1], b[2], a[2], a[3]];
        faces.remove(6);
        // Cut the corner (4, 0) of cell (3, 0) off with a boundary crossing on each side.
        let (x, y) = (p.len() as u32, p.len() as u32 + 1);
        p.push(DVec3::new(3.6, 0.0, 0.0));
        p.push(DVec3::new(4.0, 0.4, 0.0));
        faces[3] = vec![3, x, y, 9, 8]; // pentagon: cell (3, 0) without its corner
        faces.push(vec![x, 4, y]); // the corner triangle, outside the pentagon
        let mut r = remesh(p, faces);
        let chi = r.euler_characteristic();
        assert_eq!(chi, 1);
        let stats = purify(&mut r, 4);
        assert!(r.faces.iter().all(|f| f.len() == 4), "{:?}", r.faces);
        assert_eq!(r.euler_characteristic(), chi);
        assert!(directed_once(&r));
        assert!(stats.chords >= 1, "{stats:?}");
        assert_eq!(stats.impure_faces, 3);
    }

    /// Triangles (N = 6): every polygon is triangulated; a hexagon needs three chords.
    #[test]
    fn triangle_output_triangulates_every_polygon() {
        let r0 = 1.0f64;
        let mut p: Vec<DVec3> = (0..6)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / 6.0;
                DVec3::new(r0 * t.cos(), r0 * t.sin(), 0.0)
            })
            .collect();
        p.push(DVec3::ZERO);
        let mut r = remesh(p, vec![(0..6).collect()]);
        let stats = purify(&mut r, 3);
        assert_eq!(r.faces.len(), 4);
        assert!(r.faces.iter().all(|f| f.len() == 3));
        assert_eq!(stats.chords, 3);
        assert_eq!(r.euler_characteristic(), 1);
    }
}
