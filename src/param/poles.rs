//! Singularities of positive integral index, poles (thesis sec. 4.3, alg. 6, eq. 4.3).
//!
//! A pole (index k/N with k a positive multiple of N, e.g. the +1 vortex at the north pole of a
//! sphere in polar coordinates) is no branch point: the matchings do not see it, and no
//! piecewise-linear map on triangles has the vortex its frames ask for (fig. 4.14, left). Alg. 6:
//! 1. [`open`]: every outgoing edge of the pole is cut open, so each star triangle gets a copy of
//!    the pole of its own (fig. 4.17) and the star becomes a hole of a new boundary loop;
//! 2. QuadCover runs on that mesh unchanged (the holes give the cut graph the paths a winding
//!    coordinate needs);
//! 3. [`close`]: each star triangle (p, a_j, a_{j+1}) becomes the quad (a_j, a_{j+1}, q_{j+1},
//!    q_j) whose inner vertices q_j sit at p (fig. 4.15) and take eq. 4.3's texture coordinates,
//!    the average of the two pole copies beside the star edge (p, a_j), moved into one chart by
//!    the transition around a_j; the map is bilinear on those quads ([`Pole::bilinear`]).
//!
//! Negative integral indices (saddles, e.g. −2/2) are representable by PL maps and stay as they
//! are.

use glam::DVec3;
use serde::Serialize;

use crate::mesh::TriMesh;

use super::rot::{M2, Rots, apply};
use super::{EdgeTransition, ParamError, Parameterization};

/// A treated pole: its star's triangles are bilinear quads in the output.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Pole {
    pub vertex: usize,
    /// The index (a positive integer: +1 for a vortex of one turn).
    pub index: f64,
    /// The star's faces counter-clockwise: face `faces[j]` is (p, a_j, a_{j+1}).
    pub faces: Vec<usize>,
    /// The ring a_j (`ring[j]` is the vertex after p in `faces[j]`).
    pub ring: Vec<usize>,
    /// Per star face its quad (a_j, a_{j+1}, q_{j+1}, q_j) in that face's chart (eq. 4.3).
    pub quads: Vec<[[f64; 2]; 4]>,
}

impl Pole {
    /// The bilinear map of star face j at (s, t) ∈ [0, 1]²: s runs from a_j to a_{j+1}, t from
    /// the outer edge (t = 0) to the pole (t = 1). Returns (texture coordinates, position);
    /// the position is (1 − t)((1 − s) a_j + s a_{j+1}) + t p, the star triangle.
    pub fn bilinear(&self, mesh: &TriMesh, j: usize, s: f64, t: f64) -> ([f64; 2], DVec3) {
        let q = &self.quads[j];
        let lerp =
            |a: [f64; 2], b: [f64; 2], x: f64| [a[0] + (b[0] - a[0]) * x, a[1] + (b[1] - a[1]) * x];
        let outer = lerp(q[0], q[1], s);
        let inner = lerp(q[3], q[2], s);
        let a = mesh.position(self.ring[j]);
        let b = mesh.position(self.ring[(j + 1) % self.ring.len()]);
        let p = mesh.position(self.vertex);
        (lerp(outer, inner, t), (a + (b - a) * s) * (1.0 - t) + p * t)
    }

    /// Whether the texture quad of star face j folds: the bilinear map is injective and
    /// orientation preserving exactly when its four corner triangles are positive (its Jacobian
    /// determinant is affine in s and t, so its corners bound it).
    pub fn quad_folded(&self, j: usize) -> bool {
        let q = &self.quads[j];
        (0..4).any(|k| {
            let (a, b, c) = (q[(k + 3) % 4], q[k], q[(k + 1) % 4]);
            let cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
            cross <= 0.0 || cross.is_nan()
        })
    }
}

