//! Constraint curves (thesis sec. 4.4): edge paths on the mesh that a parameter line must follow
//! exactly (`geometric`) or whose layout only is prescribed (`combinatorial`: the singularities
//! on one parameter line, a closed loop that closes instead of spiralling). Plain data: the
//! curves themselves ([`Curve`]), their checks ([`check_path`]), edge paths between picked
//! vertices ([`shortest_edge_path`]), sharp features and boundary loops as curves ([`detect`]) and
//! the field's alignment to geometric curves ([`alignment`]). QuadCover's use of them
//! (eq. 4.5–4.9, alg. 7) is in `param::constraints`.

pub mod align;
pub mod detect;
mod path;

use serde::{Deserialize, Serialize};

use crate::mesh::TriMesh;

pub use align::{
    AcuteCorners, CurveAlignment, acute_corners, alignment, faces_reached, stripe_across,
    stripe_corners,
};
pub use detect::{DetectedCurve, boundary_curves, detect_features, feature_edges};
pub use path::{edge_key, path_edges, shortest_edge_path, shortest_edge_path_avoiding};

/// Whether a parameter line runs exactly along the curve, or only the layout it implies holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CurveKind {
    #[default]
    Geometric,
    Combinatorial,
}

impl CurveKind {
    pub fn label(self) -> &'static str {
        match self {
            CurveKind::Geometric => "geometric",
            CurveKind::Combinatorial => "combinatorial",
        }
    }
    pub fn toggled(self) -> CurveKind {
        match self {
            CurveKind::Geometric => CurveKind::Combinatorial,
            CurveKind::Combinatorial => CurveKind::Geometric,
        }
    }
}

/// Where a curve came from: drawn (or written in a project), detected as a sharp feature, or a
/// piece of a boundary loop (`align_boundary`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CurveOrigin {
    #[default]
    Drawn,
    Feature,
    Boundary,
}

/// A constraint curve over mesh edges, in mesh vertex indices: consecutive vertices share an
/// edge, and so do the last and the first when `closed` (the first is not repeated).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Curve {
    pub id: u32,
    pub vertices: Vec<usize>,
    pub closed: bool,
    pub kind: CurveKind,
    pub origin: CurveOrigin,
}

impl Curve {
    /// The curve's edges as (from, to) vertex pairs, in order (the closing one last).
    pub fn segments(&self) -> Vec<(usize, usize)> {
        let v = &self.vertices;
        let mut s: Vec<(usize, usize)> = v.windows(2).map(|w| (w[0], w[1])).collect();
        if self.closed && v.len() > 2 {
            s.push((v[v.len() - 1], v[0]));
        }
        s
    }
}

/// Per mesh edge: whether one of `curves` runs along it (what remesh relaxation keeps its
/// vertices on), or an empty list without curves (relaxation then uses the sharp edges).
pub fn curve_edges<'a>(mesh: &TriMesh, curves: impl IntoIterator<Item = &'a Curve>) -> Vec<bool> {
    let mut out = Vec::new();
    for c in curves {
        if out.is_empty() {
            out = vec![false; mesh.n_edges()];
        }
        for (a, b) in c.segments() {
            if let Some(h) = halfedge_between(mesh, a, b) {
                out[mesh.edge(h)] = true;
            }
        }
    }
    out
}

/// Rings around faces a repair left folded within which [`curves_beside`] names curves (the
/// CLI's warning and report, the editor's panel).
pub const BESIDE_FOLDS_RINGS: usize = 2;

/// Curves named in a message: "curve 3", "curves 0, 1, 2", or the first eight and "and N
/// more".
pub fn curves_named(ids: &[u32]) -> String {
    const NAMED: usize = 8;
    let shown: Vec<String> = ids.iter().take(NAMED).map(u32::to_string).collect();
    let noun = if ids.len() == 1 { "curve" } else { "curves" };
    if ids.len() > NAMED {
        format!("{noun} {} and {} more", shown.join(", "), ids.len() - NAMED)
    } else {
        format!("{noun} {}", shown.join(", "))
    }
}

