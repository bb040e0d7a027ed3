//! Tangential relaxation of a remesh on the input surface (the last step of Instant Meshes and
//! QuadWild): the connectivity stays, the vertices move to even out edge lengths and angles.
//!
//! Each iteration is one local/global step of the square fit ([`super::square_fit`]): every
//! face gets its ideal polygon (a square or equilateral triangle of the remesh's mean edge
//! length, turned to fit it in its tangent plane), then one sparse solve moves all vertices at
//! once, each in its tangent plane, to match those polygons best. Then:
//! - *free* vertices are projected back onto the input ([`Surface`]);
//! - *sliding* vertices (on a constraint chain: boundary loops, feature curves) move along the
//!   chain's tangent only and are projected onto that chain, near where they were (never onto
//!   another chain passing nearby);
//! - *fixed* vertices (chain corners: input vertices with a number of constrained edges other
//!   than two, or where the chain turns by more than `corner_angle_deg` both between its
//!   neighbours and between the points a remesh edge length away along it, so that a scan's
//!   jagged boundary is not all corners) do not move.
//!
//! The solve is global, so the sizes even out across the mesh in a few iterations, where the
//! Jacobi smoothing this replaced moved each vertex towards its neighbours only
//! (`docs/remesh.md` has both measured). What it cannot even out is the map's own variation of
//! scale along the grid's rows: the connectivity fixes how many quads go around each part.
//!
//! After each step, faces that would flip against the input (their Newell normal against the
//! input's normal at the closest point to the face centroid, with a margin) or whose smallest
//! corner angle would drop below `min(previous, min_angle_deg)` have their vertices' steps
//! halved, up to three times, then put back; repeated until no face is made worse. So no face
//! flips that was not flipped before, and the smallest corner angle of the mesh never
//! decreases.
//!
//! Last, under the same guard, chain vertices move onto an input vertex of their chain between
//! their chain neighbours where the two edges then follow the chain closer (a crease bending
//! within a cell), and vertices beside a loose end of a chain (a crease fading out) onto it.

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use super::square_fit::{TangentFrame, TangentSystem, ideal_polygons};
use super::surface::Surface;
use super::{Origin, Remesh};
use crate::mesh::TriMesh;

/// Options of [`relax`].
#[derive(Clone, Debug)]
pub struct RelaxOptions {
    /// Local/global iterations of the square fit (0 = off).
    pub iterations: usize,
    /// How strongly each vertex is pulled towards where it is in each step (μ of the square
    /// fit, against 1 per corner pair the vertex is in: a quad vertex of valence 4 is in 12):
    /// small values take the whole step of the fit at once.
    pub pull: f64,
    /// How much every face is fitted to one common size (the mean edge length) rather than to
    /// its own (0..=1; the square fit's size blend): 1 evens out edge lengths across the mesh
    /// at some cost in angles where the map's scale varies, 0 evens out shapes only.
    pub size_weight: f64,
    /// Chains of constrained input edges turning by more than this (degrees) at a vertex have a
    /// fixed corner there.
    pub corner_angle_deg: f64,
    /// Corner angles (degrees) are kept at least at `min(what they were, max(this, the
    /// remesh's smallest angle))`: no corner drops below the smallest one of the input.
    pub min_angle_deg: f64,
    /// After the iterations, slide chain vertices to bring the corners around them nearer to
    /// square (`RelaxStats::evened`).
    pub even_corners: bool,
}

impl Default for RelaxOptions {
    fn default() -> Self {
        RelaxOptions {
            iterations: 9,
            pull: 0.1,
            size_weight: 0.75,
            corner_angle_deg: 30.0,
            min_angle_deg: 15.0,
            even_corners: true,
        }
    }
}

/// What [`relax`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RelaxStats {
    /// Vertices whose position changed.
    pub moved: usize,
    /// Largest distance of a vertex from where it started (absolute, in mesh units).
    pub max_offset: f64,
    /// Vertices that slid along a constraint chain / stayed fixed / moved freely.
    pub sliding: usize,
    pub fixed: usize,
    pub free: usize,
    /// Vertex steps put back because a face would have flipped or degenerated.
    pub rejected: usize,
    /// Chain vertices moved after the iterations onto a bend of their chain (the edges to
    /// their chain neighbours then follow it closer) or onto a loose end of it.
    pub fitted: usize,
    /// Chain vertices slid after the iterations to bring the corners around them nearer to
    /// square (a boundary the grid meets obliquely).
    pub evened: usize,
    pub iterations: usize,
}

/// A chain of constrained input edges between corners (or a closed loop without corners).
struct Chain {
    /// Input vertices in order; a closed chain repeats its first vertex at the end.
    verts: Vec<usize>,
    pts: Vec<DVec3>,
    closed: bool,
    boundary: bool,
}

impl Chain {
    fn n_segments(&self) -> usize {
        self.pts.len() - 1
    }

