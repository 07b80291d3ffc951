//! The reference spectroradiometer's wavelength scale, checked against a line lamp.
//!
//! A grating instrument's wavelength scale is specified to ±0.3 nm (CS-2000) or ±0.5 nm
//! (specbos), and an Infitec green moves by about 0.008 in xy per nm: a meter matrix
//! made against an unchecked reference inherits up to 0.003 of error on the green. A
//! mercury–argon lamp's lines are atomic constants. With the lamp before the lens, the
//! instrument's spectrum is averaged over a few readings; for each line that stands
//! clear of its neighbours at the instrument's bandwidth
//! ([`LineLamp::isolated_lines`]) the peak pixel is found near the line's wavelength
//! and the line's centroid taken over ±(FWHM + step/2) around it, re-centred on the
//! centroid (the slit function is symmetric, so the centroid is where the instrument
//! puts the line; a slit with wings beyond its FWHM loses a little of them to the
//! window, symmetrically once the window is centred). The offset (and, where the lines span 150 nm or more, the dispersion's
//! slope) that maps the measured centroids onto the true wavelengths is fitted by least
//! squares: the [`WavelengthScale`] the reference's readings are then corrected with
//! ([`lumiwall_devices::CorrectedReference`]).

use lumiwall_devices::WavelengthScale;
use lumiwall_devices::{DeviceError, LampHolder, LineLamp, SpectralRadiance, Spectroradiometer};
use serde::{Deserialize, Serialize};

/// Times a line's window is re-centred on its centroid.
const RECENTRE_STEPS: usize = 3;

/// Spectra averaged for the check.
pub const READINGS: u32 = 4;

/// How far from its true wavelength a line's peak is looked for (nm): the
/// instruments' specified ±0.5 nm with room to spare.
pub const SEARCH_NM: f64 = 2.0;

/// Largest offset accepted (nm): beyond it the instrument is out of its specification
/// and goes back to its maker.
pub const MAX_OFFSET_NM: f64 = 2.0;

/// Largest dispersion error accepted (relative): 1 % is 4 nm across 380–780 nm.
pub const MAX_SLOPE: f64 = 0.01;

/// Largest RMS disagreement between the lines and the fitted scale accepted (nm).
pub const MAX_RMS_NM: f64 = 0.1;

/// Smallest span of the lines (nm) over which a slope is fitted as well.
pub const SLOPE_SPAN_NM: f64 = 150.0;

/// One line as the instrument saw it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LineFit {
    /// The line's true wavelength (nm, air).
    pub true_nm: f64,
    /// Where the instrument put its centroid (nm, the instrument's labels).
    pub measured_nm: f64,
    /// True wavelength minus the corrected scale's wavelength of the centroid (nm).
    pub residual_nm: f64,
}

/// What the check found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WavelengthCheck {
    /// The lamp used.
    pub lamp: String,
    /// The fitted scale.
    pub scale: WavelengthScale,
    /// Whether the slope was fitted (else only the offset).
    pub slope_fitted: bool,
    /// The lines used.
    pub lines: Vec<LineFit>,
    /// RMS of the residuals (nm).
    pub rms_nm: f64,
}

/// Why the check failed.
#[derive(Debug, thiserror::Error)]
pub enum WavelengthCheckError {
    /// The instrument or the lamp holder failed.
    #[error("wavelength check: {0}")]
    Device(#[from] DeviceError),
    /// Fewer than two clean lines in the instrument's range.
    #[error(
        "wavelength check: the {lamp} has {found} line(s) clear of its neighbours at a \
         {fwhm_nm} nm bandwidth within {range:?} nm; at least 2 are needed"
    )]
    TooFewLines {
        /// The lamp.
        lamp: String,
        /// Clean lines found.
        found: usize,
        /// The instrument's bandwidth.
        fwhm_nm: f64,
        /// The instrument's range.
        range: [f64; 2],
    },
    /// A line is not in the spectrum.
    #[error(
        "wavelength check: no line near {true_nm:.2} nm (peak {peak:.3e} above the \
         background, whose spread is {spread:.3e}): is the {lamp} lit, warmed up and \
         before the lens?"
    )]
    LineMissing {
        /// The lamp.
        lamp: String,
        /// The line looked for.
        true_nm: f64,
        /// The largest value near it, above the background (the median sample).
        peak: f64,
        /// The background's spread (median absolute deviation of the samples).
        spread: f64,
    },
    /// The lines disagree or the offset is out of specification.
    #[error(
        "wavelength check: the scale fitted to the {lamp}'s lines is {offset_nm:+.3} nm, \
         slope {slope:+.2e}, with {rms_nm:.3} nm RMS between the lines (accepted: within \
         ±{MAX_OFFSET_NM} nm, slope ±{MAX_SLOPE}, {MAX_RMS_NM} nm RMS); a different lamp, \
         stray light, or an instrument due for service"
    )]
    OutOfSpecification {
        /// The lamp.
        lamp: String,
        /// The fitted offset.
        offset_nm: f64,
        /// The fitted slope.
        slope: f64,
        /// The lines' RMS disagreement.
        rms_nm: f64,
    },
}

