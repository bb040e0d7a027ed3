//! Rotations of texture space by multiples of 2π/N, small 2×2 algebra, sparse linear
//! combinations of loop gaps, and the translation lattices (Z², 2Z², Eisenstein G6).

/// A 2×2 matrix, row-major `[a, b, c, d]` = [[a, b], [c, d]].
pub(crate) type M2 = [f64; 4];

pub(crate) const ID: M2 = [1.0, 0.0, 0.0, 1.0];

pub(crate) fn mul(a: &M2, b: &M2) -> M2 {
    [
        a[0] * b[0] + a[1] * b[2],
        a[0] * b[1] + a[1] * b[3],
        a[2] * b[0] + a[3] * b[2],
        a[2] * b[1] + a[3] * b[3],
    ]
}
pub(crate) fn apply(a: &M2, v: [f64; 2]) -> [f64; 2] {
    [a[0] * v[0] + a[1] * v[1], a[2] * v[0] + a[3] * v[1]]
}
pub(crate) fn transpose(a: &M2) -> M2 {
    [a[0], a[2], a[1], a[3]]
}
pub(crate) fn inverse(a: &M2) -> M2 {
    let det = a[0] * a[3] - a[1] * a[2];
    [a[3] / det, -a[1] / det, -a[2] / det, a[0] / det]
}
pub(crate) fn sub(a: &M2, b: &M2) -> M2 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3]]
}

/// The matrices R^k, k in 0..N, with R = M_1 = [[cos a, sin a], [−sin a, cos a]], a = 2π/N: the
/// field module's matching matrix (`field::matching_matrix`), acting on stacked frame rows and on
/// texture coordinates alike (φ_j = R^{r_ij} φ_i + w_ij). Exact entries for multiples of 90°.
#[derive(Clone, Debug)]
pub(crate) struct Rots {
    pub n: usize,
    m: Vec<M2>,
}

impl Rots {
    pub fn new(n: usize) -> Rots {
        let snap = |x: f64| {
            for t in [0.0, 0.5, -0.5, 1.0, -1.0] {
                if (x - t).abs() < 1e-14 {
                    return t;
                }
            }
            x
        };
        let m = (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                let (c, s) = (snap(a.cos()), snap(a.sin()));
                [c, s, -s, c]
            })
            .collect();
        Rots { n, m }
    }
    pub fn norm(&self, k: i64) -> u8 {
        k.rem_euclid(self.n as i64) as u8
    }
    pub fn get(&self, k: i64) -> &M2 {
        &self.m[k.rem_euclid(self.n as i64) as usize]
    }
}

/// A sparse linear combination Σ_k M_k W_k of the 2-D loop gaps W_k (sorted by k).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Lin(pub Vec<(u32, M2)>);

impl Lin {
    pub fn single(k: usize) -> Lin {
        Lin(vec![(k as u32, ID)])
    }
    pub fn is_zero(&self) -> bool {
        self.0.is_empty()
    }
    /// M · self.
    pub fn left(&self, m: &M2) -> Lin {
        Lin(self.0.iter().map(|(k, a)| (*k, mul(m, a))).collect())
    }
    pub fn add(&self, other: &Lin) -> Lin {
        let (a, b) = (&self.0, &other.0);
        let mut out = Vec::with_capacity(a.len() + b.len());
        let (mut i, mut j) = (0, 0);
        while i < a.len() || j < b.len() {
            if j >= b.len() || (i < a.len() && a[i].0 < b[j].0) {
                out.push(a[i]);
                i += 1;
            } else if i >= a.len() || b[j].0 < a[i].0 {
                out.push(b[j]);
                j += 1;
            } else {
                let m = [
                    a[i].1[0] + b[j].1[0],
                    a[i].1[1] + b[j].1[1],
                    a[i].1[2] + b[j].1[2],
                    a[i].1[3] + b[j].1[3],
                ];
                if m.iter().any(|x| x.abs() > 1e-12) {
                    out.push((a[i].0, m));
                }
                i += 1;
                j += 1;
            }
        }
        Lin(out)
    }
    pub fn eval(&self, w: &[[f64; 2]]) -> [f64; 2] {
        let mut s = [0.0; 2];
        for (k, m) in &self.0 {
            let v = apply(m, w[*k as usize]);
            s[0] += v[0];
            s[1] += v[1];
        }
        s
    }
}

