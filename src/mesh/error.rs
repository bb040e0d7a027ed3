//! Errors for meshes that cannot be repaired safely. Each names the count and the first offender.

use thiserror::Error;

/// A mesh that cannot be turned into a manifold, oriented triangle mesh without guessing.
///
/// Locations (`at`) are human-readable and point into the source file where possible,
/// e.g. "face 17 (line 42)".
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MeshError {
    #[error("empty mesh: {0}")]
    Empty(String),
    #[error(
        "{count} face(s) reference a vertex that does not exist; first: {at} uses vertex {index} of {vertex_count}"
    )]
    IndexOutOfRange {
        count: usize,
        at: String,
        index: u32,
        vertex_count: usize,
    },
    #[error("{count} vertex coordinate(s) are NaN or infinite; first: {at}")]
    NonFinite { count: usize, at: String },
    #[error(
        "{count} vertex coordinate(s) beyond ±1e75, where face areas overflow; first: {at} (scale the model down)"
    )]
    Huge { count: usize, at: String },
    #[error("{count} degenerate face(s) (zero area or a repeated vertex); first: {at}")]
    DegenerateFace { count: usize, at: String },
    #[error(
        "{count} non-manifold edge(s) (more than two faces); first: edge between vertices {v0} and {v1}, shared by {faces} faces including {at}"
    )]
    NonManifoldEdge {
        count: usize,
        v0: usize,
        v1: usize,
        faces: usize,
        at: String,
    },
    #[error(
        "{count} non-manifold vertex(es) (faces around it form {fans} separate fans); first: {at}"
    )]
    NonManifoldVertex {
        count: usize,
        at: String,
        fans: usize,
    },
    #[error(
        "non-orientable surface (a Möbius-like band): component {component} cannot be oriented consistently; the conflict shows at {at}"
    )]
    NonOrientable { component: usize, at: String },
    #[error(
        "remeshing at edge length {edge_length:.3e} would make about {vertices:.2e} vertices, more than the limit of {limit:.0e}: ask for a longer edge length (or fewer target vertices)"
    )]
    TooLarge {
        edge_length: f64,
        vertices: f64,
        limit: f64,
    },
}
