//! Constraint curves (issue #14, thesis sec. 4.4, alg. 7): geometric curves lie on parameter
//! lines of the lattice, checked face by face on the final map (not through the solver's own
//! bookkeeping); a closed combinatorial loop makes a spiral close up; a combinatorial curve puts
//! two singularities on one line; contradictions name the curve; curve edits replay
//! bit-identically and broken curves are errors naming the curve and the position.

use quadcover::constraint::{CurveKind, shortest_edge_path};
use quadcover::edit::{Base, Edit, EditError, EditState, Settings, Solved};
use quadcover::mesh::{TriMesh, generate};
use quadcover::param::{ConstraintCurve, Lattice, Parameterization, QuadCover, fit_matchings};
use seams::contract_error;

#[path = "support/seams.rs"]
mod seams;

#[path = "support/meshes.rs"]
mod meshes;
use meshes::{base_for, shared};

#[path = "support/remesh_checks.rs"]
mod remesh_checks;

/// The remesh `solve --remesh` makes of a solved state (relaxation keeps its vertices on the
/// state's curves) and how well its edges run along the curves: the share of the curves'
/// samples within 1e-3 of the bounding-box diagonal (the issue's tolerance for "a mesh edge
/// along every sharp edge") of a remesh edge along them, and the samples that miss (printed
/// with the worst distance and the patched places under `what`).
fn remesh_along_curves(
    base: &Base,
    state: &EditState,
    solved: &Solved,
    what: &str,
) -> (quadcover::extract::Remesh, f64, Vec<glam::DVec3>) {
    let mesh = base.mesh();
    let n = base.settings().symmetry as u8;
    let options = quadcover::extract::ExtractOptions {
        constrained_edges: quadcover::constraint::curve_edges(mesh, state.curves.values()),
        ..Default::default()
    };
    let remesh = quadcover::extract::extract(mesh, &solved.param.uv, n, &options).unwrap();
    let along: Vec<_> = state
        .curves
        .values()
        .flat_map(|c| c.segments())
        .map(|(a, b)| (mesh.position(a), mesh.position(b)))
        .collect();
    let (lo, hi) = mesh.bounding_box();
    let diagonal = (hi - lo).length();
    let (share, worst, misses) = remesh_checks::edges_along(&remesh, &along, 1e-3 * diagonal);
    eprintln!(
        "{what} remesh: {:.2} % of the curves' samples within 1e-3 of the diagonal of a remesh edge along them (worst {:.2e} of the diagonal), {} patched places",
        100.0 * share,
        worst / diagonal,
        remesh.patched_places
    );
    (remesh, share, misses)
}

fn replay_solve(base: &Base, edits: &[Edit]) -> (EditState, Solved) {
    let r = base.replay(edits, &quadcover::edit::never).unwrap();
    assert!(r.skipped.is_empty(), "skipped: {:?}", r.skipped);
    let state = r.last().clone();
    let solved = base.solve(&state, &quadcover::edit::never).unwrap();
    (state, solved)
}

/// Line normals and spacing of the lattice lines (Z²: u and v lines at integers; G6: the three
/// families of the triangular lattice, spaced √3/2).
fn families(n: usize) -> (Vec<[f64; 2]>, f64) {
    if n == 6 {
        let f = (0..3)
            .map(|l| {
                let a = std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * l as f64 / 3.0;
                [a.cos(), a.sin()]
            })
            .collect();
        (f, 3f64.sqrt() / 2.0)
    } else {
        (vec![[1.0, 0.0], [0.0, 1.0]], 1.0)
    }
}

/// Worst deviation of a mesh edge (a, b) from a lattice line, over the faces at the edge: in
/// each, some family's coordinate must be equal at both ends and a multiple of the spacing.
fn line_error(mesh: &TriMesh, uv: &[[f64; 2]], n: usize, a: usize, b: usize) -> f64 {
    let (fam, s) = families(n);
    let h = mesh
        .outgoing(a)
        .find(|&h| mesh.to(h) == b)
        .or_else(|| mesh.outgoing(b).find(|&h| mesh.to(h) == a))
        .expect("curve edge");
    let mut worst: f64 = 0.0;
    for h in [Some(h), mesh.twin(h)].into_iter().flatten() {
        let (p, q) = (uv[h], uv[mesh.next(h)]);
        let best = fam
            .iter()
            .map(|nl| {
                let (x, y) = (
                    (nl[0] * p[0] + nl[1] * p[1]) / s,
                    (nl[0] * q[0] + nl[1] * q[1]) / s,
                );
                (x - y).abs() + (x - x.round()).abs()
            })
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(best);
    }
    worst
}

fn check_geometric(base: &Base, state: &EditState, solved: &Solved) -> usize {
    let mesh = base.mesh();
    let n = base.settings().symmetry as usize;
    let p = &solved.param;
    let lattice = if n == 6 { Lattice::G6 } else { Lattice::Z2 };
    assert!(
        contract_error(mesh, &p.uv, n, lattice) < 1e-6,
        "not seamless"
    );
    // Ear tips are left off the line (one line through a face's three corners would fold
    // it): the face's third edge, between the tip's neighbours, is on the line instead.
    let ears: std::collections::BTreeSet<usize> =
        p.curves.iter().flat_map(|c| c.ear_tips.clone()).collect();
    let mut edges = 0;
    for c in state.curves.values() {
        if c.kind != CurveKind::Geometric {
            continue;
        }
        let v = &c.vertices;
        for (a, b) in c.segments() {
            edges += 1;
            if ears.contains(&a) || ears.contains(&b) {
                continue;
            }
            let e = line_error(mesh, &p.uv, n, a, b);
            assert!(e < 1e-6, "curve {} edge {a}-{b} is off a line by {e}", c.id);
        }
        for (i, &m) in v.iter().enumerate() {
            if !ears.contains(&m) {
                continue;
            }
            let k = v.len();
            let (a, b) = (v[(i + k - 1) % k], v[(i + 1) % k]);
            assert!(
                mesh.outgoing(a).any(|h| mesh.to(h) == b),
                "ear tip {m}: its neighbours {a}, {b} share no edge"
            );
            let e = line_error(mesh, &p.uv, n, a, b);
            assert!(
                e < 1e-6,
                "curve {} chord {a}-{b} of ear tip {m} is off a line by {e}",
                c.id
            );
        }
    }
    edges
}

#[test]
fn fandisk_features_lie_on_parameter_lines() {
    let Some(path) = shared("fandisk.obj") else {
        return;
    };
    let base = base_for(&path, Settings::default());
    let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
    let sharp = quadcover::constraint::feature_edges(base.mesh(), 40.0).len();
    let edges = check_geometric(&base, &state, &solved);
    assert_eq!(edges, sharp, "every sharp edge is on a curve");
    assert!(!solved.param.curves.is_empty());
    assert!(solved.param.curves.iter().all(|c| c.max_offset < 1e-6));
    // No singularity one edge off a curve: the design moves them onto it (a crease through
    // a branch point turns a corner there on one side).
    let mesh = base.mesh();
    let mut on_curve = vec![false; mesh.n_vertices()];
    for c in state.curves.values() {
        for &v in &c.vertices {
            on_curve[v] = true;
        }
    }
    let singular: Vec<usize> = solved
        .param
        .singularities
        .iter()
        .map(|s| s.vertex)
        .collect();
    for &p in &singular {
        let beside = mesh
            .outgoing(p)
            .map(|h| mesh.to(h))
            .find(|&q| on_curve[q] && !mesh.is_boundary_vertex(q) && !singular.contains(&q));
        assert!(
            on_curve[p] || beside.is_none(),
            "singularity {p} is one edge off curve vertex {beside:?}"
        );
    }
    // Nor is one farther off rounded onto a curve's line beside it (`off_lines`).
    let on_lines = singularities_on_curve_lines(&base, &state, &solved.param, 3.0);
    assert!(
        on_lines.is_empty(),
        "on curve lines beside them: {on_lines:?}"
    );
    let through = singular
        .iter()
        .filter(|&&p| {
            solved
                .param
                .curves
                .iter()
                .any(|c| c.singular_vertices.contains(&p))
        })
        .count();
    eprintln!(
        "fandisk, features at 40°: {through} of {} singularities on curves, {} flipped faces",
        singular.len(),
        solved.param.flipped_faces
    );
    // 84 before the singularities moved onto the curves and the runs could turn at them
    // (2Z², 2026-12-02); 6 where two opposite ones one edge apart shared a lattice point,
    // until the re-rounding under curves moved them apart along their crease; 2 where two
    // creases meet at 19° (both on one line, the faces between them squeezed), until the
    // faces of acute corners turned the frame (2026-12-03).
    assert_eq!(
        solved.param.flipped_faces, 0,
        "{} folded faces",
        solved.param.flipped_faces
    );
    // That corner's apex is a singularity: its cone angle is the wedge's 90° and 360° for
    // the rest.
    let apexes =
        quadcover::constraint::acute_corners(mesh, state.curves.values(), 4, base.grid_size())
            .apexes;
    assert!(!apexes.is_empty(), "fandisk has an acute corner at 40°");
    for a in &apexes {
        assert!(singular.contains(a), "apex {a} is no singularity");
    }
    assert!(
        !solved.param.rerounded_gaps.is_empty(),
        "the folds left by the repair were re-rounded"
    );
    // The quad remesh has an edge along every sharp edge.
    let (remesh, share, misses) = remesh_along_curves(&base, &state, &solved, "fandisk");
    // 98.5 % in the issue's first measurement (2026-12-01), 98.8 % with 2 folds at the acute
    // corner (2026-12-03, before its frame turned), 99.6 % until the relaxation moved chain
    // vertices onto the creases' bends and loose ends (2026-12-06): the misses were remesh
    // edges cutting a crease's bend (a chord 0.02 off, the tolerance 0.0076) and crease ends
    // just off a remesh vertex (docs/remesh.md). Now every sample.
    assert!(
        misses.is_empty(),
        "{:.2} % of the sharp edges' samples; misses at {:?}",
        100.0 * share,
        &misses[..misses.len().min(4)]
    );
    assert!(
        remesh.patched_places <= 3,
        "{} patched places",
        remesh.patched_places
    );
}

/// Other feature angles: other curves and other corners (fandisk at 30°, 35°, 50° and 60°).
#[test]
fn fandisk_features_at_other_angles() {
    let Some(path) = shared("fandisk.obj") else {
        return;
    };
    let base = base_for(&path, Settings::default());
    // Folds before the acute corners' frame (2026-12-03): 2, 2, 9, 4.
    for (angle, most) in [(30.0, 0), (35.0, 0), (50.0, 2), (60.0, 0)] {
        let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: angle }]);
        check_geometric(&base, &state, &solved);
        eprintln!(
            "fandisk, features at {angle}°: {} flipped faces",
            solved.param.flipped_faces
        );
        assert!(
            solved.param.flipped_faces <= most,
            "{angle}°: {} folded faces",
            solved.param.flipped_faces
        );
    }
}

/// Coarser grids: fandisk's 19° corner between two creases keeps its singularity at the apex
/// when the +1/4 one edge along a crease from it is within the cancellation radius (a grid
/// cell), as it is at 2000 and 3000 target vertices. Cancelled, the corner had no singularity
/// and the map kept 6 and 5 folded faces beside it.
#[test]
fn fandisk_acute_apex_keeps_its_singularity_on_coarse_grids() {
    let Some(path) = shared("fandisk.obj") else {
        return;
    };
    for target in [2000, 3000] {
        let settings = Settings {
            target_vertices: Some(target),
            ..Settings::default()
        };
        let base = base_for(&path, settings);
        let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
        check_geometric(&base, &state, &solved);
        let apexes = quadcover::constraint::acute_corners(
            base.mesh(),
            state.curves.values(),
            4,
            base.grid_size(),
        )
        .apexes;
        eprintln!(
            "fandisk at {target} target vertices, features at 40°: apexes {apexes:?}, {} singularities, {} flipped faces",
            solved.param.singularities.len(),
            solved.param.flipped_faces
        );
        assert!(!apexes.is_empty(), "fandisk has an acute corner at 40°");
        for a in &apexes {
            assert!(
                solved.param.singularities.iter().any(|s| s.vertex == *a),
                "{target}: apex {a} is no singularity"
            );
        }
        assert_eq!(
            solved.param.flipped_faces, 0,
            "{target}: {} folded faces",
            solved.param.flipped_faces
        );
    }
}

