//! OBJ and PLY writers, from plain slices (no dependency on `TriMesh`).
//!
//! Choices:
//! - Saves are atomic: [`write_atomic`] writes a temporary file in the target's directory, syncs
//!   it and renames it over the target; on failure the target is untouched and the temporary file
//!   removed.
//! - Coordinates are never rescaled and are printed with Rust's shortest round-trip formatting
//!   (`{}`, or `{:e}` for very large / small magnitudes to keep lines short), so reading the file
//!   back gives the same `f64` bits. Binary PLY stores `double`s.
//! - OBJ per-corner UVs: a `vt` record is shared by the corners of one vertex whose UVs are
//!   bitwise equal, so a map that is continuous across a vertex stays continuous in the file
//!   (corners with different UVs, i.e. along seams, get their own `vt`).
//! - Inputs are validated first (indices in range, finite values, UV count = corner count,
//!   polygons with at least 3 vertices, polylines with at least 2) so no invalid file is written.

use std::collections::HashMap;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;

use super::WriteError;

/// Faces given to a writer: triangles or general polygons.
#[derive(Clone, Copy, Debug)]
pub enum Faces<'a> {
    Triangles(&'a [[u32; 3]]),
    Polygons(&'a [Vec<u32>]),
}

impl<'a> From<&'a [[u32; 3]]> for Faces<'a> {
    fn from(t: &'a [[u32; 3]]) -> Self {
        Faces::Triangles(t)
    }
}

impl<'a> From<&'a [Vec<u32>]> for Faces<'a> {
    fn from(p: &'a [Vec<u32>]) -> Self {
        Faces::Polygons(p)
    }
}

impl<'a> From<&'a Vec<[u32; 3]>> for Faces<'a> {
    fn from(t: &'a Vec<[u32; 3]>) -> Self {
        Faces::Triangles(t)
    }
}

impl<'a> From<&'a Vec<Vec<u32>>> for Faces<'a> {
    fn from(p: &'a Vec<Vec<u32>>) -> Self {
        Faces::Polygons(p)
    }
}

impl Faces<'_> {
    pub fn len(&self) -> usize {
        match self {
            Faces::Triangles(t) => t.len(),
            Faces::Polygons(p) => p.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Vertex indices of face `f`.
    pub fn face(&self, f: usize) -> &[u32] {
        match self {
            Faces::Triangles(t) => &t[f],
            Faces::Polygons(p) => &p[f],
        }
    }

    /// Total number of face corners.
    pub fn corner_count(&self) -> usize {
        match self {
            Faces::Triangles(t) => 3 * t.len(),
            Faces::Polygons(p) => p.iter().map(Vec::len).sum(),
        }
    }
}

/// What to write to an OBJ file.
#[derive(Clone, Copy, Debug)]
pub struct ObjOutput<'a> {
    pub positions: &'a [DVec3],
    pub faces: Faces<'a>,
    /// One UV per face corner, in face order (`3 * f + k` for triangles).
    pub corner_uvs: Option<&'a [[f64; 2]]>,
    /// `l` records (0-based vertex indices), e.g. stripes.
    pub polylines: &'a [Vec<u32>],
}

impl<'a> ObjOutput<'a> {
    pub fn new(positions: &'a [DVec3], faces: impl Into<Faces<'a>>) -> Self {
        ObjOutput {
            positions,
            faces: faces.into(),
            corner_uvs: None,
            polylines: &[],
        }
    }

    pub fn with_uvs(mut self, corner_uvs: &'a [[f64; 2]]) -> Self {
        self.corner_uvs = Some(corner_uvs);
        self
    }

    pub fn with_polylines(mut self, polylines: &'a [Vec<u32>]) -> Self {
        self.polylines = polylines;
        self
    }
}

/// PLY encodings the writer produces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PlyEncoding {
    Ascii,
    #[default]
    BinaryLittleEndian,
}

fn invalid(msg: String) -> WriteError {
    WriteError::Invalid(msg)
}

