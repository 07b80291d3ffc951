//! Acceptance: XYZ in → post pass → virtual wall → XYZ out, within the display's gamut,
//! ΔE2000 < 0.5 (noiseless), over 10^4 random in-gamut colours per display.
//!
//! The profile is built from the simulator's true primaries and true per-code tone
//! curves at the display centre (a perfect calibration), so the test isolates the post
//! pass: matrix, black subtraction, LUT inversion and quantisation to the display's own
//! bit depth. ΔE2000 is `lumiwall_calib::colorimetry`, checked here on Sharma et al.'s
//! published pairs first.
#![allow(
    clippy::needless_range_loop,
    reason = "pixel and channel indices address several arrays at once"
)]

use std::collections::HashMap;
use std::path::PathBuf;

use lumiwall_calib::colorimetry::{Lab, delta_e2000, delta_e2000_xyz};
use lumiwall_devices::sim::VirtualWall;
use lumiwall_devices::{DisplayId, Xyz};
use lumiwall_profiles::apply::{ApplyOptions, PreparedProfile, lut::invert_forward, mat3};
use lumiwall_profiles::{
    BlackMode, DisplayKey, DisplayProfile, FORMAT_VERSION, MeasurementInfo, OutOfGamut, ToneCurve,
};

fn wall_file(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/walls")
        .join(name)
}

fn arr(v: Xyz) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// The profile a perfect calibration of display `id` (at its centre) gives.
fn true_profile(wall: &VirtualWall, id: DisplayId, bit_depth: u32) -> DisplayProfile {
    let info = wall.displays().into_iter().find(|d| d.id == id).unwrap();
    let tp = wall.true_primaries(id).unwrap();
    let black = arr(tp.black);
    let prim = [tp.red, tp.green, tp.blue].map(|p| {
        let p = arr(p);
        [p[0] - black[0], p[1] - black[1], p[2] - black[2]]
    });
    let m = mat3::inverse(&mat3::from_columns(&prim)).unwrap();
    let max = f64::from((1u32 << bit_depth) - 1);
    let curves = [0, 1, 2].map(|c| {
        let forward: Vec<[f64; 2]> = (0..=max as u32)
            .map(|k| {
                let d = f64::from(k) / max;
                [d, wall.true_relative_intensity(id, c, d).unwrap()]
            })
            .collect();
        let inverse_lut = invert_forward(&forward, 4096).unwrap();
        ToneCurve {
            forward,
            inverse_lut,
        }
    });
    let white = [0, 1, 2].map(|i| prim.iter().map(|p| p[i]).sum::<f64>());
    let xy = |p: &[f64; 3]| {
        let s = p[0] + p[1] + p[2];
        [p[0] / s, p[1] / s]
    };
    let profile = DisplayProfile {
        format_version: FORMAT_VERSION,
        display: DisplayKey {
            wall: wall.name(),
            display: id.0,
            tile_col: info.tile_col,
            tile_row: info.tile_row,
            eye: info.eye,
        },
        created_utc: "2026-11-22T00:00:00Z".into(),
        primaries_xyz_cd_m2: prim,
        black_xyz_cd_m2: black,
        display_model: Default::default(),
        black_mode: BlackMode::Individual,
        shown_black_xyz_cd_m2: black,
        target_white_xyz_cd_m2: white,
        common_primaries_xy: prim.map(|p| xy(&p)),
        xyz_to_drive: m,
        drive_offset: mat3::mul_vec(&m, &black).map(|v| -v),
        channel_usage: [1.0; 3],
        headroom: 1.0,
        curves,
        flat_field: None,
        out_of_gamut: OutOfGamut::Clip,
        bit_depth,
        measurement: MeasurementInfo {
            instrument: "simulator truth".into(),
            readings: 0,
            additivity_error: None,
        },
    };
    profile.validate().unwrap();
    profile
}

#[test]
fn delta_e2000_reproduces_sharma_pairs() {
    let lab = |l, a, b| Lab { l, a, b };
    let d1 = delta_e2000(lab(50.0, 2.6772, -79.7751), lab(50.0, 0.0, -82.7485));
    assert!((d1 - 2.0425).abs() < 1e-4, "{d1}");
    let d17 = delta_e2000(lab(50.0, 2.5, 0.0), lab(73.0, 25.0, -18.0));
    assert!((d17 - 27.1492).abs() < 1e-4, "{d17}");
}

