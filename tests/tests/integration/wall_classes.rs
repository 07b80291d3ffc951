//! The wall classes of issue 12 as fixture walls (non-additive Infitec DLPs, a cold
//! start, an off-axis meter on a gain screen, 8-bit inputs with a very weak channel):
//! each commissions with the noiseless meter, the solve flags what the matrix model
//! cannot represent on exactly the walls that have it, and the verification figures
//! are printed; the noiseless acceptance is asserted on every one. The DLP walls'
//! white segment is modelled (`DisplayModel::WhiteSegment`).

use lumiwall_calib::measure::MeasureOptions;
use lumiwall_calib::solve::SolveWarning;
use lumiwall_calib::station::Noise;
use lumiwall_calib::verify::{VerifyOptions, VerifyReport, chart_targets};
use lumiwall_profiles::BlackMode;

/// Commissions `file` noiseless and verifies it with the 51-patch chart: the solve's
/// warnings and the verification, whose OVERALL row is printed.
fn commission_and_verify(file: &str) -> (Vec<SolveWarning>, VerifyReport) {
    commission_and_verify_with(file, MeasureOptions::default())
}

/// [`commission_and_verify`] with these measuring options.
fn commission_and_verify_with(
    file: &str,
    measure: MeasureOptions,
) -> (Vec<SolveWarning>, VerifyReport) {
    let opts = crate::support::options_8500k(measure, BlackMode::Individual, false);
    commission_and_verify_opts(file, &opts)
}

/// [`commission_and_verify`] with these commissioning options.
fn commission_and_verify_opts(
    file: &str,
    opts: &lumiwall_calib::commission::CommissionOptions,
) -> (Vec<SolveWarning>, VerifyReport) {
    let (o, report) = commission_and_verify_outcome(file, opts);
    (o.solution.warnings, report)
}

/// [`commission_and_verify_opts`] with the whole commissioning outcome (measurements
/// included).
fn commission_and_verify_outcome(
    file: &str,
    opts: &lumiwall_calib::commission::CommissionOptions,
) -> (lumiwall_calib::commission::CommissionOutcome, VerifyReport) {
    let station = crate::support::direct_station(file, Noise::None);
    commission_and_verify_on(station, file, opts)
}

/// [`commission_and_verify_outcome`] with the station given (`file`: its wall, named
/// in the messages).
fn commission_and_verify_on(
    mut station: lumiwall_calib::station::Station,
    file: &str,
    opts: &lumiwall_calib::commission::CommissionOptions,
) -> (lumiwall_calib::commission::CommissionOutcome, VerifyReport) {
    let out = tempfile::tempdir().expect("tmp");
    let o = station
        .commission(out.path(), opts, &mut |_| {})
        .expect("commission");
    let budget = opts.measure.budget;
    for m in &o.measured {
        assert!(m.measurement.readings <= budget, "{file}: {m:?}");
    }
    let profiles = &o.solution.profiles;
    let targets = chart_targets(profiles).expect("chart");
    let report = station
        .verify(profiles, &targets, &VerifyOptions::default(), &mut |_| {})
        .expect("verify");
    let table = report.summary_table();
    let overall = table
        .lines()
        .find(|l| l.starts_with("OVERALL"))
        .unwrap_or("");
    eprintln!("{file}: {overall}");
    (o, report)
}

fn additivity_warnings(w: &[SolveWarning]) -> usize {
    w.iter()
        .filter(|w| matches!(w, SolveWarning::Additivity { .. }))
        .count()
}

/// On an Infitec wall verify pairs every left-eye patch with the right eye's on the
/// same tile (the stereo colour mismatch a viewer sees); a mono wall has no pairs.
#[test]
fn verify_compares_the_eyes_on_infitec_walls_only() {
    for (file, pairs) in [("dlp-infitec-2x1.toml", 2 * 51), ("cold-start-2x2.toml", 0)] {
        let (_, report) = commission_and_verify(file);
        assert_eq!(report.eyes_delta_e2000.len(), pairs, "{file}");
        assert!(
            report
                .eyes_delta_e2000
                .iter()
                .all(|d| d.is_finite() && *d >= 0.0)
        );
        assert_eq!(
            report.summary_table().contains("left/right eyes"),
            pairs > 0,
            "{file}"
        );
    }
}

fn white_segment_notes(w: &[SolveWarning]) -> usize {
    w.iter()
        .filter(|w| matches!(w, SolveWarning::WhiteSegment { .. }))
        .count()
}

/// Issue 12 item 1: the single-chip DLPs' white segment is recognised on every display
/// and inverted by the profile, so the wall verifies inside the noiseless
/// acceptance (median ΔE2000 ≤ 0.5, max ≤ 2.0; the matrix alone gave 4.09 / 11.2).
#[test]
fn the_white_segment_dlp_wall_is_modelled_on_every_display_and_verifies_within_the_noiseless_limits()
 {
    let (w, report) = commission_and_verify("dlp-infitec-2x1.toml");
    assert_eq!(white_segment_notes(&w), 4, "{w:?}");
    assert_eq!(additivity_warnings(&w), 0, "{w:?}");
    assert_within_noiseless_limits("dlp-infitec-2x1.toml", &report);
}

