//! The wall solve against a synthetic analytic display model written here, independent
//! of the code under test: known primaries, per-channel power or S curves, black.
//! The profiles must invert the model (ΔE2000 < 0.05 noiseless), keep channel usage in
//! [0, headroom] with the maximum exactly at headroom, and handle the stiff cases.
//!
//! `cargo test -p lumiwall-calib --test calibration solve:: -- --nocapture` prints the numbers.

use crate::common::Lcg;
use lumiwall_calib::CalibError;
use lumiwall_calib::colorimetry::{cct_to_xy, delta_e2000_xyz};
use lumiwall_calib::solve::{
    CompositeReading, DisplayMeasurement, Limiting, SolveOptions, SolveWarning, WallSolution,
    WhiteTarget, solve_wall,
};
use lumiwall_calib::tone::suggest_next_drive;
use lumiwall_core::Channel;
use lumiwall_devices::Xyz;
use lumiwall_profiles::{BlackMode, DisplayKey, DisplayModel, DisplayProfile, Eye, OutOfGamut};
use nalgebra::{Matrix3, Vector3};

#[derive(Clone, Copy)]
enum Curve {
    Power(f64),
    /// Normalised logistic of drive^1.3 with steepness k.
    S(f64),
}

impl Curve {
    fn eval(self, d: f64) -> f64 {
        match self {
            Curve::Power(g) => d.powf(g),
            Curve::S(k) => {
                let sig = |x: f64| 1.0 / (1.0 + (-k * (x - 0.55)).exp());
                (sig(d.powf(1.3)) - sig(0.0)) / (sig(1.0) - sig(0.0))
            }
        }
    }
}

/// A display: reading(drive) = black + Σ_c P_c · curve_c(drive_c) + W · min_c curve_c
/// (additive when the white segment `W` is zero).
#[derive(Clone)]
struct Model {
    /// Black-subtracted full-drive XYZ of R, G, B (cd/m²).
    p: [Xyz; 3],
    black: Xyz,
    curves: [Curve; 3],
    /// A single-chip DLP's white segment at full drive (cd/m²).
    white_segment: Xyz,
}

impl Model {
    fn from_xy(prim: [(f64, f64, f64); 3], black: (f64, f64, f64), curves: [Curve; 3]) -> Self {
        let x = |(x, y, l): (f64, f64, f64)| Xyz::from_xy_luminance(x, y, l);
        Model {
            p: prim.map(x),
            black: x(black),
            curves,
            white_segment: Xyz::default(),
        }
    }

    fn show(&self, drive: [f64; 3]) -> Xyz {
        let mut out = self.black;
        let mut least = f64::INFINITY;
        for ((p, curve), d) in self.p.iter().zip(&self.curves).zip(drive) {
            let i = curve.eval(d.clamp(0.0, 1.0));
            out = out + *p * i;
            least = least.min(i);
        }
        out + self.white_segment * least
    }

    fn measure(&self, index: u32, ramp_samples: usize) -> DisplayMeasurement {
        let mut ramps: [Vec<(f64, Xyz)>; 3] = [vec![], vec![], vec![]];
        for c in 0..3 {
            let mut rel: Vec<(f64, f64)> = Vec::new();
            while rel.len() < ramp_samples {
                let d = suggest_next_drive(&rel).unwrap();
                rel.push((d, self.curves[c].eval(d)));
                let mut drive = [0.0; 3];
                drive[c] = d;
                ramps[c].push((d, self.show(drive)));
            }
        }
        let mut primaries = [Xyz::default(); 3];
        for c in 0..3 {
            let mut drive = [0.0; 3];
            drive[c] = 1.0;
            primaries[c] = self.show(drive);
        }
        DisplayMeasurement {
            key: key(index),
            bit_depth: 10,
            black: self.black,
            primaries,
            white: Some(self.show([1.0; 3])),
            ramps,
            readings: (2 + 3 + 3 * ramp_samples) as u32,
            instrument: "analytic model".into(),
            composites: Vec::new(),
            ramp_sigma_rel: Default::default(),
        }
    }
}

