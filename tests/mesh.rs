//! Foundation checks on real data: every shared mesh loads with the statistics its README gives,
//! every broken file fails with a message naming the problem, and `quadcover info` handles both.

use std::path::{Path, PathBuf};
use std::process::Command;

use quadcover::load::{LoadError, load_mesh};
use quadcover::mesh::MeshError;

fn shared_meshes() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/meshes");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipping: {} not found", dir.display());
        None
    }
}

fn broken(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/broken")
        .join(name)
}

/// (file, V in file, V referenced, E, F, genus, boundary loop lengths) from shared/meshes/README.md.
type Expected = (
    &'static str,
    usize,
    usize,
    usize,
    usize,
    i64,
    &'static [usize],
);
const SHARED: &[Expected] = &[
    (
        "bunny.obj",
        35947,
        34834,
        104288,
        69451,
        0,
        &[80, 42, 40, 39, 22],
    ),
    ("kitten.obj", 1850, 1850, 5550, 3700, 1, &[]),
    ("eight.obj", 5544, 5544, 16638, 11092, 2, &[]),
    ("fertility.obj", 4494, 4494, 13500, 9000, 4, &[]),
    ("fandisk.obj", 6475, 6475, 19419, 12946, 0, &[]),
    ("camelhead.obj", 11381, 11381, 34084, 22704, 0, &[56]),
    (
        "cerebral-vessels.obj",
        40571,
        40571,
        121557,
        80979,
        0,
        &[59, 20, 19, 15, 14, 14, 13, 12, 11],
    ),
    ("max-planck.obj", 5272, 5272, 15810, 10540, 0, &[]),
    ("spot.obj", 2930, 2930, 8784, 5856, 0, &[]),
    ("igea.obj", 134345, 134345, 403029, 268686, 0, &[]),
];

#[test]
fn every_shared_mesh_has_the_statistics_of_its_readme() {
    let Some(dir) = shared_meshes() else { return };
    for &(name, v_file, v_ref, e, f, genus, loops) in SHARED {
        let loaded = load_mesh(&dir.join(name)).unwrap_or_else(|err| panic!("{name}: {err}"));
        let m = &loaded.mesh;
        let t = m.topology();
        assert_eq!(loaded.file_vertices, v_file, "{name}: V in file");
        assert_eq!(
            (t.vertices, t.edges, t.faces),
            (v_ref, e, f),
            "{name}: V, E, F"
        );
        assert_eq!(t.components.len(), 1, "{name}: components");
        assert_eq!(t.genus, genus, "{name}: genus");
        let mut lengths: Vec<usize> = m.boundary_loops().iter().map(|l| l.len()).collect();
        lengths.sort_unstable_by(|a, b| b.cmp(a));
        assert_eq!(lengths, loops, "{name}: boundary loop lengths");
        assert_eq!(
            t.euler_characteristic,
            2 - 2 * genus - loops.len() as i64,
            "{name}: chi"
        );
        // Nothing is re-oriented or dropped, except the bunny's unreferenced vertices.
        assert!(loaded.report.flipped_faces.is_empty(), "{name}");
        assert_eq!(
            loaded.report.warnings.len(),
            usize::from(v_file != v_ref),
            "{name}: {:?}",
            loaded.report.warnings
        );
        // Gauss–Bonnet with boundary: Σ defects = 2πχ.
        let total: f64 = (0..m.n_vertices()).map(|v| m.angle_defect(v)).sum();
        let expected = std::f64::consts::TAU * t.euler_characteristic as f64;
        assert!(
            (total - expected).abs() < 1e-6 * m.n_vertices() as f64,
            "{name}: Σ defect {total} vs {expected}"
        );
    }
}

#[test]
fn bunny_keeps_the_original_index_of_every_vertex() {
    let Some(dir) = shared_meshes() else { return };
    let loaded = load_mesh(&dir.join("bunny.obj")).unwrap();
    let map = &loaded.report.original_vertex;
    assert_eq!(map.len(), 34834);
    assert!(
        map.windows(2).all(|w| w[0] < w[1]),
        "vertex order must be preserved"
    );
    assert!(
        loaded.report.warnings[0].contains("1113 unreferenced"),
        "{:?}",
        loaded.report.warnings
    );
}

fn invalid(name: &str) -> MeshError {
    match load_mesh(&broken(name)) {
        Err(LoadError::Invalid { source, .. }) => source,
        Err(e) => panic!("{name}: expected a validation error, got a read error: {e}"),
        Ok(_) => panic!("{name}: loaded, but it is broken"),
    }
}

