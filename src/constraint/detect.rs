//! Sharp features and boundary loops as constraint curves (`detect_features`, `align_boundary`).
//!
//! Both detectors pick a set of mesh edges (feature edges, boundary edges) and chain them into
//! edge paths with the same rules:
//!
//! * A vertex is a **split point** when the number of chosen edges at it is not two (an end of a
//!   chain, or a junction of three or more), when the chain turns sharply there (the angle
//!   between the directions of the incoming and the outgoing edge exceeds [`SHARP_TURN_DEG`],
//!   measured in 3-D, and so does the angle between the chords to the chain's points a
//!   `scale` away on either side, so that a scanned boundary's zigzag at a scale below the
//!   grid's is no corner; of such turns closer than `scale` along the chain only the sharpest
//!   splits), and, for features only, when it is a boundary vertex (a crease meeting
//!   the boundary).
//! * Curves run between split points and never pass through one. A loop of chosen edges with no
//!   split point at all is one closed curve. A loop with exactly one split point is cut there
//!   and at the vertex half-way around (by edge count), giving two open curves, since a curve
//!   may repeat no vertex except through `closed`.
//! * Every chosen edge lies on exactly one curve. Features only: a connected set of feature
//!   edges shorter in total than [`MIN_FEATURE_CELLS`] times `scale` is dropped first
//!   ([`significant_feature_edges`]). On scans a dihedral threshold picks up single edges and
//!   short chains of noise (max-planck at 60°: 52 sets, most of them one to three edges), and
//!   a parameter line held along each of them folds the map around it. So is a set round a
//!   cone point ([`CONE_POINT_CELLS`], [`CONE_POINT_TURNS`]): next to a cone's apex the edges'
//!   dihedral angles exceed the threshold a few edges out, the finer the tessellation the
//!   nearer, so whether they were curves depended on the density. So is a set that is mostly
//!   no crease half a cell away ([`CreaseAngles`]): a ledge or step narrower than that (a
//!   boolean union of faceted primitives leaves such ledges), a ridge of a scan's noise.
//!   Boundary loops are never dropped.
//! * Output order is by the smallest edge id of each chain (the two halves of a loop with one
//!   split point come together, in walking order). Each chain is oriented along the first
//!   halfedge of its smallest edge, so boundary curves run with the surface on their left.
//!   Closed curves start at the start vertex of that halfedge.
//!
//! Every curve passes [`check_path`](super::check_path).

use glam::DVec3;

use crate::mesh::TriMesh;
use crate::mesh::disjoint::Disjoint;

/// A curve is split at a vertex where it turns by more than this (degrees): the angle between
/// the direction of the edge arriving at the vertex and that of the edge leaving it, in 3-D.
/// A cube corner in a boundary (90°) splits; a 24-gon (15° per vertex) does not.
pub const SHARP_TURN_DEG: f64 = 50.0;

/// A detected curve: vertices in order (the first not repeated when closed).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DetectedCurve {
    pub vertices: Vec<usize>,
    pub closed: bool,
}

/// Interior edges whose dihedral angle (between the two face normals) exceeds `angle_deg`.
pub fn feature_edges(mesh: &TriMesh, angle_deg: f64) -> Vec<usize> {
    let cos = angle_deg.to_radians().cos();
    (0..mesh.n_edges())
        .filter(|&e| {
            let (h0, h1) = mesh.edge_halfedges(e);
            h1.is_some_and(|h1| {
                let a = mesh.face_normal(mesh.face_of(h0));
                let b = mesh.face_normal(mesh.face_of(h1));
                a.dot(b) < cos
            })
        })
        .collect()
}

/// A connected set of feature edges shorter than this many grid cells in total is no feature
/// to align to (see the module documentation).
pub const MIN_FEATURE_CELLS: f64 = 4.0;

/// A connected set of feature edges within this many grid cells of one vertex that gathers a
/// cone point's curvature ([`CONE_POINT_TURNS`]) is that point's, not a crease.
pub const CONE_POINT_CELLS: f64 = 6.0;

/// The angle defect (in turns) within one grid cell of a set's most curved vertex from which
/// the set is a cone point's ([`CONE_POINT_CELLS`]): more than a box corner's quarter turn.
/// Round a cone's apex the edges' dihedral angles exceed any threshold for a few edges out
/// (more, the sharper the cone), whatever the tessellation, and a line held along each of
/// them folds the map: a cone of radius 1 and height 2 with features at 40° at 15 000 target
/// vertices, 9 curves and 161 folded faces; at 30 000, 57 000.
pub const CONE_POINT_TURNS: f64 = 1.0 / 3.0;

/// [`feature_edges`] without the connected sets of them (edges sharing a vertex) that are no
/// crease at the grid's scale `scale` (model units; 0 keeps every set): those shorter in total
/// than [`MIN_FEATURE_CELLS`] cells, those whose bend mostly flattens out half a cell away
/// ([`FAINT_SHARE`], [`CreaseAngles`]), and those round a cone point ([`CONE_POINT_CELLS`],
/// [`CONE_POINT_TURNS`]; sets on the boundary are kept). In edge id order.
pub fn significant_feature_edges(mesh: &TriMesh, angle_deg: f64, scale: f64) -> Vec<usize> {
    significant_feature_edges_with(mesh, angle_deg, scale, &mut CreaseAngles::new(mesh, scale))
}

