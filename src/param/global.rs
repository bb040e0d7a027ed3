//! Global step (alg. 4, eq. 2.43–2.44): per-corner expressions ψ_f(v) = R^α x_v + Σ_k M_k W_k
//! in terms of one 2-D unknown per regular vertex and the loop gaps W_k (branch points are fixed
//! by eq. 2.40), the conforming 2×2-block Laplacian over the x_v, and rounding of the W_k to the
//! lattice (direct, as in the thesis, or greedy one loop at a time, MIQ-style).

use glam::DVec3;

use crate::mesh::TriMesh;

use super::ParamError;
use super::cut::{CutGraph, NONE, step};
use super::rot::{Aff, ID, Lattice, Lin, M2, Rots, apply, inverse, mul, sub, transpose};
use super::system::{BlockBuilder, BlockSolver, Factoring};
use super::untangle::MapSpace;
use crate::sparse::{Analysis, SparseBuilder};

pub(crate) struct GlobalSystem {
    pub corner_var: Vec<u32>,
    pub corner_rot: Vec<u8>,
    pub corner_lin: Vec<Lin>,
    pub n_loops: usize,
    solver: BlockSolver,
}

/// The change of the global map per unit of one gap coordinate ([`GlobalSystem::responses`]).
pub(crate) struct GapResponse<'a> {
    system: &'a GlobalSystem,
    rots: &'a Rots,
    /// The corners whose constants move.
    moved: std::collections::HashMap<usize, [f64; 2]>,
    /// The vertex unknowns' change.
    x: Vec<[f64; 2]>,
}

impl GapResponse<'_> {
    /// The change at corner c.
    pub fn at(&self, c: usize) -> [f64; 2] {
        let mut p = self.moved.get(&c).copied().unwrap_or([0.0; 2]);
        let v = self.system.corner_var[c];
        if v != NONE {
            let q = apply(
                self.rots.get(self.system.corner_rot[c] as i64),
                self.x[v as usize],
            );
            p[0] += q[0];
            p[1] += q[1];
        }
        p
    }
}

/// Cotan stiffness K_ab = A⟨∇λ_a, ∇λ_b⟩ of face f.
pub(crate) fn stiffness(mesh: &TriMesh, f: usize) -> [[f64; 3]; 3] {
    let d: [DVec3; 3] = std::array::from_fn(|k| mesh.vector(3 * f + k));
    let a4 = 4.0 * mesh.face_area(f);
    std::array::from_fn(|a| std::array::from_fn(|b| d[(a + 1) % 3].dot(d[(b + 1) % 3]) / a4))
}