/// Issue 12's noiseless acceptance (median ΔE2000 ≤ 0.5, max ≤ 2.0; the dark patches of
/// 1–2 cd/m² within Δxy 0.005 and ΔL 3 %) and, stricter than it asks, DisplayCAL's
/// white ≤ 1 and grey balance ≤ 0.5 on the whole wall.
fn assert_within_noiseless_limits(file: &str, report: &VerifyReport) {
    for p in report
        .patches
        .iter()
        .filter(|p| p.target.starts_with("dark"))
    {
        assert!(
            p.delta_xy <= 0.005 && p.delta_l_percent.abs() <= 3.0,
            "{file}: {} {}: Δxy {:.4}, ΔL {:+.2} %",
            p.display,
            p.target,
            p.delta_xy,
            p.delta_l_percent
        );
    }
    let all = &report.overall;
    let white = all.white_de.unwrap_or(f64::INFINITY);
    let grey = all.grey_balance.unwrap_or(f64::INFINITY);
    assert!(
        all.median_de <= 0.5 && all.max_de <= 2.0 && white <= 1.0 && grey <= 0.5,
        "{file}: median {:.2} max {:.2} white {white:.2} grey balance {grey:.2}",
        all.median_de,
        all.max_de
    );
}

/// The additive classes, including 8-bit channels of which the white uses a sixth
/// (infitec-pair: before verification patches were dithered, 8-bit quantisation alone
/// put its grey balance at 0.88).
#[test]
fn the_additive_wall_classes_commission_without_an_additivity_warning_and_verify_within_the_noiseless_limits()
 {
    // The cold wall warms up first, as `commission --warm-up` does; without it the
    // wall verified later is brighter than the one measured (3 % here).
    let warm_up = MeasureOptions {
        warm_up: Some(lumiwall_calib::measure::warm_up::WarmUp::default()),
        ..MeasureOptions::default()
    };
    for (file, measure) in [
        ("cold-start-2x2.toml", warm_up),
        ("offaxis-gain-2x1.toml", MeasureOptions::default()),
        ("weak-channel-3x1.toml", MeasureOptions::default()),
        ("infitec-pair.toml", MeasureOptions::default()),
    ] {
        let (w, report) = commission_and_verify_with(file, measure);
        assert_eq!(additivity_warnings(&w), 0, "{file}: {w:?}");
        assert_eq!(white_segment_notes(&w), 0, "{file}: {w:?}");
        assert_within_noiseless_limits(file, &report);
    }
}

/// Largest white ΔE2000 over the displays.
fn worst_white(report: &VerifyReport) -> f64 {
    report
        .per_display
        .iter()
        .map(|(_, s)| s.white_de.unwrap_or(f64::INFINITY))
        .fold(0.0, f64::max)
}

/// The grey-drive pass (`commission --grey-levels`, default the white): with each
/// channel read at its own drive in the display's white, the noiseless meter sees every
/// display's white as targeted (ΔE2000 ≤ 0.02); without the pass the tone curve is
/// interpolated at the white's drives and some display's white is off by 0.08 or more.
/// Every display stays within its 40 readings either way.
#[test]
fn with_the_grey_drive_pass_every_display_shows_its_white_as_targeted_with_the_noiseless_meter() {
    let with =
        crate::support::options_8500k(MeasureOptions::default(), BlackMode::Individual, false);
    let without = lumiwall_calib::commission::CommissionOptions {
        grey_levels: Vec::new(),
        ..with.clone()
    };
    for file in [
        "mono-2x1.toml",
        "infitec-pair.toml",
        "weak-channel-3x1.toml",
    ] {
        let (_, passed) = commission_and_verify_opts(file, &with);
        let (_, interpolated) = commission_and_verify_opts(file, &without);
        let (a, b) = (worst_white(&passed), worst_white(&interpolated));
        eprintln!("{file}: worst white ΔE2000 {b:.3} without the pass, {a:.3} with it");
        assert!(a <= 0.05, "{file}: white ΔE2000 {a:.3} with the pass");
        assert!(
            b > 2.0 * a.max(0.005),
            "{file}: {b:.3} without, {a:.3} with"
        );
    }
}

#[test]
fn a_very_weak_blue_limits_the_white_and_says_which_channels_are_barely_used() {
    let (w, _) = commission_and_verify("weak-channel-3x1.toml");
    let low = w
        .iter()
        .filter(|w| w.to_string().contains("used for the white"))
        .count();
    assert!(low >= 3, "{w:?}");
}

/// Commissions the wall described by `file_text` (written to a temporary file) with the
/// simulated meter of `noise` and these measuring options, to the 8500 K white.
fn commission_text(
    file_text: &str,
    noise: Noise,
    measure: MeasureOptions,
) -> lumiwall_calib::commission::CommissionOutcome {
    let opts = crate::support::options_8500k(measure, BlackMode::Individual, false);
    commission_text_with(file_text, noise, &opts, &mut |_| {})
}

/// [`commission_text`] with the commissioning options `opts`, telling `progress`.
fn commission_text_with(
    file_text: &str,
    noise: Noise,
    opts: &lumiwall_calib::commission::CommissionOptions,
    progress: &mut dyn FnMut(lumiwall_calib::measure::Progress),
) -> lumiwall_calib::commission::CommissionOutcome {
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("wall.toml");
    std::fs::write(&path, file_text).expect("wall file");
    let mut station = lumiwall_calib::station::Station::open(
        &path,
        &lumiwall_calib::station::StationOptions::new(
            lumiwall_calib::station::MeterChoice::Direct,
            noise,
        ),
    )
    .expect("station");
    station
        .commission(&dir.path().join("out"), opts, progress)
        .expect("commission")
}

