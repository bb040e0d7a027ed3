//! Solving after a few diagonal entries of a factored matrix were lowered, without refactoring
//! it: A = A₀ − E D Eᵀ, with E the unit columns of the changed rows and D > 0 the decreases.
//!
//! By the Woodbury identity, with A₀ = Pᵀ L Lᵀ P and Y = L⁻¹ P E,
//!
//!   A⁻¹ b = Pᵀ L⁻ᵀ (z + Y K⁻¹ Yᵀ z),   z = L⁻¹ P b,   K = D⁻¹ − Yᵀ Y,
//!
//! so once Y and K's Cholesky factor are known, a solve costs one forward and one backward
//! substitution plus a few small products, like a solve with A₀. K is positive definite exactly
//! when A is (it is the Schur complement of A₀'s block in [[A₀, E], [Eᵀ, D⁻¹]], and A is the
//! other one).
//!
//! Y is cheap because its columns are sparse: L⁻¹ e_p is nonzero only on the elimination-tree
//! path from p to the root. The columns are computed together, supernode by supernode up the
//! tree: at each supernode, one dense triangular solve and one product for all the columns whose
//! path passes through it.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::cholesky::llt::solve::solve_in_place;
use faer::linalg::matmul::matmul;
use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::{Accum, Conj, Mat, Par};

use super::rows::{PathBlock, path_columns};
use super::{SolverError, SpdSolver, clear_upper_vector_state};

/// [`SpdSolver::downdated`] declines (the caller refactors) when computing Y and YᵀY would take
/// more than this multiple of a refactorization's floating-point work. Measured on the field's
/// systems: 439 rows at 1.1 M faces, ratio 0.12, 0.1 s against 1.5 s; 3909 rows at 4.3 M
/// faces, ratio 1.2, 6.0 s against 7–10 s (its dense products run faster per flop than the
/// factorization's many small supernodes).
const REFACTOR_RATIO: f64 = 1.5;

/// A factored matrix A₀ with some diagonal entries lowered: solves with A₀ − E D Eᵀ.
pub struct DiagonalDowndate<'a> {
    solver: &'a SpdSolver<f64>,
    symbolic: &'a SymbolicSupernodalCholesky<usize>,
    /// Y = L⁻¹ P E by supernode, ancestors after descendants.
    blocks: Vec<PathBlock<f64>>,
    /// The Cholesky factor (lower triangle) of K = D⁻¹ − Yᵀ Y.
    capacitance: Mat<f64>,
    /// How many diagonal entries were lowered.
    rank: usize,
}

impl SpdSolver<f64> {
    /// Solves with this matrix minus `decrease[j]` on the diagonal at `rows[j]`, reusing the
    /// factor (see the module documentation). An error when the factor is not supernodal (small
    /// matrices: refactoring them is cheap), when the rows are out of range or repeated, when a
    /// decrease is not positive and finite, when the lowered matrix is not positive definite, or
    /// when so many rows changed that refactoring is cheaper (see [`REFACTOR_RATIO`]).
    pub fn downdated(
        &self,
        rows: &[usize],
        decrease: &[f64],
    ) -> Result<DiagonalDowndate<'_>, SolverError> {
        let n = self.n();
        let build = |m: String| Err(SolverError::Build(m));
        if rows.len() != decrease.len() {
            return build(format!(
                "{} rows but {} decreases",
                rows.len(),
                decrease.len()
            ));
        }
        if let Some(d) = decrease.iter().find(|d| !(d.is_finite() && **d > 0.0)) {
            return build(format!(
                "a diagonal decrease must be positive and finite, not {d}"
            ));
        }
        let mut seen = vec![false; n];
        for &r in rows {
            if r >= n || std::mem::replace(&mut seen[r], true) {
                return build(format!("row {r} is out of range or repeated"));
            }
        }
        let symbolic = self.analysis.symbolic.as_ref();
        let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else {
            return build("the factor is simplicial; refactor instead".into());
        };
        if self.l_values.len() != sym.len_val() {
            return Err(SolverError::NotPositiveDefinite(
                "the last refactorization failed; there is no factor to downdate".into(),
            ));
        }
        let permuted: Vec<usize> = match symbolic.perm() {
            Some(p) => rows.iter().map(|&r| p.arrays().1[r]).collect(),
            None => rows.to_vec(),
        };
        let factor = SupernodalLltRef::new(sym, &self.l_values);
        let blocks = path_blocks(sym, factor, &permuted)?;

