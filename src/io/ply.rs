//! PLY reader: `ascii`, `binary_little_endian` and `binary_big_endian` encodings.
//!
//! Choices:
//! - Hand-written (the PLY crates on crates.io are unmaintained); about 300 lines.
//! - The `vertex` element must have scalar `x`, `y`, `z` properties of any scalar type; its other
//!   properties, and all properties of other elements (scalars and lists), are read and dropped.
//! - The `face` element must have a list property `vertex_indices` (or `vertex_index`) with any
//!   count / item scalar types; polygons are fan-triangulated. Other elements (`edge`, `tristrips`,
//!   `material`, …) are skipped, so a file with only triangle strips reads as "no faces".
//! - All values are read as `f64` (exact for every PLY scalar type); indices must be integral.
//! - ASCII data is read as a stream of tokens (instances need not be one per line); the line of
//!   an instance is the line of its first token. Binary data starts right after the `\n` that ends
//!   the `end_header` line.

use glam::DVec3;

use super::{ReadError, SoupBuilder, capped, check_index, shorten, text_lines};
use crate::mesh::PolygonSoup;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Encoding {
    Ascii,
    BinaryLe,
    BinaryBe,
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset of the data.
    data_start: usize,
    /// 1-based line number of the first data line (ASCII).
    data_line: usize,
}

fn unsupported(detail: String) -> ReadError {
    ReadError::UnsupportedEncoding {
        format: "PLY".to_string(),
        detail,
    }
}

fn parse_header(bytes: &[u8]) -> Result<Header, ReadError> {
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut offset = 0usize;
    let mut last_line = 0;
    for (line, text) in text_lines(bytes) {
        last_line = line;
        // Offset of the next line: this line's bytes plus the '\n' (the stripped '\r' included).
        let raw_len = bytes[offset..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len() - offset, |p| p + 1);
        offset += raw_len;
        let perr = |message: String| ReadError::Parse { line, message };
        let words: Vec<&str> = text.split_whitespace().collect();
        if line == 1 {
            if words.first() != Some(&"ply") {
                return Err(perr(
                    "not a PLY file: the first line must be `ply`".to_string(),
                ));
            }
            continue;
        }
        match words.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                encoding = Some(match words.get(1).copied() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::BinaryLe,
                    Some("binary_big_endian") => Encoding::BinaryBe,
                    Some(other) => {
                        return Err(unsupported(format!(
                            "line {line}: unknown encoding `{}` (expected ascii, \
                             binary_little_endian or binary_big_endian)",
                            shorten(other)
                        )));
                    }
                    None => return Err(perr("`format` line without an encoding".to_string())),
                });
            }
            Some("element") => {
                let (Some(name), Some(count), None) = (words.get(1), words.get(2), words.get(3))
                else {
                    return Err(perr("expected `element <name> <count>`".to_string()));
                };
                let count = count
                    .parse::<u64>()
                    .map_err(|_| perr(format!("invalid element count `{}`", shorten(count))))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let Some(element) = elements.last_mut() else {
                    return Err(perr("`property` before any `element`".to_string()));
                };
                let ty = |name: &str| {
                    Scalar::parse(name)
                        .ok_or_else(|| perr(format!("unknown property type `{}`", shorten(name))))
                };
                let (kind, name) = match words.as_slice() {
                    [_, "list", count, item, name] => (
                        Kind::List {
                            count: ty(count)?,
                            item: ty(item)?,
                        },
                        name,
                    ),
                    [_, t, name] if *t != "list" => (Kind::Scalar(ty(t)?), name),
                    _ => {
                        return Err(perr(
                            "expected `property <type> <name>` or \
                             `property list <count type> <item type> <name>`"
                                .to_string(),
                        ));
                    }
                };
                element.props.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            Some("end_header") => {
                let encoding = encoding
                    .ok_or_else(|| perr("header ends without a `format` line".to_string()))?;
                return Ok(Header {
                    encoding,
                    elements,
                    data_start: offset,
                    data_line: line + 1,
                });
            }
            Some(other) => {
                return Err(perr(format!("unknown header keyword `{}`", shorten(other))));
            }
        }
    }
    Err(ReadError::Parse {
        line: last_line,
        message: "the header has no `end_header` line".to_string(),
    })
}

