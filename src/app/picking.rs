//! Picking: the one module every tool asks what is under the cursor.
//!
//! - [`camera_ray`] turns a cursor position in the viewport into a world-space ray through the
//!   same view and projection the renderer draws with ([`OrbitCamera::view_proj`]);
//!   [`project`] goes the other way.
//! - [`Picker`] casts that ray against the mesh through a BVH and returns the face, the point
//!   and the nearest corner vertex ([`Hit`]).
//! - [`Picker::pick_vertex_glyph`] finds the glyph (e.g. a singularity) nearest the cursor in
//!   screen space, within a radius in points, whose vertex is not hidden behind the surface.
//! - [`Picker::pick_curve`] finds the constraint curve with an edge nearest the cursor in screen
//!   space, within a radius, at a point not hidden behind the surface.
//!
//! **Why a CPU BVH, and why `obvhs`.** A ray cast answers synchronously on the mouse move that
//! asks (a GPU id buffer answers a frame or more later, and needs a second render target and a
//! read-back per hover), and it works the same in headless tests without a GPU. Of the
//! maintained BVH crates, `obvhs` (PLOC builder, BVH2/CWBVH traversal) depends on the glam we
//! already use (0.34) plus a few small crates, where `parry3d` brings its own math stack
//! (`glamx`) and a whole collision library, and `bvh` brings nalgebra. Its build of a
//! million-triangle BVH takes a fraction of a second (it runs in a background job when a mesh
//! is loaded) and a ray cast a few microseconds to well under a millisecond.

use std::sync::Arc;
use std::time::Duration;

use glam::{DVec3, Vec3, Vec3A, Vec4};
use obvhs::BvhBuildParams;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::ray::{Ray as BvhRay, RayHit};
use obvhs::triangle::Triangle;

use super::camera::OrbitCamera;
use crate::constraint::Curve;
use crate::mesh::TriMesh;

/// A world-space ray (`dir` is unit length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

/// The viewport's camera and its rectangle on screen (egui points).
#[derive(Clone, Copy, Debug)]
pub struct View {
    pub camera: OrbitCamera,
    pub rect: egui::Rect,
}

impl View {
    fn aspect(&self) -> f32 {
        self.rect.width().max(1.0) / self.rect.height().max(1.0)
    }
}

/// The ray from the eye through the cursor at `pos` (egui points, inside `view.rect`).
pub fn camera_ray(view: &View, pos: egui::Pos2) -> Ray {
    let r = view.rect;
    let x = 2.0 * (pos.x - r.left()) / r.width().max(1.0) - 1.0;
    let y = 1.0 - 2.0 * (pos.y - r.top()) / r.height().max(1.0);
    let inv = view.camera.view_proj(view.aspect()).inverse();
    // DirectX-style depth: 0 at the near plane, 1 at the far plane.
    let near = inv.project_point3(Vec3::new(x, y, 0.0));
    let far = inv.project_point3(Vec3::new(x, y, 1.0));
    let dir = (far - near).normalize_or(-view.camera.back());
    Ray { origin: near, dir }
}

/// Where the world point `p` appears on screen (egui points), or `None` when it is behind the
/// eye or outside the depth range.
pub fn project(view: &View, p: Vec3) -> Option<egui::Pos2> {
    let clip = view.camera.view_proj(view.aspect()) * Vec4::new(p.x, p.y, p.z, 1.0);
    if clip.w <= 1e-9 {
        return None;
    }
    let ndc = clip.truncate() / clip.w;
    if !(0.0..=1.0).contains(&ndc.z) {
        return None;
    }
    let r = view.rect;
    Some(egui::pos2(
        r.left() + 0.5 * (ndc.x + 1.0) * r.width(),
        r.top() + 0.5 * (1.0 - ndc.y) * r.height(),
    ))
}

/// A ray hit on the mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub face: usize,
    /// The hit point (world space).
    pub point: DVec3,
    /// Distance along the ray.
    pub t: f32,
    /// The face's corner nearest the hit point (mesh vertex index).
    pub vertex: usize,
}

/// A BVH over one mesh's triangles (build it off the UI thread: [`Picker::new`] takes about a
/// second per million triangles on one core, less with rayon).
pub struct Picker {
    mesh: Arc<TriMesh>,
    bvh: Bvh2,
    /// Triangles in BVH order (`tris[i]` is face `bvh.primitive_indices[i]`).
    tris: Vec<Triangle>,
}

impl std::fmt::Debug for Picker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Picker")
            .field("faces", &self.tris.len())
            .finish()
    }
}

fn v3a(p: DVec3) -> Vec3A {
    Vec3A::new(p.x as f32, p.y as f32, p.z as f32)
}

