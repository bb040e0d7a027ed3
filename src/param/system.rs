//! Symmetric systems whose unknowns are 2-D texture values and whose couplings are
//! (scaled) rotations R^k. For N = 2 every R^k = ±I, so u and v decouple into two systems with
//! the same half-size scalar matrix (sec. 4.2); otherwise 2×2 blocks are assembled.

use crate::sparse::{SparseBuilder, SpdSolver};

use super::ParamError;
use super::rot::M2;

pub(crate) struct BlockBuilder {
    scalar: bool,
    b: SparseBuilder,
}

impl BlockBuilder {
    pub fn new(scalar: bool, n: usize, nnz_hint: usize) -> BlockBuilder {
        let dim = if scalar { n } else { 2 * n };
        let cap = if scalar { nnz_hint } else { 4 * nnz_hint };
        BlockBuilder {
            scalar,
            b: SparseBuilder::with_capacity(dim, cap),
        }
    }
    /// Block (i, j) += k · m.
    pub fn add(&mut self, i: usize, j: usize, k: f64, m: &M2) {
        if self.scalar {
            self.b.add(i, j, k * m[0]);
        } else {
            for r in 0..2 {
                for c in 0..2 {
                    let v = k * m[2 * r + c];
                    if v != 0.0 {
                        self.b.add(2 * i + r, 2 * j + c, v);
                    }
                }
            }
        }
    }
    pub fn factor(&self) -> Result<BlockSolver, ParamError> {
        let m = self.b.build()?;
        Ok(BlockSolver {
            scalar: self.scalar,
            solver: SpdSolver::new(&m)?,
        })
    }
}

/// A factored block system; solves reuse the factorization (only back-substitution).
pub(crate) struct BlockSolver {
    scalar: bool,
    solver: SpdSolver,
}

impl BlockSolver {
    pub fn n(&self) -> usize {
        if self.scalar {
            self.solver.n()
        } else {
            self.solver.n() / 2
        }
    }
    pub fn solve(&self, rhs: &[[f64; 2]]) -> Result<Vec<[f64; 2]>, ParamError> {
        Ok(self.solve_many(&[rhs])?.remove(0))
    }
    pub fn solve_many(&self, rhs: &[&[[f64; 2]]]) -> Result<Vec<Vec<[f64; 2]>>, ParamError> {
        let n = self.n();
        if rhs.is_empty() {
            return Ok(Vec::new());
        }
        if self.scalar {
            let cols: Vec<Vec<f64>> = rhs
                .iter()
                .flat_map(|r| (0..2).map(move |c| r.iter().map(|x| x[c]).collect::<Vec<f64>>()))
                .collect();
            let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
            let sol = self.solver.solve_many(&refs)?;
            Ok((0..rhs.len())
                .map(|k| (0..n).map(|i| [sol[2 * k][i], sol[2 * k + 1][i]]).collect())
                .collect())
        } else {
            let cols: Vec<Vec<f64>> = rhs
                .iter()
                .map(|r| r.iter().flat_map(|x| [x[0], x[1]]).collect())
                .collect();
            let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
            let sol = self.solver.solve_many(&refs)?;
            Ok(sol
                .iter()
                .map(|s| (0..n).map(|i| [s[2 * i], s[2 * i + 1]]).collect())
                .collect())
        }
    }
}
