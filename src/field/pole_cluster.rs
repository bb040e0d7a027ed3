//! Pole clusters: a pole's worth of positive singularities crowded where the surface has little
//! curvature to pay for them.
//!
//! Why: the relaxed field solve is quadratic in z = e^{iNθ}, and a quadratic energy lets N zeros
//! of order one merge into one zero of order N at no extra cost. Where curvature directions
//! guide nothing (an umbilic dome: a capsule's hemispherical ends, a rounded tip) the field
//! carried in from the guided part (a cylinder's rulings) then winds round one point, and its
//! rounding puts N singularities of index +1/N within a few cells of it: polar cells around the
//! dome's top. A seamless map must shrink its cells towards such a cluster, because the cluster
//! holds a full turn of index over a patch that holds almost no Gaussian curvature (a capsule:
//! conformal distortion 1.47, remesh RSD edge 26 %). The Ginzburg–Landau renormalization
//! (`smoothing::RENORMALIZE_STEPS`) makes the merged zero unstable and spreads the N zeros
//! over the dome; `field::compute_field` renormalizes when [`crowded_pole`] finds a cluster.
//!
//! A cluster that does sit on its curvature (a cone's apex holds it in one vertex) is left as
//! it is: renormalization cannot spread what the geometry concentrates. So is a pole, one
//! vertex of index +1 or more (a spheroid's umbilic), which the pole treatment takes.

use std::collections::HashMap;
use std::f64::consts::TAU;

use crate::mesh::TriMesh;
use crate::mesh::disjoint::Disjoint;

/// Positive singularities closer than this many grid cells are linked into one cluster, at each
/// of these scales in turn (a dome's N singularities sit 3–8 cells apart, depending on N and
/// the dome's size).
pub const LINK_CELLS: [f64; 3] = [4.0, 8.0, 16.0];
/// A cluster is a crowded pole when the angle defect within its extent (plus [`MARGIN_CELLS`])
/// is below this fraction of its total index (as angle, 2π per unit of index).
pub const CURVATURE_SHARE: f64 = 0.5;
/// See [`CURVATURE_SHARE`].
pub const MARGIN_CELLS: f64 = 2.0;

/// Whether the positive singularities (`indices[v] = Some(k)`, index k/N; boundary vertices
/// `None`), linked at any of [`LINK_CELLS`] grid cells (`cell` is the grid size), form a
/// cluster of total index at least +1, none of them a pole by itself, whose ball (its extent
/// around its centroid plus [`MARGIN_CELLS`]) holds a net index of at least +1 (negative
/// singularities inside count) and less than [`CURVATURE_SHARE`] of that net index in angle
/// defect (`defects`: the mesh's, [`TriMesh::angle_defects`]).
pub fn crowded_pole(
    mesh: &TriMesh,
    indices: &[Option<i32>],
    defects: &[f64],
    n: u32,
    cell: f64,
) -> bool {
    if !(cell.is_finite() && cell > 0.0) {
        return false;
    }
    let positive: Vec<usize> = (0..indices.len())
        .filter(|&v| indices[v].is_some_and(|k| k > 0))
        .collect();
    let total: i32 = positive.iter().map(|&v| indices[v].unwrap_or(0)).sum();
    total >= n as i32
        && LINK_CELLS
            .iter()
            .any(|&link| crowded_at(mesh, indices, &positive, defects, n, cell, link * cell))
}

