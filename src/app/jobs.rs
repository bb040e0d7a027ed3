//! Background jobs: a closure runs on its own thread and sends one result back
//! through a channel. The UI polls every frame and never blocks on a solver.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::mpsc::{Receiver, TryRecvError, channel};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use super::document::{FieldDisplay, LoadedDocument, LoadedProject, ParamDisplay, SolveOutcome};
use super::picking::Picker;

/// What a job produces.
pub enum JobOutput {
    Loaded(Box<LoadedDocument>),
    Field(FieldDisplay),
    Param(ParamDisplay),
    /// A field from `quadcover::field::compute_field`.
    FieldComputed(Box<crate::field::FieldResult>),
    /// A parameterization from `quadcover::param::parameterize`.
    /// A parameterization, and the mesh's QuadCover analysis it used (kept for re-solves).
    Parameterized(
        Box<crate::param::Parameterization>,
        std::sync::Arc<crate::param::ParamAnalysis>,
    ),
    /// A file was written; the message says what and where.
    Exported(String),
    /// A project and its mesh were read and checked.
    ProjectLoaded(Box<LoadedProject>),
    /// A solve of the document's edits (see [`super::document::SolveRequest`]).
    Solved(Box<SolveOutcome>),
    /// The picking BVH of the current mesh.
    Picker(Arc<Picker>),
    /// The remesh of a parameterization, or why its extraction failed
    /// ([`super::remesh::RemeshRequest`]).
    Remeshed(Box<super::remesh::RemeshResult>),
}

/// Shared progress of a running job: a fraction in [0, 1] (or unknown) and a
/// cancellation flag the job may check.
#[derive(Default)]
pub struct Progress {
    /// Fraction * 1e6, or u32::MAX when unknown.
    fraction: AtomicU32,
    cancel: AtomicBool,
    /// What the job is doing now (shown beside its name).
    stage: Mutex<String>,
    /// A solve job's early result: the global step's map before the injectivity repair
    /// (`Base::solve_previewing`), taken by the editor to show while the repair runs.
    preview: Mutex<Option<Vec<[f64; 2]>>>,
}

impl Progress {
    pub fn set(&self, fraction: f32) {
        let v = (fraction.clamp(0.0, 1.0) * 1e6) as u32;
        self.fraction.store(v, Ordering::Relaxed);
    }

    pub fn get(&self) -> Option<f32> {
        match self.fraction.load(Ordering::Relaxed) {
            u32::MAX => None,
            v => Some(v as f32 / 1e6),
        }
    }

    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    pub fn set_stage(&self, stage: &str) {
        if let Ok(mut s) = self.stage.lock() {
            stage.clone_into(&mut s);
        }
    }

    pub fn set_preview(&self, uv: &[[f64; 2]]) {
        if let Ok(mut p) = self.preview.lock() {
            *p = Some(uv.to_vec());
        }
    }

    /// The preview, once (`None` when there is none or it was taken).
    pub fn take_preview(&self) -> Option<Vec<[f64; 2]>> {
        self.preview.lock().ok().and_then(|mut p| p.take())
    }

    pub fn stage(&self) -> String {
        self.stage.lock().map(|s| s.clone()).unwrap_or_default()
    }
}

/// A running job.
pub struct Job {
    pub name: String,
    /// Mesh generation the job works on (`None`: independent of the current mesh).
    /// Results for an older generation are discarded.
    pub generation: Option<u64>,
    /// For solve jobs: the document's edit revision they solve (older ones are dropped).
    pub revision: Option<u64>,
    /// For remesh extractions: the parameterization revision they extract
    /// ([`super::document::Document::param_revision`]).
    pub param_revision: Option<u64>,
    pub started: Instant,
    pub progress: Arc<Progress>,
    rx: Receiver<Result<JobOutput, String>>,
}

impl Job {
    /// Starts `work` on a new thread. `ctx` (if any) is asked to repaint when it ends.
    pub fn spawn<F>(name: impl Into<String>, ctx: Option<egui::Context>, work: F) -> Job
    where
        F: FnOnce(&Progress) -> Result<JobOutput, String> + Send + 'static,
    {
        let (tx, rx) = channel();
        let progress = Arc::new(Progress {
            fraction: AtomicU32::new(u32::MAX),
            cancel: AtomicBool::new(false),
            stage: Mutex::new(String::new()),
            preview: Mutex::new(None),
        });
        let p = Arc::clone(&progress);
        let name = name.into();
        let thread_name = format!("job: {name}");
        let spawned = std::thread::Builder::new()
            .name(thread_name)
            .spawn(move || {
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&p)))
                    .unwrap_or_else(|_| Err("the job panicked".to_string()));
                let _ = tx.send(result);
                if let Some(ctx) = ctx {
                    ctx.request_repaint();
                }
            });
        let (tx2, rx2) = channel();
        let rx = match spawned {
            Ok(_) => rx,
            Err(e) => {
                let _ = tx2.send(Err(format!("cannot start a thread: {e}")));
                rx2
            }
        };
        Job {
            name,
            generation: None,
            revision: None,
            param_revision: None,
            started: Instant::now(),
            progress,
            rx,
        }
    }

    /// Tags the job with the mesh generation it works on.
    pub fn for_generation(mut self, generation: u64) -> Job {
        self.generation = Some(generation);
        self
    }

    /// Tags a solve job with the edit revision it solves.
    pub fn for_revision(mut self, revision: u64) -> Job {
        self.revision = Some(revision);
        self
    }

    /// Tags a remesh extraction with the parameterization revision it extracts.
    pub fn for_param(mut self, param_revision: u64) -> Job {
        self.param_revision = Some(param_revision);
        self
    }

    /// Whether [`Job::cancel`] was called.
    pub fn cancelled(&self) -> bool {
        self.progress.cancelled()
    }

    /// `Some(result)` once the job has finished.
    pub fn poll(&self) -> Option<Result<JobOutput, String>> {
        match self.rx.try_recv() {
            Ok(r) => Some(r),
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => Some(Err("the job ended without a result".into())),
        }
    }

    pub fn cancel(&self) {
        self.progress.cancel.store(true, Ordering::Relaxed);
    }
}
