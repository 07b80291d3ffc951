//! [`IntensityDistribution`]: luminous intensity in cd over the directions of a
//! luminaire's local frame, as an analytic law (isotropic, spot) or a goniometric
//! table in (C, γ) with bilinear interpolation.

use super::error::PhotometryError;
use super::frame::normalize;
use std::f64::consts::{PI, TAU};

/// Horizontal (C-plane) symmetry of tabulated photometric data, used to unfold a
/// reduced table into a full 0°–360° one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CSymmetry {
    /// Data for all C planes.
    None,
    /// One C plane, rotationally symmetric about the photometric axis.
    Rotational,
    /// Mirror symmetric about the C0–C180 plane: I(C) = I(360° − C).
    PlaneC0C180,
    /// Mirror symmetric about the C90–C270 plane: I(C) = I(180° − C).
    PlaneC90C270,
    /// Symmetric about both planes (quadrant data).
    Quadrant,
}

impl CSymmetry {
    fn images(self, c: f64) -> Vec<f64> {
        let raw = match self {
            CSymmetry::None | CSymmetry::Rotational => vec![c],
            CSymmetry::PlaneC0C180 => vec![c, -c],
            CSymmetry::PlaneC90C270 => vec![c, 180.0 - c],
            CSymmetry::Quadrant => vec![c, -c, 180.0 - c, 180.0 + c],
        };
        raw.into_iter().map(wrap_deg).collect()
    }
}

fn wrap_deg(c: f64) -> f64 {
    let w = c.rem_euclid(360.0);
    if (360.0 - w).abs() < 1e-9 { 0.0 } else { w }
}

const ANGLE_TOL_DEG: f64 = 1e-6;

/// A goniometric table unfolded to full C coverage.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct GonioTable {
    /// C angles in radians, strictly increasing in [0, 2π).
    c_rad: Vec<f64>,
    /// γ angles in radians, strictly increasing in [0, π]; outside this range I = 0.
    gamma_rad: Vec<f64>,
    /// Intensities in cd, `cd[ic * gamma.len() + ig]`.
    cd: Vec<f64>,
}

impl GonioTable {
    /// Builds a table from reduced data and its symmetry. `c_deg` and the rows of
    /// `cd_rows` (one per C angle, each `gamma_deg.len()` long) are as given in a file.
    pub(crate) fn unfold(
        c_deg: &[f64],
        gamma_deg: &[f64],
        cd_rows: &[Vec<f64>],
        symmetry: CSymmetry,
    ) -> Result<Self, PhotometryError> {
        if gamma_deg.is_empty() || c_deg.is_empty() || cd_rows.len() != c_deg.len() {
            return Err(PhotometryError::InvalidParameter(
                "a goniometric table needs at least one C and one γ angle and one row per C angle"
                    .into(),
            ));
        }
        check_increasing(gamma_deg, "γ")?;
        if gamma_deg[0] < -ANGLE_TOL_DEG || gamma_deg[gamma_deg.len() - 1] > 180.0 + ANGLE_TOL_DEG {
            return Err(PhotometryError::InvalidParameter(format!(
                "γ angles must lie in [0°, 180°], got {}° … {}°",
                gamma_deg[0],
                gamma_deg[gamma_deg.len() - 1]
            )));
        }
        for row in cd_rows {
            if row.len() != gamma_deg.len() {
                return Err(PhotometryError::InvalidParameter(
                    "every C plane needs one intensity per γ angle".into(),
                ));
            }
            if let Some(bad) = row.iter().find(|v| !v.is_finite() || **v < 0.0) {
                return Err(PhotometryError::InvalidParameter(format!(
                    "luminous intensities must be finite and ≥ 0 cd, found {bad}"
                )));
            }
        }
        let gamma_rad: Vec<f64> = gamma_deg
            .iter()
            .map(|g| g.clamp(0.0, 180.0).to_radians())
            .collect();
        if symmetry == CSymmetry::Rotational || c_deg.len() == 1 {
            return Ok(Self {
                c_rad: vec![0.0],
                gamma_rad,
                cd: cd_rows[0].clone(),
            });
        }
        check_increasing(c_deg, "C")?;
        let given: Vec<f64> = c_deg.iter().map(|c| wrap_deg(*c)).collect();
        let mut full: Vec<f64> = given.iter().flat_map(|c| symmetry.images(*c)).collect();
        full.sort_by(f64::total_cmp);
        full.dedup_by(|a, b| (*a - *b).abs() < ANGLE_TOL_DEG);
        let ng = gamma_deg.len();
        let mut cd = Vec::with_capacity(full.len() * ng);
        for c in &full {
            let source = symmetry
                .images(*c)
                .into_iter()
                .find_map(|img| given.iter().position(|g| ang_close(*g, img)))
                .ok_or_else(|| {
                    PhotometryError::InvalidParameter(format!(
                        "C angle {c}° has no mirror image among the given C planes; the declared symmetry does not match the angles"
                    ))
                })?;
            cd.extend_from_slice(&cd_rows[source]);
        }
        Ok(Self {
            c_rad: full.iter().map(|c| c.to_radians()).collect(),
            gamma_rad,
            cd,
        })
    }

