//! How many of the meter's readings each reading of a run averages: one on a wall
//! whose chart greys the meter resolves, more on a dim one.
//!
//! Why: with a CS-100A class meter a wall white of about 12 cd/m² puts the
//! verification chart's 2 % grey at 0.25 cd/m², where one reading's x scatters about
//! 0.007 (the sensors' zero-light noise; Kresse 2003 gives the CS-100A's xy as reliable
//! above 12 cd/m² only). No placement of 40 readings gets such a wall's grey balance
//! within 0.5 on every run, and more readings spread by the usual plan level off
//! (`bench/walls/README.md`: dim-mono-2x1 at 128 readings met every limit on 37 of 40
//! seeds, at 1024 its grey balance was still 0.24). Averaging every reading `n` times
//! runs the same plan on a meter `√n` times quieter, and the run's figures then follow
//! the meter's noise down. An instrument's own driver does the same in the dark
//! (ArgyllCMS's K-10 driver averages up to 20 readings below 0.2 cd/m²); here it is
//! chosen per run, from the wall white, because a grey's colour needs the whole curve
//! quiet, not only its darkest readings (averaging only the readings below the
//! reliable limit 4× met every limit on 39 of 40 dim-mono-2x1 seeds and 17 of 20
//! weak-green-infitec-2x2, averaging all of them 40 and 20).
//!
//! The rule ([`needed`]): enough readings per reading that the darkest chart grey's x
//! and y scatter at most [`DARKEST_GREY_XY_SIGMA`] per reading, at most [`MAX_AUTO`].
//! Where the meter can be aimed again at no cost, a commissioning surveys every
//! display's black, primaries and white before any ramp anyway; the wall white those
//! allow chooses ([`AveragingChoice`]), and where it asks for more than one reading the
//! displays are surveyed again with the averaged meter (a bright wall's run is as it
//! was). Where a technician aims, the run reads once and says after the solve what the
//! wall needed.

use std::str::FromStr;

use lumiwall_devices::ReadingNoise;
use serde::{Deserialize, Serialize};

use super::Rig;

/// Standard deviation of x and y of one (averaged) reading of the chart's darkest grey
/// that [`needed`] aims at. Realistic meter, 40 readings per display (64 on
/// weak-green-infitec-2x2), runs within every limit of issue 12 with each reading the
/// mean of 1 / 2 / 4: dim-mono-2x1 (wall white 12.7 cd/m², one reading's x at its 2 %
/// grey 0.0074) 43 of 60 / 37 of 40 / 40 of 40; weak-green-infitec-2x2 (8.6 cd/m²,
/// 0.011) 17 of 60 / 15 of 20 / 20 of 20; the same wall with lamps for 20 cd/m²
/// (0.0047) 39 of 40 with one. At 0.005 those walls average 3, 5 and 1.
pub const DARKEST_GREY_XY_SIGMA: f64 = 0.005;

/// Most readings [`Averaging::Auto`] averages: a wall that needs more is dimmer than the
/// meter resolves within the rule (below about 4 cd/m² with a CS-100A class one, whose
/// readings take a second; below about 17 cd/m² by the stated noise of a K-10-A's
/// eighth-of-a-second reading, whose simulated noise is about half that: dim-mono-2x1
/// through the emulated K-10-A at 16, seeds 101–106, 6 of 6 within every limit, mean
/// worst grey balance 0.15), and the run says so.
pub const MAX_AUTO: u32 = 16;

/// How many of the meter's readings each reading averages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Averaging {
    /// As many as the wall white needs ([`needed`]), where it is known before the run
    /// (the meter revisits displays at no cost); one otherwise, with a warning after
    /// the solve when the wall white needed more.
    Auto,
    /// This many (1: the meter's readings as they come).
    Fixed(u32),
}

impl Averaging {
    /// The fixed count, within 1..=[`lumiwall_devices::averaging::MAX_AVERAGED`]; one
    /// under [`Averaging::Auto`] (until a run chooses).
    pub fn count_or_one(self) -> u32 {
        match self {
            Averaging::Fixed(n) => n.clamp(1, lumiwall_devices::averaging::MAX_AVERAGED),
            Averaging::Auto => 1,
        }
    }
}

impl Default for Averaging {
    fn default() -> Self {
        Averaging::Fixed(1)
    }
}

impl FromStr for Averaging {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Averaging::Auto);
        }
        match s.parse::<u32>() {
            Ok(n) if (1..=lumiwall_devices::averaging::MAX_AVERAGED).contains(&n) => {
                Ok(Averaging::Fixed(n))
            }
            _ => Err(format!(
                "'{s}' is not an averaging: give auto, or the readings each reading \
                 averages (1 to {})",
                lumiwall_devices::averaging::MAX_AVERAGED
            )),
        }
    }
}

/// Readings each reading should average on a wall white of `white_y_cd_m2` at
/// chromaticity `white_xy` with a meter of this stated noise: the darkest chart grey's
/// x and y within [`DARKEST_GREY_XY_SIGMA`], 1 to [`MAX_AUTO`]; and whether the
/// wall needed more than that.
pub fn needed(noise: &ReadingNoise, white_xy: [f64; 2], white_y_cd_m2: f64) -> (u32, bool) {
    let (n, _, too_dim) = rule(noise, white_xy, white_y_cd_m2);
    (n, too_dim)
}

