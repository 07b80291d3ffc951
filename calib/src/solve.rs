//! The wall solve (Kresse 2003, 3.3.1–3.3.7; DESIGN.md steps 5–6): from each display's
//! black, primaries and ramps to one [`DisplayProfile`] per display and eye.
//!
//! Steps:
//! 1. Black is subtracted from every reading; `P` = black-subtracted XYZ of R, G, B
//!    (columns), `xyz_to_drive = P⁻¹`.
//! 2. Tone curves: a ramp reading's relative intensity is its least-squares component
//!    along its primary, `t = (XYZ − black)·P_c / |P_c|²`. It uses all three tristimulus
//!    values (the Y ratio alone is noisy for blue, whose Y is small) and equals the Y
//!    ratio when the channel's chromaticity is constant. The full-drive reading is the
//!    point (1, 1). Fit and inverse: [`crate::tone`].
//! 3. Common gamut of all displays (both eyes): [`crate::gamut`] on the black-subtracted
//!    primaries.
//! 4. White chromaticity from [`WhiteTarget`]; luminance: the largest `Y` such that on
//!    every display each channel needed for the white input (plus the black offset of
//!    the black mode) is ≤ headroom: the most limited channel is at exactly headroom.
//! 5. Black (3.3.6): `Ignore` offset 0; `Individual` offset `−P⁻¹·black`; `Common`
//!    offset `P⁻¹·(common_black − black)`, where the common black is the XYZ of least
//!    luminance that every display can show, i.e. `P_i⁻¹·(common_black − black_i) ≥ 0`
//!    for all i. It is found exactly as a 3-variable linear programme (vertex
//!    enumeration with cutting planes, starting from the implied bound
//!    `common_black ≥ black_i` componentwise), rather than Kresse's sequential clipping,
//!    which depends on display order and need not be minimal.

use std::fmt;

use lumiwall_core::{BitDepth, Channel, Headroom, Xy};
use lumiwall_devices::Xyz;
use lumiwall_profiles::{
    BlackMode, DisplayKey, DisplayModel, DisplayProfile, FORMAT_VERSION, MIN_LUT_ENTRIES,
    MeasurementInfo, OutOfGamut, ToneCurve,
};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::CalibError;
use crate::colorimetry::cct_to_xy;
use crate::gamut::{MIN_TRIANGLE_AREA, XyPoint, common_gamut_named, signed_area};
use crate::tone::fit_monotone_named;

/// A channel used for less than this fraction of the headroom by the white gets a
/// [`SolveWarning::LowChannelUsage`]: few code values are left for the image.
const LOW_USAGE_FRACTION: f64 = 0.25;

/// A display's own black counts as outside its gamut when a channel intensity of it is
/// below `−BLACK_OUTSIDE_TOLERANCE` (rounding of the matrix inverse).
const BLACK_OUTSIDE_TOLERANCE: f64 = 1e-9;

/// Smallest white-segment luminance, as a share of the full white's, that the solve
/// models ([`DisplayModel::WhiteSegment`]); below it the display counts as additive (a
/// residual of about meter noise, or a lamp drifting by a fraction of a percent in the
/// seconds between the primaries and the white, must not become a model term).
pub const MIN_WHITE_SEGMENT_SHARE: f64 = 0.02;

/// Largest negative component of a white segment in channel intensities, relative to its
/// largest one, still taken for a white segment (a clear segment passes the lamp's
/// light, a positive mixture of the primaries; noise may push one component slightly
/// below zero).
const WHITE_SEGMENT_NEGATIVE_SHARE: f64 = 0.1;

/// Relative tolerance within which a constraint of the common-black linear programme
/// counts as met (rounding of the 3×3 solves).
const LP_FEASIBILITY: f64 = 1e-9;

/// Everything measured on one display (one projector, one eye) for the solve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisplayMeasurement {
    /// Which display.
    pub key: DisplayKey,
    /// Bits per channel of the display input (8, 10, 12 or 16).
    pub bit_depth: u32,
    /// Reading at drive (0, 0, 0), XYZ in cd/m².
    pub black: Xyz,
    /// Readings at full drive of R, G, B alone, raw (black included), cd/m².
    pub primaries: [Xyz; 3],
    /// Reading at full drive W = (1, 1, 1), raw, for the additivity check.
    pub white: Option<Xyz>,
    /// Per channel R, G, B: `(drive 0..=1, raw XYZ)` readings in any order; may include
    /// drives 0 and 1.
    pub ramps: [Vec<(f64, Xyz)>; 3],
    /// Number of meter readings taken for this display.
    pub readings: u32,
    /// Instrument that measured (model and serial, or "virtual").
    pub instrument: String,
    /// Greys read whole at the drives a provisional profile gave them (the white, from
    /// [`crate::measure::grey_drives::WHOLE_GREY_MIN_BUDGET`] readings): the solve
    /// scales the primaries by per-channel gains so that the model shows them as read
    /// (`composite_gains`); empty in measurements written before them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub composites: Vec<CompositeReading>,
    /// Per channel, the relative standard error of each ramp sample's intensity, in the
    /// order of `ramps` ([`crate::measure::channel_colour::ramp_sigma_rel`]): the solve
    /// smooths each curve's samples within it ([`crate::tone::smoothing`]). Empty (the
    /// curve passes through the samples) for an exact meter, one that states no noise,
    /// a channel whose list does not match its ramp, and measurements written before it.
    #[serde(default, skip_serializing_if = "no_sigma")]
    pub ramp_sigma_rel: [Vec<f64>; 3],
}