fn key(i: u32) -> DisplayKey {
    DisplayKey {
        wall: "model".into(),
        display: i,
        tile_col: i,
        tile_row: 0,
        eye: Eye::Mono,
    }
}

fn options(mode: BlackMode, headroom: f64) -> SolveOptions {
    SolveOptions {
        white: WhiteTarget::Cct(6500.0),
        headroom,
        black_mode: mode,
        out_of_gamut: OutOfGamut::Clip,
        lut_entries: 4096,
        max_additivity_error: 0.02,
    }
}

/// Full-drive primaries `(x, y, Y cd/m²)` and black `(x, y, Y)` of one projector.
type ProjectorXy = ([(f64, f64, f64); 3], (f64, f64, f64));

/// Three different projectors: gamuts, luminances, gammas and blacks all differ.
#[rustfmt::skip]
const WALL_XY: [ProjectorXy; 3] = [
    ([(0.640, 0.330, 60.0), (0.300, 0.600, 190.0), (0.150, 0.060, 20.0)], (0.30, 0.31, 0.40)),
    ([(0.660, 0.320, 45.0), (0.280, 0.640, 260.0), (0.145, 0.052, 14.0)], (0.27, 0.25, 0.55)),
    ([(0.620, 0.345, 80.0), (0.310, 0.590, 150.0), (0.155, 0.070, 25.0)], (0.33, 0.36, 0.25)),
];

/// The projectors of [`WALL_XY`] with these tone curves.
fn wall(curves: [[Curve; 3]; 3]) -> Vec<Model> {
    WALL_XY
        .iter()
        .zip(curves)
        .map(|((prim, black), c)| Model::from_xy(*prim, *black, c))
        .collect()
}

/// Every model measured with `ramp_samples` adaptive samples per channel, display
/// index = position.
fn measure_all(models: &[Model], ramp_samples: usize) -> Vec<DisplayMeasurement> {
    models
        .iter()
        .enumerate()
        .map(|(i, m)| m.measure(i as u32, ramp_samples))
        .collect()
}

/// The post pass of profiles/src/profile.rs, written out here: m = M·xyz + offset;
/// with a white segment W (u = M·W) the `a` with `a + u·min(a) = m`, found by trying
/// each channel as the minimum and solving the linear system of that region (not the
/// closed form of the code under test); clamp, then the inverse LUT.
fn post_pass(p: &DisplayProfile, xyz: Xyz) -> ([f64; 3], [f64; 3]) {
    let v = [xyz.x, xyz.y, xyz.z];
    let m: [f64; 3] = std::array::from_fn(|c| {
        (0..3).map(|k| p.xyz_to_drive[c][k] * v[k]).sum::<f64>() + p.drive_offset[c]
    });
    let lin = match p.display_model {
        DisplayModel::Additive => m,
        DisplayModel::WhiteSegment { white_xyz_cd_m2: w } => {
            let mm = Matrix3::from_fn(|r, c| p.xyz_to_drive[r][c]);
            let u = mm * Vector3::from(w);
            let mv = Vector3::from(m);
            let region = |k: usize| {
                let mut a = Matrix3::identity();
                for r in 0..3 {
                    a[(r, k)] += u[r];
                }
                a.try_inverse().unwrap() * mv
            };
            // Region k is consistent when channel k is the smallest there.
            let a = (0..3)
                .map(|k| (k, region(k)))
                .find(|(k, a)| (0..3).all(|j| a[*k] <= a[j] + 1e-12))
                .map(|(_, a)| a)
                .expect("one region is consistent");
            [a[0], a[1], a[2]]
        }
    };
    let mut drive = [0.0; 3];
    for c in 0..3 {
        drive[c] = f64::from(p.curves[c].drive_for(lin[c].clamp(0.0, 1.0) as f32));
    }
    (lin, drive)
}