impl GlobalSystem {
    /// The system's sparsity pattern depends on the mesh only (see [`Self::pattern`]), so an
    /// analysis computed beforehand can be passed in. `gauge`: the cut graph of a system this
    /// one updates; each vertex's unknown is then written in the frame that one used, so that
    /// the two matrices differ only where the matchings do (see below).
    pub fn new(
        mesh: &TriMesh,
        cut: &CutGraph,
        rots: &Rots,
        how: Factoring,
        gauge: Option<&CutGraph>,
    ) -> Result<GlobalSystem, ParamError> {
        let nc = 3 * mesh.n_faces();
        let mut corner_var = vec![NONE; nc];
        let mut corner_rot = vec![0u8; nc];
        let mut corner_lin = vec![Lin::default(); nc];
        let mut pinned = vec![false; cut.translation_kernel.len()];
        // One unknown per vertex, numbered by vertex, so that the pattern is the mesh's. Branch
        // points (fixed by eq. 2.40) and the pinned vertex keep a decoupled identity row.
        let mut removed = vec![false; mesh.n_vertices()];
        let mut fan: Vec<(usize, Aff)> = Vec::new();
        for v in 0..mesh.n_vertices() {
            let h0 = mesh.vertex_halfedge(v);
            fan.clear();
            fan.push((h0, Aff::default()));
            let mut h = h0;
            let mut closing = None;
            loop {
                let c = mesh.edge(mesh.prev(h));
                let last = &fan.last().expect("the fan's first corner").1;
                // Most edges are off the cut graph: nothing to compose.
                let acc = if cut.transitions[c].is_identity() {
                    last.clone()
                } else {
                    step(mesh, &cut.transitions[c], c, mesh.face_of(h), rots).after(last, rots)
                };
                match mesh.twin(mesh.prev(h)) {
                    None => break,
                    Some(hn) if hn == h0 => {
                        closing = Some(acc);
                        break;
                    }
                    Some(hn) => {
                        fan.push((hn, acc));
                        h = hn;
                    }
                }
            }
            let comp = cut.comp_of_face[mesh.face_of(h0)] as usize;
            if cut.singular[v] {
                // x = R^h x + m  ⇒  x = (I − R^h)^{-1} m   (eq. 2.40)
                let close = closing.expect("branch points are interior");
                let inv = inverse(&sub(&ID, rots.get(close.rot as i64)));
                let xlin = close.lin.left(&inv);
                for (h, a) in fan.drain(..) {
                    corner_lin[h] = xlin.left(rots.get(a.rot as i64)).add(&a.lin);
                }
                removed[v] = true;
                continue;
            }
            let var = if cut.translation_kernel[comp] && !pinned[comp] {
                pinned[comp] = true;
                removed[v] = true;
                NONE
            } else {
                v as u32
            };
            // x_v is written in the disk frame of its first face, R^{-ρ} of the face frame
            // (cut.rs). Another cut graph turns that frame by the difference of the ρ there;
            // turning x_v back by it makes every coupling R^{rot_b - rot_a} the same as with
            // that cut graph wherever the matchings around both vertices are (the ρ of the
            // face itself cancels in the difference).
            let shift = gauge.map_or(0, |g| {
                let f0 = mesh.face_of(h0);
                g.rho[f0] as i64 - cut.rho[f0] as i64
            });
            for (h, a) in fan.drain(..) {
                corner_var[h] = var;
                corner_rot[h] = rots.norm(a.rot as i64 + shift);
                corner_lin[h] = a.lin;
            }
        }
        let nv = mesh.n_vertices();
        let mut b = BlockBuilder::new(rots.n == 2, nv, nv + 9 * mesh.n_faces(), &how);
        for v in 0..nv {
            b.add(v, v, if removed[v] { 1.0 } else { 0.0 }, &ID);
        }
        for f in 0..mesh.n_faces() {
            let k = stiffness(mesh, f);
            let fv = mesh.face(f);
            for a in 0..3 {
                let va = corner_var[3 * f + a];
                for bb in 0..3 {
                    let vb = corner_var[3 * f + bb];
                    if va == NONE || vb == NONE {
                        // Kept as an explicit zero: the pattern stays the mesh's.
                        b.add(fv[a], fv[bb], 0.0, &ID);
                        continue;
                    }
                    let r = rots.get(corner_rot[3 * f + bb] as i64 - corner_rot[3 * f + a] as i64);
                    b.add(va as usize, vb as usize, k[a][bb], r);
                }
            }
        }
        let solver = b.factor_by(how)?;
        Ok(GlobalSystem {
            corner_var,
            corner_rot,
            corner_lin,
            n_loops: cut.generators.len(),
            solver,
        })
    }

    /// The seamless maps this system describes with the gaps `w` fixed (what the injectivity
    /// repair moves within): ψ_c = c_c + R^{rot_c} x_v.
    pub fn map_space(&self, n_vertices: usize, w: &[[f64; 2]]) -> MapSpace {
        MapSpace {
            consts: self.corner_lin.iter().map(|l| l.eval(w)).collect(),
            var: self.corner_var.clone(),
            rot: self.corner_rot.clone(),
            basis: vec![ID; n_vertices],
            free: vec![[true, true]; n_vertices],
        }
    }

    /// The factored system (a base for updates).
    pub fn solver(&self) -> &BlockSolver {
        &self.solver
    }

    /// The factored system's analysis (its pattern is the mesh's vertex adjacency).
    pub fn analysis(&self) -> &Analysis {
        self.solver.analysis()
    }

    /// The pattern of the system: vertex adjacency plus the diagonal (values are placeholders).
    pub fn pattern(mesh: &TriMesh) -> Result<Analysis, ParamError> {
        let nv = mesh.n_vertices();
        let mut b = SparseBuilder::<f64>::with_capacity(nv, nv + 9 * mesh.n_faces());
        for v in 0..nv {
            b.add(v, v, 1.0);
        }
        for fv in mesh.faces() {
            for &a in fv {
                for &c in fv {
                    b.add(a as usize, c as usize, 1.0);
                }
            }
        }
        Ok(Analysis::new(&b.build()?)?)
    }

    /// Per-corner targets b_a = A⟨∇λ_a, X̃⟩ (rows) of the disk-frame field.
    pub(crate) fn targets(mesh: &TriMesh, disk: &[[DVec3; 2]]) -> Vec<[f64; 2]> {
        let mut out = vec![[0.0; 2]; 3 * mesh.n_faces()];
        for (f, x) in disk.iter().enumerate() {
            let n = mesh.face_normal(f);
            for a in 0..3 {
                let g = n.cross(mesh.vector(3 * f + (a + 1) % 3)) * 0.5;
                out[3 * f + a] = [g.dot(x[0]), g.dot(x[1])];
            }
        }
        out
    }