/// True when no channel has stated sample errors (nothing to write).
fn no_sigma(s: &[Vec<f64>; 3]) -> bool {
    s.iter().all(Vec::is_empty)
}

/// A reading of all three channels together at one drive (a grey as the display
/// showed it), averaged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CompositeReading {
    /// The drive triple shown (each at a code of the display input).
    pub drive: [f64; 3],
    /// Mean reading, raw (black included), cd/m².
    pub xyz: Xyz,
    /// Readings averaged.
    pub readings: u32,
}

/// Target white of the wall.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum WhiteTarget {
    /// CIE 1931 xy chromaticity.
    Xy([f64; 2]),
    /// Correlated colour temperature in kelvin, on the CIE daylight locus (4000–25000 K).
    Cct(f64),
    /// The native white (R+G+B at full drive, black removed) of the display with this
    /// index in the measurement list.
    NativeOf(usize),
}

/// Options of the solve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SolveOptions {
    /// Target white chromaticity.
    pub white: WhiteTarget,
    /// Largest channel intensity the white may use, in (0, 1] (e.g. 0.9 leaves room for
    /// lamp ageing).
    pub headroom: f64,
    /// Black handling (Kresse 3.3.6).
    pub black_mode: BlackMode,
    /// Out-of-gamut handling written into the profiles.
    pub out_of_gamut: OutOfGamut,
    /// Entries of each inverse LUT (≥ 1024).
    pub lut_entries: usize,
    /// Relative additivity error |W − (R+G+B−2·black)| / Y_W above which a warning is
    /// issued.
    pub max_additivity_error: f64,
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self {
            white: WhiteTarget::Cct(6504.0),
            headroom: 1.0,
            black_mode: BlackMode::Individual,
            out_of_gamut: OutOfGamut::Clip,
            lut_entries: 4096,
            max_additivity_error: 0.02,
        }
    }
}

/// The display and channel that limit the wall white: at exactly the headroom.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Limiting {
    /// Index of the display in the measurement list.
    pub display: usize,
    /// Its channel at the headroom.
    pub channel: Channel,
}

impl Limiting {
    /// The old `(display index, channel 0..3)` form.
    pub fn as_tuple(self) -> (usize, usize) {
        (self.display, self.channel.index())
    }
}

/// Something the technician should know about a solved wall.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum SolveWarning {
    /// The target white is outside the common gamut triangle.
    WhiteOutsideCommonGamut {
        /// The target white chromaticity.
        white_xy: Xy,
    },
    /// A channel is used for little of its range by the white, so few code values carry
    /// the image (Kresse 3.3.9).
    LowChannelUsage {
        /// Display name.
        display: String,
        /// The channel.
        channel: Channel,
        /// Linear channel intensity the white uses, 0..=1.
        usage: f64,
        /// The display's bits per channel.
        bit_depth: BitDepth,
    },
    /// A display's black is outside its own gamut (negative channel intensities).
    BlackOutsideOwnGamut {
        /// Display name.
        display: String,
        /// Channel intensities of the black.
        intensities: [f64; 3],
    },
    /// The display is not additive and its white reading was modelled as a single-chip
    /// DLP's white segment ([`DisplayModel::WhiteSegment`]).
    WhiteSegment {
        /// Display name.
        display: String,
        /// Luminance of the white segment as a share of the full white's.
        share: f64,
    },
    /// The additivity error exceeds [`SolveOptions::max_additivity_error`] and is not a
    /// white segment.
    Additivity {
        /// Display name.
        display: String,
        /// Relative additivity error |W − (R+G+B−2·black)| / Y_W.
        error: f64,
        /// The allowed error.
        limit: f64,
    },
}

impl fmt::Display for SolveWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SolveWarning::WhiteOutsideCommonGamut { white_xy } => write!(
                f,
                "target white xy ({:.4}, {:.4}) lies outside the common gamut triangle",
                white_xy.x, white_xy.y
            ),
            SolveWarning::LowChannelUsage {
                display,
                channel,
                usage,
                bit_depth,
            } => write!(
                f,
                "{display}: {} channel only {:.0} % used for the white; fewer than {:.0} of {} code values carry the image (consider lowering this channel in the projector's service menu, Kresse 3.3.9)",
                channel.name(),
                100.0 * usage,
                usage * bit_depth.max_code_f64(),
                bit_depth.max_code() + 1
            ),
            SolveWarning::BlackOutsideOwnGamut {
                display,
                intensities: own,
            } => write!(
                f,
                "{display}: black lies outside its own gamut (channel intensities {:.4}, {:.4}, {:.4})",
                own[0], own[1], own[2]
            ),
            SolveWarning::WhiteSegment { display, share } => write!(
                f,
                "{display}: not additive: a white segment of {:.1} % of the full white's luminance (single-chip DLP); modelled as white ∝ min(R, G, B) and inverted by the profile",
                100.0 * share
            ),
            SolveWarning::Additivity {
                display,
                error,
                limit,
            } => write!(
                f,
                "{display}: additivity error {:.1} % (|W − (R+G+B−2·black)| / Y_W) exceeds {:.1} %; the matrix model will be off by about that much",
                100.0 * error,
                100.0 * limit
            ),
        }
    }
}

/// Result of the wall solve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WallSolution {
    /// One profile per measurement, in the same order.
    pub profiles: Vec<DisplayProfile>,
    /// xy of the common primaries R, G, B.
    pub common_primaries_xy: [[f64; 2]; 3],
    /// The wall's white (input for common RGB 1,1,1), XYZ in cd/m², black excluded.
    pub white_xyz_cd_m2: Xyz,
    /// The common black (least-luminance black every display can show), XYZ in cd/m².
    /// Computed in every mode; shown only in `Common` mode.
    pub common_black_xyz_cd_m2: Xyz,
    /// The display and channel at exactly the headroom.
    pub limiting: Limiting,
    /// Things the technician should know (low channel usage, additivity, …); `Display`
    /// gives the text for reports.
    pub warnings: Vec<SolveWarning>,
}