    /// The closest point to `q` on the segments within reach `reach` (arc length) of segment
    /// `s`, and its segment.
    fn project_near(&self, q: DVec3, s: usize, reach: f64) -> (DVec3, usize) {
        let ns = self.n_segments();
        let seg = |i: usize| (self.pts[i], self.pts[i + 1]);
        let on = |i: usize| closest_on_segment(q, self.pts[i], self.pts[i + 1]);
        let mut best = (on(s), s);
        let mut best_d = (best.0 - q).length_squared();
        for dir in [1i64, -1] {
            // always the next segment on each side, further ones within reach
            let (mut i, mut walked) = (s as i64, 0.0);
            for _ in 1..ns {
                i += dir;
                if !self.closed && (i < 0 || i >= ns as i64) {
                    break;
                }
                let k = i.rem_euclid(ns as i64) as usize;
                let p = on(k);
                let d = (p - q).length_squared();
                if d < best_d {
                    best_d = d;
                    best = (p, k);
                }
                let (a, b) = seg(k);
                walked += (b - a).length();
                if walked > reach {
                    break;
                }
            }
        }
        best
    }

    /// Chain points strictly after location `from` up to location `to` (locations are segment
    /// indices; a point i is at location i), the shorter way round on a closed chain.
    fn points_between(&self, from: usize, to: usize) -> Vec<usize> {
        let ns = self.n_segments();
        if !self.closed {
            return (from.min(to) + 1..=from.max(to)).collect();
        }
        let fwd = (to + ns - from) % ns;
        let (start, count) = if fwd <= ns - fwd {
            (from, fwd)
        } else {
            (to, ns - fwd)
        };
        (1..=count).map(|k| (start + k) % ns).collect()
    }

    /// Places on the chain between locations `from` and `to` through `at` (the chain points
    /// strictly between, and the quarter points of the segments at them), with their segment.
    fn places_between(&self, from: usize, at: usize, to: usize) -> Vec<(DVec3, usize)> {
        let ns = self.n_segments();
        let mut places = Vec::new();
        for i in self.points_around(from, at, to) {
            places.push((self.pts[i], i.min(ns - 1)));
            let before = if self.closed {
                Some((i + ns - 1) % ns)
            } else {
                i.checked_sub(1)
            };
            for j in [before, Some(i)].into_iter().flatten().filter(|&j| j < ns) {
                for t in [0.25, 0.5, 0.75] {
                    places.push((self.pts[j].lerp(self.pts[j + 1], t), j));
                }
            }
        }
        places
    }

    /// Chain points strictly between locations `from` and `to`, by way of `at`.
    fn points_around(&self, from: usize, at: usize, to: usize) -> Vec<usize> {
        let mut points = self.points_between(from, at);
        points.extend(self.points_between(at, to));
        points
    }

    /// The largest distance of the chain points strictly between locations `from` and `to`
    /// from the chord [p, q].
    fn chord_deviation(&self, p: DVec3, q: DVec3, from: usize, to: usize) -> f64 {
        self.points_between(from, to)
            .into_iter()
            .map(|i| (closest_on_segment(self.pts[i], p, q) - self.pts[i]).length())
            .fold(0.0, f64::max)
    }

    /// Where a vertex at `now` (on segment `seg`) between chain neighbours `ends` (at
    /// locations `locs`) follows the chain best with its two chords: the chain point between
    /// the neighbours with the smallest largest deviation of the chain from the chords, both
    /// at least `min_length` long; `None` when no point qualifies.
    fn chord_fit(
        &self,
        ends: [DVec3; 2],
        locs: [usize; 2],
        now: DVec3,
        seg: usize,
        min_length: f64,
    ) -> Option<ChordFit> {
        let deviation_at = |p: DVec3, loc: usize| {
            self.chord_deviation(ends[0], p, locs[0], loc)
                .max(self.chord_deviation(p, ends[1], loc, locs[1]))
        };
        let deviation_now = deviation_at(now, seg);
        self.points_around(locs[0], seg, locs[1])
            .into_iter()
            .filter(|&i| {
                let p = self.pts[i];
                (p - ends[0]).length() >= min_length && (p - ends[1]).length() >= min_length
            })
            .map(|i| (deviation_at(self.pts[i], i), i))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .map(|(deviation, i)| ChordFit {
                point: self.pts[i],
                segment: i.min(self.n_segments() - 1),
                deviation,
                deviation_now,
            })
    }

    /// The closest point to `q` on the whole chain (squared distance, segment).
    fn project_all(&self, q: DVec3) -> (f64, usize) {
        (0..self.n_segments())
            .map(|i| {
                let p = closest_on_segment(q, self.pts[i], self.pts[i + 1]);
                ((p - q).length_squared(), i)
            })
            .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a })
    }
}

/// A chain vertex's better place ([`Chain::chord_fit`]).
struct ChordFit {
    point: DVec3,
    segment: usize,
    /// The largest distance of the chain from the two chords there, and where the vertex is.
    deviation: f64,
    deviation_now: f64,
}

/// The point of segment [a, b] closest to q (a for a degenerate segment).
fn closest_on_segment(q: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    a + (b - a) * crate::mesh::segment_parameter(q, a, b)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Fixed,
    Free,
    Slide(u32),
}

