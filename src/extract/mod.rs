//! Remeshing from a seamless parameterization: quad (N = 4), triangle (N = 6, plus the hexagon
//! dual) and stripe (N = 2) extraction, and the thesis's quality measures (sec. 5.2).
//!
//! Design (QEx-style, Ebke et al. 2013):
//! - Per-corner UVs are mapped to *lattice coordinates* where the grid is Z² and the rotation by
//!   2π/N is an integer matrix (N = 6: `a = u − v/√3, b = 2v/√3`, so G6 becomes Z²). Coordinates
//!   within `snap_tolerance` of an integer are snapped, which absorbs float noise of other tools.
//! - Transitions per interior halfedge are derived from the UVs: best rotation, then the
//!   translation rounded to the lattice.
//! - Grid points are owned by exactly one mesh element: a vertex (lattice point exactly at a
//!   vertex), the interior of an edge, or the interior of a face.
//! - From each grid point the lattice directions that start into the surface are traced across
//!   triangles (applying transitions) to the next grid point, or to where the iso-line leaves the
//!   surface (a boundary crossing, which becomes an output vertex). Degenerate incidences (an
//!   iso-line through a mesh vertex) are resolved by a symbolic perturbation of the vertex that is
//!   the same physical displacement in every chart, so neighbouring faces always agree.
//! - Faces are closed by walking the rotation system (next edge = clockwise-next slot at the end
//!   point); boundary points get extra slots along the input boundary.

mod ears;
mod fill;
mod lattice;
mod pinch;
mod poles;
mod purify;
mod snap;
pub use purify::PurifyStats;
mod quality;
pub mod relax;
mod rotate;
pub mod square_fit;
mod stripes;
pub mod surface;
mod trace;

use glam::DVec3;
use thiserror::Error;

pub use quality::{
    RemeshQuality, corner_angles_deg, edge_lengths, irregular_vertices, quality, remesh_report,
    remesh_report_until,
};

use crate::mesh::TriMesh;

/// Options of [`extract`].
#[derive(Clone, Debug)]
pub struct ExtractOptions {
    /// Lattice coordinates within this distance of an integer are snapped to it.
    pub snap_tolerance: f64,
    /// Longest face (in sides) accepted when closing faces; longer cycles are dropped as patched.
    pub max_face_sides: usize,
    /// Pure output: a quad extraction all quads, a triangle extraction all triangles, at the
    /// same density (local chords, collapses and paired midpoints; see `purify`).
    pub pure: bool,
    /// Split every face of a quad extraction into four (1:4 midpoint split, half the edge
    /// length; all quads too, but with an irregular vertex in every former non-quad).
    pub split_to_quads: bool,
    /// Tangential relaxation of the output vertices on the input surface (`relax`; `None`: the
    /// vertices stay where the map puts them).
    pub relax: Option<relax::RelaxOptions>,
    /// Input edges whose remesh vertices relaxation keeps on them (constraint curves); boundary
    /// edges always are. Empty: the boundary and the input's sharp edges (dihedral angle above
    /// `SHARP_EDGE_DEG`).
    pub constrained_edges: Vec<bool>,
    /// Refuse grids finer than this many points (estimated from the UV area before any point
    /// is made), instead of exhausting memory on a mistyped scale.
    pub max_points: usize,
    /// The map's treated poles (`Parameterization::poles`): their star faces are bilinear
    /// quads, extracted through a tessellated proxy and welded into the pole (`poles`).
    pub poles: Vec<crate::param::Pole>,
}

impl Default for ExtractOptions {
    fn default() -> Self {
        ExtractOptions {
            snap_tolerance: 1e-4,
            max_face_sides: 32,
            pure: true,
            split_to_quads: false,
            relax: Some(relax::RelaxOptions::default()),
            constrained_edges: Vec::new(),
            max_points: 50_000_000,
            poles: Vec::new(),
        }
    }
}

