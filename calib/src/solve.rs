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

use lumiwall_devices::Xyz;
use lumiwall_profiles::{
    BlackMode, DisplayKey, DisplayProfile, FORMAT_VERSION, MIN_LUT_ENTRIES, MeasurementInfo,
    OutOfGamut, ToneCurve,
};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::CalibError;
use crate::colorimetry::cct_to_xy;
use crate::gamut::{MIN_TRIANGLE_AREA, Xy, common_gamut_named, signed_area};
use crate::tone::fit_monotone_named;

const CHANNELS: [&str; 3] = ["red", "green", "blue"];

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
    /// `(display index, channel 0..3)` that is at exactly the headroom.
    pub limiting: (usize, usize),
    /// Things the technician should know (low channel usage, additivity, …).
    pub warnings: Vec<String>,
}

/// Per-display quantities derived from the measurement.
struct Prepared {
    /// Black-subtracted primaries as columns.
    p: Matrix3<f64>,
    p_inv: Matrix3<f64>,
    black: Vector3<f64>,
    curves: Option<[ToneCurve; 3]>,
    additivity_error: Option<f64>,
}

fn check_xyz(what: &str, v: Xyz) -> Result<(), CalibError> {
    for (name, c) in [("X", v.x), ("Y", v.y), ("Z", v.z)] {
        if !c.is_finite() {
            return Err(CalibError::NonFinite {
                what: format!("{what} {name}"),
                value: c,
            });
        }
        if c < 0.0 {
            return Err(CalibError::Negative {
                what: format!("{what} {name}"),
                value: c,
            });
        }
    }
    Ok(())
}

fn vec3(v: Xyz) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

fn xyz_of(v: &Vector3<f64>) -> Xyz {
    Xyz::new(v[0], v[1], v[2])
}

fn rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
}

fn arr(v: &Vector3<f64>) -> [f64; 3] {
    [v[0], v[1], v[2]]
}

fn validate_options(o: &SolveOptions) -> Result<(), CalibError> {
    let bad = |option: &str, reason: String| CalibError::InvalidOption {
        option: option.into(),
        reason,
    };
    if !(o.headroom > 0.0 && o.headroom <= 1.0) {
        return Err(bad("headroom", format!("{} is not in (0, 1]", o.headroom)));
    }
    if o.lut_entries < MIN_LUT_ENTRIES {
        return Err(bad(
            "lut_entries",
            format!(
                "{} is below the minimum of {MIN_LUT_ENTRIES}",
                o.lut_entries
            ),
        ));
    }
    if !(o.max_additivity_error >= 0.0 && o.max_additivity_error.is_finite()) {
        return Err(bad(
            "max_additivity_error",
            format!("{} is not a finite number ≥ 0", o.max_additivity_error),
        ));
    }
    Ok(())
}

fn prepare(m: &DisplayMeasurement, lut_entries: Option<usize>) -> Result<Prepared, CalibError> {
    let name = m.key.to_string();
    check_xyz(&format!("{name}: black reading"), m.black)?;
    for (c, p) in m.primaries.iter().enumerate() {
        check_xyz(&format!("{name}: {} full-drive reading", CHANNELS[c]), *p)?;
    }
    if let Some(w) = m.white {
        check_xyz(&format!("{name}: white full-drive reading"), w)?;
    }
    let black = vec3(m.black);
    let cols: Vec<Vector3<f64>> = m.primaries.iter().map(|p| vec3(*p) - black).collect();
    for (c, col) in cols.iter().enumerate() {
        if col[1].is_nan() || col[1] <= 0.0 || col.iter().sum::<f64>() <= 0.0 {
            return Err(CalibError::NoSignal {
                what: format!("{name}: {} channel", CHANNELS[c]),
                full_drive: col[1],
            });
        }
    }
    let tri: Vec<Xy> = cols.iter().filter_map(|c| xyz_of(c).xy()).collect();
    let area = if tri.len() == 3 {
        signed_area(tri[0], tri[1], tri[2]).abs()
    } else {
        0.0
    };
    if area < MIN_TRIANGLE_AREA {
        return Err(CalibError::DegeneratePrimaries {
            display: name,
            area,
            min_area: MIN_TRIANGLE_AREA,
        });
    }
    let p = Matrix3::from_columns(&cols);
    let p_inv = p
        .try_inverse()
        .ok_or_else(|| CalibError::DegeneratePrimaries {
            display: name.clone(),
            area,
            min_area: MIN_TRIANGLE_AREA,
        })?;
    let fit = |c: usize, entries: usize| -> Result<ToneCurve, CalibError> {
        let what = format!("{name}: {} ramp", CHANNELS[c]);
        let pc = cols[c];
        let norm2 = pc.norm_squared();
        let mut samples: Vec<(f64, f64)> = Vec::with_capacity(m.ramps[c].len() + 1);
        for &(drive, xyz) in &m.ramps[c] {
            check_xyz(&format!("{what} at drive {drive:.4}"), xyz)?;
            samples.push((drive, (vec3(xyz) - black).dot(&pc) / norm2));
        }
        samples.push((1.0, 1.0));
        fit_monotone_named(&samples, &what)?.to_tone_curve(entries)
    };
    let curves = match lut_entries {
        Some(entries) => Some([fit(0, entries)?, fit(1, entries)?, fit(2, entries)?]),
        None => None,
    };
    let additivity_error = m.white.and_then(|w| {
        let sum = cols[0] + cols[1] + cols[2] + black;
        let wy = w.y;
        (wy > 0.0).then(|| (vec3(w) - sum).norm() / wy)
    });
    Ok(Prepared {
        p,
        p_inv,
        black,
        curves,
        additivity_error,
    })
}