/// Per-display quantities derived from the measurement.
struct Prepared {
    /// Black-subtracted primaries as columns.
    p: Matrix3<f64>,
    p_inv: Matrix3<f64>,
    black: Vector3<f64>,
    curves: Option<[ToneCurve; 3]>,
    additivity_error: Option<f64>,
    /// How the channels mix (a white segment when the white reading shows one).
    model: DisplayModel,
}

impl Prepared {
    /// Channel intensities that show `XYZ − black = P·m` on this display
    /// ([`DisplayModel::channels_for`]).
    fn channels_for(&self, m: Vector3<f64>) -> Vector3<f64> {
        Vector3::from(self.model.channels_for(&rows(&self.p_inv), arr(&m)))
    }

    /// Share of the full white's luminance that the white segment gives (0 additive).
    fn white_segment_share(&self) -> f64 {
        match self.model {
            DisplayModel::Additive => 0.0,
            DisplayModel::WhiteSegment { white_xyz_cd_m2: w } => {
                let full = self.p.row(1).sum() + w[1];
                if full > 0.0 { w[1] / full } else { 0.0 }
            }
        }
    }
}

/// The display model the white reading asks for: a white segment when the white holds
/// more light than R + G + B (at least [`MIN_WHITE_SEGMENT_SHARE`] of its luminance)
/// and that light is a positive mix of the primaries; otherwise additive (and a
/// remaining additivity error is the solve's warning).
fn display_model(white: Option<Xyz>, sum: Vector3<f64>, p_inv: &Matrix3<f64>) -> DisplayModel {
    let Some(w) = white else {
        return DisplayModel::Additive;
    };
    let residual = w.to_vector() - sum;
    if !(w.y > 0.0 && residual[1] >= MIN_WHITE_SEGMENT_SHARE * w.y) {
        return DisplayModel::Additive;
    }
    let u = p_inv * residual;
    let largest = u.max();
    let positive_mix = largest > 0.0
        && u.iter()
            .all(|v| *v >= -WHITE_SEGMENT_NEGATIVE_SHARE * largest);
    if positive_mix && DisplayModel::invertible(arr(&u)) {
        DisplayModel::WhiteSegment {
            white_xyz_cd_m2: arr(&residual),
        }
    } else {
        DisplayModel::Additive
    }
}

/// Largest negative X or Z, as a share of the reading's X + Y + Z, taken as a
/// colorimeter's noise rather than a wrong zero: the Z of a dim red is a few per
/// mille of its light, and a sensor's zero-light noise of a few mcd/m² takes it below
/// zero about half the time (a red of 0.1 cd/m² under a CS-100A's 8 mcd/m² in Z).
const NEGATIVE_NOISE_SHARE: f64 = 0.02;

/// Refuses a non-finite component, a negative Y, and an X or Z more negative than
/// [`NEGATIVE_NOISE_SHARE`] of the reading.
fn check_xyz(what: &str, v: Xyz) -> Result<(), CalibError> {
    let noise = NEGATIVE_NOISE_SHARE * (v.x + v.y + v.z).max(0.0);
    for (name, c, tolerance) in [("X", v.x, noise), ("Y", v.y, 0.0), ("Z", v.z, noise)] {
        if !c.is_finite() {
            return Err(CalibError::NonFinite {
                what: format!("{what} {name}"),
                value: c,
            });
        }
        if c < -tolerance {
            return Err(CalibError::Negative {
                what: format!("{what} {name}"),
                value: c,
            });
        }
    }
    Ok(())
}

/// Checks the black and full-drive primary readings of a display.
fn check_black_and_primaries(name: &str, m: &DisplayMeasurement) -> Result<(), CalibError> {
    check_xyz(&format!("{name}: black reading"), m.black)?;
    for c in Channel::ALL {
        check_xyz(
            &format!("{name}: {} full-drive reading", c.name()),
            m.primaries[c.index()],
        )?;
    }
    Ok(())
}

/// `m` as rows, the profile's matrix layout (`xyz_to_drive`).
pub(crate) fn rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
}

fn arr(v: &Vector3<f64>) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

/// The display's bit depth for code-value counts (clamped into 1..=16).
pub(crate) fn clamped_bit_depth(bits: u32) -> BitDepth {
    BitDepth::new(bits.clamp(1, BitDepth::MAX_BITS)).unwrap_or(BitDepth::EIGHT)
}

fn invalid_option(option: &str, reason: String) -> CalibError {
    CalibError::InvalidOption {
        option: option.into(),
        reason,
    }
}

/// Headroom as the vocabulary type; the error names the option.
fn checked_headroom(headroom: f64) -> Result<Headroom, CalibError> {
    Headroom::new(headroom)
        .map_err(|_| invalid_option("headroom", format!("{headroom} is not in (0, 1]")))
}

/// Refuses an empty measurement list.
fn require_measurements(measurements: &[DisplayMeasurement]) -> Result<(), CalibError> {
    if measurements.is_empty() {
        return Err(invalid_option("measurements", "no display measured".into()));
    }
    Ok(())
}

