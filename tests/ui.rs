//! Editor UI tests with egui_kittest (headless, wgpu on lavapipe when present).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use quadcover::app::editor::ExportKind;
use quadcover::app::settings::{DisplayMode, Pattern, Shading};
use quadcover::app::{EditorApp, EditorOptions};
use support::{out_dir, shared_mesh};

mod support;

fn harness(recent: &Path, open: Option<PathBuf>) -> Harness<'static, EditorApp> {
    harness_with(recent, open, false)
}

fn harness_with(
    recent: &Path,
    open: Option<PathBuf>,
    auto_solve: bool,
) -> Harness<'static, EditorApp> {
    let opts = EditorOptions {
        open,
        recent_store: Some(recent.to_path_buf()),
        auto_solve,
    };
    // Tall enough that the whole side panel is on screen (clicks land on visible widgets).
    let builder = Harness::builder().with_size(egui::vec2(1100.0, 1400.0));
    let builder = if gpu_available() {
        builder.wgpu()
    } else {
        builder
    };
    builder.build_eframe(move |cc| EditorApp::new(cc, opts))
}

/// A fresh editor on a shared mesh (its recent-files list in a temporary folder, returned to
/// keep it), with the mesh loaded and, with `auto_solve`, its field, parameterization and
/// remesh computed.
fn editor_on(mesh: &str, auto_solve: bool) -> (tempfile::TempDir, Harness<'static, EditorApp>) {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness_with(
        &dir.path().join("recent.txt"),
        Some(shared_mesh(mesh)),
        auto_solve,
    );
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    (dir, h)
}

/// Like [`editor_on`] with auto-solve, on a copy of the shared mesh in the temporary folder
/// (projects are saved beside it); returns the copy's path too.
fn editor_on_copy(mesh: &str) -> (tempfile::TempDir, PathBuf, Harness<'static, EditorApp>) {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join(mesh);
    std::fs::copy(shared_mesh(mesh), &path).expect("copy the mesh");
    let mut h = harness_with(&dir.path().join("recent.txt"), Some(path.clone()), true);
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    (dir, path, h)
}

/// Whether a wgpu adapter exists. Without one the UI tests still run (the
/// viewport shows a notice), unless QUADCOVER_REQUIRE_GPU=1 makes it a failure.
fn gpu_available() -> bool {
    static AVAILABLE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *AVAILABLE.get_or_init(probe_gpu)
}

fn probe_gpu() -> bool {
    support::offscreen("no GPU adapter, UI tests run without rendering").is_some()
}

/// Steps the UI until no background job runs (or a timeout).
fn settle(h: &mut Harness<'static, EditorApp>) {
    let start = Instant::now();
    while h.state().busy() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "jobs did not finish"
        );
        h.step();
        std::thread::sleep(Duration::from_millis(10));
    }
    h.run_steps(3);
}

fn save_render(h: &mut Harness<'static, EditorApp>, name: &str) {
    if !gpu_available() {
        return;
    }
    match h.render() {
        Ok(img) => {
            let path = out_dir().join(name);
            img.save(&path).expect("write png");
            eprintln!("wrote {}", path.display());
        }
        Err(e) => eprintln!("no render of the UI ({e})"),
    }
}

#[test]
fn starts_with_default_mesh_and_loads_a_shared_mesh() {
    let dir = tempfile::tempdir().expect("tempdir");
    let recent = dir.path().join("recent.txt");
    let mut h = harness(&recent, None);
    settle(&mut h);
    h.get_by_label_contains("File: spot.obj");
    h.get_by_label("Faces: 5856");
    h.get_by_label("Genus: 0");
    save_render(&mut h, "ui_default.png");

    let kitten = shared_mesh("kitten.obj");
    let ctx = h.ctx.clone();
    h.state_mut().open_path(&kitten, Some(ctx));
    settle(&mut h);
    h.get_by_label("File: kitten.obj");
    h.get_by_label("Vertices: 1850");
    h.get_by_label("Faces: 3700");
    h.get_by_label("Genus: 1");
    h.get_by_label("Components: 1");
    h.get_by_label("Boundary loops: 0");
    assert!(h.state().error.is_none());
    // the recent-files list remembers it
    let text = std::fs::read_to_string(&recent).expect("recent list written");
    assert!(text.contains("kitten.obj"), "{text}");
}

#[test]
fn switches_display_mode_pattern_and_shading() {
    let (dir, mut h) = editor_on("kitten.obj", false);

    // the real solvers, as background jobs: field, then QuadCover
    h.get_by_label("Compute field").click();
    h.step();
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(h.state().document.frame_field.is_some());
    assert_eq!(h.state().document.display.mode, DisplayMode::Field);
    h.get_by_label_contains("Field: N = 4");
    save_render(&mut h, "ui_kitten_field.png");

    h.get_by_label("Parameterize").click();
    h.step();
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(h.state().document.has_param());
    assert_eq!(h.state().document.display.mode, DisplayMode::Pattern);
    assert_eq!(h.state().document.display.pattern, Pattern::QuadGrid);
    h.get_by_label_contains("Parameterization: ");
    save_render(&mut h, "ui_kitten_quads.png");

    // A re-solve reuses the mesh's QuadCover analysis (numeric work only) and gives the same map.
    let analysis = h
        .state()
        .document
        .param_analysis
        .clone()
        .expect("analysis kept");
    let first = h
        .state()
        .document
        .parameterization
        .as_ref()
        .unwrap()
        .uv
        .clone();
    h.get_by_label("Parameterize").click();
    h.step();
    settle(&mut h);
    let again = h.state().document.param_analysis.clone().unwrap();
    assert!(std::sync::Arc::ptr_eq(&analysis, &again));
    assert_eq!(
        h.state().document.parameterization.as_ref().unwrap().uv,
        first
    );

    // File ▸ Export, as background jobs: the UV OBJ reads back with the solver's UVs, and the
    // remesh of the genus-1 kitten is a closed quad-dominant mesh.
    let uv_path = dir.path().join("kitten-uv.obj");
    let remesh_path = dir.path().join("kitten-quads.obj");
    h.state_mut()
        .start_export(None, ExportKind::UvObj, uv_path.clone());
    h.state_mut()
        .start_export(None, ExportKind::Remesh, remesh_path.clone());
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let back = quadcover::io::read_obj_bytes(&std::fs::read(&uv_path).unwrap()).unwrap();
    let uv = &h.state().document.parameterization.as_ref().unwrap().uv;
    assert_eq!(back.corner_uvs.as_ref(), Some(uv));
    let text = std::fs::read_to_string(&remesh_path).unwrap();
    let sides: Vec<usize> = text
        .lines()
        .filter(|l| l.starts_with("f "))
        .map(|l| l.split_whitespace().count() - 1)
        .collect();
    let quads = sides.iter().filter(|&&n| n == 4).count();
    assert!(
        sides.len() > 1000 && quads * 10 > sides.len() * 9,
        "{quads} quads of {}",
        sides.len()
    );
    assert!(
        h.state().status.starts_with("Saved "),
        "{}",
        h.state().status
    );

    h.get_by_label("Shaded").click();
    h.run_steps(2);
    assert_eq!(h.state().document.display.mode, DisplayMode::Shaded);
    h.get_by_label("Texture pattern").click();
    h.run_steps(2);
    assert_eq!(h.state().document.display.mode, DisplayMode::Pattern);

    // pattern combo box
    h.get_by_label("Pattern").click();
    h.run_steps(2);
    h.get_by_label("Octagon-square (4.8.8)").click();
    h.run_steps(2);
    assert_eq!(h.state().document.display.pattern, Pattern::OctagonSquare);

    h.get_by_label("Flat").click();
    h.get_by_label("Wireframe").click();
    h.run_steps(2);
    assert_eq!(h.state().document.display.shading, Shading::Flat);
    assert!(h.state().document.display.wireframe);
    save_render(&mut h, "ui_kitten_octagons.png");

    // the synthetic demo field still works and switches to the LIC
    h.get_by_label("Demo (synthetic data)").click();
    h.run_steps(2);
    h.get_by_label("Synthetic field").click();
    h.step();
    settle(&mut h);
    assert_eq!(h.state().document.display.mode, DisplayMode::Field);
}

#[test]
fn bad_file_shows_error_and_editor_keeps_running() {
    let (dir, mut h) = editor_on("kitten.obj", false);

    let bad = dir.path().join("broken.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nf 1 2 9\nthis is not obj\n").expect("write");
    let ctx = h.ctx.clone();
    h.state_mut().open_path(&bad, Some(ctx.clone()));
    settle(&mut h);
    let err = h.state().error.clone().expect("an error is shown");
    assert!(err.contains("broken.obj"), "{err}");
    h.get_by_label_contains("Could not complete");
    save_render(&mut h, "ui_error.png");
    // the previous document is intact
    h.get_by_label("File: kitten.obj");

    // a missing file too
    h.state_mut()
        .open_path(&dir.path().join("missing.obj"), Some(ctx));
    settle(&mut h);
    assert!(
        h.state()
            .error
            .as_deref()
            .unwrap_or("")
            .contains("missing.obj")
    );

    // dismiss and keep working
    h.get_by_label("OK").click();
    h.run_steps(2);
    assert!(h.state().error.is_none());
    h.get_by_label("Flat").click();
    h.run_steps(2);
    assert_eq!(h.state().document.display.shading, Shading::Flat);

    // files dropped on the window are opened
    h.input_mut()
        .dropped_files
        .push(Arc::new(Dropped(shared_mesh("spot.obj"))));
    h.step();
    settle(&mut h);
    h.get_by_label("File: spot.obj");
}

#[test]
fn results_for_a_replaced_mesh_are_discarded() {
    let (_dir, mut h) = editor_on("kitten.obj", false);
    let ctx = h.ctx.clone();
    h.state_mut().start_field(Some(ctx.clone()), 4);
    h.state_mut().open_path(&shared_mesh("spot.obj"), Some(ctx));
    settle(&mut h);
    h.get_by_label("File: spot.obj");
    assert!(h.state().document.frame_field.is_none());
    assert!(h.state().document.field.is_none());
    assert!(h.state().error.is_none());
}

