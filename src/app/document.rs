//! The document: the one state type through which the editor talks to the core.
//!
//! It owns the mesh with its load report, the solve settings, the edit list with its undo
//! cursor (the history *is* the edit list: `edits[..cursor]` are applied, the rest is the redo
//! tail), the core's [`Base`] and cached [`EditState`]s per position (a cache: replay is the
//! truth), the solved field and parameterization shown (in display-ready form), overlay lines
//! and the display settings. Every change of geometry-related data bumps
//! [`Document::revision`] and rebuilds the shared [`SceneData`], which the viewport uploads once
//! per revision; every change of what should be solved (edit, undo, redo, settings, load) bumps
//! [`Document::edit_revision`], and a [`SolveRequest`] tagged with it carries the work to a
//! background job ([`SolveRequest::run`]); outcomes for an older revision are dropped.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;

use super::scene::{FacePatches, LineSegment, SceneData, singularity_color};
use super::settings::DisplaySettings;
use crate::edit::project::{relative_mesh_path, sha256_hex};
use crate::edit::{
    Base, Curve, Edit, EditError, EditState, MeshRef, Project, Settings, Skipped, Solved,
};
use crate::mesh::{Topology, TriMesh};

/// The default mesh: Spot by Keenan Crane (CC0).
pub const DEFAULT_MESH_NAME: &str = "spot.obj";
pub const DEFAULT_MESH_OBJ: &[u8] = include_bytes!("../../assets/spot.obj");

/// A singular vertex of an N-symmetric field with index `index / N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Singularity {
    pub vertex: usize,
    /// Numerator k of the index k/N.
    pub index: i32,
}

/// A field in display form (see [`FieldDisplay::from_frame_field`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FieldDisplay {
    /// N (2, 4 or 6).
    pub symmetry: u32,
    /// One tangent direction per face (any representative of the N directions).
    pub face_dirs: Vec<DVec3>,
    pub singularities: Vec<Singularity>,
}

impl FieldDisplay {
    /// Display form of a core frame field: U of each face, singularities `(vertex, k)` with
    /// index k/N.
    pub fn from_frame_field(
        field: &crate::field::FrameField,
        singularities: impl IntoIterator<Item = (usize, i32)>,
    ) -> FieldDisplay {
        FieldDisplay {
            symmetry: field.symmetry.n(),
            face_dirs: field.frames.iter().map(|f| f[0]).collect(),
            singularities: singularities
                .into_iter()
                .map(|(vertex, index)| Singularity { vertex, index })
                .collect(),
        }
    }
}

/// A parameterization result: per-corner UVs indexed `3*f + k`, and the triangles drawing the
/// faces where the map is not linear (the poles' bilinear stars; empty for most maps).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParamDisplay {
    pub corner_uvs: Vec<[f64; 2]>,
    pub patches: FacePatches,
}

impl ParamDisplay {
    /// The display of a QuadCover result on `mesh`: its UVs, its pole stars tessellated.
    pub fn from_parameterization(mesh: &TriMesh, p: &crate::param::Parameterization) -> Self {
        ParamDisplay {
            corner_uvs: p.uv.clone(),
            patches: FacePatches::from_poles(mesh, &p.poles),
        }
    }
}

/// Whether the injectivity repair ran on the map shown.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FoldRepair {
    /// It ran (a no-op without folds): `before` folded faces before it, `ms` its time.
    Ran { before: usize, ms: f64 },
    /// It was off (`Settings::no_untangle`): the folds are the global step's.
    Off,
    /// Not a QuadCover result (synthetic UVs).
    None,
    /// The global step's map, shown while its repair runs (`Document::show_preview`).
    Pending,
}

/// The folded faces of the map shown ([`crate::param::folded_faces`] of its UVs; a pole's
/// star faces by their bilinear quads), found once per result (the overlay and the panel's
/// count read them).
#[derive(Clone, Debug, PartialEq)]
pub struct Folds {
    /// Faces whose texture triangle has non-positive signed area (for a pole's star faces:
    /// whose quad folds, [`crate::param::Pole::quad_folded`]).
    pub faces: Vec<usize>,
    /// Vertices where the map is not locally injective although no face is folded: their fan
    /// turns by another multiple of 2π than their cone angle (`Parameterization::miswound`).
    pub miswound: Vec<usize>,
    pub repair: FoldRepair,
    /// Constraint curves (ids) beside the folded faces ([`crate::constraint::curves_beside`]).
    pub beside_curves: Vec<u32>,
}

impl Folds {
    pub fn new(uv: &[[f64; 2]], repair: FoldRepair) -> Folds {
        Folds {
            faces: crate::param::folded_faces(uv),
            miswound: Vec::new(),
            repair,
            beside_curves: Vec::new(),
        }
    }

    /// Like [`Folds::new`] for a map with poles: a star face is shown as the bilinear quad
    /// its triangle's UVs do not describe, so it is folded when its quad is (as the core counts
    /// `Parameterization::flipped_faces`).
    pub fn with_poles(uv: &[[f64; 2]], poles: &[crate::param::Pole], repair: FoldRepair) -> Folds {
        let mut folds = Folds::new(uv, repair);
        if poles.is_empty() {
            return folds;
        }
        let star: std::collections::HashSet<usize> =
            poles.iter().flat_map(|p| p.faces.iter().copied()).collect();
        folds.faces.retain(|f| !star.contains(f));
        for p in poles {
            let quads = (0..p.faces.len()).filter(|&j| p.quad_folded(j));
            folds.faces.extend(quads.map(|j| p.faces[j]));
        }
        folds.faces.sort_unstable();
        folds.faces.dedup();
        folds
    }

