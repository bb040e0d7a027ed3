//! Solving with a factored matrix after a few of its rows (and so, by symmetry, the matching
//! columns) changed, without refactoring it: the editor's re-solve after a singularity moves
//! (issue #13), where a move changes the systems' couplings only along the path it took.
//!
//! With A₀ factored and A = A₀ + E, let S be a set of rows covering E (every nonzero E_ij has
//! i ∈ S or j ∈ S), P the unit columns of S, X = Pᵀ E its rows and Y = (I − P Pᵀ) E P the rest
//! of its columns. Then E = P X + Y Pᵀ = U Wᴴ with U = [P, Y] and Wᴴ = [X; Pᵀ], and by the
//! Woodbury identity
//!
//!   A⁻¹ b = x₀ − Z (I + Wᴴ Z)⁻¹ Wᴴ x₀,   x₀ = A₀⁻¹ b,   Z = A₀⁻¹ U,
//!
//! so after 2|S| solves with A₀ for Z (one multi-column solve) and a small dense LU, each solve
//! costs one solve with A₀ and a few products.
//!
//! With a supernodal factor A₀ = Pᵀ L Lᴴ P the correction goes inside the factor instead:
//! A = Pᵀ L (I + Ỹ W̃ᴴ) Lᴴ P with Ỹ = L⁻¹ P U and W̃ = L⁻¹ P W, so
//!
//!   A⁻¹ b = Pᵀ L⁻ᴴ (z − Ỹ (I + W̃ᴴ Ỹ)⁻¹ W̃ᴴ z),   z = L⁻¹ P b.
//!
//! U's and W's columns are sparse, and L⁻¹ of a sparse column is nonzero only on the
//! elimination-tree paths from its rows to the root: Ỹ and W̃ cost a few small dense solves
//! along those paths (as in [`super::DiagonalDowndate`]), not 2|S| whole solves, and a solve
//! costs one forward and one backward substitution, like one with A₀. (Measured on the bunny's
//! local step, 104 k unknowns: 2|S| + 1 = 7 whole columns took 70 ms, a single one 23 ms.)
//!
//! Every solve is checked against A itself and refined once when the residual is large, so an
//! ill-conditioned correction shows as an error instead of a wrong answer.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::{PartialPivLu, Solve};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::{Accum, Conj, Mat, Par};

use super::{Scalar, SolverError, SparseMatrix, SpdSolver, clear_upper_vector_state};

/// Relative residual ‖A x − b‖ / ‖b‖ above which a solve is refined once, and above which
/// (after refining) it is an error.
const REFINE_ABOVE: f64 = 1e-11;
const FAIL_ABOVE: f64 = 1e-7;

/// A factored matrix A₀ and a matrix A of the same pattern that differs from it in a few rows.
pub struct RowUpdate<T: Scalar> {
    base: Arc<SpdSolver<T>>,
    matrix: Arc<SparseMatrix<T>>,
    rows: Vec<usize>,
    /// X: per row of S its entries (column, E value).
    x: Vec<Vec<(usize, T)>>,
    /// Y: per row of S its column's entries outside S (row, E value).
    y: Vec<Vec<(usize, T)>>,
    /// Z = A₀⁻¹ U and the LU factors of I + Wᴴ Z, made by the first solve: its right-hand
    /// sides and U's columns go through A₀'s factor together (the solves read the whole factor
    /// from memory, and one pass for all columns costs little more than one for a single one).
    correction: std::sync::OnceLock<Arc<Correction<T>>>,
    /// The correction inside a supernodal factor (module documentation), when there is one.
    through: Option<Through<T>>,
}

/// Ỹ and W̃ along their elimination-tree paths, and the LU factors of I + W̃ᴴ Ỹ.
struct Through<T: Scalar> {
    /// Columns 0..s: L⁻¹ P (unit columns of S); s..2s: L⁻¹ P Y; 2s..3s: L⁻¹ P Xᴴ. Ỹ is
    /// columns 0..2s, W̃ columns 2s..3s then 0..s.
    blocks: Vec<PathBlock<T>>,
    capacitance: PartialPivLu<T>,
}

/// The rows of some sparse columns of L⁻¹ in one supernode: its columns
/// `start..start + values.nrows()`, for the columns (`active`, ascending) whose paths pass
/// through it.
pub(super) struct PathBlock<T: Scalar> {
    pub start: usize,
    pub active: Vec<usize>,
    pub values: Mat<T>,
}

