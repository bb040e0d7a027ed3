//! Constraint curves in the editor (thesis sec. 4.4): how curves are drawn (one style per kind,
//! the selection, curves a solve found contradictory), the document's curve overlay and the
//! sharp-feature preview (both cached, uploaded apart from the scene), and the side panel's
//! *Tools* and *Curves* sections (tool choice with the tool's own controls, feature detection,
//! boundary alignment).
//!
//! Styles: geometric curves are solid, thick and orange; combinatorial ones dashed, thin and
//! cyan; the selected curve is drawn over them, thick and light yellow (dashed when
//! combinatorial); curves of the last solve's contradiction are thick and red. The dashes are
//! laid out along the curve's length with a period proportional to the mesh size, so they do
//! not depend on the edge lengths.

use std::collections::BTreeMap;
use std::sync::Arc;

use glam::Vec3;

use super::editor::{EditorApp, plain};
use super::scene::{LineSegment, Overlay};
use super::tools::{ToolContext, ToolKind, ToolOutput, next_overlay_revision};
use crate::constraint::{Curve, CurveKind, CurveOrigin};
use crate::edit::Edit;
use crate::mesh::TriMesh;

/// Linear RGBA colours of the curve styles.
pub const GEOMETRIC_COLOR: [f32; 4] = [1.0, 0.42, 0.0, 1.0];
pub const COMBINATORIAL_COLOR: [f32; 4] = [0.0, 0.75, 1.0, 1.0];
pub const SELECTED_COLOR: [f32; 4] = [1.0, 1.0, 0.45, 1.0];
pub const HOVERED_COLOR: [f32; 4] = [1.0, 1.0, 1.0, 0.55];
pub const CONTRADICTION_COLOR: [f32; 4] = [1.0, 0.0, 0.0, 1.0];
pub const FEATURE_PREVIEW_COLOR: [f32; 4] = [0.9, 0.1, 0.9, 1.0];
/// A preview path a click would refuse.
pub const REFUSED_COLOR: [f32; 4] = [0.9, 0.05, 0.05, 0.8];

/// The colour of a curve kind.
pub fn kind_color(kind: CurveKind) -> [f32; 4] {
    match kind {
        CurveKind::Geometric => GEOMETRIC_COLOR,
        CurveKind::Combinatorial => COMBINATORIAL_COLOR,
    }
}

/// The dash period (world units) for a mesh of this size: about 1/60 of its diagonal.
pub fn dash_period(mesh: &TriMesh) -> f32 {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in mesh.positions() {
        lo = lo.min(p.as_vec3());
        hi = hi.max(p.as_vec3());
    }
    let d = (hi - lo).length();
    if d.is_finite() && d > 0.0 {
        d / 60.0
    } else {
        1.0
    }
}

/// How to draw one polyline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineStyle {
    pub color: [f32; 4],
    pub thick: bool,
    /// Dash period (world units); `None` draws it solid.
    pub dashes: Option<f32>,
}

impl LineStyle {
    /// A curve's own style (see the module documentation).
    pub fn of_kind(kind: CurveKind, period: f32) -> LineStyle {
        match kind {
            CurveKind::Geometric => LineStyle {
                color: GEOMETRIC_COLOR,
                thick: true,
                dashes: None,
            },
            CurveKind::Combinatorial => LineStyle {
                color: COMBINATORIAL_COLOR,
                thick: false,
                dashes: Some(period),
            },
        }
    }
}

