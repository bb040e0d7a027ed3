//! QuadCover (thesis ch. 2, sec. 4.1.2, 4.2): seamless global parameterization of a triangle
//! mesh guided by a frame field with N-fold rotational symmetry, N = 2 (stripes), 4 (quads),
//! 6 (hexagons).
//!
//! Pipeline ([`QuadCover::new`] once per mesh + matchings, [`QuadCover::solve`] per field):
//! 1. Cut graph (`cut`): branch points from the matchings, a greedy shortest system of loops
//!    with boundary vertices and branch points as one identified root; per-edge transitions.
//! 2. Local step (`local`, alg. 3): co-gradient removal with the 2×2-block Crouzeix–Raviart
//!    Laplacian (eq. 2.42), integration of the curl*-free field over the dual spanning forest.
//! 3. Global step (`global`, alg. 4): loop gaps measured and rounded to the lattice, conforming
//!    2×2-block Laplacian solved with the path basis (eq. 2.43–2.44); branch points land where
//!    eq. 2.40 puts them (½Z² for quads, Z² with `pure_quad`).
//!
//! Both sparse systems depend only on geometry, matchings and cut graph, so they are factored in
//! [`QuadCover::new`]; solving for new frames (same matchings) is back-substitution only.
//!
//! Output (per corner `3f + k`, Euclidean texture coordinates, grid unit 1): across every
//! interior edge e with faces i = face(h0), j = face(h1), `uv_j = R^t uv_i + τ` with R the
//! matching matrix M_1 (a rotation by −2π/N of texture space, `field::matching_matrix`) and τ in the lattice ([`Parameterization::transitions`]); t = 0, τ = 0 away
//! from the cut graph.

// Index loops over the 3 corners / vertices read clearer than iterator chains here.
#![allow(clippy::needless_range_loop)]

mod batched;
mod constrained;
mod constraints;
pub mod crowded;
mod cut;
mod global;
mod integer;
mod local;
mod metrics;
mod poles;
mod relax_conformal;
use relax_conformal::LastSolve;
mod reround;
mod rot;
mod system;
mod under_curves;
mod untangle;

pub mod pipeline;

pub mod bench;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use glam::DVec3;
use serde::Serialize;
use thiserror::Error;

use crate::mesh::TriMesh;
use crate::sparse::{Analysis, SolverError};

pub use constraints::{ConstraintCurve, CurveFit};
pub use crowded::CrowdedRefinement;
pub use local::curl_star;
pub use poles::{FileQuad, Locus, Pole, Tessellation, poles_from_quads, tessellate};
pub use rot::Lattice;

use cut::CutGraph;
use global::GlobalSystem;
use local::LocalSystem;
use rot::Rots;
use system::Factoring;

#[derive(Debug, Error)]
pub enum ParamError {
    #[error("invalid input: {0}")]
    InvalidInput(String),
    #[error(transparent)]
    Solver(#[from] SolverError),
    /// The constraint curves admit no parameterization (thesis sec. 4.4); `curves` are the ids
    /// of the curves involved, which the message names.
    #[error("{message}")]
    Contradiction { curves: Vec<u32>, message: String },
    /// The caller's cancel check said stop (during the injectivity repair).
    #[error("cancelled")]
    Cancelled,
}

/// Whether a first map under curves whose 2Z² rounding collapsed strips between parallel
/// curves ([`Parameterization::collapsed_strips`]) and that keeps folds takes crowded tries
/// ([`QuadCover::solve_speculating`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Collapse {
    /// As any other map.
    Tries,
    /// None: no finer grid widens a strip the rounding collapsed (a comb's slots, a gear's
    /// teeth at coarse grids: 3–24 s of tries, none kept), and the caller solves it on Z²
    /// instead (`Base::on_z2_if_folded`).
    ToZ2,
}

/// A cancel check polled by long steps (the repair): true = stop.
pub type CancelCheck<'a> = &'a (dyn Fn() -> bool + Sync);

/// Receives the global step's map (per-corner UVs, seamless, singularities and gaps on the
/// lattice) when the injectivity repair is about to change it: the editor shows it while the
/// repair runs.
pub type PreviewSink<'a> = &'a (dyn Fn(&[[f64; 2]]) + Sync);

/// A [`PreviewSink`] that ignores the preview.
pub fn no_preview(_: &[[f64; 2]]) {}

/// How loop gaps are rounded to the lattice.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum Rounding {
    /// All gaps at once to the nearest lattice point (the thesis, alg. 4).
    #[default]
    Direct,
    /// MIQ-style: fix the gap closest to the lattice, re-optimise the rest, repeat.
    Greedy,
}

#[derive(Clone, Debug, Default)]
pub struct ParamOptions {
    pub rounding: Rounding,
    /// Gaps in 2Z² (N = 2, 4) so that singularities land on Z² (end of sec. 2.4.5).
    pub pure_quad: bool,
    /// Skip the injectivity repair after the global step (`untangle`): folds stay.
    pub no_untangle: bool,
    /// Skip alg. 6 for singularities of positive integral index (sec. 4.3): the PL map
    /// degenerates around them (fig. 4.14, left). For comparisons.
    pub no_poles: bool,
    /// Never solve again on grids made finer around crowded singularities
    /// ([`crowded::LADDER`]) when the first map keeps folds or mis-wound vertices.
    pub no_crowded_refinement: bool,
}

/// A frame field as QuadCover consumes it (see `FrameField` in docs/CONTRACTS.md): per face the
/// rows (U, V) of the target Jacobian, per edge the matching r_e (φ_j = R^{r_e} φ_i + w).
#[derive(Clone, Copy, Debug)]
pub struct FieldRef<'a> {
    pub symmetry: usize,
    pub frames: &'a [[DVec3; 2]],
    pub matchings: &'a [i32],
}

#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct StageTimings {
    pub cut_ms: f64,
    pub local_ms: f64,
    pub global_ms: f64,
    /// The injectivity repair (0 when nothing was folded or it is off).
    pub repair_ms: f64,
}

/// A gap the injectivity repair rounded again (its first rounding collapsed cells: two
/// branch points on one lattice point).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Rerounded {
    /// Index of the cut path (as in [`Parameterization::gaps`]).
    pub path: usize,
    pub from: [f64; 2],
    pub to: [f64; 2],
}