/// [`significant_feature_edges`] with the crease angles at the grid's scale kept in `creases`
/// (made for the same mesh and `scale`), so that asking again at another angle measures only
/// the edges not measured before: the editor's preview asks at every step of its slider.
pub fn significant_feature_edges_with(
    mesh: &TriMesh,
    angle_deg: f64,
    scale: f64,
    creases: &mut CreaseAngles,
) -> Vec<usize> {
    let edges = feature_edges(mesh, angle_deg);
    if scale <= 0.0 || edges.is_empty() {
        return edges;
    }
    creases.measure(mesh, &edges);
    let kept = (CREASE_KEPT_FRACTION * angle_deg).to_radians();
    let persists: Vec<bool> = edges.iter().map(|&e| creases.angle[e] > kept).collect();
    // The connected sets (edges sharing a vertex), by the smallest vertex of each.
    let mut sets = Disjoint::new(mesh.n_vertices());
    for &e in &edges {
        let [a, b] = mesh.edge_vertices(e);
        sets.union(a, b);
    }
    let mut length = vec![0.0; mesh.n_vertices()];
    let mut faint = vec![0.0; mesh.n_vertices()];
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); mesh.n_vertices()];
    for (&e, &persists) in edges.iter().zip(&persists) {
        let [a, b] = mesh.edge_vertices(e);
        let root = sets.find(a);
        let l = (mesh.position(b) - mesh.position(a)).length();
        length[root] += l;
        if !persists {
            faint[root] += l;
        }
        members[root].extend([a, b]);
    }
    let defects = mesh.angle_defects();
    let mut dropped = vec![false; mesh.n_vertices()];
    for (root, vs) in members.iter_mut().enumerate() {
        if vs.is_empty() {
            continue;
        }
        vs.sort_unstable();
        vs.dedup();
        dropped[root] = length[root] < MIN_FEATURE_CELLS * scale
            || faint[root] > FAINT_SHARE * length[root]
            || cone_point(mesh, vs, &defects, scale);
    }
    edges
        .into_iter()
        .filter(|&e| !dropped[sets.find(mesh.edge_vertices(e)[0])])
        .collect()
}

/// The radius, in grid cells, over which a feature edge's crease must persist
/// ([`CreaseAngles`]).
pub const CREASE_CELLS: f64 = 0.5;

/// The share of the detection angle that the crease measured over [`CREASE_CELLS`] must keep
/// (loose, so that a real crease between curved sides is not broken up).
pub const CREASE_KEPT_FRACTION: f64 = 0.5;

/// A connected set of feature edges goes when more than this share of its length is no crease
/// half a cell away ([`CreaseAngles`]). Whole sets, not single edges: next to a junction of
/// creases the two sides mix the third face's normals, and one edge taken out of a crease
/// (fandisk at 1500 and 6500 target vertices had one) would leave a sharp edge off the lines.
pub const FAINT_SHARE: f64 = 0.5;

/// The crease angles of edges at the radius `r` = [`CREASE_CELLS`] `scale` (model units): the
/// faces within `r` of the edge's midpoint are split between its two faces by their distance
/// through the surface (centroid to centroid across edges; a face is within `r` when a point of
/// it is), and the angle between the two sides' area-weighted normals is the edge's crease angle
/// there, which must still be [`CREASE_KEPT_FRACTION`] of the detection angle. A crease is one at
/// the grid's scale when the surface keeps its bend half a cell away. What fails are bends
/// narrower than that, which the grid cannot follow: a ledge a fraction of a cell wide (a
/// boolean union of a faceted dome and a cylinder leaves one where the polygons differ: two 90°
/// creases 0.001 apart, each a curve, and the map folded around them: 208 faces, 148
/// singularities), a step lower than half a cell, a scan's ridge of noise. A thin plate's rim
/// keeps both creases (the far side's faces are on the rim's side), and where the input's
/// triangles are larger than `r` only the edge's own two faces are within it, so nothing
/// changes. Kept per edge, so that the editor's preview measures each edge once.
#[derive(Debug)]
pub struct CreaseAngles {
    r: f64,
    /// Per edge (radians); NaN until measured.
    angle: Vec<f64>,
}

impl CreaseAngles {
    pub fn new(mesh: &TriMesh, scale: f64) -> Self {
        CreaseAngles {
            r: CREASE_CELLS * scale,
            angle: vec![f64::NAN; mesh.n_edges()],
        }
    }

    /// Measures the edges of `edges` not measured yet, in parallel.
    fn measure(&mut self, mesh: &TriMesh, edges: &[usize]) {
        use rayon::prelude::*;
        let todo: Vec<usize> = edges
            .iter()
            .copied()
            .filter(|&e| self.angle[e].is_nan())
            .collect();
        let r = self.r;
        let angles: Vec<f64> = todo.par_iter().map(|&e| crease_angle(mesh, e, r)).collect();
        for (e, a) in todo.into_iter().zip(angles) {
            self.angle[e] = a;
        }
    }
}

