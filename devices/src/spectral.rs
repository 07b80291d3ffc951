//! What a spectroradiometer measures: spectral radiance on the instrument's own
//! wavelength grid, and the tristimulus values computed from it with the CIE 1931
//! observer (as the instruments' firmware and ArgyllCMS do).

use lumiwall_core::observer::{Observer, cie1931};

use crate::{Colorimeter, DeviceError, Xyz};

/// The maximum luminous efficacy of radiation for photopic vision, K_m (lm/W).
pub const K_M_LM_PER_W: f64 = 683.0;

/// Most samples one spectral reading may hold (0.1 nm steps over 200–1200 nm).
pub const MAX_SPECTRAL_SAMPLES: usize = 10_001;

/// One spectral reading: spectral radiance at `start_nm + i·step_nm`.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralRadiance {
    /// Wavelength of the first sample (nm).
    pub start_nm: f64,
    /// Sample spacing (nm).
    pub step_nm: f64,
    /// Spectral radiance per sample (W·sr⁻¹·m⁻²·nm⁻¹).
    pub w_sr_m2_nm: Vec<f64>,
}

impl SpectralRadiance {
    /// Wavelength of the last sample (nm).
    pub fn end_nm(&self) -> f64 {
        self.start_nm + self.step_nm * (self.w_sr_m2_nm.len().saturating_sub(1)) as f64
    }

    /// Fails unless the grid is usable: a positive finite step, a finite start, at
    /// least two and at most [`MAX_SPECTRAL_SAMPLES`] samples, every value finite, and
    /// the grid covering 380–780 nm (where the CIE observer carries weight).
    pub fn check(&self, device: &str) -> Result<(), DeviceError> {
        let bad = |why: String| DeviceError::Garbled {
            device: device.into(),
            command: "spectrum".into(),
            answer: why,
        };
        let n = self.w_sr_m2_nm.len();
        if !(2..=MAX_SPECTRAL_SAMPLES).contains(&n) {
            return Err(bad(format!(
                "{n} samples (a spectrum has 2..={MAX_SPECTRAL_SAMPLES})"
            )));
        }
        if !(self.step_nm.is_finite() && self.step_nm > 0.0 && self.start_nm.is_finite()) {
            return Err(bad(format!(
                "grid start {} nm, step {} nm",
                self.start_nm, self.step_nm
            )));
        }
        if self.start_nm > 380.0 + 1e-9 || self.end_nm() < 780.0 - 1e-9 {
            return Err(bad(format!(
                "grid {}–{} nm does not cover 380–780 nm",
                self.start_nm,
                self.end_nm()
            )));
        }
        if let Some(i) = self.w_sr_m2_nm.iter().position(|v| !v.is_finite()) {
            return Err(bad(format!("sample {i} is {}", self.w_sr_m2_nm[i])));
        }
        Ok(())
    }

    /// XYZ (Y = luminance in cd/m²): `K_m · Σ L(λᵢ)·[x̄, ȳ, z̄](λᵢ)·Δλ` with the CIE 1931
    /// 2° observer interpolated at the instrument's wavelengths.
    pub fn xyz(&self) -> Result<Xyz, DeviceError> {
        self.xyz_bandpass_corrected(0.0)
    }

    /// XYZ of the spectrum an instrument of optical bandwidth `bandwidth_nm` (full
    /// width at half maximum of a triangular slit) measured, corrected to second
    /// order for that bandwidth. The instrument reports the true spectrum convolved
    /// with its slit `h`, so `Σ M·c̄ = Σ S·(c̄ ∗ h) ≈ Σ S·(c̄ + σ²/2·c̄″)` with
    /// `σ² = FWHM²/6`; weighting `M` with `c̄ − σ²/2·c̄″` instead leaves an error of
    /// fourth order in σ, however narrow the source's bands (only the smooth CIE
    /// functions are differentiated; compare CIE 214:2014). Without it, a 5 nm slit
    /// moves a narrow-band Infitec green by about 0.0014 in xy.
    pub fn xyz_bandpass_corrected(&self, bandwidth_nm: f64) -> Result<Xyz, DeviceError> {
        self.xyz_corrected(bandwidth_nm, &WavelengthScale::NOMINAL)
    }

