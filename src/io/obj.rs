//! Wavefront OBJ reader: `v`, `vt`, `f` and `l` records; the records of normals, groups,
//! materials, points and display attributes ([`IGNORED`]) and comments are ignored. Any other
//! record is ignored with a warning naming its keyword, count and first line: free-form
//! geometry ([`FREE_FORM`]: a NURBS surface is no mesh we can read) and keywords OBJ does not
//! have (a typo, or another format's text), so that what is lost is never lost silently.
//!
//! Choices:
//! - Hand-written rather than `tobj`: tobj (without its `use_f64` feature) stores coordinates as
//!   `f32`, and in every mode it re-indexes the vertices of each object in first-use order, dropping
//!   unreferenced vertices. We need the file's vertex indices (messages, `V` counts that include
//!   unreferenced vertices), exact `f64` coordinates and line numbers, which a 100-line parser
//!   gives directly.
//! - Vertex records read the first three numbers; a 4th (`w`) or colour values are ignored.
//! - Face corners `v`, `v/vt`, `v//vn`, `v/vt/vn`; negative indices are relative to the vertices
//!   read so far; positive indices may refer forward (checked once the whole file is read). All
//!   objects and groups share one index space, so they merge into one soup naturally.
//! - Per-corner texture coordinates are returned (in [`ObjData::corner_uvs`]) only when every face
//!   corner has a `vt` index; `vt` records keep their `u v` (a missing `v` reads as 0).
//! - `l` polylines are returned in [`ObjData::polylines`], not in the soup.

use glam::DVec3;

use super::{ReadError, SoupBuilder, check_index, parse_f64, shorten, text_lines};
use crate::mesh::PolygonSoup;

/// Records that carry nothing a triangle mesh needs: read past without a word.
pub const IGNORED: &[&str] = &[
    "vn",
    "vp",
    "o",
    "g",
    "s",
    "mg",
    "p",
    "usemtl",
    "mtllib",
    "usemap",
    "maplib",
    "lod",
    "bevel",
    "c_interp",
    "d_interp",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
];

/// Free-form curve and surface records: geometry this reader does not tessellate.
pub const FREE_FORM: &[&str] = &[
    "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp",
    "end", "con",
];

/// Everything read from an OBJ file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ObjData {
    pub soup: PolygonSoup,
    /// Per triangle corner (`3 * t + k`, same triangles as `soup.triangles`) texture coordinates,
    /// when every face corner in the file has a `vt` index.
    pub corner_uvs: Option<Vec<[f64; 2]>>,
    /// `l` records: 0-based vertex indices of each polyline.
    pub polylines: Vec<Vec<u32>>,
    /// Quads `f a b p p` with one vertex twice (the star faces of a pole, as `quadcover solve`
    /// writes them): read as the triangle (a, b, p), `soup.triangles[triangle]`, whose quad
    /// texture coordinates (a, b, q_{j+1}, q_j) are kept here (with UVs only).
    pub pole_quads: Vec<PoleQuad>,
}

/// A quad read as a triangle because two consecutive corners share their vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct PoleQuad {
    pub triangle: usize,
    /// The repeated vertex (the pole).
    pub pole: u32,
    /// Texture coordinates of (a, b, q_{j+1}, q_j): the two pole corners last.
    pub uv: [[f64; 2]; 4],
}

/// One `f` or `l` record: corners `[start, start + len)` of the corner arrays.
struct Record {
    start: usize,
    len: usize,
    line: usize,
}

/// A corner as read: 0-based vertex index (possibly out of range), how it was written, and
/// the 0-based texture index if given.
#[derive(Clone, Copy)]
struct Corner {
    v: i64,
    written: i64,
    vt: Option<i64>,
}