/// Appends the polyline through `vertices` (mesh vertices; back to the first when `closed`)
/// to `overlay` in `style`.
pub fn push_polyline(
    overlay: &mut Overlay,
    mesh: &TriMesh,
    vertices: &[usize],
    closed: bool,
    style: LineStyle,
) {
    let n = mesh.n_vertices();
    let mut points: Vec<Vec3> = vertices
        .iter()
        .filter(|&&v| v < n)
        .map(|&v| mesh.position(v).as_vec3())
        .collect();
    if closed && points.len() > 2 {
        points.push(points[0]);
    }
    let out = if style.thick {
        &mut overlay.thick_lines
    } else {
        &mut overlay.lines
    };
    let seg = |a: Vec3, b: Vec3| LineSegment {
        a: a.to_array(),
        b: b.to_array(),
        color: style.color,
    };
    match style.dashes {
        None => out.extend(points.windows(2).map(|w| seg(w[0], w[1]))),
        Some(period) => dashes(&points, period.max(1e-12), &mut |a, b| out.push(seg(a, b))),
    }
}

/// The dashes of a polyline: on for 60 % of each `period` of arc length, off for the rest,
/// continued across its vertices.
fn dashes(points: &[Vec3], period: f32, emit: &mut dyn FnMut(Vec3, Vec3)) {
    let on = 0.6 * period;
    let mut start = 0.0f32; // arc length at the segment's start
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = (b - a).length();
        if len <= 0.0 {
            continue;
        }
        let at = |t: f32| a + (b - a) * (t / len);
        // dash k covers [k period, k period + on] of arc length; pieces of float noise dropped
        let end = start + len;
        let mut k = (start / period).floor();
        while k * period < end {
            let (d0, d1) = ((k * period).max(start), (k * period + on).min(end));
            if d1 - d0 > 1e-4 * period {
                emit(at(d0 - start), at(d1 - start));
            }
            k += 1.0;
        }
        start += len;
    }
}

/// The document's curves as an overlay: each in its kind's style, the ids in `contradiction`
/// in red, those in `beside_folds` (curves beside faces the repair left folded, shown with the
/// *Folds* overlay) thick in the folds' colour.
pub fn curves_overlay(
    mesh: &TriMesh,
    curves: &BTreeMap<u32, Curve>,
    contradiction: &[u32],
    beside_folds: &[u32],
) -> Overlay {
    let period = dash_period(mesh);
    let mut o = Overlay {
        revision: next_overlay_revision(),
        ..Overlay::default()
    };
    for c in curves.values() {
        let mut style = LineStyle::of_kind(c.kind, period);
        if contradiction.contains(&c.id) {
            style.color = CONTRADICTION_COLOR;
            style.thick = true;
        } else if beside_folds.contains(&c.id) {
            style.color = crate::app::folds::FOLD_COLOR;
            style.thick = true;
        }
        push_polyline(&mut o, mesh, &c.vertices, c.closed, style);
    }
    o
}

/// The feature edges as an overlay (the preview before *Detect features*).
pub fn feature_overlay(mesh: &TriMesh, edges: &[usize]) -> Overlay {
    Overlay {
        revision: next_overlay_revision(),
        lines: edges
            .iter()
            .map(|&e| {
                let [a, b] = mesh.edge_vertices(e);
                LineSegment {
                    a: mesh.position(a).as_vec3().to_array(),
                    b: mesh.position(b).as_vec3().to_array(),
                    color: FEATURE_PREVIEW_COLOR,
                }
            })
            .collect(),
        ..Overlay::default()
    }
}

/// One line describing a curve: id, kind, origin, vertex count, open or closed.
pub fn describe(c: &Curve) -> String {
    let origin = match c.origin {
        CurveOrigin::Drawn => "drawn",
        CurveOrigin::Feature => "sharp feature",
        CurveOrigin::Boundary => "boundary",
    };
    format!(
        "Curve {}: {}, {origin}, {} vertices, {}",
        c.id,
        c.kind.label(),
        c.vertices.len(),
        if c.closed { "closed" } else { "open" }
    )
}

