//! Branch points the global step left wound the wrong number of turns (see
//! [`super::miswound`]): a start for the repair that winds correctly.
//!
//! Why it happens: a branch point is fixed by the rounded gaps (eq. 2.40), up to about a cell
//! away from where the guiding field puts it. The global step's energy is a Dirichlet energy,
//! for which a single pinned point hardly matters: the ring follows the field, not the pinned
//! point, and when the rounding moved the branch point farther than its ring is wide, the
//! lattice point ends up outside the ring's image. The fan then turns 90° instead of 450° at a
//! −1/4 singularity (a neighbour wraps twice to make up for it), and since a winding changes
//! only through a degenerate face, the barrier of the repair keeps it so.
//!
//! What we do: minimise the same energy Σ w_f ‖J_f − I‖² over the few rings around such a
//! branch point, the region's edge held, with the faces near the branch point made stiff
//! (weights growing towards it). Stiff faces keep the shape of their target triangles, so the
//! ring is carried along with the branch point and wraps its lattice point by the cone angle;
//! the offset is spread over the softer outer rings. The result is kept only when the branch
//! point then winds correctly and at most [`MAX_ADDED_FOLDS`] faces more are folded; the repair
//! unfolds those.
//!
//! A second round runs on the final, fold-free map ([`super::rewind_left`]) for the branch points
//! still wound wrongly: their rewinding added too many folds, or the repair unwound them again.
//! Most of the latter are pairs of branch points a few rings apart, where rewinding one unwinds
//! the other. There the steps of [`WIDE_LADDER`] are wider and stiffer, a try may not wind any
//! other branch point wrongly, and when it would, those branch points are made centres of the
//! stiff region too and the solve is repeated ([`JOINT_TRIES`]).

use std::collections::HashMap;

use glam::DVec3;

use super::{
    MapSpace, NONE, corner_uv, faces_around, fan_turn, fan_turn_with, jacobian, jacobian_terms,
    number_unknowns, reference, unknowns_of, wound_by,
};
use crate::mesh::TriMesh;
use crate::param::rot::Rots;
use crate::sparse::{SparseBuilder, SpdSolver};

/// The stiffenings tried per branch point, in order, until one winds it correctly: (rings of
/// the region, stiffness S, stiff rings n). A face r rings out (its nearest corner; the fan is
/// ring 0) weighs 1 + S t² times its own weight, with t = 1 − r / rings for n = 0 and t = 1
/// within n rings, 0 beyond, otherwise. The soft one first: it adds the fewest folds for the
/// repair to undo (bunny, N = 4: 12 of its 16 branch points, 27 → 23 folds; the stiff one
/// alone 27 → 93 folds and half again the repair time).
const LADDER: [(usize, f64, usize); 2] = [(8, 10.0, 0), (8, 100.0, 1)];
/// Most folded faces a rewinding may add: a twist too tight for its region costs the repair
/// more than the rewinding gains (bunny ×16 at 1.1 M faces without a limit: 239 → 1477 folds
/// after rewinding and 11 s of repair; with it 3 s). More rings on fine meshes, where a fan is
/// a small part of a cell, was measured and rejected (docs/untangling.md).
const MAX_ADDED_FOLDS: i64 = 20;
/// The second round's stiffenings (after the repair, for branch points still wound wrongly):
/// stiffer than the first round's last step, and wider.
const WIDE_LADDER: [(usize, f64, usize); 2] = [(8, 100.0, 1), (12, 100.0, 1)];
/// Stiff solves per branch point and step of the second round: b alone, then with the branch
/// points each try wound wrongly added.
const JOINT_TRIES: usize = 4;
/// The second round's limit on the folds one rewinding adds. The repair's work after it grows
/// with them, most on fine meshes, where a fan is a small part of a cell (bunny ×16 at 1.1 M
/// faces, 26 branch points left: with 60 and steps up to 16 rings and S = 1000, 26 → 6 left in
/// 7 s more; with 30 and these two steps, 26 → 11 in 1.2 s; with 20, 26 → 18).
const WIDE_MAX_ADDED_FOLDS: i64 = 30;

/// How a rewinding round tries: its stiffenings in order, the most folds one rewinding may add,
/// and whether a try must leave every other branch point's winding as it was (joining those
/// it would unwind as centres, [`JOINT_TRIES`]).
pub(crate) struct Round {
    ladder: &'static [(usize, f64, usize)],
    max_added: i64,
    joint: bool,
}

/// The rewinding before the repair (from the global step's map).
pub(crate) const BEFORE_REPAIR: Round = Round {
    ladder: &LADDER,
    max_added: MAX_ADDED_FOLDS,
    joint: false,
};

/// The second rewinding, on the final fold-free map ([`super::rewind_left`]).
pub(crate) const ON_FINAL_MAP: Round = Round {
    ladder: &WIDE_LADDER,
    max_added: WIDE_MAX_ADDED_FOLDS,
    joint: true,
};