/// [`needed`] with the darkest grey's x or y scatter of one reading, whichever is
/// larger (0 for light without a chromaticity): `(n, sigma, too_dim)`.
fn rule(noise: &ReadingNoise, white_xy: [f64; 2], white_y_cd_m2: f64) -> (u32, f64, bool) {
    let grey = super::black_readings::darkest_grey(white_xy, white_y_cd_m2);
    let Some([sx, sy]) = noise.sigma_xy(grey) else {
        return (1, 0.0, false);
    };
    let sigma = sx.max(sy);
    let ratio = sigma / DARKEST_GREY_XY_SIGMA;
    let n = (ratio * ratio).ceil();
    if !n.is_finite() || n > f64::from(MAX_AUTO) {
        return (MAX_AUTO, sigma, true);
    }
    ((n as u32).max(1), sigma, false)
}

/// What [`Averaging::Auto`] chose for a run, and why.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AveragingChoice {
    /// Meter readings each reading averages.
    pub readings_per_reading: u32,
    /// The wall white the survey allows (cd/m²): the dimmest display's at the target
    /// chromaticity and headroom.
    pub wall_white_cd_m2: f64,
    /// The darkest chart grey's x or y scatter of one reading of the meter, whichever
    /// is larger.
    pub darkest_grey_sigma_xy: f64,
    /// Meter readings of the survey that chose (the displays surveyed in this run);
    /// where it chose more than one, those displays were surveyed again and these
    /// readings are extra ([`super::MeasureLog::first_survey_readings`]).
    pub estimate_readings: u32,
    /// The wall needs more than [`MAX_AUTO`].
    pub too_dim: bool,
}

impl AveragingChoice {
    /// The choice for a wall white of `white_y_cd_m2` at `white_xy` with a meter of this
    /// stated noise, from a survey of `estimate_readings` readings.
    pub fn for_wall(
        noise: &ReadingNoise,
        white_xy: [f64; 2],
        white_y_cd_m2: f64,
        estimate_readings: u32,
    ) -> Self {
        let (readings_per_reading, sigma, too_dim) = rule(noise, white_xy, white_y_cd_m2);
        Self {
            readings_per_reading,
            wall_white_cd_m2: white_y_cd_m2,
            darkest_grey_sigma_xy: sigma,
            estimate_readings,
            too_dim,
        }
    }

    /// One line for the console.
    pub fn summary(&self) -> String {
        let head = format!(
            "wall white about {:.1} cd/m² (survey of {} readings): the chart's {:.0} % grey \
             reads ±{:.4} in xy per reading",
            self.wall_white_cd_m2,
            self.estimate_readings,
            100.0 * super::black_readings::DARKEST_GREY_SHARE,
            self.darkest_grey_sigma_xy,
        );
        match (self.readings_per_reading, self.too_dim) {
            (1, _) => format!("{head}: one meter reading per reading"),
            (n, false) => format!(
                "{head}: each reading averages {n} meter readings (the run takes {n}× as \
                 long; the displays are surveyed again)"
            ),
            (n, true) => format!(
                "{head}: each reading averages {n} meter readings, the most it will, and the \
                 darkest greys stay noisier than it aims for (±{:.4} per averaged reading, \
                 against {DARKEST_GREY_XY_SIGMA}; a meter quieter in the dark, or brighter \
                 lamps, help)",
                self.darkest_grey_sigma_xy / f64::from(n).sqrt()
            ),
        }
    }
}

/// Meter readings each reading averaged in these saved measurements
/// ([`super::MeasureLog::readings_averaged`]): the most of any, 1 for none.
pub fn of_saved<'m>(measured: impl IntoIterator<Item = &'m super::MeasuredDisplay>) -> u32 {
    measured
        .into_iter()
        .map(|m| m.log.meter_readings_each())
        .max()
        .unwrap_or(1)
}

/// Runs `f` with `rig`'s meter averaging `n` readings for each
/// ([`lumiwall_devices::AveragingMeter`]).
pub fn with_averaging<T>(rig: &mut Rig<'_>, n: u32, f: impl FnOnce(&mut Rig<'_>) -> T) -> T {
    let mut meter = lumiwall_devices::AveragingMeter::new(&mut *rig.meter, n);
    let mut averaged = Rig {
        pattern: &mut *rig.pattern,
        meter: &mut meter,
        positioner: &mut *rig.positioner,
    };
    f(&mut averaged)
}

#[cfg(test)]
mod tests {
    use super::*;

    const W8500: [f64; 2] = [0.2908, 0.2999];

    #[test]
    fn a_bright_wall_reads_once_and_a_dim_one_averages_more_the_dimmer_it_is() {
        let noise = ReadingNoise::CS100A_CLASS;
        assert_eq!(needed(&noise, W8500, 50.0), (1, false));
        assert_eq!(needed(&noise, W8500, 20.0), (1, false));
        let (at_12, _) = needed(&noise, W8500, 12.7);
        let (at_8, _) = needed(&noise, W8500, 8.6);
        assert!((2..=4).contains(&at_12), "{at_12}");
        assert!(at_8 > at_12 && at_8 <= 8, "{at_8}");
        assert_eq!(needed(&noise, W8500, 2.0), (MAX_AUTO, true));
    }

    #[test]
    fn an_exact_meter_never_averages() {
        assert_eq!(needed(&ReadingNoise::EXACT, W8500, 0.5), (1, false));
    }

    #[test]
    fn averaging_parses_auto_and_counts_and_refuses_the_rest() {
        assert_eq!("auto".parse(), Ok(Averaging::Auto));
        assert_eq!("4".parse(), Ok(Averaging::Fixed(4)));
        for bad in ["0", "65", "-1", "x", ""] {
            assert!(bad.parse::<Averaging>().is_err(), "{bad}");
        }
    }
}