/// The common white and every display's channel luminances of a commissioning.
fn calibration(o: &lumiwall_calib::commission::CommissionOutcome) -> (f64, Vec<[f64; 3]>) {
    let channels = o
        .measured
        .iter()
        .map(|m| m.measurement.primaries.map(|p| p.y))
        .collect();
    (o.solution.white_xyz_cd_m2.y, channels)
}

/// The profiles' common white and every display's channel luminances.
fn calibration_of(file_text: &str, warm_up: bool) -> (f64, Vec<[f64; 3]>) {
    let measure = MeasureOptions {
        warm_up: warm_up.then(lumiwall_calib::measure::warm_up::WarmUp::default),
        ..MeasureOptions::default()
    };
    calibration(&commission_text(file_text, Noise::None, measure))
}

/// Largest relative difference between two calibrations (white and channels).
fn largest_difference(a: &(f64, Vec<[f64; 3]>), b: &(f64, Vec<[f64; 3]>)) -> f64 {
    let mut d = (a.0 / b.0 - 1.0).abs();
    for (p, q) in a.1.iter().zip(&b.1) {
        for c in 0..3 {
            d = d.max((p[c] / q[c] - 1.0).abs());
        }
    }
    d
}

/// Started two minutes after switch-on, `--warm-up` waits until the lamps have settled
/// and the wall gets the calibration it gets when warm (within 0.5 %, the meter's
/// repeatability); without the wait the first displays are measured several percent
/// dark.
#[test]
fn a_cold_start_with_the_warm_up_wait_gives_the_warm_walls_calibration() {
    let cold =
        std::fs::read_to_string(crate::support::wall_path("cold-start-2x2.toml")).expect("fixture");
    assert!(cold.contains("minutes_since_switch_on = 2.0"));
    let warm = cold.replace(
        "minutes_since_switch_on = 2.0",
        "minutes_since_switch_on = 180.0",
    );
    let reference = calibration_of(&warm, false);
    let waited = calibration_of(&cold, true);
    let rushed = calibration_of(&cold, false);
    let (dw, dr) = (
        largest_difference(&waited, &reference),
        largest_difference(&rushed, &reference),
    );
    eprintln!(
        "cold start against warm: with the wait {:.2} %, without {:.2} %",
        100.0 * dw,
        100.0 * dr
    );
    assert!(dw < 0.005 && dr > 0.02, "{dw} {dr}");
}

/// The commissioning's default warm check (`CommissionOptions::warm_check`; `commission`
/// without `--warm-up` or `--no-warm-check`), with `noise`: the calibration of the wall
/// in `file_text`, what the check saw, and whether the wait followed.
fn calibration_with_the_warm_check(
    file_text: &str,
    noise: Noise,
) -> (
    (f64, Vec<[f64; 3]>),
    lumiwall_calib::measure::warm_up::WarmCheckReport,
    bool,
) {
    let opts = lumiwall_calib::commission::CommissionOptions {
        warm_check: Some(lumiwall_calib::measure::warm_up::WarmCheck::default()),
        ..crate::support::options_8500k(MeasureOptions::default(), BlackMode::Individual, false)
    };
    let (mut check, mut waited) = (None, false);
    let o = commission_text_with(file_text, noise, &opts, &mut |p| match p {
        lumiwall_calib::measure::Progress::WarmCheck(r) => check = Some(r),
        lumiwall_calib::measure::Progress::WarmedUp(_) => waited = true,
        _ => {}
    });
    let check = check.expect("the warm check ran");
    (calibration(&o), check, waited)
}

/// Without `--warm-up`, the commissioning checks first whether the wall is warming: the
/// fixture started two minutes after switch-on is found warming, with the exact and
/// with the realistic meter, is waited for and gets the warm wall's calibration (within
/// 0.5 %, as with `--warm-up`); a warm wall is found warm and measured at once.
#[test]
fn the_default_warm_check_waits_for_a_cold_wall_and_measures_a_warm_one_at_once() {
    let cold =
        std::fs::read_to_string(crate::support::wall_path("cold-start-2x2.toml")).expect("fixture");
    let warm = cold.replace(
        "minutes_since_switch_on = 2.0",
        "minutes_since_switch_on = 180.0",
    );
    assert_ne!(cold, warm, "the fixture starts cold");
    for noise in [Noise::None, Noise::Realistic] {
        let (reference, warm_check, warm_waited) = calibration_with_the_warm_check(&warm, noise);
        let (checked, cold_check, cold_waited) = calibration_with_the_warm_check(&cold, noise);
        let d = largest_difference(&checked, &reference);
        eprintln!(
            "{noise:?}: cold {cold_check:?}, warm {warm_check:?}; cold against warm {:.2} %",
            100.0 * d
        );
        assert!(
            cold_check.warming && cold_waited,
            "{noise:?}: {cold_check:?}"
        );
        assert!(
            !warm_check.warming && !warm_waited,
            "{noise:?}: {warm_check:?}"
        );
        assert!(d < 0.005, "{noise:?}: cold against warm {d}");
    }
}