    /// The panel's line: "N folded faces (M before repair)", "No folded faces", …, and the
    /// mis-wound vertices when there are any.
    pub fn summary(&self) -> String {
        let n = self.faces.len();
        let count = match n {
            0 => "No folded faces".to_string(),
            1 => "1 folded face".to_string(),
            n => format!("{n} folded faces"),
        };
        let line = match self.repair {
            FoldRepair::Ran { before: 0, .. } | FoldRepair::None => count,
            FoldRepair::Ran { before, .. } => format!("{count} ({before} before repair)"),
            FoldRepair::Off => format!("{count} (untangling off)"),
            FoldRepair::Pending => format!("{count} (before the repair, which is running)"),
        };
        let line = match self.beside_curves.as_slice() {
            [] => line,
            cs => format!("{line}, beside {}", crate::constraint::curves_named(cs)),
        };
        match self.miswound.len() {
            0 => line,
            1 => format!("{line}; 1 mis-wound vertex"),
            m => format!("{line}; {m} mis-wound vertices"),
        }
    }

    /// The faces the overlay marks: the folded ones and those around mis-wound vertices.
    pub fn shown_faces(&self, mesh: &crate::mesh::TriMesh) -> Vec<usize> {
        let mut out = self.faces.clone();
        for &v in self.miswound.iter().filter(|&&v| v < mesh.n_vertices()) {
            out.extend(mesh.outgoing(v).map(|h| mesh.face_of(h)));
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// Kinds of overlay polylines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    CutGraph,
    Constraint,
    Selection,
}

impl LineKind {
    /// Linear RGBA.
    pub fn color(self) -> [f32; 4] {
        match self {
            LineKind::CutGraph => [0.9, 0.1, 0.05, 1.0],
            LineKind::Constraint => [0.05, 0.75, 0.2, 1.0],
            LineKind::Selection => [1.0, 0.55, 0.0, 1.0],
        }
    }
}

/// Mesh statistics shown in the side panel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshStats {
    pub vertices: usize,
    pub edges: usize,
    pub faces: usize,
    pub components: usize,
    pub genus: i64,
    pub boundary_loops: usize,
    pub euler_characteristic: i64,
}

impl From<&Topology> for MeshStats {
    fn from(t: &Topology) -> Self {
        MeshStats {
            vertices: t.vertices,
            edges: t.edges,
            faces: t.faces,
            components: t.components.len(),
            genus: t.genus,
            boundary_loops: t.boundary_loops,
            euler_characteristic: t.euler_characteristic,
        }
    }
}

/// A freshly loaded mesh (produced by a background job).
pub struct LoadedDocument {
    pub path: Option<PathBuf>,
    pub name: String,
    pub mesh: Arc<TriMesh>,
    /// `RepairReport::original_vertex`: each mesh vertex's index in the file.
    pub to_file: Vec<u32>,
    /// The file's vertex count (edits name file vertices).
    pub file_vertices: usize,
    /// SHA-256 of the file's bytes (a project records it).
    pub sha256: String,
    pub warnings: Vec<String>,
    pub stats: MeshStats,
    pub scene: SceneData,
}

/// Reads, validates and prepares a mesh for display. Runs off the UI thread.
pub fn load_bytes(name: &str, bytes: &[u8]) -> Result<LoadedDocument, String> {
    let format = crate::io::Format::from_path(Path::new(name)).unwrap_or(crate::io::Format::Obj);
    let soup = crate::io::read_mesh_bytes(bytes, format).map_err(|e| format!("{name}: {e}"))?;
    finish_load(None, name.to_string(), soup, sha256_hex(bytes))
}

/// Like [`load_bytes`], from a file.
pub fn load_path(path: &Path) -> Result<LoadedDocument, String> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string());
    let soup = crate::io::read_mesh(path).map_err(|e| match e {
        crate::io::ReadError::Io { .. } => e.to_string(),
        _ => format!("{name}: {e}"),
    })?;
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    finish_load(Some(path.to_path_buf()), name, soup, sha256_hex(&bytes))
}

fn finish_load(
    path: Option<PathBuf>,
    name: String,
    soup: crate::mesh::PolygonSoup,
    sha256: String,
) -> Result<LoadedDocument, String> {
    let (mesh, mut report) = TriMesh::from_soup(&soup).map_err(|e| format!("{name}: {e}"))?;
    let needles = crate::mesh::isotropic::needle_area_share(&mesh);
    if needles > crate::mesh::isotropic::NEEDLE_AREA_SHARE {
        report.warnings.push(format!(
            "{:.0} % of the area is in needle triangles (a corner under {}°): a raw tessellation \
             the field cannot follow (the map will fold); File > Remesh input makes an isotropic \
             copy with the sharp features kept",
            100.0 * needles,
            crate::mesh::isotropic::NEEDLE_DEG
        ));
    }
    // (At the default density: the document's settings come later.)
    let settings = crate::edit::Settings::default().field_params();
    if let Some(grid) =
        crate::mesh::isotropic::too_coarse(&mesh, &settings.density, settings.symmetry)
    {
        report.warnings.push(format!(
            "{} vertices, far fewer than the grid's {:.0}: a low-poly mesh whose faces are too \
             large for the map to bend or hold singularities inside (it will fold); File > \
             Remesh input makes an isotropic copy with the sharp features kept",
            mesh.n_vertices(),
            grid
        ));
    }
    if let Some(share) =
        crate::mesh::isotropic::long_needles(&mesh, &settings.density, settings.symmetry)
        && needles <= crate::mesh::isotropic::NEEDLE_AREA_SHARE
    {
        report.warnings.push(format!(
            "{:.0} % of the area is in needle triangles longer than {} grid cells (fans across \
             flat faces): the map cannot bend or hold a singularity inside them (it will fold \
             there); File > Remesh input makes an isotropic copy with the sharp features kept",
            100.0 * share,
            crate::mesh::isotropic::LONG_NEEDLE_CELLS
        ));
    }
    let fans = crate::mesh::isotropic::fan_centres(&mesh).len();
    if fans > 0 {
        report.warnings.push(format!(
            "{fans} vertices are centres of flat fans of {} or more triangles (as CAD \
             tessellators and UV spheres make): a pole the field puts there cannot split into \
             singularities of index 1/N; File > Remesh input makes an isotropic copy",
            crate::mesh::isotropic::FAN_VALENCE
        ));
    }
    let stats = MeshStats::from(&mesh.topology());
    let scene = SceneData::from_trimesh(&mesh);
    Ok(LoadedDocument {
        path,
        name,
        mesh: Arc::new(mesh),
        to_file: report.original_vertex,
        file_vertices: soup.positions.len(),
        sha256,
        warnings: report.warnings,
        stats,
        scene,
    })
}

