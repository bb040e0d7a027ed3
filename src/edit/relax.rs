//! Relaxation (thesis sec. 3.3): "each singularity is optimized locally by moving it
//! successively to all adjacent vertices. The value of the current position is measured by the
//! amount of curl of the frame field […]. Furthermore, if the distance between two
//! singularities becomes too close, those singularities will be merged."
//!
//! Evaluating a candidate position exactly would need a global re-smoothing and a local
//! QuadCover step (two factorizations) per candidate. Instead each singularity's candidates are
//! scored on a patch around it (faces within two grid cells): the field is re-smoothed there
//! with the outside held fixed (one small factorization per singularity; the candidates differ
//! only in the right-hand side), and the curl is measured per edge as the diagonal estimate
//! c_e² / L_ee of what the local step removes (c_e = curl* of the edge, L_ee the diagonal of the
//! local step's Crouzeix–Raviart system). A move is taken when it lowers that estimate; sweeps
//! repeat until no singularity moves (a singularity never returns to a vertex one left, so they
//! cannot cycle). Their result is kept only when the exact curl ([`Base::curl`], the local
//! step's) is lower; where the estimate finds nothing at all, single moves are tried on the
//! exact curl within a budget of local-step factorizations. Then pairs closer than
//! `relax_merge_within` grid cells are merged, opposite indices first (same-index pairs when the
//! merge rules allow the sum), each kept only when the exact curl drops, and the sweeps run once
//! more. So relax never raises the curl and never adds singularities. Everything runs
//! sequentially in a fixed order, so a relax replays bit for bit.

use std::collections::{BTreeMap, VecDeque};

use super::base::{Base, EditState};
use super::{Cancel, EditError};
use crate::field::cancel::{PathSearch, apply};
use crate::field::matching_matrix;
use crate::field::transport::NO_FACE;
use crate::sparse::{SparseBuilder, SpdSolver};

/// Sweeps over all singularities per round, and rounds of (sweeps, merges).
const MAX_SWEEPS: usize = 20;
const MAX_ROUNDS: usize = 2;
/// Patch radius in grid cells, and the largest patch.
const PATCH_CELLS: f64 = 2.0;
const MAX_PATCH_FACES: usize = 2000;
/// A candidate must lower the patch's curl estimate by this fraction.
const MIN_GAIN: f64 = 1e-6;
/// Exact evaluations (each a local-step factorization, whose cost grows with the mesh) per
/// relax, for merges and where the estimate finds no improving move: about this many faces'
/// worth in all, between 4 and 32 evaluations.
const EXACT_FACES: usize = 800_000;

pub(crate) struct RelaxOutcome {
    pub state: EditState,
    /// Moves to neighbours and merges made (for messages).
    #[allow(dead_code)]
    pub moves: usize,
    #[allow(dead_code)]
    pub merges: usize,
}

struct Scratch {
    /// Local index of a face in the current patch, or u32::MAX.
    local: Vec<u32>,
    search: PathSearch,
    /// Vertices a singularity has left during this relax: no singularity moves back onto
    /// them, so the sweeps cannot cycle (the released weights change the estimate between
    /// visits, and a singularity could otherwise step back and forth until MAX_SWEEPS).
    left: Vec<bool>,
    /// Vertices of geometric curves: a singularity there stays (the design put it on the curve,
    /// a corner of its line, eq. 4.9) and none moves onto one.
    pinned: Vec<bool>,
}

