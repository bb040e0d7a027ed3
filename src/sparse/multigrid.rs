//! Smoothed-aggregation algebraic multigrid (Vaněk, Mandel & Brezina 1996) as the
//! preconditioner of conjugate gradients, for Hermitian (symmetric) positive definite systems
//! whose solution is needed only approximately. The field's relaxed solve (thesis sec. 3.2) is
//! one: its solution only decides how the matchings round. At 1.1 M faces its direct solve
//! needed a 1.5 s ordering and a 3 s complex factorization with 49 M entries; the hierarchy is
//! set up in ~1 s and a cycle takes ~0.15 s (bench on 2 cores).
//!
//! Why by hand: no maintained Rust crate offers AMG for complex Hermitian matrices. The one
//! thing specific to our systems is the near-null space. For a graph Laplacian it is the
//! constant vector; the relaxed field system is a *connection* Laplacian (|z_j − ρ_ij z_i|²,
//! |ρ| = 1), whose locally smoothest vectors are parallel-transported ones. So the tentative
//! prolongator spreads each aggregate's value by the transport phases read off the matrix along
//! a tree inside the aggregate (`b_child = b_parent · (−a_cp / |a_cp|)`), which is the constant
//! vector for real M-matrices and the locally parallel field for connection Laplacians.
//!
//! Cycle: hybrid Gauss–Seidel (blocks of rows in parallel; forward before the coarse
//! correction, backward after), so the V-cycle is a Hermitian positive definite preconditioner;
//! the coarsest level is factored directly. Coarse operators are Galerkin products Pᴴ A P.
//!
//! Precision: the hierarchy (every level's matrix, prolongation and the coarsest factor) is kept
//! in single precision (`f32` / `c32`), CG itself and its products with A in double. The cycles
//! stream the hierarchy through memory, so fewer bytes make them faster (the field's relaxed
//! system at 1.1 M faces on one core: setup 1.6 → 1.45 s, 8 iterations 2.2 → 1.8 s), while the
//! preconditioner's rounding only perturbs CG's search directions: the iteration count stayed
//! the same and CG still reaches 1e-10 (tested).

use rayon::prelude::*;

use super::{Scalar, SolverError, SparseBuilder, SparseMatrix, SpdSolver};

/// Levels stop coarsening below this many unknowns; that level is factored directly.
const COARSEST: usize = 8_000;
/// Strength of connection on coarse levels: j is a strong neighbour of i when
/// |a_ij|² ≥ STRENGTH² a_ii a_jj (the fine level keeps every connection: its systems are
/// Laplacian-like and every neighbour matters).
const STRENGTH: f64 = 0.08;
/// Rows per parallel task in the row-wise products.
const CHUNK: usize = 4096;

/// One task's rows for [`Csr::from_rows`]: each row's entry count, then all entries.
type RowsChunk<T> = (Vec<usize>, Vec<(u32, T)>);

/// Compressed sparse rows, u32 column indices.
#[derive(Clone, Debug)]
struct Csr<T> {
    n_cols: usize,
    ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<T>,
}

impl<T: Scalar> Csr<T> {
    fn n_rows(&self) -> usize {
        self.ptr.len() - 1
    }

