//! The move-singularity tool (thesis sec. 3.3): hover a singularity glyph to see its vertex and
//! index; press on it and drag for a live preview of the edge path to the vertex under the
//! cursor (or the merge with the singularity there, or why it is refused); release commits one
//! [`Edit::MoveSingularity`]; Esc abandons the drag. A press elsewhere is not claimed, so the
//! camera orbits.

use std::sync::Arc;

use super::{Tool, ToolContext, ToolEvent, ToolOutput, next_overlay_revision};
use crate::app::document::LineKind;
use crate::app::picking::project;
use crate::app::scene::{Glyph, LineSegment, Overlay, singularity_color};
use crate::edit::{Edit, MovePreview};

/// How near (points) the cursor must be to a glyph to pick it.
pub const PICK_RADIUS_PX: f32 = 10.0;

#[derive(Clone, Debug, Default)]
enum State {
    #[default]
    Idle,
    /// The cursor is over a singularity (mesh vertex).
    Hover(usize),
    Dragging(Drag),
    /// Esc abandoned the drag; the rest of the gesture (until the release) is swallowed so
    /// the camera does not start orbiting.
    Cancelled,
}

#[derive(Clone, Debug)]
struct Drag {
    /// Mesh vertex of the singularity being moved, and its index numerator.
    from: usize,
    k: i32,
    cursor: egui::Pos2,
    /// The vertex under the cursor (mesh index) and whether it is a singularity glyph.
    target: Option<(usize, Option<i32>)>,
    preview: Option<MovePreview>,
    overlay: Option<Arc<Overlay>>,
}

/// See the module documentation.
#[derive(Debug, Default)]
pub struct MoveSingularityTool {
    state: State,
}

impl MoveSingularityTool {
    pub fn new() -> MoveSingularityTool {
        MoveSingularityTool::default()
    }

    /// The singularity the cursor is over (mesh vertex), when hovering or dragging from one.
    pub fn hovered(&self) -> Option<usize> {
        match &self.state {
            State::Hover(v) => Some(*v),
            State::Dragging(d) => Some(d.from),
            State::Idle | State::Cancelled => None,
        }
    }

    /// The preview of the drag in progress.
    pub fn preview(&self) -> Option<&MovePreview> {
        match &self.state {
            State::Dragging(d) => d.preview.as_ref(),
            _ => None,
        }
    }

    /// The singularity glyph under `pos` (mesh vertex), among the current state's.
    fn pick_singularity(cx: &ToolContext, pos: egui::Pos2, except: Option<usize>) -> Option<usize> {
        let picker = cx.picker?;
        let candidates: Vec<usize> = match cx.document.current_state() {
            Some(s) => s.singularities.keys().copied().collect(),
            None => cx
                .document
                .field
                .as_ref()
                .map(|f| f.singularities.iter().map(|s| s.vertex).collect())
                .unwrap_or_default(),
        };
        picker.pick_vertex_glyph(
            &cx.view,
            pos,
            candidates.into_iter().filter(|&v| Some(v) != except),
            PICK_RADIUS_PX,
        )
    }

    /// Updates the drag's target and preview for the cursor at `pos`.
    fn update_drag(cx: &ToolContext, drag: &mut Drag, pos: egui::Pos2) {
        drag.cursor = pos;
        let Some((base, state)) = cx.document.editable() else {
            return;
        };
        let target = match Self::pick_singularity(cx, pos, Some(drag.from)) {
            Some(v) => Some(v),
            None => cx
                .picker
                .and_then(|p| p.pick(&cx.view, pos))
                .map(|h| h.vertex),
        };
        let target = target.map(|v| (v, state.singularities.get(&v).copied()));
        if target.map(|t| t.0) == drag.target.map(|t| t.0) {
            return;
        }
        drag.target = target;
        // The preview is a Dijkstra: computed only when the hovered vertex changes.
        drag.preview = match target {
            Some((v, _)) if v != drag.from => Some(base.preview_move(state, drag.from, v)),
            _ => None,
        };
        drag.overlay = drag.preview.as_ref().map(|p| {
            let mesh = base.mesh();
            let color = LineKind::Selection.color();
            let lines = p
                .path
                .windows(2)
                .map(|w| LineSegment {
                    a: mesh.position(w[0]).as_vec3().to_array(),
                    b: mesh.position(w[1]).as_vec3().to_array(),
                    color,
                })
                .collect();
            let mut glyphs = Vec::new();
            if let (Ok(Some(k)), Some(&q)) = (&p.result, p.path.last())
                && *k != 0
            {
                glyphs.push(Glyph {
                    position: mesh.position(q).as_vec3().to_array(),
                    color: singularity_color(*k, base.settings().symmetry),
                });
            }
            Arc::new(Overlay {
                revision: next_overlay_revision(),
                lines,
                glyphs,
                ..Overlay::default()
            })
        });
    }

