//! `quadcover info MESH`: statistics and validation remarks of a mesh file.

use std::path::PathBuf;

use clap::Args;

use super::CliError;
use crate::load::load_mesh;
use crate::mesh::isotropic::{NEEDLE_AREA_SHARE, NEEDLE_DEG, needle_area_share};

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Mesh file (OBJ, PLY, OFF or STL).
    pub mesh: PathBuf,
    /// Print the statistics as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &InfoArgs) -> Result<(), CliError> {
    let loaded = load_mesh(&args.mesh)?;
    let topology = loaded.mesh.topology();
    let needles = needle_area_share(&loaded.mesh);
    // Against the default grid (`solve` checks its own density).
    let params = crate::edit::Settings::default().field_params();
    let coarse = crate::mesh::isotropic::too_coarse(&loaded.mesh, &params.density, params.symmetry)
        .is_some();
    let long_needles =
        crate::mesh::isotropic::long_needles(&loaded.mesh, &params.density, params.symmetry);
    if args.json {
        let value = serde_json::json!({
            "file": args.mesh,
            "file_vertices": loaded.file_vertices,
            "topology": topology,
            "needle_area_share": needles,
            "coarse": coarse,
            "long_needle_area_share": long_needles,
            "warnings": loaded.report.warnings,
        });
        println!("{}", serde_json::to_string_pretty(&value)?);
        return Ok(());
    }
    println!("file            {}", args.mesh.display());
    if loaded.file_vertices != topology.vertices {
        println!("file vertices   {}", loaded.file_vertices);
    }
    println!("{topology}");
    let (lo, hi) = loaded.mesh.bounding_box();
    println!("bounding box    {:?} .. {:?}", lo.to_array(), hi.to_array());
    println!("mean edge       {:.6}", loaded.mesh.mean_edge_length());
    print!(
        "needles         {:.1} % of the area (triangles with a corner under {}°)",
        100.0 * needles,
        NEEDLE_DEG
    );
    if needles > NEEDLE_AREA_SHARE {
        println!(": a raw tessellation; `solve` remeshes it first (`quadcover prepare`)");
    } else if let Some(share) = long_needles {
        println!(
            ", {:.1} % in needles longer than {} cells of the default grid (fans across flat \
             faces); `solve` remeshes it first (`quadcover prepare`)",
            100.0 * share,
            crate::mesh::isotropic::LONG_NEEDLE_CELLS
        );
    } else {
        println!();
    }
    if coarse {
        println!(
            "low-poly        far fewer vertices than the default grid's: `solve` remeshes it \
             first (`quadcover prepare`)"
        );
    }
    let fans = crate::mesh::isotropic::fan_centres(&loaded.mesh);
    if !fans.is_empty() {
        println!(
            "fan centres     {} flat vertices with {} or more triangles (fans as CAD \
             tessellators and UV spheres make): poles there cannot split; `solve --prepare` \
             remeshes them",
            fans.len(),
            crate::mesh::isotropic::FAN_VALENCE
        );
    }
    if loaded.report.warnings.is_empty() {
        println!("warnings        none");
    } else {
        println!("warnings        {}", loaded.report.warnings.len());
        for w in &loaded.report.warnings {
            println!("  - {w}");
        }
    }
    Ok(())
}