#[test]
fn camera_orbits_pans_zooms_and_fits() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(&dir.path().join("recent.txt"), None);
    settle(&mut h);
    let fitted = h.state().camera;
    let c = egui::pos2(700.0, 400.0);
    let drag = |h: &mut Harness<'static, EditorApp>, button, to: egui::Pos2| {
        h.hover_at(c);
        h.event(egui::Event::PointerButton {
            pos: c,
            button,
            pressed: true,
            modifiers: egui::Modifiers::NONE,
        });
        h.step();
        for i in 1..=5 {
            h.hover_at(c + (to - c) * (i as f32 / 5.0));
            h.step();
        }
        h.event(egui::Event::PointerButton {
            pos: to,
            button,
            pressed: false,
            modifiers: egui::Modifiers::NONE,
        });
        h.step();
    };
    // LMB: orbit
    drag(
        &mut h,
        egui::PointerButton::Primary,
        c + egui::vec2(120.0, 30.0),
    );
    let orbited = h.state().camera;
    assert!((orbited.yaw - fitted.yaw).abs() > 0.3, "{orbited:?}");
    assert!((orbited.pitch - fitted.pitch).abs() > 0.05);
    assert_eq!(orbited.target, fitted.target);
    // RMB: pan
    drag(
        &mut h,
        egui::PointerButton::Secondary,
        c + egui::vec2(-80.0, 40.0),
    );
    let panned = h.state().camera;
    assert!((panned.target - orbited.target).length() > 1e-3);
    assert_eq!(panned.yaw, orbited.yaw);
    // wheel: zoom
    h.hover_at(c);
    h.event(egui::Event::MouseWheel {
        unit: egui::MouseWheelUnit::Point,
        delta: egui::vec2(0.0, 200.0),
        phase: egui::TouchPhase::Move,
        source: egui::MouseWheelSource::Wheel,
        modifiers: egui::Modifiers::NONE,
    });
    h.run_steps(20);
    assert!(h.state().camera.distance < panned.distance * 0.95);
    // F: fit again (target and distance)
    h.key_press(egui::Key::F);
    h.run_steps(2);
    let refit = h.state().camera;
    assert!((refit.target - fitted.target).length() < 1e-5);
    assert!((refit.distance - fitted.distance).abs() < 1e-4);
    // the Fit button does the same
    drag(
        &mut h,
        egui::PointerButton::Secondary,
        c + egui::vec2(50.0, 50.0),
    );
    h.get_by_label("Fit (F)").click();
    h.run_steps(2);
    assert!((h.state().camera.target - fitted.target).length() < 1e-5);
}

#[derive(Debug)]
struct Dropped(PathBuf);

impl egui::DroppedFile for Dropped {
    fn path(&self) -> &Path {
        &self.0
    }

    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|e| e.to_string())
    }
}

/// As the editor starts (`run_editor`): the mesh loads, then field and QuadCover run in the
/// background without a click, and the parameterization is shown as its pattern.
#[test]
fn on_start_field_and_parameterization_are_computed_in_the_background() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness_with(
        &dir.path().join("recent.txt"),
        Some(shared_mesh("kitten.obj")),
        true,
    );
    // The first frames come back at once while the jobs run.
    h.run_steps(2);
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(h.state().document.frame_field.is_some());
    assert!(h.state().document.has_param());
    assert_eq!(h.state().document.display.mode, DisplayMode::Pattern);
    h.get_by_label_contains("Parameterization: ");
}

// ---- singularity editing (issue #13) ----------------------------------------------------------

use quadcover::app::files::PendingAction;
use quadcover::app::picking::project;
use quadcover::edit::{Edit, Project};

/// Singularities of the document's current state as (file vertex, k).
/// An edit moving the first singularity to a free interior neighbour (through the document
/// API; the drag tests cover the gesture).
fn move_to_free_neighbour(h: &Harness<'static, EditorApp>) -> Edit {
    let (base, state) = h.state().document.editable().unwrap();
    let (&p, _) = state.singularities.iter().next().unwrap();
    let q = base
        .mesh()
        .outgoing(p)
        .map(|hh| base.mesh().to(hh))
        .find(|q| !state.singularities.contains_key(q) && !base.mesh().is_boundary_vertex(*q))
        .expect("a free neighbour");
    Edit::MoveSingularity {
        from: base.file_vertex(p),
        to: base.file_vertex(q),
    }
}

fn singularities(h: &Harness<'static, EditorApp>) -> Vec<(usize, i32)> {
    h.state()
        .document
        .file_singularities()
        .expect("the document is editable")
}

fn uvs(h: &Harness<'static, EditorApp>) -> Vec<[f64; 2]> {
    h.state()
        .document
        .parameterization
        .as_ref()
        .expect("a parameterization")
        .uv
        .clone()
}

/// A move the drag test can do on screen: the source glyph's and the target vertex's screen
/// positions, the mesh vertices and the index k.
struct ScreenMove {
    from_px: egui::Pos2,
    to_px: egui::Pos2,
    from: usize,
    to: usize,
    k: i32,
}

/// Finds a visible singularity and a visible non-singular vertex 40–120 px away on screen
/// that the move would accept (and that is not near another glyph).
fn find_screen_move(app: &EditorApp) -> ScreenMove {
    let view = app.view();
    let picker = app.current_picker().expect("the picking BVH is built");
    let (base, state) = app.document.editable().expect("editable");
    let inner = view.rect.shrink(60.0);
    let glyph_px: Vec<(usize, egui::Pos2)> = state
        .singularities
        .keys()
        .filter_map(|&v| Some((v, project(&view, base.mesh().position(v).as_vec3())?)))
        .collect();
    for &(p, sp) in &glyph_px {
        if !inner.contains(sp) || picker.pick_vertex_glyph(&view, sp, [p], 10.0) != Some(p) {
            continue;
        }
        // another glyph too close would make the press ambiguous
        if glyph_px
            .iter()
            .any(|&(q, sq)| q != p && sq.distance(sp) < 14.0)
        {
            continue;
        }
        for (dx, dy) in [
            (60.0, 0.0),
            (0.0, 60.0),
            (-60.0, 0.0),
            (0.0, -60.0),
            (45.0, 45.0),
        ] {
            let Some(hit) = picker.pick(&view, sp + egui::vec2(dx, dy)) else {
                continue;
            };
            let q = hit.vertex;
            let Some(sq) = project(&view, base.mesh().position(q).as_vec3()) else {
                continue;
            };
            let far_from_glyphs = glyph_px.iter().all(|&(_, g)| g.distance(sq) > 16.0);
            if state.singularities.contains_key(&q)
                || !far_from_glyphs
                || !inner.contains(sq)
                || sq.distance(sp) < 40.0
                || picker.pick(&view, sq).map(|h| h.vertex) != Some(q)
            {
                continue;
            }
            if let Ok(Some(k)) = base.preview_move(state, p, q).result {
                assert_eq!(k, state.singularities[&p]);
                return ScreenMove {
                    from_px: sp,
                    to_px: sq,
                    from: p,
                    to: q,
                    k,
                };
            }
        }
    }
    panic!("no visible singularity with a free vertex beside it");
}

fn press(h: &mut Harness<'static, EditorApp>, pos: egui::Pos2, pressed: bool) {
    h.event(egui::Event::PointerButton {
        pos,
        button: egui::PointerButton::Primary,
        pressed,
        modifiers: egui::Modifiers::NONE,
    });
}

/// Hover a glyph (tooltip), press on it, drag in steps onto a free vertex (live preview),
/// release: one edit, re-solved in the background; undo and redo restore the states exactly.
#[test]
fn dragging_a_singularity_moves_it_and_undo_redo_restore_it() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let before = singularities(&h);
    let uv_before = uvs(&h);
    let revision_before = h.state().document.revision();
    let mv = find_screen_move(h.state());
    let (file_from, file_to) = {
        let base = h.state().document.edit_base.clone().unwrap();
        (base.file_vertex(mv.from), base.file_vertex(mv.to))
    };
    let camera = h.state().camera;

    // hover: the tooltip names the vertex and the index
    h.hover_at(mv.from_px);
    h.run_steps(2);
    h.get_by_label_contains(&format!("Singularity at vertex {file_from}, index"));

    // press and drag: the preview follows the cursor, the camera does not orbit
    press(&mut h, mv.from_px, true);
    h.step();
    for i in 1..=6 {
        h.hover_at(mv.from_px + (mv.to_px - mv.from_px) * (i as f32 / 6.0));
        h.step();
    }
    assert_eq!(h.state().camera, camera, "the drag orbited the camera");
    assert!(h.state().tool.active());
    let overlay = h
        .state()
        .tool
        .overlay()
        .expect("a path preview while dragging");
    assert!(!overlay.lines.is_empty());
    h.get_by_label_contains(&format!("-> {file_to}"));
    press(&mut h, mv.to_px, false);
    h.step();
    assert!(!h.state().tool.active());
    assert_eq!(
        h.state().document.applied_edits(),
        &[Edit::MoveSingularity {
            from: file_from,
            to: file_to
        }]
    );
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(h.state().document.solve_current());
    assert!(h.state().document.solve_error.is_none());
    let after = singularities(&h);
    let mut expected: Vec<(usize, i32)> = before
        .iter()
        .copied()
        .filter(|&(v, _)| v != file_from)
        .chain([(file_to, mv.k)])
        .collect();
    expected.sort_unstable();
    assert_eq!(after, expected);
    // the shown field and texture were rebuilt for the new state
    assert!(h.state().document.revision() > revision_before);
    let shown: Vec<usize> = h
        .state()
        .document
        .field
        .as_ref()
        .unwrap()
        .singularities
        .iter()
        .map(|s| s.vertex)
        .collect();
    assert!(shown.contains(&mv.to) && !shown.contains(&mv.from));
    let uv_after = uvs(&h);
    assert!(uv_after != uv_before, "the map did not change");
    assert!(h.state().title().contains('*'), "{}", h.state().title());
    save_render(&mut h, "ui_moved_singularity.png");

    // the Edit menu lists the history
    h.get_by_label("Edit").click();
    h.run_steps(2);
    h.get_by_label_contains(&format!("1. Move singularity {file_from} -> {file_to}"));
    h.key_press(egui::Key::Escape);
    h.run_steps(2);

    // undo (Ctrl+Z): the earlier state exactly
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.step();
    settle(&mut h);
    assert_eq!(h.state().document.cursor(), 0);
    assert_eq!(singularities(&h), before);
    assert!(
        uvs(&h) == uv_before,
        "undo gives the earlier map bit for bit"
    );
    assert!(!h.state().document.is_dirty());
    // redo (Ctrl+Shift+Z), undo again, redo (Ctrl+Y)
    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::Z,
    );
    h.step();
    settle(&mut h);
    assert_eq!(singularities(&h), after);
    assert!(uvs(&h) == uv_after, "redo gives the later map bit for bit");
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.step();
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Y);
    h.step();
    settle(&mut h);
    assert_eq!(h.state().document.cursor(), 1);
    assert_eq!(singularities(&h), after);

    // Esc cancels a drag: no edit
    let mv2 = find_screen_move(h.state());
    press(&mut h, mv2.from_px, true);
    h.step();
    for i in 1..=4 {
        h.hover_at(mv2.from_px + (mv2.to_px - mv2.from_px) * (i as f32 / 4.0));
        h.step();
    }
    assert!(h.state().tool.active());
    h.key_press(egui::Key::Escape);
    h.step();
    assert!(h.state().tool.overlay().is_none(), "the preview is gone");
    // moving on with the button still down neither drags nor orbits
    let cam = h.state().camera;
    h.hover_at(mv2.to_px + egui::vec2(30.0, 10.0));
    h.step();
    assert_eq!(h.state().camera, cam);
    press(&mut h, mv2.to_px, false);
    h.step();
    assert!(!h.state().tool.active());
    settle(&mut h);
    assert_eq!(h.state().document.edits.len(), 1);
    assert_eq!(singularities(&h), after);

    // a press away from any glyph still orbits
    let empty = h.state().view().rect.left_top() + egui::vec2(120.0, 300.0);
    press(&mut h, empty, true);
    h.step();
    for i in 1..=4 {
        h.hover_at(empty + egui::vec2(20.0 * i as f32, 0.0));
        h.step();
    }
    press(&mut h, empty + egui::vec2(80.0, 0.0), false);
    h.step();
    assert_ne!(h.state().camera.yaw, camera.yaw);
    assert_eq!(h.state().document.edits.len(), 1);
}