/// xy triangles `[R, G, B]` of the displays' black-subtracted primaries, named by key.
pub fn primaries_xy(
    measurements: &[DisplayMeasurement],
) -> Result<Vec<(String, [Xy; 3])>, CalibError> {
    measurements
        .iter()
        .map(|m| {
            let name = m.key.to_string();
            let mut tri = [[0.0; 2]; 3];
            for c in 0..3 {
                tri[c] = (m.primaries[c] - m.black)
                    .xy()
                    .ok_or_else(|| CalibError::NoSignal {
                        what: format!("{name}: {} channel", CHANNELS[c]),
                        full_drive: m.primaries[c].y - m.black.y,
                    })?;
            }
            Ok((name, tri))
        })
        .collect()
}

/// Solves the wall: common gamut of the black-subtracted primaries, then
/// [`solve_wall_in_gamut`].
pub fn solve_wall(
    measurements: &[DisplayMeasurement],
    options: &SolveOptions,
) -> Result<WallSolution, CalibError> {
    if measurements.is_empty() {
        return Err(CalibError::InvalidOption {
            option: "measurements".into(),
            reason: "no display measured".into(),
        });
    }
    for m in measurements {
        let name = m.key.to_string();
        check_xyz(&format!("{name}: black reading"), m.black)?;
        for (c, p) in m.primaries.iter().enumerate() {
            check_xyz(&format!("{name}: {} full-drive reading", CHANNELS[c]), *p)?;
        }
    }
    let gamut = common_gamut_named(&primaries_xy(measurements)?)?;
    solve_wall_in_gamut(measurements, options, gamut)
}

