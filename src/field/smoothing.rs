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

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::transport::{EdgeTransport, NO_FACE};
use crate::mesh::TriMesh;
use crate::sparse::{
    Analysis, DiagonalDowndate, Multigrid, Scalar, SolverError, SparseBuilder, SparseMatrix,
    SpdSolver, c64,
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
    /// The factored fixed-matching system, when [`SmoothInput::keep_system`] asked for it.
    pub system: Option<std::sync::Arc<FixedSystem>>,
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
    /// Asked with the relaxed solution's rounded turns and its magnitude |z| per face whether
    /// to renormalize it ([`RENORMALIZE_STEPS`]); only [`Relaxation::Complex`] does.
    pub renormalize: Option<&'a Renormalize<'a>>,
    /// Where the analysis of [`DualLayout::pattern`] comes from if it is computed elsewhere
    /// (it depends on the mesh only, so callers compute it while other work runs); asked for
    /// by the thread that factors the fixed-matching system beside the relaxed solve.
    pub analysis: Option<&'a AnalysisSource<'a>>,
    /// The layout of the dual systems if built elsewhere ([`DualLayout::from_mesh`] of this
    /// mesh); built here otherwise.
    pub layout: Option<&'a DualLayout>,
    /// Keep the factored fixed-matching system in [`SmoothOutput::system`], for re-solves with
    /// other matchings and released weights (singularity edits, sec. 3.3).
    pub keep_system: bool,
    /// Edges whose turn is not the nearest but the one that rotates the frame by the given
    /// angle from the edge's first face to its second (within half a step): the creases
    /// between corners that `constraint::acute_corners` holds with one face each, across which
    /// the nearest turn is the wrong one. Kept by the rounding passes, as the cancellation's
    /// are.
    pub fixed_rotations: &'a [(usize, f64)],
}

/// Where a value of a dual system comes from: the diagonal of a column, or one side of an edge's
/// pair of entries (see [`DualLayout::fill`]).
#[derive(Clone, Copy)]
enum Source {
    Diagonal {
        column: u32,
        degree: u32,
    },
    /// (j, i): the edge's first entry; (i, j): its second.
    Edge {
        edge: u32,
        second: bool,
    },
}

/// The pattern of the smoothing systems: the dual graph (faces adjacent across an interior edge,
/// `pairs` lists them) and the diagonal, with placeholder values, which all of them
/// (fixed-matching and relaxed, real and complex) share; and, when every pair of faces is
/// adjacent once, where each of its entries comes from (the index in `pairs` for the edges).
fn dual_columns(
    nf: usize,
    pairs: &[(usize, usize)],
) -> Result<(SparseMatrix, Option<Vec<Source>>), SolverError> {
    if let Some(&(i, j)) = pairs.iter().find(|&&(i, j)| i >= nf || j >= nf || i == j) {
        return Err(SolverError::Build(format!(
            "dual pair ({i}, {j}) is not two distinct faces of {nf}"
        )));
    }
    if nf >= 1 << 31 || pairs.len() >= 1 << 31 {
        return Err(SolverError::Build(format!("{nf} faces are too many")));
    }
    // Counted straight into compressed columns (column f: f and its neighbours, at most four
    // entries, sorted in place): sorting five million triplets took 0.2 s at a million faces.
    let mut col_ptr = vec![0usize; nf + 1];
    for &(i, j) in pairs {
        col_ptr[i + 1] += 1;
        col_ptr[j + 1] += 1;
    }
    for f in 0..nf {
        col_ptr[f + 1] += col_ptr[f] + 1;
    }
    let mut entries = vec![
        (
            0usize,
            Source::Edge {
                edge: 0,
                second: false
            }
        );
        col_ptr[nf]
    ];
    let mut fill: Vec<usize> = col_ptr[..nf].to_vec();
    for f in 0..nf {
        let degree = (col_ptr[f + 1] - col_ptr[f] - 1) as u32;
        entries[fill[f]] = (
            f,
            Source::Diagonal {
                column: f as u32,
                degree,
            },
        );
        fill[f] += 1;
    }
    for (k, &(i, j)) in pairs.iter().enumerate() {
        let edge = k as u32;
        entries[fill[i]] = (
            j,
            Source::Edge {
                edge,
                second: false,
            },
        );
        fill[i] += 1;
        entries[fill[j]] = (i, Source::Edge { edge, second: true });
        fill[j] += 1;
    }
    let mut repeated = false;
    for f in 0..nf {
        let column = &mut entries[col_ptr[f]..col_ptr[f + 1]];
        column.sort_unstable_by_key(|&(row, _)| row);
        repeated |= column.windows(2).any(|w| w[0].0 == w[1].0);
    }
    if repeated {
        // Two faces sharing two edges (a two-triangle pillow): one entry for both.
        let mut b = SparseBuilder::with_capacity(nf, entries.len());
        for f in 0..nf {
            for &(g, _) in &entries[col_ptr[f]..col_ptr[f + 1]] {
                b.add(g, f, 0.0);
            }
        }
        return Ok((b.build()?, None));
    }
    let (row_idx, sources): (Vec<usize>, Vec<Source>) = entries.into_iter().unzip();
    let values = vec![0.0; row_idx.len()];
    let pattern = SparseMatrix::from_columns(nf, col_ptr, row_idx, values)?;
    Ok((pattern, Some(sources)))
}