/// A one-display wall five minutes after switch-on (the cold-start fixture cut to one
/// tile): its short run would drift 0.7 % within itself, inside the drift check's 1 %,
/// but its lamp is still warming by 2.2 % per 120 readings, and the wall would be used
/// in a state it was not calibrated in. The default warm check finds it warming, with
/// the exact and the realistic meter, waits, and the wall gets the warm wall's
/// calibration (within 0.5 %, each meter against its own on the warm wall); measured at
/// once (exact meter) it is more than 1 % off.
#[test]
fn a_short_run_on_a_lamp_still_warming_is_waited_for_and_gets_the_warm_calibration() {
    let fixture =
        std::fs::read_to_string(crate::support::wall_path("cold-start-2x2.toml")).expect("fixture");
    let one = fixture
        .replace("cols = 2\nrows = 2", "cols = 1\nrows = 1")
        .replace(
            "minutes_since_switch_on = 2.0",
            "minutes_since_switch_on = 5.0",
        );
    assert!(one.contains("cols = 1\nrows = 1") && one.contains("switch_on = 5.0"));
    let warm = one.replace(
        "minutes_since_switch_on = 5.0",
        "minutes_since_switch_on = 180.0",
    );
    for noise in [Noise::None, Noise::Realistic] {
        let (reference, warm_check, warm_waited) = calibration_with_the_warm_check(&warm, noise);
        assert!(
            !warm_check.warming && !warm_waited,
            "{noise:?}: the warm wall {warm_check:?}"
        );
        let (checked, check, waited) = calibration_with_the_warm_check(&one, noise);
        let d = largest_difference(&checked, &reference);
        eprintln!(
            "{noise:?}: {check:?}; against the warm wall {:.2} %",
            100.0 * d
        );
        assert!(check.warming && waited, "{noise:?}: {check:?}");
        assert!(
            check.run_drift_percent.abs()
                < lumiwall_calib::measure::warm_up::WarmCheck::default().max_run_drift_percent,
            "{noise:?}: {check:?}"
        );
        assert!(d < 0.005, "{noise:?}: against the warm wall {d}");
    }
    let d = largest_difference(&calibration_of(&one, false), &calibration_of(&warm, false));
    eprintln!("measured at once: against the warm wall {:.2} %", 100.0 * d);
    assert!(d > 0.01, "measured at once {d}");
}

/// A commissioning stopped in the grey-drive pass and resumed the next morning on lamps
/// switched on a minute before: every display's measurement is saved, but the pass still
/// reads each display's channels, so the resumed run checks first whether the wall is
/// warming (on the first display whose pass is left), finds it warming, waits, and ends
/// with the drives of the run that was not stopped for its white and a 20 % grey
/// (within 0.5 %; exact meter; without the check 4.4 % apart).
#[test]
fn a_run_resumed_for_its_grey_drive_pass_on_a_cold_wall_waits_for_it_first() {
    use lumiwall_calib::measure::Progress;
    let warm = std::fs::read_to_string(crate::support::wall_path("cold-start-2x2.toml"))
        .expect("fixture")
        .replace(
            "minutes_since_switch_on = 2.0",
            "minutes_since_switch_on = 180.0",
        );
    let reference = commission_text_with(&warm, Noise::None, &warm_checked(false), &mut |_| {});
    let (mut station, out) = stopped_before_the_grey_drive_pass(&warm);

    station.wall.advance_hours(12.0);
    station.wall.switch_on_again();
    station.wall.advance_seconds(60.0);
    let (mut check, mut waited, mut measured) = (None, false, 0);
    let resumed = station
        .commission(out.path(), &warm_checked(true), &mut |p| match p {
            Progress::WarmCheck(r) => check = Some(r),
            Progress::WarmedUp(_) => waited = true,
            Progress::DisplayDone { .. } => measured += 1,
            _ => {}
        })
        .expect("resumed commissioning");
    let mut d: f64 = 0.0;
    for (a, b) in white_and_grey_drives(&resumed)
        .iter()
        .zip(white_and_grey_drives(&reference).iter())
    {
        for c in 0..3 {
            d = d.max((a[c] / b[c] - 1.0).abs());
        }
    }
    eprintln!(
        "resumed against not stopped: drives within {:.3} %",
        100.0 * d
    );
    let check = check.expect("the resumed run checks the wall's warmth");
    assert!(check.warming && waited, "{check:?}");
    assert_eq!(measured, 0, "every measurement was saved");
    assert!(d < 0.005, "{d}");
}

/// Options with the default warm check (and the support's other defaults).
fn warm_checked(resume: bool) -> lumiwall_calib::commission::CommissionOptions {
    lumiwall_calib::commission::CommissionOptions {
        warm_check: Some(lumiwall_calib::measure::warm_up::WarmCheck::default()),
        ..crate::support::options_8500k(MeasureOptions::default(), BlackMode::Individual, resume)
    }
}

/// The drives of every display's white and 20 % grey (where the grey-drive pass's
/// samples lie).
fn white_and_grey_drives(o: &lumiwall_calib::commission::CommissionOutcome) -> Vec<[f64; 3]> {
    let white = o.solution.white_xyz_cd_m2;
    o.solution
        .profiles
        .iter()
        .flat_map(|p| {
            let prepared = lumiwall_profiles::apply::PreparedProfile::new(
                p,
                &lumiwall_profiles::apply::ApplyOptions::default(),
            )
            .expect("profile");
            [1.0, 0.2].map(|s| lumiwall_calib::verify::drive_for(&prepared, white * s, [0.5, 0.5]))
        })
        .collect()
}