/// Transition across an interior edge: uv_j = R^rotation uv_i + translation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct EdgeTransition {
    pub rotation: u8,
    pub translation: [f64; 2],
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Singularity {
    pub vertex: usize,
    /// Index (multiple of 1/N).
    pub index: f64,
    /// Holonomy Σ r around the vertex (mod N): the fractional index times N.
    pub holonomy: u8,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Distortion {
    pub mean: f64,
    pub p99: f64,
}

impl LocalSolution {
    /// Σ_f A_f (‖U_f − U*_f‖² + ‖V_f − V*_f‖²): the part of `frames` the local step removed.
    pub fn curl(&self, mesh: &TriMesh, frames: &[[DVec3; 2]]) -> f64 {
        removed(mesh, frames, &self.curl_free)
    }
}

/// Σ_f A_f (‖U_f − U*_f‖² + ‖V_f − V*_f‖²).
fn removed(mesh: &TriMesh, frames: &[[DVec3; 2]], curl_free: &[[DVec3; 2]]) -> f64 {
    frames
        .iter()
        .zip(curl_free)
        .enumerate()
        .map(|(f, (x, y))| {
            mesh.face_area(f) * ((x[0] - y[0]).length_squared() + (x[1] - y[1]).length_squared())
        })
        .sum()
}

/// The local step's result: curl*-free frames, their integral on M \ G and the measured gaps.
#[derive(Clone, Debug)]
pub struct LocalSolution {
    /// Curl*-free frames in each face's own frame (same convention as the input).
    pub curl_free: Vec<[DVec3; 2]>,
    disk: Vec<[DVec3; 2]>,
    /// The input frames in the same disk frames: unlike the curl*-free ones never degenerate
    /// next to a singularity (the references of the rewinding and, near branch points, of the
    /// repair: `untangle::rewind`, `untangle::repair`).
    guide: Vec<[DVec3; 2]>,
    /// Integrated values per corner (disk frames), not yet seamless.
    pub uv: Vec<[f64; 2]>,
    /// Measured gap of each cut path (real valued).
    pub gaps: Vec<[f64; 2]>,
    pub local_ms: f64,
}

#[derive(Clone, Debug)]
pub struct Parameterization {
    pub symmetry: usize,
    pub lattice: Lattice,
    /// Per corner 3f + k.
    pub uv: Vec<[f64; 2]>,
    /// Interior vertices with non-zero index: the branch points (holonomy ≠ 0, fractional
    /// index) and vertices of non-zero integral index (not branch points, sec. 4.3).
    pub singularities: Vec<Singularity>,
    /// One vertex path per cut path γ_k (2g + b + s − 1 of them, see [`expected_cut_paths`]).
    pub cut_paths: Vec<Vec<usize>>,
    /// Measured (local step) and rounded gaps per cut path.
    pub gaps_measured: Vec<[f64; 2]>,
    pub gaps: Vec<[f64; 2]>,
    /// Per edge (identity on boundary edges and away from the cut graph).
    pub transitions: Vec<EdgeTransition>,
    /// Faces whose texture triangle has non-positive signed area, after the repair.
    pub flipped_faces: usize,
    /// The same before the injectivity repair (equal to `flipped_faces` when it is off).
    pub flipped_faces_before_repair: usize,
    /// Gaps the repair rounded again because their first rounding made folds unavoidable.
    pub rerounded_gaps: Vec<Rerounded>,
    /// Under curves, quads on 2Z²: the corners where curves meet that the first rounding put
    /// on the line of a parallel curve half a cell or more from them (and under two cells away
    /// in space), collapsing the strip between
    /// (`constraints::Traced::collapsed_strips`; no repair widens it again). A map solved on
    /// Z² instead (`Base::on_z2_if_folded`) keeps the 2Z² rounding's count.
    pub collapsed_strips: usize,
    /// Interior vertices whose fan turns by other than their cone angle 2π(1 − index) although
    /// no face around them need be folded (e.g. a −1/4 branch point turning 90° instead of
    /// 450° beside a vertex turning 720°): the map is not locally injective there, and the
    /// remesh gets a patched place. Poles' stars are not checked.
    pub miswound: Vec<usize>,
    /// Singularities of positive integral index treated by alg. 6: their stars' triangles are
    /// bilinear quads (`uv` keeps the triangles' own corners there, which are not seamless at
    /// the pole: seams and folds of those faces are their quads').
    pub poles: Vec<Pole>,
    /// Poles alg. 6 could not treat (the star touches the boundary, another pole's star or a
    /// constraint curve): the map degenerates around them.
    pub untreated_poles: Vec<usize>,
    /// The curl of the guiding field: what the local step removes, Σ_f A_f ‖X_f − X*_f‖² over
    /// both frame rows (X* the curl*-free frames), in grid cells (thesis sec. 3.3 measures
    /// singularity placement by it).
    pub curl: f64,
    pub seam_max_error: f64,
    /// How each constraint curve sits in the map (empty without curves).
    pub curves: Vec<CurveFit>,
    pub conformal_distortion: Distortion,
    pub area_distortion: f64,
    pub timings: StageTimings,
    /// Set when the map is one of the tries on a grid made finer around crowded singularities
    /// ([`crowded::LADDER`]): the first ended with folds or mis-wound vertices, this one with
    /// fewer.
    pub crowded_refinement: Option<CrowdedRefinement>,
}

impl Parameterization {
    /// Whether the solve that made this map took the crowded tries (a try was kept, or the map
    /// still has folds or mis-wound vertices, which asks for them unless they are off). Under
    /// curves a few mis-wound vertices ask for none ([`crowded::FEW_MISWOUND`]).
    pub fn took_crowded_tries(&self) -> bool {
        self.crowded_refinement.is_some() || !crowded_done(self, !self.curves.is_empty())
    }
}

/// Number of cut paths the construction yields: per component with genus g, b boundary loops
/// and s branch points, 2g + b + s − 1 if b + s ≥ 1, else 2g; summed over components.
pub fn expected_cut_paths(genus: usize, boundary_loops: usize, branch_points: usize) -> usize {
    let k = boundary_loops + branch_points;
    if k == 0 { 2 * genus } else { 2 * genus + k - 1 }
}

/// The symbolic analyses (fill-reducing orderings) of QuadCover's two systems. Their patterns
/// depend on the mesh only, not on the symmetry, matchings or cut graph: unknowns that those
/// remove (branch points, pinned nodes) keep decoupled identity rows instead.
#[derive(Clone, Debug)]
pub struct ParamAnalysis {
    local: Analysis,
    global: Analysis,
}

impl ParamAnalysis {
    /// Both analyses, one after the other: meant to run on a thread of its own beside other
    /// work (the frame field), whose idle core time it fills.
    pub fn new(mesh: &TriMesh) -> Result<ParamAnalysis, ParamError> {
        Ok(ParamAnalysis {
            local: LocalSystem::pattern(mesh)?,
            global: GlobalSystem::pattern(mesh)?,
        })
    }
}

/// A prepared QuadCover solver for one mesh, symmetry and set of matchings.
pub struct QuadCover {
    symmetry: usize,
    lattice: Lattice,
    /// Per cut path the lattice its gap is rounded to. With 2Z² (`pure_quad`) a loop's gap need
    /// only be in D₂ = {a + b even} unless the loop ends at a branch point turning by a half turn: the
    /// monodromy x ↦ Rx + t around a ±1/4 branch point fixes (I − R)⁻¹t = ½(a − b, a + b),
    /// which is in Z² exactly when t ∈ D₂ (and R preserves D₂); only a half turn R = −I (±1/2
    /// for quads, every branch point of N = 2) needs t ∈ 2Z². D₂'s points are at most 1 from
    /// any point, 2Z²'s √2.
    gap_lattices: Vec<Lattice>,
    rots: Rots,
    cut: CutGraph,
    local: LocalSystem,
    global: GlobalSystem,
    opts: ParamOptions,
    pub timings: StageTimings,
    /// The solver on the mesh with the poles' stars cut open (alg. 6), for the last set of
    /// poles the frames had.
    opened: std::sync::Mutex<Option<std::sync::Arc<Opened>>>,
    /// The mesh's angle defects, once they are needed.
    defects: std::sync::OnceLock<std::sync::Arc<Vec<f64>>>,
    /// Whether the kept map gets the conformal relaxation ([`Self::relax_conformal_of`]): not
    /// on a mesh opened at poles, whose stars' quads it would fold once closed.
    relax_last: bool,
}

/// Meshes from this many faces (up to [`MISWOUND_TRIES_MAX_FACES`]) start the crowded tries
/// beside the first solve
/// ([`QuadCover::solve_previewing`]): where a try costs seconds, waiting for the first map to
/// ask for it doubles the repair's wall time; on small meshes a try the first map then does not
/// need would only take the core its repair runs on.
const SPECULATE_FACES: usize = 200_000;

/// Whether [`QuadCover::solve_previewing`] starts the crowded tries beside the first solve on
/// this mesh ([`SPECULATE_FACES`], [`MISWOUND_TRIES_MAX_FACES`]).
pub fn speculates(mesh: &TriMesh) -> bool {
    (SPECULATE_FACES..MISWOUND_TRIES_MAX_FACES).contains(&mesh.n_faces())
}

/// From this many faces on, a fold-free map takes no crowded try for wrongly wound vertices
/// alone (folds still take them), and the tries are no longer started beside the first solve
/// (they are wanted too rarely there). The windings re-rounding already stops at this size
/// (`reround::WINDING_MAX_FACES`) for the same reason. igea subdivided once (1.07 M faces,
/// default settings) spent 11 of its 15.3 s of repair in three tries for 28 → 20 wrongly wound
/// vertices, of 537 000; the target there is 5 s.
const MISWOUND_TRIES_MAX_FACES: usize = 500_000;

/// Whether a map needs no crowded try: no fold and no mis-wound vertex (from
/// [`MISWOUND_TRIES_MAX_FACES`] faces on, no fold); under curves a few
/// mis-wound vertices ([`crowded::FEW_MISWOUND`]) are let be (most constrained maps keep a few,
/// and a second solve for those doubled the repair time of the constraint sweep for 10 % fewer
/// of them; many are a crowded cluster at a coarse density, what the finer grid is for,
/// docs/untangling.md).
fn crowded_done(p: &Parameterization, under_curves: bool) -> bool {
    // (`uv` has one entry per corner: its length / 3 is the mesh's face count.)
    p.flipped_faces == 0
        && (p.miswound.is_empty()
            || (under_curves && p.miswound.len() <= crowded::FEW_MISWOUND)
            || p.uv.len() / 3 >= MISWOUND_TRIES_MAX_FACES)
}

/// Sets `stop` for the tries after the i-th when the i-th is done (the ladder would stop
/// there).
fn stop_later_if_done(p: &Parameterization, under_curves: bool, stop: &[AtomicBool], i: usize) {
    if crowded_done(p, under_curves) {
        for later in &stop[i + 1..] {
            later.store(true, Ordering::Relaxed);
        }
    }
}

/// A crowded try: its map, what its last step needs again, its frames.
type Try = (Parameterization, Option<LastSolve>, Vec<[DVec3; 2]>);

/// The opened solver and the treated poles' indices.
type OpenedFor = (std::sync::Arc<Opened>, Vec<(usize, f64)>);

/// QuadCover on the mesh with the stars of `poles` cut open.
struct Opened {
    poles: Vec<usize>,
    untreated: Vec<usize>,
    mesh: TriMesh,
    qc: QuadCover,
}

/// What a plain solve (no curves, no poles) was made from, for completing its report: the
/// frames, the local step, the gaps as first rounded and the global step's time.
struct PlainMap<'a> {
    frames: &'a [[DVec3; 2]],
    local: &'a LocalSolution,
    rounded: &'a [[f64; 2]],
    global_ms: f64,
}

