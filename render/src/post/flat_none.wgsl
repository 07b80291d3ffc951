// Variant without a flat-field texture: no binding, no fetch, no division.
fn gain_at(px: u32, py: u32) -> vec3<f32> {
    return vec3<f32>(1.0);
}

fn div_gain(v: vec3<f32>, g: vec3<f32>) -> vec3<f32> {
    return v;
}