/// Solves the wall for a given common gamut `[R, G, B]` xy (e.g. one computed from raw
/// primaries, as reproduces Kresse's Tab. 6): white, luminance scale, black, matrices
/// and tone curves.
pub fn solve_wall_in_gamut(
    measurements: &[DisplayMeasurement],
    options: &SolveOptions,
    common_primaries_xy: [[f64; 2]; 3],
) -> Result<WallSolution, CalibError> {
    validate_options(options)?;
    if measurements.is_empty() {
        return Err(CalibError::InvalidOption {
            option: "measurements".into(),
            reason: "no display measured".into(),
        });
    }
    let prepared = measurements
        .iter()
        .map(|m| prepare(m, Some(options.lut_entries)))
        .collect::<Result<Vec<_>, _>>()?;
    let mut warnings = Vec::new();
    let ws = white_from_prepared(
        &prepared,
        measurements,
        options.white,
        options.headroom,
        options.black_mode,
    )?;
    let cg = common_primaries_xy;
    let white_xy = ws.white_xy;
    let inside = (0..3).all(|e| {
        signed_area(cg[e], cg[(e + 1) % 3], white_xy) * signed_area(cg[0], cg[1], cg[2]) >= 0.0
    });
    if !inside {
        warnings.push(format!(
            "target white xy ({:.4}, {:.4}) lies outside the common gamut triangle",
            white_xy[0], white_xy[1]
        ));
    }
    let h = options.headroom;
    let white = vec3(ws.white_xyz_cd_m2);
    let common_black = vec3(ws.common_black_xyz_cd_m2);
    let offsets: Vec<Vector3<f64>> = ws.drive_offsets.iter().map(|o| Vector3::from(*o)).collect();
    let limiting = ws.limiting;

    // Profiles.
    let created_utc = now_rfc3339();
    let mut profiles = Vec::with_capacity(measurements.len());
    for (i, (m, p)) in measurements.iter().zip(&prepared).enumerate() {
        let name = m.key.to_string();
        let usage = p.p_inv * white + offsets[i];
        for c in 0..3 {
            if usage[c] < 0.25 * h {
                warnings.push(format!(
                    "{name}: {} channel only {:.0} % used for the white; fewer than {:.0} of {} code values carry the image (consider lowering this channel in the projector's service menu, Kresse 3.3.9)",
                    CHANNELS[c],
                    100.0 * usage[c],
                    usage[c] * f64::from((1u32 << m.bit_depth.min(16)) - 1),
                    (1u32 << m.bit_depth.min(16))
                ));
            }
        }
        let own = p.p_inv * p.black;
        if own.iter().any(|v| *v < -1e-9) {
            warnings.push(format!(
                "{name}: black lies outside its own gamut (channel intensities {:.4}, {:.4}, {:.4})",
                own[0], own[1], own[2]
            ));
        }
        if let Some(e) = p.additivity_error
            && e > options.max_additivity_error
        {
            warnings.push(format!(
                "{name}: additivity error {:.1} % (|W − (R+G+B−2·black)| / Y_W) exceeds {:.1} %; the matrix model will be off by about that much",
                100.0 * e,
                100.0 * options.max_additivity_error
            ));
        }
        let shown_black = match options.black_mode {
            BlackMode::Common => common_black,
            BlackMode::Ignore | BlackMode::Individual => p.black,
        };
        let prim = [
            arr(&p.p.column(0).into_owned()),
            arr(&p.p.column(1).into_owned()),
            arr(&p.p.column(2).into_owned()),
        ];
        let profile = DisplayProfile {
            format_version: FORMAT_VERSION,
            display: m.key.clone(),
            created_utc: created_utc.clone(),
            primaries_xyz_cd_m2: prim,
            black_xyz_cd_m2: arr(&p.black),
            black_mode: options.black_mode,
            shown_black_xyz_cd_m2: arr(&shown_black),
            target_white_xyz_cd_m2: arr(&white),
            common_primaries_xy,
            xyz_to_drive: rows(&p.p_inv),
            drive_offset: arr(&offsets[i]),
            channel_usage: arr(&usage),
            headroom: h,
            curves: p.curves.clone().ok_or_else(|| CalibError::InvalidOption {
                option: "curves".into(),
                reason: "tone curves were not fitted".into(),
            })?,
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
        profiles.push(profile);
    }
    Ok(WallSolution {
        profiles,
        common_primaries_xy,
        white_xyz_cd_m2: xyz_of(&white),
        common_black_xyz_cd_m2: xyz_of(&common_black),
        limiting,
        warnings,
    })
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
    /// `(display index, channel)` at exactly the headroom.
    pub limiting: (usize, usize),
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
    if !(headroom > 0.0 && headroom <= 1.0) {
        return Err(CalibError::InvalidOption {
            option: "headroom".into(),
            reason: format!("{headroom} is not in (0, 1]"),
        });
    }
    if measurements.is_empty() {
        return Err(CalibError::InvalidOption {
            option: "measurements".into(),
            reason: "no display measured".into(),
        });
    }
    let prepared = measurements
        .iter()
        .map(|m| prepare(m, None))
        .collect::<Result<Vec<_>, _>>()?;
    white_from_prepared(&prepared, measurements, white, headroom, black_mode)
}

fn white_from_prepared(
    prepared: &[Prepared],
    measurements: &[DisplayMeasurement],
    white: WhiteTarget,
    headroom: f64,
    black_mode: BlackMode,
) -> Result<WhiteSolution, CalibError> {
    // Target white chromaticity.
    let white_xy = match white {
        WhiteTarget::Xy(xy) => xy,
        WhiteTarget::Cct(k) => cct_to_xy(k)?,
        WhiteTarget::NativeOf(i) => {
            let p = prepared.get(i).ok_or_else(|| CalibError::InvalidOption {
                option: "white".into(),
                reason: format!(
                    "native white of display index {i}, but only {} displays were measured",
                    measurements.len()
                ),
            })?;
            xyz_of(&(p.p * Vector3::new(1.0, 1.0, 1.0)))
                .xy()
                .ok_or_else(|| CalibError::InvalidOption {
                    option: "white".into(),
                    reason: format!("display index {i} has no native white"),
                })?
        }
    };
    if !(white_xy.iter().all(|v| v.is_finite()) && white_xy[1] > 0.0 && white_xy[0] > 0.0)
        || white_xy[0] + white_xy[1] >= 1.0
    {
        return Err(CalibError::InvalidOption {
            option: "white".into(),
            reason: format!("xy {white_xy:?} is not a valid chromaticity"),
        });
    }
    let w_unit = vec3(Xyz::from_xy_luminance(white_xy[0], white_xy[1], 1.0));

    // Common black (computed always, used in Common mode).
    let common_black = common_black(prepared)?;

    // Offsets per black mode, in channel space.
    let offsets: Vec<Vector3<f64>> = prepared
        .iter()
        .map(|p| match black_mode {
            BlackMode::Ignore => Vector3::zeros(),
            BlackMode::Individual => -(p.p_inv * p.black),
            BlackMode::Common => p.p_inv * (common_black - p.black),
        })
        .collect();

    // Luminance scale.
    let h = headroom;
    let mut y_white = f64::INFINITY;
    let mut limiting = (0, 0);
    for (i, p) in prepared.iter().enumerate() {
        let a = p.p_inv * w_unit;
        let name = measurements[i].key.to_string();
        for c in 0..3 {
            if a[c].is_nan() || a[c] <= 0.0 {
                return Err(CalibError::UnreachableWhite {
                    display: name,
                    reason: format!(
                        "target white xy ({:.4}, {:.4}) is outside this display's gamut: its {} channel would need {:.4} (negative light)",
                        white_xy[0], white_xy[1], CHANNELS[c], a[c]
                    ),
                });
            }
            let room = h - offsets[i][c];
            if room <= 0.0 {
                return Err(CalibError::UnreachableWhite {
                    display: name,
                    reason: format!(
                        "the common black alone needs {:.3} of the {} channel, more than the headroom {h}; choose black mode individual or check the black readings",
                        offsets[i][c], CHANNELS[c]
                    ),
                });
            }
            let y = room / a[c];
            if y < y_white {
                y_white = y;
                limiting = (i, c);
            }
        }
    }
    // In Individual mode the white must also be bright enough that no channel goes
    // negative once the display's own black is subtracted.
    for (i, p) in prepared.iter().enumerate() {
        let a = p.p_inv * w_unit;
        for c in 0..3 {
            let need = -offsets[i][c] / a[c];
            if need > y_white {
                let name = measurements[i].key.to_string();
                return Err(CalibError::UnreachableWhite {
                    display: name,
                    reason: format!(
                        "its black (Y {:.3} cd/m²) is above the wall's white: the white can be at most {:.3} cd/m² (limited by display index {} {}), but this display's {} channel needs a white of at least {:.3} cd/m² to stay above its own black; use black mode common or ignore, or fix this display's black",
                        p.black[1], y_white, limiting.0, CHANNELS[limiting.1], CHANNELS[c], need
                    ),
                });
            }
        }
    }
    let white = w_unit * y_white;
    let channel_usage = prepared
        .iter()
        .zip(&offsets)
        .map(|(p, o)| arr(&(p.p_inv * white + o)))
        .collect();
    Ok(WhiteSolution {
        white_xy,
        white_xyz_cd_m2: xyz_of(&white),
        common_black_xyz_cd_m2: xyz_of(&common_black),
        limiting,
        drive_offsets: offsets.iter().map(arr).collect(),
        channel_usage,
    })
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
    for _ in 0..=all.len() {
        let c = solve_lp_vertices(&active, scale).ok_or_else(|| CalibError::Singular {
            what: "common black linear programme".into(),
        })?;
        // Most violated constraint (normalised).
        let mut worst: Option<(usize, f64)> = None;
        for (k, (n, b)) in all.iter().enumerate() {
            let viol = (b - n.dot(&c)) / n.norm().max(1e-300);
            if viol > 1e-12 * scale && worst.is_none_or(|w| viol > w.1) {
                worst = Some((k, viol));
            }
        }
        match worst {
            None => return Ok(c),
            Some((k, _)) => active.push(all[k]),
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
                    .all(|(n, b)| n.dot(&v) >= b - 1e-9 * scale * n.norm().max(1.0));
                if feasible {
                    best = Some(v);
                }
            }
        }
    }
    best
}

/// Current time as RFC 3339 UTC (`2026-11-22T23:05:00Z`).
fn now_rfc3339() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0);
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    // Civil-from-days (Howard Hinnant).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        (rem % 3600) / 60,
        rem % 60
    )
}
