//! `quadcover solve MESH --symmetry 2|4|6 … --out UV.obj [--report REPORT.json]`: frame field
//! (computed, or read with `--field`), QuadCover, seamless per-corner UVs written in the input's
//! vertex and face order, and an optional JSON report. Progress per stage goes to stderr.

use std::collections::HashMap;
use std::path::PathBuf;
use std::time::Instant;

use crate::extract::{self, ExtractOptions, RemeshQuality, dual, remesh_report};
use clap::{Args, ValueEnum};
use indicatif::ProgressBar;
use serde::Serialize;
use std::io::Write;

use super::CliError;
use crate::field::{self, Density, FieldParams, Symmetry};
use crate::io;
use crate::mesh::TriMesh;
use crate::param::{self, ParamOptions, Rounding};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RoundingArg {
    Direct,
    Greedy,
}

#[derive(Debug, Args)]
pub struct SolveArgs {
    /// Mesh file (OBJ, PLY, OFF or STL).
    pub mesh: PathBuf,
    /// Rotational symmetry: 2 (stripes), 4 (quads) or 6 (hexagons).
    #[arg(long, default_value_t = 4)]
    pub symmetry: u32,
    /// Target number of grid vertices (sets the grid size).
    #[arg(long, conflicts_with = "scale")]
    pub target_vertices: Option<usize>,
    /// Grid size in model units (one texture unit).
    #[arg(long)]
    pub scale: Option<f64>,
    /// Weight of curvature alignment against smoothness (eq. 3.5–3.6).
    #[arg(long)]
    pub tau: Option<f64>,
    /// Fraction of the most reliable curvature directions kept as constraints.
    #[arg(long)]
    pub reliable_fraction: Option<f64>,
    /// Neighbour-averaging passes over the shape operators before the curvature directions are
    /// taken (default 5; 0 = the thesis's eq. 3.2 as is). More passes, fewer singularities on
    /// noisy scans.
    #[arg(long)]
    pub curvature_smoothing: Option<usize>,
    /// Cancel opposite-index singularity pairs closer than this many grid cells (sec. 3.3;
    /// default 1, 0 = keep the rounded field).
    #[arg(long)]
    pub cancel_pairs_within: Option<f64>,
    /// Round gaps to 2Z² so that singularities land on integer grid points (N = 2, 4).
    #[arg(long)]
    pub pure_quad: bool,
    /// Gap rounding: direct (thesis) or greedy (MIQ-style).
    #[arg(long, value_enum, default_value = "direct")]
    pub rounding: RoundingArg,
    /// Frame field JSON (`field::io` format) instead of computing one.
    #[arg(long)]
    pub field: Option<PathBuf>,
    /// Output OBJ with per-corner `vt`.
    #[arg(long)]
    pub out: PathBuf,
    /// Optional JSON report.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Also extract and write the remesh (quads for N = 4, triangles for N = 6, iso-line
    /// polylines for N = 2); its quality goes into the report's `remesh` block.
    #[arg(long)]
    pub remesh: Option<PathBuf>,
    /// With --symmetry 6 and --remesh: write the hexagon mesh (dual of the triangle remesh).
    #[arg(long, requires = "remesh")]
    pub dual: bool,
}

#[derive(Debug, Serialize)]
struct SingularityOut {
    vertex: usize,
    index: f64,
}

#[derive(Debug, Serialize)]
struct DistortionOut {
    mean: f64,
    p99: f64,
}

#[derive(Debug, Default, Serialize)]
struct TimingsOut {
    curvature: f64,
    smooth: f64,
    local: f64,
    cut: f64,
    global: f64,
    remesh: f64,
    total: f64,
}

#[derive(Debug, Serialize)]
struct Report {
    vertices: usize,
    faces: usize,
    genus: i64,
    boundary_loops: usize,
    symmetry: usize,
    singularities: Vec<SingularityOut>,
    cut_paths: usize,
    flipped_faces: usize,
    seam_max_error: f64,
    conformal_distortion: DistortionOut,
    area_distortion: f64,
    timings_ms: TimingsOut,
    #[serde(skip_serializing_if = "Option::is_none")]
    remesh: Option<RemeshQuality>,
}

/// Per-stage progress on stderr: a spinner naming the running stage on terminals (indicatif
/// draws nothing when stderr is not a terminal), and one plain line per finished stage always.
struct Progress(ProgressBar);