/// Rapid edits coalesce: only the newest state is solved and shown; Relax runs in the job.
#[test]
fn rapid_edits_coalesce_and_relax_runs_in_the_background() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    let before = singularities(&h);
    let curl_before = h.state().document.parameterization.as_ref().unwrap().curl;
    // Relax, undo, redo, in the same frame: one solve for the last revision
    h.get_by_label("Relax").click();
    h.step();
    h.state_mut().undo();
    h.state_mut().redo();
    let revision = h.state().document.edit_revision();
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(h.state().document.solve_error.is_none());
    assert_eq!(
        h.state().document.solve_info.as_ref().unwrap().revision,
        revision
    );
    assert_eq!(h.state().document.applied_edits(), &[Edit::Relax]);
    let relaxed = singularities(&h);
    assert!(relaxed.len() <= before.len());
    let curl = h.state().document.parameterization.as_ref().unwrap().curl;
    assert!(
        curl <= curl_before + 1e-9,
        "relax raised the curl: {curl_before} -> {curl}"
    );
    h.get_by_label_contains("1 of 1 edits applied");
}

/// Save the project, reopen it (same edits, same singularities, the same map bit for bit);
/// broken project files show an error and the editor keeps its document; opening another
/// file with unsaved changes asks first.
#[test]
fn projects_save_reopen_and_broken_ones_keep_the_document() {
    let (dir, mesh, mut h) = editor_on_copy("spot.obj");
    // an edit through the document API (the drag test covers the gesture)
    let edit = move_to_free_neighbour(&h);
    h.state_mut().commit_edit(edit.clone());
    settle(&mut h);
    assert!(h.state().document.is_dirty());
    let sing = singularities(&h);
    let uv = uvs(&h);

    let project_path = dir.path().join("spot-project.json");
    assert!(h.state_mut().save_project_to(&project_path));
    assert!(!h.state().document.is_dirty());
    assert!(!h.state().title().contains('*'), "{}", h.state().title());
    assert!(h.state().title().contains("spot-project.json"));
    let saved = Project::load(&project_path).expect("the saved project reads back");
    assert_eq!(saved.edits, vec![edit.clone()]);
    assert_eq!(saved.mesh.path, PathBuf::from("spot.obj"));

    // reopen in a fresh editor: same edits, singularities and map
    let mut h2 = harness_with(
        &dir.path().join("recent.txt"),
        Some(project_path.clone()),
        false,
    );
    settle(&mut h2);
    assert!(h2.state().error.is_none(), "{:?}", h2.state().error);
    assert_eq!(
        h2.state().document.applied_edits(),
        std::slice::from_ref(&edit)
    );
    assert_eq!(singularities(&h2), sing);
    assert!(
        uvs(&h2) == uv,
        "a replayed project gives the same map bit for bit"
    );
    assert!(!h2.state().document.is_dirty());
    drop(h2);

    // broken projects: the error names the file (and the edit); the document stays
    let json = std::fs::read_to_string(&project_path).unwrap();
    let changed_mesh = dir.path().join("changed.obj");
    std::fs::write(
        &changed_mesh,
        format!("{}\n# changed\n", std::fs::read_to_string(&mesh).unwrap()),
    )
    .unwrap();
    let cases = [
        (
            "truncated.json",
            json[..json.len() / 2].to_string(),
            "truncated",
        ),
        (
            "unknown-op.json",
            json.replace("move_singularity", "explode"),
            "edit 1",
        ),
        (
            "out-of-range.json",
            json.replacen(
                &format!(
                    "\"to\": {}",
                    match edit {
                        Edit::MoveSingularity { to, .. } => to,
                        _ => unreachable!(),
                    }
                ),
                "\"to\": 99999999",
                1,
            ),
            "edit 1",
        ),
        (
            "hash.json",
            json.replace("\"spot.obj\"", "\"changed.obj\""),
            "changed",
        ),
    ];
    for (name, text, expect) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let ctx = h.ctx.clone();
        h.state_mut().open_path(&path, Some(ctx));
        settle(&mut h);
        let err = h
            .state()
            .error
            .clone()
            .unwrap_or_else(|| panic!("{name}: no error shown"));
        assert!(err.contains(name), "{name}: {err}");
        assert!(err.contains(expect), "{name}: {err}");
        h.get_by_label_contains("Could not complete");
        assert_eq!(
            h.state().document.applied_edits(),
            std::slice::from_ref(&edit),
            "{name}"
        );
        assert_eq!(singularities(&h), sing, "{name}");
        assert_eq!(
            h.state().document.project_path.as_deref(),
            Some(project_path.as_path())
        );
        h.get_by_label("OK").click();
        h.run_steps(2);
        assert!(h.state().error.is_none());
    }

    // Ctrl+S saves to the project's file
    h.get_by_label("Relax").click();
    h.step();
    settle(&mut h);
    assert!(h.state().document.is_dirty());
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::S);
    h.step();
    assert!(!h.state().document.is_dirty());
    let saved = Project::load(&project_path).unwrap();
    assert_eq!(saved.edits, vec![edit.clone(), Edit::Relax]);

    // unsaved changes: opening another file asks; Cancel keeps, Discard opens
    h.state_mut().undo();
    settle(&mut h);
    assert!(h.state().document.is_dirty());
    assert!(h.state().title().contains('*'));
    h.state_mut()
        .request(PendingAction::Open(shared_mesh("kitten.obj")));
    h.run_steps(2);
    assert!(h.state().confirm.is_some());
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    settle(&mut h);
    assert!(h.state().confirm.is_none());
    h.get_by_label("File: spot.obj");
    h.state_mut()
        .request(PendingAction::Open(shared_mesh("kitten.obj")));
    h.run_steps(2);
    h.get_by_label("Discard").click();
    h.run_steps(2);
    settle(&mut h);
    h.get_by_label("File: kitten.obj");
    assert!(h.state().document.edits.is_empty());
}

/// New settings rebuild the base and replay the edits in the background; an edit that no
/// longer applies is skipped with a visible notice; closing with unsaved changes asks first.
#[test]
fn settings_replay_the_edits_and_skipped_edits_are_shown() {
    let (dir, _mesh, mut h) = editor_on_copy("spot.obj");
    let (good, free, not_singular) = {
        let (base, state) = h.state().document.editable().unwrap();
        let (&p, _) = state.singularities.iter().next().unwrap();
        let q = base
            .mesh()
            .outgoing(p)
            .map(|hh| base.mesh().to(hh))
            .find(|q| !state.singularities.contains_key(q))
            .unwrap();
        let other = (0..base.mesh().n_vertices())
            .find(|v| *v != q && *v != p && !state.singularities.contains_key(v))
            .unwrap();
        (
            Edit::MoveSingularity {
                from: base.file_vertex(p),
                to: base.file_vertex(q),
            },
            base.file_vertex(q),
            base.file_vertex(other),
        )
    };
    // a project whose second edit names a vertex that is not singular: replay skips it
    let bad = Edit::MoveSingularity {
        from: not_singular,
        to: free,
    };
    let mut project = h
        .state()
        .document
        .project_for(&dir.path().join("p.json"))
        .unwrap();
    project.edits = vec![good.clone(), bad.clone()];
    project.save(&dir.path().join("p.json")).unwrap();
    let ctx = h.ctx.clone();
    h.state_mut()
        .open_path(&dir.path().join("p.json"), Some(ctx));
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let skipped = &h.state().document.skipped;
    assert_eq!(skipped.len(), 1, "{skipped:?}");
    assert_eq!(skipped[0].position, 2);
    assert_eq!(skipped[0].edit, bad);
    h.get_by_label_contains("Skipped edits (1)");
    h.get_by_label_contains("edit 2: Move singularity");
    let after_good = singularities(&h);

    // new settings: the base is rebuilt and both edits replayed
    let base_before = h.state().document.edit_base.clone().unwrap();
    h.state_mut().settings_draft.tau = 0.5;
    h.run_steps(2);
    h.get_by_label("Apply settings").click();
    h.step();
    assert!(
        h.state().document.editable().is_none(),
        "the old base is not editable"
    );
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let base_after = h.state().document.edit_base.clone().unwrap();
    assert!(!Arc::ptr_eq(&base_before, &base_after));
    assert_eq!(base_after.settings().tau, 0.5);
    assert!(h.state().document.solve_current());
    assert_eq!(h.state().document.applied_edits().len(), 2);
    assert!(h.state().document.is_dirty());
    // the first edit still moved its singularity (same mesh, same move)
    let (from, to) = match good {
        Edit::MoveSingularity { from, to } => (from, to),
        _ => unreachable!(),
    };
    let now = singularities(&h);
    assert!(now.iter().any(|&(v, _)| v == to), "{now:?}");
    assert!(!now.iter().any(|&(v, _)| v == from), "{now:?}");
    assert!(after_good.iter().any(|&(v, _)| v == to));

    // closing with unsaved changes asks; Cancel keeps the window
    h.state_mut().request(PendingAction::Close);
    h.run_steps(2);
    h.get_by_label("Unsaved changes");
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    assert!(h.state().confirm.is_none());
    assert!(h.state().document.is_dirty());
}

/// Two visible singularities apart from the others whose indices satisfy `want`:
/// (mesh p, mesh q, screen p, screen q).
fn find_pair(
    app: &EditorApp,
    want: impl Fn(i32, i32) -> bool,
) -> Option<(usize, usize, egui::Pos2, egui::Pos2)> {
    let view = app.view();
    let picker = app.current_picker()?;
    let (base, state) = app.document.editable()?;
    let inner = view.rect.shrink(60.0);
    let screen = |v: usize| project(&view, base.mesh().position(v).as_vec3());
    let glyphs: Vec<(usize, egui::Pos2)> = state
        .singularities
        .keys()
        .filter_map(|&v| Some((v, screen(v)?)))
        .filter(|(v, s)| {
            inner.contains(*s) && picker.pick_vertex_glyph(&view, *s, [*v], 10.0) == Some(*v)
        })
        .collect();
    let isolated = |v: usize, s: egui::Pos2| {
        state
            .singularities
            .keys()
            .all(|&w| w == v || screen(w).is_none_or(|t| t.distance(s) > 14.0))
    };
    for &(p, sp) in &glyphs {
        for &(q, sq) in &glyphs {
            if p != q
                && want(state.singularities[&p], state.singularities[&q])
                && sp.distance(sq) > 30.0
                && isolated(p, sp)
                && isolated(q, sq)
            {
                return Some((p, q, sp, sq));
            }
        }
    }
    None
}

