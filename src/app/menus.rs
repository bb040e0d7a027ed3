//! The menu bar (File, Edit with the history, View) and the keyboard shortcuts.

use std::path::PathBuf;

use super::editor::{EditorApp, plain};
use super::files::{ExportKind, PendingAction, quick_screenshot_path};
use super::tools::ToolEvent;

impl EditorApp {
    /// Ctrl+Z undo, Ctrl+Shift+Z / Ctrl+Y redo, Ctrl+S save the project.
    pub(super) fn shortcuts(&mut self, ui: &mut egui::Ui) {
        if ui.ctx().egui_wants_keyboard_input() || self.confirm.is_some() {
            return;
        }
        use egui::{Key, KeyboardShortcut, Modifiers};
        let shift_cmd = Modifiers::COMMAND | Modifiers::SHIFT;
        let (redo, undo, save) = ui.input_mut(|i| {
            // Ctrl+Shift+Z first: the plain Ctrl+Z shortcut also matches it.
            let redo = i.consume_shortcut(&KeyboardShortcut::new(shift_cmd, Key::Z))
                | i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::Y));
            let undo = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::Z));
            let save = i.consume_shortcut(&KeyboardShortcut::new(Modifiers::COMMAND, Key::S));
            (redo, undo, save)
        });
        if self.tool.active() && (undo || redo) {
            // a gesture in progress ends first
            let view = self.last_view;
            let cx = super::tools::ToolContext {
                view,
                document: &self.document,
                picker: None,
                modifiers: egui::Modifiers::NONE,
            };
            self.tool.event(&cx, ToolEvent::Cancel);
        }
        if redo {
            self.redo();
        } else if undo {
            self.undo();
        }
        if save {
            self.save_project();
        }
    }

    pub(super) fn menu_bar(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| self.file_menu(ui, frame));
            ui.menu_button("Edit", |ui| self.edit_menu(ui));
            ui.menu_button("View", |ui| {
                if ui.button("Fit to mesh (F)").clicked() {
                    self.fit();
                    ui.close();
                }
                ui.checkbox(&mut self.document.display.wireframe, "Wireframe");
                ui.separator();
                ui.label("Remesh");
                for m in super::settings::RemeshDisplay::ALL {
                    ui.radio_value(&mut self.document.display.remesh, m, m.label());
                }
                ui.checkbox(&mut self.remesh.show_quality, "Remesh quality window");
            });
        });
    }

    fn file_menu(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        if ui.button("Open…").clicked() {
            if let Some(p) = rfd::FileDialog::new()
                .add_filter("Meshes and projects", &["obj", "ply", "off", "stl", "json"])
                .pick_file()
            {
                self.request(PendingAction::Open(p));
            }
            ui.close();
        }
        if ui.button("Open project…").clicked() {
            if let Some(p) = rfd::FileDialog::new()
                .add_filter("quadcover project", &["json"])
                .pick_file()
            {
                self.request(PendingAction::Open(p));
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
                self.request(PendingAction::Open(p));
                ui.close();
            }
        });
        if ui.button("Open default mesh (Spot)").clicked() {
            self.request(PendingAction::OpenDefault);
            ui.close();
        }
        let has_mesh = self.document.mesh.is_some();
        if ui
            .add_enabled(has_mesh, egui::Button::new("Remesh input"))
            .on_hover_text(
                "An isotropic copy of the mesh (about 20 000 vertices, sharp edges over 35° and \
                 the boundary kept), written beside it as NAME-remeshed.obj and opened: for raw \
                 CAD tessellations (needles, fanned faces), which the field cannot follow",
            )
            .clicked()
        {
            self.request(PendingAction::RemeshInput);
            ui.close();
        }
        ui.separator();
        if ui
            .add_enabled(
                has_mesh,
                egui::Button::new("Save project").shortcut_text("Ctrl+S"),
            )
            .clicked()
        {
            self.save_project();
            ui.close();
        }
        if ui
            .add_enabled(has_mesh, egui::Button::new("Save project as…"))
            .clicked()
        {
            self.save_project_as();
            ui.close();
        }
        if ui
            .add_enabled(
                has_mesh,
                egui::Button::new("Quick save project (current folder)"),
            )
            .on_hover_text("Where no file dialog is available")
            .clicked()
        {
            let p = self
                .document
                .project_path
                .clone()
                .unwrap_or_else(|| self.quick_project_path());
            self.save_project_to(&p);
            ui.close();
        }
        ui.separator();
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
    }

    /// Undo / Redo and the history: applied edits, then the redo tail (greyed, "undone");
    /// clicking an entry goes back or forward to just after it.
    fn edit_menu(&mut self, ui: &mut egui::Ui) {
        let doc = &self.document;
        let undo_text = match doc.applied_edits().last() {
            Some(e) => format!("Undo {}", plain(&e.label())),
            None => "Undo".into(),
        };
        let redo_text = match doc.edits.get(doc.cursor()) {
            Some(e) => format!("Redo {}", plain(&e.label())),
            None => "Redo".into(),
        };
        let (can_undo, can_redo) = (doc.can_undo(), doc.can_redo());
        if ui
            .add_enabled(
                can_undo,
                egui::Button::new(undo_text).shortcut_text("Ctrl+Z"),
            )
            .clicked()
        {
            self.undo();
            ui.close();
        }
        if ui
            .add_enabled(
                can_redo,
                egui::Button::new(redo_text).shortcut_text("Ctrl+Shift+Z / Ctrl+Y"),
            )
            .clicked()
        {
            self.redo();
            ui.close();
        }
        ui.separator();
        ui.label("History");
        let mut goto = None;
        if ui
            .selectable_label(self.document.cursor() == 0, "0. (no edits)")
            .clicked()
        {
            goto = Some(0);
        }
        let cursor = self.document.cursor();
        for (i, e) in self.document.edits.iter().enumerate() {
            let text = format!("{}. {}", i + 1, plain(&e.label()));
            let rich = if i < cursor {
                egui::RichText::new(text)
            } else {
                egui::RichText::new(format!("{text} (undone)"))
                    .weak()
                    .italics()
            };
            if ui.selectable_label(i + 1 == cursor, rich).clicked() {
                goto = Some(i + 1);
            }
        }
        if let Some(c) = goto {
            self.goto_history(c);
            ui.close();
        }
    }
}
