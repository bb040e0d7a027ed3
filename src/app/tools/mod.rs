//! Viewport tools: interaction modes that turn pointer gestures into edits.
//!
//! Modelled on Fyrox's interaction modes (press / move / release / key handlers, one file per
//! mode) and Graphite's tool state machines: each tool is a small state machine fed
//! [`ToolEvent`]s; it may change its own transient preview while a gesture runs, and when the
//! gesture ends it hands at most one committed [`Edit`] back ([`ToolOutput::commit`]), so one
//! gesture is one undo step. Tools never change the document themselves; they read it (and
//! the core's [`crate::edit::Base`]) through [`ToolContext`], and ask [`super::picking`] what
//! is under the cursor. A press a tool does not claim falls through to the camera (orbit).

pub mod move_singularity;

use std::sync::Arc;

use super::document::Document;
use super::picking::{Picker, View};
use super::scene::Overlay;
use crate::edit::Edit;

pub use move_singularity::MoveSingularityTool;

/// What a tool sees of the editor in one frame.
pub struct ToolContext<'a> {
    pub view: View,
    pub document: &'a Document,
    /// `None` while the mesh's BVH is still being built.
    pub picker: Option<&'a Picker>,
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
}

/// A tool's answer to one event.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ToolOutput {
    /// The tool owns the gesture: the camera must not orbit.
    pub captured: bool,
    /// The edit the finished gesture commits.
    pub commit: Option<Edit>,
    /// A message for the status line (e.g. why a gesture was refused).
    pub status: Option<String>,
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
    /// took over).
    fn reset(&mut self);
}

/// The overlay revision counter (shared by all tools, so revisions never repeat).
pub(crate) fn next_overlay_revision() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}