    fn row(&self, i: usize) -> impl Iterator<Item = (usize, T)> + '_ {
        (self.ptr[i]..self.ptr[i + 1]).map(move |k| (self.col[k] as usize, self.val[k]))
    }

    /// The rows of a Hermitian matrix stored by columns: row i of A is the conjugate of column i.
    fn from_hermitian(m: &SparseMatrix<T>) -> Csr<T> {
        Csr {
            n_cols: m.n,
            ptr: m.col_ptr.clone(),
            col: m.row_idx.iter().map(|&i| i as u32).collect(),
            val: m.values.iter().map(|v| v.conjugate()).collect(),
        }
    }

    fn to_sparse_matrix(&self) -> Result<SparseMatrix<T>, SolverError> {
        let mut b = SparseBuilder::with_capacity(self.n_rows(), self.val.len());
        for i in 0..self.n_rows() {
            for (j, v) in self.row(i) {
                // Stored by columns: entry (i, j) of A is entry (j, i) of Aᴴ.
                b.add(j, i, v.conjugate());
            }
        }
        b.build()
    }

    /// Builds rows in parallel: `row(i, scratch, out)` appends row i's (column, value) pairs.
    fn from_rows<S: Send>(
        n_rows: usize,
        n_cols: usize,
        scratch: impl Fn() -> S + Sync + Send,
        row: impl Fn(usize, &mut S, &mut Vec<(u32, T)>) + Sync + Send,
    ) -> Csr<T> {
        // A few large tasks: each allocates its scratch (a dense accumulator) once.
        let tasks = 4 * rayon::current_num_threads();
        let per = n_rows.div_ceil(tasks).max(1);
        let chunks: Vec<RowsChunk<T>> = (0..n_rows.div_ceil(per))
            .into_par_iter()
            .map(|c| {
                let mut s = scratch();
                let s = &mut s;
                let mut lens = Vec::with_capacity(per);
                let mut out = Vec::new();
                for i in c * per..((c + 1) * per).min(n_rows) {
                    let before = out.len();
                    row(i, s, &mut out);
                    lens.push(out.len() - before);
                }
                (lens, out)
            })
            .collect();
        let nnz = chunks.iter().map(|c| c.1.len()).sum();
        let mut ptr = Vec::with_capacity(n_rows + 1);
        ptr.push(0);
        for (lens, _) in &chunks {
            for l in lens {
                ptr.push(ptr.last().copied().unwrap_or(0) + l);
            }
        }
        // Each task's entries are copied to their place in parallel.
        let mut col = vec![0u32; nnz];
        let mut val = vec![T::ZERO; nnz];
        let mut pieces = Vec::with_capacity(chunks.len());
        let (mut col_rest, mut val_rest) = (&mut col[..], &mut val[..]);
        for (_, entries) in &chunks {
            let (c, cr) = col_rest.split_at_mut(entries.len());
            let (v, vr) = val_rest.split_at_mut(entries.len());
            pieces.push((c, v, entries));
            (col_rest, val_rest) = (cr, vr);
        }
        pieces.into_par_iter().for_each(|(c, v, entries)| {
            for ((c, v), &(ec, ev)) in c.iter_mut().zip(v.iter_mut()).zip(entries.iter()) {
                *c = ec;
                *v = ev;
            }
        });
        Csr {
            n_cols,
            ptr,
            col,
            val,
        }
    }

    /// The conjugate transpose.
    fn adjoint(&self) -> Csr<T> {
        let mut ptr = vec![0usize; self.n_cols + 1];
        for &c in &self.col {
            ptr[c as usize + 1] += 1;
        }
        for j in 0..self.n_cols {
            ptr[j + 1] += ptr[j];
        }
        let mut next = ptr.clone();
        let mut col = vec![0u32; self.col.len()];
        let mut val = vec![T::ZERO; self.col.len()];
        for i in 0..self.n_rows() {
            for k in self.ptr[i]..self.ptr[i + 1] {
                let c = self.col[k] as usize;
                col[next[c]] = i as u32;
                val[next[c]] = self.val[k].conjugate();
                next[c] += 1;
            }
        }
        Csr {
            n_cols: self.n_rows(),
            ptr,
            col,
            val,
        }
    }

    /// The Galerkin product R A P (R = Pᴴ = self) row by row, without forming A P: coarse row
    /// I sums r_Ii a_ik p_kJ over the fine rows i of aggregate I's column of P.
    fn galerkin(&self, a: &Csr<T>, p: &Csr<T>) -> Csr<T> {
        let nc = p.n_cols;
        Csr::from_rows(
            self.n_rows(),
            nc,
            || (vec![T::ZERO; nc], vec![false; nc], Vec::<u32>::new()),
            |row, (acc, seen, touched), out| {
                for (i, r) in self.row(row) {
                    for (k, a) in a.row(i) {
                        let ra = r * a;
                        for (c, p) in p.row(k) {
                            if !seen[c] {
                                seen[c] = true;
                                touched.push(c as u32);
                            }
                            acc[c] += ra * p;
                        }
                    }
                }
                touched.sort_unstable();
                for &c in touched.iter() {
                    let c = c as usize;
                    out.push((c as u32, acc[c]));
                    acc[c] = T::ZERO;
                    seen[c] = false;
                }
                touched.clear();
            },
        )
    }

    /// y = A x.
    #[inline(never)]
    fn apply(&self, x: &[T], y: &mut [T]) {
        y.par_chunks_mut(CHUNK).enumerate().for_each(|(c, ys)| {
            for (o, y) in ys.iter_mut().enumerate() {
                let i = c * CHUNK + o;
                let mut s = T::ZERO;
                for k in self.ptr[i]..self.ptr[i + 1] {
                    s += self.val[k] * x[self.col[k] as usize];
                }
                *y = s;
            }
        });
    }

    /// Real diagonal (Hermitian positive definite: real and positive).
    fn diagonal(&self) -> Result<Vec<f64>, SolverError> {
        (0..self.n_rows())
            .map(|i| {
                let d = self
                    .row(i)
                    .find(|&(j, _)| j == i)
                    .map_or(0.0, |(_, v)| v.real_part());
                if d > 0.0 && d.is_finite() {
                    Ok(d)
                } else {
                    Err(SolverError::NotPositiveDefinite(format!(
                        "diagonal entry {i} is {d}"
                    )))
                }
            })
            .collect()
    }
}

