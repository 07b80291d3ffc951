//! Display-type correction matrices for a filter colorimeter (ArgyllCMS's CCMX idea).
//!
//! A filter colorimeter's filters deviate from the CIE 1931 functions, so its error
//! depends on the spectrum: each display type (lamp, colour filters, Infitec comb of
//! one eye) has its own. The error is linear in the light, so no additivity test can
//! reveal it (R + G + B − 2·black = white holds in its readings). What corrects it is
//! a reference: a spectroradiometer reads the same patches, and a 3×3 matrix `M` with
//! `reference ≈ M · meter` is fitted by least squares on the black-subtracted red,
//! green, blue and white of one display of the type (as ArgyllCMS's `ccxxmake` does,
//! Gill 2009). The matrix then applies to every reading of every display of that type:
//! here, of that eye. Where the displays of one type still differ in spectrum (an
//! Infitec comb filter shifted by a few nm from projector to projector moves a filter
//! colorimeter's error a lot), one matrix per display is made instead
//! (`lumiwall meter-matrix --per-display`: the reference reads every display).
//!
//! [`MeterMatrices`] is saved as JSON (`lumiwall meter-matrix` writes it; `commission`
//! and `verify` take it with `--meter-matrix`). Readings go through it in
//! [`crate::measure::Session`], so commissioning, the warm-up wait and verification all
//! see corrected readings.

use std::path::Path;

use lumiwall_core::Eye;
use lumiwall_devices::{Colorimeter, DeviceError, DisplayInfo, Xyz};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::Rig;

/// Readings averaged per patch and instrument (a filter colorimeter's xy noise is a
/// large relative error in Z on an Infitec blue of y ≈ 0.03); a colour patch whose mean
/// chromaticity is still less certain than [`XY_STANDARD_ERROR`] gets more, up to
/// [`MAX_REPEATS`].
pub const REPEATS: u32 = 8;

/// Most readings per colour patch and instrument.
pub const MAX_REPEATS: u32 = 32;

/// The standard error of a colour patch's mean x and y (from its readings' scatter)
/// that ends its repeats: a tenth of the 0.002 a corrected Infitec primary may be off.
pub const XY_STANDARD_ERROR: f64 = 0.0002;

/// Version of the matrices file.
pub const FORMAT_VERSION: u32 = 1;

/// Largest relative residual of the fit (|reference − M·meter| / |reference| over the
/// four patches) accepted: a few times what the meter's noise leaves on a saturated
/// blue; above it the display is not one display type (e.g. a white segment the matrix
/// cannot carry) or a reading was wrong (aim, warm-up).
pub const MAX_FIT_RESIDUAL: f64 = 0.05;

/// Why a matrix could not be made or read.
#[derive(Debug, thiserror::Error)]
pub enum MeterMatrixError {
    /// The patches do not determine a matrix.
    #[error(
        "the {eye} display's readings of red, green and blue are (nearly) collinear in the \
         meter's readings: no correction matrix can be fitted; check the patterns reach \
         the display"
    )]
    Singular {
        /// Display type.
        eye: Eye,
    },
    /// The fit leaves too large a residual.
    #[error(
        "the {eye} correction matrix leaves a {:.1} % residual on the patches it was \
         fitted to (at most {:.1} %): the meter and the reference did not read the same \
         light (aim, warm-up) or the display is not additive",
        100.0 * residual,
        100.0 * MAX_FIT_RESIDUAL
    )]
    Residual {
        /// Display type.
        eye: Eye,
        /// The residual.
        residual: f64,
    },
    /// The reference instrument could not be opened.
    #[error("the reference spectroradiometer: {0}")]
    Reference(#[source] DeviceError),
    /// The reference's wavelength check failed.
    #[error(transparent)]
    WavelengthCheck(#[from] super::wavelength_check::WavelengthCheckError),
    /// A device failed while the patches were read.
    #[error("reading the {eye} display's patches for the meter matrix: {source}")]
    Device {
        /// Display type.
        eye: Eye,
        /// What the device reported.
        #[source]
        source: DeviceError,
    },
    /// The matrices belong to another instrument.
    #[error(
        "the meter matrices were made for '{made_for}', this meter is '{this}': a filter \
         colorimeter's error is its own; run `lumiwall meter-matrix` with this meter"
    )]
    OtherInstrument {
        /// The instrument the matrices were made for.
        made_for: String,
        /// The meter in use.
        this: String,
    },
    /// The file could not be read or written.
    #[error("meter matrix file {path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
}

