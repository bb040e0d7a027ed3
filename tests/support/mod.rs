//! Helpers shared by the render and UI tests (a folder, so cargo does not build it as a test).

use std::path::PathBuf;

use quadcover::app::render::Offscreen;

/// A mesh of ../shared/meshes (read-only test data beside the repository).
pub fn shared_mesh(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/meshes")
        .join(name)
}

/// Where rendered images go: target/render-tests/ (or under CARGO_TARGET_DIR).
pub fn out_dir() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target"));
    let dir = target.join("render-tests");
    std::fs::create_dir_all(&dir).expect("create target/render-tests");
    dir
}

/// An offscreen renderer, or `None` with a message (`without` says what the test does then)
/// where no adapter exists; with QUADCOVER_REQUIRE_GPU=1 that is a failure instead.
pub fn offscreen(without: &str) -> Option<Offscreen> {
    match Offscreen::new() {
        Ok(o) => {
            eprintln!("adapter: {:?}", o.adapter_info);
            Some(o)
        }
        Err(e) => {
            if std::env::var("QUADCOVER_REQUIRE_GPU").as_deref() == Ok("1") {
                panic!("QUADCOVER_REQUIRE_GPU=1 but {e}");
            }
            eprintln!("{without}: {e}");
            None
        }
    }
}
