//! The one sparse-solver wrapper: symmetric positive definite systems through faer's sparse
//! Cholesky, with the symbolic analysis kept so that re-solves with new values (same pattern)
//! or new right-hand sides skip it. Fields, parameterization and extraction all solve here.
//! [`Multigrid`] serves systems that need only an approximate solution (the field's relaxed
//! solve), where a factorization would cost more than it buys.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};

pub use faer::{c32, c64};
use thiserror::Error;

pub mod dissection;
pub mod downdate;
pub mod multigrid;
pub mod rows;
pub use dissection::nested_dissection;
pub use downdate::DiagonalDowndate;
pub use multigrid::{IterativeSolution, Multigrid};
pub use rows::RowUpdate;

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

/// Entry type of the systems: real (`f64`) or complex (`c64`, Hermitian systems).
///
/// Why complex: the parameterization systems (N = 4, 6) and the relaxed field solve couple
/// 2-D unknowns by scaled rotations, i.e. 2 × 2 blocks [[a, −b], [b, a]]. Those are complex
/// numbers a + ib acting on x + iy, so the real 2n × 2n symmetric system is an n × n Hermitian
/// one. Its Cholesky factor has half the entries and the factorization about half the floating
/// point work of the real block form (measured: 11.1 s → 5.4 s on 556 k vertices).
pub trait Scalar:
    faer::traits::ComplexField
    + Copy
    + Send
    + Sync
    + PartialEq
    + std::fmt::Debug
    + std::ops::AddAssign
    + std::ops::SubAssign
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Neg<Output = Self>
    + std::ops::Mul<Output = Self>
    + bytemuck::Zeroable
    + 'static
{
    const ZERO: Self;
    fn finite(self) -> bool;
    /// The complex conjugate (the value itself for reals).
    fn conjugate(self) -> Self;
    /// |x|².
    fn modulus_sq(self) -> f64;
    fn real_part(self) -> f64;
    fn from_real(x: f64) -> Self;
    /// x · s for a real s.
    fn scaled(self, s: f64) -> Self;
    /// The single-precision type of the same kind (`f32`, `c32`; itself for those), in which
    /// [`Multigrid`] keeps its hierarchy.
    type Single: Scalar;
    fn to_single(self) -> Self::Single;
    fn from_single(x: Self::Single) -> Self;
}