/// Read an OBJ file from memory.
pub fn read_obj_bytes(bytes: &[u8]) -> Result<ObjData, ReadError> {
    let mut builder = SoupBuilder::with_capacity(0, 0);
    let mut texcoords: Vec<[f64; 2]> = Vec::new();
    let mut corners: Vec<Corner> = Vec::new();
    let mut faces: Vec<Record> = Vec::new();
    let mut lines: Vec<Record> = Vec::new();
    // Keywords read past with a warning: count and first line.
    let mut skipped: std::collections::HashMap<String, (usize, usize)> = Default::default();

    for (line, text) in text_lines(bytes) {
        let mut words = text.split_whitespace();
        let Some(key) = words.next() else { continue };
        match key {
            "v" => {
                let mut c = [0.0; 3];
                for (k, slot) in c.iter_mut().enumerate() {
                    let tok = words.next().ok_or_else(|| ReadError::Parse {
                        line,
                        message: format!("vertex record has {k} coordinates, expected 3"),
                    })?;
                    *slot = parse_f64(tok, "a vertex coordinate", line)?;
                }
                builder.push_vertex(DVec3::from_array(c), Some(line))?;
            }
            "vt" => {
                let u = words.next().ok_or_else(|| ReadError::Parse {
                    line,
                    message: "texture coordinate record has no values".to_string(),
                })?;
                let u = parse_f64(u, "a texture coordinate", line)?;
                let v = match words.next() {
                    Some(t) => parse_f64(t, "a texture coordinate", line)?,
                    None => 0.0,
                };
                texcoords.push([u, v]);
            }
            "f" | "l" => {
                let start = corners.len();
                for tok in words {
                    corners.push(parse_corner(
                        tok,
                        builder.vertex_count(),
                        texcoords.len(),
                        line,
                    )?);
                }
                let rec = Record {
                    start,
                    len: corners.len() - start,
                    line,
                };
                if key == "f" {
                    faces.push(rec);
                } else {
                    lines.push(rec);
                }
            }
            _ if key.starts_with('#') || IGNORED.contains(&key) => {}
            _ => {
                skipped
                    .entry(shorten(key).into_owned())
                    .or_insert((0, line))
                    .0 += 1
            }
        }
    }

    let nv = builder.vertex_count();
    let with_uvs = !faces.is_empty()
        && faces.iter().all(|f| {
            corners[f.start..f.start + f.len]
                .iter()
                .all(|c| c.vt.is_some())
        });
    let mut corner_uvs = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    if faces.iter().any(|f| f.len > 3) {
        // Polygons: fan diagonals must avoid every edge of the file, later faces' included.
        let valid = |c: &Corner| usize::try_from(c.v).ok().filter(|&i| i < nv);
        for rec in &faces {
            let cs = &corners[rec.start..rec.start + rec.len];
            let edges = (0..cs.len()).filter_map(|k| {
                Some((
                    valid(&cs[k])? as u32,
                    valid(&cs[(k + 1) % cs.len()])? as u32,
                ))
            });
            builder.known_edges(edges);
        }
    }
    let mut pole_quads = Vec::new();
    let mut rotated: Vec<Corner> = Vec::new();
    for (face, rec) in faces.iter().enumerate() {
        let mut cs = &corners[rec.start..rec.start + rec.len];
        poly.clear();
        for c in cs {
            poly.push(check_index(c.v, c.written, nv, face, Some(rec.line))?);
        }
        // A pole quad a b p p (in any rotation): the triangle a b p, its quad UVs aside.
        if poly.len() == 4 {
            let rep: Vec<usize> = (0..4).filter(|&k| poly[k] == poly[(k + 1) % 4]).collect();
            let distinct = {
                let mut v = poly.clone();
                v.sort_unstable();
                v.dedup();
                v.len()
            };
            if rep.len() == 1 && distinct == 3 {
                let k = rep[0]; // corners k and k + 1 are the pole
                rotated.clear();
                rotated.extend((0..4).map(|i| cs[(k + 2 + i) % 4]));
                cs = &rotated[..3];
                let p4 = poly.clone();
                poly.clear();
                poly.extend((0..3).map(|i| p4[(k + 2 + i) % 4]));
                if with_uvs {
                    let t = builder.soup.triangles.len();
                    let uv = |c: &Corner| texcoords[c.vt.unwrap_or(0) as usize];
                    pole_quads.push(PoleQuad {
                        triangle: t,
                        pole: poly[2],
                        uv: [
                            uv(&rotated[0]),
                            uv(&rotated[1]),
                            uv(&rotated[2]),
                            uv(&rotated[3]),
                        ],
                    });
                }
            }
        }
        let apex = builder.push_polygon(&poly, Some(rec.line))?;
        if with_uvs {
            let uv = |c: &Corner| -> Result<[f64; 2], ReadError> {
                let t = c.vt.unwrap_or(-1);
                usize::try_from(t)
                    .ok()
                    .and_then(|t| texcoords.get(t).copied())
                    .ok_or_else(|| ReadError::Parse {
                        line: rec.line,
                        message: format!(
                            "face {face}: texture coordinate index {} is out of range \
                             (the file has {} vt records)",
                            t + 1,
                            texcoords.len()
                        ),
                    })
            };
            let n = cs.len();
            for k in 1..n - 1 {
                corner_uvs.push(uv(&cs[apex])?);
                corner_uvs.push(uv(&cs[(apex + k) % n])?);
                corner_uvs.push(uv(&cs[(apex + k + 1) % n])?);
            }
        }
    }
    let mut polylines = Vec::with_capacity(lines.len());
    for rec in &lines {
        let mut pl = Vec::with_capacity(rec.len);
        for c in &corners[rec.start..rec.start + rec.len] {
            match usize::try_from(c.v) {
                Ok(i) if i < nv => pl.push(i as u32),
                _ => {
                    return Err(ReadError::Parse {
                        line: rec.line,
                        message: format!(
                            "polyline vertex index {} is out of range (the file has {nv} vertices)",
                            c.written
                        ),
                    });
                }
            }
        }
        polylines.push(pl);
    }
    let mut soup = builder.finish()?;
    let mut skipped: Vec<(String, usize, usize)> = skipped
        .into_iter()
        .map(|(k, (n, line))| (k, n, line))
        .collect();
    skipped.sort_by_key(|&(_, _, line)| line);
    soup.warnings.extend(skipped_warning(&skipped));
    Ok(ObjData {
        soup,
        corner_uvs: with_uvs.then_some(corner_uvs),
        polylines,
        pole_quads,
    })
}

