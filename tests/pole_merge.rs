//! Merges that create a pole (a singularity of positive integral index, thesis sec. 4.3): four
//! +1/4 singularities moved onto one by `move_singularity` edits of a project file make a +4/4
//! pole, which QuadCover treats by alg. 6 (its star triangles become bilinear quads); the map
//! stays valid, seamless and non-degenerate. With `no_pole_merges` the merge is skipped.

use std::collections::BTreeMap;
use std::path::Path;

use quadcover::edit::{Base, Edit, MeshRef, Project, Settings, Solved};
use quadcover::mesh::TriMesh;
use quadcover::param::{Parameterization, Pole};

#[path = "support/seams.rs"]
#[allow(dead_code)] // `rot` only
mod seams;
use seams::rot;

#[path = "support/meshes.rs"]
mod meshes;
use meshes::{base_for, shared};

const N: usize = 4;

/// The four +1/4 singularities closest together: (target, the three moved onto it), mesh
/// vertices. Per +1/4 singularity its three nearest +1/4 ones; the cluster of least radius
/// (ties: the lower vertex).
fn tightest_four(base: &Base) -> (usize, [usize; 3], f64) {
    let mesh = base.mesh();
    let pos: Vec<usize> = base
        .initial()
        .singularities
        .iter()
        .filter(|(_, k)| **k == 1)
        .map(|(v, _)| *v)
        .collect();
    assert!(pos.len() >= 4, "{} singularities of index +1/4", pos.len());
    pos.iter()
        .map(|&t| {
            let mut near: Vec<(f64, usize)> = pos
                .iter()
                .filter(|&&v| v != t)
                .map(|&v| ((mesh.position(v) - mesh.position(t)).length(), v))
                .collect();
            near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            (t, [near[0].1, near[1].1, near[2].1], near[2].0)
        })
        .min_by(|a, b| a.2.total_cmp(&b.2).then(a.0.cmp(&b.0)))
        .unwrap()
}

/// Signed area of a polygon in texture space.
fn area(p: &[[f64; 2]]) -> f64 {
    let k = p.len();
    (0..k)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % k]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        / 2.0
}

/// |uv_{face(h1)} − (R^t uv_{face(h0)} + translation)| for a point pair.
fn transition_error(p: &Parameterization, e: usize, from: [f64; 2], to: [f64; 2]) -> f64 {
    let t = p.transitions[e];
    let r = rot(N, t.rotation as usize, from);
    (to[0] - r[0] - t.translation[0]).hypot(to[1] - r[1] - t.translation[1])
}

/// The edge (p, ring[k]) of a pole: in face k, the halfedge leaving p.
fn star_halfedge(mesh: &TriMesh, pole: &Pole, k: usize) -> usize {
    let f = pole.faces[k];
    (3 * f..3 * f + 3)
        .find(|&h| mesh.from(h) == pole.vertex)
        .unwrap()
}

/// Measures of a solved map with poles.
#[derive(Debug)]
struct Measured {
    /// Worst transition error over interior edges that are not pole star edges (both corners),
    /// and the worst distance of their translations from the lattice.
    seam: f64,
    lattice: f64,
    /// Worst transition error between neighbouring pole quads (both corners of each star edge)
    /// and of the quads' outer corners from their triangles' corners.
    quad_seam: f64,
    quad_outer: f64,
    /// Smallest pole quad area, the median triangle area (texture space), the total area.
    min_quad_area: f64,
    median_face_area: f64,
    total_area: f64,
    range: [f64; 2],
}

