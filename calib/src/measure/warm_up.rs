//! Waiting for a cold wall: before the first display is measured, its white is read
//! over and over until the luminance has stopped changing, so that the first and the
//! last display of a run are measured at the same lamp state (a UHP or xenon lamp
//! needs 10–30 minutes; ArgyllCMS's drift compensation solves the same problem by
//! re-reading white between patches).
//!
//! Stable means: the least-squares trend of the luminance over the last `window`
//! readings, extrapolated over the window, is below `max_change_percent`. A real
//! colorimeter takes 1–3 s a reading, so the default window of 120 readings is two to
//! six minutes. Noise averages out in the trend; a wall that never settles within
//! `max_readings` is an error the technician can act on.
//!
//! Without being asked to wait, a commissioning still checks first whether the wall is
//! warming ([`check_warm`]): a short trend of the first display's white
//! ([`WarmCheck`]), extrapolated over the readings the run will take. A wall that would
//! drift more over the run than the drift check at its end allows
//! ([`super::drift::WARN_LUMINANCE_PERCENT`]), by more than the trend's own noise, is
//! waited for as above; a warm wall costs the check's readings (not counted in any
//! display's budget) and nothing else. On a wall two minutes after switch-on the
//! first and last displays were otherwise measured 5 % apart in luminance and the
//! calibration was off by a white ΔE2000 of 6.6 (noiseless meter, 2×2 Infitec DLPs,
//! 64 readings per display): the drift check reported it, after the run.

use lumiwall_devices::DisplayInfo;
use serde::{Deserialize, Serialize};

use super::{MeasureError, MeasureOptions, Patch, Progress, Rig, Session, display_key};

/// How to wait for a cold wall.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WarmUp {
    /// Readings the trend is fitted over.
    pub window: u32,
    /// Largest luminance change over the window (percent) that counts as stable.
    pub max_change_percent: f64,
    /// Readings after which the wait gives up.
    pub max_readings: u32,
}

impl Default for WarmUp {
    /// 0.05 % over 120 readings (two to six minutes on a real colorimeter): what is
    /// left of the drift then is below the meter's own repeatability.
    fn default() -> Self {
        Self {
            window: 120,
            max_change_percent: 0.05,
            max_readings: 6000,
        }
    }
}

/// What the wait saw.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WarmUpReport {
    /// Readings it took.
    pub readings: u32,
    /// Luminance change over the first full window (percent).
    pub first_change_percent: f64,
    /// Luminance change over the last window (percent), below the limit.
    pub last_change_percent: f64,
}

/// How to check, before the first display, whether the wall is still warming up
/// (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WarmCheck {
    /// Readings of the first display's white the trend is fitted over.
    pub readings: u32,
    /// Largest luminance drift over the run (percent, the trend extrapolated over the
    /// readings the run will take) that does not call for the wait.
    pub max_run_drift_percent: f64,
    /// Standard errors of its own by which the trend must differ from flat to count.
    pub sigmas: f64,
}

impl Default for WarmCheck {
    /// 40 readings (one to two minutes on a real colorimeter), the drift check's own 1 %
    /// limit over the run, 4σ: on the warm cold-start-2x2 fixture (realistic meter,
    /// 41 seeds) the trend over 24 readings came out beyond 3σ twice, which would have
    /// been a needless wait; 40 readings at 4σ still find a wall ten minutes after
    /// switch-on (8-minute lamps, ~1 % more drift over a 4-display run) at about 6σ.
    fn default() -> Self {
        Self {
            readings: 40,
            max_run_drift_percent: super::drift::WARN_LUMINANCE_PERCENT,
            sigmas: 4.0,
        }
    }
}

/// What the warm check saw.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WarmCheckReport {
    /// Readings it took.
    pub readings: u32,
    /// Luminance change over them along their least-squares line (percent).
    pub change_percent: f64,
    /// Standard error of that change from the readings' scatter about the line.
    pub change_sigma_percent: f64,
    /// The change extrapolated over the readings the run will take (percent).
    pub run_drift_percent: f64,
    /// True when the run would drift beyond the limit, beyond the trend's noise: the
    /// wall is waited for.
    pub warming: bool,
}

impl WarmCheckReport {
    /// One line for the console and the station's log.
    pub fn summary(&self) -> String {
        format!(
            "warm check: {} readings of the white, luminance {:+.2} % ± {:.2} %, {:+.1} % over \
             this run's readings: {}",
            self.readings,
            self.change_percent,
            self.change_sigma_percent,
            self.run_drift_percent,
            if self.warming {
                "the wall is warming up, waiting for it (--no-warm-check skips this)"
            } else {
                "warm enough"
            }
        )
    }
}