/// Drags the glyph at `sp` onto `sq` in steps; checks the tooltip shows `expect` before the
/// release.
fn drag_glyph(h: &mut Harness<'static, EditorApp>, sp: egui::Pos2, sq: egui::Pos2, expect: &str) {
    press(h, sp, true);
    h.step();
    for i in 1..=6 {
        h.hover_at(sp + (sq - sp) * (i as f32 / 6.0));
        h.step();
    }
    assert!(h.state().tool.overlay().is_some(), "no preview");
    h.get_by_label_contains(expect);
    press(h, sq, false);
    h.step();
    settle(h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
}

/// Dragging a singularity onto one of the opposite sign cancels both (the tooltip says so
/// before the release); with `no_half_merges`, dragging +1/4 onto +1/4 is refused: the
/// tooltip and then the notice say why, and nothing is committed.
#[test]
fn dragging_onto_another_singularity_merges_or_says_why_not() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    let before = singularities(&h);
    let base = h.state().document.edit_base.clone().unwrap();
    let (p, q, sp, sq) = find_pair(h.state(), |a, b| a == -b).expect("an opposite pair on screen");
    let (fp, fq) = (base.file_vertex(p), base.file_vertex(q));
    {
        let (_, state) = h.state().document.editable().unwrap();
        assert_eq!(base.preview_move(state, p, q).result, Ok(Some(0)));
    }
    drag_glyph(&mut h, sp, sq, "both cancel");
    assert_eq!(
        h.state().document.applied_edits(),
        &[Edit::MoveSingularity { from: fp, to: fq }]
    );
    let expected: Vec<(usize, i32)> = before
        .iter()
        .copied()
        .filter(|&(v, _)| v != fp && v != fq)
        .collect();
    assert_eq!(singularities(&h), expected);

    // no_half_merges: +1/4 onto +1/4 would make a +2/4 hanging node
    h.state_mut().settings_draft.no_half_merges = true;
    h.state_mut().apply_settings();
    settle(&mut h);
    assert!(h.state().document.settings.no_half_merges);
    let before = singularities(&h);
    let (_, _, sp, sq) = find_pair(h.state(), |a, b| a == 1 && b == 1).expect("two +1/4 on screen");
    drag_glyph(&mut h, sp, sq, "Refused:");
    assert_eq!(
        h.state().document.edits.len(),
        1,
        "the refused merge was committed"
    );
    assert_eq!(singularities(&h), before);
    let notice = h.state().notice.clone().expect("the refusal is shown");
    assert!(notice.contains("refused"), "{notice}");
    h.get_by_label_contains(&notice);
}

/// Undo and redo back to a state solved a moment ago show its remembered solve at once (no
/// job runs), bit for bit the same map.
#[test]
fn undo_and_redo_show_remembered_solves_at_once() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    let uv_bits = |h: &Harness<'static, EditorApp>| -> Vec<[u64; 2]> {
        let p = h.state().document.parameterization.as_ref().unwrap();
        p.uv.iter()
            .map(|x| [x[0].to_bits(), x[1].to_bits()])
            .collect()
    };
    let (before, sing_before) = (uv_bits(&h), singularities(&h));
    let edit = move_to_free_neighbour(&h);
    h.state_mut().commit_edit(edit);
    settle(&mut h);
    let (after, sing_after) = (uv_bits(&h), singularities(&h));
    assert_ne!(sing_after, sing_before);
    h.state_mut().undo();
    assert!(!h.state().busy(), "undo started a solve");
    assert!(h.state().document.solve_current());
    assert_eq!(uv_bits(&h), before);
    assert_eq!(singularities(&h), sing_before);
    h.state_mut().redo();
    assert!(!h.state().busy(), "redo started a solve");
    assert_eq!(uv_bits(&h), after);
    assert_eq!(singularities(&h), sing_after);
}

// ---- constraint curves (thesis sec. 4.4) ------------------------------------------------------

use quadcover::app::tools::ToolKind;
use quadcover::constraint::{CurveKind, CurveOrigin, check_path, feature_edges};
use quadcover::edit::Curve;
use std::collections::BTreeMap;

/// The document's curves (mesh vertices), by id.
fn curves(h: &Harness<'static, EditorApp>) -> BTreeMap<u32, Curve> {
    h.state()
        .document
        .curves()
        .cloned()
        .expect("the document has a state")
}

/// The vertex a click near `near` picks, and a screen position next to it (inside the face
/// hit there, a tenth of the way to the other corners) where a click picks it too: exactly at
/// a vertex, a ray may slip between the faces around it.
fn clickable_vertex(app: &EditorApp, near: egui::Pos2) -> (usize, egui::Pos2) {
    let view = app.view();
    let picker = app.current_picker().expect("the picking BVH is built");
    let mesh = picker.mesh();
    let hit = picker
        .pick(&view, near)
        .unwrap_or_else(|| panic!("no surface at {near:?}"));
    let v = hit.vertex;
    let corners = mesh.faces()[hit.face].map(|w| mesh.position(w as usize));
    let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
    let p = mesh.position(v) * 0.8 + centre * 0.2;
    let s = project(&view, p.as_vec3()).expect("in view");
    assert_eq!(picker.pick(&view, s).map(|h| h.vertex), Some(v), "{near:?}");
    (v, s)
}

/// A click: hover, press, release (a frame each).
fn click(h: &mut Harness<'static, EditorApp>, pos: egui::Pos2) {
    h.hover_at(pos);
    h.step();
    press(h, pos, true);
    h.step();
    press(h, pos, false);
    h.step();
}

/// The committed `AddCurve` edit at the end of the applied edits, in mesh vertices (checked to
/// map back to the file's) with its id, closed flag and kind.
fn last_added(h: &Harness<'static, EditorApp>) -> (u32, Vec<usize>, bool, CurveKind) {
    let base = h.state().document.edit_base.clone().unwrap();
    match h.state().document.applied_edits().last() {
        Some(Edit::AddCurve {
            id,
            vertices,
            closed,
            kind,
        }) => {
            let mesh: Vec<usize> = vertices
                .iter()
                .map(|&f| base.mesh_vertex(f).expect("a file vertex of the mesh"))
                .collect();
            assert_eq!(
                mesh.iter()
                    .map(|&v| base.file_vertex(v))
                    .collect::<Vec<_>>(),
                *vertices
            );
            (*id, mesh, *closed, *kind)
        }
        e => panic!("the last edit is not a curve: {e:?}"),
    }
}

/// Clicks draw an open curve (Enter finishes it) and a closed one (clicking the first vertex
/// closes it), with a live preview; Enter on a single vertex is refused; the selected curve
/// switches to combinatorial, undo and redo restore the states exactly; a click selects
/// a curve and Delete removes it; a stroke and a double click draw curves too; the project
/// saves and reopens with the same curves.
#[test]
fn curves_are_drawn_retyped_deleted_undone_and_saved() {
    let (dir, _mesh_path, mut h) = editor_on_copy("spot.obj");
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    h.get_by_label("Draw curves").click();
    h.run_steps(2);
    assert_eq!(h.state().tool_kind, ToolKind::DrawCurve);
    let base = h.state().document.edit_base.clone().unwrap();
    let mesh = base.mesh().clone();
    let c = h.state().view().rect.center();
    let at = |h: &Harness<'static, EditorApp>, dx: f32, dy: f32| {
        clickable_vertex(h.state(), c + egui::vec2(dx, dy))
    };
    let camera = h.state().camera;

    // an open curve: three clicks, a preview towards the cursor, Enter
    let (a, pa) = at(&h, -110.0, -100.0);
    let (b, pb) = at(&h, -30.0, -120.0);
    let (e, pe) = at(&h, 50.0, -100.0);
    click(&mut h, pa);
    click(&mut h, pb);
    click(&mut h, pe);
    let drawing = h
        .state()
        .tool
        .overlay()
        .expect("the curve in progress is shown");
    assert!(!drawing.thick_lines.is_empty());
    h.hover_at(c + egui::vec2(90.0, -40.0));
    h.run_steps(2);
    let preview = h.state().tool.overlay().expect("a preview");
    assert!(
        !preview.lines.is_empty(),
        "no preview path to the hovered vertex"
    );
    h.get_by_label_contains("Drawing: ");
    assert!(h.state().document.edits.is_empty(), "committed too early");
    h.key_press(egui::Key::Enter);
    h.step();
    let (id0, v0, closed, kind) = last_added(&h);
    assert_eq!((id0, closed, kind), (0, false, CurveKind::Geometric));
    assert_eq!((v0[0], *v0.last().unwrap()), (a, e));
    assert!(v0.contains(&b));
    check_path(&mesh, &v0, false).expect("an edge path");
    // Curve edits are applied in the solve job (they may design the field again).
    settle(&mut h);
    assert_eq!(curves(&h)[&0].vertices, v0);
    assert_eq!(h.state().camera, camera, "clicks orbited the camera");
    settle(&mut h);

    // a closed curve: three clicks, then the first vertex again
    let far = |h: &Harness<'static, EditorApp>, p: egui::Pos2| {
        let cs = curves(h);
        h.state()
            .current_picker()
            .unwrap()
            .pick_curve(&h.state().view(), p, cs.values(), 12.0)
            .is_none()
    };
    let (d, pd) = at(&h, -70.0, 50.0);
    let (f, pf) = at(&h, 30.0, 60.0);
    let (g, pg) = at(&h, -20.0, 130.0);
    assert!(
        far(&h, pd),
        "the closed curve's first click would select curve 0"
    );
    click(&mut h, pd);
    click(&mut h, pf);
    click(&mut h, pg);
    click(&mut h, pd);
    let (id1, v1, closed, _) = last_added(&h);
    assert_eq!((id1, closed), (1, true));
    assert_eq!(v1[0], d);
    assert!(v1.contains(&f) && v1.contains(&g));
    check_path(&mesh, &v1, true).expect("a closed edge path");
    assert_eq!(h.state().tool.selected_curve(), Some(1));
    settle(&mut h);
    h.get_by_label(&format!(
        "Curve 1: geometric, drawn, {} vertices, closed",
        v1.len()
    ));
    settle(&mut h);
    save_render(&mut h, "ui_curves_drawn.png");

    // switch its kind; undo and redo give the states (and the maps) exactly
    let state_before = h.state().document.current_state().cloned().unwrap();
    let uv_before = uvs(&h);
    h.get_by_label("Make combinatorial").click();
    h.step();
    assert_eq!(
        h.state().document.applied_edits().last(),
        Some(&Edit::SetCurveKind {
            id: 1,
            kind: CurveKind::Combinatorial
        })
    );
    settle(&mut h);
    let state_after = h.state().document.current_state().cloned().unwrap();
    assert_eq!(state_after.curves[&1].kind, CurveKind::Combinatorial);
    let uv_after = uvs(&h);
    h.get_by_label_contains("Curve 1: combinatorial");
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.step();
    settle(&mut h);
    assert_eq!(h.state().document.cursor(), 2);
    assert_eq!(
        h.state().document.current_state(),
        Some(&state_before),
        "undo"
    );
    assert!(
        uvs(&h) == uv_before,
        "undo gives the earlier map bit for bit"
    );
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Y);
    h.step();
    settle(&mut h);
    assert_eq!(
        h.state().document.current_state(),
        Some(&state_after),
        "redo"
    );
    assert!(uvs(&h) == uv_after, "redo gives the later map bit for bit");

    // a click on curve 0 selects it; Delete removes it
    let view = h.state().view();
    let picker = h.state().current_picker().unwrap();
    let cs = curves(&h);
    let on_curve = cs[&0]
        .segments()
        .into_iter()
        .filter_map(|(p, q)| {
            let sp = project(&view, mesh.position(p).as_vec3())?;
            let sq = project(&view, mesh.position(q).as_vec3())?;
            Some(sp + (sq - sp) * 0.5)
        })
        .find(|&m| picker.pick_curve(&view, m, cs.values(), 6.0) == Some(0))
        .expect("a visible point on curve 0");
    click(&mut h, on_curve);
    assert_eq!(h.state().tool.selected_curve(), Some(0));
    assert_eq!(h.state().document.edits.len(), 3, "a selecting click drew");
    h.step();
    h.get_by_label(&format!(
        "Curve 0: geometric, drawn, {} vertices, open",
        v0.len()
    ));
    h.key_press(egui::Key::Delete);
    h.step();
    assert_eq!(
        h.state().document.applied_edits().last(),
        Some(&Edit::RemoveCurve { id: 0 })
    );
    settle(&mut h);
    assert_eq!(curves(&h).keys().copied().collect::<Vec<_>>(), vec![1]);
    assert_eq!(h.state().tool.selected_curve(), None);

    // one vertex is no curve: Enter is refused; Esc aborts it
    let (_, ps) = at(&h, -120.0, 0.0);
    click(&mut h, ps);
    h.step();
    h.get_by_label_contains("Drawing: 1 vertices");
    h.key_press(egui::Key::Enter);
    h.step();
    let notice = h.state().notice.clone().expect("the refusal is shown");
    assert!(notice.contains("at least two vertices"), "{notice}");
    assert_eq!(h.state().document.edits.len(), 4);
    h.key_press(egui::Key::Escape);
    h.step();
    assert!(
        h.state()
            .tool
            .overlay()
            .is_none_or(|o| o.thick_lines.is_empty())
    );
    h.key_press(egui::Key::Enter);
    h.step();
    assert_eq!(
        h.state().document.edits.len(),
        4,
        "an aborted curve was committed"
    );

    // a stroke: press on the surface, drag, release
    let (s0, ps0) = at(&h, -120.0, 0.0);
    let (s1, ps1) = at(&h, 60.0, 20.0);
    press(&mut h, ps0, true);
    h.step();
    for i in 1..=8 {
        h.hover_at(ps0 + (ps1 - ps0) * (i as f32 / 8.0));
        h.step();
    }
    assert!(h.state().tool.active());
    press(&mut h, ps1, false);
    h.step();
    assert_eq!(h.state().camera, camera, "the stroke orbited the camera");
    let (id2, v2, closed, _) = last_added(&h);
    assert_eq!((id2, closed), (2, false));
    assert_eq!((v2[0], *v2.last().unwrap()), (s0, s1));
    check_path(&mesh, &v2, false).expect("a stroke snapped to an edge path");
    // The next curve waits for the job that applies this one.
    settle(&mut h);

    // a double click finishes an open curve (two clicks in one frame)
    let (t0, pt0) = at(&h, -100.0, 200.0);
    let (t1, pt1) = at(&h, 0.0, 220.0);
    assert!(far(&h, pt0));
    click(&mut h, pt0);
    h.hover_at(pt1);
    h.step();
    let button = |pressed| egui::Event::PointerButton {
        pos: pt1,
        button: egui::PointerButton::Primary,
        pressed,
        modifiers: egui::Modifiers::NONE,
    };
    h.input_mut()
        .events
        .extend([button(true), button(false), button(true), button(false)]);
    h.run_steps(2);
    let (id3, v3, closed, _) = last_added(&h);
    assert_eq!((id3, closed), (3, false));
    assert_eq!((v3[0], *v3.last().unwrap()), (t0, t1));
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert_eq!(
        h.state().view().rect,
        view.rect,
        "the side panel changed width"
    );

    // save, reopen: the same edits and curves
    let saved_curves = curves(&h);
    assert_eq!(
        saved_curves.keys().copied().collect::<Vec<_>>(),
        vec![1, 2, 3]
    );
    let project_path = dir.path().join("curves.json");
    assert!(h.state_mut().save_project_to(&project_path));
    let saved = Project::load(&project_path).expect("the project reads back");
    assert_eq!(saved.edits, h.state().document.applied_edits());
    let mut h2 = harness_with(&dir.path().join("recent.txt"), Some(project_path), false);
    settle(&mut h2);
    assert!(h2.state().error.is_none(), "{:?}", h2.state().error);
    assert_eq!(
        h2.state().document.applied_edits(),
        h.state().document.applied_edits()
    );
    assert_eq!(curves(&h2), saved_curves);
    h2.get_by_label("3 curves: 3 drawn, 0 sharp features, 0 boundary");
}

