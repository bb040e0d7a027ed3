//! The curve tool (thesis sec. 4.4): draws constraint curves over mesh edges, and selects,
//! retypes and deletes them.
//!
//! - **Clicks.** A click on the surface picks the nearest vertex of the face under the cursor
//!   and starts a curve there; every further click extends it by a shortest edge path from its
//!   last vertex, previewed live from the last vertex to the vertex under the cursor. Clicking
//!   the first vertex closes the curve; Enter or a double click finishes an open one;
//!   Backspace / Delete takes back the last click; Esc aborts the curve.
//! - **Strokes.** Pressing on the surface and dragging draws a stroke: the vertices under the
//!   cursor are joined by shortest edge paths (repeats dropped); the release commits it (closed
//!   when it ends where it began). Pressing off the surface orbits the camera, as always.
//! - **Selection.** Without a curve in progress, a click near a curve (a few points on screen,
//!   [`Picker::pick_curve`](crate::app::picking::Picker::pick_curve)) selects it instead of
//!   starting one (Ctrl+click starts one there anyway); Delete removes it, the panel switches
//!   it between geometric and combinatorial and describes it. Esc drops the selection.
//!
//! A curve never uses an edge twice ([`check_path`]): where the shortest path to a click would
//! reuse one (typically the curve's own last edge, where it turns back), the shortest path
//! that avoids the curve's edges is taken; a click with no such path is refused with a notice,
//! a stroke skips such vertices. One finished curve is one [`Edit::AddCurve`] (file
//! vertex indices; id one more than the largest in use), of the kind the panel's toggle says.

use std::sync::Arc;

use super::{Tool, ToolContext, ToolEvent, ToolOutput, next_overlay_revision};
use crate::app::curves::{self, HOVERED_COLOR, LineStyle, REFUSED_COLOR, SELECTED_COLOR};
use crate::app::picking::project;
use crate::app::scene::Overlay;
use crate::constraint::{
    Curve, CurveKind, check_path, edge_key, path_edges, shortest_edge_path,
    shortest_edge_path_avoiding,
};
use crate::edit::Edit;
use crate::mesh::TriMesh;

/// How near (points) the cursor must be to a curve's edge to pick the curve.
pub const CURVE_PICK_RADIUS_PX: f32 = 6.0;
/// How far (points) the pointer must move with the button down for a stroke instead of a click.
pub const DRAG_THRESHOLD_PX: f32 = 4.0;

#[derive(Clone, Copy, Debug, Default, PartialEq)]
enum Gesture {
    #[default]
    None,
    /// The button went down on the surface over `vertex` and has not moved far yet; `finish`:
    /// a double click arrived before the release.
    Pressed {
        at: egui::Pos2,
        vertex: usize,
        finish: bool,
    },
    /// A stroke; `from_idle`: it started a new curve (committed on release) rather than
    /// extending the one in progress.
    Stroke { from_idle: bool },
    /// Esc during a press: the rest of it (until the release) is swallowed.
    Cancelled,
}

/// What the tool's overlay shows (it is rebuilt when this changes).
#[derive(Clone, Debug, PartialEq)]
struct OverlayKey {
    generation: u64,
    kind: CurveKind,
    points: Vec<usize>,
    preview: Option<(Vec<usize>, bool)>,
    selected: Option<Curve>,
    hovered: Option<Curve>,
}

/// See the module documentation.
#[derive(Debug, Default)]
pub struct DrawCurveTool {
    /// The kind of new curves.
    pub kind: CurveKind,
    /// The curve in progress (mesh vertices, an open edge path); empty when none.
    points: Vec<usize>,
    /// `points.len()` after each click or stroke piece (Backspace takes one back).
    anchors: Vec<usize>,
    gesture: Gesture,
    /// The vertex under the cursor while drawing, and the path from the last vertex to it
    /// (with whether a click there is accepted).
    hover_vertex: Option<usize>,
    preview: Option<(Vec<usize>, bool)>,
    /// The curve under the cursor when not drawing.
    hover_curve: Option<u32>,
    last_hover: Option<egui::Pos2>,
    selected: Option<u32>,
    overlay: Option<Arc<Overlay>>,
    overlay_key: Option<OverlayKey>,
}