/// Where a vertex of [`Tessellation`] lies on the input mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Locus {
    Vertex(usize),
    /// In the interior of an input edge.
    Edge(usize),
    /// In the interior of an input face.
    Face(usize),
    /// On the collapsed inner edge of a pole's quads (the pole itself, `poles[i]`).
    PoleRing(usize),
}

/// The pole stars' bilinear quads cut into k × k cells of two triangles each (per corner texture
/// coordinates, as the rest of the map): a PL map as close to the bilinear one as k makes it,
/// for renderers and extraction, which take triangles.
#[derive(Clone, Debug, Default)]
pub struct Tessellation {
    pub positions: Vec<DVec3>,
    pub loci: Vec<Locus>,
    pub triangles: Vec<[u32; 3]>,
    /// Per corner 3t + c.
    pub uv: Vec<[f64; 2]>,
    /// Per triangle the input (star) face it lies in.
    pub face: Vec<usize>,
}

/// Tessellates every pole's quads into k × k cells. The innermost row of positions sits at
/// t = `inner` instead of 1 (its texture coordinates stay at t = 1): `inner` < 1 keeps the
/// triangles non-degenerate (a tiny hole of that relative size around the pole, for extraction,
/// which welds its ring back into the pole); 1 draws the exact star.
pub fn tessellate(mesh: &TriMesh, poles: &[Pole], k: usize, inner: f64) -> Tessellation {
    let k = k.max(1);
    let mut t = Tessellation::default();
    for (pi, pole) in poles.iter().enumerate() {
        let d = pole.faces.len();
        // Node (j, a, b), a ∈ 0..=k along s, b ∈ 0..=k along t; shared along the sides with the
        // neighbouring quads (side a = k of quad j is side a = 0 of quad j + 1), and
        // every ring row node of the outer edge is its own.
        let mut side: Vec<Vec<u32>> = vec![Vec::new(); d];
        let node = |t: &mut Tessellation, locus: Locus, pos: DVec3| -> u32 {
            t.positions.push(pos);
            t.loci.push(locus);
            (t.positions.len() - 1) as u32
        };
        let star_edge = |j: usize| {
            // Edge (p, a_j): in face j, the halfedge leaving p.
            let f = pole.faces[j];
            let h = (0..3)
                .map(|c| 3 * f + c)
                .find(|&h| mesh.from(h) == pole.vertex)
                .unwrap_or(3 * f);
            mesh.edge(h)
        };
        for j in 0..d {
            let e = star_edge(j);
            side[j] = (0..=k)
                .map(|b| {
                    let tt = b as f64 / k as f64;
                    let (_, pos) = pole.bilinear(mesh, j, 0.0, tt.min(inner));
                    let locus = match b {
                        0 => Locus::Vertex(pole.ring[j]),
                        b if b == k => Locus::PoleRing(pi),
                        _ => Locus::Edge(e),
                    };
                    node(&mut t, locus, pos)
                })
                .collect();
        }
        for j in 0..d {
            let f = pole.faces[j];
            // grid[a][b] for rows b ≥ 1; row 0 is the input edge (a_j, a_{j+1}) alone, so the
            // tessellation meets the unchanged neighbour face across it without T-junctions.
            let mut grid = vec![vec![0u32; k + 1]; k + 1];
            for b in 0..=k {
                grid[0][b] = side[j][b];
                grid[k][b] = side[(j + 1) % d][b];
            }
            for a in 1..k {
                for b in 1..=k {
                    let (s, tt) = (a as f64 / k as f64, b as f64 / k as f64);
                    let (_, pos) = pole.bilinear(mesh, j, s, tt.min(inner));
                    let locus = if b == k {
                        Locus::PoleRing(pi)
                    } else {
                        Locus::Face(f)
                    };
                    grid[a][b] = node(&mut t, locus, pos);
                }
            }
            let uv_at = |(a, b): (usize, usize)| {
                pole.bilinear(mesh, j, a as f64 / k as f64, b as f64 / k as f64)
                    .0
            };
            let push = |t: &mut Tessellation, tri: [(usize, usize); 3]| {
                t.triangles.push(tri.map(|(x, y)| grid[x][y]));
                t.uv.extend(tri.map(uv_at));
                t.face.push(f);
            };
            // Counter-clockwise: s runs a_j → a_{j+1} (the face's orientation), t towards p.
            // Row 0: fans from a_j and a_{j+1} onto row 1.
            let m = k / 2;
            for a in 0..k {
                let apex = if a < m { 0 } else { k };
                push(&mut t, [(apex, 0), (a + 1, 1), (a, 1)]);
            }
            push(&mut t, [(0, 0), (k, 0), (m, 1)]);
            for a in 0..k {
                for b in 1..k {
                    push(&mut t, [(a, b), (a + 1, b), (a + 1, b + 1)]);
                    push(&mut t, [(a, b), (a + 1, b + 1), (a, b + 1)]);
                }
            }
        }
    }
    t
}