/// Solutions with A₀, and the correction.
type Solves<T> = (Vec<Vec<T>>, Arc<Correction<T>>);

struct Correction<T: Scalar> {
    z: Vec<Vec<T>>,
    capacitance: PartialPivLu<T>,
}

impl<T: Scalar> RowUpdate<T> {
    /// The update from `base` (factoring `base_matrix`) to `matrix`; `None` when the two differ
    /// in more than `max_rows` rows (refactoring is then the cheaper way) or not at all (solve
    /// with the base). An error when the patterns differ.
    pub fn new(
        base: &Arc<SpdSolver<T>>,
        base_matrix: &SparseMatrix<T>,
        matrix: Arc<SparseMatrix<T>>,
        max_rows: usize,
    ) -> Result<Option<RowUpdate<T>>, SolverError> {
        let n = matrix.n();
        if base_matrix.col_ptr != matrix.col_ptr
            || base_matrix.row_idx != matrix.row_idx
            || base.n() != n
        {
            return Err(SolverError::Build(
                "an updated matrix must keep the factored one's pattern".into(),
            ));
        }
        let diff = changed_entries(base_matrix, &matrix);
        if diff.is_empty() {
            return Ok(None);
        }
        let Some(rows) = cover(n, &diff, max_rows) else {
            return Ok(None);
        };
        let s = rows.len();
        let mut slot = vec![usize::MAX; n];
        for (k, &r) in rows.iter().enumerate() {
            slot[r] = k;
        }
        // X (rows of S) and Y (columns of S outside S), from the stored entries of E (both
        // triangles are stored).
        let mut x = vec![Vec::new(); s];
        let mut y = vec![Vec::new(); s];
        for &(i, j, d) in &diff {
            if slot[i] != usize::MAX {
                x[slot[i]].push((j, d));
            } else {
                y[slot[j]].push((i, d));
            }
        }
        let mut update = RowUpdate {
            base: base.clone(),
            matrix,
            rows,
            x,
            y,
            correction: Default::default(),
            through: None,
        };
        update.through = update.through_factor()?;
        Ok(Some(update))
    }

    /// The factored matrix this updates.
    pub fn base(&self) -> &SpdSolver<T> {
        &self.base
    }

    /// How many rows changed (|S|).
    pub fn rank(&self) -> usize {
        self.rows.len()
    }

    /// Whether the correction goes inside the factor (a supernodal one).
    pub fn inside_factor(&self) -> bool {
        self.through.is_some()
    }

    /// Ỹ, W̃ and the capacitance for a supernodal factor; `None` for a simplicial one.
    fn through_factor(&self) -> Result<Option<Through<T>>, SolverError> {
        let symbolic = self.base.analysis.symbolic.as_ref();
        let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else {
            return Ok(None);
        };
        let inverse = symbolic.perm().map(|p| p.arrays().1);
        let at = |r: usize| inverse.map_or(r, |p| p[r]);
        let s = self.rows.len();
        let mut columns: Vec<Vec<(usize, T)>> = Vec::with_capacity(3 * s);
        columns.extend(self.rows.iter().map(|&r| vec![(at(r), T::from_real(1.0))]));
        columns.extend(
            self.y
                .iter()
                .map(|c| c.iter().map(|&(i, d)| (at(i), d)).collect()),
        );
        columns.extend(
            self.x
                .iter()
                .map(|c| c.iter().map(|&(j, d)| (at(j), d.conjugate())).collect()),
        );
        let factor = SupernodalLltRef::new(sym, &self.base.l_values);
        let blocks = path_columns(sym, factor, &columns, |_| Ok(()))?;
        // I + W̃ᴴ Ỹ: per supernode the Gram matrix of its active columns, scattered.
        let m = 2 * s;
        let w_of = |c: usize| {
            if c >= 2 * s {
                Some(c - 2 * s)
            } else if c < s {
                Some(c + s)
            } else {
                None
            }
        };
        let y_of = |c: usize| (c < 2 * s).then_some(c);
        let mut cap = Mat::<T>::zeros(m, m);
        for i in 0..m {
            cap[(i, i)] = T::from_real(1.0);
        }
        for b in &blocks {
            let k = b.active.len();
            let mut gram = Mat::<T>::zeros(k, k);
            matmul(
                gram.as_mut(),
                Accum::Replace,
                b.values.adjoint(),
                b.values.as_ref(),
                T::from_real(1.0),
                Par::Seq,
            );
            for (a, &ca) in b.active.iter().enumerate() {
                let Some(wa) = w_of(ca) else { continue };
                for (c, &cc) in b.active.iter().enumerate() {
                    if let Some(yc) = y_of(cc) {
                        cap[(wa, yc)] += gram[(a, c)];
                    }
                }
            }
            // Column 0..s is in both Ỹ and W̃ (row s..2s of the capacitance).
        }
        clear_upper_vector_state();
        Ok(Some(Through {
            blocks,
            capacitance: cap.partial_piv_lu(),
        }))
    }

