//! Isotropic remeshing of the input, keeping its sharp features and boundary (Botsch & Kobbelt
//! 2004, "A remeshing approach to multiresolution modeling": split long edges, collapse short
//! ones, flip, smooth tangentially, project back onto the input).
//!
//! Why: the field's smoothing (thesis eq. 3.4) counts dual edges, not lengths, and singularities
//! can only sit on vertices. A raw CAD tessellation (an STL of long needles, caps fanned from one
//! rim vertex) has neither the uniform sampling the smoothing assumes nor interior vertices for
//! the singularities: a capped cylinder's map then folds 110 faces with conformal distortion 70.
//! Remeshed to near-equilateral triangles first, the same part maps with no fold. [`needs_remesh`]
//! and [`too_coarse`] (a low-poly part: faces many grid cells wide) are the tests `solve`
//! applies; `quadcover prepare` and the editor's *Remesh input* run it on request.
//!
//! What is kept: edges whose dihedral angle exceeds the feature angle and boundary edges are
//! *feature edges*. They are never flipped; they are split into feature edges; a vertex on a
//! feature chain only collapses or slides along its chain and is projected back onto the chain's
//! original segments; chain corners (vertices with other than two feature edges, or whose chain
//! turns by more than [`CORNER_TURN_DEG`]) never move. Every other vertex is projected onto the
//! input surface (closest point, parry3d's BVH). Every step runs in a fixed order, so the result
//! is a pure function of the input and the options.

use std::collections::HashMap;

use glam::DVec3;

use super::{MeshError, TriMesh};
use crate::extract::surface::Surface;

/// A feature chain's vertex with a turn sharper than this (degrees) is a corner and stays put.
pub const CORNER_TURN_DEG: f64 = 20.0;
/// Input triangles whose smallest angle is below this (degrees) are needles for [`needs_remesh`].
pub const NEEDLE_DEG: f64 = 10.0;
/// [`needs_remesh`]'s threshold: the share of the surface's area in needles. The shared meshes
/// have at most 1.3 % (camelhead), raw CAD tessellations 40–100 %.
pub const NEEDLE_AREA_SHARE: f64 = 0.2;

/// [`long_needles`]: a needle longer than this many grid cells ...
pub const LONG_NEEDLE_CELLS: f64 = 2.0;
/// ... is a long needle, and a mesh with more than this share of its area in long needles is
/// remeshed whatever its needle share. A boolean of an icosphere (2455 vertices) with a cube
/// corner cut out has 7.7 % of its area in needles, all of them on the three flat faces of the
/// notch, fans of needles 16 cells long at 3000 target vertices: with features at 40° its map
/// kept 77–83 folded faces at 1500, 3000 and 15 000 target vertices; remeshed, none. The shared
/// meshes have at most 1.2 % (camelhead) at 1500–50 000 target vertices.
pub const LONG_NEEDLE_AREA_SHARE: f64 = 0.05;

/// [`too_coarse`]: a low-poly mesh has fewer vertices than this ...
pub const COARSE_MAX_VERTICES: usize = 1_000;
/// ... and this many times fewer than the grid. The shared meshes at the default density (10 000
/// grid vertices) have 1 850 (kitten) and more: at most 5.4 times fewer. It was 16: a raw
/// pocket with a boss (81 vertices, few needles) with features at 40° then solved raw at 800
/// and 1000 target vertices (10 and 12 times) and kept 36 and 38 folded faces (conformal p99
/// 3843 and 160); remeshed, none (p99 2.5). At 5 and 8 times raw parts map but with more
/// distortion (the pocket at 400: p99 5.2 against 2.3 remeshed; a star prism, 20 vertices, at
/// 160: 17.2 against 3.9).
pub const COARSE_RATIO: f64 = 4.0;

/// [`too_coarse`] remeshes a low-poly mesh of this many vertices or more only when it is
/// faceted like a CAD part ([`FLAT_EDGE_SHARE`]); below it (a tetrahedron, an icosahedron, a
/// prism) always.
pub const POLYHEDRON_VERTICES: usize = 100;
/// [`too_coarse`]: a mesh is faceted like a CAD part when more than this share of its interior
/// edge length lies between coplanar faces (dihedral angle under [`FLAT_EDGE_DEG`]): planar
/// faces split into triangles. The CAD parts and polyhedra measured have 26–81 %; decimated
/// organic models 0–2.6 % (an icosphere of 642 vertices 0, spot at 832 vertices 0.9 %, kitten
/// at 898 0.5 %, fertility at 920 2.6 %). Remeshed, such a smooth low-poly model gets its
/// facets' creases for guidance: the icosphere 240 singularities against 8 kept as it is, spot
/// 76 against 60 (RSD edge / angle 12.9 / 8.2 against 9.6 / 6.9 %), kitten 36 against 30
/// (14.5 / 8.7 against 9.0 / 6.8 %), with no fold kept as it is; the CAD parts measured map
/// better remeshed (a hexagon nut's RSD edge 18.2 against 8.0 %).
pub const FLAT_EDGE_SHARE: f64 = 0.1;
/// See [`FLAT_EDGE_SHARE`] (degrees).
pub const FLAT_EDGE_DEG: f64 = 0.1;

