//! Small geometric helpers on planar polygons.

/// A 3-vector in metres (positions) or a direction.
pub type V3 = nalgebra::Vector3<f64>;

/// Area-weighted normal (Newell's method): its length is the
/// polygon's area in m² and its direction the unit normal (right-hand winding).
pub(super) fn newell(vertices: &[V3]) -> V3 {
    let mut n = V3::zeros();
    let k = vertices.len();
    for i in 0..k {
        let a = vertices[i];
        let b = vertices[(i + 1) % k];
        n += a.cross(&b);
    }
    n * 0.5
}

/// Area of a planar polygon in m².
pub fn polygon_area_m2(vertices: &[V3]) -> f64 {
    newell(vertices).norm()
}

/// Unit normal of a planar polygon (right-hand winding), `None` when degenerate.
pub fn polygon_normal(vertices: &[V3]) -> Option<V3> {
    let n = newell(vertices);
    let len = n.norm();
    if len > 0.0 && len.is_finite() {
        Some(n / len)
    } else {
        None
    }
}
