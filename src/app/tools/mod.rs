//! Viewport tools: interaction modes that turn pointer gestures into edits.
//!
//! Modelled on Fyrox's interaction modes (press / move / release / key handlers, one file per
//! mode) and Graphite's tool state machines: each tool is a small state machine fed
//! [`ToolEvent`]s; it may change its own transient preview while a gesture runs, and when the
//! gesture ends it hands at most one committed [`Edit`] back ([`ToolOutput::commit`]), so one
//! gesture is one undo step. Tools never change the document themselves; they read it (and
//! the core's [`crate::edit::Base`]) through [`ToolContext`], and ask [`super::picking`] what
//! is under the cursor. A press a tool does not claim falls through to the camera (orbit).
//! A tool may also show controls in the side panel ([`Tool::panel`]), which commit edits the
//! same way.
//!
//! - [`MoveSingularityTool`]: drag singularity glyphs (thesis sec. 3.3).
//! - [`DrawCurveTool`]: draw constraint curves by clicks or strokes, select, retype and delete
//!   them (sec. 4.4).

pub mod draw_curve;
pub mod move_singularity;

use std::sync::Arc;

use super::document::Document;
use super::picking::{Picker, View};
use super::scene::Overlay;
use crate::edit::Edit;

pub use draw_curve::DrawCurveTool;
pub use move_singularity::MoveSingularityTool;

/// What a tool sees of the editor in one frame.
pub struct ToolContext<'a> {
    pub view: View,
    pub document: &'a Document,
    /// `None` while the mesh's BVH is still being built.
    pub picker: Option<&'a Picker>,
    /// The keyboard modifiers held in this frame.
    pub modifiers: egui::Modifiers,
}

/// Pointer and key input over the viewport (positions in egui points).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToolEvent {
    /// The pointer moved to a position (no button, or a drag the tool does not own).
    Hover(Option<egui::Pos2>),
    /// The primary button went down at a position in the viewport.
    Press(egui::Pos2),
    /// The pointer moved with the primary button down.
    Drag(egui::Pos2),
    /// The primary button went up.
    Release(egui::Pos2),
    /// Esc: abandon the gesture.
    Cancel,
    /// Enter: finish what is being built (e.g. an open curve).
    Finish,
    /// A double click of the primary button at a position (after its second release).
    DoubleClick(egui::Pos2),
    /// Delete or Backspace: remove the selection.
    Delete,
}

/// A tool's answer to one event.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ToolOutput {
    /// The tool owns the gesture: the camera must not orbit.
    pub captured: bool,
    /// The edit the finished gesture commits.
    pub commit: Option<Edit>,
    /// A message for the status line.
    pub status: Option<String>,
    /// Why a gesture was refused: shown as the side panel's notice.
    pub notice: Option<String>,
}

impl ToolOutput {
    /// Takes `other`'s commit, status and notice where it has them.
    pub fn merge(&mut self, other: ToolOutput) {
        self.captured |= other.captured;
        if other.commit.is_some() {
            self.commit = other.commit;
        }
        if other.status.is_some() {
            self.status = other.status;
        }
        if other.notice.is_some() {
            self.notice = other.notice;
        }
    }
}

/// An interaction mode of the viewport.
pub trait Tool {
    /// Shown in the UI.
    fn name(&self) -> &'static str;
    /// Feeds one event; see [`ToolOutput`].
    fn event(&mut self, cx: &ToolContext, event: ToolEvent) -> ToolOutput;
    /// Whether a gesture is in progress (the camera then stays put).
    fn active(&self) -> bool;
    /// The transient overlay (drawn with depth by the renderer), if any.
    fn overlay(&self) -> Option<Arc<Overlay>>;
    /// Screen-space hints: highlight rings, a tooltip.
    fn paint(&self, cx: &ToolContext, ui: &mut egui::Ui);
    /// Drops any gesture and hover state (the document changed under it, or another tool
    /// took over). A selection stays (it is checked against the document when used).
    fn reset(&mut self);
    /// Drops the selection too (another document was opened).
    fn clear_selection(&mut self) {}
    /// The tool's controls in the side panel; an edit they commit goes through
    /// [`ToolOutput::commit`] like a gesture's.
    fn panel(&mut self, cx: &ToolContext, ui: &mut egui::Ui) -> ToolOutput {
        let _ = (cx, ui);
        ToolOutput::default()
    }
    /// The selected constraint curve's id, for tools that select curves.
    fn selected_curve(&self) -> Option<u32> {
        None
    }
}

/// The overlay revision counter (shared by all tools, so revisions never repeat).
pub(crate) fn next_overlay_revision() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// The viewport tools the side panel offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToolKind {
    MoveSingularity,
    DrawCurve,
}

impl ToolKind {
    pub const ALL: [ToolKind; 2] = [ToolKind::MoveSingularity, ToolKind::DrawCurve];

    pub fn label(self) -> &'static str {
        match self {
            ToolKind::MoveSingularity => "Move singularities",
            ToolKind::DrawCurve => "Draw curves",
        }
    }

    pub fn hint(self) -> &'static str {
        match self {
            ToolKind::MoveSingularity => "Drag singularity glyphs to move or merge them",
            ToolKind::DrawCurve => {
                "Click vertices or drag strokes to draw constraint curves; click a curve to select it"
            }
        }
    }

    /// A fresh tool of this kind.
    pub fn make(self) -> Box<dyn Tool> {
        match self {
            ToolKind::MoveSingularity => Box::new(MoveSingularityTool::new()),
            ToolKind::DrawCurve => Box::new(DrawCurveTool::new()),
        }
    }
}
