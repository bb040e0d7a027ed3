//! Per-face tangent bases and the discrete Levi-Civita transport between adjacent faces.
//!
//! An angle `theta` in face `f` denotes the tangent direction `cos(theta) e1 + sin(theta) e2` with
//! `(e1, e2) = mesh.face_basis(f)`. Unfolding face `j` into the plane of face `i` across their
//! shared edge maps the direction at angle `theta` in `i` to `theta + kappa_ij` in `j`, where
//! `kappa_ij = angle_j(edge) - angle_i(edge)` (the angle of the shared edge vector in each basis).

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::TriMesh;

/// Marker for "no face" (boundary side of an edge).
pub const NO_FACE: u32 = u32::MAX;

/// Orthonormal tangent basis and unit normal per face.
#[derive(Clone, Debug)]
pub struct FaceBases {
    pub e1: Vec<DVec3>,
    pub e2: Vec<DVec3>,
    pub normal: Vec<DVec3>,
}

impl FaceBases {
    pub fn new(mesh: &TriMesh) -> FaceBases {
        let data: Vec<(DVec3, DVec3, DVec3)> = (0..mesh.n_faces())
            .into_par_iter()
            .map(|f| {
                let (e1, e2) = mesh.face_basis(f);
                (e1, e2, mesh.face_normal(f))
            })
            .collect();
        let mut b = FaceBases {
            e1: Vec::with_capacity(data.len()),
            e2: Vec::with_capacity(data.len()),
            normal: Vec::with_capacity(data.len()),
        };
        for (e1, e2, n) in data {
            b.e1.push(e1);
            b.e2.push(e2);
            b.normal.push(n);
        }
        b
    }

    /// Angle of the tangent part of `v` in the basis of face `f`.
    pub fn angle_of(&self, f: usize, v: DVec3) -> f64 {
        v.dot(self.e2[f]).atan2(v.dot(self.e1[f]))
    }

    /// Unit tangent vector at angle `theta` in face `f`.
    pub fn direction(&self, f: usize, theta: f64) -> DVec3 {
        let (s, c) = theta.sin_cos();
        c * self.e1[f] + s * self.e2[f]
    }
}

/// Per edge: the two faces (`face(h0)`, `face(h1)`, [`NO_FACE`] on the boundary) and the transport
/// angle `kappa` from the first to the second (0 on the boundary).
#[derive(Clone, Debug)]
pub struct EdgeTransport {
    pub faces: Vec<[u32; 2]>,
    pub kappa: Vec<f64>,
}

impl EdgeTransport {
    pub fn new(mesh: &TriMesh, bases: &FaceBases) -> EdgeTransport {
        let data: Vec<([u32; 2], f64)> = (0..mesh.n_edges())
            .into_par_iter()
            .map(|e| {
                let (h0, h1) = mesh.edge_halfedges(e);
                let i = mesh.face_of(h0);
                match h1 {
                    None => ([i as u32, NO_FACE], 0.0),
                    Some(h1) => {
                        let j = mesh.face_of(h1);
                        let d = mesh.vector(h0);
                        let k = wrap_pi(bases.angle_of(j, d) - bases.angle_of(i, d));
                        ([i as u32, j as u32], k)
                    }
                }
            })
            .collect();
        let (faces, kappa) = data.into_iter().unzip();
        EdgeTransport { faces, kappa }
    }

    pub fn is_interior(&self, e: usize) -> bool {
        self.faces[e][1] != NO_FACE
    }

    pub fn n_interior(&self) -> usize {
        self.faces.iter().filter(|f| f[1] != NO_FACE).count()
    }
}

/// Wraps an angle into (-π, π].
pub fn wrap_pi(a: f64) -> f64 {
    let mut x = a.rem_euclid(TAU);
    if x > PI {
        x -= TAU;
    }
    x
}