/// A noiseless station on the wall in `file_text` whose commissioning (default warm
/// check) was stopped right after the last display's measurement was saved, and its
/// output folder; the stop is lifted again.
fn stopped_before_the_grey_drive_pass(
    file_text: &str,
) -> (lumiwall_calib::station::Station, tempfile::TempDir) {
    stopped_before_the_grey_drive_pass_with(file_text, Noise::None, &warm_checked(false))
}

/// [`stopped_before_the_grey_drive_pass`] with this meter error model and these
/// commissioning options.
fn stopped_before_the_grey_drive_pass_with(
    file_text: &str,
    noise: Noise,
    opts: &lumiwall_calib::commission::CommissionOptions,
) -> (lumiwall_calib::station::Station, tempfile::TempDir) {
    use std::sync::atomic::Ordering;
    let stop = lumiwall_calib::station::StopFlag::default();
    let mut station = lumiwall_calib::station::Station::with_wall(
        lumiwall_devices::sim::VirtualWall::from_toml_str(file_text).expect("wall"),
        &lumiwall_calib::station::StationOptions {
            stop: Some(stop.clone()),
            ..lumiwall_calib::station::StationOptions::new(
                lumiwall_calib::station::MeterChoice::Direct,
                noise,
            )
        },
    )
    .expect("station");
    let out = tempfile::tempdir().expect("tmp");
    let displays = station.displays().len();
    let mut done = 0;
    let stopped = station.commission(out.path(), opts, &mut |p| {
        if matches!(p, lumiwall_calib::measure::Progress::DisplayDone { .. }) {
            done += 1;
            // the last display measured: the next pattern is the grey-drive pass's
            stop.store(done == displays, Ordering::SeqCst);
        }
    });
    assert!(
        matches!(
            stopped,
            Err(lumiwall_calib::commission::CommissionError::Interrupted { saved, .. })
                if saved == displays
        ),
        "{stopped:?}"
    );
    stop.store(false, Ordering::SeqCst);
    (station, out)
}

/// Issue 12 item 3: after the last display the first one's white is read again, and a
/// cold wall measured without the warm-up wait shows its drift there (while a warm one
/// does not), so the report says how far apart the first and last displays' lamp
/// states were.
#[test]
fn the_drift_over_a_cold_run_is_reported_and_a_warm_run_shows_none() {
    let cold =
        std::fs::read_to_string(crate::support::wall_path("cold-start-2x2.toml")).expect("wall");
    let warm = cold.replace(
        "minutes_since_switch_on = 2.0",
        "minutes_since_switch_on = 600.0",
    );
    assert_ne!(cold, warm, "the fixture starts cold");
    let mut drift = Vec::new();
    for text in [&cold, &warm] {
        let wall = lumiwall_devices::sim::VirtualWall::from_toml_str(text).expect("wall");
        let mut station = lumiwall_calib::station::Station::with_wall(
            wall,
            &lumiwall_calib::station::StationOptions::new(
                lumiwall_calib::station::MeterChoice::Direct,
                Noise::None,
            ),
        )
        .expect("station");
        let out = tempfile::tempdir().expect("tmp");
        let opts =
            crate::support::options_8500k(MeasureOptions::default(), BlackMode::Individual, false);
        let o = station
            .commission(out.path(), &opts, &mut |_| {})
            .expect("commission");
        let d = o.drift.expect("a drift re-read");
        eprintln!("{}", d.summary());
        let report = std::fs::read_to_string(out.path().join("report.md")).expect("report");
        assert!(report.contains("drift over the run"), "{report}");
        drift.push(d);
    }
    assert!(drift[0].is_significant() && drift[0].luminance_change_percent() > 1.0);
    assert!(!drift[1].is_significant(), "{}", drift[1].summary());
}

/// On `weak-channel-3x1` the weak blue of display 1 sets a wall white that display 0,
/// measured first, reaches with about a tenth of its red and green. Every display is
/// surveyed (black, primaries, white) before any ramp is read, so display 0's ramps
/// already know it: most of its red and green samples lie where the wall uses those
/// channels, and its greys come out balanced.
#[test]
fn the_first_displays_ramps_are_focused_on_the_white_that_a_later_dimmer_display_sets() {
    let opts =
        crate::support::options_8500k(MeasureOptions::default(), BlackMode::Individual, false);
    let (o, report) = commission_and_verify_outcome("weak-channel-3x1.toml", &opts);
    let first = &o.measured[0].measurement;
    let usage = o.solution.profiles[0].channel_usage;
    for c in 0..2 {
        let full = first.primaries[c].y - first.black.y;
        let rel: Vec<f64> = first.ramps[c]
            .iter()
            .map(|(_, xyz)| (xyz.y - first.black.y) / full)
            .collect();
        let used = rel.iter().filter(|r| **r <= 1.5 * usage[c]).count();
        eprintln!(
            "channel {c}: usage {:.3}, {used} of {} samples within 1.5 × usage",
            usage[c],
            rel.len()
        );
        assert!(
            usage[c] < 0.2,
            "the weak display no longer limits: {usage:?}"
        );
        assert!(3 * used >= 2 * rel.len(), "channel {c}: {rel:?}");
    }
    let grey = report.per_display[0].1.grey_balance.expect("greys");
    eprintln!("display 0 grey balance {grey:.3}");
    assert!(grey < 0.15, "display 0 grey balance {grey}");
}