/// The ids of the `curves` with a vertex within `rings` rings of the vertices of `faces`,
/// sorted: what to name when a map under curves keeps folded faces (the repair could not undo
/// them; the usual cause is a singularity on or beside such a curve, where its line has to turn
/// or squeeze the faces between).
pub fn curves_beside<'a>(
    mesh: &TriMesh,
    curves: impl IntoIterator<Item = &'a Curve>,
    faces: &[usize],
    rings: usize,
) -> Vec<u32> {
    let mut near = vec![false; mesh.n_vertices()];
    let front: Vec<usize> = faces
        .iter()
        .filter(|&&f| f < mesh.n_faces())
        .flat_map(|&f| mesh.face(f))
        .collect();
    for &v in &front {
        near[v] = true;
    }
    mesh.mark_rings(&mut near, front, rings);
    let mut ids: Vec<u32> = curves
        .into_iter()
        .filter(|c| {
            c.vertices
                .iter()
                .any(|&v| near.get(v).copied().unwrap_or(false))
        })
        .map(|c| c.id)
        .collect();
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// A closed geometric curve turning by less than this at each vertex is a round rim
/// ([`rim_faces`]): the corner angle `detect` splits curves at.
pub const RIM_TURN_DEG: f64 = 50.0;

/// A round rim is a crease: its faces' normals differ by this much on average (degrees).
pub const RIM_BEND_DEG: f64 = 20.0;

/// The faces along round rims: closed geometric curves that turn by less than
/// [`RIM_TURN_DEG`] at every vertex and run over interior edges only, bent by
/// [`RIM_BEND_DEG`] or more on average (a cylinder's or a hole's rim, a crease all round), both
/// sides of each edge.
/// The field drops the curvature guidance their crease's bend reaches for N = 6
/// (`field::FieldParams::rim_aligned`).
pub fn rim_faces<'a>(mesh: &TriMesh, curves: impl IntoIterator<Item = &'a Curve>) -> Vec<u32> {
    let mut out = Vec::new();
    let limit = RIM_TURN_DEG.to_radians().cos();
    for c in curves {
        if c.kind != CurveKind::Geometric || !c.closed || c.vertices.len() < 3 {
            continue;
        }
        let segments = c.segments();
        let dir =
            |(a, b): (usize, usize)| (mesh.position(b) - mesh.position(a)).normalize_or_zero();
        let round = (0..segments.len())
            .all(|i| dir(segments[i]).dot(dir(segments[(i + 1) % segments.len()])) > limit);
        // (An aligned boundary loop has no crease, and no bend in the shape operators.)
        let faces: Option<Vec<[usize; 2]>> = segments
            .iter()
            .map(|&(a, b)| {
                let h = halfedge_between(mesh, a, b)?;
                Some([mesh.face_of(h), mesh.face_of(mesh.twin(h)?)])
            })
            .collect();
        let Some(faces) = faces.filter(|_| round) else {
            continue;
        };
        // A crease: a drawn loop on a smooth surface has no bend of its own in the operators.
        let bend = faces
            .iter()
            .map(|&[f, g]| {
                let c = mesh
                    .face_normal(f)
                    .dot(mesh.face_normal(g))
                    .clamp(-1.0, 1.0);
                c.acos().to_degrees()
            })
            .sum::<f64>()
            / faces.len() as f64;
        if bend >= RIM_BEND_DEG {
            out.extend(faces.iter().flatten().map(|&f| f as u32));
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// A halfedge of the edge between `a` and `b` (the one from `a` to `b` when it exists; on a
/// boundary edge only one of the two does), if they share an edge.
pub fn halfedge_between(mesh: &TriMesh, a: usize, b: usize) -> Option<usize> {
    if a >= mesh.n_vertices() || b >= mesh.n_vertices() {
        return None;
    }
    mesh.halfedge_to(a, b).or_else(|| mesh.halfedge_to(b, a))
}

/// What is wrong with a curve's vertex list ([`check_path`]), by 0-based positions in it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PathError {
    TooShort {
        closed: bool,
        need: usize,
        len: usize,
    },
    OutOfRange {
        position: usize,
        vertex: usize,
        n_vertices: usize,
    },
    NoEdge {
        positions: [usize; 2],
        vertices: [usize; 2],
    },
    EdgeTwice {
        positions: [usize; 2],
        vertices: [usize; 2],
    },
}

impl PathError {
    /// The message with the vertex at each position named by `name(position)` (e.g. the
    /// file's vertex numbers where the check ran on the repaired mesh's).
    pub fn describe(&self, name: impl Fn(usize) -> usize) -> String {
        match *self {
            PathError::TooShort { closed, need, len } => format!(
                "a{} curve needs at least {need} vertices, this one has {len}",
                if closed { " closed" } else { "n open" }
            ),
            PathError::OutOfRange {
                position,
                n_vertices,
                ..
            } => format!(
                "vertex {} at position {position} is out of range (the mesh has {n_vertices} vertices)",
                name(position)
            ),
            PathError::NoEdge {
                positions: [i, j], ..
            } => format!(
                "vertices {} and {} at positions {i} and {j} share no edge",
                name(i),
                name(j)
            ),
            PathError::EdgeTwice {
                positions: [i, j], ..
            } => format!(
                "the edge {}-{} at positions {i} and {j} is used twice",
                name(i),
                name(j)
            ),
        }
    }

    fn vertex_at(&self, position: usize) -> usize {
        match *self {
            PathError::OutOfRange { vertex, .. } => vertex,
            PathError::NoEdge {
                positions,
                vertices,
            }
            | PathError::EdgeTwice {
                positions,
                vertices,
            } => vertices[(positions[1] == position) as usize],
            PathError::TooShort { .. } => position,
        }
    }
}

impl std::fmt::Display for PathError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.describe(|p| self.vertex_at(p)))
    }
}