    fn tooltip(&self, cx: &ToolContext) -> Option<String> {
        let (base, state) = cx.document.editable()?;
        let n = base.settings().symmetry;
        let index = |k: i32| format!("{}{k}/{n}", if k > 0 { "+" } else { "" });
        match &self.state {
            State::Idle | State::Cancelled => None,
            State::Hover(v) => {
                let k = state.singularities.get(v)?;
                Some(format!(
                    "Singularity at vertex {}, index {}\nDrag it to move or merge it",
                    base.file_vertex(*v),
                    index(*k)
                ))
            }
            State::Dragging(d) => {
                let from = base.file_vertex(d.from);
                let Some((to, at_target)) = d.target else {
                    return Some(format!(
                        "Moving the singularity at vertex {from} ({})",
                        index(d.k)
                    ));
                };
                let to_file = base.file_vertex(to);
                let Some(p) = &d.preview else {
                    return Some(format!("Vertex {to_file}: release here to keep it"));
                };
                Some(match (&p.result, at_target) {
                    (Err(why), _) => format!("Refused: {why}"),
                    (Ok(None), _) => {
                        format!("Vertex {to_file}: the singularity leaves through the boundary")
                    }
                    (Ok(Some(0)), Some(k2)) => {
                        format!("Merge with {} at vertex {to_file}: both cancel", index(k2))
                    }
                    (Ok(Some(k)), Some(k2)) => format!(
                        "Merge with {} at vertex {to_file}: index {} there",
                        index(k2),
                        index(*k)
                    ),
                    (Ok(Some(k)), None) => format!(
                        "Move {from} -> {to_file} ({} edges): index {} there",
                        p.path.len().saturating_sub(1),
                        index(*k)
                    ),
                })
            }
        }
    }
}