/// A project file read together with its mesh (produced by a background job): the mesh's hash
/// and the edits' vertices are checked against the file before anything is replaced.
pub struct LoadedProject {
    pub path: PathBuf,
    pub project: Project,
    pub mesh: LoadedDocument,
}

/// Reads a project and its mesh. Errors name the file (and the edit, for edits).
pub fn load_project(path: &Path) -> Result<LoadedProject, String> {
    let project = Project::load(path).map_err(|e| e.to_string())?;
    let mesh_path = project.mesh_path(path);
    let bytes = std::fs::read(&mesh_path).map_err(|e| {
        format!(
            "{}: cannot read its mesh {}: {e}",
            path.display(),
            mesh_path.display()
        )
    })?;
    project
        .check_mesh(path, &bytes)
        .map_err(|e| e.to_string())?;
    let mesh = load_path(&mesh_path)?;
    project
        .check_vertices(path, mesh.file_vertices)
        .map_err(|e| e.to_string())?;
    Ok(LoadedProject {
        path: path.to_path_buf(),
        project,
        mesh,
    })
}

/// The work of one background solve, tagged with the document's edit revision.
pub struct SolveRequest {
    pub revision: u64,
    pub generation: u64,
    /// Build a new [`Base`] first (the mesh or the settings changed); then every applied edit
    /// is replayed from the initial state.
    pub rebuild: Option<Rebuild>,
    /// The base to use when not rebuilding.
    pub base: Option<Arc<Base>>,
    /// Position and state of the newest cached state at or before the cursor (ignored when
    /// rebuilding).
    pub start: usize,
    pub start_state: Option<EditState>,
    /// The edits to apply after `start` (or all applied edits when rebuilding).
    pub edits: Vec<Edit>,
}

/// What a [`Base`] is built from.
pub struct Rebuild {
    /// The base for the same mesh with the settings before, whose field a change that does not
    /// touch it (merge rules, pure quad, rounding) reuses.
    pub previous: Option<Arc<Base>>,
    pub mesh: Arc<TriMesh>,
    pub to_file: Vec<u32>,
    pub file_vertices: usize,
    pub settings: Settings,
}

/// The result of a [`SolveRequest`].
pub struct SolveOutcome {
    pub revision: u64,
    /// The newly built base (when the request rebuilt it).
    pub base: Option<Arc<Base>>,
    /// Position of `states[0]`.
    pub first: usize,
    /// The states at positions `first..=cursor`.
    pub states: Vec<EditState>,
    /// Edits skipped on the way (positions 1-based in the whole list).
    pub skipped: Vec<Skipped>,
    /// The solve of the last state, or why it failed.
    pub solved: Result<Solved, String>,
    /// When the solve failed because the constraint curves contradict: their ids.
    pub contradiction: Vec<u32>,
}

fn edit_error(e: EditError) -> String {
    match e {
        EditError::Cancelled => "cancelled (a newer edit replaced it)".into(),
        e => e.to_string(),
    }
}

impl SolveRequest {
    /// Runs the request (in a background job): base, edits, solve. `stage` reports progress;
    /// `preview` gets the global step's map when the injectivity repair is about to change it.
    pub fn run(
        self,
        cancel: crate::edit::Cancel,
        stage: &dyn Fn(&str),
        preview: crate::param::PreviewSink<'_>,
    ) -> Result<SolveOutcome, String> {
        let (base, new_base, first, start_state) = match self.rebuild {
            Some(r) => {
                let reused = match &r.previous {
                    Some(previous) => previous
                        .with_settings(r.settings.clone())
                        .map_err(edit_error)?,
                    None => None,
                };
                let base = match reused {
                    Some(base) => base,
                    None => {
                        stage("field and QuadCover analyses");
                        Base::new(r.mesh, r.to_file, r.file_vertices, r.settings, cancel)
                            .map_err(edit_error)?
                    }
                };
                let base = Arc::new(base);
                let initial = base.initial().clone();
                (base.clone(), Some(base), 0, initial)
            }
            None => {
                let base = self.base.ok_or("no field to edit yet")?;
                let state = self.start_state.ok_or("no state to start from")?;
                (base, None, self.start, state)
            }
        };
        if !self.edits.is_empty() {
            stage(&format!("applying {} edit(s)", self.edits.len()));
        }
        let replay = base
            .replay_from(start_state, first, &self.edits, cancel)
            .map_err(edit_error)?;
        let (states, skipped) = (replay.states, replay.skipped);
        stage("field re-solve and QuadCover");
        let solved = base.solve_previewing(states.last().expect("a state"), cancel, preview);
        let contradiction = match &solved {
            Err(EditError::Contradiction { curves, .. }) => curves.clone(),
            _ => Vec::new(),
        };
        let solved = solved.map_err(edit_error);
        if cancel() {
            return Err(edit_error(EditError::Cancelled));
        }
        Ok(SolveOutcome {
            revision: self.revision,
            base: new_base,
            first,
            states,
            skipped,
            solved,
            contradiction,
        })
    }
}

/// What the last solve produced, besides the field and the map.
#[derive(Clone, Debug)]
pub struct SolveInfo {
    /// The edit revision it was solved for.
    pub revision: u64,
    pub e_smooth: f64,
    pub e_align: f64,
    pub curl: f64,
    pub timings: Vec<(String, f64)>,
}

