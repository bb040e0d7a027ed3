//! From a triangle soup to a validated, oriented, manifold [`TriMesh`].
//!
//! Order of checks: coordinates and indices, degenerate faces, exact duplicate faces (repaired),
//! unreferenced vertices (repaired), non-manifold edges, orientation (repaired where the component
//! is orientable), non-manifold vertices. Repairs never move a vertex.

use std::collections::{HashMap, HashSet};

use glam::DVec3;

use super::soup::PolygonSoup;
use super::{INVALID, MeshError, TriMesh};

/// What was repaired while building, for the editor and `quadcover info` to show.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RepairReport {
    /// One line per repair or reader remark, e.g. "dropped 1113 unreferenced vertices".
    pub warnings: Vec<String>,
    /// For each mesh vertex, its index in the soup (vertex order is preserved).
    pub original_vertex: Vec<u32>,
    /// For each mesh face, its triangle index in the soup (face order is preserved).
    pub original_face: Vec<u32>,
    /// Faces whose orientation was reversed (mesh face indices).
    pub flipped_faces: Vec<u32>,
}

/// A warning when boundary vertices share their position with another boundary vertex: the
/// faces on either side are not connected there (an unwelded triangle soup, or seams an
/// exporter split), so the field, the cut graph and the grid treat the seam as a boundary and
/// the remesh is cut open along it. Nothing is welded: that could join surfaces meant to touch
/// only, and a repair here never changes what the file says is connected.
fn unwelded(mesh: &TriMesh, original_vertex: &[u32], soup: &PolygonSoup) -> Option<String> {
    let mut seen: HashSet<[u64; 3]> = HashSet::new();
    let (mut count, mut first) = (0usize, None);
    for v in (0..mesh.n_vertices()).filter(|&v| mesh.is_boundary_vertex(v)) {
        // +0.0 makes −0.0 the same key, as the STL reader's welding does.
        if !seen.insert(mesh.position(v).to_array().map(|x| (x + 0.0).to_bits())) {
            count += 1;
            first.get_or_insert(v);
        }
    }
    let first = first?;
    let components = mesh.face_components().1;
    Some(format!(
        "{count} boundary vertex(es) lie exactly on another one ({components} component(s) of \
         faces; first: {}): the faces there are not connected (an unwelded triangle soup or \
         split seams?); the solve treats them as boundaries; weld the vertices in a mesh tool \
         if they should be one surface",
        soup.describe_vertex(original_vertex[first] as usize)
    ))
}

impl TriMesh {
    /// Builds a mesh from raw positions and triangles (generated meshes, tests).
    pub fn from_triangles(
        positions: Vec<DVec3>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<TriMesh, MeshError> {
        let soup = PolygonSoup {
            source_polygon: (0..triangles.len() as u32).collect(),
            positions,
            triangles,
            ..Default::default()
        };
        TriMesh::from_soup(&soup).map(|(m, _)| m)
    }

    /// Validates a soup, applies the safe repairs and builds the halfedge connectivity.
    pub fn from_soup(soup: &PolygonSoup) -> Result<(TriMesh, RepairReport), MeshError> {
        let mut report = RepairReport {
            warnings: soup.warnings.clone(),
            ..Default::default()
        };
        if soup.positions.is_empty() {
            return Err(MeshError::Empty("no vertices".into()));
        }
        if soup.triangles.is_empty() {
            return Err(MeshError::Empty(format!(
                "{} vertices but no faces",
                soup.positions.len()
            )));
        }
        check_coordinates(soup)?;
        check_indices(soup)?;
        check_degenerate(soup)?;

        // Exact duplicates: the same three vertices (in any order). Keep the first.
        let mut seen: HashMap<[u32; 3], usize> = HashMap::with_capacity(soup.triangles.len());
        let mut kept: Vec<u32> = Vec::with_capacity(soup.triangles.len());
        for (t, tri) in soup.triangles.iter().enumerate() {
            let mut key = *tri;
            key.sort_unstable();
            if seen.insert(key, t).is_none() {
                kept.push(t as u32);
            }
        }
        let duplicates = soup.triangles.len() - kept.len();
        if duplicates > 0 {
            let first = (0..soup.triangles.len())
                .find(|t| kept.binary_search(&(*t as u32)).is_err())
                .unwrap_or(0);
            report.warnings.push(format!(
                "removed {duplicates} duplicate face(s); first: {}",
                soup.describe_triangle(first)
            ));
        }

        // Unreferenced vertices are dropped; vertex order is otherwise kept.
        let mut new_index = vec![INVALID; soup.positions.len()];
        for &t in &kept {
            for &v in &soup.triangles[t as usize] {
                new_index[v as usize] = 0;
            }
        }
        let mut positions = Vec::with_capacity(soup.positions.len());
        for (v, slot) in new_index.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = positions.len() as u32;
                positions.push(soup.positions[v]);
                report.original_vertex.push(v as u32);
            }
        }
        let unreferenced = soup.positions.len() - positions.len();
        if unreferenced > 0 {
            let first = new_index.iter().position(|&i| i == INVALID).unwrap_or(0);
            report.warnings.push(format!(
                "dropped {unreferenced} unreferenced vertex(es); first: {}",
                soup.describe_vertex(first)
            ));
        }
        let mut faces: Vec<[u32; 3]> = kept
            .iter()
            .map(|&t| soup.triangles[t as usize].map(|v| new_index[v as usize]))
            .collect();
        report.original_face = kept.clone();
        let describe_face = |f: usize| soup.describe_triangle(kept[f] as usize);

