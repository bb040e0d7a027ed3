//! Extraction around poles (thesis sec. 4.3): the star faces of a pole are bilinear quads whose
//! inner edge collapses into the pole, which triangles cannot carry. Extraction runs on a proxy
//! mesh instead: the input with each star replaced by its quads' tessellation
//! (`param::tessellate`), whose innermost row sits a hair off the pole (a tiny hole, so no
//! triangle is degenerate). Afterwards every output vertex on such a hole is welded into one
//! vertex at the pole, faces lose the corners that coincide, and origins are named on the input.
//! Iso-lines and grid lines then close around the pole as the map winds (stripes become
//! circles; quad and triangle grids get the polar layout: a fan of faces meeting at the pole).

use std::collections::HashMap;

use glam::DVec3;

use crate::mesh::{PolygonSoup, TriMesh};
use crate::param::{Locus, Pole, tessellate};

use super::{ExtractError, Origin, Remesh};

/// Cells per quad side: the proxy follows the bilinear map to about 1/16 of a star edge.
const CELLS: usize = 4;
/// Where the proxy's innermost row sits (t of the bilinear map; 1 is the pole).
const INNER: f64 = 1.0 - 1e-4;

/// The proxy mesh and how its elements map back to the input.
pub(crate) struct Proxy {
    pub mesh: TriMesh,
    pub uv: Vec<[f64; 2]>,
    /// Per proxy vertex: where it lies on the input.
    loci: Vec<Locus>,
    /// Per proxy face: the input face it lies in.
    face: Vec<usize>,
}

impl Proxy {
    pub fn new(mesh: &TriMesh, uv: &[[f64; 2]], poles: &[Pole]) -> Result<Proxy, ExtractError> {
        let n = mesh.n_vertices();
        let t = tessellate(mesh, poles, CELLS, INNER);
        let mut star = vec![false; mesh.n_faces()];
        for p in poles {
            for &f in &p.faces {
                star[f] = true;
            }
        }
        // Tessellation nodes at input vertices are those vertices.
        let node = |i: usize| -> u32 {
            match t.loci[i] {
                Locus::Vertex(v) => v as u32,
                _ => (n + i) as u32,
            }
        };
        let mut positions = mesh.positions().to_vec();
        positions.extend(&t.positions);
        let mut loci: Vec<Locus> = (0..n).map(Locus::Vertex).collect();
        loci.extend(&t.loci);
        let (mut triangles, mut corner_uv, mut face) = (Vec::new(), Vec::new(), Vec::new());
        for f in (0..mesh.n_faces()).filter(|&f| !star[f]) {
            triangles.push(mesh.faces()[f]);
            corner_uv.extend_from_slice(&uv[3 * f..3 * f + 3]);
            face.push(f);
        }
        for (k, tri) in t.triangles.iter().enumerate() {
            triangles.push(tri.map(|i| node(i as usize)));
            corner_uv.extend_from_slice(&t.uv[3 * k..3 * k + 3]);
            face.push(t.face[k]);
        }
        let soup = PolygonSoup {
            source_polygon: (0..triangles.len() as u32).collect(),
            positions,
            triangles,
            ..Default::default()
        };
        let bad = |why: String| ExtractError::Poles(why);
        let (proxy, report) = TriMesh::from_soup(&soup).map_err(|e| bad(e.to_string()))?;
        if proxy.n_faces() != face.len() || !report.flipped_faces.is_empty() {
            return Err(bad(
                "the tessellated stars do not fit their neighbours".into()
            ));
        }
        // Unreferenced vertices (the poles themselves) were dropped: renumber the loci.
        let loci = report
            .original_vertex
            .iter()
            .map(|&o| loci[o as usize])
            .collect();
        Ok(Proxy {
            mesh: proxy,
            uv: corner_uv,
            loci,
            face,
        })
    }

    /// Where the proxy's vertex `v` lies on the input (`None`: on a pole's hole: the pole).
    fn vertex(&self, v: usize) -> Locus {
        self.loci[v]
    }