/// Constraint chains of the input and where each input vertex / edge lies on them.
struct Chains {
    chains: Vec<Chain>,
    /// Per input edge: (chain, segment) if constrained.
    edge: Vec<Option<(u32, u32)>>,
    /// Per input vertex: a (chain, segment) through it, unless it is a corner or unconstrained.
    vertex: Vec<Option<(u32, u32)>>,
    corner: Vec<bool>,
}

/// The input's constraint chains; a chain turning by more than `corner_angle_deg` at a vertex
/// has a corner there if it also turns by more than that between the points `scale` away along
/// the chain on either side: a scan's jagged boundary turns sharply at many vertices, but
/// not over a remesh edge.
fn build_chains(
    input: &TriMesh,
    constrained: &[bool],
    corner_angle_deg: f64,
    scale: f64,
) -> Chains {
    let nv = input.n_vertices();
    let ne = input.n_edges();
    let is_con =
        |e: usize| input.is_boundary_edge(e) || constrained.get(e).copied().unwrap_or(false);
    let mut incident: Vec<Vec<usize>> = vec![Vec::new(); nv];
    for e in 0..ne {
        if is_con(e) {
            let [a, b] = input.edge_vertices(e);
            incident[a].push(e);
            incident[b].push(e);
        }
    }
    let other = |e: usize, v: usize| {
        let [a, b] = input.edge_vertices(e);
        if a == v { b } else { a }
    };
    let cos_max = corner_angle_deg.to_radians().cos();
    let corner: Vec<bool> = (0..nv)
        .map(|v| match incident[v].len() {
            0 => false,
            2 => {
                let p = input.position(v);
                // the point `scale` away along the chain, or where the chain ends or branches
                let reach = |first: usize| {
                    let (mut e, mut q) = (first, other(first, v));
                    let mut walked = (input.position(q) - p).length();
                    // at most 64 input edges: a remesh edge spans a few on any input we take
                    for _ in 0..64 {
                        if walked >= scale || incident[q].len() != 2 || q == v {
                            break;
                        }
                        let Some(g) = incident[q].iter().copied().find(|&g| g != e) else {
                            break;
                        };
                        let r = other(g, q);
                        walked += (input.position(r) - input.position(q)).length();
                        (e, q) = (g, r);
                    }
                    input.position(q)
                };
                // turn angle between (p − a) and (b − p)
                let turns = |a: DVec3, b: DVec3| {
                    let (u, w) = ((p - a).normalize_or_zero(), (b - p).normalize_or_zero());
                    u.dot(w) < cos_max
                };
                let near = |e: usize| input.position(other(e, v));
                turns(near(incident[v][0]), near(incident[v][1]))
                    && turns(reach(incident[v][0]), reach(incident[v][1]))
            }
            _ => true,
        })
        .collect();
    let mut edge: Vec<Option<(u32, u32)>> = vec![None; ne];
    let mut chains = Vec::new();
    let mut walk = |start: usize, e0: usize, edge: &mut Vec<Option<(u32, u32)>>| {
        let id = chains.len() as u32;
        let mut verts = vec![start];
        let (mut v, mut e) = (start, e0);
        loop {
            edge[e] = Some((id, verts.len() as u32 - 1));
            let w = other(e, v);
            verts.push(w);
            if w == start || corner[w] {
                break;
            }
            // a non-corner constrained vertex has exactly two constrained edges
            let next = incident[w].iter().copied().find(|&g| g != e);
            match next {
                Some(g) if edge[g].is_none() => {
                    v = w;
                    e = g;
                }
                _ => break,
            }
        }
        let closed = verts.first() == verts.last() && !corner[start];
        let pts = verts.iter().map(|&v| input.position(v)).collect();
        chains.push(Chain {
            verts,
            pts,
            closed,
            boundary: input.is_boundary_edge(e0),
        });
    };
    for v in 0..nv {
        if corner[v] {
            for &e in &incident[v] {
                if edge[e].is_none() {
                    walk(v, e, &mut edge);
                }
            }
        }
    }
    for e in 0..ne {
        if is_con(e) && edge[e].is_none() {
            let [a, _] = input.edge_vertices(e);
            walk(a, e, &mut edge);
        }
    }
    let vertex = (0..nv)
        .map(|v| {
            if corner[v] {
                return None;
            }
            incident[v].first().and_then(|&e| edge[e])
        })
        .collect();
    Chains {
        chains,
        edge,
        vertex,
        corner,
    }
}

/// The input's (vertex-normal interpolated) unit normal at a projection.
fn normal_at(input: &TriMesh, vn: &[DVec3], face: usize, bary: [f64; 3]) -> DVec3 {
    if face >= input.n_faces() {
        return DVec3::ZERO;
    }
    let [a, b, c] = input.face(face);
    let n = vn[a] * bary[0] + vn[b] * bary[1] + vn[c] * bary[2];
    let n = n.normalize_or_zero();
    if n == DVec3::ZERO {
        input.face_normal(face)
    } else {
        n
    }
}

