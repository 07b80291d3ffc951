//! Tone-curve fit and inverse against analytic curves (independent of the code under
//! test): exact recovery of power laws, S-curves from adaptively placed samples, noisy
//! non-monotone ramps, flat regions, steep toes, typed errors and a proptest round trip.
//!
//! `cargo test -p lumiwall-calib --test calibration tone:: -- --nocapture` prints the errors reached.

use crate::common::Lcg;
use lumiwall_calib::CalibError;
use lumiwall_calib::tone::{fit_monotone_named, fit_tone_curve, suggest_next_drive};
use lumiwall_profiles::ToneCurve;
use proptest::prelude::*;

/// Normalised logistic S-curve with a power-law toe (a typical DLP/LCD projector curve).
fn s_curve(d: f64) -> f64 {
    let k = 7.0;
    let sig = |x: f64| 1.0 / (1.0 + (-k * (x - 0.55)).exp());
    let g = |x: f64| (sig(x) - sig(0.0)) / (sig(1.0) - sig(0.0));
    g(d.powf(1.3))
}

fn max_err(curve: impl Fn(f64) -> f64, truth: impl Fn(f64) -> f64) -> f64 {
    (0..=2000)
        .map(|i| i as f64 / 2000.0)
        .map(|d| (curve(d) - truth(d)).abs())
        .fold(0.0, f64::max)
}

fn check_lut(curve: &ToneCurve) {
    assert!(curve.inverse_lut.len() >= 1024);
    assert!(
        curve.inverse_lut.windows(2).all(|w| w[1] >= w[0]),
        "LUT not monotone"
    );
    assert!(curve.inverse_lut.iter().all(|v| (0.0..=1.0).contains(v)));
    assert!(
        curve
            .forward
            .windows(2)
            .all(|w| w[1][1] >= w[0][1] && w[1][0] > w[0][0])
    );
    assert_eq!(curve.forward.first().unwrap(), &[0.0, 0.0]);
    assert_eq!(curve.forward.last().unwrap(), &[1.0, 1.0]);
}

/// Largest |intensity_for(drive_for(i)) − i| over a dense grid of intensities.
fn round_trip_err(curve: &ToneCurve) -> f64 {
    (0..=4000)
        .map(|k| k as f64 / 4000.0)
        .map(|i| (curve.intensity_for(f64::from(curve.drive_for(i as f32))) - i).abs())
        .fold(0.0, f64::max)
}

#[test]
fn power_laws_are_recovered_exactly_from_four_samples() {
    for gamma in [1.0, 1.8, 2.2, 2.4, 2.8] {
        let truth = |d: f64| d.powf(gamma);
        let samples: Vec<(f64, f64)> = [0.0, 0.25, 0.5, 0.75, 1.0]
            .iter()
            .map(|d| (*d, truth(*d)))
            .collect();
        let fit = fit_monotone_named(&samples, "test").unwrap();
        let err = max_err(|d| fit.eval(d), truth);
        println!("gamma {gamma}: 4 samples, max |fit − truth| = {err:.2e}");
        assert!(err < 1e-9, "gamma {gamma}: {err}");
        let inv_err = (1..1000)
            .map(|k| k as f64 / 1000.0)
            .map(|i| (fit.inverse(i) - i.powf(1.0 / gamma)).abs())
            .fold(0.0, f64::max);
        assert!(inv_err < 1e-9, "inverse gamma {gamma}: {inv_err}");
    }
}

#[test]
fn s_curve_from_adaptive_samples() {
    let mut samples: Vec<(f64, f64)> = Vec::new();
    let mut report = Vec::new();
    while samples.len() < 12 {
        let d = suggest_next_drive(&samples).unwrap();
        assert!((0.0..=1.0).contains(&d));
        assert!(
            samples.iter().all(|s| (s.0 - d).abs() > 1e-9),
            "repeated drive {d}"
        );
        samples.push((d, s_curve(d)));
        if samples.len() >= 3 {
            let fit = fit_monotone_named(&samples, "s").unwrap();
            report.push((samples.len(), max_err(|x| fit.eval(x), s_curve)));
        }
    }
    for (n, e) in &report {
        println!("S-curve, {n:2} adaptive samples: max |fit − truth| = {e:.2e}");
    }
    let at = |n: usize| report.iter().find(|r| r.0 == n).unwrap().1;
    assert!(at(8) < 0.01, "8 samples: {}", at(8));
    assert!(at(10) < 0.005, "10 samples: {}", at(10));
    assert!(at(12) < at(6));
    let curve = fit_tone_curve(&samples, 1024).unwrap();
    check_lut(&curve);
    let rt = round_trip_err(&curve);
    println!("S-curve LUT round trip max error {rt:.2e}");
    assert!(rt < 1e-3);
}

