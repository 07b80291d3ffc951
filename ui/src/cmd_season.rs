//! `lumiwall bench season`: nightly recalibration over a simulated season on the
//! virtual wall, judged against the simulator's truth (`lumiwall_bench::season`).

use std::path::PathBuf;

use lumiwall_bench::season::{
    self, ForecastCheck, NightRow, SeasonBench, SeasonError, SeasonSummary,
};
use lumiwall_calib::recalibrate::DriftLimits;
use lumiwall_calib::solve::SolveOptions;
use lumiwall_calib::station::{MeterChoice, Noise};
use lumiwall_calib::verify::Tolerances;
use lumiwall_profiles::store::{ForecastOptions, Timestamp};

use crate::CliError;
use crate::values;

/// Arguments of `lumiwall bench season`.
#[derive(Debug, clap::Args)]
pub(crate) struct SeasonArgs {
    /// Wall description (TOML).
    #[arg(long, default_value = "fixtures/walls/heyewall-48.toml")]
    wall: PathBuf,
    /// Nights after the commissioning (1 to 3650).
    #[arg(long, default_value_t = 120)]
    nights: u32,
    /// Hours the lamps burn per day (above 0, at most 24).
    #[arg(long, default_value_t = 12.0, allow_negative_numbers = true, value_parser = values::positive_finite)]
    lamp_hours_per_day: f64,
    /// Night whose recalibration follows a lamp change (0: none).
    #[arg(long, default_value_t = 60)]
    lamp_change_night: u32,
    /// Display whose lamp is changed (default: the one with the least reserve that
    /// night, the lamp the forecast says to replace first).
    #[arg(long)]
    lamp_change_display: Option<u32>,
    /// Night after whose recalibration the forecast is made and checked.
    #[arg(long, default_value_t = 30)]
    forecast_night: u32,
    /// No date is predicted further ahead than this many days (1 to 3650).
    #[arg(long, default_value_t = 730, value_parser = clap::value_parser!(u32).range(1..=3650))]
    horizon_days: u32,
    /// Error model of the station meter: realistic (matched to the simulated reference
    /// spectroradiometer first) or none.
    #[arg(long, default_value = "none")]
    noise: Noise,
    /// Meter path (direct is fastest; emulated goes through the pty).
    #[arg(long, default_value = "direct")]
    meter: MeterChoice,
    /// Largest channel usage the commissioning's common white may take (the reserve
    /// the nightly runs live on), in (0, 1].
    #[arg(long, default_value_t = 0.85, value_parser = |s: &str| values::positive_at_most(s, 1.0))]
    headroom: f64,
    /// Each display is measured in full once in this many nights, in turn (the nightly
    /// run's `--full-check-every`); one white reading checks it on the others.
    #[arg(long, default_value_t = 7, value_parser = clap::value_parser!(u32).range(1..=366))]
    full_check_every: u32,
    /// Scratch folder: profiles, the season's store, the plot (season.svg).
    #[arg(long, default_value = "out/bench-season")]
    out: PathBuf,
    /// Meter readings each reading averages, as `commission --averaging` (the nights
    /// average as the commissioning did, as `recalibrate`'s default).
    #[arg(long, default_value = "auto")]
    averaging: lumiwall_calib::measure::averaging::Averaging,
}

/// Runs `lumiwall bench season`: prints the night-by-night table, the forecast check,
/// the costs and the `SEASON` line.
pub(crate) fn bench(a: SeasonArgs) -> Result<(), CliError> {
    values::check_output_dir("--out", &a.out)?;
    let bench = SeasonBench {
        solve: SolveOptions {
            headroom: a.headroom,
            ..SolveOptions::default()
        },
        wall: a.wall,
        nights: a.nights,
        lamp_hours_per_day: a.lamp_hours_per_day,
        lamp_change_night: (a.lamp_change_night > 0).then_some(a.lamp_change_night),
        lamp_change_display: a.lamp_change_display,
        forecast_night: a.forecast_night,
        forecast: ForecastOptions {
            horizon_days: f64::from(a.horizon_days),
            ..ForecastOptions::default()
        },
        noise: a.noise,
        meter: a.meter,
        limits: DriftLimits::default(),
        full_check_every_nights: a.full_check_every,
        tolerances: Tolerances::default(),
        averaging: a.averaging,
        out: a.out,
        start_utc: Timestamp::now(),
    };
    println!(
        "season on {}: {} nights, lamps {} h/day, headroom {}, each display in full every {} \
         nights (a white reading between), meter noise {}; truth = the 51-patch chart read \
         by a perfect meter after each night",
        bench.wall.display(),
        bench.nights,
        bench.lamp_hours_per_day,
        bench.solve.headroom,
        bench.full_check_every_nights,
        bench.noise.name()
    );
    println!(
        "{:>5} {:>8} {:<13} {:>8} {:>7} {:>8} {:>8} {:>7} {:>6} {:>6} {:>6} {:>6}  event",
        "night",
        "lamp h",
        "verdict",
        "readings",
        "meas s",
        "white",
        "reserve",
        "median",
        "max",
        "white",
        "within",
        "time s"
    );
    let (_, summary) = season::run(&bench, &mut print_night).map_err(cli_error)?;
    print!("{}", summary_text(&summary));
    Ok(())
}