/// Parallel creases under two grid cells apart: a box 4 × 2 × 1 with seven slots 0.2 wide and
/// 0.6 deep across its top (`tests/data/comb7.obj`, the raw part as trimesh's boolean difference
/// of boxes writes it: 64 vertices), remeshed as `solve` does, at 1500 target vertices with
/// features at 40°. On 2Z² every corner of a slot is a singularity on an even lattice point, so
/// a slot is 0 or at least 2 cells wide; here it measures 1.3, and the rounding put one slot's
/// walls on one line (265 folded faces after the repair, the slot's floor folded end to end).
/// The map is solved again on Z² (`Base::on_z2_if_folded`): no fold, and the remesh is all
/// quads. The rounding's collapsed strips are counted (`Parameterization::collapsed_strips`):
/// with them the 2Z² map takes no crowded tries before that (5 s of tries, none kept).
#[test]
fn narrow_slots_at_a_coarse_grid_are_solved_on_z2() {
    let mesh = remeshed_as_solve_does(&test_data("comb7.obj"));
    let settings = Settings {
        target_vertices: Some(1500),
        ..Settings::default()
    };
    let (base, state, solved, _) = with_features_at_40(mesh, settings, "comb at 1500");
    check_geometric(&base, &state, &solved);
    let p = &solved.param;
    assert_eq!(p.lattice, Lattice::Z2, "the 2Z² map was kept");
    assert_eq!(p.flipped_faces, 0, "{} folded faces", p.flipped_faces);
    // The 2Z² rounding put slot corners on the lines of the walls across (12 measured
    // 2026-12-07), which sends the folded map to Z² without crowded tries.
    assert!(
        p.collapsed_strips >= 4,
        "{} collapsed strips",
        p.collapsed_strips
    );
    let (remesh, _, _) = remesh_along_curves(&base, &state, &solved, "comb at 1500");
    remesh_checks::assert_manifold(&remesh, "comb at 1500");
    assert!(remesh.faces.iter().all(|f| f.len() == 4), "not all quads");
    assert_eq!(
        remesh.euler_characteristic(),
        base.mesh().euler_characteristic()
    );
}

/// A shared mesh solved with its boundary aligned (default settings but `n`), or None without
/// the shared meshes.
fn aligned(name: &str, n: u32) -> Option<(Base, EditState, Solved)> {
    let path = shared(name)?;
    let settings = Settings {
        symmetry: n,
        ..Settings::default()
    };
    let base = base_for(&path, settings);
    let (state, solved) = replay_solve(&base, &[Edit::AlignBoundary { on: true }]);
    Some((base, state, solved))
}

#[test]
fn boundaries_lie_on_parameter_lines() {
    let cases = [
        ("camelhead.obj", 4),
        ("camelhead.obj", 6),
        ("bunny.obj", 4),
        ("bunny.obj", 6),
    ];
    for (name, n) in cases {
        let Some((base, state, solved)) = aligned(name, n) else {
            return;
        };
        let boundary: usize = base.mesh().boundary_loops().iter().map(|l| l.len()).sum();
        let edges = check_geometric(&base, &state, &solved);
        assert_eq!(edges, boundary, "{name}: every boundary edge is on a curve");
        let ears: usize = solved.param.curves.iter().map(|c| c.ear_tips.len()).sum();
        eprintln!(
            "{name} N = {n}: {edges} boundary edges on lines ({ears} ear tips off them), {} flipped faces",
            solved.param.flipped_faces
        );
        // Jagged scanned boundaries: no corner a fraction of a cell from another, no run of a
        // line shorter than half a cell, no ear on one line (each folded faces before).
        assert_eq!(
            solved.param.flipped_faces, 0,
            "{name} N = {n}: folded faces"
        );
        // The remesh's boundary runs along the input's.
        let (remesh, share, _) =
            remesh_along_curves(&base, &state, &solved, &format!("{name} N = {n}"));
        // Measured 2026-12-03: camelhead 97.4 % (N = 4) and 98.0 % (N = 6), the bunny 79.2 %.
        // What misses is mostly within a few tolerances: the remesh's boundary edges are chords
        // between grid points on the boundary line, and the input's boundary bends between
        // them (the bunny's scanned holes are jagged at well under a cell); the rest lies at
        // patched places.
        let floor = if name == "bunny.obj" { 0.75 } else { 0.97 };
        assert!(
            share >= floor,
            "{name} N = {n}: {:.2} % of the boundary's samples",
            100.0 * share
        );
        assert!(
            remesh
                .faces
                .iter()
                .all(|f| f.len() == if n == 6 { 3 } else { 4 })
        );
        // A manifold copy of the input: the bunny N = 6 had two sides of a narrow hole meet at
        // one grid point (a vertex with two fans, Euler characteristic −4 instead of −3) before
        // pinched vertices were split (src/extract/pinch.rs).
        remesh_checks::assert_manifold(&remesh, &format!("{name} N = {n}"));
        assert_eq!(
            remesh.euler_characteristic(),
            base.mesh().euler_characteristic(),
            "{name} N = {n}: Euler characteristic"
        );
    }
}

/// The bunny with its boundary aligned at 1500 vertices, symmetry `n`, replayed and solved
/// (`None` without the shared meshes).
fn bunny_aligned_at_1500(n: u32) -> Option<(Base, EditState, Solved)> {
    let path = shared("bunny.obj")?;
    let settings = Settings {
        symmetry: n,
        target_vertices: Some(1500),
        ..Settings::default()
    };
    let base = base_for(&path, settings);
    let (state, solved) = replay_solve(&base, &[Edit::AlignBoundary { on: true }]);
    Some((base, state, solved))
}

/// The bunny with its boundary aligned, N = 4 at 1500 vertices, keeps few wrongly wound
/// vertices. It kept 28 while a constrained map whose gaps were rounded again was not rewound
/// afterwards (the space at hand was the first map's), 16 once it was; since the rounding keeps
/// branch points off the lines beside them (`param::constraints::off_lines`, 2026-12-07) its
/// first map needs no re-rounding and keeps 8 (the re-rounding itself is checked on fandisk).
#[test]
fn the_aligned_bunny_at_1500_vertices_keeps_few_wrongly_wound_vertices() {
    let Some((base, state, solved)) = bunny_aligned_at_1500(4) else {
        return;
    };
    let p = &solved.param;
    eprintln!(
        "bunny aligned, N = 4, 1500 vertices: {} mis-wound, re-rounded {:?}",
        p.miswound.len(),
        p.rerounded_gaps
    );
    assert_eq!(p.flipped_faces, 0);
    assert!(p.miswound.len() <= 8, "{} mis-wound", p.miswound.len());
    check_geometric(&base, &state, &solved);
}

/// Many mis-wound vertices under curves take a finer try around crowded singularities
/// (`param::crowded::FEW_MISWOUND`), as folds do. The bunny with its boundary aligned, N = 6 at
/// 1500 vertices, kept 20 mis-wound vertices on the uniform grid (10 since the constrained
/// solve rewinds after its re-rounding too), and the remesh patched 28
/// places, one of them closing a hole (Euler characteristic −2 instead of −3); on the finer try
/// 8 are left and the remesh is a manifold copy of the input.
#[test]
fn many_miswound_vertices_under_curves_take_a_finer_try() {
    let Some((base, state, solved)) = bunny_aligned_at_1500(6) else {
        return;
    };
    let p = &solved.param;
    eprintln!(
        "bunny aligned, N = 6, 1500 vertices: {} mis-wound, crowded refinement {:?}",
        p.miswound.len(),
        p.crowded_refinement
    );
    assert_eq!(p.flipped_faces, 0);
    assert!(p.crowded_refinement.is_some(), "no finer try was kept");
    assert!(p.miswound.len() <= 12, "{} mis-wound", p.miswound.len());
    check_geometric(&base, &state, &solved);
    let (remesh, _, _) = remesh_along_curves(&base, &state, &solved, "bunny aligned, N = 6, 1500");
    remesh_checks::assert_manifold(&remesh, "bunny aligned, N = 6, 1500");
    assert_eq!(
        remesh.euler_characteristic(),
        base.mesh().euler_characteristic(),
        "Euler characteristic"
    );
}

/// Composes the map's transitions over the faces left of the path (clockwise around each inner
/// vertex) and returns the value at the last vertex in the first face's chart, with the value
/// at the first vertex.
fn along_left(mesh: &TriMesh, p: &Parameterization, path: &[usize]) -> ([f64; 2], [f64; 2]) {
    let n = p.symmetry;
    let rot = |r: u8, x: [f64; 2]| {
        let a = std::f64::consts::TAU * r as f64 / n as f64;
        let (c, s) = (a.cos(), a.sin());
        [c * x[0] + s * x[1], -s * x[0] + c * x[1]]
    };
    let hs: Vec<usize> = path
        .windows(2)
        .map(|w| mesh.outgoing(w[0]).find(|&h| mesh.to(h) == w[1]).unwrap())
        .collect();
    // chart: first-face chart -> current chart is x ↦ R^k x + t; we track the inverse map
    // current -> first as a list of steps instead (apply in reverse).
    let mut steps: Vec<(u8, [f64; 2], bool)> = Vec::new();
    for i in 0..hs.len() - 1 {
        let mut g = mesh.next(hs[i]);
        while g != hs[i + 1] {
            let e = mesh.edge(g);
            let t = p.transitions[e];
            let forward = mesh.edge_halfedges(e).0 == g;
            steps.push((t.rotation, t.translation, forward));
            g = mesh.next(mesh.twin(g).unwrap());
        }
    }
    let mut x = p.uv[mesh.next(*hs.last().unwrap())];
    for &(r, t, forward) in steps.iter().rev() {
        // uv_j = R^r uv_i + t (i the face of the edge's first halfedge).
        x = if forward {
            // We came from i to j: x is in j; back to i: R^{-r}(x − t).
            rot(((n as u8) - r) % n as u8, [x[0] - t[0], x[1] - t[1]])
        } else {
            let y = rot(r, x);
            [y[0] + t[0], y[1] + t[1]]
        };
    }
    (p.uv[hs[0]], x)
}

#[test]
fn a_combinatorial_curve_puts_two_singularities_on_one_line() {
    let Some(path) = shared("spot.obj") else {
        return;
    };
    let base = base_for(&path, Settings::default());
    let mesh = base.mesh().clone();
    let s0 = base.initial().clone();
    let solved0 = base.solve(&s0, &quadcover::edit::never).unwrap();
    // A pair of singularities a few cells apart not on one line.
    let sing: Vec<usize> = s0.singularities.keys().copied().collect();
    let mut chosen = None;
    'outer: for &p in &sing {
        for &q in &sing {
            if p >= q {
                continue;
            }
            let Some(path) = shortest_edge_path(&mesh, p, q) else {
                continue;
            };
            if path.len() < 6
                || path.len() > 30
                || path[1..path.len() - 1]
                    .iter()
                    .any(|v| sing.contains(v) || mesh.is_boundary_vertex(*v))
            {
                continue;
            }
            let (a, b) = along_left(&mesh, &solved0.param, &path);
            if (a[0] - b[0]).abs() > 0.25 && (a[1] - b[1]).abs() > 0.25 {
                chosen = Some(path);
                break 'outer;
            }
        }
    }
    let path = chosen.expect("a pair of singularities off one line");
    let file: Vec<usize> = path.iter().map(|&v| base.file_vertex(v)).collect();
    let (_, solved) = replay_solve(
        &base,
        &[Edit::AddCurve {
            id: 7,
            vertices: file,
            closed: false,
            kind: CurveKind::Combinatorial,
        }],
    );
    let (a, b) = along_left(&mesh, &solved.param, &path);
    let off = (a[0] - b[0]).abs().min((a[1] - b[1]).abs());
    assert!(
        off < 1e-6,
        "singularities {a:?} and {b:?} are not on one line"
    );
}

