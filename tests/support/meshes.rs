//! The shared test meshes (../shared/meshes, read-only beside the repository) and an edit base
//! on one, for the core's tests (included with `#[path]`, like `seams.rs`).
#![allow(dead_code)] // each test file uses what it needs

use std::path::{Path, PathBuf};
use std::sync::Arc;

use quadcover::edit::{Base, Settings};

pub const MESHES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/meshes");

/// The shared mesh `name`, or `None` with a message when the folder is missing.
pub fn shared(name: &str) -> Option<PathBuf> {
    let p = Path::new(MESHES).join(name);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipping: {} not found", p.display());
        None
    }
}

/// Every shared mesh but igea (269 k triangles: too slow for every test run).
pub const EVERY_BUT_IGEA: [&str; 9] = [
    "spot.obj",
    "kitten.obj",
    "eight.obj",
    "fertility.obj",
    "fandisk.obj",
    "camelhead.obj",
    "max-planck.obj",
    "bunny.obj",
    "cerebral-vessels.obj",
];

/// The shared mesh `name`, loaded, or `None` with a message when the folder is missing.
pub fn load_shared(name: &str) -> Option<quadcover::mesh::TriMesh> {
    Some(quadcover::load::load_mesh(&shared(name)?).unwrap().mesh)
}

/// An edit base on a mesh file, with the file's vertex numbering.
pub fn base_for(path: &Path, settings: Settings) -> Base {
    let loaded = quadcover::load::load_mesh(path).unwrap();
    Base::new(
        Arc::new(loaded.mesh),
        loaded.report.original_vertex,
        loaded.file_vertices,
        settings,
        &quadcover::edit::never,
    )
    .unwrap()
}