fn cli_error(e: SeasonError) -> CliError {
    match e {
        SeasonError::Station(e) => e.into(),
        SeasonError::Settings(_) => CliError::input(e.to_string()),
        _ => CliError::failure(e.to_string()),
    }
}

fn print_night(r: &NightRow) {
    let verdict = r
        .verdict
        .map_or("commissioned".to_string(), |v| format!("{v:?}"));
    let mut event = r
        .lamp_changed
        .as_ref()
        .map_or(String::new(), |k| format!("lamp of {k} replaced"));
    if let (false, Some(k)) = (r.within, &r.worst_white) {
        event += &format!(" worst white: {k}");
    }
    println!(
        "{:>5} {:>8.0} {:<13} {:>8} {:>7.0} {:>8.2} {:>8.3} {:>7.3} {:>6.2} {:>6.2} {:>6} {:>6.1}  {event}",
        r.night,
        r.clock_h,
        verdict,
        r.readings,
        r.measuring_s,
        r.white_cd_m2,
        r.least_reserve,
        r.truth_median_de,
        r.truth_max_de,
        r.truth_white_de,
        if r.within { "yes" } else { "NO" },
        r.elapsed.as_secs_f64(),
    );
}

fn days(d: Option<f64>) -> String {
    d.map_or("beyond".into(), |d| format!("{d:.1}"))
}

fn forecast_lines(checks: &[ForecastCheck]) -> String {
    let mut s = format!(
        "{:<46} {:>9} {:>9} {:>9} {:>11}\n",
        "display", "predicted", "true", "error d", "% of lead"
    );
    for c in checks {
        s += &format!(
            "{:<46} {:>9} {:>9} {:>9.1} {:>11.1}\n",
            c.display.to_string(),
            days(c.predicted_days),
            days(c.true_days),
            c.error_days,
            c.error_pct_of_lead
        );
    }
    s
}

fn summary_text(s: &SeasonSummary) -> String {
    let [m, x, w] = s.limits_de;
    let mut out = format!(
        "limits (the verify tolerance, or 110 % of the commissioning's figure where the \
         commissioning was not within it): median ≤ {m:.3}, max ≤ {x:.2}, white ≤ {w:.2}\n"
    );
    if s.forecast.is_empty() {
        out += "forecast: not checked (the season ended before the forecast night)\n";
    } else {
        out += &format!(
            "forecast of the day each display can no longer show the common white at full \
             drive, made after night {} (days after it; beyond: not within the {:.0}-day \
             horizon, counted as the horizon):\n",
            s.forecast_night, s.horizon_days
        );
        out += &forecast_lines(&s.forecast);
    }
    match &s.lamp_change {
        Some((k, found)) => {
            out += &format!(
                "lamp change of {k}: {}\n",
                if *found {
                    "detected on its night"
                } else {
                    "NOT detected"
                }
            );
        }
        None => out += "lamp change: none simulated\n",
    }
    out += &format!(
        "lamp changes found that did not happen: {}\n",
        s.false_lamp_changes.len()
    );
    let ((cr, cs), (nr, ns)) = (s.commission_cost, s.nightly_cost);
    out += &format!(
        "cost per night: {nr:.0} meter readings ({:.1} % of the commissioning's {cr}), 0 \
         camera captures, {:.1} min measuring ({:.1} % of the commissioning's {:.1} min)\n",
        100.0 * nr / (cr as f64).max(1.0),
        ns / 60.0,
        100.0 * ns / cs.max(1e-9),
        cs / 60.0
    );
    out += &format!("plot: {}\n", s.plot.display());
    out += &format!(
        "SEASON nights {} within-tolerance {} forecast-error {}\n",
        s.nights,
        s.within,
        s.forecast_error_pct_of_horizon
            .map_or("n/a".to_string(), |e| format!("{e:.1} %"))
    );
    out
}
