//! Exact integer linear algebra for the combinatorial constraints C_c w = 0 (thesis eq. 4.8,
//! alg. 7 steps 4–5): the integer solutions form a lattice, whose basis comes from a column
//! Hermite reduction with a unimodular transform (exact, in i128); the rounding picks the
//! lattice point nearest the measured values (least squares in the basis, rounded, then
//! improved coordinate-wise).
//!
//! The Hermite reduction's basis can be very skewed (entries of 3.7 million on a remeshed
//! fandisk with features at 40°, against 68 on the original), and rounding coordinates in a
//! skewed basis lands arbitrarily far from the target (there: curve values of 35 000 cells and
//! the whole map folded); the basis is therefore LLL-reduced first (Lenstra, Lenstra & Lovász
//! 1982, δ = 3/4), which keeps the lattice and makes its vectors short and nearly orthogonal.
//!
//! The thesis eliminates by Gauss and rounds the free variables; that leaves the dependent ones
//! integer only when every pivot is ±1 (a constraint like 2c = w₁ + w₂ at a singularity of
//! index 1/4 breaks it). The lattice basis keeps every solution integer.

/// Integer solution of `rows · w = 0` (rows sparse over `n` variables) nearest to `target` in
/// the metric `metric` (dense n × n, symmetric positive definite; the identity when `None`);
/// `Err` when the arithmetic overflows (then the constraints are unusable as given).
#[cfg(test)]
pub(crate) fn nearest_integer_solution(
    rows: &[Vec<(usize, i128)>],
    n: usize,
    target: &[f64],
    metric: Option<&[f64]>,
) -> Result<Vec<i64>, String> {
    let basis = reduced_kernel(rows, n)?;
    let sparse = metric.map(|m| sparse_rows(m, n));
    let w = nearest_in_lattice(&basis, n, target, sparse.as_deref())?;
    debug_assert!(
        rows.iter()
            .all(|row| row.iter().map(|&(j, a)| a * w[j] as i128).sum::<i128>() == 0)
    );
    Ok(w)
}

/// An LLL-reduced basis (columns) of the integer solutions of `rows · w = 0` over `n`
/// variables; [`nearest_in_lattice`] rounds in it (callers rounding many targets under the same
/// rows compute it once).
pub(crate) fn reduced_kernel(
    rows: &[Vec<(usize, i128)>],
    n: usize,
) -> Result<Vec<Vec<i128>>, String> {
    let reduced = |basis: Result<Vec<Vec<i128>>, String>| {
        basis.and_then(|mut b| lll_reduce(&mut b).map(|()| b))
    };
    let largest = |b: &[Vec<i128>]| b.iter().flatten().map(|x| x.unsigned_abs()).max();
    let dense = rows.len() * n * n <= DENSE_MAX_WORK;
    // In the rows' order first (what every measured solve used; by substitution when the dense
    // transform is too much work), then the other ways, while the reduced basis stays long: the
    // Hermite basis can grow past what LLL's floating-point Gram–Schmidt resolves (a box with
    // three slots and features at 40°: entries of 10²⁵ before and after, curve values of
    // millions of cells, every face folded), and another elimination order starts it shorter.
    type Way = fn(&[Vec<(usize, i128)>], usize) -> Result<Vec<Vec<i128>>, String>;
    let in_order: Way = |rows, n| kernel_basis(rows, n, false);
    let robustly: Way = |rows, n| kernel_basis(rows, n, true);
    let ways: [Way; 3] = if dense {
        [in_order, robustly, kernel_by_substitution]
    } else {
        [kernel_by_substitution, in_order, robustly]
    };
    let mut best: Option<Vec<Vec<i128>>> = None;
    let mut failed = None;
    for way in ways {
        match reduced(way(rows, n)) {
            Ok(b) if largest(&b).is_none_or(|x| x <= SHORT_ENTRY) => return Ok(b),
            Ok(b) => {
                if best.as_ref().is_none_or(|c| largest(&b) < largest(c)) {
                    best = Some(b);
                }
            }
            Err(e) => failed = Some(e),
        }
    }
    match best {
        Some(b) if largest(&b).is_some_and(|x| x <= EXACT_ENTRY) => Ok(b),
        Some(b) => Err(format!(
            "the constraint lattice has no short basis (entries up to {:.1e})",
            largest(&b).unwrap_or(0) as f64
        )),
        None => Err(failed.unwrap_or_else(|| "no constraint lattice".to_string())),
    }
}

/// Entries up to which a reduced kernel basis is taken as it is (far above what curve
/// equations give: a few units).
const SHORT_ENTRY: u128 = 1 << 31;

/// Entries up to which the rounding ([`nearest_in_lattice`], in f64) stays exact.
const EXACT_ENTRY: u128 = 1 << 52;

/// Rows × variables² past which [`reduced_kernel`] substitutes first ([`kernel_by_substitution`])
/// instead of reducing the dense n × n transform: spot with features at 12° (1493 rows over
/// 1684 variables) took 0.8 s that way, at 10° minutes.
const DENSE_MAX_WORK: usize = 50_000_000;

