//! `lumiwall profiles`: the profile store from the command line — record a profile
//! folder as a run, list runs, show a display's history and the wall's drift as tables.

use std::fmt::Write as _;
use std::path::PathBuf;

use lumiwall_profiles::store::{
    CommissionRun, Drift, DriftLimits, ProfileStore, Timestamp, drift::native_white_xyz_cd_m2,
    drift::xy_of, parse_time,
};
use lumiwall_profiles::{DisplayProfile, ProfileSet};

use crate::CliError;
use crate::values;

/// Arguments of `lumiwall profiles`.
#[derive(Debug, clap::Args)]
pub(crate) struct ProfilesArgs {
    #[command(subcommand)]
    command: ProfilesCommand,
}

#[derive(Debug, clap::Subcommand)]
enum ProfilesCommand {
    /// Every stored profile of a display (or of every display), oldest first.
    History(HistoryArgs),
    /// How each display changed since a date: white luminance %, white Δxy, black,
    /// channel usage. Exits with status 3 if a --max-* limit is exceeded.
    Drift(DriftArgs),
    /// When each display will stop reaching the common white (lamp-life forecast from
    /// the history: per-channel decay fits, lamp changes detected), and which lamp to
    /// replace first.
    Forecast(crate::cmd_forecast::ForecastArgs),
    /// Restore the profiles (and measurements) the last `lumiwall recalibrate` replaced
    /// in a profile folder.
    #[cfg(feature = "station")]
    Rollback(RollbackArgs),
    /// Record a profile folder (`wall.json` and its profiles) as one run.
    Import(ImportArgs),
    /// The walls in the store and their runs.
    Runs(RunsArgs),
}

#[derive(Debug, clap::Args)]
struct HistoryArgs {
    /// Profile store (SQLite file).
    #[arg(long)]
    store: PathBuf,
    /// Wall name.
    #[arg(long)]
    wall: String,
    /// Only this projector (index in the wall file, 0-based); all eyes are shown.
    #[arg(long)]
    display: Option<u32>,
}

#[derive(Debug, clap::Args)]
struct DriftArgs {
    /// Profile store (SQLite file).
    #[arg(long)]
    store: PathBuf,
    /// Wall name.
    #[arg(long)]
    wall: String,
    /// Compare against the first run at or after this time (a date such as 2026-11-01,
    /// taken as 00:00 UTC, or RFC 3339); default: the first run of the wall.
    #[arg(long)]
    since: Option<String>,
    /// Fail (exit 3) if any display's white luminance changed by more than this many
    /// percent (a finite number greater than 0).
    #[arg(long, allow_negative_numbers = true, value_parser = values::positive_finite)]
    max_luminance_change_pct: Option<f64>,
    /// Fail (exit 3) if any display's white moved by more than this in CIE 1931 xy (a
    /// finite number greater than 0).
    #[arg(long, allow_negative_numbers = true, value_parser = values::positive_finite)]
    max_delta_xy: Option<f64>,
}

#[derive(Debug, clap::Args)]
struct ImportArgs {
    /// Profile store (SQLite file); created if missing.
    #[arg(long)]
    store: PathBuf,
    /// Profile folder written by `lumiwall commission` (holds `wall.json`).
    #[arg(long)]
    dir: PathBuf,
    /// Time of the run (date or RFC 3339); default: the newest `created_utc` of the profiles.
    #[arg(long)]
    time: Option<String>,
    /// What made the run: commission, nightly, service, ….
    #[arg(long, default_value = "import")]
    source: String,
    /// Free text stored with the run (lamp changed, …).
    #[arg(long, default_value = "")]
    note: String,
}

#[cfg(feature = "station")]
#[derive(Debug, clap::Args)]
struct RollbackArgs {
    /// Profile folder written by `lumiwall commission` and changed by `recalibrate`.
    #[arg(long)]
    profiles: PathBuf,
}

#[derive(Debug, clap::Args)]
struct RunsArgs {
    /// Profile store (SQLite file).
    #[arg(long)]
    store: PathBuf,
    /// Only this wall's runs; without it, the walls are listed.
    #[arg(long)]
    wall: Option<String>,
}

