// Variant with a flat-field texture: bilinear, along v first, then u (as the CPU path).
@group(0) @binding(4) var<storage, read> flat: array<f32>;

fn texel(x: u32, y: u32) -> vec3<f32> {
    let k = 3u * (y * p.flat_w + x);
    return vec3<f32>(flat[k], flat[k + 1u], flat[k + 2u]);
}

fn axis(pos: f32, size: u32) -> vec3<f32> {
    let last = size - 1u;
    let x = clamp(pos * f32(size) - 0.5, 0.0, f32(last));
    let i0 = min(u32(x), last);
    let i1 = min(i0 + 1u, last);
    return vec3<f32>(f32(i0), f32(i1), x - f32(i0));
}

fn gain_at(px: u32, py: u32) -> vec3<f32> {
    let u = (f32(px) + 0.5) / f32(p.width);
    let v = (f32(py) + 0.5) / f32(p.height);
    let ax = axis(u, p.flat_w);
    let ay = axis(v, p.flat_h);
    let x0 = u32(ax.x);
    let x1 = u32(ax.y);
    let y0 = u32(ay.x);
    let y1 = u32(ay.y);
    let a0 = texel(x0, y0);
    let c0 = a0 + (texel(x0, y1) - a0) * ay.z;
    let a1 = texel(x1, y0);
    let c1 = a1 + (texel(x1, y1) - a1) * ay.z;
    return c0 + (c1 - c0) * ax.z;
}

fn div_gain(v: vec3<f32>, g: vec3<f32>) -> vec3<f32> {
    return v / g;
}
