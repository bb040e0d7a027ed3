//! `quadcover solve MESH --symmetry 2|4|6 … --out UV.obj [--report REPORT.json]`: frame field
//! (computed, or read with `--field`), QuadCover, seamless per-corner UVs written in the input's
//! vertex and face order, and an optional JSON report. Progress per stage goes to stderr.

use std::collections::HashMap;
use std::path::PathBuf;
use std::time::Instant;

use crate::extract::{self, ExtractOptions, RemeshQuality, dual, remesh_report};
use clap::{Args, ValueEnum};
use indicatif::ProgressBar;
use serde::Serialize;
use std::io::Write;

use super::{CliError, prepare};
use crate::edit::{self, Base, Project, Settings, project::RoundingSetting};
use crate::field::{self, Symmetry};
use crate::io;
use crate::mesh::TriMesh;
use crate::mesh::isotropic::{
    NEEDLE_AREA_SHARE, isotropic_remesh, long_needles, needle_area_share, prepared_options,
    too_coarse,
};
use crate::param;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RoundingArg {
    Direct,
    Greedy,
}

#[derive(Debug, Args)]
pub struct SolveArgs {
    /// Mesh file (OBJ, PLY, OFF or STL); optional with --project (which names its mesh).
    #[arg(required_unless_present = "project")]
    pub mesh: Option<PathBuf>,
    /// Project file (settings and edits, see the README): its edits are replayed; flags given
    /// here override its settings.
    #[arg(long, conflicts_with = "field")]
    pub project: Option<PathBuf>,
    /// Rotational symmetry: 2 (stripes), 4 (quads) or 6 (hexagons) [default: 4].
    #[arg(long)]
    pub symmetry: Option<u32>,
    /// Target number of grid vertices (sets the grid size).
    #[arg(long, conflicts_with = "scale")]
    pub target_vertices: Option<usize>,
    /// Grid size in model units (one texture unit).
    #[arg(long)]
    pub scale: Option<f64>,
    /// Never remesh the input, even a raw tessellation (see --prepare).
    #[arg(long, conflicts_with = "prepare")]
    pub keep_input: bool,
    /// Remesh the input isotropically first (as `quadcover prepare`), keeping sharp features and
    /// the boundary. Without a project or a field file this happens by itself when more than
    /// 20 % of the input's area is in needles (triangles with a corner under 10°: raw CAD
    /// tessellations); the output OBJ and REPORT.json then describe the remeshed mesh.
    #[arg(long)]
    pub prepare: bool,
    /// Weight of curvature alignment against smoothness (eq. 3.5–3.6).
    #[arg(long)]
    pub tau: Option<f64>,
    /// Fraction of the most reliable curvature directions kept as constraints.
    #[arg(long)]
    pub reliable_fraction: Option<f64>,
    /// Neighbour-averaging passes over the shape operators before the curvature directions are
    /// taken (default 5; 0 = the thesis's eq. 3.2 as is). More passes, fewer singularities on
    /// noisy scans.
    #[arg(long)]
    pub curvature_smoothing: Option<usize>,
    /// Cancel opposite-index singularity pairs closer than this many grid cells (sec. 3.3;
    /// default 1, 0 = keep the rounded field).
    #[arg(long)]
    pub cancel_pairs_within: Option<f64>,
    /// Round gaps to 2Z² so that singularities land on integer grid points (N = 4; the default,
    /// kept for old scripts).
    #[arg(long, conflicts_with = "no_pure_quad")]
    pub pure_quad: bool,
    /// Round gaps to ½Z² as in the thesis (N = 4): less distortion, but singularities between
    /// grid points, so more irregular vertices in the remesh.
    #[arg(long)]
    pub no_pure_quad: bool,
    /// Gap rounding: direct (thesis) or greedy (MIQ-style) [default: direct].
    #[arg(long, value_enum)]
    pub rounding: Option<RoundingArg>,
    /// Refuse singularity merges that would create index ±2/4 (hanging nodes; N = 4).
    #[arg(long)]
    pub no_half_merges: bool,
    /// Refuse singularity merges that would create a pole (positive integral index, e.g. +4/4;
    /// by default they are allowed and treated by alg. 6, sec. 4.3).
    #[arg(long)]
    pub no_pole_merges: bool,
    /// Keep the folds the global step leaves (no injectivity repair; REPORT.json still counts
    /// them).
    #[arg(long)]
    pub no_untangle: bool,
    /// Renormalize the field's relaxed solve (Ginzburg–Landau steps pulling it to unit length):
    /// lower smoothing energy and distortion; splits umbilic poles; the field takes longer
    #[arg(long)]
    pub renormalize_field: bool,
    /// Keep the grid size uniform on thin parts too (by default tubes, handles and small holes
    /// narrower than 5 grid cells around are made finer, so that the remesh stays manifold)
    #[arg(long)]
    pub no_thin_refinement: bool,
    /// Never solve again on a grid made finer around crowded singularities (by default, while
    /// the repaired map keeps folds or mis-wound vertices, under curves folds, up to three more
    /// tries make the grid up to 2–3× finer around singularities of one sign closer than 1.5–2
    /// cells, and the best map is kept; the vertex count then grows a little)
    #[arg(long)]
    pub no_crowded_refinement: bool,
    /// `relax` edits merge singularities closer than this many grid cells [default: 1].
    #[arg(long)]
    pub relax_merge_within: Option<f64>,
    /// Align to sharp features: edges whose dihedral angle exceeds ANGLE_DEG become geometric
    /// constraint curves (a `detect_features` edit after the project's edits).
    #[arg(long, value_name = "ANGLE_DEG", conflicts_with = "field")]
    pub features: Option<f64>,
    /// Align to the boundary: every boundary loop becomes geometric constraint curves, split at
    /// sharp corners (an `align_boundary` edit after the project's edits).
    #[arg(long, conflicts_with = "field")]
    pub align_boundary: bool,
    /// Frame field JSON (`field::io` format) instead of computing one.
    #[arg(long)]
    pub field: Option<PathBuf>,
    /// Output OBJ with per-corner `vt`.
    #[arg(long)]
    pub out: PathBuf,
    /// Optional JSON report.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Also extract and write the remesh (quads for N = 4, triangles for N = 6, iso-line
    /// polylines for N = 2); its quality goes into the report's `remesh` block.
    #[arg(long)]
    pub remesh: Option<PathBuf>,
    /// With --remesh: leave the remesh's vertices where the map puts them (no tangential
    /// relaxation on the input surface).
    #[arg(long)]
    pub no_relax: bool,
    /// With --symmetry 6 and --remesh: write the hexagon mesh (dual of the triangle remesh).
    #[arg(long, requires = "remesh")]
    pub dual: bool,
}