/// The share of `mesh`'s interior edge length between faces whose normals differ by less than
/// [`FLAT_EDGE_DEG`].
pub fn flat_edge_share(mesh: &TriMesh) -> f64 {
    let cos = FLAT_EDGE_DEG.to_radians().cos();
    let (mut flat, mut total) = (0.0, 0.0);
    for e in 0..mesh.n_edges() {
        let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
            continue;
        };
        let l = mesh.vector(h0).length();
        total += l;
        let (a, b) = (
            mesh.face_normal(mesh.face_of(h0)),
            mesh.face_normal(mesh.face_of(h1)),
        );
        if a.dot(b) > cos {
            flat += l;
        }
    }
    if total > 0.0 { flat / total } else { 0.0 }
}

/// Vertices of a prepared input (`quadcover prepare`, `solve` on a raw tessellation, the
/// editor's *Remesh input*) unless asked otherwise or the input has more ([`prepared_options`]):
/// fine enough for the field under any grid of the usual densities, and about 2 s.
pub const PREPARED_VERTICES: usize = 20_000;
/// Feature angle (degrees) a prepared input keeps: QuadWild's default for sharp features.
pub const PREPARED_FEATURE_ANGLE: f64 = 35.0;

/// The most vertices a remesh may be asked for: past it the work runs for minutes and takes
/// many gigabytes (a torus remeshed for 10⁸ target vertices filled 9.7 GB within a minute).
pub const MAX_VERTICES: f64 = 2e7;

/// Options of [`isotropic_remesh`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IsotropicOptions {
    /// Target edge length (model units).
    pub edge_length: f64,
    /// Edges with a dihedral angle above this (degrees) are kept as features.
    pub feature_angle_deg: f64,
    /// Rounds of split, collapse, flip, smooth and project.
    pub iterations: usize,
}

impl IsotropicOptions {
    /// Options giving about `vertices` vertices on `mesh` (equilateral triangles of the same
    /// total area), features at `feature_angle_deg`.
    pub fn for_vertices(mesh: &TriMesh, vertices: usize, feature_angle_deg: f64) -> Self {
        // a vertex per two triangles of area √3/4 L²
        let area = mesh.total_area();
        let l = (2.0 * area / (3f64.sqrt() * vertices.max(4) as f64)).sqrt();
        IsotropicOptions {
            edge_length: l,
            feature_angle_deg,
            iterations: 10,
        }
    }
}

/// The options `solve`, `quadcover prepare` and the editor use: [`PREPARED_VERTICES`] vertices,
/// or the input's own count when it has more (a large scan keeps its detail), or twice the
/// grid's target vertices (the field needs a finer mesh than the grid); sharp edges at
/// `feature_angle_deg`.
pub fn prepared_options(
    mesh: &TriMesh,
    target_vertices: Option<usize>,
    feature_angle_deg: f64,
) -> IsotropicOptions {
    let vertices = PREPARED_VERTICES
        .max(mesh.n_vertices())
        .max(2 * target_vertices.unwrap_or(0));
    IsotropicOptions::for_vertices(mesh, vertices, feature_angle_deg)
}

/// The share of `mesh`'s area in triangles whose smallest angle is below [`NEEDLE_DEG`].
pub fn needle_area_share(mesh: &TriMesh) -> f64 {
    area_share(mesh, |f| is_needle(mesh, f))
}

/// Whether face `f`'s smallest angle is below [`NEEDLE_DEG`]; a NaN angle (a degenerate
/// triangle) counts as a needle.
fn is_needle(mesh: &TriMesh, f: usize) -> bool {
    let min = (0..3)
        .map(|k| mesh.corner_angle(3 * f + k))
        .fold(f64::INFINITY, f64::min);
    min.to_degrees() < NEEDLE_DEG || min.is_nan()
}

/// The share of `mesh`'s area (faces of finite area) in the faces `chosen` picks.
fn area_share(mesh: &TriMesh, chosen: impl Fn(usize) -> bool) -> f64 {
    let (mut picked, mut total) = (0.0, 0.0);
    for f in 0..mesh.n_faces() {
        let a = mesh.face_area(f);
        if !a.is_finite() {
            continue;
        }
        total += a;
        if chosen(f) {
            picked += a;
        }
    }
    if total > 0.0 { picked / total } else { 0.0 }
}

/// Triangles around a vertex from which it is a fan centre ([`fan_centres`]).
pub const FAN_VALENCE: usize = 24;

/// Largest |angle defect| (radians) of a fan centre ([`fan_centres`]): a nearly flat one.
pub const FAN_FLAT_DEFECT: f64 = std::f64::consts::FRAC_PI_4;

/// Interior vertices with [`FAN_VALENCE`] or more triangles around them and nearly no angle
/// defect ([`FAN_FLAT_DEFECT`]): the centres of the fans a CAD tessellator puts on flat round
/// faces. In the field's dual graph such a fan is a long cycle around no face, which holds a
/// zero of order N at no cost: the field's renormalization cannot split it there, and it
/// becomes a pole (a capped cylinder of radius 1 with 80–128 triangles round its caps' centres:
/// two poles, conformal distortion 2.0–2.2, p99 5.6–9.9, with any number of renormalization
/// steps; remeshed, eight +1/4 and 1.41–1.46, p99 2.0). A cone's apex is left out: its pole is
/// the geometry's (remeshed, a cone with a 96-fold apex folded where it had not). None on the
/// shared meshes (at most 12 triangles at a vertex).
pub fn fan_centres(mesh: &TriMesh) -> Vec<usize> {
    (0..mesh.n_vertices())
        .filter(|&v| {
            !mesh.is_boundary_vertex(v)
                && mesh.outgoing(v).count() >= FAN_VALENCE
                && mesh.angle_defect(v).abs() < FAN_FLAT_DEFECT
        })
        .collect()
}