fn measure(mesh: &TriMesh, p: &Parameterization) -> Measured {
    let uv = &p.uv;
    let mut star_edge = vec![false; mesh.n_edges()];
    let mut star_face = vec![false; mesh.n_faces()];
    for pole in &p.poles {
        for k in 0..pole.faces.len() {
            star_edge[mesh.edge(star_halfedge(mesh, pole, k))] = true;
            star_face[pole.faces[k]] = true;
        }
    }
    let (mut seam, mut lattice) = (0.0f64, 0.0f64);
    for e in 0..mesh.n_edges() {
        let (h0, Some(h1)) = mesh.edge_halfedges(e) else {
            continue;
        };
        if star_edge[e] {
            continue;
        }
        // h0 runs a → b in face(h0), h1 b → a in face(h1); uv[h] is the corner at from(h).
        seam = seam
            .max(transition_error(p, e, uv[h0], uv[mesh.next(h1)]))
            .max(transition_error(p, e, uv[mesh.next(h0)], uv[h1]));
        lattice = lattice.max(
            p.lattice
                .transitions()
                .distance(p.transitions[e].translation),
        );
    }
    let (mut quad_seam, mut quad_outer, mut min_quad_area) = (0.0f64, 0.0f64, f64::INFINITY);
    let mut total_area = 0.0;
    for pole in &p.poles {
        let d = pole.faces.len();
        for k in 0..d {
            let h = star_halfedge(mesh, pole, k);
            let e = mesh.edge(h);
            lattice = lattice.max(
                p.lattice
                    .transitions()
                    .distance(p.transitions[e].translation),
            );
            // Quad k = (a_k, a_{k+1}, q_{k+1}, q_k) in chart k; its side on star edge k is
            // (a_k, q_k); quad k − 1's is (a_k, q_k) = (corner 1, corner 2) in chart k − 1.
            let (here, before) = (&pole.quads[k], &pole.quads[(k + d - 1) % d]);
            let (h0, _) = mesh.edge_halfedges(e);
            for (x, y) in [(here[0], before[1]), (here[3], before[2])] {
                let err = if mesh.face_of(h0) == pole.faces[k] {
                    transition_error(p, e, x, y)
                } else {
                    transition_error(p, e, y, x)
                };
                quad_seam = quad_seam.max(err);
            }
            // The outer corners are the triangle's a_k and a_{k+1} corners.
            for (q, c) in [(here[0], uv[mesh.next(h)]), (here[1], uv[mesh.prev(h)])] {
                quad_outer = quad_outer.max((q[0] - c[0]).hypot(q[1] - c[1]));
            }
            let a = area(&here[..]);
            min_quad_area = min_quad_area.min(a);
            total_area += a;
        }
    }
    let mut face_areas: Vec<f64> = (0..mesh.n_faces())
        .filter(|&f| !star_face[f])
        .map(|f| area(&uv[3 * f..3 * f + 3]))
        .collect();
    total_area += face_areas.iter().sum::<f64>();
    face_areas.sort_by(f64::total_cmp);
    let range = [0, 1].map(|k| {
        let lo = uv.iter().map(|x| x[k]).fold(f64::INFINITY, f64::min);
        let hi = uv.iter().map(|x| x[k]).fold(f64::NEG_INFINITY, f64::max);
        hi - lo
    });
    Measured {
        seam,
        lattice,
        quad_seam,
        quad_outer,
        min_quad_area,
        median_face_area: face_areas[face_areas.len() / 2],
        total_area,
        range,
    }
}

/// Singularities of the solve as (vertex, k): QuadCover's.
fn param_set(solved: &Solved) -> BTreeMap<usize, i32> {
    solved
        .param
        .singularities
        .iter()
        .map(|s| (s.vertex, (s.index * N as f64).round() as i32))
        .collect()
}

fn write_project(
    dir: &Path,
    name: &str,
    mesh: &Path,
    settings: Settings,
    edits: &[Edit],
) -> std::path::PathBuf {
    let project = Project {
        mesh: MeshRef {
            path: mesh.to_path_buf(),
            sha256: Some(quadcover::edit::project::sha256_hex(
                &std::fs::read(mesh).unwrap(),
            )),
        },
        settings,
        edits: edits.to_vec(),
    };
    let path = dir.join(name);
    project.save(&path).unwrap();
    path
}