/// Where an output vertex lies on the input mesh (what relaxation keeps it on).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// At input vertex `v`.
    Vertex(u32),
    /// In the interior of input edge `e` (on the boundary when `e` is a boundary edge).
    Edge(u32),
    /// In the interior of input face `f`.
    Face(u32),
    /// Made by a post-process (dual centroids, splits) with no input element of its own.
    Unknown,
}

/// An extracted polygon mesh (or stripes, as polylines).
#[derive(Clone, Debug, Default)]
pub struct Remesh {
    pub positions: Vec<DVec3>,
    /// Per output vertex: the input element it lies on (same length as `positions`).
    pub origins: Vec<Origin>,
    /// Polygons, counter-clockwise as seen from the input's normal side.
    pub faces: Vec<Vec<u32>>,
    /// Iso-lines (stripes, N = 2).
    pub polylines: Vec<Vec<u32>>,
    /// Places where the input needed local patching (flipped / degenerate triangles, traces
    /// that could not be matched, dropped faces).
    pub patched_places: usize,
    /// What made the output pure (zero when `ExtractOptions::pure` is off).
    pub purified: PurifyStats,
    /// What relaxation did (`None`: not run).
    pub relaxed: Option<relax::RelaxStats>,
}

impl Remesh {
    /// V − E + F over the vertices the faces use (what extraction must keep of the input).
    pub fn euler_characteristic(&self) -> i64 {
        let mut edges = std::collections::HashSet::new();
        let mut used = std::collections::HashSet::new();
        for f in &self.faces {
            for k in 0..f.len() {
                let (a, b) = (f[k], f[(k + 1) % f.len()]);
                edges.insert((a.min(b), a.max(b)));
                used.insert(a);
            }
        }
        used.len() as i64 - edges.len() as i64 + self.faces.len() as i64
    }
}

/// Why extraction failed.
#[derive(Debug, Error)]
pub enum ExtractError {
    #[error("symmetry must be 2, 4 or 6, got {0}")]
    Symmetry(u8),
    #[error("expected {expected} per-corner UVs (3 per triangle), got {got}")]
    UvCount { expected: usize, got: usize },
    #[error("UV of corner {0} is not finite")]
    NonFinite(usize),
    #[error(
        "the UVs are not seamless: across {bad} of {total} interior edges the two triangles' UVs \
         do not differ by a rotation by a multiple of 2π/N and a lattice translation (worst \
         mismatch {worst:.3e} lattice units)"
    )]
    NotSeamless {
        bad: usize,
        total: usize,
        worst: f64,
    },
    #[error(
        "the parameterization covers no grid point: the grid is coarser than the surface (ask \
         for more target vertices or a smaller grid size; for `extract`, scale the UVs up)"
    )]
    Empty,
    #[error("cancelled")]
    Cancelled,
    #[error("the pole stars cannot be extracted: {0}")]
    Poles(String),
    #[error(
        "the grid would have about {estimated:.3e} points (limit {limit}): the grid size is far \
         too small for this mesh (ask for fewer target vertices or a larger grid size; for \
         `extract`, scale the UVs down)"
    )]
    TooFine { estimated: f64, limit: usize },
}

/// Extracts a quad (N = 4), triangle (N = 6) or stripe (N = 2) mesh from per-corner UVs
/// (`uv[3 * f + k]`) of a seamless parameterization.
pub fn extract(
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    symmetry: u8,
    opts: &ExtractOptions,
) -> Result<Remesh, ExtractError> {
    extract_until(mesh, uv, symmetry, opts, &|| false)
}

