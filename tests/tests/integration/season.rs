//! A short season of nightly recalibrations (`lumiwall bench season`) on a two-display
//! virtual wall: every night stays within the verify tolerance against the
//! simulator's truth, a night costs far fewer readings than the commissioning, the
//! nights that rewrite nothing still feed the forecast, and the lamp change is found on
//! its night and nowhere else.

use lumiwall_bench::season::{self, SeasonBench};
use lumiwall_calib::recalibrate::{DriftLimits, Verdict};
use lumiwall_calib::solve::SolveOptions;
use lumiwall_calib::station::{MeterChoice, Noise};
use lumiwall_calib::verify::Tolerances;
use lumiwall_profiles::store::{ForecastOptions, ProfileStore, Timestamp};

fn bench(out: &std::path::Path) -> SeasonBench {
    SeasonBench {
        wall: crate::support::wall_path("mono-2x1.toml"),
        nights: 10,
        lamp_hours_per_day: 24.0,
        lamp_change_night: Some(8),
        lamp_change_display: None,
        forecast_night: 6,
        forecast: ForecastOptions::default(),
        noise: Noise::None,
        meter: MeterChoice::Direct,
        solve: SolveOptions {
            headroom: 0.85,
            ..SolveOptions::default()
        },
        limits: DriftLimits::default(),
        full_check_every_nights: 3,
        tolerances: Tolerances::default(),
        averaging: lumiwall_calib::measure::averaging::Averaging::Fixed(1),
        out: out.to_path_buf(),
        start_utc: "2026-01-01T02:00:00Z".parse::<Timestamp>().unwrap(),
    }
}

#[test]
fn a_short_season_stays_within_tolerance_and_finds_its_lamp_change() {
    let dir = tempfile::tempdir().unwrap();
    let b = bench(dir.path());
    let mut seen = 0;
    let (rows, summary) = season::run(&b, &mut |_| seen += 1).unwrap();
    assert_eq!(seen, 11, "night 0 and ten nights reported as they finish");
    assert_eq!(summary.within, 10, "{rows:#?}");
    // every night is a recalibration that costs under half a commissioning
    let (commission_readings, _) = summary.commission_cost;
    for r in &rows[1..] {
        assert!(r.verdict.is_some());
        assert!(
            2 * r.readings < commission_readings,
            "night {}: {} readings",
            r.night,
            r.readings
        );
    }
    // the new lamp is brighter: that night rewrites the profiles and keeps the white
    let change = &rows[8];
    assert!(change.lamp_changed.is_some());
    assert_eq!(change.verdict, Some(Verdict::Recalibrated));
    // (the same white, up to the rounding of solving it again)
    let kept = (change.white_cd_m2 - rows[0].white_cd_m2).abs() / rows[0].white_cd_m2;
    assert!(
        kept < 1e-12,
        "{} vs {}",
        change.white_cd_m2,
        rows[0].white_cd_m2
    );
    let (key, found) = summary.lamp_change.clone().unwrap();
    assert_eq!(Some(&key), change.lamp_changed.as_ref());
    assert!(
        found,
        "the store's history finds the lamp change on night 8"
    );
    assert!(
        summary.false_lamp_changes.is_empty(),
        "{:?}",
        summary.false_lamp_changes
    );
    // the forecast was checked for both displays, each date is within the horizon in
    // the truth, and the predictions are within 5 % of the lead time
    assert_eq!(summary.forecast.len(), 2);
    for f in &summary.forecast {
        assert!(f.true_days.is_some(), "{f:?}");
        assert!(f.error_pct_of_lead < 5.0, "{f:?}");
    }
    let of_horizon = summary
        .forecast_error_pct_of_horizon
        .expect("a forecast was made");
    assert!(of_horizon < 2.0, "{:#?}", summary.forecast);
    assert!(summary.plot.is_file());
}

#[test]
fn nights_that_rewrite_nothing_still_store_their_lamp_readings() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = bench(dir.path());
    b.nights = 3;
    b.lamp_change_night = None;
    let (rows, _) = season::run(&b, &mut |_| {}).unwrap();
    let unchanged = rows
        .iter()
        .filter(|r| r.verdict == Some(Verdict::Unchanged))
        .count();
    assert!(
        unchanged > 0,
        "aged 24 h a night, the wall holds its calibration at first"
    );
    let store = ProfileStore::open_existing(&dir.path().join("season.lumistore")).unwrap();
    // one reading per night and display: the commissioning's profile, then either a
    // recalibration's profile or the night's lamp reading
    for display in 0..2 {
        assert_eq!(store.lamp_readings("mono-2x1", display).unwrap().len(), 4);
    }
}

#[test]
fn a_season_refuses_settings_that_describe_none() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = bench(dir.path());
    b.lamp_hours_per_day = 25.0;
    let e = season::run(&b, &mut |_| {}).unwrap_err();
    assert!(e.to_string().contains("at most 24"), "{e}");
    b.lamp_hours_per_day = 12.0;
    b.nights = 0;
    assert!(season::run(&b, &mut |_| {}).is_err());
}