    /// How the map of [`Self::solve`] changes per unit of each gap coordinate in `units`
    /// ((loop, coordinate)): ψ is affine in the gaps, so the change is the map of the unit gap
    /// with the field's targets left out. Only the faces with a corner on that gap enter the
    /// right-hand side, and all units are solved at once (a triangular solve per column costs
    /// as much memory traffic as several together).
    pub fn responses<'a>(
        &'a self,
        mesh: &TriMesh,
        rots: &'a Rots,
        units: &[(usize, usize)],
    ) -> Result<Vec<GapResponse<'a>>, ParamError> {
        // Per unit, the corners whose constant moves, and by how much.
        let mut moved: Vec<Vec<(usize, [f64; 2])>> = vec![Vec::new(); units.len()];
        for (c, lin) in self.corner_lin.iter().enumerate() {
            for (k, m) in &lin.0 {
                for (j, &(loop_k, i)) in units.iter().enumerate() {
                    if *k as usize == loop_k {
                        let mut e = [0.0; 2];
                        e[i] = 1.0;
                        moved[j].push((c, apply(m, e)));
                    }
                }
            }
        }
        let mut rhs = vec![vec![[0.0; 2]; self.solver.n()]; units.len()];
        for (j, corners) in moved.iter().enumerate() {
            // Sorted by corner, so a face's corners are together.
            for (f, of_face) in corners
                .chunk_by(|a, b| a.0 / 3 == b.0 / 3)
                .map(|g| (g[0].0 / 3, g))
            {
                let mut d = [[0.0; 2]; 3];
                for &(c, x) in of_face {
                    d[c % 3] = x;
                }
                let k = stiffness(mesh, f);
                for a in 0..3 {
                    let va = self.corner_var[3 * f + a];
                    if va == NONE {
                        continue;
                    }
                    let mut r = [0.0; 2];
                    for bb in 0..3 {
                        r[0] -= k[a][bb] * d[bb][0];
                        r[1] -= k[a][bb] * d[bb][1];
                    }
                    let r = apply(rots.get(-(self.corner_rot[3 * f + a] as i64)), r);
                    rhs[j][va as usize][0] += r[0];
                    rhs[j][va as usize][1] += r[1];
                }
            }
        }
        let refs: Vec<&[[f64; 2]]> = rhs.iter().map(|r| r.as_slice()).collect();
        let xs = self.solver.solve_many(&refs)?;
        Ok(moved
            .into_iter()
            .zip(xs)
            .map(|(moved, x)| GapResponse {
                system: self,
                rots,
                moved: moved.into_iter().collect(),
                x,
            })
            .collect())
    }

    /// Solves for the vertex unknowns with the gaps W fixed; returns ψ per corner (disk frame).
    pub fn solve(
        &self,
        mesh: &TriMesh,
        rots: &Rots,
        disk: &[[DVec3; 2]],
        w: &[[f64; 2]],
    ) -> Result<Vec<[f64; 2]>, ParamError> {
        let b = Self::targets(mesh, disk);
        let consts: Vec<[f64; 2]> = self.corner_lin.iter().map(|l| l.eval(w)).collect();
        let mut rhs = vec![[0.0; 2]; self.solver.n()];
        for f in 0..mesh.n_faces() {
            let k = stiffness(mesh, f);
            for a in 0..3 {
                let va = self.corner_var[3 * f + a];
                if va == NONE {
                    continue;
                }
                let mut r = b[3 * f + a];
                for bb in 0..3 {
                    let c = consts[3 * f + bb];
                    r[0] -= k[a][bb] * c[0];
                    r[1] -= k[a][bb] * c[1];
                }
                let r = apply(rots.get(-(self.corner_rot[3 * f + a] as i64)), r);
                rhs[va as usize][0] += r[0];
                rhs[va as usize][1] += r[1];
            }
        }
        let x = self.solver.solve(&rhs)?;
        Ok((0..consts.len())
            .map(|c| {
                let mut p = consts[c];
                let v = self.corner_var[c];
                if v != NONE {
                    let q = apply(rots.get(self.corner_rot[c] as i64), x[v as usize]);
                    p[0] += q[0];
                    p[1] += q[1];
                }
                p
            })
            .collect())
    }

    /// Greedy rounding: the energy reduced to the gaps (Schur complement H of the vertex block,
    /// computed with the reused factorization), then one loop at a time the gap closest to the
    /// lattice is fixed and the others re-optimised (Gaussian conditioning, O(K²) per step).
    /// The energy as a function of the gaps alone (the vertex unknowns eliminated): the dense
    /// Schur complement H restricted to the gap components `indices` (gap k's at 2k, 2k + 1),
    /// row-major |indices|², computed with the reused factorization (one solve per index).
    pub fn gap_hessian(
        &self,
        mesh: &TriMesh,
        rots: &Rots,
        indices: &[usize],
    ) -> Result<Vec<f64>, ParamError> {
        let nl = self.n_loops;
        let m = 2 * nl;
        let k = indices.len();
        if nl == 0 || k == 0 {
            return Ok(Vec::new());
        }
        if let Some(&i) = indices.iter().find(|&&i| i >= m) {
            return Err(ParamError::InvalidInput(format!(
                "gap component {i} out of range ({m})"
            )));
        }
        // Sparse columns of Q_xW and dense Q_WW.
        let mut cols: Vec<Vec<(u32, [f64; 2])>> = vec![Vec::new(); m];
        let mut qww = vec![0.0; m * m];
        for f in 0..mesh.n_faces() {
            let k = stiffness(mesh, f);
            for a in 0..3 {
                let ca = 3 * f + a;
                for bb in 0..3 {
                    let cb = 3 * f + bb;
                    let kab = k[a][bb];
                    let va = self.corner_var[ca];
                    if va != NONE {
                        let ra = transpose(rots.get(self.corner_rot[ca] as i64));
                        for (l, ml) in &self.corner_lin[cb].0 {
                            let q = mul(&ra, ml);
                            for c in 0..2 {
                                cols[2 * *l as usize + c].push((va, [kab * q[c], kab * q[2 + c]]));
                            }
                        }
                    }
                    for (kk, mk) in &self.corner_lin[ca].0 {
                        let mkt = transpose(mk);
                        for (l, ml) in &self.corner_lin[cb].0 {
                            let q = mul(&mkt, ml);
                            for r in 0..2 {
                                for c in 0..2 {
                                    qww[(2 * *kk as usize + r) * m + 2 * *l as usize + c] +=
                                        kab * q[2 * r + c];
                                }
                            }
                        }
                    }
                }
            }
        }
        for col in &mut cols {
            col.sort_by_key(|x| x.0);
            col.dedup_by(|next, prev| {
                if next.0 == prev.0 {
                    prev.1[0] += next.1[0];
                    prev.1[1] += next.1[1];
                    true
                } else {
                    false
                }
            });
        }
        let nx = self.solver.n();
        let mut h: Vec<f64> = indices
            .iter()
            .flat_map(|&i| indices.iter().map(move |&j| (i, j)))
            .map(|(i, j)| qww[i * m + j])
            .collect();
        for start in (0..k).step_by(32) {
            let end = (start + 32).min(k);
            let dense: Vec<Vec<[f64; 2]>> = indices[start..end]
                .iter()
                .map(|&j| {
                    let mut d = vec![[0.0; 2]; nx];
                    for &(v, x) in &cols[j] {
                        d[v as usize] = x;
                    }
                    d
                })
                .collect();
            let refs: Vec<&[[f64; 2]]> = dense.iter().map(|d| d.as_slice()).collect();
            let y = self.solver.solve_many(&refs)?;
            for (jj, yj) in y.iter().enumerate() {
                let b = start + jj;
                for (a, &i) in indices.iter().enumerate() {
                    let s: f64 = cols[i]
                        .iter()
                        .map(|&(v, x)| x[0] * yj[v as usize][0] + x[1] * yj[v as usize][1])
                        .sum();
                    h[a * k + b] -= s;
                }
            }
        }
        Ok(h)
    }

    pub fn greedy_round(
        &self,
        mesh: &TriMesh,
        rots: &Rots,
        measured: &[[f64; 2]],
        lattices: &[Lattice],
    ) -> Result<Vec<[f64; 2]>, ParamError> {
        let nl = self.n_loops;
        let m = 2 * nl;
        if nl == 0 {
            return Ok(Vec::new());
        }
        let all: Vec<usize> = (0..m).collect();
        let h = self.gap_hessian(mesh, rots, &all)?;
        let Some(mut cov) = dense_spd_inverse(&h, m) else {
            // Not positive definite numerically: fall back to direct rounding.
            return Ok(measured
                .iter()
                .zip(lattices)
                .map(|(&p, l)| l.nearest(p))
                .collect());
        };
        let mut w: Vec<f64> = measured.iter().flat_map(|p| [p[0], p[1]]).collect();
        let mut free: Vec<usize> = (0..nl).collect();
        while !free.is_empty() {
            let (pos, &k) = free
                .iter()
                .enumerate()
                .min_by(|a, b| {
                    let da = lattices[*a.1].distance([w[2 * a.1], w[2 * a.1 + 1]]);
                    let db = lattices[*b.1].distance([w[2 * b.1], w[2 * b.1 + 1]]);
                    da.total_cmp(&db)
                })
                .unwrap();
            free.swap_remove(pos);
            let target = lattices[k].nearest([w[2 * k], w[2 * k + 1]]);
            let delta = [target[0] - w[2 * k], target[1] - w[2 * k + 1]];
            let ckk: M2 = [
                cov[2 * k * m + 2 * k],
                cov[2 * k * m + 2 * k + 1],
                cov[(2 * k + 1) * m + 2 * k],
                cov[(2 * k + 1) * m + 2 * k + 1],
            ];
            let ci = inverse(&ckk);
            let g = apply(&ci, delta);
            w[2 * k] = target[0];
            w[2 * k + 1] = target[1];
            // Conditioning of the remaining free gaps and their covariance.
            let idx: Vec<usize> = free.iter().flat_map(|&l| [2 * l, 2 * l + 1]).collect();
            for &i in &idx {
                w[i] += cov[i * m + 2 * k] * g[0] + cov[i * m + 2 * k + 1] * g[1];
            }
            let proj: Vec<[f64; 2]> = idx
                .iter()
                .map(|&i| {
                    let c = [cov[i * m + 2 * k], cov[i * m + 2 * k + 1]];
                    [c[0] * ci[0] + c[1] * ci[2], c[0] * ci[1] + c[1] * ci[3]]
                })
                .collect();
            for (a, &i) in idx.iter().enumerate() {
                for &j in &idx {
                    cov[i * m + j] -=
                        proj[a][0] * cov[2 * k * m + j] + proj[a][1] * cov[(2 * k + 1) * m + j];
                }
            }
        }
        Ok((0..nl).map(|k| [w[2 * k], w[2 * k + 1]]).collect())
    }
}

