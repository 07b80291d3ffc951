// Ray traversal of the voxel hierarchy and the GI shading of lumiwall's voxel GI
// (render/src/voxel/gpu.rs). The CPU reference is traverse.rs (walk, exit_face) and
// gi.rs (shade, visible), step for step.

struct Params {
    n: u32,
    levels: u32,
    count: u32,
    light_count: u32,
    vpl_count: u32,
    first: u32,              // shade: the samples [first, last) of lights then VPLs
    last: u32,
    point_count: u32,
    inv_voxel: vec4<f32>,    // x: 1 / voxel edge (1/m); positions are relative to the grid's origin
    shading: vec4<f32>,      // offset (m), VPL clamp² (m²), -, -
    offsets: array<vec4<u32>, 3>,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read> grid: array<u32>;
// trace_rays: per ray origin.xyz, t_min, dir.xyz, t_max (grid coordinates);
// shade: per pixel p, n, rho, le (n = 0: nothing); then the lights (p, n, w) and
// the VPLs (p, n, flux) in `items`
@group(0) @binding(2) var<storage, read> items: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> out: array<vec4<f32>>;
// shade: the point lights' intensity tables (points.rs)
@group(0) @binding(4) var<storage, read> tables: array<f32>;

const TABLE_W: u32 = 256u;
const TABLE_H: u32 = 128u;

// Bilinear intensity (cd) of the table at `offset` towards unit `d`, as
// points::intensity.
fn point_intensity(offset: u32, d: vec3<f32>) -> f32 {
    let w = f32(TABLE_W);
    let h = f32(TABLE_H);
    let phi = atan2(d.z, d.x);
    let theta = acos(clamp(d.y, -1.0, 1.0));
    let u = (phi / 6.283185307179586 + 0.5) * w - 0.5;
    let v = clamp(theta / 3.141592653589793 * h - 0.5, 0.0, h - 1.0);
    let u0 = floor(u);
    let v0 = floor(v);
    let fu = u - u0;
    let fv = v - v0;
    let iw = i32(TABLE_W);
    let i0 = u32(((i32(u0) % iw) + iw) % iw);
    let i1 = u32(((i32(u0) + 1) % iw + iw) % iw);
    let j0 = u32(v0);
    let j1 = min(j0 + 1u, TABLE_H - 1u);
    let top = tables[offset + j0 * TABLE_W + i0] * (1.0 - fu) + tables[offset + j0 * TABLE_W + i1] * fu;
    let bottom = tables[offset + j1 * TABLE_W + i0] * (1.0 - fu) + tables[offset + j1 * TABLE_W + i1] * fu;
    return top * (1.0 - fv) + bottom * fv;
}

// A point light's illuminance at the surfel, as gi.rs point_light.
fn point_light(sp: vec3<f32>, sn: vec3<f32>, start: vec3<f32>, lp: vec3<f32>, color: vec3<f32>, table: u32) -> vec3<f32> {
    let v = lp - sp;
    let r2 = dot(v, v);
    let r = sqrt(r2);
    let c = dot(sn, v) / r;
    if !(c > 0.0) {
        return vec3<f32>(0.0);
    }
    let o = vec3<f32>(-v.x / r, -v.y / r, -v.z / r);
    let i = point_intensity(table, o);
    if i > 0.0 && visible(start, lp + o * P.shading.x) {
        return color * (i * c / r2);
    }
    return vec3<f32>(0.0);
}

fn level_offset(level: u32) -> u32 {
    return P.offsets[level / 4u][level % 4u];
}

fn occupied(level: u32, c: vec3<u32>) -> bool {
    let m = P.n >> level;
    let i = c.x + m * (c.y + m * c.z);
    return ((grid[level_offset(level) + (i >> 5u)] >> (i & 31u)) & 1u) == 1u;
}

// (t, voxel.xyz) of the first set voxel on o + t·d, t in [t_min, t_max]; t < 0: none.
fn trace(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> vec4<f32> {
    let nf = f32(P.n);
    let n = i32(P.n);
    var inv = vec3<f32>(0.0);
    var t = t_min;
    var t_end = t_max;
    for (var a = 0u; a < 3u; a++) {
        if d[a] == 0.0 {
            if o[a] < 0.0 || o[a] > nf {
                return vec4<f32>(-1.0);
            }
            continue;
        }
        inv[a] = 1.0 / d[a];
        let ta = (0.0 - o[a]) * inv[a];
        let tb = (nf - o[a]) * inv[a];
        t = max(t, min(ta, tb));
        t_end = min(t_end, max(ta, tb));
    }
    if !(t <= t_end) {
        return vec4<f32>(-1.0);
    }
    var pi = clamp(vec3<i32>(floor(o + d * t)), vec3<i32>(0), vec3<i32>(n - 1));
    let top = P.levels - 1u;
    var level = top;
    let cap = 16u * P.n + 64u;
    for (var steps = 1u; steps <= cap; steps++) {
        let cell = vec3<u32>(pi >> vec3<u32>(level));
        if occupied(level, cell) {
            if level == 0u {
                return vec4<f32>(t, vec3<f32>(cell));
            }
            level -= 1u;
            continue;
        }
        let size = 1 << level;
        var axis = 0u;
        var bound = 0;
        var t_exit = 3.4e38;
        for (var a = 0u; a < 3u; a++) {
            if d[a] == 0.0 {
                continue;
            }
            let ci = i32(cell[a]);
            var b = ci * size;
            if d[a] > 0.0 {
                b = (ci + 1) * size;
            }
            let ta = (f32(b) - o[a]) * inv[a];
            if ta < t_exit {
                axis = a;
                bound = b;
                t_exit = ta;
            }
        }
        if t_exit > t_end {
            return vec4<f32>(-1.0);
        }
        t = max(t, t_exit);
        for (var b = 0u; b < 3u; b++) {
            let lo = i32(cell[b]) * size;
            pi[b] = clamp(i32(floor(o[b] + d[b] * t)), lo, lo + size - 1);
        }
        if d[axis] > 0.0 {
            pi[axis] = bound;
        } else {
            pi[axis] = bound - 1;
        }
        if pi[axis] < 0 || pi[axis] >= n {
            return vec4<f32>(-1.0);
        }
        if level < top && (pi[axis] >> (level + 1u)) != (i32(cell[axis]) >> 1u) {
            level += 1u;
        }
    }
    return vec4<f32>(-1.0);
}

@compute @workgroup_size(64)
fn trace_rays(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.x + id.y * groups.x * 64u;
    if i >= P.count {
        return;
    }
    let a = items[2u * i];
    let b = items[2u * i + 1u];
    out[i] = trace(a.xyz, b.xyz, a.w, b.w);
}

fn visible(a: vec3<f32>, b: vec3<f32>) -> bool {
    let inv_h = P.inv_voxel.x;
    let o = a * inv_h;
    let e = b * inv_h;
    let d = e - o;
    // the first voxel diagonal is skipped, as gi.rs visible
    let t0 = min(1.7320508 / sqrt(dot(d, d)), 0.5);
    return trace(o, d, t0, 1.0).x < 0.0;
}

fn illuminance(sp: vec3<f32>, sn: vec3<f32>, start: vec3<f32>, p: vec3<f32>, n: vec3<f32>, w: vec3<f32>, clamp2: f32) -> vec3<f32> {
    let v = p - sp;
    let r2 = dot(v, v);
    let r = sqrt(r2);
    let c = dot(sn, v) / r;
    let c2 = -dot(n, v) / r;
    if !(c > 0.0 && c2 > 0.0) {
        return vec3<f32>(0.0);
    }
    if !visible(start, p + n * P.shading.x) {
        return vec3<f32>(0.0);
    }
    return w * (c * c2 / max(r2, clamp2));
}

// One chunk of the samples (lights, then VPLs) per dispatch, added to `out`: a
// software rasteriser such as llvmpipe caps the loop iterations of one invocation
// (shade_chunk in gi.rs keeps a chunk's traversal steps under the cap).
@compute @workgroup_size(64)
fn shade(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.x + id.y * groups.x * 64u;
    if i >= P.count {
        return;
    }
    let sp = items[4u * i].xyz;
    let sn = items[4u * i + 1u].xyz;
    let rho = items[4u * i + 2u].xyz;
    let le = items[4u * i + 3u].xyz;
    var acc = vec4<f32>(le, 0.0);
    if P.first != 0u {
        acc = out[i];
    }
    if all(sn == vec3<f32>(0.0)) {
        out[i] = vec4<f32>(0.0);
        return;
    }
    let start = sp + sn * P.shading.x;
    let inv_pi = 0.31830988618379067;
    let lights = 4u * P.count;
    var e = vec3<f32>(0.0);
    var done = 0u;
    for (var k = P.first; k < P.last; k++) {
        done += 1u;
        let j = lights + 3u * k;
        if k < P.light_count {
            e += illuminance(sp, sn, start, items[j].xyz, items[j + 1u].xyz, items[j + 2u].xyz, 0.0);
        } else if k < P.light_count + P.vpl_count {
            e += illuminance(sp, sn, start, items[j].xyz, items[j + 1u].xyz, items[j + 2u].xyz * inv_pi, P.shading.y);
        } else {
            let q = lights + 3u * (P.light_count + P.vpl_count) + 2u * (k - P.light_count - P.vpl_count);
            e += point_light(sp, sn, start, items[q].xyz, items[q + 1u].xyz, u32(items[q].w));
        }
    }
    // w counts the samples summed: the host checks that no loop was cut short
    out[i] = vec4<f32>(acc.xyz + rho * inv_pi * e, acc.w + f32(done));
}
