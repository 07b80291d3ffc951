//! The simulated spectroradiometer and its error model.
//!
//! A grating spectroradiometer does not filter the light three ways as a colorimeter
//! does: it samples the spectrum and the firmware integrates the CIE functions. Its
//! systematic errors are therefore of another kind, each drawn once from the
//! instrument seed (its serial number): one wavelength-scale offset shared by all
//! pixels, the slit function (a triangle of the instrument's optical bandwidth), and a
//! smooth error of the spectral responsivity (an absolute gain and a tilt across the
//! range, left by the calibration lamp's uncertainty). Each reading adds noise: a
//! relative fluctuation of the whole reading and an independent dark noise per pixel,
//! so that low light is noisy the way a real array is.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use std::sync::{Arc, Mutex};

use super::observer::Spectrum;
use super::wall::VirtualWall;
use crate::line_lamp::{LampHolder, LineLamp};
use crate::spectral::{K_M_LM_PER_W, SpectralRadiance, Spectroradiometer};
use crate::{Colorimeter, DeviceError, MeterInfo, Xyz};

/// Radiance of the simulated line lamp's strongest line (W·sr⁻¹·m⁻²): a pen lamp
/// close before the lens, about 10 cd/m² in its green line.
const LAMP_STRONGEST_LINE_W_SR_M2: f64 = 0.02;

/// Error model of a spot spectroradiometer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpectroModel {
    /// Model name reported by [`Colorimeter::info`].
    pub model: String,
    /// Instrument seed: fixes its systematic errors (like a serial number).
    pub seed: u64,
    /// First wavelength of the instrument's grid (nm).
    pub start_nm: f64,
    /// Last wavelength (nm).
    pub end_nm: f64,
    /// Grid step of what it reports (nm).
    pub step_nm: f64,
    /// Full width at half maximum of the (triangular) slit function (nm); 0: none.
    pub bandwidth_nm: f64,
    /// Bound of the wavelength-scale offset (nm, drawn uniformly in ±bound).
    pub wavelength_offset_nm: f64,
    /// Bound of the absolute responsivity error (relative, drawn in ±bound).
    pub gain_rel: f64,
    /// Bound of the responsivity tilt: relative error at the ends of 380–780 nm,
    /// linear between, 0 at 580 nm (drawn in ±bound).
    pub tilt_rel: f64,
    /// 1σ relative fluctuation of one whole reading.
    pub noise_rel: f64,
    /// 1σ dark noise of each pixel (W·sr⁻¹·m⁻²·nm⁻¹).
    pub dark_noise_w_sr_m2_nm: f64,
    /// Below this the maker calls readings unreliable (cd/m²); informative.
    pub min_reliable_cd_m2: f64,
    /// Below this luminance the instrument reports too dark (cd/m²).
    pub floor_cd_m2: f64,
    /// Above this luminance it saturates even at its shortest integration time (cd/m²).
    pub max_cd_m2: f64,
}

impl SpectroModel {
    /// A perfect spectroradiometer on the simulator's own grid (1 nm over 360–830 nm,
    /// so it reads exactly the truth): no slit, no errors, no noise, no limits.
    pub fn noiseless() -> Self {
        Self {
            model: "ideal spectroradiometer (simulated)".into(),
            seed: 0,
            start_nm: 360.0,
            end_nm: 830.0,
            step_nm: 1.0,
            bandwidth_nm: 0.0,
            wavelength_offset_nm: 0.0,
            gain_rel: 0.0,
            tilt_rel: 0.0,
            noise_rel: 0.0,
            dark_noise_w_sr_m2_nm: 0.0,
            min_reliable_cd_m2: 0.0,
            floor_cd_m2: 0.0,
            max_cd_m2: f64::INFINITY,
        }
    }

