//! The one sparse-solver wrapper: symmetric positive definite systems through faer's sparse
//! Cholesky, with the symbolic analysis kept so that re-solves with new values (same pattern)
//! or new right-hand sides skip it. Fields, parameterization and extraction all solve here.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};
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
    #[error("not enough memory for the factorization")]
    OutOfMemory,
}

/// Collects matrix entries; duplicates are summed.
#[derive(Clone, Debug, Default)]
pub struct SparseBuilder {
    n: usize,
    entries: Vec<(usize, usize, f64)>,
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
        self.entries.push((i, j, v));
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
    /// Compressed columns with sorted, unique rows. A counting sort by column (O(nnz)) and a
    /// small sort per column: faer's generic triplet conversion sorted all entries and took
    /// about a tenth of a whole `solve` run.
    pub fn build(&self) -> Result<SparseMatrix, SolverError> {
        let n = self.n;
        if let Some(&(i, j, _)) = self.entries.iter().find(|e| e.0 >= n || e.1 >= n) {
            return Err(SolverError::Build(format!(
                "entry ({i}, {j}) outside a {n} x {n} matrix"
            )));
        }
        let mut start = vec![0usize; n + 1];
        for e in &self.entries {
            start[e.1 + 1] += 1;
        }
        for j in 0..n {
            start[j + 1] += start[j];
        }
        let mut next = start.clone();
        let mut slots = vec![(0usize, 0.0f64); self.entries.len()];
        for &(i, j, v) in &self.entries {
            slots[next[j]] = (i, v);
            next[j] += 1;
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::with_capacity(slots.len());
        let mut values = Vec::with_capacity(slots.len());
        col_ptr.push(0);
        for j in 0..n {
            let col = &mut slots[start[j]..start[j + 1]];
            col.sort_unstable_by_key(|e| e.0);
            for &(i, v) in col.iter() {
                if row_idx.len() > col_ptr[j] && row_idx.last() == Some(&i) {
                    *values.last_mut().expect("a value per row") += v;
                } else {
                    row_idx.push(i);
                    values.push(v);
                }
            }
            col_ptr.push(row_idx.len());
        }
        Ok(SparseMatrix {
            n,
            col_ptr,
            row_idx,
            values,
        })
    }
}

/// Collects 2 × 2 blocks of a matrix whose unknowns come in pairs (2i, 2i + 1), such as the
/// (u, v) values of a parameterization or the (re, im) parts of a complex field; duplicates are
/// summed. Blocks are stored whole (zeros included), so the two columns of a pair share one
/// structure: that keeps assembly at a quarter of the entries, lets the factorization form wide
/// supernodes, and suits the block ordering of [`SpdSolver::new_blocked`].
#[derive(Clone, Debug, Default)]
pub struct BlockBuilder2 {
    blocks: usize,
    entries: Vec<(u32, u32, [f64; 4])>,
}

impl BlockBuilder2 {
    /// A builder for a matrix of `blocks` × `blocks` blocks (2·blocks unknowns).
    pub fn with_capacity(blocks: usize, nnz_blocks: usize) -> BlockBuilder2 {
        BlockBuilder2 {
            blocks,
            entries: Vec::with_capacity(nnz_blocks),
        }
    }
    /// Adds the block `m` (row-major [m00, m01, m10, m11]) at block (i, j).
    pub fn add(&mut self, i: usize, j: usize, m: [f64; 4]) {
        debug_assert!(i < self.blocks && j < self.blocks);
        self.entries.push((i as u32, j as u32, m));
    }
    pub fn build(&self) -> Result<SparseMatrix, SolverError> {
        let nb = self.blocks;
        if let Some(&(i, j, _)) = self
            .entries
            .iter()
            .find(|e| e.0 as usize >= nb || e.1 as usize >= nb)
        {
            return Err(SolverError::Build(format!(
                "block ({i}, {j}) outside a {nb} x {nb} block matrix"
            )));
        }
        let mut start = vec![0usize; nb + 1];
        for e in &self.entries {
            start[e.1 as usize + 1] += 1;
        }
        for j in 0..nb {
            start[j + 1] += start[j];
        }
        let mut next = start.clone();
        let mut slots = vec![(0u32, [0.0f64; 4]); self.entries.len()];
        for &(i, j, m) in &self.entries {
            slots[next[j as usize]] = (i, m);
            next[j as usize] += 1;
        }
        // Per block column: sort and merge, then write its two scalar columns.
        let mut col_ptr = Vec::with_capacity(2 * nb + 1);
        let mut row_idx = Vec::with_capacity(4 * slots.len());
        let mut values = Vec::with_capacity(4 * slots.len());
        col_ptr.push(0);
        let mut merged: Vec<(u32, [f64; 4])> = Vec::new();
        for j in 0..nb {
            let col = &mut slots[start[j]..start[j + 1]];
            col.sort_unstable_by_key(|e| e.0);
            merged.clear();
            for &(i, m) in col.iter() {
                match merged.last_mut() {
                    Some((r, acc)) if *r == i => {
                        for k in 0..4 {
                            acc[k] += m[k];
                        }
                    }
                    _ => merged.push((i, m)),
                }
            }
            for c in 0..2 {
                for &(i, m) in &merged {
                    row_idx.push(2 * i as usize);
                    values.push(m[c]);
                    row_idx.push(2 * i as usize + 1);
                    values.push(m[2 + c]);
                }
                col_ptr.push(row_idx.len());
            }
        }
        Ok(SparseMatrix {
            n: 2 * nb,
            col_ptr,
            row_idx,
            values,
        })
    }
}

/// A square sparse matrix in compressed columns (sorted, unique row indices).
#[derive(Clone, Debug)]
pub struct SparseMatrix {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
}

impl SparseMatrix {
    pub fn n(&self) -> usize {
        self.n
    }
    pub fn nnz(&self) -> usize {
        self.values.len()
    }
    fn pattern(&self) -> SymbolicSparseColMatRef<'_, usize> {
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }
    fn as_faer(&self) -> SparseColMatRef<'_, usize, f64> {
        SparseColMatRef::new(self.pattern(), &self.values)
    }
    /// y = A x.
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        let mut y = vec![0.0; self.n];
        for (j, &xj) in x.iter().enumerate().take(self.n) {
            for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                y[self.row_idx[k]] += self.values[k] * xj;
            }
        }
        y
    }
    /// Entries as (row, col, value), column by column.
    pub fn entries(&self) -> Vec<(usize, usize, f64)> {
        (0..self.n)
            .flat_map(|j| {
                (self.col_ptr[j]..self.col_ptr[j + 1])
                    .map(move |k| (self.row_idx[k], j, self.values[k]))
            })
            .collect()
    }
}

