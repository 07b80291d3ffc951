//! `calib::measure` against an analytic display and a scripted meter: reading budget,
//! adaptive ramps, low-light policy, retries of transient errors and the typed error of
//! a meter that stops answering.

use lumiwall_calib::measure::{
    LowLight, MeasureError, MeasureOptions, Rig, display_key, measure_display, relative_intensity,
};
use lumiwall_devices::{
    Colorimeter, DeviceError, DisplayId, DisplayInfo, Eye, MeterInfo, MeterPositioner,
    PatternOutput, Xyz,
};

/// Analytic display: black + Σ_c curve_c(drive_c) · P_c, curve_c = drive^γ_c.
#[derive(Clone)]
struct Display {
    black: Xyz,
    primaries: [Xyz; 3],
    gamma: [f64; 3],
}

impl Display {
    fn curve(&self, c: usize, d: f64) -> f64 {
        d.clamp(0.0, 1.0).powf(self.gamma[c])
    }
    fn emit(&self, drive: [f64; 3]) -> Xyz {
        (0..3).fold(self.black, |acc, c| {
            acc + self.primaries[c] * self.curve(c, drive[c])
        })
    }
}

fn display() -> Display {
    Display {
        black: Xyz::new(0.25, 0.3, 0.4),
        primaries: [
            Xyz::new(41.0, 21.0, 1.9),
            Xyz::new(36.0, 72.0, 12.0),
            Xyz::new(18.0, 7.2, 95.0),
        ],
        gamma: [2.2, 2.4, 2.0],
    }
}

/// Shows patterns and reads them; fails readings as scripted.
struct Bench {
    display: Display,
    shown: [f64; 3],
    reading: u32,
    /// Readings (1-based attempt numbers) answered with a timeout.
    timeouts: Vec<u32>,
    /// From this attempt on, the meter never answers.
    dead_after: Option<u32>,
    min_reliable_cd_m2: f64,
}

impl Bench {
    fn new() -> Self {
        Self {
            display: display(),
            shown: [0.0; 3],
            reading: 0,
            timeouts: vec![],
            dead_after: None,
            min_reliable_cd_m2: 0.0,
        }
    }
}

struct Pattern<'a>(&'a std::cell::RefCell<Bench>);
struct Meter<'a>(&'a std::cell::RefCell<Bench>);
struct Aim;

impl PatternOutput for Pattern<'_> {
    fn displays(&self) -> Vec<DisplayInfo> {
        vec![info()]
    }
    fn show(&mut self, _: DisplayId, drive: [f64; 3]) -> Result<(), DeviceError> {
        self.0.borrow_mut().shown = drive;
        Ok(())
    }
}

impl Colorimeter for Meter<'_> {
    fn info(&self) -> MeterInfo {
        MeterInfo {
            model: "scripted".into(),
            serial: "1".into(),
            min_reliable_cd_m2: self.0.borrow().min_reliable_cd_m2,
            max_cd_m2: 1e6,
            noise: None,
        }
    }
    fn measure(&mut self) -> Result<Xyz, DeviceError> {
        let mut b = self.0.borrow_mut();
        b.reading += 1;
        let n = b.reading;
        if b.timeouts.contains(&n) || b.dead_after.is_some_and(|k| n > k) {
            return Err(DeviceError::Timeout {
                device: "scripted meter".into(),
                timeout_ms: 10,
            });
        }
        Ok(b.display.emit(b.shown))
    }
}

impl MeterPositioner for Aim {
    fn aim(&mut self, _: DisplayId, _: [f64; 2]) -> Result<(), DeviceError> {
        Ok(())
    }
}

fn info() -> DisplayInfo {
    DisplayInfo {
        id: DisplayId(3),
        name: "test display".into(),
        tile_col: 1,
        tile_row: 0,
        eye: Eye::Left,
        bit_depth: 10,
    }
}

fn run(
    bench: Bench,
    opts: &MeasureOptions,
) -> (
    Result<lumiwall_calib::measure::MeasuredDisplay, MeasureError>,
    Bench,
) {
    let cell = std::cell::RefCell::new(bench);
    let result = {
        let mut pattern = Pattern(&cell);
        let mut meter = Meter(&cell);
        let mut aim = Aim;
        let mut rig = Rig {
            pattern: &mut pattern,
            meter: &mut meter,
            positioner: &mut aim,
        };
        let key = display_key("bench", &info());
        measure_display(&mut rig, &info(), &key, opts, &mut |_| {})
    };
    (result, cell.into_inner())
}

