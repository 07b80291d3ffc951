//! `lumiwall bench readings`: calibration accuracy against the number of meter readings.
//!
//! For each meter error model and each reading budget the wall is commissioned and
//! then verified against the truth: the 51-patch chart read by a perfect meter on the
//! same wall, so the station meter's own error stays in the figures. With the realistic
//! meter the station first matches its meter to the simulated reference
//! spectroradiometer (one matrix per eye, `lumiwall meter-matrix`), as a station
//! commissioning Infitec walls with a filter colorimeter would. Each row says whether
//! it meets issue 12's limits ([`Limits`]); one [`ReadingsRow`] per run.
#![cfg(feature = "readings")]

use std::path::PathBuf;
use std::time::{Duration, Instant};

use lumiwall_calib::commission::{CommissionError, CommissionOptions};
use lumiwall_calib::measure::MeasureOptions;
use lumiwall_calib::measure::grey_drives::GreyLevel;
use lumiwall_calib::measure::meter_matrix::{MeterMatrices, MeterMatrixError};
use lumiwall_calib::solve::SolveOptions;
use lumiwall_calib::station::{MeterChoice, Noise, Station, StationError, StationOptions};
use lumiwall_calib::verify::{Summary, VerifyError, VerifyOptions, chart_targets};
use lumiwall_devices::sim::SpectroModel;

/// What to compare.
#[derive(Debug, Clone)]
pub struct ReadingsBench {
    /// Wall description (TOML).
    pub wall: PathBuf,
    /// Reading budgets per display to compare.
    pub budgets: Vec<u32>,
    /// Meter path.
    pub meter: MeterChoice,
    /// The wall solve of every run.
    pub solve: SolveOptions,
    /// Verify patches per display (unused: the 51-patch chart is read).
    pub patches: usize,
    /// Scratch folder for the profiles of each run (one sub-folder per run).
    pub out: PathBuf,
    /// Wait for the wall to warm up before each commissioning (`commission
    /// --warm-up`), as a station does on a wall just switched on.
    pub warm_up: bool,
    /// Without `warm_up`: check first whether the wall is warming and wait when it is,
    /// as `commission` does unless `--no-warm-check`.
    pub warm_check: bool,
    /// Match the realistic meter to the reference on every display (`meter-matrix
    /// --per-display`) instead of once per eye; `None`: as `meter-matrix` does by
    /// default on the wall ([`Station::per_display_matrices_by_default`]).
    pub per_display_matrix: Option<bool>,
    /// The simulated reference spectroradiometer the realistic meter is matched to
    /// ([`SpectroModel::cs2000`] by default; [`SpectroModel::noiseless`] shows what
    /// the station reaches when the reference adds no error of its own).
    pub reference: SpectroModel,
    /// The grey-drive pass's greys (`commission --grey-levels`); `None`: commission's
    /// default ([`lumiwall_calib::measure::grey_drives::default_levels`]).
    pub grey_levels: Option<Vec<GreyLevel>>,
}

/// The reference of [`ReadingsBench::reference`] by default: the simulated CS-2000 of
/// serial number 2000, the unit `lumiwall meter-matrix` simulates by default.
pub fn default_reference() -> SpectroModel {
    SpectroModel::cs2000(DEFAULT_REFERENCE_SEED)
}

/// Serial number of the simulated reference of [`default_reference`].
pub const DEFAULT_REFERENCE_SEED: u64 = 2000;

/// One commission-and-verify run.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadingsRow {
    /// Error model of the meter.
    pub noise: Noise,
    /// Reading budget per display.
    pub budget: u32,
    /// Most readings any display took.
    pub max_readings: u32,
    /// The truth's figures over every display's chart.
    pub truth: Summary,
    /// Worst white ΔE2000 of any display.
    pub worst_white_de: f64,
    /// Worst grey balance (mean |ΔC'|) of any display.
    pub worst_grey_balance: f64,
    /// The limits the row is held to.
    pub limits: Limits,
    /// Wall time of commissioning and verification.
    pub elapsed: Duration,
}

/// Issue 12's acceptance limits: noiseless median ≤ 0.5 and max ≤ 2.0; with the
/// realistic meter, against the truth, median ≤ 1.0, max ≤ 3.0, white ≤ 1.0 and grey
/// balance ≤ 0.5.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Median ΔE2000.
    pub median_de: f64,
    /// Largest ΔE2000.
    pub max_de: f64,
    /// White ΔE2000 of every display.
    pub white_de: f64,
    /// Grey balance of every display.
    pub grey_balance: f64,
}

impl Limits {
    /// The limits for a meter error model.
    pub fn for_noise(noise: Noise) -> Self {
        match noise {
            Noise::None => Limits {
                median_de: 0.5,
                max_de: 2.0,
                white_de: f64::INFINITY,
                grey_balance: f64::INFINITY,
            },
            Noise::Realistic => Limits {
                median_de: 1.0,
                max_de: 3.0,
                white_de: 1.0,
                grey_balance: 0.5,
            },
        }
    }
}

impl ReadingsRow {
    /// True when every figure is within [`ReadingsRow::limits`].
    pub fn meets_limits(&self) -> bool {
        let l = &self.limits;
        self.truth.median_de <= l.median_de
            && self.truth.max_de <= l.max_de
            && self.worst_white_de <= l.white_de
            && self.worst_grey_balance <= l.grey_balance
    }
}

