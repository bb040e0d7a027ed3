//! The square fit that relaxes a remesh (`relax.rs`): local/global steps in the manner of
//! as-rigid-as-possible shape fitting, with every vertex moving in its tangent plane.
//!
//! The energy, over the positions x of the remesh's vertices (p: where they are now):
//!
//! E(x) = Σ_faces Σ_{corners i < j of the face} ‖(x_i − x_j) − (P_i − P_j)‖²
//!      + Σ_v Σ_k μ_vk (t_vk · (x_v − p_v))²,    x_v = p_v + t_v1 y_v1 + t_v2 y_v2,
//!
//! where P is the face's *ideal polygon*: the regular polygon (square, equilateral triangle) of
//! the remesh's mean edge length, in the face's tangent plane, turned to fit the face's corners
//! best (local step, [`ideal_polygons`]). The global step ([`TangentSystem::step`]) minimises E
//! over the tangent offsets y (2 unknowns per vertex) for those polygons: one sparse SPD solve.
//! Every corner pair counts, so the diagonals of a quad hold its right angles as its sides hold
//! its lengths, and one size everywhere evens out edge lengths across the whole mesh, which a
//! vertex-by-vertex (Jacobi) smoothing only does locally. μ pulls each vertex towards where it
//! is (a proximal step; the relaxation's `pull`): a large μ along a direction holds the vertex
//! there (sliding vertices move along their chain's tangent only, fixed ones not at all).

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::sparse::{Analysis, SparseBuilder, SparseMatrix, SpdSolver};

/// A vertex's two unit tangent directions and the pull μ along each.
#[derive(Clone, Copy, Debug)]
pub struct TangentFrame {
    pub t: [DVec3; 2],
    pub pull: [f64; 2],
}

impl TangentFrame {
    /// The frame's normal (t1 × t2).
    pub fn normal(&self) -> DVec3 {
        self.t[0].cross(self.t[1])
    }
}

/// Every pair of corners (i < j) of an m-gon.
fn corner_pairs(m: usize) -> impl Iterator<Item = (usize, usize)> {
    (0..m).flat_map(move |i| (i + 1..m).map(move |j| (i, j)))
}

/// Local step: per face, a regular polygon in the plane normal to the mean of its vertices'
/// normals, centred at the face's centroid and turned (a 2D Procrustes fit, no reflection) to
/// match the corners best. Its size is the geometric blend, with weight `size_weight` (0..=1),
/// of side `side` and of the size fitting the face best: 1 evens out sizes across the mesh, 0
/// only the faces' shapes. The corners are taken counter-clockwise about the
/// normal, as the remesh's faces are oriented.
pub fn ideal_polygons(
    pos: &[DVec3],
    faces: &[Vec<u32>],
    frames: &[TangentFrame],
    side: f64,
    size_weight: f64,
) -> Vec<Vec<DVec3>> {
    faces
        .par_iter()
        .map(|f| {
            let m = f.len();
            if m < 3 {
                return f.iter().map(|&v| pos[v as usize]).collect();
            }
            let c = f.iter().map(|&v| pos[v as usize]).sum::<DVec3>() / m as f64;
            let nrm = f
                .iter()
                .map(|&v| frames[v as usize].normal())
                .sum::<DVec3>()
                .normalize_or_zero();
            let (u, w) = nrm.any_orthonormal_pair();
            // corners of the unit-radius polygon
            let corner = |k: usize| DVec2::from_angle(std::f64::consts::TAU * k as f64 / m as f64);
            let (mut dot, mut cross) = (0.0, 0.0);
            for (k, &v) in f.iter().enumerate() {
                let d = pos[v as usize] - c;
                let x = DVec2::new(d.dot(u), d.dot(w));
                let q = corner(k);
                dot += q.dot(x);
                cross += q.perp_dot(x);
            }
            // the radius of the common size, and of the face's own best-fitting size
            let common = side / (2.0 * (std::f64::consts::PI / m as f64).sin());
            let own = dot.hypot(cross) / m as f64;
            let radius = if own > 0.0 {
                common.powf(size_weight) * own.powf(1.0 - size_weight)
            } else {
                common
            };
            let turn = DVec2::from_angle(cross.atan2(dot)) * radius;
            (0..m)
                .map(|k| {
                    let r = turn.rotate(corner(k));
                    c + u * r.x + w * r.y
                })
                .collect()
        })
        .collect()
}