fn check_positions(positions: &[DVec3]) -> Result<(), WriteError> {
    match positions.iter().position(|p| !p.is_finite()) {
        Some(v) => Err(invalid(format!("vertex {v} has a non-finite coordinate"))),
        None => Ok(()),
    }
}

fn check_faces(faces: &Faces, vertex_count: usize) -> Result<(), WriteError> {
    for f in 0..faces.len() {
        let face = faces.face(f);
        if face.len() < 3 {
            return Err(invalid(format!("face {f} has {} vertices", face.len())));
        }
        if let Some(&i) = face.iter().find(|&&i| i as usize >= vertex_count) {
            return Err(invalid(format!(
                "face {f} refers to vertex {i}, but there are {vertex_count} vertices"
            )));
        }
    }
    Ok(())
}

/// Write `x` so that it parses back to the same bits, in a short form.
fn num(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-5..1e16).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Write an OBJ file atomically.
pub fn write_obj(path: &Path, out: &ObjOutput) -> Result<(), WriteError> {
    validate_obj(out)?;
    write_atomic(path, |w| write_obj_unchecked(w, out))
}

/// Write OBJ text to any writer (e.g. a `Vec<u8>`).
pub fn write_obj_to<W: Write>(w: &mut W, out: &ObjOutput) -> Result<(), WriteError> {
    validate_obj(out)?;
    write_obj_unchecked(w, out).map_err(|source| WriteError::Io {
        path: PathBuf::from("<stream>"),
        source,
    })
}

fn validate_obj(out: &ObjOutput) -> Result<(), WriteError> {
    let nv = out.positions.len();
    check_positions(out.positions)?;
    check_faces(&out.faces, nv)?;
    if let Some(uvs) = out.corner_uvs {
        let corners = out.faces.corner_count();
        if uvs.len() != corners {
            return Err(invalid(format!(
                "{} corner UVs given for {corners} face corners",
                uvs.len()
            )));
        }
        if let Some(c) = uvs
            .iter()
            .position(|uv| !uv[0].is_finite() || !uv[1].is_finite())
        {
            return Err(invalid(format!("corner {c} has a non-finite UV")));
        }
    }
    for (l, pl) in out.polylines.iter().enumerate() {
        if pl.len() < 2 {
            return Err(invalid(format!("polyline {l} has {} vertices", pl.len())));
        }
        if let Some(&i) = pl.iter().find(|&&i| i as usize >= nv) {
            return Err(invalid(format!(
                "polyline {l} refers to vertex {i}, but there are {nv} vertices"
            )));
        }
    }
    Ok(())
}

fn write_obj_unchecked<W: Write>(w: &mut W, out: &ObjOutput) -> io::Result<()> {
    writeln!(w, "# written by quadcover")?;
    for p in out.positions {
        writeln!(w, "v {} {} {}", num(p.x), num(p.y), num(p.z))?;
    }
    // Per corner, the 1-based vt index, sharing one vt per (vertex, UV bits).
    let mut corner_vt: Vec<usize> = Vec::new();
    if let Some(uvs) = out.corner_uvs {
        let mut ids: HashMap<(u32, u64, u64), usize> = HashMap::new();
        let mut c = 0;
        for f in 0..out.faces.len() {
            for &v in out.faces.face(f) {
                let uv = uvs[c];
                let key = (v, uv[0].to_bits(), uv[1].to_bits());
                let next = ids.len() + 1;
                let id = *ids.entry(key).or_insert_with(|| next);
                if id == next {
                    writeln!(w, "vt {} {}", num(uv[0]), num(uv[1]))?;
                }
                corner_vt.push(id);
                c += 1;
            }
        }
    }
    let mut c = 0;
    for f in 0..out.faces.len() {
        w.write_all(b"f")?;
        for &v in out.faces.face(f) {
            if corner_vt.is_empty() {
                write!(w, " {}", v as u64 + 1)?;
            } else {
                write!(w, " {}/{}", v as u64 + 1, corner_vt[c])?;
            }
            c += 1;
        }
        w.write_all(b"\n")?;
    }
    for pl in out.polylines {
        w.write_all(b"l")?;
        for &v in pl {
            write!(w, " {}", v as u64 + 1)?;
        }
        w.write_all(b"\n")?;
    }
    Ok(())
}

