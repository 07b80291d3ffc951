//! The simulated spot colorimeter and its error model.
//!
//! The instrument sees the displays' spectra through its own three filters: the CIE
//! 1931 functions, each shifted in wavelength by a per-instrument amount and calibrated
//! by the maker on illuminant A (one gain per filter, with a small calibration error).
//! So its systematic error depends on the spectrum, as a real filter colorimeter's
//! does: small on a lamp white, larger on narrow-band (Infitec) primaries, and linear
//! in the light (it keeps additivity; no reading of R, G, B and white reveals it).
//! Then a per-instrument absolute luminance gain and (optionally, for what-if
//! studies) an xy offset, drawn once from the instrument seed. Then the noise, in
//! each of the X, Y and Z sensors on its own, as a filter colorimeter's three
//! photodiodes have it: a relative high-light noise (Y's the stated luminance
//! repeatability, X's and Z's larger so that illuminant A reads with the stated xy
//! repeatability; [`crate::ReadingNoise::sensor_rel`]) and a zero-light noise
//! (Gaussian, a few mcd/m², independent of the light: it dominates in the dark;
//! [`MeterModel::dark_sigma_xyz_cd_m2`]). A saturated colour keeps its strongest
//! component as precise as a white's: the Z of a blue of y 0.02 scatters 0.2 %, not
//! the 2 % an xy noise of 0.0005 would give it. Then display rounding. Limits: over `max_cd_m2` → [`DeviceError::OverRange`]; below
//! `floor_cd_m2` → [`DeviceError::TooDark`]; between the floor and
//! `min_reliable_cd_m2` the meter still answers, with larger noise.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::observer::{Spectrum, cie1931};
use super::spectra::planck;
use super::wall::VirtualWall;
use crate::{Colorimeter, DeviceError, MeterInfo, Xyz};
use lumiwall_core::Xy;

/// Error model of a spot colorimeter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeterModel {
    /// Model name reported by [`Colorimeter::info`].
    pub model: String,
    /// Instrument seed: fixes its systematic errors (like a serial number).
    pub seed: u64,
    /// Bound of the systematic luminance gain error (drawn uniformly in ±bound).
    pub lum_systematic_rel: f64,
    /// Bound of the systematic x and y offsets (each drawn uniformly in ±bound), the
    /// same for every spectrum. Not how a filter colorimeter errs (see
    /// `filter_shift_nm`); kept for what-if studies.
    pub xy_systematic: f64,
    /// Bound of the wavelength shift of each of the three filters against the CIE
    /// 1931 functions (nm, each drawn uniformly in ±bound): the instrument's spectral
    /// mismatch. 0: the CIE observer exactly.
    #[serde(default)]
    pub filter_shift_nm: f64,
    /// Bound of the relative error of each filter's calibration gain (the maker
    /// calibrates on illuminant A; each drawn uniformly in ±bound).
    #[serde(default)]
    pub filter_gain_rel: f64,
    /// 1σ relative luminance noise per reading at high luminance.
    pub lum_noise_rel: f64,
    /// Relative luminance noise added by the Y sensor's zero-light noise at
    /// `low_light_cd_m2` (so σ_Y = this × `low_light_cd_m2` cd/m² at any light).
    pub lum_low_light_rel: f64,
    /// 1σ noise of x and y per reading at high luminance, on illuminant A (it sets
    /// the X and Z sensors' relative noise; [`crate::ReadingNoise::sensor_rel`]).
    pub xy_noise: f64,
    /// xy noise of a white at `low_light_cd_m2` from the sensors' zero-light noise:
    /// it sets how much noisier the X and Z sensors are than Y's
    /// ([`MeterModel::dark_sigma_xyz_cd_m2`]).
    pub xy_low_light: f64,
    /// Luminance where the low-light noise terms are referenced (cd/m²).
    pub low_light_cd_m2: f64,
    /// Below this the maker calls readings unreliable (cd/m²); informative.
    pub min_reliable_cd_m2: f64,
    /// Below this the meter refuses with [`DeviceError::TooDark`] (cd/m²).
    pub floor_cd_m2: f64,
    /// Above this the meter reports [`DeviceError::OverRange`] (cd/m²).
    pub max_cd_m2: f64,
    /// Significant digits of the luminance display and decimals of x, y
    /// (`None`: no rounding).
    pub display_digits: Option<u32>,
}