pub(crate) fn relax(
    base: &Base,
    state: &EditState,
    cancel: Cancel,
) -> Result<RelaxOutcome, EditError> {
    let mesh = base.mesh().clone();
    let system = base
        .field_of(state)
        .system
        .clone()
        .ok_or_else(|| EditError::Field("the field kept no system".into()))?;
    let mut scratch = Scratch {
        local: vec![u32::MAX; mesh.n_faces()],
        search: PathSearch::new(mesh.n_vertices()),
        left: vec![false; mesh.n_vertices()],
        pinned: pinned(&mesh, state),
    };
    let ctx = Ctx {
        base,
        target: system.target(),
        weights: system.weights(),
        cancelled: system.released_by_cancellation(),
        scale: (0..mesh.n_faces())
            .map(|f| base.field().multipliers[f] / base.grid_size())
            .collect(),
    };
    // The estimate guides the moves; the exact curl (the local step's) decides what is kept, so
    // relax never raises it.
    let mut best = state.clone();
    let mut best_curl = base.curl(state)?;
    let (mut moves, mut merges) = (0, 0);
    let radius = base.settings().relax_merge_within * base.grid_size();
    let mut budget = (EXACT_FACES / mesh.n_faces().max(1)).clamp(4, 32);
    for _round in 0..MAX_ROUNDS {
        if cancel() {
            return Err(EditError::Cancelled);
        }
        let (swept, moved) = ctx.sweeps(&best, &mut scratch, cancel)?;
        let mut improved = false;
        if moved > 0 && take_if_lower(base, &mut best, &mut best_curl, swept)? {
            moves += moved;
            improved = true;
        }
        if !improved && moves + merges == 0 {
            // Where the estimate finds nothing (or misleads from the start), moves are tried on
            // the exact curl, within a budget of local-step factorizations.
            let singular: Vec<usize> = best.singularities.keys().copied().collect();
            'singular: for p in singular {
                if scratch.pinned[p] {
                    continue;
                }
                let mesh = base.mesh();
                let neighbours: Vec<usize> = mesh.outgoing(p).map(|h| mesh.to(h)).collect();
                for q in neighbours {
                    if mesh.is_boundary_vertex(q)
                        || best.singularities.contains_key(&q)
                        || scratch.pinned[q]
                    {
                        continue;
                    }
                    if budget == 0 || cancel() {
                        break 'singular;
                    }
                    let Ok(mv) = base.plan(&best, &mut scratch.search, p, q) else {
                        continue;
                    };
                    budget -= 1;
                    let candidate = base.commit(&best, &mv);
                    if take_if_lower(base, &mut best, &mut best_curl, candidate)? {
                        moves += 1;
                        improved = true;
                        continue 'singular;
                    }
                }
            }
        }
        // Global moves down the map's log-scale, which the patches above cannot see.
        let (undrifted, undrifted_curl) = (best.clone(), best_curl);
        let drifted = super::drift::drift(
            base,
            &mut best,
            &mut best_curl,
            &scratch.pinned,
            &mut scratch.search,
            cancel,
        )?;
        if drifted > 0 && !super::drift::maps_as_well(base, &undrifted, &best, cancel)? {
            (best, best_curl) = (undrifted, undrifted_curl);
        } else if drifted > 0 {
            moves += drifted;
            improved = true;
        }
        // Merge close pairs, nearest first, each kept only when it lowers the curl.
        let mut merged = false;
        if radius > 0.0 {
            for (p, q) in close_pairs(base, &best.singularities, radius) {
                if cancel() {
                    return Err(EditError::Cancelled);
                }
                if !(best.singularities.contains_key(&p) && best.singularities.contains_key(&q))
                    || scratch.pinned[p]
                    || scratch.pinned[q]
                {
                    continue;
                }
                let Ok(mv) = base.plan(&best, &mut scratch.search, p, q) else {
                    continue;
                };
                if budget == 0 {
                    break;
                }
                budget -= 1;
                let candidate = base.commit(&best, &mv);
                if take_if_lower(base, &mut best, &mut best_curl, candidate)? {
                    merges += 1;
                    merged = true;
                }
            }
        }
        if !merged && !improved {
            break;
        }
    }
    Ok(RelaxOutcome {
        state: best,
        moves,
        merges,
    })
}

/// The vertices of the state's geometric curves ([`Scratch::pinned`]).
fn pinned(mesh: &crate::mesh::TriMesh, state: &EditState) -> Vec<bool> {
    let mut pinned = vec![false; mesh.n_vertices()];
    for c in state.curves.values() {
        if c.kind == crate::constraint::CurveKind::Geometric {
            for &v in &c.vertices {
                pinned[v] = true;
            }
        }
    }
    pinned
}