impl Picker {
    pub fn new(mesh: Arc<TriMesh>) -> Picker {
        let tris: Vec<Triangle> = mesh
            .faces()
            .iter()
            .map(|f| Triangle {
                v0: v3a(mesh.position(f[0] as usize)),
                v1: v3a(mesh.position(f[1] as usize)),
                v2: v3a(mesh.position(f[2] as usize)),
            })
            .collect();
        let bvh = if tris.is_empty() {
            Bvh2::default()
        } else {
            build_bvh2_from_tris(
                &tris,
                BvhBuildParams::fast_build(),
                &mut Duration::default(),
            )
        };
        // Reorder the triangles like the BVH's primitives, so traversal reads them in order.
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| tris[i as usize])
            .collect();
        Picker { mesh, bvh, tris }
    }

    pub fn mesh(&self) -> &Arc<TriMesh> {
        &self.mesh
    }

    /// Whether this picker was built for `mesh` (the same allocation).
    pub fn is_for(&self, mesh: &Arc<TriMesh>) -> bool {
        Arc::ptr_eq(&self.mesh, mesh)
    }

    /// The nearest hit of the ray on the mesh (both sides of the faces count).
    pub fn cast(&self, ray: &Ray) -> Option<Hit> {
        if self.tris.is_empty() {
            return None;
        }
        let r = BvhRay::new_inf(ray.origin.into(), ray.dir.into());
        let mut hit = RayHit::none();
        let tris = &self.tris;
        if !self
            .bvh
            .ray_traverse(r, &mut hit, |ray, id| tris[id].intersect(ray))
        {
            return None;
        }
        let face = self.bvh.primitive_indices[hit.primitive_id as usize] as usize;
        let point = (ray.origin + ray.dir * hit.t).as_dvec3();
        let f = self.mesh.faces()[face];
        let vertex = f
            .iter()
            .map(|&v| v as usize)
            .min_by(|&a, &b| {
                let da = self.mesh.position(a).distance_squared(point);
                let db = self.mesh.position(b).distance_squared(point);
                da.total_cmp(&db)
            })
            .unwrap_or(f[0] as usize);
        Some(Hit {
            face,
            point,
            t: hit.t,
            vertex,
        })
    }

    /// What is under the cursor.
    pub fn pick(&self, view: &View, pos: egui::Pos2) -> Option<Hit> {
        self.cast(&camera_ray(view, pos))
    }

    /// Whether mesh vertex `v` is seen from the eye: the ray towards it hits the surface at the
    /// vertex (a face around it, or within a small distance of it) and not in front of it.
    pub fn vertex_visible(&self, view: &View, v: usize) -> bool {
        let p = self.mesh.position(v).as_vec3();
        self.point_visible(view, p, |f| f.contains(&(v as u32)))
    }

    /// Whether the surface point `p` is seen from the eye: the ray towards it hits nothing in
    /// front of it (within a small distance), or hits a face `on_surface` accepts (the faces
    /// `p` lies on).
    fn point_visible(&self, view: &View, p: Vec3, on_surface: impl Fn(&[u32; 3]) -> bool) -> bool {
        let eye = view.camera.eye();
        let to = p - eye;
        let dist = to.length();
        if dist <= 0.0 {
            return true;
        }
        let ray = Ray {
            origin: eye,
            dir: to / dist,
        };
        let Some(hit) = self.cast(&ray) else {
            return true;
        };
        let tol = 1e-3 * view.camera.radius.max(1e-6) + 1e-4 * dist;
        if hit.t >= dist - tol {
            return true;
        }
        on_surface(&self.mesh.faces()[hit.face])
    }

    /// Of the `curves`, the one with an edge nearest the cursor on screen within `radius_px`
    /// points, at a point of the edge not hidden behind the surface; its id.
    pub fn pick_curve<'a>(
        &self,
        view: &View,
        pos: egui::Pos2,
        curves: impl IntoIterator<Item = &'a Curve>,
        radius_px: f32,
    ) -> Option<u32> {
        let n = self.mesh.n_vertices();
        let at = |v: usize| self.mesh.position(v).as_vec3();
        // (screen distance, curve, edge, position along the edge)
        let mut near: Vec<(f32, u32, usize, usize, f32)> = Vec::new();
        for c in curves {
            for (a, b) in c.segments() {
                if a >= n || b >= n {
                    continue;
                }
                let (Some(sa), Some(sb)) = (project(view, at(a)), project(view, at(b))) else {
                    continue;
                };
                let (d, t) = distance_to_segment(pos, sa, sb);
                if d <= radius_px {
                    near.push((d, c.id, a, b, t));
                }
            }
        }
        near.sort_by(|x, y| x.0.total_cmp(&y.0));
        // Screen and world parameters along an edge differ by the perspective: close enough
        // for a visibility test, which accepts both faces of the edge.
        near.into_iter()
            .take(64)
            .find(|&(_, _, a, b, t)| {
                let (a32, b32) = (a as u32, b as u32);
                self.point_visible(view, at(a).lerp(at(b), t), |f| {
                    f.contains(&a32) && f.contains(&b32)
                })
            })
            .map(|(_, id, ..)| id)
    }

    /// Of the `vertices`, the one whose glyph is nearest the cursor on screen within
    /// `radius_px` points and not hidden behind the surface.
    pub fn pick_vertex_glyph(
        &self,
        view: &View,
        pos: egui::Pos2,
        vertices: impl IntoIterator<Item = usize>,
        radius_px: f32,
    ) -> Option<usize> {
        let mut near: Vec<(f32, usize)> = vertices
            .into_iter()
            .filter(|&v| v < self.mesh.n_vertices())
            .filter_map(|v| {
                let s = project(view, self.mesh.position(v).as_vec3())?;
                let d = s.distance(pos);
                (d <= radius_px).then_some((d, v))
            })
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0));
        near.into_iter()
            .map(|(_, v)| v)
            .find(|&v| self.vertex_visible(view, v))
    }
}

