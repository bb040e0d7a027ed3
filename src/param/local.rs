//! Local step (alg. 3, eq. 2.42): remove the co-gradient part of the frame field on the covering
//! with the 2×2-block non-conforming (Crouzeix–Raviart, edge-midpoint) Laplacian, then integrate
//! the curl*-free field over the dual spanning forest of M \ G, respecting the matchings.

use glam::DVec3;

use crate::mesh::TriMesh;

use super::ParamError;
use super::cut::{CutGraph, NONE};
use super::rot::{ID, Rots, apply, transpose};
use super::system::{BlockBuilder, BlockSolver, Factoring};
use crate::sparse::{Analysis, SparseBuilder};

/// The factored non-conforming system; depends on geometry and matchings only.
pub(crate) struct LocalSystem {
    edge_var: Vec<u32>,
    /// Per unknown: pinned to 0 (one per closed component whose constants are in the kernel).
    pinned: Vec<bool>,
    solver: BlockSolver,
}

/// Unknown number per edge (interior edges in edge order; `NONE` on the boundary) and count.
fn interior_edge_numbering(mesh: &TriMesh) -> (Vec<u32>, usize) {
    let mut n = 0u32;
    let vars = (0..mesh.n_edges())
        .map(|e| {
            if mesh.is_boundary_edge(e) {
                NONE
            } else {
                n += 1;
                n - 1
            }
        })
        .collect();
    (vars, n as usize)
}

/// Rotation exponent of edge e's unknown as seen from face f (0 on the h0 side, r_e on the other).
fn side_rot(mesh: &TriMesh, cut: &CutGraph, h: usize) -> i64 {
    let e = mesh.edge(h);
    if mesh.edge_halfedges(e).0 == h {
        0
    } else {
        cut.matching[e] as i64
    }
}

impl LocalSystem {
    /// Unknowns: one per interior edge, numbered in edge order. The system's pattern depends on
    /// the mesh only (see [`Self::pattern`]), so an analysis computed beforehand can be passed in.
    pub fn new(
        mesh: &TriMesh,
        cut: &CutGraph,
        rots: &Rots,
        how: Factoring,
    ) -> Result<LocalSystem, ParamError> {
        let (edge_var, n) = interior_edge_numbering(mesh);
        // Constants on the covering are in the kernel only on closed components whose matchings
        // are a coboundary; one edge there is pinned to 0 by a decoupled identity row.
        let mut pinned = vec![false; n];
        let mut comp_pinned = vec![false; cut.translation_kernel.len()];
        for e in 0..mesh.n_edges() {
            if edge_var[e] == NONE {
                continue;
            }
            let c = cut.comp_of_face[mesh.face_of(mesh.edge_halfedges(e).0)] as usize;
            if cut.closed_comp[c] && cut.translation_kernel[c] && !comp_pinned[c] {
                comp_pinned[c] = true;
                pinned[edge_var[e] as usize] = true;
            }
        }
        let mut b = BlockBuilder::new(rots.n == 2, n, n + 9 * mesh.n_faces(), &how);
        for v in 0..n {
            b.add(v, v, if pinned[v] { 1.0 } else { 0.0 }, &ID);
        }
        for f in 0..mesh.n_faces() {
            let area = mesh.face_area(f);
            let d: [DVec3; 3] = std::array::from_fn(|k| mesh.vector(3 * f + k));
            for a in 0..3 {
                let va = edge_var[mesh.edge(3 * f + a)];
                if va == NONE {
                    continue;
                }
                let sa = side_rot(mesh, cut, 3 * f + a);
                for bb in 0..3 {
                    let vb = edge_var[mesh.edge(3 * f + bb)];
                    if vb == NONE {
                        continue;
                    }
                    if pinned[va as usize] || pinned[vb as usize] {
                        // Kept as an explicit zero: the pattern stays the mesh's.
                        b.add(va as usize, vb as usize, 0.0, &ID);
                        continue;
                    }
                    let sb = side_rot(mesh, cut, 3 * f + bb);
                    b.add(
                        va as usize,
                        vb as usize,
                        d[a].dot(d[bb]) / area,
                        rots.get(sb - sa),
                    );
                }
            }
        }
        Ok(LocalSystem {
            edge_var,
            pinned,
            solver: b.factor_by(how)?,
        })
    }

    /// The factored system (a base for updates).
    pub fn solver(&self) -> &BlockSolver {
        &self.solver
    }

    /// The pattern of the system: interior edges sharing a face, plus the diagonal.
    pub fn pattern(mesh: &TriMesh) -> Result<Analysis, ParamError> {
        let (edge_var, n) = interior_edge_numbering(mesh);
        let mut b = SparseBuilder::<f64>::with_capacity(n, n + 9 * mesh.n_faces());
        for v in 0..n {
            b.add(v, v, 1.0);
        }
        for f in 0..mesh.n_faces() {
            for a in 0..3 {
                for c in 0..3 {
                    let (va, vc) = (
                        edge_var[mesh.edge(3 * f + a)],
                        edge_var[mesh.edge(3 * f + c)],
                    );
                    if va != NONE && vc != NONE {
                        b.add(va as usize, vc as usize, 1.0);
                    }
                }
            }
        }
        Ok(Analysis::new(&b.build()?)?)
    }

