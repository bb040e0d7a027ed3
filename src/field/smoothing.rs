//! Reliability-weighted smoothing of N-symmetric direction fields (thesis sec. 3.2, generalised
//! from π/2 to 2π/N).
//!
//! Unknowns are the per-face angles θ_i = θ⁰_i + α_i (angle of U_i in the face basis) and the
//! integer matchings r_e. The energy is E = E_smooth + τ E_align with
//!   E_smooth = Σ_e (θ_j − θ_i − κ_ij − (2π/N) r_ij)²      (eq. 3.5; β_ij = θ⁰_j − θ⁰_i − κ_ij)
//!   E_align  = Σ_i ω_i (θ_i − t_i)²                         (eq. 3.6; α_i = θ_i − t_i)
//! where t_i is the representative of the curvature direction θ⁰_i (mod 2π/N) nearest to the
//! relaxed solution. Scheme: (1) relaxed solve, (2) round all matchings to the nearest integer,
//! then optionally cancel close singularity pairs (sec. 3.3, [`SmoothInput::adjust_turns`]),
//! (3) re-solve the angles with the matchings fixed; rounding and (3) are repeated until the
//! rounding no longer changes (each pass can only lower E, so this terminates), so that on output
//! every matching is the closest-angle matching of the final frames, except on the edges the
//! cancellation changed, which stay as it set them.
//!
//! Relaxed solve, two variants:
//! - [`Relaxation::SpanningForest`]: the thesis's scheme literally — a spanning forest of the dual
//!   graph rooted at all faces with ω_i ≠ 0 fixes r = 0 on tree edges; with the remaining r
//!   continuous they absorb every non-tree residual, so the relaxed minimiser is α = 0 on the roots
//!   propagated by parallel transport along the tree.
//! - [`Relaxation::Complex`] (default): the N-RoSy representation z_i = e^{iNθ_i}, minimising
//!   Σ_e |z_j − e^{iNκ_ij} z_i|² + τ Σ_i ω_i |z_i − e^{iNθ⁰_i}|² in one sparse SPD solve (the
//!   complex form of eq. 3.5/3.6 in which the matchings disappear); θ_i = arg(z_i)/N. It places
//!   singularities far better than tree propagation (see the tests for a comparison). It is
//!   solved by multigrid-preconditioned CG to [`RELAXED_TOLERANCE`], the fixed-matching system by
//!   a sparse Cholesky factorization that every pass reuses.

use std::f64::consts::TAU;

use serde::{Deserialize, Serialize};

use super::transport::{EdgeTransport, NO_FACE};
use crate::sparse::{
    Analysis, Multigrid, Scalar, SolverError, SparseBuilder, SparseMatrix, SpdSolver, c64,
};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Relaxation {
    #[default]
    Complex,
    SpanningForest,
}

#[derive(Clone, Debug)]
pub struct SmoothOutput {
    /// Angle of U per face in the face basis.
    pub theta: Vec<f64>,
    /// Integer matching per edge (not reduced mod N; 0 on boundary edges).
    pub r: Vec<i64>,
    pub e_smooth: f64,
    pub e_align: f64,
    /// Rounding + re-solve passes until the matchings were stable.
    pub passes: usize,
    /// Faces held by a (soft) anchor because their component had no alignment constraint.
    pub anchors: Vec<usize>,
    /// Wall-clock seconds per stage (assembly, relaxed solve, cancellation, waiting for the
    /// analysis, fixed-matching factorization, rounding passes).
    pub timings: Vec<(String, f64)>,
}

/// Input of [`smooth`].
pub struct SmoothInput<'a> {
    pub n: u32,
    pub transport: &'a EdgeTransport,
    /// Curvature (reference) direction per face.
    pub theta0: &'a [f64],
    /// Reliability weight ω_i per face (0 = ignored).
    pub omega: &'a [f64],
    pub tau: f64,
    pub relaxation: Relaxation,
    /// Called with the relaxed angles and their rounded turns, before the fixed-matching system
    /// is built: may return changed turns (e.g. close singularity pairs cancelled, sec. 3.3),
    /// which the rounding passes then keep, and faces whose alignment weight to drop.
    pub adjust_turns: Option<&'a AdjustTurns<'a>>,
    /// Where the analysis of [`dual_pattern`] comes from if it is computed elsewhere
    /// (it depends on the mesh only, so callers compute it while other work runs); asked for
    /// only once the relaxed solve is done and the fixed-matching system assembled.
    pub analysis: Option<&'a AnalysisSource<'a>>,
}

