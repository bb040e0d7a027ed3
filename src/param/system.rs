//! Symmetric systems whose unknowns are 2-D texture values and whose couplings are
//! (scaled) rotations R^k. For N = 2 every R^k = ±I, so u and v decouple into two systems with
//! the same half-size scalar matrix (sec. 4.2); otherwise 2×2 blocks are assembled.

use crate::sparse::{BlockBuilder2, SparseBuilder, SpdSolver};

use super::ParamError;
use super::rot::M2;

pub(crate) struct BlockBuilder {
    scalar: bool,
    /// The scalar matrix for N = 2 (u and v decouple).
    b: SparseBuilder,
    /// The 2 × 2-block matrix otherwise.
    blocks: BlockBuilder2,
}

impl BlockBuilder {
    pub fn new(scalar: bool, n: usize, nnz_hint: usize) -> BlockBuilder {
        if scalar {
            BlockBuilder {
                scalar,
                b: SparseBuilder::with_capacity(n, nnz_hint),
                blocks: BlockBuilder2::default(),
            }
        } else {
            BlockBuilder {
                scalar,
                b: SparseBuilder::new(0),
                blocks: BlockBuilder2::with_capacity(n, nnz_hint),
            }
        }
    }
    /// Block (i, j) += k · m.
    pub fn add(&mut self, i: usize, j: usize, k: f64, m: &M2) {
        if self.scalar {
            self.b.add(i, j, k * m[0]);
        } else {
            self.blocks.add(i, j, m.map(|x| k * x));
        }
    }
    pub fn factor(&self) -> Result<BlockSolver, ParamError> {
        let solver = if self.scalar {
            SpdSolver::new(&self.b.build()?)?
        } else {
            SpdSolver::new_blocked(&self.blocks.build()?, 2)?
        };
        Ok(BlockSolver {
            scalar: self.scalar,
            solver,
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
