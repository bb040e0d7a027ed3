//! The output contract checked from the UVs alone (shared by the parameterization and edit
//! tests; included with `#[path]` so that other test crates do not carry it unused).

use std::f64::consts::TAU;

use quadcover::mesh::TriMesh;
use quadcover::param::Lattice;

pub fn rot(n: usize, k: usize, p: [f64; 2]) -> [f64; 2] {
    let (s, c) = (TAU * k as f64 / n as f64).sin_cos();
    [c * p[0] + s * p[1], -s * p[0] + c * p[1]]
}

/// Checks the output contract independently of the reported transitions: for every interior
/// edge some R^r and one lattice translation relate the two faces' corner UVs at both endpoints.
/// Returns the worst error over edges of the best r.
pub fn contract_error(mesh: &TriMesh, uv: &[[f64; 2]], n: usize, lattice: Lattice) -> f64 {
    let mut worst: f64 = 0.0;
    for e in 0..mesh.n_edges() {
        let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
            continue;
        };
        let (ia, ib, ja, jb) = (uv[h0], uv[mesh.next(h0)], uv[mesh.next(h1)], uv[h1]);
        let best = (0..n)
            .map(|r| {
                let (pa, pb) = (rot(n, r, ia), rot(n, r, ib));
                let ta = [ja[0] - pa[0], ja[1] - pa[1]];
                let tb = [jb[0] - pb[0], jb[1] - pb[1]];
                (ta[0] - tb[0]).hypot(ta[1] - tb[1]) + lattice.distance(ta)
            })
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(best);
    }
    worst
}

/// [`contract_error`] for a map with treated poles: at a pole the star faces are bilinear quads
/// whose inner corner on star edge (p, a_k) stands in for the faces' own pole corners (which are
/// not seamless), so across that edge the quads' corners must be related instead.
#[allow(dead_code)] // only the crates whose maps have poles use it
pub fn contract_error_with_poles(mesh: &TriMesh, p: &quadcover::param::Parameterization) -> f64 {
    let n = p.symmetry;
    // (face, pole vertex, other end of the star edge) -> the quad corner standing in for p.
    let mut inner = std::collections::HashMap::new();
    for pole in &p.poles {
        let d = pole.faces.len();
        for k in 0..d {
            inner.insert((pole.faces[k], pole.ring[k]), pole.quads[k][3]);
            inner.insert((pole.faces[k], pole.ring[(k + 1) % d]), pole.quads[k][2]);
        }
    }
    let at = |c: usize, other: usize| -> [f64; 2] {
        inner
            .get(&(mesh.face_of(c), other))
            .filter(|_| p.poles.iter().any(|x| x.vertex == mesh.from(c)))
            .copied()
            .unwrap_or(p.uv[c])
    };
    let mut worst: f64 = 0.0;
    for e in 0..mesh.n_edges() {
        let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
            continue;
        };
        let (a, b) = (mesh.from(h0), mesh.to(h0));
        let (ia, ib) = (at(h0, b), at(mesh.next(h0), a));
        let (ja, jb) = (at(mesh.next(h1), b), at(h1, a));
        let best = (0..n)
            .map(|r| {
                let (pa, pb) = (rot(n, r, ia), rot(n, r, ib));
                let ta = [ja[0] - pa[0], ja[1] - pa[1]];
                let tb = [jb[0] - pb[0], jb[1] - pb[1]];
                (ta[0] - tb[0]).hypot(ta[1] - tb[1]) + p.lattice.transitions().distance(ta)
            })
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(best);
    }
    worst
}
