//! Thin parts: where the surface closes around itself within a few grid cells (a vessel, a
//! finger, a thin handle, a beam, a small hole), a seamless grid of cell size h goes around
//! with only as many cells as the rounding of its period leaves. Two cells around (the period
//! of a 2.4-cell tube rounded down) make two quads on the same four vertices, and the remesh
//! is not manifold; three or four make a remesh that is manifold but hardly a tube. The
//! density multiplier m (`density`) makes those parts finer, so that at least
//! [`MIN_CELLS_AROUND`] cells go around them.
//!
//! How a part is found thin: from one seed face per cube of side R = [`MIN_CELLS_AROUND`] h / π,
//! the faces within Euclidean distance r of the seed that are connected to it through such
//! faces are grown. The grown set is a disc unless the surface closes around within it: then
//! its boundary has two or more long loops (a tube's two rims; a hole's rim and the outer one).
//! A tube of radius ρ closes within a ball of radius 2ρ, so every tube of circumference
//! πR = [`MIN_CELLS_AROUND`] h or less closes at r = R, and the smallest radius r* at which it
//! closes (down a ladder of radii, then bisected) measures it: πr* around. (The rims' lengths
//! would overestimate it: at r = 2ρ a rim is a saddle-shaped loop 22 % longer than the tube is
//! around.) The faces within [`FULL`] R of the seed get m = [`MIN_CELLS_AROUND`] h / (πr*),
//! falling off linearly to 1 at [`FALLOFF`] R; where seeds overlap the larger m holds.

use std::collections::{BinaryHeap, HashMap};

use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::TriMesh;
use crate::mesh::heap::Nearest;

/// Cells a thin part should have around it.
pub const MIN_CELLS_AROUND: f64 = 5.0;
/// The largest refinement of a thin part (a needle-thin spike is not made 50 times finer).
pub const MAX_MULTIPLIER: f64 = 4.0;
/// Radii tried, as fractions of R (largest first).
const LADDER: [f64; 8] = [1.0, 0.8, 0.64, 0.51, 0.41, 0.33, 0.26, 0.21];
/// Boundary loops of a grown set shorter than this fraction of its radius are ignored: a
/// vertex just outside the radius with its neighbours inside (a bump) leaves a one-ring hole.
const LOOP_FRACTION: f64 = 0.5;
/// A thin seed's multiplier holds within this many times R of it (seeds are one per cube of
/// side R, so every point of a thin part is within √3 R of one)...
const FULL: f64 = 1.733;
/// ...and falls off to 1 at this many times R (a scale that changes within a cell or two folds
/// the map at coarse densities).
const FALLOFF: f64 = FULL + 1.0;
/// Bisection steps on the radius at which a set closes (to 1/32 of a ladder step).
const BISECTIONS: usize = 5;

/// What the thin-part search found.
#[derive(Clone, Debug, PartialEq)]
pub struct ThinParts {
    /// Per face the multiplier the thin parts need (1 elsewhere).
    pub multipliers: Vec<f64>,
    /// Faces with a multiplier above 1.
    pub faces: usize,
    /// The largest multiplier.
    pub max_multiplier: f64,
}

impl Default for ThinParts {
    /// Nothing thin (and no multipliers).
    fn default() -> ThinParts {
        ThinParts {
            multipliers: Vec::new(),
            faces: 0,
            max_multiplier: 1.0,
        }
    }
}

