//! The individual stages outside the edit list (field alone, QuadCover on the shown field) and
//! the synthetic demos, as background jobs.

use std::sync::Arc;

use glam::DVec3;

use super::document::{FieldDisplay, ParamDisplay};
use super::editor::EditorApp;
use super::jobs::{Job, JobOutput};

impl EditorApp {
    /// Synthetic demo: a 4-field aligned with the projection
    /// of the x axis (y where x is normal), computed in the background.
    pub fn start_demo_field(&mut self, ctx: Option<egui::Context>, symmetry: u32) {
        let Some(mesh) = self.document.mesh.clone() else {
            return;
        };
        let generation = self.document.generation();
        self.jobs.push(
            Job::spawn("Synthetic field", ctx, move |progress| {
                let n = mesh.n_faces();
                let mut dirs = Vec::with_capacity(n);
                for f in 0..n {
                    if f % 4096 == 0 {
                        progress.set(f as f32 / n.max(1) as f32);
                    }
                    let nrm = mesh.face_normal(f);
                    let mut d = DVec3::X - nrm * nrm.dot(DVec3::X);
                    if d.length_squared() < 1e-4 {
                        d = DVec3::Y - nrm * nrm.dot(DVec3::Y);
                    }
                    dirs.push(d.normalize_or_zero());
                }
                Ok(JobOutput::Field(FieldDisplay {
                    symmetry,
                    face_dirs: dirs,
                    singularities: Vec::new(),
                }))
            })
            .for_generation(generation),
        );
    }

    /// Synthetic demo: planar projection UVs (x, y)
    /// scaled so about 12 cells span the mesh.
    pub fn start_demo_param(&mut self, ctx: Option<egui::Context>) {
        let Some(mesh) = self.document.mesh.clone() else {
            return;
        };
        let generation = self.document.generation();
        self.jobs.push(
            Job::spawn("Synthetic parameterization", ctx, move |_| {
                let (lo, hi) = mesh.bounding_box();
                let s = 12.0 / (hi - lo).max_element().max(1e-12);
                let mut uvs = Vec::with_capacity(3 * mesh.n_faces());
                for f in mesh.faces() {
                    for &v in f {
                        let p = (mesh.position(v as usize) - lo) * s;
                        uvs.push([p.x, p.y]);
                    }
                }
                Ok(JobOutput::Param(ParamDisplay {
                    corner_uvs: uvs,
                    ..Default::default()
                }))
            })
            .for_generation(generation),
        );
    }

    /// Computes a frame field of symmetry `n` (2, 4 or 6) in the background (the field stage
    /// alone, outside the edit list).
    pub fn start_field(&mut self, ctx: Option<egui::Context>, n: u32) {
        let Some(mesh) = self.document.mesh.clone() else {
            return;
        };
        let generation = self.document.generation();
        self.jobs.push(
            Job::spawn(format!("Computing {n}-field"), ctx, move |_| {
                let symmetry = crate::field::Symmetry::from_n(n).map_err(|e| e.to_string())?;
                let params = crate::field::FieldParams {
                    symmetry,
                    ..Default::default()
                };
                crate::field::compute_field(&mesh, &params)
                    .map(|r| JobOutput::FieldComputed(Box::new(r)))
                    .map_err(|e| e.to_string())
            })
            .for_generation(generation),
        );
    }

    /// Runs QuadCover on the current field in the background.
    pub fn start_parameterize(&mut self, ctx: Option<egui::Context>) {
        let (Some(mesh), Some(field)) = (
            self.document.mesh.clone(),
            self.document.frame_field.clone(),
        ) else {
            return;
        };
        let generation = self.document.generation();
        let analysis = self.document.param_analysis.clone();
        self.jobs.push(
            Job::spawn("Parameterizing (QuadCover)", ctx, move |_| {
                let run = || -> Result<JobOutput, crate::param::ParamError> {
                    let analysis = match analysis {
                        Some(a) => a,
                        None => Arc::new(crate::param::ParamAnalysis::new(&mesh)?),
                    };
                    let qc = crate::param::QuadCover::with_analysis(
                        &mesh,
                        field.symmetry.n() as usize,
                        &field.matchings,
                        crate::param::ParamOptions::default(),
                        Some(&analysis),
                    )?;
                    let p = qc.solve(&mesh, &field.frames)?;
                    Ok(JobOutput::Parameterized(Box::new(p), analysis))
                };
                run().map_err(|e| e.to_string())
            })
            .for_generation(generation),
        );
    }
}
