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
        rot(
            self.n,
            self.corner_rot[c],
            DVec2::new(1.0, 0.618_033_988_749_894_8),
        )
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
        cross(dd, self.perturbation(c)) > 0.0
    }
}
