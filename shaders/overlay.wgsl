// Overlays drawn over the surface: thick screen-space line segments (cut graph,
// constraints, selection, field crosses) and disc glyphs at singular vertices.
// Uniforms and linear_to_srgb: shaders/common.wgsl.

@group(0) @binding(0) var<uniform> u: Uniforms;

// Move a world point towards the camera by `amount` scene radii so overlays
// lying on the surface win the depth test without showing through it.
fn pull_forward(x: vec3<f32>, amount: f32) -> vec3<f32> {
    let to_eye = u.camera_pos.xyz - x;
    let d = max(length(to_eye), 1e-9);
    let shift = min(amount * u.camera_pos.w, 0.5 * d);
    return x + to_eye / d * shift;
}

// ---------------------------------------------------------------- lines

struct LineIn {
    @builtin(vertex_index) index: u32,
    @location(0) a: vec3<f32>,
    @location(1) b: vec3<f32>,
    @location(2) color: vec4<f32>,
}

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
    // signed distance across the line in pixels
    @location(1) across: f32,
    // half the line's width in pixels
    @location(2) half_width: f32,
}

// A segment `width_px` wide, as two triangles (corners: end, side).
fn line_vertex(v: LineIn, width_px: f32) -> LineOut {
    let ca = u.view_proj * vec4<f32>(pull_forward(v.a, 0.004), 1.0);
    let cb = u.view_proj * vec4<f32>(pull_forward(v.b, 0.004), 1.0);
    let half_px = 0.5 * width_px + 1.0;
    let sa = ca.xy / max(ca.w, 1e-6) * u.viewport.xy * 0.5;
    let sb = cb.xy / max(cb.w, 1e-6) * u.viewport.xy * 0.5;
    var dir = sb - sa;
    if (dot(dir, dir) < 1e-12) {
        dir = vec2<f32>(1.0, 0.0);
    }
    dir = normalize(dir);
    let nrm = vec2<f32>(-dir.y, dir.x);
    var ends = array<f32, 6>(0.0, 1.0, 0.0, 0.0, 1.0, 1.0);
    var sides = array<f32, 6>(-1.0, -1.0, 1.0, 1.0, -1.0, 1.0);
    let e = ends[v.index];
    let s = sides[v.index];
    var c = mix(ca, cb, e);
    let offset_px = nrm * s * half_px + dir * (e * 2.0 - 1.0) * half_px * 0.5;
    let offset_ndc = offset_px * 2.0 * u.viewport.zw;
    c = vec4<f32>(c.xy + offset_ndc * c.w, c.zw);
    var out: LineOut;
    out.clip = c;
    out.color = v.color;
    out.across = s * half_px;
    out.half_width = 0.5 * width_px;
    return out;
}

// Lines of the overlay width (cut graph, previews, combinatorial curves).
@vertex
fn vs_line(v: LineIn) -> LineOut {
    return line_vertex(v, u.params2.w);
}

// Lines twice as wide (geometric curves, highlighted curves).
@vertex
fn vs_thick_line(v: LineIn) -> LineOut {
    return line_vertex(v, 2.0 * u.params2.w);
}

@fragment
fn fs_line(in: LineOut) -> @location(0) vec4<f32> {
    let cov = clamp(in.half_width + 0.5 - abs(in.across), 0.0, 1.0);
    if (cov <= 0.0) {
        discard;
    }
    return vec4<f32>(linear_to_srgb(in.color.rgb), in.color.a * cov);
}

// ---------------------------------------------------------------- glyphs

struct GlyphIn {
    @builtin(vertex_index) index: u32,
    @location(0) position: vec3<f32>,
    @location(1) color: vec4<f32>,
}

struct GlyphOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) local: vec2<f32>,
}

@vertex
fn vs_glyph(v: GlyphIn) -> GlyphOut {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(-1.0, 1.0),
        vec2<f32>(-1.0, 1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
    );
    let local = corners[v.index];
    var c = u.view_proj * vec4<f32>(pull_forward(v.position, 0.02), 1.0);
    let offset_ndc = local * (0.5 * u.params2.z) * 2.0 * u.viewport.zw;
    c = vec4<f32>(c.xy + offset_ndc * c.w, c.zw);
    var out: GlyphOut;
    out.clip = c;
    out.color = v.color;
    out.local = local;
    return out;
}

@fragment
fn fs_glyph(in: GlyphOut) -> @location(0) vec4<f32> {
    let r = length(in.local);
    let px = max(fwidth(r), 1e-6);
    let alpha = clamp((1.0 - r) / px, 0.0, 1.0);
    if (alpha <= 0.0) {
        discard;
    }
    // dark outline ring so light colours stay visible on light shading
    let ring = clamp((r - 0.72) / px, 0.0, 1.0);
    let rgb = mix(in.color.rgb, vec3<f32>(0.02), ring);
    return vec4<f32>(linear_to_srgb(rgb), alpha);
}