impl Tool for MoveSingularityTool {
    fn name(&self) -> &'static str {
        "Move singularity"
    }

    fn event(&mut self, cx: &ToolContext, event: ToolEvent) -> ToolOutput {
        let mut out = ToolOutput::default();
        match event {
            ToolEvent::Hover(pos) => {
                if !matches!(self.state, State::Dragging(_) | State::Cancelled) {
                    self.state = match pos.and_then(|p| Self::pick_singularity(cx, p, None)) {
                        Some(v) => State::Hover(v),
                        None => State::Idle,
                    };
                }
            }
            ToolEvent::Press(pos) => {
                let Some(v) = Self::pick_singularity(cx, pos, None) else {
                    self.state = State::Idle;
                    return out;
                };
                let Some((_, state)) = cx.document.editable() else {
                    out.notice =
                        Some("Wait for the solve to finish before moving singularities".into());
                    return out;
                };
                let Some(&k) = state.singularities.get(&v) else {
                    return out;
                };
                let mut drag = Drag {
                    from: v,
                    k,
                    cursor: pos,
                    target: None,
                    preview: None,
                    overlay: None,
                };
                Self::update_drag(cx, &mut drag, pos);
                self.state = State::Dragging(drag);
                out.captured = true;
            }
            ToolEvent::Drag(pos) => match &mut self.state {
                State::Dragging(d) => {
                    Self::update_drag(cx, d, pos);
                    out.captured = true;
                }
                State::Cancelled => out.captured = true,
                _ => {}
            },
            ToolEvent::Release(_) if matches!(self.state, State::Cancelled) => {
                self.state = State::Idle;
                out.captured = true;
            }
            ToolEvent::Release(pos) => {
                if let State::Dragging(mut d) = std::mem::take(&mut self.state) {
                    Self::update_drag(cx, &mut d, pos);
                    out.captured = true;
                    if let (Some((base, _)), Some((to, _)), Some(p)) =
                        (cx.document.editable(), d.target, &d.preview)
                    {
                        match &p.result {
                            Ok(_) => {
                                out.commit = Some(Edit::MoveSingularity {
                                    from: base.file_vertex(d.from),
                                    to: base.file_vertex(to),
                                });
                            }
                            Err(why) => out.notice = Some(why.clone()),
                        }
                    }
                    self.state = match Self::pick_singularity(cx, pos, None) {
                        Some(v) if out.commit.is_none() => State::Hover(v),
                        _ => State::Idle,
                    };
                }
            }
            ToolEvent::Cancel => {
                if matches!(self.state, State::Dragging(_)) {
                    out.captured = true;
                    out.status = Some("Move cancelled".into());
                    self.state = State::Cancelled;
                } else if !matches!(self.state, State::Cancelled) {
                    self.state = State::Idle;
                }
            }
            ToolEvent::Finish | ToolEvent::DoubleClick(_) | ToolEvent::Delete => {}
        }
        out
    }

    fn active(&self) -> bool {
        matches!(self.state, State::Dragging(_) | State::Cancelled)
    }

    fn overlay(&self) -> Option<Arc<Overlay>> {
        match &self.state {
            State::Dragging(d) => d.overlay.clone(),
            _ => None,
        }
    }

    fn paint(&self, cx: &ToolContext, ui: &mut egui::Ui) {
        let Some(mesh) = cx.document.mesh.as_ref() else {
            return;
        };
        let ring = |ui: &mut egui::Ui, v: usize, color: egui::Color32| {
            if v < mesh.n_vertices()
                && let Some(s) = project(&cx.view, mesh.position(v).as_vec3())
            {
                ui.painter()
                    .circle_stroke(s, PICK_RADIUS_PX, egui::Stroke::new(2.5, color));
            }
        };
        let (anchor, rings): (Option<egui::Pos2>, Vec<(usize, egui::Color32)>) = match &self.state {
            State::Idle | State::Cancelled => (None, Vec::new()),
            State::Hover(v) => (
                project(&cx.view, mesh.position(*v).as_vec3()),
                vec![(*v, egui::Color32::WHITE)],
            ),
            State::Dragging(d) => {
                let mut r = vec![(d.from, egui::Color32::WHITE)];
                if let Some((t, _)) = d.target {
                    let ok = d.preview.as_ref().is_none_or(|p| p.result.is_ok());
                    r.push((
                        t,
                        if ok {
                            egui::Color32::from_rgb(255, 150, 30)
                        } else {
                            egui::Color32::from_rgb(230, 40, 40)
                        },
                    ));
                }
                (Some(d.cursor), r)
            }
        };
        for (v, c) in rings {
            ring(ui, v, c);
        }
        if let (Some(anchor), Some(text)) = (anchor, self.tooltip(cx)) {
            egui::Area::new(egui::Id::unique("quadcover tool tooltip"))
                .order(egui::Order::Tooltip)
                .fixed_pos(anchor + egui::vec2(16.0, 16.0))
                .interactable(false)
                .show(ui.ctx(), |ui| {
                    egui::Frame::popup(ui.style()).show(ui, |ui| {
                        ui.label(crate::app::editor::plain(&text));
                    });
                });
        }
    }

    fn reset(&mut self) {
        self.state = State::Idle;
    }

    fn panel(&mut self, cx: &ToolContext, ui: &mut egui::Ui) -> ToolOutput {
        if cx.document.editable().is_some() {
            ui.weak("Drag a singularity glyph to move or merge it (Esc cancels)");
        }
        ToolOutput::default()
    }
}
