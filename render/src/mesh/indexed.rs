//! [`IndexedMesh`]: shared vertex positions and triangles indexing them.

/// A triangle mesh with shared vertices. Positions are in metres; a triangle's
/// front side is the one from which its vertices appear counter-clockwise (normal
/// `(b − a) × (c − a)`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IndexedMesh {
    /// Vertex positions, metres.
    pub positions: Vec<[f64; 3]>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

impl IndexedMesh {
    /// The corner positions of triangle `t`, or `None` if `t` or one of its indices
    /// is out of range.
    pub fn triangle_positions(&self, t: usize) -> Option<[[f64; 3]; 3]> {
        let tri = self.triangles.get(t)?;
        Some([
            *self.positions.get(tri[0] as usize)?,
            *self.positions.get(tri[1] as usize)?,
            *self.positions.get(tri[2] as usize)?,
        ])
    }

    /// All triangles as corner positions (skipping ones with invalid indices), e.g.
    /// for [`super::Bvh::build`].
    pub fn triangle_soup(&self) -> Vec<[[f64; 3]; 3]> {
        (0..self.triangles.len())
            .filter_map(|t| self.triangle_positions(t))
            .collect()
    }

    /// Unnormalised normal (b − a) × (c − a) of triangle `t`; its length is twice the
    /// area in m².
    pub fn triangle_normal(&self, t: usize) -> Option<[f64; 3]> {
        self.triangle_positions(t).map(|p| tri_normal(&p))
    }

    /// Area of triangle `t` in m².
    pub fn triangle_area_m2(&self, t: usize) -> Option<f64> {
        self.triangle_normal(t).map(|n| 0.5 * len(n))
    }

    /// Total area of all valid triangles, m².
    pub fn total_area_m2(&self) -> f64 {
        (0..self.triangles.len())
            .filter_map(|t| self.triangle_area_m2(t))
            .sum()
    }
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub(crate) fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(crate) fn len(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
pub(crate) fn tri_normal(p: &[[f64; 3]; 3]) -> [f64; 3] {
    cross(sub(p[1], p[0]), sub(p[2], p[0]))
}