/// The correction of one instrument for one display type (one eye of the wall).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeterMatrix {
    /// The display type: the eye whose displays it corrects.
    pub eye: Eye,
    /// The one display (index in the wall file) it was made on and corrects; `None`:
    /// every display of `eye` without a matrix of its own.
    #[serde(default)]
    pub display: Option<u32>,
    /// Row-major `M`: corrected XYZ = `M` · meter XYZ.
    pub matrix: [[f64; 3]; 3],
    /// Largest relative residual `|reference − M·meter| / |reference|` of the fit on
    /// its four patches.
    pub fit_residual: f64,
}

/// The corrections of one instrument, per display type.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeterMatrices {
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// The instrument corrected ("model serial").
    pub instrument: String,
    /// The reference it was matched to.
    pub reference: String,
    /// One matrix per eye of the wall.
    pub matrices: Vec<MeterMatrix>,
    /// The reference's wavelength check, if one was made before the matrices.
    #[serde(default)]
    pub reference_wavelength_check: Option<super::wavelength_check::WavelengthCheck>,
}

impl MeterMatrices {
    /// The matrix for display `display` of `eye`: its own if one was made, else the
    /// one of its eye, if any.
    pub fn for_display(&self, display: u32, eye: Eye) -> Option<Matrix3<f64>> {
        let own = self
            .matrices
            .iter()
            .find(|m| m.eye == eye && m.display == Some(display));
        own.or_else(|| {
            self.matrices
                .iter()
                .find(|m| m.eye == eye && m.display.is_none())
        })
        .map(|m| Matrix3::from_fn(|r, c| m.matrix[r][c]))
    }