/// Runs `lumiwall profiles`.
pub(crate) fn run(args: ProfilesArgs) -> Result<(), CliError> {
    let text = match args.command {
        ProfilesCommand::History(a) => {
            let store = ProfileStore::open_existing(&a.store)?;
            history_table(&store, &a.wall, a.display)?
        }
        ProfilesCommand::Drift(a) => return drift(&a),
        ProfilesCommand::Forecast(a) => return crate::cmd_forecast::run(&a),
        #[cfg(feature = "station")]
        ProfilesCommand::Rollback(a) => {
            let restored = lumiwall_calib::recalibrate::rollback(&a.profiles)
                .map_err(|e| CliError::input(e.to_string()))?;
            format!(
                "restored {} profiles in {} (the ones before the last recalibration)\n",
                restored.len(),
                a.profiles.display()
            )
        }
        ProfilesCommand::Import(a) => import(&a)?,
        ProfilesCommand::Runs(a) => {
            let store = ProfileStore::open_existing(&a.store)?;
            runs_table(&store, a.wall.as_deref())?
        }
    };
    print!("{text}");
    Ok(())
}

fn time_cell(t: Timestamp) -> String {
    t.strftime("%Y-%m-%d %H:%MZ").to_string()
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |v| format!("{v:.digits$}"))
}

/// `lumiwall profiles drift`: prints the drift table and checks the limits.
fn drift(a: &DriftArgs) -> Result<(), CliError> {
    let store = ProfileStore::open_existing(&a.store)?;
    let since = a.since.as_deref().map(parse_time).transpose()?;
    let drifts = store.drift_wall(&a.wall, since)?;
    if drifts.is_empty() {
        return Err(CliError::input(format!(
            "no profile of wall {:?} in {}{}; check --wall with `lumiwall profiles runs --store {}`",
            a.wall,
            a.store.display(),
            since.map_or(String::new(), |t| format!(" since {t}")),
            a.store.display()
        )));
    }
    print!("{}", drift_table(&drifts));
    let limits = DriftLimits {
        max_luminance_change_pct: a.max_luminance_change_pct,
        max_delta_xy: a.max_delta_xy,
    };
    check_limits(&drifts, limits)
}

/// One row per stored profile: native white, black and channel usage.
fn history_table(
    store: &ProfileStore,
    wall: &str,
    display: Option<u32>,
) -> Result<String, CliError> {
    let displays: Vec<u32> = match display {
        Some(d) => vec![d],
        None => store.display_numbers(wall)?,
    };
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<17} {:>4} {:<5} {:>12} {:>7} {:>7} {:>12} {:>6} {:>6} {:>6} {:>8}",
        "time (UTC)",
        "disp",
        "eye",
        "white cd/m²",
        "x",
        "y",
        "black cd/m²",
        "use R",
        "use G",
        "use B",
        "readings"
    );
    let mut rows = 0;
    for d in displays {
        for (t, p) in store.history(wall, d)? {
            let w = native_white_xyz_cd_m2(&p);
            let xy = xy_of(w);
            let u = p.channel_usage;
            let _ = writeln!(
                out,
                "{:<17} {:>4} {:<5} {:>12.2} {:>7} {:>7} {:>12.4} {:>6.3} {:>6.3} {:>6.3} {:>8}",
                time_cell(t),
                p.display.display,
                p.display.eye.to_string(),
                w[1],
                opt(xy.map(|v| v[0]), 4),
                opt(xy.map(|v| v[1]), 4),
                p.black_xyz_cd_m2[1],
                u[0],
                u[1],
                u[2],
                p.measurement.readings
            );
            rows += 1;
        }
    }
    if rows == 0 {
        return Err(CliError::input(format!(
            "no stored profile of wall {wall:?}{} in {}; list the walls with `lumiwall profiles runs`",
            display.map_or(String::new(), |d| format!(" display {d}")),
            store.path().display()
        )));
    }
    Ok(out)
}

/// One row per display and eye.
fn drift_table(drifts: &[Drift]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:>4} {:<5} {:<17} {:<17} {:>4} {:>12} {:>8} {:>7} {:>12} {:>7} {:>7} {:>7}",
        "disp",
        "eye",
        "from (UTC)",
        "to (UTC)",
        "runs",
        "white cd/m²",
        "ΔY %",
        "Δxy",
        "Δblack cd/m²",
        "Δuse R",
        "Δuse G",
        "Δuse B"
    );
    for d in drifts {
        let du = d.channel_usage_change;
        let _ = writeln!(
            out,
            "{:>4} {:<5} {:<17} {:<17} {:>4} {:>12.2} {:>8} {:>7} {:>+12.4} {:>+7.3} {:>+7.3} {:>+7.3}",
            d.display.display,
            d.display.eye.to_string(),
            time_cell(d.baseline_utc),
            time_cell(d.current_utc),
            d.profiles,
            d.current_white_y_cd_m2,
            d.white_luminance_change_pct
                .map_or("-".into(), |v| format!("{v:+.2}")),
            opt(d.white_delta_xy, 4),
            d.black_change_cd_m2,
            du[0],
            du[1],
            du[2]
        );
    }
    let worst_y = drifts
        .iter()
        .filter_map(|d| d.white_luminance_change_pct.map(|v| (v, d)))
        .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()));
    let worst_xy = drifts
        .iter()
        .filter_map(|d| d.white_delta_xy.map(|v| (v, d)))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((v, d)) = worst_y {
        let _ = writeln!(
            out,
            "largest white luminance change: {v:+.2} % (display {} {})",
            d.display.display, d.display.eye
        );
    }
    if let Some((v, d)) = worst_xy {
        let _ = writeln!(
            out,
            "largest white shift: Δxy {v:.4} (display {} {})",
            d.display.display, d.display.eye
        );
    }
    out
}

