// Pass 2 of the field display: screen-space line integral convolution.
//
// Input (written by `fs_field` in shaders/mesh.wgsl, one texel per pixel):
//   g_dirs.xy, g_dirs.zw, g_misc.xy   unit screen directions (pixels, y down) of
//                                     the N/2 line families of the field
//   g_misc.z                          white noise fixed on the surface
//   g_misc.w                          view depth, 0 where there is no surface
// Output: r = LIC intensity in [0, 1] (mean 0.5), read by `fs_main`.
//
// For every family a streamline is integrated both ways from the pixel in
// ~1 px steps. Directions are sign-less lines and the family index is only
// defined per face, so at each step the family whose direction is closest to
// the previous step is taken, with its sign flipped to continue forwards.
// Streamlines stop at the silhouette and at depth discontinuities. The noise is
// averaged with a Hann window. Families are combined by taking, per pixel, the
// one whose LIC deviates most from the mean: each family keeps full contrast
// and shows as woven streaks instead of being averaged into grey.

// Uniforms, PI and the fullscreen triangle: shaders/common.wgsl.

@group(0) @binding(0) var<uniform> u: Uniforms;
@group(1) @binding(0) var g_dirs: texture_2d<f32>;
@group(1) @binding(1) var g_misc: texture_2d<f32>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VsOut {
    var out: VsOut;
    out.clip = fullscreen_clip(fullscreen_xy(i));
    return out;
}

const MAX_STEPS: i32 = 32;
// relative depth change per step that ends a streamline
const DEPTH_JUMP: f32 = 0.03;

fn family_dir(d: vec4<f32>, m: vec4<f32>, k: u32) -> vec2<f32> {
    switch k {
        case 0u: { return d.xy; }
        case 1u: { return d.zw; }
        default: { return m.xy; }
    }
}

// The direction of the family at (d, m) closest to `prev`, signed to agree with it.
fn continue_dir(d: vec4<f32>, m: vec4<f32>, prev: vec2<f32>, lines: u32) -> vec2<f32> {
    var best = vec2<f32>(0.0);
    var best_dot = -1.0;
    for (var k = 0u; k < lines; k = k + 1u) {
        let e = family_dir(d, m, k);
        let c = dot(e, prev);
        if (abs(c) > best_dot) {
            best_dot = abs(c);
            best = select(-e, e, c >= 0.0);
        }
    }
    return best;
}

fn lic_family(start: vec2<i32>, m0: vec4<f32>, d0: vec2<f32>, lines: u32, half_len: f32) -> f32 {
    let size = vec2<i32>(textureDimensions(g_misc));
    let steps = clamp(i32(ceil(half_len)), 1, MAX_STEPS);
    let h = half_len / f32(steps);
    var acc = m0.z;
    var wsum = 1.0;
    var w2sum = 1.0;
    for (var side = 0; side < 2; side = side + 1) {
        var prev = select(-d0, d0, side == 0);
        var pos = vec2<f32>(start) + vec2<f32>(0.5);
        var depth = m0.w;
        for (var i = 1; i <= steps; i = i + 1) {
            pos = pos + prev * h;
            let q = vec2<i32>(floor(pos));
            if (any(q < vec2<i32>(0)) || any(q >= size)) {
                break;
            }
            let mq = textureLoad(g_misc, q, 0);
            if (mq.w <= 0.0 || abs(mq.w - depth) > DEPTH_JUMP * depth) {
                break;
            }
            let dq = continue_dir(textureLoad(g_dirs, q, 0), mq, prev, lines);
            if (dot(dq, dq) < 0.25) {
                break;
            }
            let wgt = 0.5 + 0.5 * cos(PI * f32(i) / f32(steps + 1));
            acc = acc + wgt * mq.z;
            wsum = wsum + wgt;
            w2sum = w2sum + wgt * wgt;
            prev = dq;
            depth = mq.w;
        }
    }
    let mean = acc / wsum;
    // Averaging lowers the contrast by sqrt(n_eff) (samples within one noise
    // cell are correlated); restore it to a fixed standard deviation.
    let n_eff = wsum * wsum / w2sum / max(u.params.w, 1.0);
    let gain = clamp(0.6 * sqrt(n_eff), 1.0, 8.0);
    return clamp(0.5 + (mean - 0.5) * gain, 0.0, 1.0);
}

@fragment
fn fs_main(in: VsOut) -> @location(0) vec4<f32> {
    let p = vec2<i32>(in.clip.xy);
    let m0 = textureLoad(g_misc, p, 0);
    if (m0.w <= 0.0) {
        return vec4<f32>(0.5, 0.0, 0.0, 1.0);
    }
    let d = textureLoad(g_dirs, p, 0);
    let lines = clamp(u.modes.w / 2u, 1u, 3u);
    let half_len = clamp(u.params2.y * max(u.params.w, 0.5), 1.0, f32(MAX_STEPS));
    var best = 0.5;
    var best_dev = -1.0;
    for (var k = 0u; k < lines; k = k + 1u) {
        let dk = family_dir(d, m0, k);
        var l = 0.5;
        if (dot(dk, dk) > 0.25) {
            l = lic_family(p, m0, dk, lines, half_len);
        }
        let dev = abs(l - 0.5);
        if (dev > best_dev) {
            best_dev = dev;
            best = l;
        }
    }
    return vec4<f32>(best, 0.0, 0.0, 1.0);
}
