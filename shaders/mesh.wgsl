// Surface shading for the quadcover viewport and offscreen renderer.
//
// Vertices are per corner (3 per face, non-indexed draw), so `vertex_index % 3`
// gives the corner and the barycentric coordinate used for the wireframe.
//
// Output is sRGB-encoded into an Rgba8Unorm target (the same bytes are blitted
// into egui's non-sRGB surface or read back by the offscreen tests).
//
// Texture patterns are evaluated at p = uv * scale. A QuadCover parameterization
// is only defined up to the transition maps phi_j = R^r phi_i + w (R the rotation
// by 2pi/N, w in the lattice), so every pattern below is built to be invariant
// under its symmetry group: the value and the line coverage depend only on the
// Euclidean distance to lattice-invariant line sets, and the pixel footprint is
// measured isotropically (length of dp/dx, dp/dy), which rotations preserve.
//
//   1 quad grid        lines x in Z, y in Z                  Z^2 x| C4
//   2 checkerboard     cells of size 1/2 centred on Z^2       Z^2 x| C4
//   3 triangles        the 3 line families of G6             G6  x| C6
//   4 hexagons         Voronoi cells of G6 (centred on G6)   G6  x| C6
//   5 stripes          bands |x - round(x)| < 1/4            Z^2 x| C2
//   6 octagon-square   4.8.8 tiling, octagons centred on Z^2 Z^2 x| C4
//   7 image            user texture, repeat (invariant only if the image is)

// Uniforms, PI and linear_to_srgb: shaders/common.wgsl.

@group(0) @binding(0) var<uniform> u: Uniforms;
@group(0) @binding(1) var pattern_tex: texture_2d<f32>;
@group(0) @binding(2) var pattern_sampler: sampler;
// LIC intensity per pixel (r), written by shaders/lic.wgsl; read by fs_main only.
@group(1) @binding(0) var lic_tex: texture_2d<f32>;

struct VsIn {
    @builtin(vertex_index) index: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) face_normal: vec3<f32>,
    @location(3) uv: vec2<f32>,
    @location(4) field: vec3<f32>,
}

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) face_normal: vec3<f32>,
    @location(3) uv: vec2<f32>,
    @location(4) field: vec3<f32>,
    @location(5) bary: vec3<f32>,
}

@vertex
fn vs_main(v: VsIn) -> VsOut {
    var out: VsOut;
    out.clip = u.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.face_normal = v.face_normal;
    out.uv = v.uv;
    out.field = v.field;
    let k = v.index % 3u;
    out.bary = vec3<f32>(f32(k == 0u), f32(k == 1u), f32(k == 2u));
    return out;
}

const SQRT3_2: f32 = 0.86602540378;

// ---------------------------------------------------------------- helpers

// Coverage of a line of width `width_px` pixels, given the distance `d` to the
// line in pattern units and the pixel footprint `pix` in pattern units.
fn line_cov(d: f32, pix: f32, width_px: f32) -> f32 {
    return clamp(0.5 * width_px + 0.5 - abs(d) / max(pix, 1e-7), 0.0, 1.0);
}

// Signed distance to the nearest cell boundary of a unit-period 1-D checker,
// positive on even cells.
fn checker_wave(q: f32) -> f32 {
    let f = fract(q);
    let d = min(f, 1.0 - f);
    let even = fract(q * 0.5) < 0.5;
    return select(-d, d, even);
}

// Lattice coordinates of G6 = {a (1,0) + b (1/2, sqrt3/2)}.
fn g6_coords(p: vec2<f32>) -> vec2<f32> {
    let b = p.y / SQRT3_2;
    return vec2<f32>(p.x - 0.5 * b, b);
}

fn g6_point(ab: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(ab.x + 0.5 * ab.y, SQRT3_2 * ab.y);
}

// ---------------------------------------------------------------- patterns
// Each returns vec2(fill in [0,1], line coverage in [0,1]).

fn pattern_quad(p: vec2<f32>, pix: f32, w: f32) -> vec2<f32> {
    let f = abs(p - round(p));
    return vec2<f32>(0.0, line_cov(min(f.x, f.y), pix, w));
}