#[test]
fn four_quarter_singularities_merge_into_a_treated_pole_on_spot() {
    let Some(mesh_path) = shared("spot.obj") else {
        return;
    };
    let base = base_for(&mesh_path, Settings::default());
    let mesh = base.mesh().clone();
    assert_eq!(mesh.topology().genus, 0);
    let s0 = base.initial().clone();
    let before = base.solve(&s0, &quadcover::edit::never).unwrap();
    let m0 = measure(&mesh, &before.param);
    assert!(before.param.poles.is_empty());
    let (t, three, radius) = tightest_four(&base);
    let fv = |v| base.file_vertex(v);
    eprintln!(
        "spot: {} singularities; target {} with {:?} (file vertices), radius {:.2} grid cells",
        s0.singularities.len(),
        fv(t),
        three.map(fv),
        radius / base.grid_size()
    );
    let edits: Vec<Edit> = three
        .iter()
        .map(|&v| Edit::MoveSingularity {
            from: fv(v),
            to: fv(t),
        })
        .collect();

    // The edits in a project file, loaded and replayed on a fresh base.
    let dir = tempfile::tempdir().unwrap();
    let pfile = write_project(
        dir.path(),
        "pole.json",
        &mesh_path,
        Settings::default(),
        &edits,
    );
    let project = Project::load(&pfile).unwrap();
    assert!(!project.settings.no_pole_merges);
    project
        .check_mesh(&pfile, &std::fs::read(&mesh_path).unwrap())
        .unwrap();
    let fresh = base_for(&project.mesh_path(&pfile), project.settings.clone());
    let replay = fresh
        .replay(&project.edits, &quadcover::edit::never)
        .unwrap();
    assert!(replay.skipped.is_empty(), "{:?}", replay.skipped);
    let state = replay.last();

    // Exactly the expected singularities: +4/4 at the target, the three gone, nothing else.
    let mut expected = s0.singularities.clone();
    for v in three {
        expected.remove(&v);
    }
    expected.insert(t, N as i32);
    assert_eq!(state.singularities, expected);
    let solved = fresh.solve(state, &quadcover::edit::never).unwrap();
    let angles: BTreeMap<usize, i32> = solved
        .indices
        .singularities
        .iter()
        .map(|s| (s.vertex, s.k))
        .collect();
    assert_eq!(angles, expected, "angle-based indices");
    assert_eq!(param_set(&solved), expected, "QuadCover's singularities");
    let p = &solved.param;
    let at_t = p.singularities.iter().find(|s| s.vertex == t).unwrap();
    assert!(
        (at_t.index - 1.0).abs() < 1e-9 && at_t.holonomy == 0,
        "{at_t:?}"
    );
    // Treated: listed in `poles` with its star, not in `untreated_poles`.
    assert_eq!(
        p.poles.iter().map(|x| x.vertex).collect::<Vec<_>>(),
        vec![t]
    );
    assert!(p.untreated_poles.is_empty(), "{:?}", p.untreated_poles);
    let pole = &p.poles[0];
    assert!((pole.index - 1.0).abs() < 1e-9);
    assert_eq!(pole.faces.len(), mesh.outgoing(t).count());
    assert_eq!(pole.quads.len(), pole.faces.len());

    // Valid, seamless, non-degenerate.
    let m = measure(&mesh, p);
    eprintln!(
        "unmerged: flips {} seam {:.2e} lattice {:.2e} range {:.2} x {:.2} area {:.1} median face {:.4}",
        before.param.flipped_faces,
        m0.seam,
        m0.lattice,
        m0.range[0],
        m0.range[1],
        m0.total_area,
        m0.median_face_area
    );
    eprintln!(
        "pole (star of {}): flips {} seam {:.2e} lattice {:.2e} quad seam {:.2e} quad outer {:.2e} \
         min quad area {:.4} quad areas {:?} range {:.2} x {:.2} area {:.1} median face {:.4}; \
         reported seam {:.2e}",
        pole.faces.len(),
        p.flipped_faces,
        m.seam,
        m.lattice,
        m.quad_seam,
        m.quad_outer,
        m.min_quad_area,
        pole.quads
            .iter()
            .map(|q| (area(q) * 1e4).round() / 1e4)
            .collect::<Vec<_>>(),
        m.range[0],
        m.range[1],
        m.total_area,
        m.median_face_area,
        p.seam_max_error
    );
    assert!(m.seam < 1e-6, "seam error {:e}", m.seam);
    assert!(
        m.lattice < 1e-6,
        "translation off the lattice by {:e}",
        m.lattice
    );
    assert!(
        m.quad_seam < 1e-6,
        "pole quads: seam error {:e}",
        m.quad_seam
    );
    assert!(
        m.quad_outer < 1e-12,
        "pole quads: outer corners {:e}",
        m.quad_outer
    );
    assert!(p.seam_max_error < 1e-6);
    assert_eq!(p.flipped_faces, 0);
    assert!((0..pole.faces.len()).all(|j| !pole.quad_folded(j)));
    assert!(
        m.min_quad_area > 0.05 * m.median_face_area,
        "a pole quad of area {} (median triangle {})",
        m.min_quad_area,
        m.median_face_area
    );
    for k in 0..2 {
        let ratio = m.range[k] / m0.range[k];
        assert!((0.8..1.25).contains(&ratio), "UV range {k}: {ratio}");
    }
    let ratio = m.total_area / m0.total_area;
    assert!((0.8..1.25).contains(&ratio), "UV area ratio {ratio}");

    // no_pole_merges in the project: the third move (+3/4 onto +1/4) is skipped, naming it.
    let strict = Settings {
        no_pole_merges: true,
        ..Settings::default()
    };
    let sfile = write_project(dir.path(), "strict.json", &mesh_path, strict, &edits);
    let project = Project::load(&sfile).unwrap();
    assert!(project.settings.no_pole_merges);
    let reused = fresh
        .with_settings(project.settings.clone())
        .unwrap()
        .unwrap();
    let replay = reused
        .replay(&project.edits, &quadcover::edit::never)
        .unwrap();
    assert_eq!(replay.skipped.len(), 1, "{:?}", replay.skipped);
    let skipped = &replay.skipped[0];
    assert_eq!(skipped.position, 3);
    assert!(
        skipped.reason.contains("no_pole_merges") && skipped.reason.contains("+4/4"),
        "{}",
        skipped.reason
    );
    let mut expected = s0.singularities.clone();
    expected.remove(&three[0]);
    expected.remove(&three[1]);
    expected.insert(t, 3);
    assert_eq!(replay.last().singularities, expected);

    // The same through the command line: `solve --project`, and `--no-pole-merges`.
    let run = |project: &Path, extra: &[&str]| -> serde_json::Value {
        let report = dir.path().join("r.json");
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_quadcover"))
            .arg("solve")
            .arg("--project")
            .arg(project)
            .arg("--out")
            .arg(dir.path().join("uv.obj"))
            .arg("--report")
            .arg(&report)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap()
    };
    let index_at = |r: &serde_json::Value, v: usize| {
        r["singularities"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["vertex"] == v)
            .map(|s| s["index"].as_f64().unwrap())
    };
    let r = run(&pfile, &[]);
    assert_eq!(r["edits_applied"], 3);
    assert_eq!(r["skipped_edits"].as_array().unwrap().len(), 0);
    assert_eq!(index_at(&r, fv(t)), Some(1.0));
    for v in three {
        assert_eq!(index_at(&r, fv(v)), None);
    }
    assert_eq!(r["flipped_faces"], 0);
    assert!(r["seam_max_error"].as_f64().unwrap() < 1e-6);
    for r in [run(&pfile, &["--no-pole-merges"]), run(&sfile, &[])] {
        assert_eq!(r["edits_applied"], 2);
        assert_eq!(r["skipped_edits"][0]["position"], 3);
        let reason = r["skipped_edits"][0]["reason"].as_str().unwrap();
        assert!(reason.contains("no_pole_merges"), "{reason}");
        assert_eq!(index_at(&r, fv(t)), Some(0.75));
    }
}