/// An affine map x ↦ R^rot x + lin(W) of texture space.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Aff {
    pub rot: u8,
    pub lin: Lin,
}

impl Aff {
    pub fn is_identity(&self) -> bool {
        self.rot == 0 && self.lin.is_zero()
    }
    /// `self ∘ first`: x ↦ self(first(x)).
    pub fn after(&self, first: &Aff, r: &Rots) -> Aff {
        Aff {
            rot: r.norm(self.rot as i64 + first.rot as i64),
            lin: first.lin.left(r.get(self.rot as i64)).add(&self.lin),
        }
    }
    pub fn inverse(&self, r: &Rots) -> Aff {
        let m = r.get(-(self.rot as i64));
        let neg = [-m[0], -m[1], -m[2], -m[3]];
        Aff {
            rot: r.norm(-(self.rot as i64)),
            lin: self.lin.left(&neg),
        }
    }
}

/// Translation lattice of the gaps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Lattice {
    /// Z² (quads N = 4, stripes N = 2).
    Z2,
    /// 2Z² (`pure_quad`: singularities on Z²).
    TwoZ2,
    /// The checkerboard lattice D₂ = {(a, b) ∈ Z² : a + b even}: enough for the gaps of loops
    /// that end only at ±1/4 branch points or the boundary to put them on Z² (`pure_quad`).
    D2,
    /// Eisenstein integers a(1,0) + b(1/2, √3/2) (hexagons, N = 6).
    G6,
    /// 2 G6: enough for the gaps of loops ending at a half-turn branch point (±3/6) to put it
    /// on G6 (its fixed point is ½ (I − R_π)⁻¹ t = t / 2).
    TwoG6,
    /// (1 − e^{2πi/3}) G6 = √3 R_{−30°} G6, of index 3: the same for a third-turn branch point
    /// (±2/6), whose fixed point is (I − R_{2π/3})⁻¹ t.
    TurnedG6,
    /// Both at once (loops ending at a half-turn and a third-turn branch point):
    /// 2√3 R_{−30°} G6.
    TwoTurnedG6,
}

