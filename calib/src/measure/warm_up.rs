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
//! ([`WarmCheck`]), beyond the trend's own noise, extrapolated over the readings the
//! run will take and over the wait's window. A wall that would drift more over the run
//! than the drift check at its end allows ([`super::drift::WARN_LUMINANCE_PERCENT`]),
//! or that the wait would not call stable, is waited for as above (with a meter that
//! has noise, the second holds for every trend beyond its noise:
//! [`WarmCheckReport::warming`]); a warm wall costs
//! the check's readings (not counted in any display's budget) and nothing else. On a
//! wall two minutes after switch-on the first and last displays were otherwise
//! measured 5 % apart in luminance and the calibration was off by a white ΔE2000 of 6.6
//! (noiseless meter, 2×2 Infitec DLPs, 64 readings per display): the drift check
//! reported it, after the run. A short run drifts little within itself, but its lamps
//! go on warming after it, and the wall is then used in a state it was not calibrated
//! in: the cold-start fixture cut to one display, five minutes after switch-on, would
//! drift 0.7 % over its run of 40 readings and was measured at once, its channels up to
//! 9.6 % off the warm wall's; it drifts 2.2 % per 120 readings, is now waited for, and
//! ends 0.18 % (exact meter) and 0.21 % (realistic) off them (test
//! `a_short_run_on_a_lamp_still_warming_is_waited_for_and_gets_the_warm_calibration`).

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
    /// readings the run will take) that does not call for the wait by itself: a trend
    /// the wait would not call stable calls for it too ([`WarmCheckReport::warming`]).
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
    /// Since a trend the wait would not call stable calls for the wait too (which with a
    /// meter that has noise is every trend beyond 4σ), warm walls with the realistic
    /// meter still wait on none of 120 runs (mono-2x1, infitec-pair and
    /// weak-channel-3x1, seeds 101–140, 40 readings).
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
    /// Values of the white the trend was fitted to: one per reading, or one per
    /// low-light average below the meter's reliable limit; none for a reading the
    /// meter refused.
    pub values: u32,
    /// False when fewer than three values, or values from fewer than half the
    /// readings, came back: the check cannot tell, and the run starts at once (the
    /// drift over it is still reported at its end).
    pub conclusive: bool,
    /// Luminance change over the readings along their least-squares line (percent).
    pub change_percent: f64,
    /// Standard error of that change from the readings' scatter about the line.
    pub change_sigma_percent: f64,
    /// The change extrapolated over the readings the run will take (percent).
    pub run_drift_percent: f64,
    /// The change extrapolated over the wait's window (percent, as the wait measures
    /// it: [`trend_over_window`]): beyond [`WarmUp::max_change_percent`] the wait would
    /// not call the wall stable.
    #[serde(default)]
    pub window_drift_percent: f64,
    /// The wait's window ([`WarmUp::window`], readings).
    #[serde(default = "default_window")]
    pub window_readings: u32,
    /// True when the check is conclusive and the trend, beyond its own noise, would
    /// drift the run beyond the limit or is one the wait would not call stable: the
    /// wall is waited for. With a meter that has noise the second holds whenever the
    /// trend is beyond its noise (4σ of the slope of 40 readings of 0.1 % is 0.66 % per
    /// 120 readings, where the wait calls 0.05 % stable): such a meter waits for any
    /// trend it can see; the exact simulated meter for one the wait would see.
    pub warming: bool,
}

