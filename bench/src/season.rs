//! `lumiwall bench season`: a season of nightly recalibrations on the virtual wall,
//! judged against the simulator's truth.
//!
//! Night 0 commissions the wall; every following night the simulator's clock advances
//! by the hours the wall is used per day (its lamps age; the recalibration's own
//! readings add their measuring time, the lamps burn then too), one lamp is replaced on
//! the configured night, and `recalibrate` runs as the nightly service runs it (readings,
//! refit and re-solve where something drifted, the run or the lamp readings recorded in
//! a profile store dated one calendar day apart). After each night a perfect meter reads
//! a colour chart through the profiles in use (the truth: the station meter's own error
//! stays in the figures).
//!
//! A night is **within tolerance** when each truth figure (median, max and white
//! ΔE2000) is within the verification's tolerance or, where the commissioning itself
//! was not, no more than 10 % above the commissioning's figure: the nightly run must
//! keep what the commissioning achieved. The truth is read on a copy of the simulator
//! ([`VirtualWall::snapshot`]), so its readings do not age the lamps.
//!
//! On the forecast night the store's lamp-life forecast (`profiles forecast`) is made
//! and checked against the truth: a copy of the simulator is run ahead day by day
//! (the lamp hours per day the season has had so far, measuring included; no lamp
//! change) until each display can no longer show that
//! night's common white at full drive. The error of a display's predicted date is in
//! percent of its true lead time (days from the forecast to the event); a display
//! whose event is beyond the forecast horizon in both counts as exact.
#![cfg(feature = "readings")]

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use lumiwall_calib::commission::{CommissionError, CommissionOptions};
use lumiwall_calib::measure::averaging::Averaging;
use lumiwall_calib::measure::meter_matrix::{MeterMatrices, MeterMatrixError};
use lumiwall_calib::measure::{MeasureOptions, Progress};
use lumiwall_calib::recalibrate::{
    DriftLimits, FullCheckRotation, RecalibrateError, RecalibrateOptions, Verdict, record_in_store,
    usage_for_white,
};
use lumiwall_calib::solve::SolveOptions;
use lumiwall_calib::station::{MeterChoice, Noise, Station, StationError, StationOptions};
use lumiwall_calib::verify::{Tolerances, VerifyError, VerifyOptions, chart_targets};
use lumiwall_devices::sim::VirtualWall;
use lumiwall_devices::{DeviceError, DisplayId};
use lumiwall_profiles::store::{
    DisplayForecast, ForecastOptions, ProfileStore, StoreError, Timestamp,
};
use lumiwall_profiles::{DisplayKey, DisplayProfile, ProfileError, ProfileSet};

/// What to simulate.
#[derive(Debug, Clone)]
pub struct SeasonBench {
    /// Wall description (TOML).
    pub wall: PathBuf,
    /// Nights after the commissioning.
    pub nights: u32,
    /// Hours the lamps burn per day.
    pub lamp_hours_per_day: f64,
    /// Night whose recalibration follows a lamp change (`None`: no change).
    pub lamp_change_night: Option<u32>,
    /// Display whose lamp is changed (`None`: the one with the least reserve the night
    /// before, the lamp the forecast says to replace first).
    pub lamp_change_display: Option<u32>,
    /// Night after whose recalibration the forecast is made and checked.
    pub forecast_night: u32,
    /// The forecast's settings.
    pub forecast: ForecastOptions,
    /// Error model of the station meter.
    pub noise: Noise,
    /// Meter path.
    pub meter: MeterChoice,
    /// The commissioning's solve (its headroom is the nightly run's too).
    pub solve: SolveOptions,
    /// Drift limits of the nightly run.
    pub limits: DriftLimits,
    /// Each display is measured in full once in this many nights (the nightly run's
    /// `--full-check-every`); a white reading checks it on the others.
    pub full_check_every_nights: u32,
    /// Verification tolerances a night is held to (see the module documentation).
    pub tolerances: Tolerances,
    /// Meter readings each reading averages, commissioning and nights alike
    /// (`commission --averaging`; the nights' `auto` averages as the commissioning did).
    pub averaging: Averaging,
    /// Scratch folder: profiles, the store and the plot.
    pub out: PathBuf,
    /// Calendar time of the commissioning (night 0).
    pub start_utc: Timestamp,
}