/// The editor's curve views: the cached overlays and the feature panel's settings.
#[derive(Debug)]
pub struct CurvesUi {
    /// The dihedral angle (degrees) of *Detect features* and its preview.
    pub feature_angle: f64,
    /// Show the feature edges at `feature_angle` over the surface.
    pub feature_preview: bool,
    /// (mesh generation, curves, contradiction, curves beside folds) the curve overlay was
    /// built for.
    curves_key: Option<CurvesKey>,
    curves_overlay: Option<Arc<Overlay>>,
    /// (document generation, feature angle, grid size) of the preview shown.
    preview_key: Option<(u64, f64, f64)>,
    /// The crease angles at the grid's scale measured so far, for (document generation, grid
    /// size): a step of the angle slider measures only the edges it adds.
    preview_creases: Option<((u64, f64), crate::constraint::detect::CreaseAngles)>,
    preview_edges: usize,
    /// [`crate::constraint::detect::noise_warning`] of the curves the preview's edges make.
    preview_warning: Option<String>,
    preview_overlay: Option<Arc<Overlay>>,
}

/// What the curve overlay depends on ([`CurvesUi`]).
type CurvesKey = (u64, BTreeMap<u32, Curve>, Vec<u32>, Vec<u32>);

impl Default for CurvesUi {
    fn default() -> Self {
        CurvesUi {
            feature_angle: 35.0,
            feature_preview: false,
            curves_key: None,
            curves_overlay: None,
            preview_key: None,
            preview_creases: None,
            preview_edges: 0,
            preview_warning: None,
            preview_overlay: None,
        }
    }
}

impl EditorApp {
    /// The document's curves as an overlay (rebuilt when they, the contradiction or the curves
    /// beside folds shown change).
    pub fn curves_overlay(&mut self) -> Option<Arc<Overlay>> {
        let doc = &self.document;
        if !doc.display.show_curves {
            return None;
        }
        let (mesh, curves) = (doc.mesh.as_ref()?, doc.curves()?);
        let beside: Vec<u32> = match &doc.folds {
            Some(f) if doc.display.show_folds => f.beside_curves.clone(),
            _ => Vec::new(),
        };
        let ui = &mut self.curves;
        let fresh = ui.curves_key.as_ref().is_some_and(|(g, c, x, b)| {
            *g == doc.generation() && c == curves && *x == doc.contradiction && *b == beside
        });
        if !fresh {
            ui.curves_overlay = (!curves.is_empty())
                .then(|| Arc::new(curves_overlay(mesh, curves, &doc.contradiction, &beside)));
            ui.curves_key = Some((
                doc.generation(),
                curves.clone(),
                doc.contradiction.clone(),
                beside,
            ));
        }
        ui.curves_overlay.clone()
    }

    /// The feature edges at the panel's angle, while the preview is on.
    pub fn feature_preview_overlay(&mut self) -> Option<Arc<Overlay>> {
        if !self.curves.feature_preview {
            return None;
        }
        self.update_feature_preview();
        self.curves.preview_overlay.clone()
    }

    fn update_feature_preview(&mut self) {
        let Some(mesh) = self.document.mesh.as_ref() else {
            return;
        };
        // What `detect_features` will keep: short sets of feature edges are dropped at the
        // grid's scale.
        let scale = self
            .document
            .edit_base
            .as_ref()
            .map_or(0.0, |b| b.grid_size());
        let ui = &mut self.curves;
        let key = (self.document.generation(), ui.feature_angle, scale);
        if ui.preview_key != Some(key) {
            use crate::constraint::detect;
            let creases_key = (key.0, scale);
            if ui.preview_creases.as_ref().map(|(k, _)| *k) != Some(creases_key) {
                ui.preview_creases = Some((creases_key, detect::CreaseAngles::new(mesh, scale)));
            }
            let (_, creases) = ui.preview_creases.as_mut().expect("made above");
            let edges =
                detect::significant_feature_edges_with(mesh, ui.feature_angle, scale, creases);
            ui.preview_edges = edges.len();
            ui.preview_warning = (scale > 0.0)
                .then(|| {
                    let curves = detect::chain_features(mesh, &edges, scale);
                    detect::noise_warning(mesh, curves.iter().map(|c| c.vertices.as_slice()), scale)
                })
                .flatten();
            ui.preview_overlay = Some(Arc::new(feature_overlay(mesh, &edges)));
            ui.preview_key = Some(key);
        }
    }

