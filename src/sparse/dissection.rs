//! Geometric nested dissection: a fill-reducing ordering for systems whose unknowns sit at points
//! of a surface (faces, vertices), for large meshes where it beats faer's AMD.
//!
//! The unknowns are split at the median of one coordinate; the unknowns of the lower half that
//! have a neighbour in the upper half form the separator, which is ordered last, after the two
//! halves ordered the same way recursively. Of the three axes, the one giving the smallest
//! separator is taken while a part is larger than [`BEST_AXIS_MIN`] (the large separators near
//! the top of the tree decide most of the factorization's work), the bounding box's longest one
//! below that.
//!
//! Measured on the dual graph of shared meshes subdivided in memory (one thread each: the
//! ordering runs beside other work; nnz(L); sequential numeric factorization):
//!
//! | faces | AMD: analysis, nnz(L), factor | nested dissection: ordering + analysis, nnz(L), factor |
//! |---|---|---|
//! | 69 k (bunny) | 0.05 s, 2.0 M, 0.05 s | 0.03 s, 2.4 M, 0.05 s |
//! | 278 k (bunny ×4) | 0.26 s, 9.7 M, 0.21 s | 0.14 s, 11.0 M, 0.25 s |
//! | 1.1 M (bunny ×16) | 1.5 s, 49.2 M, 1.20 s | 0.5 + 0.4 s, 49.2 M, 1.19 s |
//! | 1.1 M (igea ×4) | 1.3 s, 51.0 M, 1.34 s | 0.45 + 0.4 s, 49.8 M, 1.25 s |
//! | 4.3 M (igea ×16) | 5.4 s, 260 M, 31.7 s | 2.1 + 1.6 s, 220 M, 7.2 s |
//!
//! Below a few hundred thousand unknowns AMD's fill is 10–50 % smaller, so [`Analysis::geometric`]
//! keeps AMD there.
//!
//! [`Analysis::geometric`]: super::Analysis::geometric

use glam::DVec3;

use super::{Scalar, SolverError, SparseMatrix};

/// Parts this small are not split further (their order is arbitrary).
const LEAF: usize = 4;
/// Parts larger than this try all three axes for the smallest separator.
const BEST_AXIS_MIN: usize = 2000;

/// An unknown with its point, contiguous so that the median selections stream through memory.
#[derive(Clone, Copy)]
struct Item {
    p: [f32; 3],
    id: u32,
}

struct Dissection<'a> {
    col_ptr: &'a [usize],
    row_idx: &'a [usize],
    /// Per unknown, the stamp of the last split that put it in an upper half.
    upper: Vec<u32>,
    stamp: u32,
}

/// The elimination order (position → unknown) of the graph of `matrix`'s pattern, which must hold
/// both triangles, with unknown `i` at `points[i]`.
pub fn nested_dissection<T: Scalar>(
    matrix: &SparseMatrix<T>,
    points: &[DVec3],
) -> Result<Vec<usize>, SolverError> {
    let n = matrix.n();
    if points.len() != n {
        return Err(SolverError::DimensionMismatch {
            expected: n,
            found: points.len(),
        });
    }
    if n > u32::MAX as usize {
        return Err(SolverError::Build(format!(
            "{n} unknowns are too many to dissect"
        )));
    }
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(SolverError::Build(format!("point {i} is not finite")));
    }
    let mut d = Dissection {
        col_ptr: &matrix.col_ptr,
        row_idx: &matrix.row_idx,
        upper: vec![0; n],
        stamp: 0,
    };
    let mut items: Vec<Item> = points
        .iter()
        .enumerate()
        .map(|(i, p)| Item {
            p: [p.x as f32, p.y as f32, p.z as f32],
            id: i as u32,
        })
        .collect();
    d.order(&mut items);
    Ok(items.into_iter().map(|item| item.id as usize).collect())
}

