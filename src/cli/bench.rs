//! `quadcover bench`: per-stage time and peak memory of the pipeline on meshes of about 10k,
//! 100k and 1M triangles (shared meshes, subdivided in memory), printed as a table.
//! Benchmarks measure; they never assert.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;

use super::CliError;
use crate::edit::{Base, Edit, Settings};
use crate::extract::{ExtractOptions, remesh_report};
use crate::field::{FieldParams, compute_field};
use crate::load::load_mesh;
use crate::mesh::TriMesh;
use crate::mesh::generate::subdivide;
use crate::param::pipeline::field_then_quadcover;
use crate::param::{ParamOptions, QuadCover, Rounding};

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Folder with the shared test meshes.
    #[arg(long, default_value = "../shared/meshes")]
    pub meshes: PathBuf,
    /// Largest size to run: 10k, 100k or 1m.
    #[arg(long, default_value = "1m")]
    pub up_to: String,
    /// Run only the benchmark meshes whose name contains this (e.g. "x16"), each `--repeat`
    /// times, and skip the remesh comparison: for comparing runs on a noisy machine.
    #[arg(long)]
    pub only: Option<String>,
    /// Runs per mesh (with --only).
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    /// Print only the remesh comparison table (no stage timings).
    #[arg(long)]
    pub remesh_only: bool,
}

/// Peak resident memory of this process in MiB since the last [`reset_peak_memory`]
/// (Linux `VmHWM`; 0 where /proc is not available).
pub fn peak_memory_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kib| kib / 1024.0)
}

/// Resets the peak-memory mark (Linux: writing 5 to /proc/self/clear_refs).
pub fn reset_peak_memory() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// One row of the table: a stage, its seconds and the peak memory while it ran.
pub struct Row {
    pub mesh: String,
    pub triangles: usize,
    pub stage: String,
    pub seconds: f64,
    pub peak_mib: f64,
}

/// Times `f` and records the peak memory it reached.
pub fn measure<T>(
    rows: &mut Vec<Row>,
    mesh: &str,
    triangles: usize,
    stage: &str,
    f: impl FnOnce() -> T,
) -> T {
    reset_peak_memory();
    let t = Instant::now();
    let out = f();
    rows.push(Row {
        mesh: mesh.into(),
        triangles,
        stage: stage.into(),
        seconds: t.elapsed().as_secs_f64(),
        peak_mib: peak_memory_mib(),
    });
    out
}

/// The benchmark meshes as (name, file, 1:4 subdivisions): ~10k fandisk (13k); ~100k spot ×16
/// (94k) and the bunny (69k); ~1M bunny ×16 (1.1M). Each is loaded only when its turn comes, so
/// the peak-memory column is not inflated by the larger ones.
fn bench_meshes(args: &BenchArgs) -> Vec<(&'static str, &'static str, usize)> {
    let mut out = vec![("fandisk", "fandisk.obj", 0)];
    let big = args.up_to.to_lowercase();
    if big == "100k" || big == "1m" {
        out.push(("spot x16", "spot.obj", 2));
        out.push(("bunny", "bunny.obj", 0));
    }
    if big == "1m" {
        out.push(("bunny x16", "bunny.obj", 2));
    }
    out
}

pub fn run(args: &BenchArgs) -> Result<(), CliError> {
    if args.remesh_only {
        return remesh_comparison(args);
    }
    let mut rows = Vec::new();
    for (name, file, subdivisions) in bench_meshes(args) {
        if args
            .only
            .as_ref()
            .is_some_and(|o| !name.contains(o.as_str()))
        {
            continue;
        }
        let mut mesh = load_mesh(&args.meshes.join(file))?.mesh;
        for _ in 0..subdivisions {
            mesh = subdivide(&mesh);
        }
        eprintln!("bench: {name} ({} triangles)", mesh.n_faces());
        let runs = if args.only.is_some() {
            args.repeat.max(1)
        } else {
            1
        };
        for _ in 0..runs {
            stages(&mut rows, name, &mesh)?;
        }
    }
    print_table(&rows);
    if args.only.is_none() {
        remesh_comparison(args)?;
        relax_comparison(args)?;
        constraint_costs(args)?;
    }
    Ok(())
}

