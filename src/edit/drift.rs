//! Drift: relax's global moves. The neighbour sweeps of `edit::relax` score a move on a patch
//! around the singularity with the outside held, so they see the curl a move makes nearby but
//! not the scale it changes far away. Where the field puts singularities for its own smoothness
//! and not for the map's, they stop at once: inside an aligned round rim the smoothest field is
//! the harmonic extension of the rim's e^{iNθ}, whose N zeros may crowd the centre (a flat disc
//! of 9165 vertices: four +1/4 at 0.28 of the radius, curl 1107, conformal distortion 1.54,
//! RSD edge of the remesh 32 %), while a map is least distorted with them near the rim (drifted
//! to 0.9: curl 107, 1.15, 10 %).
//!
//! A seamless map is a flat metric with cones at the singularities; its log-scale ρ
//! (parameter length per unit of surface length) has the cones' logarithmic poles, −(k/N) ln r,
//! plus a smooth part ρ̃, and the curl (what the local step removes) is least where ρ varies
//! least. ρ is read off the local step's curl*-free frames (`param::curl_free`: their length is
//! the density of the nearest map), relative to the density asked for; the slope of ρ̃ at a
//! cone is fitted over an annulus of `INNER_CELLS`..`OUTER_CELLS` grid cells with the cone's own
//! pole taken out. A positive cone, which shrinks the cells around it, moves down ρ̃, towards
//! larger cells. For negative cones the variance of ρ says up ρ̃, but on the meshes measured
//! down lowered the curl more (spot: 284 → 189 against 281; kitten 332 → 266 against 329; a
//! plate with three aligned holes 406 → 214 against no step kept); why is not settled (perhaps
//! the positive cones beside them that the field's pair cancellation left), so both ways are
//! tried at the first step and the better kept for the rest of the drift. All cones move at
//! once, the steepest by `step` cells and the others in proportion; a step is kept only when
//! the exact curl drops, otherwise it is halved, so drift never raises the curl (relax's
//! contract). The curl is not the map, though: cones keep clear of geometric curves and of
//! each other, and relax takes a drift back when the solved map is worse ([`maps_as_well`]).

use super::base::{Base, EditState};
use super::{Cancel, EditError};
use crate::field::cancel::PathSearch;
use glam::DVec3;

/// The annulus (in grid cells around a singularity) over which ρ's slope is fitted.
const INNER_CELLS: f64 = 1.0;
const OUTER_CELLS: f64 = 3.0;
/// The first step (grid cells, for the steepest cone), the largest, and the one below which
/// drift stops.
const FIRST_STEP: f64 = 2.0;
const MAX_STEP: f64 = 4.0;
const MIN_STEP: f64 = 0.5;
/// Exact evaluations (local-step factorizations) a drift may take: about this many faces'
/// worth, between 4 and 16 (each costs a factorization, and the slopes another after a kept
/// step).
const TRY_FACES: usize = 1_000_000;
/// A cone within this many grid cells of a geometric curve does not drift, and none drifts
/// that near: the curl knows nothing of the curves, and a singularity beside a curve leaves its
/// line too little room (fandisk with features at 40°: 2 folded faces after relax without this).
const CURVE_CLEARANCE_CELLS: f64 = 2.0;
/// No cone drifts nearer another singularity than this many grid cells (or than it already
/// is): igea at the default density has 188 singularities a few cells apart, and a drift
/// that let them crowd lowered the curl and folded the map (0 → 30 folded faces, 14 → 78
/// crowded singularities).
const SINGULAR_CLEARANCE_CELLS: f64 = 3.0;
/// A cone moves only when its move is at least this many grid cells (its neighbours' slopes
/// are flat against the steepest's).
const MIN_MOVE_CELLS: f64 = 0.5;