/// A channel at full drive in the white (weak-channel-3x1's failing blue, which sets
/// the common white) needs no sample at the white's drive; the grey-drive pass reads it
/// at the drive of a grey of 90 % of the white instead, in the ramp's last gap, and
/// spends what it leaves of the budget on the black. Commissioned with the realistic
/// meter at 40 readings and verified against the truth (the noiseless meter), the 90 %
/// and 95 % greys of that display keep their balance against its white: without the
/// stand-in (its ramp ended at 0.75) the curve came out about 1 % high there and the
/// 90 % grey was 0.72 ΔC' off against the white; with it 0.08 (the 95 %: 0.11).
#[test]
fn a_channel_at_full_drive_in_the_white_is_read_in_its_last_gap_and_the_greys_below_the_white_keep_their_balance()
 {
    let file = "weak-channel-3x1.toml";
    let opts =
        crate::support::options_8500k(MeasureOptions::default(), BlackMode::Individual, false);
    let mut station = crate::support::direct_station(file, Noise::Realistic);
    let out = tempfile::tempdir().expect("tmp");
    let o = station
        .commission(out.path(), &opts, &mut |_| {})
        .expect("commission");
    let weak = &o.measured[1];
    let budget = opts.measure.budget;
    assert!(
        weak.measurement.readings <= budget,
        "{}",
        weak.measurement.readings
    );
    let gap = lumiwall_calib::measure::grey_drives::MIN_DRIVE_GAP;
    let top_blue: Vec<f64> = weak
        .log
        .samples
        .iter()
        .filter_map(|r| match r.patch {
            lumiwall_calib::measure::Patch::Ramp(lumiwall_core::Channel::Blue, d)
                if d > 0.8 && d < 1.0 - gap =>
            {
                Some(d)
            }
            _ => None,
        })
        .collect();
    assert!(
        !top_blue.is_empty(),
        "no blue sample in (0.8, 1): {:?}",
        weak.log.samples
    );
    let black_reads = weak.log.readings_of(lumiwall_calib::measure::Patch::Black);
    assert!(black_reads > 4, "black read {black_reads} times");

    let profiles = &o.solution.profiles;
    let targets = chart_targets(profiles).expect("chart");
    let mut truth = crate::support::direct_station(file, Noise::None);
    let report = truth
        .verify(profiles, &targets, &VerifyOptions::default(), &mut |_| {})
        .expect("verify");
    let weak_key = &profiles[1].display;
    for grey in ["grey 90 %", "grey 95 %"] {
        let p = report
            .patches
            .iter()
            .find(|p| &p.display == weak_key && p.target == grey)
            .expect("grey patch");
        let c = p.grey_delta_c2000.expect("a grey has a balance");
        eprintln!("{grey}: |ΔC'| {c:.3} against the display's white");
        assert!(c.abs() <= 0.25, "{grey}: |ΔC'| {c:.3}");
    }
}

/// On a dim wall every dark sample of the grey-drive pass is averaged, and one of an
/// early grey must not take the readings a later one needs. `infitec-pair` with lamps
/// of 170 cd/m² (a 12 cd/m² wall white), the realistic meter and 40 readings per
/// display, wall seeds 101–116: every display reads the chart's darkest grey whole
/// (`GreyLevel::Split`, read where a channel's toe is unsampled, which at this white it
/// always is). Before the pass left a reading for each sample still to come, the red
/// of the 1 cd/m² grey took three or four of the last readings on four of these 32
/// displays and the darkest grey went unread (`grey_drives::readings_after`).
#[test]
fn a_dim_walls_grey_drive_pass_leaves_its_darkest_grey_a_reading() {
    use lumiwall_calib::measure::Patch;
    let text =
        std::fs::read_to_string(crate::support::wall_path("infitec-pair.toml")).expect("wall file");
    assert!(
        text.contains("white_cd_m2 = 1000.0") && text.contains("\nseed = 5\n"),
        "the fixture's lamp or seed changed"
    );
    let mut unread = Vec::new();
    for seed in 101..=116 {
        let dim = text
            .replace("white_cd_m2 = 1000.0", "white_cd_m2 = 170.0")
            .replace("seed = 5", &format!("seed = {seed}"));
        let o = commission_text(&dim, Noise::Realistic, MeasureOptions::default());
        for m in &o.measured {
            assert!(m.measurement.readings <= 40, "seed {seed}: {m:?}");
            if !m
                .log
                .samples
                .iter()
                .any(|r| matches!(r.patch, Patch::Grey(_)))
            {
                unread.push(format!("seed {seed}: {}", m.measurement.key));
            }
        }
    }
    assert!(unread.is_empty(), "darkest grey unread on {unread:?}");
}

/// A dim wall (mono-2x1 with lamps of 15 cd/m² instead of 250: a wall white near 7.6
/// cd/m², the chart's 2 % grey near 0.15 cd/m²) at 64 readings per display with the
/// realistic meter: the grey-drive pass reads the chart's darkest grey whole where a
/// channel of it sits below that channel's ramp samples, and the split samples of the
/// grey read last join that display's ramps at the grey's drives (`grey_drives::default_levels`: at every
/// budget, where it once stopped at 64), within each display's budget.
#[test]
fn at_64_readings_a_dim_wall_splits_its_darkest_grey_into_toe_samples() {
    use lumiwall_calib::measure::Patch;
    let dim = crate::support::dim_mono_2x1(15.0);
    let measure = MeasureOptions {
        budget: 64,
        ..MeasureOptions::default()
    };
    let o = commission_text(&dim, Noise::Realistic, measure);
    let mut split = 0;
    for m in &o.measured {
        assert!(m.log.readings <= 64, "{}", m.log.readings);
        let mut greys = m.log.samples.iter().filter_map(|r| match (r.patch, r.xyz) {
            (Patch::Grey(d), Some(_)) => Some(d),
            _ => None,
        });
        // The grey read last: one aimed again, if its first reading was off, whose
        // samples come first (the reading that aimed it joins only where not beside).
        if let Some(d) = greys.next_back() {
            let joined = (0..3).any(|c| {
                m.measurement.ramps[c]
                    .iter()
                    .any(|(drive, _)| (drive - d[c]).abs() < 1e-12)
            });
            assert!(joined, "the grey at {d:?} left no toe sample");
            split += 1;
        }
    }
    assert!(split > 0, "no darkest grey read whole on the dim wall");
}