/// The warning for records read past that may have carried geometry (keyword, count, first
/// line, in the order of first lines, the first few): said to be free-form geometry when any
/// of them is, the likelier loss.
fn skipped_warning(skipped: &[(String, usize, usize)]) -> Option<String> {
    if skipped.is_empty() {
        return None;
    }
    const LISTED: usize = 5;
    let mut list = skipped
        .iter()
        .take(LISTED)
        .map(|(k, n, line)| format!("`{k}` ×{n} (first at line {line})"))
        .collect::<Vec<_>>()
        .join(", ");
    if skipped.len() > LISTED {
        list += &format!(" and {} more kinds", skipped.len() - LISTED);
    }
    Some(
        if skipped
            .iter()
            .any(|(k, _, _)| FREE_FORM.contains(&k.as_str()))
        {
            format!(
                "free-form curves or surfaces are not read, only polygon faces (tessellate them in the modelling tool first); records ignored: {list}"
            )
        } else {
            format!("records of no OBJ kind this reader knows are ignored: {list}")
        },
    )
}

/// Parse `v`, `v/vt`, `v//vn` or `v/vt/vn`, resolving negative (relative) indices against the
/// counts read so far. Index 0 resolves to -1 (out of range, reported later with the face).
fn parse_corner(tok: &str, nv: usize, nvt: usize, line: usize) -> Result<Corner, ReadError> {
    let bad = || ReadError::Parse {
        line,
        message: format!("malformed face corner `{}`", shorten(tok)),
    };
    let mut parts = tok.split('/');
    let v_str = parts.next().ok_or_else(bad)?;
    let vt_str = parts.next();
    let _vn = parts.next();
    if parts.next().is_some() {
        return Err(bad());
    }
    let written: i64 = v_str.parse().map_err(|_| bad())?;
    let resolve = |i: i64, n: usize| -> i64 {
        if i < 0 {
            (n as i64).saturating_add(i)
        } else {
            i - 1
        }
    };
    let vt = match vt_str {
        None | Some("") => None,
        Some(s) => Some(resolve(s.parse::<i64>().map_err(|_| bad())?, nvt)),
    };
    Ok(Corner {
        v: resolve(written, nv),
        written,
        vt,
    })
}