/// Write a PLY file atomically: `double` x, y, z and an `int` `vertex_indices` list (count type
/// `uchar`, or `int` if a polygon has more than 255 vertices).
pub fn write_ply(
    path: &Path,
    positions: &[DVec3],
    faces: Faces,
    encoding: PlyEncoding,
) -> Result<(), WriteError> {
    validate_ply(positions, &faces)?;
    write_atomic(path, |w| {
        write_ply_unchecked(w, positions, &faces, encoding)
    })
}

/// Write PLY to any writer (e.g. a `Vec<u8>`).
pub fn write_ply_to<W: Write>(
    w: &mut W,
    positions: &[DVec3],
    faces: Faces,
    encoding: PlyEncoding,
) -> Result<(), WriteError> {
    validate_ply(positions, &faces)?;
    write_ply_unchecked(w, positions, &faces, encoding).map_err(|source| WriteError::Io {
        path: PathBuf::from("<stream>"),
        source,
    })
}

fn validate_ply(positions: &[DVec3], faces: &Faces) -> Result<(), WriteError> {
    check_positions(positions)?;
    check_faces(faces, positions.len())?;
    if positions.len() > i32::MAX as usize {
        return Err(invalid("too many vertices for int indices".to_string()));
    }
    Ok(())
}

fn write_ply_unchecked<W: Write>(
    w: &mut W,
    positions: &[DVec3],
    faces: &Faces,
    encoding: PlyEncoding,
) -> io::Result<()> {
    let wide = (0..faces.len()).any(|f| faces.face(f).len() > 255);
    let count_type = if wide { "int" } else { "uchar" };
    let enc = match encoding {
        PlyEncoding::Ascii => "ascii",
        PlyEncoding::BinaryLittleEndian => "binary_little_endian",
    };
    write!(
        w,
        "ply\nformat {enc} 1.0\ncomment written by quadcover\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
         element face {}\nproperty list {count_type} int vertex_indices\nend_header\n",
        positions.len(),
        faces.len()
    )?;
    match encoding {
        PlyEncoding::Ascii => {
            for p in positions {
                writeln!(w, "{} {} {}", num(p.x), num(p.y), num(p.z))?;
            }
            for f in 0..faces.len() {
                let face = faces.face(f);
                write!(w, "{}", face.len())?;
                for &v in face {
                    write!(w, " {v}")?;
                }
                w.write_all(b"\n")?;
            }
        }
        PlyEncoding::BinaryLittleEndian => {
            for p in positions {
                for x in p.to_array() {
                    w.write_all(&x.to_le_bytes())?;
                }
            }
            for f in 0..faces.len() {
                let face = faces.face(f);
                if wide {
                    w.write_all(&(face.len() as i32).to_le_bytes())?;
                } else {
                    w.write_all(&[face.len() as u8])?;
                }
                for &v in face {
                    w.write_all(&(v as i32).to_le_bytes())?;
                }
            }
        }
    }
    Ok(())
}

/// Write a file atomically: `fill` writes to a temporary file next to `path`, which is then
/// flushed, synced and renamed over `path`. Usable for any file the application saves.
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> Result<(), WriteError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let io_err = |source| WriteError::Io {
        path: path.to_path_buf(),
        source,
    };
    let name = path
        .file_name()
        .ok_or_else(|| io_err(io::Error::new(io::ErrorKind::InvalidInput, "no file name")))?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let tmp = dir.join(format!(
        ".{}.{}-{}.tmp",
        name.to_string_lossy(),
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let file = File::options().write(true).create_new(true).open(&tmp)?;
        let mut w = BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io_err)
}