/// XYZ inputs spread over the common gamut: common RGB in {0.1, 0.4, 0.7, 1.0}³.
fn targets(sol: &WallSolution) -> Vec<Xyz> {
    let unit = |xy: [f64; 2]| {
        let v = Xyz::from_xy_luminance(xy[0], xy[1], 1.0);
        Vector3::new(v.x, v.y, v.z)
    };
    let c = Matrix3::from_columns(&sol.common_primaries_xy.map(unit));
    let w = sol.white_xyz_cd_m2;
    let s = c.try_inverse().unwrap() * Vector3::new(w.x, w.y, w.z);
    let levels = [0.1, 0.4, 0.7, 1.0];
    let mut out = Vec::new();
    for r in levels {
        for g in levels {
            for b in levels {
                let v = c * Vector3::new(r * s[0], g * s[1], b * s[2]);
                out.push(Xyz::new(v[0], v[1], v[2]));
            }
        }
    }
    out
}

fn check_usage(sol: &WallSolution, headroom: f64) {
    let mut max = 0.0_f64;
    for p in &sol.profiles {
        for u in p.channel_usage {
            assert!((-1e-12..=headroom + 1e-12).contains(&u), "usage {u}");
            max = max.max(u);
        }
    }
    assert!(
        (max - headroom).abs() < 1e-12,
        "max usage {max} vs headroom {headroom}"
    );
    let Limiting { display, channel } = sol.limiting;
    assert!((sol.profiles[display].channel_usage[channel.index()] - headroom).abs() < 1e-12);
}

fn max_delta_e(models: &[Model], sol: &WallSolution, mode: BlackMode) -> f64 {
    let mut worst = 0.0_f64;
    let white = sol.white_xyz_cd_m2;
    for (m, p) in models.iter().zip(&sol.profiles) {
        for t in targets(sol) {
            let (lin, drive) = post_pass(p, t);
            assert!(
                lin.iter().all(|l| (-1e-9..=1.0 + 1e-9).contains(l)),
                "{lin:?}"
            );
            let shown = m.show(drive);
            let expected = match mode {
                BlackMode::Individual => t,
                BlackMode::Common => t + sol.common_black_xyz_cd_m2,
                BlackMode::Ignore => t + m.black,
            };
            worst = worst.max(delta_e2000_xyz(expected, shown, white));
        }
    }
    worst
}

/// Power-law tone curves of the three projectors of [`WALL_XY`], different per channel.
const POWER_CURVES: [[Curve; 3]; 3] = [
    [Curve::Power(2.2), Curve::Power(2.4), Curve::Power(2.0)],
    [Curve::Power(2.6), Curve::Power(2.1), Curve::Power(2.3)],
    [Curve::Power(1.8), Curve::Power(2.5), Curve::Power(2.2)],
];

#[test]
fn profiles_invert_the_model_in_every_black_mode() {
    let models = wall(POWER_CURVES);
    let meas = measure_all(&models, 5);
    for (mode, headroom) in [
        (BlackMode::Individual, 1.0),
        (BlackMode::Common, 1.0),
        (BlackMode::Ignore, 1.0),
        (BlackMode::Individual, 0.9),
    ] {
        let sol = solve_wall(&meas, &options(mode, headroom)).unwrap();
        check_usage(&sol, headroom);
        let de = max_delta_e(&models, &sol, mode);
        let w = sol.white_xyz_cd_m2;
        println!(
            "{mode:?} headroom {headroom}: white {:.2} cd/m², limited by display {} channel {}, max ΔE2000 over 64 colours × 3 displays = {de:.4}",
            w.y, sol.limiting.display, sol.limiting.channel
        );
        assert!(de < 0.05, "{mode:?}: ΔE2000 {de}");
        let xy = w.xy().unwrap();
        let target = cct_to_xy(6500.0).unwrap();
        assert!((xy[0] - target[0]).abs() < 1e-12 && (xy[1] - target[1]).abs() < 1e-12);
    }
}

#[test]
fn s_curves_from_ten_adaptive_samples() {
    let s = [Curve::S(7.0), Curve::S(6.0), Curve::S(8.0)];
    let models = wall([
        s,
        [Curve::S(5.5); 3],
        [Curve::S(7.5), Curve::Power(2.2), Curve::S(6.5)],
    ]);
    for n in [6, 8, 10, 14] {
        let meas = measure_all(&models, n);
        let sol = solve_wall(&meas, &options(BlackMode::Individual, 1.0)).unwrap();
        let de = max_delta_e(&models, &sol, BlackMode::Individual);
        println!(
            "S-curves, {n} ramp samples per channel ({} readings per display): max ΔE2000 {de:.3}",
            meas[0].readings
        );
        if n >= 10 {
            assert!(de < 0.5, "{n} samples: {de}");
        }
    }
}

