//! The JETI specbos driver reading the virtual wall through the pty emulator: the
//! XYZ and the spectrum it returns equal what the simulated spectroradiometer sees,
//! to the protocol's precision; the instrument's refusals arrive as typed errors.
#![cfg(all(feature = "serial", feature = "sim"))]

use std::path::Path;
use std::time::Duration;

use lumiwall_devices::serial::{
    JetiSpecbos, SpecbosConfig, SpecbosEmulator, SpecbosEmulatorOptions,
};
use lumiwall_devices::sim::{SpectroModel, VirtualWall};
use lumiwall_devices::{
    Colorimeter, DeviceError, DisplayId, MeterPositioner, PatternOutput, Spectroradiometer,
};

fn wall() -> VirtualWall {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/walls/infitec-pair.toml");
    VirtualWall::from_toml_file(&path).expect("wall")
}

fn fast() -> SpecbosEmulatorOptions {
    SpecbosEmulatorOptions {
        time_scale: 0.0,
        ..SpecbosEmulatorOptions::default()
    }
}

fn config() -> SpecbosConfig {
    SpecbosConfig {
        read_timeout: Duration::from_millis(1000),
        ..SpecbosConfig::default()
    }
}

/// An emulated specbos on `wall` backed by `model`, and the driver opened on it.
fn open(wall: &VirtualWall, model: SpectroModel) -> (SpecbosEmulator, JetiSpecbos) {
    let instrument = wall.spectroradiometer(model).expect("instrument");
    let emulator = SpecbosEmulator::spawn(Box::new(instrument), fast()).expect("emulator");
    let driver = JetiSpecbos::open(emulator.path(), config()).expect("driver");
    (emulator, driver)
}

#[test]
fn the_driver_reads_the_simulators_truth_through_the_pty_as_xyz_and_as_a_spectrum() {
    let wall = wall();
    let (emulator, mut specbos) = open(&wall, SpectroModel::noiseless());
    assert_eq!(specbos.info().model, "JETI specbos 1211");
    assert_eq!(specbos.info().serial, "12110001");
    assert_eq!(specbos.wavelength_range_nm(), [360.0, 830.0]);
    let id = DisplayId(1);
    wall.positioner().aim(id, [0.3, 0.6]).expect("aim");
    for drive in [[1.0, 1.0, 1.0], [0.0, 1.0, 0.0], [0.2, 0.05, 0.7]] {
        wall.pattern_output().show(id, drive).expect("show");
        let truth = wall.emitted_xyz(id, drive, [0.3, 0.6]).expect("truth");
        let xyz = specbos.measure().expect("xyz");
        let spectrum = specbos.measure_spectrum().expect("spectrum");
        assert_eq!(spectrum.w_sr_m2_nm.len(), 471);
        let from_spectrum = spectrum.xyz().expect("xyz");
        for (got, what) in [(xyz, "*fetch:XYZ"), (from_spectrum, "*fetch:sprad")] {
            for (g, t) in got.to_array().iter().zip(truth.to_array()) {
                // 7 significant digits per spectral value
                assert!(
                    (g - t).abs() <= 1e-6 * t.abs() + 1e-12,
                    "{what} {drive:?}: {got:?} vs truth {truth:?}"
                );
            }
        }
    }
    assert_eq!(emulator.readings_requested(), 6);
}

#[test]
fn over_and_under_exposure_arrive_as_over_range_and_too_dark() {
    let wall = wall();
    let id = DisplayId(0);
    wall.positioner().aim(id, [0.5, 0.5]).expect("aim");
    wall.pattern_output().show(id, [1.0; 3]).expect("show");
    let mut bright = SpectroModel::noiseless();
    bright.max_cd_m2 = 1.0e-3;
    let (_e, mut specbos) = open(&wall, bright);
    assert!(matches!(
        specbos.measure(),
        Err(DeviceError::OverRange { .. })
    ));
    let mut dark = SpectroModel::noiseless();
    dark.floor_cd_m2 = 1.0e9;
    let (_e, mut specbos) = open(&wall, dark);
    assert!(matches!(
        specbos.measure_spectrum(),
        Err(DeviceError::TooDark { .. })
    ));
}

#[test]
fn an_instrument_calibrated_beyond_380_to_780_nm_is_read_over_its_range_up_to_830_nm() {
    let wall = wall();
    let mut wide = SpectroModel::noiseless();
    wide.start_nm = 350.0;
    wide.end_nm = 1000.0;
    let (_e, mut specbos) = open(&wall, wide);
    assert_eq!(specbos.wavelength_range_nm(), [350.0, 830.0]);
    let id = DisplayId(0);
    wall.positioner().aim(id, [0.5, 0.5]).expect("aim");
    wall.pattern_output().show(id, [1.0; 3]).expect("show");
    let s = specbos.measure_spectrum().expect("spectrum");
    assert_eq!(s.w_sr_m2_nm.len(), 481);
    let truth = wall.emitted_xyz(id, [1.0; 3], [0.5, 0.5]).expect("truth");
    assert!((s.xyz().expect("xyz").y / truth.y - 1.0).abs() < 1e-5);
}

#[test]
fn an_instrument_that_is_not_a_specbos_or_says_nothing_is_refused_with_a_clear_error() {
    // a pty with nobody behind it: the identification times out
    let (_master, slave) = serialport::TTYPort::pair().expect("pty");
    let path = serialport::SerialPort::name(&slave).expect("path");
    let err = JetiSpecbos::open(
        &path,
        SpecbosConfig {
            read_timeout: Duration::from_millis(200),
            ..SpecbosConfig::default()
        },
    )
    .expect_err("silence");
    assert!(matches!(err, DeviceError::Timeout { .. }), "{err}");
}