/// A hash of a parameterization's symmetry and UVs (bit for bit): the key of its remesh.
fn param_key(p: &crate::param::Parameterization) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::hash::DefaultHasher::new();
    p.symmetry.hash(&mut h);
    for uv in &p.uv {
        uv[0].to_bits().hash(&mut h);
        uv[1].to_bits().hash(&mut h);
    }
    h.finish()
}

/// The panel's one-line summary of a field.
fn field_summary(display: &FieldDisplay, e_smooth: f64) -> String {
    format!(
        "N = {}, {} singularities, E_smooth {e_smooth:.3e}",
        display.symmetry,
        display.singularities.len()
    )
}

/// The editor's document.
pub struct Document {
    pub path: Option<PathBuf>,
    pub name: String,
    pub mesh: Option<Arc<TriMesh>>,
    /// Each mesh vertex's index in the file (`RepairReport::original_vertex`).
    pub to_file: Vec<u32>,
    /// The mesh file's vertex count.
    pub file_vertices: usize,
    /// SHA-256 of the mesh file's bytes.
    pub mesh_sha256: Option<String>,
    pub stats: Option<MeshStats>,
    /// Validation / repair warnings of the load.
    pub warnings: Vec<String>,
    pub field: Option<FieldDisplay>,
    pub param: Option<ParamDisplay>,
    /// The folded faces of `param` (`None` without one); a new `Arc` per result.
    pub folds: Option<Arc<Folds>>,
    /// The display a solve's preview replaced ([`Document::show_preview`]), put back when that
    /// solve fails: the last good result stays on screen.
    preview_backup: Option<(Option<ParamDisplay>, Option<Arc<Folds>>)>,
    /// The core field the display form came from (input of the parameterization).
    pub frame_field: Option<crate::field::FrameField>,
    /// The core parameterization result.
    pub parameterization: Option<crate::param::Parameterization>,
    /// The remesh of `parameterization` last extracted ([`super::remesh`]): kept while a newer
    /// one is extracted, and when that fails (`remesh_error` says why).
    pub remesh: Option<Arc<super::remesh::RemeshView>>,
    /// Why the last extraction failed (`None` after a good one).
    pub remesh_error: Option<String>,
    /// The parameterization revision whose extraction has concluded (or whose remesh was
    /// remembered): while it is not the current one, an extraction is due.
    remesh_for: Option<u64>,
    /// The last few remeshes by their map's key ([`param_key`]): undo and redo back to a
    /// remembered solve show its remesh at once too.
    remesh_cache: Vec<(u64, Arc<super::remesh::RemeshView>)>,
    /// The key of `parameterization`.
    param_key: u64,
    /// QuadCover's symbolic analyses for this mesh (they depend on the mesh only): every
    /// re-solve after the first, whatever the field or symmetry, does numeric work only.
    pub param_analysis: Option<Arc<crate::param::ParamAnalysis>>,
    /// One-line summaries of the field / parameterization results.
    pub field_summary: String,
    pub param_summary: String,
    pub lines: Vec<(LineKind, Vec<[DVec3; 2]>)>,
    pub display: DisplaySettings,
    /// The solve settings (the project's).
    pub settings: Settings,
    /// The core's base for (mesh, settings); `None` until the first solve job built it. While
    /// a rebuild for new settings runs it may still be the old one ([`Document::base_current`]).
    pub edit_base: Option<Arc<Base>>,
    /// The edit list; `edits[..cursor]` are applied, the rest is the redo tail.
    pub edits: Vec<Edit>,
    cursor: usize,
    /// Cached states: `states[i]` after `edits[..i]`, a valid prefix (cleared by a rebuild).
    states: Vec<EditState>,
    /// Edits the last replay skipped (a notice in the panel).
    pub skipped: Vec<Skipped>,
    /// The state whose solve is shown, and what the solve reported.
    pub shown_state: Option<EditState>,
    pub solve_info: Option<SolveInfo>,
    /// Why the last solve failed (the last good result stays on screen).
    pub solve_error: Option<String>,
    /// The curves the last solve found contradictory (drawn red); empty after a good solve.
    pub contradiction: Vec<u32>,
    /// The last few solves with their base and state, newest last: undo and redo back to one
    /// of them show it at once instead of solving again (a solve is a pure function of the
    /// base and the state, so this is the same result).
    solve_cache: Vec<(Arc<Base>, EditState, Solved)>,
    /// The project file this document was opened from or saved to.
    pub project_path: Option<PathBuf>,
    /// (applied edits, settings) at the last save or open: unsaved changes are a difference.
    saved: (Vec<Edit>, Settings),
    edit_revision: u64,
    /// Increases whenever `parameterization` is replaced or cleared.
    param_revision: u64,
    scene: Option<Arc<SceneData>>,
    generation: u64,
    /// Base scene without field/param/overlays (rebuilt from the mesh once per load).
    base_scene: Option<SceneData>,
    revision: u64,
}

impl Default for Document {
    fn default() -> Self {
        Document {
            path: None,
            name: String::new(),
            mesh: None,
            to_file: Vec::new(),
            file_vertices: 0,
            mesh_sha256: None,
            stats: None,
            warnings: Vec::new(),
            field: None,
            param: None,
            folds: None,
            preview_backup: None,
            frame_field: None,
            parameterization: None,
            remesh: None,
            remesh_error: None,
            remesh_for: None,
            remesh_cache: Vec::new(),
            param_key: 0,
            param_analysis: None,
            field_summary: String::new(),
            param_summary: String::new(),
            lines: Vec::new(),
            display: DisplaySettings::default(),
            settings: Settings::default(),
            edit_base: None,
            edits: Vec::new(),
            cursor: 0,
            states: Vec::new(),
            skipped: Vec::new(),
            shown_state: None,
            solve_info: None,
            solve_error: None,
            contradiction: Vec::new(),
            solve_cache: Vec::new(),
            project_path: None,
            saved: (Vec::new(), Settings::default()),
            edit_revision: 1,
            param_revision: 1,
            scene: None,
            generation: 0,
            base_scene: None,
            revision: 1,
        }
    }
}

