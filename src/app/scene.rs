//! CPU-side, GPU-ready scene data: per-corner vertices, overlay line segments and
//! singularity glyphs. Built from plain arrays so it does not depend on any core
//! type; [`SceneData::from_trimesh`] adapts the core mesh and [`FacePatches::from_poles`] the
//! poles' bilinear stars.
//!
//! **Pole stars.** Around a pole the map is bilinear on quads, not linear on the star's
//! triangles (`crate::param::Pole`): the star triangles' own corner UVs disagree at the pole, and
//! drawn linearly they show a seam fanning out from it. [`SceneData::set_patches`] draws those
//! faces by finer triangles instead (the quads cut into k × k cells, [`FacePatches`]): their
//! corners are appended after the input faces' (vertex `3 * n_faces()` on), and the replaced
//! faces' own corners are collapsed to a point, so they cover no pixel but keep their slots
//! (vertex `3 * f + k` stays face `f`'s corner `k`).

use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};

/// One triangle corner. Vertex `3*f + k` is corner `k` of face `f`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Vertex {
    pub position: [f32; 3],
    /// Smooth (vertex) normal.
    pub normal: [f32; 3],
    /// Face normal (for flat shading).
    pub face_normal: [f32; 3],
    /// Texture coordinate (parameterization), per corner.
    pub uv: [f32; 2],
    /// Field direction of the face (unit, tangent), zero when there is no field.
    pub field: [f32; 3],
}

/// A line segment overlay (cut graph, constraints, selection, field crosses).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct LineSegment {
    pub a: [f32; 3],
    pub b: [f32; 3],
    /// Linear RGBA.
    pub color: [f32; 4],
}

/// A disc glyph (singular vertex).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Glyph {
    pub position: [f32; 3],
    /// Linear RGBA.
    pub color: [f32; 4],
}

/// Lines and glyphs drawn over the scene and uploaded apart from it, so a change does not
/// re-upload the mesh: the constraint curves, the feature preview, the active tool's transient
/// overlay (drag preview, selection). `revision` changes whenever the content does (a new
/// number from `tools::next_overlay_revision`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Overlay {
    pub revision: u64,
    /// Lines of the pattern's line width (thinner than `lines`), drawn first: the remesh's
    /// edges, many and close together.
    pub fine_lines: Vec<LineSegment>,
    /// Lines of the overlay width ([`super::settings::DisplaySettings::overlay_line_width_px`]).
    pub lines: Vec<LineSegment>,
    /// Lines twice as wide, drawn after `lines`.
    pub thick_lines: Vec<LineSegment>,
    pub glyphs: Vec<Glyph>,
    /// Small discs (about half a glyph across), drawn after everything else: the remesh's
    /// irregular vertices, which often sit on a singularity's glyph.
    pub dots: Vec<Glyph>,
    /// Drawn after every glyph (the singularities' too) instead of under them: a marker at a
    /// singular vertex (a folded face there) stays visible.
    pub over_glyphs: bool,
}

impl Overlay {
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
            && self.fine_lines.is_empty()
            && self.thick_lines.is_empty()
            && self.glyphs.is_empty()
            && self.dots.is_empty()
    }
}

/// Everything the renderer uploads for one version of the document.
#[derive(Clone, Debug, Default)]
pub struct SceneData {
    pub vertices: Vec<Vertex>,
    pub lines: Vec<LineSegment>,
    pub glyphs: Vec<Glyph>,
    /// Axis-aligned bounding box (min, max).
    pub bbox: (Vec3, Vec3),
    /// True when `uv` holds a parameterization.
    pub has_uv: bool,
    /// True when `field` holds a field.
    pub has_field: bool,
    /// Symmetry order N of the field (2, 4 or 6); 4 when there is no field.
    pub symmetry: u32,
    /// Per triangle appended after the input faces' (vertices from `3 * n_faces()` on), the
    /// input face it draws ([`SceneData::set_patches`]); empty without patches.
    pub patch_faces: Vec<u32>,
    /// The replaced faces' edges, each once: their wireframe (the patches' own triangles are
    /// finer than the mesh, so the renderer draws these instead of the patches' wireframe).
    pub patch_wire: Vec<[[f32; 3]; 2]>,
    /// The replaced faces and their corners before they were collapsed (restored when the
    /// patches go).
    replaced: Vec<(u32, [Vertex; 3])>,
}