/// faer parallelises supernodal factorizations with rayon by default. On the 2-core machines we
/// target that is slower: a 90 000-unknown grid Laplacian factors in 120 ms sequentially and in
/// 220 ms with rayon (`cargo test --release --lib factor_timing -- --ignored --nocapture`).
/// Our own rayon work (per-face loops) is unaffected.
const PAR: Par = Par::Seq;

/// A factored symmetric positive definite matrix (LLᵀ); keeps its symbolic analysis (ordering
/// and elimination structure) so that refactoring with new values of the same pattern only
/// redoes the numeric part.
#[derive(Clone, Debug)]
pub struct SpdSolver {
    symbolic: Arc<SymbolicCholesky<usize>>,
    l_values: Vec<f64>,
    n: usize,
}

impl SpdSolver {
    /// Symbolic analysis (AMD fill-reducing ordering) and numeric factorization.
    pub fn new(matrix: &SparseMatrix) -> Result<SpdSolver, SolverError> {
        Self::with_ordering(matrix, None)
    }

    /// The same for a matrix made of `block` × `block` blocks (unknowns `block·i + c`, e.g. the
    /// (u, v) pairs of a parameterization): the ordering is computed on the graph of blocks and
    /// expanded, which keeps each block together and makes AMD, the costliest part of the
    /// analysis, about `block²` times cheaper.
    pub fn new_blocked(matrix: &SparseMatrix, block: usize) -> Result<SpdSolver, SolverError> {
        if block <= 1 || !matrix.n.is_multiple_of(block) {
            return Self::new(matrix);
        }
        let perm = block_ordering(matrix, block)?;
        Self::with_ordering(matrix, Some(perm))
    }

    fn with_ordering(
        matrix: &SparseMatrix,
        perm: Option<(Vec<usize>, Vec<usize>)>,
    ) -> Result<SpdSolver, SolverError> {
        let ordering = match &perm {
            Some((fwd, inv)) => SymmetricOrdering::Custom(PermRef::new_checked(fwd, inv, matrix.n)),
            None => SymmetricOrdering::Amd,
        };
        let symbolic = factorize_symbolic_cholesky(
            matrix.pattern(),
            Side::Lower,
            ordering,
            Default::default(),
        )
        .map_err(|e| SolverError::Build(format!("{e:?}")))?;
        let l_values = Self::numeric(&symbolic, matrix)?;
        Ok(SpdSolver {
            symbolic: Arc::new(symbolic),
            l_values,
            n: matrix.n,
        })
    }

