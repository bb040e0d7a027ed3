//! The viewport panel: the camera's mouse input, the active tool's events and hints, and the
//! wgpu paint callback.

use super::editor::EditorApp;
use super::picking::View;
use super::tools::{ToolContext, ToolEvent, ToolOutput};
use super::viewport::ViewportCallback;

impl EditorApp {
    pub(super) fn viewport(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let ppp = ui.ctx().pixels_per_point();
        self.viewport_px = [
            (rect.width() * ppp).round().max(1.0) as u32,
            (rect.height() * ppp).round().max(1.0) as u32,
        ];
        let fit_rect =
            egui::Rect::from_min_size(rect.min + egui::vec2(8.0, 8.0), egui::vec2(60.0, 22.0));
        let view = View {
            camera: self.camera,
            rect,
        };
        self.last_view = view;

        // The tool sees the pointer first; a press it does not claim orbits the camera.
        let (pos, pressed, released, down, moved, modifiers, double) = ui.input(|i| {
            (
                i.pointer.interact_pos().or(i.pointer.hover_pos()),
                i.pointer.primary_pressed(),
                i.pointer.primary_released(),
                i.pointer.primary_down(),
                i.pointer.delta() != egui::Vec2::ZERO || i.pointer.is_moving(),
                i.modifiers,
                i.pointer
                    .button_double_clicked(egui::PointerButton::Primary),
            )
        });
        let shift = modifiers.shift;
        let keys = !ui.ctx().egui_wants_keyboard_input() && self.confirm.is_none();
        let key = |k: egui::Key| keys && ui.input(|i| i.key_pressed(k));
        let (escape, enter) = (key(egui::Key::Escape), key(egui::Key::Enter));
        let delete = key(egui::Key::Delete) || key(egui::Key::Backspace);
        let over = pos
            .filter(|p| rect.contains(*p) && !fit_rect.contains(*p) && response.contains_pointer());
        let picker = {
            let mesh = self.document.mesh.as_ref();
            self.picker
                .as_deref()
                .filter(|p| mesh.is_some_and(|m| p.is_for(m)))
        };
        let cx = ToolContext {
            view,
            document: &self.document,
            picker,
            modifiers,
        };
        let mut out = ToolOutput::default();
        let mut feed = |tool: &mut Box<dyn super::tools::Tool>, ev: ToolEvent| {
            out.merge(tool.event(&cx, ev));
        };
        if escape {
            feed(&mut self.tool, ToolEvent::Cancel);
        }
        if enter {
            feed(&mut self.tool, ToolEvent::Finish);
        }
        if delete {
            feed(&mut self.tool, ToolEvent::Delete);
        }
        let mut hold = false;
        if self.tool.active() {
            if let Some(p) = pos {
                if released || !down {
                    feed(&mut self.tool, ToolEvent::Release(p));
                } else if moved {
                    feed(&mut self.tool, ToolEvent::Drag(p));
                } else {
                    hold = true;
                }
            }
        } else if pressed
            && !shift
            && let Some(p) = over
        {
            feed(&mut self.tool, ToolEvent::Press(p));
        } else if !down {
            feed(&mut self.tool, ToolEvent::Hover(over));
        }
        if double && let Some(p) = over {
            feed(&mut self.tool, ToolEvent::DoubleClick(p));
        }
        out.captured |= hold;
        let captured = out.captured || self.tool.active();

        // camera input
        let delta = response.drag_delta();
        if !captured {
            if response.dragged_by(egui::PointerButton::Primary) && !shift {
                self.camera.orbit(delta.x, delta.y);
            } else if response.dragged_by(egui::PointerButton::Middle)
                || response.dragged_by(egui::PointerButton::Secondary)
                || (response.dragged_by(egui::PointerButton::Primary) && shift)
            {
                self.camera.pan(delta.x, delta.y, rect.height());
            }
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
                overlays: vec![
                    self.remesh_overlay(),
                    self.curves_overlay(),
                    self.feature_preview_overlay(),
                    self.folds_overlay(),
                    self.tool.overlay(),
                ],
                remesh_surface: self.remesh_surface(),
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
        // the tool's hints, with the camera of this frame
        let cx = ToolContext {
            view: View {
                camera: self.camera,
                rect,
            },
            document: &self.document,
            picker: None,
            modifiers,
        };
        self.tool.paint(&cx, ui);

        if ui.put(fit_rect, egui::Button::new("Fit (F)")).clicked() {
            self.fit();
        }
        if self.busy() {
            let r = egui::Rect::from_min_size(
                rect.right_top() + egui::vec2(-32.0, 8.0),
                egui::vec2(24.0, 24.0),
            );
            ui.put(r, egui::Spinner::new());
        }

        self.take_tool_output(out);
    }
}
