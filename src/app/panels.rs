//! The side panel: mesh, display, solve settings, tools and curves ([`super::curves`]), edits
//! (Relax, history, skipped edits), jobs.

use super::editor::{EditorApp, plain};
use super::scene::singularity_color;
use super::settings::{DisplayMode, Pattern, Shading};
use crate::edit::Settings;

impl EditorApp {
    pub(super) fn side_panel(&mut self, ui: &mut egui::Ui) {
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
            let folds = self.document.folds.as_ref().map(|f| f.summary());
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
            ui.checkbox(&mut d.show_folds, "Folds").on_hover_text(
                "Highlight the faces whose texture triangle is folded (non-positive signed area)",
            );
            if d.show_folds {
                match folds {
                    Some(text) => ui.label(text),
                    None => ui.weak("Folds: no parameterization yet"),
                };
            }
            self.remesh_section(ui);

            ui.separator();
            ui.heading("Singularity index");
            let n = symmetry.unwrap_or(4);
            legend(ui, n);

            ui.separator();
            ui.heading("Solve");
            self.solve_section(ui);

            ui.separator();
            ui.heading("Tools");
            self.tools_section(ui);

            ui.separator();
            ui.heading("Curves");
            self.curves_section(ui);

            ui.separator();
            ui.heading("Edits");
            self.edits_section(ui);

            ui.separator();
            ui.heading("Jobs");
            if self.jobs.is_empty() {
                ui.label("Idle");
            }
            if self.solve_pending {
                ui.label("A re-solve for the newest edit waits for the cancelled one to stop");
            }
            for job in &self.jobs {
                // wrapped: a long job name must not widen the panel (the viewport would move)
                ui.horizontal_wrapped(|ui| {
                    ui.spinner();
                    let stage = job.progress.stage();
                    let cancelled = if job.cancelled() { ", cancelled" } else { "" };
                    ui.label(plain(&format!(
                        "{}{}{} ({:.1} s{cancelled})",
                        job.name,
                        if stage.is_empty() { "" } else { ": " },
                        stage,
                        job.started.elapsed().as_secs_f32()
                    )));
                });
                if let Some(f) = job.progress.get() {
                    ui.add(egui::ProgressBar::new(f).show_percentage());
                }
            }
            if !self.status.is_empty() {
                ui.separator();
                ui.label(plain(&self.status));
            }
        });
    }

    /// The solve settings (applied with *Apply settings*: the base is rebuilt and the edits
    /// replayed) and the individual stages.
    fn solve_section(&mut self, ui: &mut egui::Ui) {
        let has_mesh = self.document.mesh.is_some();
        let idle = self.jobs.is_empty();
        let d = &mut self.settings_draft;
        ui.horizontal(|ui| {
            ui.label("Symmetry N");
            for n in [2u32, 4, 6] {
                ui.selectable_value(&mut d.symmetry, n, n.to_string());
            }
        });
        #[derive(PartialEq, Clone, Copy)]
        enum Density {
            Auto,
            Vertices,
            Scale,
        }
        let mut density = match (d.target_vertices, d.scale) {
            (Some(_), _) => Density::Vertices,
            (None, Some(_)) => Density::Scale,
            _ => Density::Auto,
        };
        ui.horizontal(|ui| {
            ui.label("Density");
            ui.selectable_value(&mut density, Density::Auto, "Default");
            ui.selectable_value(&mut density, Density::Vertices, "Vertices");
            ui.selectable_value(&mut density, Density::Scale, "Grid size");
        });
        let grid = self.document.edit_base.as_ref().map(|b| b.grid_size());
        let thin = self
            .document
            .edit_base
            .as_ref()
            .map(|b| (b.field().thin.faces, b.field().thin.max_multiplier));
        match density {
            Density::Auto => {
                d.target_vertices = None;
                d.scale = None;
            }
            Density::Vertices => {
                d.scale = None;
                let mut v = d.target_vertices.unwrap_or(6500);
                ui.add(
                    egui::DragValue::new(&mut v)
                        .range(10..=10_000_000)
                        .speed(50.0)
                        .prefix("target vertices "),
                );
                d.target_vertices = Some(v);
            }
            Density::Scale => {
                d.target_vertices = None;
                let mut s = d.scale.or(grid).unwrap_or(0.05);
                let speed = s * 0.01;
                ui.add(
                    egui::DragValue::new(&mut s)
                        .range(1e-9..=1e9)
                        .speed(speed)
                        .max_decimals(6)
                        .prefix("grid edge "),
                );
                d.scale = Some(s);
            }
        }
        if let Some(g) = grid {
            ui.label(format!("Grid size now: {g:.4}"));
        }
        if let Some((faces, m)) = thin.filter(|t| t.0 > 0) {
            ui.label(format!("Thin parts: {faces} faces up to {m:.2}× finer"));
        }
        ui.add(
            egui::Slider::new(&mut d.tau, 0.0..=10.0)
                .logarithmic(true)
                .text("τ (alignment)"),
        )
        .on_hover_text("Alignment to curvature directions against smoothness; 0 = smoothest");
        ui.add(egui::Slider::new(&mut d.reliable_fraction, 0.0..=1.0).text("Reliable fraction"));
        ui.add(
            egui::Slider::new(
                &mut d.curvature_smoothing,
                0..=crate::edit::project::MAX_CURVATURE_SMOOTHING,
            )
            .logarithmic(true)
            .text("Curvature smoothing"),
        )
        .on_hover_text(
            "Neighbour-averaging passes over the shape operators before the curvature \
             directions are taken (default 5; 0 = eq. 3.2 as is). More passes, fewer \
             singularities on noisy scans and on low-poly models' facets",
        );
        ui.add_enabled(
            d.symmetry == 4,
            egui::Checkbox::new(&mut d.pure_quad, "Pure quad (singularities on Z²)"),
        )
        .on_hover_text(
            "Round gaps to D₂ (2Z² at half-turn singularities) so that every singularity becomes \
             one irregular vertex of the quad remesh (N = 4; more distortion than the thesis's ½Z²)",
        );
        ui.checkbox(&mut d.renormalize_field, "Renormalize field")
            .on_hover_text(
                "Pull the relaxed field to unit length (Ginzburg–Landau steps): a smoother field \
                 and less distortion; splits umbilic poles into ±1/N; the field takes longer",
            );
        ui.checkbox(&mut d.refine_thin_parts, "Refine thin parts")
            .on_hover_text(
                "Make tubes, handles and small holes narrower than 5 grid cells around finer, so \
                 that the grid goes around them with 5 cells and the remesh stays manifold",
            );
        ui.checkbox(&mut d.refine_crowded, "Refine crowded singularities")
            .on_hover_text(
                "While the repaired map keeps folds or mis-wound vertices (under curves: folds), \
                 solve again (up to three times) with the grid 2–3× finer around singularities \
                 of one sign closer than 1.5–2 cells, and keep the best map",
            );
        ui.checkbox(&mut d.no_half_merges, "No half merges (refuse ±2/4)");
        ui.checkbox(&mut d.no_pole_merges, "No pole merges (refuse +N/N)")
            .on_hover_text(
                "Refuse merges that would create a pole (positive integral index, e.g. four \
                 +1/4 into +4/4); allowed by default: the pole's star becomes bilinear quads",
            );
        let mut untangle = !d.no_untangle;
        ui.checkbox(&mut untangle, "Untangle folds").on_hover_text(
            "Repair the folded faces the global step leaves (an injectivity repair of the map)",
        );
        d.no_untangle = !untangle;
        ui.add(
            egui::Slider::new(&mut d.relax_merge_within, 0.0..=5.0)
                .text("Relax merge radius (cells)"),
        );
        let valid = d.validate();
        let changed = *d != self.document.settings;
        ui.horizontal(|ui| {
            let label = if self.document.edit_base.is_none() {
                "Solve"
            } else {
                "Apply settings"
            };
            if ui
                .add_enabled(
                    has_mesh && valid.is_ok() && (changed || self.document.edit_base.is_none()),
                    egui::Button::new(label),
                )
                .on_hover_text(
                    "Recompute the field and QuadCover with these settings, replaying the edits",
                )
                .clicked()
            {
                self.apply_settings();
            }
            if ui
                .add_enabled(changed, egui::Button::new("Revert"))
                .clicked()
            {
                self.settings_draft = self.document.settings.clone();
            }
            if ui.button("Defaults").clicked() {
                self.settings_draft = Settings::default();
            }
        });
        if let Err(e) = valid {
            ui.colored_label(egui::Color32::LIGHT_RED, plain(&e));
        } else if changed {
            ui.colored_label(
                egui::Color32::LIGHT_YELLOW,
                "Settings changed: apply to recompute",
            );
        }
        ui.horizontal(|ui| {
            ui.label("Stages:");
            if ui
                .add_enabled(has_mesh && idle, egui::Button::new("Compute field"))
                .on_hover_text("The field alone (default settings but N), outside the edit list")
                .clicked()
            {
                let n = self.settings_draft.symmetry;
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
        if let Some(e) = &self.document.solve_error {
            ui.colored_label(
                egui::Color32::LIGHT_RED,
                plain(&format!(
                    "The last solve failed (the previous result is shown): {e}"
                )),
            );
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
    }

    /// Relax, undo / redo, the tool hint, the history length and skipped edits.
    fn edits_section(&mut self, ui: &mut egui::Ui) {
        let can_edit = self.document.editable().is_some();
        ui.horizontal(|ui| {
            if ui
                .add_enabled(self.document.edit_base.is_some(), egui::Button::new("Relax"))
                .on_hover_text(
                    "Move every singularity to the neighbour that lowers the curl, until none does; merge close ones",
                )
                .clicked()
            {
                self.relax();
            }
            if ui
                .add_enabled(self.document.can_undo(), egui::Button::new("Undo"))
                .clicked()
            {
                self.undo();
            }
            if ui
                .add_enabled(self.document.can_redo(), egui::Button::new("Redo"))
                .clicked()
            {
                self.redo();
            }
        });
        ui.label(format!(
            "{} of {} edits applied{}",
            self.document.cursor(),
            self.document.edits.len(),
            if self.document.is_dirty() {
                " (unsaved)"
            } else {
                ""
            }
        ));
        if !can_edit && self.document.mesh.is_some() {
            ui.weak("Editing starts when the solve has finished");
        }
        if let Some(n) = &self.notice {
            ui.colored_label(egui::Color32::from_rgb(230, 180, 60), plain(n));
        }
        if !self.document.skipped.is_empty() {
            egui::CollapsingHeader::new(format!("Skipped edits ({})", self.document.skipped.len()))
                .default_open(true)
                .show(ui, |ui| {
                    for s in &self.document.skipped {
                        ui.colored_label(
                            egui::Color32::from_rgb(230, 180, 60),
                            plain(&format!(
                                "edit {}: {} skipped: {}",
                                s.position,
                                s.edit.label(),
                                s.reason
                            )),
                        );
                    }
                });
        }
        if let Some(info) = &self.document.solve_info {
            ui.label(format!(
                "E_smooth {:.3e}, E_align {:.3e}, curl {:.4}",
                info.e_smooth, info.e_align, info.curl
            ));
            if !info.timings.is_empty() {
                let total: f64 = info.timings.iter().map(|t| t.1).sum();
                ui.weak(format!("last solve {:.0} ms", total * 1e3))
                    .on_hover_text(
                        info.timings
                            .iter()
                            .map(|(n, t)| format!("{n}: {:.1} ms", t * 1e3))
                            .collect::<Vec<_>>()
                            .join("\n"),
                    );
            }
        }
    }
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