/// A basis of the integer kernel of `rows` found by substitution first: a row with a
/// coefficient ±1 gives that variable as an integer combination of the row's others, exactly,
/// so it is eliminated from the other rows (sparse; pivots that grow the entries least first,
/// then those that fill in least). Nearly every curve equation has one (a line value c_κ, or a
/// gap, with coefficient ±1 once the row is divided by its gcd). The rows left without one go
/// to [`kernel_basis`] over their own few variables; variables in no row left are free. Each
/// basis vector over the variables kept is completed by the substitutions in reverse order.
/// The integer solutions are exactly those completions (every substitution is integral), so the
/// lattice is the same as [`kernel_basis`]'s, in another basis. `Err` on overflow or when the
/// completed vectors grow past [`REDUCE_ABOVE`] (the caller then reduces densely).
fn kernel_by_substitution(rows: &[Vec<(usize, i128)>], n: usize) -> Result<Vec<Vec<i128>>, String> {
    use std::collections::{BTreeMap, BTreeSet};
    let overflow = || "integer overflow in the constraint substitution".to_string();
    let normalized = |row: BTreeMap<usize, i128>| -> BTreeMap<usize, i128> {
        let g = row.values().fold(0i128, |g, &a| ext_gcd(g, a).0);
        if g > 1 {
            row.into_iter().map(|(j, a)| (j, a / g)).collect()
        } else {
            row
        }
    };
    let mut live: Vec<Option<BTreeMap<usize, i128>>> = rows
        .iter()
        .map(|row| {
            let mut m = BTreeMap::new();
            for &(j, a) in row {
                *m.entry(j).or_insert(0) += a;
            }
            m.retain(|_, a| *a != 0);
            (!m.is_empty()).then(|| normalized(m))
        })
        .collect();
    let mut col: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); n];
    for (i, row) in live.iter().enumerate() {
        for &j in row.iter().flat_map(|r| r.keys()) {
            col[j].insert(i);
        }
    }
    // w_var = Σ c_l w_l, in the order eliminated.
    let mut substitutions: Vec<(usize, Vec<(usize, i128)>)> = Vec::new();
    let mut eliminated = vec![false; n];
    // The substituted entries grow by (largest other coefficient of the row) × (largest
    // coefficient of the variable elsewhere): the least growth first, then Markowitz's fill-in
    // (row length − 1) × (column length − 1). Candidates wait in order of the cost they had
    // when queued, checked again when they come up (a scan of every row per step took seconds
    // on 4000 rows).
    type Rows = [Option<BTreeMap<usize, i128>>];
    let cost =
        |live: &Rows, col: &[BTreeSet<usize>], i: usize, j: usize| -> Option<(u128, usize)> {
            let row = live[i].as_ref()?;
            if row.get(&j)?.abs() != 1 {
                return None;
            }
            let row_max = row
                .iter()
                .filter(|&(&l, _)| l != j)
                .map(|(_, a)| a.unsigned_abs())
                .max()
                .unwrap_or(0);
            let col_max = col[j]
                .iter()
                .filter(|&&r| r != i)
                .map(|&r| live[r].as_ref().map_or(0, |row| row[&j].unsigned_abs()))
                .max()
                .unwrap_or(0);
            Some((row_max * col_max, (row.len() - 1) * (col[j].len() - 1)))
        };
    let mut queue: BTreeSet<(u128, usize, usize, usize)> = BTreeSet::new();
    let enqueue = |queue: &mut BTreeSet<_>, live: &Rows, col: &[BTreeSet<usize>], i: usize| {
        for &j in live[i].iter().flat_map(|r| r.keys()) {
            if let Some((g, m)) = cost(live, col, i, j) {
                queue.insert((g, m, i, j));
            }
        }
    };
    for i in 0..live.len() {
        enqueue(&mut queue, &live, &col, i);
    }
    while let Some(first) = queue.pop_first() {
        let (g, m, i, j) = first;
        match cost(&live, &col, i, j) {
            None => continue,
            Some(now) if now != (g, m) => {
                queue.insert((now.0, now.1, i, j));
                continue;
            }
            Some(_) => {}
        }
        let row = live[i].take().expect("a live row");
        for &l in row.keys() {
            col[l].remove(&i);
        }
        let aj = row[&j];
        for r in std::mem::take(&mut col[j]) {
            let mut target = live[r].take().expect("a live row");
            let f = target[&j] * aj;
            for (&l, &a) in &row {
                let e = target.entry(l).or_insert(0);
                *e = f
                    .checked_mul(a)
                    .and_then(|d| e.checked_sub(d))
                    .ok_or_else(overflow)?;
                if *e == 0 {
                    target.remove(&l);
                    col[l].remove(&r);
                } else {
                    col[l].insert(r);
                }
            }
            if !target.is_empty() {
                live[r] = Some(normalized(target));
                enqueue(&mut queue, &live, &col, r);
            }
        }
        // a_j w_j + Σ a_l w_l = 0 with a_j = ±1: w_j = −a_j Σ a_l w_l.
        let expr = row.iter().filter(|&(&l, _)| l != j);
        substitutions.push((j, expr.map(|(&l, &a)| (l, -aj * a)).collect()));
        eliminated[j] = true;
    }
    // The rows left, over their own variables, and the free variables.
    let in_left: Vec<usize> = (0..n).filter(|&j| !col[j].is_empty()).collect();
    let local: BTreeMap<usize, usize> = in_left.iter().enumerate().map(|(i, &j)| (j, i)).collect();
    let left_rows: Vec<Vec<(usize, i128)>> = live
        .iter()
        .flatten()
        .map(|r| r.iter().map(|(j, &a)| (local[j], a)).collect())
        .collect();
    let mut kept: Vec<Vec<(usize, i128)>> = (0..n)
        .filter(|&j| !eliminated[j] && col[j].is_empty())
        .map(|j| vec![(j, 1)])
        .collect();
    if !in_left.is_empty() {
        let m = in_left.len();
        let mut sub =
            kernel_basis(&left_rows, m, false).or_else(|_| kernel_basis(&left_rows, m, true))?;
        // Short before it is completed (the Hermite basis alone reached 10⁸ on 30 rows).
        lll_reduce(&mut sub)?;
        kept.extend(sub.into_iter().map(|v| {
            v.iter()
                .enumerate()
                .filter(|&(_, &x)| x != 0)
                .map(|(i, &x)| (in_left[i], x))
                .collect()
        }));
    }
    let basis: Vec<Vec<i128>> = kept
        .into_iter()
        .map(|v| {
            let mut w = vec![0i128; n];
            for (j, x) in v {
                w[j] = x;
            }
            for (j, expr) in substitutions.iter().rev() {
                let mut x = 0i128;
                for &(l, c) in expr {
                    x = c
                        .checked_mul(w[l])
                        .and_then(|d| x.checked_add(d))
                        .ok_or_else(overflow)?;
                }
                w[*j] = x;
            }
            Ok(w)
        })
        .collect::<Result<_, String>>()?;
    // Chains of substitutions through coefficients ±2 multiply: past this the reduction's f64
    // Gram–Schmidt would not be exact (the curves' systems measured: entries up to 5019).
    if basis
        .iter()
        .flatten()
        .any(|x| x.unsigned_abs() > REDUCE_ABOVE)
    {
        return Err("the substitution grew the basis".to_string());
    }
    Ok(basis)
}