/// Source of scalar values: ASCII tokens or binary bytes.
enum Data<'a> {
    Ascii {
        bytes: &'a [u8],
        pos: usize,
        line: usize,
    },
    Binary {
        bytes: &'a [u8],
        pos: usize,
        big_endian: bool,
    },
}

impl Data<'_> {
    /// Line of the next token (ASCII), for messages.
    fn line(&mut self) -> Option<usize> {
        match self {
            Data::Ascii { bytes, pos, line } => {
                while let Some(&b) = bytes.get(*pos) {
                    if !b.is_ascii_whitespace() {
                        break;
                    }
                    if b == b'\n' {
                        *line += 1;
                    }
                    *pos += 1;
                }
                Some(*line)
            }
            Data::Binary { .. } => None,
        }
    }

    fn offset(&self) -> usize {
        match self {
            Data::Ascii { pos, .. } | Data::Binary { pos, .. } => *pos,
        }
    }

    /// Next value; `Ok(None)` at end of data, `Err(token)` for an ASCII token that is no number.
    fn read(&mut self, ty: Scalar) -> Result<Option<f64>, String> {
        match self {
            Data::Ascii { .. } => {
                self.line();
                let Data::Ascii { bytes, pos, .. } = self else {
                    return Ok(None);
                };
                let start = *pos;
                while bytes.get(*pos).is_some_and(|b| !b.is_ascii_whitespace()) {
                    *pos += 1;
                }
                if start == *pos {
                    return Ok(None);
                }
                let tok = String::from_utf8_lossy(&bytes[start..*pos]);
                match tok.parse::<f64>() {
                    Ok(v) => Ok(Some(v)),
                    Err(_) => Err(shorten(&tok).into_owned()),
                }
            }
            Data::Binary {
                bytes,
                pos,
                big_endian,
            } => {
                let n = ty.size();
                let Some(raw) = bytes.get(*pos..*pos + n) else {
                    return Ok(None);
                };
                *pos += n;
                let mut buf = [0u8; 8];
                buf[..n].copy_from_slice(raw);
                if *big_endian {
                    buf[..n].reverse();
                }
                let [b0, b1, b2, b3, ..] = buf;
                Ok(Some(match ty {
                    Scalar::I8 => b0 as i8 as f64,
                    Scalar::U8 => b0 as f64,
                    Scalar::I16 => i16::from_le_bytes([b0, b1]) as f64,
                    Scalar::U16 => u16::from_le_bytes([b0, b1]) as f64,
                    Scalar::I32 => i32::from_le_bytes([b0, b1, b2, b3]) as f64,
                    Scalar::U32 => u32::from_le_bytes([b0, b1, b2, b3]) as f64,
                    Scalar::F32 => f32::from_le_bytes([b0, b1, b2, b3]) as f64,
                    Scalar::F64 => f64::from_le_bytes(buf),
                }))
            }
        }
    }
}

