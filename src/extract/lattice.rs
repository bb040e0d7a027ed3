//! Lattice coordinates, rotations and per-halfedge transitions derived from per-corner UVs.

use glam::DVec2;

use super::ExtractError;
use crate::mesh::TriMesh;

const SQRT3: f64 = 1.732_050_807_568_877_2;

/// A transition `p ↦ R^rot p + t` from the chart of a halfedge's face to its twin's.
#[derive(Clone, Copy, Debug, Default)]
pub struct Transition {
    pub rot: u8,
    pub t: [f64; 2],
}

/// A snapped seamless parameterization in lattice coordinates.
pub struct Param<'a> {
    pub mesh: &'a TriMesh,
    pub n: u8,
    /// Per corner (`3 f + k`) lattice coordinates.
    pub lat: Vec<DVec2>,
    /// Per halfedge (with a twin) the transition into the twin's chart.
    pub trans: Vec<Transition>,
    /// Per vertex: its reference corner lies on a lattice point.
    pub on_lattice: Vec<bool>,
    /// Per corner: rotation from the vertex's reference corner chart to this corner's chart.
    pub corner_rot: Vec<u8>,
    /// Per vertex: its symbolic perturbation in its reference corner's chart (`perturbation`).
    pert: Vec<DVec2>,
    /// Per face: positively oriented, non-degenerate in lattice space.
    pub face_ok: Vec<bool>,
    /// Lattice directions in counter-clockwise order; `dirs[i + n/2] = -dirs[i]`.
    pub dirs: Vec<[i64; 2]>,
    pub tol: f64,
}

/// Rotation by 2π/N of lattice coordinates (an integer matrix).
pub fn rot1(n: u8, p: DVec2) -> DVec2 {
    match n {
        4 => DVec2::new(-p.y, p.x),
        6 => DVec2::new(-p.y, p.x + p.y),
        _ => -p,
    }
}

pub fn rot(n: u8, r: u8, mut p: DVec2) -> DVec2 {
    for _ in 0..(r % n) {
        p = rot1(n, p);
    }
    p
}

pub fn roti(n: u8, r: u8, d: [i64; 2]) -> [i64; 2] {
    let p = rot(n, r, DVec2::new(d[0] as f64, d[1] as f64));
    [p.x.round() as i64, p.y.round() as i64]
}

pub fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

pub fn dv(d: [i64; 2]) -> DVec2 {
    DVec2::new(d[0] as f64, d[1] as f64)
}

/// Lattice coordinates to (u, v).
pub fn to_uv(n: u8, p: DVec2) -> DVec2 {
    if n == 6 {
        DVec2::new(p.x + 0.5 * p.y, 0.5 * SQRT3 * p.y)
    } else {
        p
    }
}

fn from_uv(n: u8, p: [f64; 2]) -> DVec2 {
    if n == 6 {
        let b = 2.0 * p[1] / SQRT3;
        DVec2::new(p[0] - 0.5 * b, b)
    } else {
        DVec2::new(p[0], p[1])
    }
}

/// Per vertex, in its reference corner's chart: the direction its symbolic perturbation moves it
/// (`Param::left`). Generic (off every lattice direction) for most vertices. A vertex at the end
/// of a boundary edge that lies on a lattice line moves into the surface instead, the line thus
/// just outside: a boundary on a grid line (aligned boundaries) is the remesh's boundary, joined
/// by the boundary chain, and no grid edge runs along it. With generic perturbations the two ends
/// of such an edge could fall on opposite sides, the line then crossing the boundary edge
/// where no crossing is made, and the faces there were patched.
fn perturbations(
    mesh: &TriMesh,
    lat: &[DVec2],
    n: u8,
    dirs: &[[i64; 2]],
    corner_rot: &[u8],
) -> Vec<DVec2> {
    let generic = DVec2::new(1.0, 0.618_033_988_749_894_8);
    let on_int = |x: f64| (x - x.round()).abs() <= 1e-9;
    let mut inward = vec![DVec2::ZERO; mesh.n_vertices()];
    for h in 0..mesh.n_halfedges() {
        if mesh.twin(h).is_some() {
            continue;
        }
        let (a, b) = (lat[h], lat[mesh.next(h)]);
        let Some(&d) = dirs[..(n as usize / 2).max(1)]
            .iter()
            .find(|&&d| cross(dv(d), b - a).abs() <= 1e-9 && on_int(cross(dv(d), a)))
        else {
            continue;
        };
        let e = if dv(d).dot(b - a) < 0.0 {
            -dv(d)
        } else {
            dv(d)
        };
        // Left of the halfedge is inside; the tangential part keeps it off every lattice
        // direction (at a corner of two such edges the sum is inside both).
        let into = rot1(n, e) + 0.381_966_011_250_105 * e;
        for c in [h, mesh.next(h)] {
            let back = (n - corner_rot[c] % n) % n;
            inward[mesh.from(c)] += rot(n, back, into);
        }
    }
    inward
        .into_iter()
        .map(|w| if w == DVec2::ZERO { generic } else { w })
        .collect()
}

fn snap(x: f64, tol: f64) -> f64 {
    let r = x.round();
    if (x - r).abs() <= tol { r } else { x }
}

