//! The injectivity repair after the global step (src/param/untangle.rs): no folded face on the
//! shared meshes, seams, singularities and gaps exactly as the global step left them, and a
//! case that folds without the repair so that these tests cannot pass by accident.

#[path = "support/meshes.rs"]
mod meshes;
#[path = "support/seams.rs"]
mod seams;

use std::path::Path;

use quadcover::field::{self, Density, FieldParams, Symmetry};
use quadcover::mesh::TriMesh;
use quadcover::param::{self, Lattice, ParamOptions, Parameterization, QuadCover};

use meshes::MESHES;
use seams::contract_error;

fn signed_area(uv: &[[f64; 2]], f: usize) -> f64 {
    let [a, b, c] = [uv[3 * f], uv[3 * f + 1], uv[3 * f + 2]];
    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
}

/// Face f's signed area over its longest edge squared: a fold when not positive, degenerate
/// (two corners on one point, its sign decided by rounding) when within 1e-9 of zero. Faces
/// of the shared meshes' maps are above 5e-4.
fn relative_area(uv: &[[f64; 2]], f: usize) -> f64 {
    let longest = (0..3)
        .map(|k| {
            let (a, b) = (uv[3 * f + k], uv[3 * f + (k + 1) % 3]);
            (b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)
        })
        .fold(0.0, f64::max);
    signed_area(uv, f) / longest
}

/// Folded or degenerate faces, read from the texture coordinates alone.
fn not_positive(uv: &[[f64; 2]]) -> Vec<usize> {
    (0..uv.len() / 3)
        // NaN (an undefined area) counts as folded.
        .filter(|&f| relative_area(uv, f).partial_cmp(&1e-9) != Some(std::cmp::Ordering::Greater))
        .collect()
}

/// Field and QuadCover of a mesh, solved with and without the repair (same field); gaps on
/// 2Z² (singularities on Z²) with `pure_quad`, the CLI's default for N = 4.
fn solve_both(
    mesh: &TriMesh,
    n: u32,
    density: Option<usize>,
    pure_quad: bool,
) -> (Parameterization, Parameterization) {
    let mut params = FieldParams {
        symmetry: Symmetry::from_n(n).unwrap(),
        ..Default::default()
    };
    if let Some(v) = density {
        params.density = Density::TargetVertices(v);
    }
    let fr = field::compute_field(mesh, &params).unwrap();
    let f = &fr.field;
    let solve = |no_untangle, frames: &[[glam::DVec3; 2]]| {
        let opts = ParamOptions {
            no_untangle,
            pure_quad,
            ..Default::default()
        };
        QuadCover::new(mesh, n as usize, &f.matchings, opts)
            .unwrap()
            .solve(mesh, frames)
            .unwrap()
    };
    let p = solve(false, &f.frames);
    // A map that is the second try, on frames made finer around crowded singularities, is
    // compared with the global step's map on those frames.
    let try_kept = p.crowded_refinement.as_ref().and_then(|r| r.crowding);
    let plain = match try_kept
        .and_then(|c| param::crowded::refined_frames(mesh, &p.singularities, &f.frames, c))
    {
        Some((refined, _)) => solve(true, &refined),
        None => solve(true, &f.frames),
    };
    (p, plain)
}