        let edges = EdgeIncidence::build(&faces);
        edges.check_manifold(&report.original_vertex, &describe_face)?;
        let flips = orient(&faces, &edges, &describe_face)?;
        if !flips.is_empty() {
            for &f in &flips {
                faces[f as usize].swap(1, 2);
            }
            report.warnings.push(format!(
                "re-oriented {} face(s) to make the orientation consistent; first: {}",
                flips.len(),
                describe_face(flips[0] as usize)
            ));
            report.flipped_faces = flips;
        }

        let mesh = TriMesh::with_connectivity(positions, faces);
        mesh.check_vertex_manifold(&report.original_vertex, soup)?;
        if let Some(w) = unwelded(&mesh, &report.original_vertex, soup) {
            report.warnings.push(w);
        }
        Ok((mesh, report))
    }

    /// Builds twins, edges and vertex halfedges for an already validated, oriented soup.
    fn with_connectivity(positions: Vec<DVec3>, faces: Vec<[u32; 3]>) -> TriMesh {
        let nh = faces.len() * 3;
        let mut twin = vec![INVALID; nh];
        let mut he_edge = vec![INVALID; nh];
        let mut edges: Vec<[u32; 2]> = Vec::with_capacity(nh / 2 + 1);
        let mut by_key: HashMap<(u32, u32), u32> = HashMap::with_capacity(nh);
        for h in 0..nh {
            let (a, b) = (faces[h / 3][h % 3], faces[h / 3][(h + 1) % 3]);
            match by_key.remove(&(b, a)) {
                Some(g) => {
                    twin[h] = g;
                    twin[g as usize] = h as u32;
                    let e = he_edge[g as usize];
                    he_edge[h] = e;
                    edges[e as usize][1] = h as u32;
                }
                None => {
                    he_edge[h] = edges.len() as u32;
                    edges.push([h as u32, INVALID]);
                    by_key.insert((a, b), h as u32);
                }
            }
        }
        let mut vertex_he = vec![INVALID; positions.len()];
        for h in 0..nh {
            let v = faces[h / 3][h % 3] as usize;
            // Prefer the outgoing boundary halfedge, so that CCW rotation visits the whole fan.
            if vertex_he[v] == INVALID || twin[h] == INVALID {
                vertex_he[v] = h as u32;
            }
        }
        TriMesh {
            positions,
            faces,
            twin,
            he_edge,
            edges,
            vertex_he,
        }
    }

    fn check_vertex_manifold(
        &self,
        original_vertex: &[u32],
        soup: &PolygonSoup,
    ) -> Result<(), MeshError> {
        // Count incident faces per vertex, compare with the size of the fan we can walk.
        let mut incident = vec![0u32; self.n_vertices()];
        for f in &self.faces {
            for &v in f {
                incident[v as usize] += 1;
            }
        }
        let mut bad = 0usize;
        let mut first: Option<(usize, usize)> = None;
        for v in 0..self.n_vertices() {
            let walked = self.outgoing(v).count() as u32;
            if walked != incident[v] {
                bad += 1;
                if first.is_none() {
                    first = Some((v, self.count_fans(v)));
                }
            }
        }
        match first {
            None => Ok(()),
            Some((v, fans)) => Err(MeshError::NonManifoldVertex {
                count: bad,
                at: soup.describe_vertex(original_vertex[v] as usize),
                fans,
            }),
        }
    }

    /// Number of separate face fans around `v` (1 for a manifold vertex).
    fn count_fans(&self, v: usize) -> usize {
        let out: Vec<usize> = (0..self.n_halfedges())
            .filter(|&h| self.from(h) == v)
            .collect();
        let mut seen = vec![false; out.len()];
        let mut fans = 0;
        for i in 0..out.len() {
            if seen[i] {
                continue;
            }
            fans += 1;
            // Walk both ways from out[i].
            let mut stack = vec![out[i]];
            while let Some(h) = stack.pop() {
                let Some(k) = out.iter().position(|&g| g == h) else {
                    continue;
                };
                if seen[k] {
                    continue;
                }
                seen[k] = true;
                if let Some(t) = self.twin(self.prev(h)) {
                    stack.push(t);
                }
                if let Some(t) = self.twin(h) {
                    stack.push(self.next(t));
                }
            }
        }
        fans
    }
}

