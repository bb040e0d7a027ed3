//! STL reader, ASCII and binary.
//!
//! Choices:
//! - Binary is recognised by its size, `84 + 50 n` bytes with `n` the count at byte 80, not by the
//!   `solid` prefix (many binary files start with "solid"). A file that starts with `solid` and
//!   whose first kilobyte has no control bytes (UTF-8 names are fine) is read as ASCII; anything
//!   else is binary (and reported as truncated if too short for its count).
//! - STL stores three corners per triangle; corners are welded by exact coordinate equality (the
//!   `f32` bits for binary, the parsed `f64` bits for ASCII, with -0 equal to +0). Vertices are
//!   numbered in first-occurrence order and a warning "welded N coincident vertices" is added.
//! - Normals and the attribute word are ignored. ASCII `facet`s with more than 3 loop vertices are
//!   fan-triangulated; several `solid`s in one file are merged.

use std::collections::HashMap;
use std::collections::hash_map::Entry;

use glam::DVec3;

use super::{ReadError, SoupBuilder, capped, parse_f64};
use crate::mesh::PolygonSoup;

/// Whether the bytes have exactly the size of a binary STL with the count they announce.
pub(crate) fn is_binary_stl(bytes: &[u8]) -> bool {
    match bytes.get(80..84) {
        Some(c) => {
            let n = u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as u64;
            84 + 50 * n == bytes.len() as u64
        }
        None => false,
    }
}

fn looks_ascii(bytes: &[u8]) -> bool {
    let trimmed = super::without_bom(bytes).trim_ascii_start();
    trimmed.starts_with(b"solid")
        && trimmed[..trimmed.len().min(1024)]
            .iter()
            .all(|&b| (b >= 0x20 && b != 0x7f) || b.is_ascii_whitespace())
}

/// Welds corners by a bitwise key and feeds the builder.
struct Welder {
    builder: SoupBuilder,
    index: HashMap<[u64; 3], u32>,
    corners: usize,
}

impl Welder {
    fn new(vertices: usize, triangles: usize) -> Self {
        Welder {
            builder: SoupBuilder::with_capacity(vertices, triangles),
            index: HashMap::with_capacity(vertices),
            corners: 0,
        }
    }

    fn vertex(&mut self, key: [u64; 3], p: DVec3, line: Option<usize>) -> Result<u32, ReadError> {
        self.corners += 1;
        let next = self.builder.vertex_count();
        match self.index.entry(key) {
            Entry::Occupied(e) => Ok(*e.get()),
            Entry::Vacant(e) => {
                let id = u32::try_from(next).map_err(|_| ReadError::UnsupportedEncoding {
                    format: "STL".to_string(),
                    detail: "more than 2^32 vertices".to_string(),
                })?;
                self.builder.push_vertex(p, line)?;
                e.insert(id);
                Ok(id)
            }
        }
    }

    fn finish(mut self) -> Result<PolygonSoup, ReadError> {
        let welded = self.corners - self.builder.vertex_count();
        if welded > 0 {
            self.builder
                .warn(format!("welded {welded} coincident vertices"));
        }
        self.builder.finish()
    }
}

/// Read an STL file from memory.
pub fn read_stl_bytes(bytes: &[u8]) -> Result<PolygonSoup, ReadError> {
    if !is_binary_stl(bytes) && looks_ascii(bytes) {
        read_ascii(bytes)
    } else {
        read_binary(bytes)
    }
}

fn read_binary(bytes: &[u8]) -> Result<PolygonSoup, ReadError> {
    let Some(c) = bytes.get(80..84) else {
        return Err(ReadError::Truncated {
            what: "header bytes of a binary STL".to_string(),
            expected: 84,
            found: bytes.len() as u64,
        });
    };
    let n = u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as u64;
    let available = (bytes.len() as u64 - 84) / 50;
    if available < n {
        return Err(ReadError::Truncated {
            what: format!(
                "triangles in binary STL ({} bytes after the 84-byte header)",
                bytes.len() - 84
            ),
            expected: n,
            found: available,
        });
    }
    let mut w = Welder::new(capped(n, bytes.len(), 50), capped(n, bytes.len(), 50));
    for rec in bytes[84..].chunks_exact(50).take(n as usize) {
        let mut tri = [0u32; 3];
        for (k, slot) in tri.iter_mut().enumerate() {
            let off = 12 + 12 * k;
            let f = |j: usize| {
                let b = &rec[off + 4 * j..off + 4 * j + 4];
                f32::from_le_bytes([b[0], b[1], b[2], b[3]])
            };
            let p = [f(0), f(1), f(2)];
            // +0.0 for -0.0 so that equal coordinates weld.
            let key = p.map(|x| (x + 0.0).to_bits() as u64);
            *slot = w.vertex(key, DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64), None)?;
        }
        w.builder.push_polygon(&tri, None)?;
    }
    w.finish()
}

fn read_ascii(bytes: &[u8]) -> Result<PolygonSoup, ReadError> {
    let mut w = Welder::new(0, 0);
    let mut poly: Vec<u32> = Vec::new();
    let mut facet_line = None;
    for (line, text) in super::text_lines(bytes) {
        let mut words = text.split_whitespace();
        match words.next() {
            Some("facet") => {
                facet_line = Some(line);
                poly.clear();
            }
            Some("vertex") => {
                let mut c = [0.0; 3];
                for (k, slot) in c.iter_mut().enumerate() {
                    let tok = words.next().ok_or_else(|| ReadError::Parse {
                        line,
                        message: format!("vertex has {k} coordinates, expected 3"),
                    })?;
                    *slot = parse_f64(tok, "a vertex coordinate", line)?;
                }
                let key = c.map(|x| (x + 0.0).to_bits());
                poly.push(w.vertex(key, DVec3::from_array(c), Some(line))?);
            }
            Some("endfacet") => {
                let Some(fl) = facet_line.take() else {
                    return Err(ReadError::Parse {
                        line,
                        message: "`endfacet` without `facet`".to_string(),
                    });
                };
                w.builder.push_polygon(&poly, Some(fl))?;
                poly.clear();
            }
            _ => {}
        }
    }
    if let Some(fl) = facet_line {
        return Err(ReadError::Parse {
            line: fl,
            message: "`facet` is not closed by `endfacet` before the end of the file".to_string(),
        });
    }
    w.finish()
}
