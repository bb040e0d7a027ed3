//! The project file: the mesh reference, the solve settings and the ordered edit list (JSON).
//!
//! ```json
//! { "format": "quadcover-project", "version": 1,
//!   "mesh": { "path": "bunny.obj", "sha256": "…" },
//!   "settings": { "symmetry": 4, "target_vertices": 6500, "tau": 1.0 },
//!   "edits": [ { "op": "move_singularity", "from": 812, "to": 1034 }, { "op": "relax" } ] }
//! ```
//! The mesh path is relative to the project file. Settings carry the `solve` options' names
//! with underscores; absent ones take the defaults, unknown ones are an error. `sha256` (of the
//! mesh file's bytes) is written on save and checked on load when present. Edits are numbered
//! from 1 in messages ("edit 3: …").

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use thiserror::Error;

use super::Edit;
use crate::field::{Density, FieldParams, Symmetry};
use crate::param::{ParamOptions, Rounding};

pub const FORMAT: &str = "quadcover-project";
pub const VERSION: u64 = 1;

/// The solve options of a project (the CLI's `solve` flags, underscores for dashes).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Settings {
    pub symmetry: u32,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target_vertices: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    pub tau: f64,
    pub reliable_fraction: f64,
    pub curvature_smoothing: usize,
    pub cancel_pairs_within: f64,
    /// N = 4: round gaps to 2Z² so that singularities land on grid points and the remesh has
    /// one irregular vertex per singularity (default on; ignored for N = 2 and 6).
    pub pure_quad: bool,
    pub rounding: RoundingSetting,
    /// Refuse merges that would create a singularity of index ±2/4 (a hanging node; N = 4).
    pub no_half_merges: bool,
    /// Refuse merges that would create a pole (positive integral index, e.g. +4/4 or +2/2;
    /// default off: alg. 6 treats poles, sec. 4.3).
    pub no_pole_merges: bool,
    /// `relax` merges singularities closer than this many grid cells.
    pub relax_merge_within: f64,
    /// Keep the folds of the global step (no injectivity repair).
    pub no_untangle: bool,
    /// Renormalize the field's relaxed solve (`FieldParams::renormalize`).
    pub renormalize_field: bool,
    /// Make thin parts finer so that the grid goes around them with enough cells
    /// (`FieldParams::refine_thin`; default on).
    pub refine_thin_parts: bool,
    /// When a map keeps folds or mis-wound vertices (under curves: folds), solve again on a grid
    /// made finer around crowded singularities and keep the better (`param::crowded`; default on).
    pub refine_crowded: bool,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RoundingSetting {
    #[default]
    Direct,
    Greedy,
}

impl Default for Settings {
    fn default() -> Settings {
        let f = FieldParams::default();
        Settings {
            symmetry: 4,
            target_vertices: None,
            scale: None,
            tau: f.tau,
            reliable_fraction: f.reliable_fraction,
            curvature_smoothing: f.curvature_smoothing,
            cancel_pairs_within: f.cancel_pairs_within,
            pure_quad: true,
            rounding: RoundingSetting::Direct,
            no_half_merges: false,
            no_pole_merges: false,
            relax_merge_within: 1.0,
            no_untangle: false,
            renormalize_field: false,
            refine_thin_parts: true,
            refine_crowded: true,
        }
    }
}

/// The most neighbour-averaging passes over the shape operators a setting may ask for.
pub const MAX_CURVATURE_SMOOTHING: usize = 1000;

impl Settings {
    /// Checks ranges; the message names the setting.
    pub fn validate(&self) -> Result<(), String> {
        Symmetry::from_n(self.symmetry).map_err(|e| format!("symmetry: {e}"))?;
        let checks = [
            ("tau", self.tau, self.tau >= 0.0),
            (
                "reliable_fraction",
                self.reliable_fraction,
                (0.0..=1.0).contains(&self.reliable_fraction),
            ),
            (
                "cancel_pairs_within",
                self.cancel_pairs_within,
                self.cancel_pairs_within >= 0.0,
            ),
            (
                "relax_merge_within",
                self.relax_merge_within,
                self.relax_merge_within >= 0.0,
            ),
        ];
        for (name, v, ok) in checks {
            if !ok || !v.is_finite() {
                return Err(format!("{name} = {v} is out of range"));
            }
        }
        if let Some(s) = self.scale
            && !(s.is_finite() && s > 0.0)
        {
            return Err(format!("scale must be positive, got {s}"));
        }
        if self.target_vertices == Some(0) {
            return Err("target_vertices must be positive".into());
        }
        // Each pass is a sweep over the mesh: a million of them ran for minutes, and past a few
        // hundred the shape operators are averaged over the whole of most meshes anyway.
        if self.curvature_smoothing > MAX_CURVATURE_SMOOTHING {
            return Err(format!(
                "curvature_smoothing = {} is out of range (at most {MAX_CURVATURE_SMOOTHING} passes)",
                self.curvature_smoothing
            ));
        }
        if self.scale.is_some() && self.target_vertices.is_some() {
            return Err("give target_vertices or scale, not both".into());
        }
        Ok(())
    }

