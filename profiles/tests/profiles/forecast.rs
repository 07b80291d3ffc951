//! The lamp-life forecast (`store::forecast`) on synthetic histories whose decay is
//! known in closed form: the predicted dates against the exact ones.

use crate::common::profile_with;
use lumiwall_core::Channel;
use lumiwall_profiles::store::{
    CommissionRun, DecayLaw, DisplayForecast, ForecastOptions, LampReading, ProfileStore,
    Timestamp, forecast::forecast,
};
use lumiwall_profiles::{DisplayProfile, Eye};

const WALL: &str = "forecast-wall";

/// Full-drive luminance of R, G, B of a new lamp (cd/m²).
const NEW_LAMP_Y: [f64; 3] = [25.0, 70.0, 8.0];

/// The forecast's settings for these histories, whose light falls exponentially.
fn exponential() -> ForecastOptions {
    ForecastOptions {
        decay: DecayLaw::Exponential,
        ..ForecastOptions::default()
    }
}

fn t0() -> Timestamp {
    "2026-06-01T02:00:00Z".parse().unwrap()
}

/// `hours` after [`t0`].
fn at(hours: f64) -> Timestamp {
    t0().checked_add(jiff::SignedDuration::from_secs_f64(hours * 3600.0))
        .unwrap()
}

/// A deterministic ±`amplitude` relative wobble for reading `i` (meter noise).
fn wobble(i: usize, amplitude: f64) -> f64 {
    1.0 + amplitude * ((i as f64 * 2.399).sin() * 0.7 + (i as f64 * 0.913).cos() * 0.3)
}

/// A profile of `display` whose channels give `light` (relative to a new lamp) and
/// whose common white needs `usage`, kept within `headroom`.
fn profile_at(display: u32, light: [f64; 3], usage: [f64; 3], headroom: f64) -> DisplayProfile {
    // chromaticities of common projector primaries, scaled to the luminance
    let xy = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];
    let primaries = std::array::from_fn(|c| {
        let y = NEW_LAMP_Y[c] * light[c];
        let [x, yy] = xy[c];
        [x / yy * y, y, (1.0 - x - yy) / yy * y]
    });
    let mut p = profile_with(WALL, display, Eye::Mono, primaries, [0.2, 0.2, 0.3], usage);
    p.headroom = headroom;
    p
}

/// Nightly profiles (every 24 h from `first_h`) with per-channel light `light(s)` at
/// `s` hours since `lamp_h`, and the newest profile's usage.
fn nights(
    display: u32,
    first_h: f64,
    count: usize,
    light: impl Fn(f64) -> [f64; 3],
    usage: [f64; 3],
    noise: f64,
) -> Vec<(Timestamp, DisplayProfile)> {
    (0..count)
        .map(|i| {
            let h = first_h + 24.0 * i as f64;
            let l = light(h).map(|v| v * wobble(i + display as usize * 31, noise));
            (at(h), profile_at(display, l, usage, 0.95))
        })
        .collect()
}

fn fitted(
    f: &DisplayForecast,
) -> (
    &Vec<lumiwall_profiles::store::ChannelForecast>,
    usize,
    &Vec<Timestamp>,
) {
    match f {
        DisplayForecast::Fitted {
            channels,
            points,
            lamp_changes,
            ..
        } => (channels, *points, lamp_changes),
        other => panic!("not fitted: {other:?}"),
    }
}

fn days_between(a: Timestamp, b: Timestamp) -> f64 {
    b.duration_since(a).as_secs_f64() / 86_400.0
}

