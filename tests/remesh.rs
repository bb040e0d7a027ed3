//! The remesh as users get it (`solve --remesh` with default settings): pure (all quads for
//! N = 4, all triangles for N = 6), manifold, with the input's Euler characteristic and boundary
//! loops, and irregular vertices at singularities (src/extract/purify.rs for what makes it pure;
//! tests/extract.rs checks the raw extraction underneath).

#[path = "support/meshes.rs"]
mod meshes;
#[path = "support/remesh_checks.rs"]
mod remesh_checks;

use remesh_checks::{assert_manifold, boundary_loops, boundary_vertices};

use glam::DVec3;
use quadcover::edit::{Settings, never};
use quadcover::extract::{ExtractOptions, Remesh, corner_angles_deg, extract, irregular_vertices};
use quadcover::mesh::TriMesh;

struct Case {
    mesh: TriMesh,
    remesh: Remesh,
    /// The same extraction without relaxation: the same faces, the vertices where the map puts
    /// them (relaxation slides the grid by up to a few cells to even out its sizes).
    unrelaxed: Remesh,
    singular: Vec<DVec3>,
}

/// What `solve --remesh` makes of a shared mesh with default settings and symmetry `n`.
fn remesh_of(name: &str, n: u32) -> Option<Case> {
    let path = meshes::shared(name)?;
    let settings = Settings {
        symmetry: n,
        ..Default::default()
    };
    let base = meshes::base_for(&path, settings);
    let solved = base.solve(base.initial(), &never).unwrap();
    let mesh = (**base.mesh()).clone();
    let remesh = extract(&mesh, &solved.param.uv, n as u8, &ExtractOptions::default()).unwrap();
    let unrelaxed = ExtractOptions {
        relax: None,
        ..Default::default()
    };
    let unrelaxed = extract(&mesh, &solved.param.uv, n as u8, &unrelaxed).unwrap();
    let singular = solved
        .param
        .singularities
        .iter()
        .map(|s| mesh.position(s.vertex))
        .collect();
    Some(Case {
        mesh,
        remesh,
        unrelaxed,
        singular,
    })
}

/// Issue check: every shared mesh, N = 4 and 6 — pure, manifold, Euler characteristic and
/// boundary loops of the input; on closed meshes where extraction closed every cell itself,
/// irregular vertices only at singularities.
#[test]
fn default_remeshes_are_pure_and_keep_the_topology() {
    let mut patched = Vec::new();
    for name in meshes::EVERY_BUT_IGEA {
        for n in [4u32, 6] {
            let Some(c) = remesh_of(name, n) else { return };
            let what = format!("{name} N={n}");
            let r = &c.remesh;
            let sides = if n == 4 { 4 } else { 3 };
            let impure = r.faces.iter().filter(|f| f.len() != sides).count();
            assert_eq!(
                impure, 0,
                "{what}: {impure} faces that are not {sides}-gons"
            );
            assert_manifold(r, &what);
            assert_eq!(
                r.euler_characteristic(),
                c.mesh.euler_characteristic(),
                "{what}: Euler"
            );
            assert_eq!(
                boundary_loops(r),
                c.mesh.boundary_loops().len(),
                "{what}: boundary loops"
            );
            let irregular = irregular_vertices(r);
            // where the map puts the irregular vertices: relaxation keeps the faces
            assert_eq!(
                r.faces, c.unrelaxed.faces,
                "{what}: relaxation kept the faces"
            );
            let h = mean_edge(&c.unrelaxed);
            let far: Vec<u32> = irregular
                .iter()
                .copied()
                .filter(|&v| {
                    let p = c.unrelaxed.positions[v as usize];
                    !c.singular.iter().any(|s| (*s - p).length() < 2.0 * h)
                })
                .collect();
            println!(
                "{what}: {} faces, {} irregular ({} singularities), {} away from them; purified {:?}",
                r.faces.len(),
                irregular.len(),
                c.singular.len(),
                far.len(),
                r.purified
            );
            // no boundary slivers in triangle remeshes (flat ears, short boundary edges:
            // src/extract/ears.rs); before, the bunny had corners of 0° and 180°. Where
            // extraction patched nothing, no slivers anywhere.
            if n == 6 {
                let (lo, hi) = corner_range(r, true);
                println!("{what}: corners at the boundary {lo:.1}°–{hi:.1}°");
                assert!(
                    lo > 3.0 && hi < 170.0,
                    "{what}: boundary corners {lo}°–{hi}°"
                );
                if r.patched_places == 0 {
                    let (lo, hi) = corner_range(r, false);
                    assert!(lo > 3.0 && hi < 170.0, "{what}: corners {lo}°–{hi}°");
                }
            }
            if r.patched_places > 0 {
                patched.push((what.clone(), r.patched_places));
            }
            if r.purified.impure_faces == 0 && r.patched_places == 0 {
                assert!(
                    far.is_empty(),
                    "{what}: irregular away from singularities: {far:?}"
                );
            }
        }
    }
    // Patched places are where a map is not locally injective (issue #15's target is none):
    // 13 over these 18 remeshes before branch points left wound wrongly were rewound again on
    // the final map (2026-12-04), 3 before the tries around crowded singularities (the same
    // day), 1 before the re-rounding for windings (fertility N = 4: branch points no stiff
    // solve within the limits winds correctly together; one gap moved by a lattice step
    // does), none since.
    eprintln!("patched places: {patched:?}");
    assert!(patched.is_empty(), "patched places {patched:?}");
}

