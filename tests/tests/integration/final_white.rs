//! A white lowered after the commission (the camera stage's strict uniformity lowers
//! it to what the darkest point of the wall can show) is shown at its luminance once
//! the tone curves are read again where it sits
//! ([`lumiwall_calib::commission::final_white`]); read through curves sampled at the
//! old white it is off by the curves' interpolation error between ramp samples
//! (heyewall-48, noiseless K-10-A: 1.25 % with PCHIP, 0.37 % with the monotone spline,
//! 0.17 % once the grey-drive pass reads each channel's widest gap, 0.02 % read again;
//! 0.14 % and 0.06 % once the solve smoothed the samples within the K-10-A's stated
//! noise, [`lumiwall_calib::tone::smoothing`], which moves the noiseless emulator's exact
//! samples by up to about half that noise; 0.30 % and 0.07 % at c586d54; 0.17 % and
//! 0.04 % once the solve smoothed within the noise the repeated readings show,
//! [`lumiwall_calib::measure::noise_seen`], none here; the test prints its figures).

use lumiwall_calib::commission::CommissionOutcome;
use lumiwall_calib::commission::final_white::resample_at_final_white;
use lumiwall_calib::measure::MeasureOptions;
use lumiwall_calib::measure::grey_drives::SPLIT_READINGS;
use lumiwall_calib::spatial::{SpotReader, Truth};
use lumiwall_calib::station::{MeterChoice, Noise, Station, StationOptions};
use lumiwall_calib::verify::{drive_for, expected_shown};
use lumiwall_core::Xyz;
use lumiwall_profiles::apply::{ApplyOptions, PreparedProfile};
use lumiwall_profiles::{BlackMode, DisplayProfile};

/// The share of the solved white the lowered white keeps (heyewall-48's strict
/// uniformity keeps 33.8 of 49.4 cd/m²).
const LOWERED: f64 = 0.684;

/// The profiles with their common white lowered to `LOWERED` of the solved one, as
/// `fit_white_to_flat_fields` lowers it.
fn lowered(profiles: &[DisplayProfile]) -> Vec<DisplayProfile> {
    let mut out = profiles.to_vec();
    for p in &mut out {
        p.target_white_xyz_cd_m2 = p.target_white_xyz_cd_m2.map(|v| v * LOWERED);
        p.channel_usage = p.channel_usage.map(|v| v * LOWERED);
    }
    out
}

/// Largest relative luminance error (%) of each display's white at its centre, read by
/// the simulator's truth.
fn worst_white_error_percent(station: &Station, profiles: &[DisplayProfile]) -> f64 {
    let mut truth = Truth(&station.wall);
    let mut worst = 0.0f64;
    for info in station.displays() {
        let p = profiles
            .iter()
            .find(|p| p.display.display == info.id.0 && p.display.eye == info.eye)
            .expect("profile");
        let prepared = PreparedProfile::new(p, &ApplyOptions::default()).expect("prepared");
        let white = Xyz::from_array(p.target_white_xyz_cd_m2);
        let uv = [0.5, 0.5];
        let shown = truth
            .read(&info, uv, drive_for(&prepared, white, uv))
            .expect("truth");
        let expected = expected_shown(p, white);
        worst = worst.max((100.0 * (shown.y / expected.y - 1.0)).abs());
    }
    worst
}

#[test]
fn a_white_lowered_after_the_commission_is_shown_at_its_luminance_once_the_curves_are_read_there() {
    // The K-10-A's driver states its 0.2 cd/m² low-light limit, so the dark readings are
    // repeated and the ramps get fewer samples than with the direct meter: the plan of
    // `lumiwall commission`.
    let options = StationOptions::new(MeterChoice::Emulated, Noise::None);
    let mut station =
        Station::open(&crate::support::wall_path("heyewall-48.toml"), &options).expect("station");
    let out = tempfile::tempdir().expect("tmp");
    let opts =
        crate::support::options_8500k(MeasureOptions::default(), BlackMode::Individual, false);
    let outcome: CommissionOutcome = station
        .commission(out.path(), &opts, &mut |_| {})
        .expect("commission");
    let at_solved = worst_white_error_percent(&station, &outcome.solution.profiles);
    let finals = lowered(&outcome.solution.profiles);
    let before = worst_white_error_percent(&station, &finals);
    let displays = station.displays();
    let resampled = resample_at_final_white(
        &displays,
        &mut station.rig(),
        &outcome,
        &finals,
        &opts,
        &mut |_| {},
    )
    .expect("resample");
    let after = worst_white_error_percent(&station, &lowered(&resampled.outcome.solution.profiles));
    println!(
        "white at the centres, worst |ΔY|: solved white {at_solved:.3} %; lowered to {LOWERED}: \
         {before:.3} % through the commission's curves, {after:.3} % once they are read there \
         ({} readings over {} displays)",
        resampled.readings,
        displays.len()
    );
    assert!(
        at_solved < 0.2,
        "the solved white is read exactly: {at_solved} %"
    );
    assert!(
        before > 0.1 && before > 2.0 * after,
        "the commission's curves miss the lowered white: {before} % (read again: {after} %)"
    );
    assert!(
        after < 0.1,
        "read again, the lowered white is right: {after} %"
    );
    // Per display at most: each channel at the white's drives twice, in its widest gap
    // and in the 1 cd/m² grey once (one reading above the K-10-A's 0.2 cd/m² limit),
    // and the darkest grey read whole with `SPLIT_READINGS` (the pass's budget leaves
    // the 1 cd/m² grey two readings a channel, for a dim wall).
    let most = 3 * 2 + 3 + 3 + SPLIT_READINGS;
    assert!(
        resampled.readings as usize <= most as usize * displays.len(),
        "{} readings",
        resampled.readings
    );
}
