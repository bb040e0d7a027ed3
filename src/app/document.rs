//! The document: the one state type through which the editor talks to the core.
//!
//! It owns the mesh with its load report, the field and the parameterization
//! (in display-ready form), overlay lines and the display settings. Every
//! change of geometry-related data bumps [`Document::revision`] and rebuilds
//! the shared [`SceneData`], which the viewport uploads once per revision.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;

use super::scene::{LineSegment, SceneData, singularity_color};
use super::settings::DisplaySettings;
use crate::mesh::{Topology, TriMesh};

/// The default mesh: Spot by Keenan Crane (CC0).
pub const DEFAULT_MESH_NAME: &str = "spot.obj";
pub const DEFAULT_MESH_OBJ: &[u8] = include_bytes!("../../assets/spot.obj");

/// A singular vertex of an N-symmetric field with index `index / N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Singularity {
    pub vertex: usize,
    /// Numerator k of the index k/N.
    pub index: i32,
}

/// A field in display form (see [`FieldDisplay::from_frame_field`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FieldDisplay {
    /// N (2, 4 or 6).
    pub symmetry: u32,
    /// One tangent direction per face (any representative of the N directions).
    pub face_dirs: Vec<DVec3>,
    pub singularities: Vec<Singularity>,
}

impl FieldDisplay {
    /// Display form of a core frame field: U of each face, singularities `(vertex, k)` with
    /// index k/N.
    pub fn from_frame_field(
        field: &crate::field::FrameField,
        singularities: impl IntoIterator<Item = (usize, i32)>,
    ) -> FieldDisplay {
        FieldDisplay {
            symmetry: field.symmetry.n(),
            face_dirs: field.frames.iter().map(|f| f[0]).collect(),
            singularities: singularities
                .into_iter()
                .map(|(vertex, index)| Singularity { vertex, index })
                .collect(),
        }
    }
}

/// A parameterization result: per-corner UVs indexed `3*f + k`.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamDisplay {
    pub corner_uvs: Vec<[f64; 2]>,
}

/// Kinds of overlay polylines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    CutGraph,
    Constraint,
    Selection,
}

impl LineKind {
    /// Linear RGBA.
    pub fn color(self) -> [f32; 4] {
        match self {
            LineKind::CutGraph => [0.9, 0.1, 0.05, 1.0],
            LineKind::Constraint => [0.05, 0.75, 0.2, 1.0],
            LineKind::Selection => [1.0, 0.55, 0.0, 1.0],
        }
    }
}

/// Mesh statistics shown in the side panel.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MeshStats {
    pub vertices: usize,
    pub edges: usize,
    pub faces: usize,
    pub components: usize,
    pub genus: i64,
    pub boundary_loops: usize,
    pub euler_characteristic: i64,
}

impl From<&Topology> for MeshStats {
    fn from(t: &Topology) -> Self {
        MeshStats {
            vertices: t.vertices,
            edges: t.edges,
            faces: t.faces,
            components: t.components.len(),
            genus: t.genus,
            boundary_loops: t.boundary_loops,
            euler_characteristic: t.euler_characteristic,
        }
    }
}

/// A freshly loaded mesh (produced by a background job).
pub struct LoadedDocument {
    pub path: Option<PathBuf>,
    pub name: String,
    pub mesh: TriMesh,
    pub warnings: Vec<String>,
    pub stats: MeshStats,
    pub scene: SceneData,
}

/// Reads, validates and prepares a mesh for display. Runs off the UI thread.
pub fn load_bytes(name: &str, bytes: &[u8]) -> Result<LoadedDocument, String> {
    let format = crate::io::Format::from_path(Path::new(name)).unwrap_or(crate::io::Format::Obj);
    let soup = crate::io::read_mesh_bytes(bytes, format).map_err(|e| format!("{name}: {e}"))?;
    finish_load(None, name.to_string(), soup)
}

/// Like [`load_bytes`], from a file.
pub fn load_path(path: &Path) -> Result<LoadedDocument, String> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string());
    let soup = crate::io::read_mesh(path).map_err(|e| match e {
        crate::io::ReadError::Io { .. } => e.to_string(),
        _ => format!("{name}: {e}"),
    })?;
    finish_load(Some(path.to_path_buf()), name, soup)
}

fn finish_load(
    path: Option<PathBuf>,
    name: String,
    soup: crate::mesh::PolygonSoup,
) -> Result<LoadedDocument, String> {
    let (mesh, report) = TriMesh::from_soup(&soup).map_err(|e| format!("{name}: {e}"))?;
    let stats = MeshStats::from(&mesh.topology());
    let scene = SceneData::from_trimesh(&mesh);
    Ok(LoadedDocument {
        path,
        name,
        mesh,
        warnings: report.warnings,
        stats,
        scene,
    })
}

/// The editor's document.
pub struct Document {
    pub path: Option<PathBuf>,
    pub name: String,
    pub mesh: Option<TriMesh>,
    pub stats: Option<MeshStats>,
    /// Validation / repair warnings of the load.
    pub warnings: Vec<String>,
    pub field: Option<FieldDisplay>,
    pub param: Option<ParamDisplay>,
    /// The core field the display form came from (input of the parameterization).
    pub frame_field: Option<crate::field::FrameField>,
    /// The core parameterization result.
    pub parameterization: Option<crate::param::Parameterization>,
    /// QuadCover's symbolic analyses for this mesh (they depend on the mesh only): every
    /// re-solve after the first, whatever the field or symmetry, does numeric work only.
    pub param_analysis: Option<Arc<crate::param::ParamAnalysis>>,
    /// One-line summaries of the field / parameterization results.
    pub field_summary: String,
    pub param_summary: String,
    pub lines: Vec<(LineKind, Vec<[DVec3; 2]>)>,
    pub display: DisplaySettings,
    scene: Option<Arc<SceneData>>,
    generation: u64,
    /// Base scene without field/param/overlays (rebuilt from the mesh once per load).
    base: Option<SceneData>,
    revision: u64,
}

