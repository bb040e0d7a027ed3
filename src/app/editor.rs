//! The eframe application: menu, side panel, viewport, error window, jobs.

use std::path::{Path, PathBuf};

use glam::DVec3;

use super::camera::OrbitCamera;
use super::document::{
    DEFAULT_MESH_NAME, DEFAULT_MESH_OBJ, Document, FieldDisplay, ParamDisplay, load_bytes,
    load_path,
};
use super::jobs::{Job, JobOutput};
use super::scene::singularity_color;
use super::settings::{DisplayMode, Pattern, Shading};
use super::viewport::{ViewportCallback, ViewportResources};

const MAX_RECENT: usize = 10;

/// Options for constructing the editor (tests use a temporary recent-files path).
#[derive(Clone, Debug, Default)]
pub struct EditorOptions {
    /// File to open at start; `None` opens the embedded default mesh.
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
    pub recent: Vec<PathBuf>,
    recent_store: Option<PathBuf>,
    /// Fit the camera when the next scene arrives.
    fit_pending: bool,
    /// Viewport size in physical pixels (last frame).
    viewport_px: [u32; 2],
    has_wgpu: bool,
    /// Decoded RGBA image waiting to be uploaded as the image pattern.
    pending_pattern_image: Option<image::RgbaImage>,
    /// Symmetry chosen for the next field computation.
    pub symmetry: u32,
    /// Run field + QuadCover after each load (see [`EditorOptions::auto_solve`]).
    auto_solve: bool,
    /// The running field job was started by `auto_solve`: parameterize when it finishes.
    auto_param_pending: bool,
    /// For jobs started while polling (they repaint the window when done).
    ctx: Option<egui::Context>,
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
            recent,
            recent_store: options.recent_store,
            fit_pending: true,
            viewport_px: [1, 1],
            has_wgpu,
            pending_pattern_image: None,
            symmetry: 4,
            auto_solve: options.auto_solve,
            auto_param_pending: false,
            ctx: Some(cc.egui_ctx.clone()),
        };
        let ctx = cc.egui_ctx.clone();
        match options.open {
            Some(path) => app.open_path(&path, Some(ctx)),
            None => app.open_default(Some(ctx)),
        }
        app
    }

    /// True while any background job runs.
    pub fn busy(&self) -> bool {
        !self.jobs.is_empty()
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

    /// Loads a mesh file in the background; errors end up in the error window.
    pub fn open_path(&mut self, path: &Path, ctx: Option<egui::Context>) {
        let p = path.to_path_buf();
        let name = p
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        self.jobs
            .push(Job::spawn(format!("Loading {name}"), ctx, move |_| {
                load_path(&p).map(|d| JobOutput::Loaded(Box::new(d)))
            }));
    }

    /// Synthetic demo: a 4-field aligned with the projection
    /// of the x axis (y where x is normal), computed in the background.
    pub fn start_demo_field(&mut self, ctx: Option<egui::Context>, symmetry: u32) {
        let Some(mesh) = self.document.mesh.clone() else {
            return;
        };
        let generation = self.document.generation();
        self.jobs.push(
            Job::spawn("Synthetic field", ctx, move |progress| {
                let n = mesh.n_faces();
                let mut dirs = Vec::with_capacity(n);
                for f in 0..n {
                    if f % 4096 == 0 {
                        progress.set(f as f32 / n.max(1) as f32);
                    }
                    let nrm = mesh.face_normal(f);
                    let mut d = DVec3::X - nrm * nrm.dot(DVec3::X);
                    if d.length_squared() < 1e-4 {
                        d = DVec3::Y - nrm * nrm.dot(DVec3::Y);
                    }
                    dirs.push(d.normalize_or_zero());
                }
                Ok(JobOutput::Field(FieldDisplay {
                    symmetry,
                    face_dirs: dirs,
                    singularities: Vec::new(),
                }))
            })
            .for_generation(generation),
        );
    }

    /// Synthetic demo: planar projection UVs (x, y)
    /// scaled so about 12 cells span the mesh.
    pub fn start_demo_param(&mut self, ctx: Option<egui::Context>) {
        let Some(mesh) = self.document.mesh.clone() else {
            return;
        };
        let generation = self.document.generation();
        self.jobs.push(
            Job::spawn("Synthetic parameterization", ctx, move |_| {
                let (lo, hi) = mesh.bounding_box();
                let s = 12.0 / (hi - lo).max_element().max(1e-12);
                let mut uvs = Vec::with_capacity(3 * mesh.n_faces());
                for f in mesh.faces() {
                    for &v in f {
                        let p = (mesh.position(v as usize) - lo) * s;
                        uvs.push([p.x, p.y]);
                    }
                }
                Ok(JobOutput::Param(ParamDisplay { corner_uvs: uvs }))
            })
            .for_generation(generation),
        );
    }

    /// Computes a frame field of symmetry `n` (2, 4 or 6) in the background.
    pub fn start_field(&mut self, ctx: Option<egui::Context>, n: u32) {
        let Some(mesh) = self.document.mesh.clone() else {
            return;
        };
        let generation = self.document.generation();
        self.jobs.push(
            Job::spawn(format!("Computing {n}-field"), ctx, move |_| {
                let symmetry = crate::field::Symmetry::from_n(n).map_err(|e| e.to_string())?;
                let params = crate::field::FieldParams {
                    symmetry,
                    ..Default::default()
                };
                crate::field::compute_field(&mesh, &params)
                    .map(|r| JobOutput::FieldComputed(Box::new(r)))
                    .map_err(|e| e.to_string())
            })
            .for_generation(generation),
        );
    }

    /// Runs QuadCover on the current field in the background.
    pub fn start_parameterize(&mut self, ctx: Option<egui::Context>) {
        let (Some(mesh), Some(field)) = (
            self.document.mesh.clone(),
            self.document.frame_field.clone(),
        ) else {
            return;
        };
        let generation = self.document.generation();
        let analysis = self.document.param_analysis.clone();
        self.jobs.push(
            Job::spawn("Parameterizing (QuadCover)", ctx, move |_| {
                let run = || -> Result<JobOutput, crate::param::ParamError> {
                    let analysis = match analysis {
                        Some(a) => a,
                        None => std::sync::Arc::new(crate::param::ParamAnalysis::new(&mesh)?),
                    };
                    let qc = crate::param::QuadCover::with_analysis(
                        &mesh,
                        field.symmetry.n() as usize,
                        &field.matchings,
                        crate::param::ParamOptions::default(),
                        Some(&analysis),
                    )?;
                    let p = qc.solve(&mesh, &field.frames)?;
                    Ok(JobOutput::Parameterized(Box::new(p), analysis))
                };
                run().map_err(|e| e.to_string())
            })
            .for_generation(generation),
        );
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
        let (uv, n) = (p.uv.clone(), p.symmetry as u8);
        self.jobs.push(Job::spawn(
            format!("Exporting {}", path.display()),
            ctx,
            move |_| {
                match kind {
                    ExportKind::UvObj => crate::export::write_uv_obj(&path, &mesh, &uv)
                        .map(|()| JobOutput::Exported(format!("Saved {}", path.display()))),
                    ExportKind::Remesh => crate::export::write_remesh(&path, &mesh, &uv, n, n == 6)
                        .map(|q| {
                            JobOutput::Exported(format!(
                                "Saved {}: {} vertices, {} irregular, RSD edge {:.1} %",
                                path.display(),
                                q.vertices,
                                q.irregular_vertices,
                                100.0 * q.rsd_edge
                            ))
                        }),
                }
                .map_err(|e| e.to_string())
            },
        ));
    }

    /// Takes finished jobs' results into the document.
    pub fn poll_jobs(&mut self) {
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
            match result {
                Ok(JobOutput::Loaded(doc)) => {
                    let path = doc.path.clone();
                    self.status = format!(
                        "Loaded {} ({} faces) in {:.2} s",
                        doc.name,
                        doc.stats.faces,
                        job.started.elapsed().as_secs_f32()
                    );
                    self.document.set_loaded(*doc);
                    if self.auto_solve {
                        self.start_field(self.ctx.clone(), self.symmetry);
                        self.auto_param_pending = true;
                    }
                    self.fit_pending = true;
                    if let Some(p) = path {
                        self.push_recent(p);
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
                    if std::mem::take(&mut self.auto_param_pending) {
                        self.start_parameterize(self.ctx.clone());
                    }
                    self.document.display.mode = DisplayMode::Field;
                    self.status = format!(
                        "{} done in {:.2} s",
                        job.name,
                        job.started.elapsed().as_secs_f32()
                    );
                }
                Ok(JobOutput::Exported(message)) => {
                    self.status = message;
                }
                Ok(JobOutput::Parameterized(p, analysis)) => {
                    self.document.param_analysis = Some(analysis);
                    let n = p.symmetry as u32;
                    self.document.set_parameterization(*p);
                    let d = &mut self.document.display;
                    d.mode = DisplayMode::Pattern;
                    // Each symmetry's own pattern, unless the user chose another that fits.
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
                    self.status = format!(
                        "{} done in {:.2} s",
                        job.name,
                        job.started.elapsed().as_secs_f32()
                    );
                }
                Err(e) => {
                    self.status = format!("{} failed", job.name);
                    self.error = Some(format!("Could not complete \"{}\":\n{e}", job.name));
                }
            }
        }
    }

    fn push_recent(&mut self, path: PathBuf) {
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

    fn upload_pending_image(&mut self, frame: &eframe::Frame) {
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

    fn menu_bar(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open…").clicked() {
                    if let Some(p) = rfd::FileDialog::new()
                        .add_filter("Meshes", &["obj", "ply", "off", "stl"])
                        .pick_file()
                    {
                        self.open_path(&p, Some(ui.ctx().clone()));
                    }
                    ui.close();
                }
                ui.menu_button("Open recent", |ui| {
                    if self.recent.is_empty() {
                        ui.label("(none)");
                    }
                    let mut chosen = None;
                    for p in &self.recent {
                        if ui.button(p.display().to_string()).clicked() {
                            chosen = Some(p.clone());
                        }
                    }
                    if let Some(p) = chosen {
                        self.open_path(&p, Some(ui.ctx().clone()));
                        ui.close();
                    }
                });
                if ui.button("Load pattern image…").clicked() {
                    if let Some(p) = rfd::FileDialog::new()
                        .add_filter("Images", &["png", "jpg", "jpeg"])
                        .pick_file()
                        && let Err(e) = self.load_pattern_image(&p)
                    {
                        self.error = Some(e);
                    }
                    ui.close();
                }
                if ui.button("Open default mesh (Spot)").clicked() {
                    self.open_default(Some(ui.ctx().clone()));
                    ui.close();
                }
                ui.separator();
                let has_param = self.document.has_param();
                for kind in [ExportKind::UvObj, ExportKind::Remesh] {
                    if ui
                        .add_enabled(has_param, egui::Button::new(kind.label()))
                        .on_disabled_hover_text("Needs a parameterization")
                        .clicked()
                    {
                        if let Some(p) = rfd::FileDialog::new()
                            .add_filter("OBJ", &["obj"])
                            .set_file_name(kind.default_name())
                            .save_file()
                        {
                            self.start_export(Some(ui.ctx().clone()), kind, p);
                        }
                        ui.close();
                    }
                }
                if ui
                    .add_enabled(
                        has_param,
                        egui::Button::new("Quick export both (current folder)"),
                    )
                    .on_disabled_hover_text("Needs a parameterization")
                    .clicked()
                {
                    for kind in [ExportKind::UvObj, ExportKind::Remesh] {
                        let p = PathBuf::from(kind.default_name());
                        self.start_export(Some(ui.ctx().clone()), kind, p);
                    }
                    ui.close();
                }
                if ui.button("Screenshot to PNG…").clicked() {
                    if let Some(p) = rfd::FileDialog::new()
                        .add_filter("PNG", &["png"])
                        .set_file_name("quadcover.png")
                        .save_file()
                    {
                        match self.screenshot(frame, &p) {
                            Ok(()) => self.status = format!("Saved {}", p.display()),
                            Err(e) => self.error = Some(e),
                        }
                    }
                    ui.close();
                }
                if ui.button("Quick screenshot (current folder)").clicked() {
                    let p = quick_screenshot_path();
                    match self.screenshot(frame, &p) {
                        Ok(()) => self.status = format!("Saved {}", p.display()),
                        Err(e) => self.error = Some(e),
                    }
                    ui.close();
                }
                ui.separator();
                if ui.button("Quit").clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("View", |ui| {
                if ui.button("Fit to mesh (F)").clicked() {
                    self.fit();
                    ui.close();
                }
                ui.checkbox(&mut self.document.display.wireframe, "Wireframe");
            });
        });
    }

    fn fit(&mut self) {
        if let Some(s) = self.document.scene() {
            self.camera.fit(s.bbox);
        }
    }

    fn side_panel(&mut self, ui: &mut egui::Ui) {
        egui::ScrollArea::vertical().show(ui, |ui| {
            ui.heading("Mesh");
            let name = if self.document.name.is_empty() {
                "(no mesh)".to_string()
            } else {
                self.document.name.clone()
            };
            ui.label(format!("File: {name}"));
            if let Some(s) = &self.document.stats {
                let rows = [
                    ("Vertices", s.vertices.to_string()),
                    ("Edges", s.edges.to_string()),
                    ("Faces", s.faces.to_string()),
                    ("Components", s.components.to_string()),
                    ("Genus", s.genus.to_string()),
                    ("Boundary loops", s.boundary_loops.to_string()),
                    ("Euler characteristic", s.euler_characteristic.to_string()),
                ];
                for (k, v) in rows {
                    ui.label(format!("{k}: {v}"));
                }
            }
            if !self.document.warnings.is_empty() {
                egui::CollapsingHeader::new(format!(
                    "Validation warnings ({})",
                    self.document.warnings.len()
                ))
                .default_open(true)
                .show(ui, |ui| {
                    for w in &self.document.warnings {
                        ui.colored_label(egui::Color32::from_rgb(230, 180, 60), w);
                    }
                });
            } else if self.document.stats.is_some() {
                ui.label("No validation warnings");
            }

            ui.separator();
            ui.heading("Display");
            let has_param = self.document.has_param();
            let has_field = self.document.field.is_some();
            let d = &mut self.document.display;
            ui.horizontal(|ui| {
                for m in DisplayMode::ALL {
                    ui.selectable_value(&mut d.mode, m, m.label());
                }
            });
            ui.horizontal(|ui| {
                ui.selectable_value(&mut d.shading, Shading::Smooth, "Smooth");
                ui.selectable_value(&mut d.shading, Shading::Flat, "Flat");
                ui.checkbox(&mut d.wireframe, "Wireframe");
            });
            let symmetry = self.document.field.as_ref().map(|f| f.symmetry);
            egui::ComboBox::from_label("Pattern")
                .selected_text(d.pattern.label())
                .show_ui(ui, |ui| {
                    for p in Pattern::ALL {
                        let mut text = p.label().to_string();
                        if let Some(n) = symmetry
                            && !p.fits_symmetry(n)
                        {
                            text.push_str(&format!(" (not {n}-symmetric)"));
                        }
                        ui.selectable_value(&mut d.pattern, p, text);
                    }
                });
            ui.add(
                egui::Slider::new(&mut d.pattern_scale, 0.05..=20.0)
                    .logarithmic(true)
                    .text("Pattern scale"),
            )
            .on_hover_text("Whole numbers keep the seams invisible; other values are a preview");
            if d.pattern == Pattern::Stripes {
                ui.horizontal(|ui| {
                    ui.add(egui::DragValue::new(&mut d.stripe_twist[0]).range(1..=12));
                    ui.add(egui::DragValue::new(&mut d.stripe_twist[1]).range(0..=12));
                    ui.label("Stripe twist (n, k)")
                        .on_hover_text("Texture mapped by (n −k; k n), thesis sec. 4.2: (1, 1) turns the stripes by 45°");
                });
            }
            ui.add(egui::Slider::new(&mut d.line_width, 0.5..=4.0).text("Line width (px)"));
            ui.add(egui::Slider::new(&mut d.lic_strength, 0.0..=1.0).text("LIC strength"));
            ui.add(
                egui::Slider::new(&mut d.lic_cell_px, 1.0..=8.0)
                    .logarithmic(true)
                    .text("LIC grain (px)"),
            );
            if d.mode == DisplayMode::Pattern && !has_param {
                ui.colored_label(egui::Color32::LIGHT_YELLOW, "No parameterization yet");
            }
            if d.mode == DisplayMode::Field && !has_field {
                ui.colored_label(egui::Color32::LIGHT_YELLOW, "No field yet");
            }
            ui.checkbox(&mut d.show_singularities, "Singularities");
            ui.checkbox(
                &mut d.show_lines,
                "Lines (cut graph, constraints, selection)",
            );

            ui.separator();
            ui.heading("Singularity index");
            let n = symmetry.unwrap_or(4);
            legend(ui, n);

            ui.separator();
            ui.heading("Solve");
            let has_mesh = self.document.mesh.is_some();
            let idle = self.jobs.is_empty();
            ui.horizontal(|ui| {
                ui.label("Symmetry N");
                for n in [2u32, 4, 6] {
                    ui.selectable_value(&mut self.symmetry, n, n.to_string());
                }
            });
            ui.horizontal(|ui| {
                if ui
                    .add_enabled(has_mesh && idle, egui::Button::new("Compute field"))
                    .clicked()
                {
                    let n = self.symmetry;
                    self.start_field(Some(ui.ctx().clone()), n);
                }
                let has_field = self.document.frame_field.is_some();
                if ui
                    .add_enabled(has_field && idle, egui::Button::new("Parameterize"))
                    .on_disabled_hover_text("Compute a field first")
                    .clicked()
                {
                    self.start_parameterize(Some(ui.ctx().clone()));
                }
            });
            if !self.document.field_summary.is_empty() {
                ui.label(format!("Field: {}", self.document.field_summary));
            }
            if !self.document.param_summary.is_empty() {
                ui.label(format!("Parameterization: {}", self.document.param_summary));
            }
            egui::CollapsingHeader::new("Demo (synthetic data)")
                .default_open(false)
                .show(ui, |ui| {
                    ui.horizontal(|ui| {
                        if ui
                            .add_enabled(has_mesh, egui::Button::new("Synthetic field"))
                            .clicked()
                        {
                            self.start_demo_field(Some(ui.ctx().clone()), 4);
                        }
                        if ui
                            .add_enabled(has_mesh, egui::Button::new("Synthetic UVs"))
                            .clicked()
                        {
                            self.start_demo_param(Some(ui.ctx().clone()));
                        }
                    });
                });

            ui.separator();
            ui.heading("Jobs");
            if self.jobs.is_empty() {
                ui.label("Idle");
            }
            for job in &self.jobs {
                ui.horizontal(|ui| {
                    ui.spinner();
                    ui.label(format!(
                        "{} ({:.1} s)",
                        job.name,
                        job.started.elapsed().as_secs_f32()
                    ));
                });
                if let Some(f) = job.progress.get() {
                    ui.add(egui::ProgressBar::new(f).show_percentage());
                }
            }
            if !self.status.is_empty() {
                ui.separator();
                ui.label(&self.status);
            }
        });
    }

    fn viewport(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let ppp = ui.ctx().pixels_per_point();
        self.viewport_px = [
            (rect.width() * ppp).round().max(1.0) as u32,
            (rect.height() * ppp).round().max(1.0) as u32,
        ];

        // camera input
        let delta = response.drag_delta();
        let shift = ui.input(|i| i.modifiers.shift);
        if response.dragged_by(egui::PointerButton::Primary) && !shift {
            self.camera.orbit(delta.x, delta.y);
        } else if response.dragged_by(egui::PointerButton::Middle)
            || response.dragged_by(egui::PointerButton::Secondary)
            || (response.dragged_by(egui::PointerButton::Primary) && shift)
        {
            self.camera.pan(delta.x, delta.y, rect.height());
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.camera.zoom((-scroll * 0.002).exp());
            }
        }
        if !ui.ctx().egui_wants_keyboard_input() && ui.input(|i| i.key_pressed(egui::Key::F)) {
            self.fit();
        }

        if self.has_wgpu {
            let cb = ViewportCallback {
                camera: self.camera,
                settings: self.document.display.clone(),
                size_px: self.viewport_px,
                revision: self.document.revision(),
                scene: self.document.scene().cloned(),
            };
            ui.painter()
                .add(egui_wgpu::Callback::new_paint_callback(rect, cb));
        } else {
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "wgpu is not available",
                egui::FontId::proportional(16.0),
                egui::Color32::GRAY,
            );
        }
        // fit button overlay
        let btn_rect =
            egui::Rect::from_min_size(rect.min + egui::vec2(8.0, 8.0), egui::vec2(60.0, 22.0));
        if ui.put(btn_rect, egui::Button::new("Fit (F)")).clicked() {
            self.fit();
        }
        if self.busy() {
            let r = egui::Rect::from_min_size(
                rect.right_top() + egui::vec2(-32.0, 8.0),
                egui::vec2(24.0, 24.0),
            );
            ui.put(r, egui::Spinner::new());
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
                ui.label(&msg);
                if ui.button("OK").clicked() {
                    self.error = None;
                }
            });
        if !open {
            self.error = None;
        }
    }
}