/// One night.
#[derive(Debug, Clone, PartialEq)]
pub struct NightRow {
    /// Night number (0: the commissioning).
    pub night: u32,
    /// Lamp hours of the wall's simulator clock.
    pub clock_h: f64,
    /// What the recalibration did (`None` on night 0).
    pub verdict: Option<Verdict>,
    /// Display whose lamp was replaced before this night.
    pub lamp_changed: Option<DisplayKey>,
    /// Meter readings of the night's run (commissioning or recalibration).
    pub readings: u64,
    /// Camera captures of the night's run.
    pub camera_captures: u64,
    /// Simulated measuring time of the night's run (the instrument's clock), seconds.
    pub measuring_s: f64,
    /// Common white luminance in use after the night, cd/m².
    pub white_cd_m2: f64,
    /// Smallest reserve any display has left for that white (1 − most used channel).
    pub least_reserve: f64,
    /// Truth: median, max and worst-white ΔE2000 of the chart.
    pub truth_median_de: f64,
    /// See `truth_median_de`.
    pub truth_max_de: f64,
    /// See `truth_median_de`.
    pub truth_white_de: f64,
    /// The display with the largest white ΔE2000.
    pub worst_white: Option<DisplayKey>,
    /// Whether the night stays within tolerance.
    pub within: bool,
    /// Wall-clock time of the night on this computer.
    pub elapsed: Duration,
}

/// The forecast of one display against the truth.
#[derive(Debug, Clone, PartialEq)]
pub struct ForecastCheck {
    /// The display.
    pub display: DisplayKey,
    /// Predicted days from the forecast night until the display cannot show the white
    /// (`None`: not within the horizon, or too little history).
    pub predicted_days: Option<f64>,
    /// The simulator's truth, in whole days (`None`: not within the horizon).
    pub true_days: Option<f64>,
    /// Error of the predicted date, days (a date beyond the horizon counts as the
    /// horizon; 0 when both are beyond it).
    pub error_days: f64,
    /// The error in percent of the true lead time (the days from the forecast to the
    /// true date, at least one).
    pub error_pct_of_lead: f64,
}

/// The season's result.
#[derive(Debug, Clone, PartialEq)]
pub struct SeasonSummary {
    /// Nights after the commissioning.
    pub nights: u32,
    /// Nights within tolerance.
    pub within: u32,
    /// The limits the truth figures were held to: median, max, white ΔE2000.
    pub limits_de: [f64; 3],
    /// Every display's forecast check (empty when the season ended before the forecast
    /// night).
    pub forecast: Vec<ForecastCheck>,
    /// Night after which the forecast was made.
    pub forecast_night: u32,
    /// The forecast's horizon, days.
    pub horizon_days: f64,
    /// Worst forecast error in percent of the horizon (`None`: no forecast was made,
    /// the season ended before the forecast night).
    pub forecast_error_pct_of_horizon: Option<f64>,
    /// The lamp change: the display and whether the store's history found it on the
    /// night it happened.
    pub lamp_change: Option<(DisplayKey, bool)>,
    /// Displays where a lamp change was found that did not happen.
    pub false_lamp_changes: Vec<DisplayKey>,
    /// The commissioning's readings and measuring time (s).
    pub commission_cost: (u64, f64),
    /// A recalibration's mean readings and measuring time (s).
    pub nightly_cost: (f64, f64),
    /// The plot written.
    pub plot: PathBuf,
}