/// Per vertex the angle by which the map's fan must turn around it, 2π(1 − index) (NaN on
/// the boundary and at poles, index ≥ 1: not checked); see `untangle::miswound`.
fn cones(mesh: &TriMesh, singularities: &[Singularity]) -> Vec<f64> {
    let tau = std::f64::consts::TAU;
    let mut out: Vec<f64> = (0..mesh.n_vertices())
        .map(|v| {
            if mesh.is_boundary_vertex(v) {
                f64::NAN
            } else {
                tau
            }
        })
        .collect();
    for s in singularities {
        out[s.vertex] = if s.index < 1.0 {
            tau * (1.0 - s.index)
        } else {
            f64::NAN
        };
    }
    out
}

/// Changed rows up to which [`QuadCover::updated`] updates a system instead of refactoring it.
/// Inside a supernodal factor each row adds three sparse columns solved along their
/// elimination-tree paths, and a solve stays one substitution pair (`sparse::RowUpdate`); a
/// move of a few edges changes a few rows, a *Relax* of the whole mesh more than this.
pub const UPDATE_MAX_ROWS: usize = 48;

/// How [`QuadCover::build`] gets its systems: factored (with analyses computed beforehand,
/// keeping the matrices for updates or not), or updated from a base solver.
enum Build<'a> {
    Fresh(Option<&'a ParamAnalysis>, bool),
    Update(&'a QuadCover),
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

impl QuadCover {
    /// Cut graph and both factorizations (the expensive, field-independent part).
    pub fn new(
        mesh: &TriMesh,
        symmetry: usize,
        matchings: &[i32],
        opts: ParamOptions,
    ) -> Result<QuadCover, ParamError> {
        Self::with_analysis(mesh, symmetry, matchings, opts, None)
    }

    /// [`QuadCover::new`] with the systems' analysis computed beforehand (for this mesh): only
    /// the numeric factorizations remain. The editor keeps one per mesh for re-solves after
    /// edits of the field; the `solve` pipeline computes it while the field is being smoothed.
    pub fn with_analysis(
        mesh: &TriMesh,
        symmetry: usize,
        matchings: &[i32],
        opts: ParamOptions,
        analysis: Option<&ParamAnalysis>,
    ) -> Result<QuadCover, ParamError> {
        Self::build(
            mesh,
            symmetry,
            matchings,
            opts,
            Build::Fresh(analysis, false),
        )
    }

    /// [`QuadCover::with_analysis`] that keeps its assembled systems, as a base that solvers
    /// for other matchings on the same mesh update instead of refactoring
    /// ([`QuadCover::updated`]): the editor's base state.
    pub fn updatable(
        mesh: &TriMesh,
        symmetry: usize,
        matchings: &[i32],
        opts: ParamOptions,
        analysis: Option<&ParamAnalysis>,
    ) -> Result<QuadCover, ParamError> {
        Self::build(
            mesh,
            symmetry,
            matchings,
            opts,
            Build::Fresh(analysis, true),
        )
    }

    /// The solver for other matchings on this one's mesh (same symmetry and options), from
    /// this one's factors when the systems differ in a few rows: a moved singularity changes
    /// the matchings only along its path, and with each vertex's unknown written in this
    /// solver's frames (see `GlobalSystem::new`) the systems change only there. Factored afresh
    /// (with this one's analyses) when more than [`UPDATE_MAX_ROWS`] rows changed. This must
    /// come from [`QuadCover::updatable`]. The result is a function of the two sets of
    /// matchings only, so a replay reproduces it bit for bit.
    pub fn updated(&self, mesh: &TriMesh, matchings: &[i32]) -> Result<QuadCover, ParamError> {
        Self::build(
            mesh,
            self.symmetry,
            matchings,
            self.opts.clone(),
            Build::Update(self),
        )
    }

    /// How many rows of the local and the global system an update changed (`None`: factored).
    pub fn updated_rows(&self) -> (Option<usize>, Option<usize>) {
        (
            self.local.solver().updated_rows(),
            self.global.solver().updated_rows(),
        )
    }

    fn build(
        mesh: &TriMesh,
        symmetry: usize,
        matchings: &[i32],
        opts: ParamOptions,
        how: Build,
    ) -> Result<QuadCover, ParamError> {
        if ![2, 4, 6].contains(&symmetry) {
            return Err(ParamError::InvalidInput(format!(
                "symmetry must be 2, 4 or 6, got {symmetry}"
            )));
        }
        if matchings.len() != mesh.n_edges() {
            return Err(ParamError::InvalidInput(format!(
                "{} matchings for {} edges",
                matchings.len(),
                mesh.n_edges()
            )));
        }
        if mesh.n_faces() == 0 {
            return Err(ParamError::InvalidInput("mesh has no faces".into()));
        }
        let lattice = match (symmetry, opts.pure_quad) {
            (6, true) => {
                return Err(ParamError::InvalidInput(
                    "--pure-quad needs symmetry 2 or 4".into(),
                ));
            }
            (6, false) => Lattice::G6,
            (_, true) => Lattice::TwoZ2,
            _ => Lattice::Z2,
        };
        let rots = Rots::new(symmetry);
        let t = Instant::now();
        let cut = match how {
            Build::Fresh(..) => CutGraph::new(mesh, &rots, matchings),
            // Only the part of the base's forest around the moved branch points is regrown.
            Build::Update(base) => CutGraph::updated(mesh, &rots, matchings, &base.cut),
        };
        let cut_ms = ms(t);
        let (local_how, global_how, gauge) = match how {
            Build::Fresh(analysis, keep) => (
                Factoring::Fresh {
                    analysis: analysis.map(|a| &a.local),
                    keep,
                },
                Factoring::Fresh {
                    analysis: analysis.map(|a| &a.global),
                    keep,
                },
                None,
            ),
            Build::Update(base) => (
                Factoring::Update {
                    base: base.local.solver(),
                    max_rows: UPDATE_MAX_ROWS,
                },
                Factoring::Update {
                    base: base.global.solver(),
                    max_rows: UPDATE_MAX_ROWS,
                },
                Some(&base.cut),
            ),
        };
        // The two systems are independent: factored side by side on two cores.
        let ((local, local_ms), (global, global_ms)) = rayon::join(
            || {
                let t = Instant::now();
                (LocalSystem::new(mesh, &cut, &rots, local_how), ms(t))
            },
            || {
                let t = Instant::now();
                (
                    GlobalSystem::new(mesh, &cut, &rots, global_how, gauge),
                    ms(t),
                )
            },
        );
        let (local, global) = (local?, global?);
        let gap_lattices = match lattice {
            Lattice::TwoZ2 => cut
                .loop_end_holonomies(mesh)
                .into_iter()
                .map(|h| {
                    // A half turn (holonomy N/2: ±1/2 for quads, any branch point for N = 2).
                    if h.iter().any(|&h| 2 * h as usize == symmetry) {
                        Lattice::TwoZ2
                    } else {
                        Lattice::D2
                    }
                })
                .collect(),
            // Branch points of ±2/6 and ±3/6 on G6 too, so that each is one vertex of the
            // triangle remesh (off G6 a grid edge runs through it and is patched).
            Lattice::G6 => cut
                .loop_end_holonomies(mesh)
                .into_iter()
                .map(|h| {
                    let half = h.contains(&3);
                    let third = h.iter().any(|&h| h == 2 || h == 4);
                    match (half, third) {
                        (true, true) => Lattice::TwoTurnedG6,
                        (true, false) => Lattice::TwoG6,
                        (false, true) => Lattice::TurnedG6,
                        (false, false) => Lattice::G6,
                    }
                })
                .collect(),
            _ => vec![lattice; cut.generators.len()],
        };
        Ok(QuadCover {
            symmetry,
            lattice,
            gap_lattices,
            rots,
            cut,
            local,
            global,
            opts,
            relax_last: true,
            timings: StageTimings {
                cut_ms,
                local_ms,
                global_ms,
                repair_ms: 0.0,
            },
            opened: Default::default(),
            defects: match how {
                Build::Update(base) => base.defects.clone(),
                Build::Fresh(..) => Default::default(),
            },
        })
    }

    /// The singularities of positive integral index the frames have, and the solver on the
    /// mesh with the treatable ones' stars cut open (alg. 6, lines 1–5); `None` without poles
    /// (or with `no_poles`). `singularities`: [`Self::singularities`] of the frames; `blocked`:
    /// vertices on constraint curves.
    fn opened(
        &self,
        mesh: &TriMesh,
        singularities: &[Singularity],
        blocked: &[bool],
    ) -> Result<Option<OpenedFor>, ParamError> {
        if self.opts.no_poles {
            return Ok(None);
        }
        let found: Vec<(usize, f64)> = singularities
            .iter()
            .filter(|s| poles::is_pole(s.holonomy, s.index))
            .map(|s| (s.vertex, s.index))
            .collect();
        if found.is_empty() {
            return Ok(None);
        }
        let candidates: Vec<usize> = found.iter().map(|x| x.0).collect();
        let (treat, untreated) = poles::treatable(mesh, &candidates, blocked);
        if treat.is_empty() {
            return Ok(None);
        }
        let indices: Vec<(usize, f64)> =
            found.into_iter().filter(|x| treat.contains(&x.0)).collect();
        let mut cache = self.opened.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(o) = cache.as_ref()
            && o.poles == treat
        {
            return Ok(Some((o.clone(), indices)));
        }
        let open = poles::open(mesh, &treat)?;
        let matchings = poles::open_matchings(
            mesh,
            &open,
            &self
                .cut
                .matching
                .iter()
                .map(|&r| r as i32)
                .collect::<Vec<_>>(),
        );
        let opts = ParamOptions {
            no_poles: true,
            ..self.opts.clone()
        };
        let mut qc = QuadCover::new(&open, self.symmetry, &matchings, opts)?;
        // The opened stars' rims are boundary there, but the poles' positions depend on the
        // gaps of loops ending on them: all on the branch points' lattice.
        qc.gap_lattices = vec![qc.lattice; qc.gap_lattices.len()];
        qc.relax_last = false;
        let o = std::sync::Arc::new(Opened {
            poles: treat,
            untreated,
            mesh: open,
            qc,
        });
        *cache = Some(o.clone());
        Ok(Some((o, indices)))
    }

    /// The opened mesh's solution as this mesh's (alg. 6, lines 7–9).
    fn close(
        &self,
        mesh: &TriMesh,
        singularities: Vec<Singularity>,
        o: &Opened,
        indices: &[(usize, f64)],
        p: Parameterization,
    ) -> Parameterization {
        let mut p = poles::close(mesh, &o.mesh, &self.rots, indices, p);
        // The opened mesh's vertices are this mesh's, then the pole copies.
        p.miswound.retain(|&v| v < mesh.n_vertices());
        p.singularities = singularities;
        p.untreated_poles = o.untreated.clone();
        p.timings.cut_ms += self.timings.cut_ms;
        p
    }

    pub fn n_cut_paths(&self) -> usize {
        self.cut.generators.len()
    }
    pub fn branch_points(&self) -> Vec<(usize, u8)> {
        (0..self.cut.singular.len())
            .filter(|&v| self.cut.singular[v])
            .map(|v| (v, self.cut.holonomy[v]))
            .collect()
    }
    /// Edges of the (pruned) cut graph: those with a non-identity transition.
    pub fn cut_edges(&self) -> Vec<usize> {
        self.cut.cut_edges()
    }

    fn check_frames(&self, mesh: &TriMesh, frames: &[[DVec3; 2]]) -> Result<(), ParamError> {
        if frames.len() != mesh.n_faces() {
            return Err(ParamError::InvalidInput(format!(
                "{} frames for {} faces",
                frames.len(),
                mesh.n_faces()
            )));
        }
        if let Some(f) = frames
            .iter()
            .position(|x| !x[0].is_finite() || !x[1].is_finite())
        {
            return Err(ParamError::InvalidInput(format!(
                "frame of face {f} is not finite"
            )));
        }
        Ok(())
    }

    /// Local step: curl*-free field, integration on M \ G, measured gaps (back-substitution only).
    pub fn local_step(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
    ) -> Result<LocalSolution, ParamError> {
        self.check_frames(mesh, frames)?;
        let t = Instant::now();
        let curl_free = self.local.solve(mesh, &self.cut, &self.rots, frames)?;
        let disk = local::to_disk_frame(&self.rots, &self.cut, &curl_free);
        let uv = local::integrate(mesh, &self.cut, &disk);
        let gaps = global::measure_gaps(mesh, &self.cut, &self.rots, &uv);
        Ok(LocalSolution {
            curl_free,
            disk,
            guide: local::to_disk_frame(&self.rots, &self.cut, frames),
            uv,
            gaps,
            local_ms: ms(t),
        })
    }

    /// Rounds the measured gaps with the configured rounding, each to its own lattice
    /// ([`QuadCover::gap_lattices`]).
    pub fn round_gaps(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
    ) -> Result<Vec<[f64; 2]>, ParamError> {
        self.round_gaps_on(mesh, local, &self.gap_lattices)
    }

    fn round_gaps_on(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        lattices: &[Lattice],
    ) -> Result<Vec<[f64; 2]>, ParamError> {
        match self.opts.rounding {
            Rounding::Direct => Ok(local
                .gaps
                .iter()
                .zip(lattices)
                .map(|(&g, l)| l.nearest(g))
                .collect()),
            Rounding::Greedy => self
                .global
                .greedy_round(mesh, &self.rots, &local.gaps, lattices),
        }
    }

    /// Global solve with the given gaps (reuses the factorization): per-corner uv.
    pub fn global_uv(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        gaps: &[[f64; 2]],
    ) -> Result<Vec<[f64; 2]>, ParamError> {
        if gaps.len() != self.cut.generators.len() {
            return Err(ParamError::InvalidInput(format!(
                "{} gaps for {} cut paths",
                gaps.len(),
                self.cut.generators.len()
            )));
        }
        self.global.solve(mesh, &self.rots, &local.disk, gaps)
    }

    /// Local step, rounding, global step, the injectivity repair and the quality report.
    pub fn solve(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
    ) -> Result<Parameterization, ParamError> {
        self.solve_until(mesh, frames, &|| false)
    }

    /// [`QuadCover::solve`] that stops with [`ParamError::Cancelled`] when `cancel` says so
    /// during the injectivity repair.
    pub fn solve_until(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        cancel: CancelCheck<'_>,
    ) -> Result<Parameterization, ParamError> {
        self.solve_previewing(mesh, frames, &[], cancel, &no_preview)
    }

    /// [`QuadCover::solve_with_curves_until`] that hands the global step's map to `preview`
    /// before the injectivity repair changes it (not for maps with poles: theirs is on the
    /// mesh with the poles' stars cut open).
    pub fn solve_previewing(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        curves: &[ConstraintCurve],
        cancel: CancelCheck<'_>,
        preview: PreviewSink<'_>,
    ) -> Result<Parameterization, ParamError> {
        self.solve_speculating(
            mesh,
            frames,
            curves,
            cancel,
            preview,
            speculates(mesh),
            Collapse::Tries,
        )
    }

    /// [`QuadCover::solve_previewing`], the crowded tries started beside the first solve when
    /// `speculate` says so (the editor's hint from its last solve; the map is the same either
    /// way). `collapse`: whether a first map that keeps folds where its rounding collapsed
    /// strips between curves takes crowded tries.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_speculating(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        curves: &[ConstraintCurve],
        cancel: CancelCheck<'_>,
        preview: PreviewSink<'_>,
        speculate: bool,
        collapse: Collapse,
    ) -> Result<Parameterization, ParamError> {
        let done = |p: &Parameterization| {
            crowded_done(p, !curves.is_empty())
                || (collapse == Collapse::ToZ2 && p.collapsed_strips > 0 && p.flipped_faces > 0)
        };
        let ladder = !self.opts.no_untangle && !self.opts.no_crowded_refinement;
        let stop: Vec<AtomicBool> = crowded::LADDER
            .iter()
            .map(|_| AtomicBool::new(false))
            .collect();
        let solve_first = || -> Result<_, ParamError> {
            let solved = self
                .solve_once(mesh, frames, curves, cancel, preview)
                .and_then(|(first, last)| {
                    if curves.is_empty() && first.poles.is_empty() && !self.opts.no_untangle {
                        Ok((self.reround_windings_of(mesh, frames, first, cancel)?, last))
                    } else {
                        Ok((first, last))
                    }
                });
            // Tries started beside it are not wanted when it failed or needs none.
            if !matches!(&solved, Ok((first, _)) if first.poles.is_empty() && !done(first)) {
                for s in &stop {
                    s.store(true, Ordering::Relaxed);
                }
            }
            let (first, last) = solved?;
            Ok((first, last, Instant::now()))
        };
        // On large meshes the tries start beside the first solve, on the field's
        // singularities (the first map's, checked below), unless one is a pole (a map with
        // poles takes no try). They are dropped when the first map needs none.
        let (first, speculated) = if ladder && speculate {
            let (first, speculated) = rayon::join(solve_first, || {
                let singularities = self.singularities(mesh, frames);
                if singularities
                    .iter()
                    .any(|s| poles::is_pole(s.holonomy, s.index))
                {
                    return None;
                }
                let tries =
                    self.crowded_tries(mesh, frames, curves, &singularities, &stop, cancel, false);
                Some((singularities, tries))
            });
            (first?, speculated)
        } else {
            (solve_first()?, None)
        };
        let (first, mut best_last, first_end) = first;
        if !ladder || !first.poles.is_empty() || done(&first) {
            return self.relax_conformal_of(mesh, frames, first, best_last, cancel);
        }
        // Tries on grids made finer around crowded singularities ([`crowded::LADDER`]), while
        // the best map so far keeps something; the best kept (a try that fails, e.g. curves
        // that contradict on the finer grid, is skipped).
        let badness = |p: &Parameterization| (p.flipped_faces, p.miswound.len());
        // The re-rounding for windings ([`Self::reround_windings_of`]) runs in every try when
        // it moved a gap of the first map; otherwise (nothing it tried helped there) only on
        // the kept try, once. In every try it cost spot ×16's re-solve after an edit 1.6 → 5.6 s;
        // this way 2.5 s, with as few mis-wound vertices left on the shared meshes
        // (docs/untangling.md).
        // (Never under curves: it moves gaps without the curves' equations.)
        let windings_in_tries = curves.is_empty() && !first.rerounded_gaps.is_empty();
        let tries = match speculated {
            Some((singularities, tries)) if singularities == first.singularities => {
                if windings_in_tries {
                    self.rerounded_tries(mesh, tries, &stop, cancel)
                } else {
                    tries
                }
            }
            _ => self.crowded_tries(
                mesh,
                frames,
                curves,
                &first.singularities,
                &stop,
                cancel,
                windings_in_tries,
            ),
        };
        let first_repair_ms = first.timings.repair_ms;
        let mut best = first;
        // The frames of the kept try, when a try is kept.
        let mut best_frames: Option<Vec<[DVec3; 2]>> = None;
        for tried in tries {
            if done(&best) {
                break;
            }
            let Some((next, next_last, refined)) = tried? else {
                continue;
            };
            if badness(&next) < badness(&best) {
                best = next;
                best_frames = Some(refined);
                best_last = next_last;
            }
        }
        // The first map's repair and the wall time the tries took after it, their solves
        // included: they are there for the repair.
        best.timings.repair_ms = first_repair_ms + first_end.elapsed().as_secs_f64() * 1e3;
        let kept_frames = best_frames.as_deref().unwrap_or(frames);
        if best_frames.is_some() && curves.is_empty() && !windings_in_tries {
            best = self.reround_windings_of(mesh, kept_frames, best, cancel)?;
        }
        self.relax_conformal_of(mesh, kept_frames, best, best_last, cancel)
    }

    /// The crowded tries ([`crowded::LADDER`]) on frames refined around `singularities`, side
    /// by side: none depends on another (a grid made finer does not move the singularities),
    /// and the caller takes them in the ladder's order, as if run one after the other. A try
    /// that is done sets `stop` for the later ones, which that order would not run (their
    /// results are then not read). With `windings`, each try's windings are re-rounded too.
    #[allow(clippy::too_many_arguments)]
    fn crowded_tries(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        curves: &[ConstraintCurve],
        singularities: &[Singularity],
        stop: &[AtomicBool],
        cancel: CancelCheck<'_>,
        windings: bool,
    ) -> Vec<Result<Option<Try>, ParamError>> {
        crowded::LADDER
            .par_iter()
            .enumerate()
            .map(|(i, &crowding)| {
                let Some((refined, refinement)) =
                    crowded::refined_frames(mesh, singularities, frames, crowding)
                else {
                    return Ok(None);
                };
                let stopped = || cancel() || stop[i].load(Ordering::Relaxed);
                let (mut next, last) =
                    match self.solve_once(mesh, &refined, curves, &stopped, &no_preview) {
                        Ok(solved) => solved,
                        Err(ParamError::Cancelled) => return Err(ParamError::Cancelled),
                        // E.g. curves that contradict on the finer grid: skipped.
                        Err(_) => return Ok(None),
                    };
                if windings {
                    next = self.reround_windings_of(mesh, &refined, next, &stopped)?;
                }
                next.crowded_refinement = Some(refinement);
                stop_later_if_done(&next, !curves.is_empty(), stop, i);
                Ok(Some((next, last, refined)))
            })
            .collect()
    }

    /// Tries solved beside the first map, their windings re-rounded now that the first map
    /// asks for it (side by side, as [`Self::crowded_tries`]).
    fn rerounded_tries(
        &self,
        mesh: &TriMesh,
        tries: Vec<Result<Option<Try>, ParamError>>,
        stop: &[AtomicBool],
        cancel: CancelCheck<'_>,
    ) -> Vec<Result<Option<Try>, ParamError>> {
        tries
            .into_par_iter()
            .enumerate()
            .map(|(i, tried)| {
                let Some((next, last, refined)) = tried? else {
                    return Ok(None);
                };
                let stopped = || cancel() || stop[i].load(Ordering::Relaxed);
                // (It keeps the try's `crowded_refinement`.)
                let next = self.reround_windings_of(mesh, &refined, next, &stopped)?;
                stop_later_if_done(&next, false, stop, i);
                Ok(Some((next, last, refined)))
            })
            .collect()
    }

    /// One solve on given frames: under curves [`Self::solve_curves`], with poles alg. 6 on
    /// the opened mesh, else [`Self::solve_on`] (with what the last step needs again).
    fn solve_once(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        curves: &[ConstraintCurve],
        cancel: CancelCheck<'_>,
        preview: PreviewSink<'_>,
    ) -> Result<(Parameterization, Option<LastSolve>), ParamError> {
        if !curves.is_empty() {
            return Ok((
                self.solve_curves(mesh, frames, curves, cancel, preview)?,
                None,
            ));
        }
        self.check_frames(mesh, frames)?;
        // One index per vertex, for the poles and the report alike; the local step beside it
        // (wasted only when there are poles to open).
        let (singularities, local) = rayon::join(
            || self.singularities(mesh, frames),
            || self.local_step(mesh, frames),
        );
        if let Some((o, indices)) = self.opened(mesh, &singularities, &[])? {
            let p = o.qc.solve_until(&o.mesh, frames, cancel)?;
            return Ok((self.close(mesh, singularities, &o, &indices, p), None));
        }
        self.solve_on(mesh, frames, singularities, local?, cancel, preview)
    }

    /// The solve without poles and curves on given frames: rounding, global step, repair,
    /// re-rounding and the last rewinding.
    fn solve_on(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        singularities: Vec<Singularity>,
        local: LocalSolution,
        cancel: CancelCheck<'_>,
        preview: PreviewSink<'_>,
    ) -> Result<(Parameterization, Option<LastSolve>), ParamError> {
        let t = Instant::now();
        let gaps = self.round_gaps(mesh, &local)?;
        let mut uv = self.global_uv(mesh, &local, &gaps)?;
        let global_ms = ms(t);
        let space = self.global.map_space(mesh.n_vertices(), &gaps);
        if !self.opts.no_untangle && !untangle::folded(&uv).is_empty() {
            preview(&uv);
        }
        let global = (self.relax_last && !self.opts.no_untangle).then(|| uv.clone());
        let cones = cones(mesh, &singularities);
        let mut repair = self.untangle(mesh, &local, &space, Some(&cones), &mut uv, cancel);
        let rounded = gaps.clone();
        let mut gaps = gaps;
        if !untangle::folded(&uv).is_empty() && !self.opts.no_untangle && !cancel() {
            let t = Instant::now();
            self.reround(mesh, &local, &mut gaps, &mut uv, &mut repair, cancel)?;
            repair.ms += ms(t);
        }
        let space = self.global.map_space(mesh.n_vertices(), &gaps);
        self.rewind_left(mesh, &local, &space, &cones, &mut uv, &mut repair, cancel);
        if cancel() {
            return Err(ParamError::Cancelled);
        }
        let plain = PlainMap {
            frames,
            local: &local,
            rounded: &rounded,
            global_ms,
        };
        let p = self.complete_plain(mesh, &plain, singularities, uv, gaps, &repair);
        let last = global.map(|global| LastSolve {
            local,
            global: (rounded, global),
        });
        Ok((p, last))
    }

    /// [`Self::complete`] for a map without curves and poles, with the gaps the re-roundings
    /// changed from `plain.rounded` listed.
    fn complete_plain(
        &self,
        mesh: &TriMesh,
        plain: &PlainMap<'_>,
        singularities: Vec<Singularity>,
        uv: Vec<[f64; 2]>,
        gaps: Vec<[f64; 2]>,
        repair: &untangle::Repair,
    ) -> Parameterization {
        let rerounded = reround::changed(plain.rounded, &gaps);
        let mut p = self.complete(
            mesh,
            plain.frames,
            singularities,
            plain.local,
            uv,
            gaps,
            plain.global_ms,
            repair,
        );
        p.rerounded_gaps = rerounded;
        p
    }

    /// After the repair and any re-rounding: branch points still wound wrongly on the final,
    /// fold-free map rewound again ([`untangle::rewind_left`]), unless the repair is off.
    #[allow(clippy::too_many_arguments)]
    fn rewind_left(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        space: &untangle::MapSpace,
        cones: &[f64],
        uv: &mut [[f64; 2]],
        repair: &mut untangle::Repair,
        cancel: CancelCheck<'_>,
    ) {
        if self.opts.no_untangle || cancel() {
            return;
        }
        let t = Instant::now();
        let rewound = untangle::rewind_left(
            mesh,
            &self.rots,
            space,
            &local.disk,
            &local.guide,
            cones,
            uv,
            cancel,
        );
        if rewound > 0 {
            repair.rewound += rewound;
            repair.ms += ms(t);
        }
    }

    /// The injectivity repair ([`untangle`]) unless it is off; counts the folds either way.
    fn untangle(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        space: &untangle::MapSpace,
        cones: Option<&[f64]>,
        uv: &mut [[f64; 2]],
        cancel: CancelCheck<'_>,
    ) -> untangle::Repair {
        if self.opts.no_untangle {
            let n = untangle::folded(uv).len();
            return untangle::Repair {
                before: n,
                ..Default::default()
            };
        }
        untangle::repair(
            mesh,
            &self.rots,
            space,
            &local.disk,
            &local.guide,
            cones,
            uv,
            cancel,
        )
    }

    /// [`Self::finish`] plus what both solves add: the curl, the repair's counts and the
    /// stage timings.
    #[allow(clippy::too_many_arguments)]
    fn complete(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        singularities: Vec<Singularity>,
        local: &LocalSolution,
        uv: Vec<[f64; 2]>,
        gaps: Vec<[f64; 2]>,
        global_ms: f64,
        repair: &untangle::Repair,
    ) -> Parameterization {
        let miswound = untangle::miswound(mesh, &uv, &cones(mesh, &singularities));
        let mut p = self.finish(mesh, singularities, uv, local.gaps.clone(), gaps);
        p.miswound = miswound;
        p.curl = local.curl(mesh, frames);
        p.flipped_faces_before_repair = repair.before;
        p.timings = StageTimings {
            cut_ms: self.timings.cut_ms,
            local_ms: self.timings.local_ms + local.local_ms,
            global_ms: self.timings.global_ms + global_ms,
            repair_ms: repair.ms,
        };
        p
    }

    /// Interior vertices of non-zero index, in vertex order (the angle defects are the
    /// mesh's: computed once, and an updated solver takes its base's).
    fn singularities(&self, mesh: &TriMesh, frames: &[[DVec3; 2]]) -> Vec<Singularity> {
        let defects = self
            .defects
            .get_or_init(|| std::sync::Arc::new(mesh.angle_defects()));
        let index = metrics::vertex_indices(mesh, &self.cut, self.symmetry, frames, defects);
        (0..mesh.n_vertices())
            .filter(|&v| !mesh.is_boundary_vertex(v))
            .map(|v| Singularity {
                vertex: v,
                index: index[v],
                holonomy: self.cut.holonomy[v],
            })
            .filter(|s| s.holonomy != 0 || s.index != 0.0)
            .collect()
    }

    fn finish(
        &self,
        mesh: &TriMesh,
        singularities: Vec<Singularity>,
        uv: Vec<[f64; 2]>,
        measured: Vec<[f64; 2]>,
        gaps: Vec<[f64; 2]>,
    ) -> Parameterization {
        let trans: Vec<(u8, [f64; 2])> = self
            .cut
            .transitions
            .iter()
            .map(|a| (a.rot, a.lin.eval(&gaps)))
            .collect();
        let seam_max_error =
            metrics::seam_error(mesh, &self.rots, &uv, &trans, self.lattice.transitions());
        let q = metrics::quality(mesh, &uv);
        Parameterization {
            symmetry: self.symmetry,
            lattice: self.lattice,
            uv,
            singularities,
            cut_paths: self.cut.paths(mesh),
            gaps_measured: measured,
            gaps,
            transitions: trans
                .into_iter()
                .map(|(rotation, translation)| EdgeTransition {
                    rotation,
                    translation,
                })
                .collect(),
            flipped_faces: q.flipped,
            flipped_faces_before_repair: q.flipped,
            rerounded_gaps: Vec::new(),
            collapsed_strips: 0,
            miswound: Vec::new(),
            poles: Vec::new(),
            untreated_poles: Vec::new(),
            curl: 0.0,
            seam_max_error,
            curves: Vec::new(),
            conformal_distortion: Distortion {
                mean: q.conformal_mean,
                p99: q.conformal_p99,
            },
            area_distortion: q.area_distortion,
            timings: StageTimings::default(),
            crowded_refinement: None,
        }
    }
}

/// The curl of a guiding field ([`Parameterization::curl`]) without the global step: the cut
/// graph and the local step's factorization only (relaxation compares singularity placements
/// by it, thesis sec. 3.3).
pub fn curl(
    mesh: &TriMesh,
    symmetry: usize,
    matchings: &[i32],
    frames: &[[DVec3; 2]],
    analysis: Option<&ParamAnalysis>,
) -> Result<f64, ParamError> {
    curl_free(mesh, symmetry, matchings, frames, analysis).map(|(curl, _)| curl)
}

/// [`curl`] and the local step's curl*-free frames it measures against (per face, in each
/// face's own frame): their length is the density a map close to `frames` has there, so its
/// logarithm is the map's log-scale (relax drifts singularities down its slope, `edit::drift`).
pub fn curl_free(
    mesh: &TriMesh,
    symmetry: usize,
    matchings: &[i32],
    frames: &[[DVec3; 2]],
    analysis: Option<&ParamAnalysis>,
) -> Result<(f64, Vec<[DVec3; 2]>), ParamError> {
    if matchings.len() != mesh.n_edges() || frames.len() != mesh.n_faces() {
        return Err(ParamError::InvalidInput(format!(
            "{} matchings and {} frames for {} edges and {} faces",
            matchings.len(),
            frames.len(),
            mesh.n_edges(),
            mesh.n_faces()
        )));
    }
    let rots = Rots::new(symmetry);
    let cut = CutGraph::new(mesh, &rots, matchings);
    let local = LocalSystem::new(
        mesh,
        &cut,
        &rots,
        Factoring::Fresh {
            analysis: analysis.map(|a| &a.local),
            keep: false,
        },
    )?;
    let curl_free = local.solve(mesh, &cut, &rots, frames)?;
    Ok((removed(mesh, frames, &curl_free), curl_free))
}

/// Faces whose texture triangle (corners 3f, 3f + 1, 3f + 2 of `uv`) has non-positive or
/// undefined signed area: the folds ([`Parameterization::flipped_faces`] counts them).
pub fn folded_faces(uv: &[[f64; 2]]) -> Vec<usize> {
    untangle::folded(uv)
}

/// One-shot QuadCover: prepare and solve.
pub fn parameterize(
    mesh: &TriMesh,
    field: FieldRef<'_>,
    opts: &ParamOptions,
) -> Result<Parameterization, ParamError> {
    QuadCover::new(mesh, field.symmetry, field.matchings, opts.clone())?.solve(mesh, field.frames)
}

/// Best-fit matchings for frames with V = J U (thesis eq. 3.3 generalised to N): per interior
/// edge the r minimising the angle between U_j and R^r-matched U_i after unfolding. A local
/// helper (the field module owns field design); used by tests and as a fallback.
pub fn fit_matchings(mesh: &TriMesh, symmetry: usize, frames: &[[DVec3; 2]]) -> Vec<i32> {
    let step = std::f64::consts::TAU / symmetry as f64;
    (0..mesh.n_edges())
        .map(|e| {
            let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
                return 0;
            };
            let d = mesh.vector(h0).normalize_or_zero();
            let ang = |f: usize| {
                let u = frames[f][0];
                u.dot(mesh.face_normal(f).cross(d)).atan2(u.dot(d))
            };
            // U_j ≈ cos·U_i + sin·V_i = rot(+r·step) U_i  ⇒  r ≈ (angle_j − angle_i) / step
            let r = ((ang(mesh.face_of(h1)) - ang(mesh.face_of(h0))) / step).round() as i64;
            r.rem_euclid(symmetry as i64) as i32
        })
        .collect()
}