struct Level<T> {
    a: Csr<T>,
    diag: Vec<f64>,
    /// Prolongation (fine × coarse) and restriction Pᴴ.
    p: Csr<T>,
    r: Csr<T>,
}

/// A multigrid hierarchy of one matrix; see the module docs.
pub struct Multigrid<T: Scalar> {
    inner: Inner<T>,
}

enum Inner<T: Scalar> {
    /// Small systems: factored (in full precision).
    Direct(SpdSolver<T>),
    /// The matrix itself for CG's products, and the hierarchy in single precision: the cycles
    /// stream the hierarchy through memory, so halving its bytes nearly halves their time, and a
    /// preconditioner needs no more digits than the relaxed solve asks for.
    Hierarchy {
        fine: Csr<T>,
        levels: Vec<Level<T::Single>>,
        coarse_solver: SpdSolver<T::Single>,
    },
}

/// Result of [`Multigrid::solve`].
#[derive(Clone, Debug)]
pub struct IterativeSolution<T> {
    pub x: Vec<T>,
    pub iterations: usize,
    /// ‖b − A x‖ / ‖b‖ at the end.
    pub relative_residual: f64,
}

const NONE: u32 = u32::MAX;

/// Aggregates (id per unknown, count) and a near-null vector of unit-modulus entries, built by
/// the usual three passes: whole neighbourhoods of still-free nodes, leftovers joined to a
/// neighbouring aggregate, the rest grouped with their free neighbours.
fn aggregate<T: Scalar>(a: &Csr<T>, diag: &[f64], strength: f64) -> (Vec<u32>, usize, Vec<T>) {
    let n = a.n_rows();
    let strong = |i: usize, j: usize, v: T| {
        i != j && v.modulus_sq() >= strength * strength * diag[i] * diag[j] && v != T::ZERO
    };
    let mut agg = vec![NONE; n];
    // (parent, entry a_{child, parent}) per node; roots have no parent.
    let mut link: Vec<(u32, T)> = vec![(NONE, T::ZERO); n];
    let mut order: Vec<u32> = Vec::with_capacity(n);
    let mut count = 0u32;
    for i in 0..n {
        if agg[i] != NONE || a.row(i).any(|(j, v)| strong(i, j, v) && agg[j] != NONE) {
            continue;
        }
        agg[i] = count;
        order.push(i as u32);
        for (j, v) in a.row(i) {
            if strong(i, j, v) {
                agg[j] = count;
                // a_{j,i} = conj(a_{i,j}).
                link[j] = (i as u32, v.conjugate());
                order.push(j as u32);
            }
        }
        count += 1;
    }
    let first_pass = agg.clone();
    for i in 0..n {
        if agg[i] != NONE {
            continue;
        }
        let best = a
            .row(i)
            .filter(|&(j, v)| strong(i, j, v) && first_pass[j] != NONE)
            .max_by(|x, y| x.1.modulus_sq().total_cmp(&y.1.modulus_sq()));
        if let Some((j, v)) = best {
            agg[i] = first_pass[j];
            link[i] = (j as u32, v);
            order.push(i as u32);
        }
    }
    for i in 0..n {
        if agg[i] != NONE {
            continue;
        }
        agg[i] = count;
        order.push(i as u32);
        for (j, v) in a.row(i) {
            if strong(i, j, v) && agg[j] == NONE {
                agg[j] = count;
                link[j] = (i as u32, v.conjugate());
                order.push(j as u32);
            }
        }
        count += 1;
    }
    // Parents come before their children in `order`.
    let mut b = vec![T::ZERO; n];
    for &i in &order {
        let i = i as usize;
        let (parent, v) = link[i];
        b[i] = if parent == NONE {
            T::from_real(1.0)
        } else {
            // Minimises the pair's term 2 Re(conj(x_c) a_cp x_p): x_c = x_p · (−a_cp / |a_cp|).
            b[parent as usize] * (-v).scaled(1.0 / v.modulus_sq().sqrt())
        };
    }
    (agg, count as usize, b)
}