fn newell(p: &[DVec3], f: &[u32]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for k in 0..f.len() {
        let (a, b) = (p[f[k] as usize], p[f[(k + 1) % f.len()] as usize]);
        n += a.cross(b);
    }
    n
}

/// A face's corner angles (degrees; 0 at a degenerate corner).
fn corner_angles_deg<'a>(p: &'a [DVec3], f: &'a [u32]) -> impl Iterator<Item = f64> + 'a {
    let n = f.len();
    (0..n).map(move |k| {
        let a = p[f[k] as usize];
        let b = p[f[(k + 1) % n] as usize];
        let c = p[f[(k + n - 1) % n] as usize];
        let ang = (c - a).angle_between(b - a).to_degrees();
        if ang.is_finite() { ang } else { 0.0 }
    })
}

/// How far a face's corners are from square: degrees outside [30°, 150°] ten times, plus
/// degrees outside [45°, 135°].
fn corner_penalty(p: &[DVec3], f: &[u32]) -> f64 {
    corner_angles_deg(p, f)
        .map(|t| {
            10.0 * ((30.0 - t).max(0.0) + (t - 150.0).max(0.0)) + ((t - 90.0).abs() - 45.0).max(0.0)
        })
        .sum()
}

fn min_corner_deg(p: &[DVec3], f: &[u32]) -> f64 {
    corner_range_deg(p, f)[0]
}

/// The smallest and the largest corner angle of a face (degrees).
fn corner_range_deg(p: &[DVec3], f: &[u32]) -> [f64; 2] {
    corner_angles_deg(p, f).fold([f64::INFINITY, 0.0], |r, a| [r[0].min(a), r[1].max(a)])
}

/// Relaxes the vertices of `remesh` tangentially on `input` (see the module docs).
/// `constrained[e]` (per input edge; may be empty) marks feature / constraint edges; boundary
/// edges are always constrained. Polyline-only remeshes (stripes) are left as they are.
pub fn relax(
    remesh: &mut Remesh,
    input: &TriMesh,
    constrained: &[bool],
    opts: &RelaxOptions,
) -> RelaxStats {
    relax_until(remesh, input, constrained, opts, &|| false)
}

/// [`relax`], stopping after the iteration during which `cancel` turns true (the positions are
/// then those of the last finished iteration).
pub fn relax_until(
    remesh: &mut Remesh,
    input: &TriMesh,
    constrained: &[bool],
    opts: &RelaxOptions,
    cancel: &(dyn Fn() -> bool + Sync),
) -> RelaxStats {
    relax_holding(remesh, input, constrained, &[], opts, cancel)
}

