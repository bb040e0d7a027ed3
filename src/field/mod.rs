//! Frame fields (thesis ch. 3, sec. 4.1.1, 4.2): principal curvature, 2-, 4- and 6-fold fields,
//! reliability-weighted smoothing, singularities, density, JSON import/export.
//!
//! # Field model (see docs/CONTRACTS.md)
//! Per face a reference frame (U_i, V_i) in the face's tangent plane: the rows of the target
//! Jacobian of the parameterization, so |U| = |V| = 1/h for grid size h. Generated fields are
//! isotropic, V = J U with J = n × · (counter-clockwise quarter turn about the face normal) — also
//! for N = 6: the parameterization uses Euclidean texture coordinates with the lattice G_6
//! (eq. 4.2), and the 6-fold symmetry is the 60° rotation of texture space. Frames may be
//! general (scaled, non-orthogonal) on import.
//!
//! Per interior edge e with halfedges (h0, h1), i = face(h0), j = face(h1), the matching
//! r_e = r_ij ∈ 0..N means (U_j; V_j) ≈ M_{r_ij} (U_i; V_i) after unfolding j into i's plane,
//! with the 2×2 matrix acting on the stacked rows (thesis sec. 4.1.1, R_N^k):
//!   M_r = [[cos(2πr/N), sin(2πr/N)], [−sin(2πr/N), cos(2πr/N)]]   (see [`matching_matrix`]),
//! i.e. U_j ≈ cos·U_i + sin·V_i; for V = J U this rotates the frame counter-clockwise by 2πr/N.
//! A parameterization then satisfies φ_j = M_{r_ij} φ_i + w_ij. r_ji = −r_ij mod N.
//! In angles (θ = angle of U in the face basis, κ_ij the transport angle, [`transport`]):
//! θ_j ≈ θ_i + κ_ij + 2π r_ij / N.

mod boundary_yield;
pub(crate) mod cancel;
pub mod classify;
pub mod curvature;
pub mod density;
pub mod index;
pub mod io;
pub mod pole_cluster;
pub mod smoothing;
pub mod thin;
pub mod transport;

use std::f64::consts::TAU;
use std::time::Instant;

use glam::DVec3;
use serde::{Deserialize, Serialize};
use thiserror::Error;

pub use classify::ShapeClass;
pub use curvature::Curvature;
pub use density::{Density, ScaleFunction};
pub use index::{IndexReport, Singularity, compute_indices};
pub use smoothing::Relaxation;

use crate::mesh::TriMesh;
use crate::sparse::{Analysis, SolverError};
use transport::{EdgeTransport, FaceBases, NO_FACE, wrap_pi};

/// Rotational symmetry order N of the field.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Symmetry {
    /// N = 2: stripes (sec. 4.2).
    Two,
    /// N = 4: quads (QuadCover).
    Four,
    /// N = 6: hexagons / triangles (HexCover, sec. 4.1).
    Six,
}

impl Symmetry {
    pub fn n(self) -> u32 {
        match self {
            Symmetry::Two => 2,
            Symmetry::Four => 4,
            Symmetry::Six => 6,
        }
    }
    pub fn from_n(n: u32) -> Result<Symmetry, FieldError> {
        match n {
            2 => Ok(Symmetry::Two),
            4 => Ok(Symmetry::Four),
            6 => Ok(Symmetry::Six),
            _ => Err(FieldError::InvalidParameter(format!(
                "symmetry must be 2, 4 or 6, got {n}"
            ))),
        }
    }
}

/// The matrix M_r acting on the stacked frame rows (U; V) and on texture coordinates, see the
/// module docs: [[cos a, sin a], [−sin a, cos a]] with a = 2πr/N.
pub fn matching_matrix(symmetry: Symmetry, r: i32) -> [[f64; 2]; 2] {
    let a = TAU * r.rem_euclid(symmetry.n() as i32) as f64 / symmetry.n() as f64;
    let (s, c) = a.sin_cos();
    [[c, s], [-s, c]]
}

#[derive(Debug, Error, Clone, PartialEq)]
pub enum FieldError {
    #[error("invalid field parameter: {0}")]
    InvalidParameter(String),
    #[error("frame field file: {0}")]
    Format(String),
    #[error("frame field does not fit the mesh: {0}")]
    MeshMismatch(String),
    #[error("the mesh has no faces")]
    EmptyMesh,
    #[error(transparent)]
    Solver(#[from] SolverError),
}

/// A frame field per the data contract (docs/CONTRACTS.md).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameField {
    pub symmetry: Symmetry,
    /// Per face (U, V), 3-D vectors in the face's tangent plane.
    pub frames: Vec<[DVec3; 2]>,
    /// Per edge the matching in 0..N (0 on boundary edges).
    pub matchings: Vec<i32>,
}