/// What constraint curves cost (thesis sec. 4.4): fandisk with its sharp features and the bunny
/// with its boundary aligned, beside the same solve without curves: the field designed with the
/// curves, QuadCover's factorizations, and the solve; of the solve, the global step (under
/// curves: tracing, integer elimination and the constrained global step, which has its own
/// factorization) and the injectivity repair with its re-roundings and finer tries.
fn constraint_costs(args: &BenchArgs) -> Result<(), CliError> {
    println!();
    println!(
        "{:<34} {:>8} {:>10} {:>12} {:>10} {:>10} {:>10} {:>8} {:>8}",
        "constraints (N = 4, defaults)",
        "curves",
        "field ms",
        "factor. ms",
        "global ms",
        "repair ms",
        "solve ms",
        "flipped",
        "p99"
    );
    for (file, edit, label) in [
        (
            "fandisk.obj",
            Edit::DetectFeatures { angle_deg: 40.0 },
            "features 40 deg",
        ),
        (
            "bunny.obj",
            Edit::AlignBoundary { on: true },
            "aligned boundary",
        ),
    ] {
        let loaded = load_mesh(&args.meshes.join(file))?;
        let base = Base::new(
            std::sync::Arc::new(loaded.mesh),
            loaded.report.original_vertex,
            loaded.file_vertices,
            Settings::default(),
            &crate::edit::never,
        )?;
        let s0 = base.initial().clone();
        let t = std::time::Instant::now();
        let s1 = base.apply(&s0, &edit, &crate::edit::never)?;
        let design_ms = t.elapsed().as_secs_f64() * 1e3;
        for (what, state, field_ms) in [("without curves", &s0, f64::NAN), (label, &s1, design_ms)]
        {
            let name = format!("{} {}", file.trim_end_matches(".obj"), what);
            constraint_row(&name, &base, state, field_ms)?;
        }
    }
    // A raw CAD tessellation (needles, caps fanned from a rim vertex): remeshed first, as
    // `solve` does by itself (`mesh::isotropic`), then its features at 40°.
    use crate::mesh::isotropic::{PREPARED_FEATURE_ANGLE, isotropic_remesh, prepared_options};
    let raw = crate::mesh::generate::raw_cylinder(0.5, 1.2, 48);
    let t = std::time::Instant::now();
    let opts = prepared_options(&raw, None, PREPARED_FEATURE_ANGLE);
    let mesh = isotropic_remesh(&raw, &opts)?;
    let prepare_ms = t.elapsed().as_secs_f64() * 1e3;
    let base = Base::for_mesh(std::sync::Arc::new(mesh), Settings::default())?;
    let s0 = base.initial().clone();
    let t = std::time::Instant::now();
    let s1 = base.apply(
        &s0,
        &Edit::DetectFeatures { angle_deg: 40.0 },
        &crate::edit::never,
    )?;
    let design_ms = t.elapsed().as_secs_f64() * 1e3;
    constraint_row("raw cylinder remeshed, features 40", &base, &s1, design_ms)?;
    println!(
        "  (the raw cylinder: 96 vertices, remeshed to {} in {prepare_ms:.0} ms)",
        base.mesh().n_vertices()
    );
    Ok(())
}

