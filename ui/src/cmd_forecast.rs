//! `lumiwall profiles forecast`: when each display will stop reaching the wall's
//! common white, from the store's history (`lumiwall_profiles::store::forecast`).

use std::fmt::Write as _;
use std::path::PathBuf;

use lumiwall_profiles::store::{
    Crossing, DecayLaw, DisplayForecast, ForecastOptions, ProfileStore, Timestamp,
};

use crate::CliError;
use crate::values;

/// The decay law on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum DecayArg {
    /// The light falls by the same amount every hour (UHP, xenon).
    Linear,
    /// The light falls by the same fraction every hour (LED, laser; IES TM-21).
    Exponential,
}

/// Arguments of `lumiwall profiles forecast`.
#[derive(Debug, clap::Args)]
pub(crate) struct ForecastArgs {
    /// Profile store (SQLite file).
    #[arg(long)]
    store: PathBuf,
    /// Wall name.
    #[arg(long)]
    wall: String,
    /// Rise of a display's white luminance between two runs that marks a lamp change
    /// (the history before it is not fitted): `10%` or `0.1`.
    #[arg(long, default_value = "10%", value_parser = values::fraction)]
    lamp_change_step: f64,
    /// Fit no burn-in (the large early loss of a UHP lamp): for LED and laser light
    /// sources, so that noise is not read as one.
    #[arg(long)]
    no_burn_in: bool,
    /// How the light falls after the burn-in: linear (discharge lamps: UHP, xenon) or
    /// exponential (LED and laser light sources, as IES TM-21 projects them).
    #[arg(long, value_enum, default_value = "linear")]
    decay: DecayArg,
    /// No date is predicted further ahead than this many days (1 to 3650).
    #[arg(long, default_value_t = 730, value_parser = clap::value_parser!(u32).range(1..=3650))]
    horizon_days: u32,
}

/// Runs `lumiwall profiles forecast`: prints one line per display and eye, and which
/// lamp to replace first.
pub(crate) fn run(a: &ForecastArgs) -> Result<(), CliError> {
    let store = ProfileStore::open_existing(&a.store)?;
    let opts = ForecastOptions {
        lamp_change_step: a.lamp_change_step,
        burn_in: !a.no_burn_in,
        decay: match a.decay {
            DecayArg::Linear => DecayLaw::Linear,
            DecayArg::Exponential => DecayLaw::Exponential,
        },
        horizon_days: f64::from(a.horizon_days),
    };
    let forecasts = store.forecast_wall(&a.wall, &opts)?;
    if forecasts.is_empty() {
        return Err(CliError::input(format!(
            "no profile of wall {:?} in {}; check --wall with `lumiwall profiles runs --store {}`",
            a.wall,
            a.store.display(),
            a.store.display()
        )));
    }
    print!("{}", table(&forecasts, &opts));
    Ok(())
}

fn day(t: Timestamp) -> String {
    t.strftime("%Y-%m-%d").to_string()
}

fn crossing_cell(x: Option<(&str, Crossing)>, horizon_days: f64) -> String {
    match x {
        Some((c, x)) => format!(
            "{c} {} ({} … {})",
            day(x.utc),
            day(x.earliest_utc),
            day(x.latest_utc)
        ),
        None => format!("not within {horizon_days:.0} d"),
    }
}

/// The forecast table and the replace-first line.
fn table(forecasts: &[DisplayForecast], opts: &ForecastOptions) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<14} {:>6} {:<10} {:>22} {:>7}  {:<36} {:<36}",
        "display",
        "points",
        "lamp since",
        "decay R/G/B %/1000 h",
        "fit rms",
        "white out of reach (±2σ)",
        "at the headroom (±2σ)"
    );
    for f in forecasts {
        let name = format!("{} {}", f.display().display, f.display().eye);
        match f {
            DisplayForecast::NotEnoughHistory { points, .. } => {
                let _ = writeln!(
                    s,
                    "{name:<14} {points:>6} {:<10} not enough history since the last lamp change \
                     (need {})",
                    "-",
                    lumiwall_profiles::store::forecast::MIN_POINTS
                );
            }
            DisplayForecast::Fitted {
                points,
                segment_start_utc,
                channels,
                headroom,
                ..
            } => {
                let decay: Vec<String> = channels
                    .iter()
                    .map(|c| format!("{:.1}", c.decay_pct_per_1000_h))
                    .collect();
                if channels.iter().all(|c| c.fit_rms_pct.is_nan()) {
                    let _ = writeln!(
                        s,
                        "{name:<14} {points:>6} {:<10} no forecast: the fit failed (light not \
                         positive, or every run at one time)",
                        day(*segment_start_utc)
                    );
                    continue;
                }
                let rms = channels
                    .iter()
                    .map(|c| c.fit_rms_pct)
                    .fold(f64::NAN, f64::max);
                let first =
                    |pick: fn(&lumiwall_profiles::store::ChannelForecast) -> Option<Crossing>| {
                        channels
                            .iter()
                            .filter_map(|c| pick(c).map(|x| (c.channel.letter(), x)))
                            .min_by_key(|(_, x)| x.utc)
                    };
                let _ = writeln!(
                    s,
                    "{name:<14} {points:>6} {:<10} {:>22} {:>6.2}%  {:<36} {:<36}   (headroom {headroom:.2})",
                    day(*segment_start_utc),
                    decay.join(" / "),
                    rms,
                    crossing_cell(first(|c| c.beyond_full_drive), opts.horizon_days),
                    crossing_cell(first(|c| c.leaves_headroom), opts.horizon_days),
                );
            }
        }
    }
    s += &replace_first(forecasts, opts);
    s
}

/// Which lamp to replace first: the display whose white goes out of reach first.
fn replace_first(forecasts: &[DisplayForecast], opts: &ForecastOptions) -> String {
    let mut s = String::new();
    let first = forecasts
        .iter()
        .filter_map(|f| f.first_beyond_full_drive().map(|(c, x)| (f, c, x)))
        .min_by_key(|(_, _, x)| x.utc);
    match first {
        Some((f, c, x)) => {
            let _ = writeln!(
                s,
                "replace first: {} (its {} reaches full drive on {}: from then on it cannot \
                 show today's common white)",
                f.display(),
                c.name(),
                day(x.utc)
            );
        }
        None => {
            let _ = writeln!(
                s,
                "every forecast display reaches today's common white for the next {:.0} days",
                opts.horizon_days
            );
        }
    }
    let unforecast = forecasts
        .iter()
        .filter(|f| match f {
            DisplayForecast::NotEnoughHistory { .. } => true,
            DisplayForecast::Fitted { channels, .. } => {
                channels.iter().all(|c| c.fit_rms_pct.is_nan())
            }
        })
        .count();
    if unforecast > 0 {
        let _ = writeln!(
            s,
            "({unforecast} of {} displays without a forecast, see above)",
            forecasts.len()
        );
    }
    s
}