/// Whether `mesh` looks like a raw tessellation that the field cannot follow (see the module
/// documentation): more than [`NEEDLE_AREA_SHARE`] of its area in needles.
pub fn needs_remesh(mesh: &TriMesh) -> bool {
    needle_area_share(mesh) > NEEDLE_AREA_SHARE
}

/// The grid's vertex count (`field::density::grid_vertices`) when `mesh` is a low-poly
/// tessellation far coarser than a grid of `density`: fewer than [`COARSE_MAX_VERTICES`]
/// vertices, and [`COARSE_RATIO`] times fewer than the grid, and either a polyhedron (fewer
/// than [`POLYHEDRON_VERTICES`]) or faceted like a CAD part ([`FLAT_EDGE_SHARE`]); `None`
/// otherwise. The map is linear on each triangle and singularities sit on vertices, so a face
/// many cells wide has room for neither: raw, a tetrahedron, an octahedron and a square pyramid
/// (4–6 vertices) map to no grid point at all, a triangular prism folds 4 faces and an
/// octagonal prism 11, with features at 40°; remeshed first, none folds.
pub fn too_coarse(
    mesh: &TriMesh,
    density: &crate::field::density::Density,
    symmetry: crate::field::Symmetry,
) -> Option<f64> {
    let n = mesh.n_vertices();
    let grid = crate::field::density::grid_vertices(mesh, density, symmetry)?;
    (n < COARSE_MAX_VERTICES
        && (n as f64) * COARSE_RATIO < grid
        && (n < POLYHEDRON_VERTICES || flat_edge_share(mesh) > FLAT_EDGE_SHARE))
        .then_some(grid)
}

/// The share of `mesh`'s area in needles (a corner under [`NEEDLE_DEG`]) longer than
/// [`LONG_NEEDLE_CELLS`] cells of a grid of `density`, when it exceeds
/// [`LONG_NEEDLE_AREA_SHARE`]; `None` otherwise (or where the grid has no size). The map is
/// linear on each triangle: a fan of needles across many cells has room neither to bend nor
/// for a singularity, whatever share of the whole surface it is.
pub fn long_needles(
    mesh: &TriMesh,
    density: &crate::field::density::Density,
    symmetry: crate::field::Symmetry,
) -> Option<f64> {
    let grid = crate::field::density::grid_vertices(mesh, density, symmetry)?;
    let total = mesh.total_area();
    let h = (total / (crate::field::density::cell_area(symmetry) * grid)).sqrt();
    let long = LONG_NEEDLE_CELLS * h;
    let longest = |f: usize| {
        (0..3)
            .map(|k| mesh.vector(3 * f + k).length())
            .fold(0.0, f64::max)
    };
    let share = area_share(mesh, |f| is_needle(mesh, f) && longest(f) > long);
    (share > LONG_NEEDLE_AREA_SHARE).then_some(share)
}

/// What a vertex may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Free,
    /// On feature chain `id`: slides along it.
    Chain(u32),
    Corner,
}

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

struct Work<'a> {
    pos: Vec<DVec3>,
    faces: Vec<[u32; 3]>,
    alive: Vec<bool>,
    vf: Vec<Vec<u32>>,
    kind: Vec<Kind>,
    /// Feature edge → chain.
    feature: HashMap<(u32, u32), u32>,
    surface: &'a Surface,
    chains: &'a [Surface],
}

/// Remeshes `mesh` isotropically (module documentation). Errors only if the result is not a
/// valid mesh, which the operations' checks are there to prevent.
pub fn isotropic_remesh(mesh: &TriMesh, opts: &IsotropicOptions) -> Result<TriMesh, MeshError> {
    let l = opts.edge_length;
    if !(l.is_finite() && l > 0.0) {
        return Ok(mesh.clone());
    }
    // A vertex per two equilateral triangles of side l (as `IsotropicOptions::for_vertices`).
    let vertices = 2.0 * mesh.total_area() / (3f64.sqrt() * l * l);
    if vertices > MAX_VERTICES {
        return Err(MeshError::TooLarge {
            edge_length: l,
            vertices,
            limit: MAX_VERTICES,
        });
    }
    let (kind, feature, chain_segments) = features(mesh, opts.feature_angle_deg);
    let surface = Surface::new(mesh);
    let chains: Vec<Surface> = chain_segments
        .iter()
        .map(|segs| {
            // a segment as a degenerate triangle: parry projects onto its longest edge
            let tris: Vec<[u32; 3]> = segs.iter().map(|&(a, b)| [a, b, b]).collect();
            Surface::from_triangles(mesh.positions(), &tris)
        })
        .collect();
    let n = mesh.n_vertices();
    let mut vf = vec![Vec::new(); n];
    for (f, t) in mesh.faces().iter().enumerate() {
        for &v in t {
            vf[v as usize].push(f as u32);
        }
    }
    let mut w = Work {
        pos: mesh.positions().to_vec(),
        faces: mesh.faces().to_vec(),
        alive: vec![true; mesh.n_faces()],
        vf,
        kind,
        feature,
        surface: &surface,
        chains: &chains,
    };
    let (lo, hi) = (0.8 * l, 4.0 / 3.0 * l);
    // raw tessellations have edges many times too long: split them all first
    for _ in 0..64 {
        if w.split_long(hi) == 0 {
            break;
        }
    }
    for _ in 0..opts.iterations {
        w.split_long(hi);
        w.collapse_short(lo, hi);
        w.flip_delaunay(opts.feature_angle_deg, 2);
        w.smooth();
    }
    w.flip_delaunay(opts.feature_angle_deg, 10);
    w.finish()
}