impl Dissection<'_> {
    /// Orders `part` in place: [lower half without separator | upper half | separator].
    fn order(&mut self, part: &mut [Item]) {
        let n = part.len();
        if n <= LEAF {
            return;
        }
        let axis = if n > BEST_AXIS_MIN {
            let mut best = (usize::MAX, 0);
            for axis in 0..3 {
                select_median(part, axis);
                let size = self.separator(part).1;
                best = best.min((size, axis));
            }
            best.1
        } else {
            longest_axis(part)
        };
        select_median(part, axis);
        let (stamp, _) = self.separator(part);
        let mid = n / 2;
        let mut interior = 0;
        for k in 0..mid {
            if !self.touches_upper(part[k].id, stamp) {
                part.swap(interior, k);
                interior += 1;
            }
        }
        part[interior..].rotate_left(mid - interior);
        let (lower, rest) = part.split_at_mut(interior);
        let upper = &mut rest[..n - mid];
        self.order(lower);
        self.order(upper);
    }

    /// Stamps the upper half of `part` (split at its middle) and counts the lower half's unknowns
    /// with a neighbour there: the separator.
    fn separator(&mut self, part: &[Item]) -> (u32, usize) {
        let mid = part.len() / 2;
        self.stamp += 1;
        let stamp = self.stamp;
        for item in &part[mid..] {
            self.upper[item.id as usize] = stamp;
        }
        let size = part[..mid]
            .iter()
            .filter(|item| self.touches_upper(item.id, stamp))
            .count();
        (stamp, size)
    }

    fn touches_upper(&self, id: u32, stamp: u32) -> bool {
        let i = id as usize;
        self.row_idx[self.col_ptr[i]..self.col_ptr[i + 1]]
            .iter()
            .any(|&j| self.upper[j] == stamp)
    }
}

fn select_median(part: &mut [Item], axis: usize) {
    let mid = part.len() / 2;
    part.select_nth_unstable_by(mid, |a, b| a.p[axis].total_cmp(&b.p[axis]));
}

fn longest_axis(part: &[Item]) -> usize {
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for item in part {
        for a in 0..3 {
            lo[a] = lo[a].min(item.p[a]);
            hi[a] = hi[a].max(item.p[a]);
        }
    }
    let ext = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Analysis, SpdSolver};
    use super::*;

    /// The 5-point Laplacian (plus identity) of a side × side grid, its unknowns at their grid
    /// points on a tilted plane.
    fn grid(side: usize) -> (SparseMatrix, Vec<DVec3>) {
        let points = (0..side * side)
            .map(|i| {
                let (x, y) = ((i % side) as f64, (i / side) as f64);
                DVec3::new(x, y, 0.3 * x)
            })
            .collect();
        (super::super::grid_laplacian(side, |_| 1.0), points)
    }

    #[test]
    fn dissection_orders_a_grid_with_amd_like_fill() {
        let side = 300;
        let (a, points) = grid(side);
        let order = nested_dissection(&a, &points).unwrap();
        let mut seen = vec![false; a.n()];
        for &i in &order {
            assert!(!std::mem::replace(&mut seen[i], true), "{i} ordered twice");
        }
        assert!(seen.iter().all(|s| *s));
        // The last unknowns are the top separator: a line across the grid.
        let top = &order[a.n() - side..];
        let rows: std::collections::BTreeSet<usize> = top.iter().map(|i| i / side).collect();
        let cols: std::collections::BTreeSet<usize> = top.iter().map(|i| i % side).collect();
        assert!(
            rows.len() == 1 || cols.len() == 1,
            "top separator is not a grid line"
        );

        let dissected = Analysis::with_order(&a, &order).unwrap();
        let amd = Analysis::new(&a).unwrap();
        let natural = Analysis::with_order(&a, &(0..a.n()).collect::<Vec<_>>()).unwrap();
        let (nd, md, nat) = (
            dissected.factor_entries(),
            amd.factor_entries(),
            natural.factor_entries(),
        );
        assert!(nd < md * 13 / 10, "dissection {nd} against AMD {md}");
        assert!(
            nd < nat / 4,
            "dissection {nd} against the natural order {nat}"
        );

        // Any order solves the same system.
        let rhs: Vec<f64> = (0..a.n()).map(|i| (i as f64 * 0.37).sin()).collect();
        let x = SpdSolver::with_analysis(dissected, &a)
            .unwrap()
            .solve(&rhs)
            .unwrap();
        let r = a.mul_vec(&x);
        let err = r
            .iter()
            .zip(&rhs)
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        assert!(err < 1e-10, "residual {err:e}");
    }

    #[test]
    fn bad_points_and_orders_are_errors() {
        let (a, mut points) = grid(20);
        assert!(nested_dissection(&a, &points[1..]).is_err());
        points[7].y = f64::NAN;
        assert!(nested_dissection(&a, &points).is_err());
        let n = a.n();
        let mut repeated: Vec<usize> = (0..n).collect();
        repeated[3] = 4;
        assert!(Analysis::with_order(&a, &repeated).is_err());
        assert!(Analysis::with_order(&a, &(0..n - 1).collect::<Vec<_>>()).is_err());
        assert!(Analysis::with_order(&a, &(1..=n).collect::<Vec<_>>()).is_err());
        // Small systems keep AMD.
        let (b, points) = grid(30);
        assert_eq!(
            Analysis::geometric(&b, &points).unwrap().factor_entries(),
            Analysis::new(&b).unwrap().factor_entries()
        );
    }
}