    /// XYZ corrected for the instrument's bandwidth (as
    /// [`SpectralRadiance::xyz_bandpass_corrected`]) and for its wavelength scale: the
    /// sample labelled λ is taken at `scale.true_nm(λ)`, where the CIE functions are
    /// evaluated, and spans `step·(1 + slope)` nm.
    pub fn xyz_corrected(
        &self,
        bandwidth_nm: f64,
        scale: &WavelengthScale,
    ) -> Result<Xyz, DeviceError> {
        let obs = observer()?;
        let half_var = bandwidth_nm * bandwidth_nm / 12.0;
        let weight = |c: &lumiwall_core::observer::Spectrum, wl: f64| {
            let curvature = c.at(wl - 1.0) - 2.0 * c.at(wl) + c.at(wl + 1.0);
            c.at(wl) - half_var * curvature
        };
        let mut acc = [0.0; 3];
        for (i, l) in self.w_sr_m2_nm.iter().enumerate() {
            let wl = scale.true_nm(self.start_nm + self.step_nm * i as f64);
            acc[0] += l * weight(&obs.x_bar, wl);
            acc[1] += l * weight(&obs.y_bar, wl);
            acc[2] += l * weight(&obs.z_bar, wl);
        }
        let step_nm = self.step_nm * (1.0 + scale.slope);
        Ok(Xyz::from_array(acc.map(|a| a * K_M_LM_PER_W * step_nm)))
    }
}

/// An instrument's wavelength scale as a line lamp measured it
/// ([`crate::line_lamp`]): the sample labelled λ nm was taken at
/// `λ + offset_nm + slope·(λ − 580 nm)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WavelengthScale {
    /// Offset at 580 nm (nm).
    pub offset_nm: f64,
    /// Relative error of the dispersion (nm per nm).
    pub slope: f64,
}

impl WavelengthScale {
    /// The instrument's own labels (no correction).
    pub const NOMINAL: WavelengthScale = WavelengthScale {
        offset_nm: 0.0,
        slope: 0.0,
    };

    /// The wavelength the sample labelled `label_nm` was taken at (nm).
    pub fn true_nm(&self, label_nm: f64) -> f64 {
        label_nm + self.offset_nm + self.slope * (label_nm - 580.0)
    }
}

fn observer() -> Result<&'static Observer, DeviceError> {
    cie1931().map_err(|e| DeviceError::Config(e.to_string()))
}

/// A spot spectroradiometer: measures the spectral radiance of the spot it is aimed
/// at; as a [`Colorimeter`] it answers the XYZ of that spectrum.
pub trait Spectroradiometer: Colorimeter {
    /// Takes one spectral reading.
    fn measure_spectrum(&mut self) -> Result<SpectralRadiance, DeviceError>;

    /// The instrument's optical bandwidth: full width at half maximum of its slit
    /// function (nm), from its specification.
    fn bandwidth_nm(&self) -> f64;

    /// First and last wavelength it reports (nm).
    fn wavelength_range_nm(&self) -> [f64; 2];
}

/// A spectroradiometer read as a colorimeter whose XYZ are corrected for the
/// instrument's bandwidth ([`SpectralRadiance::xyz_bandpass_corrected`]) and, where a
/// line lamp measured it, its wavelength scale ([`SpectralRadiance::xyz_corrected`]):
/// the reference a filter colorimeter is matched to on narrow-band primaries.
pub struct CorrectedReference<'a> {
    /// The instrument.
    pub instrument: &'a mut dyn Spectroradiometer,
    /// Its wavelength scale ([`WavelengthScale::NOMINAL`] when unchecked).
    pub scale: WavelengthScale,
}

