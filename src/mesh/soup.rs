//! What file readers produce: raw positions and triangles, before any topology is built.
//!
//! Readers triangulate polygons (fan) and keep, where the format has lines, the source line of each
//! vertex and face so that validation errors can point into the file.

use glam::DVec3;

/// Raw triangle soup as read from a file: indices are 0-based and already range-checked by the reader.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PolygonSoup {
    pub positions: Vec<DVec3>,
    /// Triangles (polygons are fan-triangulated by the reader).
    pub triangles: Vec<[u32; 3]>,
    /// For each triangle, the index of the polygon it came from in the file (equal to the triangle
    /// index when the file had only triangles).
    pub source_polygon: Vec<u32>,
    /// 1-based line number of each vertex in a text file (empty for binary files).
    pub vertex_lines: Vec<u32>,
    /// 1-based line number of each source polygon in a text file (empty for binary files).
    pub polygon_lines: Vec<u32>,
    /// Warnings raised while reading (e.g. "welded 12 coincident STL vertices").
    pub warnings: Vec<String>,
}

impl PolygonSoup {
    /// Where a triangle came from, for messages: "polygon 17 (line 42)" or "face 17".
    pub fn describe_triangle(&self, t: usize) -> String {
        let p = self.source_polygon.get(t).copied().unwrap_or(t as u32) as usize;
        match self.polygon_lines.get(p) {
            Some(line) => format!("face {p} (line {line})"),
            None => format!("face {p}"),
        }
    }

    /// Where a vertex came from, for messages: "vertex 3 (line 5)" or "vertex 3".
    pub fn describe_vertex(&self, v: usize) -> String {
        match self.vertex_lines.get(v) {
            Some(line) => format!("vertex {v} (line {line})"),
            None => format!("vertex {v}"),
        }
    }
}