/// See [`SmoothInput::analysis`].
pub type AnalysisSource<'a> = dyn Fn() -> Result<Analysis, SolverError> + Sync + 'a;

/// See [`SmoothInput::adjust_turns`]: new turns, and the faces whose alignment to release.
pub type AdjustTurns<'a> = dyn Fn(&[f64], &[i64]) -> Option<(Vec<i64>, Vec<usize>)> + Sync + 'a;

/// See [`SmoothInput::renormalize`].
pub type Renormalize<'a> = dyn Fn(&[i64], &[f64]) -> bool + Sync + 'a;

/// Renormalization of the relaxed solution (a Merriman–Bence–Osher scheme for the
/// Ginzburg–Landau energy of z): `RENORMALIZE_STEPS` times, z ← the minimiser of the relaxed
/// energy + μ Σ_i |z_i − z_i/|z_i||², μ = [`RENORMALIZE_WEIGHT`]. The relaxed energy is
/// quadratic: where alignment constraints wind around a region that holds none (a disc whose
/// rim is an aligned curve: a cylinder's cap, a boss, a round face), its minimiser is the
/// harmonic extension of the rim's e^{iNθ}, which has one zero of order N there: on a
/// symmetric tessellation (a fan around a centre vertex, as CAD tessellators make) it rounds
/// to a pole of index +1 with polar cells. Pulling |z| towards 1 makes a zero of order N
/// unstable (N zeros of order one cost less) and pushes the zeros apart until they balance the
/// rim. Measured on a capped cylinder with its rims aligned: N = 4, 2 poles, conformal
/// distortion 1.93 (p99 7.05), 70 irregular remesh vertices → eight +1/4, 1.195 (p99 1.67),
/// 8 irregular; N = 6, 1.98 (p99 7.0), 126 irregular → twelve +1/6, 1.26 (p99 4.6). μ is in
/// the units of the dual graph (edge weights 1): 1/√μ = 10 faces is the diffusion length of a
/// step; steps/μ below about 3000 left a symmetric disc's pole whole. Converged within 30
/// steps on the meshes measured (30, 60 and 100 steps equal). Which solves renormalize is the
/// caller's choice (`field::compute_field`: under curves, when the rounding has a pole; and a
/// solution anchored almost nowhere, [`unanchored`]; docs/untangling.md has what
/// renormalizing every solve under curves measured).
pub const RENORMALIZE_STEPS: usize = 30;
/// See [`RENORMALIZE_STEPS`].
pub const RENORMALIZE_WEIGHT: f64 = 0.01;

/// The relaxed solution's magnitude below which, at its 90th percentile, it is anchored almost
/// nowhere: [`unanchored`].
pub const UNANCHORED_P90: f64 = 0.2;

/// Whether the relaxed solution (magnitudes |z| per face) is anchored almost nowhere: 90 % of
/// the faces below [`UNANCHORED_P90`], where aligned faces are near 1. On a surface whose
/// curvature directions are unreliable everywhere (a sphere: every point an umbilic) the
/// alignment holds only a few faces, the quadratic energy's minimiser decays away from them and
/// its zeros crowd together: an icosphere's N = 2 field had its four +1/2 within 23° of each
/// other, the UV sphere's N = 6 field a +1/2 and six +1/6 around one pole, and their maps folded
/// by the hundred (215 and 632 faces left after the repair). Renormalized, the zeros spread out
/// (four +1/2, twelve +1/6 as on an icosahedron) and nothing folds. The shared meshes are at
/// 0.23 or more (spot N = 6) and up to 0.98; those spheres at 0.05–0.15 (2026-12-05). A mild
/// spheroid (z × 1.6) is as low at N = 2 and 6 (0.14, 0.06) but rounds to poles at its umbilics,
/// which the pole treatment takes: `field::compute_field` leaves such a solution as it is.
pub fn unanchored(magnitudes: &[f64]) -> bool {
    if magnitudes.is_empty() {
        return false;
    }
    let mut m = magnitudes.to_vec();
    let k = (m.len() - 1) * 9 / 10;
    let p90 = *m.select_nth_unstable_by(k, f64::total_cmp).1;
    p90 < UNANCHORED_P90
}

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

/// The connected components of the dual graph, each with its most reliable face: the systems
/// need one anchor in every component without a positive weight to be definite, and which
/// components those are changes with the weights (τ = 0, released faces) while the components
/// do not.
struct DualComponents {
    label: Vec<u32>,
    /// Per component, the face with the largest ω (the first such).
    best: Vec<usize>,
}

