//! Quality measures of a parameterization: flips, distortion, seams, singularity indices.

use std::f64::consts::TAU;

use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::TriMesh;

use super::cut::CutGraph;
use super::rot::{Lattice, Rots, apply};

/// Per face: (signed Jacobian determinant, σ_max, σ_min) of the map surface → texture.
pub(crate) fn jacobians(mesh: &TriMesh, uv: &[[f64; 2]]) -> Vec<(f64, f64, f64)> {
    (0..mesh.n_faces())
        .into_par_iter()
        .map(|f| jacobian(mesh, uv, f))
        .collect()
}

/// Face f's (signed Jacobian determinant, σ_max, σ_min) of the map surface → texture.
pub(crate) fn jacobian(mesh: &TriMesh, uv: &[[f64; 2]], f: usize) -> (f64, f64, f64) {
    let (e1, e2) = mesh.face_basis(f);
    let [a, b, c] = mesh.face(f).map(|v| mesh.position(v));
    let (p1, p2) = (b - a, c - a);
    let (x1, y1, x2, y2) = (p1.dot(e1), p1.dot(e2), p2.dot(e1), p2.dot(e2));
    let det_p = x1 * y2 - x2 * y1;
    let q1 = [
        uv[3 * f + 1][0] - uv[3 * f][0],
        uv[3 * f + 1][1] - uv[3 * f][1],
    ];
    let q2 = [
        uv[3 * f + 2][0] - uv[3 * f][0],
        uv[3 * f + 2][1] - uv[3 * f][1],
    ];
    // J = Q P^{-1}, P^{-1} = [[y2, -x2], [-y1, x1]] / det_p
    let j = [
        (q1[0] * y2 - q2[0] * y1) / det_p,
        (-q1[0] * x2 + q2[0] * x1) / det_p,
        (q1[1] * y2 - q2[1] * y1) / det_p,
        (-q1[1] * x2 + q2[1] * x1) / det_p,
    ];
    let det = j[0] * j[3] - j[1] * j[2];
    let (e, ff, g, h) = (
        (j[0] + j[3]) / 2.0,
        (j[0] - j[3]) / 2.0,
        (j[2] + j[1]) / 2.0,
        (j[2] - j[1]) / 2.0,
    );
    let (q, r) = (e.hypot(h), ff.hypot(g));
    (det, q + r, (q - r).abs())
}

/// [`conformal_p99`] of the map `uv`.
pub(crate) fn map_conformal_p99(mesh: &TriMesh, uv: &[[f64; 2]]) -> f64 {
    conformal_p99(&jacobians(mesh, uv))
}

/// The 99th percentile over faces of the conformal distortion σ_max/σ_min over the valid
/// faces (det J > 0, σ_min > 0), as [`quality`] reports it: the value at index ⌊0.99·n⌋ of
/// the sorted values, found by selection (at 1.1 M faces a sort took 80 ms).
pub(crate) fn conformal_p99(j: &[(f64, f64, f64)]) -> f64 {
    let mut conf: Vec<f64> = j
        .par_iter()
        .filter(|x| x.0 > 0.0 && x.2 > 0.0)
        .map(|&(_, s1, s2)| s1 / s2)
        .collect();
    if conf.is_empty() {
        return 1.0;
    }
    let k = ((conf.len() as f64 * 0.99) as usize).min(conf.len() - 1);
    *conf.select_nth_unstable_by(k, f64::total_cmp).1
}

const CAP: f64 = 1000.0;

pub(crate) struct Quality {
    pub flipped: usize,
    pub conformal_mean: f64,
    pub conformal_p99: f64,
    pub area_distortion: f64,
}

/// `flipped`: faces whose texture triangle has non-positive signed area. Over the valid faces
/// (det J > 0, σ_min > 0): conformal distortion σ_max/σ_min (area-weighted mean, 99th percentile over faces);
/// area distortion = area-weighted mean of max(r, 1/r), r = det J / (area-weighted mean |det J|).
/// Per-face values enter the means capped at 1000 (near-degenerate images would dominate).
pub(crate) fn quality(mesh: &TriMesh, uv: &[[f64; 2]]) -> Quality {
    let j = jacobians(mesh, uv);
    let areas: Vec<f64> = (0..mesh.n_faces())
        .into_par_iter()
        .map(|f| mesh.face_area(f))
        .collect();
    let total: f64 = areas.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    // Folds by the texture triangle's own orientation: a zero-area input face with a proper
    // image is not one.
    let flipped = super::untangle::folded(uv).len();
    // Distortion over the valid (non-flipped, non-degenerate) faces; flips are counted apart.
    let valid: Vec<bool> = j.iter().map(|x| x.0 > 0.0 && x.2 > 0.0).collect();
    let vtotal: f64 = areas
        .iter()
        .zip(&valid)
        .filter(|x| *x.1)
        .map(|x| x.0)
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    let conformal_mean = j
        .iter()
        .zip(&areas)
        .zip(&valid)
        .filter(|x| *x.1)
        .map(|((x, a), _)| (x.1 / x.2).min(CAP) * a)
        .sum::<f64>()
        / vtotal;
    let conformal_p99 = conformal_p99(&j);
    let mean_det = j
        .iter()
        .zip(&areas)
        .map(|(x, a)| x.0.abs() * a)
        .sum::<f64>()
        / total;
    let area_distortion = j
        .iter()
        .zip(&areas)
        .zip(&valid)
        .filter(|x| *x.1)
        .map(|((x, a), _)| {
            let r = x.0 / mean_det;
            r.max(1.0 / r).min(CAP) * a
        })
        .sum::<f64>()
        / vtotal;
    Quality {
        flipped,
        conformal_mean,
        conformal_p99,
        area_distortion,
    }
}