impl WarmCheckReport {
    /// One line for the console and the station's log.
    pub fn summary(&self) -> String {
        if !self.conclusive {
            return format!(
                "warm check: {} readable values of the white in {} readings: cannot tell \
                 whether the wall is warming; measuring at once (the drift over the run is \
                 reported at its end)",
                self.values, self.readings
            );
        }
        format!(
            "warm check: {} readings of the white, luminance {:+.2} % ± {:.2} %, {:+.1} % over \
             this run's readings, {:+.2} % per {} readings: {}",
            self.readings,
            self.change_percent,
            self.change_sigma_percent,
            self.run_drift_percent,
            self.window_drift_percent,
            self.window_readings,
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

/// The least-squares line through `points` (x, y): its slope in percent of the mean y
/// per unit of x, and the slope's standard error from the scatter about the line.
/// (0, 0) for fewer than three points, x all alike or a mean y not above 0.
fn slope_with_sigma(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (x, y) in points {
        sxy += (x - mean_x) * (y - mean_y);
        sxx += (x - mean_x) * (x - mean_x);
    }
    if points.len() < 3 || sxx <= 0.0 || mean_y <= 0.0 || !(sxx.is_finite() && sxy.is_finite()) {
        return (0.0, 0.0);
    }
    let slope = sxy / sxx;
    let residual: f64 = points
        .iter()
        .map(|(x, y)| (y - mean_y - slope * (x - mean_x)).powi(2))
        .sum();
    let slope_sigma = (residual / (n - 2.0) / sxx).sqrt();
    (100.0 * slope / mean_y, 100.0 * slope_sigma / mean_y)
}

/// The change over the window of `wait` of a trend of `per_reading` percent a reading,
/// as the wait measures it (the least-squares trend of its window, from its first
/// reading to its last).
pub fn trend_over_window(per_reading: f64, wait: &WarmUp) -> f64 {
    per_reading * f64::from(wait_window(wait) - 1)
}

/// Readings the wait fits its trend over ([`WarmUp::window`], at least 8).
fn wait_window(wait: &WarmUp) -> u32 {
    wait.window.max(8)
}

/// [`WarmCheckReport::window_readings`] of a report kept before it was recorded.
fn default_window() -> u32 {
    WarmUp::default().window
}

/// The console line of a warm check's or a wait's step `p` (the wait as
/// [`WarmUp::default`] waits: a line per window); `None` for other steps, and between
/// the wait's lines.
pub fn progress_line(p: &Progress) -> Option<String> {
    match p {
        Progress::WarmCheck(r) => Some(r.summary()),
        Progress::WarmedUp(r) => Some(r.summary()),
        Progress::WarmingUp {
            readings,
            change_percent,
        } => warming_up_line(&WarmUp::default(), *readings, *change_percent),
        _ => None,
    }
}

/// The console line of the wait's progress, once per window of `wait` (`None` between):
/// `readings` of the white so far, its luminance changing `change_percent` over the
/// last window.
fn warming_up_line(wait: &WarmUp, readings: u32, change_percent: f64) -> Option<String> {
    let window = wait_window(wait);
    readings.is_multiple_of(window).then(|| {
        format!(
            "warming up: {readings} readings of the white, luminance still changing \
             {change_percent:+.2} % per {window} readings"
        )
    })
}

/// Change over `y` (percent of its mean) along its least-squares line, `y` read one
/// after the other.
fn trend_percent(y: &[f64]) -> f64 {
    let points: Vec<(f64, f64)> = y.iter().enumerate().map(|(i, v)| (i as f64, *v)).collect();
    slope_with_sigma(&points).0 * (y.len().max(1) - 1) as f64
}

/// The readings a run of `displays` displays at `per_display` readings each will take,
/// for the warm check's extrapolation (saturating).
pub fn readings_of_run(per_display: u32, displays: usize) -> u32 {
    per_display.saturating_mul(u32::try_from(displays).unwrap_or(u32::MAX))
}

/// What follows a warm check: the readings of the run, and the wait if the wall is
/// warming.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ahead {
    /// Readings the run will take.
    pub run_readings: u32,
    /// The wait that follows when the wall is warming.
    pub wait: WarmUp,
}

/// Whether the wall is warming (module docs): reads `info`'s white `check.readings`
/// times and extrapolates the trend over the readings the run will take and over the
/// window of the wait that follows when it is (`ahead`).
pub fn check_warm(
    rig: &mut Rig<'_>,
    wall: &str,
    info: &DisplayInfo,
    opts: &MeasureOptions,
    check: &WarmCheck,
    ahead: Ahead,
    progress: &mut dyn FnMut(Progress),
) -> Result<WarmCheckReport, MeasureError> {
    let Ahead { run_readings, wait } = ahead;
    let n = check.readings.max(3);
    let session_opts = MeasureOptions {
        budget: n,
        ..opts.clone()
    };
    let key = display_key(wall, info);
    let mut s = Session::start(rig, &key, info.id, opts.spot_uv, &session_opts)?;
    let mut points = Vec::with_capacity(n as usize);
    let mut used = 0;
    while s.remaining() > 0 {
        let before = s.log.readings;
        let value = s.sample(Patch::White, false, &mut |_| {})?;
        let took = s.log.readings.saturating_sub(before);
        if let Some(x) = value.filter(|x| x.y > 0.0 && x.y.is_finite()) {
            // at the middle of the readings it averages
            points.push((f64::from(before) + 0.5 * f64::from(took.max(1) - 1), x.y));
            used += took;
        }
        if took == 0 {
            break;
        }
    }
    let report = judge_warmth(&points, (s.log.readings, used), check, run_readings, &wait);
    progress(Progress::WarmCheck(report));
    Ok(report)
}

/// Before a run on `first`: the wait when `opts` asks for it
/// ([`MeasureOptions::warm_up`]), else the warm `check` and the wait (as
/// [`WarmUp::default`]) when it finds the wall warming; nothing without either.
/// `Ok(false)` when the technician skipped `first` while aiming (the display stays
/// skipped; the caller may try the next one).
pub fn wait_or_check(
    rig: &mut Rig<'_>,
    wall: &str,
    first: &DisplayInfo,
    opts: &MeasureOptions,
    check: Option<&WarmCheck>,
    run_readings: u32,
    progress: &mut dyn FnMut(Progress),
) -> Result<bool, MeasureError> {
    let waited = (|| {
        let ahead = Ahead {
            run_readings,
            wait: WarmUp::default(),
        };
        let wait = match (opts.warm_up, check) {
            (Some(w), _) => Some(w),
            (None, Some(c)) => check_warm(rig, wall, first, opts, c, ahead, progress)?
                .warming
                .then_some(ahead.wait),
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
        }) => Ok(false),
        other => other.map(|()| true),
    }
}

/// The warm check's verdict on the white's luminances `points` (reading index, Y), from
/// `used` of the `taken` readings (`readings`), for a run of `run_readings` readings
/// and the `wait` that follows if the wall is warming.
fn judge_warmth(
    points: &[(f64, f64)],
    readings: (u32, u32),
    check: &WarmCheck,
    run_readings: u32,
    wait: &WarmUp,
) -> WarmCheckReport {
    let (taken, used) = readings;
    let (per_reading, sigma) = slope_with_sigma(points);
    let span = points.last().map_or(0.0, |p| p.0) - points.first().map_or(0.0, |p| p.0);
    let run_drift = per_reading * f64::from(run_readings);
    let window_drift = trend_over_window(per_reading, wait);
    let conclusive = points.len() >= 3 && 2 * used >= taken;
    let beyond_noise = per_reading.abs() > check.sigmas * sigma;
    let too_much = run_drift.abs() > check.max_run_drift_percent
        || window_drift.abs() > wait.max_change_percent;
    WarmCheckReport {
        readings: taken,
        values: points.len() as u32,
        conclusive,
        change_percent: per_reading * span,
        change_sigma_percent: sigma * span,
        run_drift_percent: run_drift,
        window_drift_percent: window_drift,
        window_readings: wait.window,
        warming: conclusive && beyond_noise && too_much,
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
    let window = wait_window(warm_up) as usize;
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
    /// pattern + − − +, which adds no trend of its own over a multiple of four readings:
    /// (reading index, Y).
    fn readings(n: usize, step: f64, wobble: f64) -> Vec<(f64, f64)> {
        (0..n)
            .map(|i| {
                let sign = if matches!(i % 4, 0 | 3) { 1.0 } else { -1.0 };
                (i as f64, 100.0 + step * i as f64 + sign * wobble)
            })
            .collect()
    }

    fn judge(points: &[(f64, f64)], run_readings: u32) -> WarmCheckReport {
        let n = points.len() as u32;
        judge_warmth(
            points,
            (n, n),
            &WarmCheck::default(),
            run_readings,
            &WarmUp::default(),
        )
    }

    #[test]
    fn a_wall_that_would_drift_past_the_limit_over_the_run_is_warming() {
        // +0.05 % a reading: +1.15 % over 24 readings, +25 % over 500
        let r = judge(&readings(24, 0.05, 0.01), 500);
        assert!(r.conclusive && r.warming, "{r:?}");
        assert!((r.change_percent - 1.15).abs() < 0.02, "{r:?}");
        assert!((r.run_drift_percent - 25.0).abs() < 0.5, "{r:?}");
    }

    #[test]
    fn a_trend_within_its_own_noise_or_steady_by_the_waits_measure_is_warm() {
        // a rise of 0.0005 % a reading hidden in ±0.1 % scatter
        let noisy = judge(&readings(24, 0.0005, 0.1), 5000);
        assert!(noisy.run_drift_percent > 1.0, "{noisy:?}");
        assert!(!noisy.warming, "{noisy:?}");
        // a clear rise of 0.036 % per 120 readings, which the wait calls stable, over a
        // run it moves by 0.15 %
        let steady = judge(&readings(24, 0.0003, 0.0), 500);
        assert!(steady.change_sigma_percent < 1e-9, "{steady:?}");
        assert!(
            (steady.window_drift_percent - 0.0003 * 119.0).abs() < 1e-5,
            "{steady:?}"
        );
        assert!((steady.run_drift_percent - 0.15).abs() < 1e-3, "{steady:?}");
        assert!(!steady.warming, "{steady:?}");
    }

    #[test]
    fn a_steady_trend_that_would_drift_a_long_run_past_the_limit_is_warming() {
        // the steady rise above over a run of 5000 readings: 1.5 %, past the drift
        // check's 1 %, though the wait would call it stable
        let long = judge(&readings(24, 0.0003, 0.0), 5000);
        assert!(long.window_drift_percent < WarmUp::default().max_change_percent);
        assert!((long.run_drift_percent - 1.5).abs() < 1e-3, "{long:?}");
        assert!(long.warming, "{long:?}");
    }

    #[test]
    fn the_wait_prints_its_progress_once_per_window() {
        let wait = WarmUp::default();
        assert_eq!(warming_up_line(&wait, 119, 1.0), None);
        let line = warming_up_line(&wait, 240, 0.72).expect("a line at 240");
        assert!(
            line.contains("240 readings") && line.contains("+0.72 % per 120"),
            "{line}"
        );
    }

    #[test]
    fn a_lamp_still_warming_is_waited_for_even_where_a_short_run_drifts_within_the_limit() {
        // 0.01 % a reading, beyond its ±0.01 % scatter: 0.64 % over a one-display run of
        // 64 readings (within the 1 % drift limit), 1.19 % per 120 readings (the wait
        // calls 0.05 % stable): the lamps would go on warming after the run
        let r = judge(&readings(40, 0.01, 0.01), 64);
        assert!(r.run_drift_percent.abs() < WarmCheck::default().max_run_drift_percent);
        assert!((r.window_drift_percent - 1.19).abs() < 0.01, "{r:?}");
        assert_eq!(r.window_readings, 120);
        assert!(r.conclusive && r.warming, "{r:?}");
        assert!(r.summary().contains("waiting"), "{}", r.summary());
    }

    #[test]
    fn low_light_averages_count_every_reading_and_a_mostly_refused_white_cannot_tell() {
        // ten averages of four readings each, rising 0.05 % a reading: the drift per
        // reading, not per average
        let averaged: Vec<(f64, f64)> = (0..10)
            .map(|k| {
                let x = 4.0 * f64::from(k) + 1.5;
                (x, 100.0 + 0.05 * x)
            })
            .collect();
        let r = judge_warmth(
            &averaged,
            (40, 40),
            &WarmCheck::default(),
            500,
            &WarmUp::default(),
        );
        assert!((r.run_drift_percent - 25.0).abs() < 0.5, "{r:?}");
        assert!(r.warming && r.values == 10 && r.readings == 40, "{r:?}");
        // five of forty readings came back: no verdict, no wait
        let refused = judge_warmth(
            &averaged[..5],
            (40, 5),
            &WarmCheck::default(),
            500,
            &WarmUp::default(),
        );
        assert!(!refused.conclusive && !refused.warming, "{refused:?}");
        assert!(refused.summary().contains("cannot tell"));
    }

    #[test]
    fn the_trend_of_a_line_is_its_rise_over_the_window_and_noise_free_flat_is_zero() {
        let y: Vec<f64> = (0..60).map(|i| 100.0 + 0.01 * f64::from(i)).collect();
        let mean = y.iter().sum::<f64>() / 60.0;
        assert!((trend_percent(&y) - 100.0 * 0.59 / mean).abs() < 1e-9);
        assert_eq!(trend_percent(&[5.0; 60]), 0.0);
    }
}