#[test]
fn budget_is_kept_and_ramps_follow_the_display() {
    for budget in [16, 24, 40, 80] {
        let opts = MeasureOptions {
            budget,
            ..MeasureOptions::default()
        };
        let (m, bench) = run(Bench::new(), &opts);
        let m = m.unwrap();
        assert!(m.measurement.readings <= budget, "{budget}");
        assert_eq!(m.measurement.readings, bench.reading);
        let d = display();
        for c in 0..3 {
            let ramp = &m.measurement.ramps[c];
            assert!(ramp.len() >= 2, "budget {budget}: {} samples", ramp.len());
            for (drive, xyz) in ramp {
                // Relative intensity of every ramp sample is the analytic curve.
                let r = relative_intensity(*xyz, m.measurement.black, m.measurement.primaries[c]);
                assert!((r - d.curve(c, *drive)).abs() < 1e-9, "{c} {drive} {r}");
            }
        }
    }
}

#[test]
fn ramp_samples_are_adaptive_not_a_fixed_grid() {
    let (m, _) = run(Bench::new(), &MeasureOptions::default());
    let m = m.unwrap();
    let drives: Vec<Vec<f64>> = m
        .measurement
        .ramps
        .iter()
        .map(|r| r.iter().map(|s| s.0).collect())
        .collect();
    // More samples in the dark half than the bright half (perceptual placement).
    for d in &drives {
        let low = d.iter().filter(|x| **x < 0.5).count();
        let high = d.iter().filter(|x| **x > 0.5).count();
        assert!(low >= high, "{d:?}");
        assert!(d.len() >= 6, "{d:?}");
    }
}

#[test]
fn transient_timeouts_are_retried() {
    let mut bench = Bench::new();
    bench.timeouts = vec![3, 10];
    let (m, _) = run(bench, &MeasureOptions::default());
    let m = m.unwrap();
    assert_eq!(m.log.retries, 2);
    assert!(m.measurement.readings <= 40);
}

