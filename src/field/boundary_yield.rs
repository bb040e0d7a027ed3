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

use super::CURVE_WEIGHT;
use super::smoothing::{self, DualLayout};
use super::transport::EdgeTransport;
use crate::sparse::{SolverError, c64};

/// See the module documentation: ½, the curvature direction nearer the diagonal than the lines
/// where the boundary's directions carry over undiminished (0.3 also released the height
/// field's last curvature faces; below it, faces within about 17° of the lines go too, N = 4).
pub const YIELD_ABOVE: f64 = 0.5;

/// Releases (sets ω to 0) the curvature faces that contradict the aligned boundary, among the
/// faces with `omega` > 0 that are not `on_curve`; the faces `along` a boundary curve (those of
/// them `on_curve`) are held to `reference` with the curves' weight [`CURVE_WEIGHT`]. Returns
/// how many were released.
pub fn yield_to_boundary(
    n: u32,
    transport: &EdgeTransport,
    reference: &[f64],
    omega: &mut [f64],
    on_curve: &[bool],
    along: &[u32],
    layout: &DualLayout,
) -> Result<usize, SolverError> {
    let nf = omega.len();
    let mut w = vec![0.0; nf];
    for &f in along {
        let f = f as usize;
        if f < nf && on_curve[f] {
            w[f] = CURVE_WEIGHT;
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

#[cfg(test)]
mod tests {
    use super::super::transport::FaceBases;
    use super::super::{FieldParams, compute_field};
    use crate::mesh::{TriMesh, generate};
    use glam::DVec3;
    use std::f64::consts::TAU;
    use std::sync::Arc;

    /// A one-turn helicoid strip (curvature lines at 45° to its sides) beside a torus far away:
    /// aligning the strip's boundary releases curvature faces on the strip (none without
    /// `boundary_aligned`), and none on the torus, which no boundary reaches (`relaxed_z` is 0
    /// on a component without weight rather than the extension of an arbitrary anchor).
    #[test]
    fn only_faces_the_boundary_reaches_yield() {
        let strip = generate::grid(60, 12, 1.0, 1.0);
        let torus = generate::torus(6.0, 2.0, 48, 16);
        let mut positions: Vec<DVec3> = strip
            .positions()
            .iter()
            .map(|p| {
                let (r, t) = (1.0 + p.y, TAU * p.x);
                DVec3::new(r * t.cos(), r * t.sin(), 0.5 * t)
            })
            .collect();
        let offset = positions.len() as u32;
        positions.extend(
            torus
                .positions()
                .iter()
                .map(|p| *p + DVec3::new(100.0, 0.0, 0.0)),
        );
        let mut faces = strip.faces().to_vec();
        faces.extend(torus.faces().iter().map(|f| f.map(|v| v + offset)));
        let mesh = TriMesh::from_triangles(positions, faces).unwrap();
        let strip_faces = strip.n_faces();
        // The strip's boundary faces, held to their boundary edge.
        let bases = FaceBases::new(&mesh);
        let mut along = Vec::new();
        let mut aligned = Vec::new();
        for h in 0..mesh.n_halfedges() {
            if mesh.twin(h).is_none() {
                let f = mesh.face_of(h);
                along.push(f as u32);
                aligned.push((f as u32, bases.angle_of(f, mesh.vector(h))));
            }
        }
        aligned.sort_by_key(|a| a.0);
        aligned.dedup_by_key(|a| a.0);
        along.sort_unstable();
        along.dedup();
        // Enough of the most reliable faces that both parts have some.
        let base = FieldParams {
            reliable_fraction: 0.4,
            ..FieldParams::default()
        };
        let plain = compute_field(&mesh, &base).unwrap();
        let curved = compute_field(
            &mesh,
            &FieldParams {
                aligned: Some(Arc::new(aligned)),
                boundary_aligned: Some(Arc::new(along.clone())),
                ..base.clone()
            },
        )
        .unwrap();
        let released = |range: std::ops::Range<usize>| {
            range
                .filter(|&f| along.binary_search(&(f as u32)).is_err())
                .filter(|&f| plain.omega[f] > 0.0 && curved.omega[f] == 0.0)
                .count()
        };
        let on_strip = released(0..strip_faces);
        let on_torus = released(strip_faces..mesh.n_faces());
        eprintln!("released: {on_strip} on the strip, {on_torus} on the torus");
        assert!(on_strip > 0, "nothing released on the strip");
        assert_eq!(on_torus, 0, "released on the torus");
        assert!(
            (strip_faces..mesh.n_faces()).any(|f| plain.omega[f] > 0.0),
            "the torus has curvature faces"
        );
    }
}