impl std::error::Error for PathError {}

/// Checks a curve's vertex list against the mesh: at least two vertices (three when closed),
/// every vertex on the mesh, consecutive ones sharing an edge, no edge used twice.
pub fn check_path(mesh: &TriMesh, vertices: &[usize], closed: bool) -> Result<(), PathError> {
    let need = if closed { 3 } else { 2 };
    if vertices.len() < need {
        return Err(PathError::TooShort {
            closed,
            need,
            len: vertices.len(),
        });
    }
    if let Some((position, &vertex)) = vertices
        .iter()
        .enumerate()
        .find(|(_, v)| **v >= mesh.n_vertices())
    {
        return Err(PathError::OutOfRange {
            position,
            vertex,
            n_vertices: mesh.n_vertices(),
        });
    }
    let n = vertices.len();
    let mut used = std::collections::HashSet::new();
    let pairs = (0..n - 1)
        .map(|i| (i, i + 1))
        .chain(closed.then_some((n - 1, 0)));
    for (i, j) in pairs {
        let (a, b) = (vertices[i], vertices[j]);
        let (positions, pair) = ([i, j], [a, b]);
        let Some(h) = halfedge_between(mesh, a, b).filter(|_| a != b) else {
            return Err(PathError::NoEdge {
                positions,
                vertices: pair,
            });
        };
        if !used.insert(mesh.edge(h)) {
            return Err(PathError::EdgeTwice {
                positions,
                vertices: pair,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    /// Curves are named when one of their vertices is within the rings of a face's vertices,
    /// and only then.
    #[test]
    fn curves_beside_faces_are_named() {
        // A 10 × 10 grid, vertices row by row (11 per row); face 0 is at the corner (0, 0).
        let m = generate::grid(10, 10, 1.0, 1.0);
        let curve = |id: u32, vertices: Vec<usize>| Curve {
            id,
            vertices,
            closed: false,
            kind: CurveKind::Geometric,
            origin: CurveOrigin::Drawn,
        };
        // Row 2 (one ring up from the corner face's top vertices at row 1), and row 8 beside
        // the opposite corner.
        let near = curve(3, (22..=26).collect());
        let far = curve(7, (94..=98).collect());
        let curves = [far, near];
        assert_eq!(curves_beside(&m, &curves, &[0], 1), vec![3]);
        assert_eq!(curves_beside(&m, &curves, &[0], 0), Vec::<u32>::new());
        assert_eq!(curves_beside(&m, &curves, &[], 5), Vec::<u32>::new());
        // A face beyond the mesh is ignored.
        assert_eq!(curves_beside(&m, &curves, &[10_000], 3), Vec::<u32>::new());
        let last = m.n_faces() - 1;
        assert_eq!(curves_beside(&m, &curves, &[0, last], 2), vec![3, 7]);
        assert_eq!(curves_named(&[3]), "curve 3");
        assert_eq!(curves_named(&[3, 7]), "curves 3, 7");
        let many: Vec<u32> = (0..11).collect();
        assert_eq!(
            curves_named(&many),
            "curves 0, 1, 2, 3, 4, 5, 6, 7 and 3 more"
        );
    }

    #[test]
    fn paths_are_checked_with_their_positions() {
        let m = generate::grid(4, 4, 1.0, 1.0);
        // Vertices of the grid are numbered row by row (5 per row).
        assert!(check_path(&m, &[0, 1, 2], false).is_ok());
        let e = check_path(&m, &[0, 1, 7], false).unwrap_err();
        assert_eq!(
            e.to_string(),
            "vertices 1 and 7 at positions 1 and 2 share no edge"
        );
        // Named by other numbers (a file's), position by position.
        assert_eq!(
            e.describe(|p| [10, 11, 17][p]),
            "vertices 11 and 17 at positions 1 and 2 share no edge"
        );
        assert!(check_path(&m, &[0], false).is_err());
        let e = check_path(&m, &[0, 99], false).unwrap_err().to_string();
        assert!(e.contains("vertex 99 at position 1"), "{e}");
        let e = check_path(&m, &[0, 1, 0], false).unwrap_err().to_string();
        assert_eq!(e, "the edge 1-0 at positions 1 and 2 is used twice");
        // Boundary edges in both directions.
        assert!(check_path(&m, &[1, 0], false).is_ok());
        assert!(check_path(&m, &[0, 1, 6, 5], true).is_ok());
    }
}