/// The smallest and largest corner angle (degrees) of the faces of `r`, or of those with a
/// vertex on the boundary only.
fn corner_range(r: &Remesh, boundary_only: bool) -> (f64, f64) {
    let on_boundary = boundary_vertices(r);
    let part = Remesh {
        positions: r.positions.clone(),
        faces: (r.faces.iter())
            .filter(|f| !boundary_only || f.iter().any(|&v| on_boundary[v as usize]))
            .cloned()
            .collect(),
        ..Default::default()
    };
    corner_angles_deg(&part)
        .into_iter()
        .fold((f64::INFINITY, 0.0), |(lo, hi), a| (lo.min(a), hi.max(a)))
}

fn mean_edge(r: &Remesh) -> f64 {
    let l = quadcover::extract::edge_lengths(r);
    l.iter().sum::<f64>() / l.len().max(1) as f64
}

/// The cases purify exists for occur: without it the bunny's quad remesh (five boundary loops
/// cut across by the grid) has other polygons, with it none, at nearly the same vertex count.
#[test]
fn purify_is_what_makes_the_bunny_all_quads() {
    let Some(c) = remesh_of("bunny.obj", 4) else {
        return;
    };
    let path = meshes::shared("bunny.obj").unwrap();
    let base = meshes::base_for(&path, Settings::default());
    let solved = base.solve(base.initial(), &never).unwrap();
    let raw = extract(
        &c.mesh,
        &solved.param.uv,
        4,
        &ExtractOptions {
            pure: false,
            ..Default::default()
        },
    )
    .unwrap();
    let non_quads = raw.faces.iter().filter(|f| f.len() != 4).count();
    assert!(
        non_quads > 20,
        "raw bunny remesh has only {non_quads} non-quads"
    );
    assert_eq!(c.remesh.purified.impure_faces, non_quads);
    assert!(c.remesh.faces.iter().all(|f| f.len() == 4));
    let (a, b) = (raw.positions.len() as f64, c.remesh.positions.len() as f64);
    assert!((b - a).abs() < 0.05 * a, "vertices {a} -> {b}");
}