/// Drifts the singularities of `best` down the map's log-scale while the exact curl drops;
/// returns the number of kept steps. `pinned` vertices (on geometric curves) neither move nor
/// take a singularity.
pub(crate) fn drift(
    base: &Base,
    best: &mut EditState,
    best_curl: &mut f64,
    pinned: &[bool],
    search: &mut PathSearch,
    cancel: Cancel,
) -> Result<usize, EditError> {
    let h = base.grid_size();
    let clearance = clearance(base, pinned);
    let mut step = FIRST_STEP;
    let mut kept = 0;
    let mut tries = 0;
    let max_tries = (TRY_FACES / base.mesh().n_faces().max(1)).clamp(4, 16);
    let mut slopes = slopes(base, best, &base.curl_free(best)?.1);
    // How negative cones move: decided by the exact curl at the first step (see the module
    // documentation), then kept.
    let mut negatives: Option<f64> = None;
    while tries < max_tries && step >= MIN_STEP {
        if cancel() {
            return Err(EditError::Cancelled);
        }
        let steepest = slopes.iter().map(|s| s.2.length()).fold(0.0, f64::max);
        if steepest <= 0.0 {
            break;
        }
        type Trial = Option<(f64, Vec<[DVec3; 2]>, EditState)>;
        let mut trial = |sign: f64| -> Result<Trial, EditError> {
            let mut candidate = best.clone();
            let mut moved = 0;
            for &(p, k, slope) in &slopes {
                let cells = step * slope.length() / steepest;
                if pinned[p] || cells < MIN_MOVE_CELLS || !candidate.singularities.contains_key(&p)
                {
                    continue;
                }
                let way = if k > 0 { -1.0 } else { sign };
                let target = base.mesh().position(p) + slope.normalize() * (way * cells * h);
                let Some(q) = walk_towards(base, &candidate, &clearance, p, target) else {
                    continue;
                };
                if let Ok(mv) = base.plan(&candidate, search, p, q) {
                    candidate = base.commit(&candidate, &mv);
                    moved += 1;
                }
            }
            if moved == 0 {
                return Ok(None);
            }
            tries += 1;
            let (curl, free) = base.curl_free(&candidate)?;
            Ok(Some((curl, free, candidate)))
        };
        let has_negative = slopes.iter().any(|s| s.1 < 0 && !pinned[s.0]);
        let result = match negatives {
            Some(sign) => trial(sign)?,
            None if !has_negative => trial(1.0)?,
            None => {
                let up = trial(1.0)?;
                let down = trial(-1.0)?;
                let (up_curl, down_curl) = (
                    up.as_ref().map_or(f64::INFINITY, |c| c.0),
                    down.as_ref().map_or(f64::INFINITY, |c| c.0),
                );
                if up_curl.min(down_curl) < *best_curl {
                    negatives = Some(if up_curl <= down_curl { 1.0 } else { -1.0 });
                }
                if up_curl <= down_curl { up } else { down }
            }
        };
        match result {
            Some((curl, free, candidate)) if curl < *best_curl => {
                *best = candidate;
                *best_curl = curl;
                kept += 1;
                step = (step * 1.5).min(MAX_STEP);
                // (from the frames the kept step was measured with: no second factorization)
                slopes = self::slopes(base, best, &free);
            }
            _ => step *= 0.5,
        }
    }
    Ok(kept)
}

/// The curl is not the map: it knows nothing of the curves' lines (the bunny with its boundary
/// aligned: lower curl, but its 2Z² map folded and was solved on Z², 84 → 133 irregular remesh
/// vertices), nor of how close singularities may sit before the rounding crowds them (igea: 0
/// → 30 folded faces). A drift is kept only when the solved map folds no more, has no more
/// mis-wound vertices and keeps its lattice (two solves).
pub(crate) fn maps_as_well(
    base: &Base,
    before: &EditState,
    after: &EditState,
    cancel: Cancel,
) -> Result<bool, EditError> {
    let (b, a) = (base.solve(before, cancel)?, base.solve(after, cancel)?);
    Ok(a.param.flipped_faces <= b.param.flipped_faces
        && a.param.miswound.len() <= b.param.miswound.len()
        && a.param.lattice == b.param.lattice)
}

/// Per singularity (vertex, in increasing order) its index (in 1/N) and the slope ∇ρ̃ of the
/// smooth part of the log-scale there, in the tangent plane (per model unit); `free` are the
/// state's curl*-free frames ([`Base::curl_free`]).
fn slopes(base: &Base, state: &EditState, free: &[[DVec3; 2]]) -> Vec<(usize, i32, DVec3)> {
    let mesh = base.mesh();
    // ρ per face relative to the density asked for there (the frames carry m_f / h).
    let h = base.grid_size();
    let multipliers = &base.field().multipliers;
    let rho: Vec<f64> = free
        .iter()
        .enumerate()
        .map(|(f, x)| {
            let density = (0.5 * (x[0].length_squared() + x[1].length_squared())).sqrt();
            (density * h / multipliers[f]).max(1e-300).ln()
        })
        .collect();
    let symmetry = base.settings().symmetry as f64;
    let normals = mesh.vertex_normals();
    let (inner, outer) = (INNER_CELLS * h, OUTER_CELLS * h);
    let mut seen = vec![false; mesh.n_faces()];
    let mut out = Vec::new();
    for (&p, &k) in &state.singularities {
        let c = mesh.position(p);
        let n = normals[p];
        let t1 = n.any_orthonormal_vector();
        let t2 = n.cross(t1);
        // Faces within `outer` of p, by a walk over edge-adjacent faces from its star.
        let mut stack: Vec<usize> = mesh.outgoing(p).map(|h| mesh.face_of(h)).collect();
        let mut visited = Vec::new();
        for &f in &stack {
            seen[f] = true;
            visited.push(f);
        }
        // Weighted least squares ρ ≈ a + g·x over the annulus.
        let mut m = [[0.0f64; 3]; 3];
        let mut r = [0.0f64; 3];
        while let Some(f) = stack.pop() {
            let d = mesh.face_centroid(f) - c;
            let dist = d.length();
            if dist >= inner && dist <= outer && rho[f].is_finite() {
                // The cone's own pole, ρ = −(k/N) ln r, taken out: where the annulus is cut
                // by a boundary or a curve it would not cancel.
                let smooth = rho[f] + k as f64 / symmetry * dist.ln();
                let x = [1.0, d.dot(t1), d.dot(t2)];
                let w = mesh.face_area(f);
                for i in 0..3 {
                    for j in 0..3 {
                        m[i][j] += w * x[i] * x[j];
                    }
                    r[i] += w * x[i] * smooth;
                }
            }
            for e in 0..3 {
                let Some(t) = mesh.twin(3 * f + e) else {
                    continue;
                };
                let g = mesh.face_of(t);
                if !seen[g] && (mesh.face_centroid(g) - c).length() <= outer {
                    seen[g] = true;
                    visited.push(g);
                    stack.push(g);
                }
            }
        }
        for f in visited {
            seen[f] = false;
        }
        let Some([_, gx, gy]) = solve3(m, r) else {
            continue;
        };
        let slope = t1 * gx + t2 * gy;
        // (a degenerate normal or fit moves nothing)
        if slope.is_finite() {
            out.push((p, k, slope));
        }
    }
    out
}