impl DualComponents {
    /// The components of the graph of `pattern` (symmetric, the diagonal stored).
    fn new(omega: &[f64], pattern: &SparseMatrix) -> DualComponents {
        let nf = omega.len();
        let mut label = vec![u32::MAX; nf];
        let mut best = Vec::new();
        let mut stack = Vec::new();
        for root in 0..nf {
            if label[root] != u32::MAX {
                continue;
            }
            let c = best.len() as u32;
            label[root] = c;
            stack.push(root);
            // The largest ω, the smallest face among equals (so independent of the visit order).
            let mut top = root;
            while let Some(f) = stack.pop() {
                if omega[f] > omega[top] || (omega[f] == omega[top] && f < top) {
                    top = f;
                }
                for &g in pattern.column_rows(f) {
                    if label[g] == u32::MAX {
                        label[g] = c;
                        stack.push(g);
                    }
                }
            }
            best.push(top);
        }
        DualComponents { label, best }
    }

    /// Per face whether it anchors its component: the most reliable face of each component with
    /// no positive weight in `w`.
    fn anchors(&self, w: &[f64]) -> Vec<bool> {
        let mut weighted = vec![false; self.best.len()];
        for (f, &wf) in w.iter().enumerate() {
            if wf > 0.0 {
                weighted[self.label[f] as usize] = true;
            }
        }
        let mut is_anchor = vec![false; w.len()];
        for (c, &f) in self.best.iter().enumerate() {
            if !weighted[c] {
                is_anchor[f] = true;
            }
        }
        is_anchor
    }
}

/// Where each entry of the dual systems comes from, so that a system is written in place, in
/// parallel, instead of being assembled from triplets again (0.3 s a system at 1.1 M faces).
/// It depends on the mesh only: [`DualLayout::from_mesh`] lets a caller build it while other
/// work runs ([`SmoothInput::layout`]).
pub struct DualLayout {
    pattern: SparseMatrix,
    /// The interior edges and their faces (i = faces[0], j = faces[1]).
    edges: Vec<usize>,
    pairs: Vec<(usize, usize)>,
    /// Per entry; `None` when two faces share two edges (then entries are summed by position).
    sources: Option<Vec<Source>>,
}

impl DualLayout {
    fn new(tr: &EdgeTransport, nf: usize) -> Result<DualLayout, SolverError> {
        let edges: Vec<usize> = (0..tr.faces.len())
            .filter(|&e| tr.faces[e][1] != NO_FACE)
            .collect();
        let pairs: Vec<(usize, usize)> = edges
            .iter()
            .map(|&e| (tr.faces[e][0] as usize, tr.faces[e][1] as usize))
            .collect();
        Self::with_pairs(nf, edges, pairs)
    }

    /// The layout of a mesh's dual systems (the same as the transport's: an edge's faces are
    /// those of its two halfedges).
    pub fn from_mesh(mesh: &TriMesh) -> Result<DualLayout, SolverError> {
        let (edges, pairs): (Vec<usize>, Vec<(usize, usize)>) = (0..mesh.n_edges())
            .filter_map(|e| match mesh.edge_halfedges(e) {
                (h0, Some(h1)) => Some((e, (mesh.face_of(h0), mesh.face_of(h1)))),
                _ => None,
            })
            .unzip();
        Self::with_pairs(mesh.n_faces(), edges, pairs)
    }

    /// Whether this is the layout of the transport's mesh (same interior edges and faces).
    fn matches(&self, tr: &EdgeTransport) -> bool {
        self.edges.len() == tr.n_interior()
            && self
                .edges
                .iter()
                .zip(&self.pairs)
                .all(|(&e, &(i, j))| tr.faces.get(e) == Some(&[i as u32, j as u32]))
    }

    /// The pattern every dual system shares (placeholder values), e.g. for its analysis.
    pub fn pattern(&self) -> &SparseMatrix {
        &self.pattern
    }

    fn with_pairs(
        nf: usize,
        edges: Vec<usize>,
        pairs: Vec<(usize, usize)>,
    ) -> Result<DualLayout, SolverError> {
        let (pattern, sources) = dual_columns(nf, &pairs)?;
        Ok(DualLayout {
            pattern,
            edges,
            pairs,
            sources,
        })
    }

    /// Σ_e |x_j − ρ_e x_i|² + Σ_i d_i |x_i|² as a matrix: `off(e)` gives the entries −ρ_e at
    /// (j, i) and −conj(ρ_e) at (i, j); ρ = 1 for the fixed-matching system, e^{iNκ} for the
    /// relaxed one.
    fn fill<T: Scalar>(
        &self,
        d: impl Fn(usize) -> T + Sync,
        off: impl Fn(usize) -> (T, T) + Sync,
        one: T,
    ) -> Result<SparseMatrix<T>, SolverError> {
        let Some(sources) = &self.sources else {
            return self.fill_by_position(d, off, one);
        };
        let off: Vec<(T, T)> = self.edges.par_iter().map(|&e| off(e)).collect();
        let values = sources
            .par_iter()
            .map(|source| match *source {
                Source::Diagonal { column, degree } => {
                    d(column as usize) + one.scaled(degree as f64)
                }
                Source::Edge { edge, second } => {
                    let (a, b) = off[edge as usize];
                    if second { b } else { a }
                }
            })
            .collect();
        self.pattern.with_values(values)
    }