/// A dim wall (mono-2x1 with 15 cd/m² lamps) at 40 readings per display, realistic
/// meter: the provisional profile's toe, extrapolated from ramp samples above the
/// chart's darkest grey, shows that grey too bright; its first reading says so, the rest
/// of its readings go to drives aimed again (`grey_drives::reaimed`), and those land
/// nearer the grey's luminance. Each display reads it twice at most, within its budget.
#[test]
fn a_dim_walls_darkest_grey_read_off_its_luminance_is_read_again_nearer_it() {
    use lumiwall_calib::measure::Patch;
    use lumiwall_calib::measure::black_readings::DARKEST_GREY_SHARE;
    use lumiwall_calib::measure::grey_drives::SPLIT_REAIM_REL;
    let dim = crate::support::dim_mono_2x1(15.0);
    let measure = MeasureOptions {
        budget: 40,
        ..MeasureOptions::default()
    };
    let o = commission_text(&dim, Noise::Realistic, measure);
    let wanted = DARKEST_GREY_SHARE * o.solution.white_xyz_cd_m2.y;
    let mut aimed_again = 0;
    for m in &o.measured {
        assert!(m.log.readings <= 40, "{}", m.log.readings);
        let black = m.measurement.black.y;
        let off = |y: f64| ((y - black) / (wanted - black) - 1.0).abs();
        let greys: Vec<f64> = m
            .log
            .samples
            .iter()
            .filter_map(|r| match (r.patch, r.xyz) {
                (Patch::Grey(_), Some(x)) => Some(x.y),
                _ => None,
            })
            .collect();
        assert!(greys.len() <= 2, "{greys:?}");
        if let [first, again] = greys[..] {
            assert!(
                off(first) > SPLIT_REAIM_REL,
                "aimed again at {first} for {wanted}"
            );
            assert!(
                off(again) < 0.5 * off(first),
                "aimed again at {again} cd/m², first {first}, wanted {wanted}"
            );
            aimed_again += 1;
        }
    }
    assert!(aimed_again > 0, "no display aimed its darkest grey again");
}

/// The emulated K-10-A reading exactly (`commission --noise none`, the default meter
/// path) states the noise a K-10-A has; its repeated readings show none, so the solve
/// does not smooth the samples within it (`measure::noise_seen`) and the wall
/// verifies nearly as the exact direct meter's does. Smoothing the exact samples
/// within the stated noise put this wall at max ΔE2000 0.84 and grey balance 0.15
/// (0.30 and 0.04 without); on seeds 101–104 (`lumiwall bench readings --meter
/// emulated --noise none`) at a largest max of 1.06 and a mean grey balance of 0.21
/// (0.31 and 0.05 without).
#[test]
fn an_exact_meter_that_states_its_noise_is_not_smoothed_within_it_and_verifies_exactly() {
    use lumiwall_calib::station::{MeterChoice, Station, StationOptions};
    let file = "weak-channel-3x1.toml";
    let options = StationOptions::new(MeterChoice::Emulated, Noise::None);
    let station = Station::open(&crate::support::wall_path(file), &options).expect("station");
    let opts =
        crate::support::options_8500k(MeasureOptions::default(), BlackMode::Individual, false);
    let (o, report) = commission_and_verify_on(station, file, &opts);
    for m in &o.measured {
        let seen = m.log.noise_seen;
        assert!(
            seen.dof >= lumiwall_calib::measure::noise_seen::MIN_DOF && seen.scale() == 0.0,
            "{}: the repeated readings of an exact meter showed noise: {seen:?}",
            m.measurement.key
        );
    }
    let all = &report.overall;
    let grey = all.grey_balance.unwrap_or(f64::INFINITY);
    eprintln!(
        "{file}, emulated K-10-A reading exactly: median {:.3} max {:.3} grey balance {grey:.3}",
        all.median_de, all.max_de
    );
    assert!(
        all.max_de <= 0.5 && grey <= 0.1,
        "{file}: max ΔE2000 {:.2}, grey balance {grey:.2}",
        all.max_de
    );
}

/// The worst display's grey balance (mean |ΔC'|) of `o`'s profiles on the chart, read
/// by the exact meter on the wall `station` commissioned: the truth.
fn truth_grey_balance(
    station: &lumiwall_calib::station::Station,
    o: &lumiwall_calib::commission::CommissionOutcome,
) -> f64 {
    let mut truth = lumiwall_calib::station::Station::with_wall(
        station.wall.clone(),
        &lumiwall_calib::station::StationOptions::new(
            lumiwall_calib::station::MeterChoice::Direct,
            Noise::None,
        ),
    )
    .expect("truth");
    let profiles = &o.solution.profiles;
    let targets = chart_targets(profiles).expect("chart");
    let report = truth
        .verify(profiles, &targets, &VerifyOptions::default(), &mut |_| {})
        .expect("verify");
    report
        .per_display
        .iter()
        .map(|(_, s)| s.grey_balance.expect("greys"))
        .fold(0.0, f64::max)
}