/// Vertices of positive integral index: interior, holonomy 0, index ≥ 1.
pub(crate) fn is_pole(holonomy: u8, index: f64) -> bool {
    holonomy == 0 && index > 0.5
}

/// Which candidate poles alg. 6 can treat: the star is a closed fan of distinct interior ring
/// vertices, no ring vertex is another treated pole or on another treated star, and no
/// constraint curve passes through the pole (`blocked`). Returns (treated, untreated).
pub(crate) fn treatable(
    mesh: &TriMesh,
    candidates: &[usize],
    blocked: &[bool],
) -> (Vec<usize>, Vec<usize>) {
    let mut used = vec![false; mesh.n_vertices()];
    let (mut ok, mut not) = (Vec::new(), Vec::new());
    for &p in candidates {
        let ring: Vec<usize> = mesh.outgoing(p).map(|h| mesh.to(h)).collect();
        let mut sorted = ring.clone();
        sorted.sort_unstable();
        sorted.dedup();
        let good = !mesh.is_boundary_vertex(p)
            && !blocked.get(p).copied().unwrap_or(false)
            && ring.len() >= 3
            && sorted.len() == ring.len()
            && !used[p]
            && ring
                .iter()
                .all(|&a| !mesh.is_boundary_vertex(a) && !used[a]);
        if good {
            used[p] = true;
            for &a in &ring {
                used[a] = true;
            }
            ok.push(p);
        } else {
            not.push(p);
        }
    }
    (ok, not)
}

/// The mesh with every pole's star cut open (alg. 6, line 5): the first star face keeps the
/// pole's vertex, the others get copies appended after the input's vertices. Faces, their order
/// and corner order are the input's (so per-corner data and halfedge indices carry over).
pub(crate) fn open(mesh: &TriMesh, poles: &[usize]) -> Result<TriMesh, ParamError> {
    let mut positions = mesh.positions().to_vec();
    let mut faces = mesh.faces().to_vec();
    for &p in poles {
        for (j, h) in mesh.outgoing(p).enumerate() {
            if j > 0 {
                faces[h / 3][h % 3] = positions.len() as u32;
                positions.push(mesh.position(p));
            }
        }
    }
    let (n, f) = (positions.len(), faces.len());
    let opened = TriMesh::from_triangles(positions, faces)
        .map_err(|e| ParamError::InvalidInput(format!("cutting the poles' stars open: {e}")))?;
    if opened.n_vertices() != n || opened.n_faces() != f {
        return Err(ParamError::InvalidInput(
            "cutting the poles' stars open changed the mesh's elements".into(),
        ));
    }
    Ok(opened)
}

/// The matchings on the opened mesh's edges (halfedges are shared; cut edges are boundary).
pub(crate) fn open_matchings(mesh: &TriMesh, opened: &TriMesh, matchings: &[i32]) -> Vec<i32> {
    (0..opened.n_edges())
        .map(|e| match opened.edge_halfedges(e) {
            (h0, Some(_)) => matchings[mesh.edge(h0)],
            _ => 0,
        })
        .collect()
}

