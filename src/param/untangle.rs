//! Injectivity repair after the global step (beyond the thesis: its open problem, sec. 5.3).
//!
//! The global step's unknowns describe seamless maps only: ψ_c = c_c + R^{r_c} Q_v y_v for
//! corner c of vertex v ([`MapSpace`]), whatever the y_v. Branch points, the pinned vertex and
//! the gaps are constants, so every map of that form is seamless with the singularities and
//! gaps on the lattice. The repair moves only the y_v, so it keeps all of that exactly.
//!
//! Method: the untangling energy of Garanzha et al. 2021 ("Foldover-free maps in 50 lines of
//! code"), per face f_ε(J) = ((1 − θ) tr JᵀJ + θ (1 + det² J)) / χ(det J, ε) with
//! χ(D, ε) = (D + √(ε² + D²)) / 2. It is finite on folded maps, and ε decreases by their rule
//! until every det J > 0; from then on it is a barrier against inversion. J maps the face's
//! target triangle (a frame applied to its edges, in the disk frames) to its texture triangle,
//! so the energy measures the deviation from the map the global step was aiming at. The frame
//! is the local step's curl*-free one, except within [`GUIDE_RINGS`] rings of a branch point,
//! where it is the field's: the global step's energy is the same with either (they differ by a
//! part orthogonal to every gradient), but the curl*-free frames degenerate next to
//! singularities, where most folds are, and the barrier then aimed at slivers there (measured:
//! docs/untangling.md). Poles need the curl*-free ones. Branch points the global step wound
//! the wrong number of turns are rewound first ([`rewind`]). We minimise the energy by
//! Newton steps with per-face Hessians projected to positive semi-definite (4×4 eigenvalue
//! clamping), not by L-BFGS: regions are small and Newton needs few steps. The Hessian's
//! pattern and its symbolic analysis are computed once per region and reused by every step.
//!
//! Folds are local, so the repair is too: the unknowns are the vertices within a few rings of
//! the folded faces, everything else is held. A region whose folds remain is grown (rings 2,
//! 4, 8, 16, 32) and solved again, until two growths leave as many folds; regions of more than
//! [`MAX_REGION`] vertices are not tried (their Newton steps cost a factorization each). The
//! regions are independent and solved in parallel. A region's result is kept only if it has
//! fewer folded faces than before: the repair never adds a fold. Small regions whose folds
//! remain are solved again from three other starts, each against one kind of local minimum
//! (see [`fan_start`], [`ring_start`], [`cone_start`]). Afterwards the repaired places are
//! relaxed over [`RELAX_RINGS`] rings with the barrier energy (fold-free regions only, kept
//! when the energy decreased), which spreads the distortion the repair concentrated next to
//! the folds. On the map a solve keeps, [`relax_conformal`] relaxes the faces left most
//! distorted towards conformality.
//!
//! Folds no motion of the unknowns can undo ("stuck": two branch points rounded onto one
//! lattice point, across a face, an edge or a vertex between them) are reported apart; the
//! caller rounds the gaps they depend on again (`QuadCover::reround`), as it does for folds
//! the repair leaves for other reasons.
//!
//! Degenerate input triangles: a face whose target triangle has an angle below 1° (a needle,
//! or zero area) gets a reference blended towards an equilateral triangle of the same area
//! (at least a thousandth of the mean face area) until its smallest angle is 1°, and a weight
//! floored at a thousandth of the mean face area. Its barrier stays finite for any
//! non-degenerate image, and it cannot dominate the energy of its neighbours.

// `!(x > 0.0)` is meant: it holds for NaN, so an undefined area counts as folded.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::collections::HashMap;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::cut::NONE;
use super::rot::{M2, Rots, apply, transpose};
use crate::mesh::TriMesh;
use crate::sparse::{Analysis, SparseBuilder, SpdSolver};

mod rewind;

/// Rounds of the second rewinding at most (each must leave fewer wrongly wound vertices); one
/// from [`super::MISWOUND_TRIES_MAX_FACES`] faces on, where a round's failing regional solves
/// cost tenths of seconds: igea subdivided once (1.07 M faces) rewound 80 of its 93 wrongly
/// wound vertices in the first round, and the second turned 1 of the 14 left and was refused,
/// 0.42 of the repair's 5.2 s (the target there is 5 s).
const WIDE_ROUNDS: usize = 3;

/// Weight of the area term (Garanzha et al.'s θ).
const THETA: f64 = 1.0 / 128.0;
/// Rings of vertices around the folds freed in successive attempts.
const RINGS: [usize; 5] = [2, 4, 8, 16, 32];
/// The widest regions of the repair from a rewound start (before the repair): folds it leaves
/// there come from a rewinding too tight for its place, and the start from the global step's
/// map, rewound afterwards on the final map, is kept instead. On bunny ×16 (1.1 M faces) the
/// 16-ring region of the rewound start took 0.29 s per solve and left its 9 folds; capped at 8
/// rings the 57 plain and 28 constrained sweep solves, the 72 re-tessellated ones and the 72
/// cases of tests/untangle.rs end with the same folds, mis-wound vertices and patched places.
const REWOUND_WIDEST_RINGS: usize = 8;
/// Largest region (vertices) the repair solves.
const MAX_REGION: usize = 1500;
/// The same for regions with components held by constraint curves: their folds rarely yield
/// to larger regions (fandisk with features at 40°: 3.8 s for 12 folds left with the limit
/// above).
const MAX_HELD_REGION: usize = 400;
/// Largest region (vertices) that is solved a second time from the fan layout ([`fan_start`]):
/// the winding it corrects is a matter of the few rings next to a branch point.
const FAN_RESTART_MAX: usize = 300;
/// A partial repair may raise the region's mean conformal distortion by this factor at most.
const PARTIAL_DISTORTION: f64 = 1.1;
/// Smallest angle of a reference triangle.
const MIN_ANGLE_DEG: f64 = 1.0;
/// Outer (ε) iterations and Newton steps per ε.
const OUTER: usize = 200;
const NEWTON_PER_EPS: usize = 3;
/// Outer iterations without a larger smallest determinant after which a region gives up.
const STAGNATION: usize = 30;
/// Outer iterations without fewer folded faces after which a region gives up.
const FOLD_STAGNATION: usize = 40;
/// The same for regions holding components of constraint curves: their folds that do not go
/// early are mostly the rounding's (the re-rounding under curves takes them), and the grown
/// regions of a few hundred vertices ran the whole 40 for nothing. Measured 2026-12-03 (repair
/// ms, 40 → 10; folds after the repair unchanged): fandisk `--features` 30° 1567 → 832, 35°
/// 1794 → 699, 40° 1656 → 585, 50° 5536 → 2098, 60° 728 → 272; bunny aligned 607 → 500;
/// camelhead (N = 4, 6) and cerebral vessels aligned within noise. At 5, fandisk at 35° kept
/// 3 folds; fandisk N = 6 at 40° keeps 23 folds instead of 21 from 20 down.
const FOLD_STAGNATION_HELD: usize = 10;
/// ε once every face is positive: f_ε is then the barrier energy up to rounding.
const EPS_BARRIER: f64 = 1e-10;
/// Rings around the repaired folds over which the result is relaxed afterwards.
const RELAX_RINGS: usize = 8;
/// Rings around the seeds of [`relax_conformal`], one entry per pass: the [`WIDTHS`] widths in
/// turn. Seeds in clusters grow into regions past [`MAX_REGION`] at 4 rings, which are not
/// solved, while isolated seeds need the room. Fertility, N = 6, 1500 vertices, on its crowded
/// try: p99 3.45 with 4 rings in every pass, 2.78 with 2 after a first 4, 2.71 alternating 2
/// and 4. igea at 1500 vertices (N = 4, 2Z²; a cell spans about 180 triangles, 7 000 seeds):
/// 2.99 with 2 and 4, 3.17 with 4 and 8, 2.76 with 1 and 2, 2.70 with 2, 4 and 1 (its global
/// step's map 2.65). Over the 72 cases of `tests/untangle.rs` and igea's 8 (2026-12-06), worst
/// p99 against the global step's map: 2, 4 in turn +3.7 % but igea at 1500 +12.6 % and +5.5 %;
/// 1, 2, 4 +3.8 %; this +4.0 % (igea, N = 6 at 1500), with one pass fewer on the bunny.
/// Before the reach and per-face weights, with 2 rings in up to 4 passes, 4 of the 72 were
/// 5–13 % above (with 1, 4 or 8 rings in the first pass more).
const CONFORMAL_RINGS: [usize; 9] = [2, 4, 1, 2, 4, 1, 2, 4, 1];
/// The distinct widths of [`CONFORMAL_RINGS`]: that many passes not kept in a row end it.
const WIDTHS: usize = 3;
/// Rings around the faces the repair changed within which [`relax_conformal`] takes faces
/// above the level as seeds, changed or not: where the repair had to leave a singularity's fan
/// more distorted (a branch point parted from another by re-rounding), the faces of the
/// neighbouring fans that the global step left above the level make room for it. Over the 72
/// cases (first pass 4 rings, then 2): the changed faces only, 4 p99 misses (+5–13 %); 4 or 8
/// rings, 1 (max-planck, N = 6, 1500 vertices, +12 %); 16, none; the whole mesh, none either,
/// but the repair then moves a fifth of the bunny's corners at 1500 vertices (N = 4; a tenth
/// with 16 rings, test `the_repair_unfolds_what_no_untangle_keeps`).
const CONFORMAL_REACH: usize = 16;

/// The seamless maps of the global step: ψ_c = consts_c + R^{rot_c} Q_v y_v for corner c of
/// v = var_c (ψ_c = consts_c where var_c is NONE); components i of y_v with `free[v][i]` false
/// are held at their value.
pub(crate) struct MapSpace {
    pub consts: Vec<[f64; 2]>,
    pub var: Vec<u32>,
    pub rot: Vec<u8>,
    pub basis: Vec<M2>,
    pub free: Vec<[bool; 2]>,
}

/// What the repair did.
#[derive(Clone, Debug, Default)]
pub(crate) struct Repair {
    pub before: usize,
    /// Folded faces no motion of the unknowns can unfold: their held corners (branch points,
    /// pinned vertices) coincide or are themselves folded. Only other gaps can help them.
    pub stuck: Vec<usize>,
    /// Branch points the global step wound wrongly, rewound before the repair.
    pub rewound: usize,
    pub ms: f64,
}

/// (stuck, folded) faces of `uv`: see [`stuck`].
pub(crate) fn count_stuck(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    uv: &[[f64; 2]],
) -> (usize, usize) {
    let f = folded(uv);
    (
        f.iter()
            .filter(|&&x| stuck(mesh, rots, space, uv, x))
            .count(),
        f.len(),
    )
}