/// [`crowded_pole`] with the `positive` singular vertices linked at distance `link`.
fn crowded_at(
    mesh: &TriMesh,
    indices: &[Option<i32>],
    positive: &[usize],
    defects: &[f64],
    n: u32,
    cell: f64,
    link: f64,
) -> bool {
    // linked over a spatial hash of side `link`
    let mut sets = Disjoint::new(positive.len());
    let bucket = |i: usize| {
        let p = mesh.position(positive[i]) / link;
        [p.x.floor() as i64, p.y.floor() as i64, p.z.floor() as i64]
    };
    let mut hash: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for i in 0..positive.len() {
        hash.entry(bucket(i)).or_default().push(i);
    }
    for i in 0..positive.len() {
        let b = bucket(i);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(others) = hash.get(&[b[0] + dx, b[1] + dy, b[2] + dz]) else {
                        continue;
                    };
                    for &j in others {
                        if j > i
                            && mesh
                                .position(positive[i])
                                .distance(mesh.position(positive[j]))
                                < link
                        {
                            sets.union(i, j);
                        }
                    }
                }
            }
        }
    }
    let mut clusters: HashMap<usize, Vec<usize>> = HashMap::new();
    for i in 0..positive.len() {
        clusters.entry(sets.find(i)).or_default().push(positive[i]);
    }
    let candidates: Vec<Vec<usize>> = clusters
        .into_values()
        .filter(|c| c.iter().map(|&v| indices[v].unwrap_or(0)).sum::<i32>() >= n as i32)
        // one vertex of index +1 or more is a pole the pole treatment takes as it is (a
        // spheroid's umbilic, thesis sec. 4.3), not zeros crowded together
        .filter(|c| c.iter().all(|&v| indices[v].unwrap_or(0) < n as i32))
        .collect();
    candidates.iter().any(|c| {
        let centre = c.iter().map(|&v| mesh.position(v)).sum::<glam::DVec3>() / c.len() as f64;
        let extent = c
            .iter()
            .map(|&v| mesh.position(v).distance(centre))
            .fold(0.0, f64::max)
            + MARGIN_CELLS * cell;
        let inside: Vec<usize> = (0..mesh.n_vertices())
            .filter(|&v| indices[v].is_some() && mesh.position(v).distance(centre) <= extent)
            .collect();
        let curvature: f64 = inside.iter().map(|&v| defects[v]).sum();
        // the net index inside: negative singularities among the positive ones pay for them
        let k: i32 = inside.iter().map(|&v| indices[v].unwrap_or(0)).sum::<i32>();
        if k < n as i32 {
            return false;
        }
        curvature < CURVATURE_SHARE * TAU * k as f64 / n as f64
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::grid;

    /// A flat 41 × 41 grid of unit cells: no curvature anywhere.
    fn flat() -> (TriMesh, Vec<Option<i32>>) {
        let mesh = grid(40, 40, 40.0, 40.0);
        let indices = (0..mesh.n_vertices())
            .map(|v| (!mesh.is_boundary_vertex(v)).then_some(0))
            .collect();
        (mesh, indices)
    }

    fn vertex_at(mesh: &TriMesh, x: f64, y: f64) -> usize {
        (0..mesh.n_vertices())
            .min_by(|&a, &b| {
                let d = |v: usize| (mesh.position(v) - glam::DVec3::new(x, y, 0.0)).length();
                d(a).total_cmp(&d(b))
            })
            .unwrap()
    }

    /// [`crowded_pole`] for N = 4 on unit cells.
    fn crowded(mesh: &TriMesh, indices: &[Option<i32>]) -> bool {
        crowded_pole(mesh, indices, &mesh.angle_defects(), 4, 1.0)
    }

    /// Index `k`/N at the vertices nearest `at`.
    fn mark(mesh: &TriMesh, indices: &mut [Option<i32>], at: &[(f64, f64)], k: i32) {
        for &(x, y) in at {
            indices[vertex_at(mesh, x, y)] = Some(k);
        }
    }

    #[test]
    fn four_quarters_close_together_on_a_flat_patch_are_a_crowded_pole() {
        let (mesh, mut indices) = flat();
        let square = [(18.0, 18.0), (22.0, 18.0), (18.0, 22.0), (22.0, 22.0)];
        mark(&mesh, &mut indices, &square, 1);
        assert!(crowded(&mesh, &indices));
        // three quarters are not a pole's worth
        mark(&mesh, &mut indices, &[(22.0, 22.0)], 0);
        assert!(!crowded(&mesh, &indices));
        // a negative one among four pays for one of them
        mark(&mesh, &mut indices, &[(22.0, 22.0)], 1);
        mark(&mesh, &mut indices, &[(20.0, 20.0)], -1);
        assert!(!crowded(&mesh, &indices));
    }

    #[test]
    fn far_apart_or_one_pole_is_no_crowded_pole() {
        let (mesh, mut indices) = flat();
        // more than the widest link (16 cells) apart
        let corners = [(2.0, 2.0), (38.0, 2.0), (2.0, 38.0), (38.0, 38.0)];
        mark(&mesh, &mut indices, &corners, 1);
        assert!(!crowded(&mesh, &indices));
        let (mesh, mut indices) = flat();
        mark(&mesh, &mut indices, &[(20.0, 20.0)], 4);
        assert!(
            !crowded(&mesh, &indices),
            "a pole is left to the pole treatment"
        );
    }

    #[test]
    fn a_cluster_on_its_curvature_is_left_alone() {
        let (flat, mut indices) = flat();
        let ring = [(19.0, 20.0), (21.0, 20.0), (20.0, 19.0), (20.0, 21.0)];
        mark(&flat, &mut indices, &ring, 1);
        assert!(crowded(&flat, &indices));
        // a cone's apex: the grid's centre lifted (slope 2.5 out to 6 cells, so the base's
        // negative defect lies outside the cluster's ball), its defect over half a turn
        let apex = vertex_at(&flat, 20.0, 20.0);
        let mut cone = flat.clone();
        let pos = flat
            .positions()
            .iter()
            .map(|p| {
                let r = (p.truncate() - glam::DVec2::new(20.0, 20.0)).length();
                glam::DVec3::new(p.x, p.y, 2.5 * (6.0 - r).max(0.0))
            })
            .collect();
        cone.set_positions(pos);
        assert!(cone.angle_defect(apex) > 0.5 * TAU);
        assert!(!crowded(&cone, &indices));
    }
}