    /// JETI specbos 1211 (the model ArgyllCMS drives as "specbos"), per the maker's
    /// published figures collected in `fixtures/instruments/jeti-specbos.md`: 380–780 nm
    /// reported at 1 nm, optical bandwidth 4.5 nm, wavelength accuracy ±0.5 nm,
    /// luminance accuracy ±2 %, luminance range 0.2–70 000 cd/m² (readings down to
    /// 0.05 cd/m² with long integration). The tilt (±1 % at the range ends) is the
    /// spectral uncertainty of a calibration lamp; the dark noise gives about 0.001
    /// cd/m² of Y (1σ), 0.5 % on a white of 0.2 cd/m². `seed` plays the serial number.
    pub fn specbos_1211(seed: u64) -> Self {
        Self {
            model: "JETI specbos 1211 (simulated)".into(),
            seed,
            start_nm: 380.0,
            end_nm: 780.0,
            bandwidth_nm: 4.5,
            wavelength_offset_nm: 0.5,
            gain_rel: 0.02,
            tilt_rel: 0.01,
            noise_rel: 0.001,
            dark_noise_w_sr_m2_nm: 2.0e-7,
            min_reliable_cd_m2: 0.2,
            floor_cd_m2: 0.05,
            max_cd_m2: 70_000.0,
            ..Self::noiseless()
        }
    }

    /// A reference spectroradiometer of the Konica Minolta CS-2000 class, per its
    /// published figures (`fixtures/instruments/jeti-specbos.md` lists them beside the
    /// specbos): 380–780 nm at 1 nm, bandwidth 5 nm, wavelength accuracy ±0.3 nm,
    /// luminance ±2 %, 0.003–500 000 cd/m²; the dark noise gives 1 % of Y (1σ) at
    /// its floor. `seed` plays the serial number.
    pub fn cs2000(seed: u64) -> Self {
        Self {
            model: "Konica Minolta CS-2000 (simulated)".into(),
            seed,
            start_nm: 380.0,
            end_nm: 780.0,
            bandwidth_nm: 5.0,
            wavelength_offset_nm: 0.3,
            gain_rel: 0.02,
            tilt_rel: 0.01,
            noise_rel: 0.00075,
            dark_noise_w_sr_m2_nm: 5.0e-9,
            min_reliable_cd_m2: 0.05,
            floor_cd_m2: 0.003,
            max_cd_m2: 500_000.0,
            ..Self::noiseless()
        }
    }

    /// The number of samples of the grid.
    pub fn samples(&self) -> usize {
        ((self.end_nm - self.start_nm) / self.step_nm).round() as usize + 1
    }
}

/// A simulated spectroradiometer reading a [`VirtualWall`] at the spot its positioner
/// aimed at. `Send`: it can be moved into a serial emulator thread.
#[derive(Debug, Clone)]
pub struct SimSpectroradiometer {
    wall: VirtualWall,
    model: SpectroModel,
    /// The instrument's systematic errors, drawn from its seed.
    offset_nm: f64,
    gain: f64,
    tilt: f64,
    rng: ChaCha8Rng,
    /// The line lamp held before the lens, if any (shared with its [`SimLampHolder`]).
    lamp: Arc<Mutex<Option<LineLamp>>>,
}

/// Puts a line lamp before a [`SimSpectroradiometer`] (made by
/// [`SimSpectroradiometer::lamp_holder`]): while it is there, the instrument measures
/// the lamp's lines instead of the wall.
#[derive(Debug, Clone)]
pub struct SimLampHolder(Arc<Mutex<Option<LineLamp>>>);

impl LampHolder for SimLampHolder {
    fn place(&mut self, lamp: &LineLamp) -> Result<(), DeviceError> {
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = Some(lamp.clone());
        Ok(())
    }

    fn remove(&mut self) -> Result<(), DeviceError> {
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = None;
        Ok(())
    }
}

impl SimSpectroradiometer {
    /// A spectroradiometer with error model `model` on `wall`; fails on a grid that is
    /// not finite, not ascending or holds more than
    /// [`crate::spectral::MAX_SPECTRAL_SAMPLES`] samples.
    pub fn new(wall: VirtualWall, model: SpectroModel) -> Result<Self, DeviceError> {
        check_model(&model)?;
        let mut sys = ChaCha8Rng::seed_from_u64(model.seed ^ 0x05ec_7b05_1211);
        let mut draw = |b: f64| {
            if b > 0.0 {
                sys.random_range(-b..=b)
            } else {
                0.0
            }
        };
        let offset_nm = draw(model.wavelength_offset_nm);
        let gain = 1.0 + draw(model.gain_rel);
        let tilt = draw(model.tilt_rel);
        let rng = ChaCha8Rng::seed_from_u64(wall.seed() ^ model.seed.rotate_left(17) ^ 0x5bec);
        Ok(Self {
            wall,
            model,
            offset_nm,
            gain,
            tilt,
            rng,
            lamp: Arc::new(Mutex::new(None)),
        })
    }