impl Lattice {
    pub fn nearest(self, p: [f64; 2]) -> [f64; 2] {
        match self {
            Lattice::Z2 => [p[0].round(), p[1].round()],
            Lattice::TwoZ2 => [2.0 * (p[0] / 2.0).round(), 2.0 * (p[1] / 2.0).round()],
            Lattice::D2 => {
                let r = [p[0].round(), p[1].round()];
                if (r[0] + r[1]).rem_euclid(2.0) == 0.0 {
                    return r;
                }
                // Odd: the nearest of the four neighbours one step along an axis.
                [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]
                    .iter()
                    .map(|d| [r[0] + d[0], r[1] + d[1]])
                    .min_by(|a, b| {
                        let da = (a[0] - p[0]).hypot(a[1] - p[1]);
                        let db = (b[0] - p[0]).hypot(b[1] - p[1]);
                        da.total_cmp(&db)
                    })
                    .unwrap_or(r)
            }
            Lattice::G6 => {
                let s3 = 3f64.sqrt();
                let b = 2.0 * p[1] / s3;
                let a = p[0] - 0.5 * b;
                let (a0, b0) = (a.floor(), b.floor());
                let mut best = [0.0; 2];
                let mut bd = f64::INFINITY;
                for (da, db) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
                    let (aa, bb) = (a0 + da, b0 + db);
                    let q = [aa + 0.5 * bb, bb * s3 / 2.0];
                    let d = (q[0] - p[0]).hypot(q[1] - p[1]);
                    if d < bd {
                        bd = d;
                        best = q;
                    }
                }
                best
            }
            Lattice::TwoG6 | Lattice::TurnedG6 | Lattice::TwoTurnedG6 => {
                // G6 in the frame where the sublattice is G6.
                let (scale, turn) = self.g6_frame();
                let (c, s) = (turn.cos(), turn.sin());
                let q = [
                    (c * p[0] + s * p[1]) / scale,
                    (-s * p[0] + c * p[1]) / scale,
                ];
                let r = Lattice::G6.nearest(q);
                [scale * (c * r[0] - s * r[1]), scale * (s * r[0] + c * r[1])]
            }
        }
    }
    /// The shortest non-zero lattice vectors (the neighbours of 0).
    pub fn steps(self) -> Vec<[f64; 2]> {
        match self {
            Lattice::Z2 => vec![[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]],
            Lattice::TwoZ2 => vec![[2.0, 0.0], [-2.0, 0.0], [0.0, 2.0], [0.0, -2.0]],
            Lattice::D2 => vec![[1.0, 1.0], [-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0]],
            Lattice::G6 | Lattice::TwoG6 | Lattice::TurnedG6 | Lattice::TwoTurnedG6 => {
                let (scale, turn) = self.g6_frame();
                (0..6)
                    .map(|k| {
                        let a = std::f64::consts::FRAC_PI_3 * k as f64 + turn;
                        [scale * a.cos(), scale * a.sin()]
                    })
                    .collect()
            }
        }
    }
    /// A G6 sublattice as G6 scaled by `scale` and turned by `turn` (radians).
    fn g6_frame(self) -> (f64, f64) {
        let s3 = 3f64.sqrt();
        let turned = -std::f64::consts::FRAC_PI_6;
        match self {
            Lattice::TwoG6 => (2.0, 0.0),
            Lattice::TurnedG6 => (s3, turned),
            Lattice::TwoTurnedG6 => (2.0 * s3, turned),
            _ => (1.0, 0.0),
        }
    }
    /// The lattice every gap and transition lies in: Z² would be enough for the map to be
    /// seamless; with 2Z² (`pure_quad`) the gaps are in D₂ or 2Z² (see `QuadCover`'s
    /// `gap_lattices`), which is what puts the branch points on Z².
    pub fn transitions(self) -> Lattice {
        match self {
            Lattice::TwoZ2 => Lattice::D2,
            Lattice::TwoG6 | Lattice::TurnedG6 | Lattice::TwoTurnedG6 => Lattice::G6,
            l => l,
        }
    }
    pub fn distance(self, p: [f64; 2]) -> f64 {
        let q = self.nearest(p);
        (q[0] - p[0]).hypot(q[1] - p[1])
    }
}

#[cfg(test)]
mod tests {
    use super::Lattice;