/// Per face the density multiplier that gives every thin part at least [`MIN_CELLS_AROUND`]
/// cells of size h / m around it (see the module's documentation).
pub fn thin_parts(mesh: &TriMesh, h: f64) -> ThinParts {
    let nf = mesh.n_faces();
    let mut multipliers = vec![1.0; nf];
    if !(h > 0.0 && h.is_finite()) || nf == 0 {
        return ThinParts {
            multipliers,
            faces: 0,
            max_multiplier: 1.0,
        };
    }
    let big_r = MIN_CELLS_AROUND * h / std::f64::consts::PI;
    let seeds = seeds(mesh, big_r);
    // Per-job scratch of one float per face: jobs of at least 64 seeds keep the allocations
    // few on large meshes.
    let found: Vec<(f64, Vec<(u32, f64)>)> = seeds
        .par_iter()
        .with_min_len(64)
        .map_init(
            || vec![f64::INFINITY; nf],
            |scratch, &s| closing(mesh, s, big_r, h, scratch),
        )
        .flatten()
        .collect();
    for (m, faces) in found {
        for (f, d) in faces {
            let t = ((FALLOFF * big_r - d) / ((FALLOFF - FULL) * big_r)).clamp(0.0, 1.0);
            let v = 1.0 + (m - 1.0) * t;
            let slot = &mut multipliers[f as usize];
            *slot = slot.max(v);
        }
    }
    let faces = multipliers.iter().filter(|&&m| m > 1.0).count();
    let max_multiplier = multipliers.iter().cloned().fold(1.0, f64::max);
    ThinParts {
        multipliers,
        faces,
        max_multiplier,
    }
}

/// The first face (in face order) of every occupied cell of a grid of spacing `s` over the
/// face centroids: seeds about `s` apart everywhere, deterministically.
fn seeds(mesh: &TriMesh, s: f64) -> Vec<usize> {
    let mut first: HashMap<[i64; 3], usize> = HashMap::new();
    for f in 0..mesh.n_faces() {
        let c = mesh.face_centroid(f) / s;
        if !c.is_finite() {
            continue;
        }
        first
            .entry([c.x.floor() as i64, c.y.floor() as i64, c.z.floor() as i64])
            .or_insert(f);
    }
    let mut seeds: Vec<usize> = first.into_values().collect();
    seeds.sort_unstable();
    seeds
}

/// Whether the surface closes around within R of `seed`'s centroid: the multiplier it needs
/// (above 1) and the faces within [`FALLOFF`] R with their reach (the smallest radius at which
/// each joins the seed's set). `reach` is per-face scratch, all infinite on entry and exit.
fn closing(
    mesh: &TriMesh,
    seed: usize,
    big_r: f64,
    h: f64,
    reach: &mut [f64],
) -> Option<(f64, Vec<(u32, f64)>)> {
    let c = mesh.face_centroid(seed);
    let far = |f: usize| {
        mesh.face(f)
            .iter()
            .map(|&v| mesh.position(v).distance(c))
            .fold(0.0, f64::max)
    };
    // Reach of a face: the smallest r at which a chain of faces within r joins it to the seed.
    // Grown in order of reach, first to R (most seeds end there), then on for the falloff.
    let mut heap = BinaryHeap::new();
    heap.push(Nearest(far(seed), seed as u32));
    let mut order: Vec<(u32, f64)> = Vec::new();
    let mut grow = |limit: f64, reach: &mut [f64], order: &mut Vec<(u32, f64)>| {
        while heap.peek().is_some_and(|top| top.0 <= limit) {
            let Some(Nearest(d, f)) = heap.pop() else {
                break;
            };
            if reach[f as usize].is_finite() {
                continue;
            }
            reach[f as usize] = d;
            order.push((f, d));
            for k in 0..3 {
                if let Some(t) = mesh.twin(3 * f as usize + k) {
                    let g = mesh.face_of(t);
                    if !reach[g].is_finite() {
                        heap.push(Nearest(far(g).max(d), g as u32));
                    }
                }
            }
        }
    };
    grow(big_r, reach, &mut order);
    let result = thin_at(mesh, &order, reach, big_r, h);
    if result.is_some() {
        grow(FALLOFF * big_r, reach, &mut order);
    }
    for &(f, _) in &order {
        reach[f as usize] = f64::INFINITY;
    }
    result.map(|m| (m, order))
}

