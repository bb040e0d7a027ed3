//! The frame field followed by QuadCover's preparation, overlapped on two cores: the systems'
//! analyses depend on the mesh only and run on a thread of their own while the field is
//! smoothed (filling the core its solves leave idle), and the factorizations start as soon as
//! the field's matchings are final, beside the field's last solve of the angles.

use crate::field::{FieldError, FieldParams, FieldResult, compute_field_then};
use crate::mesh::TriMesh;

use super::{ParamAnalysis, ParamError, ParamOptions, QuadCover};

#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error(transparent)]
    Field(#[from] FieldError),
    #[error(transparent)]
    Param(#[from] ParamError),
}

/// Frame field and a prepared [`QuadCover`] for its matchings.
pub fn field_then_quadcover(
    mesh: &TriMesh,
    params: &FieldParams,
    symmetry: usize,
    opts: &ParamOptions,
) -> Result<(FieldResult, QuadCover), PipelineError> {
    std::thread::scope(|scope| {
        let analysis = scope.spawn(|| ParamAnalysis::new(mesh));
        let (field, qc) = compute_field_then(mesh, params, |matchings| {
            let analysis = match analysis.join() {
                Ok(a) => a?,
                Err(panic) => std::panic::resume_unwind(panic),
            };
            QuadCover::with_analysis(mesh, symmetry, matchings, opts.clone(), Some(&analysis))
        })?;
        Ok((field, qc?))
    })
}