impl MeterModel {
    /// A perfect meter: no systematic error, no noise, no rounding, no limits; reads
    /// exactly [`VirtualWall::emitted_xyz`].
    pub fn noiseless() -> Self {
        Self {
            model: "ideal meter (simulated)".into(),
            seed: 0,
            lum_systematic_rel: 0.0,
            xy_systematic: 0.0,
            filter_shift_nm: 0.0,
            filter_gain_rel: 0.0,
            lum_noise_rel: 0.0,
            lum_low_light_rel: 0.0,
            xy_noise: 0.0,
            xy_low_light: 0.0,
            low_light_cd_m2: 1.0,
            min_reliable_cd_m2: 0.0,
            floor_cd_m2: 0.0,
            max_cd_m2: f64::INFINITY,
            display_digits: None,
        }
    }

    /// Konica Minolta CS-100A per its datasheet: luminance accuracy ±2 % as the bound
    /// of the per-instrument gain; the xy accuracy ±0.004 (illuminant A) comes from the
    /// filters: each shifted up to ±1.5 nm from the CIE functions and calibrated on
    /// illuminant A with up to ±0.3 % gain error per filter (about ±0.002 in xy on
    /// illuminant A, more on narrow-band primaries); repeatability 0.2 % + 1 digit and
    /// xy 0.001 (2σ) per reading; range 0.01–299 900 cd/m², unreliable below ~1 cd/m²
    /// (Kresse 3.3.7); 4-digit display. `seed` plays the serial number.
    pub fn cs100a(seed: u64) -> Self {
        Self {
            model: "Konica Minolta CS-100A (simulated)".into(),
            seed,
            lum_systematic_rel: 0.02,
            xy_systematic: 0.0,
            filter_shift_nm: 1.5,
            filter_gain_rel: 0.003,
            lum_noise_rel: 0.001,
            lum_low_light_rel: 0.004,
            xy_noise: 0.0005,
            xy_low_light: 0.002,
            low_light_cd_m2: 1.0,
            min_reliable_cd_m2: 1.0,
            floor_cd_m2: 0.01,
            max_cd_m2: 299_900.0,
            display_digits: Some(4),
        }
    }

    /// 1σ zero-light noise of the X, Y and Z sensors (cd/m²): σ_Y from the relative
    /// luminance noise at `low_light_cd_m2`, X and Z `k` times noisier, with `k` such
    /// that a white (x ≈ y ≈ 1/3) at `low_light_cd_m2` has the xy noise
    /// `xy_low_light` (σ_x ≈ σ_Y·√(5k²+1)/(9Y)). The CS-100A model gives
    /// σ_Y 4 mcd/m² and k ≈ 1.96.
    pub fn dark_sigma_xyz_cd_m2(&self) -> [f64; 3] {
        let sy = self.lum_low_light_rel * self.low_light_cd_m2;
        if sy <= 0.0 {
            return [0.0; 3];
        }
        let r = 9.0 * self.xy_low_light * self.low_light_cd_m2 / sy;
        let k = ((r * r - 1.0) / 5.0).max(0.0).sqrt();
        [k * sy, sy, k * sy]
    }

    /// The noise of one reading as [`MeterInfo::noise`] states it.
    pub fn reading_noise(&self) -> crate::ReadingNoise {
        crate::ReadingNoise {
            luminance_rel: self.lum_noise_rel,
            xy: self.xy_noise,
            dark_xyz_cd_m2: self.dark_sigma_xyz_cd_m2(),
        }
    }

    /// 1σ relative luminance noise at `y_cd_m2`: the high-light repeatability and the
    /// Y sensor's zero-light noise.
    pub fn lum_sigma_rel(&self, y_cd_m2: f64) -> f64 {
        self.lum_noise_rel
            .hypot(self.dark_sigma_xyz_cd_m2()[1] / y_cd_m2.max(1e-9))
    }