/// The opened mesh's solution as the input's (alg. 6, lines 7–9): the quads and their eq. 4.3
/// coordinates, transitions per input edge, pole copies named by their pole in the cut paths,
/// star faces counted as folded by their quads. `singularities` are the input's.
pub(crate) fn close(
    mesh: &TriMesh,
    opened: &TriMesh,
    rots: &Rots,
    poles: &[(usize, f64)],
    mut p: Parameterization,
) -> Parameterization {
    let n = rots.n as i64;
    let uv = &p.uv;
    let mut stars = Vec::with_capacity(poles.len());
    // Transitions per input edge: the opened mesh's where the edge is still interior.
    let mut transitions: Vec<EdgeTransition> = (0..mesh.n_edges())
        .map(|e| {
            let (h0, _) = mesh.edge_halfedges(e);
            let e2 = opened.edge(h0);
            p.transitions.get(e2).copied().unwrap_or_default()
        })
        .collect();
    for &(pv, index) in poles {
        let hs: Vec<usize> = mesh.outgoing(pv).collect();
        let d = hs.len();
        let faces: Vec<usize> = hs.iter().map(|&h| mesh.face_of(h)).collect();
        let ring: Vec<usize> = hs.iter().map(|&h| mesh.to(h)).collect();
        // Per star edge k = (p, a_k), between faces k − 1 and k: the transition T_k from chart
        // k to chart k − 1 around a_k's outer side, x ↦ R^ρ x + τ.
        let mut trans: Vec<(i64, [f64; 2])> = Vec::with_capacity(d);
        for k in 0..d {
            let target = faces[(k + d - 1) % d];
            let mut cur = mesh.next(hs[k]); // a_k → a_{k+1}, leaving a_k in face k
            let mut rho = 0i64;
            let mut steps = 0;
            while opened.face_of(cur) != target && steps <= 64 {
                let Some(t) = opened.twin(cur) else { break };
                let e = opened.edge(cur);
                let (h0, _) = opened.edge_halfedges(e);
                let r = p.transitions.get(e).map_or(0, |x| x.rotation as i64);
                rho += if h0 == cur { r } else { -r };
                cur = opened.next(t);
                steps += 1;
            }
            let m = rots.get(rho);
            let (ck, ck1) = (mesh.next(hs[k]), mesh.prev(hs[(k + d - 1) % d]));
            // ck: a_k's corner in face k; ck1: a_k's corner in face k − 1.
            let ra = apply(m, uv[ck]);
            trans.push((rho.rem_euclid(n), [uv[ck1][0] - ra[0], uv[ck1][1] - ra[1]]));
        }
        // q_k in chart k (eq. 4.3).
        let mut q_here = Vec::with_capacity(d);
        for k in 0..d {
            let (rho, tau) = trans[k];
            let mi = rots.get(-rho);
            let pk = uv[hs[k]];
            let pk1 = uv[hs[(k + d - 1) % d]];
            let back = apply(mi, [pk1[0] - tau[0], pk1[1] - tau[1]]);
            let q = [(pk[0] + back[0]) / 2.0, (pk[1] + back[1]) / 2.0];
            q_here.push(q);
            // The input edge (p, a_k): uv_{face(h1)} = R^t uv_{face(h0)} + translation.
            let e = mesh.edge(hs[k]);
            let (h0, _) = mesh.edge_halfedges(e);
            transitions[e] = if mesh.face_of(h0) == faces[k] {
                EdgeTransition {
                    rotation: rho.rem_euclid(n) as u8,
                    translation: tau,
                }
            } else {
                let t = apply(mi, tau);
                EdgeTransition {
                    rotation: (-rho).rem_euclid(n) as u8,
                    translation: [-t[0], -t[1]],
                }
            };
        }
        let outer: Vec<[[f64; 2]; 2]> = hs
            .iter()
            .map(|&h| [uv[mesh.next(h)], uv[mesh.prev(h)]])
            .collect();
        let maps: Vec<(M2, [f64; 2])> = trans.iter().map(|&(r, t)| (*rots.get(r), t)).collect();
        unfold_quads(&outer, &maps, &mut q_here);
        let quads = (0..d)
            .map(|j| {
                let k = (j + 1) % d;
                let (m, t) = &maps[k];
                let qb = apply(m, q_here[k]);
                [
                    outer[j][0],
                    outer[j][1],
                    [qb[0] + t[0], qb[1] + t[1]],
                    q_here[j],
                ]
            })
            .collect();
        stars.push(Pole {
            vertex: pv,
            index,
            faces,
            ring,
            quads,
        });
    }
    // Folds: star faces by their quads.
    let folded = super::untangle::folded(&p.uv);
    let mut star_face = vec![false; mesh.n_faces()];
    for s in &stars {
        for &f in &s.faces {
            star_face[f] = true;
        }
    }
    let quad_folds: usize = stars
        .iter()
        .map(|s| (0..s.faces.len()).filter(|&j| s.quad_folded(j)).count())
        .sum();
    p.flipped_faces = folded.iter().filter(|&&f| !star_face[f]).count() + quad_folds;
    // Cut paths: pole copies by their pole.
    let mut owner: Vec<usize> = (0..mesh.n_vertices()).collect();
    for &(pv, _) in poles {
        for (j, h) in mesh.outgoing(pv).enumerate() {
            if j > 0 {
                let c = opened.faces()[h / 3][h % 3] as usize;
                if owner.len() <= c {
                    owner.resize(c + 1, usize::MAX);
                }
                owner[c] = pv;
            }
        }
    }
    for path in &mut p.cut_paths {
        for v in path.iter_mut() {
            *v = owner.get(*v).copied().unwrap_or(*v);
        }
    }
    p.transitions = transitions;
    p.poles = stars;
    p
}