/// The held interior vertices of `uv` (branch points) whose fan turns by more than π off
/// `cones[v]`.
pub(crate) fn wrongly_wound(
    mesh: &TriMesh,
    space: &MapSpace,
    uv: &[[f64; 2]],
    cones: &[f64],
) -> Vec<usize> {
    (0..mesh.n_vertices())
        .filter(|&v| {
            !mesh.is_boundary_vertex(v)
                && !cones[v].is_nan()
                && space.var[mesh.vertex_halfedge(v)] == NONE
                && !wound_by(fan_turn(mesh, uv, v), cones[v])
        })
        .collect()
}

/// Rewinds the vertices `held` ([`wrongly_wound`]) in turn; returns those rewound. `guide`
/// are the frames of the field in the disk frames: the curl*-free ones degenerate next to
/// singularities, just where this works.
#[allow(clippy::too_many_arguments)]
pub(crate) fn rewind(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    guide: &[[DVec3; 2]],
    mean_area: f64,
    uv: &mut [[f64; 2]],
    cones: &[f64],
    held: Vec<usize>,
    round: &Round,
) -> Vec<usize> {
    let wrong = |uv: &[[f64; 2]], v: usize| !wound_by(fan_turn(mesh, uv, v), cones[v]);
    let mut done = Vec::new();
    for b in held {
        // An earlier one's region may have rewound it already.
        if !wrong(uv, b) {
            continue;
        }
        'ladder: for &step in round.ladder {
            // b alone; then, in the second round, b with the branch points its region unwound
            // (two near each other otherwise take turns: rewinding one unwinds the other)
            let mut centers = vec![b];
            for _ in 0..JOINT_TRIES {
                let Some(y) = stiff_solve(mesh, rots, space, guide, mean_area, uv, &centers, step)
                else {
                    continue 'ladder;
                };
                let trial = trial_of(mesh, rots, space, uv, cones, &y, &centers, round.joint);
                if trial.centers_ok
                    && trial.added <= round.max_added
                    && (!round.joint || trial.unwound_others.is_empty())
                {
                    for (v, yv) in &y {
                        for h in mesh.outgoing(*v) {
                            uv[h] = corner_uv(rots, space, h, *yv);
                        }
                    }
                    for c in centers {
                        if !done.contains(&c) {
                            done.push(c);
                        }
                    }
                    break 'ladder;
                }
                if !round.joint || trial.unwound_others.is_empty() {
                    break;
                }
                centers.extend(trial.unwound_others);
            }
        }
    }
    done
}

/// What a stiff solve `y` does: whether every one of `centers` winds correctly, how many folds it
/// adds, and (with `others`) which other branch points whose fans it moves it winds wrongly.
struct Trial {
    centers_ok: bool,
    added: i64,
    unwound_others: Vec<usize>,
}

#[allow(clippy::too_many_arguments)]
fn trial_of(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    uv: &[[f64; 2]],
    cones: &[f64],
    y: &[(usize, [f64; 2])],
    centers: &[usize],
    others: bool,
) -> Trial {
    let ok = |v: usize, t: f64| wound_by(t, cones[v]);
    // The trial map without copying the map: at 1.1 M faces a copy per try took seconds.
    let moved: HashMap<usize, [f64; 2]> = y.iter().copied().collect();
    let at = |c: usize| match moved.get(&mesh.from(c)) {
        Some(&yv) => corner_uv(rots, space, c, yv),
        None => uv[c],
    };
    let centers_ok = centers.iter().all(|&c| ok(c, fan_turn_with(mesh, c, at)));
    // Folds the rewinding adds, for the repair to undo: past a few it costs more than it gains
    // (a twist too tight for the region).
    let mut faces: Vec<usize> = y
        .iter()
        .flat_map(|(v, _)| mesh.outgoing(*v).map(|h| mesh.face_of(h)))
        .collect();
    faces.sort_unstable();
    faces.dedup();
    let area = |f: usize, after: bool| -> f64 {
        let q: [[f64; 2]; 3] =
            std::array::from_fn(|a| if after { at(3 * f + a) } else { uv[3 * f + a] });
        0.5 * ((q[1][0] - q[0][0]) * (q[2][1] - q[0][1])
            - (q[1][1] - q[0][1]) * (q[2][0] - q[0][0]))
    };
    let added = faces
        .iter()
        .map(|&f| i64::from(!(area(f, true) > 0.0)) - i64::from(!(area(f, false) > 0.0)))
        .sum::<i64>();
    if !others {
        return Trial {
            centers_ok,
            added,
            unwound_others: Vec::new(),
        };
    }
    let mut others: Vec<usize> = y
        .iter()
        .flat_map(|(v, _)| mesh.outgoing(*v).map(|h| mesh.to(h)))
        .filter(|&c| {
            !centers.contains(&c)
                && !moved.contains_key(&c)
                && !mesh.is_boundary_vertex(c)
                && !cones[c].is_nan()
                && space.var[mesh.vertex_halfedge(c)] == NONE
        })
        .collect();
    others.sort_unstable();
    others.dedup();
    let unwound_others = others
        .into_iter()
        .filter(|&c| ok(c, fan_turn(mesh, uv, c)) && !ok(c, fan_turn_with(mesh, c, at)))
        .collect();
    Trial {
        centers_ok,
        added,
        unwound_others,
    }
}