impl WarmUpReport {
    /// One line for the console and the station's log.
    pub fn summary(&self) -> String {
        format!(
            "warm: after {} readings of the white the luminance changes {:+.3} % per {} \
             readings (it changed {:+.2} % at first)",
            self.readings,
            self.last_change_percent,
            WarmUp::default().window,
            self.first_change_percent
        )
    }
}

/// The least-squares line through `y` (at 0, 1, 2, …): the change over `y` and its
/// standard error from the scatter about the line, both in percent of the mean.
/// (0, 0) for fewer than three values or a mean not above 0.
fn trend_with_sigma(y: &[f64]) -> (f64, f64) {
    let n = y.len() as f64;
    let mean_x = (n - 1.0) / 2.0;
    let mean_y = y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, v) in y.iter().enumerate() {
        let dx = i as f64 - mean_x;
        sxy += dx * (v - mean_y);
        sxx += dx * dx;
    }
    if y.len() < 3 || sxx <= 0.0 || mean_y <= 0.0 {
        return (0.0, 0.0);
    }
    let slope = sxy / sxx;
    let residual: f64 = y
        .iter()
        .enumerate()
        .map(|(i, v)| (v - mean_y - slope * (i as f64 - mean_x)).powi(2))
        .sum();
    let slope_sigma = (residual / (n - 2.0) / sxx).sqrt();
    let percent = 100.0 * (n - 1.0) / mean_y;
    (slope * percent, slope_sigma * percent)
}

/// Change over `y` (percent of its mean) along its least-squares line.
fn trend_percent(y: &[f64]) -> f64 {
    trend_with_sigma(y).0
}

/// Whether the wall is warming (module docs): reads `info`'s white `check.readings`
/// times and extrapolates the trend over `run_readings`, the readings the run will take.
pub fn check_warm(
    rig: &mut Rig<'_>,
    wall: &str,
    info: &DisplayInfo,
    opts: &MeasureOptions,
    check: &WarmCheck,
    run_readings: u32,
    progress: &mut dyn FnMut(Progress),
) -> Result<WarmCheckReport, MeasureError> {
    let n = check.readings.max(3);
    let session_opts = MeasureOptions {
        budget: n,
        ..opts.clone()
    };
    let key = display_key(wall, info);
    let mut s = Session::start(rig, &key, info.id, opts.spot_uv, &session_opts)?;
    let mut y = Vec::with_capacity(n as usize);
    while s.remaining() > 0 {
        if let Some(x) = s
            .sample(Patch::White, false, &mut |_| {})?
            .filter(|x| x.y > 0.0)
        {
            y.push(x.y);
        }
    }
    let report = judge_warmth(&y, check, run_readings);
    progress(Progress::WarmCheck(report));
    Ok(report)
}

/// Before a run on `first`: the wait when `opts` asks for it
/// ([`MeasureOptions::warm_up`]), else the warm `check` and the wait (as
/// [`WarmUp::default`]) when it finds the wall warming; nothing without either. A
/// technician who skips `first` while aiming skips this too (the display stays
/// skipped): `Ok`.
pub fn wait_or_check(
    rig: &mut Rig<'_>,
    wall: &str,
    first: &DisplayInfo,
    opts: &MeasureOptions,
    check: Option<&WarmCheck>,
    run_readings: u32,
    progress: &mut dyn FnMut(Progress),
) -> Result<(), MeasureError> {
    let waited = (|| {
        let wait = match (opts.warm_up, check) {
            (Some(w), _) => Some(w),
            (None, Some(c)) => check_warm(rig, wall, first, opts, c, run_readings, progress)?
                .warming
                .then(WarmUp::default),
            (None, None) => None,
        };
        if let Some(w) = wait {
            wait_for_warm_up(rig, wall, first, opts, &w, progress)?;
        }
        Ok(())
    })();
    match waited {
        Err(MeasureError::Aim {
            source: lumiwall_devices::DeviceError::AimSkipped(_),
            ..
        }) => Ok(()),
        other => other,
    }
}

/// The warm check's verdict on the white's luminances `y`, read one after the other.
fn judge_warmth(y: &[f64], check: &WarmCheck, run_readings: u32) -> WarmCheckReport {
    let (change, sigma) = trend_with_sigma(y);
    let per_reading = change / (y.len().max(2) - 1) as f64;
    let run_drift = per_reading * f64::from(run_readings);
    WarmCheckReport {
        readings: y.len() as u32,
        change_percent: change,
        change_sigma_percent: sigma,
        run_drift_percent: run_drift,
        warming: change.abs() > check.sigmas * sigma
            && run_drift.abs() > check.max_run_drift_percent,
    }
}