/// One pole quad as read back from a file: the mesh face it replaces, its four corners' mesh
/// vertices (a, b, p, p) and texture coordinates (a, b, q_{j+1}, q_j).
#[derive(Clone, Copy, Debug)]
pub struct FileQuad {
    pub face: usize,
    pub vertices: [usize; 3],
    pub uv: [[f64; 2]; 4],
}

/// The poles of a map read back from a file whose star faces are quads `a b p p` (what
/// `write_uv_obj` writes). Every face of each pole's star must be such a quad, in the face's
/// orientation. The index is not in the file: 0.
pub fn poles_from_quads(mesh: &TriMesh, quads: &[FileQuad]) -> Result<Vec<Pole>, String> {
    let mut by_face = std::collections::HashMap::new();
    let mut pole_vertices = std::collections::BTreeSet::new();
    for q in quads {
        if q.face >= mesh.n_faces() || q.vertices.iter().any(|&v| v >= mesh.n_vertices()) {
            return Err(format!("pole quad of face {} is out of range", q.face));
        }
        by_face.insert(q.face, q);
        pole_vertices.insert(q.vertices[2]);
    }
    let mut out = Vec::with_capacity(pole_vertices.len());
    for p in pole_vertices {
        if mesh.is_boundary_vertex(p) {
            return Err(format!(
                "pole quads around vertex {p}, which is on the boundary"
            ));
        }
        let (mut faces, mut ring, mut uvs) = (Vec::new(), Vec::new(), Vec::new());
        for h in mesh.outgoing(p) {
            let f = mesh.face_of(h);
            let (a, b) = (mesh.to(h), mesh.to(mesh.next(h)));
            let Some(q) = by_face.get(&f) else {
                return Err(format!(
                    "vertex {p} has pole quads, but its star face {f} is a triangle"
                ));
            };
            if q.vertices != [a, b, p] {
                return Err(format!(
                    "the pole quad of face {f} does not run a_j, a_j+1, p, p around vertex {p}"
                ));
            }
            faces.push(f);
            ring.push(a);
            uvs.push(q.uv);
        }
        out.push(Pole {
            vertex: p,
            index: 0.0,
            faces,
            ring,
            quads: uvs,
        });
    }
    Ok(out)
}