/// Why a run of the benchmark failed.
#[derive(Debug, thiserror::Error)]
pub enum ReadingsError {
    /// The station could not be opened.
    #[error(transparent)]
    Station(#[from] StationError),
    /// The meter could not be matched to the reference.
    #[error(transparent)]
    MeterMatrix(#[from] MeterMatrixError),
    /// Commissioning failed.
    #[error("budget {budget}: {source}")]
    Commission {
        /// The budget of the failed run.
        budget: u32,
        /// What failed (boxed: the error is large).
        #[source]
        source: Box<CommissionError>,
    },
    /// Verification failed (boxed: the error is large).
    #[error(transparent)]
    Verify(#[from] Box<VerifyError>),
    /// A budget is below [`MeasureOptions::MIN_BUDGET`] (checked before any run).
    #[error(
        "a budget of {budget} readings per display is too small: every display needs at \
         least {min}; raise it to {min} or more"
    )]
    BudgetTooSmall {
        /// The budget asked for.
        budget: u32,
        /// Smallest workable budget.
        min: u32,
    },
}

/// Runs every noise model (exact first) and budget; `on_row` sees each row as it is
/// finished (the benchmark takes minutes).
pub fn run(
    bench: &ReadingsBench,
    on_row: &mut dyn FnMut(&ReadingsRow),
) -> Result<Vec<ReadingsRow>, ReadingsError> {
    let min = MeasureOptions::MIN_BUDGET;
    if let Some(&budget) = bench.budgets.iter().find(|&&b| b < min) {
        return Err(ReadingsError::BudgetTooSmall { budget, min });
    }
    let mut rows = Vec::new();
    for noise in Noise::ALL {
        for &budget in &bench.budgets {
            let row = run_one(bench, noise, budget)?;
            on_row(&row);
            rows.push(row);
        }
    }
    Ok(rows)
}

/// With the realistic meter, the station's meter matched to the simulated reference
/// spectroradiometer `reference` (its wavelength scale checked with a Hg-Ar lamp; one
/// matrix per eye, or per display), as a station commissioning Infitec walls with a
/// filter colorimeter would; nothing for the exact meter.
pub(crate) fn match_meter(
    station: &mut Station,
    noise: Noise,
    reference: &SpectroModel,
    per_display: bool,
) -> Result<Option<MeterMatrices>, MeterMatrixError> {
    Ok(match noise {
        Noise::Realistic => {
            Some(station.meter_matrices_against_simulated(reference.clone(), per_display)?)
        }
        Noise::None => None,
    })
}

/// Commissions the wall with `budget` readings per display (after matching a noisy
/// meter to the reference) and verifies the chart against the truth.
fn run_one(bench: &ReadingsBench, noise: Noise, budget: u32) -> Result<ReadingsRow, ReadingsError> {
    let started = Instant::now();
    let mut station = Station::open(
        &bench.wall,
        &StationOptions::new(bench.meter.clone(), noise),
    )?;
    let per_display = bench
        .per_display_matrix
        .unwrap_or_else(|| station.per_display_matrices_by_default());
    let meter_matrix = match_meter(&mut station, noise, &bench.reference, per_display)?;
    let out = bench.out.join(format!("{}-{budget}", noise.name()));
    let opts = CommissionOptions {
        measure: MeasureOptions {
            budget,
            meter_matrix,
            warm_up: bench
                .warm_up
                .then(lumiwall_calib::measure::warm_up::WarmUp::default),
            ..MeasureOptions::default()
        },
        solve: bench.solve,
        resume: false,
        meter_correction: false,
        warm_check: bench
            .warm_check
            .then(lumiwall_calib::measure::warm_up::WarmCheck::default),
        grey_levels: bench
            .grey_levels
            .clone()
            .unwrap_or_else(lumiwall_calib::measure::grey_drives::default_levels),
    };
    let outcome =
        station
            .commission(&out, &opts, &mut |_| {})
            .map_err(|e| ReadingsError::Commission {
                budget,
                source: Box::new(e),
            })?;
    let max_readings = outcome
        .measured
        .iter()
        .map(|m| m.measurement.readings)
        .max()
        .unwrap_or(0);
    let profiles = &outcome.solution.profiles;
    let targets = chart_targets(profiles).map_err(Box::new)?;
    let mut truth = Station::with_wall(
        station.wall.clone(),
        &StationOptions::new(MeterChoice::Direct, Noise::None),
    )?;
    drop(station);
    let opts = VerifyOptions {
        patches: targets.len(),
        ..VerifyOptions::default()
    };
    let report = truth
        .verify(profiles, &targets, &opts, &mut |_| {})
        .map_err(Box::new)?;
    let worst = |f: fn(&Summary) -> Option<f64>| {
        report
            .per_display
            .iter()
            .map(|(_, s)| f(s).unwrap_or(f64::NAN))
            .fold(0.0, |a: f64, b| if b.is_nan() || b > a { b } else { a })
    };
    Ok(ReadingsRow {
        noise,
        budget,
        max_readings,
        worst_white_de: worst(|s| s.white_de),
        worst_grey_balance: worst(|s| s.grey_balance),
        truth: report.overall,
        limits: Limits::for_noise(noise),
        elapsed: started.elapsed(),
    })
}
