//! The eframe application: the wiring of menus ([`super::menus`]), the side panel
//! ([`super::panels`]), the viewport and its tools ([`super::view_ui`], [`super::tools`]), the
//! background jobs and their results. The actions live beside it: files
//! ([`super::files`]), edits, undo and solves ([`super::edits`]), the individual stages
//! ([`super::stages`]).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::camera::OrbitCamera;
use super::document::{
    DEFAULT_MESH_NAME, DEFAULT_MESH_OBJ, Document, load_bytes, load_path, load_project,
};
use super::jobs::{Job, JobOutput};
use super::picking::Picker;
use super::settings::{DisplayMode, Pattern};
use super::tools::{Tool, ToolKind};
use super::viewport::ViewportResources;
use crate::edit::Settings;

pub use super::files::{ExportKind, PendingAction};

pub(super) const MAX_RECENT: usize = 10;

/// Options for constructing the editor (tests use a temporary recent-files path).
#[derive(Clone, Debug, Default)]
pub struct EditorOptions {
    /// File to open at start (a mesh, or a project `.json`); `None` opens the embedded
    /// default mesh.
    pub open: Option<PathBuf>,
    /// Where the recent-files list is kept; `None` keeps it in memory only.
    pub recent_store: Option<PathBuf>,
    /// After each load, compute the field and the parameterization in the background.
    pub auto_solve: bool,
}

