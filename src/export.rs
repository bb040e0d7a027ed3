//! Exports of a parameterized mesh, shared by the editor and the command line: the mesh with
//! per-corner UVs, and the remesh extracted from them. Saves are atomic (see `io::write`).

use std::collections::HashMap;
use std::path::Path;

use thiserror::Error;

use crate::extract::{self, ExtractError, ExtractOptions, RemeshQuality};
use crate::io::WriteError;
use crate::io::write::{ObjOutput, write_obj};
use crate::mesh::TriMesh;
use crate::param::Pole;

#[derive(Debug, Error)]
pub enum ExportError {
    #[error(transparent)]
    Write(#[from] WriteError),
    #[error("remeshing failed: {0}")]
    Extract(#[from] ExtractError),
}

/// Writes `mesh` as OBJ with per-corner UVs (`uv[3f + k]`); corners with bitwise equal UVs at a
/// vertex share one `vt`, so the map stays visibly continuous away from the cuts. The star faces
/// of `poles` are written as their quads ([`pole_quads`]); vertices and other faces keep the
/// mesh's order.
pub fn write_uv_obj(
    path: &Path,
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    poles: &[Pole],
) -> Result<(), ExportError> {
    let (faces, corner_uvs) = uv_polygons(mesh.faces(), uv, poles, |f| f, |v| v);
    write_obj(
        path,
        &ObjOutput::new(mesh.positions(), &faces).with_uvs(&corner_uvs),
    )?;
    Ok(())
}

/// Per star face of `poles`: its quad (a_j, a_{j+1}, p, p) as mesh vertices, with the quad's
/// texture coordinates (eq. 4.3). In OBJ the pole vertex appears twice, for the two inner
/// corners q_{j+1}, q_j that coincide with it, each with its own `vt`.
pub fn pole_quads(poles: &[Pole]) -> HashMap<usize, ([u32; 4], [[f64; 2]; 4])> {
    let mut out = HashMap::new();
    for p in poles {
        let d = p.ring.len();
        for (j, &f) in p.faces.iter().enumerate() {
            let (a, b, c) = (
                p.ring[j] as u32,
                p.ring[(j + 1) % d] as u32,
                p.vertex as u32,
            );
            out.insert(f, ([a, b, c, c], p.quads[j]));
        }
    }
    out
}

/// The polygons to write for output triangles `triangles` with per-corner UVs `uv` (`3t + k`):
/// `face_of(t)` names the mesh face triangle t shows, `vertex(v)` the output index of mesh
/// vertex v; triangles showing a star face become its pole quad, the rest stay as they are.
pub fn uv_polygons(
    triangles: &[[u32; 3]],
    uv: &[[f64; 2]],
    poles: &[Pole],
    face_of: impl Fn(usize) -> usize,
    vertex: impl Fn(u32) -> u32,
) -> (Vec<Vec<u32>>, Vec<[f64; 2]>) {
    let quads = pole_quads(poles);
    let mut faces = Vec::with_capacity(triangles.len());
    let mut corner_uvs = Vec::with_capacity(uv.len());
    for (t, tri) in triangles.iter().enumerate() {
        match quads.get(&face_of(t)) {
            Some((q, quv)) => {
                faces.push(q.iter().map(|&v| vertex(v)).collect());
                corner_uvs.extend_from_slice(quv);
            }
            None => {
                faces.push(tri.to_vec());
                corner_uvs.extend_from_slice(&uv[3 * t..3 * t + 3]);
            }
        }
    }
    (faces, corner_uvs)
}

/// Extracts the remesh of a seamless parameterization of symmetry `n` — quads (N = 4),
/// triangles or with `dual` hexagons (N = 6), iso-line polylines (N = 2) — writes it as OBJ and
/// returns its quality.
pub fn write_remesh(
    path: &Path,
    mesh: &TriMesh,
    uv: &[[f64; 2]],
    poles: &[Pole],
    n: u8,
    dual: bool,
) -> Result<RemeshQuality, ExportError> {
    let opts = ExtractOptions {
        poles: poles.to_vec(),
        ..Default::default()
    };
    let (mut remesh, mut quality) = extract::remesh_report(mesh, uv, n, &opts)?;
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
        write_uv_obj(&path, &mesh, &uv, &[]).unwrap();
        let back = read_obj_bytes(&std::fs::read(&path).unwrap()).unwrap();
        assert_eq!(back.corner_uvs.as_deref(), Some(uv.as_slice()));
        assert_eq!(back.soup.triangles, mesh.faces());

        let path = dir.path().join("quads.obj");
        let q = write_remesh(&path, &mesh, &uv, &[], 4, false).unwrap();
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