fn pattern_checker(p: vec2<f32>, pix: f32) -> vec2<f32> {
    // cells of side 1/2 centred on lattice points: q = 2p + 1/2 has boundaries at integers
    let q = 2.0 * p + vec2<f32>(0.5);
    let pq = 2.0 * pix;
    let sx = clamp(checker_wave(q.x) / max(pq, 1e-7), -1.0, 1.0);
    let sy = clamp(checker_wave(q.y) / max(pq, 1e-7), -1.0, 1.0);
    return vec2<f32>(0.5 + 0.5 * sx * sy, 0.0);
}

fn pattern_triangles(p: vec2<f32>, pix: f32, w: f32) -> vec2<f32> {
    let ab = g6_coords(p);
    let c = ab.x + ab.y;
    let da = abs(ab.x - round(ab.x));
    let db = abs(ab.y - round(ab.y));
    let dc = abs(c - round(c));
    let d = min(da, min(db, dc)) * SQRT3_2;
    return vec2<f32>(0.0, line_cov(d, pix, w));
}

fn pattern_hexagons(p: vec2<f32>, pix: f32, w: f32) -> vec2<f32> {
    let ab = g6_coords(p);
    let base = floor(ab);
    var d1 = 1e9;
    var d2 = 1e9;
    var c1 = vec2<f32>(0.0);
    var c2 = vec2<f32>(0.0);
    for (var i = -1; i <= 2; i = i + 1) {
        for (var j = -1; j <= 2; j = j + 1) {
            let c = g6_point(base + vec2<f32>(f32(i), f32(j)));
            let dd = dot(p - c, p - c);
            if (dd < d1) {
                d2 = d1;
                c2 = c1;
                d1 = dd;
                c1 = c;
            } else if (dd < d2) {
                d2 = dd;
                c2 = c;
            }
        }
    }
    // distance to the bisector of the two nearest lattice points (|c2 - c1| = 1)
    let d = (d2 - d1) / (2.0 * max(length(c2 - c1), 1e-6));
    let centre = 1.0 - clamp(sqrt(d1) * 2.0, 0.0, 1.0);
    return vec2<f32>(0.35 * centre, line_cov(d, pix, w));
}

fn pattern_stripes(p: vec2<f32>, pix: f32) -> vec2<f32> {
    // band where |x - round(x)| < 1/4; signed distance to the band edge
    let d = 0.25 - abs(p.x - round(p.x));
    return vec2<f32>(clamp(0.5 + d / max(pix, 1e-7), 0.0, 1.0), 0.0);
}

fn pattern_octagon_square(p: vec2<f32>, pix: f32, w: f32) -> vec2<f32> {
    // regular octagons of apothem 1/2 centred on Z^2, squares at (1/2,1/2)+Z^2
    let q = abs(p - round(p));
    let d_oct = max(max(q.x, q.y), (q.x + q.y) * 0.70710678) - 0.5;
    let in_square = clamp(0.5 + d_oct / max(pix, 1e-7), 0.0, 1.0);
    return vec2<f32>(in_square, line_cov(d_oct, pix, w));
}

// ---------------------------------------------------------------- LIC
//
// The field display is a screen-space line integral convolution in three
// passes (see render.rs): `fs_field` writes white noise fixed on the surface,
// the field's N/2 line directions projected to the screen and the view depth
// into two offscreen targets; shaders/lic.wgsl convolves the noise along
// screen-space streamlines of each direction family; `fs_main` reads the
// result at its pixel and blends it over the shading.

fn hash3(p: vec3<i32>) -> f32 {
    var h = u32(p.x) * 73856093u ^ u32(p.y) * 19349663u ^ u32(p.z) * 83492791u;
    h = (h ^ (h >> 13u)) * 1274126177u;
    h = h ^ (h >> 16u);
    return f32(h & 0xffffu) / 65535.0;
}