    /// The holder that puts a line lamp before this instrument (it keeps working after
    /// the instrument moved into an emulator thread).
    pub fn lamp_holder(&self) -> SimLampHolder {
        SimLampHolder(self.lamp.clone())
    }

    /// What the instrument reports for `lamp`: each line seen through the slit
    /// (a triangle of unit area; at least one sample step wide, so an instrument without
    /// a slit still sees a line between its samples), at its offset wavelengths, times
    /// its responsivity error, plus noise.
    fn sample_lamp(&mut self, lamp: &LineLamp) -> SpectralRadiance {
        let m = &self.model;
        let fwhm = m.bandwidth_nm.max(m.step_nm);
        let fluctuation = 1.0 + m.noise_rel * self.rng.sample::<f64, _>(StandardNormal);
        let strongest = lamp
            .lines
            .iter()
            .map(|l| l.relative_intensity)
            .fold(0.0, f64::max);
        let scale = LAMP_STRONGEST_LINE_W_SR_M2 / strongest.max(f64::MIN_POSITIVE);
        let values = (0..m.samples())
            .map(|i| {
                let wl = m.start_nm + m.step_nm * i as f64;
                let seen: f64 = lamp
                    .lines
                    .iter()
                    .map(|l| {
                        let d = (wl + self.offset_nm - l.wavelength_nm).abs();
                        l.relative_intensity * scale * (1.0 - d / fwhm).max(0.0) / fwhm
                    })
                    .sum();
                let responsivity = self.gain * (1.0 + self.tilt * (wl - 580.0) / 200.0);
                let dark = m.dark_noise_w_sr_m2_nm * self.rng.sample::<f64, _>(StandardNormal);
                seen * responsivity * fluctuation + dark
            })
            .collect();
        SpectralRadiance {
            start_nm: m.start_nm,
            step_nm: m.step_nm,
            w_sr_m2_nm: values,
        }
    }

    /// The error model.
    pub fn model(&self) -> &SpectroModel {
        &self.model
    }

    /// This instrument's wavelength-scale offset (nm): its pixel labelled λ sees λ +
    /// offset.
    pub fn wavelength_offset_nm(&self) -> f64 {
        self.offset_nm
    }

    fn name(&self) -> String {
        format!("{} #{}", self.model.model, self.model.seed)
    }

    /// What the instrument reports for the true spectrum `truth` (scaled so that the
    /// CIE observer gives cd/m²): sampled through the slit at its offset wavelengths,
    /// times its responsivity error, plus noise.
    fn sample(&mut self, truth: &Spectrum) -> SpectralRadiance {
        let m = &self.model;
        let fluctuation = 1.0 + m.noise_rel * self.rng.sample::<f64, _>(StandardNormal);
        let n = m.samples();
        let mut values = Vec::with_capacity(n);
        for i in 0..n {
            let wl = m.start_nm + m.step_nm * i as f64;
            let seen = through_slit(truth, wl + self.offset_nm, m.bandwidth_nm) / K_M_LM_PER_W;
            let responsivity = self.gain * (1.0 + self.tilt * (wl - 580.0) / 200.0);
            let dark = m.dark_noise_w_sr_m2_nm * self.rng.sample::<f64, _>(StandardNormal);
            values.push(seen * responsivity * fluctuation + dark);
        }
        SpectralRadiance {
            start_nm: m.start_nm,
            step_nm: m.step_nm,
            w_sr_m2_nm: values,
        }
    }

    fn check_range(&self, reading: &SpectralRadiance, true_y: f64) -> Result<(), DeviceError> {
        if true_y * self.gain > self.model.max_cd_m2 {
            return Err(DeviceError::OverRange {
                device: self.name(),
            });
        }
        let y = reading.xyz()?.y;
        if !y.is_finite() || y < self.model.floor_cd_m2 || y <= 0.0 {
            return Err(DeviceError::TooDark {
                device: self.name(),
                y_cd_m2: y.max(0.0),
                limit_cd_m2: self.model.floor_cd_m2,
            });
        }
        Ok(())
    }
}