impl FrameField {
    /// Counts, matching range, finite frames, boundary matchings 0.
    pub fn validate(&self, mesh: &TriMesh) -> Result<(), FieldError> {
        if self.frames.len() != mesh.n_faces() || self.matchings.len() != mesh.n_edges() {
            return Err(FieldError::MeshMismatch(format!(
                "field has {} frames and {} matchings, mesh has {} faces and {} edges",
                self.frames.len(),
                self.matchings.len(),
                mesh.n_faces(),
                mesh.n_edges()
            )));
        }
        let n = self.symmetry.n() as i32;
        if let Some(f) = self
            .frames
            .iter()
            .position(|fr| !fr[0].is_finite() || !fr[1].is_finite())
        {
            return Err(FieldError::Format(format!(
                "frame of face {f} is not finite"
            )));
        }
        for (e, &r) in self.matchings.iter().enumerate() {
            if !(0..n).contains(&r) {
                return Err(FieldError::Format(format!(
                    "matching of edge {e} is {r}, not in 0..{n}"
                )));
            }
            if r != 0 && mesh.is_boundary_edge(e) {
                return Err(FieldError::Format(format!(
                    "boundary edge {e} has matching {r}, expected 0"
                )));
            }
        }
        Ok(())
    }

    /// Matching r_ij seen from face `i` across edge `e` (r_ji = −r_ij mod N).
    pub fn matching_from(&self, mesh: &TriMesh, e: usize, from_face: usize) -> i32 {
        let n = self.symmetry.n() as i32;
        let (h0, _) = mesh.edge_halfedges(e);
        let r = self.matchings[e];
        if mesh.face_of(h0) == from_face {
            r
        } else {
            (-r).rem_euclid(n)
        }
    }
}

/// What guides the field.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Guidance {
    /// Principal curvature directions on the most reliable faces (N = 4), resp. on the most
    /// reliable cylindrical faces (N = 2, 6), extended by smoothing.
    #[default]
    Curvature,
    /// The smoothest field, anchored at one face per component (for shapes without reliable
    /// curvature).
    Smooth,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FieldParams {
    pub symmetry: Symmetry,
    pub guidance: Guidance,
    /// Weight of E_align against E_smooth (eq. 3.5, 3.6): 0 = smoothest.
    pub tau: f64,
    /// Fraction of the candidate faces kept as alignment constraints (most reliable first).
    pub reliable_fraction: f64,
    /// A face is planar (sec. 4.1.1) when ρ = |(κ1 − κ2, κ1 + κ2)| < planar_threshold / L, with L
    /// the bounding-box diagonal.
    pub planar_threshold: f64,
    pub relaxation: Relaxation,
    pub density: Density,
    pub scale: ScaleFunction,
    /// Opposite-index singularities closer than this many grid cells are cancelled pairwise
    /// after rounding (sec. 3.3), integral indices included (indices from the unreduced turns,
    /// `cancel`); 0 keeps the rounded field as it is. The default 1 takes the bunny (N = 4)
    /// from 63 to 53 singularities, max-planck (N = 4) from 47 to 45; at N = 2 the bunny from 31
    /// to 29, max-planck from 12 to 6 and igea from 52 to 38, with no integral index left.
    pub cancel_pairs_within: f64,
    /// Neighbour-averaging passes over the vertex shape operators before eq. 3.2 (0 = the thesis
    /// as is). The default 5 halves the singularities of curvature fields on scanned meshes
    /// (bunny, N = 4: 110 -> 63; remesh irregular vertices 49 -> 21).
    pub curvature_smoothing: usize,
    /// Renormalize every relaxed solve ([`smoothing::RENORMALIZE_STEPS`]), not only one that
    /// rounds to a pole under aligned curves. Lower smoothing energy and conformal distortion
    /// (docs/untangling.md: spot N = 4 1.268 → 1.171, fertility 1.242 → 1.181); off by default:
    /// it splits the curvature lines' umbilic poles (thesis sec. 4.3) and costs the field more.
    #[serde(default)]
    pub renormalize: bool,
    /// Make thin parts (tubes, handles, beams, small holes narrower than
    /// [`thin::MIN_CELLS_AROUND`] grid cells around) finer, so that the grid goes around them
    /// with that many cells ([`thin::thin_parts`]); the rest keeps the grid size the density
    /// asks for, so the vertex count grows by what the thin parts add.
    #[serde(default = "refine_thin_default")]
    pub refine_thin: bool,
    /// Keep the factored fixed-matching system in [`FieldResult::system`] (the edit model
    /// re-solves with it; it costs the factor's memory, so only asked for there).
    #[serde(skip)]
    pub keep_system: bool,
    /// Faces held to a direction (face, angle in the face basis, any of the N representatives):
    /// the faces along geometric constraint curves (thesis sec. 4.4), with the alignment weight
    /// [`CURVE_WEIGHT`] in place of their curvature alignment (with τ = 0 there is none).
    #[serde(skip)]
    pub aligned: Option<std::sync::Arc<Vec<(u32, f64)>>>,
    /// Of the `aligned` faces, those along boundary edges of the curves: curvature faces that
    /// contradict them yield (`boundary_yield`).
    #[serde(skip)]
    pub boundary_aligned: Option<std::sync::Arc<Vec<u32>>>,
    /// Of the `aligned` faces, those along round rims (closed crease curves without corners,
    /// `constraint::rim_faces`): for N = 6 the faces their crease's bend reaches lose their
    /// curvature guidance
    /// ([`crease_reach`]).
    #[serde(skip)]
    pub rim_aligned: Option<std::sync::Arc<Vec<u32>>>,
    /// Vertices (sorted) whose singularities the pair cancellation leaves: the apexes of acute
    /// corners between geometric curves (`constraint::acute_corners`), whose wedge the design
    /// holds to a lattice corner, so that the apex carries the index the corner asks for. Its
    /// partner one edge along a crease is within a cell at coarse grids: cancelled, the corner
    /// has no singularity and the map folds beside it (fandisk with features at 40°, 3000
    /// target vertices: 5 folded faces; 0 with the pair kept, as at the default density).
    #[serde(skip)]
    pub kept_singular: Option<std::sync::Arc<Vec<usize>>>,
    /// Frame rotations prescribed between two adjacent faces (first face, second face, angle in
    /// radians from the first's frame to the second's across their shared edge): where
    /// `constraint::acute_corners` holds two corners meeting at a crease with one face each,
    /// the nearest turn across the crease is the wrong one ([`smoothing::SmoothInput`]'s
    /// `fixed_rotations`).
    #[serde(skip)]
    pub fixed_rotations: Option<std::sync::Arc<Vec<(u32, u32, f64)>>>,
    /// Read the curvature guidance from the unsmoothed shape operators (eq. 3.2 as is), the
    /// density from the smoothed ones (`curvature_smoothing`): a design whose hexagonal field
    /// changes line family along a sharp crease is made again so (`edit::families`), since the
    /// smoothing carries the crease's bend, 30° off the crease for six directions, into the flat
    /// faces beside it.
    #[serde(skip)]
    pub raw_guidance: bool,
}

