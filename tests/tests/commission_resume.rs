//! A meter that stops answering mid-ramp (emulator fault plan, through the real pty
//! driver) stops the commissioning with a typed error that names the display and the
//! reading, leaves nothing half-written, and a resumed run completes from the saved
//! displays. Verification then runs through the pty as well.

use std::path::{Path, PathBuf};
use std::time::Duration;

use lumiwall_calib::commission::{CommissionError, CommissionOptions, commission};
use lumiwall_calib::measure::{MeasureError, MeasureOptions, Progress, Rig};
use lumiwall_calib::solve::{SolveOptions, WhiteTarget};
use lumiwall_calib::verify::{VerifyOptions, default_targets, verify_wall};
use lumiwall_devices::DeviceError;
use lumiwall_devices::serial::{Emulator, EmulatorOptions, FaultPlan, K10aConfig, KleinK10a};
use lumiwall_devices::sim::{MeterModel, VirtualWall};
use lumiwall_profiles::ProfileSet;

fn wall() -> VirtualWall {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/walls/infitec-pair.toml");
    VirtualWall::from_toml_file(&p).unwrap()
}

/// The simulated meter behind the emulator, opened with the real driver.
fn emulated_meter(wall: &VirtualWall, faults: FaultPlan) -> (Emulator, KleinK10a) {
    let (emu, port) = Emulator::spawn_with(
        Box::new(wall.meter(MeterModel::noiseless())),
        faults,
        EmulatorOptions::with_time_scale(0.002),
    )
    .unwrap();
    let driver = port
        .open(K10aConfig {
            read_timeout: Duration::from_millis(300),
            retries: 0,
            ..K10aConfig::default()
        })
        .unwrap();
    (emu, driver)
}

fn options(resume: bool) -> CommissionOptions {
    CommissionOptions {
        measure: MeasureOptions {
            max_retries: 1,
            ..MeasureOptions::default()
        },
        solve: SolveOptions {
            white: WhiteTarget::Cct(8500.0),
            ..SolveOptions::default()
        },
        resume,
        meter_correction: true,
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

#[test]
fn meter_timeout_mid_ramp_then_resume_completes() {
    let out = tempfile::tempdir().unwrap();
    let wall = wall();
    let displays = wall.displays();
    assert_eq!(displays.len(), 2);
    let mut pattern = wall.pattern_output();
    let mut positioner = wall.positioner();

    // Run 1: the meter answers 40 readings of display 0 and 20 of display 1, then
    // never again — 20 readings into display 1 it is measuring a ramp.
    let (emu, mut meter) = emulated_meter(
        &wall,
        FaultPlan {
            stop_after_readings: Some(60),
            ..FaultPlan::default()
        },
    );
    let mut per_display = Vec::new();
    let err = {
        let mut rig = Rig {
            pattern: &mut pattern,
            meter: &mut meter,
            positioner: &mut positioner,
        };
        let mut progress = |p: Progress| {
            if let Progress::DisplayDone { readings, .. } = p {
                per_display.push(readings);
            }
        };
        commission(
            &wall.name(),
            &displays,
            &mut rig,
            out.path(),
            &options(false),
            &mut progress,
        )
        .unwrap_err()
    };
    emu.stop();
    assert_eq!(
        per_display,
        vec![40],
        "display 0 completes with 40 readings"
    );
    let msg = err.to_string();
    println!("{msg}");
    match &err {
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
    // Nothing half-written: no profiles, no manifest, no temporary files; the run
    // folder holds the manifest and display 0's measurement only.
    assert_eq!(files(out.path()), vec!["run".to_string()]);
    let run = files(&out.path().join("run"));
    assert_eq!(run.len(), 2, "{run:?}");
    assert!(run.contains(&"run.json".to_string()));
    assert!(
        run.iter()
            .any(|f| f.starts_with("d000-") && f.ends_with(".measurement.json"))
    );

    // Run 2: the meter is back; --resume measures display 1 only.
    let (emu, mut meter) = emulated_meter(&wall, FaultPlan::default());
    let mut resumed = Vec::new();
    let mut measured = Vec::new();
    let mut rig = Rig {
        pattern: &mut pattern,
        meter: &mut meter,
        positioner: &mut positioner,
    };
    let outcome = commission(
        &wall.name(),
        &displays,
        &mut rig,
        out.path(),
        &options(true),
        &mut |p| match p {
            Progress::Resumed { display, .. } => resumed.push(display.0),
            Progress::DisplayDone { display, .. } => measured.push(display.0),
            Progress::Reading { .. } => {}
        },
    )
    .unwrap();
    assert_eq!(resumed, vec![0]);
    assert_eq!(measured, vec![1]);
    assert_eq!(emu.readings_requested(), 40);
    let (name, profiles) = ProfileSet::load_dir(out.path()).unwrap();
    assert_eq!(name, wall.name());
    assert_eq!(profiles.len(), 2);

    // Verify through the pty: 20 colours on both eyes.
    let targets = default_targets(&profiles, 20).unwrap();
    let vopts = VerifyOptions {
        meter_xy_offset: outcome.meter_correction.as_ref().map(|c| c.xy_offset),
        ..VerifyOptions::default()
    };
    let report = verify_wall(
        &mut rig,
        &displays,
        &profiles,
        &targets,
        &vopts,
        &mut |_| {},
    )
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
    emu.stop();
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
    let wall = wall();
    let mut pattern = wall.pattern_output();
    let mut positioner = wall.positioner();
    let mut meter = wall.meter(MeterModel::noiseless());
    let mut rig = Rig {
        pattern: &mut pattern,
        meter: &mut meter,
        positioner: &mut positioner,
    };
    let err = commission(
        &wall.name(),
        &wall.displays(),
        &mut rig,
        out.path(),
        &options(true),
        &mut |_| {},
    )
    .unwrap_err();
    assert!(
        matches!(err, CommissionError::ResumeMismatch { .. }),
        "{err}"
    );
    assert!(err.to_string().contains("'other'"), "{err}");
}