/// A cylinder with a helical field: the parameter lines spiral, unless a closed combinatorial
/// loop around it makes the lines along it close up (fig. 4.21).
#[test]
fn a_closed_combinatorial_loop_closes_the_spiral() {
    let mesh = generate::cylinder(1.0, 2.0, 48, 24);
    let alpha: f64 = 25f64.to_radians();
    let frames: Vec<[glam::DVec3; 2]> = (0..mesh.n_faces())
        .map(|f| {
            let c = mesh.face_centroid(f);
            let et = glam::DVec3::new(-c.y, c.x, 0.0).normalize();
            let ez = glam::DVec3::Z;
            let n = mesh.face_normal(f);
            let mut u = et * alpha.cos() + ez * alpha.sin();
            u -= n * n.dot(u);
            let u = u.normalize() * 3.0;
            [u, n.cross(u)]
        })
        .collect();
    let matchings = fit_matchings(&mesh, 4, &frames);
    let qc = QuadCover::new(&mesh, 4, &matchings, Default::default()).unwrap();
    // The ring of vertices at mid-height (vertex rows of nu = 48 around).
    let ring: Vec<usize> = (0..48).map(|i| 12 * 48 + i).collect();
    assert!(quadcover::constraint::check_path(&mesh, &ring, true).is_ok());
    let free = qc.solve(&mesh, &frames).unwrap();
    let curve = ConstraintCurve {
        id: 3,
        vertices: &ring,
        closed: true,
        geometric: false,
    };
    let closed = qc.solve_with_curves(&mesh, &frames, &[curve]).unwrap();
    // Going once around: the value returned at the ring's first vertex.
    let mut around = ring.clone();
    around.push(ring[0]);
    around.push(ring[1]);
    let family = closed.curves[0].family as usize;
    let shift = |p: &Parameterization| {
        let (a, b) = along_left(&mesh, p, &around[..around.len() - 1]);
        (a[family] - b[family]).abs()
    };
    assert!(
        shift(&free) > 0.5,
        "the free map spirals: shift {}",
        shift(&free)
    );
    assert!(
        shift(&closed) < 1e-6,
        "the loop closes: shift {}",
        shift(&closed)
    );
    assert!(closed.seam_max_error < 1e-6);
}

#[test]
fn a_closed_combinatorial_loop_around_one_singularity_is_a_contradiction() {
    let Some(path) = shared("spot.obj") else {
        return;
    };
    let base = base_for(&path, Settings::default());
    let mesh = base.mesh().clone();
    let s0 = base.initial().clone();
    // A singularity whose 1-ring holds no other.
    let (&p, _) = s0
        .singularities
        .iter()
        .find(|(v, _)| {
            mesh.one_ring(**v)
                .iter()
                .all(|w| !s0.singularities.contains_key(w) && !mesh.is_boundary_vertex(*w))
        })
        .unwrap();
    let ring: Vec<usize> = mesh
        .one_ring(p)
        .iter()
        .map(|&v| base.file_vertex(v))
        .collect();
    let r = base.replay(
        &[Edit::AddCurve {
            id: 11,
            vertices: ring,
            closed: true,
            kind: CurveKind::Combinatorial,
        }],
        &quadcover::edit::never,
    );
    let state = r.unwrap().last().clone();
    match base.solve(&state, &quadcover::edit::never) {
        Err(EditError::Contradiction { curves, message }) => {
            assert_eq!(curves, vec![11]);
            assert!(message.contains("curve 11"), "{message}");
        }
        other => panic!(
            "expected a contradiction, got {:?}",
            other.map(|s| s.param.flipped_faces)
        ),
    }
}

#[test]
fn curve_edits_replay_bit_identically_and_undo_exactly() {
    let Some(path) = shared("camelhead.obj") else {
        return;
    };
    let base = base_for(&path, Settings::default());
    let mesh = base.mesh().clone();
    let a = 100;
    let b = mesh.one_ring(a)[0];
    let ring_a = mesh.one_ring(a);
    let c = mesh
        .one_ring(b)
        .into_iter()
        .find(|&x| x != a && !ring_a.contains(&x))
        .unwrap();
    let f = |v: usize| base.file_vertex(v);
    let edits = vec![
        Edit::AlignBoundary { on: true },
        Edit::AddCurve {
            id: 50,
            vertices: vec![f(a), f(b), f(c)],
            closed: false,
            kind: CurveKind::Geometric,
        },
        Edit::SetCurveKind {
            id: 50,
            kind: CurveKind::Combinatorial,
        },
        Edit::RemoveCurve { id: 50 },
        Edit::AlignBoundary { on: false },
    ];
    let r1 = base.replay(&edits, &quadcover::edit::never).unwrap();
    let r2 = base.replay(&edits, &quadcover::edit::never).unwrap();
    assert!(r1.skipped.is_empty());
    assert_eq!(r1.states, r2.states);
    // Undo to after the first edit: the replayed prefix is the cached state.
    let prefix = base.replay(&edits[..1], &quadcover::edit::never).unwrap();
    assert_eq!(prefix.last(), &r1.states[1]);
    assert!(r1.states[1].curves.len() > 1);
    assert_eq!(r1.states[2].curves[&50].kind, CurveKind::Geometric);
    assert_eq!(r1.states[3].curves[&50].kind, CurveKind::Combinatorial);
    assert!(!r1.states[4].curves.contains_key(&50));
    // Boundary alignment off: back to the initial field exactly.
    assert_eq!(r1.last().turns, base.initial().turns);
    assert!(r1.last().curves.is_empty());
    let s1 = base.solve(&r1.states[2], &quadcover::edit::never).unwrap();
    let s2 = base.solve(&r2.states[2], &quadcover::edit::never).unwrap();
    assert_eq!(s1.param.uv, s2.param.uv);
    // A broken curve names itself and the positions.
    let broken = Edit::AddCurve {
        id: 4,
        vertices: vec![f(a), f(c)],
        closed: false,
        kind: CurveKind::Geometric,
    };
    let why = base.check_edit(&broken).unwrap_err();
    assert!(
        why.contains("curve 4") && why.contains("positions 0 and 1"),
        "{why}"
    );
    let r = base.replay(&[broken], &quadcover::edit::never).unwrap();
    assert_eq!(r.skipped.len(), 1);
}

#[test]
fn cli_features_and_broken_curve_files() {
    let Some(path) = shared("fandisk.obj") else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("qc-constraints-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let exe = env!("CARGO_BIN_EXE_quadcover");
    let uv = dir.join("uv.obj");
    let (_, r) = solve_cli(
        &[
            path.as_os_str(),
            "--features".as_ref(),
            "40".as_ref(),
            "--out".as_ref(),
            uv.as_os_str(),
        ],
        &dir.join("r.json"),
    );
    let curves = r["curves"].as_array().unwrap();
    assert!(curves.len() >= 20);
    assert!(
        curves
            .iter()
            .all(|c| c["max_offset"].as_f64().unwrap() < 1e-6)
    );
    // A project whose curve skips an edge: exit code 2, the edit and the positions named.
    let project = dir.join("p.json");
    std::fs::write(
        &project,
        format!(
            r#"{{"format": "quadcover-project", "version": 1, "mesh": {{"path": "{}"}},
                "settings": {{}}, "edits": [{{"op": "add_curve", "id": 0, "vertices": [0, 5000], "closed": false, "kind": "geometric"}}]}}"#,
            path.display()
        ),
    )
    .unwrap();
    let out = std::process::Command::new(exe)
        .args(["solve", "--project", project.to_str().unwrap(), "--out"])
        .arg(dir.join("uv2.obj"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("edit 1") && err.contains("curve 0") && err.contains("positions 0 and 1"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A cap whose rim is an aligned curve: the relaxed field is the harmonic extension of the
/// rim's winding, with one zero of order N at the centre, which rounded to a pole (+1) with
/// polar cells (2026-12-03 before the renormalization: conformal distortion 1.93, p99 7.05,
/// 70 irregular remesh vertices at N = 4). Renormalized, each cap gets N singularities of
/// index +1/N and the map is nearly conformal.
#[test]
fn aligned_rims_give_caps_quarter_singularities_not_poles() {
    // Radius 0.5, height 1.2; the rims are sharp (90°), so features at 40° make them closed
    // geometric curves around the flat caps.
    let mesh = std::sync::Arc::new(generate::capped_cylinder(0.5, 1.2, 64, 24, 12));
    for n in [4u32, 6] {
        let settings = Settings {
            symmetry: n,
            ..Settings::default()
        };
        let base = Base::for_mesh(mesh.clone(), settings).unwrap();
        let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
        let what = format!("capped cylinder, N = {n}");
        assert_eq!(state.curves.len(), 2, "{what}: the two rims");
        check_geometric(&base, &state, &solved);
        let p = &solved.param;
        let ks: Vec<f64> = p.singularities.iter().map(|s| s.index * n as f64).collect();
        eprintln!(
            "{what}: singularities {ks:?}, conformal distortion {:.3} (p99 {:.2}), {} folds",
            p.conformal_distortion.mean, p.conformal_distortion.p99, p.flipped_faces
        );
        assert!(p.poles.is_empty(), "{what}: poles");
        // Indices in units of 1/N.
        assert!(
            ks.iter().all(|&k| (k - 1.0).abs() < 1e-9),
            "{what}: indices {ks:?}"
        );
        assert_eq!(p.flipped_faces, 0, "{what}");
        // N = 6 (measured 1.26, p99 4.6): six +1/6 balance the rim about a ring from it, and
        // the faces between are stretched.
        let p99 = if n == 4 { 2.0 } else { 5.0 };
        assert!(
            p.conformal_distortion.mean < 1.3 && p.conformal_distortion.p99 < p99,
            "{what}: conformal distortion {:?}",
            p.conformal_distortion
        );
        let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, &what);
        assert_eq!(remesh.patched_places, 0, "{what}");
        assert!(share > 0.99, "{what}: {share}");
    }
}

/// A triangle with corners of `alpha` and 90° (in degrees) on a base of 4, as a flat sheet
/// (`height` 0) or the prism over it, remeshed isotropically to about `vertices` vertices with
/// its edges kept (as `solve` would a CAD part's tessellation).
fn triangle_part(alpha: f64, height: f64, vertices: usize) -> std::sync::Arc<TriMesh> {
    let corners = [
        (0.0, 0.0),
        (4.0, 0.0),
        (4.0, 4.0 * alpha.to_radians().tan()),
    ];
    extruded(&corners, &[[0, 1, 2]], height, vertices)
}

/// A polygon (counter-clockwise, triangulated by `cap`) as a flat sheet (`height` 0) or the
/// prism over it, remeshed isotropically to about `vertices` vertices with its edges kept.
fn extruded(
    polygon: &[(f64, f64)],
    cap: &[[u32; 3]],
    height: f64,
    vertices: usize,
) -> std::sync::Arc<TriMesh> {
    use quadcover::mesh::isotropic::{IsotropicOptions, isotropic_remesh};
    let raw = raw_extruded(polygon, cap, height);
    let opts = IsotropicOptions::for_vertices(&raw, vertices, 35.0);
    std::sync::Arc::new(isotropic_remesh(&raw, &opts).unwrap())
}

/// [`extruded`] as a CAD exporter writes it: the polygon's vertices only.
fn raw_extruded(polygon: &[(f64, f64)], cap: &[[u32; 3]], height: f64) -> TriMesh {
    use glam::DVec3;
    let layer = |z: f64| polygon.iter().map(move |&(x, y)| DVec3::new(x, y, z));
    let (positions, faces): (Vec<DVec3>, Vec<[u32; 3]>) = if height == 0.0 {
        (layer(0.0).collect(), cap.to_vec())
    } else {
        let n = polygon.len() as u32;
        let mut faces: Vec<[u32; 3]> = cap.iter().map(|&[a, b, c]| [a, c, b]).collect();
        faces.extend(cap.iter().map(|&[a, b, c]| [n + a, n + b, n + c]));
        for i in 0..n {
            let j = (i + 1) % n;
            faces.extend([[i, j, n + j], [i, n + j, n + i]]);
        }
        (layer(0.0).chain(layer(height)).collect(), faces)
    };
    TriMesh::from_triangles(positions, faces).unwrap()
}

/// `mesh` solved with features at 40°, and its singularities on curve lines beside them
/// (within 3 cells, [`singularities_on_curve_lines`]); the counts printed under `what`.
fn with_features_at_40(
    mesh: std::sync::Arc<TriMesh>,
    settings: Settings,
    what: &str,
) -> (Base, EditState, Solved, Vec<usize>) {
    let base = Base::for_mesh(mesh, settings).unwrap();
    let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
    let p = &solved.param;
    let on_lines = singularities_on_curve_lines(&base, &state, p, 3.0);
    eprintln!(
        "{what}: {} singularities, {} on curve lines beside them, {} mis-wound, {} folds before the repair, {} after, {} gaps re-rounded",
        p.singularities.len(),
        on_lines.len(),
        p.miswound.len(),
        p.flipped_faces_before_repair,
        p.flipped_faces,
        p.rerounded_gaps.len()
    );
    (base, state, solved, on_lines)
}

/// A mesh of `tests/data`.
fn test_data(name: &str) -> TriMesh {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    quadcover::load::load_mesh(&path).unwrap().mesh
}

/// A raw tessellation remeshed as `solve` remeshes one by itself (`mesh::isotropic`).
fn remeshed_as_solve_does(raw: &TriMesh) -> std::sync::Arc<TriMesh> {
    use quadcover::mesh::isotropic::{PREPARED_FEATURE_ANGLE, isotropic_remesh, prepared_options};
    let opts = prepared_options(raw, None, PREPARED_FEATURE_ANGLE);
    std::sync::Arc::new(isotropic_remesh(raw, &opts).unwrap())
}

/// Corners of curves the smallest turn of the field would close: at 45° (N = 4) the
/// smoothing's choice between a 0° and a 90° lattice corner was a coin toss, and a right
/// isosceles triangle with its boundary aligned came out with both 45° corners at 0° (817 of
/// about 6000 faces folded after the repair, 2026-12-03), the prism over it with features on
/// 3048. Such corners are acute now (`constraint::acute_corners`, below 0.52 of 2π/N), and the
/// +1/4 their lattice corners ask for in the prism's caps, which the design put on a curve
/// beside the apex (where it turned that curve's line instead), is moved off the curves.
#[test]
fn corners_at_45_degrees_become_lattice_corners() {
    let cases = [
        (
            "right isosceles triangle, boundary aligned",
            0.0,
            Edit::AlignBoundary { on: true },
        ),
        (
            "prism over it, features at 40°",
            1.5,
            Edit::DetectFeatures { angle_deg: 40.0 },
        ),
    ];
    for (what, height, edit) in cases {
        let mesh = triangle_part(45.0, height, 3000);
        let base = Base::for_mesh(mesh.clone(), Settings::default()).unwrap();
        let (state, solved) = replay_solve(&base, &[edit]);
        let p = &solved.param;
        check_geometric(&base, &state, &solved);
        let ks: Vec<f64> = p.singularities.iter().map(|s| s.index * 4.0).collect();
        eprintln!(
            "{what}: {} folds before the repair, {} after, singularities {ks:?}",
            p.flipped_faces_before_repair, p.flipped_faces
        );
        assert_eq!(p.flipped_faces, 0, "{what}");
        if height == 0.0 {
            // Each of the sheet's corners a lattice corner of 90° (none of 0°, none of 180°
            // along a side): by Gauss–Bonnet the indices inside sum to +1/4.
            assert_eq!(ks.iter().sum::<f64>(), 1.0, "{what}: {ks:?}");
        } else {
            // Each of the prism's six corners is a +1/4: three lattice corners of 90°.
            for corner in 0..6 {
                let at = mesh
                    .positions()
                    .iter()
                    .position(|q| {
                        let z = if corner < 3 { 0.0 } else { height };
                        let (x, y) = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0)][corner % 3];
                        (*q - glam::DVec3::new(x, y, z)).length() < 1e-9
                    })
                    .expect("the remesh keeps the corners");
                let k = p.singularities.iter().find(|s| s.vertex == at);
                assert!(
                    k.is_some_and(|s| (s.index - 0.25).abs() < 1e-9),
                    "{what}: corner {corner} (vertex {at}) has index {:?}",
                    k.map(|s| s.index)
                );
            }
        }
        let (remesh, _, _) = remesh_along_curves(&base, &state, &solved, what);
        remesh_checks::assert_manifold(&remesh, what);
        assert_eq!(
            remesh.euler_characteristic(),
            mesh.euler_characteristic(),
            "{what}"
        );
    }
}