/// Alignment weight τω of a face along a constraint curve, against the dual Laplacian's
/// diagonal of about 3: the field there stays within a few hundredths of a radian of the curve.
pub const CURVE_WEIGHT: f64 = 100.0;

fn refine_thin_default() -> bool {
    true
}

impl Default for FieldParams {
    fn default() -> FieldParams {
        FieldParams {
            symmetry: Symmetry::Four,
            guidance: Guidance::Curvature,
            tau: 1.0,
            reliable_fraction: 0.1,
            planar_threshold: 1.0,
            relaxation: Relaxation::Complex,
            density: Density::default(),
            scale: ScaleFunction::Uniform,
            curvature_smoothing: 5,
            cancel_pairs_within: 1.0,
            renormalize: false,
            refine_thin: true,
            keep_system: false,
            aligned: None,
            boundary_aligned: None,
            rim_aligned: None,
            kept_singular: None,
            fixed_rotations: None,
            raw_guidance: false,
        }
    }
}

#[derive(Clone, Debug)]
pub struct FieldResult {
    pub field: FrameField,
    /// Angle of U per face in the face basis (`mesh.face_basis`).
    pub theta: Vec<f64>,
    /// The principal curvature the guidance was read from ([`FieldParams::raw_guidance`]).
    pub curvature: Curvature,
    /// Reference (curvature) direction per face, angle in the face basis.
    pub reference: Vec<f64>,
    /// Reliability weight ω_i actually used (0 = unconstrained).
    pub omega: Vec<f64>,
    pub classes: Vec<ShapeClass>,
    /// Grid size h.
    pub grid_size: f64,
    /// Per-face density multiplier m_i (|U_i| = m_i / h).
    pub multipliers: Vec<f64>,
    /// How many faces the thin parts made finer and by how much (their multipliers are in
    /// `multipliers`).
    pub thin: thin::ThinParts,
    pub indices: IndexReport,
    /// E_smooth (eq. 3.5) of the result.
    pub e_smooth: f64,
    /// E_align (eq. 3.6, without τ) of the result.
    pub e_align: f64,
    /// Rounding + fixed-matching passes.
    pub passes: usize,
    /// (stage, seconds).
    pub timings: Vec<(String, f64)>,
    /// Unreduced integer turns per edge (first face to second; 0 on boundary edges): the
    /// matchings before reduction mod N, from which indices follow combinatorially.
    pub turns: Vec<i64>,
    /// The factored fixed-matching system, with [`FieldParams::keep_system`].
    pub system: Option<std::sync::Arc<smoothing::FixedSystem>>,
}

