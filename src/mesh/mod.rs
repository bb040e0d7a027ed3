//! Triangle meshes: validated halfedge connectivity, geometry and topology.
//!
//! Halfedge `h = 3*f + k` runs from `faces[f][k]` to `faces[f][(k + 1) % 3]` with face `f` on its
//! left, so `next`, `prev` and `face` are arithmetic; only twins, edges and one outgoing halfedge
//! per vertex are stored. Build a mesh with [`TriMesh::from_soup`] (files) or
//! [`TriMesh::from_triangles`] (generated meshes); both validate and never panic on bad input.

mod build;
pub(crate) mod disjoint;
mod error;
pub mod generate;
mod geometry;
pub use geometry::segment_parameter;
pub(crate) mod heap;
pub mod isotropic;
pub mod soup;
mod topology;

#[cfg(test)]
mod tests;

pub use build::RepairReport;
pub use error::MeshError;
pub use soup::PolygonSoup;
pub use topology::{ComponentTopology, Topology};

use glam::DVec3;

/// Marker for "no such element" in the compact index arrays.
pub(crate) const INVALID: u32 = u32::MAX;

/// A manifold, consistently oriented triangle mesh (possibly with boundary and several components).
#[derive(Clone, Debug)]
pub struct TriMesh {
    positions: Vec<DVec3>,
    faces: Vec<[u32; 3]>,
    twin: Vec<u32>,
    he_edge: Vec<u32>,
    /// Per edge its halfedges: `[h0, h1]`, `h1 == INVALID` on the boundary.
    edges: Vec<[u32; 2]>,
    /// Per vertex an outgoing halfedge; the boundary one for boundary vertices.
    vertex_he: Vec<u32>,
}

impl TriMesh {
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }
    pub fn n_edges(&self) -> usize {
        self.edges.len()
    }
    pub fn n_halfedges(&self) -> usize {
        self.twin.len()
    }
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }
    pub fn position(&self, v: usize) -> DVec3 {
        self.positions[v]
    }
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.faces
    }
    pub fn face(&self, f: usize) -> [usize; 3] {
        self.faces[f].map(|v| v as usize)
    }

    /// Replaces vertex positions (same count), e.g. after smoothing or scaling a generated mesh.
    pub fn set_positions(&mut self, positions: Vec<DVec3>) {
        assert_eq!(
            positions.len(),
            self.positions.len(),
            "vertex count must not change"
        );
        self.positions = positions;
    }

    // --- halfedges -------------------------------------------------------------------------
    pub fn next(&self, h: usize) -> usize {
        if h % 3 == 2 { h - 2 } else { h + 1 }
    }
    pub fn prev(&self, h: usize) -> usize {
        if h.is_multiple_of(3) { h + 2 } else { h - 1 }
    }
    pub fn face_of(&self, h: usize) -> usize {
        h / 3
    }
    pub fn twin(&self, h: usize) -> Option<usize> {
        let t = self.twin[h];
        (t != INVALID).then_some(t as usize)
    }
    pub fn edge(&self, h: usize) -> usize {
        self.he_edge[h] as usize
    }
    /// Start vertex of halfedge `h`.
    pub fn from(&self, h: usize) -> usize {
        self.faces[h / 3][h % 3] as usize
    }
    /// End vertex of halfedge `h`.
    pub fn to(&self, h: usize) -> usize {
        self.faces[h / 3][(h + 1) % 3] as usize
    }
    /// Vector from the start to the end of `h`.
    pub fn vector(&self, h: usize) -> DVec3 {
        self.positions[self.to(h)] - self.positions[self.from(h)]
    }

    // --- edges -----------------------------------------------------------------------------
    /// The halfedges of edge `e`: the first, and the second unless `e` is on the boundary.
    pub fn edge_halfedges(&self, e: usize) -> (usize, Option<usize>) {
        let [a, b] = self.edges[e];
        (a as usize, (b != INVALID).then_some(b as usize))
    }
    pub fn edge_vertices(&self, e: usize) -> [usize; 2] {
        let h = self.edges[e][0] as usize;
        [self.from(h), self.to(h)]
    }
    pub fn is_boundary_edge(&self, e: usize) -> bool {
        self.edges[e][1] == INVALID
    }

    // --- vertices --------------------------------------------------------------------------
    /// An outgoing halfedge of `v`; for boundary vertices the one with no twin.
    pub fn vertex_halfedge(&self, v: usize) -> usize {
        self.vertex_he[v] as usize
    }
    pub fn is_boundary_vertex(&self, v: usize) -> bool {
        self.twin[self.vertex_he[v] as usize] == INVALID
    }
    /// Outgoing halfedges of `v` in counter-clockwise order (seen from the normal side). For a
    /// boundary vertex the walk starts at the boundary halfedge leaving it and ends at the
    /// last interior one, so it covers the whole fan.
    pub fn outgoing(&self, v: usize) -> Outgoing<'_> {
        let start = self.vertex_he[v] as usize;
        Outgoing {
            mesh: self,
            start,
            current: Some(start),
        }
    }
    /// The halfedge from `a` to `b` (its face on the left of a → b), if there is one.
    pub fn halfedge_to(&self, a: usize, b: usize) -> Option<usize> {
        self.outgoing(a).find(|&h| self.to(h) == b)
    }
    /// Neighbouring vertices of `v` in counter-clockwise order (boundary vertices: both boundary
    /// neighbours included, the last one reached through the last face).
    pub fn one_ring(&self, v: usize) -> Vec<usize> {
        let mut ring: Vec<usize> = self.outgoing(v).map(|h| self.to(h)).collect();
        if self.is_boundary_vertex(v)
            && let Some(last) = self.outgoing(v).last()
        {
            ring.push(self.from(self.prev(last)));
        }
        ring
    }
    /// Marks in `near` (one flag per vertex) every vertex within `rings` rings of `front`,
    /// breadth first; the vertices of `front` must be marked already.
    pub fn mark_rings(&self, near: &mut [bool], mut front: Vec<usize>, rings: usize) {
        for _ in 0..rings {
            let mut next = Vec::new();
            for &v in &front {
                for h in self.outgoing(v) {
                    let w = self.to(h);
                    if !near[w] {
                        near[w] = true;
                        next.push(w);
                    }
                }
            }
            front = next;
        }
    }
}

/// Iterator over the outgoing halfedges of a vertex, see [`TriMesh::outgoing`].
pub struct Outgoing<'a> {
    mesh: &'a TriMesh,
    start: usize,
    current: Option<usize>,
}

impl Iterator for Outgoing<'_> {
    type Item = usize;
    fn next(&mut self) -> Option<usize> {
        let h = self.current?;
        let m = self.mesh;
        self.current = m.twin(m.prev(h)).filter(|&g| g != self.start);
        Some(h)
    }
}
