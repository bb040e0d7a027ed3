//! Grid extraction (N = 4 quads, N = 6 triangles): grid points, tracing, face closing.

use super::fill;
use glam::{DVec2, DVec3};

use super::lattice::{Param, cross, dv, to_uv};
use super::{ExtractOptions, Origin, Remesh};

#[derive(Clone, Copy, Debug)]
#[allow(dead_code)] // parameters kept for debugging output
enum Owner {
    Vertex(usize),
    /// Edge point: its halfedge `h0` and parameter along it.
    Edge(usize, f64),
    Face(usize),
    /// Boundary crossing of an iso-line: boundary halfedge and parameter along it.
    Boundary(usize, f64),
}

#[derive(Clone, Copy, Debug)]
struct Slot {
    face: usize,
    q: DVec2,
    d: [i64; 2],
    g: DVec2,
}

struct Point {
    owner: Owner,
    pos: DVec3,
    slots: Vec<Slot>,
}

struct Grid<'p, 'm> {
    p: &'p Param<'m>,
    points: Vec<Point>,
    /// Per face: grid points in its closure, in its chart.
    closure: Vec<Vec<(DVec2, u32)>>,
    /// Per boundary halfedge: crossings (point in the face chart, family, point id).
    crossings: Vec<Vec<(DVec2, usize, u32)>>,
    vertex_point: Vec<u32>,
    edge_points: Vec<Vec<(f64, u32)>>,
    patched: usize,
}

const NONE: u32 = u32::MAX;

fn angle_from(n: u8, e: DVec2, w: DVec2) -> f64 {
    let (a, b) = (to_uv(n, e), to_uv(n, w));
    let ang = cross(a, b).atan2(a.dot(b));
    if ang < -1e-12 {
        ang + std::f64::consts::TAU
    } else {
        ang.max(0.0)
    }
}

fn family(n: u8, dirs: &[[i64; 2]], d: [i64; 2]) -> usize {
    let i = dirs.iter().position(|&x| x == d).unwrap_or(0);
    i % (n as usize / 2).max(1)
}

impl<'p, 'm> Grid<'p, 'm> {
    fn new(p: &'p Param<'m>) -> Self {
        let mesh = p.mesh;
        let mut g = Grid {
            p,
            points: Vec::new(),
            closure: vec![Vec::new(); mesh.n_faces()],
            crossings: vec![Vec::new(); mesh.n_halfedges()],
            vertex_point: vec![NONE; mesh.n_vertices()],
            edge_points: vec![Vec::new(); mesh.n_edges()],
            patched: p.face_ok.iter().filter(|&&ok| !ok).count(),
        };
        g.collect_points();
        g.collect_crossings();
        g
    }

    fn add(&mut self, owner: Owner, pos: DVec3) -> u32 {
        self.points.push(Point {
            owner,
            pos,
            slots: Vec::new(),
        });
        self.points.len() as u32 - 1
    }