/// Computes a frame field: curvature → classification/reliability → smoothing → density →
/// frames and matchings → singularities.
pub fn compute_field(mesh: &TriMesh, params: &FieldParams) -> Result<FieldResult, FieldError> {
    compute_field_then(mesh, params, |_| ()).map(|(r, ())| r)
}

/// [`compute_field`], handing the final matchings to `next` as soon as they are known: `next`
/// runs on the other core while the field's singularities are found. A pipeline uses it to
/// start the parameterization's factorizations, which need only the matchings.
pub fn compute_field_then<T: Send>(
    mesh: &TriMesh,
    params: &FieldParams,
    next: impl FnOnce(&[i32]) -> T + Send,
) -> Result<(FieldResult, T), FieldError> {
    if mesh.n_faces() == 0 {
        return Err(FieldError::EmptyMesh);
    }
    for (name, v, ok) in [
        ("tau", params.tau, params.tau >= 0.0),
        (
            "reliable_fraction",
            params.reliable_fraction,
            (0.0..=1.0).contains(&params.reliable_fraction),
        ),
        (
            "planar_threshold",
            params.planar_threshold,
            params.planar_threshold >= 0.0,
        ),
        (
            "cancel_pairs_within",
            params.cancel_pairs_within,
            params.cancel_pairs_within >= 0.0,
        ),
    ] {
        if !ok || !v.is_finite() {
            return Err(FieldError::InvalidParameter(format!("{name} = {v}")));
        }
    }
    // The smoothing systems' analysis (fill-reducing ordering and symbolic factorization, by
    // nested dissection of the face centroids on large meshes) depends on the mesh only: it runs
    // on a thread of its own from the start, beside the bases and the curvature.
    std::thread::scope(|scope| {
        // The dual systems' layout first (the smoothing needs it after the curvature), then the
        // analysis of its pattern (needed by the fixed-matching factorization).
        let (layout_tx, layout_rx) = std::sync::mpsc::channel();
        let pending = std::sync::Mutex::new(Some(scope.spawn(move || {
            let layout = smoothing::DualLayout::from_mesh(mesh).map(std::sync::Arc::new);
            let _ = layout_tx.send(layout.clone());
            let centroids: Vec<_> = (0..mesh.n_faces()).map(|f| mesh.face_centroid(f)).collect();
            Analysis::geometric(layout?.pattern(), &centroids)
        })));
        let layout = || -> Result<std::sync::Arc<smoothing::DualLayout>, SolverError> {
            layout_rx
                .recv()
                .unwrap_or_else(|_| Err(SolverError::Build("the layout thread ended early".into())))
        };
        let done = std::sync::OnceLock::new();
        let analysis = || -> Result<Analysis, SolverError> {
            done.get_or_init(|| match pending.lock().ok().and_then(|mut p| p.take()) {
                Some(handle) => handle.join().unwrap_or_else(|_| {
                    Err(SolverError::Build("the analysis thread panicked".into()))
                }),
                None => Err(SolverError::Build("the analysis is not available".into())),
            })
            .clone()
        };
        field_with_analysis(mesh, params, next, &analysis, &layout)
    })
}