/// Checks `instrument`'s wavelength scale with `lamp`, which `holder` puts before it
/// (and takes away again, also when the check fails).
pub fn check(
    instrument: &mut dyn Spectroradiometer,
    holder: &mut dyn LampHolder,
    lamp: &LineLamp,
) -> Result<WavelengthCheck, WavelengthCheckError> {
    let fwhm_nm = instrument.bandwidth_nm();
    let range = instrument.wavelength_range_nm();
    holder.place(lamp)?;
    let spectrum = average_spectrum(instrument, READINGS);
    let removed = holder.remove();
    let spectrum = spectrum?;
    removed?;
    let fwhm_nm = fwhm_nm.max(spectrum.step_nm);
    let wanted = lamp.isolated_lines(fwhm_nm, spectrum.step_nm, SEARCH_NM, range);
    if wanted.len() < 2 {
        return Err(WavelengthCheckError::TooFewLines {
            lamp: lamp.name.clone(),
            found: wanted.len(),
            fwhm_nm,
            range,
        });
    }
    let measured = wanted
        .iter()
        .map(|&l| line_centroid(&spectrum, l, fwhm_nm, &lamp.name))
        .collect::<Result<Vec<f64>, _>>()?;
    let result = fit_scale(&lamp.name, &wanted, &measured);
    let within = result.scale.offset_nm.abs() <= MAX_OFFSET_NM
        && result.scale.slope.abs() <= MAX_SLOPE
        && result.rms_nm <= MAX_RMS_NM;
    if !within {
        return Err(WavelengthCheckError::OutOfSpecification {
            lamp: lamp.name.clone(),
            offset_nm: result.scale.offset_nm,
            slope: result.scale.slope,
            rms_nm: result.rms_nm,
        });
    }
    Ok(result)
}

/// The mean of `n` spectral readings.
fn average_spectrum(
    instrument: &mut dyn Spectroradiometer,
    n: u32,
) -> Result<SpectralRadiance, DeviceError> {
    let mut sum = instrument.measure_spectrum()?;
    for _ in 1..n {
        let next = instrument.measure_spectrum()?;
        let same_grid = next.w_sr_m2_nm.len() == sum.w_sr_m2_nm.len()
            && next.start_nm == sum.start_nm
            && next.step_nm == sum.step_nm;
        if !same_grid {
            return Err(DeviceError::Garbled {
                device: instrument.info().model,
                command: "spectrum".into(),
                answer: "the wavelength grid changed between two readings".into(),
            });
        }
        for (a, b) in sum.w_sr_m2_nm.iter_mut().zip(&next.w_sr_m2_nm) {
            *a += b;
        }
    }
    for a in &mut sum.w_sr_m2_nm {
        *a /= f64::from(n);
    }
    Ok(sum)
}