        // K = D⁻¹ − Σ over supernodes of (block)ᵀ(block), scattered to the active columns.
        let k = rows.len();
        let mut capacitance =
            Mat::<f64>::from_fn(k, k, |i, j| if i == j { 1.0 / decrease[i] } else { 0.0 });
        for b in &blocks {
            let m = b.active.len();
            let mut gram = Mat::<f64>::zeros(m, m);
            matmul(
                gram.as_mut(),
                Accum::Replace,
                b.values.transpose(),
                b.values.as_ref(),
                1.0,
                Par::Seq,
            );
            for (a, &ja) in b.active.iter().enumerate() {
                for (c, &jc) in b.active.iter().enumerate() {
                    capacitance[(ja, jc)] -= gram[(a, c)];
                }
            }
        }
        // Sequential, like everything here: faer's default would run this on the rayon workers
        // and leave their vector registers dirty (see `clear_upper_vector_state`).
        let req = cholesky_in_place_scratch::<f64>(k, Par::Seq, Default::default());
        let mut mem = MemBuffer::try_new(req).map_err(|_| SolverError::OutOfMemory)?;
        let factored = cholesky_in_place(
            capacitance.as_mut(),
            Default::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        );
        clear_upper_vector_state();
        factored.map_err(|_| {
            SolverError::NotPositiveDefinite(
                "the matrix with the lowered diagonal is not positive definite".into(),
            )
        })?;
        Ok(DiagonalDowndate {
            solver: self,
            symbolic: sym,
            blocks,
            capacitance,
            rank: k,
        })
    }
}

/// Y = L⁻¹ P E (E: the unit columns at the permuted rows `p`), by supernode along the paths
/// (`rows::path_columns`), declined when computing it and YᵀY would cost more than
/// [`REFACTOR_RATIO`] refactorizations.
fn path_blocks(
    sym: &SymbolicSupernodalCholesky<usize>,
    factor: SupernodalLltRef<'_, usize, f64>,
    p: &[usize],
) -> Result<Vec<PathBlock<f64>>, SolverError> {
    let (begin, end) = (sym.supernode_begin(), sym.supernode_end());
    let columns: Vec<Vec<(usize, f64)>> = p.iter().map(|&r| vec![(r, 1.0)]).collect();
    path_columns(sym, factor, &columns, |active| {
        // Floating-point work of Y (triangular solve and update per block) and of YᵀY against
        // that of refactoring: with thousands of columns the Gram products near the root come
        // close to the factorization itself.
        let (mut work, mut refactor) = (0.0f64, 0.0f64);
        for (s, active) in active.iter().enumerate() {
            let (size, below) = (
                (end[s] - begin[s]) as f64,
                sym.supernode(s).pattern().len() as f64,
            );
            refactor += size * size * size / 3.0 + size * size * below + size * below * below;
            let m = active.len() as f64;
            work += size * size * m + below * size * m + size * m * m;
        }
        if work > REFACTOR_RATIO * refactor {
            return Err(SolverError::Build(format!(
                "a refactorization is cheaper ({refactor:.2e} against {work:.2e} flops)"
            )));
        }
        Ok(())
    })
}