#[test]
fn topological_defects_in_files_are_reported_with_their_location() {
    let e = invalid("nonmanifold_edge.obj");
    assert!(
        matches!(
            e,
            MeshError::NonManifoldEdge {
                count: 1,
                faces: 3,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("line"), "{e}");
    let e = invalid("nonmanifold_vertex.obj");
    assert!(matches!(e, MeshError::NonManifoldVertex { .. }), "{e}");
    assert!(
        e.to_string().contains("vertex") && e.to_string().contains("line"),
        "{e}"
    );
    let e = invalid("nonorientable.obj");
    assert!(matches!(e, MeshError::NonOrientable { .. }), "{e}");
    let e = invalid("degenerate.obj");
    assert!(
        matches!(e, MeshError::DegenerateFace { count: 1, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("line"), "{e}");
    // Face areas overflow past 1e77: the field saw "a mesh of zero area" before.
    let e = invalid("huge_coordinate.obj");
    assert!(matches!(e, MeshError::Huge { count: 3, .. }), "{e}");
    assert!(e.to_string().contains("line 2"), "{e}");
}

#[test]
fn repairable_files_load_with_warnings() {
    let ok = |name: &str, needle: &str| {
        let loaded = load_mesh(&broken(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            loaded.report.warnings.iter().any(|w| w.contains(needle)),
            "{name}: {:?}",
            loaded.report.warnings
        );
        loaded
    };
    let l = ok("inconsistent_orientation.obj", "re-oriented");
    assert_eq!(l.mesh.topology().genus, 0);
    ok("duplicate_faces.obj", "duplicate face");
    ok("unreferenced_vertices.obj", "unreferenced");
}

/// Runs the command-line tool with `args`.
fn quadcover<S: AsRef<std::ffi::OsStr>>(args: impl IntoIterator<Item = S>) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_quadcover"))
        .args(args)
        .output()
        .expect("run quadcover")
}

fn info(path: &Path) -> std::process::Output {
    quadcover([Path::new("info"), path])
}

#[test]
fn info_prints_statistics_for_every_shared_mesh() {
    let Some(dir) = shared_meshes() else { return };
    for &(name, _, v_ref, _, f, genus, loops) in SHARED {
        let out = info(&dir.join(name));
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        for (key, value) in [
            ("vertices", v_ref),
            ("faces", f),
            ("boundary loops", loops.len()),
        ] {
            assert!(
                text.lines()
                    .any(|l| l.starts_with(key) && l.ends_with(&format!(" {value}"))),
                "{name}: {key} {value} in\n{text}"
            );
        }
        assert!(
            text.lines()
                .any(|l| l.starts_with("genus") && l.ends_with(&format!(" {genus}"))),
            "{name}\n{text}"
        );
        // none of them is a raw tessellation that `solve` would remesh by itself
        assert!(
            text.lines()
                .any(|l| l.starts_with("needles") && !l.contains("raw tessellation")),
            "{name}\n{text}"
        );
    }
}

/// The files of the broken corpus (tests/data/broken), in name order, each with whether the
/// loader repairs it (with a warning) instead of refusing it.
fn broken_corpus() -> Vec<(String, PathBuf, bool)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/broken");
    let repairable = [
        "inconsistent_orientation.obj",
        "duplicate_faces.obj",
        "unreferenced_vertices.obj",
    ];
    let mut files: Vec<(String, PathBuf, bool)> = std::fs::read_dir(&dir)
        .expect("broken corpus")
        .map(|entry| {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            let fixable = repairable.contains(&name.as_str());
            (name, path, fixable)
        })
        .filter(|(name, _, _)| !name.ends_with(".md"))
        .collect();
    files.sort();
    files
}

#[test]
fn info_exits_with_2_and_a_message_on_every_broken_file() {
    let files = broken_corpus();
    for (name, path, repairable) in &files {
        let out = info(path);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.contains("panicked"), "{name} panicked: {stderr}");
        if *repairable {
            assert!(out.status.success(), "{name}: {stderr}");
            assert!(
                String::from_utf8_lossy(&out.stdout).contains("warnings"),
                "{name}"
            );
        } else {
            assert_eq!(out.status.code(), Some(2), "{name}: {stderr}");
            assert!(
                stderr.starts_with("error: ") && stderr.len() > 15,
                "{name}: {stderr}"
            );
        }
    }
    assert!(
        files.len() >= 15,
        "the broken corpus has only {} files",
        files.len()
    );
}

/// `solve` on every broken file of the corpus that cannot be repaired: exit code 2 and a
/// message that names the file (before, reader errors such as "line 1: vertex record has 2
/// coordinates" came without it). A project whose mesh is missing names both.
#[test]
fn solve_names_the_file_of_every_broken_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let solve = |input: &[&std::ffi::OsStr]| {
        let out_obj = dir.path().join("out.obj");
        let mut args: Vec<&std::ffi::OsStr> = vec!["solve".as_ref()];
        args.extend(input);
        args.extend(["--out".as_ref(), out_obj.as_os_str()]);
        let out = quadcover(args);
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(!stderr.contains("panicked"), "{input:?} panicked: {stderr}");
        assert_eq!(out.status.code(), Some(2), "{input:?}: {stderr}");
        stderr
    };
    let mut n = 0;
    for (name, path, repairable) in broken_corpus() {
        if repairable {
            continue;
        }
        let stderr = solve(&[path.as_os_str()]);
        let last = stderr.lines().last().unwrap_or_default();
        assert!(
            last.starts_with("error: ") && last.contains(&name),
            "{name}: {stderr}"
        );
        n += 1;
    }
    assert!(n >= 15, "the broken corpus has only {n} unrepairable files");
    let project = dir.path().join("lost.qcproj.json");
    std::fs::write(
        &project,
        r#"{ "format": "quadcover-project", "version": 1, "mesh": { "path": "nowhere.obj" },
            "settings": {}, "edits": [] }"#,
    )
    .unwrap();
    let stderr = solve(&["--project".as_ref(), project.as_os_str()]);
    assert!(
        stderr.contains("nowhere.obj") && stderr.contains("lost.qcproj.json"),
        "{stderr}"
    );
}

