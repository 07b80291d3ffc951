//! `lumiwall bench readings`: calibration accuracy against the number of meter readings.
//!
//! For each meter error model and each reading budget the wall is commissioned and
//! then verified with the same meter; one [`ReadingsRow`] per run.
#![cfg(feature = "readings")]

use std::path::PathBuf;
use std::time::{Duration, Instant};

use lumiwall_calib::commission::{CommissionError, CommissionOptions};
use lumiwall_calib::measure::MeasureOptions;
use lumiwall_calib::solve::SolveOptions;
use lumiwall_calib::station::{MeterChoice, Noise, Station, StationError, StationOptions};
use lumiwall_calib::verify::{VerifyError, default_targets};

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
    /// Verify patches per display.
    pub patches: usize,
    /// Scratch folder for the profiles of each run (one sub-folder per run).
    pub out: PathBuf,
}

/// One commission-and-verify run.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadingsRow {
    /// Error model of the meter.
    pub noise: Noise,
    /// Reading budget per display.
    pub budget: u32,
    /// Most readings any display took.
    pub max_readings: u32,
    /// Median ΔE2000 over every verified patch.
    pub median_de: f64,
    /// Largest ΔE2000.
    pub max_de: f64,
    /// Largest |ΔL| in percent.
    pub max_abs_dl_percent: f64,
    /// Wall time of commissioning and verification.
    pub elapsed: Duration,
}

/// Why a run of the benchmark failed.
#[derive(Debug, thiserror::Error)]
pub enum ReadingsError {
    /// The station could not be opened.
    #[error(transparent)]
    Station(#[from] StationError),
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

/// Commissions the wall with `budget` readings per display and verifies it with the
/// same meter model.
fn run_one(bench: &ReadingsBench, noise: Noise, budget: u32) -> Result<ReadingsRow, ReadingsError> {
    let started = Instant::now();
    let mut station = Station::open(
        &bench.wall,
        &StationOptions::new(bench.meter.clone(), noise),
    )?;
    let out = bench.out.join(format!("{}-{budget}", noise.name()));
    let opts = CommissionOptions {
        measure: MeasureOptions {
            budget,
            ..MeasureOptions::default()
        },
        solve: bench.solve,
        resume: false,
        meter_correction: true,
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
    let targets = default_targets(profiles, bench.patches).map_err(Box::new)?;
    let report = station
        .verify_commissioned(&outcome, profiles, &targets)
        .map_err(Box::new)?;
    Ok(ReadingsRow {
        noise,
        budget,
        max_readings,
        median_de: report.overall.median_de,
        max_de: report.overall.max_de,
        max_abs_dl_percent: report.overall.max_abs_dl_percent,
        elapsed: started.elapsed(),
    })
}