/// Issue check: a folded parameterization (the global step without the injectivity repair, at a
/// coarse density where it folds most) extracts to an all-quad manifold mesh with the same
/// counts, within 1 %, as the same map after the repair: folds are traced through, not cut out.
/// The folded map is the global step's on the repaired map's frames and gaps (the repair may
/// re-round a gap, which changes the layout).
#[test]
fn folded_maps_extract_like_their_repaired_maps() {
    use quadcover::param::QuadCover;
    for (name, target) in [
        ("bunny.obj", 1500),
        ("camelhead.obj", 1500),
        ("fertility.obj", 0),
    ] {
        let Some(path) = meshes::shared(name) else {
            return;
        };
        // On one grid: the repair's further tries on a finer grid around crowded
        // singularities would compare a different grid.
        let settings = Settings {
            target_vertices: (target > 0).then_some(target),
            refine_crowded: false,
            ..Default::default()
        };
        let base = meshes::base_for(&path, settings.clone());
        let solved = base.solve(base.initial(), &never).unwrap();
        let mesh = base.mesh();
        let qc =
            QuadCover::new(mesh, 4, &solved.field.matchings, settings.param_options()).unwrap();
        let local = qc.local_step(mesh, &solved.field.frames).unwrap();
        let folded_uv = qc.global_uv(mesh, &local, &solved.param.gaps).unwrap();
        let folds = quadcover::param::folded_faces(&folded_uv).len();
        // (fertility at the default density has the fewest: 6)
        assert!(
            folds >= 5,
            "{name}: only {folds} folds without the repair, the case tests nothing"
        );
        let mut counts = Vec::new();
        for (what, uv, folded) in [
            ("folded", &folded_uv, folds),
            ("repaired", &solved.param.uv, solved.param.flipped_faces),
        ] {
            let r = extract(mesh, uv, 4, &ExtractOptions::default()).unwrap();
            let what = format!("{name} {what}");
            assert!(
                r.faces.iter().all(|f| f.len() == 4),
                "{what}: not all quads"
            );
            assert_manifold(&r, &what);
            assert_eq!(
                r.euler_characteristic(),
                mesh.euler_characteristic(),
                "{what}: Euler"
            );
            println!(
                "{what}: {folded} folded, {} vertices, {} faces, {} patched",
                r.positions.len(),
                r.faces.len(),
                r.patched_places
            );
            counts.push((r.positions.len() as f64, r.faces.len() as f64));
        }
        let ((v0, f0), (v1, f1)) = (counts[0], counts[1]);
        assert!(
            (v0 - v1).abs() <= 0.01 * v1,
            "{name}: vertices {v0} vs {v1}"
        );
        assert!((f0 - f1).abs() <= 0.01 * f1, "{name}: faces {f0} vs {f1}");
    }
}

/// Issue check: folded maps whose extraction used to come out non-manifold or with the wrong
/// Euler characteristic (N = 6, the global step without the repair). Fandisk with its features
/// at 40° traces three cells twice, once per sheet of a fold, in opposite orientations (9 edges
/// in four faces, χ 5 instead of 2 with the repair on); cerebral vessels at 1500 vertices left a
/// fold's lone triangle standing in a hole, which then stayed open (χ −8 instead of −7).
#[test]
fn folds_traced_on_both_sheets_leave_a_manifold_remesh() {
    use quadcover::edit::Edit;
    for (name, target, edits) in [
        (
            "fandisk.obj",
            0,
            vec![Edit::DetectFeatures { angle_deg: 40.0 }],
        ),
        ("cerebral-vessels.obj", 1500, Vec::new()),
    ] {
        let Some(path) = meshes::shared(name) else {
            return;
        };
        let settings = Settings {
            symmetry: 6,
            target_vertices: (target > 0).then_some(target),
            no_untangle: true,
            ..Default::default()
        };
        let base = meshes::base_for(&path, settings);
        let state = base.replay(&edits, &never).unwrap().last().clone();
        let solved = base.solve(&state, &never).unwrap();
        assert!(
            solved.param.flipped_faces >= 50,
            "{name}: only {} folds, the case tests nothing",
            solved.param.flipped_faces
        );
        let mesh = base.mesh();
        let r = extract(mesh, &solved.param.uv, 6, &ExtractOptions::default()).unwrap();
        assert!(
            r.faces.iter().all(|f| f.len() == 3),
            "{name}: not all triangles"
        );
        assert_manifold(&r, name);
        assert_eq!(
            r.euler_characteristic(),
            mesh.euler_characteristic(),
            "{name}: Euler"
        );
        assert_eq!(
            boundary_loops(&r),
            mesh.boundary_loops().len(),
            "{name}: boundary loops"
        );
    }
}