/// `quadcover-screenshot-N.png` in the current folder, N the first free number.
/// What File ▸ Export writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportKind {
    /// The mesh with per-corner UVs.
    UvObj,
    /// Quads (N = 4), hexagons (N = 6) or stripe polylines (N = 2).
    Remesh,
}

impl ExportKind {
    fn label(self) -> &'static str {
        match self {
            ExportKind::UvObj => "Export OBJ with UVs…",
            ExportKind::Remesh => "Export remesh…",
        }
    }
    fn default_name(self) -> &'static str {
        match self {
            ExportKind::UvObj => "quadcover-uv.obj",
            ExportKind::Remesh => "quadcover-remesh.obj",
        }
    }
}

fn quick_screenshot_path() -> PathBuf {
    (1..)
        .map(|n| PathBuf::from(format!("quadcover-screenshot-{n}.png")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| PathBuf::from("quadcover-screenshot.png"))
}

/// Colored dots for the singularity indices k/N, k = -N..N (k != 0).
fn legend(ui: &mut egui::Ui, n: u32) {
    ui.horizontal_wrapped(|ui| {
        let n_i = n as i32;
        for k in (-n_i..=n_i).filter(|k| *k != 0) {
            let c = singularity_color(k, n);
            let to8 = |x: f32| (x.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8;
            let color = egui::Color32::from_rgb(to8(c[0]), to8(c[1]), to8(c[2]));
            // one widget per entry so wrapping never separates a dot from its label
            let text = format!("{}{k}/{n}", if k > 0 { "+" } else { "" });
            let galley = ui.painter().layout_no_wrap(
                text,
                egui::TextStyle::Body.resolve(ui.style()),
                ui.visuals().text_color(),
            );
            let size = egui::vec2(16.0 + galley.size().x, galley.size().y.max(12.0));
            let (rect, _) = ui.allocate_exact_size(size, egui::Sense::hover());
            let dot = egui::pos2(rect.left() + 6.0, rect.center().y);
            ui.painter().circle_filled(dot, 5.5, color);
            let text_pos = egui::pos2(rect.left() + 16.0, rect.center().y - 0.5 * galley.size().y);
            ui.painter()
                .galley(text_pos, galley, ui.visuals().text_color());
        }
    });
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
            self.open_path(p, Some(ui.ctx().clone()));
        }

        egui::Panel::top("menu").show(ui, |ui| self.menu_bar(ui, frame));
        egui::Panel::left("side")
            .default_size(290.0)
            .resizable(true)
            .show(ui, |ui| self.side_panel(ui));
        egui::CentralPanel::no_frame().show(ui, |ui| self.viewport(ui));
        self.error_window(ui);
        if self.busy() {
            ui.ctx()
                .request_repaint_after(std::time::Duration::from_millis(100));
        }
    }
}