fn validate_options(o: &SolveOptions) -> Result<(), CalibError> {
    checked_headroom(o.headroom)?;
    if o.lut_entries < MIN_LUT_ENTRIES {
        return Err(invalid_option(
            "lut_entries",
            format!(
                "{} is below the minimum of {MIN_LUT_ENTRIES}",
                o.lut_entries
            ),
        ));
    }
    if !(o.max_additivity_error >= 0.0 && o.max_additivity_error.is_finite()) {
        return Err(invalid_option(
            "max_additivity_error",
            format!("{} is not a finite number ≥ 0", o.max_additivity_error),
        ));
    }
    Ok(())
}

fn prepare(m: &DisplayMeasurement, lut_entries: Option<usize>) -> Result<Prepared, CalibError> {
    let name = m.key.to_string();
    check_black_and_primaries(&name, m)?;
    if let Some(w) = m.white {
        check_xyz(&format!("{name}: white full-drive reading"), w)?;
    }
    let black = m.black.to_vector();
    let cols: Vec<Vector3<f64>> = m.primaries.iter().map(|p| p.to_vector() - black).collect();
    for c in Channel::ALL {
        let col = cols[c.index()];
        if col[1].is_nan() || col[1] <= 0.0 || col.iter().sum::<f64>() <= 0.0 {
            return Err(CalibError::NoSignal {
                what: format!("{name}: {} channel", c.name()),
                full_drive: col[1],
            });
        }
    }
    let tri: Vec<XyPoint> = cols.iter().filter_map(|c| Xyz::from(*c).xy()).collect();
    let area = if tri.len() == 3 {
        signed_area(tri[0], tri[1], tri[2]).abs()
    } else {
        0.0
    };
    let degenerate = || CalibError::DegeneratePrimaries {
        display: name.clone(),
        area,
        min_area: MIN_TRIANGLE_AREA,
    };
    if area < MIN_TRIANGLE_AREA {
        return Err(degenerate());
    }
    let p = Matrix3::from_columns(&cols);
    let p_inv = p.try_inverse().ok_or_else(degenerate)?;
    let sum = cols[0] + cols[1] + cols[2] + black;
    let additivity_error = m.white.and_then(|w| {
        let wy = w.y;
        (wy > 0.0).then(|| (w.to_vector() - sum).norm() / wy)
    });
    let model = display_model(m.white, sum, &p_inv);
    let curves = match lut_entries {
        Some(entries) => Some(fit_curves(m, &name, &cols, entries)?),
        None => None,
    };
    let gains = curves
        .as_ref()
        .and_then(|c| composite_gains(m, &p, &model, c));
    let (p, p_inv) = match gains {
        Some(g) => {
            let scaled = p * Matrix3::from_diagonal(&g);
            (scaled, scaled.try_inverse().ok_or_else(degenerate)?)
        }
        None => (p, p_inv),
    };
    Ok(Prepared {
        p,
        p_inv,
        black,
        curves,
        additivity_error,
        model,
    })
}

/// Largest relative change of a channel's full-drive light that the composite readings
/// may make (the solve's `composite_gains`): a few times what a colorimeter's noise
/// leaves on four averaged primaries; more means the display changed between the
/// readings (drift, a lamp) or a reading was wrong, and the readings are left as they
/// are.
pub const MAX_COMPOSITE_GAIN_CHANGE: f64 = 0.03;

/// Channel gains `g` that make the model show the composite readings as read: least
/// squares over `P·diag(c(d))·g = W_d − K − W_seg·min(c(d))` with `c` the tone curves'
/// intensities at each reading's drive. Scaling `P`'s columns by `g` moves the white
/// and every grey together (the greys keep their balance against the white), where
/// one knot per channel at the white's drive would move the white alone. `None` without
/// composite readings, or when a gain is not finite or changes a channel by more than
/// [`MAX_COMPOSITE_GAIN_CHANGE`].
fn composite_gains(
    m: &DisplayMeasurement,
    p: &Matrix3<f64>,
    model: &DisplayModel,
    curves: &[ToneCurve; 3],
) -> Option<Vector3<f64>> {
    if m.composites.is_empty() {
        return None;
    }
    let segment = match model {
        DisplayModel::Additive => Vector3::zeros(),
        DisplayModel::WhiteSegment { white_xyz_cd_m2 } => Vector3::from(*white_xyz_cd_m2),
    };
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for r in &m.composites {
        let c = Vector3::from_fn(|i, _| curves[i].intensity_for(r.drive[i]));
        let a = p * Matrix3::from_diagonal(&c);
        let b = r.xyz.to_vector() - m.black.to_vector() - segment * c.min();
        ata += a.transpose() * a;
        atb += a.transpose() * b;
    }
    let g = ata.try_inverse()? * atb;
    let plausible = g
        .iter()
        .all(|v| v.is_finite() && (v - 1.0).abs() <= MAX_COMPOSITE_GAIN_CHANGE);
    plausible.then_some(g)
}

/// Tone curves of the three channels from the ramps (step 2 of the module docs).
fn fit_curves(
    m: &DisplayMeasurement,
    name: &str,
    cols: &[Vector3<f64>],
    entries: usize,
) -> Result<[ToneCurve; 3], CalibError> {
    let black = m.black.to_vector();
    let fit = |c: Channel| -> Result<ToneCurve, CalibError> {
        let what = format!("{name}: {} ramp", c.name());
        let pc = cols[c.index()];
        let norm2 = pc.norm_squared();
        let ramp = &m.ramps[c.index()];
        let mut samples: Vec<(f64, f64)> = Vec::with_capacity(ramp.len() + 1);
        for &(drive, xyz) in ramp {
            check_xyz(&format!("{what} at drive {drive:.4}"), xyz)?;
            samples.push((drive, (xyz.to_vector() - black).dot(&pc) / norm2));
        }
        crate::tone::smoothing::smooth_within_noise(&mut samples, &m.ramp_sigma_rel[c.index()]);
        samples.push((1.0, 1.0));
        fit_monotone_named(&samples, &what)?.to_tone_curve(entries)
    };
    Ok([
        fit(Channel::Red)?,
        fit(Channel::Green)?,
        fit(Channel::Blue)?,
    ])
}