/// Fails unless the model's grid and bounds are usable.
fn check_model(m: &SpectroModel) -> Result<(), DeviceError> {
    let finite_nonneg = [
        m.bandwidth_nm,
        m.wavelength_offset_nm,
        m.gain_rel,
        m.tilt_rel,
        m.noise_rel,
        m.dark_noise_w_sr_m2_nm,
    ];
    let grid_ok = m.start_nm.is_finite()
        && m.end_nm.is_finite()
        && m.step_nm.is_finite()
        && m.step_nm > 0.0
        && m.end_nm > m.start_nm
        && (m.end_nm - m.start_nm) / m.step_nm < crate::spectral::MAX_SPECTRAL_SAMPLES as f64;
    if !grid_ok || finite_nonneg.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
        return Err(DeviceError::Config(format!(
            "spectroradiometer model {:?}: grid {}–{} nm step {} nm, or a negative or \
             non-finite error bound",
            m.model, m.start_nm, m.end_nm, m.step_nm
        )));
    }
    Ok(())
}

/// The spectrum seen through a triangular slit of full width at half maximum
/// `fwhm_nm` centred at `wl` (0: the value at `wl`), integrated at 0.25 nm.
fn through_slit(s: &Spectrum, wl: f64, fwhm_nm: f64) -> f64 {
    if fwhm_nm <= 0.0 {
        return s.at(wl);
    }
    let steps = (fwhm_nm / 0.25).ceil() as i64;
    let h = fwhm_nm / steps as f64;
    let (mut sum, mut weight) = (0.0, 0.0);
    for k in -steps..=steps {
        let w = 1.0 - (k.abs() as f64 * h) / fwhm_nm;
        sum += w * s.at(wl + k as f64 * h);
        weight += w;
    }
    sum / weight
}

impl Colorimeter for SimSpectroradiometer {
    fn info(&self) -> MeterInfo {
        MeterInfo {
            model: self.model.model.clone(),
            serial: format!("SIM-{}", self.model.seed),
            min_reliable_cd_m2: self.model.min_reliable_cd_m2,
            max_cd_m2: self.model.max_cd_m2,
            noise: None,
        }
    }

    fn measure(&mut self) -> Result<Xyz, DeviceError> {
        self.measure_spectrum()?.xyz()
    }
}

impl Spectroradiometer for SimSpectroradiometer {
    fn measure_spectrum(&mut self) -> Result<SpectralRadiance, DeviceError> {
        let lamp = self.lamp.lock().unwrap_or_else(|e| e.into_inner()).clone();
        if let Some(lamp) = lamp {
            let reading = self.sample_lamp(&lamp);
            let y = reading.xyz()?.y;
            self.check_range(&reading, y)?;
            return Ok(reading);
        }
        let truth = self.wall.read_spot_spectrum()?;
        let true_y = super::observer::cie1931()
            .map_err(|e| DeviceError::Config(e.to_string()))?
            .tristimulus(&truth)[1];
        let reading = self.sample(&truth);
        self.check_range(&reading, true_y)?;
        Ok(reading)
    }

    fn bandwidth_nm(&self) -> f64 {
        self.model.bandwidth_nm
    }

    fn wavelength_range_nm(&self) -> [f64; 2] {
        [self.model.start_nm, self.model.end_nm]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DisplayId, MeterPositioner, PatternOutput};

    fn wall(name: &str) -> VirtualWall {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures/walls")
            .join(name);
        VirtualWall::from_toml_file(&path).expect("wall")
    }

    fn read(wall: &VirtualWall, model: SpectroModel, drive: [f64; 3]) -> (Xyz, Xyz) {
        let id = DisplayId(0);
        wall.pattern_output().show(id, drive).expect("show");
        wall.positioner().aim(id, [0.5, 0.5]).expect("aim");
        let mut s = SimSpectroradiometer::new(wall.clone(), model).expect("model");
        let got = s.measure().expect("reading");
        (got, wall.emitted_xyz(id, drive, [0.5, 0.5]).expect("truth"))
    }

    fn dxy(a: Xyz, b: Xyz) -> f64 {
        a.chromaticity()
            .expect("light")
            .distance(b.chromaticity().expect("light"))
    }

