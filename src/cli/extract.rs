//! `quadcover extract UV.obj --symmetry 4|6|2 --out OUT.obj [--report R.json] [--dual]`:
//! remeshing from a seamless parameterization given as an OBJ with per-corner UVs.

use std::path::PathBuf;

use clap::Args;

use super::CliError;
use crate::extract::{ExtractOptions, dual, quality, remesh_report};
use crate::io::{ObjOutput, read_obj_bytes, write_obj};
use crate::mesh::TriMesh;
use crate::param::{FileQuad, poles_from_quads};

#[derive(Debug, Args)]
pub struct ExtractArgs {
    /// OBJ file with per-corner texture coordinates (`f v/vt ...`).
    pub mesh: PathBuf,
    /// Symmetry of the parameterization: 4 (quads), 6 (triangles / hexagons), 2 (stripes).
    #[arg(long, default_value_t = 4)]
    pub symmetry: u8,
    /// Output OBJ (polygons, or `l` polylines for stripes).
    #[arg(long)]
    pub out: PathBuf,
    /// Write the quality report as JSON here too.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// For --symmetry 6: write the hexagon mesh (dual of the triangle mesh).
    #[arg(long)]
    pub dual: bool,
    /// Split every face of a quad extraction into four (half the edge length).
    #[arg(long, alias = "pure-quad")]
    pub split_to_quads: bool,
    /// Keep the polygons extraction leaves (cells cut by the boundary, off-lattice
    /// singularities, fold patches) instead of making the output pure quads / triangles.
    #[arg(long)]
    pub no_pure: bool,
    /// Leave the vertices where the map puts them (no tangential relaxation on the surface).
    #[arg(long)]
    pub no_relax: bool,
}

pub fn run(args: &ExtractArgs) -> Result<(), CliError> {
    let bytes = std::fs::read(&args.mesh)
        .map_err(|e| format!("{}: cannot read: {e}", args.mesh.display()))?;
    use crate::io::Format;
    // Only an OBJ carries per-corner texture coordinates: a PLY's or STL's text read as one
    // gave "the file contains no vertices".
    if let Some(f) = Format::from_path(&args.mesh)
        .or_else(|| Format::sniff(&bytes))
        .filter(|f| *f != Format::Obj)
    {
        return Err(format!(
            "{}: this is {f}; `extract` reads an OBJ with per-corner texture coordinates (`vt`), \
             as `solve --out` writes",
            args.mesh.display()
        )
        .into());
    }
    let data = read_obj_bytes(&bytes).map_err(|e| format!("{}: {e}", args.mesh.display()))?;
    let Some(corner_uvs) = data.corner_uvs else {
        return Err(format!(
            "{}: no per-corner texture coordinates (every face corner needs a `vt` index)",
            args.mesh.display()
        )
        .into());
    };
    if let Some(c) = corner_uvs
        .iter()
        .position(|uv| !uv.iter().all(|x| x.is_finite()))
    {
        return Err(format!(
            "{}: a texture coordinate of {} is not finite",
            args.mesh.display(),
            data.soup.describe_triangle(c / 3)
        )
        .into());
    }
    let (mesh, repair) =
        TriMesh::from_soup(&data.soup).map_err(|e| format!("{}: {e}", args.mesh.display()))?;
    // Map the file's triangles to the mesh's faces (repairs may drop or re-orient triangles).
    let mut uv = Vec::with_capacity(3 * mesh.n_faces());
    for f in 0..mesh.n_faces() {
        let t = repair.original_face[f] as usize;
        let src = data.soup.triangles[t];
        for &v in &mesh.faces()[f] {
            let ov = repair.original_vertex[v as usize] as usize;
            let k = src.iter().position(|&x| x as usize == ov).unwrap_or(0);
            uv.push(corner_uvs[3 * t + k]);
        }
    }
    // Star faces written as pole quads (a b p p): the poles of the map.
    let mut face_of_triangle = vec![usize::MAX; data.soup.triangles.len()];
    for (f, &t) in repair.original_face.iter().enumerate() {
        face_of_triangle[t as usize] = f;
    }
    let mut file_vertex = vec![usize::MAX; data.soup.positions.len()];
    for (v, &o) in repair.original_vertex.iter().enumerate() {
        file_vertex[o as usize] = v;
    }
    let quads: Vec<FileQuad> = data
        .pole_quads
        .iter()
        .filter(|q| face_of_triangle[q.triangle] != usize::MAX)
        .map(|q| FileQuad {
            face: face_of_triangle[q.triangle],
            vertices: data.soup.triangles[q.triangle].map(|v| file_vertex[v as usize]),
            uv: q.uv,
        })
        .collect();
    let poles =
        poles_from_quads(&mesh, &quads).map_err(|e| format!("{}: {e}", args.mesh.display()))?;
    let opts = ExtractOptions {
        poles,
        split_to_quads: args.split_to_quads,
        pure: !args.no_pure,
        relax: (!args.no_relax).then(Default::default),
        ..Default::default()
    };
    let (mut remesh, mut q) = remesh_report(&mesh, &uv, args.symmetry, &opts)?;
    if args.dual && args.symmetry == 6 {
        remesh = dual(&remesh);
        q = quality(&remesh, &mesh);
    }
    let out = ObjOutput::new(&remesh.positions, &remesh.faces).with_polylines(&remesh.polylines);
    write_obj(&args.out, &out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    println!("{q}");
    if let Some(path) = &args.report {
        let json = serde_json::to_string_pretty(&q)?;
        crate::io::write_atomic(path, |w| std::io::Write::write_all(w, json.as_bytes()))?;
    }
    Ok(())
}