impl DiagonalDowndate<'_> {
    /// Solves (A₀ − E D Eᵀ) x = rhs.
    pub fn solve(&self, rhs: &[f64]) -> Result<Vec<f64>, SolverError> {
        let n = self.solver.n();
        if rhs.len() != n {
            return Err(SolverError::DimensionMismatch {
                expected: n,
                found: rhs.len(),
            });
        }
        let symbolic = self.solver.analysis.symbolic.as_ref();
        let perm = symbolic.perm();
        let mut z = match perm {
            Some(p) => Mat::<f64>::from_fn(n, 1, |i, _| rhs[p.arrays().0[i]]),
            None => Mat::<f64>::from_fn(n, 1, |i, _| rhs[i]),
        };
        let factor = SupernodalLltRef::new(self.symbolic, &self.solver.l_values);
        let req = self.symbolic.solve_in_place_scratch::<f64>(1, Par::Seq);
        let mut mem = MemBuffer::try_new(req).map_err(|_| SolverError::OutOfMemory)?;
        factor.l_solve_with_conj(Conj::No, z.as_mut(), Par::Seq, MemStack::new(&mut mem));
        // s = K⁻¹ Yᵀ z, then z += Y s.
        let mut s = Mat::<f64>::zeros(self.rank, 1);
        for b in &self.blocks {
            for (a, &j) in b.active.iter().enumerate() {
                let column = b.values.col(a);
                s[(j, 0)] += (0..b.values.nrows())
                    .map(|r| column[r] * z[(b.start + r, 0)])
                    .sum::<f64>();
            }
        }
        solve_in_place(
            self.capacitance.as_ref(),
            s.as_mut(),
            Par::Seq,
            MemStack::new(&mut []),
        );
        for b in &self.blocks {
            for (a, &j) in b.active.iter().enumerate() {
                let column = b.values.col(a);
                for r in 0..b.values.nrows() {
                    z[(b.start + r, 0)] += column[r] * s[(j, 0)];
                }
            }
        }
        factor.l_transpose_solve_with_conj(Conj::No, z.as_mut(), Par::Seq, MemStack::new(&mut mem));
        clear_upper_vector_state();
        let x: Vec<f64> = match perm {
            Some(p) => (0..n).map(|i| z[(p.arrays().1[i], 0)]).collect(),
            None => (0..n).map(|i| z[(i, 0)]).collect(),
        };
        if x.iter().all(|v| v.is_finite()) {
            Ok(x)
        } else {
            Err(SolverError::NonFinite)
        }
    }

    /// How many diagonal entries were lowered.
    pub fn rank(&self) -> usize {
        self.rank
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(side: usize, weight: impl Fn(usize) -> f64) -> super::super::SparseMatrix {
        super::super::grid_laplacian(side, weight)
    }

    /// Weights like the field's: large on a scattered tenth of the rows (τω up to 10⁴), zero
    /// elsewhere.
    fn weight(i: usize) -> f64 {
        if i % 10 == 3 {
            1e4 * (1.0 + (i as f64).sin().abs())
        } else {
            0.0
        }
    }

    #[test]
    fn downdated_solves_match_a_fresh_factorization() {
        let side = 200;
        let a0 = grid(side, weight);
        let solver = SpdSolver::new(&a0).unwrap();
        // Release a cluster of weighted rows and some scattered ones, as cancelled paths do.
        let rows: Vec<usize> = (0..side * side)
            .filter(|&i| weight(i) > 0.0 && ((i / side).abs_diff(60) < 4 || i % 997 == 3))
            .collect();
        assert!(rows.len() > 40, "{} rows", rows.len());
        let decrease: Vec<f64> = rows.iter().map(|&i| weight(i)).collect();
        let released = grid(side, |i| if rows.contains(&i) { 0.0 } else { weight(i) });
        let fresh = SpdSolver::new(&released).unwrap();
        let down = solver.downdated(&rows, &decrease).unwrap();
        assert_eq!(down.rank(), rows.len());
        for seed in 0..3 {
            let rhs: Vec<f64> = (0..side * side)
                .map(|i| ((i * 7 + seed * 13) as f64).sin() * (1.0 + weight(i)))
                .collect();
            let (x, y) = (down.solve(&rhs).unwrap(), fresh.solve(&rhs).unwrap());
            let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let err = x
                .iter()
                .zip(&y)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(err <= 1e-9 * scale, "max error {err:e} against {scale:e}");
            // The solution is of the released system, not of the original one.
            let z = solver.solve(&rhs).unwrap();
            let moved = z
                .iter()
                .zip(&y)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(
                moved > 1e3 * err.max(1e-12),
                "release changed nothing ({moved:e})"
            );
        }
    }

    #[test]
    fn lowering_too_far_or_bad_arguments_are_errors() {
        let side = 200;
        let solver = SpdSolver::new(&grid(side, weight)).unwrap();
        // Twice the weight on some weighted rows: their diagonal turns negative.
        let rows: Vec<usize> = (0..side * side)
            .filter(|&i| weight(i) > 0.0)
            .take(20)
            .collect();
        let twice: Vec<f64> = rows.iter().map(|&i| 2.0 * weight(i)).collect();
        assert!(matches!(
            solver.downdated(&rows, &twice).err(),
            Some(SolverError::NotPositiveDefinite(_))
        ));
        assert!(solver.downdated(&[3, 3], &[1.0, 1.0]).is_err());
        assert!(solver.downdated(&[side * side], &[1.0]).is_err());
        assert!(solver.downdated(&[3], &[0.0]).is_err());
        assert!(solver.downdated(&[3], &[f64::NAN]).is_err());
        assert!(solver.downdated(&[3, 13], &[1.0]).is_err());
        let down = solver.downdated(&[3], &[1.0]).unwrap();
        assert!(matches!(
            down.solve(&[1.0]).err(),
            Some(SolverError::DimensionMismatch { .. })
        ));
        // Releasing every weighted row costs more than refactoring: declined.
        let all: Vec<usize> = (0..side * side).filter(|&i| weight(i) > 0.0).collect();
        let half: Vec<f64> = all.iter().map(|&i| 0.5 * weight(i)).collect();
        let declined = solver.downdated(&all, &half).err();
        assert!(
            matches!(&declined, Some(SolverError::Build(m)) if m.contains("cheaper")),
            "{declined:?}"
        );
        // A small factor is simplicial: the caller refactors instead.
        let small = SpdSolver::new(&grid(4, |_| 1.0)).unwrap();
        assert!(small.downdated(&[0], &[0.5]).is_err());
    }
}
