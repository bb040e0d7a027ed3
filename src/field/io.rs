//! JSON import/export of frame fields.
//!
//! Format (`serde_json`, one object):
//! ```json
//! { "format": "quadcover-frame-field", "version": 1, "symmetry": 4,
//!   "num_faces": 2, "num_edges": 5,
//!   "frames": [[[ux, uy, uz], [vx, vy, vz]], ...],   // per face, 3-D vectors (U, V)
//!   "matchings": [0, 3, ...] }                         // per edge, in 0..N (0 on boundary edges)
//! ```
//! Frames are written as JSON numbers in the shortest decimal form that reads back to the same
//! f64. Exactness on import: serde_json parses decimals approximately unless its
//! `float_roundtrip` feature is on (it is, in Cargo.toml, for every module). As a guard against
//! that feature being dropped, the numbers of the `frames` array are also re-read from the text
//! with Rust's correctly rounded `str::parse`; tests/field.rs checks export → import is bit-exact. Unknown and duplicate keys are rejected, so the
//! `"frames"` key occurs exactly once in a valid file.

use serde::{Deserialize, Serialize};

use super::{FieldError, FrameField, Symmetry};
use crate::mesh::TriMesh;

pub const FORMAT_NAME: &str = "quadcover-frame-field";
pub const FORMAT_VERSION: u32 = 1;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FieldFile {
    format: String,
    version: u32,
    symmetry: u32,
    num_faces: usize,
    num_edges: usize,
    frames: Vec<[[f64; 3]; 2]>,
    matchings: Vec<i32>,
}

/// Serialises a field (no mesh needed; counts are taken from the field).
pub fn to_json(field: &FrameField) -> Result<String, FieldError> {
    if let Some(f) = field
        .frames
        .iter()
        .position(|fr| !fr[0].is_finite() || !fr[1].is_finite())
    {
        return Err(FieldError::Format(format!(
            "frame of face {f} is not finite"
        )));
    }
    let file = FieldFile {
        format: FORMAT_NAME.into(),
        version: FORMAT_VERSION,
        symmetry: field.symmetry.n(),
        num_faces: field.frames.len(),
        num_edges: field.matchings.len(),
        frames: field
            .frames
            .iter()
            .map(|[u, v]| [u.to_array(), v.to_array()])
            .collect(),
        matchings: field.matchings.clone(),
    };
    serde_json::to_string(&file).map_err(|e| FieldError::Format(e.to_string()))
}

/// Parses a field and validates it against `mesh`: counts, symmetry, matching range, finite
/// frames, and 0 on boundary edges.
pub fn from_json(text: &str, mesh: &TriMesh) -> Result<FrameField, FieldError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let file: FieldFile =
        serde_json::from_str(text).map_err(|e| FieldError::Format(e.to_string()))?;
    if file.format != FORMAT_NAME {
        return Err(FieldError::Format(format!(
            "\"format\" is \"{}\", expected \"{FORMAT_NAME}\"",
            file.format
        )));
    }
    if file.version != FORMAT_VERSION {
        return Err(FieldError::Format(format!(
            "unsupported version {} (this build reads version {FORMAT_VERSION})",
            file.version
        )));
    }
    let symmetry = Symmetry::from_n(file.symmetry)?;
    let mut file = file;
    exact_frames(text, &mut file.frames)?;
    if file.num_faces != mesh.n_faces() || file.num_edges != mesh.n_edges() {
        return Err(FieldError::MeshMismatch(format!(
            "field is for a mesh with {} faces and {} edges, this mesh has {} faces and {} edges",
            file.num_faces,
            file.num_edges,
            mesh.n_faces(),
            mesh.n_edges()
        )));
    }
    if file.frames.len() != file.num_faces || file.matchings.len() != file.num_edges {
        return Err(FieldError::Format(format!(
            "{} frames and {} matchings listed, header says {} faces and {} edges",
            file.frames.len(),
            file.matchings.len(),
            file.num_faces,
            file.num_edges
        )));
    }
    let field = FrameField {
        symmetry,
        frames: file
            .frames
            .iter()
            .map(|[u, v]| [glam::DVec3::from_array(*u), glam::DVec3::from_array(*v)])
            .collect(),
        matchings: file.matchings,
    };
    field.validate(mesh)?;
    Ok(field)
}

/// Re-reads the numbers of the `"frames"` array with a correctly rounded parser (see module docs).
fn exact_frames(text: &str, frames: &mut [[[f64; 3]; 2]]) -> Result<(), FieldError> {
    let err = || {
        FieldError::Format(
            "the \"frames\" array must be written literally (no escapes in its key)".into(),
        )
    };
    let start = text.find("\"frames\"").ok_or_else(err)? + "\"frames\"".len();
    let bytes = text.as_bytes();
    let mut i = start;
    let mut depth = 0usize;
    let mut values = Vec::with_capacity(6 * frames.len());
    while i < bytes.len() {
        match bytes[i] {
            b'[' => depth += 1,
            b']' => {
                depth = depth.checked_sub(1).ok_or_else(err)?;
                if depth == 0 {
                    break;
                }
            }
            b'-' | b'0'..=b'9' if depth > 0 => {
                let end = text[i..]
                    .find(|c: char| !matches!(c, '0'..='9' | '-' | '+' | '.' | 'e' | 'E'))
                    .map_or(text.len(), |k| i + k);
                values.push(text[i..end].parse::<f64>().map_err(|_| err())?);
                i = end;
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    if values.len() != 6 * frames.len() {
        return Err(err());
    }
    for (fr, v) in frames.iter_mut().zip(values.chunks_exact(6)) {
        *fr = [[v[0], v[1], v[2]], [v[3], v[4], v[5]]];
    }
    Ok(())
}