/// Where the instrument put the line whose true wavelength is `true_nm` (in its own
/// labels): the centroid over ±(FWHM + step/2) around the largest sample within
/// ±[`SEARCH_NM`] of it, after the background (the median sample) is taken off, the
/// window then re-centred on the centroid.
fn line_centroid(
    s: &SpectralRadiance,
    true_nm: f64,
    fwhm_nm: f64,
    lamp: &str,
) -> Result<f64, WavelengthCheckError> {
    let label = |i: usize| s.start_nm + s.step_nm * i as f64;
    let background = median(&s.w_sr_m2_nm);
    let spread = median(
        &s.w_sr_m2_nm
            .iter()
            .map(|v| (v - background).abs())
            .collect::<Vec<_>>(),
    );
    let near = |i: &usize, reach: f64| (label(*i) - true_nm).abs() <= reach;
    let peak = (0..s.w_sr_m2_nm.len())
        .filter(|i| near(i, SEARCH_NM))
        .max_by(|a, b| s.w_sr_m2_nm[*a].total_cmp(&s.w_sr_m2_nm[*b]));
    let peak_value = peak.map_or(0.0, |p| s.w_sr_m2_nm[p] - background);
    let Some(peak) = peak.filter(|_| peak_value > 50.0 * spread.max(f64::MIN_POSITIVE)) else {
        return Err(WavelengthCheckError::LineMissing {
            lamp: lamp.into(),
            true_nm,
            peak: peak_value,
            spread,
        });
    };
    let missing = || WavelengthCheckError::LineMissing {
        lamp: lamp.into(),
        true_nm,
        peak: peak_value,
        spread,
    };
    // The window starts at the peak pixel and is re-centred on the centroid: a slit
    // with wings would pull an off-centre window's centroid toward its middle.
    let mut centre = label(peak);
    let mut centroid = f64::NAN;
    for _ in 0..RECENTRE_STEPS {
        let (mut moment, mut total) = (0.0, 0.0);
        for i in 0..s.w_sr_m2_nm.len() {
            if (label(i) - centre).abs() <= fwhm_nm + 0.5 * s.step_nm + 1e-9 {
                let v = s.w_sr_m2_nm[i] - background;
                moment += v * label(i);
                total += v;
            }
        }
        centroid = moment / total;
        if !(total > 0.0 && centroid.is_finite() && (centroid - true_nm).abs() <= SEARCH_NM) {
            return Err(missing());
        }
        centre = centroid;
    }
    Ok(centroid)
}

