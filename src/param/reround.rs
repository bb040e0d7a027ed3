//! Re-rounding where the injectivity repair left folds (issue #15): gaps moved by one lattice
//! step near the folds, the best candidates repaired again. Without curves any gap may move
//! ([`QuadCover::reround`]); under constraint curves only steps that keep the combinatorial
//! equations C_c w = 0 (eq. 4.8, 4.9) and the geometric curves on their lines
//! ([`QuadCover::reround_curves`]). The same for vertices a fold-free map winds wrongly
//! ([`QuadCover::reround_windings`], [`QuadCover::reround_curve_windings`]).

use super::CancelCheck;
use super::batched::first_taken;
use super::constrained::{self, ConstrainedStep};
use super::constraints::Traced;
use super::{
    Lattice, LocalSolution, ParamError, Parameterization, QuadCover, Rerounded, cut, untangle,
};
use crate::mesh::TriMesh;
use rayon::prelude::*;

/// Gaps tried per round when the repair left folds ([`QuadCover::reround`]), the best
/// candidates of them repaired per round, and the rounds.
const REROUND_GAPS: usize = 8;
/// Curve values tried per round of the re-rounding under curves ([`values_near`]).
const REROUND_VALUES: usize = 4;
const REROUND_TRIES: usize = 3;
const REROUND_ROUNDS: usize = 6;
/// Rounds of [`QuadCover::reround_windings`].
const WINDING_ROUNDS: usize = 4;
/// [`QuadCover::reround_windings`] runs for at most this many wrongly wound vertices: more
/// are a detailed scan on a coarse grid, where the pass is slow for little (igea at 1500
/// vertices, N = 4: 10 → 42 s of repair for 18 → 16).
const WINDING_MAX_VERTICES: usize = 12;
/// Nor on meshes larger than this: every candidate is ranked by global solves and the best
/// are repaired again, all at full size (the bunny ×16, 1.1 M faces, without pure quads:
/// repair 5.7 s leaving 6 mis-wound vertices without it, 30 s leaving 2 with it; igea, 270 k
/// faces, keeps it).
const WINDING_MAX_FACES: usize = 500_000;
/// When at most this many vertices are wound wrongly (a branch point and the neighbour that
/// took its turn: one patched place in the remesh), [`QuadCover::reround_windings`] tries every
/// ranked candidate, not only the best [`REROUND_TRIES`] (a branch point's corners depend on 2
/// or 3 gaps: 8 to 18 candidates). The cerebral vessels' last pair (N = 6, 1500 vertices) is
/// parted by the 12th. With 4, the 72 cases of tests/untangle.rs end with no wrongly wound
/// vertex (4 left with 2), but their repairs take 33 s instead of 25 (the bunny, N = 6 at 1500
/// vertices, 1.2 → 6.0 s, for a map it already had none in).
const WINDING_LAST: usize = 2;
/// Rings around the wrongly wound vertices over which candidates are ranked.
const WINDING_RANK_RINGS: usize = 4;
/// A re-rounded map is kept only with a conformal distortion (99th percentile) at most this
/// factor above the map it replaces (issue #15's 5 %): parting two singularities rounded onto
/// one lattice point moves one by a whole step of 2Z², and on spot at 1500 vertices that took
/// the p99 from 2.49 (the crowded try it spared) to 3.97.
const WINDING_P99_SLACK: f64 = 1.05;
/// Faces walked from a wrongly wound branch point, through one seamless chart, in search of a
/// singularity rounded onto its lattice point ([`collided`]): the far one of igea's pairs at
/// the default density sits about 1 500 faces away (4.7 cells in space); 600 missed it.
const COLLISION_FACES: usize = 5000;

/// Gaps per cut path.
type Gaps = Vec<[f64; 2]>;
/// [`QuadCover::ranked_steps`]: the base map and the stepped gaps, best first.
type RankedSteps = (Vec<[f64; 2]>, Vec<Gaps>);
/// The global map's responses to a unit of gap coordinates ((loop, coordinate)), kept across
/// the rounds of one re-rounding.
type Responses<'a> = std::collections::HashMap<(usize, usize), super::global::GapResponse<'a>>;

impl QuadCover {
    /// The gaps the held corners near the folded faces depend on, at most [`REROUND_GAPS`]: the
    /// corners of the faces around the folded faces' vertices (the other held corner of a
    /// stuck face may sit across an edge, or beyond a vertex between them), stuck faces first.
    fn gaps_near(&self, mesh: &TriMesh, stuck: &[usize], folds: &[usize]) -> Vec<usize> {
        let stuck: std::collections::HashSet<usize> = stuck.iter().copied().collect();
        let (mut order, rest): (Vec<usize>, Vec<usize>) =
            folds.iter().partition(|f| stuck.contains(f));
        order.extend(rest);
        self.gaps_of_corners(order.iter().flat_map(|&f| {
            (3 * f..3 * f + 3)
                .flat_map(|h| mesh.outgoing(mesh.from(h)))
                .flat_map(|h| [h, mesh.next(h), mesh.prev(h)])
                .collect::<Vec<_>>()
        }))
    }

    /// The gaps the held corners among `corners` depend on, each once, in order of first
    /// appearance, at most [`REROUND_GAPS`].
    fn gaps_of_corners(&self, corners: impl Iterator<Item = usize>) -> Vec<usize> {
        let mut candidates: Vec<usize> = corners
            .filter(|&c| self.global.corner_var[c] == cut::NONE)
            .flat_map(|c| self.global.corner_lin[c].0.iter().map(|x| x.0 as usize))
            .collect();
        let mut seen = std::collections::HashSet::new();
        candidates.retain(|k| seen.insert(*k));
        candidates.truncate(REROUND_GAPS);
        candidates
    }