/// A stale extraction stops: the cancel check is polled between the stages and at every
/// relaxation iteration, and a check that turns true gives `Cancelled`; one that never does
/// gives exactly `extract`'s result.
#[test]
fn extraction_can_be_cancelled() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let Some(path) = meshes::shared("kitten.obj") else {
        return;
    };
    let base = meshes::base_for(&path, Settings::default());
    let solved = base.solve(base.initial(), &never).unwrap();
    let (mesh, uv) = (base.mesh(), &solved.param.uv);
    let opts = ExtractOptions::default();
    let polls = AtomicUsize::new(0);
    let counted = || {
        polls.fetch_add(1, Ordering::Relaxed);
        false
    };
    let full = quadcover::extract::extract_until(mesh, uv, 4, &opts, &counted).unwrap();
    let iterations = full.relaxed.unwrap().iterations;
    assert!(
        polls.load(Ordering::Relaxed) > iterations,
        "{} polls for {iterations} relaxation iterations",
        polls.load(Ordering::Relaxed)
    );
    assert_eq!(
        full.positions,
        extract(mesh, uv, 4, &opts).unwrap().positions
    );
    for after in [0, 1, 5] {
        let polls = AtomicUsize::new(0);
        let cancel = || polls.fetch_add(1, Ordering::Relaxed) >= after;
        let r = quadcover::extract::extract_until(mesh, uv, 4, &opts, &cancel);
        assert!(
            matches!(r, Err(quadcover::extract::ExtractError::Cancelled)),
            "cancelled after {after} polls: {:?}",
            r.map(|r| r.faces.len())
        );
    }
}

/// Thin parts get enough cells around (`field::thin`). A torus whose tube is about 2.5 grid
/// cells around, and the cerebral vessels at 1500 vertices (the coarse density of the
/// flip-free checks; vessels 2–3 cells around): with a uniform grid the period around the
/// tube rounds to two cells, whose quads share all four vertices, and the remesh is not
/// manifold (required here, so that the test cannot pass by accident); with the default
/// refinement it is manifold, all quads, with the input's Euler characteristic and boundary
/// loops, and the torus's tube has at least five cells around.
#[test]
fn thin_tubes_get_enough_cells_around() {
    use quadcover::edit::Base;
    use std::sync::Arc;
    let torus = quadcover::mesh::generate::torus(10.0, 0.6, 160, 12);
    let tube = 2.0 * std::f64::consts::PI * 0.6;
    let h = tube / 2.5;
    let mut cases: Vec<(String, Base, TriMesh)> = Vec::new();
    for refine in [false, true] {
        let settings = Settings {
            scale: Some(h),
            refine_thin_parts: refine,
            refine_crowded: refine,
            ..Default::default()
        };
        let n = torus.n_vertices();
        let base = Base::new(
            Arc::new(torus.clone()),
            (0..n as u32).collect(),
            n,
            settings,
            &never,
        )
        .unwrap();
        cases.push((format!("torus, refine {refine}"), base, torus.clone()));
        if let Some(path) = meshes::shared("cerebral-vessels.obj") {
            // Without the refinement the grid is uniform: no finer tries around crowded
            // singularities either (they refine vessels too).
            let settings = Settings {
                target_vertices: Some(1500),
                refine_thin_parts: refine,
                refine_crowded: refine,
                ..Default::default()
            };
            let base = meshes::base_for(&path, settings);
            let mesh = (**base.mesh()).clone();
            cases.push((format!("cerebral vessels, refine {refine}"), base, mesh));
        }
    }
    for (what, base, mesh) in &cases {
        let solved = base.solve(base.initial(), &never).unwrap();
        let r = extract(mesh, &solved.param.uv, 4, &ExtractOptions::default()).unwrap();
        let bad = quadcover::extract::quality(&r, mesh).non_manifold_edges;
        let thin = &base.field().thin;
        println!(
            "{what}: {} vertices, {} faces, {bad} non-manifold edges, thin faces {} (x{:.2})",
            r.positions.len(),
            r.faces.len(),
            thin.faces,
            thin.max_multiplier
        );
        if what.ends_with("false") {
            assert!(bad > 0, "{what}: manifold without the refinement");
            assert_eq!(thin.faces, 0, "{what}");
            continue;
        }
        assert!(thin.faces > 0, "{what}: nothing found thin");
        assert_manifold(&r, what);
        assert!(
            r.faces.iter().all(|f| f.len() == 4),
            "{what}: not all quads"
        );
        assert_eq!(
            r.euler_characteristic(),
            mesh.euler_characteristic(),
            "{what}"
        );
        assert_eq!(boundary_loops(&r), mesh.boundary_loops().len(), "{what}");
        if what.starts_with("torus") {
            // Around the tube: the remesh vertices in the plane y = 0 on the x > 0 side lie
            // on as many grid lines as there are cells around; count the quads crossing it.
            let around = r
                .faces
                .iter()
                .filter(|f| {
                    let ps: Vec<DVec3> = f.iter().map(|&v| r.positions[v as usize]).collect();
                    ps.iter().any(|p| p.y > 0.0)
                        && ps.iter().any(|p| p.y <= 0.0)
                        && ps.iter().all(|p| p.x > 0.0)
                })
                .count();
            assert!(around >= 5, "{what}: {around} quads around the tube");
        }
    }
}