fn field_with_analysis<T: Send>(
    mesh: &TriMesh,
    params: &FieldParams,
    next: impl FnOnce(&[i32]) -> T + Send,
    analysis: &smoothing::AnalysisSource,
    layout: &dyn Fn() -> Result<std::sync::Arc<smoothing::DualLayout>, SolverError>,
) -> Result<(FieldResult, T), FieldError> {
    let n = params.symmetry.n();
    let mut timings = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: &str, timings: &mut Vec<(String, f64)>| {
        timings.push((name.to_string(), clock.elapsed().as_secs_f64()));
        clock = Instant::now();
    };
    let bases = FaceBases::new(mesh);
    let tr = EdgeTransport::new(mesh, &bases);
    lap("bases + transport", &mut timings);
    // The smoothing passes of the shape operators the guidance is read from.
    let guide_passes = if params.raw_guidance {
        0
    } else {
        params.curvature_smoothing
    };
    let curvature = Curvature::compute(mesh, &bases, guide_passes);
    // A curvature-driven density reads the smoothed operators still.
    let density_curvature = (guide_passes != params.curvature_smoothing
        && matches!(params.scale, ScaleFunction::Curvature { .. }))
    .then(|| Curvature::compute(mesh, &bases, params.curvature_smoothing));
    lap("curvature", &mut timings);
    let (lo, hi) = mesh.bounding_box();
    let diag = (hi - lo).length().max(f64::MIN_POSITIVE);
    let (reference, cand, classes) =
        classify::targets(&curvature, params.symmetry, params.planar_threshold / diag);
    let mut omega = match params.guidance {
        Guidance::Curvature => curvature.reliability(params.reliable_fraction, &cand),
        Guidance::Smooth => vec![0.0; mesh.n_faces()],
    };
    let mut reference = reference;
    // Fetched here only when the boundary yield needs it (it is built beside this work).
    let mut early_layout = None;
    if let Some(aligned) = &params.aligned
        && params.tau > 0.0
    {
        let mut on_curve = vec![false; omega.len()];
        for &(f, angle) in aligned.iter() {
            let f = f as usize;
            if f < omega.len() && angle.is_finite() {
                reference[f] = angle;
                omega[f] = CURVE_WEIGHT / params.tau;
                on_curve[f] = true;
            }
        }
        if let Some(rims) = &params.rim_aligned
            && params.symmetry == Symmetry::Six
        {
            let mut on_rim = vec![false; omega.len()];
            for &f in rims.iter() {
                if let Some(r) = on_rim.get_mut(f as usize) {
                    *r = true;
                }
            }
            let near = crease_reach(mesh, &on_rim, guide_passes);
            for (f, w) in omega.iter_mut().enumerate() {
                if near[f] && !on_curve[f] {
                    *w = 0.0;
                }
            }
        }
        if let Some(along) = &params.boundary_aligned
            && !along.is_empty()
        {
            let layout = early_layout.insert(layout()?);
            boundary_yield::yield_to_boundary(
                n, &tr, &reference, &mut omega, &on_curve, along, layout,
            )?;
        }
    }
    lap("classification + reliability", &mut timings);
    let mut multipliers = density::face_multipliers(
        mesh,
        &params.scale,
        density_curvature.as_ref().unwrap_or(&curvature),
    )?;
    let grid_size = density::grid_size(mesh, &params.density, params.symmetry, &multipliers)?;
    let thin = if params.refine_thin {
        let thin = thin::thin_parts(mesh, grid_size);
        for (m, t) in multipliers.iter_mut().zip(&thin.multipliers) {
            *m = m.max(*t);
        }
        thin::ThinParts {
            multipliers: Vec::new(),
            ..thin
        }
    } else {
        thin::ThinParts::default()
    };
    lap("thin parts", &mut timings);
    let radius = params.cancel_pairs_within * grid_size;
    // χ first: the components' walk only for the meshes that can be a closed torus.
    let lone_torus = mesh.euler_characteristic() == 0 && {
        let t = mesh.topology();
        t.genus == 1 && t.boundary_loops == 0 && t.components.len() == 1
    };
    // The angle defects, computed once for the cancellation, the renormalization's question and
    // the singularity pass.
    let defects = std::sync::OnceLock::new();
    let kept = params
        .kept_singular
        .as_deref()
        .map_or(&[][..], |v| v.as_slice());
    let cancel = |_theta: &[f64], turns: &[i64]| {
        let defects = defects.get_or_init(|| mesh.angle_defects());
        let near = cancel::cancel_close_pairs(mesh, &tr, defects, turns, n, radius, kept);
        if !lone_torus {
            return near;
        }
        // A closed torus whose field keeps one pair of opposite singularities (and no other):
        // the loop around the pair is the commutator of the two handle loops, a translation
        // only, and with handles that do not turn the frames (a torus's curvature lines) no
        // translation at all, so every seamless map puts both on one point and collapses the
        // edges between them (a torus with sliver triangles: two faces of zero area left
        // after the repair, which no re-rounding could part). Cancelled at any distance.
        let current = near.as_ref().map_or(turns, |(r, _)| r.as_slice());
        let singular: Vec<i32> = index::turn_indices_from(mesh, &tr, current, n, defects)
            .into_iter()
            .flatten()
            .filter(|&k| k != 0)
            .collect();
        if singular.len() != 2 || singular[0] + singular[1] != 0 {
            return near;
        }
        match cancel::cancel_close_pairs(mesh, &tr, defects, current, n, f64::INFINITY, &[]) {
            Some((r, more)) => {
                let mut released = near.map(|(_, a)| a).unwrap_or_default();
                released.extend(more);
                released.sort_unstable();
                released.dedup();
                Some((r, released))
            }
            None => near,
        }
    };
    // Renormalized ([`smoothing::RENORMALIZE_STEPS`]): every relaxed solution with
    // `renormalize`; one anchored almost nowhere ([`smoothing::unanchored`]: a sphere, all
    // umbilics) that rounds to no pole; under aligned curves, one whose rounding has a singularity of
    // index +1/2 or more (at least 2/N: the pole a symmetric disc inside an aligned rim rounds
    // to; without curves such poles are the curvature lines' umbilics, thesis sec. 4.3); and
    // one whose rounding crowds a pole's worth of singularities on a dome ([`pole_cluster`]).
    let renormalize = |turns: &[i64], magnitudes: &[f64]| {
        if params.renormalize {
            return true;
        }
        let defects = defects.get_or_init(|| mesh.angle_defects());
        let indices = index::turn_indices_from(mesh, &tr, turns, n, defects);
        let at_least = |least: i32| indices.iter().any(|k| k.is_some_and(|k| k >= least));
        // Anchored almost nowhere, unless it rounds to a pole (index +1: a spheroid's
        // umbilic, which the pole treatment takes as it is, thesis sec. 4.3).
        if smoothing::unanchored(magnitudes) && !at_least(n as i32) {
            return true;
        }
        if params.aligned.is_some() && at_least((n as i32 / 2).max(2)) {
            return true;
        }
        // a pole's worth of singularities crowded on a dome ([`pole_cluster`])
        pole_cluster::crowded_pole(mesh, &indices, defects, n, grid_size)
    };
    let layout = match early_layout {
        Some(layout) => layout,
        None => layout()?,
    };
    // The prescribed rotations per edge, oriented from the edge's first face to its second.
    let fixed_rotations: Vec<(usize, f64)> = params
        .fixed_rotations
        .iter()
        .flat_map(|list| list.iter())
        .filter_map(|&(a, b, rotation)| {
            (3 * a as usize..3 * a as usize + 3).find_map(|h| {
                let e = mesh.edge(h);
                match tr.faces[e] {
                    [f0, f1] if f0 == a && f1 == b => Some((e, rotation)),
                    [f0, f1] if f0 == b && f1 == a => Some((e, -rotation)),
                    _ => None,
                }
            })
        })
        .collect();
    let sm = smoothing::smooth(&smoothing::SmoothInput {
        n,
        transport: &tr,
        theta0: &reference,
        omega: &omega,
        tau: params.tau,
        relaxation: params.relaxation,
        adjust_turns: (radius > 0.0).then_some(&cancel as &smoothing::AdjustTurns),
        renormalize: Some(&renormalize as &smoothing::Renormalize),
        analysis: Some(analysis),
        layout: Some(&layout),
        keep_system: params.keep_system,
        fixed_rotations: &fixed_rotations,
    })?;
    timings.extend(sm.timings.iter().cloned());
    clock = Instant::now();
    let frames = frames_from_angles(&bases, &sm.theta, |f| multipliers[f] / grid_size);
    let matchings = reduce_matchings(&tr, &sm.r, n);
    let field = FrameField {
        symmetry: params.symmetry,
        frames,
        matchings,
    };
    timings.push(("density + frames".into(), clock.elapsed().as_secs_f64()));
    // The matchings are final: the next stage starts on a thread of its own meanwhile.
    let (indices, seconds, handed_on) = std::thread::scope(|scope| {
        let handle = scope.spawn(|| next(&field.matchings));
        let clock = Instant::now();
        let defects = defects.get_or_init(|| mesh.angle_defects());
        let indices =
            index::indices_from_angles_with(mesh, &tr, &sm.theta, &field.matchings, n, defects);
        let seconds = clock.elapsed().as_secs_f64();
        handle
            .join()
            .map(|handed_on| (indices, seconds, handed_on))
            .map_err(|_| FieldError::InvalidParameter("the next pipeline stage panicked".into()))
    })?;
    timings.push(("singularities".into(), seconds));
    let result = FieldResult {
        field,
        theta: sm.theta,
        curvature,
        reference,
        omega,
        classes,
        grid_size,
        multipliers,
        thin,
        indices,
        e_smooth: sm.e_smooth,
        e_align: sm.e_align,
        passes: sm.passes,
        timings,
        turns: sm.r,
        system: sm.system,
    };
    Ok((result, handed_on))
}