    fn ng(&self) -> usize {
        self.gamma_rad.len()
    }

    fn value(&self, ic: usize, gamma: f64) -> f64 {
        let g = &self.gamma_rad;
        let row = &self.cd[ic * self.ng()..(ic + 1) * self.ng()];
        if gamma < g[0] - 1e-12 || gamma > g[g.len() - 1] + 1e-12 {
            return 0.0;
        }
        if g.len() == 1 {
            return row[0];
        }
        let k = g.partition_point(|x| *x <= gamma).clamp(1, g.len() - 1);
        let (g0, g1) = (g[k - 1], g[k]);
        let t = ((gamma - g0) / (g1 - g0)).clamp(0.0, 1.0);
        row[k - 1] * (1.0 - t) + row[k] * t
    }

    fn intensity(&self, c: f64, gamma: f64) -> f64 {
        let cs = &self.c_rad;
        let n = cs.len();
        if n == 1 {
            return self.value(0, gamma);
        }
        let k = cs.partition_point(|x| *x <= c);
        let (i0, i1, c0, c1) = if k == 0 || k == n {
            let c_rel = if k == 0 { c + TAU } else { c };
            let t_c0 = cs[n - 1];
            let t_c1 = cs[0] + TAU;
            return lerp_c(self, n - 1, 0, t_c0, t_c1, c_rel, gamma);
        } else {
            (k - 1, k, cs[k - 1], cs[k])
        };
        lerp_c(self, i0, i1, c0, c1, c, gamma)
    }

    /// ∫∫ I sin γ dγ dC of the bilinear interpolant, exactly.
    fn flux(&self) -> f64 {
        let n = self.c_rad.len();
        let ng = self.ng();
        let g = &self.gamma_rad;
        let row_integral = |ic: usize| -> f64 {
            let row = &self.cd[ic * ng..(ic + 1) * ng];
            let mut s = 0.0;
            for k in 1..ng {
                let (a, b) = (g[k - 1], g[k]);
                let (fa, fb) = (row[k - 1], row[k]);
                let h = b - a;
                if h <= 0.0 {
                    continue;
                }
                s += fa * (a.cos() - b.cos()) + (fb - fa) / h * (b.sin() - a.sin() - h * b.cos());
            }
            s
        };
        if n == 1 {
            return TAU * row_integral(0);
        }
        (0..n)
            .map(|i| {
                let prev = if i == 0 {
                    self.c_rad[n - 1] - TAU
                } else {
                    self.c_rad[i - 1]
                };
                let next = if i + 1 == n {
                    self.c_rad[0] + TAU
                } else {
                    self.c_rad[i + 1]
                };
                0.5 * (next - prev) * row_integral(i)
            })
            .sum()
    }

    fn max_cd(&self) -> f64 {
        self.cd.iter().copied().fold(0.0, f64::max)
    }

