//! Symmetric systems whose unknowns are 2-D texture values and whose couplings are
//! (scaled) rotations R^k. For N = 2 every R^k = ±I, so u and v decouple into two systems with
//! the same half-size scalar matrix (sec. 4.2). Otherwise a rotation block [[c, s], [−s, c]] is
//! the complex number c − is acting on u + iv, and the system is assembled and factored as a
//! Hermitian one (half the work of the real 2 × 2-block form, see `sparse::Scalar`).

use crate::sparse::{Analysis, Scalar, SparseBuilder, SpdSolver, c64};

use super::ParamError;
use super::rot::M2;

pub(crate) enum BlockBuilder {
    /// N = 2: u and v decouple.
    Scalar(SparseBuilder<f64>),
    /// N = 4, 6: one complex unknown u + iv per node.
    Complex(SparseBuilder<c64>),
}

/// The complex number of a scaled rotation block [[a, −b], [b, a]] (row-major `m`).
fn block_to_complex(m: &M2) -> c64 {
    debug_assert!(m[0] == m[3] && m[1] == -m[2], "not a rotation block: {m:?}");
    c64::new(m[0], m[2])
}

impl BlockBuilder {
    pub fn new(scalar: bool, n: usize, nnz_hint: usize) -> BlockBuilder {
        if scalar {
            BlockBuilder::Scalar(SparseBuilder::with_capacity(n, nnz_hint))
        } else {
            BlockBuilder::Complex(SparseBuilder::with_capacity(n, nnz_hint))
        }
    }
    /// Block (i, j) += k · m.
    pub fn add(&mut self, i: usize, j: usize, k: f64, m: &M2) {
        match self {
            BlockBuilder::Scalar(b) => b.add(i, j, k * m[0]),
            BlockBuilder::Complex(b) => b.add(i, j, block_to_complex(m) * k),
        }
    }
    /// Factors the system, with `analysis` of its pattern if one was computed beforehand.
    pub fn factor(&self, analysis: Option<&Analysis>) -> Result<BlockSolver, ParamError> {
        fn solver<T: Scalar>(
            b: &SparseBuilder<T>,
            analysis: Option<&Analysis>,
        ) -> Result<SpdSolver<T>, ParamError> {
            let m = b.build()?;
            Ok(match analysis {
                Some(a) => SpdSolver::with_analysis(a.clone(), &m)?,
                None => SpdSolver::new(&m)?,
            })
        }
        Ok(match self {
            BlockBuilder::Scalar(b) => BlockSolver::Scalar(solver(b, analysis)?),
            BlockBuilder::Complex(b) => BlockSolver::Complex(solver(b, analysis)?),
        })
    }
}

/// A factored block system; solves reuse the factorization (only back-substitution).
pub(crate) enum BlockSolver {
    Scalar(SpdSolver<f64>),
    Complex(SpdSolver<c64>),
}

impl BlockSolver {
    pub fn n(&self) -> usize {
        match self {
            BlockSolver::Scalar(s) => s.n(),
            BlockSolver::Complex(s) => s.n(),
        }
    }
    pub fn analysis(&self) -> &Analysis {
        match self {
            BlockSolver::Scalar(s) => s.analysis(),
            BlockSolver::Complex(s) => s.analysis(),
        }
    }
    pub fn solve(&self, rhs: &[[f64; 2]]) -> Result<Vec<[f64; 2]>, ParamError> {
        Ok(self.solve_many(&[rhs])?.remove(0))
    }
    pub fn solve_many(&self, rhs: &[&[[f64; 2]]]) -> Result<Vec<Vec<[f64; 2]>>, ParamError> {
        if rhs.is_empty() {
            return Ok(Vec::new());
        }
        match self {
            BlockSolver::Scalar(s) => {
                let n = s.n();
                let cols: Vec<Vec<f64>> = rhs
                    .iter()
                    .flat_map(|r| (0..2).map(move |c| r.iter().map(|x| x[c]).collect()))
                    .collect();
                let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
                let sol = s.solve_many(&refs)?;
                Ok((0..rhs.len())
                    .map(|k| (0..n).map(|i| [sol[2 * k][i], sol[2 * k + 1][i]]).collect())
                    .collect())
            }
            BlockSolver::Complex(s) => {
                let cols: Vec<Vec<c64>> = rhs
                    .iter()
                    .map(|r| r.iter().map(|x| c64::new(x[0], x[1])).collect())
                    .collect();
                let refs: Vec<&[c64]> = cols.iter().map(|c| c.as_slice()).collect();
                let sol = s.solve_many(&refs)?;
                Ok(sol
                    .iter()
                    .map(|s| s.iter().map(|z| [z.re, z.im]).collect())
                    .collect())
            }
        }
    }
}