/// One row of the constraint table: `state` solved on `base`, with the field design's time.
fn constraint_row(
    name: &str,
    base: &Base,
    state: &crate::edit::EditState,
    field_ms: f64,
) -> Result<(), CliError> {
    let solved = base.solve(state, &crate::edit::never)?;
    let lap = |stage: &str| {
        1e3 * solved
            .timings
            .iter()
            .filter(|(s, _)| s.contains(stage))
            .map(|(_, t)| t)
            .sum::<f64>()
    };
    println!(
        "{:<34} {:>8} {:>10.1} {:>12.1} {:>10.1} {:>10.1} {:>10.1} {:>8} {:>8.3}",
        name,
        state.curves.len(),
        field_ms,
        lap("factorizations"),
        solved.param.timings.global_ms,
        solved.param.timings.repair_ms,
        lap("QuadCover solve"),
        solved.param.flipped_faces,
        solved.param.conformal_distortion.p99
    );
    Ok(())
}

/// Remesh quality with default settings (what `solve --remesh` gives) next to the thesis's
/// tables 5.1 (QuadCover bunny) and 5.2 (HexCover), Instant Meshes as measured for the remesh
/// issue on this kind of machine, and the targets.
fn remesh_comparison(args: &BenchArgs) -> Result<(), CliError> {
    println!();
    let header = [
        "remesh (default settings)",
        "vertices",
        "irregular",
        "non-pure",
        "RSD edge",
        "RSD angle",
        "angles",
        "mean dist",
        "Hausdorff",
        "extract",
    ];
    let line = |c: [String; 10]| {
        println!(
            "{:<30} {:>8} {:>9} {:>8} {:>9} {:>9} {:>13} {:>9} {:>9} {:>8}",
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9]
        )
    };
    line(header.map(String::from));
    let text = |c: [&str; 10]| c.map(String::from);
    line(text([
        "thesis 5.1 bunny QuadCover",
        "6535",
        "37",
        "-",
        "18.2 %",
        "14.8 %",
        "-",
        "-",
        "-",
        "-",
    ]));
    line(text([
        "thesis 5.2 HexCover",
        "-",
        "-",
        "-",
        "10.5-13.9 %",
        "8.5-11.4 %",
        "-",
        "-",
        "-",
        "-",
    ]));
    line(text([
        "Instant Meshes bunny",
        "6470",
        "207",
        "0",
        "11.0 %",
        "10.3 %",
        "23-180°",
        "-",
        "-",
        "-",
    ]));
    line(text([
        "Instant Meshes igea 50k",
        "-",
        "643",
        "0",
        "7.0 %",
        "7.0 %",
        "-",
        "-",
        "-",
        "-",
    ]));
    line(text([
        "target bunny 6500",
        "",
        "<= 37",
        "0",
        "<= 9 %",
        "<= 8 %",
        "30-150°",
        "<= 0.3 %",
        "-",
        "-",
    ]));
    line(text([
        "target igea 50k",
        "",
        "<= 150",
        "0",
        "<= 6 %",
        "<= 6 %",
        "-",
        "-",
        "-",
        "-",
    ]));
    // (file, N, target vertices, pure quads, τ): the defaults, and τ = 0.1 (`--tau 0.1`, the
    // first thing to try on scans) where it meets more targets.
    let mut cases: Vec<(&str, u32, usize, bool, f64)> = vec![
        ("bunny.obj", 4, 6500, true, 1.0),
        ("bunny.obj", 4, 6500, false, 1.0),
        ("bunny.obj", 6, 6500, true, 1.0),
        ("spot.obj", 4, 6500, true, 1.0),
        ("spot.obj", 4, 6500, true, 0.1),
        ("kitten.obj", 4, 6500, true, 1.0),
        ("kitten.obj", 6, 6500, true, 1.0),
        ("eight.obj", 4, 6500, true, 1.0),
        ("fertility.obj", 4, 6500, true, 1.0),
        ("fertility.obj", 6, 6500, true, 1.0),
        ("fandisk.obj", 4, 6500, true, 1.0),
        ("camelhead.obj", 4, 6500, true, 1.0),
        ("max-planck.obj", 4, 6500, true, 1.0),
        ("max-planck.obj", 4, 6500, true, 0.1),
        ("cerebral-vessels.obj", 4, 6500, true, 1.0),
    ];
    if args.up_to != "10k" {
        cases.push(("igea.obj", 4, 50_000, true, 1.0));
        cases.push(("igea.obj", 4, 50_000, true, 0.1));
    }
    for (file, n, target, pure_quad, tau) in cases {
        let path = args.meshes.join(file);
        if !path.exists() {
            continue;
        }
        let loaded = load_mesh(&path)?;
        let settings = Settings {
            symmetry: n,
            target_vertices: Some(target),
            pure_quad,
            tau,
            ..Default::default()
        };
        let base = Base::new(
            std::sync::Arc::new(loaded.mesh),
            loaded.report.original_vertex,
            loaded.file_vertices,
            settings,
            &crate::edit::never,
        )?;
        let solved = base.solve(base.initial(), &crate::edit::never)?;
        let t = Instant::now();
        let (_, q) = remesh_report(
            base.mesh(),
            &solved.param.uv,
            n as u8,
            &ExtractOptions {
                poles: solved.param.poles.clone(),
                ..Default::default()
            },
        )?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let regular_sides = if n == 6 { 3 } else { 4 };
        let other: usize = q
            .faces_by_sides
            .iter()
            .filter(|(sides, _)| **sides != regular_sides)
            .map(|(_, c)| c)
            .sum();
        line([
            format!(
                "{} N={n}{}{}",
                file.trim_end_matches(".obj"),
                if n == 4 && !pure_quad {
                    " no-pure-quad"
                } else {
                    ""
                },
                if tau == Settings::default().tau {
                    String::new()
                } else {
                    format!(" tau {tau}")
                }
            ),
            q.vertices.to_string(),
            q.irregular_vertices.to_string(),
            other.to_string(),
            format!("{:.1} %", 100.0 * q.rsd_edge),
            format!("{:.1} %", 100.0 * q.rsd_angle),
            format!("{:.0}-{:.0}°", q.min_angle_deg, q.max_angle_deg),
            format!("{:.3} %", 100.0 * q.mean_distance),
            format!("{:.2} %", 100.0 * q.hausdorff),
            format!("{ms:.0} ms"),
        ]);
    }
    Ok(())
}