    /// Largest node value whose direction lies within `half_angle` (+ one cell) of
    /// `axis_local`. Bilinear interpolation never exceeds its cell's corners, so this
    /// bounds I over the cone.
    fn max_in_cone(&self, axis_local: [f64; 3], half_angle: f64) -> f64 {
        let max_step = |v: &[f64], wrap: bool| -> f64 {
            let mut m: f64 = 0.0;
            for w in v.windows(2) {
                m = m.max(w[1] - w[0]);
            }
            if wrap && !v.is_empty() {
                m = m.max(v[0] + TAU - v[v.len() - 1]);
            }
            m
        };
        let slack = max_step(&self.gamma_rad, false)
            + if self.c_rad.len() > 1 {
                max_step(&self.c_rad, true)
            } else {
                0.0
            };
        let limit = (half_angle + slack).min(PI);
        let cos_limit = limit.cos();
        let ng = self.ng();
        let axis_gamma = (-axis_local[2]).clamp(-1.0, 1.0).acos();
        let mut best: f64 = 0.0;
        for (ic, c) in self.c_rad.iter().enumerate() {
            for (ig, gam) in self.gamma_rad.iter().enumerate() {
                let inside = if self.c_rad.len() == 1 {
                    // rotationally symmetric: the closest direction at this γ is at the axis's C
                    (gam - axis_gamma).abs() <= limit
                } else {
                    let dir = direction_of(*c, *gam);
                    dir[0] * axis_local[0] + dir[1] * axis_local[1] + dir[2] * axis_local[2]
                        >= cos_limit
                };
                if inside {
                    best = best.max(self.cd[ic * ng + ig]);
                }
            }
        }
        best
    }
}

fn lerp_c(t: &GonioTable, i0: usize, i1: usize, c0: f64, c1: f64, c: f64, gamma: f64) -> f64 {
    let w = if c1 > c0 {
        ((c - c0) / (c1 - c0)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    t.value(i0, gamma) * (1.0 - w) + t.value(i1, gamma) * w
}

fn ang_close(a: f64, b: f64) -> bool {
    let d = (a - b).rem_euclid(360.0);
    d < ANGLE_TOL_DEG || 360.0 - d < ANGLE_TOL_DEG
}

fn check_increasing(v: &[f64], what: &str) -> Result<(), PhotometryError> {
    if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
        return Err(PhotometryError::InvalidParameter(format!(
            "{what} angle {bad} is not a number"
        )));
    }
    // steps below the angle tolerance make the interpolation and the flux integral
    // divide by (nearly) zero
    if v.windows(2).any(|w| w[1] - w[0] < ANGLE_TOL_DEG) {
        return Err(PhotometryError::InvalidParameter(format!(
            "{what} angles must be strictly increasing, each by at least {ANGLE_TOL_DEG}°"
        )));
    }
    Ok(())
}

/// Local unit direction for photometric angles (radians): γ from the nadir (−z),
/// C counter-clockwise from +x.
fn direction_of(c: f64, gamma: f64) -> [f64; 3] {
    let s = gamma.sin();
    [s * c.cos(), s * c.sin(), -gamma.cos()]
}

#[derive(Debug, Clone, PartialEq)]
enum Shape {
    Isotropic { cd: f64 },
    Spot { cd: f64, inner: f64, outer: f64 },
    Table(GonioTable),
}

/// Luminous intensity (cd) over directions in the luminaire's local frame.
///
/// Local frame: −z is the nadir (γ = 0°, the photometric axis of a downlight), +x is
/// C = 0°, +y is C = 90°; see [`super::LightFrame`] for placing it in the world.
/// Tabulated data (IES LM-63 type C, EULUMDAT) are unfolded to full C coverage at load
/// time and interpolated bilinearly in (C, γ); directions outside the measured γ range
/// have zero intensity.
#[derive(Debug, Clone, PartialEq)]
pub struct IntensityDistribution {
    shape: Shape,
    scale: f64,
    declared_flux_lm: Option<f64>,
    rated_lamp_flux_lm: Option<f64>,
    name: String,
}

/// Where an [`IntensityDistribution`] came from (for reports).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PhotometricSource {
    /// Isotropic point source.
    Isotropic,
    /// Analytic spot.
    Spot,
    /// Goniometric table (IES, EULUMDAT or code).
    Table,
}

impl IntensityDistribution {
    /// Isotropic point source of `intensity_cd` in every direction (flux 4π·I lm).
    /// Negative or non-finite intensities are taken as 0.
    pub fn isotropic(intensity_cd: f64) -> Self {
        Self::with_shape(
            Shape::Isotropic {
                cd: sanitize(intensity_cd),
            },
            "isotropic",
        )
    }