/// A mesh vertex as the file numbers it (what the user sees everywhere).
fn file_vertex(cx: &ToolContext, v: usize) -> usize {
    cx.document
        .edit_base
        .as_ref()
        .filter(|b| v < b.mesh().n_vertices())
        .map_or(v, |b| b.file_vertex(v))
}

impl DrawCurveTool {
    pub fn new() -> DrawCurveTool {
        DrawCurveTool::default()
    }

    /// The curve in progress (mesh vertices).
    pub fn points(&self) -> &[usize] {
        &self.points
    }

    /// The preview path from the last vertex to the one under the cursor, and whether a click
    /// there is accepted.
    pub fn preview(&self) -> Option<(&[usize], bool)> {
        self.preview.as_ref().map(|(p, ok)| (p.as_slice(), *ok))
    }

    fn curve_at(cx: &ToolContext, pos: egui::Pos2) -> Option<u32> {
        cx.picker?.pick_curve(
            &cx.view,
            pos,
            cx.document.curves()?.values(),
            CURVE_PICK_RADIUS_PX,
        )
    }

    fn vertex_at(cx: &ToolContext, pos: egui::Pos2) -> Option<usize> {
        cx.picker?.pick(&cx.view, pos).map(|h| h.vertex)
    }

    /// The path the curve in progress takes to `v`: a shortest edge path, or when that would
    /// use an edge of the curve again (it often does where the curve turns back, e.g. its last
    /// edge), the shortest path that does not. `None` when there is neither.
    fn path_to(&self, mesh: &TriMesh, v: usize) -> Option<Vec<usize>> {
        let last = *self.points.last()?;
        let path = shortest_edge_path(mesh, last, v)?;
        let used = path_edges(&self.points);
        if path
            .windows(2)
            .all(|w| !used.contains(&edge_key(w[0], w[1])))
        {
            return Some(path);
        }
        shortest_edge_path_avoiding(mesh, last, v, &used)
    }

    /// The curve in progress extended to `v` ([`DrawCurveTool::path_to`]), checked.
    fn extended(&self, cx: &ToolContext, mesh: &TriMesh, v: usize) -> Result<Vec<usize>, String> {
        let path = self.path_to(mesh, v).ok_or_else(|| {
            format!(
                "vertex {} cannot be reached without using an edge of the curve twice",
                file_vertex(cx, v)
            )
        })?;
        let mut c = self.points.clone();
        c.extend_from_slice(&path[1..]);
        check_path(mesh, &c, false).map_err(|why| format!("the curve would be broken: {why}"))?;
        Ok(c)
    }

    /// The curve in progress closed by a path back to its first vertex, checked (the first
    /// vertex is not repeated).
    fn closed(&self, mesh: &TriMesh) -> Result<Vec<usize>, String> {
        let path = self
            .path_to(mesh, self.points[0])
            .ok_or("the curve cannot be closed without using one of its edges twice")?;
        let mut c = self.points.clone();
        c.extend_from_slice(&path[1..path.len() - 1]);
        if c.len() < 3 {
            return Err("a closed curve needs at least three vertices".into());
        }
        check_path(mesh, &c, true).map_err(|why| format!("the curve would be broken: {why}"))?;
        Ok(c)
    }

    /// Extends the curve in progress to `v` (starts one when there is none).
    fn extend(&mut self, cx: &ToolContext, mesh: &TriMesh, v: usize) -> Result<(), String> {
        match self.points.last() {
            None => self.points = vec![v],
            Some(&last) if last == v => return Ok(()),
            Some(_) => self.points = self.extended(cx, mesh, v)?,
        }
        self.anchors.push(self.points.len());
        Ok(())
    }

    fn abort(&mut self) {
        self.points.clear();
        self.anchors.clear();
        self.preview = None;
        self.hover_vertex = None;
    }

