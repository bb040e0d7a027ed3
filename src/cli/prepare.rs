//! `quadcover prepare MESH --out OUT`: the input remeshed isotropically, its sharp features and
//! boundary kept (`mesh::isotropic`). For raw CAD tessellations (STL needles, fanned caps), on
//! which the field has nothing to follow and the map folds; `solve` does the same by itself when
//! [`needs_remesh`] says so.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;

use super::CliError;
use crate::io::{self, ObjOutput};
use crate::load::load_mesh;
use crate::mesh::isotropic::{
    IsotropicOptions, isotropic_remesh, needle_area_share, prepared_options,
};

pub use crate::mesh::isotropic::PREPARED_FEATURE_ANGLE as DEFAULT_FEATURE_ANGLE;

#[derive(Debug, Args)]
pub struct PrepareArgs {
    /// Mesh file (OBJ, PLY, OFF or STL).
    pub mesh: PathBuf,
    /// Output OBJ.
    #[arg(long)]
    pub out: PathBuf,
    /// About this many vertices (default 20000, or the input's count if it has more).
    #[arg(long, conflicts_with = "edge_length")]
    pub vertices: Option<usize>,
    /// Target edge length in model units.
    #[arg(long)]
    pub edge_length: Option<f64>,
    /// Edges sharper than this dihedral angle (degrees) are kept as features (default 35).
    #[arg(long, default_value_t = DEFAULT_FEATURE_ANGLE)]
    pub features: f64,
}

pub fn run(args: &PrepareArgs) -> Result<(), CliError> {
    if args.vertices == Some(0) {
        return Err("--vertices must be positive".into());
    }
    if let Some(l) = args.edge_length.filter(|l| !(l.is_finite() && *l > 0.0)) {
        return Err(format!("--edge-length must be positive, got {l}").into());
    }
    if !(args.features.is_finite() && (0.0..=180.0).contains(&args.features)) {
        return Err(format!(
            "--features must be an angle in [0, 180], got {}",
            args.features
        )
        .into());
    }
    let loaded = load_mesh(&args.mesh)?;
    let mesh = &loaded.mesh;
    let mut opts = match args.vertices {
        Some(v) => IsotropicOptions::for_vertices(mesh, v, args.features),
        None => prepared_options(mesh, None, args.features),
    };
    if let Some(l) = args.edge_length {
        opts.edge_length = l;
    }
    let t = Instant::now();
    let out = isotropic_remesh(mesh, &opts)
        .map_err(|e| format!("{}: remeshing failed: {e}", args.mesh.display()))?;
    eprintln!(
        "{}: {} vertices, {} faces ({:.0} % of the area in needles) -> {} vertices, {} faces \
         ({:.0} %), edge length {:.4}, features above {}°, {:.0} ms",
        args.mesh.display(),
        mesh.n_vertices(),
        mesh.n_faces(),
        100.0 * needle_area_share(mesh),
        out.n_vertices(),
        out.n_faces(),
        100.0 * needle_area_share(&out),
        opts.edge_length,
        args.features,
        t.elapsed().as_secs_f64() * 1e3
    );
    io::write_obj(&args.out, &ObjOutput::new(out.positions(), out.faces()))?;
    Ok(())
}