/// Default location of the recent-files list.
pub fn default_recent_store() -> Option<PathBuf> {
    let base = std::env::var_os("XDG_CONFIG_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".config")))?;
    Some(base.join("quadcover").join("recent.txt"))
}

pub struct EditorApp {
    pub document: Document,
    pub camera: OrbitCamera,
    /// Running background jobs.
    pub jobs: Vec<Job>,
    /// Error shown in a modal window until dismissed.
    pub error: Option<String>,
    /// Last status line.
    pub status: String,
    /// A refused edit or a skipped-edit remark, shown in the side panel until the next edit.
    pub notice: Option<String>,
    pub recent: Vec<PathBuf>,
    pub(super) recent_store: Option<PathBuf>,
    /// Fit the camera when the next scene arrives.
    pub(super) fit_pending: bool,
    /// Viewport size in physical pixels (last frame).
    pub(super) viewport_px: [u32; 2],
    pub(super) has_wgpu: bool,
    /// Decoded RGBA image waiting to be uploaded as the image pattern.
    pub(super) pending_pattern_image: Option<image::RgbaImage>,
    /// The solve settings as edited in the side panel (applied with *Apply settings*).
    pub settings_draft: Settings,
    /// Run field + QuadCover after each load (see [`EditorOptions::auto_solve`]).
    pub(super) auto_solve: bool,
    /// A solve is wanted once the running (cancelled) one has ended: edits coalesce.
    pub(super) solve_pending: bool,
    /// The picking BVH of the current mesh (built in the background after each load).
    pub picker: Option<Arc<Picker>>,
    /// The active viewport tool, and which it is ([`EditorApp::set_tool`]).
    pub tool: Box<dyn Tool>,
    pub tool_kind: ToolKind,
    /// The other tools, keeping their settings while another is active.
    pub(super) parked_tools: Vec<(ToolKind, Box<dyn Tool>)>,
    /// The curve overlays and the feature panel ([`super::curves`]).
    pub curves: super::curves::CurvesUi,
    /// The fold overlay's cache ([`super::folds`]).
    pub(super) folds: super::folds::FoldsUi,
    /// The remesh extraction and the quality window ([`super::remesh`]).
    pub remesh: super::remesh::RemeshUi,
    /// An action waiting for the answer to "save the unsaved changes?".
    pub confirm: Option<PendingAction>,
    /// The user chose to close without saving.
    pub(super) allow_close: bool,
    pub(super) last_title: String,
    /// The viewport's camera and rectangle in the last frame (for picking).
    pub(super) last_view: super::picking::View,
    /// For jobs started while polling (they repaint the window when done).
    pub(super) ctx: Option<egui::Context>,
}

impl EditorApp {
    pub fn new(cc: &eframe::CreationContext<'_>, options: EditorOptions) -> EditorApp {
        let mut has_wgpu = false;
        if let Some(rs) = cc.wgpu_render_state.as_ref() {
            let res = ViewportResources::new(&rs.device, &rs.queue, rs.target_format);
            rs.renderer.write().callback_resources.insert(res);
            has_wgpu = true;
        }
        let recent = options
            .recent_store
            .as_ref()
            .and_then(|p| std::fs::read_to_string(p).ok())
            .map(|s| {
                s.lines()
                    .filter(|l| !l.trim().is_empty())
                    .map(PathBuf::from)
                    .take(MAX_RECENT)
                    .collect()
            })
            .unwrap_or_default();
        let mut app = EditorApp {
            document: Document::default(),
            camera: OrbitCamera::default(),
            jobs: Vec::new(),
            error: None,
            status: String::new(),
            notice: None,
            recent,
            recent_store: options.recent_store,
            fit_pending: true,
            viewport_px: [1, 1],
            has_wgpu,
            pending_pattern_image: None,
            settings_draft: Settings::default(),
            auto_solve: options.auto_solve,
            solve_pending: false,
            picker: None,
            tool: ToolKind::MoveSingularity.make(),
            tool_kind: ToolKind::MoveSingularity,
            parked_tools: Vec::new(),
            curves: Default::default(),
            folds: Default::default(),
            remesh: Default::default(),
            confirm: None,
            allow_close: false,
            last_title: String::new(),
            last_view: super::picking::View {
                camera: OrbitCamera::default(),
                rect: egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(1.0, 1.0)),
            },
            ctx: Some(cc.egui_ctx.clone()),
        };
        let ctx = cc.egui_ctx.clone();
        match options.open {
            Some(path) => app.open_path(&path, Some(ctx)),
            None => app.open_default(Some(ctx)),
        }
        app
    }

    /// True while any background job runs (or a solve waits for a cancelled one to end, or
    /// the parameterization shown for its remesh).
    pub fn busy(&self) -> bool {
        !self.jobs.is_empty() || self.solve_pending || self.remesh_pending()
    }

    /// Loads the embedded default mesh in the background.
    pub fn open_default(&mut self, ctx: Option<egui::Context>) {
        self.jobs.push(Job::spawn(
            format!("Loading {DEFAULT_MESH_NAME}"),
            ctx,
            |_| {
                load_bytes(DEFAULT_MESH_NAME, DEFAULT_MESH_OBJ)
                    .map(|d| JobOutput::Loaded(Box::new(d)))
            },
        ));
    }

    /// Loads a mesh file, or a project (`.json`), in the background; errors end up in the
    /// error window and the current document stays. (Does not ask about unsaved changes:
    /// [`EditorApp::request`] does.)
    pub fn open_path(&mut self, path: &Path, ctx: Option<egui::Context>) {
        let p = path.to_path_buf();
        let name = p
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if super::files::is_project_path(&p) {
            self.jobs.push(Job::spawn(
                format!("Opening project {name}"),
                ctx,
                move |_| load_project(&p).map(|d| JobOutput::ProjectLoaded(Box::new(d))),
            ));
            return;
        }
        self.jobs
            .push(Job::spawn(format!("Loading {name}"), ctx, move |_| {
                load_path(&p).map(|d| JobOutput::Loaded(Box::new(d)))
            }));
    }

    /// Takes finished jobs' results into the document, and the current solve's early map.
    pub fn poll_jobs(&mut self) {
        let revision = self.document.edit_revision();
        if let Some(job) = self.jobs.iter().find(|j| j.revision == Some(revision))
            && let Some(uv) = job.progress.take_preview()
            && self.document.show_preview(uv)
        {
            show_pattern(&mut self.document);
            self.status = format!(
                "{}: showing the global step's map, repairing folds",
                job.name
            );
        }
        let mut i = 0;
        while i < self.jobs.len() {
            let Some(result) = self.jobs[i].poll() else {
                i += 1;
                continue;
            };
            let job = self.jobs.remove(i);
            if job
                .generation
                .is_some_and(|g| g != self.document.generation())
            {
                self.status = format!("{}: discarded (the mesh changed)", job.name);
                continue;
            }
            if let Some(r) = job.revision
                && r != self.document.edit_revision()
            {
                // superseded by a newer edit (cancelled or not): dropped
                continue;
            }
            let secs = job.started.elapsed().as_secs_f32();
            match result {
                Ok(JobOutput::Loaded(doc)) => {
                    let path = doc.path.clone();
                    self.status = format!(
                        "Loaded {} ({} faces) in {secs:.2} s",
                        doc.name, doc.stats.faces,
                    );
                    self.document.set_loaded(*doc);
                    self.after_load();
                    if self.auto_solve {
                        self.schedule_solve();
                    }
                    if let Some(p) = path {
                        self.push_recent(p);
                    }
                }
                Ok(JobOutput::ProjectLoaded(project)) => {
                    let path = project.path.clone();
                    self.status = format!(
                        "Opened project {} ({} edits) in {secs:.2} s",
                        path.display(),
                        project.project.edits.len()
                    );
                    self.document.set_project(*project);
                    self.settings_draft = self.document.settings.clone();
                    self.after_load();
                    self.schedule_solve();
                    self.push_recent(path);
                }
                Ok(JobOutput::Solved(outcome)) => {
                    let skipped_before = self.document.skipped.len();
                    if self.document.take_outcome(*outcome) {
                        if self.document.solve_error.is_none() {
                            show_pattern(&mut self.document);
                            self.status = format!("{} done in {secs:.2} s", job.name);
                        } else {
                            self.status = format!("{} failed", job.name);
                            if !self.document.contradiction.is_empty() {
                                self.notice = self.document.solve_error.clone();
                            }
                        }
                        if self.document.skipped.len() > skipped_before {
                            self.notice = Some(format!(
                                "{} edits skipped (see Edits)",
                                self.document.skipped.len()
                            ));
                        }
                    }
                }
                Ok(JobOutput::Picker(p)) => {
                    if self.document.mesh.as_ref().is_some_and(|m| p.is_for(m)) {
                        self.picker = Some(p);
                    }
                }
                Ok(JobOutput::Field(f)) => {
                    self.document.set_field(Some(f));
                    self.document.display.mode = DisplayMode::Field;
                    self.status = format!("{} done", job.name);
                }
                Ok(JobOutput::Param(p)) => {
                    self.document.set_param(Some(p));
                    self.document.display.mode = DisplayMode::Pattern;
                    self.status = format!("{} done", job.name);
                }
                Ok(JobOutput::FieldComputed(r)) => {
                    self.document.set_frame_field(*r);
                    self.document.display.mode = DisplayMode::Field;
                    self.status = format!("{} done in {secs:.2} s", job.name);
                }
                Ok(JobOutput::Exported(message)) => {
                    self.status = message;
                }
                Ok(JobOutput::Remeshed(result)) => self.take_remesh(*result),
                Err(e) if job.param_revision.is_some() => {
                    self.take_remesh(super::remesh::RemeshResult {
                        generation: self.document.generation(),
                        param_revision: job.param_revision.unwrap_or_default(),
                        outcome: Err(e),
                    });
                }
                Ok(JobOutput::Parameterized(p, analysis)) => {
                    self.document.param_analysis = Some(analysis);
                    // the stage runs QuadCover with the default options: the repair is on
                    self.document.set_parameterization(*p, true);
                    show_pattern(&mut self.document);
                    self.status = format!("{} done in {secs:.2} s", job.name);
                }
                Err(e) if job.revision.is_some() => {
                    self.status = format!("{} failed", job.name);
                    self.document.solve_error = Some(e);
                }
                Err(e) => {
                    self.status = format!("{} failed", job.name);
                    self.error = Some(format!("Could not complete \"{}\":\n{e}", job.name));
                }
            }
        }
        if self.solve_pending && !self.jobs.iter().any(|j| j.revision.is_some()) {
            self.spawn_solve();
        }
        self.sync_remesh();
    }

    fn after_load(&mut self) {
        self.tool.reset();
        self.tool.clear_selection();
        for (_, t) in &mut self.parked_tools {
            t.clear_selection();
        }
        self.notice = None;
        self.fit_pending = true;
        self.spawn_picker();
    }

    pub(super) fn push_recent(&mut self, path: PathBuf) {
        let path = std::fs::canonicalize(&path).unwrap_or(path);
        self.recent.retain(|p| p != &path);
        self.recent.insert(0, path);
        self.recent.truncate(MAX_RECENT);
        if let Some(store) = &self.recent_store {
            if let Some(dir) = store.parent() {
                let _ = std::fs::create_dir_all(dir);
            }
            let text: String = self
                .recent
                .iter()
                .map(|p| format!("{}\n", p.display()))
                .collect();
            let _ = std::fs::write(store, text);
        }
    }

    pub(super) fn fit(&mut self) {
        if let Some(s) = self.document.scene() {
            self.camera.fit(s.bbox);
        }
    }

    /// The window title: the project's (or mesh's) file name, `*` for unsaved changes.
    pub fn title(&self) -> String {
        let name = match &self.document.project_path {
            Some(p) => p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            None => self.document.name.clone(),
        };
        let dirty = if self.document.is_dirty() { "*" } else { "" };
        if name.is_empty() {
            "quadcover".into()
        } else {
            format!("{name}{dirty} — quadcover")
        }
    }

    fn error_window(&mut self, ui: &mut egui::Ui) {
        let Some(msg) = self.error.clone() else {
            return;
        };
        let mut open = true;
        egui::Window::new("Error")
            .collapsible(false)
            .resizable(false)
            .anchor(egui::Align2::CENTER_CENTER, egui::vec2(0.0, 0.0))
            .open(&mut open)
            .show(ui.ctx(), |ui| {
                ui.label(plain(&msg));
                if ui.button("OK").clicked() {
                    self.error = None;
                }
            });
        if !open {
            self.error = None;
        }
    }
}