/// Whether folded face f stays folded whatever the unknowns: all its corners held; or all but
/// one, free in both directions, while the two held corners coincide; or one held corner and,
/// across the opposite edge, another held corner on the same point; or a free interior corner
/// with two held neighbours on one point ([`pinched`]).
pub(crate) fn stuck(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    uv: &[[f64; 2]],
    f: usize,
) -> bool {
    if (0..3).any(|a| pinched(mesh, rots, space, uv, 3 * f + a)) {
        return true;
    }
    let movable: Vec<bool> = (0..3)
        .map(|a| {
            let c = 3 * f + a;
            let v = mesh.from(c);
            space.var[c] != NONE && (space.free[v][0] || space.free[v][1])
        })
        .collect();
    let held: Vec<usize> = (0..3).filter(|&a| !movable[a]).collect();
    match held.len() {
        3 => true,
        2 => {
            let a = (0..3).find(|&a| movable[a]).unwrap_or(0);
            let v = mesh.from(3 * f + a);
            let [p, q] = [uv[3 * f + held[0]], uv[3 * f + held[1]]];
            let scale = 1.0 + p[0].abs().max(p[1].abs());
            space.free[v][0] && space.free[v][1] && (p[0] - q[0]).hypot(p[1] - q[1]) <= 1e-9 * scale
        }
        1 => {
            // The two faces lie on one side of their edge: one of them is folded.
            let a = held[0];
            let Some(t) = mesh.twin(3 * f + (a + 1) % 3) else {
                return false;
            };
            let o = mesh.prev(t);
            let w = mesh.from(o);
            if space.var[o] != NONE && (space.free[w][0] || space.free[w][1]) {
                return false;
            }
            // g's corners in f's chart: the rigid motion taking edge (w1, w2) of g onto f's.
            let (p1, p2) = (uv[3 * f + (a + 1) % 3], uv[3 * f + (a + 2) % 3]);
            let (q1, q2) = (uv[mesh.next(t)], uv[t]);
            let (dp, dq) = (
                [p2[0] - p1[0], p2[1] - p1[1]],
                [q2[0] - q1[0], q2[1] - q1[1]],
            );
            let lq = dq[0].hypot(dq[1]);
            if !(lq > 0.0) {
                return false;
            }
            let ang = dp[1].atan2(dp[0]) - dq[1].atan2(dq[0]);
            let (c, sn) = (ang.cos(), ang.sin());
            let x = [uv[o][0] - q1[0], uv[o][1] - q1[1]];
            let s_g = [p1[0] + c * x[0] - sn * x[1], p1[1] + sn * x[0] + c * x[1]];
            let s_f = uv[3 * f + a];
            let scale = 1.0 + s_f[0].abs().max(s_f[1].abs());
            (s_g[0] - s_f[0]).hypot(s_g[1] - s_f[1]) <= 1e-9 * scale
        }
        _ => false,
    }
}

/// Whether corner c's vertex x is free, interior, and has two held neighbours that sit on one
/// point of x's own chart (read as x's unknowns: the value of y_x that would put x onto
/// each). Its fan then cannot be positive: the directions to the two coincide, so the two
/// arcs of the fan between them turn by multiples of 2π that add up to 2π, and one of them
/// turns by 0. Two branch points rounded onto one lattice point with a vertex between them
/// (camelhead and fandisk at N = 4 on 2Z²) are this case.
fn pinched(mesh: &TriMesh, rots: &Rots, space: &MapSpace, uv: &[[f64; 2]], c: usize) -> bool {
    let x = mesh.from(c);
    if space.var[c] == NONE || space.free[x] != [true, true] || mesh.is_boundary_vertex(x) {
        return false;
    }
    let mut held: Vec<(usize, [f64; 2])> = Vec::new();
    for h in mesh.outgoing(x) {
        let w = mesh.next(h);
        let v = mesh.from(w);
        if space.var[w] != NONE && space.free[v] != [false, false] {
            continue;
        }
        let z = corner_unknowns(rots, space, h, uv[w]);
        let scale = 1.0 + z[0].abs().max(z[1].abs());
        if held
            .iter()
            .any(|(u, q)| *u != v && (q[0] - z[0]).hypot(q[1] - z[1]) <= 1e-9 * scale)
        {
            return true;
        }
        held.push((v, z));
    }
    false
}

/// The angle by which the fan of vertex v turns in `uv`: the sum of its corners' signed angles.
pub(crate) fn fan_turn(mesh: &TriMesh, uv: &[[f64; 2]], v: usize) -> f64 {
    fan_turn_with(mesh, v, |c| uv[c])
}

/// Whether a fan turning by `turn` is wound by the cone angle `cone` (within π; false for NaN).
pub(crate) fn wound_by(turn: f64, cone: f64) -> bool {
    (turn - cone).abs() <= std::f64::consts::PI
}

/// The vertices within `rings` rings of `seeds` (the seeds included), sorted.
pub(crate) fn vertices_within(mesh: &TriMesh, seeds: &[usize], rings: usize) -> Vec<usize> {
    let mut seen: std::collections::HashSet<usize> = seeds.iter().copied().collect();
    let mut front = seeds.to_vec();
    for _ in 0..rings {
        let mut next = Vec::new();
        for &v in &front {
            for h in mesh.outgoing(v) {
                let w = mesh.to(h);
                if seen.insert(w) {
                    next.push(w);
                }
            }
        }
        front = next;
    }
    let mut out: Vec<usize> = seen.into_iter().collect();
    out.sort_unstable();
    out
}

/// [`fan_turn`] with the texture coordinates of corner c given by `at(c)`.
pub(crate) fn fan_turn_with(mesh: &TriMesh, v: usize, at: impl Fn(usize) -> [f64; 2]) -> f64 {
    mesh.outgoing(v)
        .map(|h| {
            let (a, b, c) = (at(h), at(mesh.next(h)), at(mesh.prev(h)));
            let (p, q) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
            (p[0] * q[1] - p[1] * q[0]).atan2(p[0] * q[0] + p[1] * q[1])
        })
        .sum()
}

/// The unknowns of the vertices `free` (per vertex and component, NONE where the component is
/// held) and their number.
fn number_unknowns(space: &MapSpace, free: &[usize]) -> (Vec<[u32; 2]>, usize) {
    let mut unknown = vec![[NONE; 2]; free.len()];
    let mut n = 0usize;
    for (i, &v) in free.iter().enumerate() {
        for k in 0..2 {
            if space.free[v][k] {
                unknown[i][k] = n as u32;
                n += 1;
            }
        }
    }
    (unknown, n)
}

/// The faces around the vertices `free`, sorted.
pub(crate) fn faces_around(mesh: &TriMesh, free: &[usize]) -> Vec<usize> {
    let mut faces: Vec<usize> = free
        .iter()
        .flat_map(|&v| mesh.outgoing(v).map(|h| mesh.face_of(h)))
        .collect();
    faces.sort_unstable();
    faces.dedup();
    faces
}

/// ∂J/∂y of face f (corners 3f..3f + 2) per unknown: ψ is affine in y, so these are constant.
/// `slot[a]` is the local slot of corner a's vertex in `free`, NONE when it is held.
fn jacobian_terms(
    rots: &Rots,
    space: &MapSpace,
    free: &[usize],
    unknown: &[[u32; 2]],
    corners: [usize; 3],
    slot: [u32; 3],
    reference: &Reference,
) -> Vec<(usize, [f64; 4])> {
    let mut dj = Vec::with_capacity(6);
    for a in 0..3 {
        let s = slot[a];
        if s == NONE {
            continue;
        }
        let (c, v) = (corners[a], free[s as usize]);
        for k in 0..2 {
            let u = unknown[s as usize][k];
            if u == NONE {
                continue;
            }
            let q = space.basis[v];
            let d = apply(rots.get(space.rot[c] as i64), [q[k], q[2 + k]]);
            let gr = reference.grad[a];
            dj.push((
                u as usize,
                [d[0] * gr[0], d[0] * gr[1], d[1] * gr[0], d[1] * gr[1]],
            ));
        }
    }
    dj
}

/// Interior vertices whose fan does not turn by its cone angle `cones[v]` (2π(1 − index); NaN
/// where nothing is checked) within π: the map is not locally injective there although no
/// face need be folded. The case seen: a −1/4 branch point whose fan turns by 90° instead of
/// 450°, beside a regular vertex whose fan turns twice (720°); every face is positive, and
/// the remesh gets a grid point with one edge and a patched place there. The repair does not
/// treat them yet (docs/untangling.md).
pub(crate) fn miswound(mesh: &TriMesh, uv: &[[f64; 2]], cones: &[f64]) -> Vec<usize> {
    (0..mesh.n_vertices())
        .into_par_iter()
        .filter(|&v| {
            let cone = cones[v];
            !mesh.is_boundary_vertex(v) && !cone.is_nan() && !wound_by(fan_turn(mesh, uv, v), cone)
        })
        .collect()
}

/// [`miswound`] of `uv` given those of `before` (`was`): only vertices of faces whose
/// corners changed are walked again.
fn miswound_after(
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    cones: &[f64],
    was: &[usize],
    before: &[[f64; 2]],
) -> Vec<usize> {
    let changed: Vec<usize> = (0..mesh.n_faces())
        .into_par_iter()
        .filter(|&f| (3 * f..3 * f + 3).any(|c| uv[c] != before[c]))
        .collect();
    let mut near: Vec<usize> = changed.iter().flat_map(|&f| mesh.face(f)).collect();
    near.sort_unstable();
    near.dedup();
    let mut out: Vec<usize> = was
        .iter()
        .copied()
        .filter(|v| near.binary_search(v).is_err())
        .chain(near.iter().copied().filter(|&v| {
            let cone = cones[v];
            !mesh.is_boundary_vertex(v) && !cone.is_nan() && !wound_by(fan_turn(mesh, uv, v), cone)
        }))
        .collect();
    out.sort_unstable();
    out
}

/// Signed area of the texture triangle of face f (corners 3f, 3f + 1, 3f + 2).
pub(crate) fn uv_area(uv: &[[f64; 2]], f: usize) -> f64 {
    let [a, b, c] = [uv[3 * f], uv[3 * f + 1], uv[3 * f + 2]];
    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
}

/// Faces whose texture triangle has non-positive (or undefined) signed area, or an area the
/// coordinates' rounding could give either sign: its height under 1e-9 of its corners'
/// magnitude, the tolerance [`stuck`] reads two held corners on one point by. Two branch
/// points rounded onto one lattice point (max-planck, N = 6, 1500 vertices) collapse the edge
/// between them; its two faces came out with an area of +4e-15, counted as unfolded, and the
/// remesh patched the hole they left.
pub(crate) fn folded(uv: &[[f64; 2]]) -> Vec<usize> {
    (0..uv.len() / 3)
        .into_par_iter()
        .filter(|&f| !positive(uv, f))
        .collect()
}

/// Whether face f's texture triangle is positive and not degenerate (see [`folded`]).
pub(crate) fn positive(uv: &[[f64; 2]], f: usize) -> bool {
    let area = uv_area(uv, f);
    // The threshold is never negative, and its edges are at most 1.5 times their longer
    // coordinate difference: most faces are decided without the three square roots (the
    // repair counts the folds of 1.1 M faces a dozen times).
    if !(area > 0.0) {
        return false;
    }
    if area > degenerate_bound(uv, f) {
        return true;
    }
    area > degenerate_area(uv, f)
}

/// An upper bound of [`degenerate_area`] without square roots.
fn degenerate_bound(uv: &[[f64; 2]], f: usize) -> f64 {
    1.5 * degenerate_by(uv, f, |d| d[0].abs().max(d[1].abs()))
}

/// The area below which face f's texture triangle is degenerate: half its longest edge times
/// 1e-9 of its corners' largest coordinate (plus one).
fn degenerate_area(uv: &[[f64; 2]], f: usize) -> f64 {
    degenerate_by(uv, f, |d| d[0].hypot(d[1]))
}

/// Half the longest edge of face f's texture triangle, each measured by `length`, times 1e-9
/// of its corners' largest coordinate (plus one).
fn degenerate_by(uv: &[[f64; 2]], f: usize, length: impl Fn([f64; 2]) -> f64) -> f64 {
    let c = [uv[3 * f], uv[3 * f + 1], uv[3 * f + 2]];
    let scale = 1.0
        + c.iter()
            .map(|p| p[0].abs().max(p[1].abs()))
            .fold(0.0, f64::max);
    let longest = (0..3)
        .map(|k| {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            length([b[0] - a[0], b[1] - a[1]])
        })
        .fold(0.0, f64::max);
    0.5 * 1e-9 * scale * longest
}

