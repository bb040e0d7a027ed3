//! Mesh file input/output: OBJ, PLY, OFF and STL readers producing a [`PolygonSoup`], and
//! atomic OBJ / PLY writers.
//!
//! Choices:
//! - The whole file is read into memory, then parsed by a hand-written reader per format (see each
//!   submodule for why). Readers never panic on any byte input: every slice access is checked and
//!   counts announced by headers are only used to preallocate up to a bound given by the file size.
//! - Polygons are fan-triangulated (`v_a v_{a+i} v_{a+i+1}`): apex a = 0 unless a diagonal from
//!   there was already used or is an edge of the file (OBJ knows all its edges up front; the
//!   streaming readers the edges of polygons read so far), see `SoupBuilder`; `source_polygon`
//!   maps triangles back.
//! - Readers check index ranges, polygon sizes and finiteness of coordinates; topology (manifold,
//!   orientation, degenerate or duplicate faces) is checked later by `TriMesh::from_soup`.
//! - [`read_mesh`] dispatches on the extension (case-insensitive) and falls back to sniffing the
//!   content when the extension is missing or unknown.

mod error;
pub mod obj;
pub mod off;
pub mod ply;
pub mod stl;
pub mod write;

use std::borrow::Cow;
use std::fmt;
use std::path::Path;

use glam::DVec3;

pub use crate::mesh::PolygonSoup;
pub use error::{ReadError, WriteError};
pub use obj::{ObjData, read_obj_bytes};
pub use write::{
    Faces, ObjOutput, PlyEncoding, write_atomic, write_obj, write_obj_to, write_ply, write_ply_to,
};

/// The mesh file formats understood by [`read_mesh`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    Obj,
    Ply,
    Off,
    Stl,
}

impl Format {
    pub const ALL: [Format; 4] = [Format::Obj, Format::Ply, Format::Off, Format::Stl];

    /// The format named by a file extension (case-insensitive, without the dot).
    pub fn from_extension(ext: &str) -> Option<Format> {
        match ext.to_ascii_lowercase().as_str() {
            "obj" => Some(Format::Obj),
            "ply" => Some(Format::Ply),
            "off" => Some(Format::Off),
            "stl" => Some(Format::Stl),
            _ => None,
        }
    }

    /// The format named by a path's extension.
    pub fn from_path(path: &Path) -> Option<Format> {
        Format::from_extension(path.extension()?.to_str()?)
    }

    /// Guess the format from the first bytes of a file.
    pub fn sniff(bytes: &[u8]) -> Option<Format> {
        if stl::is_binary_stl(bytes) {
            return Some(Format::Stl);
        }
        let head = without_bom(&bytes[..bytes.len().min(4096)]);
        let text = String::from_utf8_lossy(head);
        let first = text
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'))?;
        let word = first.split_whitespace().next()?;
        if word == "ply" {
            Some(Format::Ply)
        } else if off::is_off_keyword(word) {
            Some(Format::Off)
        } else if word == "solid" {
            Some(Format::Stl)
        } else if text.lines().any(|l| {
            let w = l.split_whitespace().next();
            matches!(w, Some("v" | "f" | "vt" | "vn" | "o" | "g" | "mtllib"))
        }) {
            Some(Format::Obj)
        } else {
            None
        }
    }

