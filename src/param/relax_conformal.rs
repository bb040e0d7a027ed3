//! The repair's last step on the map a solve keeps: the faces the repair left more distorted
//! than the global step's map at its 99th percentile relaxed towards conformality
//! ([`untangle::relax_conformal`]).
//!
//! Why after everything: run inside every repair (the crowded ladder's tries, the re-roundings'
//! candidates) the same relaxation changed which try and which gaps were kept, and left more
//! wrongly wound vertices (cerebral vessels N = 6 at 1500 vertices: 4 → 10). On the kept map it
//! changes nothing but the distortion.

use glam::DVec3;

use super::{
    CancelCheck, Distortion, LocalSolution, ParamError, Parameterization, QuadCover, cones,
    metrics, untangle,
};
use crate::mesh::TriMesh;

/// What [`QuadCover::solve_on`] computed that the relaxation needs again, so that it does not
/// solve the local and global steps a second time (at 1.1 M faces 1.1 s): its local step and
/// the global step's map with the gaps it was solved on. `solve_previewing` keeps the kept
/// try's.
pub(super) struct LastSolve {
    pub(super) local: LocalSolution,
    pub(super) global: (Vec<[f64; 2]>, Vec<[f64; 2]>),
}

impl QuadCover {
    /// `p` (solved on `frames`) with its repaired places relaxed; `p` itself when the repair
    /// did nothing or is off, under curves, with poles and on the mesh opened at them (their
    /// maps hold more than the global step's unknowns), or when something is left folded.
    pub(super) fn relax_conformal_of(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        mut p: Parameterization,
        last: Option<LastSolve>,
        cancel: CancelCheck<'_>,
    ) -> Result<Parameterization, ParamError> {
        if self.opts.no_untangle
            || !self.relax_last
            || !p.curves.is_empty()
            || !p.poles.is_empty()
            || p.flipped_faces > 0
            || p.timings.repair_ms <= 0.0
            || cancel()
        {
            return Ok(p);
        }
        let t = std::time::Instant::now();
        // The level: the global step's 99th percentile, on the gaps the map was first rounded
        // to when the repair rounded some again (the "before the repair").
        let (local, global, level) = match last {
            Some(LastSolve {
                local,
                global: (gaps, global),
            }) if gaps == p.gaps => (local, global, None),
            Some(LastSolve {
                local,
                global: (_, first),
            }) => {
                let global = self.global_uv(mesh, &local, &p.gaps)?;
                let p99 = |uv: &[[f64; 2]]| metrics::map_conformal_p99(mesh, uv);
                let level = p99(&first).min(p99(&global));
                (local, global, Some(level))
            }
            None => {
                let local = self.local_step(mesh, frames)?;
                let global = self.global_uv(mesh, &local, &p.gaps)?;
                (local, global, None)
            }
        };
        let space = self.global.map_space(mesh.n_vertices(), &p.gaps);
        let cones = cones(mesh, &p.singularities);
        let relaxed = untangle::relax_conformal(
            mesh,
            &self.rots,
            &space,
            &local.disk,
            &local.guide,
            &cones,
            &global,
            level,
            &p.uv,
            &p.miswound,
            cancel,
        );
        if cancel() {
            return Err(ParamError::Cancelled);
        }
        // Only free unknowns moved: the singularities, gaps, cut and curl are as they were.
        if let Some((uv, miswound)) = relaxed {
            let trans: Vec<(u8, [f64; 2])> = p
                .transitions
                .iter()
                .map(|t| (t.rotation, t.translation))
                .collect();
            p.seam_max_error =
                metrics::seam_error(mesh, &self.rots, &uv, &trans, self.lattice.transitions());
            let quality = metrics::quality(mesh, &uv);
            p.flipped_faces = quality.flipped;
            p.conformal_distortion = Distortion {
                mean: quality.conformal_mean,
                p99: quality.conformal_p99,
            };
            p.area_distortion = quality.area_distortion;
            p.miswound = miswound;
            p.uv = uv;
        }
        p.timings.repair_ms += t.elapsed().as_secs_f64() * 1e3;
        Ok(p)
    }
}
