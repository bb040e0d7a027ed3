//! Symmetric systems whose unknowns are 2-D texture values and whose couplings are
//! (scaled) rotations R^k. For N = 2 every R^k = ±I, so u and v decouple into two systems with
//! the same half-size scalar matrix (sec. 4.2). Otherwise a rotation block [[c, s], [−s, c]] is
//! the complex number c − is acting on u + iv, and the system is assembled and factored as a
//! Hermitian one (half the work of the real 2 × 2-block form, see `sparse::Scalar`).

use std::sync::Arc;

use crate::sparse::{Analysis, RowUpdate, Scalar, SparseBuilder, SparseMatrix, SpdSolver, c64};

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
    /// A builder for the system factored `how`: on the analysed pattern when there is an
    /// analysis (see [`SparseBuilder::on_pattern`]).
    pub fn new(scalar: bool, n: usize, nnz_hint: usize, how: &Factoring) -> BlockBuilder {
        match (how.analysis(), scalar) {
            (Some(a), true) => BlockBuilder::Scalar(SparseBuilder::on_pattern(a)),
            (Some(a), false) => BlockBuilder::Complex(SparseBuilder::on_pattern(a)),
            (None, true) => BlockBuilder::Scalar(SparseBuilder::with_capacity(n, nnz_hint)),
            (None, false) => BlockBuilder::Complex(SparseBuilder::with_capacity(n, nnz_hint)),
        }
    }
    /// Block (i, j) += k · m.
    pub fn add(&mut self, i: usize, j: usize, k: f64, m: &M2) {
        match self {
            BlockBuilder::Scalar(b) => b.add(i, j, k * m[0]),
            BlockBuilder::Complex(b) => b.add(i, j, block_to_complex(m) * k),
        }
    }
    /// Factors the system, with `analysis` of its pattern if one was computed beforehand;
    /// `keep`: keep the assembled matrix, for systems that later ones update (see
    /// [`Self::update`]).
    pub fn factor(
        &self,
        analysis: Option<&Analysis>,
        keep: bool,
    ) -> Result<BlockSolver, ParamError> {
        fn solver<T: Scalar>(
            b: &SparseBuilder<T>,
            analysis: Option<&Analysis>,
            keep: bool,
        ) -> Result<Factored<T>, ParamError> {
            let m = b.build()?;
            let solver = match analysis {
                Some(a) => SpdSolver::with_analysis(a.clone(), &m)?,
                None => SpdSolver::new(&m)?,
            };
            Ok(Factored::Full {
                solver: Arc::new(solver),
                matrix: keep.then(|| Arc::new(m)),
            })
        }
        Ok(match self {
            BlockBuilder::Scalar(b) => BlockSolver::Scalar(solver(b, analysis, keep)?),
            BlockBuilder::Complex(b) => BlockSolver::Complex(solver(b, analysis, keep)?),
        })
    }

    /// The system as an update of `base` (a factored system of the same pattern that kept its
    /// matrix) when the two differ in at most `max_rows` rows: no factorization, solves go
    /// through the base's factor (see [`RowUpdate`]); otherwise factored afresh with the base's
    /// analysis. The choice depends on the two matrices only, so it is reproducible.
    pub fn update(&self, base: &BlockSolver, max_rows: usize) -> Result<BlockSolver, ParamError> {
        fn solver<T: Scalar>(
            b: &SparseBuilder<T>,
            base: &Factored<T>,
            max_rows: usize,
        ) -> Result<Factored<T>, ParamError> {
            let Factored::Full {
                solver,
                matrix: Some(base_matrix),
            } = base
            else {
                return Err(ParamError::InvalidInput(
                    "an update needs a fully factored base that kept its matrix".into(),
                ));
            };
            let m = b.build()?;
            if m.values() == base_matrix.values() {
                return Ok(Factored::Same(solver.clone()));
            }
            let m = Arc::new(m);
            Ok(
                match RowUpdate::new(solver, base_matrix, m.clone(), max_rows)? {
                    Some(u) => Factored::Rows(Box::new(u)),
                    None => Factored::Full {
                        solver: Arc::new(SpdSolver::with_analysis(solver.analysis().clone(), &m)?),
                        matrix: None,
                    },
                },
            )
        }
        Ok(match (self, base) {
            (BlockBuilder::Scalar(b), BlockSolver::Scalar(f)) => {
                BlockSolver::Scalar(solver(b, f, max_rows)?)
            }
            (BlockBuilder::Complex(b), BlockSolver::Complex(f)) => {
                BlockSolver::Complex(solver(b, f, max_rows)?)
            }
            _ => {
                return Err(ParamError::InvalidInput(
                    "an update must keep the base's symmetry".into(),
                ));
            }
        })
    }
}

