//! Crowded singularities: where singularities of one sign lie closer than a grid cell, the
//! global step must still put each on a lattice point of its own (N = 4 on Z² or D₂, N = 6 on
//! G₆), so the cells between them are stretched to several times their size, and at coarse
//! densities the map folds or winds wrongly there (spot N = 6 at 1500 vertices: four +1/6
//! within 1.5 cells on each horn). A grid finer around them gives each its cell: the faces
//! within [`FULL`] cells of a crowded singularity get the density multiplier
//! m = min(c / d, m_max) (d: the distance to its nearest singularity of the same sign in
//! cells, c the crowding distance of a [`Crowding`]), falling off to 1 at [`FALLOFF`] cells. The grid size
//! is read from the frames (|U| = m / h per face), so this works on any frames.
//!
//! `QuadCover::solve*` use it for further tries only: while the best map so far ends with
//! folds or mis-wound vertices (under constraint curves: folds), it is solved again on frames
//! refined by the next step of [`LADDER`] and the best kept (measured in
//! `docs/untangling.md`: always refining gave as many patched places more at the default
//! density as it took away, and costs vertices everywhere).

use glam::DVec3;
use serde::Serialize;

use super::Singularity;
use crate::mesh::TriMesh;

/// How crowded singularities are found and refined: same-sign singularities closer than
/// `within` grid cells, the grid up to `cap` times finer around them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Crowding {
    pub within: f64,
    pub cap: f64,
}

/// Under constraint curves, mis-wound vertices up to this many do not call for a finer try
/// (folds always do). Measured on the 28 constrained sweep solves (shared meshes with their
/// boundaries aligned or features at 40°, N = 4 and 6, default density and 1500 vertices),
/// 2026-12-04: mis-wound vertices 288 → 236, patched places 512 → 476, the bunny aligned at
/// 1500 vertices with N = 6 a manifold copy again (χ −2 → −3), cerebral vessels aligned at 1500
/// vertices with N = 6 30 → 2 mis-wound, 15 → 1 patched; the repair summed 138 → 146 s, and the
/// four solves that take a finer try have 18–42 % more vertices. With no limit (every
/// mis-wound vertex) the sweep's repair time doubled for 10 % fewer of them. 12 → 8 on
/// 2026-12-05, when the constrained solve began rewinding after its re-rounding too (fewer
/// mis-wound vertices on first maps, so at 12 the bunny aligned at 1500 vertices, N = 6, no
/// longer took its try: 13 → 23 patched places): over the sweep mis-wound 237 → 209, patched
/// 478 → 459, repair summed 91 → 98 s (docs/untangling.md).
pub const FEW_MISWOUND: usize = 8;

/// The tries after the first solve, in order: each runs only while the best map so far keeps
/// folds or mis-wound vertices (docs/untangling.md: 1.5 cells and 2× is best at coarse
/// densities, 2 cells at the default one, a cap of 3 on the coarsest clusters).
pub const LADDER: [Crowding; 3] = [
    Crowding {
        within: 1.5,
        cap: 2.0,
    },
    Crowding {
        within: 2.0,
        cap: 2.0,
    },
    Crowding {
        within: 1.5,
        cap: 3.0,
    },
];
/// The multiplier holds within this many grid cells of a crowded singularity...
const FULL: f64 = 1.0;
/// ...and falls off to 1 at this many (a scale that changes within a cell or two folds the
/// map at coarse densities).
const FALLOFF: f64 = 3.0;

/// What the refinement did (in REPORT.json as `crowded_refinement`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct CrowdedRefinement {
    /// The try kept.
    pub crowding: Option<Crowding>,
    /// Singularities with a same-sign neighbour closer than `crowding.within` cells.
    pub singularities: usize,
    /// Faces whose grid was made finer.
    pub faces: usize,
    /// The largest multiplier.
    pub max_multiplier: f64,
}

/// The frames made finer around crowded singularities, or `None` when none is crowded.
pub fn refined_frames(
    mesh: &TriMesh,
    singularities: &[Singularity],
    frames: &[[DVec3; 2]],
    crowding: Crowding,
) -> Option<(Vec<[DVec3; 2]>, CrowdedRefinement)> {
    let crowded = crowded(mesh, singularities, frames, crowding);
    if crowded.is_empty() {
        return None;
    }
    let mut refinement = CrowdedRefinement {
        crowding: Some(crowding),
        singularities: crowded.len(),
        faces: 0,
        max_multiplier: 1.0,
    };
    let mut refined = frames.to_vec();
    for (f, fr) in refined.iter_mut().enumerate().take(mesh.n_faces()) {
        let c = mesh.face_centroid(f);
        let mut m: f64 = 1.0;
        for &(p, h, mc) in &crowded {
            let d = c.distance(p) / h;
            if d < FALLOFF {
                let t = ((FALLOFF - d) / (FALLOFF - FULL)).clamp(0.0, 1.0);
                m = m.max(1.0 + (mc - 1.0) * t);
            }
        }
        if m > 1.0 {
            fr[0] *= m;
            fr[1] *= m;
            refinement.faces += 1;
            refinement.max_multiplier = refinement.max_multiplier.max(m);
        }
    }
    Some((refined, refinement))
}

