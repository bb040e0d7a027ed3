//! The field's side of geometric curves (alg. 7 needs a field along which the curve is a
//! parameter line): every face with an edge on a geometric curve takes the edge's direction as
//! an alignment constraint, strong enough that one of the N directions runs along it (on sharp
//! creases the curvature directions are unreliable anyway); the smoothing propagates it.

use glam::DVec3;

use super::{Curve, CurveKind, halfedge_between};
use crate::mesh::TriMesh;

/// One face's alignment to one curve edge: the unit edge direction (in the face's plane).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveAlignment {
    pub face: usize,
    pub direction: DVec3,
}

/// The alignments the geometric curves ask for: one per (face, curve edge) with the face on
/// either side of the edge, in curve and edge order (a face at a corner of a curve, or on two
/// curves, appears once per edge; the field combines them modulo its symmetry).
///
/// The direction is the curve's chord over `scale` (model units) beyond either end of the
/// edge, within the curve: a scanned boundary zigzags at the scale of its edges, and the
/// zigzag's edges, combined modulo 2π/N, would turn the field away from where the curve runs
/// (edges ±30° off the curve's course average to 45° off it for N = 4). `scale` = 0 takes
/// each edge's own direction.
pub fn alignment<'a>(
    mesh: &TriMesh,
    curves: impl IntoIterator<Item = &'a Curve>,
    scale: f64,
) -> Vec<CurveAlignment> {
    let mut out = Vec::new();
    for c in curves {
        if c.kind != CurveKind::Geometric {
            continue;
        }
        let segments = c.segments();
        let m = segments.len();
        let length = |i: usize| {
            let (a, b) = segments[i];
            (mesh.position(b) - mesh.position(a)).length()
        };
        // The curve's point at least `scale` beyond segment i's end (`forward`) or start.
        let reach = |i: usize, forward: bool| -> usize {
            let mut len = 0.0;
            let mut j = i;
            for _ in 1..m {
                if len >= scale {
                    break;
                }
                let next = if forward {
                    if j + 1 < m {
                        j + 1
                    } else if c.closed {
                        0
                    } else {
                        break;
                    }
                } else if j > 0 {
                    j - 1
                } else if c.closed {
                    m - 1
                } else {
                    break;
                };
                j = next;
                len += length(j);
            }
            if forward {
                segments[j].1
            } else {
                segments[j].0
            }
        };
        for (i, &(a, b)) in segments.iter().enumerate() {
            let Some(h) = halfedge_between(mesh, a, b) else {
                continue;
            };
            let edge = mesh.vector(h);
            let chord = if scale > 0.0 {
                mesh.position(reach(i, true)) - mesh.position(reach(i, false))
            } else {
                edge
            };
            // A chord that doubles back (a curve tighter than the scale) falls back to the
            // edge.
            let d = if chord.dot(edge) > 0.0 { chord } else { edge };
            let d = d.normalize_or_zero();
            if d == DVec3::ZERO {
                continue;
            }
            out.push(CurveAlignment {
                face: mesh.face_of(h),
                direction: d,
            });
            if let Some(t) = mesh.twin(h) {
                out.push(CurveAlignment {
                    face: mesh.face_of(t),
                    direction: -d,
                });
            }
        }
    }
    out
}
