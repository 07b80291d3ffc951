// lumiwall post pass: XYZ (cd/m²) → display code values, one invocation per pixel.
// Same arithmetic as lumiwall_profiles::apply (the scalar reference) and post::cpu.
// The flat-field part (`gain_at`, `div_gain`) is appended by the host: one variant
// reads the texture, the other has no texture binding at all.

// Mirrors `struct Params` in gpu.rs field by field (m0..m2 = its `m`, pad0/pad1 = its
// `pad`); change both together.
struct Params {
    m0: vec4<f32>,
    m1: vec4<f32>,
    m2: vec4<f32>,
    offset: vec4<f32>,
    white_dir: vec4<f32>,
    white_u: vec4<f32>,
    white_k: vec4<f32>,
    lut_scale: vec4<f32>,
    lut_len: vec4<u32>,
    lut_base: vec4<u32>,
    lut_slope: vec4<u32>,
    width: u32,
    height: u32,
    row0: u32,
    npix: u32,
    max_code: u32,
    dither: u32,
    false_colour: u32,
    flat_w: u32,
    flat_h: u32,
    max_input: f32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> p: Params;
@group(0) @binding(1) var<storage, read> xyz_in: array<f32>;
@group(0) @binding(2) var<storage, read> lut: array<f32>;
@group(0) @binding(3) var<storage, read_write> codes: array<u32>;

const F_OOG: u32 = 1u;
const F_OVER: u32 = 2u;
const F_INVALID: u32 = 4u;
const F_BELOW: u32 = 8u;
// lumiwall_profiles::apply::GAMUT_TOLERANCE
const TOL: f32 = 1.0e-5;

fn non_finite(v: f32) -> bool {
    // Bit test: shader compilers may assume finite maths and fold `v != v`.
    return (bitcast<u32>(v) & 0x7f800000u) == 0x7f800000u;
}

fn drive_for(c: u32, a: f32) -> f32 {
    let n = p.lut_len[c];
    let t = clamp(a, 0.0, 1.0) * p.lut_scale[c];
    let i = min(u32(t), n - 2u);
    let f = t - f32(i);
    return lut[p.lut_base[c] + i] + lut[p.lut_slope[c] + i] * f;
}

fn drives(a: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(drive_for(0u, a.x), drive_for(1u, a.y), drive_for(2u, a.z));
}

fn bayer(x: u32, y: u32) -> f32 {
    let z = x ^ y;
    var v = 0u;
    for (var i = 0u; i < 4u; i = i + 1u) {
        let b = ((z >> i) & 1u) * 2u + ((y >> i) & 1u);
        v = v | (b << (2u * (3u - i)));
    }
    return (f32(v) + 0.5) / 256.0;
}

fn quantise(d: f32, thr: f32) -> u32 {
    let v = d * f32(p.max_code) + thr;
    return min(u32(max(v, 0.0)), p.max_code);
}

struct Out {
    drive: vec3<f32>,
    flags: u32,
}

// The white-segment step: a display's white segment taken out of the channel intensities (u = 0,
// k = 1 for an additive display: then a − 0·s = a exactly).
fn white_step(a: vec3<f32>) -> vec3<f32> {
    let u = p.white_u.xyz;
    let k = p.white_k.xyz;
    let s = max(min(min(a.x * k.x, a.y * k.y), a.z * k.z), 0.0);
    return vec3<f32>(a.x - u.x * s, a.y - u.y * s, a.z - u.z * s);
}

// The linear form of white_step in the region of a = v + offset, applied to v.
fn white_region(v: vec3<f32>, a: vec3<f32>) -> vec3<f32> {
    let u = p.white_u.xyz;
    let k = p.white_k.xyz;
    let t = vec3<f32>(a.x * k.x, a.y * k.y, a.z * k.z);
    var j = 2u;
    if (t.x <= t.y && t.x <= t.z) {
        j = 0u;
    } else if (t.y <= t.z) {
        j = 1u;
    }
    if (t[j] <= 0.0) {
        return v;
    }
    let r = v[j] * k[j];
    return vec3<f32>(v.x - u.x * r, v.y - u.y * r, v.z - u.z * r);
}

fn invalid_out() -> Out {
    if (p.false_colour != 0u) {
        return Out(vec3<f32>(1.0, 1.0, 0.0), F_INVALID);
    }
    return Out(drives(clamp(white_step(p.offset.xyz), vec3<f32>(0.0), vec3<f32>(1.0))), F_INVALID);
}

fn post(xyz_raw: vec3<f32>, g: vec3<f32>) -> Out {
    if (non_finite(xyz_raw.x) || non_finite(xyz_raw.y) || non_finite(xyz_raw.z)) {
        return invalid_out();
    }
    var flags = 0u;
    var xyz = xyz_raw;
    let big = max(abs(xyz.x), max(abs(xyz.y), abs(xyz.z)));
    if (big > p.max_input) {
        let k = p.max_input / big;
        xyz = vec3<f32>(xyz.x * k, xyz.y * k, xyz.z * k);
    }
    var m = vec3<f32>(
        p.m0.x * xyz.x + p.m0.y * xyz.y + p.m0.z * xyz.z,
        p.m1.x * xyz.x + p.m1.y * xyz.y + p.m1.z * xyz.z,
        p.m2.x * xyz.x + p.m2.y * xyz.y + p.m2.z * xyz.z,
    );
    m = div_gain(m, g);
    let off = p.offset.xyz;
    var a = white_step(m + off);
    let fast = all(a >= vec3<f32>(0.0)) && all(a <= vec3<f32>(1.0));
    if (!fast) {
        if (any(a < vec3<f32>(-TOL))) {
            let lum = xyz.y;
            if (lum > 0.0) {
                let mw = div_gain(lum * p.white_dir.xyz, g);
                var t = 0.0;
                for (var c = 0u; c < 3u; c = c + 1u) {
                    let aw = mw[c] + off[c];
                    if (a[c] < -TOL) {
                        if (aw >= 0.0) {
                            t = max(t, -a[c] / (aw - a[c]));
                        } else {
                            flags = flags | F_BELOW;
                        }
                    }
                }
                if (t > 0.0) {
                    flags = flags | F_OOG;
                    let tt = min(t, 1.0);
                    m = m + tt * (mw - m);
                }
            } else {
                if (any(xyz != vec3<f32>(0.0))) {
                    flags = flags | F_OOG;
                }
                if (any(off < vec3<f32>(0.0))) {
                    flags = flags | F_BELOW;
                }
                m = vec3<f32>(0.0);
            }
            a = white_step(m + off);
        }
        if (any(a > vec3<f32>(1.0 + TOL))) {
            flags = flags | F_OVER;
            let a_pre = m + off;
            let mr = white_region(m, a_pre);
            let offr = white_region(off, a_pre);
            var s = 1.0;
            for (var c = 0u; c < 3u; c = c + 1u) {
                if (a[c] > 1.0) {
                    var sc = 0.0;
                    if (mr[c] > 0.0) {
                        sc = max((1.0 - offr[c]) / mr[c], 0.0);
                    }
                    s = min(s, sc);
                }
            }
            a = s * mr + offr;
        }
        a = clamp(a, vec3<f32>(0.0), vec3<f32>(1.0));
        if (p.false_colour != 0u) {
            if ((flags & F_OOG) != 0u) {
                return Out(vec3<f32>(1.0, 0.0, 1.0), flags);
            }
            if ((flags & F_OVER) != 0u) {
                return Out(vec3<f32>(0.0, 1.0, 1.0), flags);
            }
        }
    }
    return Out(drives(a), flags);
}

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = gid.x + gid.y * nwg.x * 256u;
    if (i >= p.npix) {
        return;
    }
    let px = i % p.width;
    let py = p.row0 + i / p.width;
    let xyz = vec3<f32>(xyz_in[3u * i], xyz_in[3u * i + 1u], xyz_in[3u * i + 2u]);
    let o = post(xyz, gain_at(px, py));
    var thr = 0.5;
    if (p.dither != 0u) {
        thr = bayer(px, py);
    }
    let r = quantise(o.drive.x, thr);
    let gc = quantise(o.drive.y, thr);
    let b = quantise(o.drive.z, thr);
    codes[2u * i] = r | (gc << 16u);
    codes[2u * i + 1u] = b | (o.flags << 16u);
}