/// Edge `e`'s crease angle at the radius `r` ([`CreaseAngles`]); π on a boundary edge (kept).
fn crease_angle(mesh: &TriMesh, e: usize, r: f64) -> f64 {
    use crate::mesh::heap::Nearest;
    use std::collections::HashMap;
    let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
        return std::f64::consts::PI;
    };
    let [a, b] = mesh.edge_vertices(e);
    let mid = 0.5 * (mesh.position(a) + mesh.position(b));
    // Per face reached: its side and its distance through the surface.
    let mut reached: HashMap<usize, (usize, f64)> = HashMap::new();
    let mut heap = std::collections::BinaryHeap::new();
    for (side, h) in [h0, h1].into_iter().enumerate() {
        let f = mesh.face_of(h);
        reached.insert(f, (side, 0.0));
        heap.push(Nearest(0.0, f as u32));
    }
    let mut normals = [DVec3::ZERO; 2];
    while let Some(Nearest(d, f)) = heap.pop() {
        let f = f as usize;
        let (side, best) = reached[&f];
        if d > best {
            continue;
        }
        normals[side] += mesh.face_area_vector(f);
        let c = mesh.face_centroid(f);
        for h in 3 * f..3 * f + 3 {
            let Some(g) = mesh.twin(h).map(|t| mesh.face_of(t)) else {
                continue;
            };
            let dg = d + (mesh.face_centroid(g) - c).length();
            if reached.get(&g).is_some_and(|&(_, dist)| dist <= dg) {
                continue;
            }
            if distance_to_face(mesh, g, mid) > r {
                continue;
            }
            reached.insert(g, (side, dg));
            heap.push(Nearest(dg, g as u32));
        }
    }
    let [n0, n1] = normals.map(|n| n.normalize_or_zero());
    n0.dot(n1).clamp(-1.0, 1.0).acos()
}

/// The distance from `q` to face `f` (parry's point query on the triangle).
fn distance_to_face(mesh: &TriMesh, f: usize, q: DVec3) -> f64 {
    use parry3d_f64::{math::Vector, query::PointQuery, shape::Triangle};
    let v = |p: DVec3| Vector::new(p.x, p.y, p.z);
    let [a, b, c] = mesh.face(f).map(|i| v(mesh.position(i)));
    Triangle::new(a, b, c).distance_to_local_point(v(q), true)
}

/// Whether the feature edges on `vertices` (one connected set) are a cone point's: all within
/// [`CONE_POINT_CELLS`] `scale` of the set's most curved vertex, with at least
/// [`CONE_POINT_TURNS`] of angle defect among the set's vertices within one cell of it.
fn cone_point(mesh: &TriMesh, vertices: &[usize], defects: &[f64], scale: f64) -> bool {
    if vertices.iter().any(|&v| mesh.is_boundary_vertex(v)) {
        return false;
    }
    let Some(&hub) = vertices
        .iter()
        .max_by(|&&a, &&b| defects[a].total_cmp(&defects[b]))
    else {
        return false;
    };
    let at = mesh.position(hub);
    let distance = |v: usize| (mesh.position(v) - at).length();
    let gathered: f64 = vertices
        .iter()
        .filter(|&&v| distance(v) <= scale)
        .map(|&v| defects[v])
        .sum();
    gathered >= CONE_POINT_TURNS * std::f64::consts::TAU
        && vertices
            .iter()
            .all(|&v| distance(v) <= CONE_POINT_CELLS * scale)
}

/// Feature edges ([`significant_feature_edges`] at `angle_deg`: sets shorter than
/// [`MIN_FEATURE_CELLS`] `scale`, those that no longer bend half a cell away and those round a
/// cone point dropped) chained into curves, split at junctions of three or more feature edges,
/// at sharp turns ([`SHARP_TURN_DEG`]) and where a chain meets the boundary; see the module
/// documentation for the rules.
/// `scale` (model units, the grid size; 0 for none) is the length over which a turn must also
/// be sharp.
pub fn detect_features(mesh: &TriMesh, angle_deg: f64, scale: f64) -> Vec<DetectedCurve> {
    let edges = significant_feature_edges(mesh, angle_deg, scale);
    chain_features(mesh, &edges, scale)
}

/// The curves [`detect_features`] makes of `edges` (what [`significant_feature_edges`] kept).
pub fn chain_features(mesh: &TriMesh, edges: &[usize], scale: f64) -> Vec<DetectedCurve> {
    chain_edges(mesh, edges, scale, |v| mesh.is_boundary_vertex(v))
}

/// A feature curve shorter than this many grid cells counts towards [`noise_warning`].
pub const SHORT_FEATURE_CELLS: f64 = 2.0;

/// Short feature curves past which [`noise_warning`] speaks.
pub const NOISY_SHORT_FEATURES: usize = 50;

/// A warning when feature curves (vertex paths) look like the tessellation's facets or a scan's
/// noise rather than creases: [`NOISY_SHORT_FEATURES`] or more of them shorter than
/// [`SHORT_FEATURE_CELLS`] grid cells (`scale`). A parameter line held along each such piece
/// folds the map around it, and hundreds of them make the solve slow and the map useless.
/// Measured on the shared meshes (curves, those under two cells): fandisk at 40° 35 and 0, at
/// 12° 56 and 8, at 5° 216 and 117; spot at 30° 84 and 18, at 20° 544 and 226 (339 folds);
/// the bunny at 40° 119 and 103; igea at 40° 78 and 75.
pub fn noise_warning<'a>(
    mesh: &TriMesh,
    curves: impl IntoIterator<Item = &'a [usize]>,
    scale: f64,
) -> Option<String> {
    let (mut all, mut short) = (0, 0);
    for c in curves {
        all += 1;
        let length: f64 = c
            .windows(2)
            .map(|w| (mesh.position(w[1]) - mesh.position(w[0])).length())
            .sum();
        if length < SHORT_FEATURE_CELLS * scale {
            short += 1;
        }
    }
    (short >= NOISY_SHORT_FEATURES).then(|| {
        format!(
            "{short} of the {all} feature curves are shorter than {SHORT_FEATURE_CELLS} grid cells: at this angle the detection picks the tessellation's facets or scan noise, not creases, and the map folds around them (try a larger angle)"
        )
    })
}

