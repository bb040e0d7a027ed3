//! Curvature classification for hexagonal (sec. 4.1.1) and stripe (sec. 4.2) fields, and the
//! per-face alignment targets for every symmetry.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_8};

use serde::{Deserialize, Serialize};

use super::Symmetry;
use super::curvature::Curvature;

/// Local shape class from (κ1 − κ2, κ1 + κ2) = ρ (cos Φ, sin Φ), sec. 4.1.1 / fig. 4.6.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ShapeClass {
    /// ρ < δ.
    Planar,
    /// |Φ| > 3π/8 (spherical or inverted spherical).
    Elliptic,
    /// |Φ| < π/8.
    Hyperbolic,
    /// π/8 ≤ |Φ| ≤ 3π/8 (cylindrical or inverted cylindrical).
    Cylindrical,
}

/// Φ ∈ [−π/2, π/2] (κ1 ≥ κ2) and ρ of the polar form of (κ1 − κ2, κ1 + κ2).
pub fn polar(k1: f64, k2: f64) -> (f64, f64) {
    let (x, y) = (k1 - k2, k1 + k2);
    (y.atan2(x), x.hypot(y))
}

pub fn classify(k1: f64, k2: f64, delta: f64) -> ShapeClass {
    let (phi, rho) = polar(k1, k2);
    if rho < delta {
        ShapeClass::Planar
    } else if phi.abs() > 3.0 * FRAC_PI_8 {
        ShapeClass::Elliptic
    } else if phi.abs() < FRAC_PI_8 {
        ShapeClass::Hyperbolic
    } else {
        ShapeClass::Cylindrical
    }
}

/// Per face: the reference direction (angle in the face basis) the field should follow, and
/// whether the face may act as an alignment constraint.
/// - N = 4: κ1 direction everywhere (4-fold symmetry makes max/min equivalent); all non-planar
///   faces are candidates (sec. 3.1/3.2; planar faces have no meaningful directions).
/// - N = 6: max-curvature direction where Φ > 0, min-curvature where Φ < 0, i.e. the direction of
///   largest |κ|; only cylindrical faces are candidates (sec. 4.1.1).
/// - N = 2: the direction of smallest |κ| (the "minimum curvature" direction along a tube, with
///   the same Φ rule mirrored); only cylindrical faces are candidates (sec. 4.2).
pub fn targets(
    curv: &Curvature,
    symmetry: Symmetry,
    delta: f64,
) -> (Vec<f64>, Vec<bool>, Vec<ShapeClass>) {
    let n = curv.k1.len();
    let mut dir = Vec::with_capacity(n);
    let mut cand = Vec::with_capacity(n);
    let mut class = Vec::with_capacity(n);
    for f in 0..n {
        let (k1, k2) = (curv.k1[f], curv.k2[f]);
        let c = classify(k1, k2, delta);
        let (phi, _) = polar(k1, k2);
        let max_bend = if phi >= 0.0 {
            curv.dir1[f]
        } else {
            curv.dir1[f] + FRAC_PI_2
        };
        let (d, ok) = match symmetry {
            Symmetry::Four => (curv.dir1[f], c != ShapeClass::Planar),
            Symmetry::Six => (max_bend, c == ShapeClass::Cylindrical),
            Symmetry::Two => (max_bend + FRAC_PI_2, c == ShapeClass::Cylindrical),
        };
        dir.push(d);
        cand.push(ok);
        class.push(c);
    }
    (dir, cand, class)
}
