//! The K-10-A driver reading the virtual wall through the pty emulator: what the
//! driver returns equals what the simulated meter sees, to the protocol's precision.
#![cfg(all(feature = "serial", feature = "sim"))]

use std::path::Path;
use std::time::Duration;

use lumiwall_devices::serial::{Emulator, EmulatorOptions, FaultPlan, K10aConfig, KLEIN_K10A};
use lumiwall_devices::sim::{MeterModel, VirtualWall};
use lumiwall_devices::{Colorimeter, DeviceError, DisplayId, MeterPositioner, PatternOutput};

fn wall_path() -> std::path::PathBuf {
    let walls = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/walls");
    let pair = walls.join("infitec-pair.toml");
    if pair.exists() {
        pair
    } else {
        walls.join("heyewall-48.toml")
    }
}

#[test]
fn readings_through_the_pty_match_the_virtual_wall() {
    let wall = VirtualWall::from_toml_file(&wall_path()).unwrap();
    let mut output = wall.pattern_output();
    let mut positioner = wall.positioner();
    let (emu, port) = Emulator::spawn_with(
        Box::new(wall.meter(MeterModel::noiseless())),
        FaultPlan::default(),
        EmulatorOptions::with_time_scale(0.01),
    )
    .unwrap();
    let mut meter = port
        .open(K10aConfig {
            read_timeout: Duration::from_millis(1000),
            ..K10aConfig::default()
        })
        .unwrap();
    let displays = output.displays();
    let last = displays.last().unwrap().id;
    let drives = [
        [1.0, 1.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.5; 3],
        [0.0; 3],
    ];
    for id in [DisplayId(0), last] {
        positioner.aim(id, [0.5, 0.5]).unwrap();
        for drive in drives {
            output.show(id, drive).unwrap();
            let got = meter.measure().unwrap();
            let truth = wall.emitted_xyz(id, drive, [0.5, 0.5]).unwrap();
            for (g, t) in got.to_array().iter().zip(truth.to_array()) {
                // 15-bit mantissa (2^-15) plus the drift of the simulated clock
                // between the reading and this check (warm-up, well below 1e-4).
                assert!(
                    (g - t).abs() <= 1e-4 * t.abs() + 1e-9,
                    "display {id} drive {drive:?}: got {got:?}, wall {truth:?}"
                );
            }
        }
    }
    assert_eq!(emu.readings_requested(), 12);
}

#[test]
fn realistic_k10a_error_model_through_the_pty() {
    let wall = VirtualWall::from_toml_file(&wall_path()).unwrap();
    let model = KLEIN_K10A.sim_meter_model(7);
    assert_eq!(model.max_cd_m2, 4000.0);
    let mut output = wall.pattern_output();
    let mut positioner = wall.positioner();
    let (_emu, port) = Emulator::spawn_with(
        Box::new(wall.meter(model)),
        FaultPlan::default(),
        EmulatorOptions::with_time_scale(0.01),
    )
    .unwrap();
    let mut meter = port.open(K10aConfig::default()).unwrap();
    let id = DisplayId(0);
    positioner.aim(id, [0.5, 0.5]).unwrap();
    output.show(id, [1.0; 3]).unwrap();
    let truth = wall.emitted_xyz(id, [1.0; 3], [0.5, 0.5]).unwrap();
    let n = 20;
    let mut sum = 0.0;
    for _ in 0..n {
        match meter.measure() {
            Ok(xyz) => sum += xyz.y,
            Err(DeviceError::OverRange { .. }) => {
                assert!(truth.y > 0.9 * KLEIN_K10A.max_cd_m2);
                return;
            }
            Err(e) => panic!("{e}"),
        }
    }
    let mean = sum / f64::from(n);
    eprintln!(
        "white: wall {:.3} cd/m², mean of {n} readings {mean:.3}",
        truth.y
    );
    // The pty path must preserve the simulated instrument exactly: the mean equals
    // the truth times this instrument's systematic gain (same seed → same draw),
    // within 4σ of the per-reading noise over n readings.
    let (gain, _) = wall.meter(KLEIN_K10A.sim_meter_model(7)).systematic_error();
    let sigma = KLEIN_K10A.sim_meter_model(7).lum_sigma_rel(truth.y);
    let rel = mean / (truth.y * gain) - 1.0;
    assert!(
        rel.abs() < 4.0 * sigma / f64::from(n).sqrt(),
        "mean {mean} vs wall {} × gain {gain}: {rel:e}",
        truth.y
    );
    assert!((gain - 1.0).abs() <= KLEIN_K10A.luminance_accuracy_rel);
}