fn prepare_all(
    measurements: &[DisplayMeasurement],
    lut_entries: Option<usize>,
) -> Result<Vec<Prepared>, CalibError> {
    measurements
        .iter()
        .map(|m| prepare(m, lut_entries))
        .collect()
}

/// xy triangles `[R, G, B]` of the displays' black-subtracted primaries, named by key.
pub fn primaries_xy(
    measurements: &[DisplayMeasurement],
) -> Result<Vec<(String, [XyPoint; 3])>, CalibError> {
    measurements
        .iter()
        .map(|m| {
            let name = m.key.to_string();
            let mut tri = [[0.0; 2]; 3];
            for c in Channel::ALL {
                let i = c.index();
                tri[i] = above_black(m.primaries[i], m.black).xy().ok_or_else(|| {
                    CalibError::NoSignal {
                        what: format!("{name}: {} channel", c.name()),
                        full_drive: m.primaries[i].y - m.black.y,
                    }
                })?;
            }
            Ok((name, tri))
        })
        .collect()
}

/// What a channel adds to black: `reading − black` with each component at least 0. A
/// light adds no negative tristimulus value; a saturated primary's Z (red) or X
/// (green, blue) is close to the black's, and a reading's noise or a meter's
/// correction matrix can leave it just below, which would put the primary's
/// chromaticity outside the diagram (x + y > 1).
fn above_black(reading: Xyz, black: Xyz) -> Xyz {
    let d = reading - black;
    Xyz::new(d.x.max(0.0), d.y.max(0.0), d.z.max(0.0))
}

/// Solves the wall: common gamut of the black-subtracted primaries, then
/// [`solve_wall_in_gamut`]. The profiles are stamped with the current time; use
/// [`solve_wall_at`] to pass it.
pub fn solve_wall(
    measurements: &[DisplayMeasurement],
    options: &SolveOptions,
) -> Result<WallSolution, CalibError> {
    solve_wall_at(measurements, options, &now_rfc3339())
}

/// [`solve_wall`] with the profiles' creation time `created_utc` (RFC 3339, e.g.
/// [`now_rfc3339`]) given by the caller.
pub fn solve_wall_at(
    measurements: &[DisplayMeasurement],
    options: &SolveOptions,
    created_utc: &str,
) -> Result<WallSolution, CalibError> {
    require_measurements(measurements)?;
    for m in measurements {
        check_black_and_primaries(&m.key.to_string(), m)?;
    }
    let gamut = common_gamut_named(&primaries_xy(measurements)?)?;
    solve_wall_in_gamut_at(measurements, options, gamut, created_utc)
}

/// Solves the wall for a given common gamut `[R, G, B]` xy (e.g. one computed from raw
/// primaries, as reproduces Kresse's Tab. 6): white, luminance scale, black, matrices
/// and tone curves. The profiles are stamped with the current time; use
/// [`solve_wall_in_gamut_at`] to pass it.
pub fn solve_wall_in_gamut(
    measurements: &[DisplayMeasurement],
    options: &SolveOptions,
    common_primaries_xy: [[f64; 2]; 3],
) -> Result<WallSolution, CalibError> {
    solve_wall_in_gamut_at(measurements, options, common_primaries_xy, &now_rfc3339())
}

/// The wall-wide terms every profile shares.
struct WallTerms<'a> {
    white: Vector3<f64>,
    common_black: Vector3<f64>,
    common_primaries_xy: [[f64; 2]; 3],
    created_utc: &'a str,
}

/// [`solve_wall_in_gamut`] with the profiles' creation time `created_utc` (RFC 3339)
/// given by the caller.
pub fn solve_wall_in_gamut_at(
    measurements: &[DisplayMeasurement],
    options: &SolveOptions,
    common_primaries_xy: [[f64; 2]; 3],
    created_utc: &str,
) -> Result<WallSolution, CalibError> {
    validate_options(options)?;
    require_measurements(measurements)?;
    let prepared = prepare_all(measurements, Some(options.lut_entries))?;
    let ws = white_from_prepared(
        &prepared,
        measurements,
        options.white,
        options.headroom,
        options.black_mode,
    )?;
    let mut warnings = Vec::new();
    if !inside_triangle(common_primaries_xy, ws.white_xy) {
        warnings.push(SolveWarning::WhiteOutsideCommonGamut {
            white_xy: Xy::from(ws.white_xy),
        });
    }
    let wall = WallTerms {
        white: ws.white_xyz_cd_m2.to_vector(),
        common_black: ws.common_black_xyz_cd_m2.to_vector(),
        common_primaries_xy,
        created_utc,
    };
    let mut profiles = Vec::with_capacity(measurements.len());
    for ((m, p), offset) in measurements.iter().zip(&prepared).zip(&ws.drive_offsets) {
        let offset = Vector3::from(*offset);
        let usage = p.channels_for(p.p_inv * wall.white + offset);
        warnings.extend(display_warnings(m, p, &usage, options));
        profiles.push(display_profile(m, p, options, &wall, &offset, &usage)?);
    }
    Ok(WallSolution {
        profiles,
        common_primaries_xy,
        white_xyz_cd_m2: ws.white_xyz_cd_m2,
        common_black_xyz_cd_m2: ws.common_black_xyz_cd_m2,
        limiting: ws.limiting,
        warnings,
    })
}