impl Document {
    /// Replaces the mesh (drops field, parameterization, overlays, edits and the project).
    pub fn set_loaded(&mut self, loaded: LoadedDocument) {
        self.generation += 1;
        self.path = loaded.path;
        self.name = loaded.name;
        self.mesh = Some(loaded.mesh);
        self.to_file = loaded.to_file;
        self.file_vertices = loaded.file_vertices;
        self.mesh_sha256 = Some(loaded.sha256);
        self.stats = Some(loaded.stats);
        self.warnings = loaded.warnings;
        self.field = None;
        self.param = None;
        self.folds = None;
        self.frame_field = None;
        self.clear_parameterization();
        self.remesh_cache.clear();
        self.param_analysis = None;
        self.field_summary.clear();
        self.param_summary.clear();
        self.lines.clear();
        self.edit_base = None;
        self.edits.clear();
        self.cursor = 0;
        self.states.clear();
        self.skipped.clear();
        self.solve_cache.clear();
        self.shown_state = None;
        self.solve_info = None;
        self.solve_error = None;
        self.contradiction.clear();
        self.project_path = None;
        self.saved = (Vec::new(), self.settings.clone());
        self.edit_revision += 1;
        self.base_scene = Some(loaded.scene);
        self.rebuild_scene();
    }

    /// Replaces the mesh by a project's: its settings and edits (all applied). The first
    /// solve job rebuilds the base and replays them.
    pub fn set_project(&mut self, loaded: LoadedProject) {
        self.settings = loaded.project.settings.clone();
        self.set_loaded(loaded.mesh);
        self.edits = loaded.project.edits;
        self.cursor = self.edits.len();
        self.project_path = Some(loaded.path);
        self.saved = (self.edits.clone(), self.settings.clone());
    }

    // ---- the edit list -------------------------------------------------------------------

    /// Increases with every change of what should be solved (edit, undo, redo, settings, load).
    pub fn edit_revision(&self) -> u64 {
        self.edit_revision
    }

    /// Number of applied edits (the undo cursor).
    pub fn cursor(&self) -> usize {
        self.cursor
    }

    pub fn applied_edits(&self) -> &[Edit] {
        &self.edits[..self.cursor]
    }

    pub fn can_undo(&self) -> bool {
        self.cursor > 0
    }

    pub fn can_redo(&self) -> bool {
        self.cursor < self.edits.len()
    }

    /// Whether the base fits the current settings.
    pub fn base_current(&self) -> bool {
        self.edit_base
            .as_ref()
            .is_some_and(|b| *b.settings() == self.settings)
    }

    /// The state after the applied edits, when it is known (cached and the base current).
    pub fn current_state(&self) -> Option<&EditState> {
        if !self.base_current() {
            return None;
        }
        self.states.get(self.cursor)
    }

    /// The constraint curves to show (mesh vertices, by id): the current state's, or while it
    /// is not known (a rebuild for new settings runs) the shown solve's.
    pub fn curves(&self) -> Option<&BTreeMap<u32, Curve>> {
        self.current_state()
            .or(self.shown_state.as_ref())
            .map(|s| &s.curves)
    }

    /// The base and the current state, when edits can be applied on the UI thread.
    pub fn editable(&self) -> Option<(&Arc<Base>, &EditState)> {
        Some((self.edit_base.as_ref()?, self.current_state()?))
    }

    /// Applies an edit: drops the redo tail, appends it, and caches its state when given (a
    /// move applied on the UI thread); otherwise the solve job applies it.
    pub fn push_edit(&mut self, edit: Edit, state: Option<EditState>) {
        self.edits.truncate(self.cursor);
        self.states.truncate(self.cursor + 1);
        self.skipped.retain(|s| s.position <= self.cursor);
        self.edits.push(edit);
        if let Some(state) = state
            && self.states.len() == self.cursor + 1
        {
            self.states.push(state);
        }
        self.cursor += 1;
        self.edit_revision += 1;
    }

    pub fn undo(&mut self) -> bool {
        if !self.can_undo() {
            return false;
        }
        self.cursor -= 1;
        self.edit_revision += 1;
        true
    }

    pub fn redo(&mut self) -> bool {
        if !self.can_redo() {
            return false;
        }
        self.cursor += 1;
        self.edit_revision += 1;
        true
    }

    /// Changes the solve settings: the base is rebuilt and the edits replayed.
    pub fn set_settings(&mut self, settings: Settings) {
        if settings == self.settings {
            return;
        }
        self.settings = settings;
        self.states.clear();
        self.edit_revision += 1;
    }

    /// Whether the applied edits or the settings differ from the last save (or open).
    pub fn is_dirty(&self) -> bool {
        self.mesh.is_some()
            && (self.saved.0.as_slice() != self.applied_edits() || self.saved.1 != self.settings)
    }

    /// Whether the shown solve is for the current edit revision.
    pub fn solve_current(&self) -> bool {
        self.solve_info
            .as_ref()
            .is_some_and(|i| i.revision == self.edit_revision)
    }

    /// The work that brings the shown result up to the current revision (`None` without mesh).
    pub fn solve_request(&self) -> Option<SolveRequest> {
        let mesh = self.mesh.clone()?;
        let mut req = SolveRequest {
            revision: self.edit_revision,
            generation: self.generation,
            rebuild: None,
            base: None,
            start: 0,
            start_state: None,
            edits: Vec::new(),
        };
        if self.base_current() && !self.states.is_empty() {
            let start = self.cursor.min(self.states.len() - 1);
            req.base = self.edit_base.clone();
            req.start = start;
            req.start_state = Some(self.states[start].clone());
            req.edits = self.edits[start..self.cursor].to_vec();
        } else {
            req.rebuild = Some(Rebuild {
                previous: self.edit_base.clone(),
                mesh,
                to_file: self.to_file.clone(),
                file_vertices: self.file_vertices,
                settings: self.settings.clone(),
            });
            req.edits = self.applied_edits().to_vec();
        }
        Some(req)
    }