    fn collect_points(&mut self) {
        let p = self.p;
        let mesh = p.mesh;
        let tol = p.tol;
        for v in 0..mesh.n_vertices() {
            if p.on_lattice[v] {
                let id = self.add(Owner::Vertex(v), mesh.position(v));
                self.vertex_point[v] = id;
                for h in mesh.outgoing(v) {
                    self.closure[h / 3].push((p.lat[h], id));
                }
            }
        }
        for e in 0..mesh.n_edges() {
            let (h0, h1) = mesh.edge_halfedges(e);
            let (a, b) = (p.lat[h0], p.lat[mesh.next(h0)]);
            let ab = b - a;
            let len2 = ab.length_squared();
            if len2 <= 1e-24 {
                continue;
            }
            let (lo, hi) = (a.min(b), a.max(b));
            for x in (lo.x - tol).ceil() as i64..=(hi.x + tol).floor() as i64 {
                for y in (lo.y - tol).ceil() as i64..=(hi.y + tol).floor() as i64 {
                    let q = DVec2::new(x as f64, y as f64);
                    let Some((t, dist)) = on_edge(a, b, q, tol) else {
                        continue;
                    };
                    if nearer_edge_claims(p, h0, q, dist) {
                        continue;
                    }
                    let pos = mesh
                        .position(mesh.from(h0))
                        .lerp(mesh.position(mesh.to(h0)), t);
                    let id = self.add(Owner::Edge(h0, t), pos);
                    self.edge_points[e].push((t, id));
                    self.closure[h0 / 3].push((q, id));
                    if let Some(h1) = h1 {
                        let q1 = p.map_point(h0, q);
                        self.closure[h1 / 3].push((q1, id));
                    }
                }
            }
        }
        for f in 0..mesh.n_faces() {
            if !p.face_ok[f] {
                continue;
            }
            let c = [p.lat[3 * f], p.lat[3 * f + 1], p.lat[3 * f + 2]];
            let lo = c[0].min(c[1]).min(c[2]);
            let hi = c[0].max(c[1]).max(c[2]);
            let area = cross(c[1] - c[0], c[2] - c[0]);
            for x in lo.x.ceil() as i64..=hi.x.floor() as i64 {
                for y in lo.y.ceil() as i64..=hi.y.floor() as i64 {
                    let q = DVec2::new(x as f64, y as f64);
                    let mut inside = true;
                    let mut bary = [0.0; 3];
                    for k in 0..3 {
                        let (a, b) = (c[k], c[(k + 1) % 3]);
                        let s = cross(b - a, q - a);
                        if s <= tol * (b - a).length() {
                            inside = false;
                            break;
                        }
                        bary[(k + 2) % 3] = s / area;
                    }
                    if !inside {
                        continue;
                    }
                    let [i, j, k] = mesh.face(f);
                    let pos = mesh.position(i) * bary[0]
                        + mesh.position(j) * bary[1]
                        + mesh.position(k) * bary[2];
                    let id = self.add(Owner::Face(f), pos);
                    self.closure[f].push((q, id));
                }
            }
        }
    }

    /// Iso-line crossings of boundary edges that are not grid points.
    fn collect_crossings(&mut self) {
        let p = self.p;
        let mesh = p.mesh;
        let nf = (p.n as usize / 2).max(1);
        for h in 0..mesh.n_halfedges() {
            if mesh.twin(h).is_some() {
                continue;
            }
            let (c0, c1) = (h, mesh.next(h));
            let (a, b) = (p.lat[c0], p.lat[c1]);
            let mut found: Vec<(f64, DVec2, usize, [i64; 2])> = Vec::new();
            for (fam, &d) in p.dirs.iter().enumerate().take(nf) {
                let dd = dv(d);
                let (la, lb) = (cross(dd, a), cross(dd, b));
                if (la - lb).abs() < 1e-15 {
                    continue;
                }
                let (lo, hi) = (la.min(lb), la.max(lb));
                for k in (lo - 1e-9).ceil() as i64..=(hi + 1e-9).floor() as i64 {
                    let kf = k as f64;
                    let q0 = line_point(d, kf);
                    if (p.on_lattice[mesh.from(c0)] && (la - kf).abs() <= 1e-9)
                        || (p.on_lattice[mesh.from(c1)] && (lb - kf).abs() <= 1e-9)
                    {
                        continue;
                    }
                    if p.left(c0, q0, d) == p.left(c1, q0, d) {
                        continue;
                    }
                    let t = ((kf - la) / (lb - la)).clamp(0.0, 1.0);
                    let x = a + (b - a) * t;
                    let r = x.round();
                    if (x - r).length() <= p.tol {
                        continue;
                    }
                    let inward = if cross(b - a, dd) > 0.0 {
                        d
                    } else {
                        [-d[0], -d[1]]
                    };
                    found.push((t, x, fam, inward));
                }
            }
            for (t, x, fam, inward) in found {
                let pos = mesh
                    .position(mesh.from(h))
                    .lerp(mesh.position(mesh.to(h)), t);
                let id = self.add(Owner::Boundary(h, t), pos);
                self.crossings[h].push((x, fam, id));
                let g = next_lattice_point(x, inward);
                self.points[id as usize].slots.push(Slot {
                    face: h / 3,
                    q: x,
                    d: inward,
                    g,
                });
            }
        }
    }

