//! Singularities: fractional index (eq. 2.37 generalised to N) and full index per vertex.
//!
//! For an interior vertex v with faces t_0, …, t_{m−1} in counter-clockwise order, crossing from
//! t_k to t_{k+1} contributes the residual angle
//!   d_k = wrap_(−π,π](θ_{k+1} − θ_k − κ_{k,k+1} − (2π/N) r_{k,k+1}),
//! and the full index is ind(v) = (K_v + Σ_k d_k) / 2π with K_v the angle defect. It is always a
//! multiple of 1/N; we store the integer k with ind(v) = k/N. Its fractional part is the
//! fractional index of eq. (2.37), ind_f(v) = (1/N)(Σ_k r_{k+1,k} mod N) (the thesis sums r along
//! its loop orientation; with our counter-clockwise order that is r_{k+1,k} = −r_{k,k+1}).
//! Summing over a closed surface, every d_k cancels with the opposite crossing and Σ K_v = 2πχ,
//! hence Σ_v k_v = Nχ.
//!
//! Boundary convention: boundary vertices carry no index. Instead each contributes
//!   b(v) = (π − Σ corner angles + Σ_{interior fan edges} d_k) / 2π
//! (geodesic curvature of the boundary plus the field's turning across its fan); with
//! B = Σ_boundary b(v) the discrete Poincaré–Hopf theorem reads Σ_interior ind(v) = χ − B.
//!
//! Turn index: from unreduced integer turns r alone the face angles telescope around the fan,
//! k = N (K_v − Σ_k (κ_{k,k+1} + (2π/N) r_{k,k+1})) / 2π (`turn_index_k_at`, `turn_indices`),
//! the index the fixed-matching solve realizes for those turns. It equals the index above
//! whenever no residual reaches π (closest turns), and unlike it changes by ±N when the turns
//! along a path change by ±N: integral indices (±N/N, holonomy 0) move and cancel by turns.

