//! Grid size (global density) and per-face scale functions (thesis fig. 5.4).
//!
//! A parameterization with grid size h has gradients of length 1/h, so frames are scaled by
//! m_i / h where m_i is the per-face multiplier of the scale function (m_i > 1: finer there).

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::curvature::Curvature;
use super::{FieldError, Symmetry};
use crate::mesh::TriMesh;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Density {
    /// Target edge length h of the output grid (the lattice spacing in 3-D units).
    EdgeLength(f64),
    /// Target number of output vertices: h = sqrt(c_N Σ_i A_i m_i² / target), where c_N is the
    /// lattice cell area per vertex for unit spacing: 1 for Z² (N = 2, 4), √3/2 for the
    /// Eisenstein lattice G_6 (N = 6, eq. 4.2).
    TargetVertices(usize),
}

impl Default for Density {
    fn default() -> Density {
        Density::TargetVertices(10_000)
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum ScaleFunction {
    /// m_i = 1.
    #[default]
    Uniform,
    /// m_i = min(1 + strength · |κ|max_i / κ_ref, max_ratio): finer where the absolute maximal
    /// principal curvature is large; κ_ref is the area-weighted mean of |κ|max.
    Curvature { strength: f64, max_ratio: f64 },
    /// Linear ramp along `axis`: m_i goes from `from` (at the smallest projection of a face
    /// centroid onto the axis) to `to` (at the largest); both must be positive.
    LinearRamp { axis: [f64; 3], from: f64, to: f64 },
}

/// Lattice cell area per vertex for unit spacing.
pub fn cell_area(symmetry: Symmetry) -> f64 {
    match symmetry {
        Symmetry::Six => 3f64.sqrt() / 2.0,
        _ => 1.0,
    }
}

pub fn face_multipliers(
    mesh: &TriMesh,
    scale: &ScaleFunction,
    curv: &Curvature,
) -> Result<Vec<f64>, FieldError> {
    let nf = mesh.n_faces();
    match *scale {
        ScaleFunction::Uniform => Ok(vec![1.0; nf]),
        ScaleFunction::Curvature {
            strength,
            max_ratio,
        } => {
            if !(strength >= 0.0
                && strength.is_finite()
                && max_ratio >= 1.0
                && max_ratio.is_finite())
            {
                return Err(FieldError::InvalidParameter(format!(
                    "curvature scale needs strength >= 0 and max_ratio >= 1 (got {strength}, {max_ratio})"
                )));
            }
            let kmax: Vec<f64> = (0..nf)
                .map(|f| curv.k1[f].abs().max(curv.k2[f].abs()))
                .collect();
            let (mut sa, mut sk) = (0.0, 0.0);
            for (f, k) in kmax.iter().enumerate() {
                let a = mesh.face_area(f);
                sa += a;
                sk += a * k;
            }
            let kref = if sa > 0.0 && sk > 0.0 { sk / sa } else { 1.0 };
            Ok(kmax
                .iter()
                .map(|k| (1.0 + strength * k / kref).min(max_ratio))
                .collect())
        }
        ScaleFunction::LinearRamp { axis, from, to } => {
            let axis = DVec3::from_array(axis).normalize_or_zero();
            if axis == DVec3::ZERO
                || !(from > 0.0 && to > 0.0 && from.is_finite() && to.is_finite())
            {
                return Err(FieldError::InvalidParameter(
                    "linear ramp needs a nonzero axis and positive finite end values".into(),
                ));
            }
            let t: Vec<f64> = (0..nf).map(|f| mesh.face_centroid(f).dot(axis)).collect();
            let lo = t.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = t.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let span = if hi > lo { hi - lo } else { 1.0 };
            Ok(t.iter()
                .map(|x| from + (to - from) * (x - lo) / span)
                .collect())
        }
    }
}

/// Grid size h for a density request.
pub fn grid_size(
    mesh: &TriMesh,
    density: &Density,
    symmetry: Symmetry,
    mult: &[f64],
) -> Result<f64, FieldError> {
    match *density {
        Density::EdgeLength(h) if h > 0.0 && h.is_finite() => Ok(h),
        Density::EdgeLength(h) => Err(FieldError::InvalidParameter(format!(
            "edge length must be positive, got {h}"
        ))),
        Density::TargetVertices(0) => Err(FieldError::InvalidParameter(
            "target vertex count must be positive".into(),
        )),
        Density::TargetVertices(n) => {
            let weighted: f64 = (0..mesh.n_faces())
                .map(|f| mesh.face_area(f) * mult[f] * mult[f])
                .sum();
            let h = (weighted / (cell_area(symmetry) * n as f64)).sqrt();
            if h > 0.0 && h.is_finite() {
                Ok(h)
            } else {
                Err(FieldError::InvalidParameter("mesh has zero area".into()))
            }
        }
    }
}

/// About how many vertices a grid of `density` has on `mesh` (uniform scale): the target, or
/// the area over the cell area (`None` where [`grid_size`] fails: no positive size or target,
/// or a mesh without area).
pub fn grid_vertices(mesh: &TriMesh, density: &Density, symmetry: Symmetry) -> Option<f64> {
    let area: f64 = (0..mesh.n_faces()).map(|f| mesh.face_area(f)).sum();
    if !(area > 0.0 && area.is_finite()) {
        return None;
    }
    match *density {
        Density::TargetVertices(n) if n > 0 => Some(n as f64),
        Density::EdgeLength(h) if h > 0.0 && h.is_finite() => {
            Some(area / (cell_area(symmetry) * h * h))
        }
        _ => None,
    }
}