    /// The repair's report for a re-rounded map `uv`: the first repair's counts and time, the
    /// stuck faces of the new map.
    fn repair_of(
        &self,
        mesh: &TriMesh,
        space: &untangle::MapSpace,
        uv: &[[f64; 2]],
        first: &untangle::Repair,
    ) -> untangle::Repair {
        untangle::Repair {
            before: first.before,
            ms: first.ms,
            rewound: first.rewound,
            stuck: untangle::folded(uv)
                .into_iter()
                .filter(|&f| untangle::stuck(mesh, &self.rots, space, uv, f))
                .collect(),
        }
    }

    /// Folds the repair left, stuck ones (two branch points rounded onto one lattice point: no
    /// motion of the vertices can undo them) or not (a branch point rounded so far from where
    /// its ring wants it that the folds it causes outgrow the repair's regions): the gaps the
    /// held corners around them depend on are moved by one lattice step, one at a time. The
    /// candidates are ranked by the global map they give (stuck faces, folds, rounding error),
    /// and the best [`REROUND_TRIES`] are repaired in turn: the repaired map plus the change of
    /// the global map (still seamless: both are maps of the global step's form), so that only
    /// the folds near the moved branch points are repaired again. The first with fewer folds
    /// than the current map is kept; rounds go on until no fold is left or nothing helps.
    /// Returns the changed gaps.
    pub(super) fn reround(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        gaps: &mut Vec<[f64; 2]>,
        uv: &mut Vec<[f64; 2]>,
        repair: &mut untangle::Repair,
        cancel: CancelCheck<'_>,
    ) -> Result<Vec<Rerounded>, ParamError> {
        let first = gaps.clone();
        // The state with the fewest folds so far: a round may trade folds for fewer stuck
        // faces, which only later rounds can turn into fewer folds.
        let mut best = (
            untangle::folded(uv).len(),
            gaps.clone(),
            uv.clone(),
            repair.clone(),
        );
        let mut known = Responses::new();
        for _ in 0..REROUND_ROUNDS {
            let folds_now = untangle::folded(uv);
            if folds_now.len() < best.0 {
                best = (folds_now.len(), gaps.clone(), uv.clone(), repair.clone());
            }
            if folds_now.is_empty() || cancel() {
                break;
            }
            let candidates = self.gaps_near(mesh, &repair.stuck, &folds_now);
            // Stuck faces must become fewer; without stuck faces any candidate may help.
            let stuck_now = repair.stuck.len();
            let (base, ranked) = self.ranked_steps(
                mesh,
                local,
                gaps,
                &candidates,
                &mut known,
                |g, base, shift| {
                    let u: Vec<[f64; 2]> = (0..base.len())
                        .map(|c| {
                            let d = shift(c);
                            [base[c][0] + d[0], base[c][1] + d[1]]
                        })
                        .collect();
                    let space = self.global.map_space(mesh.n_vertices(), g);
                    let (stuck, folds) = untangle::count_stuck(mesh, &self.rots, &space, &u);
                    (stuck < stuck_now || stuck_now == 0).then_some((stuck, folds))
                },
            )?;
            let mut kept = false;
            'tries: for (i, g) in ranked.into_iter().take(REROUND_TRIES).enumerate() {
                let fresh = self.global_uv(mesh, local, &g)?;
                let space = self.global.map_space(mesh.n_vertices(), &g);
                // The repaired map moved by the change of the global map; for the best
                // candidate also the new global map itself, repaired from scratch (either
                // start wins on some meshes: spot at 1500 vertices, N = 4 and N = 6).
                let moved: Vec<[f64; 2]> = (0..uv.len())
                    .map(|c| std::array::from_fn(|k| uv[c][k] + fresh[c][k] - base[c][k]))
                    .collect();
                let starts = if i == 0 {
                    vec![moved, fresh]
                } else {
                    vec![moved]
                };
                for mut u in starts {
                    if cancel() {
                        break 'tries;
                    }
                    self.untangle(mesh, local, &space, None, &mut u, cancel);
                    let after = untangle::count_stuck(mesh, &self.rots, &space, &u);
                    if after < (stuck_now, folds_now.len()) {
                        *gaps = g;
                        *uv = u;
                        *repair = self.repair_of(mesh, &space, uv, repair);
                        kept = true;
                        break 'tries;
                    }
                }
            }
            if !kept {
                break;
            }
        }
        if untangle::folded(uv).len() >= best.0 {
            (_, *gaps, *uv, *repair) = best;
        }
        Ok(changed(&first, gaps))
    }

    /// Every change of one of the gaps `candidates` by one lattice step, ranked by `score(g,
    /// base, shift)` (the stepped gaps, the map of `gaps`, and per corner the change of the map
    /// the step makes; `None` drops the step), then by the rounding error. The map is affine in
    /// the gaps, so two solves per gap give the map of every step of it (to rounding: good
    /// enough for ranking; a kept map is solved for exactly). Returns the base map and the
    /// stepped gaps, best first.
    #[allow(clippy::too_many_arguments)]
    fn ranked_steps<'a>(
        &'a self,
        mesh: &TriMesh,
        local: &LocalSolution,
        gaps: &[[f64; 2]],
        candidates: &[usize],
        known: &mut Responses<'a>,
        mut score: impl FnMut(
            &[[f64; 2]],
            &[[f64; 2]],
            &dyn Fn(usize) -> [f64; 2],
        ) -> Option<(usize, usize)>,
    ) -> Result<RankedSteps, ParamError> {
        let error = |g: &[[f64; 2]]| -> f64 {
            g.iter()
                .zip(&local.gaps)
                .map(|(a, b)| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2))
                .sum()
        };
        let base = self.global_uv(mesh, local, gaps)?;
        // The responses do not depend on the gaps: those of earlier rounds are kept.
        let units: Vec<(usize, usize)> = candidates
            .iter()
            .flat_map(|&k| [(k, 0), (k, 1)])
            .filter(|u| !known.contains_key(u))
            .collect();
        let solved = self.global.responses(mesh, &self.rots, &units)?;
        known.extend(units.into_iter().zip(solved));
        let mut ranked: Vec<((usize, usize, f64), Gaps)> = Vec::new();
        for &k in candidates {
            let (d0, d1) = (&known[&(k, 0)], &known[&(k, 1)]);
            // Steps that keep the gap on its lattice: the coarser of the two.
            let steps = match self.gap_lattices[k] {
                Lattice::TwoG6 | Lattice::TurnedG6 | Lattice::TwoTurnedG6 => {
                    self.gap_lattices[k].steps()
                }
                _ => self.lattice.steps(),
            };
            for d in steps {
                let mut g = gaps.to_vec();
                g[k] = [g[k][0] + d[0], g[k][1] + d[1]];
                let shift = |c: usize| -> [f64; 2] {
                    let (a, b) = (d0.at(c), d1.at(c));
                    std::array::from_fn(|i| d[0] * a[i] + d[1] * b[i])
                };
                if let Some((a, b)) = score(&g, &base, &shift) {
                    let e = error(&g);
                    ranked.push(((a, b, e), g));
                }
            }
        }
        ranked.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap_or(std::cmp::Ordering::Equal));
        Ok((base, ranked.into_iter().map(|r| r.1).collect()))
    }

    /// Vertices the final, fold-free map still winds wrongly ([`untangle::miswound`]) after
    /// the rewinding: a branch point rounded farther from where its ring wants it than the
    /// rewinding can carry the ring. The gaps the branch points' own corners depend on are
    /// moved by one lattice step, one at a time; the candidates are ranked by the repaired map
    /// plus the change of the global map they give, within [`WINDING_RANK_RINGS`] rings of the
    /// wrongly wound vertices (wrongly wound vertices, folds, rounding error), and the best
    /// [`REROUND_TRIES`] (every one for the last [`WINDING_LAST`]) are repaired from there
    /// (rewinding included). The first that leaves no fold and fewer wrongly wound vertices is
    /// kept; rounds go on until none is left or nothing helps. For the last pair, when nothing
    /// leaves fewer, one try whose wrongly wound vertices are all new is taken once (the pair
    /// parted at the cost of others), with a round more; the state before it comes back
    /// unless a later round gets below its count (igea, N = 4: 1 patched place → 0). Runs only
    /// for a few such vertices ([`WINDING_MAX_VERTICES`]).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn reround_windings(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        cones: &[f64],
        gaps: &mut Vec<[f64; 2]>,
        uv: &mut Vec<[f64; 2]>,
        repair: &mut untangle::Repair,
        cancel: CancelCheck<'_>,
    ) -> Result<(), ParamError> {
        let mut known = Responses::new();
        // The state before a sideways step (below), restored when no later round gets below
        // its count.
        let mut before_sideways: Option<(usize, Gaps, Vec<[f64; 2]>, usize)> = None;
        // (a sideways step gives one round more)
        for round in 0..=WINDING_ROUNDS {
            let wrong = untangle::miswound(mesh, uv, cones);
            if (round == WINDING_ROUNDS && before_sideways.is_none())
                || wrong.is_empty()
                || wrong.len() > WINDING_MAX_VERTICES
                || !untangle::folded(uv).is_empty()
                || cancel()
            {
                break;
            }
            // Singularities the rounding put on the lattice point of a wrongly wound one: no
            // map winds both (the fans of two cones at one point cover it twice), so the steps
            // that part them come first, and the gaps their corners depend on.
            let pairs = collided(mesh, uv, cones, &wrong);
            // The gaps the wrongly wound branch points' own corners depend on.
            let candidates = self.gaps_of_corners(
                pairs
                    .iter()
                    .flat_map(|&(b, s)| [b, s])
                    .chain(wrong.iter().flat_map(|&v| mesh.outgoing(v))),
            );
            // Ranked by the windings and folds near them only: a scan of the whole mesh per
            // candidate step cost igea (270 k faces) a second per round.
            let near = untangle::vertices_within(mesh, &wrong, WINDING_RANK_RINGS);
            let near_faces = untangle::faces_around(mesh, &near);
            let (base, ranked) =
                self.ranked_steps(mesh, local, gaps, &candidates, &mut known, |_, _, shift| {
                    // The repaired map moved by the step, where it matters.
                    let at = |c: usize| -> [f64; 2] {
                        let d = shift(c);
                        [uv[c][0] + d[0], uv[c][1] + d[1]]
                    };
                    let (wound, folds) = wound_and_folded(mesh, cones, &near, &near_faces, at);
                    let together = pairs
                        .iter()
                        .filter(|&&(b, s)| coincident(at(b), at(s)))
                        .count();
                    Some((wound + 2 * together, folds))
                })?;
            let p99 = |uv: &[[f64; 2]]| super::metrics::map_conformal_p99(mesh, uv);
            let p99_now = p99(uv);
            let mut kept = false;
            // The last pair parted at the cost of as many other wrongly wound vertices: taken
            // once, when no try leaves fewer, for the next round to part those.
            let mut sideways: Option<(Gaps, Vec<[f64; 2]>, usize)> = None;
            let tries = if wrong.len() <= WINDING_LAST {
                ranked.len()
            } else {
                REROUND_TRIES
            };
            let now_uv: &[[f64; 2]] = uv;
            let mut taken: Option<(Gaps, Vec<[f64; 2]>, usize)> = None;
            let mut failed = None;
            first_taken(
                ranked.into_iter().take(tries).collect(),
                cancel,
                |g: Gaps| -> Result<_, ParamError> {
                    let fresh = self.global_uv(mesh, local, &g)?;
                    let space = self.global.map_space(mesh.n_vertices(), &g);
                    let (u, r) = self
                        .repaired_try(mesh, local, &space, cones, now_uv, &fresh, &base, cancel);
                    let fine =
                        untangle::folded(&u).is_empty() && p99(&u) <= WINDING_P99_SLACK * p99_now;
                    let now = if fine {
                        untangle::miswound(mesh, &u, cones)
                    } else {
                        Vec::new()
                    };
                    Ok((g, u, r.rewound, fine, now))
                },
                |outcome| {
                    let (g, u, rewound, fine, now) = match outcome {
                        Ok(o) => o,
                        Err(e) => {
                            failed = Some(e);
                            return true;
                        }
                    };
                    if !fine {
                        return false;
                    }
                    if now.len() < wrong.len() {
                        taken = Some((g, u, rewound));
                        return true;
                    }
                    if sideways.is_none()
                        && before_sideways.is_none()
                        && wrong.len() <= WINDING_LAST
                        && now.len() == wrong.len()
                        && now.iter().all(|v| wrong.binary_search(v).is_err())
                    {
                        sideways = Some((g, u, rewound));
                    }
                    false
                },
            );
            if let Some(e) = failed {
                return Err(e);
            }
            if let Some((g, u, rewound)) = taken {
                *gaps = g;
                *uv = u;
                repair.rewound += rewound;
                kept = true;
            }
            if !kept && let Some((g, u, rewound)) = sideways {
                before_sideways = Some((wrong.len(), gaps.clone(), uv.clone(), repair.rewound));
                *gaps = g;
                *uv = u;
                repair.rewound += rewound;
                kept = true;
            }
            if !kept {
                break;
            }
        }
        if let Some((count, g, u, rewound)) = before_sideways
            && untangle::miswound(mesh, uv, cones).len() >= count
        {
            *gaps = g;
            *uv = u;
            repair.rewound = rewound;
        }
        Ok(())
    }

    /// [`Self::reround_windings`] on a finished plain map `p` (no curves, no poles) solved on
    /// `frames`: the local step again (the same on the same frames), the windings re-rounded,
    /// and the report completed again when a gap moved.
    pub(super) fn reround_windings_of(
        &self,
        mesh: &TriMesh,
        frames: &[[glam::DVec3; 2]],
        p: Parameterization,
        cancel: CancelCheck<'_>,
    ) -> Result<Parameterization, ParamError> {
        // Not under curves (the gaps would move without their equations) nor with poles.
        if !p.curves.is_empty()
            || !p.poles.is_empty()
            || p.flipped_faces > 0
            || p.miswound.is_empty()
            || p.miswound.len() > WINDING_MAX_VERTICES
            || mesh.n_faces() > WINDING_MAX_FACES
        {
            return Ok(p);
        }
        let t = std::time::Instant::now();
        let local = self.local_step(mesh, frames)?;
        let cones = super::cones(mesh, &p.singularities);
        let (mut gaps, mut uv) = (p.gaps.clone(), p.uv.clone());
        let mut repair = untangle::Repair {
            before: p.flipped_faces_before_repair,
            ..Default::default()
        };
        self.reround_windings(
            mesh,
            &local,
            &cones,
            &mut gaps,
            &mut uv,
            &mut repair,
            cancel,
        )?;
        if cancel() {
            return Err(ParamError::Cancelled);
        }
        let spent = t.elapsed().as_secs_f64() * 1e3;
        if gaps == p.gaps {
            let mut p = p;
            p.timings.repair_ms += spent;
            return Ok(p);
        }
        // The gaps as the global step rounded them, before any re-rounding.
        let mut rounded = p.gaps.clone();
        for r in &p.rerounded_gaps {
            rounded[r.path] = r.from;
        }
        let plain = super::PlainMap {
            frames,
            local: &local,
            rounded: &rounded,
            global_ms: 0.0,
        };
        let mut q = self.complete_plain(mesh, &plain, p.singularities.clone(), uv, gaps, &repair);
        q.crowded_refinement = p.crowded_refinement.clone();
        q.timings = p.timings;
        q.timings.repair_ms += spent;
        Ok(q)
    }

    /// The global step's map of the integer unknowns `w` under the curves: with geometric
    /// curves the constrained solve (`step`'s factorization when given), otherwise the plain
    /// one.
    pub(super) fn curve_map(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        traced: &Traced,
        step: Option<&ConstrainedStep>,
        w: &[f64],
    ) -> Result<(Vec<[f64; 2]>, untangle::MapSpace), ParamError> {
        let gaps = traced.gaps(w);
        if traced.has_geometric() {
            let fixes = traced.fixes(w);
            match step {
                Some(step) => step.solve(&gaps, &fixes),
                None => constrained::solve(
                    mesh,
                    &self.cut,
                    &self.global,
                    &self.rots,
                    &local.disk,
                    &gaps,
                    &fixes,
                ),
            }
        } else {
            let uv = self.global_uv(mesh, local, &gaps)?;
            Ok((uv, self.global.map_space(mesh.n_vertices(), &gaps)))
        }
    }

    /// [`QuadCover::reround`] under constraint curves: a gap coordinate near the folds moves by
    /// one lattice step, and the curve values c_κ (other gaps only if they must) follow so that
    /// the combinatorial equations C_c w = 0 still hold ([`Traced::stepped`]); the lines of
    /// geometric curves move with their values and stay exact. On fandisk this separates two
    /// opposite branch points of one crease that the rounding put on one lattice point. Each
    /// candidate is solved with the curves' lines fixed, on one factorization
    /// ([`ConstrainedStep`]), ranked by its unrepaired map (stuck faces, folds, rounding
    /// error); the best [`REROUND_TRIES`] are repaired, and the first with fewer (stuck,
    /// folded) faces is kept. Updates the unknowns `w`, the map and the repair's counts;
    /// returns the changed gaps.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn reround_curves(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        traced: &Traced,
        factored: Option<&ConstrainedStep>,
        w: &mut Vec<f64>,
        uv: &mut Vec<[f64; 2]>,
        repair: &mut untangle::Repair,
        cancel: CancelCheck<'_>,
    ) -> Result<Vec<Rerounded>, ParamError> {
        let first = traced.gaps(w);
        let measured: Vec<f64> = local
            .gaps
            .iter()
            .flat_map(|&g| traced.lattice_coords(g))
            .collect();
        let error =
            |w: &[f64]| -> f64 { measured.iter().zip(w).map(|(a, b)| (a - b).powi(2)).sum() };
        for _ in 0..REROUND_ROUNDS {
            let folds_now = untangle::folded(uv);
            if folds_now.is_empty() || cancel() {
                break;
            }
            let now = (repair.stuck.len(), folds_now.len());
            type Ranked = (
                (usize, usize, f64),
                Vec<f64>,
                Vec<[f64; 2]>,
                untangle::MapSpace,
            );
            let unknowns: Vec<usize> = self
                .gaps_near(mesh, &repair.stuck, &folds_now)
                .into_iter()
                .flat_map(|k| [2 * k, 2 * k + 1])
                .chain(values_near(mesh, traced, &repair.stuck, &folds_now))
                .collect();
            let steps = unit_steps(traced, w, &unknowns);
            if cancel() {
                return Ok(Vec::new());
            }
            // Each candidate's map is a solve on the one factorization: side by side.
            let mut ranked: Vec<Ranked> = steps
                .into_par_iter()
                .map(|w2| -> Result<Option<Ranked>, ParamError> {
                    let (u, space) = self.curve_map(mesh, local, traced, factored, &w2)?;
                    let (stuck, folds) = untangle::count_stuck(mesh, &self.rots, &space, &u);
                    Ok((stuck < now.0 || now.0 == 0).then(|| {
                        let e = error(&w2);
                        ((stuck, folds, e), w2, u, space)
                    }))
                })
                .collect::<Result<Vec<_>, _>>()?
                .into_iter()
                .flatten()
                .collect();
            ranked.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap_or(std::cmp::Ordering::Equal));
            // The repaired map moved by the change of the global map: only the folds near the
            // moved branch points are repaired again. (Repairing the candidate's global map
            // from scratch as well, as `reround` does for its best, gave the same folds on
            // fandisk at 40°, 50° and 60° in more time.)
            let (base, _) = self.curve_map(mesh, local, traced, factored, w)?;
            let now_uv: &[[f64; 2]] = uv;
            let mut taken = None;
            first_taken(
                ranked.into_iter().take(REROUND_TRIES).collect(),
                cancel,
                |(_, w2, fresh, space): Ranked| {
                    let mut u: Vec<[f64; 2]> = (0..now_uv.len())
                        .map(|c| std::array::from_fn(|k| now_uv[c][k] + fresh[c][k] - base[c][k]))
                        .collect();
                    self.untangle(mesh, local, &space, None, &mut u, cancel);
                    let after = untangle::count_stuck(mesh, &self.rots, &space, &u);
                    (after < now).then_some((w2, u, space))
                },
                |outcome| {
                    let kept = outcome.is_some();
                    taken = outcome;
                    kept
                },
            );
            let Some((w2, u, space)) = taken else {
                break;
            };
            *w = w2;
            *uv = u;
            *repair = self.repair_of(mesh, &space, uv, repair);
        }
        Ok(changed(&first, &traced.gaps(w)))
    }
}