    fn numeric(
        symbolic: &SymbolicCholesky<usize>,
        matrix: &SparseMatrix,
    ) -> Result<Vec<f64>, SolverError> {
        let mut l_values = vec![0.0; symbolic.len_val()];
        let req = symbolic.factorize_numeric_llt_scratch::<f64>(PAR, Default::default());
        let mut mem = MemBuffer::try_new(req).map_err(|_| SolverError::OutOfMemory)?;
        symbolic
            .factorize_numeric_llt::<f64>(
                &mut l_values,
                matrix.as_faer(),
                Side::Lower,
                Default::default(),
                PAR,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| SolverError::NotPositiveDefinite(format!("{e:?}")))?;
        Ok(l_values)
    }

    /// New values with the same sparsity pattern: only the numeric factorization is redone.
    pub fn refactor(&mut self, matrix: &SparseMatrix) -> Result<(), SolverError> {
        if matrix.n() != self.n {
            return Err(SolverError::DimensionMismatch {
                expected: self.n,
                found: matrix.n(),
            });
        }
        self.l_values = Self::numeric(&self.symbolic, matrix)?;
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
        let req = self.symbolic.solve_in_place_scratch::<f64>(rhs.len(), PAR);
        let mut mem = MemBuffer::try_new(req).map_err(|_| SolverError::OutOfMemory)?;
        LltRef::<usize, f64>::new(&self.symbolic, &self.l_values).solve_in_place_with_conj(
            Conj::No,
            b.as_mut(),
            PAR,
            MemStack::new(&mut mem),
        );
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

/// AMD on the graph whose nodes are the `block`-sized groups of unknowns, expanded to the
/// unknowns: (forward, inverse) with forward[k] = the unknown eliminated k-th.
fn block_ordering(
    matrix: &SparseMatrix,
    block: usize,
) -> Result<(Vec<usize>, Vec<usize>), SolverError> {
    let nq = matrix.n / block;
    let mut col_ptr = Vec::with_capacity(nq + 1);
    let mut rows = Vec::with_capacity(matrix.nnz() / (block * block) + nq);
    let mut mark = vec![usize::MAX; nq];
    col_ptr.push(0);
    for q in 0..nq {
        let begin = rows.len();
        for j in q * block..(q + 1) * block {
            for k in matrix.col_ptr[j]..matrix.col_ptr[j + 1] {
                let r = matrix.row_idx[k] / block;
                if mark[r] != q {
                    mark[r] = q;
                    rows.push(r);
                }
            }
        }
        rows[begin..].sort_unstable();
        col_ptr.push(rows.len());
    }
    let pattern = SymbolicSparseColMatRef::new_checked(nq, nq, &col_ptr, None, &rows);
    let (mut fwd, mut inv) = (vec![0usize; nq], vec![0usize; nq]);
    let req = amd::order_maybe_unsorted_scratch::<usize>(nq, rows.len());
    let mut mem = MemBuffer::try_new(req).map_err(|_| SolverError::OutOfMemory)?;
    amd::order_maybe_unsorted(
        &mut fwd,
        &mut inv,
        pattern,
        Default::default(),
        MemStack::new(&mut mem),
    )
    .map_err(|e| SolverError::Build(format!("{e:?}")))?;
    let forward: Vec<usize> = fwd
        .iter()
        .flat_map(|&q| (0..block).map(move |c| q * block + c))
        .collect();
    let mut inverse = vec![0usize; matrix.n];
    for (k, &v) in forward.iter().enumerate() {
        inverse[v] = k;
    }
    Ok((forward, inverse))
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
    fn blocked_ordering_solves_the_same_system() {
        // 2 × 2 blocks coupling neighbours by a rotation, plus a definite diagonal.
        let n = 40;
        let mut b = SparseBuilder::new(2 * n);
        for i in 0..n {
            b.add(2 * i, 2 * i, 3.0);
            b.add(2 * i + 1, 2 * i + 1, 3.0);
            let j = (i + 7) % n;
            b.add_sym(2 * i, 2 * j + 1, 0.5);
            b.add_sym(2 * i + 1, 2 * j, -0.5);
        }
        let a = b.build().unwrap();
        let rhs: Vec<f64> = (0..2 * n).map(|i| (i as f64 * 0.37).cos()).collect();
        let x = SpdSolver::new_blocked(&a, 2).unwrap().solve(&rhs).unwrap();
        let r = a.mul_vec(&x);
        assert!(r.iter().zip(&rhs).all(|(a, b)| (a - b).abs() < 1e-12));
    }

    #[test]
    fn block_builder_matches_scalar_assembly() {
        let blocks = [
            (0, 0, [2.0, 0.0, 0.0, 2.0]),
            (1, 0, [0.0, -1.0, 1.0, 0.0]),
            (0, 1, [0.0, 1.0, -1.0, 0.0]),
            (1, 1, [3.0, 0.5, 0.5, 3.0]),
            (1, 1, [1.0, 0.0, 0.0, 1.0]),
        ];
        let mut bb = BlockBuilder2::with_capacity(2, blocks.len());
        let mut sb = SparseBuilder::new(4);
        for &(i, j, m) in &blocks {
            bb.add(i, j, m);
            for r in 0..2 {
                for c in 0..2 {
                    sb.add(2 * i + r, 2 * j + c, m[2 * r + c]);
                }
            }
        }
        assert_eq!(bb.build().unwrap().entries(), sb.build().unwrap().entries());
    }

    #[test]
    fn duplicates_are_summed_and_bad_indices_rejected() {
        let mut b = SparseBuilder::new(2);
        b.add(1, 0, 1.0);
        b.add(0, 0, 2.0);
        b.add(1, 0, 3.0);
        b.add(1, 1, 5.0);
        assert_eq!(
            b.build().unwrap().entries(),
            vec![(0, 0, 2.0), (1, 0, 4.0), (1, 1, 5.0)]
        );
        b.add(2, 0, 1.0);
        assert!(matches!(b.build(), Err(SolverError::Build(_))));
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

#[cfg(test)]
mod timing {
    use super::*;

    /// Not a test: prints factorization times of a 2-D grid Laplacian with 2 × 2 rotation
    /// blocks (run with --ignored --nocapture).
    #[test]
    #[ignore]
    fn factor_timing() {
        let n = 300; // 90 000 blocks, 180 000 unknowns
        let id = |i: usize, j: usize| i * n + j;
        let mut b = SparseBuilder::new(2 * n * n);
        let couple = |p: usize, q: usize, b: &mut SparseBuilder| {
            for k in 0..2 {
                b.add(2 * p + k, 2 * p + k, 1.0);
                b.add(2 * q + k, 2 * q + k, 1.0);
            }
            // minus a rotation by 60° (a dense block, as for N = 6 or the complex relaxation)
            let (c, s) = (0.5, 0.75f64.sqrt());
            b.add_sym(2 * p, 2 * q, -c);
            b.add_sym(2 * p, 2 * q + 1, s);
            b.add_sym(2 * p + 1, 2 * q, -s);
            b.add_sym(2 * p + 1, 2 * q + 1, -c);
        };
        for i in 0..n {
            for j in 0..n {
                b.add(2 * id(i, j), 2 * id(i, j), 0.01);
                b.add(2 * id(i, j) + 1, 2 * id(i, j) + 1, 0.01);
                if i + 1 < n {
                    couple(id(i, j), id(i + 1, j), &mut b);
                }
                if j + 1 < n {
                    couple(id(i, j), id(i, j + 1), &mut b);
                }
            }
        }
        let t = std::time::Instant::now();
        let a = b.build().unwrap();
        println!("build {:?}", t.elapsed());
        let t = std::time::Instant::now();
        let s = SpdSolver::new(&a).unwrap();
        println!("plain AMD: symbolic + numeric {:?}", t.elapsed());
        let t = std::time::Instant::now();
        let sb = SpdSolver::new_blocked(&a, 2).unwrap();
        println!("block AMD: symbolic + numeric {:?}", t.elapsed());
        let t = std::time::Instant::now();
        let mut s2 = sb.clone();
        s2.refactor(&a).unwrap();
        println!("numeric only {:?}", t.elapsed());
        let rhs: Vec<f64> = (0..a.n()).map(|i| (i as f64).sin()).collect();
        let (x, y) = (s.solve(&rhs).unwrap(), sb.solve(&rhs).unwrap());
        let diff = x
            .iter()
            .zip(&y)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!("max difference between the two solutions {diff:e}");
    }
}