/// Per face: gradients of the barycentric coordinates on the reference triangle, and weight.
#[derive(Clone, Copy, Debug)]
struct Reference {
    grad: [[f64; 2]; 3],
    weight: f64,
}

/// The target triangle of face f under the frame `disk[f]` (rows ∇u, ∇v).
fn target(mesh: &TriMesh, disk: &[[DVec3; 2]], f: usize) -> [[f64; 2]; 3] {
    let p = mesh.face(f).map(|v| mesh.position(v));
    let x = disk[f];
    std::array::from_fn(|a| {
        let d = p[a] - p[0];
        [x[0].dot(d), x[1].dot(d)]
    })
}

/// The similarity part of each face's frame (rows ∇u, ∇v): J = [[a, b], [c, d]] in the face's
/// tangent basis becomes [[e, −h], [h, e]] with e = (a + d)/2, h = (c − b)/2, the nearest
/// conformal map. Against it the barrier energy measures conformal distortion (up to its weak
/// area term), the quality the report gives; the frame's own anisotropy (curl*-free frames next
/// to singularities) is left out.
fn conformal_frames(mesh: &TriMesh, disk: &[[DVec3; 2]]) -> Vec<[DVec3; 2]> {
    (0..mesh.n_faces())
        .into_par_iter()
        .map(|f| {
            let (e1, e2) = mesh.face_basis(f);
            let [gu, gv] = disk[f];
            let (a, b, c, d) = (gu.dot(e1), gu.dot(e2), gv.dot(e1), gv.dot(e2));
            let (e, h) = ((a + d) / 2.0, (c - b) / 2.0);
            if !(e.hypot(h) > 0.0) {
                return disk[f];
            }
            [e1 * e - e2 * h, e1 * h + e2 * e]
        })
        .collect()
}

/// The reference of face f: its target triangle, regularised when degenerate (module docs).
fn reference(mesh: &TriMesh, disk: &[[DVec3; 2]], f: usize, mean_area: f64) -> Reference {
    let mut t = target(mesh, disk, f);
    let area = tri_area(&t);
    let weight = if area.is_finite() {
        area.max(1e-3 * mean_area)
    } else {
        1e-3 * mean_area
    };
    if !(min_angle(&t) >= MIN_ANGLE_DEG.to_radians()) || !(area > 0.0) {
        // Equilateral triangle of the same area on t0 → t1's direction, blended in until the
        // smallest angle is 1° (bisection on the blend).
        let side = (4.0 * weight / 3f64.sqrt()).sqrt();
        let d = [t[1][0] - t[0][0], t[1][1] - t[0][1]];
        let len = d[0].hypot(d[1]);
        let e = if len > 0.0 && len.is_finite() {
            [d[0] / len, d[1] / len]
        } else {
            [1.0, 0.0]
        };
        let n = [-e[1], e[0]];
        let h = side * 3f64.sqrt() / 2.0;
        let eq = [
            t[0],
            [t[0][0] + side * e[0], t[0][1] + side * e[1]],
            [
                t[0][0] + 0.5 * side * e[0] + h * n[0],
                t[0][1] + 0.5 * side * e[1] + h * n[1],
            ],
        ];
        let blend = |s: f64| -> [[f64; 2]; 3] {
            std::array::from_fn(|a| {
                let q = |i: usize| {
                    let v = (1.0 - s) * t[a][i] + s * eq[a][i];
                    if v.is_finite() { v } else { eq[a][i] }
                };
                [q(0), q(1)]
            })
        };
        let ok =
            |tt: &[[f64; 2]; 3]| tri_area(tt) > 0.0 && min_angle(tt) >= MIN_ANGLE_DEG.to_radians();
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if ok(&blend(mid)) { hi = mid } else { lo = mid }
        }
        t = blend(hi);
    }
    // ∇λ_a = (edge opposite a, turned by −90°) / (2A).
    let a2 = 2.0 * tri_area(&t);
    let grad = std::array::from_fn(|a| {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let e = [t[c][0] - t[b][0], t[c][1] - t[b][1]];
        [-e[1] / a2, e[0] / a2]
    });
    Reference { grad, weight }
}

fn tri_area(t: &[[f64; 2]; 3]) -> f64 {
    0.5 * ((t[1][0] - t[0][0]) * (t[2][1] - t[0][1]) - (t[1][1] - t[0][1]) * (t[2][0] - t[0][0]))
}

fn min_angle(t: &[[f64; 2]; 3]) -> f64 {
    (0..3)
        .map(|a| {
            let (b, c) = (t[(a + 1) % 3], t[(a + 2) % 3]);
            let u = [b[0] - t[a][0], b[1] - t[a][1]];
            let v = [c[0] - t[a][0], c[1] - t[a][1]];
            (u[0] * v[1] - u[1] * v[0])
                .abs()
                .atan2(u[0] * v[0] + u[1] * v[1])
        })
        .fold(f64::INFINITY, f64::min)
}

/// J (row-major [J00, J01, J10, J11]) of the map reference → texture with corner values `q`.
fn jacobian(q: &[[f64; 2]; 3], r: &Reference) -> [f64; 4] {
    let mut j = [0.0; 4];
    for a in 0..3 {
        for i in 0..2 {
            for k in 0..2 {
                j[2 * i + k] += q[a][i] * r.grad[a][k];
            }
        }
    }
    j
}

fn det(j: &[f64; 4]) -> f64 {
    j[0] * j[3] - j[1] * j[2]
}

fn chi(d: f64, eps: f64) -> f64 {
    // (D + √(ε² + D²)) / 2, written to stay accurate for D ≪ 0.
    let r = eps.hypot(d);
    if d >= 0.0 {
        0.5 * (d + r)
    } else {
        0.5 * eps * eps / (r - d)
    }
}

fn energy(j: &[f64; 4], eps: f64) -> f64 {
    let d = det(j);
    let s = j.iter().map(|x| x * x).sum::<f64>();
    ((1.0 - THETA) * s + THETA * (1.0 + d * d)) / chi(d, eps)
}

/// f_ε, its gradient and its Hessian projected to positive semi-definite, all in J.
fn energy_derivatives(j: &[f64; 4], eps: f64) -> (f64, [f64; 4], [[f64; 4]; 4]) {
    let (f, grad, h) = energy_derivatives_unprojected(j, eps);
    (f, grad, project_psd_isotropic(j, &h))
}

/// f_ε, its gradient and its Hessian, all in J.
fn energy_derivatives_unprojected(j: &[f64; 4], eps: f64) -> (f64, [f64; 4], [[f64; 4]; 4]) {
    let d = det(j);
    let s = j.iter().map(|x| x * x).sum::<f64>();
    let r = eps.hypot(d);
    let c = chi(d, eps);
    let c1 = c / r; // χ'
    let c2 = eps * eps / (2.0 * r * r * r); // χ''
    let gd = [j[3], -j[2], -j[1], j[0]]; // ∇ det
    let mut hd = [[0.0; 4]; 4]; // ∇² det
    hd[0][3] = 1.0;
    hd[3][0] = 1.0;
    hd[1][2] = -1.0;
    hd[2][1] = -1.0;
    let n = (1.0 - THETA) * s + THETA * (1.0 + d * d);
    let gn: [f64; 4] =
        std::array::from_fn(|i| 2.0 * (1.0 - THETA) * j[i] + 2.0 * THETA * d * gd[i]);
    let f = n / c;
    let grad: [f64; 4] = std::array::from_fn(|i| gn[i] / c - n * c1 / (c * c) * gd[i]);
    let k_dd = n * (2.0 * c1 * c1 / (c * c * c) - c2 / (c * c));
    let mut h = [[0.0; 4]; 4];
    for a in 0..4 {
        for b in 0..4 {
            let hn = 2.0 * (1.0 - THETA) * if a == b { 1.0 } else { 0.0 }
                + THETA * (2.0 * gd[a] * gd[b] + 2.0 * d * hd[a][b]);
            h[a][b] = hn / c - c1 / (c * c) * (gn[a] * gd[b] + gd[a] * gn[b])
                + k_dd * gd[a] * gd[b]
                - n * c1 / (c * c) * hd[a][b];
        }
    }
    (f, grad, h)
}

/// The nearest positive semi-definite matrix to the Hessian `h` of an energy of |J|² and
/// det J alone (negative eigenvalues clamped to 0), in closed form (the analytic eigensystem
/// of Smith, De Goes and Kim 2019 for isotropic energies, here in 2D).
///
/// Why it is closed form: split 2×2 matrices into the conformal plane {[a b; −b a]} and the
/// anti-conformal one {[c d; d −c]}. J and ∇det J = cof J lie in the span of J's conformal
/// part e_c and anti-conformal part e_a, and ∇²det is +1 on the conformal plane and −1 on the
/// other (2 det X = |conformal part|² − |anti-conformal part|² in these units). So the Hessian
/// (a combination of I, J Jᵀ, J cof Jᵀ + cof J Jᵀ, cof J cof Jᵀ and ∇²det) has the two
/// directions perpendicular to e_c and e_a in their planes (twist e_t, flip e_l) as
/// eigenvectors and a 2×2 block on (e_c, e_a). It replaced cyclic Jacobi rotations
/// (`project_psd`, kept as the tests' reference), which took a third of the bunny's repair.
fn project_psd_isotropic(j: &[f64; 4], h: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    use std::f64::consts::FRAC_1_SQRT_2;
    let (a, b) = (0.5 * (j[0] + j[3]), 0.5 * (j[1] - j[2]));
    let (c, d) = (0.5 * (j[0] - j[3]), 0.5 * (j[1] + j[2]));
    // Unit directions; any pair of the plane where J has no part in it (the Hessian is then
    // isotropic there).
    let unit = |x: f64, y: f64| {
        let r = x.hypot(y);
        if r > 0.0 { (x / r, y / r) } else { (1.0, 0.0) }
    };
    let (a, b) = unit(a, b);
    let (c, d) = unit(c, d);
    let k = FRAC_1_SQRT_2;
    let e = [
        [k * a, k * b, -k * b, k * a],   // e_c
        [k * c, k * d, k * d, -k * c],   // e_a
        [-k * b, k * a, -k * a, -k * b], // e_t
        [-k * d, k * c, k * c, k * d],   // e_l
    ];
    let quad = |u: &[f64; 4], v: &[f64; 4]| -> f64 {
        (0..4)
            .map(|r| u[r] * (0..4).map(|s| h[r][s] * v[s]).sum::<f64>())
            .sum()
    };
    let (p, q, r) = (quad(&e[0], &e[0]), quad(&e[1], &e[1]), quad(&e[0], &e[1]));
    let (lt, ll) = (quad(&e[2], &e[2]), quad(&e[3], &e[3]));
    let mean = 0.5 * (p + q);
    let rad = (0.5 * (p - q)).hypot(r);
    let (hi, lo) = (mean + rad, mean - rad);
    if lo >= 0.0 && lt >= 0.0 && ll >= 0.0 {
        return *h;
    }
    // The block's part on (e_c, e_a): kept, dropped, or its positive eigenpair alone.
    let block = if lo >= 0.0 {
        [p, r, q]
    } else if hi <= 0.0 {
        [0.0; 3]
    } else {
        // Eigenvector of `hi` from the better conditioned of the two rows.
        let (x, y) = if (hi - q).abs() >= (hi - p).abs() {
            (hi - q, r)
        } else {
            (r, hi - p)
        };
        let n2 = x * x + y * y;
        [hi * x * x / n2, hi * x * y / n2, hi * y * y / n2]
    };
    let (lt, ll) = (lt.max(0.0), ll.max(0.0));
    std::array::from_fn(|r| {
        std::array::from_fn(|s| {
            block[0] * e[0][r] * e[0][s]
                + block[1] * (e[0][r] * e[1][s] + e[1][r] * e[0][s])
                + block[2] * e[1][r] * e[1][s]
                + lt * e[2][r] * e[2][s]
                + ll * e[3][r] * e[3][s]
        })
    })
}