/// The feature preview warns when the angle picks the tessellation's facets rather than creases
/// (`constraint::detect::noise_warning`): spot at 20° (226 curves under two grid cells), not at
/// 40°.
#[test]
fn the_feature_preview_warns_below_the_facets_angle() {
    // Solved: the warning measures in grid cells, which the edit base knows.
    let (_dir, mut h) = editor_on("spot.obj", true);
    let warning = "feature curves are shorter than";
    h.state_mut().curves.feature_angle = 20.0;
    h.state_mut().curves.feature_preview = true;
    h.run_steps(2);
    assert!(
        h.query_by_label_contains(warning).is_some(),
        "no warning at 20°"
    );
    h.state_mut().curves.feature_angle = 40.0;
    h.run_steps(2);
    assert!(
        h.query_by_label_contains(warning).is_none(),
        "a warning at 40°"
    );
    assert!(
        h.state().document.edits.is_empty(),
        "the preview is no edit"
    );
}

/// The feature angle previews the sharp edges before anything is applied; *Detect features*
/// turns them into feature curves (undo removes them); *Align to boundary* adds the boundary
/// loops as curves and removes them again.
#[test]
fn sharp_features_are_previewed_and_detected_and_boundaries_aligned() {
    let (_dir, mut h) = editor_on("fandisk.obj", true);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let mesh = h.state().document.mesh.clone().unwrap();
    assert_eq!(h.state().curves.feature_angle, 35.0);
    let expected = feature_edges(&mesh, 35.0);
    assert!(expected.len() > 100, "{} feature edges", expected.len());
    assert!(!h.state().curves.feature_preview);
    h.get_by_label("Preview edges").click();
    h.run_steps(2);
    h.get_by_label(&format!("{} edges", expected.len()));
    save_render(&mut h, "ui_feature_preview.png");
    // a larger angle previews fewer edges
    h.state_mut().curves.feature_angle = 60.0;
    h.run_steps(2);
    let fewer = feature_edges(&mesh, 60.0).len();
    assert!(fewer < expected.len());
    h.get_by_label(&format!("{fewer} edges"));
    h.state_mut().curves.feature_angle = 35.0;
    h.run_steps(2);
    assert!(
        h.state().document.edits.is_empty(),
        "the preview is no edit"
    );

    h.get_by_label("Detect features").click();
    h.step();
    assert_eq!(
        h.state().document.applied_edits(),
        &[Edit::DetectFeatures { angle_deg: 35.0 }]
    );
    settle(&mut h);
    let found = curves(&h);
    assert!(!found.is_empty(), "no feature curves");
    let feature_set: std::collections::HashSet<usize> = expected.iter().copied().collect();
    let mut covered = std::collections::HashSet::new();
    for c in found.values() {
        assert_eq!(c.origin, CurveOrigin::Feature);
        assert_eq!(c.kind, CurveKind::Geometric);
        check_path(&mesh, &c.vertices, c.closed).expect("an edge path");
        for (p, q) in c.segments() {
            let e = mesh.edge(quadcover::constraint::halfedge_between(&mesh, p, q).unwrap());
            assert!(
                feature_set.contains(&e),
                "curve {} leaves the features",
                c.id
            );
            covered.insert(e);
        }
    }
    assert_eq!(covered, feature_set, "every feature edge is on a curve");
    h.step();
    h.get_by_label(&format!(
        "{} curves: 0 drawn, {} sharp features, 0 boundary",
        found.len(),
        found.len()
    ));
    assert!(
        !h.state().curves.feature_preview,
        "the preview stays after applying"
    );
    settle(&mut h);
    save_render(&mut h, "ui_features_detected.png");
    h.state_mut().undo();
    settle(&mut h);
    assert!(curves(&h).is_empty());
    h.state_mut().redo();
    settle(&mut h);
    assert_eq!(curves(&h), found);

    // a mesh with a boundary loop
    let ctx = h.ctx.clone();
    h.state_mut()
        .request(PendingAction::Open(shared_mesh("camelhead.obj")));
    h.run_steps(2);
    if h.state().confirm.is_some() {
        h.get_by_label("Discard").click();
        h.run_steps(2);
    }
    drop(ctx);
    settle(&mut h);
    h.get_by_label("File: camelhead.obj");
    assert!(curves(&h).is_empty());
    h.get_by_label("Align to boundary").click();
    h.step();
    assert_eq!(
        h.state().document.applied_edits(),
        &[Edit::AlignBoundary { on: true }]
    );
    settle(&mut h);
    let boundary = curves(&h);
    assert!(!boundary.is_empty(), "no boundary curves");
    let mesh = h.state().document.mesh.clone().unwrap();
    let mut edges = 0;
    for c in boundary.values() {
        assert_eq!(c.origin, CurveOrigin::Boundary);
        check_path(&mesh, &c.vertices, c.closed).expect("an edge path");
        assert!(c.vertices.iter().all(|&v| mesh.is_boundary_vertex(v)));
        edges += c.segments().len();
    }
    let boundary_edges = (0..mesh.n_edges())
        .filter(|&e| mesh.edge_halfedges(e).1.is_none())
        .count();
    assert_eq!(edges, boundary_edges, "the loop is covered once");
    settle(&mut h);
    save_render(&mut h, "ui_boundary_aligned.png");
    h.get_by_label("Align to boundary").click();
    h.step();
    assert_eq!(
        h.state().document.applied_edits().last(),
        Some(&Edit::AlignBoundary { on: false })
    );
    settle(&mut h);
    assert!(curves(&h).is_empty());
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
}

/// A closed combinatorial curve around a single singularity cannot close as one parameter line
/// (the lattice turns by its index on the way round): the solve reports a contradiction, which is drawn red
/// and shown as the notice while the last good result stays; removing the curve solves again.
#[test]
fn contradictory_curves_are_shown_and_the_last_good_result_stays() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    let uv_before = uvs(&h);
    let edit = {
        let (base, state) = h.state().document.editable().unwrap();
        let mesh = base.mesh();
        let (&p, _) = state
            .singularities
            .iter()
            .find(|(v, _)| {
                mesh.one_ring(**v)
                    .iter()
                    .all(|w| !state.singularities.contains_key(w))
            })
            .expect("an isolated singularity");
        let ring = mesh.one_ring(p);
        check_path(mesh, &ring, true).expect("the link is a closed path");
        Edit::AddCurve {
            id: 0,
            vertices: ring.iter().map(|&v| base.file_vertex(v)).collect(),
            closed: true,
            kind: CurveKind::Combinatorial,
        }
    };
    h.state_mut().commit_edit(edit);
    assert!(
        h.state().document.current_state().is_none(),
        "a curve edit was applied on the UI thread (it may design the field: the job does it)"
    );
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let error = h
        .state()
        .document
        .solve_error
        .clone()
        .expect("the solve reports the contradiction");
    assert_eq!(h.state().document.contradiction, vec![0]);
    assert_eq!(h.state().notice.as_deref(), Some(error.as_str()));
    assert!(uvs(&h) == uv_before, "the last good map stays");
    h.get_by_label_contains("Contradictory curves (red)");
    save_render(&mut h, "ui_contradiction.png");
    h.state_mut().commit_edit(Edit::RemoveCurve { id: 0 });
    settle(&mut h);
    assert!(h.state().document.solve_error.is_none());
    assert!(h.state().document.contradiction.is_empty());
}