    /// Switches the viewport tool (the other one keeps its settings, e.g. the new curves' kind).
    pub fn set_tool(&mut self, kind: ToolKind) {
        if kind == self.tool_kind {
            return;
        }
        self.tool.reset();
        let parked = match self.parked_tools.iter().position(|(k, _)| *k == kind) {
            Some(i) => self.parked_tools.remove(i).1,
            None => kind.make(),
        };
        let old = std::mem::replace(&mut self.tool, parked);
        self.parked_tools.push((self.tool_kind, old));
        self.tool_kind = kind;
    }

    /// A tool's answer (a gesture's or its panel's): a refusal becomes the notice, a commit
    /// goes through [`EditorApp::commit_edit`].
    pub(super) fn take_tool_output(&mut self, out: ToolOutput) {
        if let Some(n) = out.notice {
            self.status = format!("{}: refused (see Edits)", self.tool.name());
            self.notice = Some(n);
        } else if let Some(s) = out.status {
            self.status = s;
        }
        if let Some(edit) = out.commit {
            self.commit_edit(edit);
        }
    }

    /// The tool choice and the active tool's controls.
    pub(super) fn tools_section(&mut self, ui: &mut egui::Ui) {
        let mut chosen = self.tool_kind;
        ui.horizontal_wrapped(|ui| {
            for k in ToolKind::ALL {
                ui.selectable_value(&mut chosen, k, k.label())
                    .on_hover_text(k.hint());
            }
        });
        self.set_tool(chosen);
        let picker = {
            let mesh = self.document.mesh.as_ref();
            self.picker
                .as_deref()
                .filter(|p| mesh.is_some_and(|m| p.is_for(m)))
        };
        let cx = ToolContext {
            view: self.last_view,
            document: &self.document,
            picker,
            modifiers: egui::Modifiers::NONE,
        };
        let out = self.tool.panel(&cx, ui);
        self.take_tool_output(out);
    }