    /// Takes a solve job's outcome; `false` (and nothing changes) when it is stale. On a
    /// failed solve the states are kept, the last good result stays shown, and
    /// [`Document::solve_error`] says why.
    pub fn take_outcome(&mut self, outcome: SolveOutcome) -> bool {
        if outcome.revision != self.edit_revision {
            return false;
        }
        if let Some(base) = outcome.base {
            self.edit_base = Some(base);
            self.states.clear();
            self.skipped.clear();
        }
        // The edit list is the one the request saw (same revision): cached states stay, the
        // new ones extend the valid prefix.
        for (i, state) in outcome.states.into_iter().enumerate() {
            if outcome.first + i == self.states.len() {
                self.states.push(state);
            }
        }
        self.skipped.retain(|s| s.position <= outcome.first);
        self.skipped.extend(outcome.skipped);
        match outcome.solved {
            Ok(solved) => {
                self.solve_error = None;
                self.contradiction.clear();
                let state = self.states.get(self.cursor).cloned();
                if let (Some(base), Some(state)) = (&self.edit_base, &state) {
                    self.remember_solve(base.clone(), state.clone(), &solved);
                }
                self.set_solved(solved, state);
            }
            Err(e) => {
                self.solve_error = Some(e);
                self.contradiction = outcome.contradiction;
                if let Some((param, folds)) = self.preview_backup.take() {
                    self.param = param;
                    self.folds = folds;
                    self.rebuild_scene();
                }
            }
        }
        true
    }

    /// Keeps a solve for undo and redo: the newest few, about three million faces' worth
    /// (between 2 and 8).
    fn remember_solve(&mut self, base: Arc<Base>, state: EditState, solved: &Solved) {
        let faces = self.mesh.as_ref().map_or(1, |m| m.n_faces().max(1));
        let keep = (3_000_000 / faces).clamp(2, 8);
        self.solve_cache
            .retain(|(b, s, _)| !(Arc::ptr_eq(b, &base) && *s == state));
        self.solve_cache.push((base, state, solved.clone()));
        let excess = self.solve_cache.len().saturating_sub(keep);
        self.solve_cache.drain(..excess);
    }

    /// Shows the remembered solve of the current base and state, if there is one (after undo or
    /// redo); `true` when it did, and the shown result is then current.
    pub fn show_remembered_solve(&mut self) -> bool {
        if !self.base_current() {
            return false;
        }
        let (Some(base), Some(state)) = (&self.edit_base, self.states.get(self.cursor)) else {
            return false;
        };
        let Some((_, state, solved)) = self
            .solve_cache
            .iter()
            .find(|(b, s, _)| Arc::ptr_eq(b, base) && s == state)
            .cloned()
        else {
            return false;
        };
        self.solve_error = None;
        self.contradiction.clear();
        self.set_solved(solved, Some(state));
        true
    }

    /// Shows a solved state: field, parameterization, cut graph, glyphs (one scene rebuild).
    fn set_solved(&mut self, solved: Solved, state: Option<EditState>) {
        let singularities: Vec<(usize, i32)> = match &state {
            Some(s) => s.singularities.iter().map(|(&v, &k)| (v, k)).collect(),
            None => solved
                .indices
                .singularities
                .iter()
                .map(|s| (s.vertex, s.k))
                .collect(),
        };
        let display = FieldDisplay::from_frame_field(&solved.field, singularities);
        self.field_summary = field_summary(&display, solved.e_smooth);
        let p = solved.param;
        self.solve_info = Some(SolveInfo {
            revision: self.edit_revision,
            e_smooth: solved.e_smooth,
            e_align: solved.e_align,
            curl: p.curl,
            timings: solved.timings,
        });
        self.param_analysis = self.edit_base.as_ref().map(|b| b.analysis().clone());
        let untangle = self
            .edit_base
            .as_ref()
            .is_none_or(|b| !b.settings().no_untangle);
        self.frame_field = Some(solved.field);
        self.field = Some(display);
        self.shown_state = state;
        self.set_parameterization(p, untangle);
    }

    /// The project for saving to `project_path`: the mesh relative to it, its hash, the
    /// settings and the applied edits. The embedded default mesh has no file: it is written
    /// beside the project first (unless a file of that name is there already).
    pub fn project_for(&self, project_path: &Path) -> Result<Project, String> {
        let mesh_file = match &self.path {
            Some(p) => p.clone(),
            None if self.name == DEFAULT_MESH_NAME => {
                let p = project_path
                    .parent()
                    .unwrap_or(Path::new(""))
                    .join(DEFAULT_MESH_NAME);
                match std::fs::read(&p) {
                    Ok(bytes) if bytes == DEFAULT_MESH_OBJ => {}
                    Ok(_) => {
                        return Err(format!(
                            "{} is another mesh than the default one: save the project elsewhere",
                            p.display()
                        ));
                    }
                    Err(_) => crate::io::write_atomic(&p, |w| {
                        std::io::Write::write_all(w, DEFAULT_MESH_OBJ)
                    })
                    .map_err(|e| format!("{}: {e}", p.display()))?,
                }
                p
            }
            None => return Err("the mesh has no file to refer to".into()),
        };
        let sha256 = match (&self.path, &self.mesh_sha256) {
            (Some(_), Some(h)) => h.clone(),
            _ => sha256_hex(
                &std::fs::read(&mesh_file).map_err(|e| format!("{}: {e}", mesh_file.display()))?,
            ),
        };
        let mut project = Project::new(
            MeshRef {
                path: relative_mesh_path(project_path, &mesh_file),
                sha256: Some(sha256),
            },
            self.settings.clone(),
        );
        project.edits = self.applied_edits().to_vec();
        Ok(project)
    }

    /// Saves the project (atomically) and remembers the path; the document is then clean.
    pub fn save_project(&mut self, project_path: &Path) -> Result<(), String> {
        let project = self.project_for(project_path)?;
        project.save(project_path).map_err(|e| e.to_string())?;
        self.project_path = Some(project_path.to_path_buf());
        self.saved = (project.edits, project.settings);
        Ok(())
    }