    pub fn symmetry(&self) -> Symmetry {
        Symmetry::from_n(self.symmetry).unwrap_or(Symmetry::Four)
    }

    /// The field's parameters.
    pub fn field_params(&self) -> FieldParams {
        let mut p = FieldParams {
            symmetry: self.symmetry(),
            tau: self.tau,
            reliable_fraction: self.reliable_fraction,
            curvature_smoothing: self.curvature_smoothing,
            cancel_pairs_within: self.cancel_pairs_within,
            renormalize: self.renormalize_field,
            refine_thin: self.refine_thin_parts,
            ..Default::default()
        };
        match (self.scale, self.target_vertices) {
            (Some(s), _) => p.density = Density::EdgeLength(s),
            (None, Some(v)) => p.density = Density::TargetVertices(v),
            _ => {}
        }
        p
    }

    /// QuadCover's options.
    pub fn param_options(&self) -> ParamOptions {
        ParamOptions {
            rounding: match self.rounding {
                RoundingSetting::Direct => Rounding::Direct,
                RoundingSetting::Greedy => Rounding::Greedy,
            },
            pure_quad: self.pure_quad && self.symmetry == 4,
            no_untangle: self.no_untangle,
            no_poles: false,
            no_crowded_refinement: !self.refine_crowded,
        }
    }
}

/// The mesh a project refers to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshRef {
    /// Relative to the project file (absolute paths are kept as they are).
    pub path: PathBuf,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sha256: Option<String>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Project {
    pub mesh: MeshRef,
    pub settings: Settings,
    pub edits: Vec<Edit>,
}

#[derive(Debug, Error)]
pub enum ProjectError {
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("{path}: line {line}, column {column}: {message}")]
    Syntax {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    #[error("{path}: edit {position}: {message}")]
    Edit {
        path: PathBuf,
        /// 1-based position in the edit list.
        position: usize,
        message: String,
    },
    #[error(
        "{path}: the mesh {mesh} has changed since the project was saved (sha256 {found}, the project expects {expected})"
    )]
    MeshChanged {
        path: PathBuf,
        mesh: PathBuf,
        expected: String,
        found: String,
    },
}

/// Lower-case hex SHA-256 of bytes.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[derive(Serialize)]
struct ProjectOut<'a> {
    format: &'a str,
    version: u64,
    mesh: &'a MeshRef,
    settings: &'a Settings,
    edits: &'a [Edit],
}

impl Project {
    pub fn new(mesh: MeshRef, settings: Settings) -> Project {
        Project {
            mesh,
            settings,
            edits: Vec::new(),
        }
    }

    /// The mesh file's path, resolved against the project file's folder.
    pub fn mesh_path(&self, project_path: &Path) -> PathBuf {
        if self.mesh.path.is_absolute() {
            return self.mesh.path.clone();
        }
        project_path
            .parent()
            .unwrap_or(Path::new(""))
            .join(&self.mesh.path)
    }

