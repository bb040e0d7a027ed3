// Copies the renderer's resolved colour texture into egui's render pass
// (the viewport rectangle is set by egui before the paint callback runs). The fullscreen
// triangle: shaders/common.wgsl.

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var src_sampler: sampler;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VsOut {
    let xy = fullscreen_xy(i);
    var out: VsOut;
    out.clip = fullscreen_clip(xy);
    out.uv = xy;
    return out;
}

@fragment
fn fs_main(in: VsOut) -> @location(0) vec4<f32> {
    return textureSampleLevel(src, src_sampler, in.uv, 0.0);
}