#[test]
fn common_black_is_equal_on_all_displays_and_minimal() {
    let models = wall([[Curve::Power(2.2); 3]; 3]);
    let meas = measure_all(&models, 4);
    let sol = solve_wall(&meas, &options(BlackMode::Common, 1.0)).unwrap();
    let cb = sol.common_black_xyz_cd_m2;
    let mut worst_lut = 0.0_f64;
    for (m, p) in models.iter().zip(&sol.profiles) {
        let (lin, drive) = post_pass(p, Xyz::default());
        assert!(lin.iter().all(|l| *l >= -1e-12));
        // Linear light: black_i + P_i·lin is the common black exactly.
        let linear = m.black + m.p[0] * lin[0] + m.p[1] * lin[1] + m.p[2] * lin[2];
        assert!(
            (linear - cb).to_array().iter().all(|d| d.abs() < 1e-9),
            "{linear:?} vs {cb:?}"
        );
        assert_eq!(p.shown_black_xyz_cd_m2, cb.to_array());
        // Through the inverse LUT (linear interpolation, uniform in intensity) the
        // error is bounded by one LUT step of each channel's full output.
        let shown = m.show(drive);
        let step: f64 =
            (0..3).map(|c| m.p[c].y).sum::<f64>() / (p.curves[0].inverse_lut.len() - 1) as f64;
        assert!((shown.y - cb.y).abs() <= step, "{shown:?} vs {cb:?}");
        worst_lut = worst_lut.max((shown.y - cb.y).abs());
    }
    println!("common black through the 4096-entry LUTs: max |ΔY| {worst_lut:.4} cd/m²");
    // Minimal: no feasible black with lower luminance among 20000 random candidates
    // around it (feasible = every display shows it with non-negative channels).
    let feasible = |c: Vector3<f64>| {
        models.iter().all(|m| {
            let p = Matrix3::from_columns(&m.p.map(|v| Vector3::new(v.x, v.y, v.z)));
            let r = p.try_inverse().unwrap() * (c - Vector3::new(m.black.x, m.black.y, m.black.z));
            r.iter().all(|v| *v >= 0.0)
        })
    };
    let c0 = Vector3::new(cb.x, cb.y, cb.z);
    assert!(feasible(c0 + Vector3::from_element(1e-9)));
    let mut lcg = Lcg::new(7);
    let mut rnd = || lcg.signed();
    let mut found_lower = 0;
    for _ in 0..20000 {
        let c = c0 + Vector3::new(rnd(), rnd(), rnd()) * 0.3;
        if feasible(c) && c[1] < c0[1] - 1e-9 {
            found_lower += 1;
        }
    }
    let blacks: Vec<f64> = models.iter().map(|m| m.black.y).collect();
    println!(
        "common black Y {:.4} cd/m² (display blacks {blacks:?})",
        cb.y
    );
    assert_eq!(found_lower, 0);
    assert!(cb.y >= blacks.iter().cloned().fold(0.0, f64::max) - 1e-12);
}

#[test]
fn green_only_ten_percent_usable_works_and_is_reported() {
    let mut models = wall([[Curve::Power(2.2); 3]; 3]);
    // Right-eye Infitec projector: green far too strong relative to the others.
    models[1].p[1] = models[1].p[1] * 6.0;
    let meas = measure_all(&models, 4);
    let sol = solve_wall(&meas, &options(BlackMode::Individual, 1.0)).unwrap();
    let g = sol.profiles[1].channel_usage[1];
    println!(
        "display 1 green usage {:.1} %; warnings: {:?}",
        100.0 * g,
        sol.warnings
    );
    assert!(g > 0.05 && g < 0.12, "{g}");
    let display_1 = meas[1].key.to_string();
    assert!(sol.warnings.iter().any(|w| matches!(
        w,
        SolveWarning::LowChannelUsage { display, channel: Channel::Green, .. } if *display == display_1
    )));
    check_usage(&sol, 1.0);
    assert!(max_delta_e(&models, &sol, BlackMode::Individual) < 0.05);
}

