// Shared by every shader in this folder: the renderer prepends this file to each of them
// (`shader!` in src/app/render.rs), so the uniform block that must match the Rust `Uniforms`
// exists once. Bindings stay with each shader, which lays out its own groups.

struct Uniforms {
    view_proj: mat4x4<f32>,
    // xyz camera position, w scene radius
    camera_pos: vec4<f32>,
    // xyz direction towards the light (world), w ambient
    light_dir: vec4<f32>,
    base_color: vec4<f32>,
    // rgb, a = opacity
    wire_color: vec4<f32>,
    // rgb pattern line/ink colour, a = fill contrast
    pattern_color: vec4<f32>,
    // x pattern scale, y wire width px, z pattern line width px, w lic noise cell size (px)
    params: vec4<f32>,
    // x lic strength, y lic length (cells), z glyph size px, w overlay line width px
    params2: vec4<f32>,
    // width, height, 1/width, 1/height (pixels)
    viewport: vec4<f32>,
    // x shading (0 smooth, 1 flat), y pattern id, z wireframe on, w symmetry N
    modes: vec4<u32>,
    // x lic on, y has uv, z has field, w stripe twist n | k << 16 (sec. 4.2)
    flags: vec4<u32>,
}

const PI: f32 = 3.14159265358979;

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(max(c, vec3<f32>(0.0)), vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

// One triangle covering the viewport, for vertex index 0, 1, 2: (x, y) in {0, 2}², the
// viewport being [0, 1]² (y down); clip position (2x − 1, 1 − 2y).
fn fullscreen_xy(i: u32) -> vec2<f32> {
    return vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
}

fn fullscreen_clip(xy: vec2<f32>) -> vec4<f32> {
    return vec4<f32>(xy.x * 2.0 - 1.0, 1.0 - xy.y * 2.0, 0.0, 1.0);
}