/// Text for the UI's fonts: egui's default fonts have no arrows, so the core's `→` (edit
/// labels, messages) and `▸` are written in ASCII.
pub fn plain(text: &str) -> String {
    text.replace('→', "->").replace('▸', ">")
}

/// After a parameterization: the pattern view, with each symmetry's own pattern unless the
/// user chose another that fits.
pub(super) fn show_pattern(document: &mut Document) {
    let Some(n) = document
        .parameterization
        .as_ref()
        .map(|p| p.symmetry as u32)
    else {
        return;
    };
    let d = &mut document.display;
    d.mode = DisplayMode::Pattern;
    let natural = match n {
        2 => Pattern::Stripes,
        6 => Pattern::Hexagons,
        _ => Pattern::QuadGrid,
    };
    let someones_natural = matches!(
        d.pattern,
        Pattern::None | Pattern::Stripes | Pattern::Hexagons | Pattern::QuadGrid
    );
    if !d.pattern.fits_symmetry(n) || someones_natural {
        d.pattern = natural;
    }
}

impl eframe::App for EditorApp {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        self.poll_jobs();
        self.upload_pending_image(frame);
        if self.fit_pending && self.document.scene().is_some() {
            self.fit();
            self.fit_pending = false;
        }
        // files dropped on the window
        let dropped: Vec<PathBuf> = ui.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_path_buf())
                .collect()
        });
        if let Some(p) = dropped.first() {
            self.request(PendingAction::Open(p.clone()));
        }
        self.shortcuts(ui);
        self.handle_close(ui);
        self.update_title(ui);

        egui::Panel::top("menu").show(ui, |ui| self.menu_bar(ui, frame));
        egui::Panel::left("side")
            .default_size(300.0)
            .resizable(true)
            .show(ui, |ui| self.side_panel(ui));
        egui::CentralPanel::no_frame().show(ui, |ui| self.viewport(ui));
        self.remesh_quality_window(ui);
        self.error_window(ui);
        self.confirm_window(ui);
        if self.busy() {
            ui.ctx()
                .request_repaint_after(std::time::Duration::from_millis(100));
        }
    }
}