    /// A deterministic scatter of numbers in [−10, 10) (xorshift from `seed`).
    fn scatter(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 20.0 - 10.0
        }
    }

    /// D₂'s nearest point is in D₂, no farther than 1, and no farther than any D₂ point of a
    /// neighbourhood (brute force); a ±1/4 monodromy's fixed point is on Z² for every
    /// translation in D₂ and off it for every other one, which is why D₂ suffices there.
    #[test]
    fn checkerboard_rounding_and_quarter_turn_fixed_points() {
        let mut rand = scatter(0x9e3779b97f4a7c15);
        for _ in 0..2000 {
            let p = [rand(), rand()];
            let q = Lattice::D2.nearest(p);
            assert_eq!((q[0] + q[1]).rem_euclid(2.0), 0.0, "{p:?} -> {q:?}");
            let d = (q[0] - p[0]).hypot(q[1] - p[1]);
            assert!(d <= 1.0 + 1e-12, "{p:?} -> {q:?}");
            assert!((Lattice::D2.distance(p) - d).abs() < 1e-12);
            for a in -12..=12 {
                for b in -12..=12 {
                    if (a + b) % 2 == 0 {
                        let e = (a as f64 - p[0]).hypot(b as f64 - p[1]);
                        assert!(d <= e + 1e-12, "{p:?}: {q:?} but ({a}, {b})");
                    }
                }
            }
            assert!(Lattice::TwoZ2.distance(p) <= 2f64.sqrt() + 1e-12);
        }
        // x ↦ Rx + t with R the quarter turn (x, y) ↦ (−y, x) fixes ½(t₀ − t₁, t₀ + t₁).
        for t0 in -5i64..=5 {
            for t1 in -5i64..=5 {
                let fixed = [(t0 - t1) as f64 / 2.0, (t0 + t1) as f64 / 2.0];
                let on_z2 = fixed.iter().all(|x| x.fract() == 0.0);
                let t = [t0 as f64, t1 as f64];
                assert_eq!(on_z2, Lattice::D2.distance(t) == 0.0, "t = {t:?}");
                // Fixed indeed: R·fixed + t = fixed.
                assert_eq!([-fixed[1] + t[0], fixed[0] + t[1]], fixed);
            }
        }
        for l in [Lattice::Z2, Lattice::TwoZ2, Lattice::D2, Lattice::G6] {
            for s in l.steps() {
                assert!(l.distance(s) < 1e-12, "{l:?} step {s:?}");
            }
        }
    }

    /// The G6 sublattices: each rounding lands in G6 and in the sublattice, is the nearest of
    /// the sublattice's points around (brute force over G6), and the half-turn (third-turn)
    /// monodromy x ↦ R x + t with t in 2 G6 ((1 − e^{2πi/3}) G6) fixes a point of G6, while
    /// for some t in G6 it does not.
    #[test]
    fn hexagonal_sublattices_put_half_and_third_turn_fixed_points_on_g6() {
        let mut rand = scatter(0x2545f4914f6cdd1d);
        let s3 = 3f64.sqrt();
        let on_g6 = |q: [f64; 2]| Lattice::G6.distance(q) < 1e-9;
        // (1 − R)⁻¹ t for a rotation by `angle`.
        let fixed = |angle: f64, t: [f64; 2]| {
            let (c, s) = (angle.cos(), angle.sin());
            let (a, b, d) = (1.0 - c, s, 1.0 - c);
            let det = a * d + b * b;
            [(d * t[0] - b * t[1]) / det, (b * t[0] + a * t[1]) / det]
        };
        let g6: Vec<[f64; 2]> = (-16..=16)
            .flat_map(|a| (-16..=16).map(move |b| [a as f64 + 0.5 * b as f64, b as f64 * s3 / 2.0]))
            .collect();
        let pi = std::f64::consts::PI;
        for (lattice, angles) in [
            (Lattice::TwoG6, vec![pi]),
            (Lattice::TurnedG6, vec![2.0 * pi / 3.0, -2.0 * pi / 3.0]),
            (Lattice::TwoTurnedG6, vec![pi, 2.0 * pi / 3.0]),
        ] {
            let members: Vec<[f64; 2]> = g6
                .iter()
                .copied()
                .filter(|&q| lattice.distance(q) < 1e-9)
                .collect();
            assert!(
                members.len() > 10 && members.len() < g6.len() / 2,
                "{lattice:?}"
            );
            for step in lattice.steps() {
                assert!(on_g6(step) && lattice.distance(step) < 1e-9, "{lattice:?}");
            }
            for _ in 0..500 {
                let p = [rand(), rand()];
                let q = lattice.nearest(p);
                assert!(on_g6(q) && lattice.distance(q) < 1e-9, "{lattice:?}: {q:?}");
                let d = (q[0] - p[0]).hypot(q[1] - p[1]);
                for m in &members {
                    assert!(d <= (m[0] - p[0]).hypot(m[1] - p[1]) + 1e-9, "{lattice:?}");
                }
                for &angle in &angles {
                    assert!(
                        on_g6(fixed(angle, q)),
                        "{lattice:?}: t = {q:?}, turn {angle}"
                    );
                }
            }
            // Plain G6 translations do not do it: [1, 0] is fixed off G6 by a half or third turn.
            for &angle in &angles {
                assert!(!on_g6(fixed(angle, [1.0, 0.0])), "{lattice:?}");
            }
        }
    }
}