    /// [`DualLayout::fill`] when two faces share two edges: entries summed by position.
    fn fill_by_position<T: Scalar>(
        &self,
        d: impl Fn(usize) -> T,
        off: impl Fn(usize) -> (T, T),
        one: T,
    ) -> Result<SparseMatrix<T>, SolverError> {
        let missing = || SolverError::Build("dual system entry missing from its pattern".into());
        let position = |i: usize, j: usize| self.pattern.position(i, j).ok_or_else(missing);
        let mut v = vec![T::ZERO; self.pattern.nnz()];
        for i in 0..self.pattern.n() {
            v[position(i, i)?] += d(i);
        }
        for (&e, &(i, j)) in self.edges.iter().zip(&self.pairs) {
            v[position(i, i)?] += one;
            v[position(j, j)?] += one;
            let (a, b) = off(e);
            v[position(j, i)?] += a;
            v[position(i, j)?] += b;
        }
        self.pattern.with_values(v)
    }
}

pub fn smooth(inp: &SmoothInput) -> Result<SmoothOutput, SolverError> {
    smooth_releasing_by(inp, Release::Downdate)
}

/// How the fixed-matching system takes the weights the cancellation released (see
/// [`ReleasedSystem`]); tests compare the two.
#[derive(Clone, Copy, PartialEq)]
#[cfg_attr(not(test), allow(dead_code))] // `Refactor`: only tests ask for it.
enum Release {
    Downdate,
    Refactor,
}

