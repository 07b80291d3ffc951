//! A meter that stops answering mid-ramp (emulator fault plan, through the real pty
//! driver) stops the commissioning with a typed error that names the display and the
//! reading, leaves nothing half-written, and a resumed run completes from the saved
//! displays. Verification then runs through the pty as well.

use std::path::Path;
use std::time::Duration;

use lumiwall_calib::commission::{CommissionError, CommissionOptions};
use lumiwall_calib::measure::{MeasureError, MeasureOptions, Progress};
use lumiwall_calib::station::{MeterChoice, Noise, Station, StationOptions};
use lumiwall_calib::verify::default_targets;
use lumiwall_devices::DeviceError;
use lumiwall_devices::serial::{FaultPlan, K10aConfig};
use lumiwall_devices::sim::VirtualWall;
use lumiwall_profiles::{BlackMode, DisplayProfile, ProfileSet};

fn wall() -> VirtualWall {
    VirtualWall::from_toml_file(&crate::support::wall_path("infitec-pair.toml")).unwrap()
}

/// The noiseless simulated meter behind the emulator (fast), opened with the real
/// driver (short timeout, no retries of its own).
fn emulated_station(wall: &VirtualWall, faults: FaultPlan) -> Station {
    let opts = StationOptions {
        time_scale: 0.002,
        faults,
        driver: K10aConfig {
            read_timeout: Duration::from_millis(300),
            retries: 0,
            ..K10aConfig::default()
        },
        ..StationOptions::new(MeterChoice::Emulated, Noise::None)
    };
    Station::with_wall(wall.clone(), &opts).unwrap()
}