/// An acute corner on the boundary (a flat 30°–60°–90° triangle with its boundary aligned):
/// the apex's fan is one face, a dead end of the dual graph, so holding it to the corner's
/// turning frame turned no path around the apex, and the field took the smallest turn: the
/// 30° corner at 0°, 3804 folded faces after the repair (2026-12-03). The faces within a cell
/// (three rings at least) of a boundary apex are held now. What the smoothing then makes is a
/// polar layout (the lines fan out from the apex, no singularity, a fourth lattice corner on
/// the boundary near the apex): fold-free and seamless, its cells small near the apex; a
/// singularity inside instead is not designed (`docs/untangling.md`).
#[test]
fn an_acute_boundary_corner_does_not_collapse() {
    let mesh = triangle_part(30.0, 0.0, 3000);
    let base = Base::for_mesh(mesh.clone(), Settings::default()).unwrap();
    let (state, solved) = replay_solve(&base, &[Edit::AlignBoundary { on: true }]);
    let p = &solved.param;
    check_geometric(&base, &state, &solved);
    eprintln!(
        "30°-60°-90° triangle aligned: {} folds before the repair, {} after",
        p.flipped_faces_before_repair, p.flipped_faces
    );
    assert_eq!(p.flipped_faces, 0);
    let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, "30° triangle");
    remesh_checks::assert_manifold(&remesh, "30° triangle");
    assert_eq!(remesh.patched_places, 0);
    assert!(share > 0.99, "{share}");
}

/// Solves a part with features at 40° whose creases are straight between corners: `curves` of
/// them, each one run of one line, the map seamless with them on lattice lines and fold-free.
fn straight_features_unfolded(base: &Base, curves: usize, what: &str) -> (EditState, Solved) {
    let (state, solved) = replay_solve(base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
    let p = &solved.param;
    check_geometric(base, &state, &solved);
    assert_eq!(state.curves.len(), curves, "{what}: one curve per edge");
    for c in state.curves.values() {
        let runs = p.curves.iter().filter(|f| f.id == c.id).count();
        assert_eq!(runs, 1, "{what}: curve {} is split into {runs} runs", c.id);
    }
    eprintln!(
        "{what}: {} folds before the repair, {} after",
        p.flipped_faces_before_repair, p.flipped_faces
    );
    assert_eq!(p.flipped_faces, 0, "{what}");
    (state, solved)
}

/// Prisms over sharp corners (10° and 20°, the other corners 90° and 80° or 70°; features at
/// 40°), meshed at about 3000 vertices: every face folded around the acute corners' caps
/// (782 and 1340 folded faces after the repair, 2026-12-03). Three causes, each needed here:
/// 1. a curve's line family was read from the local step's curl*-free frames, which leave the
///    field next to singularities (turned by up to 120° along the side rectangle's edges,
///    whose four corners are all +1/4), so a straight crease was split into runs with jogs of
///    90° and 270°; it is read from the field now;
/// 2. the cap's +1/4 beside the acute apex sat on a curve because the region it may move into
///    held no vertex off the curves within two cancellation radii (every vertex there lies on
///    the corner's two creases); the region widens until it does;
/// 3. the last edges before the apex, whose faces the corner's turning frames hold at about
///    45° to the crease, were put on the other family: a run whose image turns by less than
///    60° from its neighbour's joins it.
///
/// Each feature curve of such a part runs between two corners without turning, so it is one
/// run; the map is fold-free and its remesh needs no patch.
#[test]
fn prisms_over_sharp_corners_do_not_fold() {
    for alpha in [10.0, 20.0] {
        let what = format!("prism over a {alpha}° triangle, features at 40°");
        let mesh = triangle_part(alpha, 1.5, 3000);
        let base = Base::for_mesh(mesh.clone(), Settings::default()).unwrap();
        let (state, solved) = straight_features_unfolded(&base, 9, &what);
        let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, &what);
        remesh_checks::assert_manifold(&remesh, &what);
        assert_eq!(remesh.patched_places, 0, "{what}");
        assert!(share > 0.99, "{what}: {share}");
    }
}

/// An L-shaped polygon (counter-clockwise) and its triangulation, for [`extruded`].
const L_POLYGON: [(f64, f64); 6] = [
    (0.0, 0.0),
    (4.0, 0.0),
    (4.0, 2.0),
    (2.0, 2.0),
    (2.0, 4.0),
    (0.0, 4.0),
];
const L_CAP: [[u32; 3]; 4] = [[0, 1, 2], [0, 2, 3], [0, 3, 5], [3, 4, 5]];

/// An L-shaped prism with features at 40°, N = 6: read from the local step's curl*-free
/// frames, its creases between the corner singularities were split into runs with jogs (14
/// folded faces after the repair at about 3000 vertices, 133 patched places in the remesh,
/// 2026-12-03); read from the field, each crease is one run and the map is fold-free. Two
/// mis-wound vertices (positive but not locally injective) make one face twice, once per
/// orientation: a pleat, which extraction drops (one patched place) so that the remesh is
/// manifold (it was not before 2026-12-04; `docs/remesh.md`).
#[test]
fn an_l_shaped_prism_with_six_fold_symmetry_does_not_fold() {
    let mesh = extruded(&L_POLYGON, &L_CAP, 1.5, 3000);
    let settings = Settings {
        symmetry: 6,
        ..Settings::default()
    };
    let base = Base::for_mesh(mesh.clone(), settings).unwrap();
    let (state, solved) = straight_features_unfolded(&base, 18, "L prism, N = 6");
    let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, "L prism, N = 6");
    remesh_checks::assert_manifold(&remesh, "L prism, N = 6");
    assert!(remesh.patched_places <= 1, "{}", remesh.patched_places);
    assert!(share > 0.99, "{share}");
}

/// Thin L- and U-shaped plates (0.4 thick) with features at 40°, N = 6, meshed isotropically
/// at 1500–6000 vertices. No corner of such a part has a lattice corner of 90°: the design put
/// the ±1/6 each corner asks for one edge along a crease beside it, where the crease's line
/// turned in the flat (2026-12-06: 2–7 folded faces after the repair, 9–36 patched places in the
/// remesh, in each of these four). Moved onto the corners (`Base::onto_junctions`), the map is
/// fold-free and the remesh patches at most a pleat.
#[test]
fn singularities_beside_prism_corners_move_onto_them() {
    let l: (&[(f64, f64)], &[[u32; 3]]) = (&L_POLYGON, &L_CAP);
    let u: (&[(f64, f64)], &[[u32; 3]]) = (
        &[
            (0.0, 0.0),
            (4.0, 0.0),
            (4.0, 4.0),
            (3.0, 4.0),
            (3.0, 1.0),
            (1.0, 1.0),
            (1.0, 4.0),
            (0.0, 4.0),
        ],
        &[
            [0, 1, 4],
            [1, 2, 3],
            [1, 3, 4],
            [0, 4, 5],
            [0, 5, 6],
            [0, 6, 7],
        ],
    );
    let settings = Settings {
        symmetry: 6,
        ..Settings::default()
    };
    for (name, (polygon, cap), vertices) in [
        ("L", l, 3000),
        ("L", l, 6000),
        ("U", u, 1500),
        ("U", u, 6000),
    ] {
        let what = format!("{name} plate at {vertices} vertices, N = 6");
        let mesh = extruded(polygon, cap, 0.4, vertices);
        let base = Base::for_mesh(mesh.clone(), settings.clone()).unwrap();
        let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
        check_geometric(&base, &state, &solved);
        let p = &solved.param;
        eprintln!(
            "{what}: {} folds before the repair, {} after, {} singularities",
            p.flipped_faces_before_repair,
            p.flipped_faces,
            p.singularities.len()
        );
        assert_eq!(p.flipped_faces, 0, "{what}");
        let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, &what);
        remesh_checks::assert_manifold(&remesh, &what);
        assert!(
            remesh.patched_places <= 2,
            "{what}: {}",
            remesh.patched_places
        );
        assert!(share > 0.99, "{what}: {share}");
    }
}

