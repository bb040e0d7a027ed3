//! Principal curvature per face from the edge shape operator (thesis sec. 3.1, after
//! Hildebrandt & Polthier / Cohen-Steiner & Morvan) and the reliability weights of eq. (3.4).

use glam::DVec3;
use rayon::prelude::*;

use super::transport::FaceBases;
use crate::mesh::TriMesh;

/// Principal curvatures per face (`k1 >= k2`, signed, convex = positive for outward normals) and
/// the angle of the `k1` direction in the face basis (the `k2` direction is at `+π/2`).
#[derive(Clone, Debug, Default)]
pub struct Curvature {
    pub k1: Vec<f64>,
    pub k2: Vec<f64>,
    pub dir1: Vec<f64>,
}

/// Symmetric 3x3 matrix stored as (xx, xy, xz, yy, yz, zz).
type Sym3 = [f64; 6];

fn outer(a: DVec3, w: f64) -> Sym3 {
    [
        w * a.x * a.x,
        w * a.x * a.y,
        w * a.x * a.z,
        w * a.y * a.y,
        w * a.y * a.z,
        w * a.z * a.z,
    ]
}

fn quad_form(s: &Sym3, a: DVec3, b: DVec3) -> f64 {
    a.x * (s[0] * b.x + s[1] * b.y + s[2] * b.z)
        + a.y * (s[1] * b.x + s[3] * b.y + s[4] * b.z)
        + a.z * (s[2] * b.x + s[4] * b.y + s[5] * b.z)
}

/// Eigen-decomposition of the symmetric 2x2 matrix [[a, b], [b, c]]:
/// (larger eigenvalue, smaller eigenvalue, angle of the larger one's eigenvector).
pub fn eig2(a: f64, b: f64, c: f64) -> (f64, f64, f64) {
    let mean = 0.5 * (a + c);
    let r = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    (mean + r, mean - r, 0.5 * (2.0 * b).atan2(a - c))
}

/// Every vertex's one ring (boundary vertices: both boundary neighbours), as compressed lists
/// walked once: the smoothing passes then read indices in order instead of walking halfedges
/// each time.
fn one_rings(mesh: &TriMesh) -> (Vec<usize>, Vec<u32>) {
    let rings: Vec<Vec<u32>> = (0..mesh.n_vertices())
        .into_par_iter()
        .map(|v| {
            let mut ring = Vec::with_capacity(8);
            let mut last = None;
            for h in mesh.outgoing(v) {
                ring.push(mesh.to(h) as u32);
                last = Some(h);
            }
            if mesh.is_boundary_vertex(v)
                && let Some(last) = last
            {
                ring.push(mesh.from(mesh.prev(last)) as u32);
            }
            ring
        })
        .collect();
    let mut ptr = Vec::with_capacity(rings.len() + 1);
    ptr.push(0);
    for r in &rings {
        ptr.push(ptr.last().copied().unwrap_or(0) + r.len());
    }
    (ptr, rings.concat())
}

/// One pass of neighbour averaging: each vertex's operator becomes the mean of itself and its
/// one-ring (ambient 3x3 tensors; the face step projects them to the tangent plane).
fn smooth_vertex_tensors(ring_ptr: &[usize], ring: &[u32], vs: &[Sym3]) -> Vec<Sym3> {
    (0..vs.len())
        .into_par_iter()
        .map(|v| {
            let mut s = vs[v];
            let neighbours = &ring[ring_ptr[v]..ring_ptr[v + 1]];
            for &u in neighbours {
                for k in 0..6 {
                    s[k] += vs[u as usize][k];
                }
            }
            let count = (neighbours.len() + 1) as f64;
            s.map(|x| x / count)
        })
        .collect()
}