fn smooth_releasing_by(inp: &SmoothInput, release: Release) -> Result<SmoothOutput, SolverError> {
    let nf = inp.theta0.len();
    let tr = inp.transport;
    let step = TAU / inp.n as f64;
    let tau = inp.tau.max(0.0);
    let w: Vec<f64> = inp.omega.iter().map(|o| tau * o.max(0.0)).collect();
    let built;
    let layout = match inp.layout {
        Some(layout) if layout.pattern.n() == nf && layout.matches(tr) => layout,
        _ => {
            built = DualLayout::new(tr, nf)?;
            &built
        }
    };
    // Anchors of the fixed-matching system (before any weight is released).
    let components = DualComponents::new(inp.omega, &layout.pattern);
    let anchor_fixed = components.anchors(&w);

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
        let a0 = components.anchors(&w0);
        (w0, a0)
    } else {
        (w.clone(), anchor_fixed.clone())
    };

    let mut timings = Vec::new();
    let mut clock = std::time::Instant::now();
    let mut lap = |name: String, timings: &mut Vec<(String, f64)>| {
        timings.push((name, clock.elapsed().as_secs_f64()));
        clock = std::time::Instant::now();
    };
    let fixed_matrix = |w: &[f64], is_anchor: &[bool]| {
        layout.fill(
            |i| w[i] + if is_anchor[i] { 1.0 } else { 0.0 },
            |_| (-1.0, -1.0),
            1.0,
        )
    };
    std::thread::scope(|scope| {
        // Fixed-matching system: dual Laplacian + diag(τω) + anchors. Its matrix does not depend
        // on the relaxed solution, only the right-hand side does (through the matchings), so it
        // is factored on a thread of its own beside the relaxed solve (at a million faces the
        // factorization takes 1.5 s and uses mostly one core). The weights the cancellation
        // releases afterwards lower a few diagonal entries, which a low-rank correction of this
        // factor takes (see `sparse::downdate`) instead of a second factorization.
        let factoring = scope.spawn(|| -> Result<(SpdSolver, SparseMatrix, f64), SolverError> {
            let matrix = fixed_matrix(&w, &anchor_fixed)?;
            let analysis = match inp.analysis {
                Some(source) => source()?,
                None => Analysis::new(&matrix)?,
            };
            let clock = std::time::Instant::now();
            let solver = SpdSolver::with_analysis_sequential(analysis, &matrix)?;
            Ok((solver, matrix, clock.elapsed().as_secs_f64()))
        });

        let relaxed = match inp.relaxation {
            Relaxation::Complex => {
                let (matrix, rhs) =
                    relaxed_complex_system(inp, &w_relaxed, &anchor_relaxed, layout)?;
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
                let angles =
                    |z: &[c64]| -> Vec<f64> { z.iter().map(|z| z.arg() / inp.n as f64).collect() };
                let mut z = solution.x;
                if let Some(ask) = inp.renormalize {
                    let asked = ask(
                        &nearest_turns(tr, &angles(&z), step),
                        &z.iter().map(|z| z.norm()).collect::<Vec<_>>(),
                    );
                    lap("smoothing: whether to renormalize".into(), &mut timings);
                    if asked {
                        z = renormalized(inp, &w_relaxed, &anchor_relaxed, layout, &rhs, z)?;
                        lap("smoothing: renormalization".into(), &mut timings);
                    }
                }
                angles(&z)
            }
            Relaxation::SpanningForest => {
                let (start, adj) = dual_adjacency(tr, nf);
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

        // Sec. 3.3 on the rounded relaxed field: the faces along a cancelled pair's path lose
        // their alignment weight (a moved singularity's path through trusted faces would
        // otherwise leave a seam in the field). The changed edges stay pinned in the rounding
        // passes below, which would otherwise be free to round the pair back.
        let w_before = &w;
        let mut w = w.clone();
        let mut pinned = vec![false; r.len()];
        for &(e, rotation) in inp.fixed_rotations {
            let [f0, f1] = tr.faces[e];
            if f1 != NO_FACE {
                let d = relaxed[f1 as usize] - relaxed[f0 as usize] - tr.kappa[e] - rotation;
                r[e] = (d / step).round() as i64;
                pinned[e] = true;
            }
        }
        let mut released = Vec::new();
        if let Some(adjust) = inp.adjust_turns
            && let Some((adjusted, faces)) = adjust(&relaxed, &r)
        {
            for (e, (a, b)) in adjusted.iter().zip(&r).enumerate() {
                pinned[e] |= a != b;
            }
            r = adjusted;
            for f in faces {
                if w[f] != 0.0 {
                    released.push((f, w[f]));
                    w[f] = 0.0;
                }
            }
        }
        lap("smoothing: cancellation".into(), &mut timings);

        let (solver, matrix_before, factor_seconds) = factoring
            .join()
            .map_err(|_| SolverError::Build("the factorization thread panicked".into()))??;
        lap(
            "smoothing: waiting for the fixed-matching factorization".into(),
            &mut timings,
        );
        timings.push((
            "smoothing: (beside the relaxed solve) fixed-matching factorization".into(),
            factor_seconds,
        ));
        let is_anchor = if released.is_empty() {
            anchor_fixed.clone()
        } else {
            components.anchors(&w)
        };
        let released_system = if released.is_empty() {
            ReleasedSystem::Unchanged
        } else if release == Release::Downdate
            && is_anchor == anchor_fixed
            && let Some(system) =
                ReleasedSystem::downdate(&solver, matrix_before.clone(), &released)
        {
            system
        } else {
            let matrix = fixed_matrix(&w, &is_anchor)?;
            ReleasedSystem::Refactored(SpdSolver::with_analysis(
                solver.analysis().clone(),
                &matrix,
            )?)
        };
        if !released.is_empty() {
            lap(released_system.describe(released.len()), &mut timings);
        }

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
            let theta = released_system.solve(&solver, &rhs_for(&r))?;
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
        let fell_back = if released_system.fell_back() {
            "; the low-rank correction was inaccurate, refactored"
        } else {
            ""
        };
        lap(
            format!("smoothing: rounding passes ({passes}{fell_back})"),
            &mut timings,
        );
        let (e_smooth, e_align) = energies(tr, step, &theta, &r, inp.omega, &target);
        drop(released_system);
        let anchors = (0..nf).filter(|&i| is_anchor[i]).collect();
        let system = if inp.keep_system {
            Some(std::sync::Arc::new(FixedSystem {
                relaxed,
                solver,
                matrix_before,
                components,
                anchor_fixed: anchor_fixed.clone(),
                w_before: w_before.clone(),
                released_by_cancellation: released.iter().map(|&(f, _)| f).collect(),
                target,
                step,
            }))
        } else {
            None
        };
        Ok(SmoothOutput {
            theta,
            r,
            e_smooth,
            e_align,
            passes,
            anchors,
            timings,
            system,
        })
    })
}

/// The relaxed (complex) minimiser z per face for the alignment weights `w` (τω, already
/// scaled) towards `theta0`: the field the weighted faces alone would extend, and by |z| how
/// firmly they determine it there (near 1 beside them, decaying where their directions wind or
/// cancel out). z = 0 on the components of the dual graph without any weight (solved with an
/// anchor, whose direction says nothing).
pub fn relaxed_z(
    n: u32,
    transport: &EdgeTransport,
    theta0: &[f64],
    w: &[f64],
    layout: &DualLayout,
) -> Result<Vec<c64>, SolverError> {
    let nf = theta0.len();
    let components = DualComponents::new(w, &layout.pattern);
    let anchor = components.anchors(w);
    let inp = SmoothInput {
        n,
        transport,
        theta0,
        omega: w,
        tau: 1.0,
        relaxation: Relaxation::Complex,
        adjust_turns: None,
        renormalize: None,
        analysis: None,
        layout: Some(layout),
        keep_system: false,
        fixed_rotations: &[],
    };
    let (matrix, rhs) = relaxed_complex_system(&inp, w, &anchor, layout)?;
    let hierarchy = Multigrid::new(&matrix)?;
    drop(matrix);
    let mut z = hierarchy
        .solve(&rhs, None, RELAXED_TOLERANCE, RELAXED_MAX_ITERATIONS)?
        .x;
    let mut anchored = vec![false; components.best.len()];
    for f in (0..nf).filter(|&f| anchor[f]) {
        anchored[components.label[f] as usize] = true;
    }
    for (f, zf) in z.iter_mut().enumerate() {
        if anchored[components.label[f] as usize] {
            *zf = c64::new(0.0, 0.0);
        }
    }
    Ok(z)
}

/// The factored fixed-matching system of a smoothing (dual Laplacian + τω + anchors, before the
/// cancellation released any weight), with the alignment targets: re-solves the angles for
/// other integer turns and further released faces (thesis sec. 3.3: after moving singularities,
/// "minimize the energy E again for the unknowns α_i, holding the matchings fix"). The released
/// weights are taken by a low-rank correction of the factor, as in the smoothing itself.
pub struct FixedSystem {
    solver: SpdSolver,
    matrix_before: SparseMatrix,
    components: DualComponents,
    anchor_fixed: Vec<bool>,
    /// The relaxed solution's angles: an anchor face is held there.
    relaxed: Vec<f64>,
    w_before: Vec<f64>,
    released_by_cancellation: Vec<usize>,
    target: Vec<f64>,
    step: f64,
}

impl std::fmt::Debug for FixedSystem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FixedSystem")
            .field("faces", &self.target.len())
            .field(
                "released_by_cancellation",
                &self.released_by_cancellation.len(),
            )
            .finish()
    }
}