/// The nearest positive semi-definite matrix (negative eigenvalues clamped to 0), by cyclic
/// Jacobi rotations on the stack: the reference `project_psd_isotropic` is tested against.
#[cfg(test)]
fn project_psd(h: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    let mut a: [[f64; 4]; 4] =
        std::array::from_fn(|i| std::array::from_fn(|k| 0.5 * (h[i][k] + h[k][i])));
    let mut v = [[0.0; 4]; 4];
    for i in 0..4 {
        v[i][i] = 1.0;
    }
    for _ in 0..32 {
        let mut off = 0.0;
        let mut on = 0.0;
        for i in 0..4 {
            for k in 0..4 {
                if i == k {
                    on += a[i][k] * a[i][k];
                } else {
                    off += a[i][k] * a[i][k];
                }
            }
        }
        if off <= 1e-30 * (on + off) {
            break;
        }
        for p in 0..3 {
            for q in p + 1..4 {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let sign = if theta >= 0.0 { 1.0 } else { -1.0 };
                let t = sign / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..4 {
                    let (akp, akq) = (a[k][p], a[k][q]);
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..4 {
                    let (apk, aqk) = (a[p][k], a[q][k]);
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for k in 0..4 {
                    let (vkp, vkq) = (v[k][p], v[k][q]);
                    v[k][p] = c * vkp - s * vkq;
                    v[k][q] = s * vkp + c * vkq;
                }
            }
        }
    }
    if (0..4).all(|i| a[i][i] >= 0.0) {
        return *h;
    }
    std::array::from_fn(|r| {
        std::array::from_fn(|k| (0..4).map(|i| a[i][i].max(0.0) * v[r][i] * v[k][i]).sum())
    })
}

/// Rings around a branch point within which the repair's references are the field's frames
/// rather than the curl*-free ones (module docs).
const GUIDE_RINGS: usize = 3;

/// The frames the repair measures against: the field's (`guide`) within [`GUIDE_RINGS`] rings
/// of a held vertex, the curl*-free ones (`disk`) elsewhere. Both in the disk frames.
fn references(
    mesh: &TriMesh,
    space: &MapSpace,
    disk: &[[DVec3; 2]],
    guide: &[[DVec3; 2]],
) -> Vec<[DVec3; 2]> {
    let mut near = vec![false; mesh.n_vertices()];
    let mut front: Vec<usize> = (0..mesh.n_vertices())
        .filter(|&v| space.var[mesh.vertex_halfedge(v)] == NONE)
        .collect();
    for &v in &front {
        near[v] = true;
    }
    for _ in 0..GUIDE_RINGS {
        let mut next = Vec::new();
        for &v in &front {
            for h in mesh.outgoing(v) {
                let w = mesh.from(mesh.next(h));
                if !near[w] {
                    near[w] = true;
                    next.push(w);
                }
            }
        }
        front = next;
    }
    (0..mesh.n_faces())
        .into_par_iter()
        .map(|f| {
            if mesh.face(f).iter().any(|&v| near[v]) {
                guide[f]
            } else {
                disk[f]
            }
        })
        .collect()
}

/// Repairs the folded faces of `uv` (per corner, in the disk frames) within the maps of
/// `space`; see the module docs. `disk` are the local step's curl*-free frames, `guide` the
/// field's.
#[allow(clippy::too_many_arguments)]
pub(crate) fn repair(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    disk: &[[DVec3; 2]],
    guide: &[[DVec3; 2]],
    cones: Option<&[f64]>,
    uv: &mut [[f64; 2]],
    cancel: super::CancelCheck<'_>,
) -> Repair {
    let t = Instant::now();
    let before = folded(uv).len();
    let held = cones.map_or_else(Vec::new, |c| rewind::wrongly_wound(mesh, space, uv, c));
    // Nothing to do (most solves): no copies, no sums over the mesh.
    if before == 0 && held.is_empty() {
        return Repair::default();
    }
    let reference = if before > 0 {
        references(mesh, space, disk, guide)
    } else {
        guide.to_vec()
    };
    let mean_area = mean_target_area(mesh, &reference);
    let guide_area = mean_target_area(mesh, guide);
    let Some(cones) = cones else {
        let at = Regions {
            mesh,
            rots,
            space,
            frames: &reference,
            mean_area,
            cones: &[],
            per_face: false,
        };
        let stuck = at.repair(&[], uv, cancel);
        return Repair {
            before,
            stuck,
            rewound: 0,
            ms: if before > 0 {
                t.elapsed().as_secs_f64() * 1e3
            } else {
                0.0
            },
        };
    };
    let start = uv.to_vec();
    let turned = rewind::rewind(
        mesh,
        rots,
        space,
        guide,
        guide_area,
        uv,
        cones,
        held,
        &rewind::BEFORE_REPAIR,
    );
    let mut rewound = turned.len();
    // Rewinding folds where the global step's map did not.
    let reference = if before == 0 && rewound > 0 {
        references(mesh, space, disk, guide)
    } else {
        reference
    };
    let at = Regions {
        mesh,
        rots,
        space,
        frames: &reference,
        mean_area,
        cones,
        per_face: false,
    };
    // The rewound start grows its regions to [`REWOUND_WIDEST_RINGS`] only: the global step's
    // map is the fallback.
    let widest = if rewound > 0 {
        REWOUND_WIDEST_RINGS
    } else {
        usize::MAX
    };
    let mut unfolded = at.unfold(&turned, uv, widest, cancel);
    // The rewound start may leave folds that the global step's map does not (seen at N = 6
    // at coarse densities): then the better of both, and only that one relaxed.
    if rewound > 0 && !folded(uv).is_empty() && !cancel() {
        let mut plain = start;
        let other = at.unfold(&[], &mut plain, usize::MAX, cancel);
        if folded(&plain).len() <= folded(uv).len() {
            uv.copy_from_slice(&plain);
            (unfolded, rewound) = (other, 0);
        }
    }
    at.relax_repaired(&unfolded, uv, cancel);
    Repair {
        before,
        stuck: unfolded.stuck,
        rewound,
        ms: if before > 0 || rewound > 0 {
            t.elapsed().as_secs_f64() * 1e3
        } else {
            0.0
        },
    }
}

/// Branch points still wound the wrong number of turns on a repaired map without folds (their
/// rewinding before the repair added too many folds, or the repair unwound them again, often
/// because rewinding one unwound a branch point near it): rewound again from this map over
/// wider, stiffer regions ([`rewind::ON_FINAL_MAP`]), together with the branch points near them
/// that a try winds wrongly, and repaired with all of them held to their winding. A round is
/// kept only when it leaves no fold and fewer wrongly wound vertices; at most
/// [`WIDE_ROUNDS`]. Returns how many branch points were rewound. Run once on the final map (after
/// re-rounding), not inside every repair: re-rounding repairs many candidate maps.
#[allow(clippy::too_many_arguments)]
pub(crate) fn rewind_left(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    disk: &[[DVec3; 2]],
    guide: &[[DVec3; 2]],
    cones: &[f64],
    uv: &mut [[f64; 2]],
    cancel: super::CancelCheck<'_>,
) -> usize {
    let mut rewound = 0;
    let mut left = rewind::wrongly_wound(mesh, space, uv, cones);
    if left.is_empty() || !folded(uv).is_empty() {
        return 0;
    }
    let reference = references(mesh, space, disk, guide);
    let at = Regions {
        mesh,
        rots,
        space,
        frames: &reference,
        mean_area: mean_target_area(mesh, &reference),
        cones,
        per_face: false,
    };
    let guide_area = mean_target_area(mesh, guide);
    let rounds = if mesh.n_faces() >= super::MISWOUND_TRIES_MAX_FACES {
        1
    } else {
        WIDE_ROUNDS
    };
    for _ in 0..rounds {
        if left.is_empty() || cancel() {
            break;
        }
        let mut trial = uv.to_vec();
        let turned = rewind::rewind(
            mesh,
            rots,
            space,
            guide,
            guide_area,
            &mut trial,
            cones,
            left.clone(),
            &rewind::ON_FINAL_MAP,
        );
        if turned.is_empty() {
            break;
        }
        at.repair(&turned, &mut trial, cancel);
        let after = rewind::wrongly_wound(mesh, space, &trial, cones);
        if !folded(&trial).is_empty() || after.len() >= left.len() {
            break;
        }
        uv.copy_from_slice(&trial);
        rewound += turned.len();
        left = after;
    }
    rewound
}

/// The mean area of the target triangles of `frames` (sequential: a parallel float sum's order
/// depends on the scheduling, and replay must be bit-identical).
fn mean_target_area(mesh: &TriMesh, frames: &[[DVec3; 2]]) -> f64 {
    (0..mesh.n_faces())
        .map(|f| tri_area(&target(mesh, frames, f)).abs())
        .filter(|a| a.is_finite())
        .sum::<f64>()
        / mesh.n_faces() as f64
}

/// What the regional solves of the repair share: the map space, the target frames and the
/// cones of the branch points whose windings are kept.
struct Regions<'a> {
    mesh: &'a TriMesh,
    rots: &'a Rots,
    space: &'a MapSpace,
    frames: &'a [[DVec3; 2]],
    mean_area: f64,
    cones: &'a [f64],
    /// Every face weighs the mean target area instead of its own ([`relax_conformal`]: the
    /// 99th percentile it aims at counts faces, and the most distorted ones are often small).
    per_face: bool,
}

/// What [`Regions::unfold`] leaves for [`Regions::relax_repaired`]: the stuck faces and the
/// faces whose surroundings are relaxed.
struct Unfolded {
    stuck: Vec<usize>,
    seeds: Vec<usize>,
}

impl Regions<'_> {
    /// The repair proper from `uv` (module docs), regions grown up to `widest` rings, without
    /// its last relaxation ([`Self::relax_repaired`]), so that of two starts only the better one
    /// is relaxed (the relaxation never changes how many faces are folded: it solves fold-free
    /// regions only, under the barrier).
    fn unfold(
        &self,
        rewound: &[usize],
        uv: &mut [[f64; 2]],
        widest: usize,
        cancel: super::CancelCheck<'_>,
    ) -> Unfolded {
        let (mesh, rots, space) = (self.mesh, self.rots, self.space);
        let all = folded(uv);
        if all.is_empty() && rewound.is_empty() {
            return Unfolded {
                stuck: Vec::new(),
                seeds: Vec::new(),
            };
        }
        let (stuck_faces, mut bad): (Vec<usize>, Vec<usize>) = all
            .into_iter()
            .partition(|&f| stuck(mesh, rots, space, uv, f));
        // The relaxation also spreads what rewinding a branch point twisted, folded or not
        // (measured over the 72 cases of `tests/untangle.rs`: p99-distortion misses 33 → 24;
        // over 4 rings only, 31).
        let mut seeds = bad.clone();
        seeds.extend(
            rewound
                .iter()
                .flat_map(|&b| mesh.outgoing(b).map(|h| mesh.face_of(h))),
        );
        seeds.sort_unstable();
        seeds.dedup();
        // Growing regions around the folds left.
        let grow = |uv: &mut [[f64; 2]], mut bad: Vec<usize>, keep: bool| -> Vec<usize> {
            let mut stalled = 0;
            for rings in RINGS.into_iter().filter(|&r| r <= widest) {
                if bad.is_empty() || stalled >= 2 || cancel() {
                    break;
                }
                let left = bad.len();
                self.solve(uv, &bad, rings, false, keep, cancel);
                bad = folded(uv)
                    .into_iter()
                    .filter(|f| stuck_faces.binary_search(f).is_err())
                    .collect();
                // Two growths in a row without fewer folds: larger regions will not do better.
                stalled = if bad.len() < left { 0 } else { stalled + 1 };
            }
            bad
        };
        bad = grow(uv, bad, true);
        // No fold comes first: where keeping every branch point's winding leaves folds, a
        // region may unwind one (it is then reported as mis-wound).
        if !bad.is_empty() && !cancel() {
            grow(uv, bad, false);
        }
        Unfolded {
            stuck: stuck_faces,
            seeds,
        }
    }

    /// Relaxation of the places [`Self::unfold`] repaired (fold-free regions only),
    /// injectivity kept by the barrier and the line search.
    fn relax_repaired(
        &self,
        unfolded: &Unfolded,
        uv: &mut [[f64; 2]],
        cancel: super::CancelCheck<'_>,
    ) {
        if !unfolded.seeds.is_empty() && !cancel() {
            self.solve(uv, &unfolded.seeds, RELAX_RINGS, true, true, cancel);
        }
    }

    /// [`Self::unfold`], then [`Self::relax_repaired`]; returns the stuck faces.
    fn repair(
        &self,
        rewound: &[usize],
        uv: &mut [[f64; 2]],
        cancel: super::CancelCheck<'_>,
    ) -> Vec<usize> {
        let unfolded = self.unfold(rewound, uv, usize::MAX, cancel);
        self.relax_repaired(&unfolded, uv, cancel);
        unfolded.stuck
    }
}

