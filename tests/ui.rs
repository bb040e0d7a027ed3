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
    let builder = Harness::builder().with_size(egui::vec2(1100.0, 720.0));
    let builder = if gpu_available() {
        builder.wgpu()
    } else {
        builder
    };
    builder.build_eframe(move |cc| EditorApp::new(cc, opts))
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
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(
        &dir.path().join("recent.txt"),
        Some(shared_mesh("kitten.obj")),
    );
    settle(&mut h);

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
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(
        &dir.path().join("recent.txt"),
        Some(shared_mesh("kitten.obj")),
    );
    settle(&mut h);

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
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness(
        &dir.path().join("recent.txt"),
        Some(shared_mesh("kitten.obj")),
    );
    settle(&mut h);
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