/// Coordinates past this overflow the geometry: a face's area is the length of a cross product
/// of edges, whose squared components grow as the fourth power of the coordinates (f64 reaches
/// 1.8e308, so 1e77 at most).
const MAX_COORDINATE: f64 = 1e75;

fn check_coordinates(soup: &PolygonSoup) -> Result<(), MeshError> {
    let at = |v: usize| {
        format!(
            "{} = {:?}",
            soup.describe_vertex(v),
            soup.positions[v].to_array()
        )
    };
    let bad: Vec<usize> = (0..soup.positions.len())
        .filter(|&v| !soup.positions[v].is_finite())
        .collect();
    if let Some(&v) = bad.first() {
        return Err(MeshError::NonFinite {
            count: bad.len(),
            at: at(v),
        });
    }
    let huge: Vec<usize> = (0..soup.positions.len())
        .filter(|&v| soup.positions[v].abs().max_element() > MAX_COORDINATE)
        .collect();
    match huge.first() {
        None => Ok(()),
        Some(&v) => Err(MeshError::Huge {
            count: huge.len(),
            at: at(v),
        }),
    }
}

fn check_indices(soup: &PolygonSoup) -> Result<(), MeshError> {
    let n = soup.positions.len();
    let mut count = 0;
    let mut first = None;
    for (t, tri) in soup.triangles.iter().enumerate() {
        if let Some(&i) = tri.iter().find(|&&i| i as usize >= n) {
            count += 1;
            first.get_or_insert((t, i));
        }
    }
    match first {
        None => Ok(()),
        Some((t, index)) => Err(MeshError::IndexOutOfRange {
            count,
            at: soup.describe_triangle(t),
            index,
            vertex_count: n,
        }),
    }
}

fn check_degenerate(soup: &PolygonSoup) -> Result<(), MeshError> {
    let degenerate = |tri: &[u32; 3]| {
        let [a, b, c] = *tri;
        if a == b || b == c || a == c {
            return true;
        }
        let p = |i: u32| soup.positions[i as usize];
        (p(b) - p(a)).cross(p(c) - p(a)).length_squared() == 0.0
    };
    let bad: Vec<usize> = (0..soup.triangles.len())
        .filter(|&t| degenerate(&soup.triangles[t]))
        .collect();
    match bad.first() {
        None => Ok(()),
        Some(&t) => Err(MeshError::DegenerateFace {
            count: bad.len(),
            at: format!(
                "{} with vertices {:?}",
                soup.describe_triangle(t),
                soup.triangles[t]
            ),
        }),
    }
}