/// Interior vertices whose fan in `p.uv` turns by more than π off 2π(1 − index) (index 0 at
/// regular vertices), computed here from the corners; vertices of index ≥ 1 (poles) are not
/// checked.
fn miswound(mesh: &TriMesh, p: &Parameterization) -> Vec<usize> {
    let index: std::collections::HashMap<usize, f64> = p
        .singularities
        .iter()
        .map(|s| (s.vertex, s.index))
        .collect();
    (0..mesh.n_vertices())
        .filter(|&v| {
            let k = index.get(&v).copied().unwrap_or(0.0);
            if mesh.is_boundary_vertex(v) || k >= 1.0 {
                return false;
            }
            let turn: f64 = mesh
                .outgoing(v)
                .map(|h| {
                    let (a, b, c) = (p.uv[h], p.uv[mesh.next(h)], p.uv[mesh.prev(h)]);
                    let (x, y) = ([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
                    (x[0] * y[1] - x[1] * y[0]).atan2(x[0] * y[0] + x[1] * y[1])
                })
                .sum();
            (turn - std::f64::consts::TAU * (1.0 - k)).abs() > std::f64::consts::PI
        })
        .collect()
}

/// The promises of the repair on one solve: nothing folded, seamless, singularities and gaps
/// on the lattice, and the branch points and gaps where the global step put them.
fn check(name: &str, mesh: &TriMesh, p: &Parameterization, plain: &Parameterization) {
    let n = p.symmetry;
    assert_eq!(p.flipped_faces, not_positive(&p.uv).len(), "{name}");
    assert!(
        p.flipped_faces <= plain.flipped_faces,
        "{name}: the repair made it worse"
    );
    assert_eq!(p.flipped_faces_before_repair, plain.flipped_faces, "{name}");
    assert_eq!(param::folded_faces(&plain.uv).len(), plain.flipped_faces);
    assert_eq!(miswound(mesh, p), p.miswound, "{name}: mis-wound vertices");
    let err = contract_error(mesh, &p.uv, n, p.lattice.transitions());
    assert!(err < 1e-6, "{name}: seam error {err}");
    for (k, g) in p.gaps.iter().enumerate() {
        let q = p.lattice.transitions().nearest(*g);
        assert!(
            (q[0] - g[0]).abs() < 1e-9 && (q[1] - g[1]).abs() < 1e-9,
            "{name}: gap {k} = {g:?} off the lattice"
        );
    }
    // Gaps change only where the report says so; branch points stay exactly where the global
    // step put them unless a gap changed.
    let changed: Vec<usize> = (0..p.gaps.len())
        .filter(|&k| p.gaps[k] != plain.gaps[k])
        .collect();
    let reported: Vec<usize> = p.rerounded_gaps.iter().map(|r| r.path).collect();
    assert_eq!(changed, reported, "{name}: changed gaps");
    for s in p.singularities.iter().filter(|s| s.holonomy != 0) {
        let h = mesh.vertex_halfedge(s.vertex);
        if changed.is_empty() {
            assert_eq!(
                p.uv[h], plain.uv[h],
                "{name}: branch point {} moved",
                s.vertex
            );
        }
        if n == 4 {
            // ½Z², or Z² with `pure_quad` (gaps on D₂ and 2Z²).
            let s = if p.lattice == Lattice::TwoZ2 {
                1.0
            } else {
                2.0
            };
            let q = p.uv[h];
            for x in q {
                assert!(((s * x).round() - s * x).abs() < 1e-6, "{name}: {q:?}");
            }
        }
        if n == 6 {
            // Every branch point on G6, ±2/6 and ±3/6 too (gaps of their loops on the
            // sublattices `Lattice::TurnedG6`, `Lattice::TwoG6`).
            let q = p.uv[h];
            assert!(
                Lattice::G6.distance(q) < 1e-6,
                "{name}: branch point {} of index {} at {q:?}",
                s.vertex,
                s.index
            );
        }
    }
}

/// Shared-mesh cases left with folds after the repair, and how many at most: none since the
/// second try on a grid made finer around crowded singularities (2026-12-04; spot N = 6 at
/// 1500 vertices kept 1 until then, see docs/untangling.md). The list stays for cases the
/// repair may not fully unfold one day; a case not listed must not fold.
const KNOWN_LEFT: &[(&str, usize)] = &[];

/// The bunny at the default density, N = 4 on ½Z² and on 2Z²: the global step leaves a dozen
/// −1/4 branch points whose fans turn 90° instead of 450° (their lattice points outside their
/// rings), and the barrier of the repair alone kept them so (12 and 10 mis-wound vertices left
/// before the rewinding). The rewinding before the repair left one pair (9595 and 9709, whose
/// rewinding added more folds than `rewind` allows); since the second rewinding on the final
/// map (`untangle::rewind_left`, wider and stiffer regions) none is left.
#[test]
fn the_repair_rewinds_branch_points() {
    if !Path::new(MESHES).exists() {
        eprintln!("skipping: {MESHES} not found");
        return;
    }
    let mesh = quadcover::load::load_mesh(&Path::new(MESHES).join("bunny.obj"))
        .unwrap()
        .mesh;
    for pure_quad in [false, true] {
        let (p, plain) = solve_both(&mesh, 4, None, pure_quad);
        let before = miswound(&mesh, &plain);
        assert!(before.len() >= 10, "{} mis-wound before", before.len());
        assert_eq!(p.flipped_faces, 0);
        let after = miswound(&mesh, &p);
        assert!(
            after.is_empty(),
            "pure_quad {pure_quad}: mis-wound {after:?}"
        );
        assert_eq!(after, p.miswound);
    }
}

/// A branch point whose stiff rewindings all add more folds than allowed is rewound through
/// its cone's power map (`rewind::power_solve`): the cerebral vessels, N = 2 (stripes): two
/// −1/2 branch points wound one full turn short, each beside a regular vertex wrapping twice,
/// were left so before (2 mis-wound vertices); now none is, with no fold and the map's promises
/// kept.
#[test]
fn short_wound_branch_points_are_rewound_through_the_power_map() {
    let Some(mesh) = meshes::load_shared("cerebral-vessels.obj") else {
        return;
    };
    let (p, plain) = solve_both(&mesh, 2, None, false);
    // The global step leaves many; the stiff rewindings alone left two.
    assert!(miswound(&mesh, &plain).len() >= 10);
    assert_eq!(p.flipped_faces, 0);
    assert_eq!(miswound(&mesh, &p), Vec::<usize>::new());
    check("cerebral vessels N = 2", &mesh, &p, &plain);
}

/// Branch points the rounding put half a cell and more from where the map has them: the rims of
/// rings around them pass close by the lattice point on one side and reach other singularities
/// before they wind around it. Regions around the lattice point, with the Möbius step that
/// carries the branch point onto it, rewind them (igea at 1500 vertices, N = 4: 10 mis-wound
/// vertices and 5 patched places with ring regions only; then 2 and 1). The last pair was a
/// −1/4 branch point whose lattice point the rounding also gave a +1/4 singularity: no map
/// winds both, and the windings re-rounding now parts such pairs first (none left).
#[test]
fn branch_points_rounded_far_away_are_rewound_around_their_lattice_point() {
    let Some(mesh) = meshes::load_shared("igea.obj") else {
        return;
    };
    let (p, plain) = solve_both(&mesh, 4, Some(1500), true);
    assert!(miswound(&mesh, &plain).len() >= 50);
    assert_eq!(p.flipped_faces, 0);
    let left = miswound(&mesh, &p);
    assert!(left.is_empty(), "mis-wound vertices left: {left:?}");
    check("igea N = 4 at 1500 vertices", &mesh, &p, &plain);
}

/// Every shared mesh (igea with QUADCOVER_TEST_IGEA=1), N = 2, 4 (gaps on ½Z² and on 2Z², the
/// default), 6, at the default density and a coarse one (1500 vertices): no folded face, and
/// the conformal distortion (mean and 99th percentile) at most 5 % above the global step's map
/// (issue #15; worst +3.7 % at the 99th percentile on 2026-12-06, igea's 8 with them +4.0 %;
/// 4 cases at +5–13 % before the conformal relaxation reached beyond the changed faces).
#[test]
fn shared_meshes_have_no_folded_face() {
    if !Path::new(MESHES).exists() {
        eprintln!("skipping: {MESHES} not found");
        return;
    }
    let big = std::env::var("QUADCOVER_TEST_IGEA").is_ok();
    let mut checked = 0;
    let mut repaired = 0;
    let mut left: Vec<(String, usize)> = Vec::new();
    let mut wound = 0;
    let mut refined = 0;
    let mut distorted: Vec<String> = Vec::new();
    for name in meshes::EVERY_BUT_IGEA.into_iter().chain(["igea.obj"]) {
        if name == "igea.obj" && !big {
            eprintln!("skipping igea.obj (set QUADCOVER_TEST_IGEA=1)");
            continue;
        }
        let mesh = quadcover::load::load_mesh(&Path::new(MESHES).join(name))
            .unwrap()
            .mesh;
        for (n, pure_quad) in [(2u32, false), (4, false), (4, true), (6, false)] {
            let lattice = if pure_quad { " 2Z²" } else { "" };
            for density in [None, Some(1500)] {
                let (p, plain) = solve_both(&mesh, n, density, pure_quad);
                let label = format!("{name} N={n}{lattice} density={density:?}");
                eprintln!(
                    "{label}: folded {} -> {}, mis-wound {} -> {}, repair {:.1} ms, conformal {:.4}/{:.3} -> {:.4}/{:.3}, crowded {:?}",
                    plain.flipped_faces,
                    p.flipped_faces,
                    miswound(&mesh, &plain).len(),
                    p.miswound.len(),
                    p.timings.repair_ms,
                    plain.conformal_distortion.mean,
                    plain.conformal_distortion.p99,
                    p.conformal_distortion.mean,
                    p.conformal_distortion.p99,
                    p.crowded_refinement
                );
                // Poles (positive integral index) are treated by alg. 6 now, and the
                // close-pair cancellation leaves none on these meshes: the per-edge checks below
                // would have to take their star faces by their quads otherwise.
                assert!(p.poles.is_empty(), "{label}: a pole");
                check(&label, &mesh, &p, &plain);
                let (before, after) = (&plain.conformal_distortion, &p.conformal_distortion);
                if after.p99 > 1.05 * before.p99 || after.mean > 1.05 * before.mean {
                    distorted.push(format!(
                        "{label}: {:.4}/{:.3} -> {:.4}/{:.3}",
                        before.mean, before.p99, after.mean, after.p99
                    ));
                }
                repaired += usize::from(plain.flipped_faces > 0);
                wound += p.miswound.len();
                refined += usize::from(p.crowded_refinement.is_some());
                checked += 1;
                if p.flipped_faces > 0 {
                    left.push((
                        format!("{name} N={n}{lattice} {density:?}"),
                        p.flipped_faces,
                    ));
                }
            }
        }
    }
    eprintln!(
        "folds left: {left:?}; mis-wound vertices left: {wound}; second tries kept: {refined}"
    );
    // The cases the repair does not fully unfold yet (see docs/untangling.md): no other case
    // may fold, and these no more than listed.
    for (case, n) in &left {
        let known = KNOWN_LEFT.iter().find(|k| k.0 == case.as_str());
        assert!(
            known.is_some_and(|k| *n <= k.1),
            "{case}: {n} folded faces left after the repair"
        );
    }
    assert!(checked >= 70, "{checked} cases checked");
    assert!(
        distorted.is_empty(),
        "conformal distortion more than 5 % above the global step's map: {distorted:?}"
    );
    // Mis-wound vertices left over all cases: 263 before the rewinding (2026-12-02), 173
    // before the second rewinding on the final map, 97 before the tries around crowded
    // singularities, 40 before the re-rounding for windings (`reround_windings`), 12 since
    // (2026-12-04), 4 since it tries every candidate for the last pair (2026-12-06).
    assert!(
        big || wound <= 6,
        "{wound} mis-wound vertices left over the cases"
    );
    // The second try is kept where the first left folds or mis-wound vertices and it has
    // fewer (spot N = 6 at 1500 vertices among them): the mechanism is exercised.
    assert!(refined >= 5, "only {refined} second tries kept");
    // The repair had work to do on most of them (these meshes fold without it).
    assert!(
        repaired >= 20,
        "only {repaired} cases folded without the repair"
    );
}

/// A coarse density on the bunny (a scan with five holes) folds without the repair and not
/// with it; the vertices far from the folds do not move at all.
#[test]
fn the_repair_unfolds_what_no_untangle_keeps() {
    let Some(path) = meshes::shared("bunny.obj") else {
        return;
    };
    let mesh = quadcover::load::load_mesh(&path).unwrap().mesh;
    let (p, plain) = solve_both(&mesh, 4, Some(1500), false);
    assert!(
        plain.flipped_faces > 0,
        "the case must fold without the repair"
    );
    assert_eq!(p.flipped_faces, 0);
    assert!(p.timings.repair_ms > 0.0 && plain.timings.repair_ms == 0.0);
    check("bunny coarse", &mesh, &p, &plain);
    // Locality: corners of vertices more than a few dozen rings away keep their values bit
    // for bit (measured: a tenth of the corners move, the relaxed rings included).
    let moved = (0..p.uv.len()).filter(|&c| p.uv[c] != plain.uv[c]).count();
    assert!(moved > 0);
    assert!(
        moved * 5 < p.uv.len(),
        "{moved} of {} corners moved",
        p.uv.len()
    );
}

/// The repair's last step (`untangle::relax_conformal`) relaxes what the repair left more
/// distorted than the global step's map: on the bunny (N = 4, 27 folds, every branch point
/// rewound) the conformal distortion's p99 stays within the 5 % of the global step's
/// map (measured 2026-12-04: 1.972 → 1.985; 2.112, +7 %, without the step), the mean too; on
/// the cerebral vessels' stripes (N = 2, 32 folds) it takes more than one pass (2.339 → 2.492,
/// +7 %, with one; 2.35 with up to four).
#[test]
fn the_repair_keeps_the_distortion_of_the_global_step() {
    for (name, n) in [("bunny.obj", 4), ("cerebral-vessels.obj", 2)] {
        let Some(path) = meshes::shared(name) else {
            return;
        };
        let mesh = quadcover::load::load_mesh(&path).unwrap().mesh;
        let (p, plain) = solve_both(&mesh, n, None, false);
        assert!(
            plain.flipped_faces > 0,
            "{name}: the case must fold without the repair"
        );
        check(name, &mesh, &p, &plain);
        let (before, after) = (&plain.conformal_distortion, &p.conformal_distortion);
        assert!(
            after.p99 <= 1.05 * before.p99 && after.mean <= 1.05 * before.mean,
            "{name}: conformal distortion {:.3}/{:.3} -> {:.3}/{:.3}",
            before.mean,
            before.p99,
            after.mean,
            after.p99
        );
    }
}

/// Two +1/6 branch points of max-planck (N = 6, 1500 vertices) rounded onto one lattice point
/// collapse the edge between them: the global step's map has two faces of zero area, which no
/// repair can open. Counted as folds, they are re-rounded apart; before, their area of +4e-15
/// passed as unfolded and the remesh patched the hole they left.
#[test]
fn branch_points_rounded_onto_one_point_are_rounded_apart() {
    use quadcover::edit::{Settings, never};
    use quadcover::extract::{ExtractOptions, extract};
    let Some(path) = meshes::shared("max-planck.obj") else {
        return;
    };
    let solve = |no_untangle| {
        let settings = Settings {
            symmetry: 6,
            target_vertices: Some(1500),
            no_untangle,
            ..Default::default()
        };
        let base = meshes::base_for(&path, settings);
        let solved = base.solve(base.initial(), &never).unwrap();
        (base.mesh().clone(), solved.param)
    };
    let (_, plain) = solve(true);
    let degenerate = (0..plain.uv.len() / 3)
        .filter(|&f| relative_area(&plain.uv, f).abs() <= 1e-9)
        .count();
    assert!(
        degenerate >= 2,
        "the global step's map has {degenerate} zero-area faces"
    );
    assert_eq!(plain.flipped_faces, not_positive(&plain.uv).len());
    let (mesh, p) = solve(false);
    assert_eq!(
        not_positive(&p.uv),
        Vec::<usize>::new(),
        "folded or degenerate faces"
    );
    assert!(!p.rerounded_gaps.is_empty(), "no gap re-rounded");
    let r = extract(&mesh, &p.uv, 6, &ExtractOptions::default()).unwrap();
    assert_eq!(r.patched_places, 0);
}

/// Needles (angles far below 1°) in the region of the folds: the repair still unfolds
/// everything, keeps the map seamless and leaves no zero-area texture triangle.
#[test]
fn needle_triangles_do_not_break_the_repair() {
    // A torus with a constant direction projected on its faces (singularities and folds at a
    // coarse scale), one ring of vertices squeezed almost onto the next: needles of ~0.01°.
    let (nu, nv) = (40, 20);
    let mut mesh = quadcover::mesh::generate::torus(3.0, 1.0, nu, nv);
    let mut pos: Vec<glam::DVec3> = (0..mesh.n_vertices()).map(|v| mesh.position(v)).collect();
    for i in 0..nu {
        let (a, b) = (i, nu + i);
        pos[a] = pos[b] + (pos[a] - pos[b]) * 1e-4;
    }
    mesh.set_positions(pos);
    let needles = (0..mesh.n_faces())
        .filter(|&f| {
            let p = mesh.face(f).map(|v| mesh.position(v));
            (0..3).any(|k| {
                let (u, w) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                u.angle_between(w) < 1f64.to_radians()
            })
        })
        .count();
    assert!(needles >= nu, "{needles} needles");
    let frames = param::projected_frames(&mesh, glam::DVec3::new(1.0, 0.3, 0.2), 3.0);
    let matchings = param::fit_matchings(&mesh, 4, &frames);
    let solve = |no_untangle| {
        QuadCover::new(
            &mesh,
            4,
            &matchings,
            ParamOptions {
                no_untangle,
                ..Default::default()
            },
        )
        .unwrap()
        .solve(&mesh, &frames)
        .unwrap()
    };
    let (p, plain) = (solve(false), solve(true));
    eprintln!(
        "needle torus: folded {} -> {}",
        plain.flipped_faces, p.flipped_faces
    );
    assert!(
        plain.flipped_faces > 0,
        "the case must fold without the repair"
    );
    let err = contract_error(&mesh, &p.uv, 4, Lattice::Z2);
    assert!(err < 1e-6, "seam error {err}");
    assert!(p.uv.iter().all(|q| q[0].is_finite() && q[1].is_finite()));
    assert_eq!(p.flipped_faces, 0);
    assert_eq!(not_positive(&p.uv), Vec::<usize>::new());
}

/// The editor's stale jobs: a cancel check that says stop ends the solve with `Cancelled`
/// (during or after the repair), one that never does gives the repaired map.
#[test]
fn a_cancelled_repair_reports_cancelled() {
    let Some(path) = meshes::shared("spot.obj") else {
        return;
    };
    let mesh = quadcover::load::load_mesh(&path).unwrap().mesh;
    let params = FieldParams::default();
    let f = field::compute_field(&mesh, &params).unwrap().field;
    let qc = QuadCover::new(&mesh, 4, &f.matchings, ParamOptions::default()).unwrap();
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let stop = || calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed) >= 1;
    let r = qc.solve_with_curves_until(&mesh, &f.frames, &[], &stop);
    assert!(matches!(r, Err(param::ParamError::Cancelled)), "{r:?}");
    let p = qc
        .solve_with_curves_until(&mesh, &f.frames, &[], &|| false)
        .unwrap();
    assert!(
        p.flipped_faces_before_repair > 0,
        "spot folds without the repair"
    );
    assert_eq!(p.flipped_faces, 0);
}

/// On a sphere every point is an umbilic: no curvature direction to align to, and the relaxed
/// field, anchored almost nowhere, crowded its zeros together (the icosphere's N = 2 field had
/// its four +1/2 within 23° of each other; the UV sphere's N = 6 field a +1/2 and six +1/6
/// around one pole), and the maps folded by the hundred (215 and 632 faces left after the
/// repair). Such a field is renormalized (`field::smoothing::unanchored`): the singularities
/// spread out and nothing folds.
#[test]
fn fields_on_spheres_spread_their_singularities_and_fold_nothing() {
    use quadcover::mesh::generate::{icosphere, uv_sphere};
    for (name, mesh, n, count) in [
        ("icosphere", icosphere(3), 2, 4),
        ("UV sphere", uv_sphere(32, 64), 6, 12),
    ] {
        let (p, _) = solve_both(&mesh, n, None, false);
        assert_eq!(p.flipped_faces, 0, "{name}, N = {n}");
        assert_eq!(p.singularities.len(), count, "{name}, N = {n}");
        let positions: Vec<_> = p
            .singularities
            .iter()
            .map(|s| mesh.position(s.vertex))
            .collect();
        // Four points spread over a sphere are a regular tetrahedron's (109°) at best, twelve an
        // icosahedron's (63°; 40° measured on this UV sphere); crowded ones were 15–23° apart.
        let closest = positions
            .iter()
            .enumerate()
            .flat_map(|(i, a)| positions[i + 1..].iter().map(move |b| a.angle_between(*b)))
            .fold(f64::INFINITY, f64::min)
            .to_degrees();
        assert!(
            closest > 30.0,
            "{name}, N = {n}: singularities {closest:.0}° apart"
        );
    }
}

/// A torus (R = 3, r = 1, 120 × 40 grid) with a vertex here and there pushed 90–98 % of the way
/// to a neighbour, making slivers; the pseudo-random choice is seeded.
fn sliver_torus(seed: u64) -> TriMesh {
    let (nu, nv) = (120usize, 40usize);
    let mut s = seed;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let mut uv: Vec<[f64; 2]> = (0..nu * nv)
        .map(|k| [(k / nv) as f64 / nu as f64, (k % nv) as f64 / nv as f64])
        .collect();
    let mut moved = vec![false; nu * nv];
    for _ in 0..900 {
        let i = (next() % nu as u64) as usize;
        let j = (next() % nv as u64) as usize;
        let near = (i.saturating_sub(2)..(i + 3).min(nu))
            .any(|a| (j.saturating_sub(2)..(j + 3).min(nv)).any(|b| moved[a * nv + b]));
        if near {
            continue;
        }
        moved[i * nv + j] = true;
        let f = 0.9 + 0.08 * (next() % 1000) as f64 / 1000.0;
        if next() % 2 == 0 {
            uv[i * nv + j][0] += f / nu as f64;
        } else {
            uv[i * nv + j][1] += f / nv as f64;
        }
    }
    let tau = std::f64::consts::TAU;
    let positions = uv
        .iter()
        .map(|&[u, v]| {
            let (u, v) = (tau * u, tau * v);
            glam::DVec3::new(
                (3.0 + v.cos()) * u.cos(),
                (3.0 + v.cos()) * u.sin(),
                v.sin(),
            )
        })
        .collect();
    let mut faces = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let at = |a: usize, b: usize| ((a % nu) * nv + b % nv) as u32;
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    TriMesh::from_triangles(positions, faces).unwrap()
}

/// A torus whose field kept one pair of opposite singularities and no other: the loop around
/// the pair is the commutator of the handle loops, which turn nothing, so every seamless map put
/// both on one point and collapsed the sliver edge between them (two faces of zero area after
/// the repair, at N = 2, 4 and 6, on three of twelve seeds). The field cancels such a pair at
/// any distance.
#[test]
fn a_lone_singularity_pair_on_a_torus_is_cancelled() {
    for seed in [5u64, 8, 12] {
        let mesh = sliver_torus(seed * 7919 + 1);
        for n in [2, 4, 6] {
            let (p, _) = solve_both(&mesh, n, None, n == 4);
            assert_eq!(p.flipped_faces, 0, "seed {seed}, N = {n}");
            assert_eq!(
                not_positive(&p.uv),
                Vec::<usize>::new(),
                "seed {seed}, N = {n}"
            );
            assert!(
                p.singularities.is_empty(),
                "seed {seed}, N = {n}: {:?}",
                p.singularities
            );
        }
    }
}

/// A capsule (a cylinder closed by two hemispheres): the cylinder's rulings guide the field and
/// the domes, all umbilics, guide nothing. The relaxed field carried the rulings over each dome
/// and wound round its top: its N singularities crowded near the pole, polar cells (a capsule
/// from an STL: conformal distortion 1.47 at N = 4 and 1.35 at N = 6, remesh RSD edge 26 % and
/// 19 %). Such a pole cluster, a full turn of index over a patch with little Gaussian curvature, is
/// renormalized (`field::pole_cluster`): the singularities spread over the domes.
#[test]
fn capsule_domes_spread_their_singularities() {
    use quadcover::mesh::generate::icosphere;
    use quadcover::mesh::isotropic::{IsotropicOptions, isotropic_remesh};
    let half = 1.0;
    let mut sphere = icosphere(3);
    let stretched = sphere
        .positions()
        .iter()
        .map(|p| *p + glam::DVec3::Z * if p.z >= 0.0 { half } else { -half })
        .collect();
    sphere.set_positions(stretched);
    let mesh = isotropic_remesh(
        &sphere,
        &IsotropicOptions::for_vertices(&sphere, 6000, 35.0),
    )
    .unwrap();
    for n in [4u32, 6] {
        let (p, _) = solve_both(&mesh, n, None, false);
        let polar: Vec<f64> = p
            .singularities
            .iter()
            .map(|s| {
                let q = mesh.position(s.vertex);
                let top = glam::DVec3::Z * q.z.signum();
                (q - top * half).angle_between(top).to_degrees()
            })
            .collect();
        eprintln!(
            "capsule, N = {n}: {} singularities at {:.0?}° from their dome's top, conformal \
             distortion {:.3}, {} folds",
            polar.len(),
            polar,
            p.conformal_distortion.mean,
            p.flipped_faces
        );
        assert_eq!(p.flipped_faces, 0, "N = {n}");
        assert_eq!(polar.len(), 2 * n as usize, "N = {n}: {polar:?}");
        assert!(p.singularities.iter().all(|s| s.index > 0.0));
        // crowded: the nearest 16° (N = 4) and 4° (N = 6) from the top, conformal distortion
        // 1.37 and 1.35; spread: 49° and 32°, 1.10 and 1.07
        assert!(polar.iter().all(|&a| a > 20.0), "N = {n}: {polar:.0?}");
        assert!(p.conformal_distortion.mean < 1.15, "N = {n}");
    }
}