/// Greedy rounding re-solves once per integer variable: only run it on meshes up to this size.
const GREEDY_MAX_TRIANGLES: usize = 150_000;

/// The measured stages of the pipeline on one mesh (N = 4, default parameters).
fn stages(rows: &mut Vec<Row>, name: &str, mesh: &TriMesh) -> Result<(), CliError> {
    let n = mesh.n_faces();
    let mut total = 0.0;
    let params = FieldParams::default();
    let symmetry = params.symmetry.n() as usize;
    // The field alone (issue #3's figure), then the pipeline as `solve` runs it.
    let alone = measure(rows, name, n, "field alone (curvature + smoothing)", || {
        compute_field(mesh, &params)
    })?;
    for (stage, seconds) in &alone.timings {
        rows.push(Row {
            mesh: name.into(),
            triangles: n,
            stage: format!("  field.{stage}"),
            seconds: *seconds,
            peak_mib: f64::NAN,
        });
    }
    // As `solve` runs it: QuadCover's analyses beside the field, its factorizations beside the
    // field's last solve (`param::pipeline`).
    let (field, qc) = measure(
        rows,
        name,
        n,
        "field, then QuadCover factorizations",
        || field_then_quadcover(mesh, &params, symmetry, &ParamOptions::default()),
    )?;
    total += rows.last().map_or(0.0, |r| r.seconds);
    let mut sub = |stage: String, seconds: f64| {
        rows.push(Row {
            mesh: name.into(),
            triangles: n,
            stage,
            seconds,
            peak_mib: f64::NAN,
        })
    };
    for (stage, ms) in [
        ("cut graph", qc.timings.cut_ms),
        ("local factor", qc.timings.local_ms),
        ("global factor", qc.timings.global_ms),
    ] {
        sub(format!("  param.{stage}"), ms / 1e3);
    }
    let (frames, matchings) = (&field.field.frames, &field.field.matchings);
    let local = measure(rows, name, n, "param.local (solve + integrate)", || {
        qc.local_step(mesh, frames)
    })?;
    total += rows.last().map_or(0.0, |r| r.seconds);
    let gaps = measure(rows, name, n, "param.global (direct rounding)", || {
        let gaps = qc.round_gaps(mesh, &local)?;
        qc.global_uv(mesh, &local, &gaps).map(|_| gaps)
    })?;
    total += rows.last().map_or(0.0, |r| r.seconds);
    rows.push(Row {
        mesh: name.into(),
        triangles: n,
        stage: "TOTAL curvature..global".into(),
        seconds: total,
        peak_mib: f64::NAN,
    });
    // The whole solve as `solve` runs it, with the injectivity repair (issue #15's target: the
    // repair at most 30 % of the bunny's solve, 5 s at 1.1 M triangles).
    let solved = measure(rows, name, n, "param.solve (local, global, repair)", || {
        qc.solve(mesh, frames)
    })?;
    rows.push(Row {
        mesh: name.into(),
        triangles: n,
        stage: format!(
            "  param.repair ({} -> {} folded)",
            solved.flipped_faces_before_repair, solved.flipped_faces
        ),
        seconds: solved.timings.repair_ms / 1e3,
        peak_mib: f64::NAN,
    });
    let shifted: Vec<[f64; 2]> = gaps.iter().map(|g| [g[0] + 1.0, g[1]]).collect();
    measure(rows, name, n, "param.global re-solve (reused)", || {
        qc.global_uv(mesh, &local, &shifted)
    })?;
    if n <= GREEDY_MAX_TRIANGLES {
        let greedy = ParamOptions {
            rounding: Rounding::Greedy,
            pure_quad: false,
            no_untangle: false,
            no_poles: false,
            no_crowded_refinement: false,
        };
        let qg = QuadCover::new(mesh, symmetry, matchings, greedy)?;
        measure(rows, name, n, "param.global (greedy rounding)", || {
            let gaps = qg.round_gaps(mesh, &local)?;
            qg.global_uv(mesh, &local, &gaps)
        })?;
    }
    edit_stages(rows, name, mesh)
}

