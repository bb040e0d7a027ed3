//! Closest-point queries on a triangle surface (the input mesh, or a triangulated remesh), over
//! parry3d's triangle-mesh BVH.
//!
//! The parry mesh is built without any [`TriMeshFlags`](parry3d_f64::shape::TriMeshFlags): no
//! topology or orientation checks, no merging or deletion of triangles, so its triangle `i` stays
//! our triangle `tri_face[i]` and nothing the input may contain (degenerate or needle
//! triangles, non-manifold fans, unreferenced vertices) is refused. Parry projects onto a
//! degenerate triangle's longest edge. Triangles with a non-finite corner are left out (their
//! bounding boxes would poison the BVH); a surface without any triangle answers every query
//! with the query point itself, face `usize::MAX` and distance `+∞`.

use glam::DVec3;
use parry3d_f64::math::Vector;
use parry3d_f64::query::PointQueryWithLocation;
use parry3d_f64::shape::{TriMesh as ParryMesh, TriMeshFlags};

use crate::mesh::TriMesh;

/// A closest-point structure over a fixed set of triangles (Send + Sync: share it across rayon).
pub struct Surface {
    mesh: Option<ParryMesh>,
    /// Per parry triangle, the index of the triangle it came from.
    tri_face: Vec<u32>,
}

/// The result of [`Surface::project`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    pub point: DVec3,
    /// The triangle (input face) the point lies on; `usize::MAX` for an empty surface.
    pub face: usize,
    /// Barycentric coordinates of `point` in that triangle (corner order of the triangle).
    pub bary: [f64; 3],
}

fn to_parry(p: DVec3) -> Vector {
    Vector::new(p.x, p.y, p.z)
}

fn from_parry(p: Vector) -> DVec3 {
    DVec3::new(p.x, p.y, p.z)
}

impl Surface {
    /// The surface of a triangle mesh; answers carry the mesh's face indices.
    pub fn new(mesh: &TriMesh) -> Surface {
        Surface::from_triangles(mesh.positions(), mesh.faces())
    }

    /// The surface of arbitrary triangles over `positions` (no validity requirements; triangles
    /// with an out-of-range index or a non-finite corner are skipped). Answers carry indices into
    /// `triangles`.
    pub fn from_triangles(positions: &[DVec3], triangles: &[[u32; 3]]) -> Surface {
        let vertices: Vec<Vector> = positions.iter().map(|&p| to_parry(p)).collect();
        let mut indices = Vec::with_capacity(triangles.len());
        let mut tri_face = Vec::with_capacity(triangles.len());
        for (f, t) in triangles.iter().enumerate() {
            let ok = t
                .iter()
                .all(|&v| positions.get(v as usize).is_some_and(|p| p.is_finite()));
            if ok {
                indices.push(*t);
                tri_face.push(f as u32);
            }
        }
        // `with_flags` only fails on an empty index buffer when no flags are asked for.
        let mesh = if indices.is_empty() {
            None
        } else {
            ParryMesh::with_flags(vertices, indices, TriMeshFlags::empty()).ok()
        };
        if mesh.is_none() {
            tri_face.clear();
        }
        Surface { mesh, tri_face }
    }

    /// The surface of polygons over `positions`: triangles as they are, longer polygons fanned
    /// around their vertex centroid (robust for the non-convex faces next to singularities).
    /// Answers carry indices into the fan triangles, not the polygons.
    pub fn from_polygons(positions: &[DVec3], polygons: &[Vec<u32>]) -> Surface {
        let mut all = positions.to_vec();
        let mut tris = Vec::new();
        for f in polygons {
            match f.len() {
                0..=2 => {}
                3 => tris.push([f[0], f[1], f[2]]),
                n => {
                    let c = f
                        .iter()
                        .map(|&v| positions.get(v as usize).copied().unwrap_or(DVec3::NAN))
                        .sum::<DVec3>()
                        / n as f64;
                    let ci = all.len() as u32;
                    all.push(c);
                    for k in 0..n {
                        tris.push([f[k], f[(k + 1) % n], ci]);
                    }
                }
            }
        }
        Surface::from_triangles(&all, &tris)
    }

    /// Whether the surface has no triangle.
    pub fn is_empty(&self) -> bool {
        self.mesh.is_none()
    }

    /// The closest point to `p` on the surface, its triangle and barycentric coordinates.
    pub fn project(&self, p: DVec3) -> Projection {
        let none = Projection {
            point: p,
            face: usize::MAX,
            bary: [1.0, 0.0, 0.0],
        };
        let Some(mesh) = &self.mesh else { return none };
        if !p.is_finite() {
            return none;
        }
        let (proj, (tri, loc)) = mesh.project_local_point_and_get_location(to_parry(p), false);
        let Some(&face) = self.tri_face.get(tri as usize) else {
            return none;
        };
        let bary = loc.barycentric_coordinates().unwrap_or([1.0 / 3.0; 3]);
        Projection {
            point: from_parry(proj.point),
            face: face as usize,
            bary,
        }
    }