    #[test]
    fn an_ideal_spectroradiometer_reads_the_simulators_truth() {
        let w = wall("infitec-pair.toml");
        for drive in [
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.4, 0.2, 0.7],
        ] {
            let (got, truth) = read(&w, SpectroModel::noiseless(), drive);
            assert!(
                (got.y / truth.y - 1.0).abs() < 2e-4,
                "{drive:?}: {got:?} vs {truth:?}"
            );
            assert!(dxy(got, truth) < 2e-5, "{drive:?}: Δxy {}", dxy(got, truth));
        }
    }

    #[test]
    fn a_wavelength_offset_moves_a_narrow_band_green_more_than_a_white() {
        let w = wall("infitec-pair.toml");
        let mut shifted = SpectroModel::noiseless();
        shifted.wavelength_offset_nm = 0.5;
        // an instrument whose offset is at least 0.35 nm
        let s = (1..100)
            .map(|seed| {
                shifted.seed = seed;
                SimSpectroradiometer::new(w.clone(), shifted.clone()).expect("model")
            })
            .find(|s| s.wavelength_offset_nm().abs() >= 0.35)
            .expect("an instrument with a large offset");
        let (g, g_true) = read(&w, shifted.clone(), [0.0, 1.0, 0.0]);
        let (wh, wh_true) = read(&w, shifted, [1.0, 1.0, 1.0]);
        let (e_green, e_white) = (dxy(g, g_true), dxy(wh, wh_true));
        eprintln!(
            "offset {:.3} nm: Δxy green {e_green:.5}, white {e_white:.5}",
            s.wavelength_offset_nm()
        );
        assert!(
            e_green > 2.0 * e_white,
            "green {e_green:.5}, white {e_white:.5}"
        );
        // the spectral locus moves ≲ 0.009 per nm near 530 nm: a band can move less
        assert!(e_green < 0.009 * s.wavelength_offset_nm().abs() + 1e-4);
    }

    #[test]
    fn the_specbos_model_stays_within_its_published_accuracy_on_a_white() {
        let w = wall("infitec-pair.toml");
        for seed in 1..=20 {
            let (got, truth) = read(&w, SpectroModel::specbos_1211(seed), [1.0, 1.0, 1.0]);
            assert!((got.y / truth.y - 1.0).abs() < 0.025, "seed {seed}");
            assert!(
                dxy(got, truth) < 0.002,
                "seed {seed}: Δxy {}",
                dxy(got, truth)
            );
        }
    }

    #[test]
    fn below_its_floor_it_reports_too_dark_and_above_its_range_over_range() {
        let w = wall("infitec-pair.toml");
        let mut m = SpectroModel::specbos_1211(1);
        m.floor_cd_m2 = 1.0e6;
        let id = DisplayId(0);
        w.pattern_output().show(id, [1.0; 3]).expect("show");
        w.positioner().aim(id, [0.5, 0.5]).expect("aim");
        let mut s = SimSpectroradiometer::new(w.clone(), m).expect("model");
        assert!(matches!(s.measure(), Err(DeviceError::TooDark { .. })));
        let mut m = SpectroModel::specbos_1211(1);
        m.max_cd_m2 = 1.0e-3;
        let mut s = SimSpectroradiometer::new(w, m).expect("model");
        assert!(matches!(s.measure(), Err(DeviceError::OverRange { .. })));
    }

    #[test]
    fn a_model_with_a_bad_grid_is_refused() {
        let mut m = SpectroModel::noiseless();
        m.step_nm = 0.0;
        assert!(SimSpectroradiometer::new(wall("infitec-pair.toml"), m).is_err());
        let mut m = SpectroModel::noiseless();
        m.end_nm = 1.0e12;
        assert!(SimSpectroradiometer::new(wall("infitec-pair.toml"), m).is_err());
    }

    #[test]
    fn the_bandpass_correction_removes_what_a_5_nm_slit_does_to_narrow_band_primaries() {
        let w = wall("dlp-infitec-2x1.toml");
        let mut m = SpectroModel::noiseless();
        m.bandwidth_nm = 5.0;
        let id = DisplayId(0);
        let mut s = SimSpectroradiometer::new(w.clone(), m).expect("model");
        for drive in [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ] {
            w.pattern_output().show(id, drive).expect("show");
            w.positioner().aim(id, [0.5, 0.5]).expect("aim");
            let spectrum = s.measure_spectrum().expect("reading");
            let truth = w.emitted_xyz(id, drive, [0.5, 0.5]).expect("truth");
            let raw = dxy(spectrum.xyz().expect("xyz"), truth);
            let corrected = dxy(spectrum.xyz_bandpass_corrected(5.0).expect("xyz"), truth);
            eprintln!("{drive:?}: Δxy as integrated {raw:.5}, bandpass-corrected {corrected:.5}");
            assert!(corrected < 1e-4 && corrected < raw / 5.0, "{drive:?}");
        }
    }
}
