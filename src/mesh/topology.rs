//! Connected components, boundary loops, Euler characteristic and genus, per component.

use std::fmt;

use serde::Serialize;

use super::TriMesh;

/// Topological summary of one connected component.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ComponentTopology {
    pub vertices: usize,
    pub edges: usize,
    pub faces: usize,
    pub euler_characteristic: i64,
    pub boundary_loops: usize,
    pub genus: i64,
}

/// Topological summary of a mesh: totals and per-component figures.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Topology {
    pub vertices: usize,
    pub edges: usize,
    pub faces: usize,
    pub euler_characteristic: i64,
    pub boundary_loops: usize,
    /// Sum of the components' genera.
    pub genus: i64,
    pub components: Vec<ComponentTopology>,
}

impl fmt::Display for Topology {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "vertices        {}", self.vertices)?;
        writeln!(f, "edges           {}", self.edges)?;
        writeln!(f, "faces           {}", self.faces)?;
        writeln!(f, "components      {}", self.components.len())?;
        writeln!(f, "euler char.     {}", self.euler_characteristic)?;
        writeln!(f, "genus           {}", self.genus)?;
        write!(f, "boundary loops  {}", self.boundary_loops)?;
        if self.components.len() > 1 {
            for (i, c) in self.components.iter().enumerate() {
                write!(
                    f,
                    "\n  component {i}: V {} E {} F {} genus {} boundary loops {}",
                    c.vertices, c.edges, c.faces, c.genus, c.boundary_loops
                )?;
            }
        }
        Ok(())
    }
}

impl TriMesh {
    /// Component id per face (0-based, in order of the smallest face index).
    pub fn face_components(&self) -> (Vec<u32>, usize) {
        let mut comp = vec![u32::MAX; self.n_faces()];
        let mut count = 0u32;
        let mut stack = Vec::new();
        for root in 0..self.n_faces() {
            if comp[root] != u32::MAX {
                continue;
            }
            comp[root] = count;
            stack.push(root);
            while let Some(f) = stack.pop() {
                for h in 3 * f..3 * f + 3 {
                    if let Some(t) = self.twin(h) {
                        let g = self.face_of(t);
                        if comp[g] == u32::MAX {
                            comp[g] = count;
                            stack.push(g);
                        }
                    }
                }
            }
            count += 1;
        }
        (comp, count as usize)
    }

    /// Boundary loops as sequences of boundary halfedges, each followed by the next along the
    /// loop (the surface is on the left of each halfedge).
    pub fn boundary_loops(&self) -> Vec<Vec<usize>> {
        let mut seen = vec![false; self.n_halfedges()];
        let mut loops = Vec::new();
        for h0 in 0..self.n_halfedges() {
            if seen[h0] || self.twin(h0).is_some() {
                continue;
            }
            let mut lp = Vec::new();
            let mut h = h0;
            while !seen[h] {
                seen[h] = true;
                lp.push(h);
                // The boundary continues with the boundary halfedge leaving our end vertex.
                h = self.vertex_halfedge(self.to(h));
            }
            loops.push(lp);
        }
        loops
    }

    pub fn euler_characteristic(&self) -> i64 {
        self.n_vertices() as i64 - self.n_edges() as i64 + self.n_faces() as i64
    }

    pub fn topology(&self) -> Topology {
        let (comp, n) = self.face_components();
        let mut parts = vec![(0usize, 0usize, 0usize, 0usize); n];
        for f in 0..self.n_faces() {
            parts[comp[f] as usize].2 += 1;
        }
        for e in 0..self.n_edges() {
            parts[comp[self.face_of(self.edge_halfedges(e).0)] as usize].1 += 1;
        }
        for v in 0..self.n_vertices() {
            parts[comp[self.face_of(self.vertex_halfedge(v))] as usize].0 += 1;
        }
        for lp in self.boundary_loops() {
            parts[comp[self.face_of(lp[0])] as usize].3 += 1;
        }
        let components: Vec<ComponentTopology> = parts
            .into_iter()
            .map(|(v, e, f, b)| {
                let chi = v as i64 - e as i64 + f as i64;
                ComponentTopology {
                    vertices: v,
                    edges: e,
                    faces: f,
                    euler_characteristic: chi,
                    boundary_loops: b,
                    genus: (2 - chi - b as i64) / 2,
                }
            })
            .collect();
        Topology {
            vertices: self.n_vertices(),
            edges: self.n_edges(),
            faces: self.n_faces(),
            euler_characteristic: self.euler_characteristic(),
            boundary_loops: components.iter().map(|c| c.boundary_loops).sum(),
            genus: components.iter().map(|c| c.genus).sum(),
            components,
        }
    }

    /// Genus of the mesh (sum over components).
    pub fn genus(&self) -> i64 {
        self.topology().genus
    }
}