/// Feature edges (sharp or boundary), chained between corners: per vertex its kind, per feature
/// edge its chain, per chain its segments (input vertex pairs).
#[allow(clippy::type_complexity)]
fn features(
    mesh: &TriMesh,
    angle_deg: f64,
) -> (Vec<Kind>, HashMap<(u32, u32), u32>, Vec<Vec<(u32, u32)>>) {
    let cos = angle_deg.to_radians().cos();
    let n = mesh.n_vertices();
    let mut at: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut edges = Vec::new();
    for e in 0..mesh.n_edges() {
        let (h0, h1) = mesh.edge_halfedges(e);
        let sharp = match h1 {
            None => true,
            Some(h1) => {
                let a = mesh.face_normal(mesh.face_of(h0));
                let b = mesh.face_normal(mesh.face_of(h1));
                a.dot(b) < cos
            }
        };
        if sharp {
            let [a, b] = mesh.edge_vertices(e);
            at[a].push(b as u32);
            at[b].push(a as u32);
            edges.push(key(a as u32, b as u32));
        }
    }
    let turn_cos = CORNER_TURN_DEG.to_radians().cos();
    let kind: Vec<Kind> = (0..n)
        .map(|v| match at[v].len() {
            0 => Kind::Free,
            2 => {
                let p = mesh.position(v);
                let d0 = (p - mesh.position(at[v][0] as usize)).normalize_or_zero();
                let d1 = (mesh.position(at[v][1] as usize) - p).normalize_or_zero();
                if d0.dot(d1) >= turn_cos {
                    Kind::Chain(u32::MAX)
                } else {
                    Kind::Corner
                }
            }
            _ => Kind::Corner,
        })
        .collect();
    // chains: flood over feature edges through chain vertices, in edge order
    edges.sort_unstable();
    let mut chain_of: HashMap<(u32, u32), u32> = HashMap::new();
    let mut segments: Vec<Vec<(u32, u32)>> = Vec::new();
    let mut kind = kind;
    for &e in &edges {
        if chain_of.contains_key(&e) {
            continue;
        }
        let id = segments.len() as u32;
        let mut segs = Vec::new();
        let mut stack = vec![e];
        chain_of.insert(e, id);
        while let Some((a, b)) = stack.pop() {
            segs.push((a, b));
            for v in [a, b] {
                if kind[v as usize] == Kind::Corner {
                    continue;
                }
                kind[v as usize] = Kind::Chain(id);
                for &x in &at[v as usize] {
                    let k = key(v, x);
                    if let std::collections::hash_map::Entry::Vacant(slot) = chain_of.entry(k) {
                        slot.insert(id);
                        stack.push(k);
                    }
                }
            }
        }
        segments.push(segs);
    }
    (kind, chain_of, segments)
}

fn normal(a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    (b - a).cross(c - a)
}

/// Angle at `c` in triangle (a, b, c).
fn angle_at(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    (a - c).angle_between(b - c)
}

