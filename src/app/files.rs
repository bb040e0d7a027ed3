//! Files of the editor: opening with the unsaved-changes question, project save / save as /
//! quick save, exports, screenshots and the pattern image.

use std::path::{Path, PathBuf};

use super::editor::EditorApp;
use super::jobs::{Job, JobOutput};
use super::settings::Pattern;
use super::viewport::ViewportResources;

/// Whether `path` names a project file (`.json`) rather than a mesh.
pub fn is_project_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
}

/// Something that replaces or closes the document, asked about first when there are unsaved
/// changes.
#[derive(Clone, Debug, PartialEq)]
pub enum PendingAction {
    /// A mesh or a project file.
    Open(PathBuf),
    OpenDefault,
    /// Remesh the document's mesh isotropically (`mesh::isotropic`), write it beside the mesh
    /// file and open it.
    RemeshInput,
    /// Close the window.
    Close,
}

/// What File ▸ Export writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportKind {
    /// The mesh with per-corner UVs.
    UvObj,
    /// Quads (N = 4), hexagons (N = 6) or stripe polylines (N = 2).
    Remesh,
}

impl ExportKind {
    pub(super) fn label(self) -> &'static str {
        match self {
            ExportKind::UvObj => "Export OBJ with UVs…",
            ExportKind::Remesh => "Export remesh…",
        }
    }
    pub(super) fn default_name(self) -> &'static str {
        match self {
            ExportKind::UvObj => "quadcover-uv.obj",
            ExportKind::Remesh => "quadcover-remesh.obj",
        }
    }
}