impl Regions<'_> {
    /// Solves the regions within `rings` rings of `seeds` (in parallel, each on its own
    /// vertices) and writes the kept results into `uv`; with `keep`, not those that unwind a
    /// branch point.
    fn solve(
        &self,
        uv: &mut [[f64; 2]],
        seeds: &[usize],
        rings: usize,
        relax: bool,
        keep: bool,
        cancel: super::CancelCheck<'_>,
    ) {
        let Regions {
            mesh,
            rots,
            space,
            frames,
            mean_area,
            cones,
            per_face,
        } = *self;
        let updates: Vec<Vec<(usize, [f64; 2])>> = regions(mesh, space, seeds, rings)
            .par_iter()
            .filter(|r| {
                let held = r.iter().any(|&v| space.free[v] != [true, true]);
                r.len() <= if held { MAX_HELD_REGION } else { MAX_REGION }
            })
            .map(|r| {
                let weights = (mean_area, per_face);
                solve_region(mesh, rots, space, frames, weights, r, uv, relax, cancel)
            })
            .map(|up| {
                if keep && !cones.is_empty() && unwinds(mesh, rots, space, cones, uv, &up) {
                    Vec::new()
                } else {
                    up
                }
            })
            .collect();
        for (v, y) in updates.into_iter().flatten() {
            for h in mesh.outgoing(v) {
                uv[h] = corner_uv(rots, space, h, y);
            }
        }
    }
}

/// The last step on a repaired map (`QuadCover::relax_conformal_of`): the faces within
/// [`CONFORMAL_REACH`] rings of those the repair changed (against `global`, the global step's
/// map on the same gaps) that are more distorted than `level` (`global`'s 99th percentile when
/// None) are relaxed towards the similarity part of their frames ([`conformal_frames`]), every
/// face weighing the same ([`Regions::per_face`]), with the barrier, every branch point's
/// winding kept and every region only when its energy decreased; in passes of
/// [`CONFORMAL_RINGS`] rings around the faces still above the level, each kept only when the
/// 99th percentile falls and no vertex more is wound wrongly, until the map's 99th percentile
/// is at or below the level (the bunny: 1 pass, the repair 134–152 → 117–129 ms; at 1.1 M
/// faces 2.7 → 3.1 s). The repair's own relaxation aims at the frames, which are
/// anisotropic next to singularities; this one at the conformal distortion the report
/// measures (72 cases: p99 more than 5 % above the global step's map in 18 → 0,
/// docs/untangling.md). `uv` has no fold; `miswound_now` are its mis-wound vertices
/// ([`miswound`], sorted; only vertices next to changed faces are checked again). Returns the
/// relaxed map and its mis-wound vertices; None when nothing changed.
#[allow(clippy::too_many_arguments)]
pub(crate) fn relax_conformal(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    disk: &[[DVec3; 2]],
    guide: &[[DVec3; 2]],
    cones: &[f64],
    global: &[[f64; 2]],
    level: Option<f64>,
    uv: &[[f64; 2]],
    miswound_now: &[usize],
    cancel: super::CancelCheck<'_>,
) -> Option<(Vec<[f64; 2]>, Vec<usize>)> {
    // (a re-rounded map is the global step's plus the repair's offset: equal up to rounding
    // where the repair did nothing)
    let moved_in = |uv: &[[f64; 2]], c: usize| {
        let (p, q) = (uv[c], global[c]);
        (p[0] - q[0]).hypot(p[1] - q[1]) > 1e-9 * (1.0 + q[0].abs().max(q[1].abs()))
    };
    let moved = |c: usize| moved_in(uv, c);
    let level = level.unwrap_or_else(|| super::metrics::map_conformal_p99(mesh, global));
    // The reach: the vertices within CONFORMAL_REACH rings of the faces the repair changed
    // (marked in place: a set of the vertices cost 0.14 s at 1.1 M faces).
    let mut near = vec![false; mesh.n_vertices()];
    let mut front = Vec::new();
    for f in 0..mesh.n_faces() {
        if (0..3).any(|a| moved(3 * f + a)) {
            for v in mesh.face(f) {
                if !near[v] {
                    near[v] = true;
                    front.push(v);
                }
            }
        }
    }
    mesh.mark_rings(&mut near, front, CONFORMAL_REACH);
    let within = |f: usize| mesh.face(f).iter().any(|&v| near[v]);
    let above = |j: &(f64, f64, f64)| !(j.1 <= level * j.2);
    let mut jac = super::metrics::jacobians(mesh, uv);
    if !(0..mesh.n_faces())
        .into_par_iter()
        .any(|f| within(f) && above(&jac[f]))
        || cancel()
    {
        return None;
    }
    let reference = references(mesh, space, disk, guide);
    let frames = conformal_frames(mesh, &reference);
    let at = Regions {
        mesh,
        rots,
        space,
        frames: &frames,
        mean_area: mean_target_area(mesh, &reference),
        cones,
        per_face: true,
    };
    // Passes, each seeded where the last left faces above the level and kept only when the
    // 99th percentile falls and no vertex more is wound wrongly; a pass not kept leaves the
    // next one, of another width, to try.
    let mut relaxed = uv.to_vec();
    let mut p99 = super::metrics::conformal_p99(&jac);
    let mut after = miswound_now.to_vec();
    // (a pass not kept leaves the map as it was: after one of each width in a row, nothing
    // more; the first pass runs even when the repaired map's p99 is at the level already, as
    // the faces above it are where the repair left its distortion)
    let mut not_kept = 0;
    for (pass, rings) in CONFORMAL_RINGS.into_iter().enumerate() {
        if (pass > 0 && p99 <= level) || not_kept == WIDTHS || cancel() {
            break;
        }
        let seeds: Vec<usize> = (0..mesh.n_faces())
            .into_par_iter()
            .filter(|&f| {
                (within(f) || (0..3).any(|a| moved_in(&relaxed, 3 * f + a))) && above(&jac[f])
            })
            .collect();
        if seeds.is_empty() {
            break;
        }
        let mut next = relaxed.clone();
        at.solve(&mut next, &seeds, rings, true, true, cancel);
        let changed: Vec<usize> = (0..mesh.n_faces())
            .into_par_iter()
            .filter(|&f| (3 * f..3 * f + 3).any(|c| next[c] != relaxed[c]))
            .collect();
        if changed.is_empty() {
            not_kept += 1;
            continue;
        }
        let mut next_jac = jac.clone();
        for &f in &changed {
            next_jac[f] = super::metrics::jacobian(mesh, &next, f);
        }
        let next_p99 = super::metrics::conformal_p99(&next_jac);
        let next_after = miswound_after(mesh, &next, cones, &after, &relaxed);
        if !(next_p99 < p99 && next_after.len() <= after.len()) {
            not_kept += 1;
            continue;
        }
        not_kept = 0;
        (relaxed, jac, p99, after) = (next, next_jac, next_p99, next_after);
    }
    if relaxed.as_slice() == uv {
        return None;
    }
    Some((relaxed, after))
}

/// Whether writing the unknowns `update` into `uv` would leave a held vertex next to them
/// (a branch point) wound wrongly that is wound by its cone angle now ([`miswound`]): the
/// untangling energy is finite on folded maps, so a region may pass through a fold and come
/// back with one turn less; the barrier would then keep it so.
fn unwinds(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    cones: &[f64],
    uv: &[[f64; 2]],
    update: &[(usize, [f64; 2])],
) -> bool {
    if update.is_empty() {
        return false;
    }
    let moved: HashMap<usize, [f64; 2]> = update.iter().copied().collect();
    let mut held: Vec<usize> = update
        .iter()
        .flat_map(|&(v, _)| mesh.outgoing(v).map(|h| mesh.from(mesh.next(h))))
        .filter(|&w| {
            space.var[mesh.vertex_halfedge(w)] == NONE
                && !mesh.is_boundary_vertex(w)
                && !cones[w].is_nan()
        })
        .collect();
    held.sort_unstable();
    held.dedup();
    let at = |c: usize| match moved.get(&mesh.from(c)) {
        Some(&y) => corner_uv(rots, space, c, y),
        None => uv[c],
    };
    held.into_iter().any(|b| {
        let right = |t: f64| (t - cones[b]).abs() <= std::f64::consts::PI;
        right(fan_turn(mesh, uv, b)) && !right(fan_turn_with(mesh, b, at))
    })
}

fn corner_uv(rots: &Rots, space: &MapSpace, c: usize, y: [f64; 2]) -> [f64; 2] {
    let v = space.var[c] as usize;
    let x = apply(rots.get(space.rot[c] as i64), apply(&space.basis[v], y));
    [space.consts[c][0] + x[0], space.consts[c][1] + x[1]]
}

/// The unknowns y_v of vertex v in the map `uv` (read at its first corner).
fn unknowns_of(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    uv: &[[f64; 2]],
    v: usize,
) -> [f64; 2] {
    let c = mesh.vertex_halfedge(v);
    corner_unknowns(rots, space, c, uv[c])
}

/// The inverse of [`corner_uv`]: the unknowns of corner c's vertex that put ψ_c at `p`.
fn corner_unknowns(rots: &Rots, space: &MapSpace, c: usize, p: [f64; 2]) -> [f64; 2] {
    let v = space.var[c] as usize;
    let d = [p[0] - space.consts[c][0], p[1] - space.consts[c][1]];
    apply(
        &transpose(&space.basis[v]),
        apply(rots.get(-(space.rot[c] as i64)), d),
    )
}