fn options(resume: bool) -> CommissionOptions {
    let measure = MeasureOptions {
        max_retries: 1,
        ..MeasureOptions::default()
    };
    // The reading counts below are the measuring pass's: no grey-drive pass.
    CommissionOptions {
        grey_levels: Vec::new(),
        ..crate::support::options_8500k(measure, BlackMode::Individual, resume)
    }
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Run 1: the meter answers 40 readings of display 0 and 20 of display 1, then never
/// again — 20 readings into display 1 it is measuring a ramp. Returns the readings of
/// each completed display and the error.
fn run_until_the_meter_stops(wall: &VirtualWall, out: &Path) -> (Vec<u32>, CommissionError) {
    let faults = FaultPlan {
        stop_after_readings: Some(60),
        ..FaultPlan::default()
    };
    let mut station = emulated_station(wall, faults);
    let mut per_display = Vec::new();
    let mut progress = |p: Progress| {
        if let Progress::DisplayDone { readings, .. } = p {
            per_display.push(readings);
        }
    };
    let err = station
        .commission(out, &options(false), &mut progress)
        .unwrap_err();
    (per_display, err)
}

/// The error names display 1, its 21st reading (a ramp), the timeout, and what to do.
fn assert_interrupted_at_display_1_reading_21(err: &CommissionError) {
    let msg = err.to_string();
    println!("{msg}");
    match err {
        CommissionError::Interrupted {
            source:
                MeasureError::Reading {
                    display,
                    reading,
                    patch,
                    source: DeviceError::Timeout { .. },
                    ..
                },
            saved: 1,
            total: 2,
            ..
        } => {
            assert!(display.contains("display 1"), "{display}");
            assert_eq!(*reading, 21);
            assert!(patch.to_string().contains("ramp"), "{patch}");
        }
        other => panic!("unexpected error {other:?}"),
    }
    assert!(msg.contains("--resume") && msg.contains("check"), "{msg}");
}

/// Nothing half-written: no profiles, no manifest, no temporary files (only the
/// folder's lock file); the run folder holds the manifest and display 0's measurement.
fn assert_only_display_0_saved(out: &Path) {
    assert_eq!(
        files(out),
        vec![".lumiwall.lock".to_string(), "run".to_string()]
    );
    let run = files(&out.join("run"));
    assert_eq!(run.len(), 2, "{run:?}");
    assert!(run.contains(&"run.json".to_string()));
    assert!(
        run.iter()
            .any(|f| f.starts_with("d000-") && f.ends_with(".measurement.json"))
    );
}

/// Verifies 20 colours on both eyes through the pty.
fn assert_verifies_through_the_pty(
    station: &mut Station,
    outcome: &lumiwall_calib::commission::CommissionOutcome,
    profiles: &[DisplayProfile],
) {
    let targets = default_targets(profiles, 20).unwrap();
    let report = station
        .verify_commissioned(outcome, profiles, &targets)
        .unwrap();
    println!("{}\n{}", report.patch_table(), report.summary_table());
    assert_eq!(report.patches.len(), 40);
    // Two displays only (the 48-display acceptance is in commission_heyewall.rs); the
    // right eye's green is used at ~15 %, its toe limits the darkest greys.
    assert!(
        report.overall.median_de < 1.0,
        "median {}",
        report.overall.median_de
    );
    assert!(report.overall.max_de < 2.5, "max {}", report.overall.max_de);
}

#[test]
fn meter_timeout_mid_ramp_stops_with_a_typed_error_and_resume_completes() {
    let out = tempfile::tempdir().unwrap();
    let wall = wall();
    assert_eq!(wall.displays().len(), 2);

    let (per_display, err) = run_until_the_meter_stops(&wall, out.path());
    assert_eq!(
        per_display,
        vec![40],
        "display 0 completes with 40 readings"
    );
    assert_interrupted_at_display_1_reading_21(&err);
    assert_only_display_0_saved(out.path());

    // Run 2: the meter is back; --resume measures display 1 only.
    let mut station = emulated_station(&wall, FaultPlan::default());
    let mut resumed = Vec::new();
    let mut measured = Vec::new();
    let outcome = station
        .commission(out.path(), &options(true), &mut |p| match p {
            Progress::Resumed { display, .. } => resumed.push(display.0),
            Progress::DisplayDone { display, .. } => measured.push(display.0),
            _ => {}
        })
        .unwrap();
    assert_eq!(resumed, vec![0]);
    assert_eq!(measured, vec![1]);
    // Display 1's 40, then its white once more: the drift re-read of the first
    // display measured in this run.
    assert_eq!(station.emulator().unwrap().readings_requested(), 41);
    let drift = outcome.drift.as_ref().expect("drift re-read");
    assert!(drift.display.contains("display 1"), "{}", drift.display);
    let (name, profiles) = ProfileSet::load_dir(out.path()).unwrap();
    assert_eq!(name, wall.name());
    assert_eq!(profiles.len(), 2);

    assert_verifies_through_the_pty(&mut station, &outcome, &profiles);
}

#[test]
fn resume_refuses_a_run_folder_of_another_wall() {
    let out = tempfile::tempdir().unwrap();
    let run = out.path().join("run");
    std::fs::create_dir_all(&run).unwrap();
    std::fs::write(
        run.join("run.json"),
        r#"{"format_version":1,"wall":"other","displays":[],"measure":{"budget":40,"spot_uv":[0.5,0.5],"low_light":{"average":{"repeats":4}},"low_light_limit_cd_m2":null,"max_retries":2,"measure_white":true,"primary_repeats":null,"focus":null}}"#,
    )
    .unwrap();
    let mut station = crate::support::direct_station("infitec-pair.toml", Noise::None);
    let err = station
        .commission(out.path(), &options(true), &mut |_| {})
        .unwrap_err();
    assert!(
        matches!(err, CommissionError::ResumeMismatch { .. }),
        "{err}"
    );
    assert!(err.to_string().contains("'other'"), "{err}");
}

/// The meter stops in the grey-drive pass (after both displays' measuring readings, the
/// budget less the pass's reserve, and one grey-drive reading): both measurements are
/// saved, and `--resume` measures nothing again but reads each display's grey drives,
/// then solves.
#[test]
fn a_meter_that_stops_in_the_grey_drive_pass_resumes_with_the_grey_drives_only() {
    let out = tempfile::tempdir().unwrap();
    let wall = wall();
    use lumiwall_calib::measure::grey_drives::{default_levels, readings_needed};
    let with_greys = |resume| CommissionOptions {
        grey_levels: default_levels(),
        ..options(resume)
    };
    // The pass's reserve depends on the noise the meter states (the emulated K-10-A's).
    let noise = emulated_station(&wall, FaultPlan::default())
        .meter
        .info()
        .noise;
    let measuring = 40 - readings_needed(&default_levels(), noise.as_ref(), 40);
    let faults = FaultPlan {
        stop_after_readings: Some(2 * measuring + 1),
        ..FaultPlan::default()
    };
    let err = emulated_station(&wall, faults)
        .commission(out.path(), &with_greys(false), &mut |_| {})
        .unwrap_err();
    assert!(matches!(err, CommissionError::Interrupted { .. }), "{err}");
    let says = err.to_string();
    assert!(
        says.contains("2 of 2 displays are measured and saved"),
        "{says}"
    );

    let mut station = emulated_station(&wall, FaultPlan::default());
    let (mut resumed, mut measured, mut greys) = (Vec::new(), Vec::new(), Vec::new());
    let outcome = station
        .commission(out.path(), &with_greys(true), &mut |p| match p {
            Progress::Resumed { display, .. } => resumed.push(display.0),
            Progress::DisplayDone { display, .. } => measured.push(display.0),
            Progress::GreyDrivesRead {
                display, readings, ..
            } => greys.push((display.0, readings)),
            _ => {}
        })
        .unwrap();
    assert_eq!(resumed, vec![0, 1]);
    assert!(measured.is_empty(), "{measured:?}");
    assert_eq!(greys.iter().map(|g| g.0).collect::<Vec<_>>(), vec![0, 1]);
    let requested: u32 = greys.iter().map(|g| g.1).sum();
    assert_eq!(station.emulator().unwrap().readings_requested(), requested);
    for m in &outcome.measured {
        assert_eq!(
            m.log.grey_drive_readings,
            Some(m.measurement.readings - measuring)
        );
        assert!(m.measurement.readings <= 40);
    }
}