/// Read a PLY file from memory.
pub fn read_ply_bytes(bytes: &[u8]) -> Result<PolygonSoup, ReadError> {
    let header = parse_header(bytes)?;
    let data_bytes = bytes.get(header.data_start..).unwrap_or(&[]);
    let mut data = match header.encoding {
        Encoding::Ascii => Data::Ascii {
            bytes: data_bytes,
            pos: 0,
            line: header.data_line,
        },
        Encoding::BinaryLe | Encoding::BinaryBe => Data::Binary {
            bytes: data_bytes,
            pos: 0,
            big_endian: header.encoding == Encoding::BinaryBe,
        },
    };
    let binary = header.encoding != Encoding::Ascii;

    let Some(vertex_el) = header.elements.iter().find(|e| e.name == "vertex") else {
        return Err(ReadError::Empty { vertices: 0 });
    };
    let xyz = ["x", "y", "z"].map(|c| {
        vertex_el
            .props
            .iter()
            .position(|p| p.name == c && matches!(p.kind, Kind::Scalar(_)))
    });
    let [Some(ix), Some(iy), Some(iz)] = xyz else {
        return Err(unsupported(
            "the `vertex` element lacks scalar `x`, `y` and `z` properties".to_string(),
        ));
    };
    let face_el = header.elements.iter().find(|e| e.name == "face");
    let face_prop = match face_el {
        None => None,
        Some(el) => {
            let p = el.props.iter().position(|p| {
                matches!(p.kind, Kind::List { .. })
                    && (p.name == "vertex_indices" || p.name == "vertex_index")
            });
            if p.is_none() {
                return Err(unsupported(
                    "the `face` element has no `vertex_indices` list property".to_string(),
                ));
            }
            p
        }
    };
    let vertex_count = usize::try_from(vertex_el.count).unwrap_or(usize::MAX);
    let mut builder = SoupBuilder::with_capacity(
        capped(vertex_el.count, data_bytes.len(), 3),
        capped(face_el.map_or(0, |e| e.count), data_bytes.len(), 4),
    );
    let mut poly: Vec<u32> = Vec::new();

    for el in &header.elements {
        if el.props.is_empty() {
            continue; // nothing to read, whatever the count
        }
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        for i in 0..el.count {
            let line = data.line();
            let truncated = |found: u64, offset: usize| ReadError::Truncated {
                what: if binary {
                    format!(
                        "`{}` elements (data ends at byte {})",
                        el.name,
                        header.data_start + offset
                    )
                } else {
                    format!("`{}` elements", el.name)
                },
                expected: el.count,
                found,
            };
            let not_a_number = |tok: String, prop: &str| ReadError::Parse {
                line: line.unwrap_or(0), // only ASCII tokens fail to parse
                message: format!(
                    "expected a number for property `{prop}` of `{}` {i}, found `{tok}`",
                    el.name
                ),
            };
            let mut xyz = [0.0; 3];
            poly.clear();
            for (pi, prop) in el.props.iter().enumerate() {
                match prop.kind {
                    Kind::Scalar(ty) => {
                        let v = data.read(ty).map_err(|t| not_a_number(t, &prop.name))?;
                        let Some(v) = v else {
                            return Err(truncated(i, data.offset()));
                        };
                        if is_vertex {
                            if pi == ix {
                                xyz[0] = v;
                            } else if pi == iy {
                                xyz[1] = v;
                            } else if pi == iz {
                                xyz[2] = v;
                            }
                        }
                    }
                    Kind::List { count, item } => {
                        let at = data.offset();
                        let n = data.read(count).map_err(|t| not_a_number(t, &prop.name))?;
                        let Some(n) = n else {
                            return Err(truncated(i, data.offset()));
                        };
                        if !(n >= 0.0 && n.fract() == 0.0) {
                            let message = format!(
                                "invalid length {n} of list `{}` in `{}` {i}",
                                prop.name, el.name
                            );
                            return Err(match line {
                                Some(line) => ReadError::Parse { line, message },
                                None => ReadError::Corrupt {
                                    offset: (header.data_start + at) as u64,
                                    message,
                                },
                            });
                        }
                        let collect = is_face && Some(pi) == face_prop;
                        for _ in 0..n as u64 {
                            let v = data.read(item).map_err(|t| not_a_number(t, &prop.name))?;
                            let Some(v) = v else {
                                return Err(truncated(i, data.offset()));
                            };
                            if collect {
                                let face = builder.polygon_count();
                                let idx = if v.fract() == 0.0 && v.abs() < 9.0e18 {
                                    v as i64
                                } else {
                                    i64::MIN
                                };
                                poly.push(check_index(idx, idx, vertex_count, face, line)?);
                            }
                        }
                    }
                }
            }
            if is_vertex {
                builder.push_vertex(DVec3::from_array(xyz), line)?;
            } else if is_face {
                builder.push_polygon(&poly, line)?;
            }
        }
    }
    builder.finish()
}