#[test]
fn noisy_non_monotone_ramp_gives_monotone_curve() {
    // Deterministic ±4 % multiplicative noise plus ±0.004 absolute noise (meter floor),
    // from a fixed LCG; neighbours near black come out of order.
    let mut lcg = Lcg::new(0x2545_f491_4f6c_dd1d);
    let mut rnd = || lcg.signed();
    let truth = |d: f64| d.powf(2.3);
    let mut samples = Vec::new();
    for k in 0..=30 {
        let d = k as f64 / 30.0;
        samples.push((d, truth(d) * (1.0 + 0.04 * rnd()) + 0.004 * rnd()));
    }
    let inversions = samples.windows(2).filter(|w| w[1].1 < w[0].1).count();
    assert!(inversions >= 1, "the test ramp must be non-monotone");
    let curve = fit_tone_curve(&samples, 2048).unwrap();
    check_lut(&curve);
    let err = max_err(|d| curve.intensity_for(d), |d| truth(d) / samples[30].1);
    let rt = round_trip_err(&curve);
    println!(
        "noisy ramp ({inversions} inversions in the raw samples): max |fit − truth| {err:.3}, LUT round trip {rt:.1e}"
    );
    // Relative intensity is relative to the (noisy) full-drive reading, as in the solve;
    // the fit stays inside the noise band (plus 0.005 for interpolation between samples).
    let full = samples.last().unwrap().1;
    for k in 0..=1000 {
        let d = k as f64 / 1000.0;
        let band = (0.04 * truth(d) + 0.004) / full + 0.005;
        let rel = truth(d) / full;
        assert!((curve.intensity_for(d) - rel).abs() <= band, "drive {d}");
    }
    assert!(rt < 1e-3);
    // A grossly non-monotone ramp still works.
    let bad = vec![(0.2, 0.3), (0.4, 0.1), (0.6, 0.5), (0.8, 0.45), (1.0, 1.0)];
    let c = fit_tone_curve(&bad, 1024).unwrap();
    check_lut(&c);
}

#[test]
fn flat_regions_map_to_their_lowest_drive() {
    // Dead zone below drive 0.1, clipping at full intensity from drive 0.8.
    let truth = |d: f64| (((d - 0.1) / 0.7).clamp(0.0, 1.0)).powf(2.0);
    let samples: Vec<(f64, f64)> = (0..=20)
        .map(|k| k as f64 / 20.0)
        .map(|d| (d, truth(d)))
        .collect();
    let curve = fit_tone_curve(&samples, 1024).unwrap();
    check_lut(&curve);
    let top = curve.drive_for(1.0);
    let low = curve.drive_for(0.01);
    println!(
        "flat regions: drive_for(1) = {top:.4} (truth 0.8), drive_for(0.01) = {low:.4} (truth 0.17)"
    );
    assert!((top - 0.8).abs() < 1e-3, "{top}");
    assert!((low - 0.17).abs() < 2e-3, "{low}");
    assert_eq!(curve.drive_for(0.0), 0.0);
    assert!(round_trip_err(&curve) < 2e-3);
}

#[test]
fn steep_toe_round_trips() {
    let truth = |d: f64| d.powi(4);
    let samples: Vec<(f64, f64)> = [0.1, 0.3, 0.5, 0.7, 0.9, 1.0]
        .iter()
        .map(|d| (*d, truth(*d)))
        .collect();
    let curve = fit_tone_curve(&samples, 4096).unwrap();
    check_lut(&curve);
    let rt = round_trip_err(&curve);
    // Drive for 1 % intensity: 0.01^(1/4) = 0.3162.
    let d = curve.drive_for(0.01);
    println!("steep toe d^4: round trip {rt:.1e}, drive_for(0.01) = {d:.5} (truth 0.31623)");
    assert!((f64::from(d) - 0.316_227_766).abs() < 1e-4);
    assert!(rt < 1e-3);
}

#[test]
fn unusable_ramps_are_typed_errors() {
    assert!(matches!(
        fit_tone_curve(&[(1.0, 1.0)], 1024),
        Err(CalibError::TooFewSamples { .. })
    ));
    assert!(matches!(
        fit_tone_curve(&[], 1024),
        Err(CalibError::TooFewSamples { .. })
    ));
    assert!(matches!(
        fit_tone_curve(&[(0.5, f64::NAN), (1.0, f64::NAN)], 1024),
        Err(CalibError::NonFinite { .. })
    ));
    assert!(matches!(
        fit_tone_curve(&[(0.5, 0.0), (1.0, 0.0)], 1024),
        Err(CalibError::NoSignal { .. })
    ));
    assert!(matches!(
        fit_tone_curve(&[(0.5, -0.01), (1.0, -0.02)], 1024),
        Err(CalibError::NoSignal { .. })
    ));
    assert!(matches!(
        fit_tone_curve(&[(0.5, 0.2), (1.0, 1.0)], 100),
        Err(CalibError::InvalidOption { .. })
    ));
    assert!(matches!(
        fit_tone_curve(&[(1.5, 0.2), (1.0, 1.0)], 1024),
        Err(CalibError::InvalidOption { .. })
    ));
    let msg = fit_monotone_named(&[(1.0, 0.0)], "display 3 green ramp")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("display 3 green ramp"), "{msg}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]
    #[test]
    fn random_ramps_round_trip(
        gamma in 0.8f64..3.2,
        drives in proptest::collection::vec(0.02f64..0.98, 2..10),
        noise in proptest::collection::vec(-0.02f64..0.02, 10),
    ) {
        let mut samples: Vec<(f64, f64)> = drives
            .iter()
            .zip(&noise)
            .map(|(d, n)| (*d, d.powf(gamma) + n))
            .collect();
        samples.push((1.0, 1.0));
        let curve = fit_tone_curve(&samples, 1024).unwrap();
        check_lut(&curve);
        prop_assert!(round_trip_err(&curve) < 2e-3);
    }
}