#[derive(Debug, Serialize)]
struct SingularityOut {
    vertex: usize,
    index: f64,
}

#[derive(Debug, Serialize)]
struct DistortionOut {
    mean: f64,
    p99: f64,
}

#[derive(Debug, Default, Serialize)]
struct TimingsOut {
    curvature: f64,
    smooth: f64,
    local: f64,
    cut: f64,
    global: f64,
    /// The injectivity repair (part of neither `global` nor `remesh`).
    repair: f64,
    remesh: f64,
    total: f64,
}

#[derive(Debug, Serialize)]
struct SkippedOut {
    /// 1-based position in the project's edit list.
    position: usize,
    edit: crate::edit::Edit,
    reason: String,
}

#[derive(Debug, Serialize)]
struct PreparedOut {
    /// Vertices and faces of the file.
    input_vertices: usize,
    input_faces: usize,
    /// Share of the file's area in triangles with a corner under 10°.
    needle_area_share: f64,
    /// Whether it was remeshed for being a low-poly mesh far coarser than the grid
    /// (`mesh::isotropic::too_coarse`).
    coarse: bool,
    edge_length: f64,
    ms: f64,
}

#[derive(Serialize)]
struct Report {
    /// The input as remeshed before the solve (`--prepare`, or a raw tessellation), if it was:
    /// the vertices, faces and UVs here are the remeshed mesh's.
    #[serde(skip_serializing_if = "Option::is_none")]
    prepared_input: Option<PreparedOut>,
    vertices: usize,
    faces: usize,
    genus: i64,
    boundary_loops: usize,
    symmetry: usize,
    singularities: Vec<SingularityOut>,
    cut_paths: usize,
    /// The lattice the gaps were rounded on: `TwoZ2` (quads' default, singularities on grid
    /// points), `Z2` (`--no-pure-quad`, or a map on 2Z² that kept folds under curves and was
    /// solved again), `G6` (hexagons).
    lattice: param::Lattice,
    flipped_faces: usize,
    /// Folded faces the global step left, before the injectivity repair.
    flipped_faces_before_repair: usize,
    /// Time of the repair (also in `timings_ms.repair`).
    repair_ms: f64,
    /// Gaps the repair rounded again (their first rounding put two branch points on one
    /// lattice point): cut path index, old and new value.
    rerounded_gaps: Vec<param::Rerounded>,
    /// Quads under curves: corners where curves meet that the 2Z² rounding put on the line of
    /// a curve under two cells away in space and half a cell or more from it in the local
    /// step's map (the strip between folds; such maps are solved on Z² when they keep folds,
    /// see `lattice`).
    collapsed_strips: usize,
    /// Interior vertices (file indices) whose fan turns by other than their cone angle
    /// although no face is folded: the map is not locally injective there.
    miswound_vertices: Vec<usize>,
    /// Constraint curves (ids) within two rings of the faces the repair left folded.
    curves_beside_folds: Vec<u32>,
    /// What the local step removed from the guiding field (thesis sec. 3.3), in grid cells.
    curl: f64,
    seam_max_error: f64,
    /// Constraint curves: line family, value and the largest offset of the map from the line
    /// (0 up to rounding for geometric curves).
    curves: Vec<param::CurveFit>,
    conformal_distortion: DistortionOut,
    area_distortion: f64,
    timings_ms: TimingsOut,
    /// Edits of the project replayed (0 without a project), and those skipped.
    edits_applied: usize,
    skipped_edits: Vec<SkippedOut>,
    /// Singularities of positive integral index treated by alg. 6 (their star faces are the
    /// quads of UV.obj), and those it could not treat.
    poles: Vec<PoleOut>,
    untreated_poles: Vec<usize>,
    /// Faces the thin-part refinement made finer, and the largest multiplier (0 and 1 when
    /// nothing is thin, it is off, or the field came from a file).
    thin_parts: ThinOut,
    /// Set when the map kept is one of the tries on a grid made finer around crowded
    /// singularities (`param::crowded::LADDER`): the try (`crowding {within, cap}`: same-sign
    /// singularities closer than `within` cells, the grid up to `cap` times finer), how many
    /// singularities, how many faces, the largest multiplier. `null` when the first map was
    /// kept.
    crowded_refinement: Option<param::CrowdedRefinement>,
    #[serde(skip_serializing_if = "Option::is_none")]
    remesh: Option<RemeshQuality>,
}