    /// 1σ x (and y) noise of a white (x ≈ y ≈ 1/3) at `y_cd_m2`.
    pub fn xy_sigma(&self, y_cd_m2: f64) -> f64 {
        self.xy_noise
            .hypot(self.xy_low_light * self.low_light_cd_m2 / y_cd_m2.max(1e-9))
    }
}

/// A simulated colorimeter reading a [`VirtualWall`] at the spot its positioner aimed
/// at. `Send`: it can be moved into a serial emulator thread.
#[derive(Debug, Clone)]
pub struct SimMeter {
    wall: VirtualWall,
    model: MeterModel,
    systematic_gain: f64,
    systematic_xy: [f64; 2],
    /// Each display's spectra through this instrument's filters (`None`: the CIE
    /// observer exactly).
    filters: Option<Filters>,
    rng: ChaCha8Rng,
}

/// One instrument's three filters: shifts against the CIE 1931 functions and the
/// calibration gains, with each display's five spectra integrated through them.
#[derive(Debug, Clone)]
struct Filters {
    /// Wavelength shift of the x̄, ȳ, z̄ filters (nm).
    shift_nm: [f64; 3],
    /// `basis[display]`: `[R, G, B, black, white segment]` as this instrument reads them.
    basis: Vec<[[f64; 3]; 5]>,
}

impl Filters {
    /// The filters for shifts `shift_nm` and calibration errors `gain_error`, and the
    /// wall's displays integrated through them. The maker's calibration makes
    /// illuminant A (Planck 2856 K) read as the CIE observer reads it, up to
    /// `gain_error`.
    fn new(
        wall: &VirtualWall,
        shift_nm: [f64; 3],
        gain_error: [f64; 3],
    ) -> Result<Self, crate::DeviceError> {
        let obs = cie1931().map_err(|e| crate::DeviceError::Config(e.to_string()))?;
        let cmf = [&obs.x_bar, &obs.y_bar, &obs.z_bar];
        let illuminant_a = Spectrum::from_fn(|wl| planck(wl, 2856.0));
        let dot = |a: &Spectrum, b: &Spectrum| -> f64 {
            a.values.iter().zip(&b.values).map(|(x, y)| x * y).sum()
        };
        let sens: [Spectrum; 3] = std::array::from_fn(|c| {
            let shifted = Spectrum::from_fn(|wl| cmf[c].at(wl - shift_nm[c]));
            let gain = dot(&illuminant_a, cmf[c]) / dot(&illuminant_a, &shifted);
            shifted.scaled(gain * (1.0 + gain_error[c]))
        });
        let basis = wall.integrated_spectra(|s| std::array::from_fn(|c| dot(s, &sens[c])));
        Ok(Filters { shift_nm, basis })
    }
}

fn round_sig(v: f64, digits: u32) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let mag = v.abs().log10().floor() as i32;
    let scale = 10f64.powi(digits as i32 - 1 - mag);
    (v * scale).round() / scale
}

impl SimMeter {
    /// A meter with error model `model` on `wall`.
    pub fn new(wall: VirtualWall, model: MeterModel) -> Self {
        let mut sys = ChaCha8Rng::seed_from_u64(model.seed ^ 0x005e_edc5_100a);
        let mut draw = |b: f64| {
            if b > 0.0 {
                sys.random_range(-b..=b)
            } else {
                0.0
            }
        };
        let systematic_gain = 1.0 + draw(model.lum_systematic_rel);
        let systematic_xy = [draw(model.xy_systematic), draw(model.xy_systematic)];
        let shift_nm = [0; 3].map(|_| draw(model.filter_shift_nm));
        let gain_error = [0; 3].map(|_| draw(model.filter_gain_rel));
        let filters = (shift_nm != [0.0; 3] || gain_error != [0.0; 3])
            .then(|| match Filters::new(&wall, shift_nm, gain_error) {
                Ok(f) => Some(f),
                Err(e) => {
                    tracing::error!("simulated meter without its filter error: {e}");
                    None
                }
            })
            .flatten();
        let rng = ChaCha8Rng::seed_from_u64(wall.seed() ^ model.seed.rotate_left(32));
        Self {
            wall,
            model,
            systematic_gain,
            systematic_xy,
            filters,
            rng,
        }
    }