#[test]
fn black_above_the_white_is_a_typed_error_naming_the_display() {
    let mut models = wall([[Curve::Power(2.2); 3]; 3]);
    // Display 0 is very dim (white ≈ 7 cd/m²), display 2 has a 12 cd/m² black.
    for c in 0..3 {
        models[0].p[c] = models[0].p[c] * 0.025;
    }
    models[2].black = Xyz::from_xy_luminance(0.31, 0.33, 12.0);
    let meas = measure_all(&models, 4);
    let err = solve_wall(&meas, &options(BlackMode::Individual, 1.0)).unwrap_err();
    let msg = err.to_string();
    println!("individual: {msg}");
    assert!(matches!(err, CalibError::UnreachableWhite { .. }));
    assert!(msg.contains("display 2") && msg.contains("12.000"), "{msg}");
    let err = solve_wall(&meas, &options(BlackMode::Common, 1.0)).unwrap_err();
    println!("common: {err}");
    assert!(matches!(err, CalibError::UnreachableWhite { .. }));
    assert!(err.to_string().contains("display 0"));
    // Ignoring black still works.
    assert!(solve_wall(&meas, &options(BlackMode::Ignore, 1.0)).is_ok());
}

#[test]
fn nearly_identical_displays_work() {
    let models = wall([[Curve::Power(2.2); 3]; 3]);
    let mut twin = models[0].clone();
    twin.p[0] = twin.p[0] * (1.0 + 1e-9);
    twin.p[2].x += 1e-9;
    let pair = vec![models[0].clone(), twin, models[0].clone()];
    let meas: Vec<DisplayMeasurement> = pair
        .iter()
        .enumerate()
        .map(|(i, m)| m.measure(i as u32, 4))
        .collect();
    let sol = solve_wall(&meas, &options(BlackMode::Common, 1.0)).unwrap();
    check_usage(&sol, 1.0);
    for c in 0..3 {
        let own = models[0].p[c].xy().unwrap();
        let g = sol.common_primaries_xy[c];
        assert!((own[0] - g[0]).abs() < 1e-6 && (own[1] - g[1]).abs() < 1e-6);
    }
    assert!(max_delta_e(&pair, &sol, BlackMode::Common) < 0.05);
}

#[test]
fn collinear_primaries_are_an_error_naming_the_display() {
    let mut models = wall([[Curve::Power(2.2); 3]; 3]);
    // Display 2's blue sits on the line between its red and green.
    models[2].p[2] = (models[2].p[0] + models[2].p[1]) * 0.1;
    let meas = measure_all(&models, 4);
    let err = solve_wall(&meas, &options(BlackMode::Individual, 1.0)).unwrap_err();
    println!("{err}");
    assert!(matches!(err, CalibError::DegeneratePrimaries { .. }));
    assert!(err.to_string().contains("display 2"));
}

#[test]
fn noisy_non_monotone_ramp_gives_a_valid_profile() {
    let models = wall([[Curve::Power(2.2); 3]; 3]);
    let mut meas = measure_all(&models, 8);
    // Swap two neighbouring readings of display 1's red ramp and add 3 % noise.
    let ramp = &mut meas[1].ramps[0];
    ramp.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (a, b) = (ramp[3].1, ramp[4].1);
    ramp[3].1 = b * 1.03;
    ramp[4].1 = a * 0.97;
    let sol = solve_wall(&meas, &options(BlackMode::Individual, 1.0)).unwrap();
    let lut = &sol.profiles[1].curves[0].inverse_lut;
    assert!(lut.windows(2).all(|w| w[1] >= w[0]));
    sol.profiles[1].validate().unwrap();
}