/// The pattern of the smoothing systems: the dual graph (faces adjacent across an interior edge,
/// `pairs` yields them) and the diagonal; placeholder values. All of them (fixed-matching and
/// relaxed, real and complex) share it; the fixed-matching system is factored with its
/// [`Analysis`], the relaxed one solved by multigrid.
pub fn dual_pattern(
    nf: usize,
    pairs: impl Iterator<Item = (usize, usize)>,
) -> Result<SparseMatrix, SolverError> {
    let pairs: Vec<(usize, usize)> = pairs.collect();
    if let Some(&(i, j)) = pairs.iter().find(|&&(i, j)| i >= nf || j >= nf || i == j) {
        return Err(SolverError::Build(format!(
            "dual pair ({i}, {j}) is not two distinct faces of {nf}"
        )));
    }
    // Counted straight into compressed columns (column f: f and its neighbours, at most four
    // entries, sorted in place): sorting five million triplets took 0.2 s at a million faces.
    let mut col_ptr = vec![0usize; nf + 1];
    for &(i, j) in &pairs {
        col_ptr[i + 1] += 1;
        col_ptr[j + 1] += 1;
    }
    for f in 0..nf {
        col_ptr[f + 1] += col_ptr[f] + 1;
    }
    let mut row_idx = vec![0usize; col_ptr[nf]];
    let mut fill: Vec<usize> = col_ptr[..nf].to_vec();
    for f in 0..nf {
        row_idx[fill[f]] = f;
        fill[f] += 1;
    }
    for &(i, j) in &pairs {
        row_idx[fill[i]] = j;
        fill[i] += 1;
        row_idx[fill[j]] = i;
        fill[j] += 1;
    }
    let mut repeated = false;
    for f in 0..nf {
        let rows = &mut row_idx[col_ptr[f]..col_ptr[f + 1]];
        rows.sort_unstable();
        repeated |= rows.windows(2).any(|w| w[0] == w[1]);
    }
    if repeated {
        // Two faces sharing two edges (a two-triangle pillow): one entry for both.
        let mut b = SparseBuilder::with_capacity(nf, row_idx.len());
        for f in 0..nf {
            for &g in &row_idx[col_ptr[f]..col_ptr[f + 1]] {
                b.add(g, f, 0.0);
            }
        }
        return b.build();
    }
    let values = vec![0.0; row_idx.len()];
    SparseMatrix::from_columns(nf, col_ptr, row_idx, values)
}

/// See [`SmoothInput::analysis`].
pub type AnalysisSource<'a> = dyn Fn() -> Result<Analysis, SolverError> + Sync + 'a;

/// See [`SmoothInput::adjust_turns`]: new turns, and the faces whose alignment to release.
pub type AdjustTurns<'a> = dyn Fn(&[f64], &[i64]) -> Option<(Vec<i64>, Vec<usize>)> + Sync + 'a;

const MAX_PASSES: usize = 50;

/// Relative residual at which the relaxed solve stops. The relaxed solution only decides the
/// rounding of the matchings (and which representative of the curvature direction each face is
/// aligned to). Against the direct solve, on the shared meshes for N = 2, 4, 6 and on the bunny
/// subdivided to 1.1 M faces, 1e-3 left every singularity count equal (one fewer pair on
/// cerebral-vessels, N = 6) and E_smooth at most 0.45 % higher (up to 1.3 % lower), in 5–9
/// iterations; 1e-4 takes ~40 % more iterations for smaller differences.
const RELAXED_TOLERANCE: f64 = 1e-3;
/// [`RELAXED_TOLERANCE`] for the alignment weight τ: the right-hand side grows with τ while the
/// part of the solution that decides the rounding, its smooth propagation away from the reliable
/// faces, does not; without the scaling, τ = 100 on fertility rounded to a rougher field than
/// τ = 10⁴ (E_smooth 36.5 against 34.0).
fn relaxed_tolerance(tau: f64) -> f64 {
    RELAXED_TOLERANCE / tau.max(1.0)
}
/// Reached only if the hierarchy is a poor preconditioner; the last iterate is used then.
const RELAXED_MAX_ITERATIONS: usize = 100;