/// `solve` remeshes a far too coarse input by itself; when that remesh fails, the input is
/// solved as it is, with a warning. `tests/data/sliver_tjunction.obj` (an icosphere of 642
/// vertices with a sliver at a T-junction, from a robustness sweep) made the remesher leave
/// zero-area faces, and `solve` exited with "remeshing the input failed" although
/// `--keep-input` solved it. A smooth low-poly model is no longer remeshed by itself, so a unit
/// box whose faces are 4 × 4 grids is added beside it: their flat inner edges make the whole
/// faceted like a CAD part (`mesh::isotropic::FLAT_EDGE_SHARE`), and the remesh is tried (and
/// fails as before: the box adds little area, so the remesh's edge length is about the same).
#[test]
fn solve_keeps_the_input_when_remeshing_it_by_itself_fails() {
    let sliver = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/sliver_tjunction.obj");
    let dir = tempfile::tempdir().unwrap();
    let mut text = std::fs::read_to_string(&sliver).unwrap();
    let n = text.lines().filter(|l| l.starts_with("v ")).count();
    let cube = quadcover::mesh::generate::cube(2);
    for p in cube.positions() {
        text += &format!("v {} {} {}\n", p.x + 5.0, p.y, p.z);
    }
    for f in cube.faces() {
        let [a, b, c] = f.map(|v| v as usize + n + 1);
        text += &format!("f {a} {b} {c}\n");
    }
    let input = dir.path().join("sliver_and_box.obj");
    std::fs::write(&input, text).unwrap();
    let (uv, quads) = (dir.path().join("uv.obj"), dir.path().join("quads.obj"));
    let out = quadcover([
        "solve".as_ref(),
        input.as_os_str(),
        "--out".as_ref(),
        uv.as_os_str(),
        "--remesh".as_ref(),
        quads.as_os_str(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(dir.path().join("quads.obj").exists(), "{stderr}");
    assert!(
        stderr.contains("remeshed") || stderr.contains("solving on the input as it is"),
        "{stderr}"
    );
}

/// `extract` names what is wrong with its input: a mesh format other than OBJ (its reader read a
/// PLY's text as an OBJ without vertices), and a texture coordinate that is not finite (named
/// by corner number alone before).
#[test]
fn extract_names_a_wrong_format_and_a_bad_texture_coordinate() {
    let dir = tempfile::tempdir().unwrap();
    let extract = |input: &Path| {
        let quads = dir.path().join("quads.obj");
        let out = quadcover([
            "extract".as_ref(),
            input.as_os_str(),
            "--out".as_ref(),
            quads.as_os_str(),
        ]);
        assert_eq!(out.status.code(), Some(2));
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let ply = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ok/cube_ascii.ply");
    let e = extract(&ply);
    assert!(e.contains("PLY") && e.contains("reads an OBJ"), "{e}");
    let obj = dir.path().join("nan_uv.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt nan 1\nvt 1 1\n\
         f 1/1 2/2 3/3\nf 2/2 4/4 3/3\n",
    )
    .unwrap();
    let e = extract(&obj);
    assert!(e.contains("not finite") && e.contains("line 9"), "{e}");
}

/// Option values that would silently do nothing are refused: a feature angle outside (0°, 180°)
/// (NaN or 1000 picked no edge) and `--dual` without six-fold symmetry (no hexagons to write).
#[test]
fn solve_refuses_option_values_that_do_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let cube = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ok/cube.obj");
    for (extra, needle) in [
        (&["--features", "nan"][..], "--features"),
        (&["--features", "1000"][..], "--features"),
        (&["--features", "0"][..], "--features"),
        (&["--dual", "--remesh", "tris.obj"][..], "--symmetry 6"),
    ] {
        let uv = dir.path().join("uv.obj");
        let mut args: Vec<&std::ffi::OsStr> = vec![
            "solve".as_ref(),
            cube.as_os_str(),
            "--out".as_ref(),
            uv.as_os_str(),
        ];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        let out = quadcover(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {stderr}");
        assert!(stderr.contains(needle), "{extra:?}: {stderr}");
    }
}