/// Relax only runs on meshes up to this size in the benchmark.
const RELAX_MAX_TRIANGLES: usize = 150_000;

/// Singularity editing (issue #13): the base (field with its system kept, QuadCover's analyses),
/// one move of a singularity by a few edges and the re-solve that follows a drag's release
/// (field re-solve + QuadCover), and `relax`.
fn edit_stages(rows: &mut Vec<Row>, name: &str, mesh: &TriMesh) -> Result<(), CliError> {
    let n = mesh.n_faces();
    let arc = std::sync::Arc::new(mesh.clone());
    let base = measure(rows, name, n, "edit: base (field kept + analyses)", || {
        Base::for_mesh(arc, Settings::default())
    })?;
    let s0 = base.initial().clone();
    // As in the editor: the initial state is solved first, and its QuadCover kept for updates.
    measure(rows, name, n, "edit: first solve (QuadCover kept)", || {
        base.solve(&s0, &crate::edit::never)
    })?;
    let Some((&p, _)) = s0.singularities.iter().next() else {
        return Ok(());
    };
    // A free interior vertex three rings away.
    let mut ring = vec![p];
    for _ in 0..3 {
        ring = ring.iter().flat_map(|&v| mesh.one_ring(v)).collect();
    }
    let Some(&q) = ring
        .iter()
        .find(|&&v| !mesh.is_boundary_vertex(v) && !s0.singularities.contains_key(&v))
    else {
        return Ok(());
    };
    let edit = Edit::MoveSingularity {
        from: base.file_vertex(p),
        to: base.file_vertex(q),
    };
    let s1 = measure(rows, name, n, "edit: move (path, matchings)", || {
        base.apply(&s0, &edit, &crate::edit::never)
    })?;
    let clock = Instant::now();
    let preview_at = std::sync::Mutex::new(None);
    let solved = measure(
        rows,
        name,
        n,
        "edit: re-solve after a move (release to repaired UVs)",
        || {
            base.solve_previewing(&s1, &crate::edit::never, &|_| {
                if let Ok(mut at) = preview_at.lock() {
                    *at = Some(clock.elapsed().as_secs_f64());
                }
            })
        },
    )?;
    let total = rows.last().map_or(f64::NAN, |r| r.seconds);
    let (local, global) = match solved.reuse {
        crate::edit::Reuse::Updated { local, global } => (local, global),
        crate::edit::Reuse::Base => (Some(0), Some(0)),
    };
    let rows_note = |r: Option<usize>| r.map_or("refactored".to_string(), |r| r.to_string());
    rows.push(Row {
        mesh: name.into(),
        triangles: n,
        stage: format!(
            "edit: re-solve after a move (release to the global step's map; rows updated {} / {})",
            rows_note(local),
            rows_note(global)
        ),
        seconds: preview_at.into_inner().ok().flatten().unwrap_or(total),
        peak_mib: f64::NAN,
    });
    for (stage, seconds) in &solved.timings {
        rows.push(Row {
            mesh: name.into(),
            triangles: n,
            stage: format!("  edit.{stage}"),
            seconds: *seconds,
            peak_mib: f64::NAN,
        });
    }
    if n <= RELAX_MAX_TRIANGLES {
        let relaxed = measure(rows, name, n, "edit: relax", || {
            base.apply(&s0, &Edit::Relax, &crate::edit::never)
        })?;
        measure(rows, name, n, "edit: re-solve after relax", || {
            base.solve(&relaxed, &crate::edit::never)
        })?;
    }
    Ok(())
}