/// Dual-graph adjacency in compressed form: for face f, `adj[start[f]..start[f + 1]]` lists
/// (neighbour face, edge).
pub(crate) fn dual_adjacency(tr: &EdgeTransport, nf: usize) -> (Vec<usize>, Vec<(u32, u32)>) {
    let mut start = vec![0usize; nf + 1];
    for f in &tr.faces {
        if f[1] != NO_FACE {
            start[f[0] as usize + 1] += 1;
            start[f[1] as usize + 1] += 1;
        }
    }
    for i in 0..nf {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut adj = vec![(0u32, 0u32); start[nf]];
    for (e, f) in tr.faces.iter().enumerate() {
        if f[1] != NO_FACE {
            let (a, b) = (f[0] as usize, f[1] as usize);
            adj[fill[a]] = (b as u32, e as u32);
            fill[a] += 1;
            adj[fill[b]] = (a as u32, e as u32);
            fill[b] += 1;
        }
    }
    (start, adj)
}

/// Per edge the number of `step` turns nearest to the angle between the faces' frames after
/// transport (eq. 3.3 before reduction mod N); 0 on boundary edges.
pub(crate) fn nearest_turns(tr: &EdgeTransport, theta: &[f64], step: f64) -> Vec<i64> {
    tr.faces
        .iter()
        .zip(&tr.kappa)
        .map(|(f, k)| {
            if f[1] == NO_FACE {
                0
            } else {
                ((theta[f[1] as usize] - theta[f[0] as usize] - k) / step).round() as i64
            }
        })
        .collect()
}

/// Weight of the reliable faces in the relaxed solve when τ = 0. Measured on fertility: with a
/// vanishing gauge (1e-6 .. 1e-3) the rounded matchings settle on a slightly rougher field
/// (E_smooth 30.16) than τ = 0.01 gives (30.07); at 1e-2 τ = 0 re-solves the same matchings
/// without alignment and is the smoothest (30.07). Rounding is a heuristic, so monotonicity in τ
/// is observed, not guaranteed.
const GAUGE_WEIGHT: f64 = 1e-2;

/// Per face whether it anchors its dual component: one face (the most reliable) in each
/// component that has no positive weight, so that the systems are definite.
fn anchor_faces(w: &[f64], omega: &[f64], start: &[usize], adj: &[(u32, u32)]) -> Vec<bool> {
    let nf = w.len();
    let mut comp = vec![false; nf];
    let mut is_anchor = vec![false; nf];
    let mut stack = Vec::new();
    for root in 0..nf {
        if comp[root] {
            continue;
        }
        comp[root] = true;
        stack.push(root);
        let (mut best, mut best_w, mut has_w) = (root, -1.0, false);
        while let Some(f) = stack.pop() {
            has_w |= w[f] > 0.0;
            if omega[f] > best_w {
                best_w = omega[f];
                best = f;
            }
            for &(g, _) in &adj[start[f]..start[f + 1]] {
                if !comp[g as usize] {
                    comp[g as usize] = true;
                    stack.push(g as usize);
                }
            }
        }
        if !has_w {
            is_anchor[best] = true;
        }
    }
    is_anchor
}

/// Where each entry of the dual systems sits in their shared value array, so that a system is
/// written in place instead of sorting five million entries again (0.3 s a system at 1.1 M
/// faces).
struct DualLayout {
    pattern: SparseMatrix,
    diag: Vec<usize>,
    /// Per interior edge: (edge, face i = faces[0], face j, position of (j, i), of (i, j)).
    pairs: Vec<(usize, usize, usize, usize, usize)>,
}

impl DualLayout {
    fn new(tr: &EdgeTransport, nf: usize) -> Result<DualLayout, SolverError> {
        let pairs = tr.faces.iter().filter(|f| f[1] != NO_FACE);
        let pattern = dual_pattern(nf, pairs.map(|f| (f[0] as usize, f[1] as usize)))?;
        let missing = || SolverError::Build("dual system entry missing from its pattern".into());
        let diag = (0..nf)
            .map(|i| pattern.position(i, i).ok_or_else(missing))
            .collect::<Result<_, _>>()?;
        let mut pairs = Vec::with_capacity(tr.faces.len());
        for (e, f) in tr.faces.iter().enumerate() {
            if f[1] != NO_FACE {
                let (i, j) = (f[0] as usize, f[1] as usize);
                let ji = pattern.position(j, i).ok_or_else(missing)?;
                let ij = pattern.position(i, j).ok_or_else(missing)?;
                pairs.push((e, i, j, ji, ij));
            }
        }
        Ok(DualLayout {
            pattern,
            diag,
            pairs,
        })
    }

    /// Σ_e |x_j − ρ_e x_i|² + Σ_i d_i |x_i|² as a matrix: `off(e)` gives the entries −ρ_e at
    /// (j, i) and −conj(ρ_e) at (i, j); ρ = 1 for the fixed-matching system, e^{iNκ} for the
    /// relaxed one.
    fn fill<T: Scalar>(
        &self,
        d: impl Fn(usize) -> T,
        off: impl Fn(usize) -> (T, T),
        one: T,
    ) -> Result<SparseMatrix<T>, SolverError> {
        let mut v = vec![T::ZERO; self.pattern.nnz()];
        for (i, &p) in self.diag.iter().enumerate() {
            v[p] += d(i);
        }
        for &(e, i, j, ji, ij) in &self.pairs {
            v[self.diag[i]] += one;
            v[self.diag[j]] += one;
            let (a, b) = off(e);
            v[ji] += a;
            v[ij] += b;
        }
        self.pattern.with_values(v)
    }
}

pub fn smooth(inp: &SmoothInput) -> Result<SmoothOutput, SolverError> {
    let nf = inp.theta0.len();
    let tr = inp.transport;
    let step = TAU / inp.n as f64;
    let tau = inp.tau.max(0.0);
    let w: Vec<f64> = inp.omega.iter().map(|o| tau * o.max(0.0)).collect();
    let (start, adj) = dual_adjacency(tr, nf);

    // τ = 0 asks for the smoothest field. Pinning one face would make the relaxed solve a
    // harmonic extension from that face, which is not the smoothest field and rounds worse than
    // a small τ. Instead the reliable faces fix the global rotation with a small weight in the
    // relaxed solve only; the fixed-matching re-solve keeps τ = 0.
    let (w_relaxed, anchor_relaxed) = if tau == 0.0 {
        let w0: Vec<f64> = inp
            .omega
            .iter()
            .map(|o| GAUGE_WEIGHT * o.max(0.0))
            .collect();
        let a0 = anchor_faces(&w0, inp.omega, &start, &adj);
        (w0, a0)
    } else {
        (w.clone(), anchor_faces(&w, inp.omega, &start, &adj))
    };

    let mut timings = Vec::new();
    let mut clock = std::time::Instant::now();
    let mut lap = |name: String, timings: &mut Vec<(String, f64)>| {
        timings.push((name, clock.elapsed().as_secs_f64()));
        clock = std::time::Instant::now();
    };
    let layout = DualLayout::new(tr, nf)?;
    let relaxed = match inp.relaxation {
        Relaxation::Complex => {
            let (matrix, rhs) = relaxed_complex_system(inp, &w_relaxed, &anchor_relaxed, &layout)?;
            lap("smoothing: assembly".into(), &mut timings);
            let hierarchy = Multigrid::new(&matrix)?;
            drop(matrix);
            lap("smoothing: relaxed multigrid setup".into(), &mut timings);
            let solution =
                hierarchy.solve(&rhs, None, relaxed_tolerance(tau), RELAXED_MAX_ITERATIONS)?;
            lap(
                format!("smoothing: relaxed CG ({} iterations)", solution.iterations),
                &mut timings,
            );
            solution.x.iter().map(|z| z.arg() / inp.n as f64).collect()
        }
        Relaxation::SpanningForest => {
            let theta = relaxed_forest(inp, &w_relaxed, &anchor_relaxed, &start, &adj);
            lap("smoothing: relaxed spanning forest".into(), &mut timings);
            theta
        }
    };
    // Alignment targets: the representative of θ⁰ (mod 2π/N) nearest the relaxed angle.
    let target: Vec<f64> = (0..nf)
        .map(|i| inp.theta0[i] + step * ((relaxed[i] - inp.theta0[i]) / step).round())
        .collect();
    let mut r = nearest_turns(tr, &relaxed, step);

    // Sec. 3.3 on the rounded relaxed field, before the fixed-matching system is factored: the
    // faces along a cancelled pair's path lose their alignment weight (a moved singularity's
    // path through trusted faces would otherwise leave a seam in the field), which changes that
    // system's matrix, so deciding this first saves a second factorization (1.5 s at a million
    // faces). The changed edges stay pinned in the rounding passes below, which would otherwise
    // be free to round the pair back.
    let mut w = w;
    let mut pinned = vec![false; r.len()];
    let mut released_any = false;
    if let Some(adjust) = inp.adjust_turns
        && let Some((adjusted, released)) = adjust(&relaxed, &r)
    {
        for (e, (a, b)) in adjusted.iter().zip(&r).enumerate() {
            pinned[e] = a != b;
        }
        r = adjusted;
        for f in released {
            released_any |= w[f] != 0.0;
            w[f] = 0.0;
        }
    }
    lap("smoothing: cancellation".into(), &mut timings);

    // Fixed-matching system: dual Laplacian + diag(τω) + anchors. Only the right-hand side
    // depends on the matchings, so one factorization serves all passes. Its anchors are the
    // relaxed system's unless that one used the gauge weights (τ = 0) or weights were released.
    let is_anchor = if tau > 0.0 && !released_any {
        anchor_relaxed
    } else {
        anchor_faces(&w, inp.omega, &start, &adj)
    };
    let fixed_matrix = layout.fill(
        |i| w[i] + if is_anchor[i] { 1.0 } else { 0.0 },
        |_| (-1.0, -1.0),
        1.0,
    )?;
    let analysis = match inp.analysis {
        Some(source) => source()?,
        None => Analysis::new(&fixed_matrix)?,
    };
    lap("smoothing: waiting for the analysis".into(), &mut timings);
    let solver = SpdSolver::with_analysis(analysis, &fixed_matrix)?;
    drop(fixed_matrix);
    lap(
        "smoothing: fixed-matching factorization".into(),
        &mut timings,
    );

    // Right-hand side of the fixed-matching system for the turns r.
    let rhs_for = |r: &[i64]| {
        let mut rhs: Vec<f64> = (0..nf)
            .map(|i| w[i] * target[i] + if is_anchor[i] { relaxed[i] } else { 0.0 })
            .collect();
        for (e, f) in tr.faces.iter().enumerate() {
            if f[1] != NO_FACE {
                let c = tr.kappa[e] + step * r[e] as f64;
                rhs[f[0] as usize] -= c;
                rhs[f[1] as usize] += c;
            }
        }
        rhs
    };
    let mut passes = 0;
    let theta = loop {
        passes += 1;
        let theta = solver.solve(&rhs_for(&r))?;
        let mut r_new = nearest_turns(tr, &theta, step);
        for (e, p) in pinned.iter().enumerate() {
            if *p {
                r_new[e] = r[e];
            }
        }
        if r_new == r || passes >= MAX_PASSES {
            break theta;
        }
        r = r_new;
    };
    lap(
        format!("smoothing: rounding passes ({passes})"),
        &mut timings,
    );
    let (e_smooth, e_align) = energies(tr, step, &theta, &r, inp.omega, &target);
    Ok(SmoothOutput {
        theta,
        r,
        e_smooth,
        e_align,
        passes,
        anchors: (0..nf).filter(|&i| is_anchor[i]).collect(),
        timings,
    })
}

/// E_smooth (eq. 3.5) and E_align (eq. 3.6, without τ).
pub fn energies(
    tr: &EdgeTransport,
    step: f64,
    theta: &[f64],
    r: &[i64],
    omega: &[f64],
    target: &[f64],
) -> (f64, f64) {
    let mut es = 0.0;
    for (e, f) in tr.faces.iter().enumerate() {
        if f[1] != NO_FACE {
            let d = theta[f[1] as usize] - theta[f[0] as usize] - tr.kappa[e] - step * r[e] as f64;
            es += d * d;
        }
    }
    let ea = (0..theta.len())
        .map(|i| omega[i] * (theta[i] - target[i]).powi(2))
        .sum();
    (es, ea)
}

/// The relaxed system (complex, Hermitian) and its right-hand side; it has the pattern of the
/// fixed-matching system, so that system's analysis serves it.
fn relaxed_complex_system(
    inp: &SmoothInput,
    w: &[f64],
    is_anchor: &[bool],
    layout: &DualLayout,
) -> Result<(SparseMatrix<c64>, Vec<c64>), SolverError> {
    let n = inp.n as f64;
    let tr = inp.transport;
    let d = |i: usize| w[i] + if is_anchor[i] { 1.0 } else { 0.0 };
    let rhs = (0..inp.theta0.len())
        .map(|i| c64::from_polar(d(i), n * inp.theta0[i]))
        .collect();
    // |z_j − ρ z_i|², ρ = e^{iNκ_ij}: ones on the diagonal, −ρ at (j, i), −conj(ρ) at (i, j).
    let matrix = layout.fill(
        |i| c64::new(d(i), 0.0),
        |e| {
            let rho = c64::from_polar(1.0, n * tr.kappa[e]);
            (-rho, -rho.conj())
        },
        c64::new(1.0, 0.0),
    )?;
    Ok((matrix, rhs))
}

fn relaxed_forest(
    inp: &SmoothInput,
    w: &[f64],
    is_anchor: &[bool],
    start: &[usize],
    adj: &[(u32, u32)],
) -> Vec<f64> {
    let nf = inp.theta0.len();
    let tr = inp.transport;
    let mut theta = vec![f64::NAN; nf];
    let mut queue = std::collections::VecDeque::new();
    for i in 0..nf {
        if w[i] > 0.0 || is_anchor[i] {
            theta[i] = inp.theta0[i];
            queue.push_back(i);
        }
    }
    // Breadth-first spanning forest: r = 0 on tree edges, so the child is the exact transport of
    // its parent (zero residual in eq. 3.5).
    while let Some(f) = queue.pop_front() {
        for &(g, e) in &adj[start[f]..start[f + 1]] {
            let g = g as usize;
            if theta[g].is_nan() {
                let k = tr.kappa[e as usize];
                theta[g] = if tr.faces[e as usize][0] as usize == f {
                    theta[f] + k
                } else {
                    theta[f] - k
                };
                queue.push_back(g);
            }
        }
    }
    theta
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::transport::FaceBases;
    use crate::mesh::generate::torus_alternating;

    /// The pattern counted straight into columns equals the one assembled from triplets, also
    /// when two faces are paired twice (a two-triangle pillow shares two edges).
    #[test]
    fn dual_pattern_equals_the_triplet_assembly() {
        let mesh = torus_alternating(3.0, 1.0, 12, 6);
        let tr = EdgeTransport::new(&mesh, &FaceBases::new(&mesh));
        let pairs: Vec<(usize, usize)> = tr
            .faces
            .iter()
            .filter(|f| f[1] != NO_FACE)
            .map(|f| (f[0] as usize, f[1] as usize))
            .collect();
        let by_triplets = |nf: usize, pairs: &[(usize, usize)]| {
            let mut b = SparseBuilder::new(nf);
            for i in 0..nf {
                b.add(i, i, 0.0);
            }
            for &(i, j) in pairs {
                b.add_sym(i, j, 0.0);
            }
            b.build().unwrap().entries()
        };
        let nf = mesh.n_faces();
        let direct = dual_pattern(nf, pairs.iter().copied()).unwrap();
        assert_eq!(direct.entries(), by_triplets(nf, &pairs));
        assert_eq!(direct.nnz(), nf + 2 * pairs.len());
        let pillow = [(0, 1), (1, 0), (1, 2)];
        assert_eq!(
            dual_pattern(3, pillow.iter().copied()).unwrap().entries(),
            by_triplets(3, &pillow)
        );
        assert!(dual_pattern(3, [(0, 3)].into_iter()).is_err());
        assert!(dual_pattern(3, [(1, 1)].into_iter()).is_err());
    }
}