/// A regular tetrahedron with features at 40° (N = 4): each apex has three corners of 60°
/// between its creases, and each must become a lattice corner of 90° (0° would run two creases
/// along one line), which makes every apex a +1/4 and asks for a +1/4 inside each face:
/// eight +1/4 in all. Above the acute corners' 46.8° the smoothing's smallest turn was left to
/// choose, and at most densities its global choice closed one corner of every apex (an apex
/// of +1/2 with ±1/4 pairs round it; 28 singularities and 25–36 folded faces after the repair
/// in 14 of 20 maps of remeshed tetrahedra, 2026-12-07). Corners under 0.9 of 2π/N are held
/// to 2π/N now, with the faces within a cell of an interior apex
/// (`constraint::HELD_FRACTION`).
#[test]
fn a_tetrahedron_s_corners_of_60_degrees_open_to_90() {
    use glam::DVec3;
    let corners = [
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(-1.0, -1.0, 1.0),
    ];
    let raw = TriMesh::from_triangles(
        corners.to_vec(),
        vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]],
    )
    .unwrap();
    for (vertices, target) in [(3000, 2000), (8000, 3000)] {
        use quadcover::mesh::isotropic::{IsotropicOptions, isotropic_remesh};
        let what = format!("tetrahedron of {vertices} vertices at {target} target vertices");
        let opts = IsotropicOptions::for_vertices(&raw, vertices, 35.0);
        let mesh = std::sync::Arc::new(isotropic_remesh(&raw, &opts).unwrap());
        let settings = Settings {
            target_vertices: Some(target),
            ..Settings::default()
        };
        let base = Base::for_mesh(mesh.clone(), settings).unwrap();
        let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
        check_geometric(&base, &state, &solved);
        let p = &solved.param;
        let ks: Vec<f64> = p.singularities.iter().map(|s| s.index * 4.0).collect();
        eprintln!(
            "{what}: {} folds before the repair, {} after, singularities {ks:?}",
            p.flipped_faces_before_repair, p.flipped_faces
        );
        assert_eq!(ks, vec![1.0; 8], "{what}");
        for c in corners {
            let at = mesh
                .positions()
                .iter()
                .position(|q| (*q - c).length() < 1e-9)
                .expect("the remesh keeps the corners");
            assert!(
                p.singularities.iter().any(|s| s.vertex == at),
                "{what}: no singularity at the apex {c}"
            );
        }
        assert_eq!(p.flipped_faces, 0, "{what}");
        let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, &what);
        remesh_checks::assert_manifold(&remesh, &what);
        assert_eq!(remesh.patched_places, 0, "{what}");
        assert!(share > 0.99, "{what}: {share}");
    }
}

/// A hexagonal pyramid with features at 40° (N = 4): its apex has six corners of 37° between
/// the creases, each acute and held to a lattice corner of 90°, so the apex is a cone of 540°,
/// a −1/2. Remeshed, the apex has one face per corner, and a single face's frame lies halfway
/// between its creases' lattice directions; the nearest turn across a crease between two such
/// faces is the wrong one (the corners add up to less than 90°), and the design made the apex
/// +3/4 (2026-12-07). The rotations across those creases are prescribed now
/// (`constraint::acute_corners`' rotations). What the map then does is not asserted: the
/// side faces' +1/4 sit beside the apex and it folds (`docs/untangling.md`).
#[test]
fn a_hexagonal_pyramid_s_apex_is_the_cone_its_held_corners_make() {
    use glam::DVec3;
    use quadcover::mesh::isotropic::{IsotropicOptions, isotropic_remesh};
    let mut positions: Vec<DVec3> = (0..6)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / 6.0;
            DVec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    positions.push(DVec3::new(0.0, 0.0, 1.2));
    let mut faces: Vec<[u32; 3]> = (0..6).map(|k| [k, (k + 1) % 6, 6]).collect();
    faces.extend([[0, 5, 4], [0, 4, 3], [0, 3, 2], [0, 2, 1]]);
    let raw = TriMesh::from_triangles(positions, faces).unwrap();
    let opts = IsotropicOptions::for_vertices(&raw, 3000, 35.0);
    let mesh = std::sync::Arc::new(isotropic_remesh(&raw, &opts).unwrap());
    let apex = mesh
        .positions()
        .iter()
        .position(|q| (*q - DVec3::new(0.0, 0.0, 1.2)).length() < 1e-9)
        .expect("the remesh keeps the apex");
    let settings = Settings {
        target_vertices: Some(3000),
        ..Settings::default()
    };
    let base = Base::for_mesh(mesh, settings).unwrap();
    let r = base
        .replay(
            &[Edit::DetectFeatures { angle_deg: 40.0 }],
            &quadcover::edit::never,
        )
        .unwrap();
    let state = r.last();
    assert_eq!(state.curves.len(), 12);
    assert_eq!(
        state.singularities.get(&apex),
        Some(&-2),
        "the apex's index in quarter turns"
    );
}

/// A T-shaped prism (a 4 × 1 bar on a 1 × 3 stem, 1 thick) with features at 40°, N = 6: the
/// curvature smoothing carried the creases' bend, 30° off their line family for six
/// directions, into the flat faces beside them, and the design turned the field by +30° on
/// one stretch of a stem crease and −30° on the next, with a singularity where the crease
/// changed family (2026-12-06, folded faces after the repair: 4 at 15 000 vertices, 1 190 at
/// 20 000; from an STL at the default density 4 241). Such a design is made again from the
/// unsmoothed shape operators (`FieldParams::raw_guidance`, `edit::families`), kept when it
/// changes family at half as many places (here 2 → 1 at both sizes): the map is fold-free and
/// its remesh manifold.
#[test]
fn a_t_shaped_prism_with_six_fold_symmetry_does_not_fold() {
    const T_POLYGON: [(f64, f64); 8] = [
        (1.5, 0.0),
        (2.5, 0.0),
        (2.5, 3.0),
        (4.0, 3.0),
        (4.0, 4.0),
        (0.0, 4.0),
        (0.0, 3.0),
        (1.5, 3.0),
    ];
    const T_CAP: [[u32; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 7],
        [6, 7, 5],
        [7, 2, 4],
        [7, 4, 5],
        [2, 3, 4],
    ];
    let settings = Settings {
        symmetry: 6,
        ..Settings::default()
    };
    for vertices in [15_000, 20_000] {
        let what = format!("T prism at {vertices} vertices, N = 6");
        let mesh = extruded(&T_POLYGON, &T_CAP, 1.0, vertices);
        let base = Base::for_mesh(mesh.clone(), settings.clone()).unwrap();
        let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
        check_geometric(&base, &state, &solved);
        let p = &solved.param;
        eprintln!(
            "{what}: {} folds before the repair, {} after, {} singularities, {} runs of {} curves",
            p.flipped_faces_before_repair,
            p.flipped_faces,
            p.singularities.len(),
            p.curves.len(),
            state.curves.len()
        );
        assert_eq!(state.curves.len(), 24, "{what}");
        assert_eq!(p.flipped_faces, 0, "{what}");
        let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, &what);
        remesh_checks::assert_manifold(&remesh, &what);
        assert!(
            remesh.patched_places <= 3,
            "{what}: {}",
            remesh.patched_places
        );
        assert!(share > 0.99, "{what}: {share}");
    }
}

/// The bunny with its boundary aligned and the field renormalized (`renormalize_field`): two
/// boundary corners one edge apart, held by parallel lines of a short run that the rounding put
/// on one value, folded their face (1 fold left, 2026-12-03); the re-rounding under curves now
/// steps the curve values c_κ holding the folded faces' corners too, not only gaps.
#[test]
fn renormalized_aligned_bunny_has_no_fold() {
    let Some(path) = shared("bunny.obj") else {
        return;
    };
    let settings = Settings {
        renormalize_field: true,
        ..Settings::default()
    };
    let base = base_for(&path, settings);
    let (state, solved) = replay_solve(&base, &[Edit::AlignBoundary { on: true }]);
    check_geometric(&base, &state, &solved);
    eprintln!(
        "bunny aligned, renormalized: {} flipped faces, conformal distortion {:.3} (p99 {:.2})",
        solved.param.flipped_faces,
        solved.param.conformal_distortion.mean,
        solved.param.conformal_distortion.p99
    );
    assert_eq!(solved.param.flipped_faces, 0);
}

/// Aligned boundaries leave a few branch points wound wrongly (a −1/4 whose fan turns 90°
/// instead of 450°, beside a vertex that took its turn), each a patched place in the remesh:
/// the cerebral vessels at the default density, N = 4, 4 of them and 2 patched places; camelhead,
/// N = 6, 4 and 1 (2026-12-06). The windings re-rounding under curves
/// (`reround_curve_windings`) parts them with gap and curve-value steps that keep the curves'
/// equations: no wrongly wound vertex, no patched place, the boundary still on its lines.
#[test]
fn aligned_boundaries_leave_no_wrongly_wound_vertex() {
    for (name, n) in [("cerebral-vessels.obj", 4), ("camelhead.obj", 6)] {
        let Some((base, state, solved)) = aligned(name, n) else {
            return;
        };
        check_geometric(&base, &state, &solved);
        let p = &solved.param;
        eprintln!(
            "{name} aligned, N = {n}: {} flipped faces, wrongly wound {:?}, re-rounded gaps {}",
            p.flipped_faces,
            p.miswound,
            p.rerounded_gaps.len()
        );
        assert_eq!(p.flipped_faces, 0, "{name}");
        assert!(p.miswound.is_empty(), "{name}: {:?}", p.miswound);
        let (remesh, _, _) = remesh_along_curves(&base, &state, &solved, name);
        assert_eq!(remesh.patched_places, 0, "{name}");
    }
}

/// A raw CAD tessellation (`generate::raw_cylinder`: the side one row of needles, the caps fans
/// from a rim vertex, as an STL exporter writes a cylinder) with features on. As it is, the caps
/// have no interior vertex for their singularities and the smoothing has no uniform sampling to
/// follow: the map folds (2026-12-03: 110 folded faces, conformal distortion 70). Remeshed
/// isotropically with its rims kept (`mesh::isotropic`, what `solve` does by itself on such
/// input), it maps with no fold, the rims on parameter lines, eight +1/4 on the caps.
#[test]
fn a_raw_cad_cylinder_maps_once_remeshed() {
    use quadcover::mesh::isotropic::{IsotropicOptions, isotropic_remesh, needs_remesh};
    let raw = generate::raw_cylinder(0.5, 1.2, 48);
    assert!(needs_remesh(&raw));
    let features = [Edit::DetectFeatures { angle_deg: 40.0 }];
    let base = Base::for_mesh(std::sync::Arc::new(raw.clone()), Settings::default()).unwrap();
    let (_, solved) = replay_solve(&base, &features);
    let p = &solved.param;
    eprintln!(
        "raw cylinder: {} folds before the repair, {} after, conformal distortion {:.2}",
        p.flipped_faces_before_repair, p.flipped_faces, p.conformal_distortion.mean
    );
    assert!(
        p.flipped_faces > 0 || p.conformal_distortion.mean > 3.0,
        "the raw tessellation is expected to fail (else this test shows nothing)"
    );

    let opts = IsotropicOptions::for_vertices(&raw, 6000, 35.0);
    let mesh = std::sync::Arc::new(isotropic_remesh(&raw, &opts).unwrap());
    let base = Base::for_mesh(mesh, Settings::default()).unwrap();
    let (state, solved) = replay_solve(&base, &features);
    assert_eq!(state.curves.len(), 2, "the two rims");
    check_geometric(&base, &state, &solved);
    let p = &solved.param;
    let ks: Vec<f64> = p.singularities.iter().map(|s| s.index * 4.0).collect();
    eprintln!(
        "remeshed raw cylinder: singularities {ks:?}, {} folds, conformal distortion {:.3} (p99 \
         {:.2})",
        p.flipped_faces, p.conformal_distortion.mean, p.conformal_distortion.p99
    );
    assert_eq!(p.flipped_faces, 0);
    assert!(p.poles.is_empty());
    assert_eq!(ks.len(), 8, "{ks:?}");
    assert!(ks.iter().all(|&k| (k - 1.0).abs() < 1e-9), "{ks:?}");
    assert!(
        p.conformal_distortion.mean < 1.6,
        "{:?}",
        p.conformal_distortion
    );
    let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, "remeshed raw cylinder");
    assert!(share > 0.99, "{share}");
    // The rims are polygons with a slight kink at every vertex: the relaxation's chord fit
    // leaves them (at a threshold of 2 % of the mean edge it pulled remesh vertices onto
    // those kinks, 40 corners under 45° on a 64-gon cylinder).
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for f in &remesh.faces {
        let n = f.len();
        for k in 0..n {
            let p = remesh.positions[f[k] as usize];
            let a = remesh.positions[f[(k + 1) % n] as usize] - p;
            let b = remesh.positions[f[(k + n - 1) % n] as usize] - p;
            let angle = a.angle_between(b).to_degrees();
            (lo, hi) = (lo.min(angle), hi.max(angle));
        }
    }
    eprintln!("remeshed raw cylinder: corners {lo:.1}°–{hi:.1}°");
    assert!(lo > 45.0 && hi < 135.0, "corners {lo:.1}°–{hi:.1}°");
}