/// The median of `v` (0 for none).
fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// The scale mapping `measured` centroids to `truth`: offset only, or offset and slope
/// where the lines span [`SLOPE_SPAN_NM`] and there are at least three.
fn fit_scale(lamp: &str, truth: &[f64], measured: &[f64]) -> WavelengthCheck {
    let n = truth.len() as f64;
    let span = measured.iter().cloned().fold(f64::MIN, f64::max)
        - measured.iter().cloned().fold(f64::MAX, f64::min);
    let slope_fitted = truth.len() >= 3 && span >= SLOPE_SPAN_NM;
    let d: Vec<f64> = truth.iter().zip(measured).map(|(t, m)| t - m).collect();
    let x: Vec<f64> = measured.iter().map(|m| m - 580.0).collect();
    let (offset_nm, slope) = if slope_fitted {
        let (mx, md) = (x.iter().sum::<f64>() / n, d.iter().sum::<f64>() / n);
        let sxx: f64 = x.iter().map(|xi| (xi - mx).powi(2)).sum();
        let sxd: f64 = x.iter().zip(&d).map(|(xi, di)| (xi - mx) * (di - md)).sum();
        let slope = sxd / sxx;
        (md - slope * mx, slope)
    } else {
        (d.iter().sum::<f64>() / n, 0.0)
    };
    let scale = WavelengthScale { offset_nm, slope };
    let lines: Vec<LineFit> = truth
        .iter()
        .zip(measured)
        .map(|(&t, &m)| LineFit {
            true_nm: t,
            measured_nm: m,
            residual_nm: t - scale.true_nm(m),
        })
        .collect();
    let rms_nm = (lines.iter().map(|l| l.residual_nm.powi(2)).sum::<f64>() / n).sqrt();
    WavelengthCheck {
        lamp: lamp.into(),
        scale,
        slope_fitted,
        lines,
        rms_nm,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_and_slope_are_recovered_exactly_from_three_lines_on_a_linear_scale() {
        let truth = [435.8328, 546.0735, 738.3980];
        let scale = WavelengthScale {
            offset_nm: 0.31,
            slope: -4e-4,
        };
        // the instrument labels a line at true t as m with scale.true_nm(m) = t
        let measured: Vec<f64> = truth
            .iter()
            .map(|t| (t - 0.31 - 4e-4 * 580.0) / (1.0 - 4e-4))
            .collect();
        let fit = fit_scale("lamp", &truth, &measured);
        assert!(fit.slope_fitted);
        assert!(
            (fit.scale.offset_nm - scale.offset_nm).abs() < 1e-9,
            "{fit:?}"
        );
        assert!((fit.scale.slope - scale.slope).abs() < 1e-12, "{fit:?}");
        assert!(fit.rms_nm < 1e-9);
    }

    use lumiwall_devices::sim::{SimLampHolder, SimSpectroradiometer, SpectroModel, VirtualWall};
    use lumiwall_devices::{Colorimeter, EmissionLine, PatternOutput};

    /// A specbos aimed at the centre of the one-tile Infitec wall showing white, and
    /// the white's luminance there (cd/m²).
    fn specbos(seed: u64) -> (SimSpectroradiometer, f64) {
        use lumiwall_devices::MeterPositioner;
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures/walls/infitec-pair.toml");
        let wall = VirtualWall::from_toml_file(&path).expect("wall");
        let id = lumiwall_devices::DisplayId(0);
        wall.pattern_output().show(id, [1.0; 3]).expect("show");
        wall.positioner().aim(id, [0.5, 0.5]).expect("aim");
        let y = wall.emitted_xyz(id, [1.0; 3], [0.5, 0.5]).expect("truth").y;
        let s = SimSpectroradiometer::new(wall, SpectroModel::specbos_1211(seed)).expect("model");
        (s, y)
    }

    /// Puts its own lamp before the instrument, whatever it is asked for.
    struct OtherLamp(SimLampHolder, LineLamp);

    impl LampHolder for OtherLamp {
        fn place(&mut self, _: &LineLamp) -> Result<(), DeviceError> {
            self.0.place(&self.1)
        }
        fn remove(&mut self) -> Result<(), DeviceError> {
            self.0.remove()
        }
    }

    #[test]
    fn the_check_finds_a_specbos_offset_and_gives_the_instrument_back_to_the_wall() {
        for seed in [1, 5, 9] {
            let (mut s, white_cd_m2) = specbos(seed);
            let mut holder = s.lamp_holder();
            let c = check(&mut s, &mut holder, &LineLamp::hg_ar()).expect("check");
            assert!(
                (c.scale.offset_nm - s.wavelength_offset_nm()).abs() < 0.01 && c.slope_fitted,
                "{c:?} vs {}",
                s.wavelength_offset_nm()
            );
            // lamp away: the instrument reads the wall's white again (within its ±2 %)
            let y = s.measure().expect("white").y;
            assert!(
                (y / white_cd_m2 - 1.0).abs() < 0.025,
                "{y} vs {white_cd_m2}"
            );
        }
    }

    /// A 1 nm instrument resolves more lines; with its scale off by up to 0.5 nm, a
    /// ±2 nm search near a weak line must not land on a strong neighbour's flank
    /// (404.66 nm beside 407.78 nm).
    #[test]
    fn a_sharp_instrument_with_a_large_offset_is_checked_on_its_clean_lines() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures/walls/infitec-pair.toml");
        let wall = VirtualWall::from_toml_file(&path).expect("wall");
        let sharp = |seed| SpectroModel {
            bandwidth_nm: 1.0,
            ..SpectroModel::specbos_1211(seed)
        };
        let mut s = (1..200)
            .map(|seed| SimSpectroradiometer::new(wall.clone(), sharp(seed)).expect("model"))
            .find(|s| s.wavelength_offset_nm() < -0.4)
            .expect("an instrument with a large negative offset");
        let mut holder = s.lamp_holder();
        let c = check(&mut s, &mut holder, &LineLamp::hg_ar()).expect("check");
        assert!(c.lines.len() >= 6, "{c:?}");
        assert!(
            (c.scale.offset_nm - s.wavelength_offset_nm()).abs() < 0.01,
            "{c:?} vs {}",
            s.wavelength_offset_nm()
        );
    }

    #[test]
    fn a_lamp_left_off_or_a_neon_lamp_stops_the_check_at_the_first_missing_line() {
        let (mut s, _) = specbos(1);
        let holder = s.lamp_holder();
        let neon = LineLamp {
            name: "Ne lamp".into(),
            lines: [585.249, 640.225, 703.241, 724.517, 743.890]
                .iter()
                .map(|&wavelength_nm| EmissionLine {
                    wavelength_nm,
                    relative_intensity: 1.0,
                })
                .collect(),
        };
        let err = check(&mut s, &mut OtherLamp(holder, neon), &LineLamp::hg_ar()).unwrap_err();
        assert!(
            matches!(err, WavelengthCheckError::LineMissing { true_nm, .. } if true_nm == 435.8328),
            "{err}"
        );
        // a lamp that is not lit, held before the lens: the instrument sees no light
        let off = LineLamp {
            name: "unlit lamp".into(),
            lines: Vec::new(),
        };
        let mut unlit = OtherLamp(s.lamp_holder(), off);
        let err = check(&mut s, &mut unlit, &LineLamp::hg_ar()).unwrap_err();
        assert!(
            matches!(
                err,
                WavelengthCheckError::Device(DeviceError::TooDark { .. })
            ),
            "{err}"
        );
    }

    #[test]
    fn two_close_lines_give_the_offset_only() {
        let fit = fit_scale("lamp", &[435.8, 546.1], &[435.5, 545.8]);
        assert!(!fit.slope_fitted);
        assert!((fit.scale.offset_nm - 0.3).abs() < 1e-9);
    }
}