/// Vertices freed for the folds `bad` with `rings` rings around them, in connected regions.
fn regions(mesh: &TriMesh, space: &MapSpace, bad: &[usize], rings: usize) -> Vec<Vec<usize>> {
    let nv = mesh.n_vertices();
    let mut dist = vec![usize::MAX; nv];
    let mut front: Vec<usize> = Vec::new();
    for &f in bad {
        for v in mesh.face(f) {
            if dist[v] == usize::MAX {
                dist[v] = 0;
                front.push(v);
            }
        }
    }
    // Vertices at distance < rings are freed: their faces reach at most distance `rings`.
    for d in 1..rings {
        let mut next = Vec::new();
        for &v in &front {
            for h in mesh.outgoing(v) {
                for w in mesh.face(mesh.face_of(h)) {
                    if dist[w] == usize::MAX {
                        dist[w] = d;
                        next.push(w);
                    }
                }
            }
        }
        front = next;
    }
    let movable = |v: usize| {
        let c = mesh.vertex_halfedge(v);
        dist[v] < rings && space.var[c] != NONE && (space.free[v][0] || space.free[v][1])
    };
    // Connected components of the freed vertices (through faces).
    let mut comp = vec![usize::MAX; nv];
    let mut out = Vec::new();
    for s in 0..nv {
        if comp[s] != usize::MAX || !movable(s) {
            continue;
        }
        let id = out.len();
        let mut members = vec![s];
        comp[s] = id;
        let mut i = 0;
        while i < members.len() {
            let v = members[i];
            i += 1;
            for h in mesh.outgoing(v) {
                for w in mesh.face(mesh.face_of(h)) {
                    if comp[w] == usize::MAX && movable(w) {
                        comp[w] = id;
                        members.push(w);
                    }
                }
            }
        }
        out.push(members);
    }
    out
}

/// A region's texture corners of a face for given unknowns.
type Corners<'a> = dyn Fn(&[[f64; 2]], &RegionFace) -> [[f64; 2]; 3] + 'a;

/// One energy face of a region: its corners and the local slot of each corner's vertex.
struct RegionFace {
    corners: [usize; 3],
    /// Per corner: the local slot of the corner's vertex, or NONE when it is held.
    slot: [u32; 3],
    reference: Reference,
}

/// The unknowns `y0` with the free neighbours of every held vertex on a folded face placed
/// by the target triangles around that vertex: ψ_w = ψ_s + (X·(p_w − p_s)) in each face, read
/// back as unknowns and averaged over the faces. None when no folded face has a held corner.
#[allow(clippy::too_many_arguments)]
fn fan_start(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    disk: &[[DVec3; 2]],
    faces: &[RegionFace],
    unknown: &[[u32; 2]],
    free: &[usize],
    uv: &[[f64; 2]],
    y0: &[[f64; 2]],
) -> Option<Vec<[f64; 2]>> {
    let mut held: Vec<usize> = Vec::new();
    for face in faces {
        let f = face.corners[0] / 3;
        if positive(uv, f) {
            continue;
        }
        for a in 0..3 {
            let c = face.corners[a];
            if face.slot[a] == NONE && space.var[c] == NONE {
                held.push(mesh.from(c));
            }
        }
    }
    held.sort_unstable();
    held.dedup();
    if held.is_empty() {
        return None;
    }
    let slot: HashMap<usize, usize> = free.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    let mut sum = vec![[0.0; 2]; free.len()];
    let mut count = vec![0usize; free.len()];
    for &s in &held {
        for h in mesh.outgoing(s) {
            let f = mesh.face_of(h);
            let ps = mesh.position(s);
            for c in [mesh.next(h), mesh.prev(h)] {
                let w = mesh.from(c);
                let Some(&i) = slot.get(&w) else { continue };
                let d = mesh.position(w) - ps;
                let target = [uv[h][0] + disk[f][0].dot(d), uv[h][1] + disk[f][1].dot(d)];
                let y = corner_unknowns(rots, space, c, target);
                sum[i][0] += y[0];
                sum[i][1] += y[1];
                count[i] += 1;
            }
        }
    }
    Some(
        (0..free.len())
            .map(|i| {
                if count[i] == 0 {
                    return y0[i];
                }
                // Held components keep their value.
                let m = [sum[i][0] / count[i] as f64, sum[i][1] / count[i] as f64];
                std::array::from_fn(|k| {
                    if unknown[i][k] == NONE {
                        y0[i][k]
                    } else {
                        m[k]
                    }
                })
            })
            .collect(),
    )
}

/// Gradient, per-face Hessian blocks (in the order of [`solve_region`]'s `positions`) and a
/// regularisation for the global step's energy Σ w ‖J − I‖² over the region's faces whose held
/// corners are all pinned (branch points; faces reaching held vertices outside the region are
/// left out: a free boundary), at `y`. None when no folded face has a pinned corner.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn cone_start(
    space: &MapSpace,
    faces: &[RegionFace],
    terms: &[Vec<(usize, [f64; 4])>],
    unknown: &[[u32; 2]],
    y: &[[f64; 2]],
    corners: &Corners<'_>,
) -> Option<(Vec<f64>, Vec<Vec<f64>>, f64)> {
    let pinned_fold = faces.iter().any(|face| {
        tri_area(&corners(y, face)) <= 0.0
            && (0..3).any(|a| face.slot[a] == NONE && space.var[face.corners[a]] == NONE)
    });
    if !pinned_fold {
        return None;
    }
    let n = unknown.iter().flatten().filter(|&&u| u != NONE).count();
    let mut g = vec![0.0; n];
    let mut diag = 0.0;
    let h: Vec<Vec<f64>> = faces
        .iter()
        .zip(terms)
        .map(|(face, dj)| {
            let kept = (0..3).all(|a| face.slot[a] != NONE || space.var[face.corners[a]] == NONE);
            if !kept {
                return vec![0.0; dj.len() * dj.len()];
            }
            let j = jacobian(&corners(y, face), &face.reference);
            let r = [j[0] - 1.0, j[1], j[2], j[3] - 1.0];
            let w = 2.0 * face.reference.weight;
            let mut out = Vec::with_capacity(dj.len() * dj.len());
            for (p, dp) in dj {
                g[*p] += w * (0..4).map(|i| r[i] * dp[i]).sum::<f64>();
                for (q, dq) in dj {
                    let s = w * (0..4).map(|i| dp[i] * dq[i]).sum::<f64>();
                    if p == q {
                        diag += s;
                    }
                    out.push(s);
                }
            }
            out
        })
        .collect();
    // Anchors vertices the kept faces do not reach (and keeps the system definite).
    Some((g, h, 1e-6 * diag / n.max(1) as f64 + 1e-300))
}

/// `pinned` (the free-boundary layout of [`cone_start`]) near the held vertices of the folded
/// faces, blended linearly (in rings) into `y` over the outer half of the region.
#[allow(clippy::too_many_arguments)]
fn blend(
    mesh: &TriMesh,
    space: &MapSpace,
    faces: &[RegionFace],
    unknown: &[[u32; 2]],
    free: &[usize],
    y: &[[f64; 2]],
    pinned: &[[f64; 2]],
    corners: &Corners<'_>,
) -> Vec<[f64; 2]> {
    let slot: HashMap<usize, usize> = free.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    let mut dist = vec![usize::MAX; free.len()];
    let mut front: Vec<usize> = Vec::new();
    for face in faces {
        if tri_area(&corners(y, face)) > 0.0 {
            continue;
        }
        for a in 0..3 {
            if face.slot[a] == NONE && space.var[face.corners[a]] == NONE {
                front.push(mesh.from(face.corners[a]));
            }
        }
    }
    // Rings from the held vertices, through the region's vertices.
    let mut d = 0;
    let mut seen: std::collections::HashSet<usize> = front.iter().copied().collect();
    while !front.is_empty() {
        let mut next = Vec::new();
        for &v in &front {
            if let Some(&i) = slot.get(&v) {
                dist[i] = d;
            }
            for h in mesh.outgoing(v) {
                let w = mesh.from(mesh.next(h));
                if slot.contains_key(&w) && seen.insert(w) {
                    next.push(w);
                }
            }
        }
        front = next;
        d += 1;
    }
    let reach = dist
        .iter()
        .filter(|&&x| x != usize::MAX)
        .max()
        .copied()
        .unwrap_or(0)
        .max(1) as f64;
    (0..free.len())
        .map(|i| {
            let phi = if dist[i] == usize::MAX {
                0.0
            } else {
                (2.0 - 2.0 * dist[i] as f64 / reach).clamp(0.0, 1.0)
            };
            std::array::from_fn(|k| {
                if unknown[i][k] == NONE {
                    y[i][k]
                } else {
                    phi * pinned[i][k] + (1.0 - phi) * y[i][k]
                }
            })
        })
        .collect()
}

/// The unknowns `y` with every free interior vertex whose fan angle sum in `uv` is off 2π by
/// more than π placed from its neighbours by the target triangles: in each face around it
/// ψ_v = ψ_a + X·(p_v − p_a) for both other corners a, read back as unknowns and averaged.
/// None when there is no such vertex.
#[allow(clippy::too_many_arguments)]
fn ring_start(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    disk: &[[DVec3; 2]],
    unknown: &[[u32; 2]],
    free: &[usize],
    y: &[[f64; 2]],
    uv: impl Fn(usize) -> [f64; 2],
) -> Option<Vec<[f64; 2]>> {
    let mut out = y.to_vec();
    let mut any = false;
    for (i, &v) in free.iter().enumerate() {
        if mesh.is_boundary_vertex(v) {
            continue;
        }
        let angle = fan_turn_with(mesh, v, &uv);
        if (angle - std::f64::consts::TAU).abs() <= std::f64::consts::PI {
            continue;
        }
        let (mut sum, mut count) = ([0.0; 2], 0.0);
        for h in mesh.outgoing(v) {
            let f = mesh.face_of(h);
            let pv = mesh.position(v);
            for a in [mesh.next(h), mesh.prev(h)] {
                let d = pv - mesh.position(mesh.from(a));
                let p = uv(a);
                let t = [p[0] + disk[f][0].dot(d), p[1] + disk[f][1].dot(d)];
                let q = corner_unknowns(rots, space, h, t);
                sum = [sum[0] + q[0], sum[1] + q[1]];
                count += 1.0;
            }
        }
        for k in 0..2 {
            if unknown[i][k] != NONE {
                out[i][k] = sum[k] / count;
            }
        }
        any = true;
    }
    any.then_some(out)
}