/// Runs 10^4 random in-gamut colours of every display through post pass and wall.
/// `patch`: show each colour as a dithered 16×16 patch and take the mean XYZ over it
/// (what a meter reading a spot sees); otherwise one pixel, rounded.
fn round_trip(wall: &VirtualWall, patch: bool) -> Vec<(f64, f64)> {
    let centre = [0.5, 0.5];
    let mut rng = lumiwall_render::rng::SplitMix64(2003);
    let mut results = Vec::new();
    for info in wall.displays() {
        let prof = true_profile(wall, info.id, info.bit_depth);
        let opts = ApplyOptions {
            dither: patch,
            ..Default::default()
        };
        let pp = PreparedProfile::new(&prof, &opts).unwrap();
        let max = f64::from(pp.max_code());
        let black = prof.black_xyz_cd_m2;
        let reference = wall.true_primaries(info.id).unwrap().white;
        let p = mat3::from_columns(&prof.primaries_xyz_cd_m2);
        let (mut worst, mut sum) = (0.0f64, 0.0f64);
        let n = 10_000;
        for _ in 0..n {
            // A random colour inside the display's gamut (black included).
            let lin = [rng.unit(), rng.unit(), rng.unit()];
            let xyz = mat3::mul_vec(&p, &lin);
            let xyz = [0, 1, 2].map(|c| xyz[c] + black[c]);
            let out = pp.apply(xyz.map(|v| v as f32), centre.map(|v| v as f32));
            let side = if patch { 16 } else { 1 };
            let mut seen: HashMap<[u16; 3], usize> = HashMap::new();
            for y in 0..side {
                for x in 0..side {
                    *seen.entry(pp.quantise_pixel(out.drive, x, y)).or_default() += 1;
                }
            }
            let mut shown = [0.0; 3];
            for (codes, count) in &seen {
                let drive = codes.map(|c| f64::from(c) / max);
                let e = arr(wall.emitted_xyz(info.id, drive, centre).unwrap());
                let w = *count as f64 / f64::from(side * side);
                for c in 0..3 {
                    shown[c] += w * e[c];
                }
            }
            let target = Xyz {
                x: xyz[0],
                y: xyz[1],
                z: xyz[2],
            };
            let shown = Xyz {
                x: shown[0],
                y: shown[1],
                z: shown[2],
            };
            let de = delta_e2000_xyz(target, shown, reference);
            worst = worst.max(de);
            sum += de;
        }
        eprintln!(
            "display {} ({:?}, {} bit, {}): ΔE2000 mean {:.3}, max {:.3} over {n} in-gamut colours",
            info.id,
            info.eye,
            info.bit_depth,
            if patch {
                "dithered 16×16 patch"
            } else {
                "single pixel"
            },
            sum / n as f64,
            worst
        );
        results.push((sum / n as f64, worst));
    }
    results
}

/// Asserts for every display of `wall` that the round trip's ΔE2000 stays below
/// `max_worst` (largest) and `max_mean` (mean).
fn assert_round_trip_within(wall: &VirtualWall, patch: bool, max_worst: f64, max_mean: f64) {
    for (mean, worst) in round_trip(wall, patch) {
        assert!(
            worst < max_worst && mean < max_mean,
            "ΔE2000 mean {mean:.3}, max {worst:.3}"
        );
    }
}

#[test]
fn round_trip_infitec_pair_8_bit_dithered_patches() {
    // The fixture's projectors take 8-bit input: one code step alone is up to ≈ 0.7
    // ΔE2000 in saturated blue-violet, so single pixels cannot meet 0.5; the dithered
    // patch mean (what a meter reads) must.
    let wall = VirtualWall::from_toml_file(&wall_file("infitec-pair.toml")).unwrap();
    assert_round_trip_within(&wall, true, 0.5, 0.15);
}

#[test]
fn round_trip_infitec_pair_10_bit_single_pixels() {
    // Same wall with 10-bit projector inputs: every single pixel within 0.5.
    let text = std::fs::read_to_string(wall_file("infitec-pair.toml")).unwrap();
    assert!(text.contains("bit_depth = 8"));
    let wall =
        VirtualWall::from_toml_str(&text.replace("bit_depth = 8", "bit_depth = 10")).unwrap();
    assert!(wall.displays().iter().all(|d| d.bit_depth == 10));
    assert_round_trip_within(&wall, false, 0.5, 0.1);
}

#[test]
fn round_trip_infitec_pair_8_bit_single_pixels_are_quantisation_limited() {
    // Undithered 8-bit pixels: bounded by about one code step (looser bound, reported).
    let wall = VirtualWall::from_toml_file(&wall_file("infitec-pair.toml")).unwrap();
    assert_round_trip_within(&wall, false, 1.0, 0.2);
}