impl QuadCover {
    /// A windings re-rounding's try: the repaired map `uv` moved by the change of the global
    /// map (`base` → `fresh`, the candidate's, in its map space), repaired and rewound.
    #[allow(clippy::too_many_arguments)]
    fn repaired_try(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        space: &untangle::MapSpace,
        cones: &[f64],
        uv: &[[f64; 2]],
        fresh: &[[f64; 2]],
        base: &[[f64; 2]],
        cancel: CancelCheck<'_>,
    ) -> (Vec<[f64; 2]>, untangle::Repair) {
        let mut u: Vec<[f64; 2]> = (0..uv.len())
            .map(|c| std::array::from_fn(|k| uv[c][k] + fresh[c][k] - base[c][k]))
            .collect();
        let mut r = self.untangle(mesh, local, space, Some(cones), &mut u, cancel);
        self.rewind_left(mesh, local, space, cones, &mut u, &mut r, cancel);
        (u, r)
    }

    /// [`Self::reround_windings`] under constraint curves: vertices the final, fold-free map
    /// still winds wrongly, after the rewinding. A gap their corners depend on, or a curve
    /// value whose line holds them, moves by one lattice step, the other curve values (and
    /// gaps only if they must) following so that C_c w = 0 still holds ([`Traced::stepped`]);
    /// the geometric curves stay on their lines. Candidates are ranked by the repaired map
    /// moved by the step (wrongly wound vertices, then folds, within [`WINDING_RANK_RINGS`]
    /// rings), the best [`REROUND_TRIES`] (every one for the last [`WINDING_LAST`]) repaired
    /// and rewound, and the first with no fold, fewer wrongly wound vertices and a p99 within
    /// [`WINDING_P99_SLACK`] is kept; rounds go on while one helps. Only for a few
    /// (`crowded::FEW_MISWOUND`; more call for a finer try first). The cerebral vessels with
    /// their boundary aligned, N = 4: 4 wrongly wound vertices (two −1/4 whose fans turn 90°
    /// instead of 450°, each beside a vertex that took its turn) and 2 patched places → none.
    /// Updates the unknowns `w`, the map and the repair's rewound count.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn reround_curve_windings(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        traced: &Traced,
        factored: Option<&ConstrainedStep>,
        cones: &[f64],
        w: &mut Vec<f64>,
        uv: &mut Vec<[f64; 2]>,
        repair: &mut untangle::Repair,
        cancel: CancelCheck<'_>,
    ) -> Result<(), ParamError> {
        if mesh.n_faces() > WINDING_MAX_FACES {
            return Ok(());
        }
        let p99 = |uv: &[[f64; 2]]| super::metrics::map_conformal_p99(mesh, uv);
        for _ in 0..WINDING_ROUNDS {
            let wrong = untangle::miswound(mesh, uv, cones);
            // More than a few are a crowded cluster, which a finer try takes first
            // (`crowded::FEW_MISWOUND`; parted here first, camelhead aligned at 1500 vertices,
            // N = 4, kept its first map with 2 instead of a finer one with none). A round kept
            // leaves fewer, so this decides at the first.
            if wrong.is_empty()
                || wrong.len() > super::crowded::FEW_MISWOUND
                || !untangle::folded(uv).is_empty()
                || cancel()
            {
                break;
            }
            let pairs = collided(mesh, uv, cones, &wrong);
            let corners = pairs
                .iter()
                .flat_map(|&(b, s)| [b, s])
                .chain(wrong.iter().flat_map(|&v| mesh.outgoing(v)));
            let mut seen = std::collections::HashSet::new();
            let unknowns: Vec<usize> = self
                .gaps_of_corners(corners)
                .into_iter()
                .flat_map(|k| [2 * k, 2 * k + 1])
                .chain(wrong.iter().flat_map(|&v| traced.value_unknowns_at(v)))
                .filter(|k| seen.insert(*k))
                .collect();
            let near = untangle::vertices_within(mesh, &wrong, WINDING_RANK_RINGS);
            let near_faces = untangle::faces_around(mesh, &near);
            let (base, _) = self.curve_map(mesh, local, traced, factored, w)?;
            // Scores and steps only: the maps (one per corner each) are solved again for the
            // few tried.
            let steps = unit_steps(traced, w, &unknowns);
            if cancel() {
                return Ok(());
            }
            let now_uv: &[[f64; 2]] = uv;
            let mirror = mirrored(w, &steps);
            let scored = (0..steps.len())
                .filter(|&j| mirror[j].is_none())
                .collect::<Vec<_>>()
                .into_par_iter()
                .map(|j| -> Result<Vec<Scored>, ParamError> {
                    let (fresh, _) = self.curve_map(mesh, local, traced, factored, &steps[j])?;
                    // The repaired map moved by the step (or by its mirror image, the
                    // opposite amount), where it matters.
                    let score = |sign: f64| {
                        wound_and_folded(mesh, cones, &near, &near_faces, |c: usize| {
                            std::array::from_fn(|a| {
                                now_uv[c][a] + sign * (fresh[c][a] - base[c][a])
                            })
                        })
                    };
                    Ok(std::iter::once((score(1.0), j))
                        .chain(
                            (0..steps.len())
                                .filter(|&i| mirror[i] == Some(j))
                                .map(|i| (score(-1.0), i)),
                        )
                        .collect())
                })
                .collect::<Result<Vec<_>, _>>()?;
            let mut order: Vec<Scored> = scored.into_iter().flatten().collect();
            // By score, then in the steps' order.
            order.sort_unstable();
            let mut steps: Vec<Option<Vec<f64>>> = steps.into_iter().map(Some).collect();
            let ranked: Vec<((usize, usize), Vec<f64>)> = order
                .into_iter()
                .filter_map(|(s, i)| steps[i].take().map(|w2| (s, w2)))
                .collect();
            let tries = if wrong.len() <= WINDING_LAST {
                ranked.len()
            } else {
                REROUND_TRIES
            };
            let p99_now = p99(uv);
            let mut taken = None;
            let mut failed = None;
            first_taken(
                ranked.into_iter().take(tries).map(|r| r.1).collect(),
                cancel,
                |w2: Vec<f64>| -> Result<_, ParamError> {
                    let (fresh, space) = self.curve_map(mesh, local, traced, factored, &w2)?;
                    let (u, r) = self
                        .repaired_try(mesh, local, &space, cones, now_uv, &fresh, &base, cancel);
                    let kept = untangle::folded(&u).is_empty()
                        && p99(&u) <= WINDING_P99_SLACK * p99_now
                        && untangle::miswound(mesh, &u, cones).len() < wrong.len();
                    Ok(kept.then_some((w2, u, r.rewound)))
                },
                |outcome| match outcome {
                    Ok(None) => false,
                    Ok(Some(t)) => {
                        taken = Some(t);
                        true
                    }
                    Err(e) => {
                        failed = Some(e);
                        true
                    }
                },
            );
            if let Some(e) = failed {
                return Err(e);
            }
            let Some((w2, u, rewound)) = taken else {
                break;
            };
            *w = w2;
            *uv = u;
            repair.rewound += rewound;
        }
        Ok(())
    }
}