/// True when `point` is inside (or on) the triangle `tri`, either orientation.
fn inside_triangle(tri: [[f64; 2]; 3], point: [f64; 2]) -> bool {
    (0..3).all(|e| {
        signed_area(tri[e], tri[(e + 1) % 3], point) * signed_area(tri[0], tri[1], tri[2]) >= 0.0
    })
}

/// Low channel usage, black outside the display's own gamut and additivity warnings
/// of one display.
fn display_warnings(
    m: &DisplayMeasurement,
    p: &Prepared,
    usage: &Vector3<f64>,
    options: &SolveOptions,
) -> Vec<SolveWarning> {
    let name = m.key.to_string();
    let mut warnings = Vec::new();
    for channel in Channel::ALL {
        let used = usage[channel.index()];
        if used < LOW_USAGE_FRACTION * options.headroom {
            warnings.push(SolveWarning::LowChannelUsage {
                display: name.clone(),
                channel,
                usage: used,
                bit_depth: clamped_bit_depth(m.bit_depth),
            });
        }
    }
    let own = p.p_inv * p.black;
    if own.iter().any(|v| *v < -BLACK_OUTSIDE_TOLERANCE) {
        warnings.push(SolveWarning::BlackOutsideOwnGamut {
            display: name.clone(),
            intensities: arr(&own),
        });
    }
    let share = p.white_segment_share();
    if share > 0.0 {
        warnings.push(SolveWarning::WhiteSegment {
            display: name,
            share,
        });
    } else if let Some(e) = p.additivity_error
        && e > options.max_additivity_error
    {
        warnings.push(SolveWarning::Additivity {
            display: name,
            error: e,
            limit: options.max_additivity_error,
        });
    }
    warnings
}

/// The validated profile of one display.
fn display_profile(
    m: &DisplayMeasurement,
    p: &Prepared,
    options: &SolveOptions,
    wall: &WallTerms<'_>,
    offset: &Vector3<f64>,
    usage: &Vector3<f64>,
) -> Result<DisplayProfile, CalibError> {
    let shown_black = match options.black_mode {
        BlackMode::Common => wall.common_black,
        BlackMode::Ignore | BlackMode::Individual => p.black,
    };
    let primaries = Channel::ALL.map(|c| arr(&p.p.column(c.index()).into_owned()));
    let profile = DisplayProfile {
        format_version: FORMAT_VERSION,
        display: m.key.clone(),
        created_utc: wall.created_utc.to_string(),
        primaries_xyz_cd_m2: primaries,
        black_xyz_cd_m2: arr(&p.black),
        display_model: p.model,
        black_mode: options.black_mode,
        shown_black_xyz_cd_m2: arr(&shown_black),
        target_white_xyz_cd_m2: arr(&wall.white),
        common_primaries_xy: wall.common_primaries_xy,
        xyz_to_drive: rows(&p.p_inv),
        drive_offset: arr(offset),
        channel_usage: arr(usage),
        headroom: options.headroom,
        curves: p
            .curves
            .clone()
            .ok_or_else(|| invalid_option("curves", "tone curves were not fitted".into()))?,
        flat_field: None,
        out_of_gamut: options.out_of_gamut,
        bit_depth: m.bit_depth,
        measurement: MeasurementInfo {
            instrument: m.instrument.clone(),
            readings: m.readings,
            additivity_error: p.additivity_error,
        },
    };
    profile.validate()?;
    Ok(profile)
}

/// The wall's white and black, solved from primaries and blacks alone (no tone curves).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WhiteSolution {
    /// Target white chromaticity.
    pub white_xy: [f64; 2],
    /// The wall's white (input for common RGB 1,1,1), XYZ in cd/m², black excluded.
    pub white_xyz_cd_m2: Xyz,
    /// The common black (least-luminance black every display can show), cd/m².
    pub common_black_xyz_cd_m2: Xyz,
    /// The display and channel at exactly the headroom.
    pub limiting: Limiting,
    /// Per display: the black term added after the matrix (linear channel intensity).
    pub drive_offsets: Vec<[f64; 3]>,
    /// Per display: linear channel intensities driven for the white input.
    pub channel_usage: Vec<[f64; 3]>,
}

/// Solves only white and black (Kresse 3.3.3, 3.3.6) from the displays' black and
/// full-drive primaries (ramps are not used and may be empty): the largest white of the
/// target chromaticity such that the most limited channel of any display is at exactly
/// `headroom`, with the black offset of `black_mode`.
pub fn solve_white(
    measurements: &[DisplayMeasurement],
    white: WhiteTarget,
    headroom: f64,
    black_mode: BlackMode,
) -> Result<WhiteSolution, CalibError> {
    checked_headroom(headroom)?;
    require_measurements(measurements)?;
    let prepared = prepare_all(measurements, None)?;
    white_from_prepared(&prepared, measurements, white, headroom, black_mode)
}