/// A saturated red whose Z is the black's to within the noise: the reading minus black
/// comes out with Z just below 0 (here −0.002 cd/m²), as on a single-chip DLP read
/// through a meter matrix; the solve takes it as 0 and writes valid profiles instead
/// of failing on a red outside the chromaticity diagram.
#[test]
fn a_primary_whose_z_reads_just_below_the_blacks_still_solves() {
    let models = wall([[Curve::Power(2.2); 3]; 3]);
    // One display: its gamut is the common one.
    let mut m = measure_all(&models[..1], 10);
    let black = m[0].black;
    m[0].primaries[0].z = black.z - 0.002;
    let sol = solve_wall(&m, &options(BlackMode::Individual, 1.0)).expect("solve");
    for [x, y] in sol.common_primaries_xy {
        assert!(x >= 0.0 && y > 0.0 && x + y <= 1.0, "{x} {y}");
    }
    assert_eq!(sol.profiles.len(), 1);
}

#[test]
fn nan_and_negative_readings_are_errors() {
    let models = wall([[Curve::Power(2.2); 3]; 3]);
    let base = measure_all(&models, 4);
    let mut m = base.clone();
    m[1].ramps[2][1].1.y = f64::NAN;
    let err = solve_wall(&m, &options(BlackMode::Individual, 1.0)).unwrap_err();
    assert!(
        matches!(err, CalibError::NonFinite { .. }) && err.to_string().contains("display 1"),
        "{err}"
    );
    // A component far below zero is a wrong zero; a dim red's Z a few per mille of
    // its light below zero is the meter's zero-light noise and solves.
    let mut m = base.clone();
    m[1].primaries[0].z = -0.005 * m[1].primaries[0].y;
    solve_wall(&m, &options(BlackMode::Individual, 1.0)).expect("noise below zero solves");
    let mut m = base.clone();
    m[0].black.z = -0.1 * (m[0].black.x + m[0].black.y);
    let err = solve_wall(&m, &options(BlackMode::Individual, 1.0)).unwrap_err();
    assert!(
        matches!(err, CalibError::Negative { .. }) && err.to_string().contains("display 0"),
        "{err}"
    );
    let mut m = base.clone();
    m[2].primaries[1].x = f64::INFINITY;
    assert!(matches!(
        solve_wall(&m, &options(BlackMode::Individual, 1.0)),
        Err(CalibError::NonFinite { .. })
    ));
    assert!(matches!(
        solve_wall(&[], &options(BlackMode::Individual, 1.0)),
        Err(CalibError::InvalidOption { .. })
    ));
    assert!(matches!(
        solve_wall(&base, &options(BlackMode::Individual, 1.2)),
        Err(CalibError::InvalidOption { .. })
    ));
}

#[test]
fn white_targets_and_additivity() {
    let models = wall([[Curve::Power(2.2); 3]; 3]);
    let mut meas = measure_all(&models, 4);
    let mut o = options(BlackMode::Individual, 1.0);
    o.white = WhiteTarget::NativeOf(2);
    let sol = solve_wall(&meas, &o).unwrap();
    let native = (models[2].p[0] + models[2].p[1] + models[2].p[2])
        .xy()
        .unwrap();
    let got = sol.white_xyz_cd_m2.xy().unwrap();
    assert!((native[0] - got[0]).abs() < 1e-12 && (native[1] - got[1]).abs() < 1e-12);
    o.white = WhiteTarget::NativeOf(7);
    assert!(matches!(
        solve_wall(&meas, &o),
        Err(CalibError::InvalidOption { .. })
    ));
    o.white = WhiteTarget::Xy([0.291, 0.300]);
    let sol = solve_wall(&meas, &o).unwrap();
    let got = sol.white_xyz_cd_m2.xy().unwrap();
    assert!((got[0] - 0.291).abs() < 1e-12 && (got[1] - 0.300).abs() < 1e-12);
    assert_eq!(
        sol.profiles[0]
            .measurement
            .additivity_error
            .map(|e| e < 1e-12),
        Some(true)
    );
    // A white 10 % darker than R+G+B (no white segment explains that).
    let w = meas[0].white.unwrap();
    meas[0].white = Some(w - (w - meas[0].black) * 0.1);
    let sol = solve_wall(&meas, &o).unwrap();
    let e = sol.profiles[0].measurement.additivity_error.unwrap();
    let expected = ((w - meas[0].black) * 0.1)
        .to_array()
        .iter()
        .map(|v| v * v)
        .sum::<f64>()
        .sqrt()
        / meas[0].white.unwrap().y;
    assert!((e - expected).abs() < 1e-12, "{e} vs {expected}");
    let display_0 = meas[0].key.to_string();
    assert!(sol.warnings.iter().any(|w| matches!(
        w,
        SolveWarning::Additivity { display, .. } if *display == display_0
    )));
    assert_eq!(sol.profiles[0].display_model, DisplayModel::Additive);
}