    /// Singularities of the current state as (file vertex, k), by file vertex.
    pub fn file_singularities(&self) -> Option<Vec<(usize, i32)>> {
        let (base, state) = self.editable()?;
        let mut v: Vec<(usize, i32)> = state
            .singularities
            .iter()
            .map(|(&m, &k)| (base.file_vertex(m), k))
            .collect();
        v.sort_unstable();
        Some(v)
    }

    // ---- display -------------------------------------------------------------------------

    /// Sets (or clears) the field; the viewport picks it up next frame.
    pub fn set_field(&mut self, field: Option<FieldDisplay>) {
        self.field = field;
        self.rebuild_scene();
    }

    /// Takes a computed core field: drops the old parameterization and cut graph.
    pub fn set_frame_field(&mut self, result: crate::field::FieldResult) {
        let sing = result.indices.singularities.iter().map(|s| (s.vertex, s.k));
        let display = FieldDisplay::from_frame_field(&result.field, sing);
        self.field_summary = field_summary(&display, result.e_smooth);
        self.frame_field = Some(result.field);
        self.clear_parameterization();
        self.param = None;
        self.folds = None;
        self.param_summary.clear();
        self.lines.retain(|(k, _)| *k != LineKind::CutGraph);
        self.set_field(Some(display));
    }

    /// Takes a computed parameterization: UVs, cut graph overlay, folded faces, summary.
    /// `untangle`: whether it was solved with the injectivity repair on.
    pub fn set_parameterization(&mut self, p: crate::param::Parameterization, untangle: bool) {
        self.preview_backup = None;
        let mut segs = Vec::new();
        if let Some(mesh) = &self.mesh {
            for path in &p.cut_paths {
                for w in path.windows(2) {
                    if w[0] < mesh.n_vertices() && w[1] < mesh.n_vertices() {
                        segs.push([mesh.position(w[0]), mesh.position(w[1])]);
                    }
                }
            }
        }
        let repair = if untangle {
            FoldRepair::Ran {
                before: p.flipped_faces_before_repair,
                ms: p.timings.repair_ms,
            }
        } else {
            FoldRepair::Off
        };
        let repair_note = match repair {
            FoldRepair::Ran { before, ms } if before > 0 => {
                format!(" ({before} before repair, repair {ms:.0} ms)")
            }
            FoldRepair::Off => " (untangling off)".to_string(),
            _ => String::new(),
        };
        let mut crowded_note = match &p.crowded_refinement {
            Some(c) => format!(
                "; grid up to {:.1}× finer around {} crowded singularities",
                c.max_multiplier, c.singularities
            ),
            None => String::new(),
        };
        if p.symmetry == 4 && p.lattice == crate::param::Lattice::Z2 && self.settings.pure_quad {
            if p.collapsed_strips > 0 {
                crowded_note.push_str(&format!(
                    "; rounded on Z² (on 2Z² {} corners fell on the lines of creases under two cells away, and the map folded)",
                    p.collapsed_strips
                ));
            } else {
                crowded_note.push_str("; rounded on Z² (on 2Z² the map folded under the curves)");
            }
        }
        self.param_summary = format!(
            "{} cut paths, {} flipped faces{repair_note}, seam error {:.1e}, conformal distortion {:.3}, curl {:.3}{crowded_note}",
            p.cut_paths.len(),
            p.flipped_faces,
            p.seam_max_error,
            p.conformal_distortion.mean,
            p.curl
        );
        let mut folds = Folds::with_poles(&p.uv, &p.poles, repair);
        folds.miswound = p.miswound.clone();
        if !folds.faces.is_empty()
            && let (Some(mesh), Some(curves)) = (&self.mesh, self.curves())
        {
            folds.beside_curves = crate::constraint::curves_beside(
                mesh,
                curves.values(),
                &folds.faces,
                crate::constraint::BESIDE_FOLDS_RINGS,
            );
        }
        self.folds = Some(Arc::new(folds));
        self.param = Some(match &self.mesh {
            Some(mesh) => ParamDisplay::from_parameterization(mesh, &p),
            None => ParamDisplay {
                corner_uvs: p.uv.clone(),
                ..Default::default()
            },
        });
        self.param_key = param_key(&p);
        self.parameterization = Some(p);
        self.param_revision += 1;
        let remembered = self
            .remesh_cache
            .iter()
            .find(|(k, _)| *k == self.param_key)
            .map(|(_, r)| r.clone());
        if let Some(r) = remembered {
            self.remesh = Some(r);
            self.remesh_error = None;
            self.remesh_for = Some(self.param_revision);
        }
        self.set_lines(LineKind::CutGraph, segs);
    }

    /// Drops the parameterization and its remesh.
    fn clear_parameterization(&mut self) {
        self.parameterization = None;
        self.remesh = None;
        self.remesh_error = None;
        self.remesh_for = None;
        self.param_revision += 1;
    }

    /// Whether the parameterization shown has its remesh (or its extraction failed), or there
    /// is none: no extraction is due.
    pub fn remesh_current(&self) -> bool {
        self.parameterization.is_none() || self.remesh_for == Some(self.param_revision)
    }

    /// Increases whenever the parameterization is replaced or cleared: a remesh extraction
    /// carries the revision it extracts, and results for another one are stale.
    pub fn param_revision(&self) -> u64 {
        self.param_revision
    }