/// Inverse of a dense symmetric positive definite matrix (Cholesky); None if not SPD.
fn dense_spd_inverse(a: &[f64], m: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; m * m];
    for j in 0..m {
        let mut d = a[j * m + j];
        for k in 0..j {
            d -= l[j * m + k] * l[j * m + k];
        }
        if d <= 0.0 || !d.is_finite() {
            return None;
        }
        let d = d.sqrt();
        l[j * m + j] = d;
        for i in j + 1..m {
            let mut s = 0.5 * (a[i * m + j] + a[j * m + i]);
            for k in 0..j {
                s -= l[i * m + k] * l[j * m + k];
            }
            l[i * m + j] = s / d;
        }
    }
    // Solve L Lᵀ X = I column by column.
    let mut inv = vec![0.0; m * m];
    let mut y = vec![0.0; m];
    for c in 0..m {
        for i in 0..m {
            let mut s = if i == c { 1.0 } else { 0.0 };
            for k in 0..i {
                s -= l[i * m + k] * y[k];
            }
            y[i] = s / l[i * m + i];
        }
        for i in (0..m).rev() {
            let mut s = y[i];
            for k in i + 1..m {
                s -= l[k * m + i] * inv[k * m + c];
            }
            inv[i * m + c] = s / l[i * m + i];
        }
    }
    Some(inv)
}

/// Measures the loop gaps W_k = ψ_j − R^t ψ_i at the generator edges (mean of both endpoints).
pub(crate) fn measure_gaps(
    mesh: &TriMesh,
    cut: &CutGraph,
    rots: &Rots,
    psi: &[[f64; 2]],
) -> Vec<[f64; 2]> {
    cut.generators
        .iter()
        .map(|&e| {
            let (h0, h1) = mesh.edge_halfedges(e as usize);
            let h1 = h1.unwrap();
            let r = rots.get(cut.transitions[e as usize].rot as i64);
            // a = from(h0): corner h0 in i, corner next(h1) in j; b = to(h0): next(h0) / h1.
            let ga = apply(r, psi[h0]);
            let gb = apply(r, psi[mesh.next(h0)]);
            let (ja, jb) = (psi[mesh.next(h1)], psi[h1]);
            [
                0.5 * (ja[0] - ga[0] + jb[0] - gb[0]),
                0.5 * (ja[1] - ga[1] + jb[1] - gb[1]),
            ]
        })
        .collect()
}