/// [`relax_until`] with the vertices `held[v]` (may be shorter than the vertex list) kept where
/// they are, like chain corners.
pub fn relax_holding(
    remesh: &mut Remesh,
    input: &TriMesh,
    constrained: &[bool],
    held: &[bool],
    opts: &RelaxOptions,
    cancel: &(dyn Fn() -> bool + Sync),
) -> RelaxStats {
    let n = remesh.positions.len();
    if remesh.faces.is_empty() || n == 0 || input.n_faces() == 0 || opts.iterations == 0 {
        return RelaxStats::default();
    }
    let faces = &remesh.faces;
    if faces.iter().flatten().any(|&v| v as usize >= n) {
        return RelaxStats::default();
    }
    // --- remesh adjacency ---------------------------------------------------------------
    let mut vertex_faces: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut undirected: HashMap<(u32, u32), u32> = HashMap::new();
    for (fi, f) in faces.iter().enumerate() {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            if vertex_faces[a as usize].last() != Some(&(fi as u32)) {
                vertex_faces[a as usize].push(fi as u32);
            }
            *undirected.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
    let mut on_boundary = vec![false; n];
    let mut boundary_edges: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (&(a, b), &c) in &undirected {
        if a == b {
            continue;
        }
        neighbours[a as usize].push(b);
        neighbours[b as usize].push(a);
        if c == 1 {
            on_boundary[a as usize] = true;
            on_boundary[b as usize] = true;
            boundary_edges[a as usize].push(b);
            boundary_edges[b as usize].push(a);
        }
    }
    for l in neighbours.iter_mut().chain(boundary_edges.iter_mut()) {
        l.sort_unstable();
    }
    // --- classification -------------------------------------------------------------------
    let rest = {
        let mut edges: Vec<(u32, u32)> =
            undirected.keys().copied().filter(|e| e.0 != e.1).collect();
        edges.sort_unstable();
        let p = &remesh.positions;
        edges
            .iter()
            .map(|&(a, b)| (p[a as usize] - p[b as usize]).length())
            .sum::<f64>()
            / edges.len().max(1) as f64
    };
    let chains = build_chains(input, constrained, opts.corner_angle_deg, rest);
    let (lo, hi) = input.bounding_box();
    let diag = (hi - lo).length().max(1e-300);
    let start = remesh.positions.clone();
    let nearest_boundary_chain = |p: DVec3| -> Option<(u32, u32)> {
        let mut best: Option<(f64, u32, u32)> = None;
        for (c, ch) in chains.chains.iter().enumerate() {
            if !ch.boundary {
                continue;
            }
            let (d2, s) = ch.project_all(p);
            if best.is_none_or(|b| d2 < b.0) {
                best = Some((d2, c as u32, s as u32));
            }
        }
        best.filter(|b| b.0.sqrt() <= 1e-6 * diag)
            .map(|b| (b.1, b.2))
    };
    let mut kind = vec![Kind::Free; n];
    let mut seg = vec![0u32; n];
    for v in 0..n {
        if held.get(v).copied().unwrap_or(false) {
            kind[v] = Kind::Fixed;
            continue;
        }
        let bd = on_boundary[v];
        let origin = remesh.origins.get(v).copied().unwrap_or(Origin::Unknown);
        let on_chain = match origin {
            Origin::Vertex(u) if (u as usize) < input.n_vertices() => {
                if chains.corner[u as usize] {
                    kind[v] = Kind::Fixed;
                    continue;
                }
                chains.vertex[u as usize]
            }
            Origin::Edge(e) if (e as usize) < input.n_edges() => chains.edge[e as usize],
            _ => None,
        };
        let found = match on_chain {
            Some(cs) if !bd || chains.chains[cs.0 as usize].boundary => Some(cs),
            _ if bd => {
                let f = nearest_boundary_chain(start[v]);
                if f.is_none() {
                    // a remesh boundary away from the input boundary (a patched hole)
                    kind[v] = Kind::Fixed;
                    continue;
                }
                f
            }
            _ => None,
        };
        if let Some((c, s)) = found {
            kind[v] = Kind::Slide(c);
            seg[v] = s;
        }
    }
    // Sliding vertices need their two neighbours along the chain; otherwise they stay.
    let chain_ends = |c: u32| {
        let ch = &chains.chains[c as usize];
        (ch.verts[0], ch.verts[ch.verts.len() - 1])
    };
    let on_same_chain = |w: usize, c: u32| match kind[w] {
        Kind::Slide(d) => d == c,
        Kind::Fixed => match remesh.origins.get(w) {
            Some(Origin::Vertex(u)) => {
                let (a, b) = chain_ends(c);
                *u as usize == a || *u as usize == b
            }
            _ => false,
        },
        Kind::Free => false,
    };
    let chain_nbrs: Vec<Option<[u32; 2]>> = (0..n)
        .map(|v| {
            let Kind::Slide(c) = kind[v] else { return None };
            let cand = if chains.chains[c as usize].boundary {
                &boundary_edges[v]
            } else {
                &neighbours[v]
            };
            let list: Vec<u32> = cand
                .iter()
                .copied()
                .filter(|&w| on_same_chain(w as usize, c))
                .collect();
            (list.len() == 2).then(|| [list[0], list[1]])
        })
        .collect();
    // Those with one neighbour on their chain may sit next to where the chain ends (a crease
    // fading out): they move onto that end below.
    let mut ending: Vec<Option<u32>> = vec![None; n];
    for v in 0..n {
        if let (Kind::Slide(c), None) = (kind[v], chain_nbrs[v]) {
            kind[v] = Kind::Fixed;
            ending[v] = Some(c);
        }
    }
    let mut stats = RelaxStats {
        sliding: kind.iter().filter(|k| matches!(k, Kind::Slide(_))).count(),
        fixed: kind.iter().filter(|k| **k == Kind::Fixed).count(),
        free: kind.iter().filter(|k| **k == Kind::Free).count(),
        ..Default::default()
    };
    // --- iterations -------------------------------------------------------------------------
    let surface = Surface::new(input);
    let vn = input.vertex_normals();
    let pull = opts.pull.max(1e-9);
    // held directions: far stronger than any vertex's corner-pair count
    const HOLD: f64 = 1e9;
    // Iterations per set of tangent frames (a factorization each): the planes turn as the
    // vertices move, and a fit in stale planes stops short (docs/remesh.md).
    const REFRAME: usize = 3;
    // Halvings of a vertex's step before it is put back where it was.
    const STEP_HALVINGS: usize = 3;
    // A chain vertex moves onto a bend of its chain when that at least halves the largest
    // distance of the chain from the chords to its two neighbours (not when that distance is
    // under 5 % of the mean edge), keeping both chords at least 0.35 mean edges long.
    const CHORD_GAIN: f64 = 0.5;
    const CHORD_NEGLIGIBLE: f64 = 0.05;
    const CHORD_MIN_LENGTH: f64 = 0.35;
    // Corners the moves onto bends keep to, where they were (the remesh issue's range).
    const FIT_CORNERS_DEG: [f64; 2] = [30.0, 150.0];
    const LOOSE_END_REACH: f64 = 0.25;
    const CORNER_PASSES: usize = 2;
    let face_normal_ref = |p: &[DVec3], f: &[u32]| {
        let c = f.iter().map(|&v| p[v as usize]).sum::<DVec3>() / f.len() as f64;
        let r = surface.project(c);
        normal_at(input, &vn, r.face, r.bary)
    };
    let face_state = |p: &[DVec3], f: &[u32]| {
        let nn = newell(p, f).normalize_or_zero();
        (nn.dot(face_normal_ref(p, f)), min_corner_deg(p, f))
    };
    let mut pos = remesh.positions.clone();
    let mut state: Vec<(f64, f64)> = faces.par_iter().map(|f| face_state(&pos, f)).collect();
    // Corner angles stay above min(what they were, this): the mesh's smallest angle never drops.
    let angle_floor = state
        .iter()
        .map(|s| s.1)
        .fold(f64::INFINITY, f64::min)
        .max(opts.min_angle_deg);
    // tangent frames where the vertices are: chain tangent for sliding vertices
    let frames_at = |pos: &[DVec3]| -> Vec<TangentFrame> {
        (0..n)
            .into_par_iter()
            .map(|v| {
                let here = surface.project(pos[v]);
                let nrm = normal_at(input, &vn, here.face, here.bary);
                let (a, b) = nrm.any_orthonormal_pair();
                let fixed = TangentFrame {
                    t: [a, b],
                    pull: [HOLD; 2],
                };
                match kind[v] {
                    Kind::Fixed => fixed,
                    Kind::Free => TangentFrame {
                        t: [a, b],
                        pull: [pull; 2],
                    },
                    Kind::Slide(_) => {
                        let [a, b] = chain_nbrs[v].unwrap_or([v as u32; 2]);
                        let t = pos[b as usize] - pos[a as usize];
                        let t = (t - nrm * t.dot(nrm)).normalize_or_zero();
                        if t == DVec3::ZERO {
                            return fixed;
                        }
                        TangentFrame {
                            t: [t, nrm.cross(t)],
                            pull: [pull, HOLD],
                        }
                    }
                }
            })
            .collect()
    };
    let Some(mut system) = TangentSystem::new(faces, n) else {
        return stats;
    };
    for it in 0..opts.iterations {
        if cancel() {
            break;
        }
        if it % REFRAME == 0 && !system.reframe(faces, frames_at(&pos), &pos) {
            break;
        }
        stats.iterations += 1;
        let ideal = ideal_polygons(&pos, faces, system.frames(), rest, opts.size_weight);
        let Some(fitted) = system.step(&pos, faces, &ideal) else {
            break;
        };
        // Vertex v's step scaled by `t`, on its chain or the surface.
        let place = |from: &[DVec3], v: usize, t: f64| -> (DVec3, u32) {
            let p = from[v];
            let q = p + (fitted[v] - p) * t;
            match kind[v] {
                Kind::Fixed => (p, seg[v]),
                Kind::Slide(c) => {
                    let ch = &chains.chains[c as usize];
                    let (np, s) = ch.project_near(q, seg[v] as usize, 2.0 * (q - p).length());
                    (np, s as u32)
                }
                Kind::Free if q.is_finite() => (surface.closest(q).0, 0),
                Kind::Free => (p, 0),
            }
        };
        let mut updates: Vec<(DVec3, u32)> = (0..n)
            .into_par_iter()
            .map(|v| place(&pos, v, 1.0))
            .collect();
        let old = pos.clone();
        let mut reverted = vec![false; n];
        let mut scale = vec![1.0f64; n];
        for v in 0..n {
            pos[v] = updates[v].0;
        }
        // Shorten the steps of the vertices of faces made worse (halved up to
        // `STEP_HALVINGS` times, then put back), until no face is worse: a region whose whole
        // step would fold a face still moves part of the way.
        let mut check: Vec<u32> = (0..faces.len() as u32).collect();
        let mut new_state = state.clone();
        while !check.is_empty() {
            let results: Vec<(u32, (f64, f64))> = check
                .par_iter()
                .map(|&fi| (fi, face_state(&pos, &faces[fi as usize])))
                .collect();
            let mut bad_vertices = Vec::new();
            for (fi, (cos, ang)) in results {
                let (cos0, ang0) = state[fi as usize];
                new_state[fi as usize] = (cos, ang);
                let worse = cos < cos0.min(0.2) || ang < ang0.min(angle_floor);
                if worse {
                    for &v in &faces[fi as usize] {
                        if !reverted[v as usize] && pos[v as usize] != old[v as usize] {
                            bad_vertices.push(v);
                        }
                    }
                }
            }
            bad_vertices.sort_unstable();
            bad_vertices.dedup();
            let mut next: Vec<u32> = Vec::new();
            for &v in &bad_vertices {
                let v = v as usize;
                scale[v] *= 0.5;
                if scale[v] < 0.5f64.powi(STEP_HALVINGS as i32) {
                    pos[v] = old[v];
                    reverted[v] = true;
                    stats.rejected += 1;
                } else {
                    let (p, s) = place(&old, v, scale[v]);
                    pos[v] = p;
                    updates[v].1 = s;
                }
                next.extend_from_slice(&vertex_faces[v]);
            }
            next.sort_unstable();
            next.dedup();
            check = next;
        }
        state = new_state;
        for v in 0..n {
            if !reverted[v] {
                seg[v] = updates[v].1;
            }
        }
    }
    // Moves vertex v to `to` unless a face of it gets worse (as in the iterations) or gets a
    // corner outside [30°, 150°] further out than its corners were.
    let try_move = |pos: &mut Vec<DVec3>,
                    state: &mut Vec<(f64, f64)>,
                    v: usize,
                    to: DVec3,
                    keep_corners: bool| {
        let fs = &vertex_faces[v];
        let ranges = |pos: &[DVec3]| -> Vec<[f64; 2]> {
            fs.iter()
                .map(|&fi| corner_range_deg(pos, &faces[fi as usize]))
                .collect()
        };
        // only when the corners are kept
        let before = if keep_corners {
            ranges(pos)
        } else {
            Vec::new()
        };
        let old = pos[v];
        pos[v] = to;
        let after: Vec<(f64, f64)> = fs
            .iter()
            .map(|&fi| face_state(pos, &faces[fi as usize]))
            .collect();
        let widened = keep_corners
            && before.iter().zip(ranges(pos)).any(|(b, a)| {
                a[0] < b[0].min(FIT_CORNERS_DEG[0]) || a[1] > b[1].max(FIT_CORNERS_DEG[1])
            });
        let worse = widened
            || fs.iter().zip(&after).any(|(&fi, &(cos, ang))| {
                let (cos0, ang0) = state[fi as usize];
                cos < cos0.min(0.2) || ang < ang0.min(angle_floor)
            });
        if worse {
            pos[v] = old;
            return false;
        }
        for (&fi, &s) in fs.iter().zip(&after) {
            state[fi as usize] = s;
        }
        true
    };
    // Vertices beside a loose end of their chain (an end no other chain shares: a crease
    // fading out) move onto it when it is within a quarter of an edge: the edge beyond runs
    // on along the line, and the chain is followed to its end. A short step, so only the
    // iterations' guard applies (fandisk's crease ends sit among corners of 150°–155°).
    let mut ends_at: HashMap<usize, usize> = HashMap::new();
    for ch in chains.chains.iter().filter(|ch| !ch.closed) {
        for u in [ch.verts[0], ch.verts[ch.verts.len() - 1]] {
            *ends_at.entry(u).or_default() += 1;
        }
    }
    for v in 0..n {
        let Some(c) = ending[v] else { continue };
        let ch = &chains.chains[c as usize];
        if ch.closed {
            continue;
        }
        let loose = [0, ch.n_segments()]
            .into_iter()
            .filter(|&i| ends_at.get(&ch.verts[i]) == Some(&1))
            .map(|i| ((ch.pts[i] - pos[v]).length(), i))
            .filter(|&(d, _)| d > 0.0 && d <= LOOSE_END_REACH * rest)
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let Some((_, i)) = loose else { continue };
        if try_move(&mut pos, &mut state, v, ch.pts[i], false) {
            stats.fitted += 1;
        }
    }
    // Where a sliding vertex v's chain neighbours are on its chain (segment locations).
    let neighbour_locations = |seg: &[u32], v: usize, ch: &Chain| -> Option<[usize; 2]> {
        let nbrs = chain_nbrs[v]?;
        let at = |w: u32| -> Option<usize> {
            match kind[w as usize] {
                Kind::Slide(_) => Some(seg[w as usize] as usize),
                // a fixed neighbour on the same chain is one of its ends
                _ => {
                    let Some(Origin::Vertex(u)) = remesh.origins.get(w as usize) else {
                        return None;
                    };
                    let u = *u as usize;
                    let ns = ch.n_segments();
                    match (u == ch.verts[0], u == ch.verts[ns]) {
                        (true, true) => Some(if 2 * (seg[v] as usize) < ns { 0 } else { ns }),
                        (true, false) => Some(0),
                        (false, true) => Some(ns),
                        _ => None,
                    }
                }
            }
        };
        Some([at(nbrs[0])?, at(nbrs[1])?])
    };
    // Sliding vertices onto the chain's bends, where their chords follow it better.
    for v in 0..n {
        let (Kind::Slide(c), Some(nbrs)) = (kind[v], chain_nbrs[v]) else {
            continue;
        };
        if cancel() {
            break;
        }
        let ch = &chains.chains[c as usize];
        let Some([la, lb]) = neighbour_locations(&seg, v, ch) else {
            continue;
        };
        let Some(fit) = ch.chord_fit(
            [pos[nbrs[0] as usize], pos[nbrs[1] as usize]],
            [la, lb],
            pos[v],
            seg[v] as usize,
            CHORD_MIN_LENGTH * rest,
        ) else {
            continue;
        };
        if fit.deviation >= CHORD_GAIN * fit.deviation_now
            || fit.deviation_now < CHORD_NEGLIGIBLE * rest
        {
            continue;
        }
        if try_move(&mut pos, &mut state, v, fit.point, true) {
            seg[v] = fit.segment as u32;
            stats.fitted += 1;
        }
    }
    // Sliding vertices with corners far from square around them (where the grid meets an
    // unaligned boundary obliquely) slide along their chain, between their chain neighbours, to
    // where those corners are least far out (corners outside [30°, 150°] weigh ten times those
    // outside [45°, 135°]), as long as the chain stays as close to the chords to them. Two
    // passes, as each move changes its neighbours' corners.
    let vertex_penalty = |pos: &[DVec3], v: usize| -> f64 {
        vertex_faces[v]
            .iter()
            .map(|&fi| corner_penalty(pos, &faces[fi as usize]))
            .sum()
    };
    let passes = if opts.even_corners { CORNER_PASSES } else { 0 };
    for v in (0..passes).flat_map(|_| 0..n) {
        let (Kind::Slide(c), Some(nbrs)) = (kind[v], chain_nbrs[v]) else {
            continue;
        };
        if cancel() {
            break;
        }
        let now = vertex_penalty(&pos, v);
        if now <= 0.0 {
            continue;
        }
        let ch = &chains.chains[c as usize];
        let Some([la, lb]) = neighbour_locations(&seg, v, ch) else {
            continue;
        };
        let ends = [pos[nbrs[0] as usize], pos[nbrs[1] as usize]];
        // keep a quarter of an edge from either neighbour
        let room = [0, 1].map(|k| 0.25 * (ends[k] - pos[v]).length().min(rest));
        // and follow the chain as closely as it does (or within the chord fit's threshold)
        let deviation = |q: DVec3, s: usize| {
            ch.chord_deviation(ends[0], q, la, s)
                .max(ch.chord_deviation(q, ends[1], s, lb))
        };
        let allowed = deviation(pos[v], seg[v] as usize).max(CHORD_NEGLIGIBLE * rest);
        let old = pos[v];
        let mut best = (now - 1e-6, None);
        for (q, s) in ch.places_between(la, seg[v] as usize, lb) {
            if (q - ends[0]).length() < room[0]
                || (q - ends[1]).length() < room[1]
                || deviation(q, s) > allowed
            {
                continue;
            }
            pos[v] = q;
            let p = vertex_penalty(&pos, v);
            if p < best.0 {
                best = (p, Some((q, s)));
            }
        }
        pos[v] = old;
        if let (_, Some((q, s))) = best
            && try_move(&mut pos, &mut state, v, q, false)
        {
            seg[v] = s as u32;
            stats.evened += 1;
        }
    }
    for v in 0..n {
        if pos[v] != start[v] {
            stats.moved += 1;
            stats.max_offset = stats.max_offset.max((pos[v] - start[v]).length());
        }
    }
    remesh.positions = pos;
    stats
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain(points: &[[f64; 2]], closed: bool) -> Chain {
        let mut pts: Vec<DVec3> = points.iter().map(|p| DVec3::new(p[0], p[1], 0.0)).collect();
        if closed {
            pts.push(pts[0]);
        }
        Chain {
            verts: (0..pts.len()).collect(),
            pts,
            closed,
            boundary: false,
        }
    }

    #[test]
    fn a_chain_vertex_moves_onto_the_bend_its_chord_cuts() {
        // An L: the vertex at (1.5, 0) between neighbours at (0.5, 0) and (2, 1.5) cuts the
        // corner at (2, 0) by 0.47; on the corner both chords run along the chain.
        let ch = chain(
            &[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [2.0, 2.0]],
            false,
        );
        let ends = [DVec3::new(0.5, 0.0, 0.0), DVec3::new(2.0, 1.5, 0.0)];
        let fit = ch
            .chord_fit(ends, [0, 3], DVec3::new(1.5, 0.0, 0.0), 1, 0.1)
            .expect("a point qualifies");
        assert!((fit.deviation_now - 0.5 * 1.5 / 2.5f64.sqrt()).abs() < 1e-12);
        assert_eq!(fit.point, DVec3::new(2.0, 0.0, 0.0));
        assert_eq!((fit.segment, fit.deviation), (2, 0.0));
        // Every point between the neighbours is within 1.6 of one of them: none qualifies.
        assert!(
            ch.chord_fit(ends, [0, 3], DVec3::new(1.5, 0.0, 0.0), 1, 1.6)
                .is_none()
        );
    }

    #[test]
    fn points_between_go_the_short_way_round_a_closed_chain() {
        let ch = chain(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], true);
        assert_eq!(ch.points_between(3, 1), vec![0, 1]);
        // a tie goes forward
        assert_eq!(ch.points_between(1, 3), vec![2, 3]);
        assert_eq!(ch.points_between(0, 3), vec![0]);
        assert_eq!(ch.points_between(0, 1), vec![1]);
        let open = chain(&[[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]], false);
        assert_eq!(open.points_between(2, 0), vec![1, 2]);
        assert!(open.points_between(1, 1).is_empty());
    }
}