/// Per-level vectors for [`cycle`], allocated once per solve (fresh 10–20 MB vectors per level
/// and cycle cost a page fault per 4 KiB).
fn workspace<S: Scalar>(levels: &[Level<S>]) -> Vec<[Vec<S>; 5]> {
    levels
        .iter()
        .map(|l| {
            let (n, nc) = (l.a.n_rows(), l.r.n_rows());
            [
                vec![S::ZERO; n],
                vec![S::ZERO; n],
                vec![S::ZERO; nc],
                vec![S::ZERO; nc],
                vec![S::ZERO; n],
            ]
        })
        .collect()
}

/// One V-cycle for A x = b from x = 0 on the first of `levels`; x is written to `x`.
fn cycle<S: Scalar>(
    levels: &[Level<S>],
    coarse_solver: &SpdSolver<S>,
    b: &[S],
    x: &mut [S],
    work: &mut [[Vec<S>; 5]],
) -> Result<(), SolverError> {
    let Some((l, below)) = levels.split_first() else {
        x.copy_from_slice(&coarse_solver.solve(b)?);
        return Ok(());
    };
    let (here, work_below) = work.split_first_mut().expect("a workspace per level");
    let [ax, res, rc, ec, before] = here;
    x.fill(S::ZERO);
    gauss_seidel(&l.a, &l.diag, b, x, before, false);
    l.a.apply(x, ax);
    for ((r, &b), &ax) in res.iter_mut().zip(b).zip(ax.iter()) {
        *r = b - ax;
    }
    l.r.apply(res, rc);
    cycle(below, coarse_solver, rc, ec, work_below)?;
    l.p.apply(ec, ax);
    for (x, e) in x.iter_mut().zip(ax.iter()) {
        *x += *e;
    }
    gauss_seidel(&l.a, &l.diag, b, x, before, true);
    Ok(())
}