/// The (face, corner) pairs using one undirected edge.
type Incidence = Vec<(u32, u8)>;

/// Undirected edges with the faces (and corner) using them, before orientation is fixed.
struct EdgeIncidence {
    /// (min vertex, max vertex) -> list of (face, k) where the halfedge k of face starts.
    map: HashMap<(u32, u32), Vec<(u32, u8)>>,
}

impl EdgeIncidence {
    fn build(faces: &[[u32; 3]]) -> EdgeIncidence {
        let mut map: HashMap<(u32, u32), Vec<(u32, u8)>> = HashMap::with_capacity(faces.len() * 2);
        for (f, tri) in faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                map.entry((a.min(b), a.max(b)))
                    .or_default()
                    .push((f as u32, k as u8));
            }
        }
        EdgeIncidence { map }
    }

    fn check_manifold(
        &self,
        original_vertex: &[u32],
        describe_face: &dyn Fn(usize) -> String,
    ) -> Result<(), MeshError> {
        let mut bad: Vec<(&(u32, u32), &Incidence)> =
            self.map.iter().filter(|(_, fs)| fs.len() > 2).collect();
        if bad.is_empty() {
            return Ok(());
        }
        // Report the edge with the smallest first face, so that messages are deterministic.
        bad.sort_by_key(|(_, fs)| fs.iter().map(|x| x.0).min());
        let (&(a, b), fs) = bad[0];
        Err(MeshError::NonManifoldEdge {
            count: bad.len(),
            v0: original_vertex[a as usize] as usize,
            v1: original_vertex[b as usize] as usize,
            faces: fs.len(),
            at: describe_face(fs.iter().map(|x| x.0).min().unwrap_or(0) as usize),
        })
    }
}

/// Decides which faces to flip so that every interior edge is used in opposite directions.
/// Per component, the orientation held by most faces wins.
fn orient(
    faces: &[[u32; 3]],
    edges: &EdgeIncidence,
    describe_face: &dyn Fn(usize) -> String,
) -> Result<Vec<u32>, MeshError> {
    let n = faces.len();
    // Neighbours with a flag: true when the shared edge runs the same way in both (needs a flip).
    let mut adj: Vec<Vec<(u32, bool)>> = vec![Vec::new(); n];
    for fs in edges.map.values() {
        if let [(f, k), (g, l)] = fs[..] {
            let dir = |f: u32, k: u8| {
                faces[f as usize][k as usize] < faces[f as usize][(k as usize + 1) % 3]
            };
            let same = dir(f, k) == dir(g, l);
            adj[f as usize].push((g, same));
            adj[g as usize].push((f, same));
        }
    }
    // The edge map's order differs from run to run; the walk, and so the face a conflict is
    // reported at, must not.
    for a in &mut adj {
        a.sort_unstable();
    }
    let mut flip: Vec<Option<bool>> = vec![None; n];
    let mut result = Vec::new();
    let mut component = 0;
    for root in 0..n {
        if flip[root].is_some() {
            continue;
        }
        let mut members = vec![root as u32];
        flip[root] = Some(false);
        let mut i = 0;
        while i < members.len() {
            let f = members[i] as usize;
            i += 1;
            let ff = flip[f].unwrap_or(false);
            for &(g, same) in &adj[f] {
                let want = ff ^ same;
                match flip[g as usize] {
                    None => {
                        flip[g as usize] = Some(want);
                        members.push(g);
                    }
                    Some(have) if have != want => {
                        return Err(MeshError::NonOrientable {
                            component,
                            at: describe_face(g as usize),
                        });
                    }
                    Some(_) => {}
                }
            }
        }
        let flipped = members
            .iter()
            .filter(|&&f| flip[f as usize] == Some(true))
            .count();
        let invert = flipped * 2 > members.len();
        for &f in &members {
            if flip[f as usize] == Some(!invert) {
                result.push(f);
            }
        }
        component += 1;
    }
    result.sort_unstable();
    Ok(result)
}