    /// Upper-case name, as used in messages.
    pub fn name(self) -> &'static str {
        match self {
            Format::Obj => "OBJ",
            Format::Ply => "PLY",
            Format::Off => "OFF",
            Format::Stl => "STL",
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Read a mesh file, choosing the reader from the extension or, failing that, the content.
pub fn read_mesh(path: &Path) -> Result<PolygonSoup, ReadError> {
    let bytes = std::fs::read(path).map_err(|source| ReadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let format = match Format::from_path(path).or_else(|| Format::sniff(&bytes)) {
        Some(f) => f,
        None => {
            let ext = path
                .extension()
                .map(|e| format!("extension `.{}`", e.to_string_lossy()))
                .unwrap_or_else(|| "no extension".to_string());
            return Err(ReadError::UnsupportedEncoding {
                format: "mesh".to_string(),
                detail: format!(
                    "{}: {ext} and content not recognized as OBJ, PLY, OFF or STL",
                    path.display()
                ),
            });
        }
    };
    read_mesh_bytes(&bytes, format)
}

/// Read a mesh from memory in the given format.
pub fn read_mesh_bytes(bytes: &[u8], format: Format) -> Result<PolygonSoup, ReadError> {
    match format {
        Format::Obj => read_obj_bytes(bytes).map(|d| d.soup),
        Format::Ply => ply::read_ply_bytes(bytes),
        Format::Off => off::read_off_bytes(bytes),
        Format::Stl => stl::read_stl_bytes(bytes),
    }
}

/// Accumulates vertices and fan-triangulated polygons into a [`PolygonSoup`].
#[derive(Default)]
pub(crate) struct SoupBuilder {
    soup: PolygonSoup,
    polygons: usize,
    /// Fan diagonals used so far and the edges of polygons with more than three sides: a fan
    /// must not reuse either. Two polygons that share two consecutive edges (a vertex of degree
    /// two between them, which remeshes have) would otherwise both get the diagonal across
    /// that vertex, and the triangulated mesh a non-manifold edge.
    diagonals: std::collections::HashSet<(u32, u32)>,
    polygon_edges: std::collections::HashSet<(u32, u32)>,
}

impl SoupBuilder {
    /// `vertices` / `polygons` are capacity hints (already capped by the caller).
    pub(crate) fn with_capacity(vertices: usize, polygons: usize) -> Self {
        let mut b = SoupBuilder::default();
        b.soup.positions.reserve(vertices);
        b.soup.triangles.reserve(polygons);
        b.soup.source_polygon.reserve(polygons);
        b
    }

    /// Registers edges of polygons still to come, so that no fan diagonal lands on them (a
    /// reader that knows all faces before triangulating calls this when some have more than
    /// three sides).
    pub(crate) fn known_edges(&mut self, edges: impl Iterator<Item = (u32, u32)>) {
        self.polygon_edges
            .extend(edges.map(|(a, b)| (a.min(b), a.max(b))));
    }

    pub(crate) fn vertex_count(&self) -> usize {
        self.soup.positions.len()
    }

    pub(crate) fn polygon_count(&self) -> usize {
        self.polygons
    }

    /// Add a vertex, rejecting NaN / infinite coordinates.
    pub(crate) fn push_vertex(&mut self, p: DVec3, line: Option<usize>) -> Result<(), ReadError> {
        let vertex = self.soup.positions.len();
        if !p.is_finite() {
            return Err(ReadError::NonFinite { vertex, line });
        }
        self.soup.positions.push(p);
        if let Some(l) = line {
            self.soup.vertex_lines.push(line_u32(l));
        }
        Ok(())
    }

    /// Add a polygon of already range-checked vertex indices (fan triangulation); returns the
    /// fan's apex corner a: the triangles are (v_a, v_{a+k}, v_{a+k+1}), k = 1..n−2, indices mod n.
    pub(crate) fn push_polygon(
        &mut self,
        verts: &[u32],
        line: Option<usize>,
    ) -> Result<usize, ReadError> {
        let face = self.polygons;
        if verts.len() < 3 {
            return Err(ReadError::FaceTooSmall {
                face,
                line,
                count: verts.len(),
            });
        }
        let poly = u32::try_from(face).map_err(|_| too_many("polygons"))?;
        let n = verts.len();
        let key = |a: u32, b: u32| (a.min(b), a.max(b));
        // Fan apex: the first corner whose diagonals are all new (corner 0 if none is).
        let apex = if n == 3 {
            0
        } else {
            (0..n)
                .find(|&a| {
                    (2..n - 1).all(|k| {
                        let d = key(verts[a], verts[(a + k) % n]);
                        !self.diagonals.contains(&d) && !self.polygon_edges.contains(&d)
                    })
                })
                .unwrap_or(0)
        };
        for k in 1..n - 1 {
            let (b, c) = (verts[(apex + k) % n], verts[(apex + k + 1) % n]);
            self.soup.triangles.push([verts[apex], b, c]);
            self.soup.source_polygon.push(poly);
        }
        if n > 3 {
            for k in 2..n - 1 {
                self.diagonals
                    .insert(key(verts[apex], verts[(apex + k) % n]));
            }
            for k in 0..n {
                self.polygon_edges.insert(key(verts[k], verts[(k + 1) % n]));
            }
        }
        if let Some(l) = line {
            self.soup.polygon_lines.push(line_u32(l));
        }
        self.polygons += 1;
        Ok(apex)
    }

    pub(crate) fn warn(&mut self, w: String) {
        self.soup.warnings.push(w);
    }

    /// Final checks: at least one vertex and one face.
    pub(crate) fn finish(self) -> Result<PolygonSoup, ReadError> {
        let vertices = self.soup.positions.len();
        if vertices == 0 || self.soup.triangles.is_empty() {
            return Err(ReadError::Empty { vertices });
        }
        if u32::try_from(vertices).is_err() {
            return Err(too_many("vertices"));
        }
        Ok(self.soup)
    }
}

fn too_many(what: &str) -> ReadError {
    ReadError::UnsupportedEncoding {
        format: "mesh".to_string(),
        detail: format!("more than 2^32 {what}"),
    }
}

fn line_u32(l: usize) -> u32 {
    u32::try_from(l).unwrap_or(u32::MAX)
}

/// Check a 0-based vertex index read from a file (`written` is how the file wrote it, for the
/// message) against the vertex count.
pub(crate) fn check_index(
    index: i64,
    written: i64,
    vertex_count: usize,
    face: usize,
    line: Option<usize>,
) -> Result<u32, ReadError> {
    match usize::try_from(index) {
        Ok(i) if i < vertex_count => u32::try_from(i).map_err(|_| too_many("vertices")),
        _ => Err(ReadError::IndexOutOfRange {
            face,
            line,
            index: written,
            vertex_count,
        }),
    }
}

/// Lines of a text file as `(1-based line number, text)`, with `\r` stripped. Invalid UTF-8 is
/// replaced (only the numeric tokens matter).
pub(crate) fn text_lines(bytes: &[u8]) -> impl Iterator<Item = (usize, Cow<'_, str>)> {
    bytes.split(|&b| b == b'\n').enumerate().map(|(i, l)| {
        let l = l.strip_suffix(b"\r").unwrap_or(l);
        // Editors on Windows may start a UTF-8 text file with a byte order mark; it is no part
        // of the first record (an OBJ's first vertex was lost to it).
        let l = if i == 0 { without_bom(l) } else { l };
        (i + 1, String::from_utf8_lossy(l))
    })
}

/// `bytes` without a leading UTF-8 byte order mark.
pub(crate) fn without_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes)
}

/// Parse a float token, with a message naming the token.
pub(crate) fn parse_f64(tok: &str, what: &str, line: usize) -> Result<f64, ReadError> {
    tok.parse::<f64>().map_err(|_| ReadError::Parse {
        line,
        message: format!("expected a number for {what}, found `{}`", shorten(tok)),
    })
}

/// Cut a token for messages.
pub(crate) fn shorten(s: &str) -> Cow<'_, str> {
    if s.chars().count() <= 40 {
        Cow::Borrowed(s)
    } else {
        Cow::Owned(format!("{}…", s.chars().take(40).collect::<String>()))
    }
}

/// A capacity hint for `count` records of at least `min_bytes` each in a file of `len` bytes.
pub(crate) fn capped(count: u64, len: usize, min_bytes: usize) -> usize {
    let bound = (len / min_bytes.max(1)) as u64;
    count.min(bound) as usize
}
