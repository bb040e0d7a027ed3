//! Reading a mesh file into a validated [`TriMesh`]: the reader, then validation and safe repairs.

use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::io::{self, ReadError};
use crate::mesh::{MeshError, RepairReport, TriMesh};

/// Why a file could not be opened as a mesh.
#[derive(Debug, Error)]
pub enum LoadError {
    #[error("{path}: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: ReadError,
    },
    #[error("{path}: {source}")]
    Invalid {
        path: PathBuf,
        #[source]
        source: MeshError,
    },
}

/// A mesh as loaded from a file, with the repairs and remarks that came with it.
#[derive(Clone, Debug)]
pub struct LoadedMesh {
    pub mesh: TriMesh,
    pub report: RepairReport,
    /// Vertex count of the file (including vertices the mesh dropped), for writing back in order.
    pub file_vertices: usize,
    /// Triangle count of the file after triangulation.
    pub file_triangles: usize,
}

/// A mesh of `../shared/meshes/` for unit tests, or `None` (with a note) when it is missing.
#[cfg(test)]
pub(crate) fn shared_test_mesh(name: &str) -> Option<TriMesh> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/meshes")
        .join(name);
    match load_mesh(&path) {
        Ok(loaded) => Some(loaded.mesh),
        Err(_) => {
            eprintln!("skipped: {} is missing", path.display());
            None
        }
    }
}

/// Reads, validates and repairs a mesh file (OBJ, PLY, OFF or STL).
pub fn load_mesh(path: &Path) -> Result<LoadedMesh, LoadError> {
    let soup = io::read_mesh(path).map_err(|source| LoadError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let (mesh, report) = TriMesh::from_soup(&soup).map_err(|source| LoadError::Invalid {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(LoadedMesh {
        mesh,
        report,
        file_vertices: soup.positions.len(),
        file_triangles: soup.triangles.len(),
    })
}