/// The distance from `p` to the segment `a`-`b` (screen points) and the parameter of the
/// nearest point along it (0 at `a`, 1 at `b`).
pub fn distance_to_segment(p: egui::Pos2, a: egui::Pos2, b: egui::Pos2) -> (f32, f32) {
    let ab = b - a;
    let len2 = ab.length_sq();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((a + ab * t).distance(p), t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize) -> Arc<TriMesh> {
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                p.push(DVec3::new(i as f64 / n as f64, j as f64 / n as f64, 0.0));
            }
        }
        let mut t = Vec::new();
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        for j in 0..n {
            for i in 0..n {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        Arc::new(TriMesh::from_triangles(p, t).expect("grid mesh"))
    }

    fn view() -> View {
        let mut camera = OrbitCamera {
            yaw: 0.0,
            pitch: 0.0,
            ..OrbitCamera::default()
        };
        camera.fit((Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)));
        View {
            camera,
            rect: egui::Rect::from_min_size(egui::pos2(100.0, 50.0), egui::vec2(400.0, 300.0)),
        }
    }

    #[test]
    fn project_and_ray_agree() {
        let v = view();
        let p = Vec3::new(0.3, 0.7, 0.0);
        let s = project(&v, p).expect("in view");
        let r = camera_ray(&v, s);
        // the ray passes through p
        let along = (p - r.origin).dot(r.dir);
        let closest = r.origin + r.dir * along;
        assert!((closest - p).length() < 1e-4, "{closest} vs {p}");
        // the view centre is the target
        let c = camera_ray(&v, v.rect.center());
        assert!((c.dir + v.camera.back()).length() < 1e-4);
    }

    #[test]
    fn picks_the_face_and_vertex_under_the_cursor() {
        let mesh = grid(20);
        let picker = Picker::new(mesh.clone());
        let v = view();
        let target = DVec3::new(0.5, 0.25, 0.0);
        let s = project(&v, target.as_vec3()).unwrap();
        let hit = picker.pick(&v, s).expect("hit");
        assert!((hit.point - target).length() < 1e-3, "{:?}", hit.point);
        assert!(mesh.faces()[hit.face].contains(&(hit.vertex as u32)));
        assert!((mesh.position(hit.vertex) - target).length() < 1e-6);
        // outside the mesh: nothing
        let miss = project(&v, Vec3::new(1.5, 0.5, 0.0)).unwrap();
        assert!(picker.pick(&v, miss).is_none());
        // glyphs: the nearest within the radius
        let a = hit.vertex;
        let got = picker.pick_vertex_glyph(&v, s + egui::vec2(3.0, 0.0), [0, a], 10.0);
        assert_eq!(got, Some(a));
        assert_eq!(
            picker.pick_vertex_glyph(&v, s + egui::vec2(40.0, 0.0), [a], 10.0),
            None
        );
    }

    /// A million triangles: the BVH builds in about a second and a pick (ray cast plus the
    /// visibility rays of nearby glyphs) takes well under the frame budget.
    #[test]
    fn picks_a_million_triangles_in_milliseconds() {
        let n = 708; // 2 * 708² = 1 002 528 triangles
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                let z = 0.03 * (17.0 * x).sin() * (13.0 * y).cos();
                p.push(DVec3::new(x, y, z));
            }
        }
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut t = Vec::with_capacity(2 * n * n);
        for j in 0..n {
            for i in 0..n {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let mesh = Arc::new(TriMesh::from_triangles(p, t).unwrap());
        let start = std::time::Instant::now();
        let picker = Picker::new(mesh.clone());
        let build = start.elapsed();
        let mut v = view();
        v.camera.pitch = 0.4;
        v.camera.yaw = 0.3;
        let glyphs: Vec<usize> = (0..200).map(|k| (k * 2503) % mesh.n_vertices()).collect();
        let start = std::time::Instant::now();
        let mut hits = 0;
        let rounds = 200;
        for k in 0..rounds {
            let pos = v.rect.center()
                + egui::vec2((k * 37 % 160) as f32 - 80.0, (k * 53 % 120) as f32 - 60.0);
            hits += picker.pick(&v, pos).is_some() as usize;
            let _ = picker.pick_vertex_glyph(&v, pos, glyphs.iter().copied(), 10.0);
        }
        let per_pick = start.elapsed() / rounds as u32;
        eprintln!(
            "1M triangles: BVH build {:.0} ms, pick + glyph pick {:.3} ms",
            build.as_secs_f64() * 1e3,
            per_pick.as_secs_f64() * 1e3
        );
        assert!(hits > rounds * 9 / 10, "{hits} hits");
        assert!(per_pick.as_secs_f64() < 5e-3, "{per_pick:?} per pick");
    }

    #[test]
    fn hidden_vertices_are_not_picked() {
        // Two parallel grids: the back one's vertices are behind the front one.
        let front = grid(4);
        let mut p: Vec<DVec3> = front.positions().to_vec();
        let n0 = p.len() as u32;
        p.extend(front.positions().iter().map(|q| *q - DVec3::Z * 0.5));
        let mut t: Vec<[u32; 3]> = front.faces().to_vec();
        t.extend(front.faces().iter().map(|f| f.map(|v| v + n0)));
        let mesh = Arc::new(TriMesh::from_triangles(p, t).unwrap());
        let picker = Picker::new(mesh.clone());
        let v = view();
        let behind = n0 as usize + 12; // the centre vertex of the back grid
        let s = project(&v, mesh.position(behind).as_vec3()).unwrap();
        assert!(!picker.vertex_visible(&v, behind));
        assert!(picker.vertex_visible(&v, 12));
        assert_eq!(picker.pick_vertex_glyph(&v, s, [behind], 10.0), None);
    }

    #[test]
    fn curves_are_picked_near_their_edges_and_not_through_the_surface() {
        use crate::constraint::{CurveKind, CurveOrigin};
        // The front grid of `hidden_vertices_are_not_picked`'s pair, and one behind it.
        let front = grid(4);
        let mut p: Vec<DVec3> = front.positions().to_vec();
        let n0 = p.len();
        p.extend(front.positions().iter().map(|q| *q - DVec3::Z * 0.5));
        let mut t: Vec<[u32; 3]> = front.faces().to_vec();
        t.extend(front.faces().iter().map(|f| f.map(|v| v + n0 as u32)));
        let mesh = Arc::new(TriMesh::from_triangles(p, t).unwrap());
        let picker = Picker::new(mesh.clone());
        let v = view();
        let curve = |id, vertices: Vec<usize>| Curve {
            id,
            vertices,
            closed: false,
            kind: CurveKind::Geometric,
            origin: CurveOrigin::Drawn,
        };
        // Row 2 of the front grid (vertices 10..=14), and the same row behind it.
        let front_row = curve(3, (10..=14).collect());
        let back_row = curve(7, (n0 + 10..=n0 + 14).collect());
        let mid = |a: usize, b: usize| {
            let pa = project(&v, mesh.position(a).as_vec3()).unwrap();
            let pb = project(&v, mesh.position(b).as_vec3()).unwrap();
            pa + (pb - pa) * 0.5
        };
        let s = mid(11, 12);
        assert_eq!(
            picker.pick_curve(&v, s + egui::vec2(0.0, 3.0), [&front_row, &back_row], 6.0),
            Some(3)
        );
        assert_eq!(
            picker.pick_curve(&v, s + egui::vec2(0.0, 30.0), [&front_row], 6.0),
            None
        );
        // the row behind projects near the front one but is hidden
        let sb = mid(n0 + 11, n0 + 12);
        assert_eq!(picker.pick_curve(&v, sb, [&back_row], 6.0), None);
        assert_eq!(
            distance_to_segment(
                egui::pos2(1.0, 1.0),
                egui::pos2(0.0, 0.0),
                egui::pos2(2.0, 0.0)
            ),
            (1.0, 0.5)
        );
    }
}