/// The solutions of C_c w = 0 nearest to `w` with one of `unknowns` moved by one lattice
/// step either way ([`Traced::stepped`]), in that order: the candidates of both re-roundings
/// under curves.
fn unit_steps(traced: &Traced, w: &[f64], unknowns: &[usize]) -> Vec<Vec<f64>> {
    unknowns
        .iter()
        .flat_map(|&k| [-1.0, 1.0].map(|step| traced.stepped(w, k, step)))
        .flatten()
        .collect()
}

/// A step's score (wrongly wound vertices, folds) and its index among the steps.
type Scored = ((usize, usize), usize);

/// Per step, the earlier step it is the mirror image of (w2 − w negated), if any: the global
/// map is affine in the unknowns, so the two move it by opposite amounts and one solve
/// serves both (the windings' ranking solves half as many maps where every unknown steps
/// both ways alone).
fn mirrored(w: &[f64], steps: &[Vec<f64>]) -> Vec<Option<usize>> {
    let mut mirror: Vec<Option<usize>> = Vec::with_capacity(steps.len());
    for (i, s) in steps.iter().enumerate() {
        let of = (0..i).find(|&j| {
            mirror[j].is_none()
                && !mirror.contains(&Some(j))
                && steps[j]
                    .iter()
                    .zip(s)
                    .zip(w)
                    .all(|((a, b), x)| a - x == -(b - x))
        });
        mirror.push(of);
    }
    mirror
}