/// How a system is factored.
#[derive(Clone, Copy)]
pub(crate) enum Factoring<'a> {
    /// Afresh, with an analysis of its pattern computed beforehand if there is one; `keep`:
    /// keep the matrix, for systems that later ones update.
    Fresh {
        analysis: Option<&'a Analysis>,
        keep: bool,
    },
    /// As an update of a base system (see [`BlockBuilder::update`]).
    Update {
        base: &'a BlockSolver,
        max_rows: usize,
    },
}

impl Factoring<'_> {
    /// The analysis of the system's pattern, when one is known beforehand.
    pub fn analysis(&self) -> Option<&Analysis> {
        match self {
            Factoring::Fresh { analysis, .. } => *analysis,
            Factoring::Update { base, .. } => Some(base.analysis()),
        }
    }
}

impl BlockBuilder {
    pub fn factor_by(&self, how: Factoring) -> Result<BlockSolver, ParamError> {
        match how {
            Factoring::Fresh { analysis, keep } => self.factor(analysis, keep),
            Factoring::Update { base, max_rows } => self.update(base, max_rows),
        }
    }
}

/// A factored system, or an update of one in a few rows.
pub(crate) enum Factored<T: Scalar> {
    Full {
        solver: Arc<SpdSolver<T>>,
        /// The assembled matrix, kept for systems that later ones update.
        matrix: Option<Arc<SparseMatrix<T>>>,
    },
    /// The base's factor, the matrix being the base's.
    Same(Arc<SpdSolver<T>>),
    Rows(Box<RowUpdate<T>>),
}

impl<T: Scalar> Factored<T> {
    fn solver(&self) -> &SpdSolver<T> {
        match self {
            Factored::Full { solver, .. } | Factored::Same(solver) => solver,
            Factored::Rows(u) => u.base(),
        }
    }
    fn n(&self) -> usize {
        self.solver().n()
    }
    fn solve_many(&self, rhs: &[&[T]]) -> Result<Vec<Vec<T>>, crate::sparse::SolverError> {
        match self {
            Factored::Full { solver, .. } | Factored::Same(solver) => solver.solve_many(rhs),
            Factored::Rows(u) => u.solve_many(rhs),
        }
    }
    fn updated_rows(&self) -> Option<usize> {
        match self {
            Factored::Full { .. } => None,
            Factored::Same(_) => Some(0),
            Factored::Rows(u) => Some(u.rank()),
        }
    }
}

/// A factored block system; solves reuse the factorization (only back-substitution).
pub(crate) enum BlockSolver {
    Scalar(Factored<f64>),
    Complex(Factored<c64>),
}

impl BlockSolver {
    pub fn n(&self) -> usize {
        match self {
            BlockSolver::Scalar(s) => s.solver().n(),
            BlockSolver::Complex(s) => s.solver().n(),
        }
    }
    pub fn analysis(&self) -> &Analysis {
        match self {
            BlockSolver::Scalar(s) => s.solver().analysis(),
            BlockSolver::Complex(s) => s.solver().analysis(),
        }
    }
    /// How many rows an update changed (`None`: factored itself).
    pub fn updated_rows(&self) -> Option<usize> {
        match self {
            BlockSolver::Scalar(s) => s.updated_rows(),
            BlockSolver::Complex(s) => s.updated_rows(),
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
