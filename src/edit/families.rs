//! Where a designed field changes line family along a sharp crease.
//!
//! A geometric curve is one parameter line per run of one line family (`param::constraints`
//! splits it where the family changes, at a singularity on it). Along a straight crease of a
//! flat-faced part such a change is the mark of a field torn between the crease's alignment and
//! the crease's own bend: the curvature smoothing carries the bend (the direction across the
//! crease) into the flat faces beside it, and for six directions that is 30° off the crease's
//! line family, so the field turns by +30° or −30° between the two and nothing decides which.
//! A T extrusion with features at 40° (N = 6) got +1/6 singularities halfway down its stem's
//! creases that way and 4 241 folded faces after the repair; designed from the unsmoothed
//! shape operators (`FieldParams::raw_guidance`), which the edit model keeps when that halves
//! the count or the field's curl, none.

use std::f64::consts::TAU;

use glam::DVec3;

use crate::constraint::{Curve, CurveKind, RIM_BEND_DEG};
use crate::field::transport::{EdgeTransport, FaceBases};
use crate::mesh::TriMesh;

/// The halfedge from `a` to `b` (its face on the left of a → b).
fn directed(mesh: &TriMesh, a: usize, b: usize) -> Option<usize> {
    mesh.outgoing(a).find(|&h| mesh.to(h) == b)
}

/// Whether the edge of halfedge `h` is a crease: its two faces' normals at least
/// [`RIM_BEND_DEG`] apart.
fn bent(mesh: &TriMesh, h: usize) -> bool {
    mesh.twin(h).is_some_and(|t| {
        let c = mesh
            .face_normal(mesh.face_of(h))
            .dot(mesh.face_normal(mesh.face_of(t)));
        c.clamp(-1.0, 1.0).acos() >= RIM_BEND_DEG.to_radians()
    })
}

/// The frame index `k` of the face of `from` carried round their common start vertex, face by
/// face through the matchings (`turns`, first face to second), to the face of `to`; `None`
/// when the boundary comes first.
fn carried(
    mesh: &TriMesh,
    tr: &EdgeTransport,
    turns: &[i64],
    from: usize,
    to: usize,
    mut k: i64,
) -> Option<i64> {
    // `from` ends at the vertex; the next halfedge of its face leaves it.
    let mut g = mesh.next(from);
    for _ in 0..mesh.n_faces() {
        if g == to {
            return Some(k);
        }
        let t = mesh.twin(g)?;
        let e = mesh.edge(g);
        // Frame j of the first face of e is frame j − r of the second.
        k += if tr.faces[e][0] as usize == mesh.face_of(g) {
            -turns[e]
        } else {
            turns[e]
        };
        g = mesh.next(t);
    }
    None
}

/// How many vertices of the geometric curves, between two crease edges of one curve, have the
/// field (angles `theta` in the face bases, `turns`) run along the curve in two different line
/// families (directions modulo N/2) on either side of them. Each side's direction is the chord
/// over two curve edges (a jagged path zigzags about its course).
pub(crate) fn crease_family_changes<'a>(
    mesh: &TriMesh,
    bases: &FaceBases,
    tr: &EdgeTransport,
    theta: &[f64],
    turns: &[i64],
    n: u32,
    curves: impl IntoIterator<Item = &'a Curve>,
) -> usize {
    let step = TAU / n as f64;
    let families = (n as i64 / 2).max(1);
    let index = |h: usize, d: DVec3| {
        let f = mesh.face_of(h);
        ((bases.angle_of(f, d) - theta[f]) / step).round() as i64
    };
    let mut count = 0;
    for c in curves
        .into_iter()
        .filter(|c| c.kind == CurveKind::Geometric)
    {
        let v = &c.vertices;
        let m = v.len();
        if m < 3 {
            continue;
        }
        let at = |i: isize| -> Option<usize> {
            if c.closed {
                Some(v[i.rem_euclid(m as isize) as usize])
            } else {
                (0..m as isize).contains(&i).then(|| v[i as usize])
            }
        };
        let inner = if c.closed { 0..m } else { 1..m - 1 };
        for i in inner.map(|i| i as isize) {
            let (Some(a), Some(x), Some(b)) = (at(i - 1), at(i), at(i + 1)) else {
                continue;
            };
            let p = |q: usize| mesh.position(q);
            let d_in = p(x) - p(at(i - 2).unwrap_or(a));
            let d_out = p(at(i + 2).unwrap_or(b)) - p(x);
            // The faces on the curve's left, or on its right where the left is open.
            let sides = directed(mesh, a, x)
                .zip(directed(mesh, x, b))
                .map(|(h_in, h_out)| (h_in, h_out, d_in, d_out))
                .or_else(|| {
                    directed(mesh, b, x)
                        .zip(directed(mesh, x, a))
                        .map(|(h_in, h_out)| (h_in, h_out, -d_out, -d_in))
                });
            let Some((h_in, h_out, d_in, d_out)) = sides else {
                continue;
            };
            if !(bent(mesh, h_in) && bent(mesh, h_out)) {
                continue;
            }
            let Some(k) = carried(mesh, tr, turns, h_in, h_out, index(h_in, d_in)) else {
                continue;
            };
            if (k - index(h_out, d_out)).rem_euclid(families) != 0 {
                count += 1;
            }
        }
    }
    count
}