    /// Curve counts, sharp-feature detection with its preview, boundary alignment.
    pub(super) fn curves_section(&mut self, ui: &mut egui::Ui) {
        let editable = self.document.editable().is_some();
        let curves = self.document.curves();
        let count =
            |o: CurveOrigin| curves.map_or(0, |c| c.values().filter(|c| c.origin == o).count());
        let (drawn, features, boundary) = (
            count(CurveOrigin::Drawn),
            count(CurveOrigin::Feature),
            count(CurveOrigin::Boundary),
        );
        ui.label(format!(
            "{} curves: {drawn} drawn, {features} sharp features, {boundary} boundary",
            drawn + features + boundary
        ));
        ui.checkbox(&mut self.document.display.show_curves, "Show curves")
            .on_hover_text(
                "Geometric: solid orange; combinatorial: dashed cyan; contradictory: red; \
                 beside folds the repair left (with Folds on): thick magenta",
            );

        ui.label("Sharp features (dihedral angle above)");
        let slider = ui.add(
            egui::Slider::new(&mut self.curves.feature_angle, 10.0..=90.0)
                .step_by(1.0)
                .suffix(" deg")
                .text("Feature angle"),
        );
        if slider.changed() {
            self.curves.feature_preview = true;
        }
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut self.curves.feature_preview, "Preview edges");
            if self.curves.feature_preview {
                self.update_feature_preview();
                ui.label(format!("{} edges", self.curves.preview_edges));
            }
        });
        if self.curves.feature_preview
            && let Some(w) = &self.curves.preview_warning
        {
            ui.colored_label(ui.visuals().warn_fg_color, w);
        }
        let angle = self.curves.feature_angle;
        if ui
            .add_enabled(editable, egui::Button::new("Detect features"))
            .on_hover_text(
                "Replace the sharp-feature curves by the edges above this angle, chained into geometric curves",
            )
            .on_disabled_hover_text("Editing starts when the solve has finished")
            .clicked()
        {
            self.curves.feature_preview = false;
            self.commit_edit(Edit::DetectFeatures { angle_deg: angle });
        }

        let has_boundary = self
            .document
            .stats
            .as_ref()
            .is_some_and(|s| s.boundary_loops > 0);
        let mut on = boundary > 0;
        let was = on;
        ui.add_enabled(
            editable && has_boundary,
            egui::Checkbox::new(&mut on, "Align to boundary"),
        )
        .on_hover_text("Every boundary loop as geometric curves, split at sharp corners")
        .on_disabled_hover_text(if has_boundary {
            "Editing starts when the solve has finished"
        } else {
            "The mesh has no boundary"
        });
        if on != was {
            self.commit_edit(Edit::AlignBoundary { on });
        }
        if !self.document.contradiction.is_empty()
            && let Some(e) = &self.document.solve_error
        {
            ui.colored_label(
                egui::Color32::from_rgb(240, 70, 60),
                plain(&format!("Contradictory curves (red): {e}")),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dashes_cover_sixty_percent_of_the_length_across_vertices() {
        let points = [
            Vec3::ZERO,
            Vec3::new(1.05, 0.0, 0.0),
            Vec3::new(1.05, 2.0, 0.0),
        ];
        let mut total = 0.0;
        let mut n = 0;
        dashes(&points, 0.1, &mut |a, b| {
            total += (b - a).length();
            n += 1;
        });
        // 31 dashes (the last one 0.05 long), the one at 1.0..1.06 split at the corner
        assert!((total - (30.0 * 0.06 + 0.05)).abs() < 1e-3, "{total}");
        assert_eq!(n, 32);
    }

    #[test]
    fn styles_differ_by_kind_and_contradictions_are_red() {
        let mesh = crate::mesh::generate::grid(4, 4, 1.0, 1.0);
        let curve = |id, kind| Curve {
            id,
            vertices: vec![0, 1, 2, 3],
            closed: false,
            kind,
            origin: CurveOrigin::Drawn,
        };
        let curves: BTreeMap<u32, Curve> = [
            (0, curve(0, CurveKind::Geometric)),
            (1, curve(1, CurveKind::Combinatorial)),
        ]
        .into();
        let o = curves_overlay(&mesh, &curves, &[], &[]);
        assert_eq!(o.thick_lines.len(), 3);
        assert!(o.thick_lines.iter().all(|l| l.color == GEOMETRIC_COLOR));
        assert!(o.lines.len() > 3, "dashed: more pieces than edges");
        assert!(o.lines.iter().all(|l| l.color == COMBINATORIAL_COLOR));
        let red = curves_overlay(&mesh, &curves, &[1], &[]);
        assert_eq!(red.lines.len(), 0);
        assert!(
            red.thick_lines
                .iter()
                .filter(|l| l.color == CONTRADICTION_COLOR)
                .count()
                > 3
        );
        // Beside folds: thick in the folds' colour (a contradiction's red wins).
        let fold = crate::app::folds::FOLD_COLOR;
        let beside = curves_overlay(&mesh, &curves, &[], &[0]);
        assert_eq!(beside.thick_lines.len(), 3);
        assert!(beside.thick_lines.iter().all(|l| l.color == fold));
        assert!(beside.lines.iter().all(|l| l.color == COMBINATORIAL_COLOR));
        let both = curves_overlay(&mesh, &curves, &[1], &[0, 1]);
        assert_eq!(
            both.thick_lines.iter().filter(|l| l.color == fold).count(),
            3
        );
        assert!(
            both.thick_lines
                .iter()
                .filter(|l| l.color == CONTRADICTION_COLOR)
                .count()
                > 3
        );
    }
}