impl Colorimeter for CorrectedReference<'_> {
    fn info(&self) -> crate::MeterInfo {
        self.instrument.info()
    }

    fn measure(&mut self) -> Result<Xyz, DeviceError> {
        let bandwidth = self.instrument.bandwidth_nm();
        self.instrument
            .measure_spectrum()?
            .xyz_corrected(bandwidth, &self.scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(start_nm: f64, step_nm: f64, n: usize, v: f64) -> SpectralRadiance {
        SpectralRadiance {
            start_nm,
            step_nm,
            w_sr_m2_nm: vec![v; n],
        }
    }

    #[test]
    fn an_equal_energy_spectrum_has_luminance_683_times_the_integral_of_v_lambda() {
        // Σ ȳ·1 nm over 360–830 nm is 106.857 (CIE 15:2004 table, 1 nm); 380–780 nm
        // holds all but 0.01 of it.
        let y = flat(380.0, 1.0, 401, 1.0e-3).xyz().expect("xyz").y;
        assert!((y - 0.683 * 106.857).abs() < 0.683 * 0.02, "Y {y}");
        let e = flat(380.0, 1.0, 401, 1.0e-3).xyz().expect("xyz");
        let xy = e.chromaticity().expect("light");
        assert!((xy.x - 1.0 / 3.0).abs() < 2e-4 && (xy.y - 1.0 / 3.0).abs() < 2e-4);
    }

    #[test]
    fn a_coarser_grid_gives_the_same_tristimulus_values_for_a_smooth_spectrum() {
        let fine = flat(380.0, 1.0, 401, 2.0e-4).xyz().expect("xyz");
        let coarse = flat(380.0, 5.0, 81, 2.0e-4).xyz().expect("xyz");
        assert!((fine.y / coarse.y - 1.0).abs() < 2e-3);
    }

    #[test]
    fn grids_that_miss_the_visible_range_or_hold_bad_numbers_are_refused() {
        assert!(flat(400.0, 1.0, 381, 1.0).check("t").is_err());
        assert!(flat(380.0, 1.0, 300, 1.0).check("t").is_err());
        assert!(flat(380.0, 0.0, 401, 1.0).check("t").is_err());
        let mut s = flat(380.0, 1.0, 401, 1.0);
        s.w_sr_m2_nm[7] = f64::NAN;
        assert!(s.check("t").is_err());
        assert!(flat(380.0, 1.0, 401, 1.0).check("t").is_ok());
    }

    /// A 10 nm band at 530 nm sampled by an instrument whose scale reads `label` for
    /// `label + offset + slope·(label − 580)`.
    fn green_band(offset_nm: f64, slope: f64) -> SpectralRadiance {
        let scale = WavelengthScale { offset_nm, slope };
        SpectralRadiance {
            start_nm: 380.0,
            step_nm: 1.0,
            w_sr_m2_nm: (0..401)
                .map(|i| {
                    let wl = scale.true_nm(380.0 + f64::from(i));
                    1e-3 * (-((wl - 530.0) / 6.0).powi(2)).exp()
                })
                .collect(),
        }
    }

    #[test]
    fn a_known_wavelength_scale_error_is_corrected_on_a_narrow_green_band() {
        let dxy = |a: Xyz, b: Xyz| {
            let (a, b) = (a.xy().expect("xy"), b.xy().expect("xy"));
            (a[0] - b[0]).hypot(a[1] - b[1])
        };
        let truth = green_band(0.0, 0.0).xyz().expect("xyz");
        let scale = WavelengthScale {
            offset_nm: 0.4,
            slope: 2e-3,
        };
        let read = green_band(scale.offset_nm, scale.slope);
        let uncorrected = read.xyz().expect("xyz");
        let corrected = read.xyz_corrected(0.0, &scale).expect("xyz");
        assert!(dxy(uncorrected, truth) > 0.001, "{uncorrected:?}");
        // what is left: the CIE tables interpolated between their 1 nm rows
        assert!(dxy(corrected, truth) < 5e-5, "{corrected:?} vs {truth:?}");
        assert!((corrected.y / truth.y - 1.0).abs() < 2e-4);
    }
}