/// The minimiser of Σ s_f w_f ‖J_f − I‖² (J_f against the target triangle of `guide`) over
/// the free vertices within `rings` rings of `b`, everything else held; s_f from [`LADDER`].
#[allow(clippy::too_many_arguments)]
fn stiff_solve(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    guide: &[[DVec3; 2]],
    mean_area: f64,
    uv: &[[f64; 2]],
    centers: &[usize],
    (rings, stiffness, stiff_rings): (usize, f64, usize),
) -> Option<Vec<(usize, [f64; 2])>> {
    // Rings from the centers.
    let mut dist: HashMap<usize, usize> = centers.iter().map(|&c| (c, 0)).collect();
    let mut front = centers.to_vec();
    for d in 1..=rings {
        let mut next = Vec::new();
        for &v in &front {
            for h in mesh.outgoing(v) {
                for w in mesh.face(mesh.face_of(h)) {
                    if let std::collections::hash_map::Entry::Vacant(e) = dist.entry(w) {
                        e.insert(d);
                        next.push(w);
                    }
                }
            }
        }
        front = next;
    }
    let mut free: Vec<usize> = dist
        .iter()
        .filter(|&(&v, &d)| d < rings && space.var[mesh.vertex_halfedge(v)] != NONE)
        .map(|(&v, _)| v)
        .collect();
    free.sort_unstable();
    let slot: HashMap<usize, usize> = free.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    let (unknown, n) = number_unknowns(space, &free);
    if n == 0 {
        return None;
    }
    let faces = faces_around(mesh, &free);
    let y0: Vec<[f64; 2]> = free
        .iter()
        .map(|&v| unknowns_of(mesh, rots, space, uv, v))
        .collect();
    // The energy is quadratic in the unknowns: one Newton step from y0 is its minimiser.
    let mut g = vec![0.0; n];
    let mut hb = SparseBuilder::<f64>::with_capacity(n, 36 * faces.len() + n);
    let mut diag = 0.0;
    for &f in &faces {
        let r = reference(mesh, guide, f, mean_area);
        let ring = mesh
            .face(f)
            .iter()
            .map(|v| dist.get(v).copied().unwrap_or(rings))
            .min()
            .unwrap_or(rings);
        let t = if stiff_rings == 0 {
            1.0 - ring as f64 / rings as f64
        } else if ring <= stiff_rings {
            1.0
        } else {
            0.0
        };
        let w = 2.0 * r.weight * (1.0 + stiffness * t * t);
        let q: [[f64; 2]; 3] = std::array::from_fn(|a| {
            let c = 3 * f + a;
            match slot.get(&mesh.from(c)) {
                Some(&s) => corner_uv(rots, space, c, y0[s]),
                None => uv[c],
            }
        });
        let j = jacobian(&q, &r);
        let res = [j[0] - 1.0, j[1], j[2], j[3] - 1.0];
        let slots: [u32; 3] =
            std::array::from_fn(|a| slot.get(&mesh.from(3 * f + a)).map_or(NONE, |&s| s as u32));
        let dj = jacobian_terms(
            rots,
            space,
            &free,
            &unknown,
            [3 * f, 3 * f + 1, 3 * f + 2],
            slots,
            &r,
        );
        for (p, dp) in &dj {
            g[*p] += w * (0..4).map(|i| res[i] * dp[i]).sum::<f64>();
            for (q, dq) in &dj {
                let s = w * (0..4).map(|i| dp[i] * dq[i]).sum::<f64>();
                if p == q {
                    diag += s;
                }
                hb.add(*p, *q, s);
            }
        }
    }
    // Keeps the system definite where a vertex reaches no face term.
    let reg = 1e-9 * diag / n as f64 + 1e-300;
    for i in 0..n {
        hb.add(i, i, reg);
    }
    let m = hb.build().ok()?;
    let solver = SpdSolver::new(&m).ok()?;
    let rhs: Vec<f64> = g.iter().map(|x| -x).collect();
    let step = solver.solve(&rhs).ok()?;
    if step.iter().any(|x| !x.is_finite()) {
        return None;
    }
    Some(
        free.iter()
            .enumerate()
            .map(|(i, &v)| {
                let mut y = y0[i];
                for k in 0..2 {
                    if unknown[i][k] != NONE {
                        y[k] += step[unknown[i][k] as usize];
                    }
                }
                (v, y)
            })
            .collect(),
    )
}
