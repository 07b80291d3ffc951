//! Helpers shared by the station tests: fixture walls opened as a
//! [`Station`], and the commissioning options they use (white 8500 K).
use std::path::PathBuf;

use lumiwall_calib::commission::CommissionOptions;
use lumiwall_calib::measure::MeasureOptions;
use lumiwall_calib::solve::{SolveOptions, WhiteTarget};
use lumiwall_calib::station::{MeterChoice, Noise, Station, StationOptions};
use lumiwall_profiles::BlackMode;

/// A wall file of fixtures/walls.
pub(crate) fn wall_path(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/walls")
        .join(file)
}

/// `fixtures/walls/mono-2x1.toml` with lamps of `lamp_cd_m2` instead of its 250
/// cd/m²: a dim wall (25 cd/m²: a wall white near 12.7 cd/m²; 15: near 7.6).
pub(crate) fn dim_mono_2x1(lamp_cd_m2: f64) -> String {
    let fixture = std::fs::read_to_string(wall_path("mono-2x1.toml")).expect("fixture");
    assert!(
        fixture.contains("white_cd_m2 = 250.0"),
        "the fixture's lamp changed"
    );
    fixture.replace(
        "white_cd_m2 = 250.0",
        &format!("white_cd_m2 = {lamp_cd_m2:?}"),
    )
}

/// The fixture wall `file` with the simulated meter called directly.
pub(crate) fn direct_station(file: &str, noise: Noise) -> Station {
    Station::open(
        &wall_path(file),
        &StationOptions::new(MeterChoice::Direct, noise),
    )
    .unwrap()
}

/// Commissioning to the 8500 K daylight white with `black_mode`, the meter correction on.
pub(crate) fn options_8500k(
    measure: MeasureOptions,
    black_mode: BlackMode,
    resume: bool,
) -> CommissionOptions {
    let grey_levels = lumiwall_calib::measure::grey_drives::default_levels();
    CommissionOptions {
        measure,
        solve: SolveOptions {
            white: WhiteTarget::Cct(8500.0),
            black_mode,
            ..SolveOptions::default()
        },
        resume,
        meter_correction: false,
        grey_levels,
        // the tests that start cold say so
        warm_check: None,
    }
}