/// Issue 12 item 1: single-chip DLPs with white segments of different sizes (and one
/// additive projector beside them) are recognised from the white reading and the
/// profiles invert them exactly; a white within 0.5 % of R+G+B (meter-noise size)
/// stays additive.
#[test]
fn white_segment_displays_are_modelled_and_inverted_in_every_black_mode() {
    let mut models = wall(POWER_CURVES);
    let native = |m: &Model| m.p[0] + m.p[1] + m.p[2];
    models[0].white_segment = native(&models[0]) * 0.25;
    models[1].white_segment = Xyz::from_xy_luminance(0.30, 0.34, 0.1 * native(&models[1]).y);
    for mode in [BlackMode::Individual, BlackMode::Common, BlackMode::Ignore] {
        let sol = solve_wall(&measure_all(&models, 5), &options(mode, 0.95)).unwrap();
        for (i, want) in [(0, true), (1, true), (2, false)] {
            let got = matches!(
                sol.profiles[i].display_model,
                DisplayModel::WhiteSegment { .. }
            );
            assert_eq!(got, want, "display {i}");
        }
        check_usage(&sol, 0.95);
        let de = max_delta_e(&models, &sol, mode);
        eprintln!("{mode:?}: max ΔE2000 {de:.4} with white segments of 25 % and 10 %");
        assert!(de < 0.05, "{mode:?}: {de}");
    }
    // Meter-noise-sized excess light is not a white segment.
    let mut meas = measure_all(&wall([[Curve::Power(2.2); 3]; 3]), 6);
    let w = meas[1].white.unwrap();
    meas[1].white = Some(w + (w - meas[1].black) * 0.005);
    let sol = solve_wall(&meas, &options(BlackMode::Individual, 1.0)).unwrap();
    assert_eq!(sol.profiles[1].display_model, DisplayModel::Additive);
}

#[test]
fn heyewall_sized_wall_of_96_displays() {
    // 48 projectors × 2 eyes: per-display variations of primaries, blacks and gammas.
    let base = wall([[Curve::Power(2.2); 3]; 3]);
    let mut lcg = Lcg::new(99);
    let mut rnd = || lcg.signed();
    let mut models = Vec::new();
    for i in 0..96 {
        let mut m = base[i % 3].clone();
        for c in 0..3 {
            let xy = m.p[c].xy().unwrap();
            let l = m.p[c].y * (1.0 + 0.3 * rnd());
            m.p[c] = Xyz::from_xy_luminance(xy[0] + 0.01 * rnd(), xy[1] + 0.01 * rnd(), l);
            m.curves[c] = Curve::Power(2.2 + 0.3 * rnd());
        }
        m.black = m.black * (1.0 + 0.5 * rnd());
        models.push(m);
    }
    let meas = measure_all(&models, 5);
    let mut o = options(BlackMode::Common, 0.9);
    o.lut_entries = 1024;
    o.white = WhiteTarget::Xy([0.291, 0.300]);
    let t0 = std::time::Instant::now();
    let sol = solve_wall(&meas, &o).unwrap();
    println!(
        "96 displays solved in {:.2} s: white {:.1} cd/m², common black {:.3} cd/m², limited by display {} channel {}",
        t0.elapsed().as_secs_f64(),
        sol.white_xyz_cd_m2.y,
        sol.common_black_xyz_cd_m2.y,
        sol.limiting.display,
        sol.limiting.channel
    );
    assert_eq!(sol.profiles.len(), 96);
    check_usage(&sol, 0.9);
}

