//! Offscreen render tests through wgpu (Mesa lavapipe on CI). Without an
//! adapter they print a message and pass, unless QUADCOVER_REQUIRE_GPU=1.
//! Images are written to target/render-tests/.

use glam::{DVec2, DVec3, Vec3};
use quadcover::app::camera::OrbitCamera;
use quadcover::app::document::{
    DEFAULT_MESH_NAME, DEFAULT_MESH_OBJ, Document, load_bytes, load_path,
};
use quadcover::app::render::Offscreen;
use quadcover::app::scene::{Glyph, LineSegment, SceneData, singularity_color};
use quadcover::app::settings::{DisplayMode, DisplaySettings, Pattern, Shading};
use quadcover::app::viewport::ViewportResources;
use support::{out_dir, shared_mesh};

mod support;

fn offscreen() -> Option<Offscreen> {
    support::offscreen("skipping render test")
}

fn save(img: &image::RgbaImage, name: &str) {
    let path = out_dir().join(name);
    img.save(&path).expect("write png");
    eprintln!("wrote {}", path.display());
}

fn luminance(p: &image::Rgba<u8>) -> f32 {
    (0.2126 * p[0] as f32 + 0.7152 * p[1] as f32 + 0.0722 * p[2] as f32) / 255.0
}

/// A flat n x n grid on [0,1]^2 at z = 0 with per-corner UVs `uv(x, y)`.
fn flat_square(n: usize, uv: impl Fn(DVec2) -> DVec2) -> SceneData {
    let mut pos = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            pos.push(DVec3::new(i as f64 / n as f64, j as f64 / n as f64, 0.0));
        }
    }
    let idx = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut faces = Vec::new();
    for j in 0..n {
        for i in 0..n {
            faces.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            faces.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    let mut scene = SceneData::from_triangles(&pos, &faces);
    let uvs: Vec<[f64; 2]> = faces
        .iter()
        .flat_map(|f| f.iter().map(|&v| pos[v as usize]))
        .map(|p| {
            let t = uv(DVec2::new(p.x, p.y));
            [t.x, t.y]
        })
        .collect();
    scene.set_corner_uvs(&uvs);
    scene
}

/// Camera looking straight down -z at the unit square, +y up in the image.
fn top_camera(scene: &SceneData) -> OrbitCamera {
    let mut cam = OrbitCamera {
        yaw: 0.0,
        pitch: 0.0,
        ..OrbitCamera::default()
    };
    cam.fit(scene.bbox);
    cam
}

fn plain_settings() -> DisplaySettings {
    DisplaySettings {
        base_color: [0.8, 0.8, 0.8],
        ..DisplaySettings::default()
    }
}

#[test]
fn default_mesh_renders_non_empty_without_black_pixels() {
    let Some(mut off) = offscreen() else { return };
    let doc = load_bytes(DEFAULT_MESH_NAME, DEFAULT_MESH_OBJ).expect("spot loads");
    off.upload(&doc.scene);
    let mut cam = OrbitCamera::default();
    cam.fit(doc.scene.bbox);
    let settings = DisplaySettings::default();
    let bg = settings.background;
    for (name, shading, wire) in [
        ("spot_smooth.png", Shading::Smooth, false),
        ("spot_flat_wire.png", Shading::Flat, true),
    ] {
        let s = DisplaySettings {
            shading,
            wireframe: wire,
            ..settings.clone()
        };
        let img = off.render(&cam, &s, 480, 360);
        save(&img, name);
        let total = (img.width() * img.height()) as usize;
        let covered = img.pixels().filter(|p| [p[0], p[1], p[2]] != bg).count();
        let black = img
            .pixels()
            .filter(|p| p[0] < 3 && p[1] < 3 && p[2] < 3)
            .count();
        assert!(
            covered > total / 10,
            "{name}: mesh covers only {covered} of {total} pixels"
        );
        if !wire {
            assert!(
                black < total / 1000,
                "{name}: {black} black pixels (NaN shading?)"
            );
        }
        assert!(img.pixels().all(|p| p[3] == 255), "{name}: not opaque");
    }
}

/// Runs of "line" pixels along row `y` inside columns [x0, x1).
fn line_runs(img: &image::RgbaImage, y: u32, x0: u32, x1: u32) -> Vec<f32> {
    let lum: Vec<f32> = (x0..x1).map(|x| luminance(img.get_pixel(x, y))).collect();
    let mut sorted = lum.clone();
    sorted.sort_by(f32::total_cmp);
    let bright = sorted[sorted.len() * 9 / 10];
    let thr = 0.6 * bright;
    let mut runs = Vec::new();
    let mut start = None;
    for (i, &l) in lum.iter().enumerate() {
        match (l < thr, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                runs.push(x0 as f32 + 0.5 * (s + i - 1) as f32);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        runs.push(x0 as f32 + 0.5 * (s + lum.len() - 1) as f32);
    }
    runs
}

#[test]
fn quad_grid_lines_have_expected_density() {
    let Some(mut off) = offscreen() else { return };
    let k = 8.0;
    let scene = flat_square(16, |p| p * k);
    off.upload(&scene);
    let cam = top_camera(&scene);
    let settings = DisplaySettings {
        mode: DisplayMode::Pattern,
        pattern: Pattern::QuadGrid,
        pattern_scale: 1.0,
        ..plain_settings()
    };
    let (w, h) = (512u32, 512u32);
    let img = off.render(&cam, &settings, w, h);
    save(&img, "square_quad_grid.png");

    // where the unit square lands on screen
    let vp = cam.view_proj(1.0);
    let to_px = |p: Vec3| {
        let c = vp.project_point3(p);
        ((c.x + 1.0) * 0.5 * w as f32, (1.0 - c.y) * 0.5 * h as f32)
    };
    let (ax, _) = to_px(Vec3::new(0.0, 0.5, 0.0));
    let (bx, _) = to_px(Vec3::new(1.0, 0.5, 0.0));
    let side = bx - ax;
    assert!(side > 200.0, "square too small on screen: {side}");
    // interior lines only (the borders sit on the mesh edge)
    for y in [h / 2 + 7, h / 2 - 29, h / 2 + 51] {
        let half_cell = 0.5 * side / k as f32;
        let runs = line_runs(&img, y, (ax + half_cell) as u32, (bx - half_cell) as u32);
        assert_eq!(
            runs.len(),
            k as usize - 1,
            "row {y}: expected {} interior grid lines, found {runs:?}",
            k - 1.0
        );
        let spacing: Vec<f32> = runs.windows(2).map(|r| r[1] - r[0]).collect();
        let expected = side / k as f32;
        for s in spacing {
            assert!(
                (s - expected).abs() < 2.0,
                "line spacing {s} px, expected {expected}"
            );
        }
    }
}

fn structure_orientation(img: &image::RgbaImage, margin: u32) -> (f32, f32) {
    let (w, h) = img.dimensions();
    let l = |x: u32, y: u32| luminance(img.get_pixel(x, y));
    let (mut jxx, mut jxy, mut jyy) = (0.0f64, 0.0f64, 0.0f64);
    for y in margin..h - margin {
        for x in margin..w - margin {
            let gx = (l(x + 1, y) - l(x - 1, y)) as f64;
            let gy = (l(x, y + 1) - l(x, y - 1)) as f64;
            jxx += gx * gx;
            jxy += gx * gy;
            jyy += gy * gy;
        }
    }
    // dominant gradient direction; streaks run perpendicular to it
    let theta_g = 0.5 * (2.0 * jxy).atan2(jxx - jyy);
    let tr = jxx + jyy;
    let det = jxx * jyy - jxy * jxy;
    let disc = (0.25 * tr * tr - det).max(0.0).sqrt();
    let (l1, l2) = (0.5 * tr + disc, 0.5 * tr - disc);
    let coherence = ((l1 - l2) / (l1 + l2).max(1e-12)) as f32;
    ((theta_g + std::f64::consts::FRAC_PI_2) as f32, coherence)
}

fn angle_diff_mod_pi(a: f32, b: f32) -> f32 {
    let d = (a - b).rem_euclid(std::f32::consts::PI);
    d.min(std::f32::consts::PI - d)
}

#[test]
fn lic_of_constant_field_is_oriented_along_the_field() {
    let Some(mut off) = offscreen() else { return };
    for angle_deg in [30.0f64, -65.0] {
        let a = angle_deg.to_radians();
        let dir = DVec3::new(a.cos(), a.sin(), 0.0);
        let mut scene = flat_square(8, |p| p);
        scene.set_face_field(&vec![dir; scene.n_faces()], 2);
        off.upload(&scene);
        let mut cam = top_camera(&scene);
        cam.zoom(0.6); // fill the image with the square
        let settings = DisplaySettings {
            mode: DisplayMode::Field,
            lic_strength: 1.0,
            ..plain_settings()
        };
        let img = off.render(&cam, &settings, 384, 384);
        save(&img, &format!("lic_constant_{angle_deg}.png"));
        let (theta, coherence) = structure_orientation(&img, 40);
        // image y points down
        let expected = (-a as f32).rem_euclid(std::f32::consts::PI);
        let err = angle_diff_mod_pi(theta, expected).to_degrees();
        assert!(
            err < 8.0,
            "streak orientation {:.1} deg, field {:.1} deg (error {err:.1})",
            theta.to_degrees(),
            expected.to_degrees()
        );
        assert!(coherence > 0.3, "streaks not coherent: {coherence}");
    }
}

/// Each pattern is invariant under its symmetry group: rendering with
/// uv' = R^r uv + w (R rotation by 2pi/N, w a lattice vector) gives the same image.
#[test]
fn patterns_are_invariant_under_their_symmetry_group() {
    let Some(mut off) = offscreen() else { return };
    let s3 = 3f64.sqrt() / 2.0;
    let cases = [
        (Pattern::QuadGrid, 4, DVec2::new(2.0, -3.0)),
        (Pattern::Checkerboard, 4, DVec2::new(1.0, 0.0)),
        (Pattern::OctagonSquare, 4, DVec2::new(-1.0, 2.0)),
        (Pattern::Stripes, 2, DVec2::new(3.0, 1.0)),
        (Pattern::Triangles, 6, DVec2::new(1.0 + 0.5, s3)),
        (Pattern::Hexagons, 6, DVec2::new(-2.0 + 0.5 * 3.0, 3.0 * s3)),
    ];
    for (pattern, n, w) in cases {
        let k = 5.3;
        let theta = 2.0 * std::f64::consts::PI / n as f64;
        let rot = |p: DVec2| {
            DVec2::new(
                theta.cos() * p.x - theta.sin() * p.y,
                theta.sin() * p.x + theta.cos() * p.y,
            )
        };
        let base = flat_square(8, |p| (p - 0.5) * k);
        let moved = flat_square(8, |p| rot((p - 0.5) * k) + w);
        let cam = top_camera(&base);
        let settings = DisplaySettings {
            mode: DisplayMode::Pattern,
            pattern,
            ..plain_settings()
        };
        off.upload(&base);
        let a = off.render(&cam, &settings, 256, 256);
        off.upload(&moved);
        let b = off.render(&cam, &settings, 256, 256);
        let name = format!("{pattern:?}").to_lowercase();
        save(&a, &format!("pattern_{name}.png"));
        let mut diff_sum = 0u64;
        let mut big = 0usize;
        for (p, q) in a.pixels().zip(b.pixels()) {
            let d = (0..3)
                .map(|c| p[c].abs_diff(q[c]) as u64)
                .max()
                .unwrap_or(0);
            diff_sum += d;
            if d > 40 {
                big += 1;
            }
        }
        let mean = diff_sum as f64 / (a.width() * a.height()) as f64;
        // the pattern must actually show something
        let lum: Vec<f32> = a.pixels().map(luminance).collect();
        let lo = lum.iter().cloned().fold(f32::MAX, f32::min);
        let hi = lum.iter().cloned().fold(f32::MIN, f32::max);
        assert!(hi - lo > 0.2, "{pattern:?}: no visible pattern");
        assert!(
            mean < 1.5 && big < 60,
            "{pattern:?} not invariant under rotation by 2pi/{n} + {w}: mean diff {mean:.2}, {big} pixels differ a lot"
        );
    }
}

/// Twisted stripes (thesis sec. 4.2, texture mapped by (n −k; k n)) stay invariant under the
/// half turn and Z² translations, and (1, 1) turns the stripes by 45°.
#[test]
fn twisted_stripes_are_seamless_and_turned() {
    let Some(mut off) = offscreen() else { return };
    let k = 5.3;
    let base = flat_square(8, |p| (p - 0.5) * k);
    let moved = flat_square(8, |p| -(p - 0.5) * k + DVec2::new(3.0, -1.0));
    let cam = top_camera(&base);
    let mut orientation = Vec::new();
    for twist in [[1, 0], [1, 1], [2, 1]] {
        let settings = DisplaySettings {
            mode: DisplayMode::Pattern,
            pattern: Pattern::Stripes,
            stripe_twist: twist,
            ..plain_settings()
        };
        off.upload(&base);
        let a = off.render(&cam, &settings, 256, 256);
        off.upload(&moved);
        let b = off.render(&cam, &settings, 256, 256);
        save(
            &a,
            &format!("pattern_stripes_twist_{}_{}.png", twist[0], twist[1]),
        );
        let diff: f64 = a
            .pixels()
            .zip(b.pixels())
            .map(|(p, q)| {
                (0..3)
                    .map(|c| p[c].abs_diff(q[c]) as u64)
                    .max()
                    .unwrap_or(0) as f64
            })
            .sum::<f64>()
            / (a.width() * a.height()) as f64;
        assert!(
            diff < 1.5,
            "twist {twist:?}: not seamless, mean diff {diff:.2}"
        );
        orientation.push(structure_orientation(&a, 40).0);
    }
    let turn = angle_diff_mod_pi(orientation[0], orientation[1]).to_degrees();
    assert!(
        (turn - 45.0).abs() < 6.0,
        "twist (1, 1) turned the stripes by {turn:.1} degrees"
    );
}

#[test]
fn overlays_and_field_on_default_mesh() {
    let Some(mut off) = offscreen() else { return };
    let doc = load_bytes(DEFAULT_MESH_NAME, DEFAULT_MESH_OBJ).expect("spot loads");
    let mesh = &doc.mesh;
    let mut scene = doc.scene.clone();
    // synthetic field: projection of the x axis; synthetic UVs: planar (x, y)
    let dirs: Vec<DVec3> = (0..mesh.n_faces())
        .map(|f| {
            let n = mesh.face_normal(f);
            (DVec3::X - n * n.dot(DVec3::X)).normalize_or_zero()
        })
        .collect();
    scene.set_face_field(&dirs, 4);
    let uvs: Vec<[f64; 2]> = mesh
        .faces()
        .iter()
        .flat_map(|f| f.iter().map(|&v| mesh.position(v as usize)))
        .map(|p| [p.x * 10.0, p.y * 10.0])
        .collect();
    scene.set_corner_uvs(&uvs);
    for (i, k) in [(0usize, -1), (500, 1), (1000, -2), (1500, 2), (2000, 3)] {
        let p = mesh.position(i);
        scene.glyphs.push(Glyph {
            position: [p.x as f32, p.y as f32, p.z as f32],
            color: singularity_color(k, 4),
        });
    }
    for e in 0..200 {
        let [a, b] = mesh.edge_vertices(e * 7);
        scene.lines.push(LineSegment {
            a: mesh.position(a).as_vec3().to_array(),
            b: mesh.position(b).as_vec3().to_array(),
            color: [0.9, 0.1, 0.05, 1.0],
        });
    }
    off.upload(&scene);
    let mut cam = OrbitCamera::default();
    cam.fit(scene.bbox);
    let field = DisplaySettings {
        mode: DisplayMode::Field,
        ..DisplaySettings::default()
    };
    let lic = off.render(&cam, &field, 480, 360);
    save(&lic, "spot_lic.png");
    let pat = DisplaySettings {
        mode: DisplayMode::Pattern,
        pattern: Pattern::QuadGrid,
        ..DisplaySettings::default()
    };
    let quad = off.render(&cam, &pat, 480, 360);
    save(&quad, "spot_quad_overlays.png");
    let none = DisplaySettings {
        show_lines: false,
        show_singularities: false,
        ..pat.clone()
    };
    let plain = off.render(&cam, &none, 480, 360);
    // overlays change some pixels, and red line pixels appear
    let changed = quad
        .pixels()
        .zip(plain.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert!(changed > 200, "overlays changed only {changed} pixels");
    let red = quad
        .pixels()
        .filter(|p| p[0] > 180 && p[1] < 110 && p[2] < 110)
        .count();
    assert!(red > 100, "cut-graph lines not visible ({red} red pixels)");
    // LIC differs from plain shading
    let shaded = off.render(&cam, &DisplaySettings::default(), 480, 360);
    let lic_changed = lic
        .pixels()
        .zip(shaded.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert!(lic_changed > 5000, "LIC barely visible: {lic_changed}");
}

#[test]
fn viewport_uploads_once_per_revision() {
    let Some(off) = offscreen() else { return };
    let mut res = ViewportResources::new(&off.device, &off.queue, wgpu::TextureFormat::Rgba8Unorm);
    let scene = flat_square(2, |p| p);
    for _ in 0..5 {
        res.sync_scene(&off.device, 7, Some(&scene));
    }
    assert_eq!(res.renderer.uploads, 1);
    res.sync_scene(&off.device, 8, Some(&scene));
    assert_eq!(res.renderer.uploads, 2);
}

#[test]
fn image_pattern_uses_the_user_texture() {
    let Some(mut off) = offscreen() else { return };
    // 2 x 2 texels: red, blue / blue, red
    let rgba = [
        220u8, 20, 20, 255, 20, 20, 220, 255, 20, 20, 220, 255, 220, 20, 20, 255,
    ];
    off.renderer
        .set_pattern_image(&off.device, &off.queue, 2, 2, &rgba);
    let scene = flat_square(4, |p| p * 3.0);
    off.upload(&scene);
    let cam = top_camera(&scene);
    let settings = DisplaySettings {
        mode: DisplayMode::Pattern,
        pattern: Pattern::Image,
        ..plain_settings()
    };
    let img = off.render(&cam, &settings, 256, 256);
    save(&img, "square_image_pattern.png");
    let reddish = img
        .pixels()
        .filter(|p| p[0] > 2 * p[2] && p[0] > 80)
        .count();
    let bluish = img
        .pixels()
        .filter(|p| p[2] > 2 * p[0] && p[2] > 80)
        .count();
    assert!(
        reddish > 2000 && bluish > 2000,
        "red {reddish}, blue {bluish}"
    );
}

/// Mean-free luminance of the interior (margin cut off), row-major, with its size.
fn centred_luminance(img: &image::RgbaImage, margin: u32) -> (Vec<f32>, usize, usize) {
    let (w, h) = img.dimensions();
    let (iw, ih) = ((w - 2 * margin) as usize, (h - 2 * margin) as usize);
    let mut l = Vec::with_capacity(iw * ih);
    for y in margin..h - margin {
        for x in margin..w - margin {
            l.push(luminance(img.get_pixel(x, y)));
        }
    }
    let mean = l.iter().sum::<f32>() / l.len() as f32;
    for v in &mut l {
        *v -= mean;
    }
    (l, iw, ih)
}

/// Normalised autocorrelation of the image at the lag `r` pixels along the
/// image direction `angle` (radians, y down), averaged over lags 3..=r.
fn directional_autocorrelation(l: &[f32], w: usize, h: usize, angle: f32, r: usize) -> f32 {
    let var: f32 = l.iter().map(|v| v * v).sum::<f32>() / l.len() as f32;
    let mut total = 0.0;
    let mut count = 0;
    for lag in 3..=r {
        let dx = (angle.cos() * lag as f32).round() as isize;
        let dy = (angle.sin() * lag as f32).round() as isize;
        let mut acc = 0.0f64;
        let mut n = 0usize;
        for y in 0..h as isize {
            for x in 0..w as isize {
                let (x2, y2) = (x + dx, y + dy);
                if x2 < 0 || y2 < 0 || x2 >= w as isize || y2 >= h as isize {
                    continue;
                }
                acc += (l[y as usize * w + x as usize] * l[y2 as usize * w + x2 as usize]) as f64;
                n += 1;
            }
        }
        total += (acc / n.max(1) as f64) as f32 / var.max(1e-12);
        count += 1;
    }
    total / count as f32
}

/// Histogram of gradient orientations mod pi (weighted by squared magnitude), `bins` bins.
fn gradient_orientation_histogram(img: &image::RgbaImage, margin: u32, bins: usize) -> Vec<f64> {
    let (w, h) = img.dimensions();
    let l = |x: u32, y: u32| luminance(img.get_pixel(x, y)) as f64;
    let mut hist = vec![0.0; bins];
    for y in margin..h - margin {
        for x in margin..w - margin {
            let gx = l(x + 1, y) - l(x - 1, y);
            let gy = l(x, y + 1) - l(x, y - 1);
            let a = gy.atan2(gx).rem_euclid(std::f64::consts::PI);
            let b = ((a / std::f64::consts::PI * bins as f64) as usize).min(bins - 1);
            hist[b] += gx * gx + gy * gy;
        }
    }
    hist
}

/// Histogram mass within `half_width` of the orientation `angle` (mod pi).
fn mass_near(hist: &[f64], angle: f32, half_width: f32) -> f64 {
    let bins = hist.len();
    (0..bins)
        .filter(|&b| {
            let c = (b as f32 + 0.5) / bins as f32 * std::f32::consts::PI;
            angle_diff_mod_pi(c, angle) <= half_width
        })
        .map(|b| hist[b])
        .sum()
}

/// Contrast (standard deviation of luminance) and count of black pixels.
fn contrast_and_black(img: &image::RgbaImage, margin: u32) -> (f32, usize) {
    let (l, _, _) = centred_luminance(img, margin);
    let std = (l.iter().map(|v| v * v).sum::<f32>() / l.len() as f32).sqrt();
    let black = img
        .pixels()
        .filter(|p| p[0] < 3 && p[1] < 3 && p[2] < 3)
        .count();
    (std, black)
}

#[test]
fn lic_of_constant_cross_field_shows_both_directions() {
    let Some(mut off) = offscreen() else { return };
    let a = 20f64.to_radians();
    let dir = DVec3::new(a.cos(), a.sin(), 0.0);
    let render = |off: &mut Offscreen, n: u32| {
        let mut scene = flat_square(8, |p| p);
        scene.set_face_field(&vec![dir; scene.n_faces()], n);
        off.upload(&scene);
        let mut cam = top_camera(&scene);
        cam.zoom(0.6);
        let settings = DisplaySettings {
            mode: DisplayMode::Field,
            lic_strength: 1.0,
            base_color: [0.55, 0.55, 0.55],
            ..plain_settings()
        };
        off.render(&cam, &settings, 384, 384)
    };
    // image directions (y down) of the field's lines
    let e0 = (-a as f32).rem_euclid(std::f32::consts::PI);
    let e1 = (e0 + std::f32::consts::FRAC_PI_2).rem_euclid(std::f32::consts::PI);
    let diag = |k: f32| (e0 + k * std::f32::consts::FRAC_PI_4).rem_euclid(std::f32::consts::PI);
    let margin = 40;
    let mut corr_n2 = [0.0; 2];
    for n in [2u32, 4, 6] {
        let img = render(&mut off, n);
        save(&img, &format!("lic_constant_n{n}.png"));
        let (contrast, black) = contrast_and_black(&img, margin);
        assert!(
            contrast > 0.05,
            "N = {n}: LIC nearly uniform (std {contrast:.3})"
        );
        assert_eq!(black, 0, "N = {n}: black pixels (NaN?)");
        let (l, w, h) = centred_luminance(&img, margin);
        let along = |t: f32| directional_autocorrelation(&l, w, h, t, 8);
        let (c0, c1, cd1, cd3) = (along(e0), along(e1), along(diag(1.0)), along(diag(3.0)));
        let hist = gradient_orientation_histogram(&img, margin, 36);
        let total: f64 = hist.iter().sum();
        let width = 10f32.to_radians();
        let (m0, m1) = (
            mass_near(&hist, e0, width) / total,
            mass_near(&hist, e1, width) / total,
        );
        let (md1, md3) = (
            mass_near(&hist, diag(1.0), width) / total,
            mass_near(&hist, diag(3.0), width) / total,
        );
        eprintln!(
            "N = {n}: contrast {contrast:.3}; autocorrelation along e0 {c0:.3}, e1 {c1:.3}, diagonals {cd1:.3} {cd3:.3}; \
             gradient mass near e0 {m0:.3}, e1 {m1:.3}, diagonals {md1:.3} {md3:.3}"
        );
        match n {
            2 => corr_n2 = [c0, c1],
            4 => {
                // streaks along both field directions, none along the diagonals
                for (c, name) in [(c0, "e0"), (c1, "e1")] {
                    assert!(c > 0.2, "N = 4: weak streaks along {name}: {c:.3}");
                    assert!(
                        c > 2.0 * cd1.max(cd3),
                        "N = 4: streaks along {name} ({c:.3}) not above the diagonals ({cd1:.3}, {cd3:.3})"
                    );
                }
                // gradient orientations peak at both directions, about 90 deg apart
                for (m, name) in [(m0, "e0"), (m1, "e1")] {
                    assert!(
                        m > 1.5 * md1.max(md3),
                        "N = 4: gradient mass near {name} {m:.3} vs diagonals {md1:.3} {md3:.3}"
                    );
                }
            }
            _ => {
                // N = 6: streaks along e0 and at +-60 deg, weaker at 90 deg from e0
                let sixty = |k: f32| {
                    (e0 + k * std::f32::consts::FRAC_PI_3).rem_euclid(std::f32::consts::PI)
                };
                let (s1, s2) = (along(sixty(1.0)), along(sixty(2.0)));
                eprintln!(
                    "N = 6: autocorrelation along e0 {c0:.3}, +60 {s1:.3}, +120 {s2:.3}, +90 {c1:.3}"
                );
                for (c, name) in [(c0, "e0"), (s1, "e0 + 60"), (s2, "e0 + 120")] {
                    assert!(c > 0.15, "N = 6: weak streaks along {name}: {c:.3}");
                    assert!(
                        c > 1.3 * c1,
                        "N = 6: streaks along {name} {c:.3} not above +90 {c1:.3}"
                    );
                }
            }
        }
    }
    // N = 2 shows one family only: nothing along the perpendicular
    assert!(
        corr_n2[0] > 2.0 * corr_n2[1].max(0.05),
        "N = 2: along {:.3}, across {:.3}",
        corr_n2[0],
        corr_n2[1]
    );
}

#[test]
fn lic_of_computed_bunny_fields() {
    let Some(mut off) = offscreen() else { return };
    let path = shared_mesh("bunny.obj");
    if !path.exists() {
        eprintln!("skipping: {} not found", path.display());
        return;
    }
    for (n, symmetry) in [
        (2, quadcover::field::Symmetry::Two),
        (4, quadcover::field::Symmetry::Four),
        (6, quadcover::field::Symmetry::Six),
    ] {
        let mut doc = Document::default();
        doc.set_loaded(load_path(&path).expect("bunny loads"));
        let params = quadcover::field::FieldParams {
            symmetry,
            ..Default::default()
        };
        let result = quadcover::field::compute_field(doc.mesh.as_ref().unwrap(), &params)
            .expect("bunny field");
        doc.set_frame_field(result);
        let scene = doc.scene().expect("scene").clone();
        assert!(scene.has_field && scene.symmetry == n);
        off.upload(&scene);
        let mut cam = OrbitCamera::default();
        cam.fit(scene.bbox);
        cam.zoom(0.55);
        let field = DisplaySettings {
            mode: DisplayMode::Field,
            show_singularities: false,
            ..DisplaySettings::default()
        };
        let (w, h) = (640, 480);
        let t0 = std::time::Instant::now();
        let lic = off.render(&cam, &field, w, h);
        let t_lic = t0.elapsed();
        save(&lic, &format!("bunny_lic_n{n}.png"));
        let t0 = std::time::Instant::now();
        let shaded = off.render(
            &cam,
            &DisplaySettings {
                show_singularities: false,
                ..DisplaySettings::default()
            },
            w,
            h,
        );
        eprintln!(
            "bunny N = {n}: {w} x {h} render with LIC {t_lic:?}, shaded {:?}",
            t0.elapsed()
        );
        // the LIC modulates the surface: visible difference and local contrast
        let bg = field.background;
        let mut covered = 0usize;
        let mut diff = 0.0f64;
        for (p, q) in lic.pixels().zip(shaded.pixels()) {
            if [q[0], q[1], q[2]] != bg {
                covered += 1;
                diff += (luminance(p) - luminance(q)).abs() as f64;
            }
        }
        let mean_diff = diff / covered.max(1) as f64;
        let black = lic
            .pixels()
            .filter(|p| p[0] < 3 && p[1] < 3 && p[2] < 3)
            .count();
        eprintln!(
            "bunny N = {n}: {covered} covered pixels, mean |LIC - shaded| {mean_diff:.3}, {black} black"
        );
        assert!(covered > (w * h) as usize / 10, "bunny barely visible");
        assert!(
            mean_diff > 0.04,
            "N = {n}: LIC barely visible ({mean_diff:.3})"
        );
        assert!(
            black < (w * h) as usize / 1000,
            "N = {n}: {black} black pixels"
        );
    }
}

/// Frames along the parallels of a sphere: U = the east direction projected into each face,
/// V = n × U, `scale` grid units per unit length (a +1 pole at each of the poles).
fn parallel_frames(mesh: &quadcover::mesh::TriMesh, scale: f64) -> Vec<[DVec3; 2]> {
    (0..mesh.n_faces())
        .map(|f| {
            let [a, b, c] = mesh.faces()[f].map(|v| mesh.position(v as usize));
            let m = (a + b + c) / 3.0;
            let n = mesh.face_normal(f);
            let east = DVec3::new(-m.y, m.x, 0.0);
            let u = (east - n * n.dot(east)).normalize() * scale;
            [u, n.cross(u)]
        })
        .collect()
}

/// The lines crossing circles around `c` (pixels) in `img`, for radii from `r0` to `r1` (every
/// pixel): per radius the angles of the dark runs' centres along the circle. Radii within 4
/// pixels of a ring (a circle mostly dark) are left out. Rays from `c` cross every circle once,
/// all at the same angle.
fn circle_crossings(
    img: &image::RgbaImage,
    c: (f32, f32),
    r0: f32,
    r1: f32,
) -> Vec<(f32, Vec<f32>)> {
    let lum = |x: f32, y: f32| luminance(img.get_pixel(x.round() as u32, y.round() as u32));
    let circles: Vec<(f32, Vec<bool>)> = (0..)
        .map(|i| r0 + i as f32)
        .take_while(|&r| r <= r1)
        .map(|r| {
            // a quarter pixel along the circle
            let n = (std::f32::consts::TAU * r * 4.0).ceil() as usize;
            let l: Vec<f32> = (0..n)
                .map(|j| {
                    let a = std::f32::consts::TAU * j as f32 / n as f32;
                    lum(c.0 + r * a.cos(), c.1 - r * a.sin())
                })
                .collect();
            let mut sorted = l.clone();
            sorted.sort_by(f32::total_cmp);
            let thr = 0.75 * sorted[n * 9 / 10];
            (r, l.iter().map(|&x| x < thr).collect())
        })
        .collect();
    let rings: Vec<f32> = circles
        .iter()
        .filter(|(_, d)| d.iter().filter(|&&x| x).count() * 2 > d.len())
        .map(|(r, _)| *r)
        .collect();
    let mut out = Vec::new();
    for (r, dark) in &circles {
        let n = dark.len();
        if rings.iter().any(|q| (q - r).abs() <= 4.0) {
            continue;
        }
        let Some(start) = (0..n).find(|&j| !dark[j]) else {
            continue;
        };
        // runs of dark samples, walking once around from a light one
        let mut centres = Vec::new();
        let mut run: Option<usize> = None;
        for i in 1..=n {
            match (dark[(start + i) % n], run) {
                (true, None) => run = Some(i),
                (false, Some(s)) => {
                    let mid = (start as f32 + 0.5 * (s + i - 1) as f32) % n as f32;
                    centres.push(std::f32::consts::TAU * mid / n as f32);
                    run = None;
                }
                _ => {}
            }
        }
        centres.sort_by(f32::total_cmp);
        out.push((*r, centres));
    }
    out
}

/// How well the crossings of [`circle_crossings`] are rays: (the share of circles crossed by
/// the most frequent number of lines, that number, the largest distance in pixels between a
/// crossing and its ray — the crossing at that angle on the outermost such circle).
fn ray_consistency(crossings: &[(f32, Vec<f32>)]) -> (f64, usize, f32) {
    let mut counts = std::collections::BTreeMap::new();
    for (_, c) in crossings {
        *counts.entry(c.len()).or_insert(0usize) += 1;
    }
    let (&mode, &hits) = counts.iter().max_by_key(|(_, h)| **h).expect("circles");
    let share = hits as f64 / crossings.len() as f64;
    let Some((_, reference)) = crossings.iter().rev().find(|(_, c)| c.len() == mode) else {
        return (share, mode, f32::INFINITY);
    };
    let mut worst = 0.0f32;
    for (r, c) in crossings
        .iter()
        .filter(|(_, c)| c.len() == mode && mode > 0)
    {
        // the same rays, sorted by angle, up to where the walk around started
        let best = (0..mode)
            .map(|shift| {
                (0..mode)
                    .map(|i| {
                        let d = (c[(i + shift) % mode] - reference[i])
                            .rem_euclid(std::f32::consts::TAU);
                        r * d.min(std::f32::consts::TAU - d)
                    })
                    .fold(0.0f32, f32::max)
            })
            .fold(f32::INFINITY, f32::min);
        worst = worst.max(best);
    }
    (share, mode, worst)
}

/// A pole's star is drawn by its bilinear quads (tessellated), not by its linear triangles:
/// on a sphere with frames along the parallels, seen from above the north pole (a +1 pole),
/// the quad grid shows rings around the pole and rays converging at it, each line crossing
/// every circle around the pole at the same angle. The star triangles' own corner UVs disagree
/// at the pole: drawn linearly, lines break off before the pole and jump across the star's
/// edges, and the check fails on that image.
#[test]
fn pole_stars_render_bilinear_without_seam() {
    use quadcover::app::document::{LoadedDocument, MeshStats, ParamDisplay};
    use quadcover::param::{ParamOptions, QuadCover, fit_matchings};
    let Some(mut off) = offscreen() else { return };
    let mesh = quadcover::mesh::generate::uv_sphere(24, 32);
    let frames = parallel_frames(&mesh, 4.0);
    let m = fit_matchings(&mesh, 4, &frames);
    let p = QuadCover::new(&mesh, 4, &m, ParamOptions::default())
        .unwrap()
        .solve(&mesh, &frames)
        .unwrap();
    let pole = p
        .poles
        .iter()
        .find(|q| q.vertex == 0)
        .expect("north pole treated");
    // the editor's path: the document takes the result and builds the scene with the patches
    let mut doc = Document::default();
    let mesh = std::sync::Arc::new(mesh);
    doc.set_loaded(LoadedDocument {
        path: None,
        name: "uv_sphere".into(),
        mesh: mesh.clone(),
        to_file: (0..mesh.n_vertices() as u32).collect(),
        file_vertices: mesh.n_vertices(),
        sha256: String::new(),
        warnings: Vec::new(),
        stats: MeshStats::from(&mesh.topology()),
        scene: SceneData::from_trimesh(&mesh),
    });
    doc.set_parameterization(p.clone(), true);
    let bilinear = doc.scene().expect("scene").as_ref().clone();
    let display = ParamDisplay::from_parameterization(&mesh, &p);
    assert_eq!(doc.param.as_ref(), Some(&display));
    let mut linear = SceneData::from_trimesh(&mesh);
    linear.set_corner_uvs(&display.corner_uvs);
    assert!(bilinear.has_uv);
    assert_eq!(bilinear.n_faces(), mesh.n_faces());
    assert!(
        pole.faces
            .iter()
            .all(|&f| bilinear.patch_faces.contains(&(f as u32)))
    );
    // looking down −z at the north pole (image x = world x, image y up = world y)
    let cam = OrbitCamera {
        target: Vec3::Z,
        yaw: 0.0,
        pitch: 0.0,
        distance: 0.5,
        radius: 1.0,
        ..OrbitCamera::default()
    };
    let scale = 4.0;
    let settings = DisplaySettings {
        mode: DisplayMode::Pattern,
        pattern: Pattern::QuadGrid,
        pattern_scale: scale,
        line_width: 2.0,
        show_lines: false,
        ..plain_settings()
    };
    let (w, h) = (480u32, 480u32);
    let vp = cam.view_proj(1.0);
    let to_px = |p: DVec3| {
        let q = vp.project_point3(p.as_vec3());
        ((q.x + 1.0) * 0.5 * w as f32, (1.0 - q.y) * 0.5 * h as f32)
    };
    let centre = to_px(mesh.position(0));
    // the star's inner radius on screen: the nearest ring vertex
    let star = pole
        .ring
        .iter()
        .map(|&a| {
            let q = to_px(mesh.position(a));
            (q.0 - centre.0).hypot(q.1 - centre.1)
        })
        .fold(f32::INFINITY, f32::min);
    assert!(star > 150.0 && star < 235.0, "star radius {star} px");
    // grid lines through the pole: the texture length of the quads' inner (collapsed) edges
    let winding: f64 = pole
        .quads
        .iter()
        .map(|q| DVec2::from(q[2]).distance(DVec2::from(q[3])))
        .sum();
    let rays = (winding * scale as f64).round() as usize;
    assert!(rays >= 8, "{rays} grid lines through the pole");

    off.upload(&bilinear);
    let img = off.render(&cam, &settings, w, h);
    save(&img, "sphere_pole_bilinear.png");
    let wire = DisplaySettings {
        wireframe: true,
        line_width: 1.2,
        show_lines: false,
        ..plain_settings()
    };
    let wire_new = off.render(&cam, &wire, w, h);
    save(&wire_new, "sphere_pole_bilinear_wire.png");
    off.upload(&linear);
    let old = off.render(&cam, &settings, w, h);
    save(&old, "sphere_pole_linear.png");
    let wire_old = off.render(&cam, &wire, w, h);

    let (share, mode, off_ray) =
        ray_consistency(&circle_crossings(&img, centre, 0.3 * star, 0.95 * star));
    let (old_share, old_mode, old_off) =
        ray_consistency(&circle_crossings(&old, centre, 0.3 * star, 0.95 * star));
    eprintln!(
        "bilinear: {share:.2} of the circles crossed by {mode} lines (expected {rays}), at most {off_ray:.1} px off their rays; linear triangles: {old_share:.2} crossed by {old_mode}, {old_off:.1} px"
    );
    assert!(
        share > 0.9 && mode == rays && off_ray < 2.5,
        "pole star not seamless: {share:.2} of the circles crossed by {mode} lines (expected {rays}), {off_ray:.1} px off their rays"
    );
    assert!(
        old_share < 0.6,
        "the linear star triangles pass the check too ({old_share:.2}, {old_mode} lines)"
    );
    // The wireframe is the mesh's, not the patches' cells: it looks the same drawn either way.
    let diff = wire_new
        .pixels()
        .zip(wire_old.pixels())
        .map(|(a, b)| (luminance(a) - luminance(b)).abs())
        .sum::<f32>()
        / (w * h) as f32;
    assert!(diff < 0.01, "wireframe differs by {diff:.4} on average");
}