/// A candidate step's moved map `at` (corner → point) scored around the wrongly wound
/// vertices: the vertices of `near` it winds wrongly, and the faces of `near_faces` it folds
/// (the ranking of [`QuadCover::reround_windings`] and [`QuadCover::reround_curve_windings`]).
fn wound_and_folded(
    mesh: &TriMesh,
    cones: &[f64],
    near: &[usize],
    near_faces: &[usize],
    at: impl Fn(usize) -> [f64; 2],
) -> (usize, usize) {
    let wound = near
        .iter()
        .filter(|&&v| {
            !mesh.is_boundary_vertex(v)
                && !cones[v].is_nan()
                && !untangle::wound_by(untangle::fan_turn_with(mesh, v, &at), cones[v])
        })
        .count();
    let folds = near_faces
        .iter()
        .filter(|&&f| {
            let q: [[f64; 2]; 3] = std::array::from_fn(|a| at(3 * f + a));
            let area = (q[1][0] - q[0][0]) * (q[2][1] - q[0][1])
                - (q[1][1] - q[0][1]) * (q[2][0] - q[0][0]);
            area.is_nan() || area <= 0.0
        })
        .count();
    (wound, folds)
}

/// The curve values c_κ whose lines hold the corners of the folded faces, the stuck ones'
/// first, at most [`REROUND_VALUES`]: two corners of a face held by parallel lines that the
/// rounding put on one value (a short run between two corners of a jagged boundary) need a
/// line moved, not a gap.
fn values_near(mesh: &TriMesh, traced: &Traced, stuck: &[usize], folds: &[usize]) -> Vec<usize> {
    let mut seen = std::collections::HashSet::new();
    let mut out: Vec<usize> = stuck
        .iter()
        .chain(folds)
        .flat_map(|&f| mesh.face(f))
        .flat_map(|v| traced.value_unknowns_at(v))
        .filter(|k| seen.insert(*k))
        .collect();
    out.truncate(REROUND_VALUES);
    out
}