/// The editor's side of a contradiction, whatever the core finds: a solve outcome that reports
/// one (injected as the solve job's result) is a failed solve; the curves it names are drawn
/// red, its message is the notice, the last good result stays; undo shows the remembered solve
/// and the contradiction is gone.
#[test]
fn a_contradiction_outcome_is_a_failed_solve_with_red_curves() {
    use quadcover::app::curves::{CONTRADICTION_COLOR, GEOMETRIC_COLOR};
    use quadcover::app::document::SolveOutcome;
    use quadcover::app::jobs::{Job, JobOutput};
    let (_dir, mut h) = editor_on("spot.obj", true);
    let edit = {
        let (base, _) = h.state().document.editable().unwrap();
        let path = quadcover::constraint::shortest_edge_path(base.mesh(), 0, 40).unwrap();
        Edit::AddCurve {
            id: 0,
            vertices: path.iter().map(|&v| base.file_vertex(v)).collect(),
            closed: false,
            kind: CurveKind::Geometric,
        }
    };
    h.state_mut().commit_edit(edit);
    settle(&mut h);
    let uv = uvs(&h);
    let solve_info = h.state().document.solve_info.clone().unwrap().revision;
    let overlay = h.state_mut().curves_overlay().expect("the curve is drawn");
    assert!(
        overlay
            .thick_lines
            .iter()
            .all(|l| l.color == GEOMETRIC_COLOR)
    );

    // the solve job of the current revision reports a contradiction of curve 0
    let message = "curve 0 cannot be a parameter line".to_string();
    let doc = &h.state().document;
    let outcome = SolveOutcome {
        revision: doc.edit_revision(),
        base: None,
        first: doc.cursor(),
        states: Vec::new(),
        skipped: Vec::new(),
        solved: Err(message.clone()),
        contradiction: vec![0],
    };
    let job = Job::spawn("Re-solving", None, move |_| {
        Ok(JobOutput::Solved(Box::new(outcome)))
    })
    .for_generation(doc.generation())
    .for_revision(doc.edit_revision());
    h.state_mut().jobs.push(job);
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert_eq!(
        h.state().document.solve_error.as_deref(),
        Some(message.as_str())
    );
    assert_eq!(h.state().document.contradiction, vec![0]);
    assert_eq!(h.state().notice.as_deref(), Some(message.as_str()));
    assert!(uvs(&h) == uv, "the last good map stays");
    assert_eq!(
        h.state().document.solve_info.clone().unwrap().revision,
        solve_info
    );
    let red = h.state_mut().curves_overlay().unwrap();
    assert!(!red.thick_lines.is_empty());
    assert!(
        red.thick_lines
            .iter()
            .all(|l| l.color == CONTRADICTION_COLOR)
    );
    h.get_by_label_contains("Contradictory curves (red): curve 0 cannot");
    h.get_by_label_contains("The last solve failed (the previous result is shown)");
    save_render(&mut h, "ui_contradiction_injected.png");

    // undo: the remembered solve of the state before, no contradiction
    h.state_mut().undo();
    settle(&mut h);
    assert!(h.state().document.contradiction.is_empty());
    assert!(h.state().document.solve_error.is_none());
    assert!(
        h.state_mut().curves_overlay().is_none(),
        "no curves left to draw"
    );
}

// ---- folds: the overlay and the injectivity repair setting ------------------------------------

/// The panel's count of folded faces.
fn folded_count(n: usize) -> String {
    match n {
        0 => "No folded faces".to_string(),
        1 => "1 folded face".to_string(),
        n => format!("{n} folded faces"),
    }
}

/// The end of the *Folds* line for `n` mis-wound vertices (`Parameterization::miswound`).
fn wound_suffix(n: usize) -> String {
    match n {
        0 => String::new(),
        1 => "; 1 mis-wound vertex".to_string(),
        n => format!("; {n} mis-wound vertices"),
    }
}

/// Thick overlay lines the *Folds* overlay draws for the document's folds: three per face,
/// folded or around a mis-wound vertex.
fn shown_lines(h: &Harness<'_, EditorApp>) -> usize {
    let doc = &h.state().document;
    let (mesh, folds) = (doc.mesh.as_ref().unwrap(), doc.folds.as_ref().unwrap());
    3 * folds.shown_faces(mesh).len()
}

/// Pixels of the fold overlay's colour ([`FOLD_COLOR`], sRGB-encoded in the render).
fn fold_pixels(img: &image::RgbaImage) -> usize {
    img.pixels()
        .filter(|p| p[0] > 220 && p[1] < 40 && (100..=175).contains(&p[2]))
        .count()
}

/// The *Folds* toggle: the count of the map shown (with the repair's before count) in the
/// panel, the faces of [`quadcover::param::folded_faces`] outlined in the viewport; a new map
/// with folds (injected: mirrored texture triangles) shows its count and is drawn.
#[test]
fn the_folds_overlay_counts_and_draws_the_folded_faces() {
    use quadcover::app::folds::FOLD_COLOR;
    use quadcover::param::folded_faces;
    let (_dir, mut h) = editor_on("spot.obj", true);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(!h.state().document.display.show_folds, "off by default");
    assert!(h.query_by_label_contains("folded face").is_none());
    assert!(h.state_mut().folds_overlay().is_none());

    let p = h.state().document.parameterization.clone().unwrap();
    let folded = folded_faces(&p.uv);
    assert_eq!(
        folded.len(),
        p.flipped_faces,
        "the core counts the same folds"
    );
    let before = p.flipped_faces_before_repair;
    h.get_by_label("Folds").click();
    h.run_steps(2);
    assert!(h.state().document.display.show_folds);
    let wound = p.miswound.len();
    h.get_by_label(&match before {
        0 => format!("{}{}", folded_count(folded.len()), wound_suffix(wound)),
        b => format!(
            "{} ({b} before repair){}",
            folded_count(folded.len()),
            wound_suffix(wound)
        ),
    });
    let lines = shown_lines(&h);
    assert!(lines >= 3 * folded.len());
    assert_eq!(
        h.state_mut().folds_overlay().map(|o| o.thick_lines.len()),
        (lines > 0).then_some(lines)
    );

    // a map with folds: every 9th face's texture triangle mirrored
    let mut q = p.clone();
    let mut mirrored = Vec::new();
    for f in (0..q.uv.len() / 3).step_by(9) {
        if !folded.contains(&f) {
            q.uv.swap(3 * f + 1, 3 * f + 2);
            mirrored.push(f);
        }
    }
    let expected: Vec<usize> = {
        let mut e: Vec<usize> = folded.iter().copied().chain(mirrored).collect();
        e.sort_unstable();
        e
    };
    assert!(expected.len() > 100, "{} folds", expected.len());
    q.flipped_faces = expected.len();
    q.flipped_faces_before_repair = expected.len() + 5;
    h.state_mut().document.set_parameterization(q, true);
    h.run_steps(2);
    let folds = h
        .state()
        .document
        .folds
        .clone()
        .expect("the folds of the map");
    assert_eq!(folds.faces, expected);
    h.get_by_label(&format!(
        "{} folded faces ({} before repair){}",
        expected.len(),
        expected.len() + 5,
        wound_suffix(wound)
    ));
    h.get_by_label_contains(&format!(
        "{} flipped faces ({} before repair, repair",
        expected.len(),
        expected.len() + 5
    ));
    let lines = shown_lines(&h);
    let overlay = h.state_mut().folds_overlay().expect("the folds are drawn");
    assert_eq!(overlay.thick_lines.len(), lines);
    assert!(lines >= 3 * expected.len());
    assert!(overlay.thick_lines.iter().all(|l| l.color == FOLD_COLOR));
    // built once per result: the next frames reuse it
    h.run_steps(2);
    let again = h.state_mut().folds_overlay().unwrap();
    assert!(Arc::ptr_eq(&overlay, &again));
    if gpu_available() {
        let on = fold_pixels(&h.render().expect("render"));
        save_render(&mut h, "ui_folds.png");
        h.get_by_label("Folds").click();
        h.run_steps(2);
        assert!(h.query_by_label_contains("folded face").is_none());
        assert!(h.state_mut().folds_overlay().is_none());
        let off = fold_pixels(&h.render().expect("render"));
        assert!(on > 200 && off < on / 20, "fold pixels: {on} on, {off} off");
    }
}

/// *Curvature smoothing* is the solve setting `curvature_smoothing` (until 2026-12-07 only a
/// project or `--curvature-smoothing` could set it): dragging its slider to the right end
/// raises the draft, and applying re-solves with it.
#[test]
fn curvature_smoothing_is_a_slider_of_the_solve_settings() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert_eq!(h.state().document.settings.curvature_smoothing, 5);
    let rail = h
        .get_by_role_and_label(egui::accesskit::Role::Slider, "Curvature smoothing")
        .rect();
    let (from, to) = (rail.center(), rail.right_center() + egui::vec2(40.0, 0.0));
    press(&mut h, from, true);
    h.step();
    for i in 1..=6 {
        h.hover_at(from + (to - from) * (i as f32 / 6.0));
        h.step();
    }
    press(&mut h, to, false);
    h.run_steps(2);
    let dragged = h.state().settings_draft.curvature_smoothing;
    assert_eq!(
        dragged,
        quadcover::edit::project::MAX_CURVATURE_SMOOTHING,
        "the draft after the drag"
    );
    h.get_by_label("Apply settings").click();
    h.step();
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let base = h.state().document.edit_base.clone().unwrap();
    assert_eq!(base.settings().curvature_smoothing, dragged);
    assert!(h.state().document.solve_current());
}

/// *Untangle folds* is `!no_untangle` of the solve settings: unchecking it and applying re-solves
/// without the repair (the folds are the global step's and the summary says so); checking it
/// again repairs them, and the summary gives the count before the repair and its time.
#[test]
fn untangle_folds_is_a_solve_setting() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(!h.state().document.settings.no_untangle);
    let revision = h.state().document.edit_revision();

    h.get_by_label("Untangle folds").click();
    h.run_steps(2);
    assert!(h.state().settings_draft.no_untangle);
    assert!(!h.state().document.settings.no_untangle, "not applied yet");
    h.get_by_label("Settings changed: apply to recompute");
    h.get_by_label("Apply settings").click();
    h.step();
    assert!(h.state().document.settings.no_untangle);
    assert!(h.state().document.edit_revision() > revision);
    assert!(
        h.state().jobs.iter().any(|j| j.revision.is_some()),
        "a solve runs"
    );
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(h.state().document.solve_current());
    let base = h.state().document.edit_base.clone().unwrap();
    assert!(base.settings().no_untangle);
    let p = h.state().document.parameterization.clone().unwrap();
    assert_eq!(p.flipped_faces, p.flipped_faces_before_repair, "no repair");
    assert_eq!(p.timings.repair_ms, 0.0);
    let unrepaired = p.flipped_faces;
    let folds = h.state().document.folds.clone().unwrap();
    assert_eq!(folds.faces.len(), unrepaired);
    h.get_by_label_contains(&format!("{unrepaired} flipped faces (untangling off)"));
    h.get_by_label("Folds").click();
    h.run_steps(2);
    h.get_by_label(&format!(
        "{} (untangling off){}",
        folded_count(unrepaired),
        wound_suffix(p.miswound.len())
    ));
    let lines = shown_lines(&h);
    assert!(lines >= 3 * unrepaired);
    assert_eq!(
        h.state_mut().folds_overlay().map(|o| o.thick_lines.len()),
        (lines > 0).then_some(lines)
    );
    save_render(&mut h, "ui_folds_unrepaired.png");

    // on again: the same global step, repaired
    h.get_by_label("Untangle folds").click();
    h.run_steps(2);
    assert!(!h.state().settings_draft.no_untangle);
    h.get_by_label("Apply settings").click();
    h.step();
    assert!(!h.state().document.settings.no_untangle);
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(
        !h.state()
            .document
            .edit_base
            .as_ref()
            .unwrap()
            .settings()
            .no_untangle
    );
    let p = h.state().document.parameterization.clone().unwrap();
    assert_eq!(p.flipped_faces_before_repair, unrepaired);
    assert!(p.flipped_faces <= unrepaired);
    let folds = h.state().document.folds.clone().unwrap();
    assert_eq!(folds.faces.len(), p.flipped_faces);
    assert!(!h.state().document.param_summary.contains("untangling off"));
    if unrepaired > 0 {
        h.get_by_label_contains(&format!(
            "{} flipped faces ({unrepaired} before repair, repair",
            p.flipped_faces
        ));
        h.get_by_label(&format!(
            "{} ({unrepaired} before repair){}",
            folded_count(p.flipped_faces),
            wound_suffix(p.miswound.len())
        ));
    } else {
        eprintln!("spot's global step left no folds: the repair had nothing to do");
    }
}