    /// The closest point to `p` on the surface and the triangle (input face) it lies on.
    pub fn closest(&self, p: DVec3) -> (DVec3, usize) {
        let r = self.project(p);
        (r.point, r.face)
    }

    /// The distance from `p` to the surface (`+∞` for an empty surface).
    pub fn distance(&self, p: DVec3) -> f64 {
        if self.is_empty() {
            return f64::INFINITY;
        }
        (self.project(p).point - p).length()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    /// Closest point on triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
    fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
        let (ab, ac, ap) = (b - a, c - a, p - a);
        let (d1, d2) = (ab.dot(ap), ac.dot(ap));
        if d1 <= 0.0 && d2 <= 0.0 {
            return a;
        }
        let bp = p - b;
        let (d3, d4) = (ab.dot(bp), ac.dot(bp));
        if d3 >= 0.0 && d4 <= d3 {
            return b;
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            return a + ab * (d1 / (d1 - d3));
        }
        let cp = p - c;
        let (d5, d6) = (ab.dot(cp), ac.dot(cp));
        if d6 >= 0.0 && d5 <= d6 {
            return c;
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            return a + ac * (d2 / (d2 - d6));
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
        }
        let denom = 1.0 / (va + vb + vc);
        let (v, w) = (vb * denom, vc * denom);
        a + ab * v + ac * w
    }

    fn brute_force(mesh: &TriMesh, p: DVec3) -> f64 {
        (0..mesh.n_faces())
            .map(|f| {
                let [a, b, c] = mesh.face(f).map(|v| mesh.position(v));
                (closest_on_triangle(p, a, b, c) - p).length()
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The BVH search returns the exact nearest distance: near the surface, far from it, and on
    /// a mesh whose triangles differ in size by a factor of a thousand. The reported face holds
    /// the point, and the barycentric coordinates reproduce it.
    #[test]
    fn surface_matches_brute_force() {
        let sphere = generate::icosphere(3);
        let mut uneven = generate::grid(40, 40, 1.0, 1.0);
        let mut p = uneven.positions().to_vec();
        for q in &mut p {
            q.x = q.x.powi(6) * 1000.0;
        }
        uneven = TriMesh::from_triangles(p, uneven.faces().to_vec()).unwrap();
        for mesh in [&sphere, &uneven] {
            let surface = Surface::new(mesh);
            let (lo, hi) = mesh.bounding_box();
            let scale = (hi - lo).length();
            let mut seed = 7u64;
            let mut rnd = || {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (seed >> 11) as f64 / (1u64 << 53) as f64
            };
            for k in 0..400 {
                let t = DVec3::new(rnd(), rnd(), rnd()) * 1.4 - DVec3::splat(0.2);
                let mut q = lo + (hi - lo) * t;
                if k % 2 == 0 {
                    // near the surface: a vertex nudged
                    let v = (rnd() * mesh.n_vertices() as f64) as usize % mesh.n_vertices();
                    q = mesh.position(v) + (q - mesh.position(v)) * 1e-3;
                }
                // 1e-9 relative; plus 1e-10 of the mesh size for the reference's own rounding
                // (Ericson's barycentric division on the 1000:1 needles, in their plane).
                let (a, b) = (surface.distance(q), brute_force(mesh, q));
                assert!(
                    (a - b).abs() <= 1e-9 * b + 1e-10 * scale,
                    "{q:?}: bvh {a}, exact {b}"
                );
                let r = surface.project(q);
                let [x, y, z] = mesh.face(r.face).map(|v| mesh.position(v));
                let on = closest_on_triangle(q, x, y, z);
                assert!((on - r.point).length() <= 1e-9 * scale, "face {}", r.face);
                let from_bary = x * r.bary[0] + y * r.bary[1] + z * r.bary[2];
                assert!((from_bary - r.point).length() <= 1e-9 * scale);
            }
        }
    }

    /// Degenerate triangles (collinear, repeated corner) and bad triangles do not panic, and an
    /// empty surface answers with infinity.
    #[test]
    fn degenerate_and_empty_surfaces() {
        let p = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::NAN,
        ];
        let s = Surface::from_triangles(&p, &[[0, 1, 2], [0, 0, 3], [0, 1, 4], [0, 1, 9]]);
        let d = s.distance(DVec3::new(1.5, 1.0, 0.0));
        assert!((d - 1.0).abs() < 1e-12, "{d}");
        let (_, f) = s.closest(DVec3::new(-1.0, 0.5, 0.0));
        assert_eq!(f, 1);
        assert!((s.distance(DVec3::new(-1.0, 0.5, 0.0)) - 1.0).abs() < 1e-12);
        let empty = Surface::from_triangles(&p, &[]);
        assert!(empty.is_empty());
        assert_eq!(empty.distance(DVec3::ONE), f64::INFINITY);
        assert_eq!(empty.closest(DVec3::ONE), (DVec3::ONE, usize::MAX));
        let only_bad = Surface::from_triangles(&p, &[[0, 1, 4]]);
        assert!(only_bad.is_empty());
        fn send_sync<T: Send + Sync>() {}
        send_sync::<Surface>();
    }
}