    /// Spot aimed along the local −z axis: `intensity_cd` inside the inner half angle,
    /// a smooth (cubic Hermite in cos γ) fall-off to 0 at the outer half angle, dark
    /// beyond. Angles are clamped to [0, π] and the inner angle to at most the outer.
    pub fn spot(intensity_cd: f64, inner_half_angle_rad: f64, outer_half_angle_rad: f64) -> Self {
        let clamp = |a: f64| if a.is_finite() { a.clamp(0.0, PI) } else { 0.0 };
        let outer = clamp(outer_half_angle_rad);
        let inner = clamp(inner_half_angle_rad).min(outer);
        Self::with_shape(
            Shape::Spot {
                cd: sanitize(intensity_cd),
                inner,
                outer,
            },
            "spot",
        )
    }

    /// A full goniometric table without symmetry: `c_deg` (strictly increasing,
    /// within [0°, 360°], 360° optional), `gamma_deg` (strictly increasing within
    /// [0°, 180°]) and `cd[ic * gamma_deg.len() + ig]` in cd.
    pub fn from_c_gamma_table(
        c_deg: &[f64],
        gamma_deg: &[f64],
        cd: &[f64],
    ) -> Result<Self, PhotometryError> {
        let ng = gamma_deg.len();
        if ng == 0 || cd.len() != c_deg.len() * ng {
            return Err(PhotometryError::InvalidParameter(format!(
                "table has {} values but {} C × {} γ angles",
                cd.len(),
                c_deg.len(),
                ng
            )));
        }
        let rows: Vec<Vec<f64>> = cd.chunks(ng).map(<[f64]>::to_vec).collect();
        let table = GonioTable::unfold(c_deg, gamma_deg, &rows, CSymmetry::None)?;
        Ok(Self::with_shape(Shape::Table(table), "table"))
    }

    pub(crate) fn from_table(
        table: GonioTable,
        name: String,
        declared_flux_lm: Option<f64>,
        rated_lamp_flux_lm: Option<f64>,
    ) -> Self {
        Self {
            shape: Shape::Table(table),
            scale: 1.0,
            declared_flux_lm,
            rated_lamp_flux_lm,
            name,
        }
    }

    fn with_shape(shape: Shape, name: &str) -> Self {
        Self {
            shape,
            scale: 1.0,
            declared_flux_lm: None,
            rated_lamp_flux_lm: None,
            name: name.into(),
        }
    }

    /// Parses an IES LM-63 file (1986, -1991, -1995 and -2002 layouts).
    ///
    /// Reads keyword lines (`[LUMINAIRE]` becomes [`Self::name`]), `TILT=NONE` and
    /// `TILT=INCLUDE` (the factor at 0° tilt is applied: the luminaire is assumed
    /// mounted as measured), photometric type C with every horizontal symmetry LM-63
    /// defines (rotational, 0–90°, 0–180°, 90–270°, full) and vertical ranges 0–90°,
    /// 90–180°, 0–180°. Candela values are multiplied by the candela multiplier, the
    /// ballast factor and the ballast-lamp factor. Types A and B and `TILT=<file>`
    /// give [`PhotometryError::Unsupported`]; truncated or garbled data give
    /// [`PhotometryError::Truncated`] / [`PhotometryError::Parse`] with the line.
    pub fn from_ies_lm63(text: &str) -> Result<Self, PhotometryError> {
        super::ies::parse(text)
    }

    /// Parses a EULUMDAT (.ldt) file, all symmetry indicators 0–4 (0 none,
    /// 1 rotational, 2 about C0–C180, 3 about C90–C270, 4 both). Intensities in
    /// cd/1000 lm become cd with the first lamp set's flux (× the conversion factor
    /// of line 24 when > 0); [`Self::declared_flux_lm`] is that flux × LORL. C angles
    /// are taken counter-clockwise seen from above, like IES type C. Decimal commas
    /// are accepted.
    pub fn from_eulumdat(text: &str) -> Result<Self, PhotometryError> {
        super::eulumdat::parse(text)
    }

    /// Luminous intensity in cd towards `dir_local` (need not be normalised; a zero
    /// or non-finite vector gives 0). Frame: −z = nadir, +x = C0°, +y = C90°.
    pub fn intensity_cd(&self, dir_local: [f64; 3]) -> f64 {
        let Some(d) = normalize(dir_local) else {
            return 0.0;
        };
        let gamma = (-d[2]).clamp(-1.0, 1.0).acos();
        let raw = match &self.shape {
            Shape::Isotropic { cd } => *cd,
            Shape::Spot { cd, inner, outer } => cd * spot_falloff(gamma, *inner, *outer),
            Shape::Table(t) => {
                let c = d[1].atan2(d[0]).rem_euclid(TAU);
                t.intensity(c, gamma)
            }
        };
        raw * self.scale
    }

