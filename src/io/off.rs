//! OFF (Object File Format) reader, ASCII only.
//!
//! Choices:
//! - Header keyword `OFF` with any of the `ST`, `C`, `N` prefixes (`COFF`, `NOFF`, `CNOFF`,
//!   `STOFF`, …); the per-vertex extras these announce (colours, normals, texture coordinates) are
//!   ignored: a vertex line contributes its first three numbers. `4OFF`/`nOFF` (other
//!   dimensions) and `OFF BINARY` are rejected as unsupported. A file without the keyword that
//!   starts with the counts line is accepted too.
//! - The counts `nv nf [ne]` may follow the keyword on the same line; `ne` is ignored.
//! - `#` starts a comment anywhere; blank lines are skipped. Vertices and faces are one per line;
//!   a face line is `n i_1 … i_n` followed by optional colour values (ignored).

use glam::DVec3;

use super::{ReadError, SoupBuilder, capped, check_index, parse_f64, shorten, text_lines};
use crate::mesh::PolygonSoup;

/// Whether `word` is an OFF header keyword (any dimension / binary variant included).
pub(crate) fn is_off_keyword(word: &str) -> bool {
    word.strip_suffix("OFF").is_some_and(|p| {
        p.chars()
            .all(|c| matches!(c, 'S' | 'T' | 'C' | 'N' | '4' | 'n'))
    })
}

fn unsupported(line: usize, detail: &str) -> ReadError {
    ReadError::UnsupportedEncoding {
        format: "OFF".to_string(),
        detail: format!("line {line}: {detail}"),
    }
}

/// Read an OFF file from memory.
pub fn read_off_bytes(bytes: &[u8]) -> Result<PolygonSoup, ReadError> {
    // Non-empty lines with comments removed.
    let mut lines = text_lines(bytes).filter_map(|(n, text)| {
        let body = text.split('#').next().unwrap_or("").trim();
        (!body.is_empty()).then(|| (n, body.to_string()))
    });

    let Some((hline, htext)) = lines.next() else {
        return Err(ReadError::Empty { vertices: 0 });
    };
    let hwords: Vec<&str> = htext.split_whitespace().collect();
    let first = hwords.first().copied().unwrap_or("");
    let counts_inline: Vec<String>;
    let counts_line;
    if is_off_keyword(first) {
        if first.contains('4') || first.contains('n') {
            return Err(unsupported(
                hline,
                &format!("`{first}` (only 3-D OFF is supported)"),
            ));
        }
        if hwords.get(1) == Some(&"BINARY") {
            return Err(unsupported(hline, "binary OFF is not supported"));
        }
        if hwords.len() > 1 {
            counts_inline = hwords[1..].iter().map(|s| s.to_string()).collect();
            counts_line = hline;
        } else {
            let Some((n, t)) = lines.next() else {
                return Err(ReadError::Empty { vertices: 0 });
            };
            counts_inline = t.split_whitespace().map(str::to_string).collect();
            counts_line = n;
        }
    } else if first.parse::<u64>().is_ok() {
        counts_inline = hwords.iter().map(|s| s.to_string()).collect();
        counts_line = hline;
    } else {
        return Err(ReadError::Parse {
            line: hline,
            message: format!(
                "expected the `OFF` header keyword, found `{}`",
                shorten(first)
            ),
        });
    }
    let count = |k: usize, what: &str| -> Result<u64, ReadError> {
        let tok = counts_inline.get(k).ok_or_else(|| ReadError::Parse {
            line: counts_line,
            message: format!("missing {what} in the counts line"),
        })?;
        tok.parse::<u64>().map_err(|_| ReadError::Parse {
            line: counts_line,
            message: format!("invalid {what} `{}`", shorten(tok)),
        })
    };
    let nv = count(0, "vertex count")?;
    let nf = count(1, "face count")?;
    if nv == 0 {
        return Err(ReadError::Empty { vertices: 0 });
    }

    let mut builder =
        SoupBuilder::with_capacity(capped(nv, bytes.len(), 6), capped(nf, bytes.len(), 6));
    for found in 0..nv {
        let Some((line, text)) = lines.next() else {
            return Err(ReadError::Truncated {
                what: "vertices".to_string(),
                expected: nv,
                found,
            });
        };
        let mut c = [0.0; 3];
        let mut words = text.split_whitespace();
        for (k, slot) in c.iter_mut().enumerate() {
            let tok = words.next().ok_or_else(|| ReadError::Parse {
                line,
                message: format!("vertex line has {k} coordinates, expected 3"),
            })?;
            *slot = parse_f64(tok, "a vertex coordinate", line)?;
        }
        builder.push_vertex(DVec3::from_array(c), Some(line))?;
    }
    let vertex_count = builder.vertex_count();
    let mut poly = Vec::new();
    for found in 0..nf {
        let Some((line, text)) = lines.next() else {
            return Err(ReadError::Truncated {
                what: "faces".to_string(),
                expected: nf,
                found,
            });
        };
        let face = found as usize;
        let mut words = text.split_whitespace();
        let n_tok = words.next().unwrap_or("");
        let n = n_tok.parse::<usize>().map_err(|_| ReadError::Parse {
            line,
            message: format!("invalid face vertex count `{}`", shorten(n_tok)),
        })?;
        poly.clear();
        for k in 0..n {
            let tok = words.next().ok_or_else(|| ReadError::Parse {
                line,
                message: format!("face {face} announces {n} vertices but lists {k}"),
            })?;
            let idx = tok.parse::<i64>().map_err(|_| ReadError::Parse {
                line,
                message: format!("invalid vertex index `{}` in face {face}", shorten(tok)),
            })?;
            poly.push(check_index(idx, idx, vertex_count, face, Some(line))?);
        }
        builder.push_polygon(&poly, Some(line))?;
    }
    // Records past the counts are no part of the mesh; say so rather than drop them silently
    // (a face appended without updating the header).
    let rest: Vec<usize> = lines.map(|(n, _)| n).collect();
    let mut soup = builder.finish()?;
    if let Some(first) = rest.first() {
        soup.warnings.push(format!(
            "{} line(s) after the {nf} faces the header declares are ignored; first: line {first}",
            rest.len()
        ));
    }
    Ok(soup)
}