/// Exit status 3 if a drift exceeds the user's limits.
fn check_limits(drifts: &[Drift], limits: DriftLimits) -> Result<(), CliError> {
    let over = limits.violations(drifts);
    if over.is_empty() {
        Ok(())
    } else {
        Err(CliError::tolerance(format!(
            "drift over the limits, re-commission these displays:\n  {}",
            over.join("\n  ")
        )))
    }
}

/// The run time of an import: `--time`, else the newest `created_utc` of the profiles.
fn import_time(time: Option<&str>, profiles: &[DisplayProfile]) -> Result<Timestamp, CliError> {
    if let Some(t) = time {
        return Ok(parse_time(t)?);
    }
    let mut newest: Option<Timestamp> = None;
    for p in profiles {
        let t = parse_time(&p.created_utc).map_err(|e| {
            CliError::input(format!(
                "profile of {} has created_utc {:?} that is not a time ({e}); give the run's time with --time",
                p.display, p.created_utc
            ))
        })?;
        newest = Some(newest.map_or(t, |n| n.max(t)));
    }
    newest.ok_or_else(|| CliError::input("the profile folder lists no profile"))
}

fn import(a: &ImportArgs) -> Result<String, CliError> {
    // The store (and SQLite's journal next to it) is written: check its folder first.
    values::check_output_files("--store", &[&a.store])?;
    let (wall, profiles) = ProfileSet::load_dir(&a.dir)?;
    let started_utc = import_time(a.time.as_deref(), &profiles)?;
    let run = CommissionRun {
        wall: wall.clone(),
        started_utc,
        source: a.source.clone(),
        note: a.note.clone(),
    };
    let mut store = ProfileStore::open(&a.store)?;
    let id = store.record(&run, &profiles)?;
    Ok(format!(
        "recorded run {id} of wall {wall}: {} profiles measured {} from {} into {}\n",
        profiles.len(),
        time_cell(started_utc),
        a.dir.display(),
        store.path().display()
    ))
}