/// The levels of a matrix (finest first) and the coarsest matrix left.
#[allow(clippy::type_complexity)]
fn build_levels<S: Scalar>(mut a: Csr<S>) -> Result<(Vec<Level<S>>, Csr<S>), SolverError> {
    let mut levels = Vec::new();
    while a.n_rows() > COARSEST {
        let diag = a.diagonal()?;
        let strength = if levels.is_empty() { 0.0 } else { STRENGTH };
        let (agg, nc, b) = aggregate(&a, &diag, strength);
        if nc * 2 > a.n_rows() {
            break;
        }
        // Tentative prolongator: column c is b on aggregate c, normalised.
        let mut size = vec![0usize; nc];
        for &g in &agg {
            size[g as usize] += 1;
        }
        // Smoothed: P = (I − ω D⁻¹ A) P_tent with ω = 4 / (3 λ), λ ≥ ρ(D⁻¹ A) by Gershgorin.
        let lambda = (0..a.n_rows())
            .into_par_iter()
            .map(|i| a.row(i).map(|(_, v)| v.modulus_sq().sqrt()).sum::<f64>() / diag[i])
            .reduce(|| 0.0, f64::max);
        let omega = 4.0 / (3.0 * lambda.max(1.0));
        let tent = |j: usize| b[j].scaled(1.0 / (size[agg[j] as usize] as f64).sqrt());
        let p = Csr::from_rows(a.n_rows(), nc, Vec::<(u32, S)>::new, |i, acc, out| {
            acc.clear();
            let mut add = |c: u32, v: S| match acc.iter_mut().find(|e| e.0 == c) {
                Some(e) => e.1 += v,
                None => acc.push((c, v)),
            };
            add(agg[i], tent(i));
            let s = -omega / diag[i];
            for (j, v) in a.row(i) {
                add(agg[j], (v * tent(j)).scaled(s));
            }
            acc.sort_unstable_by_key(|e| e.0);
            out.extend(acc.iter().copied());
        });
        let r = p.adjoint();
        let coarse = r.galerkin(&a, &p);
        levels.push(Level { a, diag, p, r });
        a = coarse;
    }
    Ok((levels, a))
}

impl<T: Scalar> Multigrid<T> {
    /// The hierarchy of a Hermitian (symmetric) positive definite matrix.
    pub fn new(matrix: &SparseMatrix<T>) -> Result<Multigrid<T>, SolverError> {
        let fine = Csr::from_hermitian(matrix);
        fine.diagonal()?;
        let single = Csr {
            n_cols: fine.n_cols,
            ptr: fine.ptr.clone(),
            col: fine.col.clone(),
            val: fine.val.par_iter().map(|v| v.to_single()).collect(),
        };
        let (levels, coarsest) = build_levels(single)?;
        let inner = if levels.is_empty() {
            Inner::Direct(SpdSolver::new(matrix)?)
        } else {
            Inner::Hierarchy {
                fine,
                levels,
                coarse_solver: SpdSolver::new(&coarsest.to_sparse_matrix()?)?,
            }
        };
        Ok(Multigrid { inner })
    }

    pub fn n(&self) -> usize {
        match &self.inner {
            Inner::Direct(solver) => solver.n(),
            Inner::Hierarchy { fine, .. } => fine.n_rows(),
        }
    }

    /// (unknowns, stored entries) per level, finest first, the coarsest (factored) one last.
    pub fn level_sizes(&self) -> Vec<(usize, usize)> {
        match &self.inner {
            Inner::Direct(solver) => vec![(solver.n(), 0)],
            Inner::Hierarchy {
                levels,
                coarse_solver,
                ..
            } => {
                let mut v: Vec<(usize, usize)> = levels
                    .iter()
                    .map(|l| (l.a.n_rows(), l.a.val.len()))
                    .collect();
                v.push((coarse_solver.n(), 0));
                v
            }
        }
    }

    /// Number of levels, the directly solved coarsest one included.
    pub fn depth(&self) -> usize {
        self.level_sizes().len()
    }