/// `solve --remesh` says when the remesh is not a manifold copy of the input, and why: the
/// torus whose tube is 2.5 cells around, with a uniform grid (`--no-thin-refinement`); with
/// the default refinement it is manifold and nothing is said.
#[test]
fn cli_warns_of_a_remesh_that_is_not_manifold() {
    let dir = tempfile::tempdir().unwrap();
    let torus = quadcover::mesh::generate::torus(10.0, 0.6, 160, 12);
    let path = dir.path().join("torus.obj");
    quadcover::io::write_obj(
        &path,
        &quadcover::io::ObjOutput::new(torus.positions(), torus.faces()),
    )
    .unwrap();
    let h = 2.0 * std::f64::consts::PI * 0.6 / 2.5;
    let run = |extra: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_quadcover"))
            .args(["solve", path.to_str().unwrap(), "--scale", &h.to_string()])
            .args(extra)
            .arg("--out")
            .arg(dir.path().join("uv.obj"))
            .arg("--remesh")
            .arg(dir.path().join("remesh.obj"))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let uniform = run(&["--no-thin-refinement"]);
    assert!(
        uniform.contains("warning: the remesh is not a manifold copy")
            && uniform.contains("drop --no-thin-refinement"),
        "{uniform}"
    );
    let refined = run(&[]);
    assert!(refined.contains("thin parts:"), "{refined}");
    assert!(refined.contains("remesh: "), "{refined}");
    assert!(!refined.contains("warning: the remesh"), "{refined}");
}

/// The lever the README names for scans: with the smoother field (`--tau 0.1`) max-planck's
/// quad remesh at about 6500 vertices meets every shape target of the remesh issue: RSD edge
/// ≤ 9 %, RSD angle ≤ 8 %, corners in [30°, 150°], all quads, irregular vertices exactly its
/// singularities (with the default τ = 1: 12.0 %, 8.0 % and corners of 26°–172° at its
/// base's rim).
#[test]
fn a_smoother_field_meets_the_shape_targets_on_max_planck() {
    let Some(path) = meshes::shared("max-planck.obj") else {
        eprintln!("skipped: shared meshes not found");
        return;
    };
    let settings = Settings {
        target_vertices: Some(6500),
        tau: 0.1,
        ..Default::default()
    };
    let base = meshes::base_for(&path, settings);
    let solved = base.solve(base.initial(), &never).unwrap();
    assert_eq!(solved.param.flipped_faces, 0);
    let remesh = extract(base.mesh(), &solved.param.uv, 4, &ExtractOptions::default()).unwrap();
    assert_manifold(&remesh, "max-planck, tau 0.1");
    assert!(remesh.faces.iter().all(|f| f.len() == 4), "not all quads");
    let q = quadcover::extract::quality(&remesh, base.mesh());
    eprintln!(
        "max-planck, tau 0.1: {} vertices, {} irregular, {} singularities, RSD {:.1} / {:.1} %, \
         corners {:.1}°–{:.1}°",
        q.vertices,
        q.irregular_vertices,
        solved.param.singularities.len(),
        100.0 * q.rsd_edge,
        100.0 * q.rsd_angle,
        q.min_angle_deg,
        q.max_angle_deg
    );
    assert_eq!(q.irregular_vertices, solved.param.singularities.len());
    assert!(q.rsd_edge <= 0.09, "RSD edge {:.3}", q.rsd_edge);
    assert!(q.rsd_angle <= 0.08, "RSD angle {:.3}", q.rsd_angle);
    assert!(
        q.min_angle_deg >= 30.0 && q.max_angle_deg <= 150.0,
        "corners {:.1}°–{:.1}°",
        q.min_angle_deg,
        q.max_angle_deg
    );
}