#[test]
fn steady_exponential_decay_is_forecast_within_a_day_and_inside_its_interval() {
    let rate_per_h = [2e-4, 4e-4, 1e-4];
    let usage = [0.85, 0.80, 0.90];
    let light = |h: f64| std::array::from_fn(|c| (-rate_per_h[c] * h).exp());
    let history = nights(0, 0.0, 40, light, usage, 0.002);
    let newest_h = 39.0 * 24.0;
    let out = forecast(&history, &exponential());
    assert_eq!(out.len(), 1);
    let (channels, points, changes) = fitted(&out[0]);
    assert_eq!((points, changes.len()), (40, 0));
    for (c, ch) in channels.iter().enumerate() {
        // exact: the true light falls to usage/headroom of the newest *reading* (the
        // usage was solved from it, meter noise and all)
        let read = wobble(39, 0.002);
        let exact_h = newest_h - (usage[c] / 0.95_f64 * read).ln() / rate_per_h[c];
        let x = ch.leaves_headroom.expect("within the horizon");
        let miss = days_between(at(exact_h), x.utc).abs();
        println!(
            "{:?}: decay {:.2} %/1000 h (exact {:.2}), leaves headroom {} (exact {}), miss {:.2} d, \
             interval {} … {}",
            ch.channel,
            ch.decay_pct_per_1000_h,
            100.0 * 1000.0 * rate_per_h[c],
            x.utc,
            at(exact_h),
            miss,
            x.earliest_utc,
            x.latest_utc
        );
        assert!(miss < 1.0, "{:?}: {miss} days off", ch.channel);
        assert!(x.earliest_utc <= at(exact_h) && at(exact_h) <= x.latest_utc);
        assert!((ch.decay_pct_per_1000_h / (1e5 * rate_per_h[c]) - 1.0).abs() < 0.05);
        let full = ch.beyond_full_drive.expect("within the horizon");
        let exact_full_h = newest_h - (usage[c] * read).ln() / rate_per_h[c];
        assert!(days_between(at(exact_full_h), full.utc).abs() < 1.5);
    }
    let (first, _) = out[0].first_to_leave_headroom().unwrap();
    assert_eq!(first, Channel::Green);
}

/// A UHP lamp loses a quarter of its light in its first hundred hours, then slowly.
fn uhp(h: f64, tau_h: f64) -> [f64; 3] {
    let l = (1.0 + 0.3 * (-h / tau_h).exp()) / 1.3 * (-1e-4 * h).exp();
    [l; 3]
}

#[test]
fn a_uhp_burn_in_is_fitted_and_not_mistaken_for_the_steady_decay() {
    let usage = [0.85; 3];
    let history = nights(0, 0.0, 30, |h| uhp(h, 100.0), usage, 0.001);
    let newest_h = 29.0 * 24.0;
    let exact_h = crossing_h(|h| uhp(h, 100.0)[0], newest_h, usage[0] / 0.95);
    let with = forecast(&history, &exponential());
    let without = forecast(
        &history,
        &ForecastOptions {
            burn_in: false,
            ..exponential()
        },
    );
    let predicted = |f: &DisplayForecast| fitted(f).0[1].leaves_headroom.unwrap().utc;
    let (miss_with, miss_without) = (
        days_between(at(exact_h), predicted(&with[0])),
        days_between(at(exact_h), predicted(&without[0])),
    );
    println!(
        "exact {}: with the burn-in term {} ({miss_with:+.1} d), without {} ({miss_without:+.1} d)",
        at(exact_h),
        predicted(&with[0]),
        predicted(&without[0])
    );
    let tau = fitted(&with[0]).0[1].burn_in_tau_h.expect("burn-in fitted");
    println!("fitted burn-in time constant {tau:.0} h (exact 100)");
    assert!((tau / 100.0 - 1.0).abs() < 0.2, "{tau}");
    assert!(miss_with.abs() < 2.0, "{miss_with}");
    // a plain exponential reads the burn-in as steady decay: far too early
    assert!(miss_without < -10.0, "{miss_without}");
    let steady = fitted(&with[0]).0[1].decay_pct_per_1000_h;
    assert!(
        (steady - 10.0).abs() < 0.5,
        "steady decay {steady} %/1000 h, exact 10"
    );
    // a lamp whose burn-in is 50 % slower: its own time constant is found
    let slower = nights(0, 0.0, 30, |h| uhp(h, 150.0), usage, 0.001);
    let exact_h = crossing_h(|h| uhp(h, 150.0)[0], newest_h, usage[0] / 0.95);
    let out = forecast(&slower, &exponential());
    let x = fitted(&out[0]).0[1].leaves_headroom.unwrap();
    let miss = days_between(at(exact_h), x.utc);
    let lead_days = (exact_h - newest_h) / 24.0;
    println!(
        "burn-in 150 h: {miss:+.1} d of a {lead_days:.0}-day lead, interval {} … {}",
        x.earliest_utc, x.latest_utc
    );
    assert!(miss.abs() < 0.05 * lead_days, "{miss}");
    assert!(x.earliest_utc <= at(exact_h) && at(exact_h) <= x.latest_utc);
}