/// Max over interior edges and both endpoints of ‖uv_j − (R^t uv_i + τ)‖ plus the distance of τ
/// to the lattice.
pub(crate) fn seam_error(
    mesh: &TriMesh,
    rots: &Rots,
    uv: &[[f64; 2]],
    trans: &[(u8, [f64; 2])],
    lattice: Lattice,
) -> f64 {
    // A maximum: the same in any order (f64::max passes over NaN either way).
    (0..mesh.n_edges())
        .into_par_iter()
        .map(|e| {
            let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
                return 0.0;
            };
            let (t, tau) = trans[e];
            let r = rots.get(t as i64);
            let mut worst = lattice.distance(tau);
            for (ci, cj) in [(h0, mesh.next(h1)), (mesh.next(h0), h1)] {
                let p = apply(r, uv[ci]);
                worst = worst.max((uv[cj][0] - p[0] - tau[0]).hypot(uv[cj][1] - p[1] - tau[1]));
            }
            worst
        })
        .reduce(|| 0.0, f64::max)
}

/// Index of every interior vertex (0 on the boundary): (Σ δ_e + K(v)) / 2π, with δ_e the
/// angle from the matched, transported U of one face to the U of the next across edge e around
/// the fan, rounded to a multiple of 1/N; `defects` the angle defects K. Edge by edge: δ_e is
/// computed once (both of the edge's ends see it, with opposite signs), which halves the
/// trigonometry of walking every vertex's fan.
pub(crate) fn vertex_indices(
    mesh: &TriMesh,
    cut: &CutGraph,
    n: usize,
    frames: &[[DVec3; 2]],
    defects: &[f64],
) -> Vec<f64> {
    use rayon::prelude::*;
    // δ_e seen from the end of h0 (h0 runs into it; from face(h0) to face(h1)).
    let delta: Vec<f64> = (0..mesh.n_edges())
        .into_par_iter()
        .map(|e| {
            let (h0, h1) = mesh.edge_halfedges(e);
            let Some(h1) = h1 else { return 0.0 };
            let (fa, fb) = (mesh.face_of(h0), mesh.face_of(h1));
            let d = mesh.vector(h0).normalize_or_zero();
            let ang = |f: usize| {
                let u = frames[f][0];
                let nrm = mesh.face_normal(f);
                u.dot(nrm.cross(d)).atan2(u.dot(d))
            };
            let r = super::cut::crossing(mesh, &cut.matching, n, e, fa) as f64;
            let delta = ang(fb) - (ang(fa) + TAU * r / n as f64);
            delta - TAU * (delta / TAU).round()
        })
        .collect();
    (0..mesh.n_vertices())
        .into_par_iter()
        .map(|v| {
            if mesh.is_boundary_vertex(v) {
                return 0.0;
            }
            let sum: f64 = mesh
                .outgoing(v)
                .map(|h| {
                    let hp = mesh.prev(h);
                    let e = mesh.edge(hp);
                    if mesh.edge_halfedges(e).0 == hp {
                        delta[e]
                    } else {
                        -delta[e]
                    }
                })
                .sum();
            let idx = (sum + defects[v]) / TAU;
            (idx * n as f64).round() / n as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The selection gives the value a full sort puts at index ⌊0.99·n⌋ of the valid
        /// faces' ratios, whatever their order; folded and degenerate faces are left out.
        #[test]
        fn the_p99_by_selection_is_the_sorted_one(
            j in prop::collection::vec((-1.0f64..1.0, 1.0f64..5.0, prop_oneof![Just(0.0), 0.1f64..1.0]), 0..400)
        ) {
            let mut ratios: Vec<f64> = j
                .iter()
                .filter(|x| x.0 > 0.0 && x.2 > 0.0)
                .map(|x| x.1 / x.2)
                .collect();
            ratios.sort_by(f64::total_cmp);
            let want = ratios
                .get(((ratios.len() as f64 * 0.99) as usize).min(ratios.len().saturating_sub(1)))
                .copied()
                .unwrap_or(1.0);
            prop_assert_eq!(conformal_p99(&j), want);
        }
    }
}