/// Isotropic frames: U = s_f (cos θ e1 + sin θ e2), V = n × U.
pub fn frames_from_angles(
    bases: &FaceBases,
    theta: &[f64],
    scale: impl Fn(usize) -> f64,
) -> Vec<[DVec3; 2]> {
    theta
        .iter()
        .enumerate()
        .map(|(f, &t)| {
            let u = bases.direction(f, t) * scale(f);
            [u, bases.normal[f].cross(u)]
        })
        .collect()
}

/// Per-edge matchings in 0..N from unwrapped turns (0 on boundary edges).
pub(crate) fn reduce_matchings(tr: &EdgeTransport, r: &[i64], n: u32) -> Vec<i32> {
    tr.faces
        .iter()
        .zip(r)
        .map(|(f, &r)| {
            if f[1] == NO_FACE {
                0
            } else {
                r.rem_euclid(n as i64) as i32
            }
        })
        .collect()
}

/// Closest-angle matching (eq. 3.3, as rounding to the nearest multiple of 2π/N) between given
/// per-face angles, per edge in 0..N.
pub fn closest_matchings(tr: &EdgeTransport, theta: &[f64], n: u32) -> Vec<i32> {
    smoothing::nearest_turns(tr, theta, TAU / n as f64)
        .into_iter()
        .map(|r| r.rem_euclid(n as i64) as i32)
        .collect()
}