impl Progress {
    fn new() -> Progress {
        let bar = ProgressBar::new_spinner();
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        Progress(bar)
    }
    fn start(&self, stage: &str) {
        self.0.set_message(format!("{stage} ..."));
    }
    fn line(&self, text: String) {
        self.0.suspend(|| eprintln!("{text}"));
    }
    fn done(&self, stage: &str, t: Instant) -> f64 {
        let ms = t.elapsed().as_secs_f64() * 1e3;
        self.line(format!("  {stage:<10} {ms:9.1} ms"));
        ms
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

pub fn run(args: &SolveArgs) -> Result<(), CliError> {
    let total = Instant::now();
    let symmetry = Symmetry::from_n(args.symmetry)?;
    let n = args.symmetry as usize;
    if let Some(s) = args
        .scale
        .filter(|s| s.is_nan() || *s <= 0.0 || s.is_infinite())
    {
        return Err(format!("--scale must be positive, got {s}").into());
    }
    if args.target_vertices == Some(0) {
        return Err("--target-vertices must be positive".into());
    }
    if args.pure_quad && n == 6 {
        return Err("--pure-quad needs --symmetry 2 or 4".into());
    }
    eprintln!("quadcover solve {} (N = {n})", args.mesh.display());
    let bar = Progress::new();
    bar.start("load");
    let t = Instant::now();
    let soup = io::read_mesh(&args.mesh)?;
    let (mesh, repair) =
        TriMesh::from_soup(&soup).map_err(|e| format!("{}: {e}", args.mesh.display()))?;
    bar.done("load", t);
    let density = match (args.scale, args.target_vertices) {
        (Some(s), _) => Some(Density::EdgeLength(s)),
        (None, Some(v)) => Some(Density::TargetVertices(v)),
        _ => None,
    };
    let mut timings = TimingsOut::default();
    let opts = ParamOptions {
        rounding: match args.rounding {
            RoundingArg::Direct => Rounding::Direct,
            RoundingArg::Greedy => Rounding::Greedy,
        },
        pure_quad: args.pure_quad,
    };
    // With a computed field, QuadCover's factorizations start as soon as its matchings are final.
    let mut prepared = None;
    let field = match &args.field {
        Some(path) => {
            let t = Instant::now();
            let text =
                std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            let mut f = field::io::from_json(&text, &mesh)
                .map_err(|e| format!("{}: {e}", path.display()))?;
            if f.symmetry != symmetry {
                return Err(format!(
                    "{}: field has symmetry {}, --symmetry is {n}",
                    path.display(),
                    f.symmetry.n()
                )
                .into());
            }
            f.validate(&mesh)?;
            if let Some(d) = density {
                // Rescale so that the mean frame row length is 1/h.
                let h = field::density::grid_size(&mesh, &d, symmetry, &vec![1.0; mesh.n_faces()])?;
                let mean = f
                    .frames
                    .iter()
                    .map(|x| 0.5 * (x[0].length() + x[1].length()))
                    .sum::<f64>()
                    / f.frames.len() as f64;
                if mean.is_nan() || mean <= 0.0 {
                    return Err(format!("{}: frames have zero length", path.display()).into());
                }
                let k = 1.0 / (h * mean);
                for x in &mut f.frames {
                    x[0] *= k;
                    x[1] *= k;
                }
            }
            timings.smooth = bar.done("field", t);
            f
        }
        None => {
            let mut params = FieldParams {
                symmetry,
                ..Default::default()
            };
            if let Some(tau) = args.tau {
                params.tau = tau;
            }
            if let Some(r) = args.reliable_fraction {
                params.reliable_fraction = r;
            }
            if let Some(c) = args.curvature_smoothing {
                params.curvature_smoothing = c;
            }
            if let Some(c) = args.cancel_pairs_within {
                params.cancel_pairs_within = c;
            }
            if let Some(d) = density {
                params.density = d;
            }
            bar.start("frame field, then the QuadCover factorizations beside its last solve");
            let (fr, qc) = param::pipeline::field_then_quadcover(&mesh, &params, n, &opts)?;
            prepared = Some(qc);
            for (name, secs) in &fr.timings {
                if name.contains("curvature") {
                    timings.curvature += secs * 1e3;
                } else {
                    timings.smooth += secs * 1e3;
                }
            }
            bar.line(format!(
                "  {:<10} {:9.1} ms",
                "curvature", timings.curvature
            ));
            bar.line(format!("  {:<10} {:9.1} ms", "smooth", timings.smooth));
            fr.field
        }
    };
    bar.start("QuadCover: cut graph, local and global step");
    let qc = match prepared {
        Some(qc) => qc,
        None => param::QuadCover::new(&mesh, n, &field.matchings, opts)?,
    };
    let p = qc.solve(&mesh, &field.frames)?;
    timings.cut = p.timings.cut_ms;
    timings.local = p.timings.local_ms;
    timings.global = p.timings.global_ms;
    bar.line(format!("  {:<10} {:9.1} ms", "cut", timings.cut));
    bar.line(format!("  {:<10} {:9.1} ms", "local", timings.local));
    bar.line(format!("  {:<10} {:9.1} ms", "global", timings.global));

    // Back to the file's vertex and face order.
    bar.start("write");
    let t = Instant::now();
    let mut mesh_face_of_tri = vec![usize::MAX; soup.triangles.len()];
    for (f, &t) in repair.original_face.iter().enumerate() {
        mesh_face_of_tri[t as usize] = f;
    }
    let key = |tri: [u32; 3]| {
        let mut k = tri;
        k.sort_unstable();
        k
    };
    let by_vertices: HashMap<[u32; 3], usize> = (0..mesh.n_faces())
        .map(|f| {
            (
                key(mesh.faces()[f].map(|v| repair.original_vertex[v as usize])),
                f,
            )
        })
        .collect();
    let mut corner_uvs = Vec::with_capacity(3 * soup.triangles.len());
    for (t, tri) in soup.triangles.iter().enumerate() {
        let f = match mesh_face_of_tri[t] {
            usize::MAX => *by_vertices
                .get(&key(*tri))
                .ok_or_else(|| format!("triangle {t} was dropped and has no duplicate"))?,
            f => f,
        };
        let mv = mesh.face(f).map(|v| repair.original_vertex[v]);
        for &sv in tri {
            let k = mv
                .iter()
                .position(|&x| x == sv)
                .ok_or("face corner mapping failed")?;
            corner_uvs.push(p.uv[3 * f + k]);
        }
    }
    io::write::write_obj(
        &args.out,
        &io::write::ObjOutput::new(&soup.positions, &soup.triangles).with_uvs(&corner_uvs),
    )?;
    bar.done("write", t);
    let remesh = match &args.remesh {
        Some(path) => {
            bar.start("remesh");
            let t = Instant::now();
            let (mut remesh, mut quality) =
                remesh_report(&mesh, &p.uv, n as u8, &ExtractOptions::default())?;
            if args.dual && n == 6 {
                remesh = dual(&remesh);
                quality = extract::quality(&remesh, &mesh);
            }
            let out = io::write::ObjOutput::new(&remesh.positions, &remesh.faces)
                .with_polylines(&remesh.polylines);
            io::write::write_obj(path, &out)?;
            timings.remesh = bar.done("remesh", t);
            Some(quality)
        }
        None => None,
    };
    timings.total = total.elapsed().as_secs_f64() * 1e3;
    let topo = mesh.topology();
    bar.line(format!(
        "  {} singularities, {} cut paths, {} flipped faces, seam error {:.1e}, conformal distortion {:.3} (p99 {:.3})",
        p.singularities.len(),
        p.cut_paths.len(),
        p.flipped_faces,
        p.seam_max_error,
        p.conformal_distortion.mean,
        p.conformal_distortion.p99
    ));
    if let Some(path) = &args.report {
        let report = Report {
            vertices: soup.positions.len(),
            faces: soup.triangles.len(),
            genus: topo.genus,
            boundary_loops: topo.boundary_loops,
            symmetry: n,
            singularities: p
                .singularities
                .iter()
                .map(|s| SingularityOut {
                    vertex: repair.original_vertex[s.vertex] as usize,
                    index: s.index,
                })
                .collect(),
            cut_paths: p.cut_paths.len(),
            flipped_faces: p.flipped_faces,
            seam_max_error: p.seam_max_error,
            conformal_distortion: DistortionOut {
                mean: p.conformal_distortion.mean,
                p99: p.conformal_distortion.p99,
            },
            area_distortion: p.area_distortion,
            timings_ms: timings,
            remesh: remesh.clone(),
        };
        let json = serde_json::to_string_pretty(&report)?;
        io::write::write_atomic(path, |w| w.write_all(json.as_bytes()))?;
    }
    Ok(())
}
