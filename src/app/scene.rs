//! CPU-side, GPU-ready scene data: per-corner vertices, overlay line segments and
//! singularity glyphs. Built from plain arrays so it does not depend on any core
//! type; [`SceneData::from_trimesh`] adapts the core mesh.

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
        }
    }

    /// Adapts the core mesh.
    pub fn from_trimesh(mesh: &crate::mesh::TriMesh) -> SceneData {
        SceneData::from_triangles(mesh.positions(), mesh.faces())
    }

    pub fn n_faces(&self) -> usize {
        self.vertices.len() / 3
    }

    /// Per-corner UVs indexed `3*f + k` (the parameterization result layout).
    pub fn set_corner_uvs(&mut self, uvs: &[[f64; 2]]) {
        for (v, uv) in self.vertices.iter_mut().zip(uvs) {
            v.uv = [uv[0] as f32, uv[1] as f32];
        }
        self.has_uv = uvs.len() == self.vertices.len();
    }

    /// Removes the parameterization.
    pub fn clear_uvs(&mut self) {
        for v in &mut self.vertices {
            v.uv = [0.0, 0.0];
        }
        self.has_uv = false;
    }

    /// Per-face field direction (any tangent vector of the N-symmetric field,
    /// e.g. `FrameField::frames[f][0]`), normalized here.
    pub fn set_face_field(&mut self, dirs: &[DVec3], symmetry: u32) {
        for (f, d) in dirs.iter().enumerate().take(self.n_faces()) {
            let d = f3(d.normalize_or_zero());
            for k in 0..3 {
                self.vertices[3 * f + k].field = d;
            }
        }
        self.has_field = dirs.len() == self.n_faces();
        self.symmetry = symmetry.max(1);
    }

    /// Removes the field.
    pub fn clear_field(&mut self) {
        for v in &mut self.vertices {
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

    fn gcd(a: u32, b: u32) -> u32 {
        if b == 0 { a } else { gcd(b, a % b) }
    }
}