    /// Outgoing directions of every grid point in counter-clockwise order.
    fn compute_slots(&mut self) {
        let p = self.p;
        let mesh = p.mesh;
        for id in 0..self.points.len() {
            let owner = self.points[id].owner;
            let mut slots: Vec<Slot> = Vec::new();
            let mut add_face =
                |h: usize, q: DVec2, pred: &dyn Fn(usize, DVec2, [i64; 2]) -> bool| {
                    let f = h / 3;
                    if !p.face_ok[f] {
                        return;
                    }
                    let e1 = p.lat[mesh.next(h)] - p.lat[h];
                    let mut local: Vec<(f64, Slot)> = Vec::new();
                    for &d in &p.dirs {
                        if pred(h, q, d) {
                            let s = Slot {
                                face: f,
                                q,
                                d,
                                g: q + dv(d),
                            };
                            // A direction the predicate takes into this face although it
                            // lies a hair clockwise of e1 (a grid line along the face's edge,
                            // decided by the symbolic perturbation) starts the face's sector,
                            // not ends it: a positive face's sector spans less than 3π/2.
                            let a = angle_from(p.n, e1, dv(d));
                            let a = if a > 1.5 * std::f64::consts::PI {
                                a - std::f64::consts::TAU
                            } else {
                                a
                            };
                            local.push((a, s));
                        }
                    }
                    local.sort_by(|a, b| a.0.total_cmp(&b.0));
                    slots.extend(local.into_iter().map(|x| x.1));
                };
            match owner {
                Owner::Vertex(v) => {
                    for h in mesh.outgoing(v) {
                        let pred = |h: usize, q: DVec2, d: [i64; 2]| {
                            !p.left(mesh.next(h), q, d) && p.left(mesh.prev(h), q, d)
                        };
                        add_face(h, p.lat[h], &pred);
                    }
                }
                Owner::Edge(h0, _) => {
                    let q0 = self.closure[h0 / 3]
                        .iter()
                        .find(|x| x.1 == id as u32)
                        .map(|x| x.0)
                        .unwrap_or_default();
                    let pred = |h: usize, q: DVec2, d: [i64; 2]| {
                        let l0 = p.left(h, q, d);
                        let l1 = p.left(mesh.next(h), q, d);
                        let l2 = p.left(mesh.prev(h), q, d);
                        (l0 && !l1) || (l0 == l1 && l2 != l0)
                    };
                    add_face(h0, q0, &pred);
                    if let Some(h1) = mesh.twin(h0) {
                        add_face(h1, p.map_point(h0, q0), &pred);
                    }
                }
                Owner::Face(f) => {
                    let q = self.closure[f]
                        .iter()
                        .find(|x| x.1 == id as u32)
                        .map(|x| x.0)
                        .unwrap_or_default();
                    add_face(3 * f, q, &|_, _, _| true);
                }
                Owner::Boundary(..) => continue,
            }
            self.points[id].slots = slots;
        }
    }

    /// Traces slot `s` of point `id`; returns the end point and its arrival slot.
    fn trace(&self, id: usize, s: usize) -> Option<(u32, usize)> {
        let p = self.p;
        let mesh = p.mesh;
        let slot = self.points[id].slots[s];
        let (mut f, mut q, mut d, mut g) = (slot.face, slot.q, slot.d, slot.g);
        for _ in 0..(4 * mesh.n_faces() + 16) {
            if let Some(&(_, qid)) = self.closure[f]
                .iter()
                .find(|x| (x.0 - g).length() <= 10.0 * p.tol.max(1e-9))
            {
                let j = self.arrival_slot(qid as usize, f, [-d[0], -d[1]])?;
                return Some((qid, j));
            }
            let l = [
                p.left(3 * f, q, d),
                p.left(3 * f + 1, q, d),
                p.left(3 * f + 2, q, d),
            ];
            let k = (0..3).find(|&k| !l[k] && l[(k + 1) % 3])?;
            let h = 3 * f + k;
            match mesh.twin(h) {
                None => {
                    let fam = family(p.n, &p.dirs, d);
                    let dd = dv(d);
                    let &(_, _, bid) = self.crossings[h]
                        .iter()
                        .filter(|x| x.1 == fam)
                        .min_by(|a, b| {
                            cross(dd, a.0 - q)
                                .abs()
                                .total_cmp(&cross(dd, b.0 - q).abs())
                        })
                        .filter(|x| cross(dd, x.0 - q).abs() < 1e-6)?;
                    return Some((bid, 0));
                }
                Some(t) => {
                    q = p.map_point(h, q);
                    g = p.map_point(h, g);
                    d = p.map_dir(h, d);
                    f = t / 3;
                }
            }
        }
        None
    }

