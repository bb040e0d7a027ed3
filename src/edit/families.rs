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
            let sides = mesh
                .halfedge_to(a, x)
                .zip(mesh.halfedge_to(x, b))
                .map(|(h_in, h_out)| (h_in, h_out, d_in, d_out))
                .or_else(|| {
                    mesh.halfedge_to(b, x)
                        .zip(mesh.halfedge_to(x, a))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::constraint::CurveOrigin;
    use crate::field::smoothing::nearest_turns;
    use crate::mesh::generate;

    /// An 8 × 4 grid, folded by 90° along its middle row (y = 2) when `folded`, and the curve
    /// along that row.
    fn crease(folded: bool) -> (TriMesh, Curve) {
        let mut mesh = generate::grid(8, 4, 8.0, 4.0);
        if folded {
            let p: Vec<DVec3> = (0..mesh.n_vertices())
                .map(|v| {
                    let q = mesh.position(v);
                    if q.y > 2.0 {
                        DVec3::new(q.x, 2.0, q.y - 2.0)
                    } else {
                        q
                    }
                })
                .collect();
            mesh.set_positions(p);
        }
        let curve = Curve {
            id: 0,
            vertices: (0..=8).map(|i| 2 * 9 + i).collect(),
            closed: false,
            kind: CurveKind::Geometric,
            origin: CurveOrigin::Drawn,
        };
        (mesh, curve)
    }

    /// A field along the crease everywhere changes no family. One whose angles turn by
    /// `turn` steps of 2π/N on the faces past x = 4 while its matchings stay those of the
    /// unturned field (a singularity at the crease's middle vertex spending `turn` steps on
    /// the faces on the left) changes family there when `turn` is not a multiple of N/2; on a
    /// flat grid (no crease) nothing is counted.
    #[test]
    fn a_turn_of_the_frames_along_a_crease_is_a_change_of_family() {
        for (n, turn, folded, expected) in [
            (6, 0, true, 0),
            (6, 1, true, 1),
            (6, 2, true, 1),
            (6, 3, true, 0),
            (4, 1, true, 1),
            (4, 2, true, 0),
            (6, 1, false, 0),
        ] {
            let (mesh, curve) = crease(folded);
            let bases = FaceBases::new(&mesh);
            let tr = EdgeTransport::new(&mesh, &bases);
            let along: Vec<f64> = (0..mesh.n_faces())
                .map(|f| bases.angle_of(f, DVec3::X))
                .collect();
            let turns = nearest_turns(&tr, &along, TAU / n as f64);
            let theta: Vec<f64> = along
                .iter()
                .enumerate()
                .map(|(f, &a)| {
                    let past = mesh.face(f).iter().all(|&v| mesh.position(v).x >= 4.0);
                    a + if past {
                        turn as f64 * TAU / n as f64
                    } else {
                        0.0
                    }
                })
                .collect();
            let count = crease_family_changes(&mesh, &bases, &tr, &theta, &turns, n, [&curve]);
            assert_eq!(count, expected, "N = {n}, {turn} steps, folded {folded}");
        }
    }
}