use std::f64::consts::TAU;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::FrameField;
use super::transport::{EdgeTransport, FaceBases, wrap_pi};
use crate::mesh::TriMesh;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Singularity {
    pub vertex: usize,
    /// Index k/N.
    pub k: i32,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct IndexReport {
    pub n: u32,
    /// Full index numerator k (index = k/N) per vertex; `None` on boundary vertices.
    pub index_k: Vec<Option<i32>>,
    /// Fractional index numerator (0..N) by eq. (2.37) per vertex; `None` on boundary vertices.
    pub fractional_k: Vec<Option<u32>>,
    /// Interior vertices with nonzero index.
    pub singularities: Vec<Singularity>,
    /// Σ of k over interior vertices (the index sum is this / N).
    pub interior_sum_k: i64,
    /// B = Σ over boundary vertices of b(v) (see module docs); 0 for closed meshes.
    pub boundary_contribution: f64,
    /// χ = V − E + F of the mesh.
    pub euler_characteristic: i64,
    /// Largest distance of N·ind(v) from an integer before rounding (numerical sanity; ~1e-12).
    pub max_rounding_residual: f64,
}

impl IndexReport {
    /// Σ_interior ind(v) + B − χ: zero up to rounding when Poincaré–Hopf holds.
    pub fn poincare_hopf_defect(&self) -> f64 {
        self.interior_sum_k as f64 / self.n as f64 + self.boundary_contribution
            - self.euler_characteristic as f64
    }
}

/// Angle per face of the field's U direction, robust for non-orthonormal frames: the angle of
/// the conformal part U − J V (equal to 2U when V = J U).
pub fn frame_angles(field: &FrameField, bases: &FaceBases) -> Vec<f64> {
    field
        .frames
        .iter()
        .enumerate()
        .map(|(f, [u, v])| {
            let jv = bases.normal[f].cross(*v);
            bases.angle_of(f, *u - jv)
        })
        .collect()
}

/// Indices of a field on a mesh (the field must match the mesh's face/edge counts).
pub fn compute_indices(mesh: &TriMesh, field: &FrameField) -> IndexReport {
    let bases = FaceBases::new(mesh);
    let tr = EdgeTransport::new(mesh, &bases);
    let theta = frame_angles(field, &bases);
    indices_from_angles(mesh, &tr, &theta, &field.matchings, field.symmetry.n())
}

pub(crate) fn indices_from_angles(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    theta: &[f64],
    matchings: &[i32],
    n: u32,
) -> IndexReport {
    indices_from_angles_with(mesh, tr, theta, matchings, n, &mesh.angle_defects())
}

/// [`indices_from_angles`] with the mesh's angle defects ([`TriMesh::angle_defects`]) given.
pub(crate) fn indices_from_angles_with(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    theta: &[f64],
    matchings: &[i32],
    n: u32,
    defects: &[f64],
) -> IndexReport {
    let ni = n as i64;
    let mut rep = IndexReport {
        n,
        index_k: vec![None; mesh.n_vertices()],
        fractional_k: vec![None; mesh.n_vertices()],
        singularities: Vec::new(),
        interior_sum_k: 0,
        boundary_contribution: 0.0,
        euler_characteristic: mesh.euler_characteristic(),
        max_rounding_residual: 0.0,
    };
    let (sum_d, sum_r, touched) = all_fan_sums(mesh, tr, theta, n, |e| matchings[e] as i64);
    for v in 0..mesh.n_vertices() {
        if !touched[v] {
            continue;
        }
        if mesh.is_boundary_vertex(v) {
            rep.boundary_contribution += (defects[v] + sum_d[v]) / TAU;
        } else {
            let x = n as f64 * (defects[v] + sum_d[v]) / TAU;
            let k = x.round();
            rep.max_rounding_residual = rep.max_rounding_residual.max((x - k).abs());
            let k = k as i32;
            rep.index_k[v] = Some(k);
            rep.fractional_k[v] = Some((-sum_r[v]).rem_euclid(ni) as u32);
            rep.interior_sum_k += k as i64;
            if k != 0 {
                rep.singularities.push(Singularity { vertex: v, k });
            }
        }
    }
    rep
}

/// [`fan_turning`] for every vertex at once, edge by edge: per vertex Σ d_k and Σ r over its
/// interior fan edges, and whether any face touches it. Crossing the edge of halfedge g from
/// face(g) to face(twin g) is the crossing counter-clockwise around the vertex g ends at, so each
/// interior edge gives one term to each of its two vertices. Alone this is no faster than
/// walking every fan (~0.1 s at a million faces), but its accesses stream through memory: in the
/// field pipeline, with the ordering thread loading memory beside it, the cancellation and
/// singularity stages took 0.18–0.26 and 0.11–0.17 s this way (five runs) against 0.29–0.54
/// and 0.22 s with fan walks (two runs).
pub(crate) fn all_fan_sums(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    theta: &[f64],
    n: u32,
    turns: impl Fn(usize) -> i64 + Sync,
) -> (Vec<f64>, Vec<i64>, Vec<bool>) {
    let step = TAU / n as f64;
    // Per interior edge: (vertex, d, r) for both crossings, as fan_turning computes them.
    let terms: Vec<[(u32, f64, i64); 2]> = (0..mesh.n_edges())
        .into_par_iter()
        .filter_map(|e| {
            let (h0, h1) = mesh.edge_halfedges(e);
            let h1 = h1?;
            let r = turns(e);
            let (d0, r0) = crossing(tr, theta, step, e, true, r);
            let (d1, r1) = crossing(tr, theta, step, e, false, r);
            Some([(mesh.to(h0) as u32, d0, r0), (mesh.to(h1) as u32, d1, r1)])
        })
        .collect();
    let nv = mesh.n_vertices();
    let (mut sum_d, mut sum_r) = (vec![0.0; nv], vec![0i64; nv]);
    for &(v, d, r) in terms.iter().flatten() {
        sum_d[v as usize] += d;
        sum_r[v as usize] += r;
    }
    let mut touched = vec![false; nv];
    for f in mesh.faces() {
        for &v in f {
            touched[v as usize] = true;
        }
    }
    (sum_d, sum_r, touched)
}

/// Around vertex v (counter-clockwise, over its interior fan edges): the summed residual angles
/// Σ d_k, the summed matchings Σ r_{k,k+1}, and whether v is on the boundary; `None` for an
/// isolated vertex. `turns(e)` is the matching of edge e (any representative mod N).
#[cfg(test)]
pub(crate) fn fan_turning(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    theta: &[f64],
    v: usize,
    n: u32,
    turns: impl Fn(usize) -> i64,
) -> Option<(f64, i64, bool)> {
    let step = TAU / n as f64;
    let hs: Vec<usize> = mesh.outgoing(v).collect();
    if hs.is_empty() {
        return None;
    }
    let boundary = mesh.is_boundary_vertex(v);
    let mut sum_d = 0.0;
    let mut sum_r = 0i64;
    let crossings = if boundary { hs.len() - 1 } else { hs.len() };
    for &h in hs.iter().take(crossings) {
        // Crossing from face(h) to the next face counter-clockwise, over the edge of prev(h).
        let e = mesh.edge(mesh.prev(h));
        let forward = tr.faces[e][0] as usize == mesh.face_of(h);
        let (d, r) = crossing(tr, theta, step, e, forward, turns(e));
        sum_d += d;
        sum_r += r;
    }
    Some((sum_d, sum_r, boundary))
}

/// Crossing interior edge e from its first face to its second (`forward`) or back, with the
/// edge's matching `turn` (first to second): the residual angle d (wrapped to (−π, π]) and the
/// matching in the direction of the crossing.
fn crossing(
    tr: &EdgeTransport,
    theta: &[f64],
    step: f64,
    e: usize,
    forward: bool,
    turn: i64,
) -> (f64, i64) {
    let (a, b) = (tr.faces[e][0] as usize, tr.faces[e][1] as usize);
    let (from, to, kappa, r) = if forward {
        (a, b, tr.kappa[e], turn)
    } else {
        (b, a, -tr.kappa[e], -turn)
    };
    (
        wrap_pi(theta[to] - theta[from] - kappa - step * r as f64),
        r,
    )
}

/// The full index numerator k (index k/N) of an interior vertex from the angles (residuals
/// wrapped); `None` on the boundary.
#[cfg(test)]
pub(crate) fn index_k_at(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    theta: &[f64],
    v: usize,
    n: u32,
    turns: impl Fn(usize) -> i64,
) -> Option<i32> {
    let (sum_d, _, boundary) = fan_turning(mesh, tr, theta, v, n, turns)?;
    (!boundary).then(|| (n as f64 * (mesh.angle_defect(v) + sum_d) / TAU).round() as i32)
}

/// The full index numerator k (index k/N) of interior vertex v from the unreduced integer turns
/// alone (`turns(e)` from the first face of e to the second), with v's angle defect `defect`:
/// around v's fan the face angles telescope, so
///   k = N (K_v − Σ_k (κ_{k,k+1} + (2π/N) r_{k,k+1})) / 2π
/// over the counter-clockwise crossings, without wrapping any residual. This is the index the
/// fixed-matching solve realizes for these turns (changing one turn by N moves the solution's
/// angles, and the index, by a full turn). It equals the angle-based index
/// ([`indices_from_angles`]) whenever every residual angle is below π, e.g. for the closest
/// turns of any field, but unlike it sees a turn change by N and never mistakes a change by
/// N/2 for its opposite (see `cancel`). `None` on the boundary.
pub(crate) fn turn_index_k_at(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    defect: f64,
    v: usize,
    n: u32,
    turns: impl Fn(usize) -> i64,
) -> Option<i32> {
    if mesh.is_boundary_vertex(v) {
        return None;
    }
    let step = TAU / n as f64;
    let mut sum = defect;
    let mut any = false;
    for h in mesh.outgoing(v) {
        any = true;
        // Crossing from face(h) to the next face counter-clockwise, over the edge of prev(h).
        let e = mesh.edge(mesh.prev(h));
        let c = tr.kappa[e] + step * turns(e) as f64;
        sum += if tr.faces[e][0] as usize == mesh.face_of(h) {
            -c
        } else {
            c
        };
    }
    any.then(|| (n as f64 * sum / TAU).round() as i32)
}

/// [`turn_indices_from`] with the angle defects computed here (tests).
#[cfg(test)]
pub(crate) fn turn_indices(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    turns: &[i64],
    n: u32,
) -> Vec<Option<i32>> {
    turn_indices_from(mesh, tr, turns, n, &mesh.angle_defects())
}

/// [`turn_index_k_at`] of every vertex at once, edge by edge, with the mesh's angle defects
/// ([`TriMesh::angle_defects`]) given (`None` on boundary and isolated vertices): crossing the
/// edge of halfedge g from face(g) to face(twin g) is the crossing counter-clockwise around the
/// vertex g ends at.
pub(crate) fn turn_indices_from(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    turns: &[i64],
    n: u32,
    defects: &[f64],
) -> Vec<Option<i32>> {
    let step = TAU / n as f64;
    let mut sum = defects.to_vec();
    let mut touched = vec![false; mesh.n_vertices()];
    for f in mesh.faces() {
        for &v in f {
            touched[v as usize] = true;
        }
    }
    for (e, &r) in turns.iter().enumerate() {
        let (h0, h1) = mesh.edge_halfedges(e);
        let Some(h1) = h1 else { continue };
        let c = tr.kappa[e] + step * r as f64;
        sum[mesh.to(h0)] -= c;
        sum[mesh.to(h1)] += c;
    }
    (0..mesh.n_vertices())
        .map(|v| {
            (touched[v] && !mesh.is_boundary_vertex(v))
                .then(|| (n as f64 * sum[v] / TAU).round() as i32)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::cancel::{PathSearch, apply};
    use crate::field::smoothing::nearest_turns;
    use crate::mesh::generate::{cylinder, torus_alternating};

    /// A closed and an open mesh with a deterministic pseudo-random field on each.
    fn fixtures() -> Vec<(TriMesh, EdgeTransport, Vec<f64>)> {
        [
            torus_alternating(3.0, 1.0, 24, 12),
            cylinder(1.0, 2.0, 20, 7),
        ]
        .into_iter()
        .map(|mesh| {
            let tr = EdgeTransport::new(&mesh, &FaceBases::new(&mesh));
            let theta = (0..mesh.n_faces())
                .map(|f| ((f * 7919) % 1000) as f64 * 0.0137)
                .collect();
            (mesh, tr, theta)
        })
        .collect()
    }

    /// For the closest turns of any field (every residual below π) the turn index equals the
    /// angle-based one, batch and per vertex; changing the turns along a path by N changes the
    /// turn index by ±N at its ends only, and leaves the angle-based one as it was.
    #[test]
    fn turn_index_equals_the_angle_index_of_closest_turns_and_sees_full_turns() {
        let mut singular = 0;
        for (mesh, tr, theta) in fixtures() {
            let interior: Vec<usize> = (0..mesh.n_vertices())
                .filter(|&v| !mesh.is_boundary_vertex(v))
                .collect();
            let (p, q) = (interior[3], interior[interior.len() / 2]);
            let path = PathSearch::new(mesh.n_vertices())
                .shortest_interior_path(&mesh, p, q, f64::INFINITY)
                .unwrap();
            for n in [2, 4, 6] {
                let mut turns = nearest_turns(&tr, &theta, TAU / n as f64);
                let matchings: Vec<i32> = turns
                    .iter()
                    .map(|r| r.rem_euclid(n as i64) as i32)
                    .collect();
                let by_angle = indices_from_angles(&mesh, &tr, &theta, &matchings, n).index_k;
                let by_turns = turn_indices(&mesh, &tr, &turns, n);
                assert_eq!(by_turns, by_angle, "N = {n}");
                singular += by_angle.iter().flatten().filter(|&&k| k != 0).count();
                for v in 0..mesh.n_vertices() {
                    let at = turn_index_k_at(&mesh, &tr, mesh.angle_defect(v), v, n, |e| turns[e]);
                    assert_eq!(at, by_turns[v], "vertex {v}, N = {n}");
                }
                apply(&mesh, &mut turns, &path, n as i32, 1);
                let moved = turn_indices(&mesh, &tr, &turns, n);
                for v in 0..mesh.n_vertices() {
                    let change = moved[v].zip(by_turns[v]).map(|(a, b)| (a - b).abs());
                    let expected = if v == p || v == q { n as i32 } else { 0 };
                    assert_eq!(change.unwrap_or(0), expected, "vertex {v}, N = {n}");
                    let angle = index_k_at(&mesh, &tr, &theta, v, n, |e| turns[e]);
                    assert_eq!(angle, by_angle[v], "vertex {v}, N = {n}");
                }
            }
        }
        assert!(singular > 100, "{singular} singularities");
    }

    /// The edge-wise sums equal the per-vertex fan walk on closed and open meshes, with random
    /// angles and turns (so that many residuals wrap), and the face-wise angle defects equal the
    /// per-vertex ones.
    #[test]
    fn edge_wise_fan_sums_and_defects_equal_the_fan_walk() {
        for (mesh, tr, theta) in fixtures() {
            // A deterministic pseudo-random field and matchings.
            let turns = |e: usize| ((e * 104_729) % 9) as i64 - 4;
            for n in [2, 4, 6] {
                let (sum_d, sum_r, touched) = all_fan_sums(&mesh, &tr, &theta, n, turns);
                for v in 0..mesh.n_vertices() {
                    let (d, r, boundary) = fan_turning(&mesh, &tr, &theta, v, n, turns).unwrap();
                    assert!(touched[v]);
                    assert_eq!(boundary, mesh.is_boundary_vertex(v));
                    assert_eq!(r, sum_r[v], "vertex {v}, N = {n}");
                    assert!(
                        (d - sum_d[v]).abs() < 1e-12,
                        "vertex {v}: {d} vs {}",
                        sum_d[v]
                    );
                }
            }
            let defects = mesh.angle_defects();
            for (v, d) in defects.iter().enumerate() {
                assert!((d - mesh.angle_defect(v)).abs() < 1e-12, "vertex {v}");
            }
        }
    }
}