/// Triangles that draw some input faces instead of their own corners: the pole stars'
/// bilinear quads cut into k × k cells ([`FacePatches::from_poles`]). Plain arrays, like
/// [`SceneData::from_triangles`]'s.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FacePatches {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Texture coordinates per corner `3 * t + c`.
    pub uv: Vec<[f64; 2]>,
    /// Per triangle the input face it lies in (the face it replaces).
    pub face: Vec<usize>,
}

impl FacePatches {
    /// Cells per side of a pole's quads: the bilinear map drawn by about 2 k² triangles per star
    /// face.
    pub const POLE_CELLS: usize = 8;

    /// The stars of `poles` (of a parameterization of `mesh`), tessellated with
    /// [`FacePatches::POLE_CELLS`] cells per side (`crate::param::tessellate`).
    pub fn from_poles(mesh: &crate::mesh::TriMesh, poles: &[crate::param::Pole]) -> FacePatches {
        if poles.is_empty() {
            return FacePatches::default();
        }
        let t = crate::param::tessellate(mesh, poles, Self::POLE_CELLS, 1.0);
        FacePatches {
            positions: t.positions,
            triangles: t.triangles,
            uv: t.uv,
            face: t.face,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }
}

fn f3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

impl SceneData {
    /// Builds per-corner vertices from indexed triangles. Smooth normals are
    /// angle-weighted; degenerate faces get a zero face normal.
    pub fn from_triangles(positions: &[DVec3], faces: &[[u32; 3]]) -> SceneData {
        let mut face_normals = Vec::with_capacity(faces.len());
        let mut vnormals = vec![DVec3::ZERO; positions.len()];
        for f in faces {
            let p = [0, 1, 2].map(|k| positions[f[k] as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            face_normals.push(n);
            for k in 0..3 {
                let a = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
                let b = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
                let angle = a.dot(b).clamp(-1.0, 1.0).acos();
                vnormals[f[k] as usize] += n * angle;
            }
        }
        let mut vertices = Vec::with_capacity(faces.len() * 3);
        for (fi, f) in faces.iter().enumerate() {
            let fnrm = face_normals[fi];
            for &v in f {
                let mut n = vnormals[v as usize].normalize_or_zero();
                if n == DVec3::ZERO {
                    n = fnrm;
                }
                vertices.push(Vertex {
                    position: f3(positions[v as usize]),
                    normal: f3(n),
                    face_normal: f3(fnrm),
                    uv: [0.0, 0.0],
                    field: [0.0; 3],
                });
            }
        }
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for f in faces {
            for &v in f {
                let p = Vec3::from(f3(positions[v as usize]));
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        if faces.is_empty() {
            lo = Vec3::splat(-1.0);
            hi = Vec3::splat(1.0);
        }
        SceneData {
            vertices,
            lines: Vec::new(),
            glyphs: Vec::new(),
            bbox: (lo, hi),
            has_uv: false,
            has_field: false,
            symmetry: 4,
            patch_faces: Vec::new(),
            patch_wire: Vec::new(),
            replaced: Vec::new(),
        }
    }

    /// Adapts the core mesh.
    pub fn from_trimesh(mesh: &crate::mesh::TriMesh) -> SceneData {
        SceneData::from_triangles(mesh.positions(), mesh.faces())
    }

    /// The input faces (patch triangles not counted).
    pub fn n_faces(&self) -> usize {
        self.vertices.len() / 3 - self.patch_faces.len()
    }

    /// Per-corner UVs indexed `3*f + k` (the parameterization result layout). Drops the patches
    /// of an earlier map ([`SceneData::set_patches`]).
    pub fn set_corner_uvs(&mut self, uvs: &[[f64; 2]]) {
        self.clear_patches();
        for (v, uv) in self.vertices.iter_mut().zip(uvs) {
            v.uv = [uv[0] as f32, uv[1] as f32];
        }
        self.has_uv = uvs.len() == self.vertices.len();
    }

    /// Removes the parameterization (and its patches).
    pub fn clear_uvs(&mut self) {
        self.clear_patches();
        for v in &mut self.vertices {
            v.uv = [0.0, 0.0];
        }
        self.has_uv = false;
    }

    /// Draws the faces `patches` lie in by the patches' triangles (with their texture
    /// coordinates) instead of by their own corners, replacing earlier patches. Each patch
    /// corner takes its face's normal, field and, interpolated at its place in the face, its
    /// smooth normal. Degenerate patch triangles (two corners at one point, as on a pole) and
    /// triangles of faces out of range are left out.
    pub fn set_patches(&mut self, patches: &FacePatches) {
        self.clear_patches();
        let n = self.n_faces();
        let mut faces: Vec<u32> = patches
            .face
            .iter()
            .filter(|&&f| f < n)
            .map(|&f| f as u32)
            .collect();
        faces.sort_unstable();
        faces.dedup();
        if faces.is_empty() {
            return;
        }
        // The replaced faces' edges, each once (keyed by their end points' bits).
        let key = |p: [f32; 3]| p.map(f32::to_bits);
        let mut seen = std::collections::HashSet::new();
        for &f in &faces {
            let c: [Vertex; 3] = std::array::from_fn(|k| self.vertices[3 * f as usize + k]);
            for k in 0..3 {
                let (a, b) = (c[k].position, c[(k + 1) % 3].position);
                let (ka, kb) = (key(a), key(b));
                if seen.insert(if ka <= kb { (ka, kb) } else { (kb, ka) }) {
                    self.patch_wire.push([a, b]);
                }
            }
            self.replaced.push((f, c));
        }
        for (t, tri) in patches.triangles.iter().enumerate() {
            let Some(&f) = patches.face.get(t).filter(|&&f| f < n) else {
                continue;
            };
            let p = tri.map(|i| patches.positions[i as usize]);
            if p[0] == p[1] || p[1] == p[2] || p[2] == p[0] {
                continue;
            }
            let Ok(k) = self.replaced.binary_search_by_key(&(f as u32), |r| r.0) else {
                continue;
            };
            let corners = self.replaced[k].1;
            for (c, &pc) in p.iter().enumerate() {
                let uv = patches.uv.get(3 * t + c).copied().unwrap_or_default();
                self.vertices.push(patch_vertex(&corners, pc, uv));
            }
            self.patch_faces.push(f as u32);
        }
        // Collapse the replaced faces to their first corner: no pixel, same slots.
        for &(f, c) in &self.replaced {
            for k in 0..3 {
                self.vertices[3 * f as usize + k].position = c[0].position;
            }
        }
    }

    /// Removes the patches: the replaced faces get their corners back.
    pub fn clear_patches(&mut self) {
        let n = self.n_faces();
        self.vertices.truncate(3 * n);
        self.patch_faces.clear();
        self.patch_wire.clear();
        for (f, c) in self.replaced.drain(..) {
            let f = f as usize;
            self.vertices[3 * f..3 * f + 3].copy_from_slice(&c);
        }
    }

    /// Per-face field direction (any tangent vector of the N-symmetric field,
    /// e.g. `FrameField::frames[f][0]`), normalized here.
    pub fn set_face_field(&mut self, dirs: &[DVec3], symmetry: u32) {
        let n = self.n_faces();
        let dir = |f: usize| f3(dirs.get(f).map_or(DVec3::ZERO, |d| d.normalize_or_zero()));
        for (f, d) in dirs.iter().enumerate().take(n) {
            let d = f3(d.normalize_or_zero());
            for k in 0..3 {
                self.vertices[3 * f + k].field = d;
            }
        }
        for (t, &f) in self.patch_faces.iter().enumerate() {
            let d = dir(f as usize);
            for k in 0..3 {
                self.vertices[3 * (n + t) + k].field = d;
            }
        }
        for (f, c) in &mut self.replaced {
            let d = dir(*f as usize);
            for v in c {
                v.field = d;
            }
        }
        self.has_field = dirs.len() == n;
        self.symmetry = symmetry.max(1);
    }

    /// Removes the field.
    pub fn clear_field(&mut self) {
        for v in self
            .vertices
            .iter_mut()
            .chain(self.replaced.iter_mut().flat_map(|(_, c)| c))
        {
            v.field = [0.0; 3];
        }
        self.has_field = false;
    }

    pub fn radius(&self) -> f32 {
        (0.5 * (self.bbox.1 - self.bbox.0).length()).max(1e-6)
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.bbox.0 + self.bbox.1)
    }
}

/// The corner of a patch triangle at `p` in the face with corners `c`: the face's normal and
/// field, its smooth normal interpolated at `p`'s barycentric coordinates.
fn patch_vertex(c: &[Vertex; 3], p: DVec3, uv: [f64; 2]) -> Vertex {
    let q = c.map(|v| DVec3::from(v.position.map(f64::from)));
    let (e1, e2, d) = (q[1] - q[0], q[2] - q[0], p - q[0]);
    let (a, b, cc) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = a * cc - b * b;
    let w = if det.abs() > 1e-30 {
        let w1 = (cc * d1 - b * d2) / det;
        let w2 = (a * d2 - b * d1) / det;
        [1.0 - w1 - w2, w1, w2]
    } else {
        [1.0, 0.0, 0.0]
    };
    let n = (0..3).fold(DVec3::ZERO, |acc, k| {
        acc + DVec3::from(c[k].normal.map(f64::from)) * w[k]
    });
    let n = n.normalize_or_zero();
    Vertex {
        position: f3(p),
        normal: if n == DVec3::ZERO {
            c[0].face_normal
        } else {
            f3(n)
        },
        face_normal: c[0].face_normal,
        uv: [uv[0] as f32, uv[1] as f32],
        field: c[0].field,
    }
}

/// Color of a singularity glyph for index `k/N` (linear RGB).
///
/// Negative indices are blue (−1/4 is pure blue), positive are yellow (+1/4 is
/// yellow); larger magnitudes shift towards purple (negative) or red (positive),
/// so every k/N gets a distinct, sign-coded color.
pub fn singularity_color(k: i32, n: u32) -> [f32; 4] {
    let x = k as f32 / n.max(1) as f32;
    if k == 0 {
        return [0.6, 0.6, 0.6, 1.0];
    }
    // t = 0 at |x| = 1/4, 1 at |x| = 1, negative below 1/4
    let t = ((x.abs() - 0.25) / 0.75).clamp(-1.0, 1.0);
    if x < 0.0 {
        if t >= 0.0 {
            // blue -> purple
            [0.35 * t + 0.0, 0.08 * (1.0 - t), 1.0 - 0.4 * t, 1.0]
        } else {
            // small magnitudes (e.g. -1/6): lighter cyan-blue
            let s = -t;
            [0.0, 0.08 + 0.6 * s, 1.0, 1.0]
        }
    } else if t >= 0.0 {
        // yellow -> red
        [1.0, 0.85 * (1.0 - t), 0.0, 1.0]
    } else {
        // small positive (e.g. +1/6): yellow-green
        let s = -t;
        [1.0 - 0.5 * s, 0.85, 0.1 * s, 1.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_and_normals() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)];
        let s = SceneData::from_triangles(&p, &[[0, 1, 2], [1, 3, 2]]);
        assert_eq!(s.vertices.len(), 6);
        for v in &s.vertices {
            assert!((v.normal[2] - 1.0).abs() < 1e-6);
            assert!((v.face_normal[2] - 1.0).abs() < 1e-6);
        }
        assert_eq!(s.bbox.0, Vec3::ZERO);
        assert_eq!(s.bbox.1, Vec3::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn singularity_colors_match_legend() {
        assert_eq!(singularity_color(-1, 4), [0.0, 0.08, 1.0, 1.0]);
        assert_eq!(singularity_color(1, 4), [1.0, 0.85, 0.0, 1.0]);
        // all distinct for k/N with small k
        let mut seen: Vec<[f32; 4]> = Vec::new();
        for n in [2u32, 4, 6] {
            for k in -3i32..=3 {
                if k == 0 {
                    continue;
                }
                let g = gcd(k.unsigned_abs(), n);
                if g != 1 {
                    continue;
                }
                let c = singularity_color(k, n);
                assert!(!seen.contains(&c), "duplicate color for {k}/{n}");
                seen.push(c);
            }
        }
    }

    /// A hexagonal star around vertex 0 (faces 0..6, (p, a_j, a_{j+1})) and one face outside
    /// it (6), with its pole's quads.
    fn star() -> (crate::mesh::TriMesh, crate::param::Pole) {
        let mut p = vec![DVec3::ZERO];
        for j in 0..6 {
            let a = std::f64::consts::TAU * j as f64 / 6.0;
            p.push(DVec3::new(a.cos(), a.sin(), 0.0));
        }
        p.push(DVec3::new(1.2, 0.7, 0.0));
        let mut faces: Vec<[u32; 3]> = (0..6).map(|j| [0, 1 + j, 1 + (j + 1) % 6]).collect();
        faces.push([2, 1, 7]);
        let mesh = crate::mesh::TriMesh::from_triangles(p, faces).unwrap();
        let pole = crate::param::Pole {
            vertex: 0,
            index: 1.0,
            faces: (0..6).collect(),
            ring: (1..=6).collect(),
            quads: (0..6)
                .map(|j| {
                    let j = j as f64;
                    [[j, -1.0], [j + 1.0, -1.0], [j + 1.0, 0.0], [j, 0.0]]
                })
                .collect(),
        };
        (mesh, pole)
    }

    #[test]
    fn pole_stars_replace_their_faces() {
        let (mesh, pole) = star();
        let mut s = SceneData::from_trimesh(&mesh);
        let before = s.vertices.clone();
        let uvs: Vec<[f64; 2]> = (0..21).map(|i| [i as f64, 0.5]).collect();
        s.set_corner_uvs(&uvs);
        let patches = FacePatches::from_poles(&mesh, std::slice::from_ref(&pole));
        let k = FacePatches::POLE_CELLS;
        // per star face: the outer row's k + 1 fan triangles and 2 k (k − 1) cell triangles
        assert_eq!(patches.triangles.len(), 6 * (k + 1 + 2 * k * (k - 1)));
        s.set_patches(&patches);
        // the innermost cells' second triangles have two corners on the pole: left out
        let drawn = 6 * (k + 1 + 2 * k * (k - 1) - k);
        assert_eq!(s.patch_faces.len(), drawn);
        assert_eq!(s.vertices.len(), 3 * 7 + 3 * drawn);
        assert_eq!(s.n_faces(), 7);
        assert!(s.has_uv);
        for f in 0..6u32 {
            assert!(s.patch_faces.contains(&f));
        }
        assert!(!s.patch_faces.contains(&6));
        // star faces collapsed to a point in their slots; the outside face and the UVs kept
        for f in 0..7 {
            let c = &s.vertices[3 * f..3 * f + 3];
            if f < 6 {
                assert!(c.iter().all(|v| v.position == before[3 * f].position));
            } else {
                assert_eq!(c[1].position, before[3 * f + 1].position);
            }
            for (k, v) in c.iter().enumerate() {
                assert_eq!(v.uv, [(3 * f + k) as f32, 0.5]);
            }
        }
        // patch corners: on the plane, normal +z, the bilinear map's texture coordinates
        for v in &s.vertices[21..] {
            assert!(v.position[2].abs() < 1e-6);
            assert!((v.normal[2] - 1.0).abs() < 1e-5 && (v.face_normal[2] - 1.0).abs() < 1e-5);
            // v = −(1 − t) and r = (1 − t) |(1 − s) a_j + s a_{j+1}| ∈ (1 − t) [√3/2, 1]
            let r = v.position[0].hypot(v.position[1]);
            assert!(
                v.uv[1] <= -r + 1e-5 && v.uv[1] >= -r / 0.866 - 1e-5,
                "{v:?}"
            );
        }
        // the star's 6 spokes and 6 ring edges, each once, as its wireframe
        assert_eq!(s.patch_wire.len(), 12);
        // the field reaches the patch corners by their face
        let dirs: Vec<DVec3> = (0..7).map(|f| DVec3::new(1.0, f as f64, 0.0)).collect();
        s.set_face_field(&dirs, 4);
        assert!(s.has_field);
        for (t, &f) in s.patch_faces.iter().enumerate() {
            let d = f3(dirs[f as usize].normalize());
            assert!((0..3).all(|c| s.vertices[21 + 3 * t + c].field == d));
        }
        // new UVs drop the patches and give the star faces their corners back
        s.set_corner_uvs(&uvs);
        assert!(s.patch_faces.is_empty() && s.patch_wire.is_empty());
        assert_eq!(s.vertices.len(), 21);
        for (v, b) in s.vertices.iter().zip(&before) {
            assert_eq!(v.position, b.position);
            assert_eq!(v.normal, b.normal);
        }
        assert_eq!(s.vertices[4].field, f3(dirs[1].normalize()));
        s.set_patches(&patches);
        s.clear_uvs();
        assert_eq!(s.vertices.len(), 21);
        assert!(!s.has_uv);
        // no poles, no patches
        assert!(FacePatches::from_poles(&mesh, &[]).is_empty());
    }

    fn gcd(a: u32, b: u32) -> u32 {
        if b == 0 { a } else { gcd(b, a % b) }
    }
}