// White noise on the surface: a hash of the 3-D position quantised to cells of
// about `u.params.w` pixels at the current zoom. The two nearest power-of-two
// cell sizes are blended (like mip levels) so the noise does not swim while
// zooming; the blend is rescaled to keep the variance of one level. The lattice
// is rotated so that axis-aligned planes do not get axis-aligned cells.
fn surface_noise(world: vec3<f32>, pixel_world: f32) -> f32 {
    let cell = max(u.params.w, 0.5) * max(pixel_world, 1e-9);
    let level = log2(1.0 / cell);
    let l0 = floor(level);
    let t = level - l0;
    let rot = mat3x3<f32>(
        vec3<f32>(0.8137, 0.4698, -0.3420),
        vec3<f32>(-0.4410, 0.8826, 0.1631),
        vec3<f32>(0.3785, 0.0180, 0.9254),
    );
    let x = rot * world;
    let a = hash3(vec3<i32>(floor(x * exp2(l0))));
    let b = hash3(vec3<i32>(floor(x * exp2(l0 + 1.0))));
    let m = mix(a, b, t);
    let norm = inverseSqrt((1.0 - t) * (1.0 - t) + t * t);
    return clamp(0.5 + (m - 0.5) * norm, 0.0, 1.0);
}

fn rotate_in_plane(d: vec3<f32>, n: vec3<f32>, angle: f32) -> vec3<f32> {
    return cos(angle) * d + sin(angle) * cross(n, d);
}

// Unit screen-space (pixel, y down) direction of the tangent vector `d` at the
// point with clip coordinates `c`; zero when `d` projects to (almost) a point.
fn screen_dir(c: vec4<f32>, d: vec3<f32>) -> vec2<f32> {
    let dc = u.view_proj * vec4<f32>(d, 0.0);
    let dn = (dc.xy * c.w - c.xy * dc.w) / (c.w * c.w);
    let px = vec2<f32>(dn.x * u.viewport.x, -dn.y * u.viewport.y);
    let len = length(px);
    // |d| = 1; below ~1e-3 of a full-length projection the direction is noise
    let full = length(vec2<f32>(u.viewport.x, u.viewport.y)) / max(c.w, 1e-9);
    if (len < 1e-3 * full) {
        return vec2<f32>(0.0);
    }
    return px / len;
}

struct FieldOut {
    // screen directions of line families 0 and 1
    @location(0) dirs: vec4<f32>,
    // xy family 2, z surface noise, w view depth (0 = no surface)
    @location(1) misc: vec4<f32>,
}

// Pass 1 of the LIC: the G-buffer. Families k = 0 .. N/2 - 1 are the surface
// directions rotated by k 2pi/N in the face plane, each projected on its own
// (projection does not commute with rotation).
@fragment
fn fs_field(in: VsOut) -> FieldOut {
    let pixel_world = 0.5 * (length(dpdx(in.world)) + length(dpdy(in.world)));
    let noise = surface_noise(in.world, pixel_world);
    let c = u.view_proj * vec4<f32>(in.world, 1.0);
    var out: FieldOut;
    let n = in.face_normal;
    var d0 = vec3<f32>(0.0);
    if (dot(in.field, in.field) > 1e-12 && dot(n, n) > 1e-12) {
        d0 = normalize(in.field);
    }
    let nn = select(vec3<f32>(0.0, 0.0, 1.0), normalize(n), dot(n, n) > 1e-12);
    let step = 2.0 * PI / f32(max(u.modes.w, 1u));
    var e0 = vec2<f32>(0.0);
    var e1 = vec2<f32>(0.0);
    var e2 = vec2<f32>(0.0);
    if (dot(d0, d0) > 0.5) {
        e0 = screen_dir(c, d0);
        e1 = screen_dir(c, rotate_in_plane(d0, nn, step));
        e2 = screen_dir(c, rotate_in_plane(d0, nn, 2.0 * step));
    }
    out.dirs = vec4<f32>(e0, e1);
    out.misc = vec4<f32>(e2, noise, max(c.w, 1e-6));
    return out;
}

// ---------------------------------------------------------------- fragment

