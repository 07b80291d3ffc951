//! Hand-built profiles shared by the profile crate's tests.

use lumiwall_profiles::{
    BlackMode, DisplayKey, DisplayProfile, Eye, FORMAT_VERSION, FlatField, MeasurementInfo,
    OutOfGamut, ToneCurve,
};

/// A tone curve of a pure power law `I = d^gamma`, with a 1024-entry inverse LUT.
pub(crate) fn power_curve(gamma: f64) -> ToneCurve {
    let forward = (0..=16)
        .map(|i| {
            let d = f64::from(i) / 16.0;
            [d, d.powf(gamma)]
        })
        .collect();
    let inverse_lut = (0..1024)
        .map(|i| (f64::from(i) / 1023.0).powf(1.0 / gamma) as f32)
        .collect();
    ToneCurve {
        forward,
        inverse_lut,
    }
}

/// A valid profile of display `display` (`eye`) of `wall` with the given measured
/// primaries `[R, G, B]` (XYZ cd/m², black excluded), black XYZ and channel usage.
pub(crate) fn profile_with(
    wall: &str,
    display: u32,
    eye: Eye,
    primaries: [[f64; 3]; 3],
    black: [f64; 3],
    usage: [f64; 3],
) -> DisplayProfile {
    DisplayProfile {
        format_version: FORMAT_VERSION,
        display: DisplayKey {
            wall: wall.to_string(),
            display,
            tile_col: display % 6,
            tile_row: display / 6,
            eye,
        },
        created_utc: "2026-11-20T02:00:00Z".into(),
        primaries_xyz_cd_m2: primaries,
        black_xyz_cd_m2: black,
        display_model: Default::default(),
        black_mode: BlackMode::Individual,
        shown_black_xyz_cd_m2: black,
        target_white_xyz_cd_m2: [76.0, 80.0, 87.0],
        common_primaries_xy: [[0.625, 0.370], [0.286, 0.613], [0.140, 0.045]],
        xyz_to_drive: [
            [0.032, -0.015, -0.005],
            [-0.010, 0.019, 0.0004],
            [0.0006, -0.002, 0.0106],
        ],
        drive_offset: [-0.004, -0.003, -0.005],
        channel_usage: usage,
        headroom: 1.0,
        curves: [power_curve(2.2), power_curve(2.4), power_curve(2.0)],
        flat_field: Some(FlatField {
            width: 4,
            height: 2,
            gain: vec![
                [1.0, 1.0, 1.0],
                [0.9, 0.92, 0.95],
                [0.8, 0.85, 0.9],
                [0.7, 0.75, 0.8],
                [0.95, 0.96, 0.97],
                [0.85, 0.86, 0.87],
                [0.75, 0.76, 0.77],
                [0.65, 0.66, 0.67],
            ],
        }),
        out_of_gamut: OutOfGamut::Clip,
        bit_depth: 10,
        measurement: MeasurementInfo {
            instrument: "virtual CS-200".into(),
            readings: 38,
            additivity_error: Some(0.004),
        },
    }
}

/// Measured primaries of the test display on the first night: white = R + G + B =
/// (90, 100, 92) cd/m².
pub(crate) const PRIMARIES: [[f64; 3]; 3] =
    [[40.0, 20.0, 2.0], [35.0, 70.0, 10.0], [15.0, 10.0, 80.0]];

/// A valid mono profile of `display` with the first night's primaries.
pub(crate) fn profile(wall: &str, display: u32) -> DisplayProfile {
    profile_with(
        wall,
        display,
        Eye::Mono,
        PRIMARIES,
        [0.3, 0.5, 0.6],
        [0.9, 1.0, 0.85],
    )
}
