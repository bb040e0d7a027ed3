//! The remesh in the side panel (its display mode, a summary, the irregular-vertex legend) and
//! the *Remesh quality* window (View ▸ Remesh quality, or *Quality* beside the display mode):
//! the numbers of [`crate::extract::RemeshQuality`] for the remesh shown and two histograms
//! (egui_plot), corner angles with the ideal angle marked and edge lengths relative to their
//! mean. Everything shown was computed with the remesh in the background
//! ([`super::remesh::RemeshView`]).

use egui_plot::{Bar, BarChart, Legend, Plot, VLine};

use super::editor::{EditorApp, plain};
use super::remesh::{FEWER_COLOR, Histogram, MORE_COLOR, RemeshView, sides_name};
use super::settings::RemeshDisplay;

/// Title of the quality window.
pub const QUALITY_WINDOW: &str = "Remesh quality";
/// Accessible labels of the two histograms.
pub const ANGLE_PLOT: &str = "Corner angle histogram";
pub const LENGTH_PLOT: &str = "Edge length histogram";

/// The id of a histogram's plot (its memory holds the bounds shown).
pub fn plot_id(label: &str) -> egui::Id {
    egui::Id::unique(("quadcover remesh plot", label))
}

/// A linear RGBA colour for egui (sRGB-encoded).
fn color32(c: [f32; 4]) -> egui::Color32 {
    let to8 = |x: f32| (x.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8;
    egui::Color32::from_rgb(to8(c[0]), to8(c[1]), to8(c[2]))
}

/// A coloured dot followed by a label (one widget, so wrapping keeps them together).
fn dot_label(ui: &mut egui::Ui, color: [f32; 4], text: String) {
    ui.horizontal(|ui| {
        let (rect, _) = ui.allocate_exact_size(egui::vec2(12.0, 12.0), egui::Sense::hover());
        ui.painter()
            .circle_filled(rect.center(), 4.5, color32(color));
        ui.label(text);
    });
}

impl EditorApp {
    /// The side panel's remesh rows (in *Display*).
    pub(super) fn remesh_section(&mut self, ui: &mut egui::Ui) {
        let d = &mut self.document.display;
        ui.horizontal(|ui| {
            egui::ComboBox::from_label("Remesh")
                .selected_text(d.remesh.label())
                .show_ui(ui, |ui| {
                    for m in RemeshDisplay::ALL {
                        ui.selectable_value(&mut d.remesh, m, m.label());
                    }
                })
                .response
                .on_hover_text(
                    "The remesh extracted from the parameterization after every solve: its \
                     edges over the surface, or its polygons alone",
                );
            ui.toggle_value(&mut self.remesh.show_quality, "Quality")
                .on_hover_text("The remesh's quality numbers and histograms");
        });
        let pending = self.remesh_pending();
        let doc = &self.document;
        match &doc.remesh {
            Some(r) => {
                let text = r.summary();
                if pending {
                    ui.weak(format!("{text} (updating)"));
                } else {
                    ui.label(text);
                }
                if doc.display.remesh != RemeshDisplay::Off && !r.irregular.is_empty() {
                    irregular_legend(ui, r);
                }
            }
            None if pending => {
                ui.horizontal(|ui| {
                    ui.spinner();
                    ui.label("Extracting the remesh");
                });
            }
            None if doc.parameterization.is_none() => {
                ui.weak("Remesh: no parameterization yet");
            }
            None => {}
        }
        if let Some(e) = &doc.remesh_error {
            ui.colored_label(
                egui::Color32::LIGHT_RED,
                plain(&format!("Remesh extraction failed: {e}")),
            );
        }
    }

    /// The *Remesh quality* window, while it is open.
    pub(super) fn remesh_quality_window(&mut self, ui: &mut egui::Ui) {
        if !self.remesh.show_quality {
            return;
        }
        let pending = self.remesh_pending();
        let doc = &self.document;
        let mut open = true;
        let right_top = ui.ctx().content_rect().right_top();
        egui::Window::new(QUALITY_WINDOW)
            .open(&mut open)
            .default_pos(right_top + egui::vec2(-420.0, 40.0))
            .default_width(400.0)
            .resizable(true)
            .show(ui.ctx(), |ui| {
                if let Some(e) = &doc.remesh_error {
                    ui.colored_label(
                        egui::Color32::LIGHT_RED,
                        plain(&format!(
                            "The last extraction failed (the last good remesh is shown): {e}"
                        )),
                    );
                }
                match &doc.remesh {
                    Some(r) => {
                        if pending {
                            ui.horizontal(|ui| {
                                ui.spinner();
                                ui.label("Extracting the remesh of the newest solve");
                            });
                        }
                        quality_contents(ui, r);
                    }
                    None if pending => {
                        ui.horizontal(|ui| {
                            ui.spinner();
                            ui.label("Extracting the remesh");
                        });
                    }
                    None => {
                        ui.label("No remesh yet: it is extracted after every solve");
                    }
                }
            });
        self.remesh.show_quality &= open;
    }
}

/// The dots of the irregular vertices and what their colours mean.
fn irregular_legend(ui: &mut egui::Ui, r: &RemeshView) {
    let regular = r.quality.regular_valence;
    ui.horizontal_wrapped(|ui| {
        dot_label(
            ui,
            FEWER_COLOR,
            format!("{} with < {regular} edges", r.fewer),
        );
        dot_label(
            ui,
            MORE_COLOR,
            format!("{} with > {regular}", r.irregular.len() - r.fewer),
        );
    });
}

/// The numbers and the histograms of one remesh.
fn quality_contents(ui: &mut egui::Ui, r: &RemeshView) {
    let q = &r.quality;
    let mut rows: Vec<String> = Vec::new();
    rows.push(match q.boundary_vertices {
        0 => format!("Vertices: {}", q.vertices),
        b => format!("Vertices: {} ({b} on the boundary)", q.vertices),
    });
    rows.push(format!("Faces: {}", q.faces));
    if !q.faces_by_sides.is_empty() {
        let mut by: Vec<(usize, usize)> = q.faces_by_sides.iter().map(|(&s, &c)| (s, c)).collect();
        by.sort_by_key(|&(s, c)| (std::cmp::Reverse(c), s));
        let by: Vec<String> = by.into_iter().map(|(s, c)| sides_name(s, c)).collect();
        rows.push(format!("By sides: {}", by.join(", ")));
    }
    if q.polylines > 0 {
        rows.push(format!("Stripes (polylines): {}", q.polylines));
    }
    for row in rows {
        ui.label(row);
    }
    if q.faces > 0 {
        ui.label(format!(
            "Irregular vertices: {} (interior valence != {})",
            q.irregular_vertices, q.regular_valence
        ));
        irregular_legend(ui, r);
    }
    let mut rows = vec![format!("RSD edge: {:.2} %", 100.0 * q.rsd_edge)];
    if q.faces > 0 {
        rows.push(format!("RSD angle: {:.2} %", 100.0 * q.rsd_angle));
        rows.push(format!(
            "Angles: {:.1}° .. {:.1}° (ideal {:.0}°)",
            q.min_angle_deg, q.max_angle_deg, r.ideal_angle
        ));
    }
    rows.push(format!(
        "Mean distance: {:.2e} (max {:.2e}, Hausdorff {:.2e}) of the bounding box diagonal",
        q.mean_distance, q.max_distance, q.hausdorff
    ));
    rows.push(format!("Patched places: {}", q.patched_places));
    if q.non_manifold_edges > 0 {
        rows.push(format!("Non-manifold edges: {}", q.non_manifold_edges));
    }
    if q.non_manifold_vertices > 0 {
        rows.push(format!(
            "Non-manifold vertices: {}",
            q.non_manifold_vertices
        ));
    }
    for row in rows {
        ui.label(row);
    }
    ui.weak(format!("extracted in {:.2} s", r.seconds));

    ui.separator();
    if r.angles.total() > 0 {
        histogram(
            ui,
            ANGLE_PLOT,
            "corner angles",
            &r.angles,
            (r.ideal_angle, format!("ideal {:.0}°", r.ideal_angle)),
            "corner angle (°)",
            [0.0, 180.0],
        );
    }
    if r.lengths.total() > 0 {
        histogram(
            ui,
            LENGTH_PLOT,
            "edge lengths",
            &r.lengths,
            (1.0, format!("mean {:.3e}", r.mean_edge)),
            "edge length / mean (longer than 2.5 in the last bar)",
            [0.0, 2.5],
        );
    }
}

/// A bar chart of `hist` with a vertical marker line, not zoomable (fixed bounds).
fn histogram(
    ui: &mut egui::Ui,
    label: &str,
    name: &str,
    hist: &Histogram,
    marker: (f64, String),
    x_label: &str,
    x_range: [f64; 2],
) {
    let bars: Vec<Bar> = hist
        .counts
        .iter()
        .enumerate()
        .map(|(i, &c)| Bar::new(hist.center(i), c as f64).width(hist.bin_width * 0.9))
        .collect();
    let max = hist.counts.iter().copied().max().unwrap_or(0) as f64;
    let response = Plot::new(label)
        .id(plot_id(label))
        .height(140.0)
        .legend(Legend::default().position(egui_plot::Corner::RightTop))
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .allow_boxed_zoom(false)
        .allow_double_click_reset(false)
        .default_x_bounds(x_range[0], x_range[1])
        .default_y_bounds(0.0, (1.1 * max).max(1.0))
        .x_axis_label(x_label)
        .show(ui, |plot| {
            plot.bar_chart(BarChart::new(name, bars).color(egui::Color32::from_rgb(110, 150, 220)));
            plot.vline(
                VLine::new(marker.1, marker.0)
                    .color(egui::Color32::from_rgb(230, 90, 60))
                    .width(2.0),
            );
        })
        .response;
    response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Figure, true, label));
}