impl Work<'_> {
    fn face_normal(&self, f: u32) -> DVec3 {
        let [a, b, c] = self.faces[f as usize].map(|v| self.pos[v as usize]);
        normal(a, b, c)
    }

    /// The live faces at both `a` and `b`.
    fn edge_faces(&self, a: u32, b: u32) -> Vec<u32> {
        self.vf[a as usize]
            .iter()
            .copied()
            .filter(|&f| self.faces[f as usize].contains(&b))
            .collect()
    }

    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> = self.vf[v as usize]
            .iter()
            .flat_map(|&f| self.faces[f as usize])
            .filter(|&x| x != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    fn on_boundary(&self, v: u32) -> bool {
        self.neighbours(v)
            .iter()
            .any(|&x| self.edge_faces(v, x).len() == 1)
    }

    /// Unique edges of the live faces, sorted.
    fn edges(&self) -> Vec<(u32, u32)> {
        let mut e: Vec<(u32, u32)> = (0..self.faces.len())
            .filter(|&f| self.alive[f])
            .flat_map(|f| {
                let t = self.faces[f];
                [key(t[0], t[1]), key(t[1], t[2]), key(t[2], t[0])]
            })
            .collect();
        e.sort_unstable();
        e.dedup();
        e
    }

    fn len(&self, (a, b): (u32, u32)) -> f64 {
        (self.pos[a as usize] - self.pos[b as usize]).length()
    }

    /// One pass: every edge longer than `hi` (longest first) is split at its midpoint.
    fn split_long(&mut self, hi: f64) -> usize {
        let mut long: Vec<((u32, u32), f64)> = self
            .edges()
            .into_iter()
            .map(|e| (e, self.len(e)))
            .filter(|&(_, l)| l > hi)
            .collect();
        long.sort_by(|x, y| y.1.total_cmp(&x.1).then(x.0.cmp(&y.0)));
        let mut count = 0;
        for ((a, b), _) in long {
            let faces = self.edge_faces(a, b);
            if faces.is_empty() {
                continue;
            }
            let m = self.pos.len() as u32;
            self.pos
                .push(0.5 * (self.pos[a as usize] + self.pos[b as usize]));
            let chain = self.feature.remove(&key(a, b));
            self.kind.push(match chain {
                Some(id) => Kind::Chain(id),
                None => Kind::Free,
            });
            if let Some(id) = chain {
                self.feature.insert(key(a, m), id);
                self.feature.insert(key(m, b), id);
            }
            self.vf.push(Vec::new());
            for f in faces {
                let t = self.faces[f as usize];
                let k = (0..3)
                    .find(|&k| key(t[k], t[(k + 1) % 3]) == key(a, b))
                    .expect("the face has the edge");
                let (x, y, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let g = self.faces.len() as u32;
                self.faces[f as usize] = [x, m, c];
                self.faces.push([m, y, c]);
                self.alive.push(true);
                self.vf[y as usize].retain(|&h| h != f);
                self.vf[y as usize].push(g);
                self.vf[c as usize].push(g);
                self.vf[m as usize].extend([f, g]);
            }
            count += 1;
        }
        count
    }

    /// One pass: edges shorter than `lo` collapse into one of their ends where that keeps the
    /// mesh manifold, the features, no edge longer than `hi` and no face turned over.
    fn collapse_short(&mut self, lo: f64, hi: f64) {
        let mut short: Vec<((u32, u32), f64)> = self
            .edges()
            .into_iter()
            .map(|e| (e, self.len(e)))
            .filter(|&(_, l)| l < lo)
            .collect();
        short.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
        for ((a, b), _) in short {
            if self.vf[a as usize].is_empty() || self.vf[b as usize].is_empty() {
                continue; // collapsed away already
            }
            let faces = self.edge_faces(a, b);
            if faces.is_empty() || self.len((a, b)) >= lo {
                continue;
            }
            if !self.try_collapse(a, b, hi) {
                self.try_collapse(b, a, hi);
            }
        }
    }

    /// Collapses vertex `a` into `b` if allowed; returns whether it did.
    fn try_collapse(&mut self, a: u32, b: u32, hi: f64) -> bool {
        match self.kind[a as usize] {
            Kind::Corner => return false,
            Kind::Chain(id) => {
                if self.feature.get(&key(a, b)) != Some(&id) {
                    return false;
                }
            }
            Kind::Free => {
                if self.feature.contains_key(&key(a, b)) {
                    return false;
                }
            }
        }
        let edge_faces = self.edge_faces(a, b);
        let na = self.neighbours(a);
        let nb = self.neighbours(b);
        // link condition: the common neighbours are exactly the edge's opposite vertices
        let opposite: Vec<u32> = edge_faces
            .iter()
            .map(|&f| {
                *self.faces[f as usize]
                    .iter()
                    .find(|&&v| v != a && v != b)
                    .expect("a triangle")
            })
            .collect();
        let common = na.iter().filter(|v| nb.contains(v)).count();
        if common != opposite.len() {
            return false;
        }
        // an interior edge between two boundary vertices would pinch the surface
        if edge_faces.len() == 2 && self.on_boundary(a) && self.on_boundary(b) {
            return false;
        }
        // the opposite vertices keep at least three neighbours
        if opposite.iter().any(|&c| self.neighbours(c).len() <= 3) {
            return false;
        }
        if na.len() + nb.len() <= 6 {
            return false; // a tetrahedron-like configuration
        }
        let pb = self.pos[b as usize];
        if na
            .iter()
            .any(|&x| x != b && (self.pos[x as usize] - pb).length() > hi)
        {
            return false;
        }
        // no face turned over or made degenerate
        for &f in &self.vf[a as usize] {
            if edge_faces.contains(&f) {
                continue;
            }
            let before = self.face_normal(f);
            let t = self.faces[f as usize].map(|v| if v == a { pb } else { self.pos[v as usize] });
            let after = normal(t[0], t[1], t[2]);
            if after.length() < 1e-3 * before.length() || after.dot(before) <= 0.0 {
                return false;
            }
        }
        // apply
        for &f in &edge_faces {
            self.alive[f as usize] = false;
            for v in self.faces[f as usize] {
                self.vf[v as usize].retain(|&g| g != f);
            }
        }
        let moved = std::mem::take(&mut self.vf[a as usize]);
        for f in moved {
            for v in self.faces[f as usize].iter_mut() {
                if *v == a {
                    *v = b;
                }
            }
            self.vf[b as usize].push(f);
        }
        self.feature.remove(&key(a, b));
        for x in na {
            if let Some(id) = self.feature.remove(&key(a, x)) {
                self.feature.insert(key(b, x), id);
            }
        }
        true
    }

    /// Flips non-feature edges whose two opposite angles sum to more than π (Delaunay), where
    /// the two faces are flatter than the feature angle and the flip turns no face over; at
    /// most `passes` passes over the edges (between smoothing steps two suffice: the next
    /// round flips again).
    fn flip_delaunay(&mut self, feature_angle_deg: f64, passes: usize) {
        let cos = feature_angle_deg.to_radians().cos();
        for _ in 0..passes {
            let mut flipped = 0;
            for (a, b) in self.edges() {
                if self.feature.contains_key(&(a, b)) {
                    continue;
                }
                let faces = self.edge_faces(a, b);
                if faces.len() != 2 {
                    continue;
                }
                // orient: f = (a, b, c), g = (b, a, d)
                let (mut f, mut g) = (faces[0], faces[1]);
                let (mut a, mut b) = (a, b);
                let t = self.faces[f as usize];
                let k = t.iter().position(|&v| v == a).expect("a in f");
                if t[(k + 1) % 3] != b {
                    std::mem::swap(&mut a, &mut b);
                }
                let t = self.faces[f as usize];
                let k = t.iter().position(|&v| v == a).expect("a in f");
                if t[(k + 1) % 3] != b {
                    std::mem::swap(&mut f, &mut g);
                }
                let c = *self.faces[f as usize]
                    .iter()
                    .find(|&&v| v != a && v != b)
                    .expect("c");
                let d = *self.faces[g as usize]
                    .iter()
                    .find(|&&v| v != a && v != b)
                    .expect("d");
                let p = |v: u32| self.pos[v as usize];
                // the cheap test first: most edges are Delaunay already
                if c == d
                    || angle_at(p(a), p(b), p(c)) + angle_at(p(a), p(b), p(d))
                        <= std::f64::consts::PI + 1e-9
                    || self.neighbours(c).contains(&d)
                {
                    continue;
                }
                if self.neighbours(a).len() <= 3 || self.neighbours(b).len() <= 3 {
                    continue;
                }
                let (nf, ng) = (self.face_normal(f), self.face_normal(g));
                if nf.normalize_or_zero().dot(ng.normalize_or_zero()) < cos {
                    continue;
                }
                let n1 = normal(p(c), p(a), p(d));
                let n2 = normal(p(d), p(b), p(c));
                let avg = nf + ng;
                if n1.dot(avg) <= 0.0 || n2.dot(avg) <= 0.0 {
                    continue;
                }
                self.faces[f as usize] = [c, a, d];
                self.faces[g as usize] = [d, b, c];
                self.vf[b as usize].retain(|&h| h != f);
                self.vf[a as usize].retain(|&h| h != g);
                self.vf[d as usize].push(f);
                self.vf[c as usize].push(g);
                flipped += 1;
            }
            if flipped == 0 {
                break;
            }
        }
    }

    /// One Gauss–Seidel sweep of tangential smoothing (half way to the neighbours' centroid),
    /// each vertex projected back onto the input (or its chain); a move that turns an adjacent
    /// face by more than 60° is undone.
    fn smooth(&mut self) {
        for v in 0..self.pos.len() as u32 {
            if self.vf[v as usize].is_empty() {
                continue;
            }
            let p = self.pos[v as usize];
            let target = match self.kind[v as usize] {
                Kind::Corner => continue,
                Kind::Chain(id) => {
                    let along: Vec<u32> = self
                        .neighbours(v)
                        .into_iter()
                        .filter(|&x| self.feature.get(&key(v, x)) == Some(&id))
                        .collect();
                    if along.len() != 2 {
                        continue;
                    }
                    let q = 0.5 * (self.pos[along[0] as usize] + self.pos[along[1] as usize]);
                    let moved = p + 0.5 * (q - p);
                    match self.chains.get(id as usize) {
                        Some(s) if !s.is_empty() => s.closest(moved).0,
                        _ => continue,
                    }
                }
                Kind::Free => {
                    let nb = self.neighbours(v);
                    if nb.is_empty() {
                        continue;
                    }
                    let q =
                        nb.iter().map(|&x| self.pos[x as usize]).sum::<DVec3>() / nb.len() as f64;
                    let n = self.vf[v as usize]
                        .iter()
                        .map(|&f| self.face_normal(f))
                        .sum::<DVec3>()
                        .normalize_or_zero();
                    let d = q - p;
                    let moved = p + 0.5 * (d - n * d.dot(n));
                    self.surface.closest(moved).0
                }
            };
            if !target.is_finite() {
                continue;
            }
            let before: Vec<DVec3> = self.vf[v as usize]
                .iter()
                .map(|&f| self.face_normal(f).normalize_or_zero())
                .collect();
            self.pos[v as usize] = target;
            let ok = self.vf[v as usize]
                .iter()
                .zip(&before)
                .all(|(&f, &n0)| self.face_normal(f).normalize_or_zero().dot(n0) > 0.5);
            if !ok {
                self.pos[v as usize] = p;
            }
        }
    }

    /// Drops dead faces and unused vertices and builds the mesh.
    fn finish(self) -> Result<TriMesh, MeshError> {
        let mut index = vec![u32::MAX; self.pos.len()];
        let mut positions = Vec::new();
        let mut faces = Vec::new();
        for (f, t) in self.faces.iter().enumerate() {
            if !self.alive[f] {
                continue;
            }
            faces.push(t.map(|v| {
                if index[v as usize] == u32::MAX {
                    index[v as usize] = positions.len() as u32;
                    positions.push(self.pos[v as usize]);
                }
                index[v as usize]
            }));
        }
        TriMesh::from_triangles(positions, faces)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    /// A unit square: a fine grid on [0, 0.8] × [0, 1] and a fan of 80 needles (0.2–0.54 long)
    /// from (1, 0.5) over the strip beside it, 10 % of the area.
    #[test]
    fn fans_of_needles_many_cells_long_ask_for_a_remesh() {
        use crate::field::Symmetry;
        use crate::field::density::Density;
        let g = generate::grid(64, 80, 0.8, 1.0);
        let mut p = g.positions().to_vec();
        let mut t = g.faces().to_vec();
        // The grid's right column, bottom to top (x = 0.8).
        let column: Vec<u32> = (0..=80).map(|j| (j * 65 + 64) as u32).collect();
        let apex = p.len() as u32;
        p.push(DVec3::new(1.0, 0.5, 0.0));
        let (bottom, top) = (apex + 1, apex + 2);
        p.push(DVec3::new(1.0, 0.0, 0.0));
        p.push(DVec3::new(1.0, 1.0, 0.0));
        for w in column.windows(2) {
            t.push([w[0], apex, w[1]]);
        }
        t.push([column[0], bottom, apex]);
        t.push([column[80], apex, top]);
        let m = TriMesh::from_triangles(p, t).unwrap();
        let needles = needle_area_share(&m);
        assert!(needles > 0.05 && needles < NEEDLE_AREA_SHARE, "{needles}");
        // 3000 grid vertices (cells of 0.018): all of the fan is long needles.
        let share = long_needles(&m, &Density::TargetVertices(3000), Symmetry::Four);
        assert!(
            share.is_some_and(|s| (s - needles).abs() < 0.02),
            "{share:?}"
        );
        // 20 grid vertices (cells of 0.22): only the fan's ends are over two cells long.
        assert_eq!(
            long_needles(&m, &Density::TargetVertices(20), Symmetry::Four),
            None
        );
    }

    /// Low-poly meshes far coarser than the default grid: an icosahedron (a polyhedron) and a
    /// raw 96-gon prism (faceted: flat caps) are remeshed, a 642-vertex icosphere (smooth, no
    /// two faces coplanar) is not.
    #[test]
    fn low_poly_meshes_are_remeshed_when_polyhedra_or_faceted() {
        use crate::field::Symmetry;
        use crate::field::density::Density;
        let coarse = |m: &TriMesh| too_coarse(m, &Density::TargetVertices(10_000), Symmetry::Four);
        let icosahedron = generate::icosphere(0);
        assert_eq!(icosahedron.n_vertices(), 12);
        assert!(coarse(&icosahedron).is_some());
        let prism = generate::raw_cylinder(1.0, 2.0, 96);
        assert!(prism.n_vertices() >= POLYHEDRON_VERTICES);
        assert!(
            flat_edge_share(&prism) > FLAT_EDGE_SHARE,
            "{}",
            flat_edge_share(&prism)
        );
        assert!(coarse(&prism).is_some());
        let sphere = generate::icosphere(3);
        assert_eq!(sphere.n_vertices(), 642);
        assert_eq!(flat_edge_share(&sphere), 0.0);
        assert_eq!(coarse(&sphere), None);
    }

    #[test]
    fn flat_fans_are_fan_centres_and_cone_apexes_are_not() {
        // A capped cylinder's cap centres (64 triangles each) are flat fans; its rim vertices
        // (6 triangles) are none.
        let cyl = generate::capped_cylinder(1.0, 2.0, 64, 8, 4);
        let centres = fan_centres(&cyl);
        assert_eq!(centres.len(), 2);
        for &c in &centres {
            assert_eq!(cyl.position(c).x.abs() + cyl.position(c).y.abs(), 0.0);
        }
        // With fewer than FAN_VALENCE triangles none.
        assert!(fan_centres(&generate::capped_cylinder(1.0, 2.0, 16, 8, 4)).is_empty());
        // One cap pushed out into a cone: its apex's defect is large, so only the other cap
        // is left.
        let mut p = cyl.positions().to_vec();
        for q in p.iter_mut().filter(|q| q.z == 2.0) {
            q.z += 1.5 * (1.0 - (q.x * q.x + q.y * q.y).sqrt());
        }
        let cone = TriMesh::from_triangles(p, cyl.faces().to_vec()).unwrap();
        assert_eq!(fan_centres(&cone).len(), 1);
    }

    /// Sharp edges of `mesh` (dihedral above `deg`) as segments.
    fn sharp(mesh: &TriMesh, deg: f64) -> Vec<(DVec3, DVec3)> {
        crate::constraint::feature_edges(mesh, deg)
            .into_iter()
            .map(|e| {
                let [a, b] = mesh.edge_vertices(e);
                (mesh.position(a), mesh.position(b))
            })
            .collect()
    }

    fn segment_distance(p: DVec3, (a, b): (DVec3, DVec3)) -> f64 {
        let d = b - a;
        let t = ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
        (a + t * d - p).length()
    }

    /// A raw CAD cylinder (needles, fanned caps) becomes near-equilateral triangles on the same
    /// surface, with the same topology, its rims kept as sharp edges, and the same result twice.
    #[test]
    fn a_raw_cylinder_is_remeshed_on_its_surface_with_its_rims() {
        let raw = generate::raw_cylinder(0.5, 1.2, 48);
        assert!(needs_remesh(&raw), "{}", needle_area_share(&raw));
        let opts = IsotropicOptions::for_vertices(&raw, 3000, 35.0);
        let out = isotropic_remesh(&raw, &opts).unwrap();
        let again = isotropic_remesh(&raw, &opts).unwrap();
        assert_eq!(out.positions(), again.positions(), "deterministic");
        assert_eq!(out.faces(), again.faces(), "deterministic");
        assert!(!needs_remesh(&out));
        assert!(
            needle_area_share(&out) < 0.01,
            "{}",
            needle_area_share(&out)
        );
        assert!(
            (2000..4500).contains(&out.n_vertices()),
            "{} vertices",
            out.n_vertices()
        );
        assert_eq!(out.euler_characteristic(), raw.euler_characteristic());
        assert_eq!(out.boundary_loops().len(), 0);
        // every vertex on the input (the faceted side, the flat caps)
        let surface = Surface::new(&raw);
        for &p in out.positions() {
            assert!(surface.distance(p) < 1e-9, "{p} off the input");
        }
        // the rims: every input rim edge covered by sharp edges of the output, and no other
        let rims = sharp(&raw, 60.0);
        assert_eq!(rims.len(), 2 * 48);
        let kept = sharp(&out, 60.0);
        for &(a, b) in &rims {
            for k in 0..=4 {
                let p = a.lerp(b, k as f64 / 4.0);
                let d = kept
                    .iter()
                    .map(|&s| segment_distance(p, s))
                    .fold(f64::INFINITY, f64::min);
                // the output's rim is a polygon inscribed in the input's: it cuts the input's
                // vertices (7.5° turns) by at most its sagitta
                let sagitta = opts.edge_length.powi(2) / (8.0 * 0.5);
                assert!(
                    d < 2.0 * sagitta,
                    "rim point {p} is {d} from the output's sharp edges"
                );
            }
        }
        for &(a, b) in &kept {
            for p in [a, b] {
                let d = rims
                    .iter()
                    .map(|&s| segment_distance(p, s))
                    .fold(f64::INFINITY, f64::min);
                assert!(d < 1e-12, "rim vertex {p} is {d} off the input's rims");
            }
            let z = [a.z, b.z];
            assert!(
                z.iter().all(|z| z.abs() < 1e-12) || z.iter().all(|z| (z - 1.2).abs() < 1e-12),
                "sharp edge {a}–{b} off the rims"
            );
        }
        // near-uniform edge lengths
        let lengths: Vec<f64> = (0..out.n_edges())
            .map(|e| {
                let [a, b] = out.edge_vertices(e);
                (out.position(a) - out.position(b)).length()
            })
            .collect();
        let mean = lengths.iter().sum::<f64>() / lengths.len() as f64;
        let rsd = (lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / lengths.len() as f64)
            .sqrt()
            / mean;
        assert!(rsd < 0.2, "edge length RSD {rsd}");
        assert!(
            (mean / opts.edge_length - 1.0).abs() < 0.25,
            "mean edge {mean}"
        );
    }

    /// A disc with a boundary: the boundary stays where it was (its corners exactly), the
    /// interior stays in the plane.
    #[test]
    fn the_boundary_and_its_corners_are_kept() {
        let grid = generate::grid(3, 2, 3.0, 2.0); // coarse: long edges to split
        let opts = IsotropicOptions {
            edge_length: 0.1,
            feature_angle_deg: 35.0,
            iterations: 10,
        };
        let out = isotropic_remesh(&grid, &opts).unwrap();
        assert_eq!(out.boundary_loops().len(), 1);
        assert_eq!(out.euler_characteristic(), 1);
        for corner in [
            DVec3::ZERO,
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(3.0, 2.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
        ] {
            assert!(
                out.positions()
                    .iter()
                    .any(|&p| (p - corner).length() < 1e-12),
                "corner {corner} lost"
            );
        }
        for v in 0..out.n_vertices() {
            let p = out.position(v);
            assert!(p.z.abs() < 1e-12);
            if out.is_boundary_vertex(v) {
                let on = p.x.abs() < 1e-9
                    || (p.x - 3.0).abs() < 1e-9
                    || p.y.abs() < 1e-9
                    || (p.y - 2.0).abs() < 1e-9;
                assert!(on, "boundary vertex {p} off the rectangle");
            }
        }
        let area: f64 = (0..out.n_faces()).map(|f| out.face_area(f)).sum();
        assert!((area - 6.0).abs() < 1e-9, "area {area}");
        for f in 0..out.n_faces() {
            assert!(out.face_normal(f).z > 0.0, "face {f} turned over");
        }
    }

    /// The shared meshes' kind of input is not remeshed by itself.
    #[test]
    fn well_shaped_meshes_do_not_need_it() {
        assert!(!needs_remesh(&generate::capped_cylinder(
            0.5, 1.2, 64, 24, 12
        )));
        assert!(!needs_remesh(&generate::icosphere(3)));
        assert!(!needs_remesh(&generate::torus(1.0, 0.3, 40, 16)));
    }
}