/// Every boundary loop as one closed curve, or split into open curves at its sharp corners
/// ([`SHARP_TURN_DEG`]); see the module documentation for the rules. Curves run along the
/// boundary halfedges (surface on the left).
/// `scale` as for [`detect_features`].
pub fn boundary_curves(mesh: &TriMesh, scale: f64) -> Vec<DetectedCurve> {
    let edges: Vec<usize> = (0..mesh.n_edges())
        .filter(|&e| mesh.is_boundary_edge(e))
        .collect();
    chain_edges(mesh, &edges, scale, |_| false)
}

/// Angle (radians) between the direction `p → v` and the direction `v → n`.
fn turn_angle(mesh: &TriMesh, p: usize, v: usize, n: usize) -> f64 {
    let a = mesh.position(v) - mesh.position(p);
    let b = mesh.position(n) - mesh.position(v);
    a.cross(b).length().atan2(a.dot(b))
}

/// Chains `edges` (ids, any order) into curves by the module's rules; `extra_split` marks further
/// split points.
fn chain_edges(
    mesh: &TriMesh,
    edges: &[usize],
    scale: f64,
    extra_split: impl Fn(usize) -> bool,
) -> Vec<DetectedCurve> {
    let nv = mesh.n_vertices();
    let mut chosen = vec![false; mesh.n_edges()];
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); nv];
    for &e in edges {
        if std::mem::replace(&mut chosen[e], true) {
            continue;
        }
        let [a, b] = mesh.edge_vertices(e);
        adj[a].push(e);
        adj[b].push(e);
    }
    let other = |e: usize, v: usize| {
        let [a, b] = mesh.edge_vertices(e);
        if a == v { b } else { a }
    };
    let sharp = SHARP_TURN_DEG.to_radians();
    // The chain's vertices from v along e, up to the first at least `scale` away (or where
    // the chain ends or branches before that), with their distances along the chain.
    let along = |v: usize, e: usize| -> Vec<(usize, f64)> {
        let (mut cur, mut e, mut len) = (v, e, 0.0);
        let mut out = Vec::new();
        loop {
            let next = other(e, cur);
            len += (mesh.position(next) - mesh.position(cur)).length();
            cur = next;
            out.push((cur, len));
            if len >= scale || cur == v {
                return out;
            }
            match adj[cur].as_slice() {
                &[a, b] => e = if a == e { b } else { a },
                _ => return out,
            }
        }
    };
    // Per degree-2 vertex: its turn if it is a sharp one, at the vertex and between the
    // chords to the points `scale` away.
    let turn: Vec<Option<f64>> = (0..nv)
        .map(|v| {
            let &[e1, e2] = adj[v].as_slice() else {
                return None;
            };
            let at_vertex = turn_angle(mesh, other(e1, v), v, other(e2, v));
            if at_vertex <= sharp {
                return None;
            }
            if scale <= 0.0 {
                return Some(at_vertex);
            }
            let (p, n) = (along(v, e1), along(v, e2));
            let (p, n) = (p[p.len() - 1].0, n[n.len() - 1].0);
            if p == v || n == v || p == n {
                return Some(at_vertex);
            }
            let t = turn_angle(mesh, p, v, n);
            (t > sharp).then_some(t)
        })
        .collect();
    // Of sharp turns closer than `scale` along the chain only the sharpest counts (the lower
    // vertex number on a tie): two corners a fraction of a grid cell apart would be two
    // lattice points on one.
    let corner = |v: usize| -> bool {
        let Some(t) = turn[v] else { return false };
        if scale <= 0.0 {
            return true;
        }
        adj[v].iter().all(|&e| {
            along(v, e).into_iter().all(|(u, d)| {
                u == v || d >= scale || turn[u].is_none_or(|tu| tu < t || (tu == t && u > v))
            })
        })
    };
    let split: Vec<bool> = (0..nv)
        .map(|v| match adj[v].as_slice() {
            [] => false,
            &[_, _] => extra_split(v) || corner(v),
            _ => true,
        })
        .collect();

    let mut used = vec![false; mesh.n_edges()];
    // Walks from `start` away along `e`, marking edges used, until a split point, `stop` or a
    // used edge; returns the vertices after `start`.
    let walk = |used: &mut Vec<bool>, start: usize, mut e: usize, stop: usize| {
        let mut out = Vec::new();
        let mut cur = start;
        loop {
            used[e] = true;
            cur = other(e, cur);
            out.push(cur);
            if split[cur] || cur == stop {
                break;
            }
            match adj[cur].iter().copied().find(|&g| g != e && !used[g]) {
                Some(g) => e = g,
                None => break,
            }
        }
        out
    };

    let mut curves = Vec::new();
    for e0 in 0..mesh.n_edges() {
        if !chosen[e0] || used[e0] {
            continue;
        }
        let h0 = mesh.edge_halfedges(e0).0;
        let (a, b) = (mesh.from(h0), mesh.to(h0));
        let forward = walk(&mut used, a, e0, a);
        let end = *forward.last().expect("a walk takes at least one edge");
        if end == a && !split[a] {
            // A loop without any split point.
            let mut vertices = vec![a];
            vertices.extend_from_slice(&forward[..forward.len() - 1]);
            curves.push(DetectedCurve {
                vertices,
                closed: true,
            });
            continue;
        }
        let mut path = Vec::new();
        if !split[a]
            && let Some(g) = adj[a].iter().copied().find(|&g| g != e0 && !used[g])
        {
            path = walk(&mut used, a, g, b);
            path.reverse();
        }
        path.push(a);
        path.extend(forward);
        if path.len() > 2 && path[0] == path[path.len() - 1] {
            // A loop with exactly one split point: cut it there and half-way around.
            let mid = (path.len() - 1) / 2;
            curves.push(DetectedCurve {
                vertices: path[..=mid].to_vec(),
                closed: false,
            });
            curves.push(DetectedCurve {
                vertices: path[mid..].to_vec(),
                closed: false,
            });
        } else {
            curves.push(DetectedCurve {
                vertices: path,
                closed: false,
            });
        }
    }
    curves
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;
    use crate::constraint::{check_path, halfedge_between};
    use crate::mesh::generate;

    /// Sets of feature edges shorter than the minimum length go, whole; longer ones stay whole.
    #[test]
    fn short_feature_sets_are_dropped_whole() {
        // The cube's twelve creases (one connected set, length 12) and a spike on the top face
        // (a vertex raised far out of it: a small set of its own).
        let mut m = generate::cube(3);
        let top = (0..m.n_vertices())
            .find(|&v| (m.position(v) - DVec3::new(0.5, 0.5, 1.0)).length() < 1e-9)
            .unwrap();
        let mut p = m.positions().to_vec();
        p[top].z += 0.25;
        m = TriMesh::from_triangles(p, m.faces().to_vec()).unwrap();
        let on_cube_edge = |v: usize| {
            let q = m.position(v);
            [q.x, q.y, q.z]
                .iter()
                .filter(|c| c.abs() < 1e-9 || (*c - 1.0).abs() < 1e-9)
                .count()
                >= 2
        };
        let on_crease = |e: usize| m.edge_vertices(e).iter().all(|&v| on_cube_edge(v));
        let all = feature_edges(&m, 40.0);
        let creases = all.iter().filter(|&&e| on_crease(e)).count();
        assert_eq!(creases, 96, "12 creases of 8 edges");
        let spike: f64 = all
            .iter()
            .filter(|&&e| !on_crease(e))
            .map(|&e| {
                let [a, b] = m.edge_vertices(e);
                (m.position(a) - m.position(b)).length()
            })
            .sum();
        assert!(spike > 0.5, "the spike's features: {spike}");
        assert_eq!(significant_feature_edges(&m, 40.0, 0.0), all);
        // Cells of 0.9: sets under 3.6 go, the spike's (the creases are 12 long; a corner's
        // quarter turn is no cone point).
        assert!(spike < 3.6, "{spike}");
        let kept = significant_feature_edges(&m, 40.0, 0.9);
        assert_eq!(kept.len(), 96);
        assert!(kept.iter().all(|&e| on_crease(e)));
        // Longer than the creases: nothing stays. And `detect_features` drops the same.
        assert!(significant_feature_edges(&m, 40.0, 12.5 / MIN_FEATURE_CELLS).is_empty());
        assert_eq!(detect_features(&m, 40.0, 0.9).len(), 12);
    }

    /// A step lower than half a cell is no crease at the grid's scale, while a plate thinner
    /// than a cell keeps its rims: `CreaseAngles`.
    #[test]
    fn creases_must_persist_half_a_cell_away() {
        // A plane of 0.1 squares with a step 0.01 high: the columns of vertices from 5 on moved
        // back to 0.001 past column 4 and raised, so a strip 0.001 wide climbs at 84° between
        // two creases (each ten edges, one piece of length 1).
        let g = generate::grid(10, 10, 1.0, 1.0);
        let p: Vec<DVec3> = g
            .positions()
            .iter()
            .map(|&q| {
                let column = (q.x * 10.0).round() as usize;
                let x = if column >= 5 { q.x - 0.099 } else { q.x };
                let z = if column >= 5 { 0.01 } else { 0.0 };
                DVec3::new(x, q.y, z)
            })
            .collect();
        let step = TriMesh::from_triangles(p, g.faces().to_vec()).unwrap();
        let all = feature_edges(&step, 40.0);
        assert_eq!(all.len(), 20, "the step's two creases");
        // Cells of 0.1: half a cell away the surface is flat again on both sides.
        assert!(significant_feature_edges(&step, 40.0, 0.1).is_empty());
        // Cells of 0.002: the strip is half a cell wide, both creases stay.
        assert_eq!(significant_feature_edges(&step, 40.0, 0.002), all);
        // A plate 1 × 1 × 0.01 (the cube flattened): its 96 crease edges stay at cells of 0.1,
        // the far face lying on the rim's side of each crease.
        let c = generate::cube(3);
        let p: Vec<DVec3> = c
            .positions()
            .iter()
            .map(|&q| q * DVec3::new(1.0, 1.0, 0.01))
            .collect();
        let plate = TriMesh::from_triangles(p, c.faces().to_vec()).unwrap();
        let all = feature_edges(&plate, 40.0);
        assert_eq!(all.len(), 96);
        assert_eq!(significant_feature_edges(&plate, 40.0, 0.1), all);
    }

    /// A cone's apex is no crease: the sets of feature edges round it go, however long, while
    /// its base rim (a crease) and a box's corners (a quarter turn each) stay. The cone (radius
    /// 1, height 3, a closed fan of 48 sectors and a flat base) remeshed as `solve` prepares a
    /// raw part.
    #[test]
    fn feature_sets_round_a_cone_point_are_dropped() {
        use crate::mesh::isotropic::{IsotropicOptions, isotropic_remesh};
        let raw = generate::raw_cone(1.0, 3.0, 48);
        let m =
            isotropic_remesh(&raw, &IsotropicOptions::for_vertices(&raw, 12_000, 35.0)).unwrap();
        let scale = (m.total_area() / 5_000.0).sqrt();
        let all = feature_edges(&m, 40.0);
        let at_apex = |e: usize| m.edge_vertices(e).iter().all(|&v| m.position(v).z > 0.5);
        let apex: Vec<usize> = all.iter().copied().filter(|&e| at_apex(e)).collect();
        let apex_length: f64 = apex
            .iter()
            .map(|&e| {
                let [a, b] = m.edge_vertices(e);
                (m.position(a) - m.position(b)).length()
            })
            .sum();
        // Long enough to pass the length rule: only the cone point's drops them.
        assert!(
            apex_length > MIN_FEATURE_CELLS * scale,
            "{} apex edges, {apex_length} long (cell {scale})",
            apex.len()
        );
        let kept = significant_feature_edges(&m, 40.0, scale);
        assert!(kept.iter().all(|&e| !at_apex(e)));
        // The rim stays whole: one closed curve.
        assert_eq!(kept.len(), all.len() - apex.len());
        let curves = detect_features(&m, 40.0, scale);
        assert_eq!(curves.len(), 1);
        assert!(curves[0].closed);
        // A box's corners are no cone points.
        let c = generate::cube(2);
        assert_eq!(significant_feature_edges(&c, 40.0, 0.1).len(), 48);
    }

    /// A capped cylinder: `generate::cylinder` with a fan at each end (two circular creases).
    fn capped_cylinder(nu: usize) -> TriMesh {
        let open = generate::cylinder(1.0, 2.0, nu, 3);
        let mut p = open.positions().to_vec();
        let mut t = open.faces().to_vec();
        let top = (3 * nu) as u32;
        let (c0, c1) = (p.len() as u32, p.len() as u32 + 1);
        p.push(DVec3::new(0.0, 0.0, 0.0));
        p.push(DVec3::new(0.0, 0.0, 2.0));
        for i in 0..nu as u32 {
            let j = (i + 1) % nu as u32;
            t.push([c0, j, i]);
            t.push([c1, top + i, top + j]);
        }
        TriMesh::from_triangles(p, t).unwrap()
    }

    /// A convex teardrop: a circular arc and the two tangents to a tip, fanned from the centre;
    /// the tip (vertex 1) is the boundary's only sharp corner (120°).
    fn teardrop() -> TriMesh {
        let mut p = vec![DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0)];
        let (t0, t1) = (60f64.to_radians(), 300f64.to_radians());
        let (a, b) = (DVec3::new(t0.cos(), t0.sin(), 0.0), p[1]);
        for k in 1..3 {
            p.push(b.lerp(a, k as f64 / 3.0));
        }
        for k in 0..=16 {
            let t = t0 + (t1 - t0) * k as f64 / 16.0;
            p.push(DVec3::new(t.cos(), t.sin(), 0.0));
        }
        let last = p[p.len() - 1];
        for k in 1..3 {
            p.push(last.lerp(b, k as f64 / 3.0));
        }
        let n = p.len() as u32;
        let t = (1..n)
            .map(|i| [0, i, if i + 1 == n { 1 } else { i + 1 }])
            .collect();
        TriMesh::from_triangles(p, t).unwrap()
    }

    /// Every curve passes `check_path`, and every edge of `expected` lies on exactly one curve
    /// and no other edge on any.
    fn assert_covers(mesh: &TriMesh, curves: &[DetectedCurve], expected: &[usize]) {
        let mut count: HashMap<usize, usize> = HashMap::new();
        for c in curves {
            check_path(mesh, &c.vertices, c.closed).unwrap_or_else(|e| panic!("{c:?}: {e}"));
            let n = c.vertices.len();
            let pairs = (0..n - 1)
                .map(|i| (i, i + 1))
                .chain(c.closed.then_some((n - 1, 0)));
            for (i, j) in pairs {
                let h = halfedge_between(mesh, c.vertices[i], c.vertices[j]).unwrap();
                *count.entry(mesh.edge(h)).or_default() += 1;
            }
        }
        for &e in expected {
            assert_eq!(count.remove(&e), Some(1), "edge {e}");
        }
        assert!(
            count.is_empty(),
            "edges on curves but not expected: {count:?}"
        );
    }

    fn boundary_edges(mesh: &TriMesh) -> Vec<usize> {
        (0..mesh.n_edges())
            .filter(|&e| mesh.is_boundary_edge(e))
            .collect()
    }

    #[test]
    fn cube_edges_are_twelve_curves() {
        let m = generate::cube(2);
        let fe = feature_edges(&m, 40.0);
        assert_eq!(fe.len(), 12 * 4);
        let curves = detect_features(&m, 40.0, 0.0);
        assert_eq!(curves.len(), 12);
        for c in &curves {
            assert!(!c.closed);
            assert_eq!(c.vertices.len(), 5, "{c:?}");
            // Both ends are cube corners (the first 8 vertices survive subdivision).
            assert!(c.vertices[0] < 8 && c.vertices[4] < 8, "{c:?}");
            assert!(c.vertices[1..4].iter().all(|&v| v >= 8), "{c:?}");
        }
        assert_covers(&m, &curves, &fe);
        // Ordered by each chain's smallest edge id.
        let smallest: Vec<usize> = curves
            .iter()
            .map(|c| {
                c.vertices
                    .windows(2)
                    .map(|w| m.edge(halfedge_between(&m, w[0], w[1]).unwrap()))
                    .min()
                    .unwrap()
            })
            .collect();
        assert!(smallest.windows(2).all(|w| w[0] < w[1]), "{smallest:?}");
        // Deterministic.
        assert_eq!(curves, detect_features(&m, 40.0, 0.0));
        // Above 90° nothing is a feature.
        assert!(detect_features(&m, 91.0, 0.0).is_empty());
    }

    #[test]
    fn unsubdivided_cube_edges_are_single_edge_curves() {
        let m = generate::cube(0);
        let curves = detect_features(&m, 40.0, 0.0);
        assert_eq!(curves.len(), 12);
        assert!(curves.iter().all(|c| !c.closed && c.vertices.len() == 2));
        assert_covers(&m, &curves, &feature_edges(&m, 40.0));
    }

    #[test]
    fn flat_grid_has_no_features() {
        let m = generate::grid(6, 4, 3.0, 2.0);
        assert!(feature_edges(&m, 1.0).is_empty());
        assert!(detect_features(&m, 1.0, 0.0).is_empty());
    }

    #[test]
    fn capped_cylinder_creases_are_two_closed_curves() {
        let m = capped_cylinder(16);
        let fe = feature_edges(&m, 40.0);
        assert_eq!(fe.len(), 32);
        let curves = detect_features(&m, 40.0, 0.0);
        assert_eq!(curves.len(), 2);
        assert!(curves.iter().all(|c| c.closed && c.vertices.len() == 16));
        assert_covers(&m, &curves, &fe);
    }

    #[test]
    fn feature_meeting_the_boundary_is_split_there() {
        // A grid folded by 90° along its middle column: one crease from boundary to boundary.
        let mut m = generate::grid(4, 3, 4.0, 3.0);
        let p = m
            .positions()
            .iter()
            .map(|q| {
                if q.x > 2.0 {
                    DVec3::new(2.0, q.y, q.x - 2.0)
                } else {
                    *q
                }
            })
            .collect();
        m.set_positions(p);
        let fe = feature_edges(&m, 40.0);
        assert_eq!(fe.len(), 3);
        let curves = detect_features(&m, 40.0, 0.0);
        assert_eq!(curves.len(), 1);
        let c = &curves[0];
        assert!(!c.closed);
        assert_eq!(c.vertices.len(), 4);
        assert!(m.is_boundary_vertex(c.vertices[0]) && m.is_boundary_vertex(c.vertices[3]));
        assert!(c.vertices.iter().all(|&v| m.position(v).x == 2.0));
        assert_covers(&m, &curves, &fe);
    }

    #[test]
    fn feature_through_a_boundary_vertex_is_split_there() {
        // A fan around boundary vertex 0 (ring at 0°, 10°, 90°, 170°, 180°) with the two outer
        // triangles bent down: creases 0-2 and 0-4 meet at 0 turning by only 20°, but 0 is on
        // the boundary.
        let mut p = vec![DVec3::ZERO];
        for (deg, z) in [
            (0.0, -1.0),
            (10.0, 0.0),
            (90.0, 0.0),
            (170.0, 0.0),
            (180.0, -1.0),
        ] {
            let t = f64::to_radians(deg);
            p.push(DVec3::new(t.cos(), t.sin(), z));
        }
        let m = TriMesh::from_triangles(p, (1..5).map(|i| [0, i, i + 1]).collect()).unwrap();
        let fe = feature_edges(&m, 40.0);
        assert_eq!(fe.len(), 2);
        let curves = detect_features(&m, 40.0, 0.0);
        assert_eq!(curves.len(), 2, "{curves:?}");
        for c in &curves {
            assert!(
                !c.closed && c.vertices.len() == 2 && c.vertices.contains(&0),
                "{c:?}"
            );
        }
        assert_covers(&m, &curves, &fe);
    }

    #[test]
    fn grid_boundary_splits_at_its_corners() {
        let (nx, ny) = (5, 3);
        let m = generate::grid(nx, ny, 5.0, 3.0);
        let curves = boundary_curves(&m, 0.0);
        assert_eq!(curves.len(), 4);
        let corners = [0, nx, (nx + 1) * ny, (nx + 1) * (ny + 1) - 1];
        let mut lengths: Vec<usize> = curves.iter().map(|c| c.vertices.len()).collect();
        lengths.sort();
        assert_eq!(lengths, vec![ny + 1, ny + 1, nx + 1, nx + 1]);
        for c in &curves {
            assert!(!c.closed);
            assert!(corners.contains(&c.vertices[0]), "{c:?}");
            assert!(corners.contains(c.vertices.last().unwrap()), "{c:?}");
            // Along the boundary halfedges (surface on the left).
            for w in c.vertices.windows(2) {
                let h = halfedge_between(&m, w[0], w[1]).unwrap();
                assert_eq!((m.from(h), m.to(h)), (w[0], w[1]));
            }
        }
        assert_covers(&m, &curves, &boundary_edges(&m));
    }

    /// A disc fanned from its centre whose boundary zigzags (radius 1 and 0.93 in turn, 60
    /// points): every boundary vertex turns by more than 50°, the boundary as a whole by 6°.
    fn zigzag_disc() -> TriMesh {
        let n = 60;
        let mut p = vec![DVec3::ZERO];
        for k in 0..n {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            let r = if k % 2 == 0 { 1.0 } else { 0.93 };
            p.push(DVec3::new(r * t.cos(), r * t.sin(), 0.0));
        }
        let t = (1..=n as u32)
            .map(|i| [0, i, if i == n as u32 { 1 } else { i + 1 }])
            .collect();
        TriMesh::from_triangles(p, t).unwrap()
    }

    #[test]
    fn a_zigzag_below_the_scale_is_no_corner() {
        let m = zigzag_disc();
        let at_vertex = boundary_curves(&m, 0.0);
        assert!(at_vertex.len() > 20, "{} curves", at_vertex.len());
        let curves = boundary_curves(&m, 0.4);
        assert_eq!(curves.len(), 1, "{curves:?}");
        assert!(curves[0].closed && curves[0].vertices.len() == 60);
        assert_covers(&m, &curves, &boundary_edges(&m));
    }

    #[test]
    fn close_corners_split_once_at_the_sharpest() {
        // A triangle of side 5 whose corner at the origin is cut off by a chamfer a 50th of a
        // side long: its two ends turn by 60° each (sharp at the vertex); at the scale of a
        // side only the sharper one is a corner, so the curves are three as for the triangle.
        let h = 3f64.sqrt() / 2.0;
        let p = vec![
            DVec3::new(0.1, 0.0, 0.0),
            DVec3::new(5.0, 0.0, 0.0),
            DVec3::new(2.5, 5.0 * h, 0.0),
            DVec3::new(0.05, 0.1 * h, 0.0),
            DVec3::new(2.5, 1.4, 0.0),
        ];
        let t = (0..4u32).map(|i| [4, i, (i + 1) % 4]).collect();
        let m = TriMesh::from_triangles(p, t).unwrap();
        let at_vertex = boundary_curves(&m, 0.0);
        assert_eq!(at_vertex.len(), 4, "{at_vertex:?}");
        let curves = boundary_curves(&m, 1.0);
        assert_eq!(curves.len(), 3, "{curves:?}");
        let ends: Vec<usize> = curves.iter().map(|c| c.vertices[0]).collect();
        assert!(
            ends.contains(&0) != ends.contains(&3),
            "one chamfer end: {ends:?}"
        );
        assert_covers(&m, &curves, &boundary_edges(&m));
    }

    #[test]
    fn disc_boundary_is_one_closed_curve() {
        let m = generate::disc(1.0, 6);
        let curves = boundary_curves(&m, 0.0);
        assert_eq!(curves.len(), 1);
        assert!(curves[0].closed);
        assert_eq!(curves[0].vertices.len(), 24);
        assert_covers(&m, &curves, &boundary_edges(&m));
    }

    #[test]
    fn cylinder_boundary_is_two_closed_curves() {
        let m = generate::cylinder(1.0, 2.0, 12, 4);
        let curves = boundary_curves(&m, 0.0);
        assert_eq!(curves.len(), 2);
        assert!(curves.iter().all(|c| c.closed && c.vertices.len() == 12));
        assert_covers(&m, &curves, &boundary_edges(&m));
        // A closed mesh has no boundary curves.
        assert!(boundary_curves(&generate::cube(1), 0.0).is_empty());
    }

    #[test]
    fn loop_with_one_corner_is_cut_there_and_half_way() {
        let m = teardrop();
        let n_boundary = boundary_edges(&m).len();
        assert_eq!(n_boundary, 22);
        let curves = boundary_curves(&m, 0.0);
        assert_eq!(curves.len(), 2, "{curves:?}");
        let (a, b) = (&curves[0], &curves[1]);
        assert!(!a.closed && !b.closed);
        assert_eq!(a.vertices[0], 1);
        assert_eq!(*b.vertices.last().unwrap(), 1);
        assert_eq!(a.vertices.last(), b.vertices.first());
        assert_eq!(a.vertices.len() - 1, n_boundary / 2);
        assert_eq!(b.vertices.len() - 1, n_boundary - n_boundary / 2);
        assert_covers(&m, &curves, &boundary_edges(&m));
    }
}