/// First hour after `from_h` at which `light` falls to `fraction` of its value there.
fn crossing_h(light: impl Fn(f64) -> f64, from_h: f64, fraction: f64) -> f64 {
    let target = light(from_h) * fraction;
    let (mut a, mut b) = (from_h, from_h + 20_000.0);
    for _ in 0..100 {
        let m = 0.5 * (a + b);
        if light(m) > target { a = m } else { b = m }
    }
    a
}

#[test]
fn a_lamp_change_restarts_the_fit_at_the_new_lamp() {
    let old = |h: f64| [(-8e-4 * h).exp(); 3];
    let change_h = 20.0 * 24.0;
    let new = move |h: f64| [(-2e-4 * (h - change_h)).exp(); 3];
    let mut history = nights(0, 0.0, 20, old, [0.9; 3], 0.001);
    history.extend(nights(0, change_h, 10, new, [0.8; 3], 0.001));
    let opts = ForecastOptions {
        burn_in: false,
        ..exponential()
    };
    let out = forecast(&history, &opts);
    let (channels, points, changes) = fitted(&out[0]);
    assert_eq!(changes, &vec![at(change_h)]);
    assert_eq!(points, 10);
    for ch in channels {
        assert!(
            (ch.decay_pct_per_1000_h - 20.0).abs() < 1.5,
            "{:?}: {} %/1000 h, the new lamp's is 20",
            ch.channel,
            ch.decay_pct_per_1000_h
        );
    }
}

#[test]
fn too_short_a_history_is_said_instead_of_a_date() {
    let history = nights(0, 0.0, 2, |h| [(-1e-3 * h).exp(); 3], [0.9; 3], 0.0);
    let out = forecast(&history, &exponential());
    assert!(matches!(
        out[0],
        DisplayForecast::NotEnoughHistory { points: 2, .. }
    ));
    assert!(out[0].first_to_leave_headroom().is_none());
}

#[test]
fn steady_light_gives_no_date_within_the_horizon_and_overused_channels_leave_now() {
    let steady = nights(0, 0.0, 30, |_| [1.0; 3], [0.85; 3], 0.002);
    let out = forecast(&steady, &exponential());
    let (channels, ..) = fitted(&out[0]);
    assert!(
        channels.iter().all(|c| c.leaves_headroom.is_none()),
        "{channels:#?}"
    );
    // usage above the headroom already: the crossing is the newest profile itself
    let over = nights(
        1,
        0.0,
        10,
        |h| [(-1e-4 * h).exp(); 3],
        [0.97, 0.5, 0.5],
        0.0,
    );
    let out = forecast(&over, &exponential());
    let (channel, x) = out[0].first_to_leave_headroom().unwrap();
    assert_eq!((channel, x.utc), (Channel::Red, at(9.0 * 24.0)));
}

#[test]
fn the_store_forecasts_every_display_of_a_wall_from_its_runs() {
    let mut store = ProfileStore::open_in_memory().unwrap();
    let fast = nights(0, 0.0, 12, |h| [(-6e-4 * h).exp(); 3], [0.8; 3], 0.001);
    let slow = nights(1, 0.0, 12, |h| [(-1e-4 * h).exp(); 3], [0.8; 3], 0.001);
    for (a, b) in fast.iter().zip(&slow) {
        let run = CommissionRun::new(WALL, a.0);
        store.record(&run, &[a.1.clone(), b.1.clone()]).unwrap();
    }
    let out = store.forecast_wall(WALL, &exponential()).unwrap();
    assert_eq!(out.len(), 2);
    let first = |i: usize| out[i].first_to_leave_headroom().unwrap().1.utc;
    assert_eq!(out[0].display().display, 0);
    assert!(first(0) < first(1), "the faster lamp leaves first");
}