/// N = 6 on the same remeshed cylinder: the faces beside the rims carry the creases' bend in
/// their curvature, across the rims, which is 30° off the rims' own alignment for six
/// directions; along a round rim nothing decides whether the field turns by +30° or −30° there,
/// and it flipped between the two (38 pairs of ±1/6 on the rims, 486 folded faces). Without
/// that guidance near round rims: six +1/6 per cap, the rims on lattice lines, no fold.
#[test]
fn a_hexagonal_field_follows_round_rims() {
    use quadcover::mesh::isotropic::{IsotropicOptions, isotropic_remesh};
    let raw = generate::raw_cylinder(0.5, 1.2, 48);
    let opts = IsotropicOptions::for_vertices(&raw, 6000, 35.0);
    let mesh = std::sync::Arc::new(isotropic_remesh(&raw, &opts).unwrap());
    let settings = Settings {
        symmetry: 6,
        ..Settings::default()
    };
    let base = Base::for_mesh(mesh, settings).unwrap();
    let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
    assert_eq!(state.curves.len(), 2, "the two rims");
    let p = &solved.param;
    let ks: Vec<f64> = p.singularities.iter().map(|s| s.index * 6.0).collect();
    eprintln!(
        "remeshed raw cylinder, N = 6: {} singularities, {} folds before the repair, {} after",
        ks.len(),
        p.flipped_faces_before_repair,
        p.flipped_faces
    );
    assert_eq!(ks.len(), 12, "{ks:?}");
    assert!(ks.iter().all(|&k| (k - 1.0).abs() < 1e-9), "{ks:?}");
    assert_eq!(p.flipped_faces, 0);
    check_geometric(&base, &state, &solved);
}

/// `quadcover solve PART --features 40 EXTRA --out DIR/uv.obj --report REPORT`.
fn solve_with_features(
    part: &std::path::Path,
    dir: &std::path::Path,
    extra: &[&str],
    report: &std::path::Path,
) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_quadcover"))
        .arg("solve")
        .arg(part)
        .args(["--features", "40"])
        .args(extra)
        .arg("--out")
        .arg(dir.join("uv.obj"))
        .arg("--report")
        .arg(report)
        .output()
        .unwrap()
}

/// A fine part beside a fan of long needles (a unit square: a grid on [0, 0.8] × [0, 1] and 80
/// needles 0.2–0.54 long from (1, 0.5) over the strip beside it, 10 % of the area, half the
/// raw-tessellation share) is remeshed by `solve`, and `info` says why; `--keep-input` keeps it.
#[test]
fn cli_remeshes_fans_of_long_needles() {
    let dir = tempfile::tempdir().unwrap();
    let g = quadcover::mesh::generate::grid(64, 80, 0.8, 1.0);
    let mut p = g.positions().to_vec();
    let mut t = g.faces().to_vec();
    let column: Vec<u32> = (0..=80).map(|j| (j * 65 + 64) as u32).collect();
    let apex = p.len() as u32;
    p.extend([[1.0, 0.5, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]].map(glam::DVec3::from_array));
    for w in column.windows(2) {
        t.push([w[0], apex, w[1]]);
    }
    t.push([column[0], apex + 1, apex]);
    t.push([column[80], apex, apex + 2]);
    let part = dir.path().join("fan.obj");
    quadcover::io::write_obj(&part, &quadcover::io::ObjOutput::new(&p, &t[..])).unwrap();
    let exe = env!("CARGO_BIN_EXE_quadcover");
    let info = std::process::Command::new(exe)
        .args(["info", "--json"])
        .arg(&part)
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    let share = v["long_needle_area_share"].as_f64().unwrap();
    assert!((share - 0.1).abs() < 0.01, "{share}");
    assert!(v["needle_area_share"].as_f64().unwrap() < 0.2, "{v}");
    let solve = |extra: &[&str]| {
        let report = dir.path().join("r.json");
        let out = std::process::Command::new(exe)
            .arg("solve")
            .arg(&part)
            .args(["--target-vertices", "3000"])
            .args(extra)
            .arg("--out")
            .arg(dir.path().join("uv.obj"))
            .arg("--report")
            .arg(&report)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "{stderr}");
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        (stderr, r)
    };
    let (stderr, r) = solve(&[]);
    assert!(
        stderr.contains("in needles longer than 2 grid cells"),
        "{stderr}"
    );
    assert_eq!(r["prepared_input"]["input_vertices"], p.len());
    assert_eq!(r["flipped_faces"], 0);
    let (stderr, r) = solve(&["--keep-input"]);
    assert!(!stderr.contains("input remeshed"), "{stderr}");
    assert!(r["prepared_input"].is_null(), "{}", r["prepared_input"]);
}

/// A low-poly mesh far coarser than the grid (an octahedron: 6 vertices, no needles) is
/// remeshed by `solve` too: kept as it is, its faces hold no grid point inside and the map
/// folds or covers none; remeshed, every crease is a grid line and nothing folds.
#[test]
fn cli_remeshes_low_poly_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let p: Vec<glam::DVec3> = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ]
    .iter()
    .map(|&a| glam::DVec3::from_array(a))
    .collect();
    let faces: [[u32; 3]; 8] = [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    let part = dir.path().join("octahedron.obj");
    quadcover::io::write_obj(&part, &quadcover::io::ObjOutput::new(&p, &faces[..])).unwrap();
    let run = |extra: &[&str], report: &std::path::Path| {
        solve_with_features(&part, dir.path(), extra, report)
    };
    let report = dir.path().join("r.json");
    let out = run(&[], &report);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("far coarser than the grid"), "{stderr}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["prepared_input"]["input_vertices"], 6);
    assert_eq!(r["prepared_input"]["coarse"], true);
    assert_eq!(r["flipped_faces"], 0);
    assert_eq!(r["singularities"].as_array().unwrap().len(), 8);
    // Every crease of the remeshed octahedron runs along a parameter line (the curves' largest
    // offset from their lattice line).
    let curves = r["curves"].as_array().unwrap();
    assert!(curves.len() >= 12, "{}", curves.len());
    assert!(
        curves
            .iter()
            .all(|c| c["max_offset"].as_f64().unwrap() < 1e-6)
    );

    let kept = dir.path().join("k.json");
    let out = run(&["--keep-input"], &kept);
    let folds = out.status.success().then(|| {
        let k: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&kept).unwrap()).unwrap();
        k["flipped_faces"].as_u64().unwrap()
    });
    assert!(
        folds.is_none_or(|f| f > 0),
        "kept as it is, the octahedron maps without a fold: the test shows nothing"
    );
}