    /// Reads and checks a matrices file.
    pub fn load(path: &Path) -> Result<Self, MeterMatrixError> {
        let err = |message: String| MeterMatrixError::File {
            path: path.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
        let m: MeterMatrices = serde_json::from_str(&text).map_err(|e| err(e.to_string()))?;
        if m.format_version != FORMAT_VERSION {
            return Err(err(format!(
                "format version {} (this lumiwall reads {FORMAT_VERSION})",
                m.format_version
            )));
        }
        let finite = m
            .matrices
            .iter()
            .all(|x| x.matrix.iter().flatten().all(|v| v.is_finite()));
        if m.matrices.is_empty() || !finite {
            return Err(err("no matrix, or a matrix with a non-finite entry".into()));
        }
        Ok(m)
    }

    /// Writes the file atomically.
    pub fn save(&self, path: &Path) -> Result<(), MeterMatrixError> {
        let text = serde_json::to_string_pretty(self).unwrap_or_default();
        lumiwall_profiles::write_atomic(path, text.as_bytes()).map_err(|e| MeterMatrixError::File {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }
}

/// Black, red, green, blue and white of one display, read by the meter and by the
/// reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PatchPairs {
    /// Meter readings `[black, R, G, B, W]`.
    pub meter: [Xyz; 5],
    /// Reference readings of the same patches.
    pub reference: [Xyz; 5],
}

/// Fits `M` with `reference ≈ M · meter` on the readings of R, G, B and W as read,
/// black included (the error is linear in all light, and the dark black's large
/// low-light noise would only add to the primaries'), each pair weighted by
/// `1 / |reference|²` so that relative errors count alike: weighted least squares,
/// `M = (Σ w·r·mᵀ)(Σ w·m·mᵀ)⁻¹`.
pub fn fit(eye: Eye, p: &PatchPairs) -> Result<MeterMatrix, MeterMatrixError> {
    let v = |x: Xyz| Vector3::new(x.x, x.y, x.z);
    let pairs: Vec<(Vector3<f64>, Vector3<f64>)> =
        (1..5).map(|i| (v(p.meter[i]), v(p.reference[i]))).collect();
    let mut mm = Matrix3::zeros();
    let mut rm = Matrix3::zeros();
    for (m, r) in &pairs {
        let w = 1.0 / r.norm_squared().max(f64::MIN_POSITIVE);
        mm += m * m.transpose() * w;
        rm += r * m.transpose() * w;
    }
    let inv = mm
        .try_inverse()
        .filter(|i| i.iter().all(|x| x.is_finite()))
        .ok_or(MeterMatrixError::Singular { eye })?;
    let matrix = rm * inv;
    let fit_residual = pairs
        .iter()
        .map(|(m, r)| (r - matrix * m).norm() / r.norm().max(f64::MIN_POSITIVE))
        .fold(0.0, f64::max);
    if fit_residual.is_nan() || fit_residual > MAX_FIT_RESIDUAL {
        return Err(MeterMatrixError::Residual {
            eye,
            residual: fit_residual,
        });
    }
    Ok(MeterMatrix {
        eye,
        display: None,
        matrix: std::array::from_fn(|r| std::array::from_fn(|c| matrix[(r, c)])),
        fit_residual,
    })
}

/// The drives of black, red, green, blue and white.
const PATCHES: [[f64; 3]; 5] = [
    [0.0; 3],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0; 3],
];

/// Mean of at least [`REPEATS`] readings (of `most` if that is fewer), more while
/// the mean's x or y standard error exceeds [`XY_STANDARD_ERROR`], at most `most`; a
/// patch too dark for the instrument reads as zero light.
fn averaged(meter: &mut dyn Colorimeter, most: u32) -> Result<Xyz, DeviceError> {
    let mut sum = Xyz::default();
    let mut xy: Vec<[f64; 2]> = Vec::new();
    let mut n = 0;
    while n < most.max(1) {
        match meter.measure() {
            Ok(v) => {
                sum = sum + v;
                xy.extend(v.xy());
            }
            Err(DeviceError::TooDark { .. }) => {}
            Err(e) => return Err(e),
        }
        n += 1;
        if n >= REPEATS.min(most) && xy_standard_error(&xy) <= XY_STANDARD_ERROR {
            break;
        }
    }
    Ok(sum * (1.0 / f64::from(n)))
}

/// The larger standard error of the mean of the x and of the y of `xy` (infinite
/// below two readings).
fn xy_standard_error(xy: &[[f64; 2]]) -> f64 {
    let n = xy.len() as f64;
    if xy.len() < 2 {
        return f64::INFINITY;
    }
    (0..2)
        .map(|k| {
            let mean = xy.iter().map(|p| p[k]).sum::<f64>() / n;
            let var = xy.iter().map(|p| (p[k] - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (var / n).sqrt()
        })
        .fold(0.0, f64::max)
}

/// Black, R, G, B and W of `display` at `uv`, read with the station's meter (through
/// `rig`) and with `reference`, which reads the spot the rig's positioner aims at.
pub fn measure_pairs(
    rig: &mut Rig<'_>,
    reference: &mut dyn Colorimeter,
    display: &DisplayInfo,
    uv: [f64; 2],
) -> Result<PatchPairs, DeviceError> {
    rig.positioner.aim(display.id, uv)?;
    let mut meter = [Xyz::default(); 5];
    let mut refr = [Xyz::default(); 5];
    for (i, drive) in PATCHES.iter().enumerate() {
        rig.pattern.show(display.id, *drive)?;
        let most = if i == 0 { REPEATS } else { MAX_REPEATS };
        meter[i] = averaged(rig.meter, most)?;
        refr[i] = averaged(reference, most)?;
    }
    Ok(PatchPairs {
        meter,
        reference: refr,
    })
}

/// One matrix per eye of the wall, each from the middle display of that eye (in wall
/// order), read at `uv`; with `per_display` also one for every display.
pub fn make(
    rig: &mut Rig<'_>,
    reference: &mut dyn Colorimeter,
    displays: &[DisplayInfo],
    uv: [f64; 2],
    per_display: bool,
) -> Result<MeterMatrices, MeterMatrixError> {
    let mut eyes: Vec<Eye> = Vec::new();
    for d in displays {
        if !eyes.contains(&d.eye) {
            eyes.push(d.eye);
        }
    }
    let mut matrices = Vec::with_capacity(eyes.len());
    for eye in eyes {
        let of_eye: Vec<&DisplayInfo> = displays.iter().filter(|d| d.eye == eye).collect();
        let display = of_eye[of_eye.len() / 2];
        let pairs = measure_pairs(rig, reference, display, uv)
            .map_err(|source| MeterMatrixError::Device { eye, source })?;
        matrices.push(fit(eye, &pairs)?);
        if per_display {
            for d in of_eye {
                let pairs = measure_pairs(rig, reference, d, uv)
                    .map_err(|source| MeterMatrixError::Device { eye, source })?;
                matrices.push(MeterMatrix {
                    display: Some(d.id.0),
                    ..fit(eye, &pairs)?
                });
            }
        }
    }
    Ok(MeterMatrices {
        format_version: FORMAT_VERSION,
        instrument: instrument_name(rig.meter.info()),
        reference: instrument_name(reference.info()),
        matrices,
        reference_wavelength_check: None,
    })
}

/// Names of the patches of [`PATCHES`].
const PATCH_NAMES: [&str; 5] = ["black", "red", "green", "blue", "white"];

/// One patch's chromaticity error against the truth, as read by the meter without and
/// with its correction, and by the reference the correction was matched to.
#[derive(Debug, Clone, PartialEq)]
pub struct PatchXyError {
    /// The display's name.
    pub display: String,
    /// Its eye.
    pub eye: Eye,
    /// Red, green, blue or white.
    pub patch: &'static str,
    /// Δxy of the meter's reading.
    pub meter: f64,
    /// Δxy of the corrected reading.
    pub corrected: f64,
    /// Δxy of the reference's reading: what no matching to it can remove.
    pub reference: f64,
}

/// The light a display sends for a drive (XYZ, cd/m²), e.g. the virtual wall's.
pub type TruthFn<'a> = dyn Fn(&DisplayInfo, [f64; 3]) -> Result<Xyz, DeviceError> + 'a;

/// Reads red, green, blue and white of every display at `uv` with the meter and the
/// reference ([`REPEATS`] readings each) and compares the chromaticities with `truth`
/// (on the virtual wall, the light the display sends), the meter's readings without
/// and with its matrix from `matrices`.
pub fn xy_errors(
    rig: &mut Rig<'_>,
    reference: &mut dyn Colorimeter,
    displays: &[DisplayInfo],
    uv: [f64; 2],
    matrices: &MeterMatrices,
    truth: &TruthFn<'_>,
) -> Result<Vec<PatchXyError>, DeviceError> {
    let mut out = Vec::new();
    for d in displays {
        let pairs = measure_pairs(rig, reference, d, uv)?;
        let matrix = matrices.for_display(d.id.0, d.eye);
        for i in 1..PATCHES.len() {
            let t = truth(d, PATCHES[i])?;
            let corrected = matrix.map_or(pairs.meter[i], |m| apply(&m, pairs.meter[i]));
            out.push(PatchXyError {
                display: d.name.clone(),
                eye: d.eye,
                patch: PATCH_NAMES[i],
                meter: xy_distance(pairs.meter[i], t),
                corrected: xy_distance(corrected, t),
                reference: xy_distance(pairs.reference[i], t),
            });
        }
    }
    Ok(out)
}

/// Chromaticity distance of two XYZ (infinite where either has no light).
fn xy_distance(a: Xyz, b: Xyz) -> f64 {
    match (a.chromaticity(), b.chromaticity()) {
        (Some(a), Some(b)) => a.distance(b),
        _ => f64::INFINITY,
    }
}

/// "model serial": what a matrix belongs to (the error of a filter colorimeter is the
/// instrument's own, not its model's).
pub fn instrument_name(i: lumiwall_devices::MeterInfo) -> String {
    format!("{} {}", i.model, i.serial)
}

impl MeterMatrices {
    /// Refuses matrices made for another instrument than `meter`.
    pub fn check_instrument(&self, meter: &dyn Colorimeter) -> Result<(), MeterMatrixError> {
        let this = instrument_name(meter.info());
        if self.instrument == this {
            Ok(())
        } else {
            Err(MeterMatrixError::OtherInstrument {
                made_for: self.instrument.clone(),
                this,
            })
        }
    }
}

/// `M · reading`; a component the matrix takes below zero (a saturated primary's
/// near-zero X or Z plus the readings' noise) is zero light.
pub fn apply(m: &Matrix3<f64>, reading: Xyz) -> Xyz {
    let c = m * Vector3::new(reading.x, reading.y, reading.z);
    Xyz::new(c[0].max(0.0), c[1].max(0.0), c[2].max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn xyz(v: [f64; 3]) -> Xyz {
        Xyz::new(v[0], v[1], v[2])
    }

    /// A meter whose x alternates by ±`spread` around a white, counting its readings.
    struct Scatter {
        spread: f64,
        readings: u32,
    }

    impl Colorimeter for Scatter {
        fn info(&self) -> lumiwall_devices::MeterInfo {
            lumiwall_devices::MeterInfo {
                model: "scatter".into(),
                serial: "0".into(),
                min_reliable_cd_m2: 0.0,
                max_cd_m2: f64::INFINITY,
                noise: None,
            }
        }
        fn measure(&mut self) -> Result<Xyz, DeviceError> {
            self.readings += 1;
            let sign = if self.readings.is_multiple_of(2) {
                1.0
            } else {
                -1.0
            };
            Ok(Xyz::new(95.0 + sign * self.spread, 100.0, 108.9))
        }
    }

    #[test]
    fn a_steady_patch_is_read_8_times_and_a_scattered_one_until_its_mean_is_certain() {
        let count = |spread| {
            let mut m = Scatter {
                spread,
                readings: 0,
            };
            averaged(&mut m, MAX_REPEATS).expect("reading");
            m.readings
        };
        // near this white x moves 0.00226 per unit of X
        // x scatter ±0.0002 (X ±0.09): standard error 0.00008 after 8
        assert_eq!(count(0.09), REPEATS);
        // ±0.0020 (X ±0.9): would need (0.0020/0.0002)² = 100 readings
        assert_eq!(count(0.9), MAX_REPEATS);
        // ±0.00081 (X ±0.36): (0.00081/0.0002)² = 16.6, 18 with the sample variance
        let mid = count(0.36);
        assert!((17..=19).contains(&mid), "{mid}");
    }

    /// An instrument whose readings are `A · truth` plus a black: the fit recovers `A⁻¹`
    /// from the four patches, and a white segment that is not in R + G + B breaks it.
    #[test]
    fn the_fit_inverts_a_linear_meter_error_and_refuses_what_is_not_one() {
        let a = Matrix3::new(1.02, 0.03, -0.01, -0.02, 0.99, 0.01, 0.0, 0.04, 1.05);
        let truth = [
            [0.1, 0.1, 0.12],
            [20.0, 11.0, 1.0],
            [15.0, 50.0, 6.0],
            [8.0, 3.0, 45.0],
        ];
        let mut t = truth.map(xyz).to_vec();
        t.push(t[1] + t[2] + t[3] - t[0] * 2.0);
        let read = |x: Xyz| apply(&a, x);
        let pairs = PatchPairs {
            meter: [t[0], t[1], t[2], t[3], t[4]].map(read),
            reference: [t[0], t[1], t[2], t[3], t[4]],
        };
        let m = fit(Eye::Left, &pairs).unwrap();
        let mm = Matrix3::from_fn(|r, c| m.matrix[r][c]);
        assert!((mm * a - Matrix3::identity()).norm() < 1e-12, "{mm}");
        assert!(m.fit_residual < 1e-12);
        // A white 20 % brighter in the reference only: no single matrix explains it.
        let mut bad = pairs;
        bad.reference[4] = bad.reference[4] * 1.2;
        assert!(matches!(
            fit(Eye::Left, &bad),
            Err(MeterMatrixError::Residual { .. })
        ));
    }
}