/// Per crowded singularity: where, its grid cell, its multiplier (brute force: singularities
/// are few).
fn crowded(
    mesh: &TriMesh,
    singularities: &[Singularity],
    frames: &[[DVec3; 2]],
    Crowding { within, cap }: Crowding,
) -> Vec<(DVec3, f64, f64)> {
    // Grid size per vertex: the mean of 1 / |U| over its faces.
    let mut cell = vec![(0.0, 0usize); mesh.n_vertices()];
    for (f, fr) in frames.iter().enumerate().take(mesh.n_faces()) {
        let u = fr[0].length();
        if u > 0.0 && u.is_finite() {
            for v in mesh.face(f) {
                cell[v].0 += 1.0 / u;
                cell[v].1 += 1;
            }
        }
    }
    let cell_at = |v: usize| (cell[v].1 > 0).then(|| cell[v].0 / cell[v].1 as f64);
    let signed: Vec<(DVec3, bool, f64)> = singularities
        .iter()
        .filter(|s| s.index != 0.0)
        .filter_map(|s| Some((mesh.position(s.vertex), s.index > 0.0, cell_at(s.vertex)?)))
        .collect();
    signed
        .iter()
        .enumerate()
        .filter_map(|(i, &(p, positive, h))| {
            let d = signed
                .iter()
                .enumerate()
                .filter(|&(j, q)| j != i && q.1 == positive)
                .map(|(_, q)| q.0.distance(p))
                .fold(f64::INFINITY, f64::min)
                / h;
            (d < within).then(|| (p, h, (within / d.max(1e-9)).min(cap)))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat grid of 20 × 20 squares (unit spacing), split into triangles.
    fn plane() -> TriMesh {
        let n = 21;
        let positions = (0..n * n)
            .map(|i| DVec3::new((i % n) as f64, (i / n) as f64, 0.0))
            .collect();
        let mut faces = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let v = (y * n + x) as u32;
                let n = n as u32;
                faces.push([v, v + 1, v + n + 1]);
                faces.push([v, v + n + 1, v + n]);
            }
        }
        TriMesh::from_triangles(positions, faces).unwrap()
    }

    fn sing(vertex: usize, index: f64) -> Singularity {
        Singularity {
            vertex,
            index,
            holonomy: 1,
        }
    }

    #[test]
    fn only_close_singularities_of_one_sign_refine_and_only_near_them() {
        let mesh = plane();
        // Cells of 4 units: singularities 4 apart are one cell apart.
        let frames = vec![[DVec3::X / 4.0, DVec3::Y / 4.0]; mesh.n_faces()];
        let v = |x: usize, y: usize| y * 21 + x;
        // Opposite signs one cell apart, or one sign two cells apart: not crowded.
        let apart = [
            sing(v(4, 10), 0.25),
            sing(v(8, 10), -0.25),
            sing(v(16, 10), 0.25),
        ];
        assert!(refined_frames(&mesh, &apart, &frames, LADDER[0]).is_none());
        let close = [
            sing(v(4, 10), 0.25),
            sing(v(8, 10), 0.25),
            sing(v(16, 2), -0.25),
        ];
        let (refined, r) = refined_frames(&mesh, &close, &frames, LADDER[0]).unwrap();
        assert_eq!(r.singularities, 2);
        assert!((r.max_multiplier - 1.5).abs() < 1e-12, "{r:?}");
        for (f, (a, b)) in frames.iter().zip(&refined).enumerate() {
            let m = b[0].length() / a[0].length();
            let d = mesh
                .face_centroid(f)
                .distance(mesh.position(v(4, 10)))
                .min(mesh.face_centroid(f).distance(mesh.position(v(8, 10))))
                / 4.0;
            // Full within a cell, none beyond three, directions kept.
            if d < FULL {
                assert!((m - 1.5).abs() < 1e-12, "face {f}: m = {m} at {d} cells");
            }
            if d >= FALLOFF {
                assert_eq!(m, 1.0, "face {f}: m = {m} at {d} cells");
            }
            assert!(b[0].normalize().distance(a[0].normalize()) < 1e-12);
            assert!((b[1].length() / a[1].length() - m).abs() < 1e-12);
        }
    }
}
