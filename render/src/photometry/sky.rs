//! CIE standard skies (ISO 15469 / CIE S 011): the overcast sky of Moon & Spencer
//! (type 1 of the 1942/CIE 1955 standard, L(θ) = Lz·(1 + 2 cos θ)/3) and the CIE clear
//! sky (type 12, CIE 1973), with the sun as a directional source. World frame: +z up.

use super::distribution::{GAUSS_LEGENDRE_4_NODES, GAUSS_LEGENDRE_4_WEIGHTS};
use super::frame::{dot, normalize};
use std::f64::consts::{FRAC_PI_2, TAU};

/// Extraterrestrial solar illuminance used for the sun, lux (IES Lighting Handbook).
pub const SOLAR_ILLUMINANCE_CONSTANT_LUX: f64 = 127_500.0;
/// Atmospheric extinction coefficient of a clear sky (IES Lighting Handbook).
pub const CLEAR_SKY_EXTINCTION: f64 = 0.21;

/// Which sky luminance distribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SkyModel {
    /// CIE standard overcast sky (Moon & Spencer).
    CieOvercast,
    /// CIE clear sky, ISO 15469 type 12 (a = −1, b = −0.32, c = 10, d = −3, e = 0.45),
    /// with the sun at `sun_dir` (unit, towards the sun).
    CieClear {
        /// Unit direction towards the sun.
        sun_dir: [f64; 3],
    },
}

/// The sun as a directional light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sun {
    /// Unit vector from the scene towards the sun (+z up).
    pub direction: [f64; 3],
    /// Illuminance on a plane normal to the sun's rays, lux.
    pub normal_illuminance_lux: f64,
}

impl Sun {
    /// Illuminance in lux on a plane with normal `normal` (unit or not).
    pub fn illuminance_on_plane_lux(&self, normal: [f64; 3]) -> f64 {
        normalize(normal).map_or(0.0, |n| {
            self.normal_illuminance_lux * dot(n, self.direction).max(0.0)
        })
    }
}

/// One cell of a sky subdivision (see [`Sky::patches`]): the sky seen through it acts
/// like a distant source of intensity-per-area `luminance_cd_m2 × solid_angle_sr`
/// (illuminance contribution L·ω·cos ε on an unobstructed plane).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkyPatch {
    /// Unit direction to the cell centre (+z up).
    pub direction: [f64; 3],
    /// Solid angle of the cell, sr.
    pub solid_angle_sr: f64,
    /// Mean sky luminance over the cell (2 × 2 sub-samples), cd/m².
    pub luminance_cd_m2: f64,
}

/// A sky luminance distribution (cd/m²) over the upper hemisphere, with optional sun.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sky {
    model: SkyModel,
    zenith_luminance_cd_m2: f64,
    sun: Option<Sun>,
}

const A: f64 = -1.0;
const B: f64 = -0.32;
const C: f64 = 10.0;
const D: f64 = -3.0;
const E: f64 = 0.45;

fn gradation(cos_z: f64) -> f64 {
    if cos_z <= 1e-12 {
        1.0
    } else {
        1.0 + A * (B / cos_z).exp()
    }
}

fn indicatrix(chi: f64) -> f64 {
    1.0 + C * ((D * chi).exp() - (D * FRAC_PI_2).exp()) + E * chi.cos().powi(2)
}

impl Sky {
    /// CIE overcast sky with zenith luminance `zenith_luminance_cd_m2` (no sun).
    pub fn cie_overcast(zenith_luminance_cd_m2: f64) -> Self {
        Self {
            model: SkyModel::CieOvercast,
            zenith_luminance_cd_m2: sanitize(zenith_luminance_cd_m2),
            sun: None,
        }
    }

    /// CIE clear sky (type 12) for a sun in direction `sun_dir` (+z up; normalised
    /// here; a zero vector means the zenith) and zenith luminance
    /// `zenith_luminance_cd_m2`. The sun's normal illuminance follows the IES
    /// Handbook clear-sky model E = 127 500 lx · exp(−0.21·m) with the Kasten–Young
    /// air mass m; a sun at or below the horizon gives no sun. The sky formula is
    /// evaluated with the solar zenith angle limited to 90°.
    pub fn cie_clear(sun_dir: [f64; 3], zenith_luminance_cd_m2: f64) -> Self {
        let s = normalize(sun_dir).unwrap_or([0.0, 0.0, 1.0]);
        let sun = (s[2] > 0.0).then(|| {
            let z_deg = s[2].clamp(-1.0, 1.0).acos().to_degrees();
            let m = 1.0 / (s[2] + 0.50572 * (96.07995 - z_deg).powf(-1.6364));
            Sun {
                direction: s,
                normal_illuminance_lux: SOLAR_ILLUMINANCE_CONSTANT_LUX
                    * (-CLEAR_SKY_EXTINCTION * m).exp(),
            }
        });
        Self {
            model: SkyModel::CieClear { sun_dir: s },
            zenith_luminance_cd_m2: sanitize(zenith_luminance_cd_m2),
            sun,
        }
    }

    /// Replaces the sun's normal illuminance (e.g. from a measurement), lux. No effect
    /// on a sky without sun.
    pub fn with_sun_normal_illuminance_lux(mut self, lux: f64) -> Self {
        if let Some(sun) = self.sun.as_mut() {
            sun.normal_illuminance_lux = sanitize(lux);
        }
        self
    }

