//! QuadCover under constraint curves (alg. 7): the curves traced and their unknowns rounded
//! ([`constraints`]), the constrained global step ([`constrained`]), the repair and its
//! re-roundings, and for N = 6 a second try with branch points kept off the curves' lines.

use std::time::Instant;

use glam::DVec3;

use super::{
    CancelCheck, ConstraintCurve, LocalSolution, ParamError, Parameterization, PreviewSink,
    QuadCover, Rerounded, cones, constrained, constraints, ms, no_preview, reround, untangle,
};
use crate::mesh::TriMesh;

/// A map under curves ([`QuadCover::curves_repaired`]): the unknowns as rounded and as
/// finally re-rounded, the repaired map, the repair's counts, the gaps the re-roundings moved
/// and the global step's time.
struct CurveMap {
    rounded: Vec<f64>,
    w: Vec<f64>,
    uv: Vec<[f64; 2]>,
    repair: untangle::Repair,
    rerounded: Vec<Rerounded>,
    global_ms: f64,
}

impl QuadCover {
    /// [`QuadCover::solve`] under constraint curves (alg. 7): the local step, the curves'
    /// line families and values, the integer unknowns rounded to the nearest solution of the
    /// combinatorial constraints, the global step with the geometric ones eliminated.
    pub fn solve_with_curves(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        curves: &[ConstraintCurve],
    ) -> Result<Parameterization, ParamError> {
        self.solve_with_curves_until(mesh, frames, curves, &|| false)
    }

    /// [`QuadCover::solve_with_curves`] that stops with [`ParamError::Cancelled`] when `cancel`
    /// says so during the injectivity repair (the editor's stale jobs).
    pub fn solve_with_curves_until(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        curves: &[ConstraintCurve],
        cancel: CancelCheck<'_>,
    ) -> Result<Parameterization, ParamError> {
        self.solve_previewing(mesh, frames, curves, cancel, &no_preview)
    }

