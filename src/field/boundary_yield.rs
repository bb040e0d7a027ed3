//! Curvature alignment yields to an aligned boundary where the two contradict.
//!
//! A geometric curve on the boundary (`align_boundary`, or one drawn along it) holds the faces
//! beside it to its direction (thesis sec. 4.4); the most reliable curvature faces hold theirs
//! (sec. 3.2). On a crease the two agree: the crease is the curvature's own feature. A boundary
//! is not: where it runs says nothing about the surface's curvature directions, which may cross
//! it at any angle. Where the boundary's directions reach far into the surface (a strip between
//! two aligned sides, a patch whose sides are straight) and the curvature directions there lie
//! nearer the diagonal between the boundary's lines than the lines themselves, the field is
//! pulled two ways: it turns from one to the other within a few faces, or rounds into
//! singularity pairs, and the map between the boundary's straight lines shears into folds.
//! Measured on generated open patches with `--align-boundary`, N = 4 (before → after):
//! a helicoid of one turn (r in [1, 2]) 2 singularities, 353 folded faces after the repair and
//! 662 patched places → none, conformal distortion 24.7 → 1.18; a wavy height field 12
//! singularities, 12 patched places → 8 and none; a 40:1 sheet 6 singularities, 12 patched
//! places → none (docs/untangling.md).
//!
//! How far the boundary reaches is read from the relaxed field of the boundary faces alone
//! ([`smoothing::relaxed_z`]): |z| is near 1 where their directions carry over coherently and
//! decays where they wind or cancel (around a round hole it falls off within a few hole radii).
//! A curvature face f is released (weight 0) when
//!   |z_f| · sin²(N δ_f / 2) > [`YIELD_ABOVE`],
//! δ_f the angle between its curvature direction and the nearest of z_f's N directions: with
//! |z| = 1 it yields when it lies nearer the diagonal (δ = π/N) than the lines (δ = 0).
//! Crease curves are left to compete as before: on fandisk with features the same test
//! releases 11 faces and moves folds and patched places both ways (measured, not kept).

use super::smoothing::{self, DualLayout};
use super::transport::EdgeTransport;
use crate::sparse::{SolverError, c64};

/// See the module documentation: ½, the curvature direction nearer the diagonal than the lines
/// where the boundary's directions carry over undiminished (0.3 also released the height
/// field's last curvature faces; below it, faces within about 17° of the lines go too, N = 4).
pub const YIELD_ABOVE: f64 = 0.5;

/// Releases (sets ω to 0) the curvature faces that contradict the aligned boundary, among the
/// faces with `omega` > 0 that are not `on_curve`; the faces `along` a boundary curve (those of
/// them `on_curve`) are held to `reference` with `weight`. Returns how many were released.
#[allow(clippy::too_many_arguments)]
pub fn yield_to_boundary(
    n: u32,
    transport: &EdgeTransport,
    reference: &[f64],
    omega: &mut [f64],
    on_curve: &[bool],
    along: &[u32],
    weight: f64,
    layout: &DualLayout,
) -> Result<usize, SolverError> {
    let nf = omega.len();
    let mut w = vec![0.0; nf];
    for &f in along {
        let f = f as usize;
        if f < nf && on_curve[f] {
            w[f] = weight;
        }
    }
    let competing = (0..nf).any(|f| omega[f] > 0.0 && !on_curve[f]);
    if !competing || w.iter().all(|&x| x == 0.0) {
        return Ok(0);
    }
    let z = smoothing::relaxed_z(n, transport, reference, &w, layout)?;
    let mut released = 0;
    for f in 0..nf {
        if on_curve[f] || omega[f] <= 0.0 {
            continue;
        }
        let reach = z[f].norm();
        if reach == 0.0 || !reach.is_finite() {
            continue;
        }
        // cos(N δ) from the curvature direction against z's (both as N-th powers).
        let cos_nd = (z[f].conj() * c64::from_polar(1.0, n as f64 * reference[f])).re / reach;
        if reach * (1.0 - cos_nd) / 2.0 > YIELD_ABOVE {
            omega[f] = 0.0;
            released += 1;
        }
    }
    Ok(released)
}