/// The multiplier a seed's grown set asks for (`None`: not thin within R).
fn thin_at(mesh: &TriMesh, order: &[(u32, f64)], reach: &[f64], big_r: f64, h: f64) -> Option<f64> {
    // Smallest radius at which the set has two long boundary loops: not closed within R, not
    // thin; else down the ladder, then bisected between the last radius that closed and the
    // first that did not. (A finger's seed near the tip closes below R and not at R, where the
    // ball holds the tip: the seeds farther down the finger find it.)
    let closes = |r: f64| two_rims(mesh, order, reach, r);
    if !closes(big_r) {
        return None;
    }
    let mut closed = Some(big_r);
    let mut open = 0.0;
    for &q in &LADDER[1..] {
        let r = q * big_r;
        if closes(r) {
            closed = Some(r);
        } else {
            open = r;
            break;
        }
    }
    let mut hi = closed?;
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (open + hi);
        if closes(mid) {
            hi = mid;
        } else {
            open = mid;
        }
    }
    // A tube of radius ρ closes at r = 2ρ: around it is πr.
    let m = (MIN_CELLS_AROUND * h / (std::f64::consts::PI * hi)).min(MAX_MULTIPLIER);
    (m > 1.0).then_some(m)
}

/// Whether the grown set at radius r (the faces of `order` whose reach is at most r) has two
/// or more boundary loops at least [`LOOP_FRACTION`] r long.
fn two_rims(mesh: &TriMesh, order: &[(u32, f64)], reach: &[f64], r: f64) -> bool {
    let inside = |f: usize| reach[f] <= r;
    // Boundary halfedges of the set: next vertex along the rim (the set lies on their left).
    let mut next: HashMap<usize, Vec<usize>> = HashMap::new();
    for &(f, d) in order {
        if d > r {
            continue;
        }
        for k in 0..3 {
            let h = 3 * f as usize + k;
            if mesh.twin(h).is_none_or(|t| !inside(mesh.face_of(t))) {
                next.entry(mesh.from(h)).or_default().push(mesh.to(h));
            }
        }
    }
    // Loops as connected components of the rim's vertices (a pinch joins two: conservative).
    let mut label: HashMap<usize, usize> = HashMap::new();
    let mut lengths: Vec<f64> = Vec::new();
    let mut starts: Vec<usize> = next.keys().copied().collect();
    starts.sort_unstable();
    let p = |v: usize| -> DVec3 { mesh.position(v) };
    for s in starts {
        if label.contains_key(&s) {
            continue;
        }
        let id = lengths.len();
        let mut len = 0.0;
        let mut stack = vec![s];
        label.insert(s, id);
        while let Some(v) = stack.pop() {
            for &w in next.get(&v).into_iter().flatten() {
                len += p(v).distance(p(w));
                if let std::collections::hash_map::Entry::Vacant(e) = label.entry(w) {
                    e.insert(id);
                    stack.push(w);
                }
            }
        }
        lengths.push(len);
    }
    lengths.iter().filter(|&&l| l >= LOOP_FRACTION * r).count() >= 2
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tube of circumference 3 cells is refined to 5 cells around (within the falloff); a
    /// wide one and a flat sheet are not.
    #[test]
    fn thin_tubes_are_refined_and_wide_ones_are_not() {
        let r = 1.0;
        let tube = crate::mesh::generate::cylinder(r, 20.0, 48, 200);
        let around = 2.0 * std::f64::consts::PI * r;
        // 3 cells around: m ≈ 5/3 along the tube (its open ends included: a rim closes it too).
        let thin = thin_parts(&tube, around / 3.0);
        assert_eq!(thin.faces, tube.n_faces());
        let mid: Vec<f64> = (0..tube.n_faces())
            .filter(|&f| (tube.face_centroid(f).z - 10.0).abs() < 5.0)
            .map(|f| thin.multipliers[f])
            .collect();
        let lo = mid.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = mid.iter().cloned().fold(0.0, f64::max);
        // πr* against 2πρ: the bisection and the faces' extent leave a few per cent.
        assert!(lo > 1.55 && hi < 1.75, "{lo} .. {hi}");
        // 8 cells around: nothing to do.
        let wide = thin_parts(&tube, around / 8.0);
        assert_eq!(wide.faces, 0, "{:?}", wide.max_multiplier);
        let sheet = crate::mesh::generate::grid(60, 60, 10.0, 10.0);
        assert_eq!(thin_parts(&sheet, 1.0).faces, 0);
        assert_eq!(thin_parts(&sheet, 3.0).faces, 0);
    }
}