/// Newton on the untangling energy over the vertices `free` (module docs); returns their new
/// unknowns when the region got better, nothing otherwise. With `relax` the region must be
/// fold-free; it is minimised with the barrier (ε = [`EPS_BARRIER`]) and kept when the energy
/// decreased and nothing folded. `(mean_area, per_face)`: the mean target area, and whether
/// every face weighs it ([`Regions::per_face`]) instead of its own target area.
#[allow(clippy::too_many_arguments)]
fn solve_region(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    disk: &[[DVec3; 2]],
    (mean_area, per_face): (f64, bool),
    free: &[usize],
    uv: &[[f64; 2]],
    relax: bool,
    cancel: super::CancelCheck<'_>,
) -> Vec<(usize, [f64; 2])> {
    let slot_of: HashMap<usize, u32> = free
        .iter()
        .enumerate()
        .map(|(i, &v)| (v, i as u32))
        .collect();
    // Unknown index per (slot, component).
    let (unknown, n) = number_unknowns(space, free);
    if n == 0 {
        return Vec::new();
    }
    let mut faces = faces_around(mesh, free);
    // A stuck face's determinant does not depend on the unknowns; its barrier would only
    // swamp the others.
    faces.retain(|&f| positive(uv, f) || !stuck(mesh, rots, space, uv, f));
    let rf: Vec<RegionFace> = faces
        .iter()
        .map(|&f| RegionFace {
            corners: [3 * f, 3 * f + 1, 3 * f + 2],
            slot: std::array::from_fn(|a| {
                slot_of.get(&mesh.from(3 * f + a)).copied().unwrap_or(NONE)
            }),
            reference: {
                let mut r = reference(mesh, disk, f, mean_area);
                if per_face {
                    r.weight = mean_area;
                }
                r
            },
        })
        .collect();
    let y0: Vec<[f64; 2]> = free
        .iter()
        .map(|&v| unknowns_of(mesh, rots, space, uv, v))
        .collect();
    let corners = |y: &[[f64; 2]], face: &RegionFace| -> [[f64; 2]; 3] {
        std::array::from_fn(|a| {
            let c = face.corners[a];
            match face.slot[a] {
                NONE => uv[c],
                s => corner_uv(rots, space, c, y[s as usize]),
            }
        })
    };
    let measure = |y: &[[f64; 2]]| -> (usize, f64) {
        rf.iter().fold((0, f64::INFINITY), |(k, m), face| {
            let d = det(&jacobian(&corners(y, face), &face.reference));
            (k + usize::from(!(d > 0.0)), m.min(d))
        })
    };
    let total = |y: &[[f64; 2]], eps: f64| -> f64 {
        rf.iter()
            .map(|face| {
                face.reference.weight * energy(&jacobian(&corners(y, face), &face.reference), eps)
            })
            .sum()
    };
    // Corner c of the map with the region's unknowns `y` written in (a copy of `uv` per
    // region cost 50 MB of copying at 1.1 M faces).
    let corner_of = |y: &[[f64; 2]], c: usize| -> [f64; 2] {
        match slot_of.get(&mesh.from(c)) {
            Some(&s) => corner_uv(rots, space, c, y[s as usize]),
            None => uv[c],
        }
    };
    let (folds0, detmin0) = measure(&y0);
    if relax && folds0 > 0 {
        return Vec::new();
    }
    // Per face its unknowns and ∂J/∂y (constant: ψ is affine in y), the Hessian's pattern
    // with each face's entries located once, and its analysis, shared by every Newton step.
    let terms: Vec<Vec<(usize, [f64; 4])>> = rf
        .iter()
        .map(|face| {
            jacobian_terms(
                rots,
                space,
                free,
                &unknown,
                face.corners,
                face.slot,
                &face.reference,
            )
        })
        .collect();
    let mut b = SparseBuilder::<f64>::with_capacity(
        n,
        n + terms.iter().map(|t| t.len().pow(2)).sum::<usize>(),
    );
    for i in 0..n {
        b.add(i, i, 1.0);
    }
    for t in &terms {
        for (p, _) in t {
            for (q, _) in t {
                b.add(*p, *q, 1.0);
            }
        }
    }
    let Ok(pattern) = b.build() else {
        return Vec::new();
    };
    let positions: Vec<Vec<usize>> = terms
        .iter()
        .map(|t| {
            t.iter()
                .flat_map(|(p, _)| t.iter().map(|(q, _)| pattern.position(*p, *q).unwrap_or(0)))
                .collect()
        })
        .collect();
    let diagonal: Vec<usize> = (0..n)
        .map(|i| pattern.position(i, i).unwrap_or(0))
        .collect();
    let Ok(analysis) = Analysis::new(&pattern) else {
        return Vec::new();
    };
    let step_of = |y: &[[f64; 2]], step: &[f64], t: f64| -> Vec<[f64; 2]> {
        y.iter()
            .enumerate()
            .map(|(i, yi)| {
                let mut r = *yi;
                for k in 0..2 {
                    let u = unknown[i][k];
                    if u != NONE {
                        r[k] += t * step[u as usize];
                    }
                }
                r
            })
            .collect()
    };
    // One Newton step on f_ε from `y`, whose energy is `e0`, with a backtracking (Armijo)
    // line search: the energy of the step taken (None when none is), and whether it made
    // progress enough for another.
    let newton = |y: &mut Vec<[f64; 2]>, eps: f64, e0: f64| -> (Option<f64>, bool) {
        let mut g = vec![0.0; n];
        let mut values = vec![0.0; pattern.nnz()];
        let mut diag = 0.0;
        for (fi, face) in rf.iter().enumerate() {
            let j = jacobian(&corners(y, face), &face.reference);
            let (_, gj, hj) = energy_derivatives(&j, eps);
            let w = face.reference.weight;
            let dj = &terms[fi];
            // H ∂J/∂y_q once per unknown q (a face has at most six): each pair is then one dot
            // product instead of sixteen products.
            let mut hd = [[0.0; 4]; 6];
            for (h, (_, dq)) in hd.iter_mut().zip(dj) {
                *h = std::array::from_fn(|i| (0..4).map(|k| hj[i][k] * dq[k]).sum::<f64>());
            }
            let mut slot = positions[fi].iter();
            for (p, dp) in dj {
                g[*p] += w * (0..4).map(|i| gj[i] * dp[i]).sum::<f64>();
                for ((qq, _), hdq) in dj.iter().zip(&hd) {
                    let s = (0..4).map(|i| dp[i] * hdq[i]).sum::<f64>();
                    values[*slot.next().unwrap_or(&0)] += w * s;
                    if p == qq {
                        diag += w * s;
                    }
                }
            }
        }
        // A small multiple of the mean diagonal keeps the system definite.
        let reg = 1e-9 * diag / n as f64 + 1e-300;
        for &d in &diagonal {
            values[d] += reg;
        }
        let Ok(m) = pattern.with_values(values) else {
            return (None, false);
        };
        let Ok(solver) = SpdSolver::with_analysis_sequential(analysis.clone(), &m) else {
            return (None, false);
        };
        let rhs: Vec<f64> = g.iter().map(|x| -x).collect();
        let Ok(step) = solver.solve(&rhs) else {
            return (None, false);
        };
        let slope: f64 = g.iter().zip(&step).map(|(a, b)| a * b).sum();
        if !(slope < 0.0) {
            return (None, false);
        }
        let mut t = 1.0;
        for _ in 0..40 {
            let trial = step_of(y, &step, t);
            let e1 = total(&trial, eps);
            if e1.is_finite() && e1 <= e0 + 1e-4 * t * slope {
                *y = trial;
                return (Some(e1), -slope >= 1e-12 * e0.abs());
            }
            t *= 0.5;
        }
        (None, false)
    };
    let constrained = free.iter().any(|&v| space.free[v] != [true, true]);
    let fold_stagnation = if constrained {
        FOLD_STAGNATION_HELD
    } else {
        FOLD_STAGNATION
    };
    // Garanzha et al.'s outer loop: Newton steps on f_ε, then ε from the progress made.
    let run = |start: Vec<[f64; 2]>| -> Vec<[f64; 2]> {
        let mut y = start;
        let detmin_start = measure(&y).1;
        let (mut best_detmin, mut since_best) = (detmin_start, 0usize);
        let (mut best_folds, mut since_fewer) = (usize::MAX, 0usize);
        let mut eps = if relax {
            EPS_BARRIER
        } else {
            (1e-12 + 0.04 * detmin_start.min(0.0).powi(2))
                .sqrt()
                .max(1e-6)
        };
        let mut e_prev = total(&y, eps);
        for _ in 0..OUTER {
            if cancel() {
                break;
            }
            // (the energies are carried along: each is the same sum over the region's faces
            // as a new evaluation would be)
            let mut e = e_prev;
            for _ in 0..NEWTON_PER_EPS {
                let (taken, more) = newton(&mut y, eps, e);
                if let Some(e1) = taken {
                    e = e1;
                }
                if !more {
                    break;
                }
            }
            let (folds_now, detmin) = measure(&y);
            let sigma = (1.0 - e / e_prev).max(0.1);
            let mu = (1.0 - sigma) * chi(detmin, eps);
            let converged = detmin > 0.0 && ((e_prev - e) / e).abs() < 1e-5;
            eps = if detmin < mu {
                2.0 * (mu * (mu - detmin)).sqrt()
            } else {
                EPS_BARRIER
            };
            e_prev = total(&y, eps);
            // ε collapsing with faces still inverted: the held boundary is in the way; the
            // caller grows the region.
            if converged || (detmin <= 0.0 && eps < 1e-14) {
                break;
            }
            // No progress of the smallest determinant for a while with faces still inverted:
            // a larger region does better than more steps.
            if detmin > best_detmin + 1e-6 * best_detmin.abs() {
                (best_detmin, since_best) = (detmin, 0);
            } else {
                since_best += 1;
                if detmin <= 0.0 && since_best >= STAGNATION {
                    break;
                }
            }
            // The same for the number of folded faces: the smallest determinant may creep up
            // for the whole budget while the last fold stays (regions of a few hundred
            // vertices at a branch point rounded too far: 200 iterations, a second each).
            if folds_now < best_folds {
                (best_folds, since_fewer) = (folds_now, 0);
            } else {
                since_fewer += 1;
                if folds_now > 0 && since_fewer >= fold_stagnation {
                    break;
                }
            }
        }
        y
    };
    // A face collapsed to a point (J = 0) is a critical point of the energy: its gradient
    // vanishes there. Its free corners start displaced by a tenth of the face's reference
    // size, in directions fixed by the vertex number (replay stays bit-identical).
    let mut start = y0.clone();
    for face in &rf {
        let j = jacobian(&corners(&y0, face), &face.reference);
        if j.iter().map(|x| x.abs()).sum::<f64>() > 1e-6 {
            continue;
        }
        let size = face.reference.weight.sqrt() * 0.1;
        for a in 0..3 {
            let s = face.slot[a];
            if s == NONE {
                continue;
            }
            let v = free[s as usize];
            let turn = ((v as u64).wrapping_mul(2_654_435_761) % 1000) as f64 / 1000.0;
            let (sn, c) = (std::f64::consts::TAU * turn).sin_cos();
            for (k, d) in [c, sn].into_iter().enumerate() {
                if unknown[s as usize][k] != NONE {
                    start[s as usize][k] += size * d;
                }
            }
        }
    }
    let mut y = run(start);
    let (mut folds, detmin) = measure(&y);
    // Restarts (below) in small regions without held components only: under constraint
    // curves they tripled the cost for no fold fewer (fandisk, features at 40°).
    let restarts = free.len() <= FAN_RESTART_MAX && !constrained;
    if relax {
        // Kept only fold-free and with less energy.
        let better = folds == 0 && total(&y, EPS_BARRIER) < total(&y0, EPS_BARRIER);
        return if better {
            free.iter().copied().zip(y).collect()
        } else {
            Vec::new()
        };
    }
    // A held vertex (a branch point) whose fan winds the wrong number of turns (e.g. 60°
    // instead of 420° at a −1/6 singularity) is a local minimum the energy rarely leaves:
    // start again from its neighbours laid out by the target triangles around it.
    if folds > 0
        && restarts
        && let Some(start) = fan_start(mesh, rots, space, disk, &rf, &unknown, free, uv, &y0)
    {
        let y1 = run(start);
        let m = measure(&y1);
        if m.0 < folds || (m.0 == folds && m.1 > detmin) {
            (y, folds) = (y1, m.0);
        }
    }
    // A free interior vertex whose fan winds no turn (angle sum 0 instead of 2π: it sits on
    // the far side of its ring, e.g. pressed onto a branch point) is another such minimum:
    // start again with those vertices placed from their neighbours by the target triangles.
    if folds > 0
        && restarts
        && let Some(start) = ring_start(mesh, rots, space, disk, &unknown, free, &y, |c| {
            corner_of(&y, c)
        })
    {
        let y1 = run(start);
        let m = measure(&y1);
        if m.0 < folds {
            (y, folds) = (y1, m.0);
        }
    }
    // A held vertex (a branch point) on a folded face whose lattice point lies outside the
    // image of its ring winds one turn short (−90° instead of 270° at a +1/4 singularity):
    // the rounding moved it farther than its ring is wide, and the folds cover a disk about
    // that wide, too wide for the layouts above. Start from the map the global step's energy
    // gives with only the held vertices pinned (a free boundary: the target triangles laid
    // out around the lattice point), blended into the current map towards the region's edge.
    if folds > 0
        && restarts
        && let Some(start) = cone_start(space, &rf, &terms, &unknown, &y, &corners)
            .and_then(|(g, h, regs)| {
                let mut values = vec![0.0; pattern.nnz()];
                for (fi, hf) in h.iter().enumerate() {
                    for (k, x) in hf.iter().enumerate() {
                        values[positions[fi][k]] += x;
                    }
                }
                for &d in &diagonal {
                    values[d] += regs;
                }
                let m = pattern.with_values(values).ok()?;
                let solver = SpdSolver::with_analysis_sequential(analysis.clone(), &m).ok()?;
                let rhs: Vec<f64> = g.iter().map(|x| -x).collect();
                let step = solver.solve(&rhs).ok()?;
                Some(step_of(&y, &step, 1.0))
            })
            .map(|pinned| blend(mesh, space, &rf, &unknown, free, &y, &pinned, &corners))
    {
        let y1 = run(start);
        let m = measure(&y1);
        if m.0 < folds {
            (y, folds) = (y1, m.0);
        }
    }
    // Only fewer folds count: a region left with as many folds but a larger smallest
    // determinant is usually badly distorted (measured: kitten N = 4 at 1500 vertices went
    // from conformal distortion 1.27 to 1.96 that way).
    // A partial repair (folds left) under constraint curves is kept only if it does not
    // distort the region much beyond what it had: whose held components leave
    // little room, it otherwise traded folds for slivers (fandisk with features at 35°:
    // conformal distortion 1.48 → 2.84 for 33 → 13 folds).
    let _ = detmin0;
    let distortion = |y: &[[f64; 2]]| -> f64 {
        let (mut sum, mut area) = (0.0, 0.0);
        for face in &rf {
            let j = jacobian(&corners(y, face), &face.reference);
            let (d, s) = (det(&j), j.iter().map(|x| x * x).sum::<f64>());
            if d > 0.0 {
                let k = (s + (s * s - 4.0 * d * d).max(0.0).sqrt()) / (2.0 * d);
                sum += face.reference.weight * k.min(1000.0);
                area += face.reference.weight;
            }
        }
        if area > 0.0 { sum / area } else { 1.0 }
    };
    // Only where curves hold components: elsewhere partial repairs are the way to full ones
    // through the growing regions (with this rule everywhere, spot N = 6 at 1500 vertices kept
    // 5 folds instead of 2).
    let acceptable =
        folds == 0 || !constrained || distortion(&y) <= PARTIAL_DISTORTION * distortion(&y0);
    if folds < folds0 && acceptable {
        free.iter().copied().zip(y).collect()
    } else {
        Vec::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shortcut in [`positive`] decides as the threshold itself does, on triangles whose
    /// area lies anywhere from below to above it (a bound under the threshold, e.g. the longer
    /// coordinate difference without the factor 1.5, fails on the diagonal ones).
    #[test]
    fn positive_decides_as_the_degenerate_threshold() {
        let mut mismatches = 0;
        for i in 0..20_000u64 {
            let r = |k: u64| {
                let x = (i * 7919 + k * 104_729).wrapping_mul(2_654_435_761) % 1_000_003;
                x as f64 / 1_000_003.0
            };
            let (scale, angle) = (10f64.powf(6.0 * r(1) - 3.0), std::f64::consts::TAU * r(2));
            let a = [1e3 * (r(3) - 0.5), 1e3 * (r(4) - 0.5)];
            let b = [a[0] + scale * angle.cos(), a[1] + scale * angle.sin()];
            // The third corner off the edge ab by a height that puts the area at 0.3–3 times
            // the threshold, on either side.
            let uv0 = [a, b, b];
            let threshold = degenerate_area(&uv0, 0);
            let len = scale;
            let height = 2.0 * threshold * (0.3 + 2.7 * r(5)) / len;
            let side = if i % 2 == 0 { 1.0 } else { -1.0 };
            let t = r(6);
            let c = [
                a[0] + t * (b[0] - a[0]) - side * height * angle.sin(),
                a[1] + t * (b[1] - a[1]) + side * height * angle.cos(),
            ];
            let uv = [a, b, c];
            if positive(&uv, 0) != (uv_area(&uv, 0) > degenerate_area(&uv, 0)) {
                mismatches += 1;
            }
        }
        assert_eq!(mismatches, 0);
    }

    /// A fan of 12 positive texture triangles around an interior vertex of index 0 that wraps
    /// twice (720°) is mis-wound although nothing is folded; wrapping once it is not; and a
    /// cone angle of 4π (index −1) makes the double wrap the right one.
    #[test]
    fn a_double_wrap_is_miswound_without_a_fold() {
        let k = 12;
        let mut positions = vec![DVec3::ZERO];
        positions.extend((0..k).map(|i| {
            let a = std::f64::consts::TAU * i as f64 / k as f64;
            DVec3::new(a.cos(), a.sin(), 0.0)
        }));
        let triangles: Vec<[u32; 3]> = (0..k as u32)
            .map(|i| [0, 1 + i, 1 + (i + 1) % k as u32])
            .collect();
        let mesh = TriMesh::from_triangles(positions, triangles).unwrap();
        let centre = (0..mesh.n_vertices())
            .find(|&v| !mesh.is_boundary_vertex(v))
            .unwrap();
        let map = |wraps: f64| -> Vec<[f64; 2]> {
            (0..3 * mesh.n_faces())
                .map(|c| {
                    let v = mesh.from(c);
                    if v == centre {
                        return [0.0, 0.0];
                    }
                    let p = mesh.position(v);
                    let a = wraps * p.y.atan2(p.x);
                    [a.cos(), a.sin()]
                })
                .collect()
        };
        // The ring's angle jumps at ±π; per face the corners take the unwrapped angle.
        let unwrapped = |wraps: f64| -> Vec<[f64; 2]> {
            let mut uv = map(wraps);
            for f in 0..mesh.n_faces() {
                let ring: Vec<usize> = (0..3).filter(|&a| mesh.from(3 * f + a) != centre).collect();
                let ang: Vec<f64> = ring
                    .iter()
                    .map(|&a| {
                        let p = mesh.position(mesh.from(3 * f + a));
                        p.y.atan2(p.x)
                    })
                    .collect();
                if (ang[0] - ang[1]).abs() > std::f64::consts::PI {
                    for (i, &a) in ring.iter().enumerate() {
                        let t = if ang[i] < 0.0 {
                            ang[i] + std::f64::consts::TAU
                        } else {
                            ang[i]
                        };
                        uv[3 * f + a] = [(wraps * t).cos(), (wraps * t).sin()];
                    }
                }
            }
            uv
        };
        let mut cones = vec![f64::NAN; mesh.n_vertices()];
        cones[centre] = std::f64::consts::TAU;
        let once = unwrapped(1.0);
        let twice = unwrapped(2.0);
        assert!(folded(&once).is_empty() && folded(&twice).is_empty());
        assert!((fan_turn(&mesh, &twice, centre) - 2.0 * std::f64::consts::TAU).abs() < 1e-9);
        assert!(miswound(&mesh, &once, &cones).is_empty());
        assert_eq!(miswound(&mesh, &twice, &cones), vec![centre]);
        // Re-checked from a map it changed to: only the changed faces' vertices are walked.
        assert_eq!(
            miswound_after(&mesh, &twice, &cones, &[], &once),
            vec![centre]
        );
        assert!(miswound_after(&mesh, &once, &cones, &[centre], &twice).is_empty());
        // Nothing changed: the earlier list stands (not walked again).
        assert_eq!(
            miswound_after(&mesh, &once, &cones, &[centre], &once),
            vec![centre]
        );
        cones[centre] = 2.0 * std::f64::consts::TAU;
        assert!(miswound(&mesh, &twice, &cones).is_empty());
        assert_eq!(miswound(&mesh, &once, &cones), vec![centre]);
    }

    #[test]
    fn psd_projection_matches_the_spectrum() {
        // A symmetric matrix with eigenvalues 3, 1, −2, −5 in a rotated basis.
        let lam = [3.0, 1.0, -2.0, -5.0];
        let (c, s) = (0.6f64, 0.8f64);
        let q = [
            [c, -s, 0.0, 0.0],
            [s, c, 0.0, 0.0],
            [0.0, 0.0, c, s],
            [0.0, 0.0, -s, c],
        ];
        let h: [[f64; 4]; 4] = std::array::from_fn(|i| {
            std::array::from_fn(|k| (0..4).map(|m| q[i][m] * lam[m] * q[k][m]).sum())
        });
        let p = project_psd(&h);
        for i in 0..4 {
            for k in 0..4 {
                let want: f64 = (0..4).map(|m| q[i][m] * lam[m].max(0.0) * q[k][m]).sum();
                assert!(
                    (p[i][k] - want).abs() < 1e-12,
                    "{i} {k}: {} vs {want}",
                    p[i][k]
                );
            }
        }
    }

    #[test]
    fn the_closed_form_projection_matches_jacobi_rotations() {
        // Folded, flat, conformal, anti-conformal and zero Jacobians, and a deterministic
        // scatter, at a small and a large ε: the closed form must give the Jacobi result.
        let mut cases = vec![
            [0.7, -0.3, 0.2, -0.4],
            [1.0, 0.0, 0.0, 1.0],
            [0.5, 0.2, -0.2, 0.5],
            [0.5, 0.2, 0.2, -0.5],
            [0.0; 4],
            [1e-9, 0.0, 0.0, -1e-9],
            [3.0, 1.0, 6.0, 2.0],
        ];
        let mut x = 0.123_456_789f64;
        for _ in 0..400 {
            cases.push(std::array::from_fn(|_| {
                x = (x * 3.987_654 + 0.271_828).fract();
                4.0 * x - 2.0
            }));
        }
        let mut clamped = 0;
        for j in &cases {
            for eps in [1e-3, 0.3, 2.0] {
                let (_, _, h) = energy_derivatives_unprojected(j, eps);
                let (want, got) = (project_psd(&h), project_psd_isotropic(j, &h));
                let scale = h.iter().flatten().map(|v| v.abs()).fold(1.0, f64::max);
                for r in 0..4 {
                    for s in 0..4 {
                        assert!(
                            (want[r][s] - got[r][s]).abs() < 1e-10 * scale,
                            "J {j:?}, ε {eps}: [{r}][{s}] {} vs {}",
                            got[r][s],
                            want[r][s]
                        );
                    }
                }
                clamped += usize::from(want != h);
            }
        }
        // The comparison covers indefinite Hessians, not only the positive ones returned as is.
        assert!(clamped > 100, "{clamped} clamped");
    }

    #[test]
    fn energy_derivatives_match_finite_differences() {
        let j = [0.7, -0.3, 0.2, -0.4]; // det < 0: a folded face
        let eps = 0.3;
        let (f, g, _) = energy_derivatives(&j, eps);
        assert!((f - energy(&j, eps)).abs() < 1e-12);
        for i in 0..4 {
            let h = 1e-6;
            let (mut a, mut b) = (j, j);
            a[i] += h;
            b[i] -= h;
            let fd = (energy(&a, eps) - energy(&b, eps)) / (2.0 * h);
            assert!(
                (fd - g[i]).abs() < 1e-5 * (1.0 + fd.abs()),
                "{i}: {fd} vs {}",
                g[i]
            );
        }
    }
}
