//! The edit pipeline: edits from tools and buttons, undo / redo, settings, and the background
//! solves that follow them (cancelled and coalesced by the document's edit revision).

use std::sync::Arc;

use super::editor::EditorApp;
use super::jobs::{Job, JobOutput};
use super::picking::Picker;
use crate::edit::Edit;

impl EditorApp {
    /// Brings the shown solve up to the document's edit revision: cancels older solve jobs
    /// (cooperatively) and starts one for the newest state once none runs, so rapid edits
    /// coalesce into one solve.
    pub fn schedule_solve(&mut self) {
        // Undo or redo back to a state solved a moment ago: shown at once, no job.
        if self.document.show_remembered_solve() {
            for job in &self.jobs {
                if job.revision.is_some() {
                    job.cancel();
                }
            }
            self.solve_pending = false;
            super::editor::show_pattern(&mut self.document);
            return;
        }
        let revision = self.document.edit_revision();
        let mut running = false;
        for job in &self.jobs {
            if let Some(r) = job.revision {
                if r != revision {
                    job.cancel();
                }
                running = true;
            }
        }
        if running {
            self.solve_pending = true;
        } else {
            self.spawn_solve();
        }
    }

    pub(super) fn spawn_solve(&mut self) {
        self.solve_pending = false;
        let Some(request) = self.document.solve_request() else {
            return;
        };
        let (revision, generation) = (request.revision, request.generation);
        let name = if request.rebuild.is_some() {
            "Computing field and QuadCover".to_string()
        } else if let Some(last) = request.edits.last() {
            format!("{} and re-solving", last.label())
        } else {
            "Re-solving field and QuadCover".to_string()
        };
        let repaint = self.ctx.clone();
        self.jobs.push(
            Job::spawn(name, self.ctx.clone(), move |progress| {
                request
                    .run(
                        &|| progress.cancelled(),
                        &|s| progress.set_stage(s),
                        &|uv| {
                            progress.set_preview(uv);
                            progress.set_stage("repairing folds (showing the global step's map)");
                            if let Some(ctx) = &repaint {
                                ctx.request_repaint();
                            }
                        },
                    )
                    .map(|o| JobOutput::Solved(Box::new(o)))
            })
            .for_generation(generation)
            .for_revision(revision),
        );
    }

    pub(super) fn spawn_picker(&mut self) {
        let Some(mesh) = self.document.mesh.clone() else {
            return;
        };
        self.picker = None;
        self.jobs.push(
            Job::spawn("Building the picking BVH", self.ctx.clone(), move |_| {
                Ok(JobOutput::Picker(Arc::new(Picker::new(mesh))))
            })
            .for_generation(self.document.generation()),
        );
    }

    /// The viewport's camera and rectangle as last drawn (what picking uses).
    pub fn view(&self) -> super::picking::View {
        self.last_view
    }

    /// The picker, when it belongs to the current mesh.
    pub fn current_picker(&self) -> Option<&Picker> {
        let mesh = self.document.mesh.as_ref()?;
        self.picker.as_deref().filter(|p| p.is_for(mesh))
    }

    /// Takes an edit a tool (or a button) committed: moves are applied here (a Dijkstra, so a
    /// refusal shows at once), relax and curve edits (which may design the field again) in the
    /// solve job; then the re-solve is scheduled.
    pub fn commit_edit(&mut self, edit: Edit) {
        let applied = match &edit {
            Edit::Relax => None,
            // Curve edits may design the field again (a second on large meshes): checked here,
            // so a broken curve is refused at once, and applied in the solve job.
            Edit::AddCurve { .. }
            | Edit::RemoveCurve { .. }
            | Edit::SetCurveKind { .. }
            | Edit::DetectFeatures { .. }
            | Edit::AlignBoundary { .. } => {
                if let Some(base) = self.document.edit_base.as_ref()
                    && let Err(why) = base.check_edit(&edit)
                {
                    self.notice = Some(format!("{}: {why}", edit.label()));
                    return;
                }
                None
            }
            _ => {
                let Some((base, state)) = self.document.editable() else {
                    self.notice = Some(format!(
                        "{}: wait for the running solve to finish",
                        edit.label()
                    ));
                    return;
                };
                match base.apply(state, &edit, &crate::edit::never) {
                    Ok(next) => Some(next),
                    Err(e) => {
                        self.notice = Some(format!("{}: {e}", edit.label()));
                        return;
                    }
                }
            }
        };
        self.notice = None;
        self.status = edit.label();
        self.document.push_edit(edit, applied);
        self.tool.reset();
        self.schedule_solve();
    }

    /// Relaxes the singularities (an edit; it runs in the solve job).
    pub fn relax(&mut self) {
        if self.document.edit_base.is_none() {
            return;
        }
        self.commit_edit(Edit::Relax);
    }

    pub fn undo(&mut self) {
        if self.document.undo() {
            self.status = "Undo".into();
            self.notice = None;
            self.tool.reset();
            self.schedule_solve();
        }
    }

    pub fn redo(&mut self) {
        if self.document.redo() {
            self.status = "Redo".into();
            self.notice = None;
            self.tool.reset();
            self.schedule_solve();
        }
    }

    /// Jumps in the history to `cursor` applied edits (several undos or redos at once).
    pub fn goto_history(&mut self, cursor: usize) {
        let mut changed = false;
        while self.document.cursor() > cursor && self.document.undo() {
            changed = true;
        }
        while self.document.cursor() < cursor && self.document.redo() {
            changed = true;
        }
        if changed {
            self.tool.reset();
            self.schedule_solve();
        }
    }

    /// Applies the side panel's settings: the base is rebuilt and the edits replayed.
    pub fn apply_settings(&mut self) {
        if let Err(e) = self.settings_draft.validate() {
            self.notice = Some(format!("Settings: {e}"));
            return;
        }
        let changed = self.settings_draft != self.document.settings;
        self.document.set_settings(self.settings_draft.clone());
        if changed || !self.document.solve_current() {
            self.tool.reset();
            self.schedule_solve();
        }
    }
}