    /// The slot of point `id` leaving in direction `w` (given in face `f`'s chart).
    fn arrival_slot(&self, id: usize, f: usize, w: [i64; 2]) -> Option<usize> {
        let p = self.p;
        let mesh = p.mesh;
        let pt = &self.points[id];
        let find = |f: usize, w: [i64; 2]| pt.slots.iter().position(|s| s.face == f && s.d == w);
        if let Some(j) = find(f, w) {
            return Some(j);
        }
        match pt.owner {
            Owner::Face(_) | Owner::Boundary(..) => None,
            Owner::Edge(h0, _) => {
                let h1 = mesh.twin(h0)?;
                if f == h0 / 3 {
                    find(h1 / 3, p.map_dir(h0, w))
                } else {
                    find(h0 / 3, p.map_dir(h1, w))
                }
            }
            Owner::Vertex(v) => {
                let fan: Vec<usize> = mesh.outgoing(v).collect();
                let i0 = fan.iter().position(|&h| h / 3 == f)?;
                let m = fan.len();
                let closed = !mesh.is_boundary_vertex(v);
                // Walk the fan both ways and take the nearest slot leaving in w (transported):
                // around a vertex of negative index the fan turns more than a full turn, so the
                // same direction comes again farther on, and the first match one way can be a
                // whole turn farther than the match the other way (two singular grid points
                // one lattice step apart traced into each other's wrong slots).
                let walk = |dir: i64| -> Vec<(usize, [i64; 2])> {
                    let mut out = Vec::new();
                    let mut w2 = w;
                    let mut i = i0;
                    for _ in 1..m.max(2) {
                        let h = fan[i];
                        let next_i = if dir == 1 {
                            // CCW: through prev(h) into twin(prev(h)).
                            let e = mesh.prev(h);
                            if mesh.twin(e).is_none() {
                                break;
                            }
                            w2 = p.map_dir(e, w2);
                            if i + 1 == m {
                                if !closed {
                                    break;
                                }
                                0
                            } else {
                                i + 1
                            }
                        } else {
                            if mesh.twin(h).is_none() {
                                break;
                            }
                            w2 = p.map_dir(h, w2);
                            if i == 0 {
                                if !closed {
                                    break;
                                }
                                m - 1
                            } else {
                                i - 1
                            }
                        };
                        i = next_i;
                        out.push((fan[i] / 3, w2));
                    }
                    out
                };
                let (ccw, cw) = (walk(1), walk(-1));
                (0..ccw.len().max(cw.len())).find_map(|k| {
                    ccw.get(k)
                        .and_then(|&(f, w2)| find(f, w2))
                        .or_else(|| cw.get(k).and_then(|&(f, w2)| find(f, w2)))
                })
            }
        }
    }
}

/// Whether the boundary turns by more than 30° at the start vertex of boundary halfedge `h`.
fn is_corner(mesh: &crate::mesh::TriMesh, h: usize) -> bool {
    let v = mesh.from(h);
    let Some(last) = mesh.outgoing(v).last() else {
        return false;
    };
    let prev = mesh.prev(last);
    let (a, b) = (mesh.vector(prev), mesh.vector(h));
    a.angle_between(b) > 30f64.to_radians()
}

/// Where lattice point `q` is on the segment `a`–`b` up to `tol` (within `tol` of its line,
/// strictly between its ends and not within `tol` of either; the tolerance absorbs a foreign
/// map's float noise), its parameter along it and its distance from the line.
fn on_edge(a: DVec2, b: DVec2, q: DVec2, tol: f64) -> Option<(f64, f64)> {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 <= 1e-24 {
        return None;
    }
    let dist = cross(ab, q - a).abs() / len2.sqrt();
    let t = (q - a).dot(ab) / len2;
    if dist > tol || (q - a).length() <= tol || (q - b).length() <= tol || t <= 0.0 || t >= 1.0 {
        return None;
    }
    Some((t, dist))
}

