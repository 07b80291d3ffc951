//! Shared fixtures of the post-pass tests: analytic displays and test frames.
#![allow(
    dead_code,
    reason = "each test binary uses a different subset of the fixtures"
)]

use lumiwall_profiles::apply::model::{AnalyticDisplay, ModelProfileSpec};
use lumiwall_profiles::{BlackMode, DisplayKey, DisplayProfile, Eye, FlatField, OutOfGamut};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub(crate) use lumiwall_profiles::apply::model::xyz_of;

/// A projector with Kresse's Infitec common-gamut primaries (Tab. 5) and S-shaped curves.
pub(crate) fn infitec_display() -> AnalyticDisplay {
    AnalyticDisplay::infitec_example()
}

/// 64×32 vignetting texture (Kresse's size): gains in (0.55, 1], per channel shifted.
pub(crate) fn vignette() -> FlatField {
    let (w, h) = (64u32, 32u32);
    let mut gain = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let u = (x as f32 + 0.5) / w as f32 - 0.55;
            let v = (y as f32 + 0.5) / h as f32 - 0.45;
            let r2 = u * u + v * v;
            gain.push([
                (1.0 - 0.8 * r2).clamp(0.55, 1.0),
                (1.0 - 0.9 * r2).clamp(0.55, 1.0),
                (1.0 - 1.0 * r2).clamp(0.55, 1.0),
            ]);
        }
    }
    FlatField {
        width: w,
        height: h,
        gain,
    }
}

pub(crate) fn key(display: u32, eye: Eye) -> DisplayKey {
    DisplayKey {
        wall: "test-wall".into(),
        display,
        tile_col: display,
        tile_row: 0,
        eye,
    }
}

/// Target white: 90 % of the display's full white at D65-ish 0.3127/0.3290 scaled to fit.
pub(crate) fn profile(
    d: &AnalyticDisplay,
    mode: BlackMode,
    flat: Option<FlatField>,
    bit_depth: u32,
) -> DisplayProfile {
    let white = d.full_white_xyz().map(|v| v * 0.9);
    d.profile(&ModelProfileSpec {
        display: key(0, Eye::Mono),
        black_mode: mode,
        common_black_xyz_cd_m2: xyz_of(0.30, 0.32, 0.6),
        target_white_xyz_cd_m2: white,
        lut_entries: 4096,
        flat_field: flat,
        out_of_gamut: OutOfGamut::Clip,
        bit_depth,
    })
    .unwrap()
}

/// `n` XYZ values (cd/m²) mixing in-gamut colours, out-of-gamut chromaticities,
/// negative components, huge (to 1e6 cd/m²), zero, tiny, NaN and ±Inf inputs.
pub(crate) fn wild_xyz(n: usize, d: &AnalyticDisplay, seed: u64) -> Vec<[f32; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let p = d.primaries_xyz_cd_m2;
    (0..n)
        .map(|i| match i % 10 {
            0..=3 => {
                let l: [f64; 3] = [rng.random(), rng.random(), rng.random()];
                [0, 1, 2].map(|k| (0..3).map(|c| p[c][k] * l[c]).sum::<f64>() as f32)
            }
            4 => {
                let x: f64 = rng.random_range(0.0..0.8);
                let y: f64 = rng.random_range(0.01..0.85);
                let lum: f64 = rng.random_range(0.0..120.0);
                xyz_of(x, y, lum).map(|v| v as f32)
            }
            5 => [0, 1, 2].map(|_| rng.random_range(-50.0f32..80.0)),
            6 => {
                let s = 10f32.powf(rng.random_range(2.0..6.0));
                [0, 1, 2].map(|_| rng.random_range(0.0f32..1.2) * s)
            }
            7 => match rng.random_range(0..4) {
                0 => [0.0; 3],
                1 => [1e-30, 1e-30, 1e-30],
                2 => [0.0, rng.random_range(0.0..0.5), 0.0],
                _ => [1e6, 1e6, 1e6],
            },
            8 => match rng.random_range(0..4) {
                0 => [f32::NAN, 1.0, 1.0],
                1 => [1.0, f32::INFINITY, 1.0],
                2 => [1.0, 1.0, f32::NEG_INFINITY],
                _ => [f32::NAN; 3],
            },
            _ => {
                let l: [f64; 3] = [
                    rng.random::<f64>() * 0.05,
                    rng.random::<f64>() * 0.05,
                    rng.random::<f64>() * 0.05,
                ];
                [0, 1, 2].map(|k| (0..3).map(|c| p[c][k] * l[c]).sum::<f64>() as f32)
            }
        })
        .collect()
}