#[test]
fn a_dead_meter_is_a_typed_error_naming_display_and_reading() {
    let mut bench = Bench::new();
    bench.dead_after = Some(20);
    let opts = MeasureOptions {
        max_retries: 2,
        ..MeasureOptions::default()
    };
    let (m, bench) = run(bench, &opts);
    let err = m.unwrap_err();
    match &err {
        MeasureError::Reading {
            display,
            reading,
            attempts,
            source: DeviceError::Timeout { .. },
            ..
        } => {
            assert!(display.contains("bench display 3"), "{display}");
            assert_eq!(*reading, 21);
            assert_eq!(*attempts, 3);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(bench.reading, 23, "bounded: 20 good + 3 attempts");
    let msg = err.to_string();
    assert!(msg.contains("cable") && msg.contains("--resume"), "{msg}");
}

#[test]
fn low_light_readings_are_averaged_or_skipped() {
    let mut bench = Bench::new();
    bench.min_reliable_cd_m2 = 1.0;
    let (m, _) = run(bench, &MeasureOptions::default());
    let m = m.unwrap();
    // Black (0.3 cd/m²) is averaged over 4 readings.
    assert_eq!(m.log.samples[0].repeats, 4);
    assert!(m.log.averaged() >= 1);
    assert!(m.measurement.readings <= 40);

    let mut bench = Bench::new();
    bench.min_reliable_cd_m2 = 1.0;
    let opts = MeasureOptions {
        low_light: LowLight::Skip,
        ..MeasureOptions::default()
    };
    let (m, _) = run(bench, &opts);
    let m = m.unwrap();
    assert!(m.log.skipped() >= 1);
    for ramp in &m.measurement.ramps {
        assert!(ramp.iter().all(|(_, xyz)| xyz.y >= 1.0), "{ramp:?}");
    }
}

/// Under the default low-light policy (four readings), a dark single-channel ramp
/// sample averages at most [`DARK_CHANNEL_REPEATS`] (two) while the dark black averages
/// four: more drives pin a dark curve better than more readings at one.
#[test]
fn a_dark_ramp_sample_averages_at_most_two_readings_where_the_black_averages_four() {
    use lumiwall_calib::measure::{DARK_CHANNEL_REPEATS, Patch};
    assert_eq!(DARK_CHANNEL_REPEATS, 2);
    let mut bench = Bench::new();
    bench.min_reliable_cd_m2 = 1.0;
    let (m, _) = run(bench, &MeasureOptions::default());
    let m = m.unwrap();
    let dark_ramps: Vec<u32> = m
        .log
        .samples
        .iter()
        .filter(|r| matches!(r.patch, Patch::Ramp(..)) && r.low_light)
        .map(|r| r.repeats)
        .collect();
    assert!(dark_ramps.len() >= 3, "{dark_ramps:?}");
    assert!(dark_ramps.iter().all(|n| *n <= 2), "{dark_ramps:?}");
    assert!(dark_ramps.contains(&2), "{dark_ramps:?}");
    assert_eq!(m.log.samples[0].patch, Patch::Black);
    assert_eq!(m.log.samples[0].repeats, 4);
}

#[test]
fn too_small_budget_is_refused() {
    let opts = MeasureOptions {
        budget: 8,
        ..MeasureOptions::default()
    };
    let (m, bench) = run(Bench::new(), &opts);
    assert!(matches!(
        m,
        Err(MeasureError::BudgetTooSmall { budget: 8, .. })
    ));
    assert_eq!(bench.reading, 0);
}

/// A session whose budget is spent shows and reads nothing more: not a first reading
/// (`sample`, `sample_channel`), not the repeats of an averaged patch (`repeated`);
/// `Session::essential_sample` reads once past it.
#[test]
fn a_session_never_reads_past_its_budget_not_even_a_samples_first_reading() {
    use lumiwall_calib::measure::{ChannelLine, Patch, Session};
    use lumiwall_core::Channel;
    let cell = std::cell::RefCell::new(Bench::new());
    let (mut pattern, mut meter, mut aim) = (Pattern(&cell), Meter(&cell), Aim);
    let mut rig = Rig {
        pattern: &mut pattern,
        meter: &mut meter,
        positioner: &mut aim,
    };
    let opts = MeasureOptions {
        budget: 6,
        ..MeasureOptions::default()
    };
    let key = display_key("bench", &info());
    let mut s = Session::start(&mut rig, &key, info().id, [0.5, 0.5], &opts).expect("session");
    let line = ChannelLine {
        black: display().black,
        full: display().primaries[0],
        noise: None,
    };
    let ramp = s.sample_channel(Patch::Ramp(Channel::Red, 0.5), &line, &mut |_| {});
    assert!(ramp.unwrap().is_some());
    for _ in 0..2 {
        assert!(s.sample(Patch::White, true, &mut |_| {}).unwrap().is_some());
    }
    // Four readings asked, three left: three read.
    let red = s.repeated(Patch::Primary(Channel::Red), 4, &mut |_| {});
    assert!(red.unwrap().is_some());
    assert_eq!(s.remaining(), 0);
    let shown_before = cell.borrow().shown;
    let spent = s.sample_channel(Patch::Ramp(Channel::Red, 0.25), &line, &mut |_| {});
    assert!(
        spent.unwrap().is_none(),
        "a sample past the budget gave a reading"
    );
    assert!(s.sample(Patch::Black, true, &mut |_| {}).unwrap().is_none());
    assert!(s.repeated(Patch::White, 4, &mut |_| {}).unwrap().is_none());
    assert_eq!(
        cell.borrow().reading,
        6,
        "readings taken with a budget of 6"
    );
    assert_eq!(
        cell.borrow().shown,
        shown_before,
        "a patch was shown past the budget"
    );
    // What a display model or a check cannot do without is read once even so.
    let black = s.essential_sample(Patch::Black, &mut |_| {});
    assert!(black.unwrap().is_some());
    drop(s);
    assert_eq!(
        cell.into_inner().reading,
        7,
        "an essential sample past the budget"
    );
}

#[test]
fn patch_channels_are_logged_as_indices() {
    use lumiwall_calib::measure::Patch;
    use lumiwall_core::Channel;
    let ramp = Patch::Ramp(Channel::Blue, 0.5);
    let json = serde_json::to_string(&ramp).unwrap();
    assert_eq!(json, r#"{"ramp":[2,0.5]}"#);
    assert_eq!(serde_json::from_str::<Patch>(&json).unwrap(), ramp);
    let primary = serde_json::to_string(&Patch::Primary(Channel::Green)).unwrap();
    assert_eq!(primary, r#"{"primary":1}"#);
    assert!(serde_json::from_str::<Patch>(r#"{"primary":3}"#).is_err());
}

/// A dim blue ramp sample read by the realistic simulated meter (its Y a few per cent of
/// its Z, just above a 0.05 cd/m² black): weighted by the meter's stated noise
/// ([`lumiwall_calib::measure::channel_reading`]), the channel's relative intensity
/// scatters at most half as much as from the luminance alone, and both are unbiased.
#[test]
fn a_dim_blue_sample_weighted_by_the_stated_noise_scatters_half_as_much_as_its_luminance() {
    use lumiwall_calib::measure::{channel_reading, luminance_only};
    use lumiwall_devices::sim::{MeterModel, VirtualWall};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/walls/dlp-infitec-2x1.toml");
    let wall = VirtualWall::from_toml_file(&path).expect("wall");
    let (mut out, mut pos) = (wall.pattern_output(), wall.positioner());
    let mut meter = wall.meter(MeterModel::cs100a(21));
    let id = DisplayId(0);
    pos.aim(id, [0.5, 0.5]).expect("aim");
    let truth = |d: [f64; 3]| wall.emitted_xyz(id, d, [0.5, 0.5]).expect("truth");
    let (black, full) = (truth([0.0; 3]), truth([0.0, 0.0, 1.0]));
    let d = 0.12;
    let want = relative_intensity(truth([0.0, 0.0, d]), black, full);
    out.show(id, [0.0, 0.0, d]).expect("show");
    let noise = meter.info().noise.expect("stated noise");
    let (mut weighted, mut lum) = (Vec::new(), Vec::new());
    for _ in 0..400 {
        let raw = meter.measure().expect("reading");
        let w = channel_reading(raw, black, full, Some(&noise));
        weighted.push(relative_intensity(w, black, full));
        lum.push(relative_intensity(
            luminance_only(raw, black, full),
            black,
            full,
        ));
    }
    let stats = |v: &[f64]| {
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        (
            m,
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt(),
        )
    };
    let ((mw, sw), (ml, sl)) = (stats(&weighted), stats(&lum));
    println!("truth {want:.5}: weighted {mw:.5} ± {sw:.5}, luminance {ml:.5} ± {sl:.5}");
    assert!(sw < 0.5 * sl, "weighted σ {sw:.5} vs luminance σ {sl:.5}");
    // The instrument's filter error shifts both by up to a few per cent; the weighting
    // must not add a bias of its own beyond that.
    assert!(
        (mw / want - 1.0).abs() < 0.05,
        "weighted mean {mw:.5} vs {want:.5}"
    );
    assert!(
        (ml / want - 1.0).abs() < 0.05,
        "luminance mean {ml:.5} vs {want:.5}"
    );
}

/// Readings kept for a later pass (`reserved`) stay unread, except that a channel
/// without any ramp sample may still take one: with nearly the whole budget reserved,
/// every channel still gets its one sample and nothing more is read.
#[test]
fn the_ramps_leave_the_reserved_readings_unless_a_channel_has_no_sample_yet() {
    for reserved in [20, 33] {
        let opts = MeasureOptions {
            budget: 40,
            reserved,
            ..MeasureOptions::default()
        };
        let (m, _) = run(Bench::new(), &opts);
        let m = m.unwrap();
        let free = 40 - reserved;
        let samples: Vec<usize> = m.measurement.ramps.iter().map(Vec::len).collect();
        assert!(samples.iter().all(|n| *n >= 1), "{reserved}: {samples:?}");
        assert!(
            m.measurement.readings <= free.max(5 + 3),
            "{reserved}: {} readings",
            m.measurement.readings
        );
    }
}

/// A display so dim that every reading is averaged spends a small budget on black and
/// the primaries: the channel left without a ramp sample is named in a typed error
/// that says where the readings went, not in the solve's "0 usable ramp samples".
#[test]
fn a_budget_spent_before_a_channel_got_a_ramp_sample_is_a_typed_error_naming_it() {
    let mut bench = Bench::new();
    bench.min_reliable_cd_m2 = 1000.0;
    let opts = MeasureOptions {
        budget: 16,
        ..MeasureOptions::default()
    };
    let (m, _) = run(bench, &opts);
    let err = m.unwrap_err();
    match &err {
        MeasureError::RampBudgetSpent {
            channel,
            budget,
            taken,
            low_light,
            ..
        } => {
            assert_eq!(*budget, 16);
            assert!(*taken >= 16 && *low_light >= 16, "{err}");
            assert!(["red", "green", "blue"].contains(channel), "{err}");
        }
        other => panic!("{other:?}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains("--budget") && msg.contains("more sensitive meter"),
        "{msg}"
    );
}

/// With a CS-100A class meter's noise (no systematic error, so the truth is the
/// simulator's light), 40 readings per display read each primary only twice at full
/// drive; its ramp samples are further readings of the same colour. Over 24 meter
/// serials on mono-2x1, the pooled primaries' chromaticity is at least a quarter
/// closer to the truth (RMS Δxy over the three) than the full-drive readings they
/// started from, and each channel's RMS error is smaller.
#[test]
fn a_primarys_colour_pooled_over_its_ramp_is_closer_to_the_truth_than_its_full_drive_reading() {
    use lumiwall_calib::measure::Patch;
    use lumiwall_devices::sim::{MeterModel, VirtualWall};
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/walls/mono-2x1.toml");
    let wall = VirtualWall::from_toml_file(&path).expect("wall");
    let info = wall.pattern_output().displays()[0].clone();
    let uv = MeasureOptions::default().spot_uv;
    let truth = |d: [f64; 3]| wall.emitted_xyz(info.id, d, uv).expect("truth");
    let black = truth([0.0; 3]);
    let true_xy: Vec<[f64; 2]> = (0..3)
        .map(|c| {
            let mut d = [0.0; 3];
            d[c] = 1.0;
            (truth(d) - black).xy().expect("colour")
        })
        .collect();
    let dist = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
    let (mut sq_pooled, mut sq_read) = ([0.0; 3], [0.0; 3]);
    let serials = 24;
    for serial in 0..serials {
        let model = MeterModel {
            lum_systematic_rel: 0.0,
            filter_shift_nm: 0.0,
            filter_gain_rel: 0.0,
            ..MeterModel::cs100a(100 + serial)
        };
        let (mut out, mut meter, mut pos) =
            (wall.pattern_output(), wall.meter(model), wall.positioner());
        let mut rig = Rig {
            pattern: &mut out,
            meter: &mut meter,
            positioner: &mut pos,
        };
        let opts = MeasureOptions {
            budget: 40,
            ..MeasureOptions::default()
        };
        let key = display_key("mono-2x1", &info);
        let m = measure_display(&mut rig, &info, &key, &opts, &mut |_| {}).expect("measured");
        let mm = &m.measurement;
        for c in 0..3 {
            let read = m
                .log
                .samples
                .iter()
                .rev()
                .find(|r| r.patch == Patch::Primary(lumiwall_core::Channel::ALL[c]))
                .and_then(|r| r.xyz)
                .expect("full-drive reading");
            let xy = |v: Xyz| (v - mm.black).xy().expect("colour");
            sq_pooled[c] += dist(xy(mm.primaries[c]), true_xy[c]).powi(2);
            sq_read[c] += dist(xy(read), true_xy[c]).powi(2);
        }
    }
    let rms = |s: [f64; 3]| s.map(|v| (v / serials as f64).sqrt());
    let (pooled, read) = (rms(sq_pooled), rms(sq_read));
    println!("RMS Δxy R, G, B: pooled {pooled:.5?}, full-drive readings {read:.5?}");
    let total = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(
        total(pooled) < 0.75 * total(read),
        "pooled {pooled:.5?} vs read {read:.5?}"
    );
    for c in 0..3 {
        assert!(
            pooled[c] < read[c],
            "channel {c}: {pooled:.5?} vs {read:.5?}"
        );
    }
}

/// The full white gets the readings a CS-100A class meter's xy noise needs (7 for a
/// standard error of 0.0002, at most 6) only from 40 readings per display, and at most
/// one in twelve of the budget; a meter without stated noise, or an exact one, reads
/// it as often as a primary.
#[test]
fn the_white_is_averaged_by_the_stated_noise_only_where_the_budget_allows() {
    let cs100a = lumiwall_devices::ReadingNoise::CS100A_CLASS;
    let exact = lumiwall_devices::ReadingNoise::EXACT;
    let quiet = lumiwall_devices::ReadingNoise {
        xy: 0.0001,
        ..cs100a
    };
    let opts = |budget| MeasureOptions {
        budget,
        reserved: 9,
        ..MeasureOptions::default()
    };
    let white = |budget, n: Option<&lumiwall_devices::ReadingNoise>| {
        (
            opts(budget).primary_repeats(),
            opts(budget).white_repeats(n),
        )
    };
    assert_eq!(white(24, Some(&cs100a)), (1, 1));
    assert_eq!(white(39, Some(&cs100a)), (1, 1));
    assert_eq!(white(40, Some(&cs100a)), (1, 3));
    assert_eq!(white(64, Some(&cs100a)), (4, 5));
    assert_eq!(white(200, Some(&cs100a)), (4, 6));
    assert_eq!(white(64, Some(&quiet)), (4, 4));
    assert_eq!(white(64, Some(&exact)), (4, 4));
    assert_eq!(white(64, None), (4, 4));
}

/// The black is read as often as the chart's darkest grey needs (`measure::black_readings`):
/// on mono-2x1 with lamps of 12.5 cd/m² (a wall white of about 6 cd/m², its 2 % grey
/// 0.13 cd/m²) a CS-100A class meter's black needs about twenty readings, of which an
/// eighth of 64 are allowed; at the fixture's 250 cd/m² it keeps the survey's readings.
#[test]
fn a_dim_walls_black_is_read_as_often_as_its_darkest_grey_needs_within_an_eighth_of_the_budget() {
    use lumiwall_calib::measure::Patch;
    use lumiwall_devices::sim::MeterModel;
    let black_readings = |lamp_cd_m2: f64| {
        let wall = mono_2x1_with_lamps(lamp_cd_m2);
        let m = measured_with_focus(&wall, MeterModel::cs100a(7), 1);
        m.log.readings_of(Patch::Black)
    };
    let (dim, bright) = (black_readings(12.5), black_readings(250.0));
    assert_eq!(dim, 64 / 8, "dim wall's black");
    assert!(bright < dim, "bright wall's black read {bright} times");
}

#[test]
fn a_black_below_the_meters_floor_is_measured_without_the_bias_of_the_readings_it_gives() {
    use lumiwall_devices::sim::MeterModel;
    // mono-2x1 with lamps of 12 cd/m²: its LCD black, about 0.008 cd/m² in Y, lies
    // below a CS-100A class meter's floor of 0.01 cd/m², and its zero-light noise
    // (0.004 cd/m² in Y) has the meter refuse two readings in three. The mean of the
    // readings it gives was 0.012 cd/m², half as much again as the truth.
    let dim = mono_2x1_with_lamps(12.0);
    let black_y = |model: MeterModel, averaged: u32| {
        let m = measured_with_focus(&dim, model, averaged);
        // The plain mean of the instrument's readings it gave (NaN where it gave none).
        let given = m.log.black_readings.mean(None).map_or(f64::NAN, |b| b.y);
        (m.measurement.black.y, given)
    };
    let (truth, _) = black_y(MeterModel::noiseless(), 1);
    assert!(truth < 0.0095, "the black {truth} is not below the floor");
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let given: Vec<f64> = (1..=40u64)
        .map(|s| black_y(MeterModel::cs100a(s), 1).1 / truth)
        .filter(|r| r.is_finite())
        .collect();
    assert!(mean(&given) > 1.3, "given readings / truth: {given:.2?}");
    // Read once and each reading the mean of three (the instrument's readings behind
    // each counted): over a hundred meters, the blacks come out as the same meters
    // read them without a floor, within the estimate's small-sample bias (eight
    // readings, two in three refused: 5–7 % low) and the scatter of the two means
    // (about 2 % each).
    let seeds = 1..=100u64;
    for averaged in [1, 3] {
        let ratios: Vec<f64> = seeds
            .clone()
            .map(|s| black_y(MeterModel::cs100a(s), averaged).0 / truth)
            .collect();
        let no_floor: Vec<f64> = seeds
            .clone()
            .map(|s| {
                let mut m = MeterModel::cs100a(s);
                m.floor_cd_m2 = 0.0;
                black_y(m, averaged).0 / truth
            })
            .collect();
        let (with, without) = (mean(&ratios), mean(&no_floor));
        assert!(
            (with - without).abs() < 0.1,
            "{averaged} each: black / truth {with:.3} with the floor, {without:.3} without"
        );
    }
}

/// The fixture wall mono-2x1 (TOML) with lamps of `lamp_cd_m2` instead of 250 cd/m².
fn mono_2x1_with_lamps(lamp_cd_m2: f64) -> String {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/walls/mono-2x1.toml");
    let text = std::fs::read_to_string(&path).expect("wall file");
    assert!(
        text.contains("white_cd_m2 = 250.0"),
        "the fixture's lamp changed"
    );
    text.replace(
        "white_cd_m2 = 250.0",
        &format!("white_cd_m2 = {lamp_cd_m2:.1}"),
    )
}

#[test]
fn a_black_the_meter_refused_every_time_lies_below_its_floor_at_the_displays_white() {
    use lumiwall_calib::measure::{MeasureLog, black_of};
    use lumiwall_devices::ReadingNoise;
    let d = display();
    let key = display_key("bench", &info());
    let opts = MeasureOptions::default();
    let noise = ReadingNoise::CS100A_CLASS;
    // A log written before it kept the black's readings: nothing to pool.
    let mut log = MeasureLog::default();
    assert_eq!(
        black_of(&log, Some(&noise), &opts, &key, &d.primaries),
        None
    );
    for _ in 0..8 {
        log.black_readings.add_refused(0.01);
    }
    let black = black_of(&log, Some(&noise), &opts, &key, &d.primaries).expect("estimated");
    // Eight refusals at a noise of 0.004 cd/m² leave about a quarter of the floor.
    assert!((0.001..0.004).contains(&black.y), "{black:?}");
    let white = d.primaries[0] + d.primaries[1] + d.primaries[2];
    let (b, w) = (black.xy().unwrap(), white.xy().unwrap());
    assert!((b[0] - w[0]).abs() < 1e-12 && (b[1] - w[1]).abs() < 1e-12);
    // A meter that states no noise leaves the refusals unexplained.
    assert_eq!(black_of(&log, None, &opts, &key, &d.primaries), None);
}

#[test]
fn an_averaged_meters_black_pools_every_instrument_reading_behind_its_readings() {
    use lumiwall_calib::measure::Patch;
    use lumiwall_devices::sim::MeterModel;
    let dim = mono_2x1_with_lamps(12.0);
    let m = measured_with_focus(&dim, MeterModel::cs100a(7), 3);
    let session_readings: u32 = m
        .log
        .samples
        .iter()
        .filter(|r| r.patch == Patch::Black)
        .map(|r| r.repeats.max(1))
        .sum();
    let pooled = &m.log.black_readings;
    assert!(pooled.refused() > 0, "a black below the floor: {pooled:?}");
    assert_eq!(pooled.given() + pooled.refused(), 3 * session_readings);
}

/// One display of the wall `toml` measured as a commissioning reads it (budget 64, the
/// black as often as the darkest chart grey needs within an eighth of it) with `model`,
/// each reading the mean of `averaged`.
fn measured_with_focus(
    toml: &str,
    model: lumiwall_devices::sim::MeterModel,
    averaged: u32,
) -> lumiwall_calib::measure::MeasuredDisplay {
    use lumiwall_calib::measure::RampFocus;
    let wall = lumiwall_devices::sim::VirtualWall::from_toml_str(toml).expect("wall");
    let info = wall.pattern_output().displays()[0].clone();
    let (mut out, mut meter, mut pos) =
        (wall.pattern_output(), wall.meter(model), wall.positioner());
    let mut meter = lumiwall_devices::AveragingMeter::new(&mut meter, averaged);
    let mut rig = Rig {
        pattern: &mut out,
        meter: &mut meter,
        positioner: &mut pos,
    };
    let opts = MeasureOptions {
        budget: 64,
        focus: Some(RampFocus {
            white_xy: [0.3127, 0.3290],
            headroom: 1.0,
            white_y_cd_m2: None,
            toe_samples: false,
            common_black: None,
        }),
        ..MeasureOptions::default()
    };
    let key = display_key("mono-2x1", &info);
    measure_display(&mut rig, &info, &key, &opts, &mut |_| {}).expect("measured")
}