/// The command line on a raw CAD tessellation: `solve` remeshes it by itself (REPORT.json's
/// `prepared_input`, the output OBJ is the remeshed mesh) and maps it without a fold;
/// `--keep-input` keeps the input and folds; `--prepare` with a project is refused;
/// `quadcover prepare` writes a mesh without needles.
#[test]
fn cli_remeshes_raw_tessellations() {
    let dir = tempfile::tempdir().unwrap();
    let raw = generate::raw_cylinder(0.5, 1.2, 48);
    let part = dir.path().join("part.obj");
    quadcover::io::write_obj(
        &part,
        &quadcover::io::ObjOutput::new(raw.positions(), raw.faces()),
    )
    .unwrap();
    let exe = env!("CARGO_BIN_EXE_quadcover");
    let run = |extra: &[&str], report: &std::path::Path| {
        solve_with_features(&part, dir.path(), extra, report)
    };
    let report = dir.path().join("r.json");
    let out = run(&[], &report);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("input remeshed"));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(r["prepared_input"]["input_vertices"], 96);
    assert!(r["prepared_input"]["needle_area_share"].as_f64().unwrap() > 0.99);
    assert_eq!(r["flipped_faces"], 0);
    let vertices = r["vertices"].as_u64().unwrap();
    assert!(vertices > 10_000, "{vertices}");
    let uv = std::fs::read_to_string(dir.path().join("uv.obj")).unwrap();
    assert_eq!(
        uv.lines().filter(|l| l.starts_with("v ")).count() as u64,
        vertices,
        "the output is the remeshed mesh"
    );

    let kept = dir.path().join("k.json");
    let out = run(&["--keep-input"], &kept);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let k: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&kept).unwrap()).unwrap();
    assert!(k.get("prepared_input").is_none());
    assert_eq!(k["vertices"], 96);
    assert!(
        k["flipped_faces"].as_u64().unwrap() > 0,
        "the raw input folds"
    );

    let project = dir.path().join("p.json");
    std::fs::write(
        &project,
        r#"{"format": "quadcover-project", "version": 1, "mesh": {"path": "part.obj"}, "settings": {}, "edits": []}"#,
    )
    .unwrap();
    let out = std::process::Command::new(exe)
        .args([
            "solve",
            "--project",
            project.to_str().unwrap(),
            "--prepare",
            "--out",
        ])
        .arg(dir.path().join("uv2.obj"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("quadcover prepare"));
    // a field file names the file's faces: refused with --prepare too
    let out = std::process::Command::new(exe)
        .args([
            "solve",
            part.to_str().unwrap(),
            "--prepare",
            "--field",
            "f.json",
            "--out",
        ])
        .arg(dir.path().join("uv3.obj"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--field"));

    let prepared = dir.path().join("prepared.obj");
    let out = std::process::Command::new(exe)
        .args([
            "prepare",
            part.to_str().unwrap(),
            "--vertices",
            "3000",
            "--out",
        ])
        .arg(&prepared)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mesh = quadcover::load::load_mesh(&prepared).unwrap().mesh;
    assert!(!quadcover::mesh::isotropic::needs_remesh(&mesh));
    assert!(
        (2000..4500).contains(&mesh.n_vertices()),
        "{}",
        mesh.n_vertices()
    );
    let out = std::process::Command::new(exe)
        .args([
            "prepare",
            part.to_str().unwrap(),
            "--edge-length",
            "-1",
            "--out",
        ])
        .arg(&prepared)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

/// The repair's second try on a grid finer around crowded singularities (`param::crowded`)
/// under curves: kitten with features at 40°, N = 6, 1500 vertices keeps a fold and 5
/// mis-wound vertices on the uniform grid; the kept try has fewer of them (measured
/// 2026-12-04: 1 fold and 1 mis-wound vertex; none and 2 while faces of zero area whose
/// rounding gave them a positive sign passed as unfolded, which let the re-rounding take
/// another path), and its geometric curves still lie on lattice lines to 1e-6.
#[test]
fn crowded_singularities_get_a_finer_grid_under_curves_too() {
    let Some(path) = shared("kitten.obj") else {
        return;
    };
    let solve = |refine_crowded| {
        let settings = Settings {
            symmetry: 6,
            target_vertices: Some(1500),
            refine_crowded,
            ..Settings::default()
        };
        let base = base_for(&path, settings);
        let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
        (base, state, solved)
    };
    let (_, _, uniform) = solve(false);
    assert!(uniform.param.crowded_refinement.is_none());
    assert!(
        uniform.param.flipped_faces > 0,
        "the uniform grid no longer folds: the case tests nothing"
    );
    let (base, state, refined) = solve(true);
    let r = refined
        .param
        .crowded_refinement
        .as_ref()
        .expect("second try kept");
    assert!(
        r.singularities > 0 && r.faces > 0 && r.max_multiplier > 1.0,
        "{r:?}"
    );
    let badness = |p: &quadcover::param::Parameterization| (p.flipped_faces, p.miswound.len());
    assert!(
        badness(&refined.param) < badness(&uniform.param),
        "{:?} kept against {:?}",
        badness(&refined.param),
        badness(&uniform.param)
    );
    assert!(refined.param.flipped_faces <= 1);
    // Same singularities (the scale does not change the indices), curves still exact.
    assert_eq!(refined.param.singularities, uniform.param.singularities);
    check_geometric(&base, &state, &refined);
}

/// `generate::grid` on the unit square mapped through `f` (u, v) → position.
fn mapped_grid(
    nx: usize,
    ny: usize,
    f: impl Fn(f64, f64) -> glam::DVec3,
) -> std::sync::Arc<TriMesh> {
    let flat = generate::grid(nx, ny, 1.0, 1.0);
    let positions = flat.positions().iter().map(|p| f(p.x, p.y)).collect();
    std::sync::Arc::new(TriMesh::from_triangles(positions, flat.faces().to_vec()).unwrap())
}

/// Solves `mesh` with its boundary aligned and checks what a four-sided patch asks for: its
/// boundary on lattice lines, no singularity, no fold, a manifold remesh along the boundary
/// with no patched place. Returns the map.
fn aligned_patch_needs_no_singularity(
    mesh: std::sync::Arc<TriMesh>,
    settings: Settings,
    what: &str,
) -> Parameterization {
    let base = Base::for_mesh(mesh, settings).unwrap();
    let (state, solved) = replay_solve(&base, &[Edit::AlignBoundary { on: true }]);
    let p = &solved.param;
    check_geometric(&base, &state, &solved);
    eprintln!(
        "{what} aligned: {} singularities, {} folds before the repair, {} after, conformal distortion {:.3} (p99 {:.2})",
        p.singularities.len(),
        p.flipped_faces_before_repair,
        p.flipped_faces,
        p.conformal_distortion.mean,
        p.conformal_distortion.p99
    );
    assert!(p.singularities.is_empty(), "{what}");
    assert_eq!(p.flipped_faces, 0, "{what}");
    let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, what);
    remesh_checks::assert_manifold(&remesh, what);
    assert_eq!(remesh.patched_places, 0, "{what}");
    assert!(share > 0.99, "{what}: {share}");
    solved.param
}

/// Open patches whose curvature directions cross their aligned boundary: the boundary's
/// directions reach across the whole patch, the curvature faces pull the field towards the
/// diagonal, and the field rounded into singularity pairs the map sheared around. A helicoid of
/// one turn (r in [1, 2], pitch π; its curvature lines at 45° to its rulings and helices):
/// 77 singularities (a generated one: 2, and 353 folded faces after the repair), conformal
/// distortion 1.41; a 40:1 sheet bent into a wave 4 singularities and a patched place in the
/// remesh (2026-12-05, before `field::boundary_yield`). Now the curvature faces that contradict
/// the boundary yield: these four-sided patches need no singularity and get none, and nothing
/// folds or is patched.
#[test]
fn curvature_yields_to_an_aligned_boundary_it_crosses() {
    use glam::DVec3;
    use std::f64::consts::{PI, TAU};
    let helicoid = mapped_grid(100, 20, |u, v| {
        let (r, t) = (1.0 + v, TAU * u);
        DVec3::new(r * t.cos(), r * t.sin(), 0.5 * t)
    });
    let sheet = mapped_grid(400, 10, |u, v| {
        DVec3::new(4.0 * u, 0.1 * v, 0.15 * (3.0 * PI * u).sin() * (1.0 + v))
    });
    for (what, mesh) in [("helicoid", helicoid), ("wavy sheet", sheet)] {
        let p = aligned_patch_needs_no_singularity(mesh, Settings::default(), what);
        assert!(p.conformal_distortion.mean < 1.3, "{what}");
    }
}

/// Right-angled corners of an aligned boundary with six-fold symmetry: a 90° corner lies
/// halfway between the lattice corners of 60° and 120°, and the smoothing chose each corner on
/// its own: a flat square got a ±1/6 pair beside a corner, a 10 × 1 rectangle four
/// singularities (2026-12-05). Decided along the loop (`constraint::acute_corners`), a
/// rectangle takes corners of 60° and 120° in turn and needs no singularity.
#[test]
fn right_angled_boundaries_with_six_fold_symmetry_need_no_singularity() {
    for (what, nx, ny, sx, sy) in [
        ("square, N = 6", 40, 40, 1.0, 1.0),
        ("10 × 1 rectangle, N = 6", 200, 20, 10.0, 1.0),
    ] {
        let settings = Settings {
            symmetry: 6,
            ..Settings::default()
        };
        let mesh = std::sync::Arc::new(generate::grid(nx, ny, sx, sy));
        aligned_patch_needs_no_singularity(mesh, settings, what);
    }
}

/// A geometric chord across a flat plate, from boundary to boundary, for every symmetry:
/// straight across and along the diagonal. With N = 6 the straight chord failed ("matrix is
/// not positive definite", naming no curve; 2026-12-05): the plate has no singularity, so its
/// translations are pinned where the lines leave them free, and the pinning compared the
/// lines' normals in the frames of their vertices, which the edit model's incremental solve
/// turns against each other (its gauge) — the chord's boundary end looked like a second line
/// family and nothing was pinned.
#[test]
fn a_chord_across_a_plate_lies_on_one_line_for_every_symmetry() {
    let mesh = std::sync::Arc::new(generate::grid(40, 40, 1.0, 1.0));
    let at = |x: f64, y: f64| {
        (0..mesh.n_vertices())
            .min_by(|&a, &b| {
                let d = |v: usize| (mesh.position(v) - glam::DVec3::new(x, y, 0.0)).length();
                d(a).total_cmp(&d(b))
            })
            .unwrap()
    };
    for (what, from, to) in [
        ("straight", at(0.5, 0.0), at(0.5, 1.0)),
        ("diagonal", at(0.0, 0.0), at(1.0, 1.0)),
    ] {
        let path = shortest_edge_path(&mesh, from, to).unwrap();
        for symmetry in [2, 4, 6] {
            let what = format!("{what} chord, N = {symmetry}");
            let settings = Settings {
                symmetry,
                ..Settings::default()
            };
            let base = Base::for_mesh(mesh.clone(), settings).unwrap();
            let edits = [Edit::AddCurve {
                id: 0,
                vertices: path.clone(),
                closed: false,
                kind: CurveKind::Geometric,
            }];
            let r = base.replay(&edits, &quadcover::edit::never).unwrap();
            let state = r.last().clone();
            let solved = base
                .solve(&state, &quadcover::edit::never)
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_eq!(check_geometric(&base, &state, &solved), path.len() - 1);
            assert!(solved.param.singularities.is_empty(), "{what}");
            assert_eq!(solved.param.flipped_faces, 0, "{what}");
        }
    }
}

/// Stripes (N = 2) along the creases of a hexagonal prism (features at 40°). A line field has
/// no quarter turn, so held along every crease it had to turn by 90° inside each right-angled
/// corner between two creases, and the smoothing put ±1/2 singularities beside the corners,
/// which were then moved onto the creases: 28 singularities and 107 folded faces after the
/// repair (2026-12-06). Creases meeting at about a right angle are now held in different
/// families (`constraint::stripe_across`: one along the stripes, one across), the one corner
/// of three at each apex that no colouring gives its natural turn is held open to 180°
/// (`constraint::stripe_corners`), and singularities are not moved onto the creases. Not every
/// prism is fold-free yet (`docs/untangling.md`).
#[test]
fn stripes_follow_the_creases_of_prisms() {
    use std::f64::consts::PI;
    let hexagon: Vec<(f64, f64)> = (0..6)
        .map(|i| {
            let a = PI / 3.0 * i as f64;
            (2.0 * a.cos(), 2.0 * a.sin())
        })
        .collect();
    let hexagon_cap: Vec<[u32; 3]> = (1..5).map(|i| [0, i, i + 1]).collect();
    let settings = Settings {
        symmetry: 2,
        ..Settings::default()
    };
    let what = "hexagonal prism";
    let mesh = extruded(&hexagon, &hexagon_cap, 1.5, 3000);
    let base = Base::for_mesh(mesh.clone(), settings).unwrap();
    let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
    let p = &solved.param;
    let edges = check_geometric(&base, &state, &solved);
    assert_eq!(
        state.curves.len(),
        3 * hexagon.len(),
        "{what}: one curve per crease"
    );
    eprintln!(
        "{what}, N = 2: {edges} curve edges, {} singularities, {} folds before the repair, {} after, {} mis-wound",
        p.singularities.len(),
        p.flipped_faces_before_repair,
        p.flipped_faces,
        p.miswound.len()
    );
    assert_eq!(p.flipped_faces, 0, "{what}");
    assert!(p.miswound.is_empty(), "{what}: {:?}", p.miswound);
}

/// A capped cylinder whose caps are fans of 96 triangles around their centres (radius 1, 16
/// rings): the field's zero of order 4 in each cap stays whole at the centre whatever the
/// renormalization does (the fan is a cycle of the dual graph around no face), and becomes a
/// pole (conformal distortion 2.1, p99 8.0). `solve` says so and names `--prepare`, which
/// remeshes the fans: then each cap has four +1/4 and nothing is said.
#[test]
fn poles_at_fan_centres_are_pointed_out() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = generate::capped_cylinder(1.0, 2.0, 96, 40, 16);
    let part = dir.path().join("part.obj");
    quadcover::io::write_obj(
        &part,
        &quadcover::io::ObjOutput::new(mesh.positions(), mesh.faces()),
    )
    .unwrap();
    assert_eq!(quadcover::mesh::isotropic::fan_centres(&mesh).len(), 2);
    let uv = dir.path().join("uv.obj");
    let run = |extra: &[&str]| {
        let mut args: Vec<&std::ffi::OsStr> = vec![
            part.as_os_str(),
            "--features".as_ref(),
            "40".as_ref(),
            "--out".as_ref(),
            uv.as_os_str(),
        ];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        solve_cli(&args, &dir.path().join("r.json"))
    };
    let (said, r) = run(&[]);
    let poles = r["poles"].as_array().unwrap().len();
    eprintln!("fans kept: {poles} poles");
    // Said exactly when a pole sits there (two today).
    assert_eq!(poles > 0, said.contains("centre of a fan"), "{said}");
    let (said, r) = run(&["--prepare"]);
    assert!(!said.contains("centre of a fan"), "{said}");
    assert!(r["poles"].as_array().unwrap().is_empty(), "{}", r["poles"]);
    assert_eq!(r["singularities"].as_array().unwrap().len(), 8);
}

/// Runs `quadcover solve` with `args` and `--report report`; it must succeed. Returns its
/// stderr and the report.
fn solve_cli(args: &[&std::ffi::OsStr], report: &std::path::Path) -> (String, serde_json::Value) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_quadcover"))
        .arg("solve")
        .args(args)
        .arg("--report")
        .arg(report)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    let r = serde_json::from_str(&std::fs::read_to_string(report).unwrap()).unwrap();
    (stderr, r)
}