/// The global step's system: its sparsity pattern (2 × 2 blocks per vertex and per pair of
/// vertices sharing a face) with where each corner pair's entries sit, and its factorization
/// for the current tangent frames ([`TangentSystem::reframe`]), after which each step is one
/// back-substitution. The symbolic analysis is made once. (Vertices move about an edge length,
/// over which the tangent plane hardly turns, and are projected back onto the surface after
/// every step, so a few steps share one set of frames; new frames for every step were measured
/// in docs/remesh.md.)
pub struct TangentSystem {
    pattern: SparseMatrix,
    /// Per vertex: positions of its two diagonal entries.
    diagonal: Vec<[usize; 2]>,
    /// Per corner pair (faces in order, pairs as [`corner_pairs`] lists them): positions of
    /// the (a, c) block's entries kl and of the (c, a) block's entries lk, for k, l in 0..2.
    blocks: Vec<[usize; 8]>,
    /// Per vertex: how many corner pairs it is in.
    degree: Vec<f64>,
    frames: Vec<TangentFrame>,
    solver: Option<SpdSolver>,
}

impl TangentSystem {
    /// The pattern for `faces` over `n` vertices (`None` if a face names a vertex ≥ n).
    pub fn new(faces: &[Vec<u32>], n: usize) -> Option<TangentSystem> {
        let mut b = SparseBuilder::new(2 * n);
        for v in 0..2 * n {
            b.add(v, v, 1.0);
        }
        let mut degree = vec![0.0; n];
        for f in faces {
            for (i, j) in corner_pairs(f.len()) {
                let (a, c) = (f[i] as usize, f[j] as usize);
                if a >= n || c >= n {
                    return None;
                }
                degree[a] += 1.0;
                degree[c] += 1.0;
                for k in 0..2 {
                    for l in 0..2 {
                        b.add_sym(2 * a + k, 2 * c + l, 1.0);
                    }
                }
            }
        }
        let pattern = b.build().ok()?;
        let at = |i: usize, j: usize| pattern.position(i, j).expect("entry in the pattern");
        let diagonal = (0..n)
            .map(|v| [at(2 * v, 2 * v), at(2 * v + 1, 2 * v + 1)])
            .collect();
        let mut blocks = Vec::new();
        for f in faces {
            for (i, j) in corner_pairs(f.len()) {
                let (a, c) = (f[i] as usize, f[j] as usize);
                let mut s = [0usize; 8];
                for k in 0..2 {
                    for l in 0..2 {
                        s[2 * k + l] = at(2 * a + k, 2 * c + l);
                        s[4 + 2 * k + l] = at(2 * c + l, 2 * a + k);
                    }
                }
                blocks.push(s);
            }
        }
        Some(TangentSystem {
            pattern,
            diagonal,
            blocks,
            degree,
            frames: Vec::new(),
            solver: None,
        })
    }

    /// Factorizes the system for new tangent frames (one per vertex, at positions `pos`). `false` if it is not
    /// positive definite (e.g. a vertex in no face and without pull); steps then fail.
    pub fn reframe(
        &mut self,
        faces: &[Vec<u32>],
        frames: Vec<TangentFrame>,
        pos: &[DVec3],
    ) -> bool {
        self.frames = Vec::new();
        if frames.len() != self.degree.len() || pos.len() != frames.len() {
            return false;
        }
        // Σ T_vᵀ T_v = degree · I on the diagonal (orthonormal frames) plus the pull;
        // −T_aᵀ T_c in the blocks of each corner pair (a, c)
        let mut values = vec![0.0; self.pattern.nnz()];
        for (v, fr) in frames.iter().enumerate() {
            for k in 0..2 {
                values[self.diagonal[v][k]] += self.degree[v] + fr.pull[k];
            }
        }
        let mut slots = self.blocks.iter();
        for f in faces {
            for (i, j) in corner_pairs(f.len()) {
                let Some(s) = slots.next() else { return false };
                let (ta, tc) = (frames[f[i] as usize].t, frames[f[j] as usize].t);
                for k in 0..2 {
                    for l in 0..2 {
                        let off = -ta[k].dot(tc[l]);
                        values[s[2 * k + l]] += off;
                        values[s[4 + 2 * k + l]] += off;
                    }
                }
            }
        }
        let Ok(matrix) = self.pattern.with_values(values) else {
            return false;
        };
        let ok = match &mut self.solver {
            Some(solver) => solver.refactor(&matrix).is_ok(),
            // ordered by the vertices' positions (nested dissection on large remeshes)
            None => {
                let points: Vec<DVec3> = pos.iter().flat_map(|&p| [p, p]).collect();
                Analysis::geometric(&matrix, &points)
                    .and_then(|a| SpdSolver::with_analysis(a, &matrix))
                    .map(|solver| self.solver = Some(solver))
                    .is_ok()
            }
        };
        if ok {
            self.frames = frames;
        }
        ok
    }