    /// Parses a project (`path` only names the file in messages).
    pub fn from_json(text: &str, path: &Path) -> Result<Project, ProjectError> {
        let format = |message: String| ProjectError::Format {
            path: path.to_path_buf(),
            message,
        };
        // A byte order mark (left by some editors on Windows) is no JSON.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| ProjectError::Syntax {
                path: path.to_path_buf(),
                line: e.line(),
                column: e.column(),
                message: match e.classify() {
                    serde_json::error::Category::Eof => "the file ends early (truncated?)".into(),
                    _ => e.to_string(),
                },
            })?;
        let serde_json::Value::Object(mut obj) = value else {
            return Err(format("not a JSON object".into()));
        };
        match obj.get("format").and_then(|f| f.as_str()) {
            Some(FORMAT) => {}
            Some(other) => return Err(format(format!("format is \"{other}\", not \"{FORMAT}\""))),
            None => return Err(format(format!("no \"format\": \"{FORMAT}\""))),
        }
        match obj.get("version").and_then(|v| v.as_u64()) {
            Some(VERSION) => {}
            Some(v) => {
                return Err(format(format!(
                    "version {v} is not supported (this quadcover reads version {VERSION})"
                )));
            }
            None => return Err(format("no \"version\" number".into())),
        }
        for key in obj.keys() {
            if !["format", "version", "mesh", "settings", "edits"].contains(&key.as_str()) {
                return Err(format(format!("unknown field \"{key}\"")));
            }
        }
        let mesh: MeshRef = serde_json::from_value(
            obj.remove("mesh")
                .ok_or_else(|| format("no \"mesh\": {\"path\": ...}".into()))?,
        )
        .map_err(|e| format(format!("mesh: {e}")))?;
        let settings: Settings = match obj.remove("settings") {
            Some(s) => serde_json::from_value(s).map_err(|e| format(format!("settings: {e}")))?,
            None => Settings::default(),
        };
        settings
            .validate()
            .map_err(|e| format(format!("settings: {e}")))?;
        let edits = match obj.remove("edits") {
            None => Vec::new(),
            Some(serde_json::Value::Array(list)) => list
                .into_iter()
                .enumerate()
                .map(|(i, v)| {
                    serde_json::from_value::<Edit>(v).map_err(|e| ProjectError::Edit {
                        path: path.to_path_buf(),
                        position: i + 1,
                        message: e.to_string(),
                    })
                })
                .collect::<Result<_, _>>()?,
            Some(_) => return Err(format("\"edits\" is not a list".into())),
        };
        Ok(Project {
            mesh,
            settings,
            edits,
        })
    }

    pub fn to_json(&self) -> String {
        let out = ProjectOut {
            format: FORMAT,
            version: VERSION,
            mesh: &self.mesh,
            settings: &self.settings,
            edits: &self.edits,
        };
        // Serialising plain data cannot fail.
        serde_json::to_string_pretty(&out).unwrap_or_default()
    }

    /// Reads and parses a project file.
    pub fn load(path: &Path) -> Result<Project, ProjectError> {
        let text = std::fs::read_to_string(path).map_err(|e| ProjectError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Project::from_json(&text, path)
    }

    /// Checks the mesh file's bytes against the recorded hash (when there is one).
    pub fn check_mesh(&self, project_path: &Path, mesh_bytes: &[u8]) -> Result<(), ProjectError> {
        let Some(expected) = &self.mesh.sha256 else {
            return Ok(());
        };
        let found = sha256_hex(mesh_bytes);
        if !found.eq_ignore_ascii_case(expected) {
            return Err(ProjectError::MeshChanged {
                path: project_path.to_path_buf(),
                mesh: self.mesh_path(project_path),
                expected: expected.clone(),
                found,
            });
        }
        Ok(())
    }

    /// Checks that every vertex an edit names exists in a file of `file_vertices` vertices.
    pub fn check_vertices(
        &self,
        project_path: &Path,
        file_vertices: usize,
    ) -> Result<(), ProjectError> {
        for (i, e) in self.edits.iter().enumerate() {
            if let Edit::AddCurve { id, vertices, .. } = e
                && let Some((at, v)) = vertices
                    .iter()
                    .enumerate()
                    .find(|(_, v)| **v >= file_vertices)
            {
                return Err(ProjectError::Edit {
                    path: project_path.to_path_buf(),
                    position: i + 1,
                    message: format!(
                        "curve {id}: vertex {v} at position {at} is out of range (the mesh has {file_vertices} vertices)"
                    ),
                });
            }
            if let Edit::MoveSingularity { from, to } = e {
                for (name, v) in [("from", from), ("to", to)] {
                    if *v >= file_vertices {
                        return Err(ProjectError::Edit {
                            path: project_path.to_path_buf(),
                            position: i + 1,
                            message: format!(
                                "{name} = {v} is out of range (the mesh has {file_vertices} vertices)"
                            ),
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// Writes the project atomically. `mesh.path` is written relative to the project's folder
    /// when the mesh lies below it.
    pub fn save(&self, path: &Path) -> Result<(), ProjectError> {
        let json = self.to_json();
        crate::io::write_atomic(path, |w| w.write_all(json.as_bytes())).map_err(|e| {
            ProjectError::Io {
                path: path.to_path_buf(),
                message: e.to_string(),
            }
        })
    }
}

/// `mesh` expressed relative to the folder of `project` when possible (both made absolute
/// first); otherwise absolute.
pub fn relative_mesh_path(project: &Path, mesh: &Path) -> PathBuf {
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let (project, mesh) = (abs(project), abs(mesh));
    let dir = project.parent().unwrap_or(Path::new("/"));
    let (a, b): (Vec<_>, Vec<_>) = (dir.components().collect(), mesh.components().collect());
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return mesh;
    }
    let mut out = PathBuf::new();
    for _ in common..a.len() {
        out.push("..");
    }
    for c in &b[common..] {
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_errors_name_the_place() {
        let mut p = Project::new(
            MeshRef {
                path: "m.obj".into(),
                sha256: Some(sha256_hex(b"abc")),
            },
            Settings {
                target_vertices: Some(6500),
                no_pole_merges: true,
                ..Settings::default()
            },
        );
        p.edits = vec![Edit::MoveSingularity { from: 3, to: 9 }, Edit::Relax];
        let json = p.to_json();
        assert!(json.contains("\"no_pole_merges\": true"), "{json}");
        let back = Project::from_json(&json, Path::new("p.json")).unwrap();
        assert_eq!(back, p);
        let marked = format!("\u{feff}{json}");
        assert_eq!(Project::from_json(&marked, Path::new("p.json")).unwrap(), p);
        // Absent settings take the defaults (poles allowed).
        let old = json.replace("\"no_pole_merges\": true,", "");
        let back = Project::from_json(&old, Path::new("p.json")).unwrap();
        assert!(!back.settings.no_pole_merges && back.settings.target_vertices == Some(6500));
        // sha256 of "abc" (FIPS 180-2 example).
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let err = |text: &str| {
            Project::from_json(text, Path::new("p.json"))
                .unwrap_err()
                .to_string()
        };
        assert!(err(&json[..json.len() / 2]).contains("truncated"));
        let bad_op = json.replace("\"relax\"", "\"explode\"");
        let e = err(&bad_op);
        assert!(e.contains("edit 2") && e.contains("explode"), "{e}");
        let e = err(&json.replace("\"from\": 3", "\"from\": -3"));
        assert!(
            e.contains("edit 1") && e.contains("-3 is not a vertex number"),
            "{e}"
        );
        // A curve's bad vertex: its position named.
        let mut c = p.clone();
        c.edits = vec![Edit::AddCurve {
            id: 4,
            vertices: vec![1, 2, 3],
            closed: false,
            kind: crate::edit::CurveKind::Geometric,
        }];
        let curve = c.to_json();
        for bad in ["-2", "2.5", "\"2\""] {
            let text = curve.replacen("2,", &format!("{bad},"), 1);
            assert_ne!(text, curve);
            let e = err(&text);
            assert!(
                e.contains("edit 1") && e.contains(&format!("{bad} at position 1")),
                "{e}"
            );
        }
        let mut slow = p.clone();
        slow.settings.curvature_smoothing = 1_000_000;
        let e = err(&slow.to_json());
        assert!(e.contains("curvature_smoothing"), "{e}");
        let e = err(&json.replace("\"tau\"", "\"tua\""));
        assert!(e.contains("settings") && e.contains("tua"), "{e}");
        let e = err(&json.replace("quadcover-project", "something"));
        assert!(e.contains("format"), "{e}");
        let e = p
            .check_vertices(Path::new("p.json"), 5)
            .unwrap_err()
            .to_string();
        assert!(e.contains("edit 1") && e.contains("to = 9"), "{e}");
        assert!(p.check_mesh(Path::new("p.json"), b"abc").is_ok());
        let e = p
            .check_mesh(Path::new("p.json"), b"abd")
            .unwrap_err()
            .to_string();
        assert!(e.contains("changed"), "{e}");
    }

    #[test]
    fn mesh_paths_are_relative_to_the_project() {
        assert_eq!(
            relative_mesh_path(Path::new("/a/b/p.json"), Path::new("/a/m/x.obj")),
            PathBuf::from("../m/x.obj")
        );
        let p = Project::new(
            MeshRef {
                path: "../m/x.obj".into(),
                sha256: None,
            },
            Settings::default(),
        );
        assert_eq!(
            p.mesh_path(Path::new("/a/b/p.json")),
            PathBuf::from("/a/b/../m/x.obj")
        );
    }
}