/// Walls, or one wall's runs.
fn runs_table(store: &ProfileStore, wall: Option<&str>) -> Result<String, CliError> {
    let mut out = String::new();
    match wall {
        None => {
            let walls = store.walls()?;
            let _ = writeln!(
                out,
                "{:<20} {:>5} {:<17} {:<17}",
                "wall", "runs", "first (UTC)", "last (UTC)"
            );
            for w in walls {
                let _ = writeln!(
                    out,
                    "{:<20} {:>5} {:<17} {:<17}",
                    w.wall,
                    w.runs,
                    time_cell(w.first_utc),
                    time_cell(w.last_utc)
                );
            }
        }
        Some(wall) => {
            let runs = store.runs(wall)?;
            let _ = writeln!(
                out,
                "{:>5} {:<17} {:<10} {:>8} {:<8} note",
                "run", "time (UTC)", "source", "profiles", "lumiwall"
            );
            for r in runs {
                let _ = writeln!(
                    out,
                    "{:>5} {:<17} {:<10} {:>8} {:<8} {}",
                    r.id.0,
                    time_cell(r.run.started_utc),
                    r.run.source,
                    r.profiles,
                    r.lumiwall_version,
                    r.run.note
                );
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumiwall_profiles::{
        BlackMode, DisplayKey, Eye, FORMAT_VERSION, MeasurementInfo, OutOfGamut, ToneCurve,
    };

    fn curve() -> ToneCurve {
        ToneCurve {
            forward: vec![[0.0, 0.0], [1.0, 1.0]],
            inverse_lut: (0..1024).map(|i| i as f32 / 1023.0).collect(),
        }
    }

    /// A profile whose native white is `white_y` cd/m² at xy (1/3, 1/3).
    fn profile(display: u32, white_y: f64, created: &str) -> DisplayProfile {
        let k = white_y / 3.0;
        DisplayProfile {
            format_version: FORMAT_VERSION,
            display: DisplayKey {
                wall: "hall-a".into(),
                display,
                tile_col: display,
                tile_row: 0,
                eye: Eye::Mono,
            },
            created_utc: created.into(),
            // Each primary a third of the white, so the native white is (Y, Y, Y).
            primaries_xyz_cd_m2: [[k, k, k]; 3],
            black_xyz_cd_m2: [0.1, 0.1, 0.1],
            display_model: Default::default(),
            black_mode: BlackMode::Ignore,
            shown_black_xyz_cd_m2: [0.1, 0.1, 0.1],
            target_white_xyz_cd_m2: [90.0, 90.0, 90.0],
            common_primaries_xy: [[0.64, 0.33], [0.3, 0.6], [0.15, 0.06]],
            xyz_to_drive: [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]],
            drive_offset: [0.0; 3],
            channel_usage: [0.9, 0.9, 0.9],
            headroom: 1.0,
            curves: [curve(), curve(), curve()],
            flat_field: None,
            out_of_gamut: OutOfGamut::Clip,
            bit_depth: 8,
            measurement: MeasurementInfo::default(),
        }
    }

    fn import_night(store: &std::path::Path, root: &std::path::Path, n: u32, y: f64) {
        let dir = root.join(format!("night{n}"));
        let created = format!("2026-11-2{n}T02:00:00Z");
        let profiles = vec![profile(0, 100.0, &created), profile(1, y, &created)];
        ProfileSet::save_dir(&dir, "hall-a", &profiles).unwrap();
        let msg = import(&ImportArgs {
            store: store.to_path_buf(),
            dir,
            time: None,
            source: "nightly".into(),
            note: String::new(),
        })
        .unwrap();
        assert!(msg.contains(&format!("2026-11-2{n} 02:00Z")), "{msg}");
    }

    #[test]
    fn import_history_drift_and_limits() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("s.lumistore");
        import_night(&path, tmp.path(), 0, 100.0);
        import_night(&path, tmp.path(), 1, 96.0);
        let store = ProfileStore::open_existing(&path).unwrap();

        let h = history_table(&store, "hall-a", Some(1)).unwrap();
        let rows: Vec<&str> = h.lines().skip(1).collect();
        assert_eq!(rows.len(), 2, "{h}");
        assert!(rows[0].starts_with("2026-11-20 02:00Z") && rows[0].contains(" 100.00 "));
        assert!(
            rows[1].contains(" 96.00 ") && rows[1].contains("0.3333"),
            "{h}"
        );
        assert!(history_table(&store, "hall-a", Some(7)).is_err());
        assert_eq!(
            history_table(&store, "hall-a", None)
                .unwrap()
                .lines()
                .count(),
            5
        );

        let drifts = store.drift_wall("hall-a", None).unwrap();
        let t = drift_table(&drifts);
        assert!(t.contains("-4.00") && t.contains("display 1 mono"), "{t}");
        let limits = |pct, xy| DriftLimits {
            max_luminance_change_pct: pct,
            max_delta_xy: xy,
        };
        assert!(check_limits(&drifts, limits(Some(5.0), Some(0.001))).is_ok());
        let err = check_limits(&drifts, limits(Some(3.0), None)).unwrap_err();
        assert_eq!(err.exit_code(), 3);
        assert!(err.message.contains("display 1 mono"), "{}", err.message);

        let runs = runs_table(&store, Some("hall-a")).unwrap();
        assert_eq!(runs.lines().count(), 3, "{runs}");
        assert!(runs_table(&store, None).unwrap().contains("hall-a"));

        // Importing the same folder again is refused as the same run.
        let again = import(&ImportArgs {
            store: path.clone(),
            dir: tmp.path().join("night1"),
            time: None,
            source: "nightly".into(),
            note: String::new(),
        })
        .unwrap_err();
        assert_eq!(again.exit_code(), 2);
        assert!(
            again.message.contains("already has run 2"),
            "{}",
            again.message
        );
    }

    #[test]
    fn import_time_needs_readable_profile_times_or_an_explicit_time() {
        let p = [profile(0, 100.0, "last tuesday")];
        let err = import_time(None, &p).unwrap_err();
        assert!(err.message.contains("--time"), "{}", err.message);
        let t = import_time(Some("2026-11-20"), &p).unwrap();
        assert_eq!(t.to_string(), "2026-11-20T00:00:00Z");
        let q = [
            profile(0, 1.0, "2026-11-20T02:00:00Z"),
            profile(1, 1.0, "2026-11-20T02:07:00Z"),
        ];
        assert_eq!(
            import_time(None, &q).unwrap().to_string(),
            "2026-11-20T02:07:00Z"
        );
    }
}