/// Folds the repair cannot undo are reported with the curves beside them: on an L-shaped prism
/// with features at 40° and N = 2 (stripes; a two-fold field cannot run along all three
/// creases of a corner), `solve` warns and names curves, and the report lists the same ones,
/// each a curve of the solve. (If this case ever comes out fold-free, the test asks for
/// another that does not.)
#[test]
fn folds_left_under_curves_name_the_curves_beside_them() {
    let dir = tempfile::tempdir().unwrap();
    let part = dir.path().join("l_prism.obj");
    let mesh = extruded(&L_POLYGON, &L_CAP, 0.4, 1500);
    quadcover::io::write_obj(
        &part,
        &quadcover::io::ObjOutput::new(mesh.positions(), mesh.faces()),
    )
    .unwrap();
    let report = dir.path().join("r.json");
    let (stderr, r) = solve_cli(
        &[
            part.as_os_str(),
            "--symmetry".as_ref(),
            "2".as_ref(),
            "--features".as_ref(),
            "40".as_ref(),
            "--out".as_ref(),
            dir.path().join("uv.obj").as_os_str(),
        ],
        &report,
    );
    let folded = r["flipped_faces"].as_u64().unwrap();
    assert!(
        folded > 0,
        "the case came out fold-free: pick one that folds"
    );
    let beside: Vec<u64> = r["curves_beside_folds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    assert!(!beside.is_empty(), "{stderr}");
    let ids: Vec<u64> = r["curves"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["id"].as_u64().unwrap())
        .collect();
    assert!(beside.iter().all(|b| ids.contains(b)), "{beside:?} {ids:?}");
    assert!(beside.windows(2).all(|w| w[0] < w[1]));
    let warning = stderr
        .lines()
        .find(|l| l.contains("stay folded after the injectivity repair"))
        .unwrap_or_else(|| panic!("no warning: {stderr}"));
    assert!(
        warning.contains(&format!("{folded} faces stay folded")),
        "{warning}"
    );
    assert!(
        warning.contains(&format!(
            "beside curve{} {}",
            if beside.len() == 1 { "" } else { "s" },
            beside[0]
        )),
        "{warning}"
    );
    // A fold-free solve has no such warning (the same part, N = 4).
    let (stderr, r) = solve_cli(
        &[
            part.as_os_str(),
            "--features".as_ref(),
            "40".as_ref(),
            "--out".as_ref(),
            dir.path().join("uv4.obj").as_os_str(),
        ],
        &report,
    );
    assert_eq!(r["flipped_faces"], 0);
    assert_eq!(r["curves_beside_folds"], serde_json::json!([]));
    assert!(!stderr.contains("stay folded"), "{stderr}");
}

/// A cone's apex is no crease: round the apex of a remeshed cone the edges' dihedral angles
/// exceed 40° for a few edges out, which made short curves radiating from the apex with
/// singularities on them (radius 0.5, height 3, 3000 target vertices, prepared as `solve` does:
/// 13 curves and 23 537 folded faces before the cone-point rule, 2026-12-07). Only the base rim
/// is a curve now, and the map does not fold.
#[test]
fn a_cone_apex_makes_no_feature_curves() {
    use quadcover::mesh::isotropic::{PREPARED_FEATURE_ANGLE, isotropic_remesh, prepared_options};
    let raw = generate::raw_cone(0.5, 3.0, 48);
    let target = 3000;
    let opts = prepared_options(&raw, Some(target), PREPARED_FEATURE_ANGLE);
    let mesh = std::sync::Arc::new(isotropic_remesh(&raw, &opts).unwrap());
    let settings = Settings {
        target_vertices: Some(target),
        ..Settings::default()
    };
    let base = Base::for_mesh(mesh, settings).unwrap();
    let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
    let p = &solved.param;
    eprintln!(
        "cone: {} curves, {} folds before the repair, {} after",
        state.curves.len(),
        p.flipped_faces_before_repair,
        p.flipped_faces
    );
    assert_eq!(state.curves.len(), 1, "the rim only");
    check_geometric(&base, &state, &solved);
    assert_eq!(p.flipped_faces, 0);
}

/// A box with three slots across its top, features at 40°: the Hermite basis of its
/// combinatorial equations (in the rows' order) had entries of 10²⁵, beyond what LLL's
/// floating-point Gram–Schmidt resolves, so the "reduced" basis stayed that long and the
/// rounding put curve values millions of cells off (every face folded, the extraction refused
/// the map). Another elimination order starts short (entries of 3).
#[test]
fn a_slotted_box_rounds_its_curve_values_near_the_map() {
    // The raw CSG tessellation (32 vertices; trimesh's boolean difference of a 2 × 2 × 1 box
    // and three 0.3-wide bars), remeshed as `solve` remeshes a raw tessellation.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/slotted_box.obj");
    let raw = quadcover::load::load_mesh(&path).unwrap().mesh;
    let mesh = remeshed_as_solve_does(&raw);
    let base = Base::for_mesh(mesh, Settings::default()).unwrap();
    let (state, solved) = replay_solve(&base, &[Edit::DetectFeatures { angle_deg: 40.0 }]);
    let p = &solved.param;
    let extent = p.uv.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    eprintln!(
        "slotted box: {} curves, {} folds before the repair, {} after, UVs within ±{extent:.0}, \
         conformal distortion {:.3}",
        state.curves.len(),
        p.flipped_faces_before_repair,
        p.flipped_faces,
        p.conformal_distortion.mean
    );
    check_geometric(&base, &state, &solved);
    assert_eq!(p.flipped_faces, 0);
    // Its slots are several cells wide: no corner falls on the line of a wall across.
    assert_eq!(p.collapsed_strips, 0);
    assert_eq!(p.lattice, Lattice::TwoZ2);
    // The part is 2 × 2 × 1 with about 10 000 grid vertices, a few dozen cells across: its UVs
    // stay within a couple of hundred (8.8 million before).
    assert!(extent < 500.0, "UVs reach {extent}");
    assert!(
        p.conformal_distortion.mean < 1.5,
        "{:?}",
        p.conformal_distortion
    );
}

/// Raw prisms (six vertices, as a CAD exporter writes them) over triangles with a 22° and a
/// 26° corner, remeshed as `solve` remeshes raw tessellations, features at 40°: the +1/4 each
/// cap needs went to the vertex off the curves nearest the apex, in the narrow part of the
/// wedge, a cell from both creases; rounded onto the lattice it folded 4 faces after the
/// repair, and the remesh patched 89 and 71 places. It goes where the wedge leaves it a cell of
/// room now (`WEDGE_ROOM`).
#[test]
fn a_cap_singularity_gets_room_inside_an_acute_wedge() {
    for (alpha, h) in [(22, 1.21208), (26, 1.4632)] {
        let what = format!("raw prism over a {alpha}° triangle");
        let raw = raw_extruded(&[(0.0, 0.0), (3.0, 0.0), (3.0, h)], &[[0, 1, 2]], 1.0);
        let mesh = remeshed_as_solve_does(&raw);
        let base = Base::for_mesh(mesh, Settings::default()).unwrap();
        let (state, solved) = straight_features_unfolded(&base, 9, &what);
        assert!(solved.param.miswound.is_empty(), "{what}");
        let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, &what);
        remesh_checks::assert_manifold(&remesh, &what);
        assert_eq!(remesh.patched_places, 0, "{what}");
        assert!(share > 0.99, "{what}: {share}");
    }
}

/// Singularities off the geometric curves that the map puts on the lattice line of a curve
/// beside them: within `cells` grid cells in space, in one chart with the singularity (faces
/// joined where their corners' UVs agree), a curve edge whose line passes through it, with the
/// singularity beside the line's run of curve edges rather than beyond its end (where a line may
/// run through it: a separatrix meeting a crease's end). Rounded onto such a line, a singularity
/// collapses the faces between it and the curve.
fn singularities_on_curve_lines(
    base: &Base,
    state: &EditState,
    p: &Parameterization,
    cells: f64,
) -> Vec<usize> {
    use std::collections::{HashSet, VecDeque};
    let mesh = base.mesh();
    let (fam, s) = families(base.settings().symmetry as usize);
    let reach = cells * base.grid_size();
    let mut curve_edge = HashSet::new();
    let mut on_curve = HashSet::new();
    for c in state.curves.values() {
        if c.kind != CurveKind::Geometric {
            continue;
        }
        for (a, b) in c.segments() {
            curve_edge.insert((a.min(b), a.max(b)));
            on_curve.extend([a, b]);
        }
    }
    let same = |x: [f64; 2], y: [f64; 2]| (x[0] - y[0]).abs() < 1e-9 && (x[1] - y[1]).abs() < 1e-9;
    let value = |nl: &[f64; 2], x: [f64; 2]| (nl[0] * x[0] + nl[1] * x[1]) / s;
    let mut out = Vec::new();
    for v in p.singularities.iter().map(|s| s.vertex) {
        if on_curve.contains(&v) {
            continue;
        }
        let pv = mesh.position(v);
        let on_line = mesh.outgoing(v).any(|h0| {
            let cone = p.uv[h0];
            // Curve edges of the chart within reach on a line through the singularity, per line.
            let mut lines: Vec<(usize, Vec<(usize, usize)>)> = Vec::new();
            let mut seen = HashSet::from([mesh.face_of(h0)]);
            let mut queue = VecDeque::from([mesh.face_of(h0)]);
            while let Some(f) = queue.pop_front() {
                for h in 3 * f..3 * f + 3 {
                    let (a, b) = (mesh.from(h), mesh.to(h));
                    let (pa, pb) = (p.uv[h], p.uv[mesh.next(h)]);
                    if curve_edge.contains(&(a.min(b), a.max(b))) {
                        for (l, nl) in fam.iter().enumerate() {
                            let (x, y, z) = (value(nl, pa), value(nl, pb), value(nl, cone));
                            if (x - y).abs() < 1e-6 && (x - z).abs() < 1e-6 {
                                let e = (a.min(b), a.max(b));
                                match lines.iter_mut().find(|(m, _)| *m == l) {
                                    Some((_, es)) if !es.contains(&e) => es.push(e),
                                    Some(_) => {}
                                    None => lines.push((l, vec![e])),
                                }
                            }
                        }
                    }
                    let Some(t) = mesh.twin(h) else { continue };
                    let g = mesh.face_of(t);
                    if seen.contains(&g)
                        || !same(p.uv[t], pb)
                        || !same(p.uv[mesh.next(t)], pa)
                        || mesh.face_centroid(g).distance(pv) > reach
                    {
                        continue;
                    }
                    seen.insert(g);
                    queue.push_back(g);
                }
            }
            // Beside a run: the point of its edges nearest the singularity is inside an edge,
            // or a vertex two of them share.
            lines.iter().any(|(_, edges)| {
                let mut best = (f64::INFINITY, None);
                for &(a, b) in edges {
                    let (pa, pb) = (mesh.position(a), mesh.position(b));
                    let t = ((pv - pa).dot(pb - pa) / (pb - pa).length_squared()).clamp(0.0, 1.0);
                    let d = pv.distance(pa + t * (pb - pa));
                    let at = if t == 0.0 {
                        Some(a)
                    } else if t == 1.0 {
                        Some(b)
                    } else {
                        None
                    };
                    if d < best.0 {
                        best = (d, at);
                    }
                }
                match best.1 {
                    None => best.0.is_finite(),
                    Some(x) => edges.iter().filter(|&&(a, b)| a == x || b == x).count() >= 2,
                }
            })
        });
        if on_line {
            out.push(v);
        }
    }
    out
}

/// A raw L-shaped bracket with a hole across its arm (trimesh: the L polygon (0, 0), (3, 0),
/// (3, 0.5), (0.5, 0.5), (0.5, 2), (0, 2) extruded by 1, less a cylinder of radius 0.15 with 24
/// sections through (2, 0.25, 0.5) along y; 3000 vertices, features at 40°, remeshed as `solve`
/// remeshes raw tessellations): the rounding took the −1/4 singularities two cells from the
/// hole's rim, whose line the local map, not yet held to the rim, put a fraction of a cell
/// away, onto the rim's line (4 of them), and the repair wound them wrongly (10 mis-wound
/// vertices, 5 patched places in the remesh). The rounding keeps them on their side of the
/// lines beside them now (`param::constraints::off_lines`).
#[test]
fn singularities_beside_a_rim_keep_off_its_line() {
    let mesh = remeshed_as_solve_does(&test_data("bracket.obj"));
    let settings = Settings {
        target_vertices: Some(3000),
        ..Settings::default()
    };
    let (base, state, solved, on_lines) =
        with_features_at_40(mesh, settings, "bracket at 3000 vertices");
    let p = &solved.param;
    check_geometric(&base, &state, &solved);
    assert!(on_lines.is_empty(), "on curve lines: {on_lines:?}");
    assert_eq!(p.flipped_faces, 0);
    assert!(p.miswound.is_empty(), "mis-wound: {:?}", p.miswound);
    let (remesh, _, _) = remesh_along_curves(&base, &state, &solved, "bracket");
    remesh_checks::assert_manifold(&remesh, "bracket");
    assert_eq!(remesh.patched_places, 0);
}

/// A raw cross-shaped plate with four round holes (trimesh: the union of the rectangles
/// [−1, 1] × [−0.3, 0.3] and [−0.3, 0.3] × [−1, 1], less disks of radius 0.12 with 12 sections
/// per quarter at (±0.7, 0) and (0, ±0.7), extruded by 0.2), N = 6, features at 40°. Remeshed
/// to 10 000 vertices, 3000 target vertices: the rounding put 7 branch points on the lines of
/// curves beside them (within 3 cells), and 2 folds stayed after the repair. A map that keeps
/// folds is tried again with the branch points moved off those lines (N = 6 only,
/// `param::constraints::off_lines`): no fold. Remeshed to 6000 vertices, 1500 target vertices:
/// that try still left 6 folds; the next, with branch points across the lines moved back as
/// well, none.
#[test]
fn a_six_fold_map_that_folds_is_tried_with_branch_points_off_the_lines() {
    use quadcover::mesh::isotropic::{IsotropicOptions, isotropic_remesh};
    let raw = test_data("cross_plate.obj");
    for (vertices, target) in [(10_000, 3000), (6000, 1500)] {
        let what = format!("cross plate at {vertices} vertices, {target} target, N = 6");
        let opts = IsotropicOptions::for_vertices(&raw, vertices, 35.0);
        let mesh = std::sync::Arc::new(isotropic_remesh(&raw, &opts).unwrap());
        let settings = Settings {
            symmetry: 6,
            target_vertices: Some(target),
            ..Settings::default()
        };
        let (base, state, solved, _) = with_features_at_40(mesh, settings, &what);
        let p = &solved.param;
        check_geometric(&base, &state, &solved);
        assert_eq!(p.flipped_faces, 0, "{what}");
        let (remesh, share, _) = remesh_along_curves(&base, &state, &solved, &what);
        remesh_checks::assert_manifold(&remesh, &what);
        eprintln!(
            "{what}: {} patched places, share {share}",
            remesh.patched_places
        );
    }
}