    /// Solves A x = b (A the matrix of [`Self::new`]) by conjugate gradients preconditioned
    /// with this hierarchy, from `guess` (or 0), until ‖b − A x‖ ≤ `tolerance` ‖b‖ or after
    /// `max_iterations` (the result says which residual was reached). Without levels (small
    /// systems) the solve is direct.
    pub fn solve(
        &self,
        b: &[T],
        guess: Option<&[T]>,
        tolerance: f64,
        max_iterations: usize,
    ) -> Result<IterativeSolution<T>, SolverError> {
        let n = self.n();
        if b.len() != n || guess.is_some_and(|g| g.len() != n) {
            return Err(SolverError::DimensionMismatch {
                expected: n,
                found: if b.len() != n {
                    b.len()
                } else {
                    guess.map_or(n, <[T]>::len)
                },
            });
        }
        let (a, levels, coarse_solver) = match &self.inner {
            Inner::Direct(solver) => {
                return Ok(IterativeSolution {
                    x: solver.solve(b)?,
                    iterations: 0,
                    relative_residual: 0.0,
                });
            }
            Inner::Hierarchy {
                fine,
                levels,
                coarse_solver,
            } => (fine, levels, coarse_solver),
        };
        let dot = |x: &[T], y: &[T]| -> f64 {
            x.par_iter()
                .zip(y)
                .map(|(x, y)| (x.conjugate() * *y).real_part())
                .sum()
        };
        let b_norm = dot(b, b).sqrt();
        if !b_norm.is_finite() || guess.is_some_and(|g| !g.iter().all(|v| v.finite())) {
            return Err(SolverError::NonFinite);
        }
        let mut x = guess.map_or_else(|| vec![T::ZERO; n], |g| g.to_vec());
        let mut q = vec![T::ZERO; n];
        a.apply(&x, &mut q);
        let mut r: Vec<T> = b.iter().zip(&q).map(|(&b, &q)| b - q).collect();
        let mut r_norm = dot(&r, &r).sqrt();
        if b_norm == 0.0 {
            return Ok(IterativeSolution {
                x: vec![T::ZERO; n],
                iterations: 0,
                relative_residual: 0.0,
            });
        }
        let mut work = workspace(levels);
        let (mut r_single, mut z_single) = (vec![T::Single::ZERO; n], vec![T::Single::ZERO; n]);
        let mut z = vec![T::ZERO; n];
        let mut precondition = |r: &[T], z: &mut [T]| -> Result<(), SolverError> {
            r_single
                .par_iter_mut()
                .zip(r)
                .for_each(|(s, r)| *s = r.to_single());
            cycle(levels, coarse_solver, &r_single, &mut z_single, &mut work)?;
            z.par_iter_mut()
                .zip(&z_single)
                .for_each(|(z, s)| *z = T::from_single(*s));
            Ok(())
        };
        precondition(&r, &mut z)?;
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        let mut iterations = 0;
        while r_norm > tolerance * b_norm && iterations < max_iterations {
            iterations += 1;
            a.apply(&p, &mut q);
            let pq = dot(&p, &q);
            if pq <= 0.0 || !pq.is_finite() {
                return Err(SolverError::NotPositiveDefinite(format!(
                    "conjugate gradients met pᴴAp = {pq}"
                )));
            }
            let alpha = rz / pq;
            x.par_iter_mut()
                .zip(&p)
                .for_each(|(x, p)| *x += p.scaled(alpha));
            r.par_iter_mut()
                .zip(&q)
                .for_each(|(r, q)| *r -= q.scaled(alpha));
            r_norm = dot(&r, &r).sqrt();
            if r_norm <= tolerance * b_norm {
                break;
            }
            precondition(&r, &mut z)?;
            let rz_new = dot(&r, &z);
            let beta = rz_new / rz;
            rz = rz_new;
            p.par_iter_mut()
                .zip(&z)
                .for_each(|(p, z)| *p = *z + p.scaled(beta));
        }
        if !x.iter().all(|v| v.finite()) {
            return Err(SolverError::NonFinite);
        }
        Ok(IterativeSolution {
            x,
            iterations,
            relative_residual: r_norm / b_norm,
        })
    }
}

