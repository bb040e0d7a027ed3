//! The one sparse-solver wrapper: symmetric positive definite systems through faer's sparse
//! Cholesky, with the symbolic analysis kept so that re-solves with new values (same pattern)
//! or new right-hand sides skip it. Fields, parameterization and extraction all solve here.

use faer::Side;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum SolverError {
    #[error("sparse matrix could not be built: {0}")]
    Build(String),
    #[error(
        "matrix is not positive definite (is an unknown unconstrained, or a weight negative?): {0}"
    )]
    NotPositiveDefinite(String),
    #[error("right-hand side has length {found}, the system has {expected} unknowns")]
    DimensionMismatch { expected: usize, found: usize },
    #[error("the solution contains NaN or infinite values")]
    NonFinite,
}

/// Collects matrix entries; duplicates are summed.
#[derive(Clone, Debug, Default)]
pub struct SparseBuilder {
    n: usize,
    entries: Vec<Triplet<usize, usize, f64>>,
}

impl SparseBuilder {
    pub fn new(n: usize) -> SparseBuilder {
        SparseBuilder {
            n,
            entries: Vec::new(),
        }
    }
    pub fn with_capacity(n: usize, nnz: usize) -> SparseBuilder {
        SparseBuilder {
            n,
            entries: Vec::with_capacity(nnz),
        }
    }
    /// Adds `v` at (i, j). For symmetric matrices add both (i, j) and (j, i).
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        debug_assert!(i < self.n && j < self.n);
        self.entries.push(Triplet::new(i, j, v));
    }
    /// Adds `v` at (i, j) and at (j, i) (once on the diagonal).
    pub fn add_sym(&mut self, i: usize, j: usize, v: f64) {
        self.add(i, j, v);
        if i != j {
            self.add(j, i, v);
        }
    }
    pub fn n(&self) -> usize {
        self.n
    }
    pub fn build(&self) -> Result<SparseMatrix, SolverError> {
        SparseColMat::try_new_from_triplets(self.n, self.n, &self.entries)
            .map(|inner| SparseMatrix { inner })
            .map_err(|e| SolverError::Build(format!("{e:?}")))
    }
}

/// A square sparse matrix in compressed columns.
#[derive(Clone, Debug)]
pub struct SparseMatrix {
    inner: SparseColMat<usize, f64>,
}

impl SparseMatrix {
    pub fn n(&self) -> usize {
        self.inner.nrows()
    }
    pub fn nnz(&self) -> usize {
        self.inner.compute_nnz()
    }
    /// y = A x.
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        let a = self.inner.as_ref();
        let mut y = vec![0.0; self.n()];
        for (j, &xj) in x.iter().enumerate().take(self.n()) {
            for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
                y[i] += v * xj;
            }
        }
        y
    }
    /// Entries as (row, col, value), column by column.
    pub fn entries(&self) -> Vec<(usize, usize, f64)> {
        let a = self.inner.as_ref();
        (0..self.n())
            .flat_map(|j| {
                a.row_idx_of_col(j)
                    .zip(a.val_of_col(j))
                    .map(move |(i, &v)| (i, j, v))
            })
            .collect()
    }
}

/// A factored symmetric positive definite matrix; keeps its symbolic analysis for refactoring.
#[derive(Clone, Debug)]
pub struct SpdSolver {
    symbolic: SymbolicLlt<usize>,
    llt: Llt<usize, f64>,
    n: usize,
}

impl SpdSolver {
    /// Symbolic analysis (fill-reducing ordering) and numeric factorization.
    pub fn new(matrix: &SparseMatrix) -> Result<SpdSolver, SolverError> {
        let symbolic = SymbolicLlt::try_new(matrix.inner.symbolic(), Side::Lower)
            .map_err(|e| SolverError::Build(format!("{e:?}")))?;
        let llt = Self::numeric(&symbolic, matrix)?;
        Ok(SpdSolver {
            symbolic,
            llt,
            n: matrix.n(),
        })
    }

    fn numeric(
        symbolic: &SymbolicLlt<usize>,
        matrix: &SparseMatrix,
    ) -> Result<Llt<usize, f64>, SolverError> {
        Llt::try_new_with_symbolic(symbolic.clone(), matrix.inner.as_ref(), Side::Lower)
            .map_err(|e| SolverError::NotPositiveDefinite(format!("{e:?}")))
    }

    /// New values with the same sparsity pattern: only the numeric factorization is redone.
    pub fn refactor(&mut self, matrix: &SparseMatrix) -> Result<(), SolverError> {
        if matrix.n() != self.n {
            return Err(SolverError::DimensionMismatch {
                expected: self.n,
                found: matrix.n(),
            });
        }
        self.llt = Self::numeric(&self.symbolic, matrix)?;
        Ok(())
    }