    /// This instrument's filter shifts against the CIE 1931 functions (nm).
    pub fn filter_shifts_nm(&self) -> [f64; 3] {
        self.filters.as_ref().map_or([0.0; 3], |f| f.shift_nm)
    }

    /// The error model.
    pub fn model(&self) -> &MeterModel {
        &self.model
    }

    /// This instrument's systematic errors: luminance gain (1 = none) and xy offset.
    pub fn systematic_error(&self) -> (f64, [f64; 2]) {
        (self.systematic_gain, self.systematic_xy)
    }

    fn name(&self) -> String {
        format!("{} #{}", self.model.model, self.model.seed)
    }

    fn apply_errors(&mut self, truth: Xyz) -> Result<Xyz, DeviceError> {
        let m = &self.model;
        let y_true = truth.y;
        if !truth.is_finite() {
            return Err(DeviceError::Garbled {
                device: self.name(),
                command: "measure".into(),
                answer: format!("{truth:?}"),
            });
        }
        if y_true * self.systematic_gain > m.max_cd_m2 {
            return Err(DeviceError::OverRange {
                device: self.name(),
            });
        }
        let Some(Xy { x, y }) = truth.chromaticity() else {
            return Err(DeviceError::TooDark {
                device: self.name(),
                y_cd_m2: y_true,
                limit_cd_m2: m.floor_cd_m2,
            });
        };
        // The gain and the xy offset, then each sensor's relative high-light noise and
        // its zero-light noise.
        let biased = Xy::new(x + self.systematic_xy[0], y + self.systematic_xy[1])
            .with_luminance(y_true * self.systematic_gain)
            .to_array();
        let noise = m.reading_noise();
        let (rel, dark) = (noise.sensor_rel(), noise.dark_xyz_cd_m2);
        let read = Xyz::from_array(std::array::from_fn(|k| {
            let n: [f64; 2] = std::array::from_fn(|_| self.rng.sample::<f64, _>(StandardNormal));
            biased[k] * (1.0 + rel[k] * n[0]) + dark[k] * n[1]
        }));
        let (mut lum, [mut xm, mut ym]) = (read.y, read.xy().unwrap_or([1.0 / 3.0; 2]));
        if let Some(d) = m.display_digits {
            lum = round_sig(lum, d);
            let k = 10f64.powi(d as i32);
            xm = (xm * k).round() / k;
            ym = (ym * k).round() / k;
        }
        if lum < m.floor_cd_m2 || lum <= 0.0 || ym <= 0.0 {
            return Err(DeviceError::TooDark {
                device: self.name(),
                y_cd_m2: lum.max(0.0),
                limit_cd_m2: m.floor_cd_m2,
            });
        }
        if m.lum_noise_rel == 0.0
            && m.lum_low_light_rel == 0.0
            && m.xy_noise == 0.0
            && m.xy_low_light == 0.0
            && self.systematic_gain == 1.0
            && self.systematic_xy == [0.0, 0.0]
            && self.filters.is_none()
            && m.display_digits.is_none()
        {
            // Perfect meter: hand back the exact tristimulus values (no xyY round trip).
            return Ok(truth);
        }
        Ok(Xy::new(xm, ym).with_luminance(lum))
    }
}

impl Colorimeter for SimMeter {
    fn info(&self) -> MeterInfo {
        MeterInfo {
            model: self.model.model.clone(),
            serial: format!("SIM-{}", self.model.seed),
            min_reliable_cd_m2: self.model.min_reliable_cd_m2,
            max_cd_m2: self.model.max_cd_m2,
            noise: Some(self.model.reading_noise()),
        }
    }

    fn measure(&mut self) -> Result<Xyz, DeviceError> {
        let seen = self
            .wall
            .read_spot_in(self.filters.as_ref().map(|f| f.basis.as_slice()))?;
        self.apply_errors(seen)
    }
}