/// A wall of about 12.7 cd/m² (mono-2x1 with lamps of 25 cd/m² instead of 250) with
/// the realistic meter and 40 readings per display, wall seeds 101–104: with
/// `--averaging auto` the wall white of the survey (every display's black, primaries
/// and white) has the displays surveyed again and every reading of the run average two
/// to four meter readings (the chart's 2 % grey reads ±0.007 in x per reading), and the
/// darkest greys come out within the grey-balance limit against the truth, where
/// reading once leaves them near or past it. The budget counts the averaged readings.
#[test]
fn a_dim_wall_averages_each_reading_as_its_white_needs_and_its_greys_keep_their_balance() {
    use lumiwall_calib::measure::averaging::Averaging;
    let dim = crate::support::dim_mono_2x1(25.0);
    assert!(dim.contains("\nseed = "), "the fixture's seed changed");
    let seed_line = dim
        .lines()
        .find(|l| l.starts_with("seed = "))
        .expect("seed")
        .to_string();
    let (mut once, mut auto) = (Vec::new(), Vec::new());
    for seed in 101..=104 {
        let dim = dim.replace(&seed_line, &format!("seed = {seed}"));
        for (averaging, grey) in [
            (Averaging::Fixed(1), &mut once),
            (Averaging::Auto, &mut auto),
        ] {
            let dir = tempfile::tempdir().expect("tmp");
            let path = dir.path().join("wall.toml");
            std::fs::write(&path, &dim).expect("wall file");
            let mut station = lumiwall_calib::station::Station::open(
                &path,
                &lumiwall_calib::station::StationOptions::new(
                    lumiwall_calib::station::MeterChoice::Direct,
                    Noise::Realistic,
                ),
            )
            .expect("station");
            let measure = MeasureOptions {
                averaging,
                ..MeasureOptions::default()
            };
            let opts = crate::support::options_8500k(measure, BlackMode::Individual, false);
            let o = station
                .commission(&dir.path().join("out"), &opts, &mut |_| {})
                .expect("commission");
            for m in &o.measured {
                assert!(
                    m.measurement.readings <= 40,
                    "seed {seed}: {}",
                    m.measurement.readings
                );
            }
            if averaging == Averaging::Auto {
                let c = o.averaging.expect("auto estimates the wall white");
                let solved = o.solution.white_xyz_cd_m2.y;
                assert!(
                    (c.wall_white_cd_m2 / solved - 1.0).abs() < 0.1,
                    "seed {seed}: estimated {} cd/m², solved {solved}",
                    c.wall_white_cd_m2
                );
                assert!(c.estimate_readings > 0, "{c:?}");
                assert_eq!(o.readings_per_reading, c.readings_per_reading);
                assert!((2..=4).contains(&c.readings_per_reading), "{c:?}");
            } else {
                assert_eq!((o.readings_per_reading, o.averaging), (1, None));
            }
            grey.push(truth_grey_balance(&station, &o));
        }
    }
    eprintln!("worst grey balance, once: {once:.3?}; auto: {auto:.3?}");
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(auto.iter().all(|g| *g <= 0.5), "auto: {auto:?}");
    assert!(
        mean(&auto) < 0.8 * mean(&once),
        "once {once:?}, auto {auto:?}"
    );
}

/// A dim wall's commissioning with `--averaging auto`, stopped after the last display
/// was measured and resumed for its grey-drive pass: the resumed run surveys nothing,
/// so it chooses nothing, and reads the pass with as many meter readings each as the
/// saved displays did (three on mono-2x1 with lamps of 25 cd/m²), not once.
#[test]
fn a_dim_wall_resumed_for_its_grey_drive_pass_averages_as_its_saved_displays_did() {
    use lumiwall_calib::measure::averaging::Averaging;
    let dim = crate::support::dim_mono_2x1(25.0);
    let auto = |resume| {
        let measure = MeasureOptions {
            averaging: Averaging::Auto,
            ..MeasureOptions::default()
        };
        crate::support::options_8500k(measure, BlackMode::Individual, resume)
    };
    let (mut station, out) =
        stopped_before_the_grey_drive_pass_with(&dim, Noise::Realistic, &auto(false));
    let resumed = station
        .commission(out.path(), &auto(true), &mut |_| {})
        .expect("resumed commissioning");
    let saved: Vec<u32> = resumed
        .measured
        .iter()
        .map(|m| m.log.meter_readings_each())
        .collect();
    assert_eq!(resumed.averaging, None, "nothing surveyed, nothing chosen");
    assert!(saved.iter().all(|n| *n == 3), "{saved:?}");
    assert_eq!(resumed.readings_per_reading, 3);
    for m in &resumed.measured {
        assert!(
            m.log.grey_drive_readings.is_some_and(|r| r > 0),
            "{}",
            m.measurement.key
        );
        assert!(m.measurement.readings <= 40, "{}", m.measurement.readings);
        assert!(
            m.log.first_survey_readings > 0,
            "the first survey is counted"
        );
    }
}