    /// Hands the curve `vertices` (mesh indices) to the document as one edit.
    fn commit(
        &mut self,
        cx: &ToolContext,
        vertices: Vec<usize>,
        closed: bool,
        out: &mut ToolOutput,
    ) {
        let Some((base, state)) = cx.document.editable() else {
            out.notice = Some("Wait for the solve to finish before adding curves".into());
            return;
        };
        if let Err(why) = check_path(base.mesh(), &vertices, closed) {
            out.notice = Some(format!("Curve refused: {why}"));
            return;
        }
        let id = state.curves.keys().next_back().map_or(0, |&k| k + 1);
        out.commit = Some(Edit::AddCurve {
            id,
            vertices: vertices.iter().map(|&v| base.file_vertex(v)).collect(),
            closed,
            kind: self.kind,
        });
        self.abort();
        self.selected = Some(id);
    }

    /// Enter, a double click, the panel's Finish: commits the open curve in progress.
    fn finish(&mut self, cx: &ToolContext, out: &mut ToolOutput) {
        if self.points.is_empty() {
            return;
        }
        if self.points.len() < 2 {
            out.notice = Some("A curve needs at least two vertices: click another one".into());
            return;
        }
        self.commit(cx, self.points.clone(), false, out);
    }

    /// A click (press and release without a drag) on `vertex`, at `pos`.
    fn click(
        &mut self,
        cx: &ToolContext,
        mesh: &TriMesh,
        pos: egui::Pos2,
        vertex: usize,
        out: &mut ToolOutput,
    ) {
        if self.points.is_empty() {
            if !cx.modifiers.command
                && let Some(id) = Self::curve_at(cx, pos)
            {
                self.selected = Some(id);
                out.status = Some(format!("Curve {id} selected"));
                return;
            }
            self.selected = None;
            self.points = vec![vertex];
            self.anchors = vec![1];
            out.status = Some(format!(
                "Curve started at vertex {}: click to extend it, click its first vertex to close it, Enter finishes it",
                file_vertex(cx, vertex)
            ));
            return;
        }
        if vertex == self.points[0] && self.points.len() >= 2 {
            match self.closed(mesh) {
                Ok(c) => self.commit(cx, c, true, out),
                Err(why) => out.notice = Some(format!("Refused: {why}")),
            }
            return;
        }
        if let Err(why) = self.extend(cx, mesh, vertex) {
            out.notice = Some(format!("Refused: {why}"));
        }
    }

    /// A stroke reached `pos`: the vertex there joins the curve when it can.
    fn stroke_to(&mut self, cx: &ToolContext, mesh: &TriMesh, pos: egui::Pos2) {
        if let Some(v) = Self::vertex_at(cx, pos) {
            // a vertex whose path would reuse an edge (the stroke doubled back) is skipped
            let _ = self.extend(cx, mesh, v);
        }
    }

    /// The release of a stroke that started a curve: commits it (closed when it came back to
    /// its first vertex).
    fn finish_stroke(&mut self, cx: &ToolContext, mesh: &TriMesh, out: &mut ToolOutput) {
        let n = self.points.len();
        if n < 2 {
            return; // a stroke that never left its vertex: a started curve, as after a click
        }
        if n >= 4 && self.points[0] == self.points[n - 1] {
            let c = self.points[..n - 1].to_vec();
            if check_path(mesh, &c, true).is_ok() {
                self.commit(cx, c, true, out);
                return;
            }
        }
        self.commit(cx, self.points.clone(), false, out);
    }

    /// The hover state for the cursor at `pos`: the curve under it, or the preview path.
    fn update_hover(&mut self, cx: &ToolContext, mesh: &TriMesh, pos: Option<egui::Pos2>) {
        if self.points.is_empty() {
            self.hover_vertex = None;
            self.preview = None;
            self.hover_curve = pos.and_then(|p| Self::curve_at(cx, p));
            return;
        }
        self.hover_curve = None;
        let v = pos.and_then(|p| Self::vertex_at(cx, p));
        if v == self.hover_vertex {
            return;
        }
        self.hover_vertex = v;
        // A Dijkstra or two: only when the vertex under the cursor changes.
        self.preview = v.and_then(|v| {
            let last = *self.points.last()?;
            if v == last {
                return None;
            }
            let ok = if v == self.points[0] && self.points.len() >= 2 {
                self.closed(mesh).is_ok()
            } else {
                self.extended(cx, mesh, v).is_ok()
            };
            match self.path_to(mesh, v) {
                Some(path) => Some((path, ok)),
                None => Some((shortest_edge_path(mesh, last, v)?, false)),
            }
        });
    }