    /// The tangent frames of the last [`TangentSystem::reframe`] (empty if it failed).
    pub fn frames(&self) -> &[TangentFrame] {
        &self.frames
    }

    /// Global step: the positions minimising E for the ideal polygons `ideal` (per face, from
    /// [`ideal_polygons`]), each vertex moved within its tangent frame from `pos`. `None` if
    /// the solve fails.
    pub fn step(
        &self,
        pos: &[DVec3],
        faces: &[Vec<u32>],
        ideal: &[Vec<DVec3>],
    ) -> Option<Vec<DVec3>> {
        let n = self.frames.len();
        if pos.len() != n || n == 0 {
            return None;
        }
        let mut rhs = vec![0.0; 2 * n];
        for (f, fit) in faces.iter().zip(ideal) {
            for (i, j) in corner_pairs(f.len()) {
                let (a, c) = (f[i] as usize, f[j] as usize);
                // the pair's residual now; its gradient in y_a is T_aᵀ r, in y_c −T_cᵀ r
                let r = (pos[a] - pos[c]) - (fit[i] - fit[j]);
                for k in 0..2 {
                    rhs[2 * a + k] -= self.frames[a].t[k].dot(r);
                    rhs[2 * c + k] += self.frames[c].t[k].dot(r);
                }
            }
        }
        let y = self.solver.as_ref()?.solve(&rhs).ok()?;
        let t = |v: usize| self.frames[v].t;
        Some(
            (0..n)
                .map(|v| pos[v] + t(v)[0] * y[2 * v] + t(v)[1] * y[2 * v + 1])
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat_frames(n: usize, pull: f64) -> Vec<TangentFrame> {
        vec![
            TangentFrame {
                t: [DVec3::X, DVec3::Y],
                pull: [pull; 2],
            };
            n
        ]
    }

    /// A skewed, stretched quad relaxes to a unit square (its own side) in a few steps.
    #[test]
    fn a_lone_quad_becomes_a_square() {
        let mut pos = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.6, 0.2, 0.0),
            DVec3::new(1.9, 0.9, 0.0),
            DVec3::new(0.1, 0.7, 0.0),
        ];
        let faces = vec![vec![0, 1, 2, 3]];
        let frames = flat_frames(4, 0.01);
        let mut sys = TangentSystem::new(&faces, 4).unwrap();
        assert!(sys.reframe(&faces, frames.clone(), &pos));
        for _ in 0..10 {
            let ideal = ideal_polygons(&pos, &faces, &frames, 1.0, 1.0);
            pos = sys.step(&pos, &faces, &ideal).unwrap();
        }
        for k in 0..4 {
            let side = (pos[(k + 1) % 4] - pos[k]).length();
            assert!((side - 1.0).abs() < 1e-3, "side {k}: {side}");
            let d = (pos[(k + 2) % 4] - pos[k]).length();
            assert!((d - 2f64.sqrt()).abs() < 1e-3, "diagonal {k}: {d}");
        }
        assert!(pos.iter().all(|p| p.z == 0.0), "stays in its tangent plane");
    }

    /// A vertex pulled hard along a direction does not move along it.
    #[test]
    fn a_strong_pull_holds_a_direction() {
        let pos = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(2.0, 2.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
        ];
        let faces = vec![vec![0, 1, 2, 3]];
        let mut frames = flat_frames(4, 0.01);
        frames[0].pull = [1e9, 1e9];
        frames[1].pull = [0.01, 1e9];
        let ideal = ideal_polygons(&pos, &faces, &frames, 1.0, 1.0);
        let mut sys = TangentSystem::new(&faces, 4).unwrap();
        assert!(sys.reframe(&faces, frames, &pos));
        let out = sys.step(&pos, &faces, &ideal).unwrap();
        assert!(out[0].length() < 1e-6, "held vertex moved to {}", out[0]);
        assert!(out[1].y.abs() < 1e-6, "vertex 1 left its line: {}", out[1]);
        assert!(
            out[1].x < 1.9,
            "vertex 1 slid towards the square: {}",
            out[1]
        );
    }
}