impl Default for Document {
    fn default() -> Self {
        Document {
            path: None,
            name: String::new(),
            mesh: None,
            stats: None,
            warnings: Vec::new(),
            field: None,
            param: None,
            frame_field: None,
            parameterization: None,
            param_analysis: None,
            field_summary: String::new(),
            param_summary: String::new(),
            lines: Vec::new(),
            display: DisplaySettings::default(),
            scene: None,
            generation: 0,
            base: None,
            revision: 1,
        }
    }
}

impl Document {
    /// Replaces the mesh (drops field, parameterization and overlays).
    pub fn set_loaded(&mut self, loaded: LoadedDocument) {
        self.generation += 1;
        self.path = loaded.path;
        self.name = loaded.name;
        self.mesh = Some(loaded.mesh);
        self.stats = Some(loaded.stats);
        self.warnings = loaded.warnings;
        self.field = None;
        self.param = None;
        self.frame_field = None;
        self.parameterization = None;
        self.param_analysis = None;
        self.field_summary.clear();
        self.param_summary.clear();
        self.lines.clear();
        self.base = Some(loaded.scene);
        self.rebuild_scene();
    }

    /// Sets (or clears) the field; the viewport picks it up next frame.
    pub fn set_field(&mut self, field: Option<FieldDisplay>) {
        self.field = field;
        self.rebuild_scene();
    }

    /// Takes a computed core field: drops the old parameterization and cut graph.
    pub fn set_frame_field(&mut self, result: crate::field::FieldResult) {
        let sing = result.indices.singularities.iter().map(|s| (s.vertex, s.k));
        let display = FieldDisplay::from_frame_field(&result.field, sing);
        self.field_summary = format!(
            "N = {}, {} singularities, E_smooth {:.3e}",
            display.symmetry,
            display.singularities.len(),
            result.e_smooth
        );
        self.frame_field = Some(result.field);
        self.parameterization = None;
        self.param = None;
        self.param_summary.clear();
        self.lines.retain(|(k, _)| *k != LineKind::CutGraph);
        self.set_field(Some(display));
    }

    /// Takes a computed parameterization: UVs, cut graph overlay, summary.
    pub fn set_parameterization(&mut self, p: crate::param::Parameterization) {
        let mut segs = Vec::new();
        if let Some(mesh) = &self.mesh {
            for path in &p.cut_paths {
                for w in path.windows(2) {
                    if w[0] < mesh.n_vertices() && w[1] < mesh.n_vertices() {
                        segs.push([mesh.position(w[0]), mesh.position(w[1])]);
                    }
                }
            }
        }
        self.param_summary = format!(
            "{} cut paths, {} flipped faces, seam error {:.1e}, conformal distortion {:.3}",
            p.cut_paths.len(),
            p.flipped_faces,
            p.seam_max_error,
            p.conformal_distortion.mean
        );
        self.param = Some(ParamDisplay {
            corner_uvs: p.uv.clone(),
        });
        self.parameterization = Some(p);
        self.set_lines(LineKind::CutGraph, segs);
    }

    /// Sets (or clears) the parameterization.
    pub fn set_param(&mut self, param: Option<ParamDisplay>) {
        self.param = param;
        self.rebuild_scene();
    }

    /// Replaces the overlay lines of one kind.
    pub fn set_lines(&mut self, kind: LineKind, segments: Vec<[DVec3; 2]>) {
        self.lines.retain(|(k, _)| *k != kind);
        if !segments.is_empty() {
            self.lines.push((kind, segments));
        }
        self.rebuild_scene();
    }

    pub fn has_param(&self) -> bool {
        self.param.is_some()
    }

    /// Increases whenever a new mesh is loaded (jobs on an older mesh are stale).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Increases whenever the scene changes.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    pub fn scene(&self) -> Option<&Arc<SceneData>> {
        self.scene.as_ref()
    }

    fn rebuild_scene(&mut self) {
        self.revision += 1;
        let Some(base) = &self.base else {
            self.scene = None;
            return;
        };
        let mut scene = base.clone();
        if let Some(p) = &self.param {
            scene.set_corner_uvs(&p.corner_uvs);
        }
        if let Some(f) = &self.field {
            scene.set_face_field(&f.face_dirs, f.symmetry);
            if let Some(mesh) = &self.mesh {
                for s in &f.singularities {
                    if s.vertex < mesh.n_vertices() {
                        let p = mesh.position(s.vertex);
                        scene.glyphs.push(super::scene::Glyph {
                            position: [p.x as f32, p.y as f32, p.z as f32],
                            color: singularity_color(s.index, f.symmetry),
                        });
                    }
                }
            }
        }
        for (kind, segs) in &self.lines {
            let color = kind.color();
            for s in segs {
                scene.lines.push(LineSegment {
                    a: s[0].as_vec3().to_array(),
                    b: s[1].as_vec3().to_array(),
                    color,
                });
            }
        }
        self.scene = Some(Arc::new(scene));
    }
}