// ---- the remesh: background extraction, display modes, quality window -------------------------

use quadcover::app::jobs::{Job, JobOutput};
use quadcover::app::quality_panel::{ANGLE_PLOT, LENGTH_PLOT, QUALITY_WINDOW, plot_id};
use quadcover::app::remesh::{
    EDGE_COLOR, FEWER_COLOR, MORE_COLOR, RemeshRequest, RemeshResult, RemeshView, sides_name,
};
use quadcover::app::settings::RemeshDisplay;
use quadcover::extract::{ExtractOptions, RemeshQuality, remesh_report};

/// What the core extracts from the document's parameterization (the editor must show this).
fn core_remesh(h: &Harness<'static, EditorApp>) -> (quadcover::extract::Remesh, RemeshQuality) {
    let doc = &h.state().document;
    let mesh = doc.mesh.clone().expect("a mesh");
    let p = doc.parameterization.as_ref().expect("a parameterization");
    remesh_report(&mesh, &p.uv, p.symmetry as u8, &ExtractOptions::default())
        .expect("the core extracts the map")
}

fn shown_remesh(h: &Harness<'static, EditorApp>) -> Arc<RemeshView> {
    h.state()
        .document
        .remesh
        .clone()
        .expect("the remesh of the map shown")
}

/// Chooses a remesh display mode in the side panel's combo box.
fn choose_remesh_display(h: &mut Harness<'static, EditorApp>, mode: RemeshDisplay) {
    h.get_by_label("Remesh").click();
    h.run_steps(2);
    h.get_by_label(mode.label()).click();
    h.run_steps(2);
    assert_eq!(h.state().document.display.remesh, mode);
}

/// After the solve the remesh is extracted in the background: the side panel sums it up, the
/// quality window (closed until asked) shows the numbers the core gives for the same map, and
/// both histograms; after the next solve (an edit) it is the new map's, and undo and redo show
/// the remembered remeshes at once.
#[test]
fn the_remesh_is_extracted_after_every_solve_and_its_quality_shown() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    let (_, q) = core_remesh(&h);
    let view = shown_remesh(&h);
    assert_eq!(view.quality.faces, q.faces);
    assert_eq!(view.quality.vertices, q.vertices);
    assert_eq!(view.quality.faces_by_sides, q.faces_by_sides);
    assert_eq!(view.quality.irregular_vertices, q.irregular_vertices);
    assert_eq!(view.irregular.len(), q.irregular_vertices);
    let input_faces = h.state().document.stats.as_ref().unwrap().faces;
    assert!(
        q.faces > 1000 && q.faces != input_faces,
        "{} remesh faces",
        q.faces
    );
    assert!(h.state().document.remesh_error.is_none());
    assert!(
        !h.state().jobs.iter().any(|j| j.param_revision.is_some()),
        "the extraction ran as a job and ended"
    );

    // the side panel: the display mode (off by default) and the summary
    assert_eq!(h.state().document.display.remesh, RemeshDisplay::Off);
    h.get_by_label("Remesh");
    h.get_by_label(&format!(
        "{} faces ({} quads), {} irregular vertices",
        q.faces, q.faces_by_sides[&4], q.irregular_vertices
    ));

    // the quality window
    assert!(h.query_by_label(QUALITY_WINDOW).is_none());
    h.get_by_label("Quality").click();
    h.run_steps(3);
    h.get_by_label(QUALITY_WINDOW);
    h.get_by_label(&format!("Faces: {}", q.faces));
    h.get_by_label(&format!("Vertices: {}", q.vertices));
    h.get_by_label(&format!(
        "Irregular vertices: {} (interior valence != 4)",
        q.irregular_vertices
    ));
    h.get_by_label(&format!("RSD edge: {:.2} %", 100.0 * q.rsd_edge));
    h.get_by_label(&format!("RSD angle: {:.2} %", 100.0 * q.rsd_angle));
    h.get_by_label(&format!("Patched places: {}", q.patched_places));
    let mut by_sides: Vec<(usize, usize)> =
        q.faces_by_sides.iter().map(|(&s, &c)| (s, c)).collect();
    by_sides.sort_by_key(|&(s, c)| (std::cmp::Reverse(c), s));
    let by_sides: Vec<String> = by_sides
        .into_iter()
        .map(|(s, c)| sides_name(s, c))
        .collect();
    h.get_by_label(&format!("By sides: {}", by_sides.join(", ")));
    h.get_by_label_contains(&format!("Mean distance: {:.2e}", q.mean_distance));
    // the histograms: both plots, the ideal angle marked (a legend entry), bounds over 0..180°
    h.get_by_label(ANGLE_PLOT);
    h.get_by_label(LENGTH_PLOT);
    h.get_by_label("ideal 90°");
    let memory = egui_plot::PlotMemory::load(&h.ctx, plot_id(ANGLE_PLOT)).expect("plot shown");
    assert!(memory.bounds().min()[0] <= 0.0 && memory.bounds().max()[0] >= 180.0);
    let corners: usize = q.faces_by_sides.iter().map(|(s, c)| s * c).sum();
    assert_eq!(
        view.angles.total(),
        corners,
        "every corner in the histogram"
    );
    save_render(&mut h, "ui_remesh_quality.png");

    // the next solve: the new map's remesh, in the panel too
    let edit = move_to_free_neighbour(&h);
    h.state_mut().commit_edit(edit);
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let (_, q2) = core_remesh(&h);
    let view2 = shown_remesh(&h);
    assert!(!Arc::ptr_eq(&view, &view2), "extracted again");
    assert_eq!(view2.quality.faces, q2.faces);
    assert_eq!(view2.quality.irregular_vertices, q2.irregular_vertices);
    h.get_by_label(&format!("Faces: {}", q2.faces));
    // closing the window
    h.get_by_label("View").click();
    h.run_steps(2);
    h.get_by_label("Remesh quality window").click();
    h.run_steps(2);
    assert!(!h.state().remesh.show_quality);
    assert!(h.query_by_label(&format!("Faces: {}", q2.faces)).is_none());
    // undo: the remembered solve with its remesh at once, no extraction
    h.state_mut().undo();
    assert!(!h.state().busy(), "undo started a job");
    assert!(Arc::ptr_eq(&shown_remesh(&h), &view));
    h.state_mut().redo();
    assert!(!h.state().busy(), "redo started a job");
    assert!(Arc::ptr_eq(&shown_remesh(&h), &view2));
}

/// Pixels of the remesh edges' colour ([`EDGE_COLOR`], sRGB-encoded about (39, 56, 196)).
fn remesh_blue_pixels(img: &image::RgbaImage) -> usize {
    img.pixels()
        .filter(|p| p[2] > 150 && p[0] < 90 && p[1] < 110 && p[2] as i32 - p[1] as i32 > 90)
        .count()
}

fn differing_pixels(a: &image::RgbaImage, b: &image::RgbaImage) -> usize {
    a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
}

/// Off draws nothing of the remesh; *Edges over surface* draws each of its edges once (and
/// its irregular vertices as dots) over the surface; *Remesh only* draws its polygons instead
/// of the surface; off again gives the first picture back.
#[test]
fn the_remesh_display_mode_changes_what_is_drawn() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    let view = shown_remesh(&h);
    let edges = quadcover::extract::edge_lengths(&view.remesh).len();
    assert!(h.state().remesh_overlay().is_none());
    assert!(h.state().remesh_surface().is_none());
    let off = gpu_available().then(|| h.render().expect("render"));

    choose_remesh_display(&mut h, RemeshDisplay::Edges);
    let overlay = h.state().remesh_overlay().expect("the remesh is drawn");
    assert_eq!(overlay.fine_lines.len(), edges, "each edge once");
    assert!(overlay.fine_lines.iter().all(|l| l.color == EDGE_COLOR));
    assert_eq!(overlay.dots.len(), view.quality.irregular_vertices);
    assert_eq!(
        overlay
            .dots
            .iter()
            .filter(|d| d.color == FEWER_COLOR)
            .count(),
        view.fewer
    );
    assert!(
        overlay
            .dots
            .iter()
            .all(|d| d.color == FEWER_COLOR || d.color == MORE_COLOR)
    );
    assert!(
        h.state().remesh_surface().is_none(),
        "the surface is the input's"
    );
    h.get_by_label_contains(&format!("{} with < 4 edges", view.fewer));
    let edges_img = gpu_available().then(|| h.render().expect("render"));
    save_render(&mut h, "ui_remesh_edges.png");

    choose_remesh_display(&mut h, RemeshDisplay::Only);
    assert!(
        h.state().remesh_overlay().is_some(),
        "its edges are drawn too"
    );
    let (key, surface) = h.state().remesh_surface().expect("the polygons are drawn");
    assert_eq!(key, view.id);
    let fan: usize = view.remesh.faces.iter().map(|f| f.len() - 2).sum();
    assert_eq!(surface.n_faces(), fan);
    let only = gpu_available().then(|| h.render().expect("render"));
    save_render(&mut h, "ui_remesh_only.png");

    choose_remesh_display(&mut h, RemeshDisplay::Off);
    assert!(h.state().remesh_overlay().is_none());
    assert!(h.state().remesh_surface().is_none());
    if let (Some(off), Some(edges_img), Some(only)) = (off, edges_img, only) {
        let off_again = h.render().expect("render");
        let (blue_off, blue_on) = (remesh_blue_pixels(&off), remesh_blue_pixels(&edges_img));
        assert!(
            blue_on > blue_off + 2000,
            "remesh edge pixels: {blue_off} off, {blue_on} on"
        );
        let changed = differing_pixels(&edges_img, &only);
        assert!(changed > 5000, "remesh only changed {changed} pixels");
        let back = differing_pixels(&off, &off_again);
        assert!(back < 200, "off again differs in {back} pixels");
    }
}