/// The faces whose shape operator a curve's own bend reaches: those with a vertex within
/// `smoothing` rings (the curvature's smoothing passes, [`Curvature::compute`]) of a vertex of
/// an aligned face (`on_curve`). A crease's dihedral angle enters the operators of its ends,
/// and each pass spreads them by one ring; a face takes the mean of its vertices'. There the
/// direction of largest |κ| runs across the crease: for N = 6 that is 30° off the curve's own
/// alignment (N = 4 and N = 2 take a right angle as the same frame), and the field turns by
/// +30° or −30° between them. Along a round rim nothing decides which, and the field flips
/// between the two within a cell: a capped cylinder remeshed isotropically, its rims aligned,
/// had 38 pairs of ±1/6 on its rims and its map 486 folded faces; without the crease's
/// directions there, six +1/6 per cap and no fold. Where creases meet at corners the corners
/// decide, and the crease's directions help: dropped along every curve, an open box's map
/// folded 210 faces instead of none, a triangular prism's 3.
fn crease_reach(mesh: &TriMesh, on_curve: &[bool], smoothing: usize) -> Vec<bool> {
    let mut reached = vec![false; mesh.n_vertices()];
    let mut front = Vec::new();
    for f in (0..mesh.n_faces()).filter(|&f| on_curve[f]) {
        for v in mesh.face(f) {
            if !reached[v] {
                reached[v] = true;
                front.push(v);
            }
        }
    }
    mesh.mark_rings(&mut reached, front, smoothing);
    (0..mesh.n_faces())
        .map(|f| mesh.face(f).iter().any(|&v| reached[v]))
        .collect()
}

/// Algorithm 5: the raw principal curvature field (unit frames along the reference direction of
/// [`classify::targets`]) with closest-angle matchings (eq. 3.3). Unsmoothed, usually noisy.
pub fn curvature_field(mesh: &TriMesh, symmetry: Symmetry) -> FrameField {
    let bases = FaceBases::new(mesh);
    let tr = EdgeTransport::new(mesh, &bases);
    let curv = Curvature::compute(mesh, &bases, 0);
    let (reference, _, _) = classify::targets(&curv, symmetry, 0.0);
    FrameField {
        symmetry,
        frames: frames_from_angles(&bases, &reference, |_| 1.0),
        matchings: closest_matchings(&tr, &reference, symmetry.n()),
    }
}

/// Largest |residual angle| over interior edges of a field: the angle between U_j and the
/// matched, transported M_r U_i (0 for a perfectly smooth field; ≤ π/N when every matching is
/// the closest-angle one).
pub fn max_matching_residual(mesh: &TriMesh, field: &FrameField) -> f64 {
    let bases = FaceBases::new(mesh);
    let tr = EdgeTransport::new(mesh, &bases);
    let theta = index::frame_angles(field, &bases);
    let step = TAU / field.symmetry.n() as f64;
    (0..mesh.n_edges())
        .filter(|&e| tr.is_interior(e))
        .map(|e| {
            let [i, j] = tr.faces[e].map(|f| f as usize);
            wrap_pi(theta[j] - theta[i] - tr.kappa[e] - step * field.matchings[e] as f64).abs()
        })
        .fold(0.0, f64::max)
}

