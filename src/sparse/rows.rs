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
//! costs one solve with A₀ and a few products. Every solve is checked against A itself and
//! refined once when the residual is large, so an ill-conditioned correction shows as an error
//! instead of a wrong answer.

use std::sync::Arc;

use faer::Mat;
use faer::linalg::solvers::{PartialPivLu, Solve};

use super::{Scalar, SolverError, SparseMatrix, SpdSolver};

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
        Ok(Some(RowUpdate {
            base: base.clone(),
            matrix,
            rows,
            x,
            y,
            correction: Default::default(),
        }))
    }

    /// The factored matrix this updates.
    pub fn base(&self) -> &SpdSolver<T> {
        &self.base
    }

    /// How many rows changed (|S|).
    pub fn rank(&self) -> usize {
        self.rows.len()
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
}