#[test]
fn solve_warnings_print_the_report_text() {
    let low = SolveWarning::LowChannelUsage {
        display: "d1".into(),
        channel: Channel::Green,
        usage: 0.1,
        bit_depth: lumiwall_core::BitDepth::TEN,
    };
    assert_eq!(
        low.to_string(),
        "d1: green channel only 10 % used for the white; fewer than 102 of 1024 code values carry the image (consider lowering this channel in the projector's service menu, Kresse 3.3.9)"
    );
    let outside = SolveWarning::WhiteOutsideCommonGamut {
        white_xy: lumiwall_core::Xy::new(0.3127, 0.329),
    };
    assert_eq!(
        outside.to_string(),
        "target white xy (0.3127, 0.3290) lies outside the common gamut triangle"
    );
    let black = SolveWarning::BlackOutsideOwnGamut {
        display: "d0".into(),
        intensities: [-0.001, 0.0, 0.002],
    };
    assert_eq!(
        black.to_string(),
        "d0: black lies outside its own gamut (channel intensities -0.0010, 0.0000, 0.0020)"
    );
    let additivity = SolveWarning::Additivity {
        display: "d2".into(),
        error: 0.1,
        limit: 0.02,
    };
    assert_eq!(
        additivity.to_string(),
        "d2: additivity error 10.0 % (|W − (R+G+B−2·black)| / Y_W) exceeds 2.0 %; the matrix model will be off by about that much"
    );
}

/// ΔE2000 of the white and of two greys (half and a fifth of it) as display `i` shows
/// them through its profile, against the targets.
fn white_and_greys_delta_e(models: &[Model], sol: &WallSolution, i: usize) -> [f64; 3] {
    let w = sol.white_xyz_cd_m2;
    [1.0, 0.5, 0.2].map(|s| {
        let (_, drive) = post_pass(&sol.profiles[i], w * s);
        delta_e2000_xyz(w * s, models[i].show(drive), w)
    })
}

/// A red primary read 0.003 off in x (a colorimeter's noise on a few readings) puts the
/// white and every grey off; the white read whole at the drive the profile gave it
/// brings the white and the greys back (the gains scale the primaries, so the greys
/// move with the white). A whole reading no gain of a few percent explains is left out.
#[test]
fn a_white_read_whole_corrects_a_primary_read_off_and_the_greys_move_with_it() {
    let models = wall(POWER_CURVES);
    let mut meas = measure_all(&models, 12);
    let red = meas[0].primaries[0] - meas[0].black;
    let xy = red.xy().unwrap();
    meas[0].primaries[0] = meas[0].black + Xyz::from_xy_luminance(xy[0] + 0.003, xy[1], red.y);
    meas[0].white = None;
    let opts = options(BlackMode::Individual, 1.0);
    let before = solve_wall(&meas, &opts).unwrap();
    let off = white_and_greys_delta_e(&models, &before, 0);
    let (_, drive) = post_pass(&before.profiles[0], before.white_xyz_cd_m2);
    let whole = |xyz: Xyz| CompositeReading {
        drive,
        xyz,
        readings: 6,
    };
    meas[0].composites = vec![whole(models[0].show(drive))];
    let after = solve_wall(&meas, &opts).unwrap();
    let fixed = white_and_greys_delta_e(&models, &after, 0);
    println!(
        "white, grey 50 %, grey 20 %: ΔE2000 {off:.3?} without, {fixed:.3?} with the whole white"
    );
    assert!(off.iter().all(|d| *d > 0.2), "{off:?}");
    assert!(fixed.iter().all(|d| *d < 0.05), "{fixed:?}");
    // X 6 % high: no plausible gain; the profile stays as without the reading.
    let shown = models[0].show(drive);
    meas[0].composites = vec![whole(Xyz::new(shown.x * 1.06, shown.y, shown.z))];
    let ignored = solve_wall(&meas, &opts).unwrap();
    assert_eq!(
        ignored.profiles[0].xyz_to_drive,
        before.profiles[0].xyz_to_drive
    );
}