    /// A⁻¹ for each right-hand side through the factor (module documentation).
    fn apply_through(&self, t: &Through<T>, rhs: &[&[T]]) -> Result<Vec<Vec<T>>, SolverError> {
        let symbolic = self.base.analysis.symbolic.as_ref();
        let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else {
            return Err(SolverError::Build("the factor is not supernodal".into()));
        };
        let n = self.matrix.n();
        let k = rhs.len();
        let perm = symbolic.perm();
        let mut z = match perm {
            Some(p) => Mat::<T>::from_fn(n, k, |i, j| rhs[j][p.arrays().0[i]]),
            None => Mat::<T>::from_fn(n, k, |i, j| rhs[j][i]),
        };
        let factor = SupernodalLltRef::new(sym, &self.base.l_values);
        let req = sym.solve_in_place_scratch::<T>(k, Par::Seq);
        let mut mem = MemBuffer::try_new(req).map_err(|_| SolverError::OutOfMemory)?;
        factor.l_solve_with_conj(Conj::No, z.as_mut(), Par::Seq, MemStack::new(&mut mem));
        let s = self.rows.len();
        let m = 2 * s;
        // W̃ᴴ z.
        let mut wz = Mat::<T>::zeros(m, k);
        for b in &t.blocks {
            for (a, &ca) in b.active.iter().enumerate() {
                let w = if ca >= 2 * s {
                    ca - 2 * s
                } else if ca < s {
                    ca + s
                } else {
                    continue;
                };
                let column = b.values.col(a);
                for j in 0..k {
                    let mut acc = T::ZERO;
                    for r in 0..b.values.nrows() {
                        acc += column[r].conjugate() * z[(b.start + r, j)];
                    }
                    wz[(w, j)] += acc;
                }
            }
        }
        let c = t.capacitance.solve(wz);
        // z −= Ỹ c.
        for b in &t.blocks {
            for (a, &ca) in b.active.iter().enumerate() {
                if ca >= 2 * s {
                    continue;
                }
                let column = b.values.col(a);
                for j in 0..k {
                    let cj = c[(ca, j)];
                    for r in 0..b.values.nrows() {
                        z[(b.start + r, j)] -= column[r] * cj;
                    }
                }
            }
        }
        factor.l_transpose_solve_with_conj(
            Conj::Yes,
            z.as_mut(),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        clear_upper_vector_state();
        Ok((0..k)
            .map(|j| match perm {
                Some(p) => (0..n).map(|i| z[(p.arrays().1[i], j)]).collect(),
                None => (0..n).map(|i| z[(i, j)]).collect(),
            })
            .collect())
    }

    /// U's columns, dense: P (unit columns of S), then Y.
    fn u_columns(&self) -> Vec<Vec<T>> {
        let n = self.matrix.n();
        let s = self.rows.len();
        let mut u: Vec<Vec<T>> = (0..2 * s).map(|_| vec![T::ZERO; n]).collect();
        for (k, &r) in self.rows.iter().enumerate() {
            u[k][r] = T::from_real(1.0);
            for &(i, d) in &self.y[k] {
                u[s + k][i] = d;
            }
        }
        u
    }

    /// A₀⁻¹ for each right-hand side, and the correction (computed with them the first time).
    fn base_solves(&self, rhs: &[&[T]]) -> Result<Solves<T>, SolverError> {
        if let Some(c) = self.correction.get() {
            return Ok((self.base.solve_many(rhs)?, c.clone()));
        }
        let u = self.u_columns();
        let mut all: Vec<&[T]> = rhs.to_vec();
        all.extend(u.iter().map(|c| c.as_slice()));
        let mut xs = self.base.solve_many(&all)?;
        let z = xs.split_off(rhs.len());
        let m = 2 * self.rows.len();
        let mut cap = Mat::<T>::zeros(m, m);
        for (c, zc) in z.iter().enumerate() {
            for (r, value) in apply_w(&self.x, &self.rows, zc).into_iter().enumerate() {
                cap[(r, c)] = value;
            }
            cap[(c, c)] += T::from_real(1.0);
        }
        let c = Arc::new(Correction {
            z,
            capacitance: cap.partial_piv_lu(),
        });
        Ok((xs, self.correction.get_or_init(|| c).clone()))
    }

    /// A⁻¹ for each right-hand side, through the Woodbury identity (module documentation).
    fn apply(&self, rhs: &[&[T]]) -> Result<Vec<Vec<T>>, SolverError> {
        if let Some(t) = &self.through {
            return self.apply_through(t, rhs);
        }
        let (mut xs, c) = self.base_solves(rhs)?;
        let m = 2 * self.rows.len();
        for x in &mut xs {
            let wx = apply_w(&self.x, &self.rows, x);
            let coef = c.capacitance.solve(Mat::<T>::from_fn(m, 1, |i, _| wx[i]));
            for (k, zk) in c.z.iter().enumerate() {
                let ck = coef[(k, 0)];
                for (xi, &zi) in x.iter_mut().zip(zk) {
                    *xi -= zi * ck;
                }
            }
        }
        Ok(xs)
    }

    /// Solves A X = B for several right-hand sides.
    pub fn solve_many(&self, rhs: &[&[T]]) -> Result<Vec<Vec<T>>, SolverError> {
        let n = self.matrix.n();
        if let Some(bad) = rhs.iter().find(|r| r.len() != n) {
            return Err(SolverError::DimensionMismatch {
                expected: n,
                found: bad.len(),
            });
        }
        let mut xs = self.apply(rhs)?;
        let norm = |v: &[T]| v.iter().map(|x| x.modulus_sq()).sum::<f64>().sqrt();
        let residual = |x: &[T], b: &[T]| -> Vec<T> {
            let ax = self.matrix.mul_vec(x);
            b.iter().zip(ax).map(|(&bi, ai)| bi - ai).collect()
        };
        for (x, b) in xs.iter_mut().zip(rhs) {
            let scale = norm(b).max(f64::MIN_POSITIVE);
            let mut r = residual(x, b);
            if norm(&r) > REFINE_ABOVE * scale {
                let dx = self.apply(&[&r])?.remove(0);
                for (xi, d) in x.iter_mut().zip(dx) {
                    *xi += d;
                }
                r = residual(x, b);
            }
            let bad = norm(&r) / scale;
            if bad.is_nan() || bad > FAIL_ABOVE {
                return Err(SolverError::NotPositiveDefinite(format!(
                    "the update of {} rows left a relative residual of {:.1e}",
                    self.rows.len(),
                    bad
                )));
            }
        }
        if xs.iter().flatten().all(|x| x.finite()) {
            Ok(xs)
        } else {
            Err(SolverError::NonFinite)
        }
    }
}

/// L⁻¹ of sparse columns (rows in the factor's order), by supernode along the paths from their
/// rows to the root: at each supernode one dense triangular solve and one product for all the
/// columns whose paths pass through it (as `DiagonalDowndate`'s `path_blocks`, for columns of
/// several entries).
///
/// `check` sees, per supernode, which columns pass through it before any work is done, and may
/// decline (`DiagonalDowndate` declines when refactoring is cheaper).
pub(super) fn path_columns<T: Scalar>(
    sym: &SymbolicSupernodalCholesky<usize>,
    factor: SupernodalLltRef<'_, usize, T>,
    columns: &[Vec<(usize, T)>],
    check: impl FnOnce(&[Vec<usize>]) -> Result<(), SolverError>,
) -> Result<Vec<PathBlock<T>>, SolverError> {
    let ns = sym.n_supernodes();
    let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
    let mut supernode_of = vec![0u32; sym.nrows()];
    for s in 0..ns {
        supernode_of[begin[s]..end[s]].fill(s as u32);
    }
    let parent = |s: usize| {
        sym.supernode(s)
            .pattern()
            .first()
            .map(|&r| supernode_of[r] as usize)
    };
    let mut active: Vec<Vec<usize>> = vec![Vec::new(); ns];
    for (j, column) in columns.iter().enumerate() {
        for &(r, _) in column {
            let mut s = Some(supernode_of[r] as usize);
            // Columns are visited in order: a supernode this column reached already has its
            // ancestors too.
            while let Some(t) = s {
                if active[t].last() == Some(&j) {
                    break;
                }
                active[t].push(j);
                s = parent(t);
            }
        }
    }
    check(&active)?;
    let mut slot = vec![usize::MAX; ns];
    let mut blocks = Vec::new();
    for s in 0..ns {
        if !active[s].is_empty() {
            slot[s] = blocks.len();
            let m = active[s].len();
            blocks.push(PathBlock {
                start: begin[s],
                active: std::mem::take(&mut active[s]),
                values: Mat::zeros(end[s] - begin[s], m),
            });
        }
    }
    for (j, column) in columns.iter().enumerate() {
        for &(r, v) in column {
            let b = &mut blocks[slot[supernode_of[r] as usize]];
            let c = b.active.binary_search(&j).map_err(|_| path_error())?;
            b.values[(r - b.start, c)] += v;
        }
    }
    let mut position = Vec::new();
    for s in 0..ns {
        let i = slot[s];
        if i == usize::MAX {
            continue;
        }
        let node = factor.supernode(s);
        let size = end[s] - begin[s];
        let (top, bottom) = node.val().split_at_row(size);
        let (done, later) = blocks.split_at_mut(i + 1);
        let block = &mut done[i];
        solve_lower_triangular_in_place(top, block.values.as_mut(), Par::Seq);
        let pattern = node.pattern();
        if pattern.is_empty() {
            continue;
        }
        let mut update = Mat::<T>::zeros(pattern.len(), block.active.len());
        matmul(
            update.as_mut(),
            Accum::Replace,
            bottom,
            block.values.as_ref(),
            T::from_real(1.0),
            Par::Seq,
        );
        let mut r = 0;
        while r < pattern.len() {
            let t = supernode_of[pattern[r]] as usize;
            let run = pattern[r..]
                .iter()
                .take_while(|&&row| supernode_of[row] as usize == t)
                .count();
            if slot[t] <= i {
                return Err(path_error());
            }
            let target = &mut later[slot[t] - i - 1];
            position.clear();
            let mut c = 0;
            for &j in &block.active {
                while c < target.active.len() && target.active[c] < j {
                    c += 1;
                }
                if c == target.active.len() || target.active[c] != j {
                    return Err(path_error());
                }
                position.push(c);
            }
            for (a, &c) in position.iter().enumerate() {
                for q in r..r + run {
                    let u = update[(q, a)];
                    target.values[(pattern[q] - target.start, c)] -= u;
                }
            }
            r += run;
        }
    }
    Ok(blocks)
}

fn path_error() -> SolverError {
    SolverError::Build("the factor's rows are not on its elimination-tree paths".into())
}

/// Wᴴ v = [X v; v_S].
fn apply_w<T: Scalar>(x: &[Vec<(usize, T)>], rows: &[usize], v: &[T]) -> Vec<T> {
    let mut out: Vec<T> = x
        .iter()
        .map(|row| row.iter().fold(T::ZERO, |a, &(j, e)| a + e * v[j]))
        .collect();
    out.extend(rows.iter().map(|&r| v[r]));
    out
}

/// The stored entries where `new` differs from `old` (same pattern), as (row, column, new − old).
fn changed_entries<T: Scalar>(
    old: &SparseMatrix<T>,
    new: &SparseMatrix<T>,
) -> Vec<(usize, usize, T)> {
    let mut out = Vec::new();
    for j in 0..new.n {
        for k in new.col_ptr[j]..new.col_ptr[j + 1] {
            if new.values[k] != old.values[k] {
                out.push((new.row_idx[k], j, new.values[k] - old.values[k]));
            }
        }
    }
    out
}

/// A small set of rows covering the changed entries, greedily by how many uncovered entries a
/// row holds (a changed row of a connection Laplacian holds all its couplings, each neighbour
/// only one or two); ascending. `None` when more than `max_rows` are needed.
fn cover<T: Scalar>(n: usize, diff: &[(usize, usize, T)], max_rows: usize) -> Option<Vec<usize>> {
    let mut by_row: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (k, &(i, _, _)) in diff.iter().enumerate() {
        by_row.entry(i).or_default().push(k);
    }
    let mut covered = vec![false; diff.len()];
    let mut chosen = Vec::new();
    let mut in_set = vec![false; n];
    loop {
        // The row with the most uncovered entries (ties: the lowest row, for determinism).
        let best = by_row
            .iter()
            .map(|(&i, ks)| (ks.iter().filter(|&&k| !covered[k]).count(), i))
            .filter(|&(c, _)| c > 0)
            .max_by(|a, b| a.0.cmp(&b.0).then(b.1.cmp(&a.1)));
        let Some((_, i)) = best else {
            break;
        };
        if chosen.len() == max_rows {
            return None;
        }
        chosen.push(i);
        in_set[i] = true;
        // Row i covers its entries (i, j) and, by symmetry, the entries (j, i).
        for (k, &(a, b, _)) in diff.iter().enumerate() {
            if in_set[a] || in_set[b] {
                covered[k] = true;
            }
        }
    }
    chosen.sort_unstable();
    Some(chosen)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::{SparseBuilder, c64, grid_laplacian};

    fn shifted(m: &SparseMatrix, rows: &[usize]) -> SparseMatrix {
        // Couplings of `rows` scaled, diagonals kept dominant: still SPD, same pattern.
        let mut b = SparseBuilder::new(m.n());
        for (i, j, v) in m.entries() {
            let s = if i != j && (rows.contains(&i) || rows.contains(&j)) {
                0.3
            } else {
                1.0
            };
            b.add(i, j, v * s);
        }
        b.build().unwrap()
    }

    #[test]
    fn a_few_changed_rows_solve_like_a_refactorization() {
        let a0 = grid_laplacian(30, |_| 1.0);
        let base = Arc::new(SpdSolver::new(&a0).unwrap());
        let changed = [17, 431, 432, 800];
        let a = shifted(&a0, &changed);
        let up = RowUpdate::new(&base, &a0, Arc::new(a.clone()), 16)
            .unwrap()
            .unwrap();
        assert!(up.rank() <= changed.len(), "rank {}", up.rank());
        let b: Vec<f64> = (0..a.n()).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        let x = up.solve_many(&[&b]).unwrap().remove(0);
        let direct = SpdSolver::new(&a).unwrap().solve(&b).unwrap();
        let err = x
            .iter()
            .zip(&direct)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        let size = direct.iter().map(|q| q.abs()).fold(0.0, f64::max);
        assert!(err <= 1e-9 * size, "{err} against {size}");
        // The base's solution is not the answer: the update changed something.
        let plain = base.solve(&b).unwrap();
        let off = plain
            .iter()
            .zip(&direct)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        assert!(off > 1e-3 * size);
    }

    #[test]
    fn complex_rows_rotated_and_a_row_decoupled() {
        // A Hermitian connection Laplacian on a path whose couplings at two nodes rotate, and a
        // node that becomes a decoupled identity row (a branch point fixed elsewhere).
        let n = 200;
        let build = |rot: &dyn Fn(usize) -> c64, cut: Option<usize>| {
            let mut b = SparseBuilder::<c64>::new(n);
            for i in 0..n {
                b.add(i, i, c64::new(2.1, 0.0));
            }
            for i in 0..n - 1 {
                let v = if Some(i) == cut || Some(i + 1) == cut {
                    c64::new(0.0, 0.0)
                } else {
                    -rot(i)
                };
                b.add(i, i + 1, v);
                b.add(i + 1, i, v.conj());
            }
            b.build().unwrap()
        };
        let a0 = build(&|_| c64::new(1.0, 0.0), None);
        let a = build(
            &|i| {
                if i == 50 || i == 120 {
                    c64::new(0.0, 1.0)
                } else {
                    c64::new(1.0, 0.0)
                }
            },
            Some(160),
        );
        let base = Arc::new(SpdSolver::new(&a0).unwrap());
        let up = RowUpdate::new(&base, &a0, Arc::new(a.clone()), 16)
            .unwrap()
            .unwrap();
        let b: Vec<c64> = (0..n)
            .map(|i| c64::new((i % 5) as f64, -((i % 3) as f64)))
            .collect();
        let x = up.solve_many(&[&b]).unwrap().remove(0);
        let direct = SpdSolver::new(&a).unwrap().solve(&b).unwrap();
        let err = x
            .iter()
            .zip(&direct)
            .map(|(p, q)| (*p - *q).norm())
            .fold(0.0, f64::max);
        assert!(err < 1e-9, "{err}");
        // Too many rows for the limit: declined.
        assert!(
            RowUpdate::new(&base, &a0, Arc::new(a), 1)
                .unwrap()
                .is_none()
        );
    }

    /// A connection Laplacian on a grid (couplings e^{iφ}, a little mass): Hermitian definite.
    fn connection_grid(
        side: usize,
        phase: &dyn Fn(usize, usize) -> f64,
        cut: &[usize],
    ) -> SparseMatrix<c64> {
        let n = side * side;
        let mut b = SparseBuilder::<c64>::new(n);
        for i in 0..n {
            b.add(
                i,
                i,
                c64::new(if cut.contains(&i) { 1.0 } else { 0.01 }, 0.0),
            );
            let (x, y) = (i % side, i / side);
            for (nx, ny) in [(x + 1, y), (x, y + 1)] {
                if nx < side && ny < side {
                    let j = ny * side + nx;
                    // Kept as explicit zeros at a decoupled row: the pattern stays the grid's.
                    let w = if cut.contains(&i) || cut.contains(&j) {
                        0.0
                    } else {
                        1.0
                    };
                    let z = c64::new(phase(i, j).cos(), phase(i, j).sin()) * w;
                    b.add(i, j, -z);
                    b.add(j, i, -z.conj());
                    b.add(i, i, c64::new(w, 0.0));
                    b.add(j, j, c64::new(w, 0.0));
                }
            }
        }
        b.build().unwrap()
    }

    #[test]
    fn inside_a_supernodal_factor_real_and_complex() {
        // Real: a grid Laplacian whose couplings change at a path of rows.
        let a0 = grid_laplacian(200, |i| if i % 97 == 0 { 1.0 } else { 0.0 });
        let base = Arc::new(SpdSolver::new(&a0).unwrap());
        let changed: Vec<usize> = (0..6).map(|k| 20_000 + k * 201).collect();
        let a = shifted(&a0, &changed);
        let up = RowUpdate::new(&base, &a0, Arc::new(a.clone()), 64)
            .unwrap()
            .unwrap();
        assert!(up.inside_factor(), "the grid's factor should be supernodal");
        let b: Vec<f64> = (0..a.n()).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        let x = up
            .solve_many(&[&b, &b[..].iter().rev().copied().collect::<Vec<_>>()])
            .unwrap();
        let direct = SpdSolver::new(&a).unwrap().solve(&b).unwrap();
        let size = direct.iter().map(|q| q.abs()).fold(0.0, f64::max);
        let err = x[0]
            .iter()
            .zip(&direct)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        assert!(err <= 1e-9 * size, "{err} against {size}");
        // Complex: turned couplings along a path, one node decoupled (a new branch point).
        let side = 160;
        let base_phase = |i: usize, j: usize| 0.001 * (i as f64) - 0.002 * (j as f64);
        let a0 = connection_grid(side, &base_phase, &[]);
        let path: Vec<usize> = (0..5).map(|k| 30 * side + 20 + k).collect();
        let turned = |i: usize, j: usize| {
            base_phase(i, j)
                + if path.contains(&i) && j == i + side {
                    std::f64::consts::FRAC_PI_2
                } else {
                    0.0
                }
        };
        let a = connection_grid(side, &turned, &[12_345]);
        let base = Arc::new(SpdSolver::new(&a0).unwrap());
        let up = RowUpdate::new(&base, &a0, Arc::new(a.clone()), 64)
            .unwrap()
            .unwrap();
        assert!(up.inside_factor());
        // The path's rows, and the decoupled node with its neighbours (their diagonals changed).
        assert!(up.rank() <= 10, "rank {}", up.rank());
        let b: Vec<c64> = (0..a.n())
            .map(|i| c64::new((i % 7) as f64, -((i % 3) as f64)))
            .collect();
        let x = up.solve_many(&[&b]).unwrap().remove(0);
        let direct = SpdSolver::new(&a).unwrap().solve(&b).unwrap();
        let size = direct.iter().map(|q| q.norm()).fold(0.0, f64::max);
        let err = x
            .iter()
            .zip(&direct)
            .map(|(p, q)| (*p - *q).norm())
            .fold(0.0, f64::max);
        assert!(err <= 1e-9 * size, "{err} against {size}");
        let plain = base.solve(&b).unwrap();
        let off = plain
            .iter()
            .zip(&direct)
            .map(|(p, q)| (*p - *q).norm())
            .fold(0.0, f64::max);
        assert!(off > 1e-3 * size, "the update changed nothing: {off}");
    }
}