/// Benchmark stages for `quadcover bench`: curvature + N = 4 smoothing with default parameters.
pub fn bench_field(mesh: &TriMesh) -> Vec<(String, f64)> {
    let t = Instant::now();
    let params = FieldParams::default();
    let mut out = match compute_field(mesh, &params) {
        Ok(r) => r.timings,
        Err(e) => vec![(format!("field failed: {e}"), f64::NAN)],
    };
    out.push(("field total".into(), t.elapsed().as_secs_f64()));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn matching_matrix_is_a_rotation_of_order_n() {
        for sym in [Symmetry::Two, Symmetry::Four, Symmetry::Six] {
            let m = matching_matrix(sym, 1);
            let mut p = [[1.0, 0.0], [0.0, 1.0]];
            for _ in 0..sym.n() {
                p = [
                    [
                        p[0][0] * m[0][0] + p[0][1] * m[1][0],
                        p[0][0] * m[0][1] + p[0][1] * m[1][1],
                    ],
                    [
                        p[1][0] * m[0][0] + p[1][1] * m[1][0],
                        p[1][0] * m[0][1] + p[1][1] * m[1][1],
                    ],
                ];
            }
            assert!(
                (p[0][0] - 1.0).abs() < 1e-12
                    && p[0][1].abs() < 1e-12
                    && (p[1][1] - 1.0).abs() < 1e-12
            );
            assert_eq!(
                matching_matrix(sym, -1),
                matching_matrix(sym, sym.n() as i32 - 1)
            );
        }
        // N = 4, r = 1: (U; V) -> (V; -U).
        assert_eq!(
            matching_matrix(Symmetry::Four, 1).map(|r| r.map(|x| x.round())),
            [[0.0, 1.0], [-1.0, 0.0]]
        );
        assert!(Symmetry::from_n(3).is_err());
    }

    #[test]
    fn eig2_and_wrap() {
        let (a, b, d) = curvature::eig2(2.0, 0.0, -1.0);
        assert_eq!((a, b, d), (2.0, -1.0, 0.0));
        let (a, b, d) = curvature::eig2(0.0, 1.0, 0.0);
        assert!(
            (a - 1.0).abs() < 1e-15
                && (b + 1.0).abs() < 1e-15
                && (d - std::f64::consts::FRAC_PI_4).abs() < 1e-15
        );
        assert_eq!(wrap_pi(3.0 * std::f64::consts::PI), std::f64::consts::PI);
        assert!((wrap_pi(-0.5 - TAU) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn classification_of_model_shapes() {
        use classify::{ShapeClass::*, classify};
        assert_eq!(classify(0.0, 0.0, 1e-3), Planar);
        assert_eq!(classify(1.0, 1.0, 1e-3), Elliptic);
        assert_eq!(classify(-1.0, -1.0, 1e-3), Elliptic);
        assert_eq!(classify(1.0, -1.0, 1e-3), Hyperbolic);
        assert_eq!(classify(1.0, 0.0, 1e-3), Cylindrical);
        assert_eq!(classify(0.0, -1.0, 1e-3), Cylindrical);
    }

    #[test]
    fn curvature_of_cylinder_and_sphere() {
        let cyl = generate::cylinder(2.0, 4.0, 64, 32);
        let b = FaceBases::new(&cyl);
        let c = Curvature::compute(&cyl, &b, 0);
        // Interior faces (away from the open ends, where edges are missing).
        let mut n = 0;
        for f in 0..cyl.n_faces() {
            let z = cyl.face_centroid(f).z;
            if (0.5..3.5).contains(&z) {
                assert!((c.k1[f] - 0.5).abs() < 0.03, "k1 {}", c.k1[f]);
                assert!(c.k2[f].abs() < 0.03, "k2 {}", c.k2[f]);
                let d = b.direction(f, c.dir1[f]);
                assert!(d.z.abs() < 0.05, "max direction goes around");
                n += 1;
            }
        }
        assert!(n > 0);
        let s = generate::icosphere(4);
        let c = Curvature::compute(&s, &FaceBases::new(&s), 0);
        for f in 0..s.n_faces() {
            assert!((c.k1[f] - 1.0).abs() < 0.05 && (c.k2[f] - 1.0).abs() < 0.05);
        }
    }

    #[test]
    fn reliability_keeps_the_requested_fraction() {
        let c = Curvature {
            k1: (0..100).map(|i| i as f64).collect(),
            k2: vec![0.0; 100],
            dir1: vec![0.0; 100],
        };
        let w = c.reliability(0.1, &[true; 100]);
        assert_eq!(w.iter().filter(|x| **x > 0.0).count(), 10);
        assert_eq!(w[99], 1.0);
        assert_eq!(w[89], 0.0);
        let mut cand = [true; 100];
        cand[99] = false;
        let w = c.reliability(0.1, &cand);
        assert_eq!(w[99], 0.0);
        assert!((w[98] - 98.0 / 99.0).abs() < 1e-15);
    }
}