/// Whether another edge of a face at halfedge `h0` (either side) holds lattice point `q` (in
/// `h0`'s chart) nearer than `dist`, or as near with a lower edge index. A point a hair from a
/// vertex (between one and a few tolerances: not snapped onto it) lies within the tolerance of
/// several of its edges' lines; each used to take it as a grid point of its own, and the
/// duplicates' traces did not meet (a box with its creases on grid lines: 48 patched places).
/// Along the vertex's fan the lines' distances grow away from the face the point is in, so
/// comparing the edges of one face at a time leaves only the nearest.
fn nearer_edge_claims(p: &Param, h0: usize, q: DVec2, dist: f64) -> bool {
    let mesh = p.mesh;
    let e = mesh.edge(h0);
    let sides = [
        Some((h0, q)),
        mesh.twin(h0).map(|h1| (h1, p.map_point(h0, q))),
    ];
    sides.into_iter().flatten().any(|(h, q)| {
        // In a folded face the two edges may hold the lattice point on two sheets of the fold:
        // two grid points, traced as such.
        p.face_ok[h / 3]
            && [mesh.next(h), mesh.prev(h)].into_iter().any(|k| {
                on_edge(p.lat[k], p.lat[mesh.next(k)], q, p.tol)
                    .is_some_and(|(_, d)| d < dist || (d == dist && mesh.edge(k) < e))
            })
    })
}

/// A lattice point on the line `cross(d, p) = level`.
fn line_point(d: [i64; 2], level: f64) -> DVec2 {
    if d[0] != 0 {
        DVec2::new(0.0, level * d[0] as f64)
    } else {
        DVec2::new(-level * d[1] as f64, 0.0)
    }
}

/// The first lattice point strictly ahead of `x` on the lattice line through `x` along `d`.
fn next_lattice_point(x: DVec2, d: [i64; 2]) -> DVec2 {
    let dd = dv(d);
    let level = cross(dd, x).round();
    let p0 = line_point(d, level);
    let s = (x - p0).dot(dd) / dd.length_squared();
    p0 + dd * ((s + 1e-9).floor() + 1.0)
}