    /// The luminance model.
    pub fn model(&self) -> SkyModel {
        self.model
    }

    /// Zenith luminance, cd/m².
    pub fn zenith_luminance_cd_m2(&self) -> f64 {
        self.zenith_luminance_cd_m2
    }

    /// Sky luminance in cd/m² seen looking along `dir` (+z up; need not be unit).
    /// Directions below the horizon and zero vectors give 0.
    pub fn luminance_cd_m2(&self, dir: [f64; 3]) -> f64 {
        let Some(d) = normalize(dir) else {
            return 0.0;
        };
        if d[2] < 0.0 {
            return 0.0;
        }
        let lz = self.zenith_luminance_cd_m2;
        match self.model {
            SkyModel::CieOvercast => lz * (1.0 + 2.0 * d[2]) / 3.0,
            SkyModel::CieClear { sun_dir } => {
                let sz = sun_dir[2].max(0.0);
                let zs = sz.acos();
                let chi = dot(d, sun_dir).clamp(-1.0, 1.0).acos();
                lz * indicatrix(chi) * gradation(d[2]) / (indicatrix(zs) * gradation(1.0))
            }
        }
    }

    /// Diffuse illuminance from the sky alone (sun excluded) on a horizontal plane,
    /// lux, by numerical integration of L·cos θ over the hemisphere.
    pub fn horizontal_illuminance_lux(&self) -> f64 {
        self.illuminance_on_plane_lux([0.0, 0.0, 1.0])
    }

    /// Diffuse sky illuminance (sun excluded) on an unobstructed plane with normal
    /// `normal`, lux (numerical: Gauss–Legendre in cos θ, trapezoid in azimuth; the
    /// ground is taken as black).
    pub fn illuminance_on_plane_lux(&self, normal: [f64; 3]) -> f64 {
        let Some(n) = normalize(normal) else {
            return 0.0;
        };
        const GL_X: [f64; 4] = GAUSS_LEGENDRE_4_NODES;
        const GL_W: [f64; 4] = GAUSS_LEGENDRE_4_WEIGHTS;
        let n_mu = 96;
        let n_phi = 720;
        let h = 1.0 / n_mu as f64;
        let dphi = TAU / n_phi as f64;
        let mut total = 0.0;
        for i in 0..n_mu {
            let mid = (i as f64 + 0.5) * h;
            for (x, w) in GL_X.iter().zip(GL_W) {
                let mu = mid + 0.5 * h * x;
                let s = (1.0 - mu * mu).max(0.0).sqrt();
                let mut ring = 0.0;
                for k in 0..n_phi {
                    let phi = (k as f64 + 0.5) * dphi;
                    let d = [s * phi.cos(), s * phi.sin(), mu];
                    let c = dot(d, n);
                    if c > 0.0 {
                        ring += self.luminance_cd_m2(d) * c;
                    }
                }
                total += 0.5 * h * w * ring * dphi;
            }
        }
        total
    }

    /// Splits the upper hemisphere into `bands` zenith-angle bands of equal width,
    /// each split in azimuth into cells of about equal solid angle (at least 4 per
    /// band), for solvers that treat the sky as a set of distant directional sources.
    /// The solid angles sum to 2π exactly. `bands` is clamped to 1…1000.
    pub fn patches(&self, bands: usize) -> Vec<SkyPatch> {
        let bands = bands.clamp(1, 1000);
        let dt = FRAC_PI_2 / bands as f64;
        let mut out = Vec::new();
        for b in 0..bands {
            let (t0, t1) = (b as f64 * dt, (b as f64 + 1.0) * dt);
            let tm = 0.5 * (t0 + t1);
            let n_phi = ((TAU * tm.sin() / dt).round() as usize).max(4);
            let dphi = TAU / n_phi as f64;
            let band_omega = t0.cos() - t1.cos();
            for k in 0..n_phi {
                let pm = (k as f64 + 0.5) * dphi;
                let mut l = 0.0;
                for (ft, fp) in [(0.25, 0.25), (0.25, 0.75), (0.75, 0.25), (0.75, 0.75)] {
                    let t = t0 + ft * dt;
                    let p = k as f64 * dphi + fp * dphi;
                    l += 0.25
                        * self.luminance_cd_m2([t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]);
                }
                out.push(SkyPatch {
                    direction: [tm.sin() * pm.cos(), tm.sin() * pm.sin(), tm.cos()],
                    solid_angle_sr: dphi * band_omega,
                    luminance_cd_m2: l,
                });
            }
        }
        out
    }

    /// Sky plus sun illuminance on a horizontal plane, lux.
    pub fn global_horizontal_illuminance_lux(&self) -> f64 {
        self.horizontal_illuminance_lux()
            + self
                .sun
                .map_or(0.0, |s| s.illuminance_on_plane_lux([0.0, 0.0, 1.0]))
    }

    /// The sun, if this sky has one above the horizon.
    pub fn sun(&self) -> Option<Sun> {
        self.sun
    }
}

fn sanitize(v: f64) -> f64 {
    if v.is_finite() && v > 0.0 { v } else { 0.0 }
}