impl Curvature {
    /// Principal curvatures per face. `smoothing` passes average each vertex's shape operator
    /// with its neighbours' first (0 = the thesis's eq. 3.2 as is): on scanned meshes the
    /// per-face operator is noisy at the scale of a few triangles, and noise there becomes
    /// singularities of the guided field.
    pub fn compute(mesh: &TriMesh, bases: &FaceBases, smoothing: usize) -> Curvature {
        let nv = mesh.n_vertices();
        // Eq. (3.1): S(e) = H_e (ê × N_e)(ê × N_e)^T, with N_e the normalised mean of the two face
        // normals and H_e = 2|e| cos(Θ_e/2) the integrated mean curvature, Θ_e the interior
        // dihedral angle (π for a flat edge), i.e. 2|e| sin(φ/2) with φ the angle between the
        // normals, signed positive on convex edges. Boundary edges contribute nothing.
        let edge_s: Vec<Option<Sym3>> = (0..mesh.n_edges())
            .into_par_iter()
            .map(|e| {
                let (h0, h1) = mesh.edge_halfedges(e);
                let h1 = h1?;
                let (ni, nj) = (
                    bases.normal[mesh.face_of(h0)],
                    bases.normal[mesh.face_of(h1)],
                );
                let d = mesh.vector(h0);
                let len = d.length();
                let ne = (ni + nj).normalize_or_zero();
                if len == 0.0 || ne == DVec3::ZERO {
                    return None;
                }
                let sin_half = (0.5 * (ni - nj).length()).min(1.0);
                let sign = if ni.cross(nj).dot(d) >= 0.0 {
                    1.0
                } else {
                    -1.0
                };
                let h = sign * 2.0 * len * sin_half;
                Some(outer((d / len).cross(ne), h))
            })
            .collect();
        // Vertex shape operator: sum over incident edges, normalised by (2/3) of the star area so
        // that the integrated edge quantities become curvatures (each edge is counted at two
        // vertices and each face at three).
        // Per vertex, in parallel: the outgoing halfedges reach every incident edge but a
        // boundary vertex's incoming boundary edge, which contributes nothing, and every
        // incident face once.
        let mut vs: Vec<Sym3> = (0..nv)
            .into_par_iter()
            .map(|v| {
                let (mut s, mut star) = ([0.0; 6], 0.0);
                for h in mesh.outgoing(v) {
                    if let Some(es) = &edge_s[mesh.edge(h)] {
                        for k in 0..6 {
                            s[k] += es[k];
                        }
                    }
                    star += mesh.face_area(mesh.face_of(h));
                }
                if star > 0.0 {
                    s.map(|x| x * 1.5 / star)
                } else {
                    [0.0; 6]
                }
            })
            .collect();
        let (ring_ptr, ring) = if smoothing > 0 {
            one_rings(mesh)
        } else {
            (Vec::new(), Vec::new())
        };
        for _ in 0..smoothing {
            vs = smooth_vertex_tensors(&ring_ptr, &ring, &vs);
        }
        // Eq. (3.2): S(t) = Σ ρ_jk S(e_jk) with ρ = 2/3 for the edges of t and 1/3 for edges
        // sharing one vertex — the mean of the three vertex operators.
        let data: Vec<(f64, f64, f64)> = (0..mesh.n_faces())
            .into_par_iter()
            .map(|f| {
                let mut s = [0.0; 6];
                for v in mesh.face(f) {
                    for k in 0..6 {
                        s[k] += vs[v][k] / 3.0;
                    }
                }
                let (e1, e2) = (bases.e1[f], bases.e2[f]);
                eig2(
                    quad_form(&s, e1, e1),
                    quad_form(&s, e1, e2),
                    quad_form(&s, e2, e2),
                )
            })
            .collect();
        let mut c = Curvature::default();
        for (k1, k2, d) in data {
            c.k1.push(k1);
            c.k2.push(k2);
            c.dir1.push(d);
        }
        c
    }

    /// Eq. (3.4): ω_i = |κ1 − κ2| / max_j |κ1 − κ2|, then all but the most reliable `fraction` of
    /// the faces where `candidate` holds are set to 0, and so are the umbilic ones among them
    /// ([`UMBILIC_RATIO`]).
    pub fn reliability(&self, fraction: f64, candidate: &[bool]) -> Vec<f64> {
        let aniso: Vec<f64> = self
            .k1
            .iter()
            .zip(&self.k2)
            .map(|(a, b)| (a - b).abs())
            .collect();
        let max = aniso.iter().cloned().fold(0.0, f64::max);
        if max <= 0.0 || !max.is_finite() || fraction <= 0.0 {
            return vec![0.0; aniso.len()];
        }
        let mut cand: Vec<f64> = aniso
            .iter()
            .zip(candidate)
            .filter(|(_, c)| **c)
            .map(|(a, _)| *a)
            .collect();
        if cand.is_empty() {
            return vec![0.0; aniso.len()];
        }
        let keep = ((fraction.min(1.0) * cand.len() as f64).ceil() as usize).clamp(1, cand.len());
        let idx = cand.len() - keep;
        let (_, thr, _) = cand.select_nth_unstable_by(idx, f64::total_cmp);
        let thr = (*thr).max(f64::MIN_POSITIVE);
        (0..aniso.len())
            .map(|f| {
                let a = aniso[f];
                let umbilic = a < UMBILIC_RATIO * (self.k1[f].abs() + self.k2[f].abs());
                if candidate[f] && a >= thr && !umbilic {
                    a / max
                } else {
                    0.0
                }
            })
            .collect()
    }
}