    /// Takes a remesh extraction's result; `false` (and nothing changes) when it is stale (for
    /// another mesh or parameterization). A failed extraction keeps the last good remesh and
    /// sets [`Document::remesh_error`].
    pub fn take_remesh(&mut self, result: super::remesh::RemeshResult) -> bool {
        if result.generation != self.generation
            || result.param_revision != self.param_revision
            || self.parameterization.is_none()
        {
            return false;
        }
        self.remesh_for = Some(self.param_revision);
        match result.outcome {
            Ok(view) => {
                let view = Arc::new(view);
                // about two million faces' worth, between 2 and 8
                let keep = (2_000_000 / view.quality.faces.max(1)).clamp(2, 8);
                self.remesh_cache.retain(|(k, _)| *k != self.param_key);
                self.remesh_cache.push((self.param_key, view.clone()));
                let excess = self.remesh_cache.len().saturating_sub(keep);
                self.remesh_cache.drain(..excess);
                self.remesh = Some(view);
                self.remesh_error = None;
            }
            Err(e) => self.remesh_error = Some(e),
        }
        true
    }

    /// Shows a solve's early map (the global step's, before the injectivity repair) in place
    /// of the shown UVs until the solve's result arrives; `false` when it does not fit the mesh.
    pub fn show_preview(&mut self, uv: Vec<[f64; 2]>) -> bool {
        let Some(mesh) = &self.mesh else {
            return false;
        };
        if uv.len() != 3 * mesh.n_faces() {
            return false;
        }
        if self.preview_backup.is_none() {
            self.preview_backup = Some((self.param.take(), self.folds.take()));
        }
        self.folds = Some(Arc::new(Folds::new(&uv, FoldRepair::Pending)));
        self.param = Some(ParamDisplay {
            corner_uvs: uv,
            patches: Default::default(),
        });
        self.rebuild_scene();
        true
    }

    /// Sets (or clears) the parameterization.
    pub fn set_param(&mut self, param: Option<ParamDisplay>) {
        self.preview_backup = None;
        self.folds = param
            .as_ref()
            .map(|p| Arc::new(Folds::new(&p.corner_uvs, FoldRepair::None)));
        self.param = param;
        self.rebuild_scene();
    }

    /// Replaces the overlay lines of one kind.
    pub fn set_lines(&mut self, kind: LineKind, segments: Vec<[DVec3; 2]>) {
        self.lines.retain(|(k, _)| *k != kind);
        if !segments.is_empty() {
            self.lines.push((kind, segments));
        }
        self.rebuild_scene();
    }

    pub fn has_param(&self) -> bool {
        self.param.is_some()
    }

    /// Increases whenever a new mesh is loaded (jobs on an older mesh are stale).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Increases whenever the scene changes.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    pub fn scene(&self) -> Option<&Arc<SceneData>> {
        self.scene.as_ref()
    }

    fn rebuild_scene(&mut self) {
        self.revision += 1;
        let Some(base) = &self.base_scene else {
            self.scene = None;
            return;
        };
        let mut scene = base.clone();
        if let Some(p) = &self.param {
            scene.set_corner_uvs(&p.corner_uvs);
            scene.set_patches(&p.patches);
        }
        if let Some(f) = &self.field {
            scene.set_face_field(&f.face_dirs, f.symmetry);
            if let Some(mesh) = &self.mesh {
                for s in &f.singularities {
                    if s.vertex < mesh.n_vertices() {
                        let p = mesh.position(s.vertex);
                        scene.glyphs.push(super::scene::Glyph {
                            position: [p.x as f32, p.y as f32, p.z as f32],
                            color: singularity_color(s.index, f.symmetry),
                        });
                    }
                }
            }
        }
        for (kind, segs) in &self.lines {
            let color = kind.color();
            for s in segs {
                scene.lines.push(LineSegment {
                    a: s[0].as_vec3().to_array(),
                    b: s[1].as_vec3().to_array(),
                    color,
                });
            }
        }
        self.scene = Some(Arc::new(scene));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn star_faces_fold_by_their_quads() {
        // faces 0 and 1 of a pole's star: 0's triangle folds but its quad does not, 1's quad
        // folds; face 2 is outside the star, its triangle folds
        let good = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let pole = crate::param::Pole {
            vertex: 0,
            index: 1.0,
            faces: vec![0, 1],
            ring: vec![1, 2],
            quads: vec![good, [good[1], good[0], good[2], good[3]]],
        };
        let flipped = [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]];
        let upright = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let uv: Vec<[f64; 2]> = [flipped, upright, flipped].concat();
        assert_eq!(Folds::new(&uv, FoldRepair::None).faces, vec![0, 2]);
        let folds = Folds::with_poles(&uv, &[pole], FoldRepair::None);
        assert_eq!(folds.faces, vec![1, 2]);
    }

    #[test]
    fn a_preview_replaces_the_shown_uvs_until_the_result() {
        let mesh = Arc::new(crate::mesh::generate::icosphere(1));
        let mut doc = Document {
            mesh: Some(mesh.clone()),
            ..Document::default()
        };
        assert!(
            !doc.show_preview(vec![[0.0; 2]; 5]),
            "does not fit the mesh"
        );
        assert!(doc.param.is_none());
        let flipped = [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]];
        let mut uv: Vec<[f64; 2]> = (0..3 * mesh.n_faces())
            .map(|c| [c as f64, (c % 3) as f64 * 0.5])
            .collect();
        uv[..3].copy_from_slice(&flipped);
        assert!(doc.show_preview(uv.clone()));
        assert_eq!(doc.param.as_ref().map(|p| &p.corner_uvs), Some(&uv));
        let folds = doc.folds.as_ref().expect("folds of the preview");
        assert_eq!(folds.repair, FoldRepair::Pending);
        assert!(folds.faces.contains(&0));
        assert!(folds.summary().contains("before the repair"));
        // A second preview keeps the display from before the first; a failed solve puts it back.
        assert!(doc.show_preview(uv.clone()));
        doc.take_outcome(SolveOutcome {
            revision: doc.edit_revision(),
            base: None,
            first: 0,
            states: Vec::new(),
            skipped: Vec::new(),
            solved: Err("failed".into()),
            contradiction: Vec::new(),
        });
        assert!(
            doc.param.is_none(),
            "the display before the preview (none) is back"
        );
        assert!(doc.folds.is_none());
    }
}