/// A sphere with a projected field (singularities, so gaps to move), its QuadCover (N = 4)
/// and local step: what the global steps' unit tests start from.
#[cfg(test)]
pub(crate) fn sphere_with_gaps() -> (TriMesh, QuadCover, LocalSolution) {
    let mesh = crate::mesh::generate::icosphere(3);
    let frames = projected_frames(&mesh, DVec3::new(0.3, 0.2, 1.0), 6.0);
    let matchings = fit_matchings(&mesh, 4, &frames);
    let qc = QuadCover::new(&mesh, 4, &matchings, ParamOptions::default()).unwrap();
    let local = qc.local_step(&mesh, &frames).unwrap();
    assert!(local.gaps.len() >= 2, "{} gaps", local.gaps.len());
    (mesh, qc, local)
}

/// Frames V = J U with U the projection of a fixed direction onto each face (fallback to a face
/// edge where the direction is normal), scaled by `scale`.
pub fn projected_frames(mesh: &TriMesh, dir: DVec3, scale: f64) -> Vec<[DVec3; 2]> {
    (0..mesh.n_faces())
        .map(|f| {
            let n = mesh.face_normal(f);
            let mut u = dir - n * n.dot(dir);
            if u.length() < 1e-3 * dir.length() {
                u = mesh.face_basis(f).0;
            }
            let u = u.normalize() * scale;
            [u, n.cross(u)]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::{self, Density, FieldParams, Symmetry};

    /// Tries started beside the first solve give the map that tries started after it give,
    /// bit for bit: where a try is kept, where the first map's windings were re-rounded (the
    /// tries' then are too), and where the first map needs none.
    #[test]
    fn tries_started_beside_the_first_solve_give_the_same_map() {
        let Some(mesh) = crate::load::shared_test_mesh("spot.obj") else {
            return;
        };
        let (mut kept, mut rerounded, mut none_needed) = (0, 0, 0);
        for (n, target) in [(4, Some(1500)), (6, Some(1500)), (4, None)] {
            let mut params = FieldParams {
                symmetry: Symmetry::from_n(n).unwrap(),
                ..Default::default()
            };
            if let Some(v) = target {
                params.density = Density::TargetVertices(v);
            }
            let f = field::compute_field(&mesh, &params).unwrap().field;
            let opts = ParamOptions {
                pure_quad: n == 4,
                ..Default::default()
            };
            let qc = QuadCover::new(&mesh, n as usize, &f.matchings, opts).unwrap();
            let solve = |speculate| {
                qc.solve_speculating(
                    &mesh,
                    &f.frames,
                    &[],
                    &|| false,
                    &no_preview,
                    speculate,
                    Collapse::Tries,
                )
                .unwrap()
            };
            let (after, beside) = (solve(false), solve(true));
            let label = format!("N = {n}, {target:?}");
            assert_eq!(after.uv, beside.uv, "{label}");
            assert_eq!(after.gaps, beside.gaps, "{label}");
            assert_eq!(after.miswound, beside.miswound, "{label}");
            assert_eq!(after.flipped_faces, beside.flipped_faces, "{label}");
            assert_eq!(
                after.crowded_refinement, beside.crowded_refinement,
                "{label}"
            );
            assert_eq!(
                format!("{:?}", after.rerounded_gaps),
                format!("{:?}", beside.rerounded_gaps),
                "{label}"
            );
            kept += usize::from(after.crowded_refinement.is_some());
            rerounded += usize::from(!after.rerounded_gaps.is_empty());
            none_needed += usize::from(after.crowded_refinement.is_none());
            eprintln!(
                "{label}: try {:?}, rerounded {}, mis-wound {}",
                after.crowded_refinement.as_ref().and_then(|r| r.crowding),
                after.rerounded_gaps.len(),
                after.miswound.len()
            );
        }
        assert!(kept > 0 && rerounded > 0 && none_needed > 0);
    }
}