    /// Total luminous flux in lm: the integral of I over the sphere (exact for the
    /// bilinear interpolant of a table; composite Gauss–Legendre in γ for analytic shapes).
    pub fn total_flux_lm(&self) -> f64 {
        let raw = match &self.shape {
            Shape::Isotropic { cd } => {
                let f = |_g: f64| *cd;
                TAU * integrate_sin(&f, &[0.0, PI])
            }
            Shape::Spot { cd, inner, outer } => {
                let f = |g: f64| cd * spot_falloff(g, *inner, *outer);
                TAU * integrate_sin(&f, &[0.0, *inner, *outer])
            }
            Shape::Table(t) => t.flux(),
        };
        raw * self.scale
    }

    /// The same shape scaled so that its total flux is `flux_lm`. A distribution
    /// with zero flux (all dark) is returned unchanged, as is a non-finite or
    /// negative target.
    pub fn scaled_to_flux(mut self, flux_lm: f64) -> Self {
        let current = self.total_flux_lm();
        if current > 0.0 && current.is_finite() && flux_lm.is_finite() && flux_lm >= 0.0 {
            self.scale *= flux_lm / current;
        }
        self
    }

    /// The same shape with every intensity multiplied by `factor` (≥ 0).
    pub fn scaled_by(mut self, factor: f64) -> Self {
        if factor.is_finite() && factor >= 0.0 {
            self.scale *= factor;
        }
        self
    }

    /// Largest intensity over all directions, cd.
    pub fn max_intensity_cd(&self) -> f64 {
        let raw = match &self.shape {
            Shape::Isotropic { cd } | Shape::Spot { cd, .. } => *cd,
            Shape::Table(t) => t.max_cd(),
        };
        raw * self.scale
    }

    /// An upper bound of the intensity (cd) over the cone of directions within
    /// `half_angle_rad` of `axis_local` (for form-factor bounds). Conservative: it
    /// may exceed the true maximum by up to one table cell's variation.
    pub fn max_intensity_in_cone_cd(&self, axis_local: [f64; 3], half_angle_rad: f64) -> f64 {
        let Some(axis) = normalize(axis_local) else {
            return self.max_intensity_cd();
        };
        let half = if half_angle_rad.is_finite() {
            half_angle_rad.max(0.0)
        } else {
            PI
        };
        let raw = match &self.shape {
            Shape::Isotropic { cd } => *cd,
            Shape::Spot { cd, inner, outer } => {
                let axis_gamma = (-axis[2]).clamp(-1.0, 1.0).acos();
                let nearest = (axis_gamma - half).max(0.0);
                cd * spot_falloff(nearest, *inner, *outer)
            }
            Shape::Table(t) => t.max_in_cone(axis, half),
        };
        raw * self.scale
    }

    /// Flux declared in the file header, lm, where the file states one: IES
    /// lamps × lumens per lamp (absolute photometry: none), EULUMDAT lamp flux of
    /// the first lamp set × light output ratio. Scaling does not change it.
    pub fn declared_flux_lm(&self) -> Option<f64> {
        self.declared_flux_lm
    }

    /// Rated lamp flux the file's intensities refer to (relative photometry), lm:
    /// IES lamps × lumens per lamp, EULUMDAT first lamp set. `None` for absolute
    /// photometry and analytic shapes.
    pub fn rated_lamp_flux_lm(&self) -> Option<f64> {
        self.rated_lamp_flux_lm
    }

    /// The same luminaire fitted with lamps of total flux `lamp_flux_lm` instead of
    /// the rated one: intensities scale by `lamp_flux_lm / rated`. Errors for
    /// distributions without a rated lamp flux and for a non-positive target.
    pub fn with_lamp_flux_lm(self, lamp_flux_lm: f64) -> Result<Self, PhotometryError> {
        let Some(rated) = self.rated_lamp_flux_lm.filter(|r| *r > 0.0) else {
            return Err(PhotometryError::InvalidParameter(format!(
                "'{}' has no rated lamp flux (absolute photometry or analytic); use scaled_to_flux instead",
                self.name
            )));
        };
        if !(lamp_flux_lm.is_finite() && lamp_flux_lm > 0.0) {
            return Err(PhotometryError::InvalidParameter(format!(
                "lamp flux must be a positive number of lm, got {lamp_flux_lm}"
            )));
        }
        Ok(self.scaled_by(lamp_flux_lm / rated))
    }