impl FixedSystem {
    /// Alignment target per face (the representative of the curvature direction nearest the
    /// relaxed solution).
    pub fn target(&self) -> &[f64] {
        &self.target
    }

    /// Weight τω_i per face before any release.
    pub fn weights(&self) -> &[f64] {
        &self.w_before
    }

    /// Faces whose weight the smoothing's pair cancellation released.
    pub fn released_by_cancellation(&self) -> &[usize] {
        &self.released_by_cancellation
    }

    /// Angles minimising E_smooth + τE_align for the turns `r` (per edge, first face to second)
    /// with the weights of the cancellation's and of `released` faces set to 0. A pure function
    /// of its arguments: the same inputs give bit-identical angles.
    pub fn solve(
        &self,
        tr: &EdgeTransport,
        r: &[i64],
        released: &[usize],
    ) -> Result<Vec<f64>, SolverError> {
        let nf = self.target.len();
        if r.len() != tr.faces.len() {
            return Err(SolverError::Build(format!(
                "{} turns for {} edges",
                r.len(),
                tr.faces.len()
            )));
        }
        let mut w = self.w_before.clone();
        let mut drop_weights = Vec::new();
        for &f in self.released_by_cancellation.iter().chain(released) {
            if f >= nf {
                return Err(SolverError::Build(format!(
                    "released face {f} out of range"
                )));
            }
            if w[f] != 0.0 {
                drop_weights.push((f, w[f]));
                w[f] = 0.0;
            }
        }
        let is_anchor = self.components.anchors(&w);
        let system = if drop_weights.is_empty() {
            ReleasedSystem::Unchanged
        } else if is_anchor == self.anchor_fixed
            && let Some(system) =
                ReleasedSystem::downdate(&self.solver, self.matrix_before.clone(), &drop_weights)
        {
            system
        } else {
            let mut values = self.matrix_before.values().to_vec();
            for f in 0..nf {
                let before = self.w_before[f] + if self.anchor_fixed[f] { 1.0 } else { 0.0 };
                let after = w[f] + if is_anchor[f] { 1.0 } else { 0.0 };
                if before != after {
                    let p = self.matrix_before.position(f, f).ok_or_else(|| {
                        SolverError::Build("fixed-matching diagonal entry missing".into())
                    })?;
                    values[p] += after - before;
                }
            }
            let matrix = self.matrix_before.with_values(values)?;
            ReleasedSystem::Refactored(SpdSolver::with_analysis(
                self.solver.analysis().clone(),
                &matrix,
            )?)
        };
        let mut rhs: Vec<f64> = (0..nf)
            .map(|i| w[i] * self.target[i] + if is_anchor[i] { self.relaxed[i] } else { 0.0 })
            .collect();
        for (e, f) in tr.faces.iter().enumerate() {
            if f[1] != NO_FACE {
                let c = tr.kappa[e] + self.step * r[e] as f64;
                rhs[f[0] as usize] -= c;
                rhs[f[1] as usize] += c;
            }
        }
        system.solve(&self.solver, &rhs)
    }
}

/// The fixed-matching system after the cancellation released alignment weights: the factor of
/// the system before, corrected for the lowered diagonal (Woodbury, `sparse::downdate`), or, when
/// that does not apply (a small, simplicial factor; a component left without any weight, which
/// changes the anchors), a refactorization.
#[allow(clippy::large_enum_variant)] // one per smoothing, never moved around
enum ReleasedSystem<'a> {
    Unchanged,
    Downdated {
        downdate: DiagonalDowndate<'a>,
        /// The system before the release and the released (face, weight), to check each
        /// solution's residual: the correction loses digits when released weights dwarf the
        /// rest of their row (τ ≫ 1), and then the system is refactored after all (once).
        before: SparseMatrix,
        released: Vec<(usize, f64)>,
        fallback: std::sync::OnceLock<SpdSolver>,
    },
    Refactored(SpdSolver),
}

/// Relative residual above which a downdated solve is not trusted (the factorization's own are
/// around 1e-15).
const DOWNDATE_RESIDUAL: f64 = 1e-10;