/// The gaps that differ between `first` and `now`, as the report lists them.
pub(super) fn changed(first: &[[f64; 2]], now: &[[f64; 2]]) -> Vec<Rerounded> {
    (0..now.len())
        .filter(|&k| now[k] != first[k])
        .map(|k| Rerounded {
            path: k,
            from: first[k],
            to: now[k],
        })
        .collect()
}

/// Whether two corners of one chart are on one lattice point (closer than 1e-6).
fn coincident(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).hypot(a[1] - b[1]) <= 1e-6
}

/// Pairs of corners (the wrongly wound branch point's, another singularity's) on one point of
/// one seamless chart: per branch point among `wrong`, the faces reached from one of its own
/// through edges whose two ends agree on both sides, at most [`COLLISION_FACES`].
fn collided(
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    cones: &[f64],
    wrong: &[usize],
) -> Vec<(usize, usize)> {
    let singular =
        |v: usize| !mesh.is_boundary_vertex(v) && (cones[v] - std::f64::consts::TAU).abs() > 1e-9;
    let mut pairs = Vec::new();
    for &b in wrong {
        if !singular(b) || cones[b].is_nan() {
            continue;
        }
        let Some(cb) = mesh.outgoing(b).next() else {
            continue;
        };
        let mut seen = std::collections::HashSet::from([mesh.face_of(cb)]);
        let mut queue = std::collections::VecDeque::from([mesh.face_of(cb)]);
        while let Some(f) = queue.pop_front() {
            for h in 3 * f..3 * f + 3 {
                let v = mesh.from(h);
                if v != b
                    && singular(v)
                    && coincident(uv[h], uv[cb])
                    && !pairs.iter().any(|&(_, s)| mesh.from(s) == v)
                {
                    pairs.push((cb, h));
                }
                let Some(t) = mesh.twin(h) else {
                    continue;
                };
                let g = mesh.face_of(t);
                let seamless = uv[h] == uv[mesh.next(t)] && uv[mesh.next(h)] == uv[t];
                if seamless && seen.len() < COLLISION_FACES && seen.insert(g) {
                    queue.push_back(g);
                }
            }
        }
    }
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    /// The batched responses to a unit of each gap coordinate equal the difference of two
    /// global solves (a sphere with a projected field: singularities, so gaps to move).
    #[test]
    fn gap_responses_are_differences_of_global_maps() {
        let (mesh, qc, local) = crate::param::sphere_with_gaps();
        let base = qc.global_uv(&mesh, &local, &local.gaps).unwrap();
        let units: Vec<(usize, usize)> = (0..local.gaps.len())
            .flat_map(|k| [(k, 0), (k, 1)])
            .collect();
        let responses = qc.global.responses(&mesh, &qc.rots, &units).unwrap();
        let mut largest: f64 = 0.0;
        for (&(k, i), r) in units.iter().zip(&responses) {
            let mut g = local.gaps.clone();
            g[k][i] += 1.0;
            let uv = qc.global_uv(&mesh, &local, &g).unwrap();
            for c in 0..uv.len() {
                let d = [uv[c][0] - base[c][0], uv[c][1] - base[c][1]];
                let a = r.at(c);
                largest = largest.max(d[0].hypot(d[1]));
                assert!(
                    (d[0] - a[0]).hypot(d[1] - a[1]) < 1e-9,
                    "gap {k}, coordinate {i}, corner {c}: {d:?} against {a:?}"
                );
            }
        }
        // Moving a gap moves the map: the comparison is not of zeros.
        assert!(largest > 0.1, "largest change {largest}");
    }

    /// A step is the mirror image of the first earlier step whose change is its negation, and
    /// each has at most one: ±1 on one unknown pair up; followers that differ, or a third
    /// copy, do not.
    #[test]
    fn steps_pair_with_their_mirror_images() {
        let w = [0.0, 2.0, -1.0];
        let steps = vec![
            vec![1.0, 2.0, -1.0],  // +e0
            vec![-1.0, 2.0, -1.0], // −e0: mirror of 0
            vec![0.0, 3.0, 0.0],   // +e1 + e2
            vec![0.0, 1.0, -1.0],  // −e1 alone: not a mirror of 2
            vec![0.0, 1.0, -2.0],  // −e1 − e2: mirror of 2
            vec![-1.0, 2.0, -1.0], // −e0 again: 0 is taken
        ];
        assert_eq!(
            mirrored(&w, &steps),
            vec![None, Some(0), None, None, Some(2), None]
        );
    }

    /// Two singular vertices on one point of a seamless chart are found, whichever of them is
    /// wound wrongly; not when they are a hair apart, when the other vertex is regular, or when
    /// the only way between them crosses a seam.
    #[test]
    fn singularities_on_one_lattice_point_are_found_through_one_chart() {
        let mesh = generate::grid(8, 8, 8.0, 8.0);
        let v = |x: usize, y: usize| y * 9 + x;
        let (b, s) = (v(2, 2), v(5, 5));
        let at = |uv: &mut Vec<[f64; 2]>, w: usize, p: [f64; 2]| {
            for h in mesh.outgoing(w) {
                uv[h] = p;
            }
        };
        let plain: Vec<[f64; 2]> = (0..3 * mesh.n_faces())
            .map(|c| {
                let p = mesh.position(mesh.from(c));
                [p.x, p.y]
            })
            .collect();
        let mut uv = plain.clone();
        let pb = uv[mesh.outgoing(b).next().unwrap()];
        at(&mut uv, s, pb);
        let tau = std::f64::consts::TAU;
        let mut cones = vec![tau; mesh.n_vertices()];
        for w in 0..mesh.n_vertices() {
            if mesh.is_boundary_vertex(w) {
                cones[w] = f64::NAN;
            }
        }
        cones[b] = 1.25 * tau;
        cones[s] = 0.75 * tau;
        let found = |uv: &[[f64; 2]], cones: &[f64], wrong: &[usize]| -> Vec<[usize; 2]> {
            collided(&mesh, uv, cones, wrong)
                .into_iter()
                .map(|(p, q)| [mesh.from(p), mesh.from(q)])
                .collect()
        };
        assert_eq!(found(&uv, &cones, &[b]), vec![[b, s]]);
        assert_eq!(found(&uv, &cones, &[s]), vec![[s, b]]);
        // A hair apart: none.
        let mut apart = uv.clone();
        at(&mut apart, s, [pb[0] + 1e-3, pb[1]]);
        assert!(found(&apart, &cones, &[b]).is_empty());
        // A regular vertex on the point: none.
        let mut regular = cones.clone();
        regular[s] = tau;
        assert!(found(&uv, &regular, &[b]).is_empty());
        // A seam around b (every corner of b's ring shifted on the far side of its edges):
        // the chart ends at b's faces.
        let mut seam = uv.clone();
        let ring: std::collections::HashSet<usize> =
            mesh.outgoing(b).map(|h| mesh.face_of(h)).collect();
        for f in 0..mesh.n_faces() {
            if !ring.contains(&f) {
                for c in 3 * f..3 * f + 3 {
                    seam[c][0] += 100.0;
                }
            }
        }
        at(&mut seam, s, pb);
        assert!(found(&seam, &cones, &[b]).is_empty());
        // (the same values without the seam are found)
        let mut no_seam = seam.clone();
        for f in ring {
            for c in 3 * f..3 * f + 3 {
                no_seam[c][0] += 100.0;
            }
        }
        at(&mut no_seam, s, [pb[0] + 100.0, pb[1]]);
        assert_eq!(found(&no_seam, &cones, &[b]), vec![[b, s]]);
    }
}
