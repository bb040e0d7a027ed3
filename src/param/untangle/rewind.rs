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
//!
//! Where every stiff solve adds too many folds (fine meshes, where the region is a small part
//! of a cell), the branch point is rewound through its cone's power map instead
//! ([`power_solve`]): a Tutte embedding in the chart where the cone is a regular point.

use std::collections::{HashMap, HashSet};

use glam::DVec3;

use super::{
    MapSpace, NONE, corner_unknowns, corner_uv, faces_around, fan_turn, fan_turn_with, jacobian,
    jacobian_terms, number_unknowns, reference, unknowns_of, wound_by,
};
use crate::mesh::TriMesh;
use crate::param::rot::{Rots, apply};
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

/// The regions of [`power_solve`], in order, in rings: wider ones put a lattice point rounded
/// far from the region's middle farther inside.
const POWER_RINGS: [usize; 4] = [8, 12, 16, 24];
/// How far from a branch point [`power_solve`] looks for the vertex that wraps twice.
const PARTNER_RINGS: usize = 24;
/// Then regions of [`PowerRegion::Radius`]: (radius in lattice units, rings around the centres).
/// The rings make b lie between the lattice point and the rim, not on the region's edge, where
/// the Möbius map would have to move its small faces far (with only the centres' fans: igea at
/// 1500 vertices, N = 4, 10 → 8 mis-wound vertices; with 4 rings 8, with 8 rings 4; both, as
/// here, 2).
const POWER_RADII: [(f64, usize); 8] = [
    (0.5, 4),
    (0.75, 4),
    (1.0, 4),
    (1.5, 4),
    (0.5, 8),
    (0.75, 8),
    (1.0, 8),
    (1.5, 8),
];

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
        let mut wound = false;
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
                if trial.kept_in(round) {
                    place(mesh, rots, space, &y, uv);
                    for c in centers {
                        if !done.contains(&c) {
                            done.push(c);
                        }
                    }
                    wound = true;
                    break 'ladder;
                }
                if !round.joint || trial.unwound_others.is_empty() {
                    break;
                }
                centers.extend(trial.unwound_others);
            }
        }
        if wound {
            continue;
        }
        // The stiff solves failed: through the cone's power map ([`power_solve`]), around b and
        // the vertex wrapping twice near it (found once: a refused try leaves `uv` as it was).
        let centers: Vec<usize> = std::iter::once(b)
            .chain(double_wrap_near(mesh, space, uv, b))
            .collect();
        let regions = POWER_RINGS
            .iter()
            .map(|&r| PowerRegion::Rings(r))
            .chain(POWER_RADII.iter().map(|&(r, k)| PowerRegion::Radius(r, k)));
        for region in regions {
            let Some(y) = power_solve(mesh, rots, space, uv, cones[b], &centers, region) else {
                continue;
            };
            if trial_of(mesh, rots, space, uv, cones, &y, &[b], round.joint).kept_in(round) {
                place(mesh, rots, space, &y, uv);
                done.push(b);
                break;
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

impl Trial {
    /// Whether `round` keeps this try: its centers wind correctly, it adds few folds and (in a
    /// joint round) unwinds no other branch point.
    fn kept_in(&self, round: &Round) -> bool {
        self.centers_ok
            && self.added <= round.max_added
            && (!round.joint || self.unwound_others.is_empty())
    }
}

/// Writes the unknowns `y` into the corners of their vertices.
fn place(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    y: &[(usize, [f64; 2])],
    uv: &mut [[f64; 2]],
) {
    for (v, yv) in y {
        for h in mesh.outgoing(*v) {
            uv[h] = corner_uv(rots, space, h, *yv);
        }
    }
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
    let dist = rings_from(mesh, centers, rings);
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

/// A vertex off the mesh boundary whose corners are all unknowns.
fn movable(mesh: &TriMesh, space: &MapSpace, v: usize) -> bool {
    !mesh.is_boundary_vertex(v) && mesh.outgoing(v).all(|h| space.var[h] != NONE)
}

/// The nearest vertex within [`PARTNER_RINGS`] of branch point `b` (the lowest index among the
/// nearest) that may move and wraps twice: where the turn a branch point wound short misses
/// went ([`power_solve`]'s region holds both).
fn double_wrap_near(mesh: &TriMesh, space: &MapSpace, uv: &[[f64; 2]], b: usize) -> Option<usize> {
    rings_from(mesh, &[b], PARTNER_RINGS)
        .into_iter()
        .filter(|&(v, _)| {
            v != b && movable(mesh, space, v) && fan_turn(mesh, uv, v) > 1.5 * std::f64::consts::TAU
        })
        .min_by_key(|&(v, d)| (d, v))
        .map(|(v, _)| v)
}

/// The rewinding through the cone's power map, for a branch point `b` whose stiff solves add
/// too many folds (on fine meshes, where the region is a small part of a cell and the twist
/// folds many small faces).
///
/// Around a cone of angle Θ the map z ↦ ζ = z^α, α = 2π / Θ (z the position relative to the
/// branch point, its angle taken continuously), is single-valued and turns the cone into a
/// regular point. So: the region's rim (held) is carried to ζ, where it winds once around 0
/// when the rim winds Θ around the branch point; the vertices inside are placed by a Tutte
/// embedding there (uniform weights: over the 57 plain sweep solves they left 7 patched places
/// against 13 with cotangent weights), which winds every vertex once; and ζ ↦ ζ^{1/α} carries
/// them back. The branch point then turns by Θ and its neighbours by 2π wherever the embedding
/// did not fold, and the repair starts from that.
///
/// The embedding is solved with b free; b must then land on 0 (pinned at 0 in the solve, its
/// neighbours stay off to one side where the rounding put the lattice point off the region's
/// middle, the usual case, and its fan does not wind at all). Where the rim is star-shaped
/// around 0 in ζ, the embedding is made with the rim on the unit circle at its angles (a convex
/// rim, so no fold), b lands at some a inside, the Möbius map w = (x − a) / (1 − ā x) of the
/// disc carries it to 0, each point is turned along the circle so that the rim points get
/// their angles back (the inverse Möbius map's angle), and each ray from 0 is stretched to the
/// rim's radius there: every step is one-to-one, so b's fan winds once around 0 in ζ (faces
/// can still fold where a triangle is large against how far the steps move it). Otherwise the
/// embedding is made on the rim itself and translated by −a, the translation falling off
/// linearly along the rings from b to the rim. Going back, each vertex takes the branch of
/// ζ^{1/α} next to a placed neighbour's, and the rotation by a multiple of 2π / N between the
/// face's chart and the branch is read at that neighbour.
///
/// The regions ([`PowerRegion`]): rings around b and around the nearest vertex that wraps
/// twice (`centers`: b first, then that vertex if there is one), so that the rim winds by Θ;
/// where the rounding put b's lattice point far from b in the map (half a cell and more: the
/// rings' rim passes close by it on one side and does not wind around it until the rings reach
/// other singularities), the faces within a radius of the lattice point in the development and
/// a few rings around the centres, so that b lies between the lattice point and the rim.
///
/// `None` when the region holds another branch point, pinned vertex or the mesh boundary, is
/// not a disc, or its rim does not wind Θ around the branch point.
pub(super) fn power_solve(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    uv: &[[f64; 2]],
    cone: f64,
    centers: &[usize],
    region: PowerRegion,
) -> Option<Vec<(usize, [f64; 2])>> {
    use std::f64::consts::{PI, TAU};
    let b = *centers.first()?;
    if !(cone.is_finite() && cone > 0.0) || space.var[mesh.vertex_halfedge(b)] != NONE {
        return None;
    }
    let unit = TAU / rots.n as f64;
    let alpha = TAU / cone;
    let (faces, in_region, dev) = match region {
        PowerRegion::Rings(rings) => {
            let dist = rings_from(mesh, centers, rings);
            let inner: Vec<usize> = dist
                .iter()
                .filter(|&(_, &d)| d < rings)
                .map(|(&v, _)| v)
                .collect();
            // The region's faces: those at a vertex inside the rings; every other vertex of
            // them is on the rim or inside (a vertex `rings` away with all its faces in it).
            let faces = faces_around(mesh, &inner);
            let in_region: HashSet<usize> = faces.iter().copied().collect();
            let dev = develop(mesh, rots, space, uv, b, |g, _| in_region.contains(&g));
            (faces, in_region, dev)
        }
        PowerRegion::Radius(radius, k) => {
            // Grown through the development: a face joins when all its corners lie within
            // `radius` of the branch point's lattice point, or when it is near a centre.
            let near = rings_from(mesh, centers, k);
            let dev = develop(
                mesh,
                rots,
                space,
                uv,
                b,
                |g, at: &dyn Fn(usize) -> [f64; 2]| {
                    mesh.face(g)
                        .iter()
                        .any(|v| near.get(v).is_some_and(|&d| d < k))
                        || (0..3).all(|a| {
                            let z = at(3 * g + a);
                            z[0].hypot(z[1]) < radius
                        })
                },
            );
            let mut faces: Vec<usize> = dev.keys().copied().collect();
            faces.sort_unstable();
            let in_region: HashSet<usize> = faces.iter().copied().collect();
            (faces, in_region, dev)
        }
    };
    if dev.len() != faces.len() {
        return None;
    }
    let mut rim: HashMap<usize, usize> = HashMap::new();
    for &f in &faces {
        for a in 0..3 {
            let h = 3 * f + a;
            let inside = mesh
                .twin(h)
                .is_some_and(|t| in_region.contains(&mesh.face_of(t)));
            if !inside && rim.insert(mesh.from(h), h).is_some() {
                return None;
            }
        }
    }
    if rim.contains_key(&b) {
        return None;
    }
    let mut free: Vec<usize> = faces
        .iter()
        .flat_map(|&f| mesh.face(f))
        .filter(|&v| v != b && !rim.contains_key(&v))
        .collect();
    free.sort_unstable();
    free.dedup();
    let movable = |v: usize| movable(mesh, space, v) && space.free[v][0] && space.free[v][1];
    if free.is_empty() || !free.iter().all(|&v| movable(v)) {
        return None;
    }
    let slot: HashMap<usize, usize> = free.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    let turn = |k: i64, x: [f64; 2]| apply(rots.get(k), x);
    // How far inside each vertex is, for the translation of a rim that is not star-shaped.
    let from_b = rings_within(mesh, &[b], &in_region);
    let rim_vertices: Vec<usize> = rim.keys().copied().collect();
    let from_rim = rings_within(mesh, &rim_vertices, &in_region);
    if !free
        .iter()
        .all(|v| from_b.contains_key(v) && from_rim.contains_key(v))
    {
        return None;
    }
    let rel = |c: usize, x: [f64; 2]| -> [f64; 2] {
        let (p, k) = dev[&(c / 3)];
        turn(-k, [x[0] - p[0], x[1] - p[1]])
    };
    // The rim, one loop.
    let start = *rim.keys().min()?;
    let mut theta: HashMap<usize, f64> = HashMap::new();
    let (mut v, mut angle) = (start, {
        let z = rel(rim[&start], uv[rim[&start]]);
        z[1].atan2(z[0])
    });
    // Whether the angle increases all along (the rim star-shaped around 0 in ζ); the step
    // back to the start is judged against the start's angle plus the cone angle.
    let (mut increasing, mut last) = (true, angle);
    for _ in 0..rim.len() {
        theta.insert(v, angle);
        let h = rim[&v];
        let (x, y) = (rel(h, uv[h]), rel(mesh.next(h), uv[mesh.next(h)]));
        if x[0].hypot(x[1]) == 0.0 || y[0].hypot(y[1]) == 0.0 {
            return None;
        }
        last = angle;
        angle += (x[0] * y[1] - x[1] * y[0]).atan2(x[0] * y[0] + x[1] * y[1]);
        v = mesh.to(h);
        if v == start {
            break;
        }
        increasing &= angle > last;
    }
    if v != start || theta.len() != rim.len() || !((angle - theta[&start] - cone).abs() <= 0.25) {
        return None;
    }
    let star = increasing && theta[&start] + cone > last;
    // ζ on the rim, then the Tutte embedding inside.
    let zeta_of = |r: f64, t: f64| {
        let s = r.powf(alpha);
        [s * (alpha * t).cos(), s * (alpha * t).sin()]
    };
    let rim_zeta: HashMap<usize, [f64; 2]> = theta
        .iter()
        .map(|(&v, &t)| {
            let z = rel(rim[&v], uv[rim[&v]]);
            (v, zeta_of(z[0].hypot(z[1]), t))
        })
        .collect();
    let on_circle = |v: usize| {
        let p = alpha * theta[&v];
        [p.cos(), p.sin()]
    };
    let rim_at = |u: usize| -> Option<[f64; 2]> {
        if star {
            theta.contains_key(&u).then(|| on_circle(u))
        } else {
            rim_zeta.get(&u).copied()
        }
    };
    let n = free.len();
    let index = |u: usize| {
        if u == b {
            Some(n)
        } else {
            slot.get(&u).copied()
        }
    };
    let mut lap = SparseBuilder::<f64>::with_capacity(n + 1, 8 * (n + 1));
    let mut rhs = vec![[0.0; 2]; n + 1];
    for v in free.iter().copied().chain([b]) {
        let i = index(v)?;
        for h in mesh.outgoing(v) {
            let u = mesh.to(h);
            lap.add(i, i, 1.0);
            if let Some(j) = index(u) {
                lap.add(i, j, -1.0);
            } else {
                let z = rim_at(u)?;
                rhs[i][0] += z[0];
                rhs[i][1] += z[1];
            }
        }
    }
    let solver = SpdSolver::new(&lap.build().ok()?).ok()?;
    let xs = solver
        .solve(&rhs.iter().map(|r| r[0]).collect::<Vec<_>>())
        .ok()?;
    let ys = solver
        .solve(&rhs.iter().map(|r| r[1]).collect::<Vec<_>>())
        .ok()?;
    // Where the branch point landed.
    let a = [xs[n], ys[n]];
    // The rim's radius in ζ by angle, for the stretch along rays.
    let mut radii: Vec<(f64, f64)> = rim_zeta
        .iter()
        .map(|(v, z)| ((alpha * theta[v]).rem_euclid(TAU), z[0].hypot(z[1])))
        .collect();
    radii.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.total_cmp(&y.1)));
    let radius_at = |t: f64| -> f64 {
        let t = t.rem_euclid(TAU);
        let k = radii.partition_point(|r| r.0 <= t);
        let (lo, hi) = if k == 0 || k == radii.len() {
            let (l, h) = (radii[radii.len() - 1], radii[0]);
            (l, (h.0 + TAU, h.1))
        } else {
            (radii[k - 1], radii[k])
        };
        let t = if t < lo.0 { t + TAU } else { t };
        let s = if hi.0 > lo.0 {
            (t - lo.0) / (hi.0 - lo.0)
        } else {
            0.0
        };
        lo.1 + s * (hi.1 - lo.1)
    };
    let zeta = |v: usize| -> [f64; 2] {
        match slot.get(&v) {
            Some(&i) if star => {
                // w = (x − a) / (1 − ā x), its angle back to the rim's, its ray stretched.
                let x = [xs[i], ys[i]];
                let w = cdiv(csub(x, a), csub([1.0, 0.0], cmul(conj(a), x)));
                let (r, psi) = (w[0].hypot(w[1]), w[1].atan2(w[0]));
                let e = [psi.cos(), psi.sin()];
                let back = cdiv(cadd(e, a), cadd([1.0, 0.0], cmul(conj(a), e)));
                let t = back[1].atan2(back[0]);
                let s = r * radius_at(t);
                [s * t.cos(), s * t.sin()]
            }
            Some(&i) => {
                // Translated by −a, falling off linearly along the rings from b to the rim.
                let (db, dr) = (from_b[&v] as f64, from_rim[&v] as f64);
                let t = dr / (db + dr);
                [xs[i] - t * a[0], ys[i] - t * a[1]]
            }
            None if v == b => [0.0, 0.0],
            None => rim_zeta[&v],
        }
    };
    // Back through ζ^{1/α}, from the rim inwards.
    let mut y: Vec<Option<[f64; 2]>> = vec![None; n];
    let mut order: Vec<usize> = theta.keys().copied().collect();
    order.sort_unstable();
    let mut queue = std::collections::VecDeque::from(order);
    while let Some(u) = queue.pop_front() {
        let zu = zeta(u);
        let au = zu[1].atan2(zu[0]);
        for h in mesh.outgoing(u) {
            let w = mesh.to(h);
            let Some(&i) = slot.get(&w) else { continue };
            if y[i].is_some() {
                continue;
            }
            // u's position in this face's chart: held on the rim, placed inside.
            let at_u = match slot.get(&u) {
                Some(&s) => corner_uv(rots, space, h, y[s]?),
                None => uv[h],
            };
            let zu_dev = rel(h, at_u);
            let ru = zu[0].hypot(zu[1]).powf(1.0 / alpha);
            if ru == 0.0 {
                continue;
            }
            // The face's rotation against the branch at u: a multiple of 2π / N.
            let raw = zu_dev[1].atan2(zu_dev[0]) - au / alpha;
            let rho = (raw / unit).round() * unit;
            if ((raw - rho) / unit).abs() > 0.25 {
                return None;
            }
            let zw = zeta(w);
            let mut aw = zw[1].atan2(zw[0]) - au;
            aw -= TAU * ((aw + PI) / TAU).floor();
            let (rw, tw) = (
                zw[0].hypot(zw[1]).powf(1.0 / alpha),
                (au + aw) / alpha + rho,
            );
            let (p, k) = dev[&mesh.face_of(h)];
            let d = turn(k, [rw * tw.cos(), rw * tw.sin()]);
            let c = mesh.next(h);
            y[i] = Some(corner_unknowns(rots, space, c, [p[0] + d[0], p[1] + d[1]]));
            queue.push_back(w);
        }
    }
    free.iter()
        .zip(&y)
        .map(|(&v, yv)| yv.map(|yv| (v, yv)))
        .collect()
}

// Complex arithmetic on [re, im] for the Möbius map.
fn cadd(x: [f64; 2], y: [f64; 2]) -> [f64; 2] {
    [x[0] + y[0], x[1] + y[1]]
}

fn csub(x: [f64; 2], y: [f64; 2]) -> [f64; 2] {
    [x[0] - y[0], x[1] - y[1]]
}

fn cmul(x: [f64; 2], y: [f64; 2]) -> [f64; 2] {
    [x[0] * y[0] - x[1] * y[1], x[0] * y[1] + x[1] * y[0]]
}

fn conj(x: [f64; 2]) -> [f64; 2] {
    [x[0], -x[1]]
}

fn cdiv(x: [f64; 2], y: [f64; 2]) -> [f64; 2] {
    let d = y[0] * y[0] + y[1] * y[1];
    [
        (x[0] * y[0] + x[1] * y[1]) / d,
        (x[1] * y[0] - x[0] * y[1]) / d,
    ]
}

/// The region of a [`power_solve`].
#[derive(Clone, Copy, Debug)]
pub(super) enum PowerRegion {
    /// The faces at vertices fewer than this many rings from the centres.
    Rings(usize),
    /// The faces whose corners all lie within this distance (in lattice units) of the branch
    /// point's lattice point in the development, grown from the branch point, and those at
    /// vertices fewer than this many rings from the centres.
    Radius(f64, usize),
}

/// The faces around branch point `b` developed through the transitions into the chart of a face
/// of its fan, grown breadth-first through the faces `accept` takes (given a corner's position
/// relative to the branch point in that chart): in face f a corner's position relative to the
/// branch point is R^(−k_f) (ψ_c − p_f).
fn develop(
    mesh: &TriMesh,
    rots: &Rots,
    space: &MapSpace,
    uv: &[[f64; 2]],
    b: usize,
    accept: impl Fn(usize, &dyn Fn(usize) -> [f64; 2]) -> bool,
) -> HashMap<usize, ([f64; 2], i64)> {
    let turn = |k: i64, x: [f64; 2]| apply(rots.get(k), x);
    let f0 = mesh.face_of(mesh.vertex_halfedge(b));
    let mut dev: HashMap<usize, ([f64; 2], i64)> = HashMap::new();
    dev.insert(f0, (uv[mesh.vertex_halfedge(b)], 0));
    let mut queue = std::collections::VecDeque::from([f0]);
    while let Some(f) = queue.pop_front() {
        let (p, k) = dev[&f];
        for a in 0..3 {
            let h = 3 * f + a;
            let Some(t) = mesh.twin(h) else { continue };
            let g = mesh.face_of(t);
            if dev.contains_key(&g) {
                continue;
            }
            // A corner of the edge that is an unknown carries the transition f → g.
            let pair = [(h, mesh.next(t)), (mesh.next(h), t)]
                .into_iter()
                .find(|&(cf, cg)| space.var[cf] != NONE && space.var[cg] != NONE);
            let Some((cf, cg)) = pair else { continue };
            let r = i64::from(space.rot[cg]) - i64::from(space.rot[cf]);
            let q = turn(r, [p[0] - space.consts[cf][0], p[1] - space.consts[cf][1]]);
            let pg = [space.consts[cg][0] + q[0], space.consts[cg][1] + q[1]];
            let kg = k + r;
            let at = |c: usize| turn(-kg, [uv[c][0] - pg[0], uv[c][1] - pg[1]]);
            if accept(g, &at) {
                dev.insert(g, (pg, kg));
                queue.push_back(g);
            }
        }
    }
    dev
}

/// Ring distances from `from` through the faces of `region` (every vertex of them).
fn rings_within(mesh: &TriMesh, from: &[usize], region: &HashSet<usize>) -> HashMap<usize, usize> {
    let mut dist: HashMap<usize, usize> = from.iter().map(|&c| (c, 0)).collect();
    let mut queue: std::collections::VecDeque<usize> = from.iter().copied().collect();
    while let Some(v) = queue.pop_front() {
        for h in mesh.outgoing(v) {
            if !region.contains(&mesh.face_of(h)) {
                continue;
            }
            let d = dist[&v] + 1;
            for w in mesh.face(mesh.face_of(h)) {
                if let std::collections::hash_map::Entry::Vacant(e) = dist.entry(w) {
                    e.insert(d);
                    queue.push_back(w);
                }
            }
        }
    }
    dist
}

/// Ring distances from `centers` up to `rings`.
fn rings_from(mesh: &TriMesh, centers: &[usize], rings: usize) -> HashMap<usize, usize> {
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
    dist
}