    /// The solve under constraint curves ([`QuadCover::solve_previewing`] with curves).
    pub(super) fn solve_curves(
        &self,
        mesh: &TriMesh,
        frames: &[[DVec3; 2]],
        curves: &[ConstraintCurve],
        cancel: CancelCheck<'_>,
        preview: PreviewSink<'_>,
    ) -> Result<Parameterization, ParamError> {
        for c in curves {
            if let Some(&v) = c.vertices.iter().find(|&&v| v >= mesh.n_vertices()) {
                return Err(ParamError::InvalidInput(format!(
                    "curve {}: vertex {v} is out of range",
                    c.id
                )));
            }
        }
        let mut blocked = vec![false; mesh.n_vertices()];
        for c in curves {
            for &v in c.vertices {
                blocked[v] = true;
            }
        }
        self.check_frames(mesh, frames)?;
        let (singularities, local) = rayon::join(
            || self.singularities(mesh, frames),
            || self.local_step(mesh, frames),
        );
        if let Some((o, indices)) = self.opened(mesh, &singularities, &blocked)? {
            let p =
                o.qc.solve_with_curves_until(&o.mesh, frames, curves, cancel)?;
            return Ok(self.close(mesh, singularities, &o, &indices, p));
        }
        let local = local?;
        let t = Instant::now();
        let families = if self.symmetry == 2 {
            constraints::FamilyFrames::CurlFree(&local.disk)
        } else {
            constraints::FamilyFrames::Field(&local.guide)
        };
        let traced = constraints::Traced::new(
            mesh,
            &self.cut,
            &self.rots,
            self.lattice,
            &self.global,
            families,
            &local.uv,
            &local.gaps,
            curves,
        )?;
        // Under curves every gap is on the one lattice the curves' equations are written in.
        let plain =
            self.round_gaps_on(mesh, &local, &vec![self.lattice; self.gap_lattices.len()])?;
        // Side by side: the rounding, and the constrained step's factorization, which depends
        // only on which components the curves fix, not on the rounded values (it serves the
        // re-rounding below as well).
        let (rounded, step) = rayon::join(
            || -> Result<Vec<f64>, ParamError> {
                // The energy's dependence on the gaps weighs the rounding of the unknowns in
                // equations.
                let hessian =
                    self.global
                        .gap_hessian(mesh, &self.rots, &traced.metric_gap_components())?;
                Ok(traced.round(&local.gaps, &plain, &hessian)?.1)
            },
            || {
                traced
                    .has_geometric()
                    .then(|| {
                        constrained::ConstrainedStep::new(
                            mesh,
                            &self.cut,
                            &self.global,
                            &self.rots,
                            &local.disk,
                            &traced.fix_pattern(),
                        )
                    })
                    .transpose()
            },
        );
        let w = rounded?;
        let step = step.map_err(|e| traced.name_failure(e))?;
        let cones = cones(mesh, &singularities);
        let repaired = |w: Vec<f64>, t: Instant, preview: PreviewSink<'_>| {
            self.curves_repaired(
                mesh,
                &local,
                &traced,
                step.as_ref(),
                &cones,
                w,
                t,
                cancel,
                preview,
            )
        };
        let first = repaired(w, t, preview)?;
        // N = 6: a map that keeps folds is tried again with the branch points rounded onto
        // lines beside them moved off ([`constraints::Traced::off_lines_try`]): first those on
        // a line, then, if that map folds too, those across one as well (each helps where the
        // other does not: the cross plate at the default density 117 → 0 folds with the first,
        // none with the second; at 3000 vertices 99 → 18 and 0). The map with the fewest
        // folds, then wrongly wound vertices, is kept.
        let badness = |c: &CurveMap| {
            (
                untangle::folded(&c.uv).len(),
                untangle::miswound(mesh, &c.uv, &cones).len(),
            )
        };
        let first_rounded = first.rounded.clone();
        let mut kept = first;
        let mut tried: Vec<Vec<f64>> = Vec::new();
        for breaks in [constraints::Breaks::OnLine, constraints::Breaks::Across] {
            if untangle::folded(&kept.uv).is_empty() || self.opts.no_untangle || cancel() {
                break;
            }
            let Some(w) = traced.off_lines_try(&first_rounded, &local.gaps, breaks) else {
                continue;
            };
            if tried.contains(&w) {
                continue;
            }
            tried.push(w.clone());
            let t = Instant::now();
            let next = match repaired(w, t, &no_preview) {
                Ok(next) => Some(next),
                Err(ParamError::Cancelled) => return Err(ParamError::Cancelled),
                // A try that fails leaves the map kept so far.
                Err(_) => None,
            };
            // The repairs so far and the try's whole time (its global step included): it is
            // there for the repair.
            let repair_ms = kept.repair.ms + ms(t);
            if let Some(next) = next
                && badness(&next) < badness(&kept)
            {
                // Its gaps moved from the first rounding's: re-rounded, as the repair's
                // re-roundings report theirs.
                let rerounded =
                    reround::changed(&traced.gaps(&first_rounded), &traced.gaps(&next.w));
                kept = CurveMap {
                    global_ms: kept.global_ms,
                    rerounded,
                    ..next
                };
            }
            kept.repair.ms = repair_ms;
        }
        let CurveMap {
            w,
            uv,
            repair,
            rerounded,
            global_ms,
            ..
        } = kept;
        let gaps = traced.gaps(&w);
        let fits = traced.fits(&self.rots, &uv, &w);
        let mut p = self.complete(
            mesh,
            frames,
            singularities,
            &local,
            uv,
            gaps,
            global_ms,
            &repair,
        );
        p.curves = fits;
        p.rerounded_gaps = rerounded;
        p.collapsed_strips = traced.collapsed_strips(&first_rounded);
        Ok(p)
    }

    /// Under curves, from the rounded unknowns `w`: the constrained global step's map (on the
    /// factored `step`), its repair, the re-roundings for folds and for windings. `t`: when the
    /// global step began, for its time.
    #[allow(clippy::too_many_arguments)]
    fn curves_repaired(
        &self,
        mesh: &TriMesh,
        local: &LocalSolution,
        traced: &constraints::Traced,
        step: Option<&constrained::ConstrainedStep>,
        cones: &[f64],
        mut w: Vec<f64>,
        t: Instant,
        cancel: CancelCheck<'_>,
        preview: PreviewSink<'_>,
    ) -> Result<CurveMap, ParamError> {
        let rounded = w.clone();
        let first_gaps = traced.gaps(&w);
        let (mut uv, space) = self
            .curve_map(mesh, local, traced, step, &w)
            .map_err(|e| traced.name_failure(e))?;
        let global_ms = ms(t);
        // The repair holds the curves' fixed components: the fits below still hold exactly.
        if !self.opts.no_untangle && !untangle::folded(&uv).is_empty() {
            preview(&uv);
        }
        let mut repair = self.untangle(mesh, local, &space, Some(cones), &mut uv, cancel);
        let mut rerounded = Vec::new();
        if !untangle::folded(&uv).is_empty() && !self.opts.no_untangle && !cancel() {
            let t = Instant::now();
            rerounded = self.reround_curves(
                mesh,
                local,
                traced,
                step,
                &mut w,
                &mut uv,
                &mut repair,
                cancel,
            )?;
            repair.ms += ms(t);
        }
        // Re-rounded gaps change the map space (its constants): the re-rounded map's, on the
        // same factorization.
        let space = if rerounded.is_empty() {
            space
        } else {
            self.curve_map(mesh, local, traced, step, &w)?.1
        };
        self.rewind_left(mesh, local, &space, cones, &mut uv, &mut repair, cancel);
        if !self.opts.no_untangle {
            let t = Instant::now();
            let before = w.clone();
            self.reround_curve_windings(
                mesh,
                local,
                traced,
                step,
                cones,
                &mut w,
                &mut uv,
                &mut repair,
                cancel,
            )?;
            if w != before {
                rerounded = reround::changed(&first_gaps, &traced.gaps(&w));
            }
            repair.ms += ms(t);
        }
        if cancel() {
            return Err(ParamError::Cancelled);
        }
        Ok(CurveMap {
            rounded,
            w,
            uv,
            repair,
            rerounded,
            global_ms,
        })
    }
}