/// Why the season stopped.
#[derive(Debug, thiserror::Error)]
pub enum SeasonError {
    /// The station could not be opened.
    #[error(transparent)]
    Station(#[from] StationError),
    /// The meter matrix could not be made.
    #[error(transparent)]
    MeterMatrix(#[from] MeterMatrixError),
    /// The commissioning failed.
    #[error("commissioning (night 0) failed: {0}")]
    Commission(#[from] Box<CommissionError>),
    /// A recalibration failed.
    #[error("night {night}: recalibration failed: {source}")]
    Recalibrate {
        /// The night.
        night: u32,
        /// What failed.
        #[source]
        source: Box<RecalibrateError>,
    },
    /// A verification failed.
    #[error("night {night}: verification failed: {source}")]
    Verify {
        /// The night.
        night: u32,
        /// What failed.
        #[source]
        source: Box<VerifyError>,
    },
    /// The simulator refused.
    #[error(transparent)]
    Device(#[from] DeviceError),
    /// The profile store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// Profiles could not be read or the plot written.
    #[error(transparent)]
    Profile(#[from] ProfileError),
    /// The settings do not describe a season.
    #[error("{0}")]
    Settings(String),
}

/// Runs the season; `on_night` sees each night's row as it is finished.
pub fn run(
    bench: &SeasonBench,
    on_night: &mut dyn FnMut(&NightRow),
) -> Result<(Vec<NightRow>, SeasonSummary), SeasonError> {
    check_settings(bench)?;
    let store_path = prepare_out_dir(&bench.out)?;
    let mut station = Station::open(
        &bench.wall,
        &StationOptions::new(bench.meter.clone(), bench.noise),
    )?;
    // as the station matches it by default (per display on an Infitec wall)
    let per_display = station.per_display_matrices_by_default();
    let meter_matrix = crate::readings::match_meter(
        &mut station,
        bench.noise,
        &crate::readings::default_reference(),
        per_display,
    )?;
    let profiles_dir = bench.out.join("profiles");
    let mut store = ProfileStore::open(&store_path)?;
    let mut season = Season {
        bench,
        profiles_dir,
        rows: Vec::new(),
        limits_de: [f64::NAN; 3],
        forecast: Vec::new(),
        lamp_change: None,
        last_reserve: Vec::new(),
        night_each: 1,
    };
    let row = season.commission(&mut station, &mut store, meter_matrix.clone())?;
    on_night(&row);
    season.rows.push(row);
    let mut opts = RecalibrateOptions {
        measure: MeasureOptions {
            meter_matrix,
            averaging: bench.averaging,
            ..MeasureOptions::default()
        },
        limits: bench.limits,
        meter_xy_offset: [0.0; 2],
        headroom: Some(bench.solve.headroom),
        rotation: FullCheckRotation::EVERY_NIGHT,
        warm_check: Some(lumiwall_calib::measure::warm_up::WarmCheck::default()),
    };
    for night in 1..=bench.nights {
        opts.rotation = FullCheckRotation {
            every_nights: bench.full_check_every_nights,
            night: u64::from(night),
        };
        let row = season.night(night, &mut station, &mut store, &opts)?;
        on_night(&row);
        season.rows.push(row);
        if night == bench.forecast_night {
            season.forecast = season.check_forecast(&station.wall, &store)?;
        }
    }
    let summary = season.summary(&store)?;
    Ok((season.rows, summary))
}

fn check_settings(b: &SeasonBench) -> Result<(), SeasonError> {
    let bad = |m: String| Err(SeasonError::Settings(m));
    if b.nights == 0 || b.nights > 3650 {
        return bad(format!("--nights {} must be 1 to 3650", b.nights));
    }
    if !(b.lamp_hours_per_day.is_finite()
        && b.lamp_hours_per_day > 0.0
        && b.lamp_hours_per_day <= 24.0)
    {
        return bad(format!(
            "--lamp-hours-per-day {} must be above 0 and at most 24",
            b.lamp_hours_per_day
        ));
    }
    let h = b.forecast.horizon_days;
    if !(h.is_finite() && (1.0..=3650.0).contains(&h)) {
        return bad(format!("the forecast horizon {h} days must be 1 to 3650"));
    }
    if b.forecast_night == 0 {
        return bad("--forecast-night must be 1 or later (night 0 is the commissioning)".into());
    }
    Ok(())
}

/// The season so far.
struct Season<'a> {
    bench: &'a SeasonBench,
    profiles_dir: PathBuf,
    rows: Vec<NightRow>,
    /// Median, max, white ΔE2000 a night may reach.
    limits_de: [f64; 3],
    forecast: Vec<ForecastCheck>,
    lamp_change: Option<(u32, DisplayKey)>,
    /// Each display's reserve for the white after the last night's readings.
    last_reserve: Vec<(DisplayKey, f64)>,
    /// Meter readings each reading of a night averages (the commissioning's under
    /// [`Averaging::Auto`]).
    night_each: u64,
}

/// The simulated lamp change and whether it was found on its night; the displays
/// where a change was found that did not happen.
type LampChangesFound = (Option<(DisplayKey, bool)>, Vec<DisplayKey>);

/// Truth figures of one verification: median, max, worst white ΔE2000.
type TruthDe = [f64; 3];

/// A verification against the truth: its figures and the display with the worst white.
struct Truth {
    de: TruthDe,
    worst_white: Option<DisplayKey>,
}

impl Season<'_> {
    fn night_utc(&self, night: u32) -> Timestamp {
        Timestamp::from_second(self.bench.start_utc.as_second() + 86_400 * i64::from(night))
            .unwrap_or(Timestamp::MAX)
    }

    /// Night 0: commissioning, recorded in the store, verified; sets the limits.
    fn commission(
        &mut self,
        station: &mut Station,
        store: &mut ProfileStore,
        meter_matrix: Option<MeterMatrices>,
    ) -> Result<NightRow, SeasonError> {
        let started = Instant::now();
        let opts = CommissionOptions {
            measure: MeasureOptions {
                meter_matrix,
                averaging: self.bench.averaging,
                ..MeasureOptions::default()
            },
            solve: self.bench.solve,
            resume: false,
            meter_correction: false,
            warm_check: Some(lumiwall_calib::measure::warm_up::WarmCheck::default()),
            grey_levels: lumiwall_calib::measure::grey_drives::default_levels(),
        };
        let clock = station.wall.elapsed_s();
        let mut readings = MeterReadings::each(self.bench.averaging.count_or_one());
        let outcome = station
            .commission(&self.profiles_dir, &opts, &mut |p| readings.count(&p))
            .map_err(Box::new)?;
        self.night_each = match self.bench.averaging {
            Averaging::Auto => u64::from(outcome.readings_per_reading),
            fixed => u64::from(fixed.count_or_one()),
        };
        let readings = readings.total;
        let measuring_s = station.wall.elapsed_s() - clock;
        let run =
            lumiwall_profiles::store::CommissionRun::new(outcome.wall.clone(), self.night_utc(0));
        store.record(&run, &outcome.solution.profiles)?;
        let Truth { de, worst_white } = verify_truth(&station.wall, &outcome.solution.profiles, 0)?;
        let t = &self.bench.tolerances;
        // the tolerance, or 110 % of what the commissioning reached where it was not within
        let limit = |tol: f64, reached: f64| if reached <= tol { tol } else { 1.1 * reached };
        self.limits_de = [
            limit(t.median_de, de[0]),
            limit(t.max_de, de[1]),
            limit(t.white_de, de[2]),
        ];
        self.last_reserve = outcome
            .solution
            .profiles
            .iter()
            .map(|p| (p.display.clone(), reserve_of(p)))
            .collect();
        Ok(NightRow {
            night: 0,
            clock_h: station.wall.elapsed_s() / 3600.0,
            verdict: None,
            lamp_changed: None,
            readings,
            camera_captures: 0,
            measuring_s,
            white_cd_m2: outcome.solution.profiles[0].target_white_xyz_cd_m2[1],
            least_reserve: least_reserve(&outcome.solution.profiles),
            truth_median_de: de[0],
            truth_max_de: de[1],
            truth_white_de: de[2],
            worst_white,
            within: self.within(de),
            elapsed: started.elapsed(),
        })
    }

    fn within(&self, de: TruthDe) -> bool {
        de.iter().zip(&self.limits_de).all(|(v, l)| *v <= *l)
    }

    /// One night: the lamps age, perhaps one is replaced, the wall is recalibrated,
    /// the outcome recorded and the wall verified against the truth.
    fn night(
        &mut self,
        night: u32,
        station: &mut Station,
        store: &mut ProfileStore,
        opts: &RecalibrateOptions,
    ) -> Result<NightRow, SeasonError> {
        let started = Instant::now();
        station.wall.advance_hours(self.bench.lamp_hours_per_day);
        let lamp_changed = self.change_lamp(night, station)?;
        let clock = station.wall.elapsed_s();
        let mut readings = MeterReadings {
            total: 0,
            each: self.night_each,
        };
        let outcome = station
            .recalibrate(&self.profiles_dir, opts, &mut |p| readings.count(&p))
            .map_err(|e| SeasonError::Recalibrate {
                night,
                source: Box::new(e),
            })?;
        let measuring_s = station.wall.elapsed_s() - clock;
        let readings = readings.total;
        record_in_store(store, &outcome, self.night_utc(night))?;
        let (_, profiles) = ProfileSet::load_dir(&self.profiles_dir)?;
        let Truth { de, worst_white } = verify_truth(&station.wall, &profiles, night)?;
        self.last_reserve = outcome
            .checks
            .iter()
            .map(|c| (c.key.clone(), c.reserve_left()))
            .collect();
        let least = outcome
            .checks
            .iter()
            .map(|c| c.reserve_left())
            .fold(f64::INFINITY, f64::min);
        Ok(NightRow {
            night,
            clock_h: station.wall.elapsed_s() / 3600.0,
            verdict: Some(outcome.verdict),
            lamp_changed,
            readings,
            camera_captures: 0,
            measuring_s,
            white_cd_m2: outcome.white_after_cd_m2,
            least_reserve: match &outcome.solution {
                Some(s) => least_reserve(&s.profiles),
                None => least,
            },
            truth_median_de: de[0],
            truth_max_de: de[1],
            truth_white_de: de[2],
            worst_white,
            within: self.within(de),
            elapsed: started.elapsed(),
        })
    }

    /// Replaces a lamp when `night` is the lamp-change night: the configured display,
    /// or the one with the least reserve in the night before's readings.
    fn change_lamp(
        &mut self,
        night: u32,
        station: &Station,
    ) -> Result<Option<DisplayKey>, SeasonError> {
        if self.bench.lamp_change_night != Some(night) {
            return Ok(None);
        }
        let (_, profiles) = ProfileSet::load_dir(&self.profiles_dir)?;
        let key = match self.bench.lamp_change_display {
            Some(d) => profiles
                .iter()
                .find(|p| p.display.display == d)
                .map(|p| p.display.clone())
                .ok_or_else(|| {
                    SeasonError::Settings(format!(
                        "--lamp-change-display {d}: the wall has displays 0..{}",
                        profiles.len().saturating_sub(1)
                    ))
                })?,
            None => self
                .last_reserve
                .iter()
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(k, _)| k.clone())
                .ok_or_else(|| SeasonError::Settings("the wall has no display".into()))?,
        };
        station.wall.replace_lamp(DisplayId(key.display))?;
        self.lamp_change = Some((night, key.clone()));
        Ok(Some(key))
    }

    /// The store's forecast now against a copy of the simulator run ahead.
    fn check_forecast(
        &self,
        wall: &VirtualWall,
        store: &ProfileStore,
    ) -> Result<Vec<ForecastCheck>, SeasonError> {
        let (name, profiles) = ProfileSet::load_dir(&self.profiles_dir)?;
        let forecasts = store.forecast_wall(&name, &self.bench.forecast)?;
        let now = self.night_utc(self.bench.forecast_night);
        let horizon = self.bench.forecast.horizon_days;
        // the lamp hours a day has had so far, the nights' measuring included
        let first_h = self.rows.first().map_or(0.0, |r| r.clock_h);
        let burnt_h = self.rows.last().map_or(0.0, |r| r.clock_h) - first_h;
        let per_day = burnt_h / f64::from(self.bench.forecast_night.max(1));
        let truth = true_exhaustion_days(wall, &profiles, per_day, horizon)?;
        Ok(profiles
            .iter()
            .zip(truth)
            .map(|(p, true_days)| {
                let predicted_days = forecasts
                    .iter()
                    .find(|f| f.display() == &p.display)
                    .and_then(DisplayForecast::first_beyond_full_drive)
                    .map(|(_, x)| x.utc.duration_since(now).as_secs_f64() / 86_400.0);
                let error_days = forecast_error_days(predicted_days, true_days, horizon);
                ForecastCheck {
                    display: p.display.clone(),
                    predicted_days,
                    true_days,
                    error_days,
                    error_pct_of_lead: 100.0 * error_days / true_days.unwrap_or(horizon).max(1.0),
                }
            })
            .collect())
    }

    fn summary(&self, store: &ProfileStore) -> Result<SeasonSummary, SeasonError> {
        let nightly: Vec<&NightRow> = self.rows.iter().filter(|r| r.night > 0).collect();
        let n = nightly.len().max(1) as f64;
        let (lamp_change, false_lamp_changes) = self.lamp_changes_found(store)?;
        let plot = self.bench.out.join("season.svg");
        lumiwall_profiles::write_atomic(&plot, plot_svg(&self.rows, &self.limits_de).as_bytes())?;
        Ok(SeasonSummary {
            nights: self.bench.nights,
            within: nightly.iter().filter(|r| r.within).count() as u32,
            limits_de: self.limits_de,
            forecast_night: self.bench.forecast_night,
            horizon_days: self.bench.forecast.horizon_days,
            forecast_error_pct_of_horizon: (!self.forecast.is_empty()).then(|| {
                let worst = self
                    .forecast
                    .iter()
                    .map(|f| f.error_days)
                    .fold(0.0, f64::max);
                100.0 * worst / self.bench.forecast.horizon_days
            }),
            forecast: self.forecast.clone(),
            lamp_change,
            false_lamp_changes,
            commission_cost: self
                .rows
                .first()
                .map_or((0, 0.0), |r| (r.readings, r.measuring_s)),
            nightly_cost: (
                nightly.iter().map(|r| r.readings as f64).sum::<f64>() / n,
                nightly.iter().map(|r| r.measuring_s).sum::<f64>() / n,
            ),
            plot,
        })
    }

    /// Whether the store's history finds the lamp change on its night, and any lamp
    /// change it finds elsewhere.
    fn lamp_changes_found(&self, store: &ProfileStore) -> Result<LampChangesFound, SeasonError> {
        let (name, _) = ProfileSet::load_dir(&self.profiles_dir)?;
        let forecasts = store.forecast_wall(&name, &self.bench.forecast)?;
        let mut found = None;
        let mut false_changes = Vec::new();
        for f in &forecasts {
            let changes = match f {
                DisplayForecast::Fitted { lamp_changes, .. }
                | DisplayForecast::NotEnoughHistory { lamp_changes, .. } => lamp_changes,
            };
            match &self.lamp_change {
                Some((night, key)) if key == f.display() => {
                    let at = self.night_utc(*night);
                    found = Some((key.clone(), changes.len() == 1 && changes[0] == at));
                }
                _ if !changes.is_empty() => false_changes.push(f.display().clone()),
                _ => {}
            }
        }
        Ok((found, false_changes))
    }
}

/// Meter readings counted from a run's progress: each reading averages `each`, which
/// the commissioning's choice ([`Progress::Averaging`]) sets for the readings after it.
struct MeterReadings {
    total: u64,
    each: u64,
}

impl MeterReadings {
    fn each(n: u32) -> Self {
        Self {
            total: 0,
            each: u64::from(n.max(1)),
        }
    }

    fn count(&mut self, p: &Progress) {
        match p {
            Progress::Reading { .. } => self.total += self.each,
            Progress::Averaging(c) => self.each = u64::from(c.readings_per_reading.max(1)),
            _ => {}
        }
    }
}

/// The 51-patch chart read through `profiles` by the perfect meter.
fn verify_truth(
    wall: &VirtualWall,
    profiles: &[DisplayProfile],
    night: u32,
) -> Result<Truth, SeasonError> {
    let err = |e: VerifyError| SeasonError::Verify {
        night,
        source: Box::new(e),
    };
    // a copy: the truth's readings must not age the season's lamps
    let mut truth = Station::with_wall(
        wall.snapshot(),
        &StationOptions::new(MeterChoice::Direct, Noise::None),
    )?;
    let targets = chart_targets(profiles).map_err(err)?;
    let opts = VerifyOptions {
        patches: targets.len(),
        ..VerifyOptions::default()
    };
    let report = truth
        .verify(profiles, &targets, &opts, &mut |_| {})
        .map_err(err)?;
    let worst = report
        .per_display
        .iter()
        .filter_map(|(k, s)| s.white_de.map(|w| (k, w)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    Ok(Truth {
        de: [
            report.overall.median_de,
            report.overall.max_de,
            worst.map_or(0.0, |w| w.1),
        ],
        worst_white: worst.map(|w| w.0.clone()),
    })
}

/// 1 − the most used channel of the most used display.
fn least_reserve(profiles: &[DisplayProfile]) -> f64 {
    profiles
        .iter()
        .map(reserve_of)
        .fold(f64::INFINITY, f64::min)
}

/// 1 − a profile's most used channel.
fn reserve_of(p: &DisplayProfile) -> f64 {
    1.0 - p
        .channel_usage
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Days from now until each display of `profiles` can no longer show its profile's
/// white at full drive, on a copy of `wall` run ahead `hours_per_day` per day (`None`:
/// not within `horizon_days`).
fn true_exhaustion_days(
    wall: &VirtualWall,
    profiles: &[DisplayProfile],
    hours_per_day: f64,
    horizon_days: f64,
) -> Result<Vec<Option<f64>>, SeasonError> {
    let ahead = wall.snapshot();
    let mut out = vec![None; profiles.len()];
    let days = horizon_days.clamp(0.0, 36_500.0) as u32;
    for day in 1..=days {
        ahead.advance_hours(hours_per_day);
        for (p, found) in profiles.iter().zip(out.iter_mut()) {
            if found.is_some() {
                continue;
            }
            let t = ahead.true_primaries(DisplayId(p.display.display))?;
            let usage = usage_for_white(t.black, [t.red, t.green, t.blue], p);
            if usage.iter().any(|u| u.is_nan() || *u > 1.0) {
                *found = Some(f64::from(day));
            }
        }
        if out.iter().all(Option::is_some) {
            break;
        }
    }
    Ok(out)
}

/// Error of a predicted date in days; a date beyond the horizon counts as the horizon.
fn forecast_error_days(predicted: Option<f64>, truth: Option<f64>, horizon_days: f64) -> f64 {
    (predicted.unwrap_or(horizon_days).min(horizon_days) - truth.unwrap_or(horizon_days)).abs()
}

/// The night-by-night plot: white luminance and reserve (left), truth ΔE2000 with its
/// limits (right), as SVG.
fn plot_svg(rows: &[NightRow], limits_de: &[f64; 3]) -> String {
    let (w, h, pad) = (900.0, 300.0, 50.0);
    let last = rows.last().map_or(1.0, |r| f64::from(r.night.max(1)));
    let x = |n: u32| pad + (w - 2.0 * pad) * f64::from(n) / last;
    let max_white = rows.iter().map(|r| r.white_cd_m2).fold(1e-9, f64::max) * 1.1;
    let max_de = rows
        .iter()
        .map(|r| r.truth_max_de)
        .chain(limits_de.iter().copied())
        .fold(1e-9, f64::max)
        * 1.1;
    let y = |v: f64, top: f64| h - pad - (h - 2.0 * pad) * (v / top).clamp(0.0, 1.0);
    let line = |f: &dyn Fn(&NightRow) -> f64, top: f64, colour: &str| {
        let pts: Vec<String> = rows
            .iter()
            .map(|r| format!("{:.1},{:.1}", x(r.night), y(f(r), top)))
            .collect();
        format!(
            "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\" points=\"{}\"/>\n",
            pts.join(" ")
        )
    };
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{}\" font-family=\"sans-serif\" font-size=\"12\">\n",
        2.0 * h
    );
    s += &format!(
        "<text x=\"{pad}\" y=\"20\">common white, cd/m² (black, 0 to {max_white:.1}); least reserve × {max_white:.1} (grey)</text>\n"
    );
    s += &line(&|r| r.white_cd_m2, max_white, "black");
    s += &line(&|r| r.least_reserve.max(0.0) * max_white, max_white, "grey");
    s += &format!("<g transform=\"translate(0,{h})\">\n");
    s += &format!(
        "<text x=\"{pad}\" y=\"20\">truth ΔE2000 (0 to {max_de:.2}): median (blue), max (red), white (green); dashed: limits</text>\n"
    );
    s += &line(&|r| r.truth_median_de, max_de, "blue");
    s += &line(&|r| r.truth_max_de, max_de, "red");
    s += &line(&|r| r.truth_white_de, max_de, "green");
    for (l, colour) in limits_de.iter().zip(["blue", "red", "green"]) {
        let yy = y(*l, max_de);
        s += &format!(
            "<line x1=\"{pad}\" x2=\"{}\" y1=\"{yy:.1}\" y2=\"{yy:.1}\" stroke=\"{colour}\" stroke-dasharray=\"4 3\"/>\n",
            w - pad
        );
    }
    for r in rows.iter().filter(|r| r.lamp_changed.is_some()) {
        s += &format!(
            "<line x1=\"{0:.1}\" x2=\"{0:.1}\" y1=\"{pad}\" y2=\"{1}\" stroke=\"orange\"/><text x=\"{0:.1}\" y=\"{2}\">lamp change</text>\n",
            x(r.night),
            h - pad,
            pad - 5.0
        );
    }
    s += &format!(
        "<text x=\"{}\" y=\"{}\">night</text>\n</g>\n</svg>\n",
        w / 2.0,
        h - 15.0
    );
    s
}

/// Makes the scratch folder and removes an earlier season's store from it (its runs
/// would collide with this season's dates); checked before the hours of work.
fn prepare_out_dir(out: &Path) -> Result<PathBuf, SeasonError> {
    let io = |path: &Path, source| {
        SeasonError::Profile(ProfileError::Io {
            path: path.to_path_buf(),
            source,
        })
    };
    std::fs::create_dir_all(out).map_err(|e| io(out, e))?;
    let store = out.join("season.lumistore");
    for suffix in ["", "-wal", "-shm"] {
        let p = PathBuf::from(format!("{}{suffix}", store.display()));
        match std::fs::remove_file(&p) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io(&p, e)),
            _ => {}
        }
    }
    Ok(store)
}
