//! Verification catches a wall that no longer matches its profiles: after commissioning
//! the two-projector Infitec pair, 2000 hours of lamp ageing make the displays darker
//! and verify reports it (negative ΔL, tolerance violations), while the fresh wall
//! passes. Also checks the default target set (inside the common gamut, below white,
//! dark colours near 1–2 cd/m²).

use std::path::PathBuf;

use lumiwall_calib::commission::{CommissionOptions, commission};
use lumiwall_calib::measure::{MeasureOptions, Rig};
use lumiwall_calib::solve::{SolveOptions, WhiteTarget};
use lumiwall_calib::verify::{Tolerances, VerifyOptions, default_targets, verify_wall};
use lumiwall_devices::sim::{MeterModel, VirtualWall};

#[test]
fn verify_detects_lamp_ageing() {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/walls/infitec-pair.toml");
    let wall = VirtualWall::from_toml_file(&path).unwrap();
    let displays = wall.displays();
    let mut pattern = wall.pattern_output();
    let mut positioner = wall.positioner();
    let mut meter = wall.meter(MeterModel::noiseless());
    let mut rig = Rig {
        pattern: &mut pattern,
        meter: &mut meter,
        positioner: &mut positioner,
    };
    let out = tempfile::tempdir().unwrap();
    let opts = CommissionOptions {
        measure: MeasureOptions::default(),
        solve: SolveOptions {
            white: WhiteTarget::Cct(8500.0),
            ..SolveOptions::default()
        },
        resume: false,
        meter_correction: true,
    };
    let o = commission(
        &wall.name(),
        &displays,
        &mut rig,
        out.path(),
        &opts,
        &mut |_| {},
    )
    .unwrap();
    let profiles = &o.solution.profiles;

    let targets = default_targets(profiles, 20).unwrap();
    assert_eq!(targets.len(), 20);
    let white = o.solution.white_xyz_cd_m2;
    for t in &targets {
        assert!(
            t.xyz.y > 0.0 && t.xyz.y < white.y,
            "{}: {}",
            t.name,
            t.xyz.y
        );
    }
    let dark: Vec<_> = targets.iter().filter(|t| t.xyz.y <= 2.0 + 1e-9).collect();
    assert!(dark.len() >= 3, "dark targets: {dark:?}");

    let tol = Tolerances {
        max_de: 2.5,
        median_de: 1.0,
        ..Tolerances::default()
    };
    let vopts = VerifyOptions::default();
    let fresh = verify_wall(&mut rig, &displays, profiles, &targets, &vopts, &mut |_| {}).unwrap();
    assert!(
        fresh.violations(&tol).is_empty(),
        "{:?}",
        fresh.violations(&tol)
    );

    wall.advance_hours(2000.0);
    let aged = verify_wall(&mut rig, &displays, profiles, &targets, &vopts, &mut |_| {}).unwrap();
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
