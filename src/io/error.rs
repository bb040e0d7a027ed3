//! Errors of the mesh readers and writers.
//!
//! Every message names what is wrong and where: 1-based file line numbers for text formats,
//! element indices or byte offsets for binary data. Face and vertex indices in messages are the
//! 0-based positions of the face / vertex in the file (the `index` of an out-of-range reference is
//! printed as written in the file, e.g. 1-based or negative for OBJ). Only `Io` carries the path:
//! callers that show other errors should prefix the file name themselves.

use std::path::PathBuf;

/// Why a mesh file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be read at all.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// No vertices, or vertices but no faces.
    #[error("{}", empty_message(*vertices))]
    Empty { vertices: usize },
    /// The data ends before the header's / the records' announced size.
    #[error("file is truncated: expected {expected} {what}, found only {found}")]
    Truncated {
        what: String,
        expected: u64,
        found: u64,
    },
    /// A text line that does not parse.
    #[error("line {line}: {message}")]
    Parse { line: usize, message: String },
    /// Binary data that is present but invalid (e.g. a negative list length).
    #[error("byte offset {offset}: {message}")]
    Corrupt { offset: u64, message: String },
    /// A face refers to a vertex that does not exist.
    #[error(
        "face {face}{}: vertex index {index} is out of range (the file has {vertex_count} vertices)",
        at_line(*line)
    )]
    IndexOutOfRange {
        face: usize,
        line: Option<usize>,
        index: i64,
        vertex_count: usize,
    },
    /// A vertex coordinate is NaN or infinite (or overflows to infinity, like `1e999`).
    #[error("vertex {vertex}{}: coordinate is not a finite number", at_line(*line))]
    NonFinite { vertex: usize, line: Option<usize> },
    /// A valid file in a variant this reader does not support, or an unknown format.
    #[error("unsupported {format} file: {detail}")]
    UnsupportedEncoding { format: String, detail: String },
    /// A polygon with fewer than 3 vertices.
    #[error(
        "face {face}{}: a polygon needs at least 3 vertices, this one has {count}",
        at_line(*line)
    )]
    FaceTooSmall {
        face: usize,
        line: Option<usize>,
        count: usize,
    },
}

fn empty_message(vertices: usize) -> String {
    if vertices == 0 {
        "the file contains no vertices".to_string()
    } else {
        format!("the file contains {vertices} vertices but no faces")
    }
}

fn at_line(line: Option<usize>) -> String {
    match line {
        Some(l) => format!(" (line {l})"),
        None => String::new(),
    }
}

/// Why a mesh could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    #[error("cannot write {}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The data given to the writer is inconsistent (bad index, UV count, non-finite value).
    #[error("invalid mesh data: {0}")]
    Invalid(String),
}