#[test]
fn nightly_lamp_readings_between_runs_give_the_same_forecast_as_profiles() {
    // One run at the start, then eleven nights in which only the lamp readings of a
    // check that rewrote nothing are stored: the forecast must use them all.
    let history = nights(0, 0.0, 12, |h| [(-4e-4 * h).exp(); 3], [0.8; 3], 0.0);
    let mut store = ProfileStore::open_in_memory().unwrap();
    store
        .record(
            &CommissionRun::new(WALL, history[0].0),
            &[history[0].1.clone()],
        )
        .unwrap();
    for (t, p) in &history[1..] {
        let reading = LampReading::of_profile(*t, p);
        assert_eq!(
            store
                .record_lamp_readings(WALL, "recalibrate", &[reading])
                .unwrap(),
            1
        );
    }
    assert_eq!(store.lamp_readings(WALL, 0).unwrap().len(), 12);
    let from_store = store.forecast_wall(WALL, &exponential()).unwrap();
    let from_profiles = forecast(&history, &exponential());
    assert_eq!(from_store, from_profiles);
    let (_, points, _) = fitted(&from_store[0]);
    assert_eq!(points, 12);
}

#[test]
fn a_lamp_reading_that_is_not_finite_or_of_another_wall_is_refused_and_nothing_is_written() {
    let mut store = ProfileStore::open_in_memory().unwrap();
    let good = LampReading::of_profile(at(0.0), &profile_at(0, [1.0; 3], [0.8; 3], 0.9));
    let mut dark = LampReading::of_profile(at(24.0), &profile_at(1, [1.0; 3], [0.8; 3], 0.9));
    dark.primaries_y_cd_m2[2] = 0.0;
    let mut unspanned = good.clone();
    unspanned.utc = at(48.0);
    unspanned.channel_usage[0] = f64::INFINITY;
    for bad in [dark, unspanned] {
        let e = store
            .record_lamp_readings(WALL, "recalibrate", &[good.clone(), bad])
            .unwrap_err();
        assert!(e.to_string().contains("lamp reading of"), "{e}");
    }
    let e = store
        .record_lamp_readings("other-wall", "recalibrate", std::slice::from_ref(&good))
        .unwrap_err();
    assert!(e.to_string().contains("belongs to wall"), "{e}");
    assert!(store.lamp_readings(WALL, 0).unwrap().is_empty());
    // the same display and time twice is refused
    store
        .record_lamp_readings(WALL, "recalibrate", std::slice::from_ref(&good))
        .unwrap();
    let e = store
        .record_lamp_readings(WALL, "recalibrate", &[good])
        .unwrap_err();
    assert!(e.to_string().contains("already has a lamp reading"), "{e}");
}

#[test]
fn a_discharge_lamp_whose_light_falls_linearly_is_forecast_by_the_linear_law_and_late_by_the_exponential()
 {
    // the virtual wall's UHP lamp after its burn-in: 3 % of the new light per 1000 h;
    // 30 nightly readings (720 h) at 0.8 of the new light, the white needs 0.85 of it now
    let light = |h: f64| [0.8 - 0.03 * h / 1000.0; 3];
    let usage = [0.85; 3];
    let history = nights(0, 0.0, 30, light, usage, 0.0);
    let newest_h = 24.0 * 29.0;
    // beyond full drive when the light is 0.85 of the newest's
    let exact_h = newest_h + (1.0 - 0.85) * light(newest_h)[0] / (0.03 / 1000.0);
    let days_late = |law: DecayLaw| {
        let opts = ForecastOptions {
            decay: law,
            ..ForecastOptions::default()
        };
        let out = forecast(&history, &opts);
        let (_, x) = out[0]
            .first_beyond_full_drive()
            .expect("a date within the horizon");
        days_between(at(exact_h), x.utc)
    };
    let lead_days = (exact_h - newest_h) / 24.0;
    assert!(
        days_late(DecayLaw::Linear).abs() < 1.0,
        "{}",
        days_late(DecayLaw::Linear)
    );
    // the exponential law keeps the relative rate of today: late by about 8 % of the lead
    let late = days_late(DecayLaw::Exponential);
    assert!(
        late > 0.05 * lead_days && late < 0.12 * lead_days,
        "{late} of {lead_days}"
    );
}