/// Takes `candidate` as the best state when its exact curl is lower than the best's.
fn take_if_lower(
    base: &Base,
    best: &mut EditState,
    best_curl: &mut f64,
    candidate: EditState,
) -> Result<bool, EditError> {
    let c = base.curl(&candidate)?;
    if c < *best_curl {
        *best = candidate;
        *best_curl = c;
        return Ok(true);
    }
    Ok(false)
}

/// Pairs of singularities closer than `radius` (3-D distance), nearest first, each vertex in at
/// most one pair; opposite indices and same-sign ones alike (the merge rules decide later).
fn close_pairs(base: &Base, singular: &BTreeMap<usize, i32>, radius: f64) -> Vec<(usize, usize)> {
    let mesh = base.mesh();
    let s: Vec<(usize, i32)> = singular.iter().map(|(&v, &k)| (v, k)).collect();
    let mut candidates = Vec::new();
    for i in 0..s.len() {
        for j in i + 1..s.len() {
            let d = (mesh.position(s[i].0) - mesh.position(s[j].0)).length();
            if d < radius {
                // Cancelling pairs before merging ones.
                let opposite = s[i].1 + s[j].1 == 0;
                candidates.push((!opposite, d, s[i].0, s[j].0));
            }
        }
    }
    candidates.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut used = BTreeMap::new();
    let mut pairs = Vec::new();
    for (_, _, a, b) in candidates {
        if !used.contains_key(&a) && !used.contains_key(&b) {
            used.insert(a, ());
            used.insert(b, ());
            pairs.push((a, b));
        }
    }
    pairs
}

struct Ctx<'a> {
    base: &'a Base,
    target: &'a [f64],
    /// τω per face before any release, and the faces the field's cancellation released.
    weights: &'a [f64],
    cancelled: &'a [usize],
    /// Frame length per face (m_f / h).
    scale: Vec<f64>,
}

type Move = (usize, Vec<(usize, f64)>, super::moves::PlannedMove);