@fragment
fn fs_main(in: VsOut) -> @location(0) vec4<f32> {
    // derivative-based quantities first, in uniform control flow
    let fw_bary = fwidth(in.bary);
    let p = in.uv * u.params.x;
    let pix = 0.5 * (length(dpdx(p)) + length(dpdy(p)));

    let geo_n = normalize(select(in.normal, in.face_normal, u.modes.x == 1u));
    let to_eye = normalize(u.camera_pos.xyz - in.world);
    let facing = dot(geo_n, to_eye) >= 0.0;
    let n = select(-geo_n, geo_n, facing);

    var albedo = u.base_color.rgb;
    if (!facing) {
        albedo = albedo * vec3<f32>(0.75, 0.55, 0.55);
    }

    // texture pattern on the parameterization
    if (u.flags.y == 1u && u.modes.y != 0u) {
        let w = u.params.z;
        var fl = vec2<f32>(0.0);
        switch u.modes.y {
            case 1u: { fl = pattern_quad(p, pix, w); }
            case 2u: { fl = pattern_checker(p, pix); }
            case 3u: { fl = pattern_triangles(p, pix, w); }
            case 4u: { fl = pattern_hexagons(p, pix, w); }
            case 5u: {
                // twisted stripes: texture space mapped by (n -k; k n), which keeps Z^2 and
                // commutes with the half turn, so the stripes stay seamless (thesis sec. 4.2)
                let tn = f32(u.flags.w & 0xffffu);
                let tk = f32(u.flags.w >> 16u);
                let q = vec2<f32>(tn * p.x - tk * p.y, tk * p.x + tn * p.y);
                fl = pattern_stripes(q, pix * length(vec2<f32>(tn, tk)));
            }
            case 6u: { fl = pattern_octagon_square(p, pix, w); }
            case 7u: {
                let t = textureSampleGrad(pattern_tex, pattern_sampler, p, dpdx(p), dpdy(p));
                albedo = mix(albedo, t.rgb, t.a);
            }
            default: {}
        }
        // When cells shrink to a few pixels, fade to the pattern's mean value
        // instead of aliasing into moire.
        let fade = smoothstep(0.3, 0.7, pix);
        // mean ink of the lines, capped, and gone once cells are below a pixel
        let mean_line = min(2.0 * w * pix, 0.5) * (1.0 - smoothstep(0.5, 2.0, pix));
        var mean_fill = 0.0;
        switch u.modes.y {
            case 2u, 5u: { mean_fill = 0.5; }
            // square area (sqrt2 - 1)^2 per unit cell
            case 6u: { mean_fill = 0.1716; }
            // hexagon centre shading is smooth already
            case 4u: { mean_fill = fl.x; }
            default: {}
        }
        fl = mix(fl, vec2<f32>(mean_fill, mean_line), fade * f32(u.modes.y != 7u));
        let fill_tint = mix(albedo, albedo * 0.55, u.pattern_color.a);
        albedo = mix(albedo, fill_tint, fl.x);
        albedo = mix(albedo, u.pattern_color.rgb, fl.y);
    }

    // field visualisation
    if (u.flags.x == 1u && u.flags.z == 1u && dot(in.field, in.field) > 1e-12) {
        let size = vec2<i32>(textureDimensions(lic_tex));
        let px = clamp(vec2<i32>(in.clip.xy), vec2<i32>(0), size - vec2<i32>(1));
        let l = textureLoad(lic_tex, px, 0).r;
        let s = u.params2.x;
        albedo = albedo * mix(1.0, 0.35 + 1.1 * l, s);
    }

    // lighting: key light + ambient + a little specular
    let l_dir = normalize(u.light_dir.xyz);
    let diff = max(dot(n, l_dir), 0.0);
    let h = normalize(l_dir + to_eye);
    let spec = pow(max(dot(n, h), 0.0), 48.0) * 0.18;
    let fill = max(dot(n, to_eye), 0.0) * 0.25;
    var color = albedo * (u.light_dir.w + 0.75 * diff + fill) + vec3<f32>(spec);

    // wireframe from barycentric coordinates, anti-aliased with fwidth
    if (u.modes.z == 1u) {
        let dpx = in.bary / max(fw_bary, vec3<f32>(1e-7));
        let dmin = min(dpx.x, min(dpx.y, dpx.z));
        let cov = clamp(0.5 * u.params.y + 0.5 - dmin, 0.0, 1.0) * u.wire_color.a;
        color = mix(color, u.wire_color.rgb, cov);
    }

    return vec4<f32>(linear_to_srgb(clamp(color, vec3<f32>(0.0), vec3<f32>(1.0))), 1.0);
}