    /// Curl*-free frames (per face rows U, V) closest to `frames` (co-gradient removed).
    pub fn solve(
        &self,
        mesh: &TriMesh,
        cut: &CutGraph,
        rots: &Rots,
        frames: &[[DVec3; 2]],
    ) -> Result<Vec<[DVec3; 2]>, ParamError> {
        let n = self.solver.n();
        let mut rhs = vec![[0.0; 2]; n];
        for (f, x) in frames.iter().enumerate() {
            for k in 0..3 {
                let h = 3 * f + k;
                let v = self.edge_var[mesh.edge(h)];
                if v == NONE {
                    continue;
                }
                let d = mesh.vector(h);
                let c = apply(
                    &transpose(rots.get(side_rot(mesh, cut, h))),
                    [d.dot(x[0]), d.dot(x[1])],
                );
                rhs[v as usize][0] += c[0];
                rhs[v as usize][1] += c[1];
            }
        }
        for (r, &p) in rhs.iter_mut().zip(&self.pinned) {
            if p {
                *r = [0.0; 2];
            }
        }
        let g = self.solver.solve(&rhs)?;
        Ok(frames
            .iter()
            .enumerate()
            .map(|(f, x)| {
                let area = mesh.face_area(f);
                let mut out = *x;
                for k in 0..3 {
                    let h = 3 * f + k;
                    let v = self.edge_var[mesh.edge(h)];
                    if v == NONE {
                        continue;
                    }
                    let gl = apply(rots.get(side_rot(mesh, cut, h)), g[v as usize]);
                    let d = mesh.vector(h) / area;
                    out[0] -= d * gl[0];
                    out[1] -= d * gl[1];
                }
                out
            })
            .collect())
    }
}

/// Frames expressed in the disk frame of each face: R^{-ρ_f} applied to the stacked rows.
pub(crate) fn to_disk_frame(rots: &Rots, cut: &CutGraph, frames: &[[DVec3; 2]]) -> Vec<[DVec3; 2]> {
    frames
        .iter()
        .zip(&cut.rho)
        .map(|(x, &r)| {
            let m = rots.get(-(r as i64));
            [x[0] * m[0] + x[1] * m[1], x[0] * m[2] + x[1] * m[3]]
        })
        .collect()
}

/// Integrates disk-frame frames over the dual spanning forest: per-corner values ψ[3f+k].
pub(crate) fn integrate(mesh: &TriMesh, cut: &CutGraph, disk: &[[DVec3; 2]]) -> Vec<[f64; 2]> {
    let pos = mesh.positions();
    let mut psi = vec![[0.0; 2]; 3 * mesh.n_faces()];
    let dot = |x: &[DVec3; 2], d: DVec3| [x[0].dot(d), x[1].dot(d)];
    for &(f, e) in &cut.face_order {
        let f = f as usize;
        let fv = mesh.face(f);
        let x = &disk[f];
        if e == NONE {
            for k in 1..3 {
                psi[3 * f + k] = dot(x, pos[fv[k]] - pos[fv[0]]);
            }
            continue;
        }
        let h = (0..3)
            .map(|k| 3 * f + k)
            .find(|&h| mesh.edge(h) == e as usize)
            .unwrap();
        let t = mesh.twin(h).unwrap();
        let k = h % 3;
        // Parent corners: from(h) = to(t) at next(t), to(h) = from(t) at t.
        psi[3 * f + k] = psi[mesh.next(t)];
        psi[3 * f + (k + 1) % 3] = psi[t];
        let base = psi[3 * f + k];
        let d = dot(x, pos[fv[(k + 2) % 3]] - pos[fv[k]]);
        psi[3 * f + (k + 2) % 3] = [base[0] + d[0], base[1] + d[1]];
    }
    psi
}

/// Per interior edge the curl* residual on the covering: ‖⟨e, X_j⟩ − R^{r_ij} ⟨e, X_i⟩‖.
pub fn curl_star(
    mesh: &TriMesh,
    symmetry: usize,
    frames: &[[DVec3; 2]],
    matchings: &[i32],
) -> Vec<f64> {
    let rots = Rots::new(symmetry);
    (0..mesh.n_edges())
        .map(|e| {
            let (h0, h1) = mesh.edge_halfedges(e);
            let Some(h1) = h1 else { return 0.0 };
            let d = mesh.vector(h0);
            let (xi, xj) = (&frames[mesh.face_of(h0)], &frames[mesh.face_of(h1)]);
            let a = apply(rots.get(matchings[e] as i64), [d.dot(xi[0]), d.dot(xi[1])]);
            (d.dot(xj[0]) - a[0]).hypot(d.dot(xj[1]) - a[1])
        })
        .collect()
}