/// Results for another parameterization (an older revision) are dropped; a failed extraction
/// keeps the last good remesh and says why in the status line and the panel; an extraction for a
/// replaced map is flagged cancelled and the newest map's remesh is the one shown.
#[test]
fn stale_remesh_results_are_dropped_and_failures_keep_the_last_good_one() {
    let (_dir, mut h) = editor_on("spot.obj", true);
    let view = shown_remesh(&h);
    let (generation, revision) = {
        let doc = &h.state().document;
        (doc.generation(), doc.param_revision())
    };
    // an extraction of an older revision, as a job's result: dropped
    let mut stale = RemeshRequest::for_document(&h.state().document).unwrap();
    stale
        .uv
        .iter_mut()
        .for_each(|uv| *uv = [2.0 * uv[0], 2.0 * uv[1]]);
    stale.param_revision = revision - 1;
    h.state_mut().jobs.push(
        Job::spawn("Extracting the remesh", None, move |_| {
            Ok(JobOutput::Remeshed(Box::new(stale.run(&|| false))))
        })
        .for_generation(generation)
        .for_param(revision - 1),
    );
    settle(&mut h);
    assert!(
        Arc::ptr_eq(&shown_remesh(&h), &view),
        "the stale result was taken"
    );
    assert!(h.state().document.remesh_error.is_none());
    // and through the document: refused
    let refused = RemeshResult {
        generation,
        param_revision: revision + 7,
        outcome: Err("stale".into()),
    };
    assert!(!h.state_mut().document.take_remesh(refused));

    // a failed extraction of the current map (injected): the last good remesh stays
    h.state_mut().jobs.push(
        Job::spawn("Extracting the remesh", None, move |_| {
            Ok(JobOutput::Remeshed(Box::new(RemeshResult {
                generation,
                param_revision: revision,
                outcome: Err("injected failure".into()),
            })))
        })
        .for_generation(generation)
        .for_param(revision),
    );
    settle(&mut h);
    assert!(Arc::ptr_eq(&shown_remesh(&h), &view));
    assert_eq!(
        h.state().document.remesh_error.as_deref(),
        Some("injected failure")
    );
    assert_eq!(
        h.state().status,
        "Remesh extraction failed (the last good remesh is shown): injected failure"
    );
    h.get_by_label("Remesh extraction failed: injected failure");

    // a real failure: a map that is not seamless (every 9th texture triangle mirrored)
    let p = h.state().document.parameterization.clone().unwrap();
    let mut broken = p.clone();
    for f in (0..broken.uv.len() / 3).step_by(9) {
        broken.uv.swap(3 * f + 1, 3 * f + 2);
    }
    h.state_mut().document.set_parameterization(broken, true);
    settle(&mut h);
    let error = h.state().document.remesh_error.clone().expect("it failed");
    assert!(error.contains("not seamless"), "{error}");
    assert!(
        Arc::ptr_eq(&shown_remesh(&h), &view),
        "the last good remesh stays"
    );
    assert!(
        h.state().status.contains("not seamless"),
        "{}",
        h.state().status
    );

    // two maps in a row: the first one's extraction is flagged cancelled when the second
    // arrives, and the second's remesh (the first map moved by a lattice vector: the same mesh)
    // is extracted after it and shown
    let map = |f: &dyn Fn([f64; 2]) -> [f64; 2]| {
        let mut q = p.clone();
        q.uv.iter_mut().for_each(|uv| *uv = f(*uv));
        q
    };
    let doubled = map(&|uv| [2.0 * uv[0], 2.0 * uv[1]]);
    let shifted = map(&|uv| [uv[0] + 1.0, uv[1]]);
    h.state_mut().document.set_parameterization(doubled, true);
    h.step();
    let extractions = |h: &Harness<'static, EditorApp>| -> Vec<(u64, bool)> {
        h.state()
            .jobs
            .iter()
            .filter_map(|j| Some((j.param_revision?, j.cancelled())))
            .collect()
    };
    let doubled_revision = h.state().document.param_revision();
    assert_eq!(extractions(&h), vec![(doubled_revision, false)]);
    h.state_mut().document.set_parameterization(shifted, true);
    h.step();
    let running = extractions(&h);
    assert!(
        running == vec![(doubled_revision, true)]
            || running.is_empty()
            || running[0].0 > doubled_revision,
        "one extraction at a time, the replaced one cancelled: {running:?}"
    );
    settle(&mut h);
    let last = shown_remesh(&h);
    assert!(h.state().document.remesh_error.is_none());
    assert_eq!(
        last.quality.faces, view.quality.faces,
        "the newest map's remesh"
    );
    assert!(!Arc::ptr_eq(&last, &view), "extracted again");
    // back to the first map: its remesh is remembered, no extraction
    h.state_mut().document.set_parameterization(p.clone(), true);
    assert!(!h.state().busy());
    assert!(Arc::ptr_eq(&shown_remesh(&h), &view));
}

/// *Renormalize field* is `renormalize_field` of the solve settings: checking it and applying
/// recomputes the field renormalized (a lower smoothing energy on spot) and the map, and the
/// project written afterwards carries the setting.
#[test]
fn renormalize_field_is_a_solve_setting() {
    let (dir, _mesh, mut h) = editor_on_copy("spot.obj");
    assert!(!h.state().document.settings.renormalize_field);
    let before = {
        let (base, state) = h.state().document.editable().unwrap();
        base.field_of(state).e_smooth
    };
    h.get_by_label("Renormalize field").click();
    h.run_steps(2);
    assert!(h.state().settings_draft.renormalize_field);
    h.get_by_label("Apply settings").click();
    h.step();
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    assert!(h.state().document.solve_current());
    let (base, state) = h.state().document.editable().unwrap();
    assert!(base.settings().renormalize_field);
    let after = base.field_of(state).e_smooth;
    assert!(after < before, "E_smooth {before} → {after}");
    let p = h.state().document.parameterization.clone().unwrap();
    assert_eq!(p.flipped_faces, 0);
    let project = h
        .state()
        .document
        .project_for(&dir.path().join("p.json"))
        .unwrap();
    assert!(
        project.to_json().contains("\"renormalize_field\": true"),
        "{}",
        project.to_json()
    );
}

/// The editor opened on `mesh`, written as `part.obj` into `dir`, with the load settled.
fn open_part(dir: &Path, mesh: &quadcover::mesh::TriMesh) -> Harness<'static, EditorApp> {
    let path = dir.join("part.obj");
    quadcover::io::write_obj(
        &path,
        &quadcover::io::ObjOutput::new(mesh.positions(), mesh.faces()),
    )
    .expect("write the part");
    let mut h = harness_with(&dir.join("recent.txt"), Some(path), false);
    settle(&mut h);
    h.get_by_label("File: part.obj");
    h
}

/// File ▸ Remesh input on the open `part.obj`: the copy is written and opened without an error.
fn remesh_input(h: &mut Harness<'static, EditorApp>) {
    h.get_by_label("File").click();
    h.run_steps(2);
    h.get_by_label("Remesh input").click();
    h.run_steps(2);
    settle(h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    h.get_by_label("File: part-remeshed.obj");
}

/// A raw CAD tessellation (needles, fanned caps) is flagged on load; File ▸ Remesh input writes
/// an isotropic copy beside it and opens it, and the copy maps without a fold.
#[test]
fn a_raw_tessellation_is_flagged_and_remeshed_from_the_file_menu() {
    let dir = tempfile::tempdir().expect("tempdir");
    let raw = quadcover::mesh::generate::raw_cylinder(0.5, 1.2, 48);
    let mut h = open_part(dir.path(), &raw);
    h.get_by_label_contains("needle triangles");

    remesh_input(&mut h);
    let written = dir.path().join("part-remeshed.obj");
    assert!(written.exists());
    let mesh = h.state().document.mesh.clone().expect("a mesh");
    assert!(mesh.n_vertices() > 10_000, "{} vertices", mesh.n_vertices());
    assert!(!quadcover::mesh::isotropic::needs_remesh(&mesh));
    assert!(
        h.query_by_label_contains("needle triangles").is_none(),
        "the copy is not flagged"
    );
    assert_eq!(mesh.euler_characteristic(), raw.euler_characteristic());
}

/// A round face tessellated as a fan (a capped cylinder with 96 triangles round each cap's
/// centre) is flagged on load: the field's pole there cannot split. The remeshed copy is not.
#[test]
fn fan_centres_are_flagged_on_load() {
    let dir = tempfile::tempdir().expect("tempdir");
    let part = quadcover::mesh::generate::capped_cylinder(1.0, 2.0, 96, 40, 16);
    let mut h = open_part(dir.path(), &part);
    h.get_by_label_contains("2 vertices are centres of flat fans");
    assert!(h.query_by_label_contains("needle triangles").is_none());
    remesh_input(&mut h);
    assert!(
        h.query_by_label_contains("centres of flat fans").is_none(),
        "the copy is not flagged"
    );
}

/// Folds left under curves name the curves beside them in the *Folds* line: fandisk with its
/// features detected, a map injected with one face beside a curve mirrored (and one far from
/// every curve, which names none).
#[test]
fn the_folds_line_names_the_curves_beside_the_folds() {
    let (_dir, mut h) = editor_on("fandisk.obj", true);
    h.get_by_label("Detect features").click();
    h.step();
    settle(&mut h);
    assert!(h.state().error.is_none(), "{:?}", h.state().error);
    let mesh = h.state().document.mesh.clone().unwrap();
    let found = curves(&h);
    let (&id, curve) = found.iter().next().expect("feature curves");
    let v = curve.vertices[curve.vertices.len() / 2];
    let f = mesh.face_of(mesh.outgoing(v).next().unwrap());
    let p = h.state().document.parameterization.clone().unwrap();
    assert_eq!(
        p.flipped_faces, 0,
        "fandisk's map under its features is fold-free"
    );
    let mut q = p.clone();
    q.uv.swap(3 * f + 1, 3 * f + 2);
    q.flipped_faces = 1;
    h.state_mut().document.set_parameterization(q, true);
    h.get_by_label("Folds").click();
    h.run_steps(2);
    let beside = quadcover::constraint::curves_beside(&mesh, found.values(), &[f], 2);
    assert!(beside.contains(&id), "{beside:?}");
    let folds = h.state().document.folds.clone().unwrap();
    assert_eq!(folds.beside_curves, beside);
    let before = match p.flipped_faces_before_repair {
        0 => String::new(),
        b => format!(" ({b} before repair)"),
    };
    h.get_by_label(&format!(
        "1 folded face{before}, beside {}{}",
        quadcover::constraint::curves_named(&beside),
        wound_suffix(p.miswound.len())
    ));
    // Those curves are drawn thick in the folds' colour, one segment per edge of each, while
    // the Folds overlay is on; off, in their kind's style again.
    use quadcover::app::folds::FOLD_COLOR;
    let edges: usize = beside.iter().map(|i| found[i].segments().len()).sum();
    let magenta = |h: &mut Harness<'static, EditorApp>| {
        h.state_mut()
            .curves_overlay()
            .unwrap()
            .thick_lines
            .iter()
            .filter(|l| l.color == FOLD_COLOR)
            .count()
    };
    assert_eq!(magenta(&mut h), edges);
    h.get_by_label("Folds").click();
    h.run_steps(2);
    assert_eq!(magenta(&mut h), 0);
}
