//! Row-major 3×3 f64 matrices as stored in profiles (`[[f64; 3]; 3]`), with the few
//! operations the profile maths needs, and the bridge to nalgebra for the solvers.

use nalgebra::Matrix3;

/// A row-major 3×3 matrix, `m[row][col]`, as profiles store it.
pub type Mat3 = [[f64; 3]; 3];

/// Reciprocal condition estimate (|det| / product of row norms) below which a matrix is
/// treated as singular by [`inverse`].
pub const SINGULAR_RCOND: f64 = 1e-12;

/// `m · v`.
pub fn mul_vec(m: &Mat3, v: &[f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// `a · b`.
pub fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

/// Determinant.
pub fn det(m: &Mat3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Inverse by the adjugate, `None` when the matrix is singular or so ill-conditioned
/// that the reciprocal condition estimate is below [`SINGULAR_RCOND`], or the result is
/// not finite.
pub fn inverse(m: &Mat3) -> Option<Mat3> {
    let d = det(m);
    let norms: f64 = m
        .iter()
        .map(|r| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt())
        .product();
    if !(d.is_finite() && norms > 0.0) || d.abs() < SINGULAR_RCOND * norms {
        return None;
    }
    let c =
        |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let adj = [
        [c(1, 1, 2, 2), -c(0, 1, 2, 2), c(0, 1, 1, 2)],
        [-c(1, 0, 2, 2), c(0, 0, 2, 2), -c(0, 0, 1, 2)],
        [c(1, 0, 2, 1), -c(0, 0, 2, 1), c(0, 0, 1, 1)],
    ];
    let inv = adj.map(|row| row.map(|v| v / d));
    inv.iter().flatten().all(|v| v.is_finite()).then_some(inv)
}

/// Matrix whose columns are `cols[0]`, `cols[1]`, `cols[2]`.
pub fn from_columns(cols: &[[f64; 3]; 3]) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (j, col) in cols.iter().enumerate() {
        for (i, v) in col.iter().enumerate() {
            m[i][j] = *v;
        }
    }
    m
}

/// As a nalgebra matrix (same rows and columns).
pub fn to_matrix3(m: &Mat3) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| m[i][j])
}

/// From a nalgebra matrix (same rows and columns).
pub fn from_matrix3(m: &Matrix3<f64>) -> Mat3 {
    [0, 1, 2].map(|i| [0, 1, 2].map(|j| m[(i, j)]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_times_matrix_is_identity() {
        let m = [
            [0.4124, 0.3576, 0.1805],
            [0.2126, 0.7152, 0.0722],
            [0.0193, 0.1192, 0.9505],
        ];
        let inv = inverse(&m).unwrap();
        let p = mul(&m, &inv);
        for (i, row) in p.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((v - e).abs() < 1e-12, "{p:?}");
            }
        }
        // Published sRGB XYZ→RGB first row (IEC 61966-2-1): 3.2406, −1.5372, −0.4986.
        assert!((inv[0][0] - 3.2406).abs() < 2e-3 && (inv[0][1] + 1.5372).abs() < 2e-3);
    }

    #[test]
    fn singular_and_near_singular_are_refused() {
        let m = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 1.0]];
        assert!(inverse(&m).is_none());
        let eps = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0 + 1e-14], [0.0, 1.0, 1.0]];
        assert!(inverse(&eps).is_none());
        let nan = [[f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert!(inverse(&nan).is_none());
    }
}