/// A face whose principal curvatures differ by less than this fraction of |κ1| + |κ2| is an
/// umbilic: its curvature directions are noise and guide nothing. Eq. (3.4) normalises by the
/// largest anisotropy, so on a surface that is umbilic everywhere (a sphere) the noise itself
/// became full-weight guidance: an icosphere's quad field had 88 singularities instead of 8.
/// Applied after the fraction is chosen, so that where the most reliable faces are not
/// umbilic nothing changes (the shared meshes' reliable faces are at 0.58 or more at their
/// 10th percentile; the sphere's at 0.001 or less).
pub const UMBILIC_RATIO: f64 = 0.1;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    /// The vertex operators the straightforward way (each edge added to both ends, each face's
    /// area to its three corners, one-rings collected), then eq. 3.2 per face.
    fn reference(mesh: &TriMesh, bases: &FaceBases, smoothing: usize) -> Curvature {
        let nv = mesh.n_vertices();
        let mut vs = vec![[0.0; 6]; nv];
        for e in 0..mesh.n_edges() {
            let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
                continue;
            };
            let (ni, nj) = (
                bases.normal[mesh.face_of(h0)],
                bases.normal[mesh.face_of(h1)],
            );
            let d = mesh.vector(h0);
            let ne = (ni + nj).normalize();
            let sign = if ni.cross(nj).dot(d) >= 0.0 {
                1.0
            } else {
                -1.0
            };
            let h = sign * 2.0 * d.length() * (0.5 * (ni - nj).length()).min(1.0);
            let s = outer((d / d.length()).cross(ne), h);
            for v in mesh.edge_vertices(e) {
                for k in 0..6 {
                    vs[v][k] += s[k];
                }
            }
        }
        let mut star = vec![0.0; nv];
        for f in 0..mesh.n_faces() {
            for v in mesh.face(f) {
                star[v] += mesh.face_area(f);
            }
        }
        for v in 0..nv {
            vs[v] = vs[v].map(|x| x * 1.5 / star[v]);
        }
        for _ in 0..smoothing {
            vs = (0..nv)
                .map(|v| {
                    let ring = mesh.one_ring(v);
                    let mut s = vs[v];
                    for &u in &ring {
                        for k in 0..6 {
                            s[k] += vs[u][k];
                        }
                    }
                    s.map(|x| x / (1 + ring.len()) as f64)
                })
                .collect();
        }
        let mut c = Curvature::default();
        for f in 0..mesh.n_faces() {
            let mut s = [0.0; 6];
            for v in mesh.face(f) {
                for k in 0..6 {
                    s[k] += vs[v][k] / 3.0;
                }
            }
            let (e1, e2) = (bases.e1[f], bases.e2[f]);
            let (k1, k2, d) = eig2(
                quad_form(&s, e1, e1),
                quad_form(&s, e1, e2),
                quad_form(&s, e2, e2),
            );
            c.k1.push(k1);
            c.k2.push(k2);
            c.dir1.push(d);
        }
        c
    }

    #[test]
    fn parallel_vertex_sums_match_the_edge_by_edge_definition_with_boundary() {
        // Open cylinder (two boundary loops) with wobbled vertices, so that every vertex,
        // boundary ones included, has a different operator.
        let mut mesh = generate::cylinder(1.0, 2.0, 24, 10);
        let wobbled = (0..mesh.n_vertices())
            .map(|v| {
                let p = mesh.position(v);
                p * (1.0 + 0.05 * (3.0 * p.z + v as f64).sin())
            })
            .collect();
        mesh.set_positions(wobbled);
        let bases = FaceBases::new(&mesh);
        for smoothing in [0, 2] {
            let (got, want) = (
                Curvature::compute(&mesh, &bases, smoothing),
                reference(&mesh, &bases, smoothing),
            );
            for f in 0..mesh.n_faces() {
                let scale = want.k1[f].abs().max(want.k2[f].abs()).max(1.0);
                assert!((got.k1[f] - want.k1[f]).abs() < 1e-12 * scale, "face {f}");
                assert!((got.k2[f] - want.k2[f]).abs() < 1e-12 * scale, "face {f}");
                if (want.k1[f] - want.k2[f]).abs() > 1e-6 {
                    assert!((got.dir1[f] - want.dir1[f]).abs() < 1e-9, "face {f}");
                }
            }
        }
    }
}