    /// Drops a selection whose curve is gone (unless an edit is being committed: the document
    /// has not seen it yet) and rebuilds the overlay when what it shows changed.
    fn sync(&mut self, cx: &ToolContext, committing: bool) {
        let curves = cx.document.curves();
        // Only the current state decides: while the job applies a just committed curve, the
        // state shown is the one before it.
        if let (Some(id), Some(state)) = (self.selected, cx.document.current_state())
            && !state.curves.contains_key(&id)
            && !committing
        {
            self.selected = None;
        }
        let Some(mesh) = cx.document.mesh.as_ref() else {
            self.overlay = None;
            self.overlay_key = None;
            return;
        };
        let get = |id: Option<u32>| id.and_then(|id| curves?.get(&id).cloned());
        let key = OverlayKey {
            generation: cx.document.generation(),
            kind: self.kind,
            points: self.points.clone(),
            preview: self.preview.clone(),
            selected: get(self.selected),
            hovered: get(self.hover_curve.filter(|&h| Some(h) != self.selected)),
        };
        if self.overlay_key.as_ref() == Some(&key) {
            return;
        }
        self.overlay = build_overlay(mesh, &key).map(Arc::new);
        self.overlay_key = Some(key);
    }
}

/// The tool's overlay: the hovered and the selected curve highlighted, the curve in progress
/// (thick, in its kind's colour) and the preview path (thin; red when a click would be refused).
fn build_overlay(mesh: &TriMesh, key: &OverlayKey) -> Option<Overlay> {
    let period = curves::dash_period(mesh);
    let mut o = Overlay {
        revision: next_overlay_revision(),
        ..Overlay::default()
    };
    let dashes = |kind: CurveKind| (kind == CurveKind::Combinatorial).then_some(period);
    for (c, color) in [
        (&key.hovered, HOVERED_COLOR),
        (&key.selected, SELECTED_COLOR),
    ] {
        if let Some(c) = c {
            let style = LineStyle {
                color,
                thick: true,
                dashes: dashes(c.kind),
            };
            curves::push_polyline(&mut o, mesh, &c.vertices, c.closed, style);
        }
    }
    let style = LineStyle {
        thick: true,
        ..LineStyle::of_kind(key.kind, period)
    };
    curves::push_polyline(&mut o, mesh, &key.points, false, style);
    if let Some((path, ok)) = &key.preview {
        let mut color = curves::kind_color(key.kind);
        color[3] = 0.7;
        let style = LineStyle {
            color: if *ok { color } else { REFUSED_COLOR },
            thick: false,
            dashes: None,
        };
        curves::push_polyline(&mut o, mesh, path, false, style);
    }
    (!o.is_empty()).then_some(o)
}

