//! The wall classes of issue 12 as fixture walls (non-additive Infitec DLPs, a cold
//! start, an off-axis meter on a gain screen, 8-bit inputs with a very weak channel):
//! each commissions with the noiseless meter, the solve flags what the matrix model
//! cannot represent on exactly the walls that have it, and the verification figures
//! are printed (the acceptance is not met on all of them yet).

mod support;

use lumiwall_calib::measure::MeasureOptions;
use lumiwall_calib::solve::SolveWarning;
use lumiwall_calib::station::Noise;
use lumiwall_calib::verify::{VerifyOptions, chart_targets};
use lumiwall_profiles::BlackMode;

/// Commissions `file` noiseless and verifies it with the 51-patch chart: the solve's
/// warnings, printed with the verification's OVERALL row.
fn commission_and_verify(file: &str) -> Vec<SolveWarning> {
    let mut station = support::direct_station(file, Noise::None);
    let out = tempfile::tempdir().expect("tmp");
    let opts = support::options_8500k(MeasureOptions::default(), BlackMode::Individual, false);
    let o = station
        .commission(out.path(), &opts, &mut |_| {})
        .expect("commission");
    let profiles = &o.solution.profiles;
    let targets = chart_targets(profiles).expect("chart");
    let report = station
        .verify(profiles, &targets, &VerifyOptions::default(), &mut |_| {})
        .expect("verify");
    let table = report.summary_table();
    let overall = table
        .lines()
        .find(|l| l.starts_with("OVERALL"))
        .unwrap_or("");
    eprintln!("{file}: {overall}");
    o.solution.warnings
}

fn additivity_warnings(w: &[SolveWarning]) -> usize {
    w.iter()
        .filter(|w| matches!(w, SolveWarning::Additivity { .. }))
        .count()
}

#[test]
fn the_white_segment_dlp_wall_is_flagged_non_additive_on_every_display() {
    let w = commission_and_verify("dlp-infitec-2x1.toml");
    assert_eq!(additivity_warnings(&w), 4, "{w:?}");
}

#[test]
fn the_additive_wall_classes_commission_without_an_additivity_warning() {
    for file in [
        "cold-start-2x2.toml",
        "offaxis-gain-2x1.toml",
        "weak-channel-3x1.toml",
    ] {
        let w = commission_and_verify(file);
        assert_eq!(additivity_warnings(&w), 0, "{file}: {w:?}");
    }
}

#[test]
fn a_very_weak_blue_limits_the_white_and_says_which_channels_are_barely_used() {
    let w = commission_and_verify("weak-channel-3x1.toml");
    let low = w
        .iter()
        .filter(|w| w.to_string().contains("used for the white"))
        .count();
    assert!(low >= 3, "{w:?}");
}