/// [`extract`], giving up with [`ExtractError::Cancelled`] once `cancel` returns true (polled
/// between the stages and at every relaxation iteration): the editor's stale extractions stop.
pub fn extract_until(
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    symmetry: u8,
    opts: &ExtractOptions,
    cancel: &(dyn Fn() -> bool + Sync),
) -> Result<Remesh, ExtractError> {
    if !matches!(symmetry, 2 | 4 | 6) {
        return Err(ExtractError::Symmetry(symmetry));
    }
    if uv.len() != 3 * mesh.n_faces() {
        return Err(ExtractError::UvCount {
            expected: 3 * mesh.n_faces(),
            got: uv.len(),
        });
    }
    if let Some(c) = uv
        .iter()
        .position(|p| !p[0].is_finite() || !p[1].is_finite())
    {
        return Err(ExtractError::NonFinite(c));
    }
    // Grid points ≈ UV area / lattice cell area (1 for Z², √3/2 for G6).
    let uv_area: f64 = uv
        .chunks_exact(3)
        .map(|t| {
            let (a, b, c) = (t[0], t[1], t[2]);
            0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs()
        })
        .sum();
    let cell = if symmetry == 6 { 0.75f64.sqrt() } else { 1.0 };
    let estimated = uv_area / cell;
    if estimated.is_nan() || estimated > opts.max_points as f64 {
        return Err(ExtractError::TooFine {
            estimated,
            limit: opts.max_points,
        });
    }
    let raw = |mesh: &TriMesh, uv: &[[f64; 2]]| -> Result<Remesh, ExtractError> {
        let param = lattice::Param::new(mesh, uv, symmetry, opts.snap_tolerance)?;
        Ok(if symmetry == 2 {
            stripes::extract_stripes(&param)
        } else {
            trace::extract_grid(&param, opts)
        })
    };
    let mut out = if opts.poles.is_empty() {
        raw(mesh, uv)?
    } else {
        for p in &opts.poles {
            if p.faces.iter().any(|&f| f >= mesh.n_faces()) || p.vertex >= mesh.n_vertices() {
                return Err(ExtractError::Poles(format!(
                    "pole at vertex {} names elements this mesh does not have",
                    p.vertex
                )));
            }
        }
        let proxy = poles::Proxy::new(mesh, uv, &opts.poles)?;
        let r = raw(&proxy.mesh, &proxy.uv)?;
        proxy.close(mesh, &opts.poles, r)
    };
    if out.positions.is_empty() {
        return Err(ExtractError::Empty);
    }
    if cancel() {
        return Err(ExtractError::Cancelled);
    }
    if opts.pure && symmetry != 2 {
        out.purified = purify::purify(&mut out, if symmetry == 4 { 4 } else { 3 });
        if symmetry == 4 && out.faces.iter().all(|f| f.len() == 4) {
            out.purified.rotated_edges = rotate::rotate_boundary_edges(&mut out);
        }
        if symmetry == 6 && out.faces.iter().all(|f| f.len() == 3) {
            // collapses can leave new flat ears
            out.purified.cut_ears = ears::cut_flat_ears(&mut out);
            out.purified.collapsed_edges += ears::collapse_short_boundary_edges(&mut out);
            out.purified.cut_ears += ears::cut_flat_ears(&mut out);
        }
    }
    if symmetry != 2 {
        let split = pinch::split_pinched_vertices(&mut out);
        out.purified.split_vertices = split.len();
        out.purified.dropped_cells = pinch::drop_detached_cells(&mut out, &split);
    }
    if symmetry == 4 && opts.split_to_quads {
        out = split_to_quads(&out);
    }
    if let Some(r) = &opts.relax
        && symmetry != 2
    {
        let sharp;
        let constrained = if opts.constrained_edges.len() == mesh.n_edges() {
            &opts.constrained_edges
        } else {
            sharp = sharp_edges(mesh, SHARP_EDGE_DEG);
            &sharp
        };
        if cancel() {
            return Err(ExtractError::Cancelled);
        }
        let held = poles::polar_region(&out, &opts.poles);
        out.relaxed = Some(relax::relax_holding(
            &mut out,
            mesh,
            constrained,
            &held,
            r,
            cancel,
        ));
        if cancel() {
            return Err(ExtractError::Cancelled);
        }
    }
    Ok(out)
}

/// Relaxation keeps vertices on input edges sharper than this (dihedral angle, degrees) on them
/// unless constraint curves are given: creases of CAD parts stay creases.
pub const SHARP_EDGE_DEG: f64 = 60.0;

