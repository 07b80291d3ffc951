//! Verification catches a wall that no longer matches its profiles: after commissioning
//! the two-projector Infitec pair, 2000 hours of lamp ageing make the displays darker
//! and verify reports it (negative ΔL, tolerance violations), while the fresh wall
//! passes. Also checks the default target set (inside the common gamut, below white,
//! dark colours near 1–2 cd/m²).

use lumiwall_calib::measure::MeasureOptions;
use lumiwall_calib::station::Noise;
use lumiwall_calib::verify::{Target, Tolerances, VerifyOptions, default_targets};
use lumiwall_core::Xyz;
use lumiwall_profiles::BlackMode;

/// The default targets: 20, all below the white, at least 3 dark ones (≤ 2 cd/m²).
fn assert_default_targets_below_white_with_dark_ones(targets: &[Target], white: Xyz) {
    assert_eq!(targets.len(), 20);
    for t in targets {
        assert!(
            t.xyz.y > 0.0 && t.xyz.y < white.y,
            "{}: {}",
            t.name,
            t.xyz.y
        );
    }
    let dark: Vec<_> = targets.iter().filter(|t| t.xyz.y <= 2.0 + 1e-9).collect();
    assert!(dark.len() >= 3, "dark targets: {dark:?}");
}

#[test]
fn verify_passes_the_fresh_wall_and_detects_lamp_ageing() {
    let mut station = crate::support::direct_station("infitec-pair.toml", Noise::None);
    let out = tempfile::tempdir().unwrap();
    let opts =
        crate::support::options_8500k(MeasureOptions::default(), BlackMode::Individual, false);
    let o = station.commission(out.path(), &opts, &mut |_| {}).unwrap();
    let profiles = &o.solution.profiles;

    let targets = default_targets(profiles, 20).unwrap();
    assert_default_targets_below_white_with_dark_ones(&targets, o.solution.white_xyz_cd_m2);

    // Grey balance: this noiseless pair shows |ΔC'| 0.8 and 1.0 on its greys today,
    // over DisplayCAL's 0.5 (issue 12's dark end and grey tracking); this test is
    // about lamp ageing, so its limit is loose like the others here.
    let tol = Tolerances {
        max_de: 2.5,
        median_de: 1.0,
        grey_balance: 1.5,
        ..Tolerances::default()
    };
    let vopts = VerifyOptions::default();
    let fresh = station
        .verify(profiles, &targets, &vopts, &mut |_| {})
        .unwrap();
    assert!(
        fresh.violations(&tol).is_empty(),
        "{:?}",
        fresh.violations(&tol)
    );

    station.wall.advance_hours(2000.0);
    let aged = station
        .verify(profiles, &targets, &vopts, &mut |_| {})
        .unwrap();
    println!("{}", aged.summary_table());
    let v = aged.violations(&tol);
    assert!(!v.is_empty(), "ageing not detected");
    let median_dl = {
        let mut d: Vec<f64> = aged.patches.iter().map(|p| p.delta_l_percent).collect();
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    };
    assert!(
        median_dl < -3.0,
        "aged wall should be darker, median ΔL {median_dl} %"
    );
}