impl<'a> Param<'a> {
    pub fn new(mesh: &'a TriMesh, uv: &[[f64; 2]], n: u8, tol: f64) -> Result<Self, ExtractError> {
        let lat: Vec<DVec2> = uv
            .iter()
            .map(|&p| {
                let q = from_uv(n, p);
                let mut s = DVec2::new(snap(q.x, tol), snap(q.y, tol));
                if n == 6 {
                    // Third line family a + b = k.
                    let sum = s.x + s.y;
                    let r = sum.round();
                    if (sum - r).abs() <= tol && sum != r {
                        if s.x.fract() == 0.0 {
                            s.y = r - s.x;
                        } else {
                            s.x = r - s.y;
                        }
                    }
                }
                s
            })
            .collect();
        let dirs: Vec<[i64; 2]> = match n {
            4 => vec![[1, 0], [0, 1], [-1, 0], [0, -1]],
            6 => vec![[1, 0], [0, 1], [-1, 1], [-1, 0], [0, -1], [1, -1]],
            _ => vec![[0, 1], [0, -1]],
        };
        let nh = mesh.n_halfedges();
        let mut trans = vec![Transition::default(); nh];
        let (mut bad, mut total, mut worst) = (0usize, 0usize, 0f64);
        for h in 0..nh {
            let Some(g) = mesh.twin(h) else { continue };
            let (ai, bi) = (lat[h], lat[mesh.next(h)]);
            let (aj, bj) = (lat[mesh.next(g)], lat[g]);
            let (ei, ej) = (bi - ai, bj - aj);
            let mut best = (f64::INFINITY, 0u8);
            for r in 0..n {
                let err = (rot(n, r, ei) - ej).length();
                if err < best.0 {
                    best = (err, r);
                }
            }
            let r = best.1;
            let t = 0.5 * ((aj - rot(n, r, ai)) + (bj - rot(n, r, bi)));
            let tr = t.round();
            let err = best.0.max((t - tr).length());
            if h < g {
                total += 1;
                if err > 1e-3 {
                    bad += 1;
                    worst = worst.max(err);
                }
            }
            trans[h] = Transition {
                rot: r,
                t: [tr.x, tr.y],
            };
        }
        if bad > 0 && bad * 20 > total.max(1) {
            return Err(ExtractError::NotSeamless { bad, total, worst });
        }
        let mut on_lattice = vec![false; mesh.n_vertices()];
        let mut corner_rot = vec![0u8; 3 * mesh.n_faces()];
        for v in 0..mesh.n_vertices() {
            let h0 = mesh.vertex_halfedge(v);
            let p = lat[h0];
            on_lattice[v] = p.x.fract() == 0.0 && p.y.fract() == 0.0;
            let mut r = 0u8;
            let mut prev: Option<usize> = None;
            for h in mesh.outgoing(v) {
                if let Some(hp) = prev {
                    // Crossing from face(hp) to face(h) through halfedge prev(hp).
                    r = (r + trans[mesh.prev(hp)].rot) % n;
                }
                corner_rot[h] = r;
                prev = Some(h);
            }
        }
        let pert = perturbations(mesh, &lat, n, &dirs, &corner_rot);
        let face_ok = (0..mesh.n_faces())
            .map(|f| {
                let (a, b, c) = (lat[3 * f], lat[3 * f + 1], lat[3 * f + 2]);
                let area = cross(b - a, c - a);
                let scale = (b - a).length_squared().max((c - a).length_squared());
                area > 1e-12 * scale.max(1e-300)
            })
            .collect();
        Ok(Param {
            mesh,
            n,
            lat,
            trans,
            on_lattice,
            corner_rot,
            pert,
            face_ok,
            dirs,
            tol,
        })
    }

    /// Maps a point of face(h)'s chart into face(twin h)'s chart.
    pub fn map_point(&self, h: usize, p: DVec2) -> DVec2 {
        let tr = self.trans[h];
        rot(self.n, tr.rot, p) + DVec2::new(tr.t[0], tr.t[1])
    }

    pub fn map_dir(&self, h: usize, d: [i64; 2]) -> [i64; 2] {
        roti(self.n, self.trans[h].rot, d)
    }

    /// The symbolic perturbation of the vertex at corner `c`, in that corner's chart.
    pub fn perturbation(&self, c: usize) -> DVec2 {
        rot(self.n, self.corner_rot[c], self.pert[self.mesh.from(c)])
    }

    /// Whether corner `c` (lattice point `p` in its face's chart) is on the left of the line
    /// through `q` with direction `d`. Vertices on the line are perturbed symbolically (the same
    /// physical displacement in every chart), so all charts agree.
    pub fn left(&self, c: usize, q: DVec2, d: [i64; 2]) -> bool {
        let dd = dv(d);
        let val = cross(dd, self.lat[c] - q);
        if val.abs() > 1e-9 {
            return val > 0.0;
        }
        cross(dd, self.perturbation(self.side_corner(c, q, dd))) > 0.0
    }

    /// The corner whose perturbation puts corner `c` (on the line through `q` along `dd`) on a
    /// side. A vertex on a lattice point is a grid point: it stays where it is. When the line
    /// runs along an edge of `c`'s face that ends there, the edge moves as a whole, by its other
    /// end's perturbation (both ends on lattice points: the lower-numbered vertex's), so every
    /// grid point on the edge, and the vertices at its ends, see the grid edge along it on one
    /// and the same side. With each end perturbed by its own displacement the ends disagreed: on
    /// a boundary edge along a grid line (aligned boundaries, creases) one end had a slot along
    /// the edge and the other none, and the face there was patched.
    fn side_corner(&self, c: usize, q: DVec2, dd: DVec2) -> usize {
        let mesh = self.mesh;
        let v = mesh.from(c);
        if !self.on_lattice[v] {
            return c;
        }
        for n in [mesh.next(c), mesh.prev(c)] {
            if cross(dd, self.lat[n] - q).abs() <= 1e-9 {
                let w = mesh.from(n);
                return if !self.on_lattice[w] || w < v { n } else { c };
            }
        }
        c
    }
}