impl Ctx<'_> {
    /// Moves singularities to better neighbours until no move lowers the estimate (or
    /// MAX_SWEEPS): the state after, and the number of moves.
    fn sweeps(
        &self,
        state: &EditState,
        scratch: &mut Scratch,
        cancel: Cancel,
    ) -> Result<(EditState, usize), EditError> {
        let mesh = self.base.mesh();
        let mut theta = self.base.angles(state)?;
        let mut w = self.weights.to_vec();
        for &f in self.cancelled.iter().chain(&state.released) {
            w[f] = 0.0;
        }
        let mut st = state.clone();
        let mut moves = 0;
        for _sweep in 0..MAX_SWEEPS {
            if cancel() {
                return Err(EditError::Cancelled);
            }
            let mut blocked = vec![false; mesh.n_vertices()];
            let mut moved = false;
            let singular: Vec<usize> = st.singularities.keys().copied().collect();
            for p in singular {
                if blocked[p] || scratch.pinned[p] {
                    continue;
                }
                let Some((q, new_theta, mv)) = self.best_move(&st, &theta, &w, p, scratch)? else {
                    continue;
                };
                for (f, t) in new_theta {
                    theta[f] = t;
                }
                let next = self.base.commit(&st, &mv);
                for &f in &next.released {
                    w[f] = 0.0;
                }
                st = next;
                scratch.left[p] = true;
                for v in [p, q] {
                    blocked[v] = true;
                    for h in mesh.outgoing(v) {
                        blocked[mesh.to(h)] = true;
                    }
                }
                moves += 1;
                moved = true;
            }
            if !moved {
                break;
            }
        }
        Ok((st, moves))
    }

    /// The neighbour of p whose move lowers the patch's curl estimate most, with the patch's
    /// re-smoothed angles for it; `None` when staying is best.
    fn best_move(
        &self,
        st: &EditState,
        theta: &[f64],
        w: &[f64],
        p: usize,
        scratch: &mut Scratch,
    ) -> Result<Option<Move>, EditError> {
        let mesh = self.base.mesh();
        let candidates: Vec<usize> = mesh
            .outgoing(p)
            .map(|h| mesh.to(h))
            .filter(|&q| {
                !mesh.is_boundary_vertex(q)
                    && !st.singularities.contains_key(&q)
                    && !scratch.left[q]
                    && !scratch.pinned[q]
            })
            .collect();
        if candidates.is_empty() {
            return Ok(None);
        }
        let faces = self.patch(p, scratch);
        if faces.is_empty() {
            return Ok(None);
        }
        // The faces a move to any candidate would release, released for staying too, so that
        // the options are compared on equal terms.
        let mut w_patch: Vec<f64> = faces.iter().map(|&f| w[f]).collect();
        for h in mesh.outgoing(p) {
            for g in mesh.outgoing(mesh.to(h)) {
                let l = scratch.local[mesh.face_of(g)];
                if l != u32::MAX {
                    w_patch[l as usize] = 0.0;
                }
            }
        }
        let result = (|| {
            let Some(solver) = self.patch_system(&faces, &w_patch, scratch)? else {
                return Ok(None);
            };
            let stay = self.patch_solve(&solver, &faces, &w_patch, theta, &st.turns, scratch)?;
            let mut best = self.patch_curl(&faces, theta, &stay, &st.turns, scratch);
            let mut choice = None;
            for q in candidates {
                let Ok(mv) = self.base.plan(st, &mut scratch.search, p, q) else {
                    continue;
                };
                // Only moves whose path stays inside the patch can be scored on it.
                if mv.path.iter().any(|&h| {
                    let e = mesh.edge(h);
                    let [a, b] = self.base.transport().faces[e];
                    scratch.local[a as usize] == u32::MAX
                        || b == NO_FACE
                        || scratch.local[b as usize] == u32::MAX
                }) {
                    continue;
                }
                let mut turns = st.turns.clone();
                let k = st.singularities[&p];
                apply(mesh, &mut turns, &mv.path, k, mv.sign);
                let moved = self.patch_solve(&solver, &faces, &w_patch, theta, &turns, scratch)?;
                let value = self.patch_curl(&faces, theta, &moved, &turns, scratch);
                if value < best * (1.0 - MIN_GAIN) {
                    best = value;
                    choice = Some((q, moved, mv));
                }
            }
            Ok(choice.map(|(q, moved, mv)| {
                let angles = faces.iter().copied().zip(moved).collect();
                (q, angles, mv)
            }))
        })();
        for &f in &faces {
            scratch.local[f] = u32::MAX;
        }
        result
    }

    /// Faces within PATCH_CELLS grid cells of p (by a breadth-first walk over edge-adjacent
    /// faces from p's star), at most MAX_PATCH_FACES; `scratch.local` numbers them.
    fn patch(&self, p: usize, scratch: &mut Scratch) -> Vec<usize> {
        let mesh = self.base.mesh();
        let tr = self.base.transport();
        let center = mesh.position(p);
        let radius = PATCH_CELLS * self.base.grid_size();
        let mut faces = Vec::new();
        let mut queue = VecDeque::new();
        for h in mesh.outgoing(p) {
            let f = mesh.face_of(h);
            if scratch.local[f] == u32::MAX {
                scratch.local[f] = faces.len() as u32;
                faces.push(f);
                queue.push_back(f);
            }
        }
        while let Some(f) = queue.pop_front() {
            if faces.len() >= MAX_PATCH_FACES {
                break;
            }
            for k in 0..3 {
                let e = mesh.edge(3 * f + k);
                let [a, b] = tr.faces[e];
                if b == NO_FACE {
                    continue;
                }
                let g = if a as usize == f { b } else { a } as usize;
                if scratch.local[g] != u32::MAX
                    || (mesh.face_centroid(g) - center).length() > radius
                {
                    continue;
                }
                scratch.local[g] = faces.len() as u32;
                faces.push(g);
                queue.push_back(g);
            }
        }
        faces
    }

    /// The patch's fixed-matching system (faces outside held): `None` when the patch touches no
    /// outside face and has no weight (then its angles are not determined by it).
    fn patch_system(
        &self,
        faces: &[usize],
        w_patch: &[f64],
        scratch: &Scratch,
    ) -> Result<Option<SpdSolver>, EditError> {
        let mesh = self.base.mesh();
        let tr = self.base.transport();
        let mut b = SparseBuilder::<f64>::new(faces.len());
        let mut held = w_patch.iter().any(|&x| x > 0.0);
        for (l, &f) in faces.iter().enumerate() {
            b.add(l, l, w_patch[l]);
            for k in 0..3 {
                let e = mesh.edge(3 * f + k);
                let [a, c] = tr.faces[e];
                if c == NO_FACE {
                    continue;
                }
                let g = if a as usize == f { c } else { a } as usize;
                b.add(l, l, 1.0);
                match scratch.local[g] {
                    u32::MAX => held = true,
                    m => b.add(l, m as usize, -1.0),
                }
            }
        }
        if !held {
            return Ok(None);
        }
        let m = b.build().map_err(|e| EditError::Field(e.to_string()))?;
        SpdSolver::new(&m)
            .map(Some)
            .map_err(|e| EditError::Field(e.to_string()))
    }

    /// Patch angles for `turns`, the outside held at `theta`.
    fn patch_solve(
        &self,
        solver: &SpdSolver,
        faces: &[usize],
        w_patch: &[f64],
        theta: &[f64],
        turns: &[i64],
        scratch: &Scratch,
    ) -> Result<Vec<f64>, EditError> {
        let mesh = self.base.mesh();
        let tr = self.base.transport();
        let step = std::f64::consts::TAU / self.base.settings().symmetry as f64;
        let mut rhs: Vec<f64> = faces
            .iter()
            .enumerate()
            .map(|(l, &f)| w_patch[l] * self.target[f])
            .collect();
        for (l, &f) in faces.iter().enumerate() {
            for k in 0..3 {
                let e = mesh.edge(3 * f + k);
                let [a, c] = tr.faces[e];
                if c == NO_FACE {
                    continue;
                }
                // Energy term (θ_c − θ_a − κ − step r)²: the side's own term in its row.
                let offset = tr.kappa[e] + step * turns[e] as f64;
                let (g, sign) = if a as usize == f {
                    (c as usize, -1.0)
                } else {
                    (a as usize, 1.0)
                };
                rhs[l] += sign * offset;
                if scratch.local[g] == u32::MAX {
                    rhs[l] += theta[g];
                }
            }
        }
        solver
            .solve(&rhs)
            .map_err(|e| EditError::Field(e.to_string()))
    }

    /// Σ c_e² / L_ee over the interior edges of the patch's faces.
    fn patch_curl(
        &self,
        faces: &[usize],
        theta: &[f64],
        patch_theta: &[f64],
        turns: &[i64],
        scratch: &Scratch,
    ) -> f64 {
        let mesh = self.base.mesh();
        let sym = self.base.settings().symmetry();
        let n = sym.n() as i64;
        let angle = |f: usize| match scratch.local[f] {
            u32::MAX => theta[f],
            l => patch_theta[l as usize],
        };
        let frame = |f: usize| {
            let (s, c) = angle(f).sin_cos();
            let (e1, e2) = mesh.face_basis(f);
            let u = (c * e1 + s * e2) * self.scale[f];
            [u, mesh.face_normal(f).cross(u)]
        };
        let mut total = 0.0;
        for &f in faces {
            for k in 0..3 {
                let h = 3 * f + k;
                let e = mesh.edge(h);
                let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
                    continue;
                };
                // Each edge once: from the face of its first halfedge, or from the face in the
                // patch when the other is outside.
                let other = mesh.face_of(if h == h0 { h1 } else { h0 });
                if h != h0 && scratch.local[other] != u32::MAX {
                    continue;
                }
                let (i, j) = (mesh.face_of(h0), mesh.face_of(h1));
                let d = mesh.vector(h0);
                let (xi, xj) = (frame(i), frame(j));
                let a = [d.dot(xi[0]), d.dot(xi[1])];
                let m = matching_matrix(sym, turns[e].rem_euclid(n) as i32);
                let ma = [
                    m[0][0] * a[0] + m[0][1] * a[1],
                    m[1][0] * a[0] + m[1][1] * a[1],
                ];
                let c = [d.dot(xj[0]) - ma[0], d.dot(xj[1]) - ma[1]];
                let l = d.length_squared() * (1.0 / mesh.face_area(i) + 1.0 / mesh.face_area(j));
                total += (c[0] * c[0] + c[1] * c[1]) / l;
            }
        }
        total
    }
}