    pub fn n(&self) -> usize {
        self.n
    }

    /// Solves A x = rhs.
    pub fn solve(&self, rhs: &[f64]) -> Result<Vec<f64>, SolverError> {
        Ok(self.solve_many(&[rhs])?.remove(0))
    }

    /// Solves A X = B for several right-hand sides at once.
    pub fn solve_many(&self, rhs: &[&[f64]]) -> Result<Vec<Vec<f64>>, SolverError> {
        if let Some(bad) = rhs.iter().find(|r| r.len() != self.n) {
            return Err(SolverError::DimensionMismatch {
                expected: self.n,
                found: bad.len(),
            });
        }
        let mut b = faer::Mat::<f64>::from_fn(self.n, rhs.len(), |i, j| rhs[j][i]);
        self.llt.solve_in_place(b.as_mut());
        let out: Vec<Vec<f64>> = (0..rhs.len())
            .map(|j| (0..self.n).map(|i| b[(i, j)]).collect())
            .collect();
        if out.iter().flatten().all(|x| x.is_finite()) {
            Ok(out)
        } else {
            Err(SolverError::NonFinite)
        }
    }
}

/// Solves A x = b with some unknowns fixed (Dirichlet values): the fixed columns move to the
/// right side, the remaining system is solved, and the fixed values are put back in place.
pub fn solve_constrained(
    matrix: &SparseMatrix,
    rhs: &[f64],
    fixed: &[(usize, f64)],
) -> Result<Vec<f64>, SolverError> {
    let n = matrix.n();
    if rhs.len() != n {
        return Err(SolverError::DimensionMismatch {
            expected: n,
            found: rhs.len(),
        });
    }
    let mut value = vec![None; n];
    for &(i, v) in fixed {
        value[i] = Some(v);
    }
    let mut free_index = vec![usize::MAX; n];
    let mut m = 0;
    for i in 0..n {
        if value[i].is_none() {
            free_index[i] = m;
            m += 1;
        }
    }
    let mut b: Vec<f64> = (0..n)
        .filter(|&i| value[i].is_none())
        .map(|i| rhs[i])
        .collect();
    let mut reduced = SparseBuilder::new(m);
    for (i, j, a) in matrix.entries() {
        match (free_index[i], value[j]) {
            (usize::MAX, _) => {}
            (fi, Some(vj)) => b[fi] -= a * vj,
            (fi, None) => reduced.add(fi, free_index[j], a),
        }
    }
    let x = if m == 0 {
        Vec::new()
    } else {
        SpdSolver::new(&reduced.build()?)?.solve(&b)?
    };
    Ok((0..n)
        .map(|i| value[i].unwrap_or_else(|| x[free_index[i]]))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1-D Laplacian with Dirichlet ends: the solution is linear.
    #[test]
    fn path_laplacian_with_fixed_ends_is_linear() {
        let n = 11;
        let mut b = SparseBuilder::new(n);
        for i in 0..n - 1 {
            b.add_sym(i, i + 1, -1.0);
            b.add(i, i, 1.0);
            b.add(i + 1, i + 1, 1.0);
        }
        let a = b.build().unwrap();
        let x = solve_constrained(&a, &vec![0.0; n], &[(0, 0.0), (n - 1, 10.0)]).unwrap();
        for (i, xi) in x.iter().enumerate() {
            assert!((xi - i as f64).abs() < 1e-10, "x[{i}] = {xi}");
        }
    }

    #[test]
    fn refactor_reuses_pattern_and_matches_fresh_factorization() {
        let n = 50;
        let build = |shift: f64| {
            let mut b = SparseBuilder::new(n);
            for i in 0..n {
                b.add(i, i, 2.0 + shift);
                if i + 1 < n {
                    b.add_sym(i, i + 1, -1.0);
                }
            }
            b.build().unwrap()
        };
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut s = SpdSolver::new(&build(0.0)).unwrap();
        s.refactor(&build(1.0)).unwrap();
        let x = s.solve(&rhs).unwrap();
        let r = build(1.0).mul_vec(&x);
        for i in 0..n {
            assert!((r[i] - rhs[i]).abs() < 1e-10);
        }
    }

    #[test]
    fn indefinite_matrix_is_an_error_not_a_panic() {
        let mut b = SparseBuilder::new(2);
        b.add(0, 0, 1.0);
        b.add(1, 1, -1.0);
        assert!(matches!(
            SpdSolver::new(&b.build().unwrap()),
            Err(SolverError::NotPositiveDefinite(_))
        ));
    }
}