/// Per vertex its distance along edges to the nearest pinned one (0 on them, infinite without
/// any).
fn clearance(base: &Base, pinned: &[bool]) -> Vec<f64> {
    use crate::mesh::heap::Nearest;
    let mesh = base.mesh();
    let mut dist = vec![f64::INFINITY; mesh.n_vertices()];
    let mut heap = std::collections::BinaryHeap::new();
    for (v, _) in pinned.iter().enumerate().filter(|x| *x.1) {
        dist[v] = 0.0;
        heap.push(Nearest(0.0, v as u32));
    }
    while let Some(Nearest(d, v)) = heap.pop() {
        let v = v as usize;
        if d > dist[v] {
            continue;
        }
        for h in mesh.outgoing(v) {
            let w = mesh.to(h);
            let dw = d + mesh.vector(h).length();
            if dw < dist[w] {
                dist[w] = dw;
                heap.push(Nearest(dw, w as u32));
            }
        }
    }
    dist
}

/// The vertex reached from p by steps to the neighbour nearest `target` while that gets nearer,
/// backed off to the last one that may take a singularity (interior, not singular); `None`
/// when that is p itself or p is within [`CURVE_CLEARANCE_CELLS`] of a geometric curve. The
/// walk stops before a boundary vertex, one that near a curve, and one nearer another
/// singularity than [`SINGULAR_CLEARANCE_CELLS`] (or than p is, if p is nearer already).
fn walk_towards(
    base: &Base,
    state: &EditState,
    clearance: &[f64],
    p: usize,
    target: DVec3,
) -> Option<usize> {
    let mesh = base.mesh();
    let keep = CURVE_CLEARANCE_CELLS * base.grid_size();
    if clearance[p] < keep {
        return None;
    }
    let nearest_other = |v: usize| {
        state
            .singularities
            .keys()
            .filter(|&&s| s != p)
            .map(|&s| (mesh.position(s) - mesh.position(v)).length())
            .fold(f64::INFINITY, f64::min)
    };
    let apart = nearest_other(p).min(SINGULAR_CLEARANCE_CELLS * base.grid_size());
    let (mut cur, mut last_free) = (p, None);
    loop {
        let d = (mesh.position(cur) - target).length();
        let next = mesh
            .outgoing(cur)
            .map(|h| mesh.to(h))
            .map(|v| ((mesh.position(v) - target).length(), v))
            .filter(|&(dv, _)| dv < d)
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let Some((_, v)) = next else {
            return last_free;
        };
        if mesh.is_boundary_vertex(v) || clearance[v] < keep || nearest_other(v) < apart {
            return last_free;
        }
        cur = v;
        if !state.singularities.contains_key(&v) {
            last_free = Some(v);
        }
    }
}

/// Solves the symmetric 3×3 system m x = r; `None` when it is (nearly) singular.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let m = glam::DMat3::from_cols_array_2d(&m);
    let scale = m.x_axis.x.abs() * m.y_axis.y.abs() * m.z_axis.z.abs();
    let det = m.determinant();
    if det.is_nan() || det.abs() <= 1e-12 * scale {
        return None;
    }
    Some((m.inverse() * glam::DVec3::from_array(r)).to_array())
}