impl<'a> ReleasedSystem<'a> {
    fn downdate(
        solver: &'a SpdSolver,
        before: SparseMatrix,
        released: &[(usize, f64)],
    ) -> Option<Self> {
        let (faces, decrease): (Vec<usize>, Vec<f64>) = released.iter().copied().unzip();
        let downdate = solver.downdated(&faces, &decrease).ok()?;
        Some(ReleasedSystem::Downdated {
            downdate,
            before,
            released: released.to_vec(),
            fallback: std::sync::OnceLock::new(),
        })
    }

    fn describe(&self, released: usize) -> String {
        match self {
            ReleasedSystem::Refactored(_) => {
                format!("smoothing: refactorization ({released} released faces)")
            }
            _ => format!("smoothing: low-rank correction ({released} released faces)"),
        }
    }

    fn solve(&self, solver: &SpdSolver, rhs: &[f64]) -> Result<Vec<f64>, SolverError> {
        match self {
            ReleasedSystem::Unchanged => solver.solve(rhs),
            ReleasedSystem::Refactored(refactored) => refactored.solve(rhs),
            ReleasedSystem::Downdated {
                downdate,
                before,
                released,
                fallback,
            } => {
                if let Some(refactored) = fallback.get() {
                    return refactored.solve(rhs);
                }
                let x = downdate.solve(rhs)?;
                let mut residual = before.mul_vec(&x);
                for &(f, d) in released {
                    residual[f] -= d * x[f];
                }
                let norm = |v: &mut dyn Iterator<Item = f64>| v.map(|a| a * a).sum::<f64>().sqrt();
                let error = norm(&mut residual.iter().zip(rhs).map(|(a, b)| a - b));
                if error <= DOWNDATE_RESIDUAL * norm(&mut rhs.iter().copied()) {
                    return Ok(x);
                }
                let mut values = before.values().to_vec();
                for &(f, d) in released {
                    let p = before.position(f, f).ok_or_else(|| {
                        SolverError::Build("fixed-matching diagonal entry missing".into())
                    })?;
                    values[p] -= d;
                }
                let matrix = before.with_values(values)?;
                let refactored = SpdSolver::with_analysis(solver.analysis().clone(), &matrix)?;
                fallback.get_or_init(|| refactored).solve(rhs)
            }
        }
    }

    /// Whether a downdated solve was found inaccurate and the system refactored.
    fn fell_back(&self) -> bool {
        matches!(self, ReleasedSystem::Downdated { fallback, .. } if fallback.get().is_some())
    }
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
    let d = |i: usize| w[i] + if is_anchor[i] { 1.0 } else { 0.0 };
    let rhs = (0..inp.theta0.len())
        .into_par_iter()
        .map(|i| c64::from_polar(d(i), n * inp.theta0[i]))
        .collect();
    Ok((relaxed_matrix(inp, layout, d)?, rhs))
}

/// The relaxed energy's matrix with `diagonal(i)` added on face i's diagonal:
/// |z_j − ρ z_i|², ρ = e^{iNκ_ij}: ones on the diagonal, −ρ at (j, i), −conj(ρ) at (i, j).
fn relaxed_matrix(
    inp: &SmoothInput,
    layout: &DualLayout,
    diagonal: impl Fn(usize) -> f64 + Sync,
) -> Result<SparseMatrix<c64>, SolverError> {
    let n = inp.n as f64;
    let tr = inp.transport;
    layout.fill(
        |i| c64::new(diagonal(i), 0.0),
        |e| {
            let rho = c64::from_polar(1.0, n * tr.kappa[e]);
            (-rho, -rho.conj())
        },
        c64::new(1.0, 0.0),
    )
}