fn white_from_prepared(
    prepared: &[Prepared],
    measurements: &[DisplayMeasurement],
    white: WhiteTarget,
    headroom: f64,
    black_mode: BlackMode,
) -> Result<WhiteSolution, CalibError> {
    let white_xy = target_white_xy(prepared, measurements, white)?;
    let w_unit = Xyz::from_xy_luminance(white_xy[0], white_xy[1], 1.0).to_vector();
    // Common black (computed always, used in Common mode).
    let common_black = common_black(prepared)?;
    let offsets = black_offsets(prepared, black_mode, &common_black);
    let scale = WhiteScale {
        prepared,
        measurements,
        w_unit,
        white_xy,
        offsets: &offsets,
    };
    let (y_white, limiting) = scale.luminance(headroom)?;
    scale.check_above_own_black(y_white, limiting)?;
    let white = w_unit * y_white;
    let channel_usage = prepared
        .iter()
        .zip(&offsets)
        .map(|(p, o)| arr(&p.channels_for(p.p_inv * white + o)))
        .collect();
    Ok(WhiteSolution {
        white_xy,
        white_xyz_cd_m2: Xyz::from(white),
        common_black_xyz_cd_m2: Xyz::from(common_black),
        limiting,
        drive_offsets: offsets.iter().map(arr).collect(),
        channel_usage,
    })
}

/// Target white chromaticity (step 4 of the module docs), validated.
fn target_white_xy(
    prepared: &[Prepared],
    measurements: &[DisplayMeasurement],
    white: WhiteTarget,
) -> Result<[f64; 2], CalibError> {
    let white_xy = match white {
        WhiteTarget::Xy(xy) => xy,
        WhiteTarget::Cct(k) => cct_to_xy(k)?,
        WhiteTarget::NativeOf(i) => {
            let p = prepared.get(i).ok_or_else(|| {
                invalid_option(
                    "white",
                    format!(
                        "native white of display index {i}, but only {} displays were measured",
                        measurements.len()
                    ),
                )
            })?;
            Xyz::from(p.p * Vector3::new(1.0, 1.0, 1.0))
                .xy()
                .ok_or_else(|| {
                    invalid_option("white", format!("display index {i} has no native white"))
                })?
        }
    };
    if !Xy::from(white_xy).is_valid() {
        return Err(invalid_option(
            "white",
            format!("xy {white_xy:?} is not a valid chromaticity"),
        ));
    }
    Ok(white_xy)
}

/// Offsets per black mode, in channel space (step 5 of the module docs).
fn black_offsets(
    prepared: &[Prepared],
    black_mode: BlackMode,
    common_black: &Vector3<f64>,
) -> Vec<Vector3<f64>> {
    prepared
        .iter()
        .map(|p| match black_mode {
            BlackMode::Ignore => Vector3::zeros(),
            BlackMode::Individual => -(p.p_inv * p.black),
            BlackMode::Common => p.p_inv * (common_black - p.black),
        })
        .collect()
}

/// The luminance scale of the wall white: inputs shared by its two checks.
struct WhiteScale<'a> {
    prepared: &'a [Prepared],
    measurements: &'a [DisplayMeasurement],
    /// The target white at 1 cd/m².
    w_unit: Vector3<f64>,
    white_xy: [f64; 2],
    offsets: &'a [Vector3<f64>],
}

impl WhiteScale<'_> {
    /// Largest white luminance with every channel (plus its black offset) at most
    /// `headroom`, and the channel that reaches it.
    fn luminance(&self, headroom: f64) -> Result<(f64, Limiting), CalibError> {
        let mut y_white = f64::INFINITY;
        let mut limiting = Limiting {
            display: 0,
            channel: Channel::Red,
        };
        for (i, p) in self.prepared.iter().enumerate() {
            let per_cd = p.p_inv * self.w_unit;
            let name = self.measurements[i].key.to_string();
            for c in Channel::ALL {
                let need = per_cd[c.index()];
                if need.is_nan() || need <= 0.0 {
                    return Err(CalibError::UnreachableWhite {
                        display: name,
                        reason: format!(
                            "target white xy ({:.4}, {:.4}) is outside this display's gamut: its {} channel would need {:.4} (negative light)",
                            self.white_xy[0],
                            self.white_xy[1],
                            c.name(),
                            need
                        ),
                    });
                }
                let offset = self.offsets[i][c.index()];
                let room = headroom - offset;
                if room <= 0.0 {
                    return Err(CalibError::UnreachableWhite {
                        display: name,
                        reason: format!(
                            "the common black alone needs {:.3} of the {} channel, more than the headroom {headroom}; choose black mode individual or check the black readings",
                            offset,
                            c.name()
                        ),
                    });
                }
            }
            let (y, channel) = self.display_limit(p, per_cd, self.offsets[i], headroom);
            if y < y_white {
                y_white = y;
                limiting = Limiting {
                    display: i,
                    channel,
                };
            }
        }
        Ok((y_white, limiting))
    }

    /// Largest white luminance one display shows with every channel at most `headroom`
    /// (offsets and `need > 0` checked by the caller), and the channel that limits it.
    /// Additive: `min_c (headroom − offset_c) / need_c`. With a white segment the channel
    /// intensities are piecewise linear and increasing in the luminance: found by
    /// bisection from the additive value.
    fn display_limit(
        &self,
        p: &Prepared,
        per_cd: Vector3<f64>,
        offset: Vector3<f64>,
        headroom: f64,
    ) -> (f64, Channel) {
        let additive = Channel::ALL
            .map(|c| ((headroom - offset[c.index()]) / per_cd[c.index()], c))
            .into_iter()
            .fold(
                (f64::INFINITY, Channel::Red),
                |a, b| if b.0 < a.0 { b } else { a },
            );
        if matches!(p.model, DisplayModel::Additive) {
            return additive;
        }
        let usage = |y: f64| p.channels_for(per_cd * y + offset);
        let over = |y: f64| usage(y).max() > headroom;
        let (mut lo, mut hi) = (0.0, additive.0);
        for _ in 0..64 {
            if over(hi) {
                break;
            }
            (lo, hi) = (hi, hi * 2.0);
        }
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if over(mid) { hi = mid } else { lo = mid }
        }
        let at = usage(lo);
        let channel = Channel::ALL.into_iter().fold(Channel::Red, |a, b| {
            if at[b.index()] > at[a.index()] { b } else { a }
        });
        (lo, channel)
    }

    /// In Individual mode the white must also be bright enough that no channel goes
    /// negative once the display's own black is subtracted.
    fn check_above_own_black(&self, y_white: f64, limiting: Limiting) -> Result<(), CalibError> {
        for (i, p) in self.prepared.iter().enumerate() {
            let per_cd = p.p_inv * self.w_unit;
            for c in Channel::ALL {
                let need = -self.offsets[i][c.index()] / per_cd[c.index()];
                if need > y_white {
                    let name = self.measurements[i].key.to_string();
                    return Err(CalibError::UnreachableWhite {
                        display: name,
                        reason: format!(
                            "its black (Y {:.3} cd/m²) is above the wall's white: the white can be at most {:.3} cd/m² (limited by display index {} {}), but this display's {} channel needs a white of at least {:.3} cd/m² to stay above its own black; use black mode common or ignore, or fix this display's black",
                            p.black[1],
                            y_white,
                            limiting.display,
                            limiting.channel.name(),
                            c.name(),
                            need
                        ),
                    });
                }
            }
        }
        Ok(())
    }
}