/// Reads `info`'s white at the calibration spot until it is stable ([`WarmUp`]).
pub fn wait_for_warm_up(
    rig: &mut Rig<'_>,
    wall: &str,
    info: &DisplayInfo,
    opts: &MeasureOptions,
    warm_up: &WarmUp,
    progress: &mut dyn FnMut(Progress),
) -> Result<WarmUpReport, MeasureError> {
    let window = warm_up.window.max(8) as usize;
    let session_opts = MeasureOptions {
        budget: warm_up.max_readings.max(warm_up.window),
        ..opts.clone()
    };
    let key = display_key(wall, info);
    let mut s = Session::start(rig, &key, info.id, opts.spot_uv, &session_opts)?;
    let mut y: Vec<f64> = Vec::with_capacity(window * 4);
    let mut first = None;
    let mut dark = 0;
    while s.remaining() > 0 {
        let reading = s.sample(Patch::White, false, &mut |_| {})?;
        let Some(x) = reading.filter(|x| x.y > 0.0) else {
            dark += 1;
            if dark >= window {
                return Err(MeasureError::DarkWhileWarming {
                    display: info.name.clone(),
                    readings: s.log.readings,
                });
            }
            continue;
        };
        dark = 0;
        y.push(x.y);
        if y.len() < window {
            continue;
        }
        let change = trend_percent(&y[y.len() - window..]);
        let first_change = *first.get_or_insert(change);
        progress(Progress::WarmingUp {
            readings: y.len() as u32,
            change_percent: change,
        });
        if change.abs() < warm_up.max_change_percent {
            let report = WarmUpReport {
                readings: y.len() as u32,
                first_change_percent: first_change,
                last_change_percent: change,
            };
            progress(Progress::WarmedUp(report));
            return Ok(report);
        }
    }
    Err(MeasureError::NotWarm {
        display: info.name.clone(),
        readings: y.len() as u32,
        change_percent: y
            .len()
            .checked_sub(window)
            .map_or(f64::NAN, |k| trend_percent(&y[k..])),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White luminances rising by `step` per reading with scatter `±wobble` in the
    /// pattern + − − +, which adds no trend of its own over a multiple of four readings.
    fn readings(n: usize, step: f64, wobble: f64) -> Vec<f64> {
        (0..n)
            .map(|i| {
                let sign = if matches!(i % 4, 0 | 3) { 1.0 } else { -1.0 };
                100.0 + step * i as f64 + sign * wobble
            })
            .collect()
    }

    #[test]
    fn a_wall_that_would_drift_past_the_limit_over_the_run_is_warming() {
        // +0.05 % a reading: +1.2 % over the check, +25 % over 500 readings
        let r = judge_warmth(&readings(24, 0.05, 0.01), &WarmCheck::default(), 500);
        assert!(r.warming, "{r:?}");
        assert!((r.change_percent - 1.15).abs() < 0.02, "{r:?}");
        assert!((r.run_drift_percent - 25.0).abs() < 0.5, "{r:?}");
    }

    #[test]
    fn a_trend_within_its_own_noise_or_within_the_limit_over_the_run_is_warm() {
        // a rise of 0.0005 % a reading hidden in ±0.1 % scatter
        let noisy = judge_warmth(&readings(24, 0.0005, 0.1), &WarmCheck::default(), 5000);
        assert!(noisy.run_drift_percent > 1.0, "{noisy:?}");
        assert!(!noisy.warming, "{noisy:?}");
        // a clear rise that stays below 1 % over a short run
        let short = judge_warmth(&readings(24, 0.001, 0.0), &WarmCheck::default(), 500);
        assert!(short.change_sigma_percent < 1e-9, "{short:?}");
        assert!(!short.warming, "{short:?}");
        assert!((short.run_drift_percent - 0.5).abs() < 0.01, "{short:?}");
    }

    #[test]
    fn the_trend_of_a_line_is_its_rise_over_the_window_and_noise_free_flat_is_zero() {
        let y: Vec<f64> = (0..60).map(|i| 100.0 + 0.01 * f64::from(i)).collect();
        let mean = y.iter().sum::<f64>() / 60.0;
        assert!((trend_percent(&y) - 100.0 * 0.59 / mean).abs() < 1e-9);
        assert_eq!(trend_percent(&[5.0; 60]), 0.0);
    }
}