/// A dense n × n metric by its rows' nonzero entries, as [`nearest_in_lattice`] takes it:
/// the metrics are mostly diagonal (the gaps' energy block and the line values' weights;
/// n = 4000 and more with features at 5°).
pub(crate) fn sparse_rows(m: &[f64], n: usize) -> Vec<Vec<(usize, f64)>> {
    (0..n)
        .map(|r| {
            (0..n)
                .map(|c| (c, m[r * n + c]))
                .filter(|&(_, v)| v != 0.0)
                .collect()
        })
        .collect()
}

/// The point of the lattice spanned by `basis` (columns over `n` variables) nearest to
/// `target` in `metric` (by rows' nonzero entries, [`sparse_rows`]; the identity when `None`).
pub(crate) fn nearest_in_lattice(
    basis: &[Vec<i128>],
    n: usize,
    target: &[f64],
    metric: Option<&[Vec<(usize, f64)>]>,
) -> Result<Vec<i64>, String> {
    debug_assert_eq!(target.len(), n);
    let k = basis.len();
    if k == 0 {
        return Ok(vec![0; n]);
    }
    let b: Vec<Vec<f64>> = basis
        .iter()
        .map(|col| col.iter().map(|&x| x as f64).collect())
        .collect();
    let identity: Vec<Vec<(usize, f64)>>;
    let sparse = match metric {
        Some(m) => m,
        None => {
            identity = (0..n).map(|r| vec![(r, 1.0)]).collect();
            &identity
        }
    };
    // The basis vectors are sparse (short after the reduction): their products over their
    // supports, in the same order (the terms left out are exact zeros). Spot with features
    // at 10°: 207 vectors over 2060 unknowns, rounded again and again by the mending and the
    // re-roundings.
    let supports: Vec<Vec<(usize, f64)>> = b
        .iter()
        .map(|col| {
            col.iter()
                .enumerate()
                .filter(|&(_, &x)| x != 0.0)
                .map(|(l, &x)| (l, x))
                .collect()
        })
        .collect();
    let dot_b = |i: usize, x: &[f64]| -> f64 { supports[i].iter().map(|&(l, v)| v * x[l]).sum() };
    let apply_m = |x: &[f64]| -> Vec<f64> {
        sparse
            .iter()
            .map(|row| row.iter().map(|&(c, v)| v * x[c]).sum())
            .collect()
    };
    // Least squares in the metric: (BᵀMB) z = BᵀM w*.
    let mb: Vec<Vec<f64>> = b.iter().map(|col| apply_m(col)).collect();
    let mut gram = vec![0.0; k * k];
    let mut rhs = vec![0.0; k];
    let mt = apply_m(target);
    for i in 0..k {
        for j in 0..k {
            gram[i * k + j] = dot_b(i, &mb[j]);
        }
        rhs[i] = dot_b(i, &mt);
    }
    let z_real = solve_dense(&gram, &rhs, k).ok_or("the constraint lattice is degenerate")?;
    let mut z: Vec<i64> = z_real.iter().map(|x| x.round() as i64).collect();
    // Coordinate descent on ‖B z − w*‖²_M, kept incrementally: with d = B z − w* and
    // g = Bᵀ M d, a step s = ±1 of z_c changes the distance by 2 s g_c + (BᵀMB)_cc and g by
    // s (BᵀMB)_{·c}, so a sweep costs O(k) per accepted step instead of O(k n) per trial (a
    // gear with 216 feature curves, k ≈ 500: minutes per rounding before).
    let md: Vec<f64> = (0..n)
        .map(|r| (0..k).map(|c| mb[c][r] * z[c] as f64).sum::<f64>() - mt[r])
        .collect();
    let d: Vec<f64> = (0..n)
        .map(|r| (0..k).map(|c| b[c][r] * z[c] as f64).sum::<f64>() - target[r])
        .collect();
    let mut best = dot(&d, &md);
    let mut g: Vec<f64> = (0..k).map(|c| dot_b(c, &md)).collect();
    for _ in 0..20 {
        let mut improved = false;
        for c in 0..k {
            for step in [-1i64, 1] {
                let s = step as f64;
                let delta = 2.0 * s * g[c] + gram[c * k + c];
                if best + delta + 1e-12 < best {
                    best += delta;
                    z[c] += step;
                    for (i, gi) in g.iter_mut().enumerate() {
                        *gi += s * gram[i * k + c];
                    }
                    improved = true;
                }
            }
        }
        if !improved {
            break;
        }
    }
    // In i128: the entries may reach [`EXACT_ENTRY`].
    (0..n)
        .map(|r| {
            let v: i128 = (0..k).map(|c| basis[c][r] * z[c] as i128).sum();
            i64::try_from(v).map_err(|_| "integer overflow in the constraint rounding".to_string())
        })
        .collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Columns spanning the integer kernel {w ∈ Zⁿ : rows · w = 0}: A U = [H | 0] with U
/// unimodular (column operations by extended gcd); the columns of U beyond the rank.
///
/// The extended-gcd combinations grow the entries geometrically with the rows eliminated (a
/// gear with 216 feature curves: 432 rows over 506 variables, 10²¹ after 260 rows, then an
/// overflow of i128). `robust` pivots each row on its smallest entry (most often ±1: the
/// other columns then only lose a multiple of it) and reduces the columns still to be
/// eliminated whenever they grow ([`reduce_if_large`]). It is the fallback, not the rule: the
/// same lattice in another basis rounds elsewhere, and over the constrained sweep that was worse
/// more often than better (`docs/untangling.md`).
fn kernel_basis(
    rows: &[Vec<(usize, i128)>],
    n: usize,
    robust: bool,
) -> Result<Vec<Vec<i128>>, String> {
    let overflow = || "integer overflow in the constraint elimination".to_string();
    let mut a: Vec<Vec<i128>> = rows
        .iter()
        .map(|row| {
            let mut d = vec![0i128; n];
            for &(j, v) in row {
                d[j] += v;
            }
            d
        })
        .collect();
    // U as columns.
    let mut u: Vec<Vec<i128>> = (0..n)
        .map(|j| (0..n).map(|i| (i == j) as i128).collect())
        .collect();
    let mut p = 0;
    for i in 0..a.len() {
        if p == n {
            break;
        }
        if robust
            && let Some(m) = (p..n)
                .filter(|&j| a[i][j] != 0)
                .min_by_key(|&j| (a[i][j].unsigned_abs(), j))
            && m != p
        {
            for row in a.iter_mut() {
                row.swap(p, m);
            }
            u.swap(p, m);
        }
        for j in p + 1..n {
            if a[i][j] == 0 {
                continue;
            }
            // Columns p and j: (x, y) -> (g, 0) with [[s, -y/g], [t, x/g]] (determinant 1).
            let (x, y) = (a[i][p], a[i][j]);
            let (g, s, t) = ext_gcd(x, y);
            let (xg, yg) = (x / g, y / g);
            let combine = |cp: i128, cj: i128| -> Result<(i128, i128), String> {
                let np = s
                    .checked_mul(cp)
                    .and_then(|l| t.checked_mul(cj).and_then(|r| l.checked_add(r)))
                    .ok_or_else(overflow)?;
                let nj = xg
                    .checked_mul(cj)
                    .and_then(|l| yg.checked_mul(cp).and_then(|r| l.checked_sub(r)))
                    .ok_or_else(overflow)?;
                Ok((np, nj))
            };
            for row in a.iter_mut() {
                let (np, nj) = combine(row[p], row[j])?;
                row[p] = np;
                row[j] = nj;
            }
            let (left, right) = u.split_at_mut(j);
            let (cp, cj) = (&mut left[p], &mut right[0]);
            for r in 0..n {
                let (np, nj) = combine(cp[r], cj[r])?;
                cp[r] = np;
                cj[r] = nj;
            }
        }
        if a[i][p] != 0 {
            p += 1;
        }
        if robust {
            reduce_if_large(&mut a[i + 1..], &mut u, p)?;
        }
    }
    Ok(u.split_off(p))
}

/// Entries past which [`kernel_basis`] reduces its columns still to be eliminated.
const REDUCE_ABOVE: u128 = 1 << 24;

/// The columns from `p` on (U's, with the rows `rest` still to be eliminated beneath) span the
/// integer kernel of the rows done so far; any unimodular change of them keeps that, so once
/// an entry passes [`REDUCE_ABOVE`] they are LLL-reduced as stacked vectors, which keeps both
/// parts short (the f64 Gram–Schmidt of the reduction stays exact enough that far below 2⁵³).
fn reduce_if_large(rest: &mut [Vec<i128>], u: &mut [Vec<i128>], p: usize) -> Result<(), String> {
    let large = |j: usize| {
        u[j].iter()
            .chain(rest.iter().map(|row| &row[j]))
            .any(|x| x.unsigned_abs() > REDUCE_ABOVE)
    };
    if !(p..u.len()).any(large) {
        return Ok(());
    }
    let n = u.len();
    let mut stacked: Vec<Vec<i128>> = (p..n)
        .map(|j| {
            let mut v = u[j].clone();
            v.extend(rest.iter().map(|row| row[j]));
            v
        })
        .collect();
    lll_reduce(&mut stacked)?;
    for (j, v) in (p..n).zip(stacked) {
        u[j].copy_from_slice(&v[..n]);
        for (row, &x) in rest.iter_mut().zip(&v[n..]) {
            row[j] = x;
        }
    }
    Ok(())
}

/// LLL reduction (δ = 3/4, Euclidean) of the lattice basis `basis` in place: the same lattice,
/// short and nearly orthogonal vectors. Exact integer updates of the vectors and, where their
/// entries are small enough for it, of their Gram matrix ([`lll_by_gram`]); otherwise on the
/// vectors ([`lll_by_vectors`]).
fn lll_reduce(basis: &mut [Vec<i128>]) -> Result<(), String> {
    let largest = basis.iter().flatten().map(|x| x.unsigned_abs()).max();
    if largest.is_some_and(|x| x <= GRAM_MAX_ENTRY) {
        let mut by_gram = basis.to_vec();
        if lll_by_gram(&mut by_gram).is_ok() {
            basis.clone_from_slice(&by_gram);
            return Ok(());
        }
    }
    lll_by_vectors(basis)
}

/// Entries up to which [`lll_reduce`] works on the Gram matrix: its entries then stay exact in
/// f64 (2⁴⁰ per product, over up to 4096 unknowns) while the vectors do not grow much. Larger
/// ones (the Hermite basis, up to 10²⁰) misled the f64 coefficients computed from the Gram
/// matrix into a long reduction to a poor basis.
const GRAM_MAX_ENTRY: u128 = 1 << 20;

/// How LLL computes its Gram–Schmidt data beside the exact vectors.
trait GramSchmidt {
    /// Row i (μ_i· and |b*_i|²) from the vectors' current state and rows 0 … i − 1.
    fn row(&mut self, i: usize, mu: &mut [Vec<f64>], bs: &mut [f64]);
    /// After b_i −= q b_j (the exact vectors `basis` already updated).
    fn subtracted(&mut self, basis: &[Vec<i128>], i: usize, j: usize, q: i128) -> Option<()>;
    /// After b_i and b_{i−1} swapped places.
    fn swapped(&mut self, i: usize);
}

/// LLL (δ = 3/4) on `basis` with the Gram–Schmidt data `gs`: size reduction by exact integer
/// updates, a row recomputed whenever its vector changes.
fn lll_with(basis: &mut [Vec<i128>], mut gs: impl GramSchmidt) -> Result<(), String> {
    const DELTA: f64 = 0.75;
    let k = basis.len();
    let overflow = || "integer overflow in the lattice reduction".to_string();
    let mut mu = vec![vec![0.0; k]; k];
    let mut bs = vec![0.0; k];
    gs.row(0, &mut mu, &mut bs);
    let mut i = 1;
    // LLL ends after polynomially many swaps; the cap only guards against float trouble.
    for _ in 0..1_000_000 {
        if i >= k {
            break;
        }
        gs.row(i, &mut mu, &mut bs);
        // size reduction of b_i against b_{i-1}, …, b_0 (b*_i does not change)
        for j in (0..i).rev() {
            let q = mu[i][j].round();
            if q == 0.0 {
                continue;
            }
            let qi = q as i128;
            subtract_multiple(basis, i, j, qi).ok_or_else(overflow)?;
            gs.subtracted(basis, i, j, qi).ok_or_else(overflow)?;
            subtract_multiple_mu(&mut mu, i, j, q);
        }
        if bs[i] >= (DELTA - mu[i][i - 1] * mu[i][i - 1]) * bs[i - 1] {
            i += 1;
        } else {
            basis.swap(i, i - 1);
            gs.swapped(i);
            // Row i − 1 is recomputed at the loop's top when i − 1 ≥ 1 (its inputs do not
            // change before): only row 0 needs it here.
            if i == 1 {
                gs.row(0, &mut mu, &mut bs);
            }
            i = (i - 1).max(1);
        }
    }
    Ok(())
}

/// LLL on the Gram matrix, exact in i128; the Gram–Schmidt coefficients in f64 from it (Cohen,
/// *A Course in Computational Algebraic Number Theory*, alg. 2.6.3). A row costs O(k²)
/// instead of O(k n) on the vectors: spot with features at 10° has 207 vectors over 2060
/// unknowns (the global phase 7.7 s on the vectors, 1.6 s on the Gram matrix).
fn lll_by_gram(basis: &mut [Vec<i128>]) -> Result<(), String> {
    let k = basis.len();
    if k < 2 {
        return Ok(());
    }
    let mut gram = vec![vec![0i128; k]; k];
    let support: Vec<Vec<usize>> = basis
        .iter()
        .map(|v| (0..v.len()).filter(|&l| v[l] != 0).collect())
        .collect();
    for a in 0..k {
        for b in 0..=a {
            let mut d = 0i128;
            for &l in &support[a] {
                d = basis[a][l]
                    .checked_mul(basis[b][l])
                    .and_then(|x| d.checked_add(x))
                    .ok_or("integer overflow in the lattice reduction")?;
            }
            gram[a][b] = d;
            gram[b][a] = d;
        }
    }
    let gs = ByGram {
        gram,
        r: vec![vec![0.0; k]; k],
    };
    lll_with(basis, gs)
}

/// The Gram matrix G (exact) and r_ij = b_i · b*_j (μ_ij = r_ij / |b*_j|²).
struct ByGram {
    gram: Vec<Vec<i128>>,
    r: Vec<Vec<f64>>,
}

impl GramSchmidt for ByGram {
    fn row(&mut self, i: usize, mu: &mut [Vec<f64>], bs: &mut [f64]) {
        let mut norm = self.gram[i][i] as f64;
        for j in 0..i {
            let mut x = self.gram[i][j] as f64;
            for l in 0..j {
                x -= mu[j][l] * self.r[i][l];
            }
            self.r[i][j] = x;
            mu[i][j] = if bs[j] > 0.0 { x / bs[j] } else { 0.0 };
            norm -= mu[i][j] * x;
        }
        bs[i] = norm;
    }
    fn subtracted(&mut self, _: &[Vec<i128>], i: usize, j: usize, q: i128) -> Option<()> {
        // |b_i − q b_j|² = G_ii − 2q G_ij + q² G_jj; (b_i − q b_j)·b_l = G_il − q G_jl.
        let g = &mut self.gram;
        let ii = g[i][i]
            .checked_sub(q.checked_mul(g[i][j])?.checked_mul(2)?)?
            .checked_add(q.checked_mul(q)?.checked_mul(g[j][j])?)?;
        for l in 0..g.len() {
            if l != i {
                let x = g[i][l].checked_sub(q.checked_mul(g[j][l])?)?;
                g[i][l] = x;
                g[l][i] = x;
            }
        }
        g[i][i] = ii;
        Some(())
    }
    fn swapped(&mut self, i: usize) {
        self.gram.swap(i, i - 1);
        for g in self.gram.iter_mut() {
            g.swap(i, i - 1);
        }
    }
}

/// [`lll_by_gram`] for vectors whose Gram matrix would overflow: the Gram–Schmidt vectors in
/// f64, a row recomputed from the exact vector (O(k n)).
fn lll_by_vectors(basis: &mut [Vec<i128>]) -> Result<(), String> {
    let k = basis.len();
    if k < 2 {
        return Ok(());
    }
    let n = basis[0].len();
    let gs = ByVectors {
        bf: basis.iter().map(|v| as_f64(v)).collect(),
        star: vec![vec![0.0; n]; k],
    };
    lll_with(basis, gs)
}

fn as_f64(v: &[i128]) -> Vec<f64> {
    v.iter().map(|&x| x as f64).collect()
}

/// The vectors in f64 and the Gram–Schmidt vectors b*_j.
struct ByVectors {
    bf: Vec<Vec<f64>>,
    star: Vec<Vec<f64>>,
}

impl GramSchmidt for ByVectors {
    fn row(&mut self, i: usize, mu: &mut [Vec<f64>], bs: &mut [f64]) {
        let mut v = self.bf[i].clone();
        // b_i is sparse (the kernel's vectors): its products with the dense b*_j over its
        // support only, in the same order (the terms left out are exact zeros).
        let support: Vec<(usize, f64)> = v
            .iter()
            .enumerate()
            .filter(|&(_, &x)| x != 0.0)
            .map(|(l, &x)| (l, x))
            .collect();
        for j in 0..i {
            let m = if bs[j] > 0.0 {
                let star = &self.star[j];
                support.iter().map(|&(l, x)| x * star[l]).sum::<f64>() / bs[j]
            } else {
                0.0
            };
            mu[i][j] = m;
            // (b_i ⟂ b*_j: nothing to take off.)
            if m != 0.0 {
                for (x, y) in v.iter_mut().zip(&self.star[j]) {
                    *x -= m * y;
                }
            }
        }
        bs[i] = dot(&v, &v);
        self.star[i] = v;
    }
    fn subtracted(&mut self, basis: &[Vec<i128>], i: usize, _: usize, _: i128) -> Option<()> {
        self.bf[i] = as_f64(&basis[i]);
        Some(())
    }
    fn swapped(&mut self, i: usize) {
        self.bf.swap(i, i - 1);
    }
}

/// b_i −= q b_j, exactly; `None` on overflow (LLL's size reduction).
fn subtract_multiple(basis: &mut [Vec<i128>], i: usize, j: usize, q: i128) -> Option<()> {
    let (lo, hi) = basis.split_at_mut(i);
    for (x, &y) in hi[0].iter_mut().zip(&lo[j]) {
        *x = x.checked_sub(q.checked_mul(y)?)?;
    }
    Some(())
}

/// The Gram–Schmidt coefficients of b_i after b_i −= q b_j (j < i): μ_ij −= q, μ_il −= q μ_jl.
fn subtract_multiple_mu(mu: &mut [Vec<f64>], i: usize, j: usize, q: f64) {
    mu[i][j] -= q;
    for l in 0..j {
        mu[i][l] -= q * mu[j][l];
    }
}

/// (g, s, t) with s·x + t·y = g = gcd(x, y) > 0 (for (x, y) ≠ (0, 0)).
fn ext_gcd(x: i128, y: i128) -> (i128, i128, i128) {
    let (mut r0, mut r1) = (x, y);
    let (mut s0, mut s1) = (1i128, 0i128);
    let (mut t0, mut t1) = (0i128, 1i128);
    while r1 != 0 {
        let q = r0.div_euclid(r1);
        (r0, r1) = (r1, r0 - q * r1);
        (s0, s1) = (s1, s0 - q * s1);
        (t0, t1) = (t1, t0 - q * t1);
    }
    if r0 < 0 {
        (-r0, -s0, -t0)
    } else {
        (r0, s0, t0)
    }
}

/// Solves a small dense symmetric positive (semi)definite system by Gaussian elimination with
/// partial pivoting; `None` if singular.
fn solve_dense(a: &[f64], b: &[f64], k: usize) -> Option<Vec<f64>> {
    let mut m: Vec<Vec<f64>> = (0..k)
        .map(|i| {
            let mut r = a[i * k..(i + 1) * k].to_vec();
            r.push(b[i]);
            r
        })
        .collect();
    for c in 0..k {
        let piv = (c..k).max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))?;
        if m[piv][c].abs() < 1e-12 {
            return None;
        }
        m.swap(c, piv);
        for r in 0..k {
            if r != c {
                let f = m[r][c] / m[c][c];
                if f != 0.0 {
                    for j in c..=k {
                        m[r][j] -= f * m[c][j];
                    }
                }
            }
        }
    }
    Some((0..k).map(|i| m[i][k] / m[i][i]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solutions_are_integer_and_nearest() {
        // 2c = w0 + w1 (a line through a singularity of index 1/4) and c = w2.
        let rows = vec![vec![(2, 2), (0, -1), (1, -1)], vec![(2, 1), (3, -1)]];
        let w = nearest_integer_solution(&rows, 4, &[2.9, 1.2, 2.1, 1.8], None).unwrap();
        assert_eq!(2 * w[2], w[0] + w[1]);
        assert_eq!(w[2], w[3]);
        // Nearest: w0 + w1 even; (3, 1, 2, 2) at distance² 0.01 + 0.04 + 0.01 + 0.04.
        assert_eq!(w, vec![3, 1, 2, 2]);
        // No constraint: plain rounding.
        assert_eq!(
            nearest_integer_solution(&[], 2, &[0.4, -1.6], None).unwrap(),
            vec![0, -2]
        );
        // Only the trivial solution.
        let rows = vec![vec![(0, 1)], vec![(1, 3), (0, 1)]];
        assert_eq!(
            nearest_integer_solution(&rows, 2, &[5.0, 5.0], None).unwrap(),
            vec![0, 0]
        );
        // A dependent row changes nothing.
        let rows = vec![vec![(0, 1), (1, -1)], vec![(0, 2), (1, -2)]];
        let w = nearest_integer_solution(&rows, 2, &[3.2, 2.6], None).unwrap();
        assert_eq!(w, vec![3, 3]);
    }

    #[test]
    fn the_metric_decides_which_variable_gives_way() {
        // w0 = w1, measured 0.2 and 0.9: the identity metric takes 1 (or 0; both at equal
        // distance up to 0.1); a stiff w0 keeps w0's nearest integer, 0.
        let rows = vec![vec![(0, 1), (1, -1)]];
        let stiff = [100.0, 0.0, 0.0, 1.0];
        let w = nearest_integer_solution(&rows, 2, &[0.2, 0.9], Some(&stiff)).unwrap();
        assert_eq!(w, vec![0, 0]);
        let soft = [1.0, 0.0, 0.0, 100.0];
        let w = nearest_integer_solution(&rows, 2, &[0.2, 0.9], Some(&soft)).unwrap();
        assert_eq!(w, vec![1, 1]);
    }

    /// A skewed basis of Z² (rows of a unimodular matrix with large entries) reduces to unit
    /// vectors, and the nearest point comes out right with it.
    #[test]
    fn lll_makes_a_skewed_basis_short() {
        let mut basis = vec![vec![1_000_001i128, 1_000_000], vec![1_000_000, 999_999]];
        lll_reduce(&mut basis).unwrap();
        let longest = basis.iter().flatten().map(|x| x.abs()).max().unwrap();
        assert_eq!(longest, 1, "{basis:?}");
        // w0 − 2 w1 + w2 = 0 over many variables: the Hermite basis grows, LLL keeps it small
        let n = 12;
        let rows: Vec<Vec<(usize, i128)>> = (0..n - 2)
            .map(|i| vec![(i, 1), (i + 1, -2), (i + 2, 1)])
            .collect();
        let target: Vec<f64> = (0..n).map(|i| 0.3 + 1.01 * i as f64).collect();
        let w = nearest_integer_solution(&rows, n, &target, None).unwrap();
        // the solutions are arithmetic progressions; the nearest is 0, 1, 2, …
        assert_eq!(w, (0..n as i64).collect::<Vec<_>>());
    }

    /// A reproducible stream of numbers below `k` (xorshift64).
    fn xorshift(mut seed: u64) -> impl FnMut(u64) -> u64 {
        move |k| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed % k
        }
    }

    /// Many sparse rows with coefficients like the curves' (±1, ±2: a line through a
    /// singularity of index 1/4): the column Hermite reduction alone grows its entries
    /// geometrically and overflowed i128 (as a gear with 216 feature curves did); reducing the
    /// columns still to be eliminated keeps them small. The solution satisfies every row exactly
    /// and is no farther from the target than the trivial one.
    #[test]
    fn many_rows_eliminate_without_overflow() {
        let (n, m) = (300, 260);
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15u64);
        let rows: Vec<Vec<(usize, i128)>> = (0..m)
            .map(|_| {
                let mut row: Vec<(usize, i128)> = Vec::new();
                for _ in 0..4 {
                    let j = next(n as u64) as usize;
                    let a = [1, -1, 2, -2][next(4) as usize];
                    row.push((j, a));
                }
                row
            })
            .collect();
        let target: Vec<f64> = (0..n).map(|_| next(2000) as f64 / 100.0 - 10.0).collect();
        let w = nearest_integer_solution(&rows, n, &target, None).unwrap();
        for row in &rows {
            assert_eq!(row.iter().map(|&(j, a)| a * w[j] as i128).sum::<i128>(), 0);
        }
        let dist = |w: &[f64]| -> f64 { w.iter().zip(&target).map(|(a, b)| (a - b).powi(2)).sum() };
        let got = dist(&w.iter().map(|&x| x as f64).collect::<Vec<_>>());
        assert!(got <= dist(&vec![0.0; n]), "{got}");
    }

    /// Substitution first gives the same lattice as the dense Hermite reduction, the integer
    /// solutions of the rows: every vector solves them, the ranks agree, and each basis vector
    /// of either is an integer combination of the other's.
    #[test]
    fn substitution_spans_the_same_lattice() {
        let mut next = xorshift(0x2545_f491_4f6c_dd1du64);
        for (n, m) in [(12, 6), (40, 30), (80, 75)] {
            // Curve-like rows, scaled by 12 as the traced ones are: two line values c (the
            // last n / 2 variables) meeting, and gaps (the first n / 2) with coefficients
            // 0, ±1, ±2; every fifth row without a unit coefficient even once divided by its
            // gcd (2, 4, −6).
            let h = n as u64 / 2;
            let rows: Vec<Vec<(usize, i128)>> = (0..m)
                .map(|i| {
                    if i % 5 == 4 {
                        return [2, 4, -6]
                            .iter()
                            .map(|&a| (next(n as u64) as usize, a))
                            .collect();
                    }
                    let mut row = vec![((h + next(h)) as usize, 12), ((h + next(h)) as usize, -12)];
                    for _ in 0..2 {
                        row.push((next(h) as usize, [0, 12, -12, 24, -24][next(5) as usize]));
                    }
                    row
                })
                .collect();
            // Reduced, so that the check's arithmetic stays small.
            let mut dense = kernel_basis(&rows, n, false)
                .or_else(|_| kernel_basis(&rows, n, true))
                .unwrap();
            let mut sub = kernel_by_substitution(&rows, n).unwrap_or_else(|e| panic!("n {n}: {e}"));
            lll_reduce(&mut dense).unwrap();
            lll_reduce(&mut sub).unwrap();
            assert_eq!(dense.len(), sub.len(), "n {n}: the kernel's rank");
            for v in dense.iter().chain(&sub) {
                for row in &rows {
                    assert_eq!(row.iter().map(|&(j, a)| a * v[j]).sum::<i128>(), 0);
                }
            }
            for v in &dense {
                assert!(
                    in_lattice(&sub, v),
                    "n {n}: a solution the substitution misses"
                );
            }
            for v in &sub {
                assert!(in_lattice(&dense, v), "n {n}: a substituted vector outside");
            }
        }
        // A sublattice of index 2 is told apart.
        let basis = vec![vec![1i128, 1, 0], vec![0, 0, 2]];
        assert!(in_lattice(&basis, &[2, 2, -2]));
        assert!(!in_lattice(&basis, &[0, 0, 1]));
    }

    /// Whether `v` is an integer combination of the independent vectors `basis`: the integer
    /// relations among them and v are one primitive vector, whose coefficient of v is ±1
    /// exactly then.
    fn in_lattice(basis: &[Vec<i128>], v: &[i128]) -> bool {
        let k = basis.len();
        let rows: Vec<Vec<(usize, i128)>> = (0..v.len())
            .map(|r| {
                (0..k)
                    .map(|c| (c, basis[c][r]))
                    .chain([(k, v[r])])
                    .filter(|&(_, a)| a != 0)
                    .collect()
            })
            .collect();
        let relations = kernel_basis(&rows, k + 1, false)
            .or_else(|_| kernel_basis(&rows, k + 1, true))
            .unwrap();
        relations.len() == 1 && relations[0][k].abs() == 1
    }

    #[test]
    fn gcd_is_bezout() {
        for (x, y) in [(4, 6), (-4, 6), (0, 5), (7, 0), (12, -18)] {
            let (g, s, t) = ext_gcd(x, y);
            assert!(g > 0);
            assert_eq!(s * x + t * y, g);
        }
    }
}
