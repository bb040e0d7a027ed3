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
pub fn alignment<'a>(
    mesh: &TriMesh,
    curves: impl IntoIterator<Item = &'a Curve>,
) -> Vec<CurveAlignment> {
    let mut out = Vec::new();
    for c in curves {
        if c.kind != CurveKind::Geometric {
            continue;
        }
        for (a, b) in c.segments() {
            let Some(h) = halfedge_between(mesh, a, b) else {
                continue;
            };
            let d = mesh.vector(h).normalize_or_zero();
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