    /// The input element an origin on the proxy lies on; `Err(i)`: on the hole of pole i.
    fn origin(&self, input: &TriMesh, o: Origin) -> Result<Origin, usize> {
        let of_locus = |l: Locus| match l {
            Locus::Vertex(v) => Ok(Origin::Vertex(v as u32)),
            Locus::Edge(e) => Ok(Origin::Edge(e as u32)),
            Locus::Face(f) => Ok(Origin::Face(f as u32)),
            Locus::PoleRing(i) => Err(i),
        };
        match o {
            Origin::Vertex(v) => of_locus(self.vertex(v as usize)),
            Origin::Face(f) => Ok(Origin::Face(self.face[f as usize] as u32)),
            Origin::Unknown => Ok(Origin::Unknown),
            Origin::Edge(e) => {
                let (h0, _) = self.mesh.edge_halfedges(e as usize);
                let [a, b] = self.mesh.edge_vertices(e as usize);
                let inside = Origin::Face(self.face[self.mesh.face_of(h0)] as u32);
                let on = |l: Locus, e: usize| match l {
                    Locus::Vertex(v) => input.edge_vertices(e).contains(&v),
                    Locus::Edge(x) => x == e,
                    _ => false,
                };
                Ok(match (self.vertex(a), self.vertex(b)) {
                    (Locus::PoleRing(i), Locus::PoleRing(j)) if i == j => return Err(i),
                    (Locus::Vertex(x), Locus::Vertex(y)) => input
                        .outgoing(x)
                        .find(|&h| input.to(h) == y)
                        .map_or(inside, |h| Origin::Edge(input.edge(h) as u32)),
                    (Locus::Edge(x), other) | (other, Locus::Edge(x)) => {
                        let ring_end = matches!(other, Locus::PoleRing(_));
                        if on(other, x) || ring_end {
                            Origin::Edge(x as u32)
                        } else {
                            inside
                        }
                    }
                    _ => inside,
                })
            }
        }
    }

    /// The proxy's extraction as the input's: hole vertices welded into their pole, corners
    /// that coincide after that removed (faces left with fewer than three go), origins on the
    /// input, unused vertices dropped.
    pub fn close(&self, input: &TriMesh, poles: &[Pole], mut r: Remesh) -> Remesh {
        let mut pole_vertex: HashMap<usize, u32> = HashMap::new();
        let mut positions: Vec<DVec3> = Vec::with_capacity(r.positions.len());
        let mut origins = Vec::with_capacity(r.positions.len());
        let map: Vec<u32> = (0..r.positions.len())
            .map(|v| match self.origin(input, r.origins[v]) {
                Ok(o) => {
                    positions.push(r.positions[v]);
                    origins.push(o);
                    (positions.len() - 1) as u32
                }
                Err(i) => *pole_vertex.entry(i).or_insert_with(|| {
                    positions.push(input.position(poles[i].vertex));
                    origins.push(Origin::Vertex(poles[i].vertex as u32));
                    (positions.len() - 1) as u32
                }),
            })
            .collect();
        super::purify::remap_faces(&mut r.faces, |v| Some(map[v as usize]));
        for l in &mut r.polylines {
            let mut g: Vec<u32> = l.iter().map(|&v| map[v as usize]).collect();
            g.dedup();
            *l = g;
        }
        r.polylines.retain(|l| l.len() >= 2);
        r.positions = positions;
        r.origins = origins;
        super::purify::compact(&mut r);
        r
    }
}

/// The remesh vertices around the poles that relaxation must leave where the map puts them. A
/// polar grid is anisotropic by nature: with P grid lines into the pole, a cell r rings out is
/// about 2πr / P wide and one ring deep, so smoothing towards isotropic cells pulls the rings
/// into zigzags while 2πr < P / 2. Held: every vertex within ⌈P / 4π⌉ + 1 rings of a pole
/// vertex (P = the pole's valence for triangles, twice it for quads, where purification joins
/// the fan's triangles pairwise; 2 × valence bounds both).
pub(crate) fn polar_region(r: &Remesh, poles: &[Pole]) -> Vec<bool> {
    let n = r.positions.len();
    let mut held = vec![false; n];
    if poles.is_empty() {
        return held;
    }
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
    for f in &r.faces {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
        }
    }
    for l in &mut neighbours {
        l.sort_unstable();
        l.dedup();
    }
    for pole in poles {
        let Some(start) = (0..n).find(|&v| r.origins[v] == Origin::Vertex(pole.vertex as u32))
        else {
            continue;
        };
        let lines = 2 * neighbours[start].len();
        let rings = (lines as f64 / (4.0 * std::f64::consts::PI)).ceil() as usize + 1;
        let mut frontier = vec![start as u32];
        held[start] = true;
        for _ in 0..rings {
            let mut next = Vec::new();
            for &v in &frontier {
                for &w in &neighbours[v as usize] {
                    if !held[w as usize] {
                        held[w as usize] = true;
                        next.push(w);
                    }
                }
            }
            frontier = next;
        }
    }
    held
}