/// Least-luminance XYZ `c` with `P_i⁻¹·(c − black_i) ≥ 0` on every display: a linear
/// programme in 3 variables solved exactly by vertex enumeration over a growing set of
/// active constraints (cutting planes), started from the implied bounds
/// `c ≥ black_i` (componentwise; implied because primaries are non-negative XYZ).
fn common_black(prepared: &[Prepared]) -> Result<Vector3<f64>, CalibError> {
    // Constraints n·c ≥ b.
    let mut all: Vec<(Vector3<f64>, f64)> = Vec::with_capacity(3 * prepared.len());
    for p in prepared {
        for c in 0..3 {
            let n: Vector3<f64> = p.p_inv.row(c).transpose();
            all.push((n, n.dot(&p.black)));
        }
    }
    let mut lower = Vector3::from_element(f64::NEG_INFINITY);
    for p in prepared {
        for k in 0..3 {
            lower[k] = lower[k].max(p.black[k]);
        }
    }
    let mut active: Vec<(Vector3<f64>, f64)> = (0..3)
        .map(|k| {
            let mut n = Vector3::zeros();
            n[k] = 1.0;
            (n, lower[k])
        })
        .collect();
    let scale = lower.norm().max(1e-12);
    let mut added = vec![false; all.len()];
    for _ in 0..=all.len() {
        let c = solve_lp_vertices(&active, scale).ok_or_else(|| CalibError::Singular {
            what: "common black linear programme".into(),
        })?;
        // Most violated constraint not yet active (normalised), with the vertex
        // search's own feasibility tolerance: a constraint it accepted as met is met.
        let mut worst: Option<(usize, f64)> = None;
        for (k, (n, b)) in all.iter().enumerate() {
            let slack = b - n.dot(&c);
            if added[k] || slack <= LP_FEASIBILITY * scale * n.norm().max(1.0) {
                continue;
            }
            let viol = slack / n.norm().max(1e-300);
            if worst.is_none_or(|w| viol > w.1) {
                worst = Some((k, viol));
            }
        }
        match worst {
            None => return Ok(c),
            Some((k, _)) => {
                added[k] = true;
                active.push(all[k]);
            }
        }
    }
    Err(CalibError::Singular {
        what: "common black linear programme did not converge".into(),
    })
}

/// Minimum-Y vertex of `{c : n·c ≥ b for all constraints}` by enumeration.
fn solve_lp_vertices(cons: &[(Vector3<f64>, f64)], scale: f64) -> Option<Vector3<f64>> {
    let m = cons.len();
    let mut best: Option<Vector3<f64>> = None;
    for i in 0..m {
        for j in i + 1..m {
            for k in j + 1..m {
                let a = Matrix3::from_rows(&[
                    cons[i].0.transpose(),
                    cons[j].0.transpose(),
                    cons[k].0.transpose(),
                ]);
                let Some(inv) = a.try_inverse() else { continue };
                let v = inv * Vector3::new(cons[i].1, cons[j].1, cons[k].1);
                if !v.iter().all(|x| x.is_finite()) {
                    continue;
                }
                if best.is_some_and(|b| v[1] >= b[1]) {
                    continue;
                }
                let feasible = cons
                    .iter()
                    .all(|(n, b)| n.dot(&v) >= b - LP_FEASIBILITY * scale * n.norm().max(1.0));
                if feasible {
                    best = Some(v);
                }
            }
        }
    }
    best
}

/// Current time as RFC 3339 UTC (`2026-11-22T23:05:00Z`): the creation time to pass to
/// [`solve_wall_at`].
pub fn now_rfc3339() -> String {
    jiff::Timestamp::now()
        .strftime("%Y-%m-%dT%H:%M:%SZ")
        .to_string()
}

#[cfg(test)]
mod clock_tests {
    use super::now_rfc3339;

    #[test]
    fn creation_time_is_rfc3339_utc_to_the_second_and_now() {
        let text = now_rfc3339();
        assert_eq!(text.len(), "2026-11-22T23:05:00Z".len(), "{text}");
        let t: jiff::Timestamp = text.parse().expect("RFC 3339");
        let age_s = jiff::Timestamp::now().as_second() - t.as_second();
        assert!((0..=2).contains(&age_s), "{text} is {age_s} s from now");
    }
}