/// What `relax` does to the bunny's remesh at about 6500 vertices (N = 4, default settings).
fn relax_comparison(args: &BenchArgs) -> Result<(), CliError> {
    let loaded = load_mesh(&args.meshes.join("bunny.obj"))?;
    let settings = Settings {
        target_vertices: Some(6500),
        ..Settings::default()
    };
    let base = Base::new(
        std::sync::Arc::new(loaded.mesh),
        loaded.report.original_vertex,
        loaded.file_vertices,
        settings,
        &crate::edit::never,
    )?;
    println!();
    println!(
        "{:<22} {:>13} {:>10} {:>8} {:>10} {:>10} {:>10} {:>10}",
        "bunny N=4, 6500 v.",
        "singularities",
        "curl",
        "flipped",
        "vertices",
        "irregular",
        "RSD edge",
        "RSD angle"
    );
    let s0 = base.initial().clone();
    let s1 = base.apply(&s0, &Edit::Relax, &crate::edit::never)?;
    for (label, state) in [("before relax", &s0), ("after relax", &s1)] {
        let solved = base.solve(state, &crate::edit::never)?;
        let opts = ExtractOptions {
            poles: solved.param.poles.clone(),
            ..Default::default()
        };
        let (_, q) = remesh_report(base.mesh(), &solved.param.uv, 4, &opts)?;
        println!(
            "{:<22} {:>13} {:>10.2} {:>8} {:>10} {:>10} {:>8.1} % {:>8.1} %",
            label,
            state.singularities.len(),
            solved.param.curl,
            solved.param.flipped_faces,
            q.vertices,
            q.irregular_vertices,
            100.0 * q.rsd_edge,
            100.0 * q.rsd_angle
        );
    }
    Ok(())
}

fn print_table(rows: &[Row]) {
    println!(
        "{:<12} {:>10} {:<46} {:>10} {:>10}",
        "mesh", "triangles", "stage", "ms", "peak MiB"
    );
    for r in rows {
        println!(
            "{:<12} {:>10} {:<46} {:>10.1} {:>10.0}",
            r.mesh,
            r.triangles,
            r.stage,
            r.seconds * 1e3,
            r.peak_mib
        );
    }
}