impl Tool for DrawCurveTool {
    fn name(&self) -> &'static str {
        "Draw curves"
    }

    fn event(&mut self, cx: &ToolContext, event: ToolEvent) -> ToolOutput {
        let mut out = ToolOutput::default();
        let Some(mesh) = cx.document.mesh.clone() else {
            return out;
        };
        match event {
            ToolEvent::Hover(pos) => {
                if self.gesture == Gesture::None && pos != self.last_hover {
                    self.last_hover = pos;
                    self.update_hover(cx, &mesh, pos);
                }
            }
            ToolEvent::Press(pos) => {
                // off the surface: not claimed, the camera orbits
                if let Some(vertex) = Self::vertex_at(cx, pos) {
                    self.gesture = Gesture::Pressed {
                        at: pos,
                        vertex,
                        finish: false,
                    };
                    out.captured = true;
                }
            }
            ToolEvent::Drag(pos) => match self.gesture {
                Gesture::Pressed { at, vertex, .. } => {
                    out.captured = true;
                    if pos.distance(at) > DRAG_THRESHOLD_PX {
                        let from_idle = self.points.is_empty();
                        if from_idle {
                            self.selected = None;
                        }
                        self.gesture = Gesture::Stroke { from_idle };
                        self.preview = None;
                        let _ = self.extend(cx, &mesh, vertex);
                        self.stroke_to(cx, &mesh, pos);
                    }
                }
                Gesture::Stroke { .. } => {
                    out.captured = true;
                    self.stroke_to(cx, &mesh, pos);
                }
                Gesture::Cancelled => out.captured = true,
                Gesture::None => {}
            },
            ToolEvent::Release(pos) => {
                let gesture = std::mem::take(&mut self.gesture);
                out.captured = gesture != Gesture::None;
                match gesture {
                    Gesture::Pressed { vertex, finish, .. } => {
                        self.click(cx, &mesh, pos, vertex, &mut out);
                        if finish && out.commit.is_none() {
                            self.finish(cx, &mut out);
                        }
                    }
                    Gesture::Stroke { from_idle } => {
                        self.stroke_to(cx, &mesh, pos);
                        if from_idle {
                            self.finish_stroke(cx, &mesh, &mut out);
                        }
                    }
                    Gesture::Cancelled | Gesture::None => {}
                }
                self.hover_vertex = None;
                self.last_hover = None;
                self.update_hover(cx, &mesh, Some(pos));
            }
            ToolEvent::Cancel => {
                if self.gesture != Gesture::None {
                    self.gesture = Gesture::Cancelled;
                    out.captured = true;
                }
                if !self.points.is_empty() {
                    self.abort();
                    out.status = Some("Curve aborted".into());
                } else if self.gesture == Gesture::None {
                    self.selected = None;
                }
            }
            ToolEvent::Finish => {
                if self.gesture == Gesture::None {
                    self.finish(cx, &mut out);
                }
            }
            ToolEvent::DoubleClick(_) => match &mut self.gesture {
                Gesture::Pressed { finish, .. } => *finish = true,
                Gesture::None => self.finish(cx, &mut out),
                _ => {}
            },
            ToolEvent::Delete if self.gesture == Gesture::None => {
                if !self.points.is_empty() {
                    self.anchors.pop();
                    let keep = self.anchors.last().copied().unwrap_or(0);
                    self.points.truncate(keep);
                    self.hover_vertex = None;
                    self.last_hover = None;
                    self.preview = None;
                } else if let Some(id) = self.selected {
                    out.commit = Some(Edit::RemoveCurve { id });
                }
            }
            ToolEvent::Delete => {}
        }
        self.sync(cx, out.commit.is_some());
        out
    }

    fn active(&self) -> bool {
        self.gesture != Gesture::None
    }

    fn overlay(&self) -> Option<Arc<Overlay>> {
        self.overlay.clone()
    }

    fn paint(&self, cx: &ToolContext, ui: &mut egui::Ui) {
        let Some(mesh) = cx.document.mesh.as_ref() else {
            return;
        };
        let screen = |v: usize| {
            (v < mesh.n_vertices())
                .then(|| project(&cx.view, mesh.position(v).as_vec3()))
                .flatten()
        };
        let ring = |ui: &mut egui::Ui, v: usize, r: f32, color: egui::Color32| {
            if let Some(s) = screen(v) {
                ui.painter()
                    .circle_stroke(s, r, egui::Stroke::new(2.0, color));
            }
        };
        let closing = self.points.len() >= 2 && self.hover_vertex == self.points.first().copied();
        if let Some(&first) = self.points.first() {
            ring(
                ui,
                first,
                if closing { 9.0 } else { 6.0 },
                egui::Color32::WHITE,
            );
        }
        if let Some(v) = self.hover_vertex.filter(|_| !closing) {
            ring(ui, v, 5.0, egui::Color32::from_gray(220));
        }
        let text = match (&self.preview, self.hover_curve) {
            (Some((path, ok)), _) if self.gesture == Gesture::None => {
                let edges = path.len().saturating_sub(1);
                Some(match (ok, closing) {
                    (true, true) => "Click: close the curve".to_string(),
                    (true, false) => format!("Click: {edges} more edges"),
                    (false, _) => "Refused: this would use an edge of the curve twice".into(),
                })
            }
            (None, Some(id)) if self.points.is_empty() => {
                cx.document.curves().and_then(|c| c.get(&id)).map(|c| {
                    match self.selected == Some(id) {
                        true => format!(
                            "Curve {id} ({}), selected: Delete removes it",
                            c.kind.label()
                        ),
                        false => format!("Curve {id} ({}): click to select", c.kind.label()),
                    }
                })
            }
            _ => None,
        };
        let anchor = ui.input(|i| i.pointer.hover_pos());
        if let (Some(text), Some(anchor)) = (text, anchor.filter(|p| cx.view.rect.contains(*p))) {
            egui::Area::new(egui::Id::unique("quadcover curve tool tooltip"))
                .order(egui::Order::Tooltip)
                .fixed_pos(anchor + egui::vec2(16.0, 16.0))
                .interactable(false)
                .show(ui.ctx(), |ui| {
                    egui::Frame::popup(ui.style()).show(ui, |ui| {
                        ui.add(egui::Label::new(text).wrap_mode(egui::TextWrapMode::Extend));
                    });
                });
        }
    }

    fn reset(&mut self) {
        self.gesture = Gesture::None;
        self.abort();
        self.hover_curve = None;
        self.last_hover = None;
        self.overlay_key = None;
    }

    fn clear_selection(&mut self) {
        self.selected = None;
    }

    fn selected_curve(&self) -> Option<u32> {
        self.selected
    }

    fn panel(&mut self, cx: &ToolContext, ui: &mut egui::Ui) -> ToolOutput {
        let mut out = ToolOutput::default();
        ui.horizontal_wrapped(|ui| {
            ui.label("New curves:");
            for k in [CurveKind::Geometric, CurveKind::Combinatorial] {
                let mut text = k.label().to_string();
                text[..1].make_ascii_uppercase();
                ui.selectable_value(&mut self.kind, k, text);
            }
        });
        let editable = cx.document.editable().is_some();
        if self.points.is_empty() {
            ui.weak(
                "Click vertices to draw a curve (click its first vertex to close it; Enter or a \
                 double click finishes it), or drag a stroke over the surface. A click on a \
                 curve selects it (Ctrl+click starts a curve there). Dragging off the surface \
                 orbits.",
            );
        } else {
            let n = self.points.len();
            ui.label(format!("Drawing: {n} vertices, {} edges", n - 1));
            let (mut finish, mut back, mut abort) = (false, false, false);
            ui.horizontal_wrapped(|ui| {
                finish = ui.button("Finish (Enter)").clicked();
                back = ui.button("Back (Backspace)").clicked();
                abort = ui.button("Abort (Esc)").clicked();
            });
            if finish {
                self.finish(cx, &mut out);
            } else if back {
                out.merge(self.event(cx, ToolEvent::Delete));
            } else if abort {
                self.abort();
            }
        }
        let selected = self
            .selected
            .and_then(|id| cx.document.curves()?.get(&id).cloned());
        match selected {
            Some(c) => {
                ui.label(curves::describe(&c));
                ui.horizontal_wrapped(|ui| {
                    let to = c.kind.toggled();
                    if ui
                        .add_enabled(editable, egui::Button::new(format!("Make {}", to.label())))
                        .clicked()
                    {
                        out.commit = Some(Edit::SetCurveKind { id: c.id, kind: to });
                    }
                    if ui
                        .add_enabled(editable, egui::Button::new("Delete curve (Del)"))
                        .clicked()
                    {
                        out.commit = Some(Edit::RemoveCurve { id: c.id });
                    }
                });
            }
            None => {
                ui.weak("No curve selected");
            }
        }
        self.sync(cx, out.commit.is_some());
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn a_curve_turning_back_takes_a_detour_and_closes_with_two_clicks() {
        let m = generate::grid(4, 4, 1.0, 1.0);
        let tool = DrawCurveTool {
            points: vec![0, 1, 2],
            anchors: vec![1, 3],
            ..DrawCurveTool::default()
        };
        // back towards 1: the shortest path reuses edge 2-1, the detour does not
        let p = tool.path_to(&m, 1).unwrap();
        assert_eq!((p[0], *p.last().unwrap()), (2, 1));
        assert!(p.len() > 2);
        let mut c = tool.points.clone();
        c.extend_from_slice(&p[1..]);
        assert!(check_path(&m, &c, false).is_ok());
        // closing back to 0 goes round instead of back along the curve
        let closed = tool.closed(&m).unwrap();
        assert!(closed.len() >= 4);
        assert!(check_path(&m, &closed, true).is_ok());
    }
}