    /// What kind of distribution this is.
    pub fn source(&self) -> PhotometricSource {
        match self.shape {
            Shape::Isotropic { .. } => PhotometricSource::Isotropic,
            Shape::Spot { .. } => PhotometricSource::Spot,
            Shape::Table(_) => PhotometricSource::Table,
        }
    }

    /// A short name (luminaire name from the file, or the analytic kind).
    pub fn name(&self) -> &str {
        &self.name
    }
}

fn sanitize(v: f64) -> f64 {
    if v.is_finite() && v > 0.0 { v } else { 0.0 }
}

fn spot_falloff(gamma: f64, inner: f64, outer: f64) -> f64 {
    if gamma <= inner {
        1.0
    } else if gamma >= outer {
        0.0
    } else {
        let (ci, co) = (inner.cos(), outer.cos());
        let t = ((gamma.cos() - co) / (ci - co)).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    }
}

/// ∫ f(γ) sin γ dγ from `breaks[0]` to π, composite 4-point Gauss–Legendre between
/// the breaks (never evaluated exactly at a break, where f may jump).
/// Nodes of the 4-point Gauss–Legendre rule on [−1, 1].
pub(crate) const GAUSS_LEGENDRE_4_NODES: [f64; 4] = [
    -0.861_136_311_594_052_6,
    -0.339_981_043_584_856_3,
    0.339_981_043_584_856_3,
    0.861_136_311_594_052_6,
];

/// Weights of the 4-point Gauss–Legendre rule on [−1, 1] (they sum to 2).
pub(crate) const GAUSS_LEGENDRE_4_WEIGHTS: [f64; 4] = [
    0.347_854_845_137_453_9,
    0.652_145_154_862_546_1,
    0.652_145_154_862_546_1,
    0.347_854_845_137_453_9,
];

fn integrate_sin(f: &dyn Fn(f64) -> f64, breaks: &[f64]) -> f64 {
    const X: [f64; 4] = GAUSS_LEGENDRE_4_NODES;
    const W: [f64; 4] = GAUSS_LEGENDRE_4_WEIGHTS;
    let mut pts: Vec<f64> = breaks.to_vec();
    pts.push(PI);
    let mut total = 0.0;
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b <= a {
            continue;
        }
        let n = 256;
        let h = (b - a) / n as f64;
        for i in 0..n {
            let mid = a + (i as f64 + 0.5) * h;
            for (x, wt) in X.iter().zip(W) {
                let g = mid + 0.5 * h * x;
                total += 0.5 * h * wt * f(g) * g.sin();
            }
        }
    }
    total
}

/// Where a table of intensities came from, for [`scaled_intensity_rows`]'s error.
pub(crate) struct IntensitySource {
    /// The file format (e.g. "IES LM-63").
    pub(crate) format: &'static str,
    /// 1-based line of the first intensity value.
    pub(crate) line: usize,
    /// What multiplies the file's values, e.g. "a candela value × multiplier".
    pub(crate) scaling: &'static str,
    /// What the technician should check when the product is too large.
    pub(crate) hint: &'static str,
}

/// The file's intensity `values` times `factor` (cd), cut into rows of `row_len`; an
/// error naming the source when a product is not finite or above
/// [`crate::scene::limits::MAX_INTENSITY_CD`].
pub(crate) fn scaled_intensity_rows(
    values: &[f64],
    factor: f64,
    row_len: usize,
    source: &IntensitySource,
) -> Result<Vec<Vec<f64>>, super::error::PhotometryError> {
    use crate::scene::limits::MAX_INTENSITY_CD;
    if let Some(v) = values
        .iter()
        .map(|v| v * factor)
        .find(|v| !(v.is_finite() && *v <= MAX_INTENSITY_CD))
    {
        return Err(super::error::PhotometryError::Parse {
            format: source.format,
            line: source.line,
            message: format!(
                "{} ({factor:e}) is {v:e} cd, above the {MAX_INTENSITY_CD:e} cd the renderer accepts; {}",
                source.scaling, source.hint
            ),
        });
    }
    Ok(values
        .chunks(row_len)
        .map(|r| r.iter().map(|v| v * factor).collect())
        .collect())
}