impl Scalar for f64 {
    const ZERO: f64 = 0.0;
    type Single = f32;
    fn to_single(self) -> f32 {
        self as f32
    }
    fn from_single(x: f32) -> f64 {
        x as f64
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn conjugate(self) -> f64 {
        self
    }
    fn modulus_sq(self) -> f64 {
        self * self
    }
    fn real_part(self) -> f64 {
        self
    }
    fn from_real(x: f64) -> f64 {
        x
    }
    fn scaled(self, s: f64) -> f64 {
        self * s
    }
}

impl Scalar for c64 {
    const ZERO: c64 = c64::new(0.0, 0.0);
    type Single = c32;
    fn to_single(self) -> c32 {
        c32::new(self.re as f32, self.im as f32)
    }
    fn from_single(x: c32) -> c64 {
        c64::new(x.re as f64, x.im as f64)
    }
    fn finite(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
    fn conjugate(self) -> c64 {
        c64::new(self.re, -self.im)
    }
    fn modulus_sq(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    fn real_part(self) -> f64 {
        self.re
    }
    fn from_real(x: f64) -> c64 {
        c64::new(x, 0.0)
    }
    fn scaled(self, s: f64) -> c64 {
        c64::new(self.re * s, self.im * s)
    }
}

impl Scalar for f32 {
    const ZERO: f32 = 0.0;
    type Single = f32;
    fn to_single(self) -> f32 {
        self
    }
    fn from_single(x: f32) -> f32 {
        x
    }
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn conjugate(self) -> f32 {
        self
    }
    fn modulus_sq(self) -> f64 {
        (self * self) as f64
    }
    fn real_part(self) -> f64 {
        self as f64
    }
    fn from_real(x: f64) -> f32 {
        x as f32
    }
    fn scaled(self, s: f64) -> f32 {
        self * s as f32
    }
}

impl Scalar for c32 {
    const ZERO: c32 = c32::new(0.0, 0.0);
    type Single = c32;
    fn to_single(self) -> c32 {
        self
    }
    fn from_single(x: c32) -> c32 {
        x
    }
    fn finite(self) -> bool {
        self.re.is_finite() && self.im.is_finite()
    }
    fn conjugate(self) -> c32 {
        c32::new(self.re, -self.im)
    }
    fn modulus_sq(self) -> f64 {
        (self.re * self.re + self.im * self.im) as f64
    }
    fn real_part(self) -> f64 {
        self.re as f64
    }
    fn from_real(x: f64) -> c32 {
        c32::new(x as f32, 0.0)
    }
    fn scaled(self, s: f64) -> c32 {
        let s = s as f32;
        c32::new(self.re * s, self.im * s)
    }
}

/// A builder on a known pattern ([`SparseBuilder::on_pattern`]).
#[derive(Clone, Debug)]
struct OnPattern<T> {
    pattern: Arc<(Vec<usize>, Vec<usize>)>,
    values: Vec<T>,
    /// The first entry outside the pattern.
    missing: Option<(usize, usize)>,
    /// The analysis's positions of a previous builder's additions, in order, and how many of
    /// them this one has used: systems assembled again add the same entries in the same order
    /// (QuadCover's, for any matchings), so the k-th addition lands where it did before, which
    /// is checked (two reads) instead of searched for.
    replay: Option<Arc<Vec<u32>>>,
    cursor: usize,
    /// This builder's positions, when the analysis has none yet; handed to it by `build`.
    record: Vec<u32>,
    positions: Arc<std::sync::OnceLock<Arc<Vec<u32>>>>,
}

/// Collects matrix entries; duplicates are summed.
#[derive(Clone, Debug)]
pub struct SparseBuilder<T: Scalar = f64> {
    n: usize,
    entries: Vec<(u32, u32, T)>,
    /// With a known pattern ([`Self::on_pattern`]): the values, summed in place in the order
    /// they are added, and the first entry that is not in the pattern.
    on_pattern: Option<OnPattern<T>>,
}

impl<T: Scalar> SparseBuilder<T> {
    pub fn new(n: usize) -> Self {
        Self::with_capacity(n, 0)
    }
    pub fn with_capacity(n: usize, nnz: usize) -> Self {
        SparseBuilder {
            n,
            entries: Vec::with_capacity(nnz),
            on_pattern: None,
        }
    }
    /// A builder for a matrix of the analysed pattern: entries are summed into place as they
    /// come (no triplets to sort: a few times faster for QuadCover's systems), in the order
    /// they are added, so equal inputs give bit-equal values. An entry outside the pattern
    /// makes [`Self::build`] fail.
    pub fn on_pattern(analysis: &Analysis) -> Self {
        let pattern = analysis.pattern.clone();
        let nnz = pattern.1.len();
        SparseBuilder {
            n: pattern.0.len() - 1,
            entries: Vec::new(),
            on_pattern: Some(OnPattern {
                pattern,
                values: vec![T::ZERO; nnz],
                missing: None,
                replay: analysis.positions.get().cloned(),
                cursor: 0,
                record: Vec::new(),
                positions: analysis.positions.clone(),
            }),
        }
    }
    /// Adds `v` at (i, j). For symmetric matrices add both (i, j) and (j, i); for Hermitian ones
    /// v at (i, j) and conj(v) at (j, i).
    pub fn add(&mut self, i: usize, j: usize, v: T) {
        debug_assert!(i < self.n && j < self.n);
        if let Some(p) = &mut self.on_pattern {
            let (col_ptr, row_idx) = (&p.pattern.0, &p.pattern.1);
            if let Some(replay) = &p.replay {
                let k = replay.get(p.cursor).map_or(usize::MAX, |&k| k as usize);
                p.cursor += 1;
                if j < self.n
                    && k < row_idx.len()
                    && row_idx[k] == i
                    && (col_ptr[j]..col_ptr[j + 1]).contains(&k)
                {
                    p.values[k] += v;
                    return;
                }
            }
            let found = (j < self.n)
                .then(|| {
                    let (a, b) = (col_ptr[j], col_ptr[j + 1]);
                    row_idx[a..b].binary_search(&i).ok().map(|k| a + k)
                })
                .flatten();
            if p.replay.is_none() {
                p.record.push(found.map_or(u32::MAX, |k| k as u32));
            }
            match found {
                Some(k) => p.values[k] += v,
                None => {
                    p.missing.get_or_insert((i, j));
                }
            }
            return;
        }
        // Out-of-range indices are kept (saturated) so that `build` reports them.
        let idx = |k: usize| u32::try_from(k).unwrap_or(u32::MAX);
        self.entries.push((idx(i), idx(j), v));
    }
    /// Adds `v` at (i, j) and at (j, i) (once on the diagonal).
    pub fn add_sym(&mut self, i: usize, j: usize, v: T) {
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
    pub fn build(&self) -> Result<SparseMatrix<T>, SolverError> {
        let n = self.n;
        if let Some(p) = &self.on_pattern {
            if let Some((i, j)) = p.missing {
                return Err(SolverError::Build(format!(
                    "entry ({i}, {j}) is not in the analysed pattern"
                )));
            }
            if p.replay.is_none() && p.record.iter().all(|&k| k != u32::MAX) {
                // The first assembly on this analysis: later ones replay its positions.
                let _ = p.positions.set(Arc::new(p.record.clone()));
            }
            return Ok(SparseMatrix {
                n,
                col_ptr: p.pattern.0.clone(),
                row_idx: p.pattern.1.clone(),
                values: p.values.clone(),
            });
        }
        if self.n >= u32::MAX as usize {
            return Err(SolverError::Build(format!("{n} unknowns is too many")));
        }
        if let Some(&(i, j, _)) = self
            .entries
            .iter()
            .find(|e| e.0 as usize >= n || e.1 as usize >= n)
        {
            return Err(SolverError::Build(format!(
                "entry ({i}, {j}) outside a {n} x {n} matrix"
            )));
        }
        let mut start = vec![0usize; n + 1];
        for e in &self.entries {
            start[e.1 as usize + 1] += 1;
        }
        for j in 0..n {
            start[j + 1] += start[j];
        }
        let mut next = start.clone();
        let mut slots = vec![(0u32, T::ZERO); self.entries.len()];
        for &(i, j, v) in &self.entries {
            slots[next[j as usize]] = (i, v);
            next[j as usize] += 1;
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::with_capacity(slots.len());
        let mut values = Vec::with_capacity(slots.len());
        col_ptr.push(0);
        for j in 0..n {
            let col = &mut slots[start[j]..start[j + 1]];
            col.sort_unstable_by_key(|e| e.0);
            for &(i, v) in col.iter() {
                let i = i as usize;
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

/// A square sparse matrix in compressed columns (sorted, unique row indices).
#[derive(Clone, Debug)]
pub struct SparseMatrix<T: Scalar = f64> {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<T>,
}

impl<T: Scalar> SparseMatrix<T> {
    pub fn n(&self) -> usize {
        self.n
    }
    pub fn nnz(&self) -> usize {
        self.values.len()
    }
    /// The stored values, column by column (see [`Self::position`]).
    pub fn values(&self) -> &[T] {
        &self.values
    }
    fn pattern(&self) -> SymbolicSparseColMatRef<'_, usize> {
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }
    fn as_faer(&self) -> SparseColMatRef<'_, usize, T> {
        SparseColMatRef::new(self.pattern(), &self.values)
    }
    /// y = A x.
    pub fn mul_vec(&self, x: &[T]) -> Vec<T> {
        let mut y = vec![T::ZERO; self.n];
        for (j, &xj) in x.iter().enumerate().take(self.n) {
            for k in self.col_ptr[j]..self.col_ptr[j + 1] {
                y[self.row_idx[k]] += self.values[k] * xj;
            }
        }
        y
    }
    /// The rows of column `j`'s stored entries, ascending.
    pub fn column_rows(&self, j: usize) -> &[usize] {
        &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]]
    }
    /// Entries as (row, col, value), column by column.
    pub fn entries(&self) -> Vec<(usize, usize, T)> {
        (0..self.n)
            .flat_map(|j| {
                (self.col_ptr[j]..self.col_ptr[j + 1])
                    .map(move |k| (self.row_idx[k], j, self.values[k]))
            })
            .collect()
    }
    /// Position of entry (i, j) in the value array, if it is stored.
    pub fn position(&self, i: usize, j: usize) -> Option<usize> {
        if j >= self.n {
            return None;
        }
        let (a, b) = (self.col_ptr[j], self.col_ptr[j + 1]);
        self.row_idx[a..b].binary_search(&i).ok().map(|k| a + k)
    }
    /// The same pattern with other values (`values[k]` for the k-th stored entry, as
    /// [`Self::position`] numbers them): systems re-assembled often write values in place.
    pub fn with_values<U: Scalar>(&self, values: Vec<U>) -> Result<SparseMatrix<U>, SolverError> {
        if values.len() != self.values.len() {
            return Err(SolverError::DimensionMismatch {
                expected: self.values.len(),
                found: values.len(),
            });
        }
        Ok(SparseMatrix {
            n: self.n,
            col_ptr: self.col_ptr.clone(),
            row_idx: self.row_idx.clone(),
            values,
        })
    }
    /// A matrix from compressed columns built elsewhere (e.g. straight from a mesh's adjacency,
    /// without sorting triplets): `row_idx[col_ptr[j]..col_ptr[j + 1]]` are column j's rows,
    /// strictly increasing and below n. Checked, O(nnz).
    pub fn from_columns(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        values: Vec<T>,
    ) -> Result<SparseMatrix<T>, SolverError> {
        let bad = |what: String| Err(SolverError::Build(format!("compressed columns: {what}")));
        if col_ptr.len() != n + 1 || col_ptr[0] != 0 || col_ptr[n] != row_idx.len() {
            return bad(format!("{} column pointers for n = {n}", col_ptr.len()));
        }
        if values.len() != row_idx.len() {
            return bad(format!(
                "{} values for {} rows",
                values.len(),
                row_idx.len()
            ));
        }
        for j in 0..n {
            if col_ptr[j] > col_ptr[j + 1] {
                return bad(format!("column {j} ends before it starts"));
            }
            let rows = &row_idx[col_ptr[j]..col_ptr[j + 1]];
            if rows.windows(2).any(|w| w[0] >= w[1]) || rows.last().is_some_and(|&i| i >= n) {
                return bad(format!(
                    "column {j}'s rows are not increasing and below {n}"
                ));
            }
        }
        Ok(SparseMatrix {
            n,
            col_ptr,
            row_idx,
            values,
        })
    }
    fn same_pattern(&self, analysis: &Analysis) -> bool {
        analysis.pattern.0 == self.col_ptr && analysis.pattern.1 == self.row_idx
    }
}

/// faer parallelises supernodal factorizations with rayon by default. On the 2-core machines we
/// target that is slower for all but the largest systems: a 90 000-unknown grid Laplacian
/// factors in 120 ms sequentially and in 220 ms with rayon (`cargo test --release --lib
/// factor_timing -- --ignored --nocapture`). Independent factorizations run side by side instead
/// (`rayon::join` in the callers), and solves stay sequential.
const PAR: Par = Par::Seq;

/// Factors with more entries than this (the million-triangle systems, 30–75 M entries) use
/// rayon after all: when they run beside a smaller one, the core that one leaves idle joins in.
/// Measured on bunny ×16 (1.1 M triangles, three runs each): the QuadCover pipeline took
/// 15.1–16.3 s against 15.7–18.7 s sequentially.
const PARALLEL_FACTOR_MIN: usize = 20_000_000;

/// Where a numeric factorization may run.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Threads {
    /// On the rayon pool when the factor is large ([`PARALLEL_FACTOR_MIN`]).
    Pool,
    /// On the calling thread only.
    Calling,
}

/// A zero-filled buffer for a factor: zeroed pages come straight from the kernel, without the
/// memset pass `vec![zero; n]` makes for complex entries (0.4–1.2 GB at a million triangles).
/// (Asking for transparent huge pages as well was measured slower here: 4.3 s against 2.9 s for
/// the field's relaxed solve, the kernel zeroing 2 MiB pages at fault time.)
fn zeroed_buffer<T: Scalar>(n: usize) -> Vec<T> {
    bytemuck::zeroed_vec(n)
}

/// The symbolic analysis of a sparsity pattern (AMD fill-reducing ordering and elimination
/// structure). It does not depend on the values nor on their type: one analysis serves a real
/// and a complex matrix of the same pattern, and every refactorization.
#[derive(Clone, Debug)]
pub struct Analysis {
    symbolic: Arc<SymbolicCholesky<usize>>,
    pattern: Arc<(Vec<usize>, Vec<usize>)>,
    /// Where the first builder on this pattern put its additions, in order (see
    /// [`SparseBuilder::on_pattern`]).
    positions: Arc<std::sync::OnceLock<Arc<Vec<u32>>>>,
}

impl Analysis {
    pub fn new<T: Scalar>(matrix: &SparseMatrix<T>) -> Result<Analysis, SolverError> {
        Self::with_ordering(matrix, SymmetricOrdering::Amd)
    }

    fn with_ordering<T: Scalar>(
        matrix: &SparseMatrix<T>,
        ordering: SymmetricOrdering<'_, usize>,
    ) -> Result<Analysis, SolverError> {
        let symbolic = factorize_symbolic_cholesky(
            matrix.pattern(),
            Side::Lower,
            ordering,
            Default::default(),
        )
        .map_err(|e| SolverError::Build(format!("{e:?}")))?;
        Ok(Analysis {
            symbolic: Arc::new(symbolic),
            pattern: Arc::new((matrix.col_ptr.clone(), matrix.row_idx.clone())),
            positions: Default::default(),
        })
    }
    /// The analysis with the elimination order `order` (position → unknown) instead of AMD.
    pub fn with_order<T: Scalar>(
        matrix: &SparseMatrix<T>,
        order: &[usize],
    ) -> Result<Analysis, SolverError> {
        let n = matrix.n();
        let mut inverse = vec![usize::MAX; n];
        for (position, &i) in order.iter().enumerate() {
            if i >= n || inverse[i] != usize::MAX {
                return Err(SolverError::Build(format!(
                    "the elimination order is not a permutation of 0..{n} (at position {position})"
                )));
            }
            inverse[i] = position;
        }
        if order.len() != n {
            return Err(SolverError::DimensionMismatch {
                expected: n,
                found: order.len(),
            });
        }
        let perm = faer::perm::PermRef::new_checked(order, &inverse, n);
        Self::with_ordering(matrix, SymmetricOrdering::Custom(perm))
    }

    /// The analysis of a system whose unknown `i` sits at `points[i]` (the pattern holding both
    /// triangles): AMD below [`DISSECTION_MIN`] unknowns, [`nested_dissection`] of the points
    /// from there on (see its measurements: at a million faces ordering and analysis take 0.9 s
    /// instead of 1.5 s, for the same fill; at four million, 15 % less fill and a factorization
    /// four times faster).
    pub fn geometric<T: Scalar>(
        matrix: &SparseMatrix<T>,
        points: &[glam::DVec3],
    ) -> Result<Analysis, SolverError> {
        // Non-finite points (a mesh validated elsewhere has none) fall back to AMD as well.
        if matrix.n() < DISSECTION_MIN || !points.iter().all(|p| p.is_finite()) {
            Analysis::new(matrix)
        } else {
            Analysis::with_order(matrix, &nested_dissection(matrix, points)?)
        }
    }

    pub fn n(&self) -> usize {
        self.pattern.0.len() - 1
    }

    /// The elimination order (position → unknown), `None` for the identity: what
    /// [`Analysis::with_order`] takes, e.g. to order a system with a block per unknown of this
    /// one without computing an ordering again.
    pub fn order(&self) -> Option<Vec<usize>> {
        self.symbolic.perm().map(|p| p.arrays().0.to_vec())
    }

    /// Entries of the Cholesky factor (its memory, and a measure of the ordering's quality).
    pub fn factor_entries(&self) -> usize {
        self.symbolic.len_val()
    }
}

/// Unknowns from which [`Analysis::geometric`] orders by nested dissection.
pub const DISSECTION_MIN: usize = 200_000;

/// A factored symmetric (Hermitian for `c64`) positive definite matrix, LLᴴ; keeps its
/// [`Analysis`] so that refactoring with new values of the same pattern only redoes the numeric
/// part.
#[derive(Clone, Debug)]
pub struct SpdSolver<T: Scalar = f64> {
    analysis: Analysis,
    l_values: Vec<T>,
}

impl<T: Scalar> SpdSolver<T> {
    /// Symbolic analysis and numeric factorization.
    pub fn new(matrix: &SparseMatrix<T>) -> Result<Self, SolverError> {
        Self::with_analysis(Analysis::new(matrix)?, matrix)
    }

    /// Numeric factorization with an existing analysis of the same pattern.
    pub fn with_analysis(
        analysis: Analysis,
        matrix: &SparseMatrix<T>,
    ) -> Result<Self, SolverError> {
        let l_values = Self::numeric_into(&analysis, matrix, Vec::new(), Threads::Pool)?;
        Ok(SpdSolver { analysis, l_values })
    }

    /// [`SpdSolver::with_analysis`] on the calling thread only, for a factorization that runs
    /// beside other parallel work: faer's parallel kernels would share the rayon pool with that
    /// work (interleaving their tasks with its, and leaving the workers' vector registers dirty,
    /// see [`clear_upper_vector_state`]); at a million faces the field's factorization gains
    /// little from a second core anyway (1.5–1.6 s either way).
    pub fn with_analysis_sequential(
        analysis: Analysis,
        matrix: &SparseMatrix<T>,
    ) -> Result<Self, SolverError> {
        let l_values = Self::numeric_into(&analysis, matrix, Vec::new(), Threads::Calling)?;
        Ok(SpdSolver { analysis, l_values })
    }

    pub fn analysis(&self) -> &Analysis {
        &self.analysis
    }

    /// The numeric factorization into `buffer` (reused when it has the right length: its pages
    /// are already mapped, which saves a tenth of a second per 400 MB at a million triangles).
    fn numeric_into(
        analysis: &Analysis,
        matrix: &SparseMatrix<T>,
        buffer: Vec<T>,
        threads: Threads,
    ) -> Result<Vec<T>, SolverError> {
        if !matrix.same_pattern(analysis) {
            return Err(SolverError::Build(
                "the matrix's sparsity pattern differs from the analysed one".into(),
            ));
        }
        let symbolic = &analysis.symbolic;
        let mut l_values = if buffer.len() == symbolic.len_val() {
            let mut b = buffer;
            b.fill(T::ZERO);
            b
        } else {
            zeroed_buffer::<T>(symbolic.len_val())
        };
        let parallel = threads == Threads::Pool && symbolic.len_val() > PARALLEL_FACTOR_MIN;
        let par = if parallel { Par::rayon(0) } else { PAR };
        let req = symbolic.factorize_numeric_llt_scratch::<T>(par, Default::default());
        let mut mem = MemBuffer::try_new(req).map_err(|_| SolverError::OutOfMemory)?;
        let result = symbolic
            .factorize_numeric_llt::<T>(
                &mut l_values,
                matrix.as_faer(),
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| SolverError::NotPositiveDefinite(format!("{e:?}")));
        clear_upper_vector_state();
        if parallel {
            // The rayon workers ran faer's kernels: each clears its own registers when it picks
            // this up (not a blocking broadcast, which would wait for a worker busy with the
            // other side of a join).
            rayon::spawn_broadcast(|_| clear_upper_vector_state());
        }
        result?;
        Ok(l_values)
    }

    /// New values with the same sparsity pattern: only the numeric factorization is redone.
    pub fn refactor(&mut self, matrix: &SparseMatrix<T>) -> Result<(), SolverError> {
        if matrix.n() != self.n() {
            return Err(SolverError::DimensionMismatch {
                expected: self.n(),
                found: matrix.n(),
            });
        }
        // On failure the solver has no factor, and solves report that.
        let buffer = std::mem::take(&mut self.l_values);
        self.l_values = Self::numeric_into(&self.analysis, matrix, buffer, Threads::Pool)?;
        Ok(())
    }

    pub fn n(&self) -> usize {
        self.analysis.n()
    }

    /// Solves A x = rhs.
    pub fn solve(&self, rhs: &[T]) -> Result<Vec<T>, SolverError> {
        Ok(self.solve_many(&[rhs])?.remove(0))
    }

    /// Solves A X = B for several right-hand sides at once.
    pub fn solve_many(&self, rhs: &[&[T]]) -> Result<Vec<Vec<T>>, SolverError> {
        let n = self.n();
        if let Some(bad) = rhs.iter().find(|r| r.len() != n) {
            return Err(SolverError::DimensionMismatch {
                expected: n,
                found: bad.len(),
            });
        }
        let symbolic = &self.analysis.symbolic;
        if self.l_values.len() != symbolic.len_val() {
            return Err(SolverError::NotPositiveDefinite(
                "the last refactorization failed; there is no factor to solve with".into(),
            ));
        }
        let mut b = faer::Mat::<T>::from_fn(n, rhs.len(), |i, j| rhs[j][i]);
        let req = symbolic.solve_in_place_scratch::<T>(rhs.len(), PAR);
        let mut mem = MemBuffer::try_new(req).map_err(|_| SolverError::OutOfMemory)?;
        LltRef::<usize, T>::new(symbolic, &self.l_values).solve_in_place_with_conj(
            Conj::No,
            b.as_mut(),
            PAR,
            MemStack::new(&mut mem),
        );
        clear_upper_vector_state();
        let out: Vec<Vec<T>> = (0..rhs.len())
            .map(|j| (0..n).map(|i| b[(i, j)]).collect())
            .collect();
        if out.iter().flatten().all(|x| x.finite()) {
            Ok(out)
        } else {
            Err(SolverError::NonFinite)
        }
    }
}

/// Clears the upper halves of the vector registers (`vzeroupper`) of the calling thread. faer's
/// dense kernels (AVX-512 on the machines we measure on) can return with them dirty, and then
/// every legacy-SSE instruction on that thread — all of our baseline-x86-64 f64 code and libm —
/// pays a state-transition penalty: after a million-face factorization, glibc's atan2 ran
/// 15–20× slower on the rayon workers and the per-vertex angle defects 5× slower, until this
/// was done. (The same penalty is why BLIS and oneDNN end their kernels with vzeroupper.)
fn clear_upper_vector_state() {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: vzeroupper needs only AVX, which the CPU was just found to support. It zeroes
        // bits 128 and up of the vector registers, which this crate's code (compiled for
        // baseline x86-64, SSE2 only) never keeps values in.
        unsafe { std::arch::x86_64::_mm256_zeroupper() }
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

/// The 5-point Laplacian of a side × side grid plus `weight(i)` on the diagonal, for tests.
#[cfg(test)]
pub(crate) fn grid_laplacian(side: usize, weight: impl Fn(usize) -> f64) -> SparseMatrix {
    let n = side * side;
    let mut b = SparseBuilder::new(n);
    for i in 0..n {
        b.add(i, i, weight(i));
        let (x, y) = (i % side, i / side);
        for (nx, ny) in [(x + 1, y), (x, y + 1)] {
            if nx < side && ny < side {
                let j = ny * side + nx;
                b.add_sym(i, j, -1.0);
                b.add(i, i, 1.0);
                b.add(j, j, 1.0);
            }
        }
    }
    b.build().unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builders_on_a_pattern_replay_its_positions_and_check_them() {
        let m = grid_laplacian(12, |i| i as f64);
        let analysis = Analysis::new(&m).unwrap();
        let entries = m.entries();
        let assemble = |order: &[(usize, usize, f64)]| {
            let mut b = SparseBuilder::<f64>::on_pattern(&analysis);
            for &(i, j, v) in order {
                b.add(i, j, v);
            }
            b.build().unwrap()
        };
        let first = assemble(&entries);
        assert!(
            analysis.positions.get().is_some(),
            "the first assembly records"
        );
        assert_eq!(first.values(), m.values());
        // The same additions again (replayed), and in another order (each replayed position
        // is checked, the wrong ones searched for): the same matrix.
        assert_eq!(assemble(&entries).values(), m.values());
        let reversed: Vec<_> = entries.iter().rev().copied().collect();
        assert_eq!(assemble(&reversed).values(), m.values());
        // Outside the pattern: an error, not a silent write.
        let mut b = SparseBuilder::<f64>::on_pattern(&analysis);
        b.add(0, 143, 1.0);
        assert!(b.build().is_err());
    }

    #[test]
    fn compressed_columns_are_checked() {
        let ok = SparseMatrix::from_columns(2, vec![0, 2, 3], vec![0, 1, 1], vec![2.0, -1.0, 2.0]);
        assert_eq!(ok.unwrap().nnz(), 3);
        for (ptr, rows) in [
            (vec![0, 2, 3], vec![1, 0, 1]), // rows not increasing
            (vec![0, 2, 3], vec![0, 2, 1]), // row out of range
            (vec![0, 2], vec![0, 1]),       // too few column pointers
            (vec![0, 2, 2], vec![0, 1, 1]), // pointers do not cover the rows
        ] {
            let n = rows.len();
            assert!(SparseMatrix::from_columns(2, ptr, rows, vec![1.0; n]).is_err());
        }
        assert!(SparseMatrix::from_columns(2, vec![0, 1, 2], vec![0, 1], vec![1.0]).is_err());
    }

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

    /// A Hermitian system equals the real symmetric 2 × 2-block system with blocks
    /// [[a, −b], [b, a]] for the entries a + ib, and one analysis serves both.
    #[test]
    fn hermitian_system_matches_its_real_block_form() {
        let n = 40;
        let mut hb = SparseBuilder::<c64>::new(n);
        let mut rb = SparseBuilder::<f64>::new(2 * n);
        let mut add = |i: usize, j: usize, z: c64| {
            hb.add(i, j, z);
            for (r, c, v) in [(0, 0, z.re), (0, 1, -z.im), (1, 0, z.im), (1, 1, z.re)] {
                rb.add(2 * i + r, 2 * j + c, v);
            }
        };
        for i in 0..n {
            add(i, i, c64::new(3.0, 0.0));
            let j = (i + 7) % n;
            let z = c64::new(-0.6, 0.8);
            add(i, j, z);
            add(j, i, z.conj());
        }
        let (h, r) = (hb.build().unwrap(), rb.build().unwrap());
        let rhs: Vec<c64> = (0..n)
            .map(|i| c64::new((i as f64 * 0.37).cos(), (i as f64).sin()))
            .collect();
        let z = SpdSolver::new(&h).unwrap().solve(&rhs).unwrap();
        let res = h.mul_vec(&z);
        assert!(res.iter().zip(&rhs).all(|(a, b)| (a - b).norm() < 1e-12));
        let rrhs: Vec<f64> = rhs.iter().flat_map(|z| [z.re, z.im]).collect();
        let x = SpdSolver::new(&r).unwrap().solve(&rrhs).unwrap();
        for i in 0..n {
            assert!((x[2 * i] - z[i].re).abs() < 1e-12 && (x[2 * i + 1] - z[i].im).abs() < 1e-12);
        }
        // The same pattern with real values reuses the complex matrix's analysis.
        let mut sb = SparseBuilder::<f64>::new(n);
        for (i, j, z) in h.entries() {
            sb.add(i, j, if i == j { z.re } else { 0.5 * z.re });
        }
        let real = sb.build().unwrap();
        let analysis = SpdSolver::new(&h).unwrap().analysis().clone();
        let s = SpdSolver::with_analysis(analysis.clone(), &real).unwrap();
        let y = s.solve(&vec![1.0; n]).unwrap();
        assert!(real.mul_vec(&y).iter().all(|v| (v - 1.0).abs() < 1e-12));
        // A different pattern is refused.
        let mut other = SparseBuilder::<f64>::new(n);
        for i in 0..n {
            other.add(i, i, 1.0);
        }
        assert!(matches!(
            SpdSolver::with_analysis(analysis, &other.build().unwrap()),
            Err(SolverError::Build(_))
        ));
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
    fn failed_refactor_leaves_an_error_not_a_panic() {
        let build = |d: f64| {
            let mut b = SparseBuilder::new(2);
            b.add(0, 0, 1.0);
            b.add(1, 1, d);
            b.build().unwrap()
        };
        let mut s = SpdSolver::new(&build(1.0)).unwrap();
        assert!(s.refactor(&build(-1.0)).is_err());
        assert!(s.solve(&[1.0, 1.0]).is_err());
        s.refactor(&build(2.0)).unwrap();
        let x = s.solve(&[1.0, 1.0]).unwrap();
        assert!(
            (x[0] - 1.0).abs() < 1e-15 && (x[1] - 0.5).abs() < 1e-15,
            "{x:?}"
        );
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

    /// Not a test: prints factorization times of a 2-D grid Laplacian coupled by rotations, in
    /// real 2 × 2-block form and in Hermitian form (run with --ignored --nocapture).
    #[test]
    #[ignore]
    fn factor_timing() {
        let n = 300; // 90 000 nodes
        let id = |i: usize, j: usize| i * n + j;
        let mut b = SparseBuilder::new(2 * n * n);
        let mut h = SparseBuilder::<c64>::new(n * n);
        // minus a rotation by 60° (a dense block, as for N = 6 or the complex relaxation)
        let z = c64::new(-0.5, 0.75f64.sqrt());
        let mut couple = |p: usize, q: usize| {
            for k in 0..2 {
                b.add(2 * p + k, 2 * p + k, 1.0);
                b.add(2 * q + k, 2 * q + k, 1.0);
            }
            h.add(p, p, c64::new(1.0, 0.0));
            h.add(q, q, c64::new(1.0, 0.0));
            b.add_sym(2 * p, 2 * q, z.re);
            b.add(2 * p, 2 * q + 1, -z.im);
            b.add(2 * q + 1, 2 * p, -z.im);
            b.add(2 * p + 1, 2 * q, z.im);
            b.add(2 * q, 2 * p + 1, z.im);
            b.add_sym(2 * p + 1, 2 * q + 1, z.re);
            h.add(p, q, z);
            h.add(q, p, z.conj());
        };
        for i in 0..n {
            for j in 0..n {
                if i + 1 < n {
                    couple(id(i, j), id(i + 1, j));
                }
                if j + 1 < n {
                    couple(id(i, j), id(i, j + 1));
                }
            }
        }
        for p in 0..n * n {
            b.add(2 * p, 2 * p, 0.01);
            b.add(2 * p + 1, 2 * p + 1, 0.01);
            h.add(p, p, c64::new(0.01, 0.0));
        }
        let (a, ah) = (b.build().unwrap(), h.build().unwrap());
        let t = std::time::Instant::now();
        let s = SpdSolver::new(&a).unwrap();
        println!("real 2x2 blocks: symbolic + numeric {:?}", t.elapsed());
        let t = std::time::Instant::now();
        let sh = SpdSolver::new(&ah).unwrap();
        println!("hermitian: symbolic + numeric {:?}", t.elapsed());
        let t = std::time::Instant::now();
        let mut s2 = sh.clone();
        s2.refactor(&ah).unwrap();
        println!("hermitian numeric only {:?}", t.elapsed());
        let rhs: Vec<f64> = (0..a.n()).map(|i| (i as f64).sin()).collect();
        let rh: Vec<c64> = (0..n * n)
            .map(|p| c64::new(rhs[2 * p], rhs[2 * p + 1]))
            .collect();
        let (x, y) = (s.solve(&rhs).unwrap(), sh.solve(&rh).unwrap());
        let diff = (0..n * n)
            .map(|p| {
                (x[2 * p] - y[p].re)
                    .abs()
                    .max((x[2 * p + 1] - y[p].im).abs())
            })
            .fold(0.0, f64::max);
        println!("max difference between the two solutions {diff:e}");
    }
}