/// `quadcover-screenshot-N.png` in the current folder, N the first free number.
pub(super) fn quick_screenshot_path() -> PathBuf {
    (1..)
        .map(|n| PathBuf::from(format!("quadcover-screenshot-{n}.png")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| PathBuf::from("quadcover-screenshot.png"))
}

impl EditorApp {
    /// Opens or closes after asking about unsaved changes (the Save / Discard / Cancel window)
    /// when there are any.
    pub fn request(&mut self, action: PendingAction) {
        if self.document.is_dirty() {
            self.confirm = Some(action);
        } else {
            self.perform(action);
        }
    }

    fn perform(&mut self, action: PendingAction) {
        let ctx = self.ctx.clone();
        match action {
            PendingAction::Open(p) => self.open_path(&p, ctx),
            PendingAction::OpenDefault => self.open_default(ctx),
            PendingAction::RemeshInput => self.remesh_input(ctx),
            PendingAction::Close => {
                self.allow_close = true;
                if let Some(ctx) = &self.ctx {
                    ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                }
            }
        }
    }

    /// Remeshes the document's mesh isotropically in the background
    /// ([`crate::mesh::isotropic`], the same as `quadcover prepare`), writes it as
    /// `<name>-remeshed.obj` beside the mesh file (the current folder for the default mesh or a
    /// read-only folder) and
    /// opens it as a new document: edits name vertices, so the old document's edits do not carry
    /// over (the unsaved-changes question comes first).
    pub fn remesh_input(&mut self, ctx: Option<egui::Context>) {
        let Some(mesh) = self.document.mesh.clone() else {
            return;
        };
        let stem = Path::new(&self.document.name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "mesh".into());
        let dir = self
            .document
            .path
            .as_ref()
            .and_then(|p| p.parent().map(Path::to_path_buf))
            // a folder marked read-only (shared meshes) is respected even where the user could
            // write anyway (root): the current folder instead
            .filter(|d| !d.metadata().is_ok_and(|m| m.permissions().readonly()))
            .unwrap_or_default();
        let out = dir.join(format!("{stem}-remeshed.obj"));
        self.jobs.push(Job::spawn(
            format!("Remeshing {}", self.document.name),
            ctx,
            move |_| {
                use crate::mesh::isotropic::{
                    PREPARED_FEATURE_ANGLE, isotropic_remesh, prepared_options,
                };
                let opts = prepared_options(&mesh, None, PREPARED_FEATURE_ANGLE);
                let remeshed =
                    isotropic_remesh(&mesh, &opts).map_err(|e| format!("remeshing failed: {e}"))?;
                let obj = crate::io::ObjOutput::new(remeshed.positions(), remeshed.faces());
                // A read-only folder (shared meshes): the current folder instead.
                let out = match crate::io::write_obj(&out, &obj) {
                    Ok(()) => out,
                    Err(first) => {
                        let here = PathBuf::from(out.file_name().unwrap_or_default());
                        crate::io::write_obj(&here, &obj).map_err(|e| {
                            format!("{}: {first}; {}: {e}", out.display(), here.display())
                        })?;
                        here
                    }
                };
                super::document::load_path(&out).map(|d| JobOutput::Loaded(Box::new(d)))
            },
        ));
    }

    /// Answers the unsaved-changes question: `Some(true)` saves first, `Some(false)` discards,
    /// `None` cancels.
    pub fn answer_confirm(&mut self, save: Option<bool>) {
        let Some(action) = self.confirm.take() else {
            return;
        };
        match save {
            None => self.status = "Cancelled".into(),
            Some(true) => {
                if self.save_project() {
                    self.perform(action);
                } else {
                    // nothing saved (dialog cancelled or unavailable): ask again
                    self.confirm = Some(action);
                }
            }
            Some(false) => self.perform(action),
        }
    }

    /// A project path for the current document in the current folder (no dialog).
    pub fn quick_project_path(&self) -> PathBuf {
        let stem = Path::new(&self.document.name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "quadcover".into());
        PathBuf::from(format!("{stem}-project.json"))
    }

    /// Saves the project to `path` (atomically); errors go to the error window.
    pub fn save_project_to(&mut self, path: &Path) -> bool {
        match self.document.save_project(path) {
            Ok(()) => {
                self.status = format!(
                    "Saved project {} ({} edits)",
                    path.display(),
                    self.document.cursor()
                );
                self.push_recent(path.to_path_buf());
                true
            }
            Err(e) => {
                self.error = Some(format!("Could not save the project:\n{e}"));
                false
            }
        }
    }

    /// File ▸ Save project: to the project's file, else as Save As.
    pub fn save_project(&mut self) -> bool {
        match self.document.project_path.clone() {
            Some(p) => self.save_project_to(&p),
            None => self.save_project_as(),
        }
    }

    /// File ▸ Save project as…: a file dialog; where none is available (no portal), the quick
    /// save path in the current folder.
    pub fn save_project_as(&mut self) -> bool {
        if self.document.mesh.is_none() {
            return false;
        }
        let name = self.quick_project_path().to_string_lossy().into_owned();
        match rfd::FileDialog::new()
            .add_filter("quadcover project", &["json"])
            .set_file_name(name)
            .save_file()
        {
            Some(p) => self.save_project_to(&p),
            None => {
                self.status =
                    "No file dialog: use File > Quick save project (current folder)".into();
                false
            }
        }
    }

    /// Handles a close request: with unsaved changes the close is cancelled and the question
    /// asked.
    pub(super) fn handle_close(&mut self, ui: &egui::Ui) {
        if ui.input(|i| i.viewport().close_requested())
            && self.document.is_dirty()
            && !self.allow_close
        {
            ui.ctx()
                .send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.confirm = Some(PendingAction::Close);
        }
    }

    pub(super) fn update_title(&mut self, ui: &egui::Ui) {
        let title = self.title();
        if title != self.last_title {
            ui.ctx()
                .send_viewport_cmd(egui::ViewportCommand::Title(title.clone()));
            self.last_title = title;
        }
    }

    pub(super) fn confirm_window(&mut self, ui: &mut egui::Ui) {
        let Some(action) = self.confirm.clone() else {
            return;
        };
        let what = match &action {
            PendingAction::Close => "Close the window".to_string(),
            PendingAction::OpenDefault => "Open the default mesh".to_string(),
            PendingAction::RemeshInput => "Open a remeshed copy of the mesh".to_string(),
            PendingAction::Open(p) => format!("Open {}", p.display()),
        };
        let mut answer = None;
        let mut quick = false;
        egui::Modal::new(egui::Id::unique("quadcover unsaved changes")).show(ui.ctx(), |ui| {
            ui.heading("Unsaved changes");
            ui.label(format!(
                "{what}: the edits and settings of {} are not saved.",
                self.document.name
            ));
            ui.horizontal(|ui| {
                if ui.button("Save").clicked() {
                    answer = Some(Some(true));
                }
                if self.document.project_path.is_none()
                    && ui
                        .button("Save in the current folder")
                        .on_hover_text("Where no file dialog is available")
                        .clicked()
                {
                    quick = true;
                }
                if ui.button("Discard").clicked() {
                    answer = Some(Some(false));
                }
                if ui.button("Cancel").clicked() {
                    answer = Some(None);
                }
            });
        });
        if quick {
            let p = self.quick_project_path();
            if self.save_project_to(&p) {
                self.confirm = None;
                self.perform(action);
            }
        } else if let Some(a) = answer {
            self.answer_confirm(a);
        }
    }

    /// Writes the parameterized mesh (OBJ with per-corner UVs) or its remesh in the background.
    pub fn start_export(&mut self, ctx: Option<egui::Context>, kind: ExportKind, path: PathBuf) {
        let (Some(mesh), Some(p)) = (
            self.document.mesh.clone(),
            self.document.parameterization.as_ref(),
        ) else {
            self.status = "Nothing to export: parameterize first".into();
            return;
        };
        let (uv, n, poles) = (p.uv.clone(), p.symmetry as u8, p.poles.clone());
        self.jobs.push(Job::spawn(
            format!("Exporting {}", path.display()),
            ctx,
            move |_| {
                match kind {
                    ExportKind::UvObj => crate::export::write_uv_obj(&path, &mesh, &uv, &poles)
                        .map(|()| JobOutput::Exported(format!("Saved {}", path.display()))),
                    ExportKind::Remesh => {
                        crate::export::write_remesh(&path, &mesh, &uv, &poles, n, n == 6).map(|q| {
                            JobOutput::Exported(format!(
                                "Saved {}: {} vertices, {} irregular, RSD edge {:.1} %",
                                path.display(),
                                q.vertices,
                                q.irregular_vertices,
                                100.0 * q.rsd_edge
                            ))
                        })
                    }
                }
                .map_err(|e| e.to_string())
            },
        ));
    }

    /// Renders the viewport offscreen at its current size and writes a PNG.
    pub fn screenshot(&self, frame: &eframe::Frame, path: &Path) -> Result<(), String> {
        let rs = frame
            .wgpu_render_state()
            .ok_or("no wgpu render state (the editor runs without wgpu)")?;
        let renderer = rs.renderer.read();
        let res = renderer
            .callback_resources
            .get::<ViewportResources>()
            .ok_or("the viewport is not initialized")?;
        let [w, h] = self.viewport_px;
        let img = super::render::render_to_rgba(
            &rs.device,
            &rs.queue,
            &res.renderer,
            &self.camera,
            &self.document.display,
            w.max(16),
            h.max(16),
        );
        img.save(path)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))
    }

    /// Loads a PNG/JPEG as the image pattern (uploaded on the next frame).
    pub fn load_pattern_image(&mut self, path: &Path) -> Result<(), String> {
        let img = image::open(path)
            .map_err(|e| format!("cannot read image {}: {e}", path.display()))?
            .to_rgba8();
        self.pending_pattern_image = Some(img);
        self.document.display.pattern = Pattern::Image;
        Ok(())
    }

    pub(super) fn upload_pending_image(&mut self, frame: &eframe::Frame) {
        let Some(img) = self.pending_pattern_image.take() else {
            return;
        };
        if let Some(rs) = frame.wgpu_render_state() {
            let mut r = rs.renderer.write();
            if let Some(res) = r.callback_resources.get_mut::<ViewportResources>() {
                res.renderer.set_pattern_image(
                    &rs.device,
                    &rs.queue,
                    img.width(),
                    img.height(),
                    img.as_raw(),
                );
            }
        }
    }
}
