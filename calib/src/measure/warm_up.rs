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

/// Change over `y` (percent of its mean) along its least-squares line.
fn trend_percent(y: &[f64]) -> f64 {
    let n = y.len() as f64;
    let mean_x = (n - 1.0) / 2.0;
    let mean_y = y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, v) in y.iter().enumerate() {
        let dx = i as f64 - mean_x;
        sxy += dx * (v - mean_y);
        sxx += dx * dx;
    }
    if sxx <= 0.0 || mean_y <= 0.0 {
        return 0.0;
    }
    100.0 * (sxy / sxx) * (n - 1.0) / mean_y
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

    #[test]
    fn the_trend_of_a_line_is_its_rise_over_the_window_and_noise_free_flat_is_zero() {
        let y: Vec<f64> = (0..60).map(|i| 100.0 + 0.01 * f64::from(i)).collect();
        let mean = y.iter().sum::<f64>() / 60.0;
        assert!((trend_percent(&y) - 100.0 * 0.59 / mean).abs() < 1e-9);
        assert_eq!(trend_percent(&[5.0; 60]), 0.0);
    }
}