/// The smallest corner cross product of a quad (positive for every corner: the bilinear map
/// is injective and orientation preserving).
fn min_corner(q: &[[f64; 2]; 4]) -> f64 {
    (0..4)
        .map(|k| {
            let (a, b, c) = (q[(k + 3) % 4], q[k], q[(k + 1) % 4]);
            (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
        })
        .fold(f64::INFINITY, f64::min)
}

/// Eq. 4.3 places the inner corners q_k at the average of the pole copies beside star edge k;
/// where the outer ring runs backwards (a jittery field right at the pole) a quad can fold even
/// though every opened triangle is positive. The q_k are free (nothing outside the star sees
/// them), so each one of a folded quad moves, within a box the size of its distance to a_k, to
/// where the smaller corner of its two quads is largest (grid search, refined three times),
/// sweeping until no quad folds. `outer[j]`: a_j, a_{j+1} in chart j; `maps[k]`: chart k to
/// chart k − 1; `q[k]`: q_k in chart k.
fn unfold_quads(outer: &[[[f64; 2]; 2]], maps: &[(M2, [f64; 2])], q: &mut [[f64; 2]]) {
    let d = q.len();
    let before = |q: &[[f64; 2]], k: usize| {
        let (m, t) = &maps[k];
        let x = apply(m, q[k]);
        [x[0] + t[0], x[1] + t[1]]
    };
    let quad = |q: &[[f64; 2]], j: usize| {
        let k = (j + 1) % d;
        [outer[j][0], outer[j][1], before(q, k), q[j]]
    };
    let folds = |q: &[[f64; 2]]| {
        (0..d)
            .filter(|&j| {
                min_corner(&quad(q, j)).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            })
            .count()
    };
    let start = folds(q);
    if start == 0 {
        return;
    }
    // A margin in squared ring edge lengths, so that corners end clearly positive.
    let ring: f64 = outer
        .iter()
        .map(|e| (e[1][0] - e[0][0]).hypot(e[1][1] - e[0][1]))
        .sum::<f64>()
        / d as f64;
    let margin = 1e-3 * ring * ring;
    // Σ of the corners' shortfall below the margin (concave in each q_k: corner crosses are
    // affine in one corner).
    let shortfall = |c: &[[f64; 2]; 4]| -> f64 {
        (0..4)
            .map(|i| {
                let (a, b, e) = (c[(i + 3) % 4], c[i], c[(i + 1) % 4]);
                let x = (b[0] - a[0]) * (e[1] - b[1]) - (b[1] - a[1]) * (e[0] - b[0]);
                (x - margin).min(0.0)
            })
            .sum()
    };
    let original = q.to_vec();
    let mut trial = q.to_vec();
    for _ in 0..20 {
        if folds(q) == 0 {
            break;
        }
        for k in 0..d {
            let prev = (k + d - 1) % d;
            trial.copy_from_slice(q);
            let mut score = |x: [f64; 2]| {
                trial[k] = x;
                shortfall(&quad(&trial, k)) + shortfall(&quad(&trial, prev))
            };
            let mut best = (score(q[k]), q[k]);
            if best.0 >= 0.0 {
                continue;
            }
            let mut r = 2.0 * ring;
            for _ in 0..4 {
                let centre = best.1;
                for i in -8..=8 {
                    for j in -8..=8 {
                        let x = [
                            centre[0] + r * i as f64 / 8.0,
                            centre[1] + r * j as f64 / 8.0,
                        ];
                        let s = score(x);
                        if s > best.0 {
                            best = (s, x);
                        }
                    }
                }
                r /= 4.0;
            }
            q[k] = best.1;
        }
    }
    if folds(q) >= start {
        q.copy_from_slice(&original);
    }
}
