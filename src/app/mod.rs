//! The desktop editor (eframe + wgpu). Everything GPU/GUI lives here; the core
//! knows nothing about it.
//!
//! - [`document::Document`]: the one state type (mesh, load report, settings, the edit list
//!   with its undo cursor, the core's base and cached states, the solved field and
//!   parameterization shown, overlays, display settings, project path and saved marker).
//! - [`jobs::Job`]: background work on its own thread, results via a channel.
//! - [`folds`]: the overlay of the folded faces of the map shown.
//! - [`remesh`]: the remesh of the map shown, extracted in the background after every solve,
//!   drawn over (or instead of) the surface; [`quality_panel`]: its quality window.
//! - [`picking`]: camera rays and BVH ray casts, for every tool; [`tools`]: the viewport's
//!   interaction modes (one file per tool), which hand one edit to the document per gesture.
//! - [`editor`] wires the menus ([`menus`]), the side panel ([`panels`], with the tools and
//!   curves sections of [`curves`]), the viewport ([`view_ui`]), the file actions ([`files`]),
//!   the edit pipeline ([`edits`]) and the individual stages ([`stages`]).
//! - [`render::Renderer`]: the wgpu renderer, shared by the viewport
//!   ([`viewport`]) and offscreen rendering ([`render::Offscreen`]).

pub mod camera;
pub mod curves;
pub mod document;
pub mod editor;
mod edits;
pub mod files;
pub mod folds;
pub mod jobs;
mod menus;
mod panels;
pub mod picking;
pub mod quality_panel;
pub mod remesh;
pub mod render;
pub mod scene;
pub mod settings;
mod stages;
pub mod tools;
mod view_ui;
pub mod viewport;

pub use editor::{EditorApp, EditorOptions};

/// Opens the editor window. With `None` it shows the embedded default mesh (Spot); a `.json`
/// path opens a project.
pub fn run_editor(path: Option<std::path::PathBuf>) -> eframe::Result<()> {
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("quadcover")
            .with_inner_size([1280.0, 800.0])
            .with_drag_and_drop(true),
        ..Default::default()
    };
    eframe::run_native(
        "quadcover",
        options,
        Box::new(move |cc| {
            Ok(Box::new(EditorApp::new(
                cc,
                EditorOptions {
                    open: path,
                    recent_store: editor::default_recent_store(),
                    auto_solve: true,
                },
            )))
        }),
    )
}

#[cfg(test)]
mod shader_tests {
    /// Parses and validates every file in shaders/ with naga, so a new shader
    /// cannot escape validation: common.wgsl alone, every other file as the renderer
    /// compiles it (common.wgsl prepended); and the renderer's sources are exactly those.
    #[test]
    fn all_shaders_validate() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        let mut count = 0;
        let mut entries: Vec<_> = std::fs::read_dir(&dir)
            .expect("shaders/ exists")
            .map(|e| e.expect("dir entry").path())
            .collect();
        entries.sort();
        for path in entries {
            let file = std::fs::read_to_string(&path).expect("shader is UTF-8 text");
            let src = if path.ends_with("common.wgsl") {
                file
            } else {
                format!("{}\n{file}", include_str!("../../shaders/common.wgsl"))
            };
            assert_eq!(
                path.extension().and_then(|e| e.to_str()),
                Some("wgsl"),
                "unexpected file in shaders/: {}",
                path.display()
            );
            let module = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("{}:\n{}", path.display(), e.emit_to_string(&src)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}:\n{}", path.display(), e.emit_to_string(&src)));
            count += 1;
        }
        for (name, src) in [
            ("mesh", super::render::MESH_WGSL),
            ("overlay", super::render::OVERLAY_WGSL),
            ("blit", super::render::BLIT_WGSL),
            ("lic", super::render::LIC_WGSL),
        ] {
            let file = std::fs::read_to_string(dir.join(format!("{name}.wgsl"))).unwrap();
            assert!(
                src.ends_with(&file),
                "{name}.wgsl: the renderer compiles another source"
            );
        }
        assert!(
            count >= 3,
            "expected the shaders of the renderer, found {count}"
        );
    }
}