#[derive(Debug, Serialize)]
struct ThinOut {
    faces: usize,
    max_multiplier: f64,
}

#[derive(Debug, Serialize)]
struct PoleOut {
    vertex: usize,
    index: f64,
    /// The star's faces (file triangle indices), counter-clockwise.
    faces: Vec<usize>,
}

/// Per-stage progress on stderr: a spinner naming the running stage on terminals (indicatif
/// draws nothing when stderr is not a terminal), and one plain line per finished stage always.
struct Progress(ProgressBar);

impl Progress {
    fn new() -> Progress {
        let bar = ProgressBar::new_spinner();
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        Progress(bar)
    }
    fn start(&self, stage: &str) {
        self.0.set_message(format!("{stage} ..."));
    }
    fn line(&self, text: String) {
        self.0.suspend(|| eprintln!("{text}"));
    }
    fn done(&self, stage: &str, t: Instant) -> f64 {
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.line(format!("  {stage:<10} {ms:9.1} ms"));
        ms
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

/// The settings a solve runs with: the project's (or the defaults), overridden by the flags
/// given.
fn settings_from(args: &SolveArgs, base: Option<&Settings>) -> Result<Settings, CliError> {
    let mut s = base.cloned().unwrap_or_default();
    if let Some(n) = args.symmetry {
        s.symmetry = n;
    }
    if let Some(v) = args.target_vertices {
        s.target_vertices = Some(v);
        s.scale = None;
    }
    if let Some(h) = args.scale {
        s.scale = Some(h);
        s.target_vertices = None;
    }
    if let Some(t) = args.tau {
        s.tau = t;
    }
    if let Some(r) = args.reliable_fraction {
        s.reliable_fraction = r;
    }
    if let Some(c) = args.curvature_smoothing {
        s.curvature_smoothing = c;
    }
    if let Some(c) = args.cancel_pairs_within {
        s.cancel_pairs_within = c;
    }
    if args.pure_quad {
        s.pure_quad = true;
    }
    if args.no_pure_quad {
        s.pure_quad = false;
    }
    if let Some(r) = args.rounding {
        s.rounding = match r {
            RoundingArg::Direct => RoundingSetting::Direct,
            RoundingArg::Greedy => RoundingSetting::Greedy,
        };
    }
    if args.no_half_merges {
        s.no_half_merges = true;
    }
    if args.no_pole_merges {
        s.no_pole_merges = true;
    }
    if let Some(m) = args.relax_merge_within {
        s.relax_merge_within = m;
    }
    if args.renormalize_field {
        s.renormalize_field = true;
    }
    if args.no_thin_refinement {
        s.refine_thin_parts = false;
    }
    if args.no_crowded_refinement {
        s.refine_crowded = false;
    }
    if args.no_untangle {
        s.no_untangle = true;
    }
    s.validate().map_err(|e| -> CliError {
        match (&args.project, base) {
            (Some(p), Some(_)) => format!("{}: settings: {e}", p.display()).into(),
            _ => e.into(),
        }
    })?;
    Ok(s)
}

pub fn run(args: &SolveArgs) -> Result<(), CliError> {
    let total = Instant::now();
    if let Some(s) = args
        .scale
        .filter(|s| s.is_nan() || *s <= 0.0 || s.is_infinite())
    {
        return Err(format!("--scale must be positive, got {s}").into());
    }
    if args.target_vertices == Some(0) {
        return Err("--target-vertices must be positive".into());
    }
    // A dihedral angle: NaN or 180° and more would pick no edge, silently.
    if let Some(a) = args.features.filter(|a| !(*a > 0.0 && *a < 180.0)) {
        return Err(format!(
            "--features takes a dihedral angle between 0 and 180 degrees, got {a}"
        )
        .into());
    }
    let project = match &args.project {
        Some(path) => Some(Project::load(path)?),
        None => None,
    };
    let settings = settings_from(args, project.as_ref().map(|p| &p.settings))?;
    let symmetry = Symmetry::from_n(settings.symmetry)?;
    let n = settings.symmetry as usize;
    if args.dual && n != 6 {
        return Err(format!(
            "--dual writes the hexagon mesh dual to a triangle remesh: it needs --symmetry 6 (here {n})"
        )
        .into());
    }
    let mesh_path = match (&args.mesh, &project, &args.project) {
        (Some(m), _, _) => m.clone(),
        (None, Some(p), Some(pp)) => p.mesh_path(pp),
        _ => return Err("no mesh given".into()),
    };
    eprintln!("quadcover solve {} (N = {n})", mesh_path.display());
    let bar = Progress::new();
    bar.start("load");
    let t = Instant::now();
    if args.prepare && args.field.is_some() {
        return Err(
            "--prepare with --field: the field file is a field on the mesh file's faces; \
             remesh the mesh with `quadcover prepare` and design the field on that"
                .into(),
        );
    }
    if args.prepare && project.is_some() {
        return Err(
            "--prepare with --project: the project's edits name its mesh file's vertices; \
             remesh the mesh with `quadcover prepare` and start a project on that"
                .into(),
        );
    }
    // Every reader error but `Io` leaves the file name to the caller; a mesh named by a
    // project also names the project.
    let named_by = match (&args.mesh, &args.project) {
        (None, Some(pp)) => format!(" (the mesh of {})", pp.display()),
        _ => String::new(),
    };
    let soup = io::read_mesh(&mesh_path).map_err(|e| match e {
        io::ReadError::Io { .. } => format!("{e}{named_by}"),
        e => format!("{}: {e}", mesh_path.display()),
    })?;
    let (mesh, repair) =
        TriMesh::from_soup(&soup).map_err(|e| format!("{}: {e}", mesh_path.display()))?;
    // The safe repairs and what is only warned about (an unwelded soup solves as a thousand
    // separate pieces): `info` and the editor list them too.
    for w in &repair.warnings {
        bar.line(format!("  warning: {w}"));
    }
    let needles = needle_area_share(&mesh);
    let params = settings.field_params();
    // The grid's vertex count when the input is far coarser.
    let coarse = too_coarse(&mesh, &params.density, params.symmetry);
    // The share of the area in needles many cells long, when large enough.
    let long = long_needles(&mesh, &params.density, params.symmetry);
    let raw = needles > NEEDLE_AREA_SHARE || coarse.is_some() || long.is_some();
    // Why the input is (or would be) remeshed, for the messages.
    let why = if let Some(grid) = coarse {
        format!(
            "{} vertices, far coarser than the grid's {grid:.0}",
            mesh.n_vertices()
        )
    } else if let (Some(share), false) = (long, needles > NEEDLE_AREA_SHARE) {
        format!(
            "{:.0} % of its area in needles longer than {} grid cells",
            100.0 * share,
            crate::mesh::isotropic::LONG_NEEDLE_CELLS
        )
    } else {
        format!("{:.0} % of its area in needles", 100.0 * needles)
    };
    // Edits name the file's vertices and a field file its faces, so with a project or a field
    // the mesh is never remeshed by itself.
    let by_itself = raw && project.is_none() && args.field.is_none() && !args.keep_input;
    let prep_clock = Instant::now();
    let opts = prepared_options(
        &mesh,
        settings.target_vertices,
        prepare::DEFAULT_FEATURE_ANGLE.min(args.features.unwrap_or(f64::INFINITY)),
    );
    let remeshed = if args.prepare || by_itself {
        match isotropic_remesh(&mesh, &opts) {
            Ok(out) => Some(out),
            // Asked for, or too large to solve anyway: the error is the answer.
            Err(e) if args.prepare || matches!(e, crate::mesh::MeshError::TooLarge { .. }) => {
                return Err(
                    format!("{}: remeshing the input failed: {e}", mesh_path.display()).into(),
                );
            }
            // Remeshing by itself is a courtesy: its failure leaves the input as it is.
            Err(e) => {
                bar.line(format!(
                    "  warning: the input looks like a raw tessellation ({why}), but remeshing it \
                     failed ({e}); solving on the input as it is"
                ));
                None
            }
        }
    } else {
        None
    };
    let (soup, mesh, repair, prepared_input) = if let Some(out) = remeshed {
        bar.line(format!(
            "  input remeshed ({why}); {} vertices -> {} (edge length {:.4}); --keep-input \
                 keeps it as it is",
            mesh.n_vertices(),
            out.n_vertices(),
            opts.edge_length
        ));
        let new_soup = crate::mesh::PolygonSoup {
            source_polygon: (0..out.n_faces() as u32).collect(),
            positions: out.positions().to_vec(),
            triangles: out.faces().to_vec(),
            ..Default::default()
        };
        // The remeshed mesh is valid already and is its own "file": identity maps back.
        let r = crate::mesh::RepairReport {
            original_vertex: (0..out.n_vertices() as u32).collect(),
            original_face: (0..out.n_faces() as u32).collect(),
            ..Default::default()
        };
        let info = PreparedOut {
            input_vertices: soup.positions.len(),
            input_faces: soup.triangles.len(),
            needle_area_share: needles,
            coarse: coarse.is_some(),
            edge_length: opts.edge_length,
            ms: prep_clock.elapsed().as_secs_f64() * 1e3,
        };
        (new_soup, out, r, Some(info))
    } else {
        if raw && !by_itself {
            bar.line(format!(
                "  warning: the input looks like a raw tessellation ({why}): the map may \
                     fold; `quadcover prepare` remeshes it (kept as it is here: --keep-input, or \
                     a project or field file, which name its vertices and faces)"
            ));
        }
        (soup, mesh, repair, None)
    };
    if let (Some(project), Some(pp)) = (&project, &args.project) {
        // The hash names the project's own mesh; another one given on the command line is the
        // user's choice.
        if args.mesh.is_none() {
            let bytes =
                std::fs::read(&mesh_path).map_err(|e| format!("{}: {e}", mesh_path.display()))?;
            project.check_mesh(pp, &bytes)?;
        }
        project.check_vertices(pp, soup.positions.len())?;
    }
    bar.done("load", t);
    let mut timings = TimingsOut::default();
    let opts = settings.param_options();
    let mut edits_applied = 0;
    let mut skipped_edits = Vec::new();
    // With a computed field, QuadCover's factorizations start as soon as its matchings are final.
    let mut prepared = None;
    let mut solved = None;
    // The constraint curves' edges (empty without curves), for the remesh's relaxation.
    let mut curve_edges = Vec::new();
    // The curves beside faces the repair left folded (named in a warning below).
    let mut curves_at_folds: Vec<u32> = Vec::new();
    // Curve shortcuts are edits after the project's (or the only ones).
    let mut shortcut_edits = Vec::new();
    if let Some(angle_deg) = args.features {
        shortcut_edits.push(edit::Edit::DetectFeatures { angle_deg });
    }
    if args.align_boundary {
        shortcut_edits.push(edit::Edit::AlignBoundary { on: true });
    }
    let project = match (project, shortcut_edits.is_empty()) {
        (Some(mut p), false) => {
            p.edits.extend(shortcut_edits);
            Some(p)
        }
        (None, false) => Some(Project::new(
            edit::MeshRef {
                path: mesh_path.clone(),
                sha256: None,
            },
            settings.clone(),
        ))
        .map(|mut p| {
            p.edits = shortcut_edits;
            p
        }),
        (p, true) => p,
    };
    let mut thin = field::thin::ThinParts::default();
    let field = match (&args.field, &project) {
        (_, Some(project)) => {
            bar.start("frame field and QuadCover's analyses, then the edits");
            let t = Instant::now();
            let base = Base::new(
                std::sync::Arc::new(mesh.clone()),
                repair.original_vertex.clone(),
                soup.positions.len(),
                settings.clone(),
                &edit::never,
            )?;
            thin = base.field().thin.clone();
            for (name, secs) in &base.field().timings {
                if name.contains("curvature") {
                    timings.curvature += secs * 1e3;
                } else {
                    timings.smooth += secs * 1e3;
                }
            }
            bar.done("field", t);
            let t = Instant::now();
            // A curve that is no edge path is a broken file, not an edit that no longer applies.
            let project_path = args
                .project
                .clone()
                .unwrap_or_else(|| "(command line)".into());
            for (i, e) in project.edits.iter().enumerate() {
                base.check_edit(e)
                    .map_err(|message| edit::ProjectError::Edit {
                        path: project_path.clone(),
                        position: i + 1,
                        message,
                    })?;
            }
            let replay = base.replay(&project.edits, &edit::never)?;
            for s in &replay.skipped {
                bar.line(format!(
                    "  skipped edit {} ({}): {}",
                    s.position,
                    s.edit.label(),
                    s.reason
                ));
            }
            edits_applied = project.edits.len() - replay.skipped.len();
            skipped_edits = replay
                .skipped
                .iter()
                .map(|s| SkippedOut {
                    position: s.position,
                    edit: s.edit.clone(),
                    reason: s.reason.clone(),
                })
                .collect();
            bar.done("edits", t);
            let features = replay
                .last()
                .curves
                .values()
                .filter(|c| c.origin == crate::constraint::CurveOrigin::Feature)
                .map(|c| c.vertices.as_slice());
            if let Some(w) =
                crate::constraint::detect::noise_warning(&mesh, features, base.grid_size())
            {
                bar.line(format!("  warning: {w}"));
            }
            let s = base.solve(replay.last(), &edit::never)?;
            curve_edges = crate::constraint::curve_edges(&mesh, replay.last().curves.values());
            if s.param.flipped_faces > 0 {
                curves_at_folds = crate::constraint::curves_beside(
                    &mesh,
                    replay.last().curves.values(),
                    &crate::param::folded_faces(&s.param.uv),
                    crate::constraint::BESIDE_FOLDS_RINGS,
                );
            }
            let field = s.field.clone();
            solved = Some(s.param);
            field
        }
        (Some(path), None) => {
            let t = Instant::now();
            let text =
                std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            let mut f = field::io::from_json(&text, &mesh)
                .map_err(|e| format!("{}: {e}", path.display()))?;
            if f.symmetry != symmetry {
                return Err(format!(
                    "{}: field has symmetry {}, --symmetry is {n}",
                    path.display(),
                    f.symmetry.n()
                )
                .into());
            }
            f.validate(&mesh)?;
            if args.scale.is_some() || args.target_vertices.is_some() {
                let d = settings.field_params().density;
                // Rescale so that the mean frame row length is 1/h.
                let h = field::density::grid_size(&mesh, &d, symmetry, &vec![1.0; mesh.n_faces()])?;
                let mean = f
                    .frames
                    .iter()
                    .map(|x| 0.5 * (x[0].length() + x[1].length()))
                    .sum::<f64>()
                    / f.frames.len() as f64;
                if mean.is_nan() || mean <= 0.0 {
                    return Err(format!("{}: frames have zero length", path.display()).into());
                }
                let k = 1.0 / (h * mean);
                for x in &mut f.frames {
                    x[0] *= k;
                    x[1] *= k;
                }
            }
            timings.smooth = bar.done("field", t);
            f
        }
        (None, None) => {
            let params = settings.field_params();
            bar.start("frame field, then the QuadCover factorizations beside its last solve");
            let (fr, qc) = param::pipeline::field_then_quadcover(&mesh, &params, n, &opts)?;
            prepared = Some(qc);
            thin = fr.thin.clone();
            for (name, secs) in &fr.timings {
                if name.contains("curvature") {
                    timings.curvature += secs * 1e3;
                } else {
                    timings.smooth += secs * 1e3;
                }
            }
            bar.line(format!(
                "  {:<10} {:9.1} ms",
                "curvature", timings.curvature
            ));
            bar.line(format!("  {:<10} {:9.1} ms", "smooth", timings.smooth));
            fr.field
        }
    };
    if thin.faces > 0 {
        bar.line(format!(
            "  thin parts: {} faces made up to {:.2}x finer (at least {} cells around; --no-thin-refinement keeps the grid uniform)",
            thin.faces,
            thin.max_multiplier,
            field::thin::MIN_CELLS_AROUND
        ));
    }
    bar.start("QuadCover: cut graph, local and global step");
    let p = match solved {
        Some(p) => p,
        None => {
            let qc = match prepared {
                Some(qc) => qc,
                None => param::QuadCover::new(&mesh, n, &field.matchings, opts)?,
            };
            qc.solve(&mesh, &field.frames)?
        }
    };
    timings.cut = p.timings.cut_ms;
    timings.local = p.timings.local_ms;
    timings.global = p.timings.global_ms;
    timings.repair = p.timings.repair_ms;
    bar.line(format!("  {:<10} {:9.1} ms", "cut", timings.cut));
    bar.line(format!("  {:<10} {:9.1} ms", "local", timings.local));
    bar.line(format!("  {:<10} {:9.1} ms", "global", timings.global));
    bar.line(format!(
        "  {:<10} {:9.1} ms ({} folded faces before)",
        "repair", timings.repair, p.flipped_faces_before_repair
    ));

    // Back to the file's vertex and face order.
    bar.start("write");
    let t = Instant::now();
    let mut mesh_face_of_tri = vec![usize::MAX; soup.triangles.len()];
    for (f, &t) in repair.original_face.iter().enumerate() {
        mesh_face_of_tri[t as usize] = f;
    }
    let key = |tri: [u32; 3]| {
        let mut k = tri;
        k.sort_unstable();
        k
    };
    let by_vertices: HashMap<[u32; 3], usize> = (0..mesh.n_faces())
        .map(|f| {
            (
                key(mesh.faces()[f].map(|v| repair.original_vertex[v as usize])),
                f,
            )
        })
        .collect();
    let mut corner_uvs = Vec::with_capacity(3 * soup.triangles.len());
    let mut face_of_tri = Vec::with_capacity(soup.triangles.len());
    for (t, tri) in soup.triangles.iter().enumerate() {
        let f = match mesh_face_of_tri[t] {
            usize::MAX => *by_vertices
                .get(&key(*tri))
                .ok_or_else(|| format!("triangle {t} was dropped and has no duplicate"))?,
            f => f,
        };
        face_of_tri.push(f);
        let mv = mesh.face(f).map(|v| repair.original_vertex[v]);
        for &sv in tri {
            let k = mv
                .iter()
                .position(|&x| x == sv)
                .ok_or("face corner mapping failed")?;
            corner_uvs.push(p.uv[3 * f + k]);
        }
    }
    // Star faces of poles as their bilinear quads (the pole vertex twice).
    let (polygons, corner_uvs) = crate::export::uv_polygons(
        &soup.triangles,
        &corner_uvs,
        &p.poles,
        |t| face_of_tri[t],
        |v| repair.original_vertex[v as usize],
    );
    io::write::write_obj(
        &args.out,
        &io::write::ObjOutput::new(&soup.positions, &polygons).with_uvs(&corner_uvs),
    )?;
    bar.done("write", t);
    let remesh = match &args.remesh {
        Some(path) => {
            bar.start("remesh");
            let t = Instant::now();
            let opts = ExtractOptions {
                constrained_edges: curve_edges.clone(),
                relax: (!args.no_relax).then(Default::default),
                poles: p.poles.clone(),
                ..Default::default()
            };
            let (mut remesh, mut quality) = remesh_report(&mesh, &p.uv, n as u8, &opts)?;
            if args.dual && n == 6 {
                remesh = dual(&remesh);
                quality = extract::quality(&remesh, &mesh);
            }
            let out = io::write::ObjOutput::new(&remesh.positions, &remesh.faces)
                .with_polylines(&remesh.polylines);
            io::write::write_obj(path, &out)?;
            timings.remesh = bar.done("remesh", t);
            if remesh.polylines.is_empty() {
                bar.line(format!(
                    "  remesh: {} vertices, {} faces, {} irregular vertices, {} patched places",
                    quality.vertices,
                    quality.faces,
                    quality.irregular_vertices,
                    quality.patched_places
                ));
                let (chi, want) = (remesh.euler_characteristic(), mesh.euler_characteristic());
                if quality.non_manifold_edges > 0
                    || quality.non_manifold_vertices > 0
                    || chi != want
                {
                    bar.line(format!(
                        "  warning: the remesh is not a manifold copy of the input ({} non-manifold \
                         edges, {} non-manifold vertices, Euler characteristic {chi} instead of \
                         {want}): {}; raise the density (--target-vertices, --scale){}",
                        quality.non_manifold_edges,
                        quality.non_manifold_vertices,
                        if quality.patched_places > 0 {
                            "parts of the surface are too thin for the grid to go around, or \
                             extraction patched holes where the map folds or is mis-wound"
                        } else {
                            "parts of the surface are too thin for the grid to go around"
                        },
                        if settings.refine_thin_parts {
                            ""
                        } else {
                            " or drop --no-thin-refinement"
                        }
                    ));
                }
            }
            Some(quality)
        }
        None => None,
    };
    timings.total = total.elapsed().as_secs_f64() * 1e3;
    let topo = mesh.topology();
    bar.line(format!(
        "  {} singularities ({} poles), {} cut paths, {} flipped faces, {} mis-wound vertices, seam error {:.1e}, conformal distortion {:.3} (p99 {:.3})",
        p.singularities.len(),
        p.poles.len(),
        p.cut_paths.len(),
        p.flipped_faces,
        p.miswound.len(),
        p.seam_max_error,
        p.conformal_distortion.mean,
        p.conformal_distortion.p99
    ));
    if let Some(c) = &p.crowded_refinement {
        bar.line(format!(
            "  finer try kept: grid up to {:.1}× finer around {} crowded singularities ({} faces)",
            c.max_multiplier, c.singularities, c.faces
        ));
    }
    if settings.param_options().pure_quad && p.lattice == param::Lattice::Z2 {
        let why = if p.collapsed_strips > 0 {
            format!(
                "on 2Z² {} corners fell on the lines of parallel creases under two grid cells \
                 from them and the strips between folded",
                p.collapsed_strips
            )
        } else {
            "on 2Z² the map kept folds under the curves (creases closer than two grid cells, \
             corners a cell apart)"
                .to_string()
        };
        bar.line(format!(
            "  rounded on Z² (as --no-pure-quad): {why}; singularities between grid points give \
             the remesh more irregular vertices"
        ));
    }
    if p.flipped_faces > 0 && !settings.no_untangle {
        bar.line(format!(
            "  warning: {}",
            folds_left_warning(p.flipped_faces, &curves_at_folds)
        ));
    }
    let fans = crate::mesh::isotropic::fan_centres(&mesh);
    let at_fans: Vec<usize> = p
        .poles
        .iter()
        .map(|q| q.vertex)
        .filter(|v| fans.binary_search(v).is_ok())
        .collect();
    if !at_fans.is_empty() {
        bar.line(format!(
            "  warning: {} of the {} poles sit at the centre of a fan of {} or more triangles \
             (vertices {}; flat fans as CAD tessellators and UV spheres make), where the field \
             cannot split them into {} singularities of +1/{n}: `--prepare` remeshes such fans",
            at_fans.len(),
            p.poles.len(),
            crate::mesh::isotropic::FAN_VALENCE,
            at_fans
                .iter()
                .map(|&v| repair.original_vertex[v].to_string())
                .collect::<Vec<_>>()
                .join(", "),
            n
        ));
    }
    if let Some(path) = &args.report {
        let report = Report {
            prepared_input,
            vertices: soup.positions.len(),
            faces: soup.triangles.len(),
            genus: topo.genus,
            boundary_loops: topo.boundary_loops,
            symmetry: n,
            singularities: p
                .singularities
                .iter()
                .map(|s| SingularityOut {
                    vertex: repair.original_vertex[s.vertex] as usize,
                    index: s.index,
                })
                .collect(),
            cut_paths: p.cut_paths.len(),
            lattice: p.lattice,
            flipped_faces: p.flipped_faces,
            flipped_faces_before_repair: p.flipped_faces_before_repair,
            repair_ms: p.timings.repair_ms,
            rerounded_gaps: p.rerounded_gaps.clone(),
            collapsed_strips: p.collapsed_strips,
            crowded_refinement: p.crowded_refinement.clone(),
            miswound_vertices: p
                .miswound
                .iter()
                .map(|&v| repair.original_vertex[v] as usize)
                .collect(),
            curves_beside_folds: curves_at_folds.clone(),
            curl: p.curl,
            seam_max_error: p.seam_max_error,
            curves: p
                .curves
                .iter()
                .map(|c| param::CurveFit {
                    singular_vertices: c
                        .singular_vertices
                        .iter()
                        .map(|&v| repair.original_vertex[v] as usize)
                        .collect(),
                    ear_tips: c
                        .ear_tips
                        .iter()
                        .map(|&v| repair.original_vertex[v] as usize)
                        .collect(),
                    ..c.clone()
                })
                .collect(),
            conformal_distortion: DistortionOut {
                mean: p.conformal_distortion.mean,
                p99: p.conformal_distortion.p99,
            },
            area_distortion: p.area_distortion,
            timings_ms: timings,
            edits_applied,
            skipped_edits,
            poles: p
                .poles
                .iter()
                .map(|x| PoleOut {
                    vertex: repair.original_vertex[x.vertex] as usize,
                    index: x.index,
                    faces: x
                        .faces
                        .iter()
                        .map(|&f| repair.original_face[f] as usize)
                        .collect(),
                })
                .collect(),
            untreated_poles: p
                .untreated_poles
                .iter()
                .map(|&v| repair.original_vertex[v] as usize)
                .collect(),
            thin_parts: ThinOut {
                faces: thin.faces,
                max_multiplier: thin.max_multiplier,
            },
            remesh: remesh.clone(),
        };
        let json = serde_json::to_string_pretty(&report)?;
        io::write::write_atomic(path, |w| w.write_all(json.as_bytes()))?;
    }
    Ok(())
}

/// The warning for faces the injectivity repair left folded, naming the constraint curves
/// beside them (`curves`, ids; empty without curves or none near).
fn folds_left_warning(folded: usize, curves: &[u32]) -> String {
    let faces = if folded == 1 {
        "1 face stays".to_string()
    } else {
        format!("{folded} faces stay")
    };
    if curves.is_empty() {
        return format!(
            "{faces} folded after the injectivity repair (the remesh patches them); a finer grid \
             (--target-vertices, --scale) may unfold them"
        );
    }
    format!(
        "{faces} folded after the injectivity repair, beside {} (the remesh patches them; \
         usually a singularity on or next to a curve, whose line has too little room there). A \
         finer grid (--target-vertices, --scale), fewer feature curves (a larger --features \
         angle) or those curves made combinatorial may help",
        crate::constraint::curves_named(curves)
    )
}