/// Per input edge: whether its dihedral angle exceeds `angle_deg`.
pub fn sharp_edges(mesh: &TriMesh, angle_deg: f64) -> Vec<bool> {
    let mut out = vec![false; mesh.n_edges()];
    for e in crate::constraint::detect::feature_edges(mesh, angle_deg) {
        out[e] = true;
    }
    out
}

/// The dual of a polygon mesh: one vertex per face (its centroid), one face per interior vertex.
/// Applied to a triangle extraction (N = 6) it gives the hexagon mesh.
pub fn dual(remesh: &Remesh) -> Remesh {
    use std::collections::HashMap;
    let mut he: HashMap<(u32, u32), usize> = HashMap::new();
    for (f, face) in remesh.faces.iter().enumerate() {
        for k in 0..face.len() {
            he.insert((face[k], face[(k + 1) % face.len()]), f);
        }
    }
    let positions: Vec<DVec3> = remesh
        .faces
        .iter()
        .map(|f| {
            f.iter()
                .map(|&v| remesh.positions[v as usize])
                .sum::<DVec3>()
                / f.len() as f64
        })
        .collect();
    let mut done = vec![false; remesh.positions.len()];
    let mut faces = Vec::new();
    for (f0, face) in remesh.faces.iter().enumerate() {
        for k in 0..face.len() {
            let v = face[k];
            if done[v as usize] {
                continue;
            }
            done[v as usize] = true;
            // Walk counter-clockwise around v: from face f with corner v, the next face contains
            // the twin of the edge (prev, v), i.e. the directed edge (v, prev).
            let mut ring = vec![f0 as u32];
            let mut f = f0;
            let mut closed = false;
            for _ in 0..64 {
                let fc = &remesh.faces[f];
                let i = fc.iter().position(|&x| x == v).unwrap_or(0);
                let prev = fc[(i + fc.len() - 1) % fc.len()];
                match he.get(&(v, prev)) {
                    Some(&g) if g == f0 => {
                        closed = true;
                        break;
                    }
                    Some(&g) => {
                        ring.push(g as u32);
                        f = g;
                    }
                    None => break,
                }
            }
            if closed && ring.len() >= 3 {
                faces.push(ring);
            }
        }
    }
    let origins = vec![Origin::Unknown; positions.len()];
    Remesh {
        positions,
        origins,
        faces,
        polylines: Vec::new(),
        patched_places: remesh.patched_places,
        purified: remesh.purified,
        relaxed: remesh.relaxed,
    }
}

/// Splits every face with a number of sides other than 4 into quads: edge midpoints, the face
/// centroid, one quad per corner. Quads are split too, so that edges stay conforming.
pub fn split_to_quads(remesh: &Remesh) -> Remesh {
    use std::collections::HashMap;
    let mut positions = remesh.positions.clone();
    let mut origins = remesh.origins.clone();
    origins.resize(positions.len(), Origin::Unknown);
    let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
    let mut faces = Vec::new();
    for face in &remesh.faces {
        let n = face.len();
        let c = face
            .iter()
            .map(|&v| remesh.positions[v as usize])
            .sum::<DVec3>()
            / n as f64;
        let ci = positions.len() as u32;
        positions.push(c);
        origins.push(Origin::Unknown);
        let mut mids = Vec::with_capacity(n);
        for k in 0..n {
            let (a, b) = (face[k], face[(k + 1) % n]);
            let key = (a.min(b), a.max(b));
            let m = *mid.entry(key).or_insert_with(|| {
                positions.push(0.5 * (remesh.positions[a as usize] + remesh.positions[b as usize]));
                origins.push(Origin::Unknown);
                positions.len() as u32 - 1
            });
            mids.push(m);
        }
        for k in 0..n {
            faces.push(vec![face[k], mids[k], ci, mids[(k + n - 1) % n]]);
        }
    }
    Remesh {
        positions,
        origins,
        faces,
        polylines: remesh.polylines.clone(),
        patched_places: remesh.patched_places,
        purified: remesh.purified,
        relaxed: remesh.relaxed,
    }
}
