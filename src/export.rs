//! Exports of a parameterized mesh, shared by the editor and the command line: the mesh with
//! per-corner UVs, and the remesh extracted from them. Saves are atomic (see `io::write`).

use std::path::Path;

use thiserror::Error;

use crate::extract::{self, ExtractError, ExtractOptions, RemeshQuality};
use crate::io::WriteError;
use crate::io::write::{ObjOutput, write_obj};
use crate::mesh::TriMesh;

#[derive(Debug, Error)]
pub enum ExportError {
    #[error(transparent)]
    Write(#[from] WriteError),
    #[error("remeshing failed: {0}")]
    Extract(#[from] ExtractError),
}

/// Writes `mesh` as OBJ with per-corner UVs (`uv[3f + k]`); corners with bitwise equal UVs at a
/// vertex share one `vt`, so the map stays visibly continuous away from the cuts.
pub fn write_uv_obj(path: &Path, mesh: &TriMesh, uv: &[[f64; 2]]) -> Result<(), ExportError> {
    write_obj(
        path,
        &ObjOutput::new(mesh.positions(), mesh.faces()).with_uvs(uv),
    )?;
    Ok(())
}

/// Extracts the remesh of a seamless parameterization of symmetry `n` — quads (N = 4),
/// triangles or with `dual` hexagons (N = 6), iso-line polylines (N = 2) — writes it as OBJ and
/// returns its quality.
pub fn write_remesh(
    path: &Path,
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    n: u8,
    dual: bool,
) -> Result<RemeshQuality, ExportError> {
    let (mut remesh, mut quality) =
        extract::remesh_report(mesh, uv, n, &ExtractOptions::default())?;
    if dual && n == 6 {
        remesh = extract::dual(&remesh);
        quality = extract::quality(&remesh, mesh);
    }
    let out = ObjOutput::new(&remesh.positions, &remesh.faces).with_polylines(&remesh.polylines);
    write_obj(path, &out)?;
    Ok(quality)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::read_obj_bytes;
    use crate::mesh::generate::grid;

    #[test]
    fn uv_obj_and_remesh_of_a_flat_grid_read_back() {
        let mesh = grid(6, 6, 3.0, 3.0);
        // UV = position: a seamless map with grid unit 1, so a 3 × 3 quad remesh.
        let uv: Vec<[f64; 2]> = (0..3 * mesh.n_faces())
            .map(|c| {
                let p = mesh.position(mesh.from(c));
                [p.x, p.y]
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("uv.obj");
        write_uv_obj(&path, &mesh, &uv).unwrap();
        let back = read_obj_bytes(&std::fs::read(&path).unwrap()).unwrap();
        assert_eq!(back.corner_uvs.as_deref(), Some(uv.as_slice()));
        assert_eq!(back.soup.triangles, mesh.faces());

        let path = dir.path().join("quads.obj");
        let q = write_remesh(&path, &mesh, &uv, 4, false).unwrap();
        assert_eq!((q.vertices, q.irregular_vertices), (16, 0));
        let text = std::fs::read_to_string(&path).unwrap();
        let faces: Vec<&str> = text.lines().filter(|l| l.starts_with("f ")).collect();
        assert_eq!(faces.len(), 9);
        assert!(
            faces.iter().all(|f| f.split_whitespace().count() == 5),
            "all quads"
        );
    }
}
