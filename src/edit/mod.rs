//! Edits of the frame field as values (thesis sec. 3.3): what the user sees is a pure function
//! of (mesh, settings, ordered edit list). [`Base`] holds everything that depends on the mesh and
//! the settings only (the computed field, its fixed-matching system, QuadCover's analyses);
//! [`Base::apply`] turns one [`EditState`] into the next, purely combinatorially (matchings and
//! released alignment weights; `relax` also solves, deterministically); [`Base::solve`] gives
//! the field and the parameterization of a state. Replay ([`Base::replay`]) is the truth; the
//! editor caches the states after each edit and checks nothing else.
//!
//! Vertices in edits are the mesh file's vertex indices (as in REPORT.json), not the repaired
//! mesh's: [`Base`] maps between them.

mod base;
mod curves;
mod drift;
mod families;
mod moves;
pub mod project;
mod relax;

use serde::{Deserialize, Serialize};

pub use crate::constraint::{Curve, CurveKind, CurveOrigin};

pub use base::{Base, EditState, MovePreview, Replay, Reuse, Skipped, Solved};
pub use project::{MeshRef, Project, ProjectError, Settings};

/// A vertex index of an edit, read with a message a user can act on (serde's own says
/// "invalid value: integer `-13`, expected usize").
fn vertex_number<'de, D: serde::Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = serde_json::Value::deserialize(d)?;
    as_vertex(&v).ok_or_else(|| {
        serde::de::Error::custom(format!(
            "{v} is not a vertex number (a whole number from 0 up)"
        ))
    })
}

/// [`vertex_number`] for a curve's vertex list, naming the position of a bad entry.
fn vertex_numbers<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<usize>, D::Error> {
    let list = Vec::<serde_json::Value>::deserialize(d)?;
    list.iter()
        .enumerate()
        .map(|(i, v)| {
            as_vertex(v).ok_or_else(|| {
                serde::de::Error::custom(format!(
                    "vertices: {v} at position {i} is not a vertex number (a whole number from 0 up)"
                ))
            })
        })
        .collect()
}

fn as_vertex(v: &serde_json::Value) -> Option<usize> {
    v.as_u64().and_then(|x| usize::try_from(x).ok())
}

/// One user edit, as written in a project file: a JSON object tagged by `op`.
/// Later kinds (density) join this list.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum Edit {
    /// Move the singularity at file vertex `from` to file vertex `to` along a shortest edge path
    /// (merging with a singularity there, or leaving through the boundary).
    MoveSingularity {
        #[serde(deserialize_with = "vertex_number")]
        from: usize,
        #[serde(deserialize_with = "vertex_number")]
        to: usize,
    },
    /// Move every singularity to the neighbouring vertex that lowers the total curl, until none
    /// does; merge singularities closer than `relax_merge_within` grid cells.
    Relax,
    /// A constraint curve over mesh edges (thesis sec. 4.4): `vertices` are file vertex indices,
    /// consecutive ones sharing an edge (and the last and the first when `closed`).
    AddCurve {
        id: u32,
        #[serde(deserialize_with = "vertex_numbers")]
        vertices: Vec<usize>,
        #[serde(default)]
        closed: bool,
        #[serde(default)]
        kind: CurveKind,
    },
    RemoveCurve {
        id: u32,
    },
    SetCurveKind {
        id: u32,
        kind: CurveKind,
    },
    /// Replaces the detected feature curves by the edges whose dihedral angle exceeds
    /// `angle_deg`, chained into geometric curves (new ids after the largest in use).
    DetectFeatures {
        angle_deg: f64,
    },
    /// Every boundary loop as closed geometric curves split at sharp corners (`on`), or none.
    AlignBoundary {
        on: bool,
    },
}

impl Edit {
    /// Short name for the history (Edit menu, notices).
    pub fn label(&self) -> String {
        match self {
            Edit::MoveSingularity { from, to } => format!("Move singularity {from} -> {to}"),
            Edit::Relax => "Relax singularities".into(),
            Edit::AddCurve {
                id, kind, closed, ..
            } => format!(
                "Add {}{} curve {id}",
                if *closed { "closed " } else { "" },
                kind.label()
            ),
            Edit::RemoveCurve { id } => format!("Remove curve {id}"),
            Edit::SetCurveKind { id, kind } => format!("Make curve {id} {}", kind.label()),
            Edit::DetectFeatures { angle_deg } => format!("Detect features above {angle_deg} deg"),
            Edit::AlignBoundary { on: true } => "Align to boundary".into(),
            Edit::AlignBoundary { on: false } => "Stop aligning to boundary".into(),
        }
    }
}

/// Why an edit or a solve did not complete.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    #[error("{0}")]
    Field(String),
    #[error("{0}")]
    Param(String),
    #[error("{0}")]
    Invalid(String),
    /// The constraint curves admit no parameterization: the message names the curves, `curves`
    /// lists their ids (the editor draws them red).
    #[error("{message}")]
    Contradiction { curves: Vec<u32>, message: String },
    #[error("cancelled")]
    Cancelled,
}

/// Asked between stages of long computations: `true` stops them with [`EditError::Cancelled`].
pub type Cancel<'a> = &'a (dyn Fn() -> bool + Sync);

/// A [`Cancel`] that never cancels.
pub fn never() -> bool {
    false
}