pub fn extract_grid(p: &Param, opts: &ExtractOptions) -> Remesh {
    let mesh = p.mesh;
    let mut grid = Grid::new(p);
    grid.compute_slots();
    let np = grid.points.len();
    // Real half-edges.
    let real: Vec<Vec<Option<(u32, usize)>>> = (0..np)
        .map(|id| {
            (0..grid.points[id].slots.len())
                .map(|s| grid.trace(id, s))
                .collect()
        })
        .collect();
    // Boundary chains.
    let loops = mesh.boundary_loops();
    for lp in &loops {
        for &h in lp {
            let v = mesh.from(h);
            if grid.vertex_point[v] == NONE && is_corner(mesh, h) {
                // Keep sharp corners of the input boundary as output vertices.
                let id = grid.add(Owner::Vertex(v), mesh.position(v));
                grid.vertex_point[v] = id;
            }
        }
    }
    let np = grid.points.len();
    let mut real = real;
    real.resize(np, Vec::new());
    let mut fwd = vec![NONE; np];
    let mut bwd = vec![NONE; np];
    let mut on_boundary = vec![false; np];
    for lp in loops {
        let mut chain: Vec<u32> = Vec::new();
        for &h in &lp {
            let v = mesh.from(h);
            if grid.vertex_point[v] != NONE {
                chain.push(grid.vertex_point[v]);
            }
            let mut on: Vec<(f64, u32)> = grid.edge_points[mesh.edge(h)].clone();
            on.extend(grid.crossings[h].iter().map(|x| {
                let t = match grid.points[x.2 as usize].owner {
                    Owner::Boundary(_, t) => t,
                    _ => 0.0,
                };
                (t, x.2)
            }));
            on.sort_by(|a, b| a.0.total_cmp(&b.0));
            chain.extend(on.into_iter().map(|x| x.1));
        }
        if chain.len() < 2 {
            grid.patched += 1;
            continue;
        }
        for (i, &a) in chain.iter().enumerate() {
            let b = chain[(i + 1) % chain.len()];
            on_boundary[a as usize] = true;
            // Merged with a traced edge running along the boundary?
            let last_b = grid.points[b as usize].slots.len().wrapping_sub(1);
            let merged = real[a as usize]
                .first()
                .copied()
                .flatten()
                .is_some_and(|(q, j)| q == b && j == last_b)
                && !grid.points[b as usize].slots.is_empty();
            if !merged {
                fwd[a as usize] = b;
                bwd[b as usize] = a;
            }
        }
    }
    let off = |id: usize| usize::from(fwd[id] != NONE);
    let len = |id: usize| off(id) + grid.points[id].slots.len() + usize::from(bwd[id] != NONE);
    let target = |id: usize, s: usize| -> Option<(usize, usize)> {
        if fwd[id] != NONE && s == 0 {
            let b = fwd[id] as usize;
            return Some((b, len(b) - 1));
        }
        let r = s - off(id);
        if r < grid.points[id].slots.len() {
            let (q, j) = real[id][r]?;
            return Some((q as usize, off(q as usize) + j));
        }
        if bwd[id] != NONE && s == len(id) - 1 {
            return Some((bwd[id] as usize, 0));
        }
        None
    };
    let mut starts = vec![0usize; np + 1];
    for id in 0..np {
        starts[id + 1] = starts[id] + len(id);
    }
    let mut visited = vec![false; starts[np]];
    let mut faces: Vec<Vec<u32>> = Vec::new();
    let mut patched = grid.patched;
    let mut bad_traces = 0;
    for id in 0..np {
        for s in 0..len(id) {
            let mutual = target(id, s).is_some_and(|(q, j)| target(q, j) == Some((id, s)));
            if !mutual {
                bad_traces += 1;
            }
        }
    }
    patched += bad_traces / 2 + bad_traces % 2;
    for id in 0..np {
        for s in 0..len(id) {
            if visited[starts[id] + s] {
                continue;
            }
            let mut cycle: Vec<u32> = Vec::new();
            let (mut cur, mut cs) = (id, s);
            let ok;
            let mut outside = false;
            loop {
                if visited[starts[cur] + cs] {
                    ok = cur == id && cs == s;
                    break;
                }
                visited[starts[cur] + cs] = true;
                if on_boundary[cur] && cs == len(cur) - 1 {
                    outside = true;
                }
                cycle.push(cur as u32);
                let Some((q, j)) = target(cur, cs) else {
                    ok = false;
                    break;
                };
                if target(q, j) != Some((cur, cs)) {
                    ok = false;
                    break;
                }
                let m = len(q);
                cur = q;
                cs = (j + m - 1) % m;
                if cycle.len() > opts.max_face_sides {
                    ok = false;
                    break;
                }
            }
            if ok && !outside {
                // Zero-length edges (two consecutive slots at one point) collapse; a cycle that
                // still passes a point twice is no polygon: patched like an open one.
                cycle.dedup();
                while cycle.len() > 1 && cycle.first() == cycle.last() {
                    cycle.pop();
                }
                let mut sorted = cycle.clone();
                sorted.sort_unstable();
                sorted.dedup();
                if sorted.len() == cycle.len() && cycle.len() >= 3 {
                    faces.push(cycle);
                } else if cycle.len() >= 3 {
                    patched += 1;
                }
            } else if !ok && !outside {
                patched += 1;
            }
        }
    }
    // A cell traced on both sheets of a fold, once per orientation: neither copy is surface.
    patched += fill::drop_pleats(&mut faces);
    // Fragments of a fold standing alone in a hole would keep it from being filled.
    patched += fill::drop_stray_faces(&mut faces, &on_boundary);
    // Patch the holes left by faces that could not be closed (their count is in `patched`).
    fill::fill_holes(&mut faces, &on_boundary);
    // Compact.
    let mut map = vec![NONE; np];
    let mut positions = Vec::new();
    let mut origins = Vec::new();
    for f in &mut faces {
        for v in f.iter_mut() {
            if map[*v as usize] == NONE {
                map[*v as usize] = positions.len() as u32;
                positions.push(grid.points[*v as usize].pos);
                origins.push(match grid.points[*v as usize].owner {
                    Owner::Vertex(v) => Origin::Vertex(v as u32),
                    Owner::Edge(h, _) | Owner::Boundary(h, _) => Origin::Edge(mesh.edge(h) as u32),
                    Owner::Face(f) => Origin::Face(f as u32),
                });
            }
            *v = map[*v as usize];
        }
    }
    Remesh {
        positions,
        origins,
        faces,
        polylines: Vec::new(),
        patched_places: patched,
        purified: Default::default(),
        relaxed: None,
    }
}
