//! Curve edits (thesis sec. 4.4): adding, removing and retyping constraint curves, detected
//! sharp features and boundary alignment. Purely combinatorial: they change the state's curve
//! set; [`Base::solve`](super::Base::solve) aligns the field to the geometric ones and
//! QuadCover runs under their constraints (alg. 7).

use super::{Base, Edit, EditError, EditState};
use crate::constraint::{
    Curve, CurveKind, CurveOrigin, DetectedCurve, boundary_curves, check_path, detect_features,
};

/// The id the next generated curve gets: one more than the largest in use.
fn next_id(state: &EditState) -> u32 {
    state.curves.keys().next_back().map_or(0, |&k| k + 1)
}

fn replace_origin(state: &mut EditState, origin: CurveOrigin, found: Vec<DetectedCurve>) {
    state.curves.retain(|_, c| c.origin != origin);
    for d in found {
        let id = next_id(state);
        state.curves.insert(
            id,
            Curve {
                id,
                vertices: d.vertices,
                closed: d.closed,
                kind: CurveKind::Geometric,
                origin,
            },
        );
    }
}

impl Base {
    /// Checks what an edit says about the mesh alone (a curve's vertices on the mesh and forming
    /// an edge path): what a broken project file gets wrong, as opposed to an edit that no longer
    /// applies to the state. Other edits pass.
    pub fn check_edit(&self, edit: &Edit) -> Result<(), String> {
        match edit {
            Edit::AddCurve {
                id,
                vertices,
                closed,
                ..
            } => self.curve_vertices(*id, vertices, *closed).map(|_| ()),
            _ => Ok(()),
        }
    }

    /// A curve's file vertices as mesh vertices, checked to be an edge path; the error names
    /// the curve, the positions and the file's vertex numbers.
    fn curve_vertices(&self, id: u32, file: &[usize], closed: bool) -> Result<Vec<usize>, String> {
        let mut mesh_vertices = Vec::with_capacity(file.len());
        for (i, &v) in file.iter().enumerate() {
            match self.mesh_vertex(v) {
                Some(m) => mesh_vertices.push(m),
                None => {
                    return Err(format!(
                        "curve {id}: vertex {v} at position {i} is not on the mesh"
                    ));
                }
            }
        }
        check_path(self.mesh(), &mesh_vertices, closed)
            .map_err(|why| format!("curve {id}: {}", why.describe(|p| file[p])))?;
        Ok(mesh_vertices)
    }

    /// The state after a curve edit; `None` for other edits.
    pub(crate) fn apply_curve_edit(
        &self,
        state: &EditState,
        edit: &Edit,
    ) -> Option<Result<EditState, EditError>> {
        let invalid = |m: String| Err(EditError::Invalid(m));
        let mut next = state.clone();
        let result = match edit {
            Edit::AddCurve {
                id,
                vertices,
                closed,
                kind,
            } => {
                if next.curves.contains_key(id) {
                    return Some(invalid(format!("curve {id} exists already")));
                }
                let mesh_vertices = match self.curve_vertices(*id, vertices, *closed) {
                    Ok(v) => v,
                    Err(why) => return Some(invalid(why)),
                };
                next.curves.insert(
                    *id,
                    Curve {
                        id: *id,
                        vertices: mesh_vertices,
                        closed: *closed,
                        kind: *kind,
                        origin: CurveOrigin::Drawn,
                    },
                );
                Ok(next)
            }
            Edit::RemoveCurve { id } => match next.curves.remove(id) {
                Some(_) => Ok(next),
                None => invalid(format!("there is no curve {id}")),
            },
            Edit::SetCurveKind { id, kind } => match next.curves.get_mut(id) {
                Some(c) => {
                    c.kind = *kind;
                    Ok(next)
                }
                None => invalid(format!("there is no curve {id}")),
            },
            Edit::DetectFeatures { angle_deg } => {
                if !(angle_deg.is_finite() && *angle_deg > 0.0 && *angle_deg < 180.0) {
                    return Some(invalid(format!(
                        "angle_deg = {angle_deg}: the feature angle must lie strictly between 0 and 180 degrees"
                    )));
                }
                replace_origin(
                    &mut next,
                    CurveOrigin::Feature,
                    detect_features(self.mesh(), *angle_deg, self.grid_size()),
                );
                Ok(next)
            }
            Edit::AlignBoundary { on } => {
                let found = if *on {
                    boundary_curves(self.mesh(), self.grid_size())
                } else {
                    Vec::new()
                };
                replace_origin(&mut next, CurveOrigin::Boundary, found);
                Ok(next)
            }
            _ => return None,
        };
        Some(result)
    }
}