/// The relaxed solution `z` renormalized ([`RENORMALIZE_STEPS`]): each step solves the relaxed
/// system with μ added to its diagonal and μ z_i/|z_i| to its right-hand side, by the same
/// preconditioned CG from the previous step. Zeros (|z_i| = 0) add nothing.
fn renormalized(
    inp: &SmoothInput,
    w: &[f64],
    is_anchor: &[bool],
    layout: &DualLayout,
    rhs: &[c64],
    mut z: Vec<c64>,
) -> Result<Vec<c64>, SolverError> {
    let mu = RENORMALIZE_WEIGHT;
    let matrix = relaxed_matrix(inp, layout, |i| {
        w[i] + if is_anchor[i] { 1.0 } else { 0.0 } + mu
    })?;
    let hierarchy = Multigrid::new(&matrix)?;
    drop(matrix);
    let tolerance = relaxed_tolerance(inp.tau.max(0.0));
    for _ in 0..RENORMALIZE_STEPS {
        let b: Vec<c64> = z
            .iter()
            .zip(rhs)
            .map(|(z, r)| {
                let a = z.norm();
                if a > 0.0 { *r + z.scaled(mu / a) } else { *r }
            })
            .collect();
        z = hierarchy
            .solve(&b, Some(&z), tolerance, RELAXED_MAX_ITERATIONS)?
            .x;
    }
    Ok(z)
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
        let direct = dual_columns(nf, &pairs).unwrap().0;
        assert_eq!(direct.entries(), by_triplets(nf, &pairs));
        assert_eq!(direct.nnz(), nf + 2 * pairs.len());
        let pillow = [(0, 1), (1, 0), (1, 2)];
        assert_eq!(
            dual_columns(3, &pillow).unwrap().0.entries(),
            by_triplets(3, &pillow)
        );
        assert!(dual_columns(3, &[(0, 3)]).is_err());
        assert!(dual_columns(3, &[(1, 1)]).is_err());
    }

    /// The parallel fill by entry sources writes the same matrix as summing by position.
    #[test]
    fn layout_fill_by_sources_equals_fill_by_position() {
        let mesh = torus_alternating(3.0, 1.0, 12, 6);
        let tr = EdgeTransport::new(&mesh, &FaceBases::new(&mesh));
        let layout = DualLayout::new(&tr, mesh.n_faces()).unwrap();
        assert!(layout.sources.is_some());
        // Built from the mesh alone, it is the transport's; another mesh's is not.
        let from_mesh = DualLayout::from_mesh(&mesh).unwrap();
        assert!(from_mesh.matches(&tr));
        assert_eq!(from_mesh.pattern().entries(), layout.pattern().entries());
        let other = torus_alternating(3.0, 1.0, 13, 6);
        assert!(!DualLayout::from_mesh(&other).unwrap().matches(&tr));
        let d = |i: usize| c64::new(0.5 + i as f64, 0.0);
        let off = |e: usize| {
            let rho = c64::from_polar(1.0, e as f64);
            (-rho, -rho.conj())
        };
        let one = c64::new(1.0, 0.0);
        let fast = layout.fill(d, off, one).unwrap();
        let slow = layout.fill_by_position(d, off, one).unwrap();
        assert_eq!(fast.entries(), slow.entries());
        // Hermitian, and each row sums its diagonal weight, degree and couplings.
        for (i, j, v) in fast.entries() {
            let p = fast.position(j, i).unwrap();
            assert_eq!(fast.values()[p], v.conj());
        }
    }

    /// Released weights taken by the low-rank correction of the factor give the field a
    /// refactorization gives: the same matchings and angles to rounding error.
    #[test]
    fn released_weights_by_downdate_equal_a_refactorization() {
        use crate::field::curvature::Curvature;
        let mesh = torus_alternating(3.0, 1.0, 240, 120);
        let bases = FaceBases::new(&mesh);
        let tr = EdgeTransport::new(&mesh, &bases);
        let curvature = Curvature::compute(&mesh, &bases, 0);
        let omega = curvature.reliability(0.1, &vec![true; mesh.n_faces()]);
        let reliable = omega.iter().filter(|w| **w > 0.0).count();
        // Release every 70th of the first half of the reliable faces, keep the turns (a few dozen,
        // as cancelled pairs release: with hundreds on this small mesh, refactoring is cheaper).
        let released: Vec<usize> = (0..mesh.n_faces())
            .filter(|&f| omega[f] > 0.0)
            .take(reliable / 2)
            .step_by(70)
            .collect();
        assert!(released.len() > 20, "{} of {reliable}", released.len());
        let adjust = |_: &[f64], turns: &[i64]| Some((turns.to_vec(), released.clone()));
        let input = SmoothInput {
            n: 4,
            transport: &tr,
            theta0: &curvature.dir1,
            omega: &omega,
            tau: 100.0,
            relaxation: Relaxation::Complex,
            adjust_turns: Some(&adjust),
            renormalize: None,
            analysis: None,
            layout: None,
            keep_system: true,
            fixed_rotations: &[],
        };
        let down = smooth_releasing_by(&input, Release::Downdate).unwrap();
        let refactored = smooth_releasing_by(&input, Release::Refactor).unwrap();
        let took =
            |out: &SmoothOutput, what: &str| out.timings.iter().any(|(n, _)| n.contains(what));
        assert!(took(&down, "low-rank correction"), "{:?}", down.timings);
        assert!(took(&refactored, "refactorization"));
        assert!(!took(&down, "refactored"), "{:?}", down.timings);
        assert_eq!(down.r, refactored.r);
        let diff = down
            .theta
            .iter()
            .zip(&refactored.theta)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(diff < 1e-9, "angles differ by {diff:e}");
        // The kept system re-solves the same turns to the same angles (the edit model's base).
        let system = down.system.as_ref().expect("kept");
        let again = system.solve(&tr, &down.r, &[]).unwrap();
        let diff = again
            .iter()
            .zip(&down.theta)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(diff < 1e-9, "re-solve differs by {diff:e}");
        // The release mattered: without it the angles are others.
        let kept = smooth_releasing_by(
            &SmoothInput {
                adjust_turns: None,
                renormalize: None,
                ..input
            },
            Release::Downdate,
        )
        .unwrap();
        let moved = kept
            .theta
            .iter()
            .zip(&down.theta)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(moved > 1e-6, "releasing changed nothing ({moved:e})");
    }
}