/// Rows per block of the Gauss–Seidel smoother are `n / GS_BLOCKS`: a fixed count, so that the
/// result does not depend on the number of threads.
const GS_BLOCKS: usize = 8;

/// One hybrid Gauss–Seidel sweep, forward or backward: Gauss–Seidel inside each of
/// [`GS_BLOCKS`] blocks of consecutive rows, which run in parallel, and Jacobi between them
/// (entries in other blocks use the values from before the sweep; faces are numbered spatially
/// coherently, so few entries cross). The backward sweep is the adjoint of the forward one, which
/// keeps the V-cycle a Hermitian preconditioner.
#[inline(never)]
fn gauss_seidel<T: Scalar>(
    a: &Csr<T>,
    diag: &[f64],
    b: &[T],
    x: &mut [T],
    before: &mut [T],
    backward: bool,
) {
    let n = a.n_rows();
    before.copy_from_slice(x);
    let before = &*before;
    let per = n.div_ceil(GS_BLOCKS).max(1);
    x.par_chunks_mut(per).enumerate().for_each(|(block, xs)| {
        let lo = block * per;
        let hi = lo + xs.len();
        let mut step = |i: usize| {
            let mut s = b[i];
            for k in a.ptr[i]..a.ptr[i + 1] {
                let j = a.col[k] as usize;
                let xj = if (lo..hi).contains(&j) {
                    xs[j - lo]
                } else {
                    before[j]
                };
                s -= a.val[k] * xj;
            }
            xs[i - lo] += s.scaled(1.0 / diag[i]);
        };
        if backward {
            (lo..hi).rev().for_each(&mut step);
        } else {
            (lo..hi).for_each(&mut step);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::transport::{EdgeTransport, FaceBases, NO_FACE};
    use crate::mesh::generate::{icosphere, subdivide, torus};
    use crate::sparse::c64;

    /// Σ_e |x_j − ρ_e x_i|² + Σ_i d_i |x_i|² on the dual graph of `mesh` (the field systems):
    /// ρ = 1 gives the real dual Laplacian, ρ = e^{4iκ} the relaxed 4-RoSy connection Laplacian.
    /// Every tenth face carries a weight, as the reliable faces do.
    fn dual_system<T: Scalar>(
        mesh: &crate::mesh::TriMesh,
        rho: impl Fn(f64) -> T,
    ) -> (SparseMatrix<T>, Vec<T>) {
        let tr = EdgeTransport::new(mesh, &FaceBases::new(mesh));
        let nf = mesh.n_faces();
        let mut b = SparseBuilder::<T>::with_capacity(nf, 5 * nf);
        let one = T::from_real(1.0);
        for i in 0..nf {
            b.add(i, i, T::from_real(if i % 10 == 0 { 0.5 } else { 0.0 }));
        }
        for (e, f) in tr.faces.iter().enumerate() {
            if f[1] != NO_FACE {
                let (i, j) = (f[0] as usize, f[1] as usize);
                let r = rho(tr.kappa[e]);
                b.add(i, i, one);
                b.add(j, j, one);
                b.add(j, i, -r);
                b.add(i, j, -r.conjugate());
            }
        }
        let rhs = (0..nf)
            .map(|i| {
                T::from_real(if i % 10 == 0 {
                    (i as f64 * 0.37).sin()
                } else {
                    0.0
                })
            })
            .collect();
        (b.build().expect("valid system"), rhs)
    }

    fn check_against_direct<T: Scalar>(matrix: &SparseMatrix<T>, rhs: &[T]) {
        let mg = Multigrid::new(matrix).expect("hierarchy");
        // Enough unknowns for at least two levels above the directly solved one, so that the
        // cycle itself (not only the coarse factorization) is exercised.
        assert!(mg.depth() >= 3, "levels {:?}", mg.level_sizes());
        let s = mg.solve(rhs, None, 1e-10, 100).expect("solve");
        // Plain CG needs hundreds of iterations on these systems; the V-cycle must cut that
        // to a mesh-independent handful.
        assert!(s.iterations <= 25, "{} iterations", s.iterations);
        assert!(s.relative_residual <= 1e-10);
        let x = SpdSolver::new(matrix).unwrap().solve(rhs).unwrap();
        let scale = x.iter().map(|v| v.modulus_sq().sqrt()).fold(0.0, f64::max);
        let err = x
            .iter()
            .zip(&s.x)
            .map(|(a, b)| (*a - *b).modulus_sq().sqrt())
            .fold(0.0, f64::max);
        assert!(err <= 1e-7 * scale, "max error {err:e}, max |x| {scale:e}");
    }

    #[test]
    fn real_dual_laplacian_matches_the_direct_solve() {
        let mesh = subdivide(&subdivide(&torus(3.0, 1.0, 80, 40)));
        let (m, rhs) = dual_system(&mesh, |_| 1.0);
        check_against_direct(&m, &rhs);
    }

    #[test]
    fn complex_connection_laplacian_matches_the_direct_solve() {
        // A sphere's curvature makes the transport phases non-trivial everywhere.
        let mesh = icosphere(6);
        let (m, rhs) = dual_system(&mesh, |k| c64::from_polar(1.0, 4.0 * k));
        check_against_direct(&m, &rhs);
    }

    #[test]
    fn warm_start_and_loose_tolerance_are_honoured() {
        let mesh = icosphere(5);
        let (m, rhs) = dual_system(&mesh, |k| c64::from_polar(1.0, 4.0 * k));
        let mg = Multigrid::new(&m).unwrap();
        let loose = mg.solve(&rhs, None, 1e-3, 100).unwrap();
        assert!(loose.relative_residual <= 1e-3 && loose.iterations >= 1);
        let tight = mg.solve(&rhs, None, 1e-10, 100).unwrap();
        assert!(tight.iterations > loose.iterations);
        // From the converged solution there is nothing left to do.
        let again = mg.solve(&rhs, Some(&tight.x), 1e-9, 100).unwrap();
        assert_eq!(again.iterations, 0);
        // The cap on iterations is a cap; the residual reached is reported.
        let capped = mg.solve(&rhs, None, 1e-14, 2).unwrap();
        assert_eq!(capped.iterations, 2);
        assert!(capped.relative_residual > 1e-14);
        let mut bad = rhs.clone();
        bad[7] = c64::new(f64::NAN, 0.0);
        assert_eq!(
            mg.solve(&bad, None, 1e-3, 100).unwrap_err(),
            SolverError::NonFinite
        );
        assert_eq!(
            mg.solve(&rhs, Some(&bad), 1e-3, 100).unwrap_err(),
            SolverError::NonFinite
        );
    }

    #[test]
    fn small_systems_are_solved_directly_and_bad_input_is_an_error() {
        let mesh = icosphere(2);
        let (m, rhs) = dual_system(&mesh, |_| 1.0f64);
        let mg = Multigrid::new(&m).unwrap();
        assert_eq!(mg.depth(), 1);
        let s = mg.solve(&rhs, None, 1e-3, 100).unwrap();
        let x = SpdSolver::new(&m).unwrap().solve(&rhs).unwrap();
        assert!(x.iter().zip(&s.x).all(|(a, b)| (a - b).abs() < 1e-12));
        assert!(matches!(
            mg.solve(&rhs[1..], None, 1e-3, 100),
            Err(SolverError::DimensionMismatch { .. })
        ));
        // Non-finite input is an error, not a silent NaN solution.
        let mut bad = rhs.clone();
        bad[3] = f64::NAN;
        assert_eq!(
            mg.solve(&bad, None, 1e-3, 100).unwrap_err(),
            SolverError::NonFinite
        );
        // A matrix that is not positive definite is reported, not iterated on.
        let mut b = SparseBuilder::<f64>::new(3);
        b.add(0, 0, -1.0);
        b.add(1, 1, 1.0);
        b.add(2, 2, 1.0);
        assert!(Multigrid::new(&b.build().unwrap()).is_err());
    }
}
