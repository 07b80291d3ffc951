//! `lumiwall bench readings`: calibration accuracy against the number of meter readings.
//!
//! For each meter error model and each reading budget the wall is commissioned and
//! then verified against the truth: the 51-patch chart read by a perfect meter on the
//! same wall, so the station meter's own error stays in the figures. With the realistic
//! meter the station first matches its meter to the simulated reference
//! spectroradiometer (one matrix per eye, `lumiwall meter-matrix`), as a station
//! commissioning Infitec walls with a filter colorimeter would. Each row says whether
//! it meets issue 12's limits ([`Limits`]); one [`ReadingsRow`] per run.
//!
//! With [`ReadingsBench::seeds`] the wall file stands for its class: every run is
//! repeated on the wall built with each seed in place of the file's (its manufacturing
//! scatter and meter noise drawn again: walls the station has never seen), and
//! [`class_summaries`] counts, per meter model and budget, the runs within the limits.
#![cfg(feature = "readings")]

use std::ops::RangeInclusive;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use lumiwall_calib::commission::{CommissionError, CommissionOptions};
use lumiwall_calib::measure::averaging::Averaging;
use lumiwall_calib::measure::grey_drives::GreyLevel;
use lumiwall_calib::measure::meter_matrix::{MeterMatrices, MeterMatrixError};
use lumiwall_calib::measure::{MeasureOptions, MeasuredDisplay};
use lumiwall_calib::solve::SolveOptions;
use lumiwall_calib::station::{MeterChoice, Noise, Station, StationError, StationOptions};
use lumiwall_calib::verify::{Summary, VerifyError, VerifyOptions, chart_targets};
use lumiwall_devices::DeviceError;
use lumiwall_devices::sim::{SpectroModel, VirtualWall};

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
    /// Meter readings each reading averages (`commission --averaging`).
    pub averaging: Averaging,
    /// The meter error models to run, in this order.
    pub noises: Vec<Noise>,
    /// Seeds to build the wall with in place of the file's, one instance of its class
    /// each (at most [`MAX_SEEDS`]); `None`: the wall as the file says.
    pub seeds: Option<RangeInclusive<u64>>,
}

/// Most seeds one run of the benchmark takes ([`ReadingsBench::seeds`]).
pub const MAX_SEEDS: u64 = 10_000;

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
    /// The seed the wall was built with in place of the file's (`None`: the file's).
    pub seed: Option<u64>,
    /// Error model of the meter.
    pub noise: Noise,
    /// Reading budget per display.
    pub budget: u32,
    /// Most meter readings any display took
    /// ([`lumiwall_calib::measure::MeasuredDisplay::meter_readings`]: its readings times
    /// the meter readings each averaged, and a first survey read again).
    pub max_readings: u32,
    /// Luminance of the common white the commissioning chose (cd/m²): how dim the wall
    /// is.
    pub wall_white_cd_m2: f64,
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
    /// The wall file could not be built with a seed of [`ReadingsBench::seeds`].
    #[error("wall {path} with seed {seed}: {source}")]
    Wall {
        /// The wall file.
        path: PathBuf,
        /// The seed.
        seed: u64,
        /// What failed.
        #[source]
        source: DeviceError,
    },
    /// The seed range is empty or longer than [`MAX_SEEDS`] (checked before any run).
    #[error(
        "seeds {first}-{last}: give a first seed at or below the last, and at most {max} \
         seeds"
    )]
    Seeds {
        /// First seed asked for.
        first: u64,
        /// Last seed asked for.
        last: u64,
        /// Most seeds allowed.
        max: u64,
    },
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
    check_bench(bench)?;
    let seeds: Vec<Option<u64>> = match &bench.seeds {
        Some(r) => r.clone().map(Some).collect(),
        None => vec![None],
    };
    let mut rows = Vec::new();
    for seed in seeds {
        for &noise in &bench.noises {
            for &budget in &bench.budgets {
                let row = run_one(bench, seed, noise, budget)?;
                on_row(&row);
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// Checks the budgets and the seed range before any run.
fn check_bench(bench: &ReadingsBench) -> Result<(), ReadingsError> {
    let min = MeasureOptions::MIN_BUDGET;
    if let Some(&budget) = bench.budgets.iter().find(|&&b| b < min) {
        return Err(ReadingsError::BudgetTooSmall { budget, min });
    }
    if let Some(r) = &bench.seeds {
        let (first, last) = (*r.start(), *r.end());
        if first > last || last - first >= MAX_SEEDS {
            return Err(ReadingsError::Seeds {
                first,
                last,
                max: MAX_SEEDS,
            });
        }
    }
    Ok(())
}

/// What the runs of one meter model and budget over a class's seeds give: how many
/// meet the limits, and their figures at the worst display.
#[derive(Debug, Clone, PartialEq)]
pub struct ClassSummary {
    /// Error model of the meter.
    pub noise: Noise,
    /// Reading budget per display.
    pub budget: u32,
    /// Runs (one per seed).
    pub runs: usize,
    /// Runs within every limit ([`ReadingsRow::meets_limits`]).
    pub within: usize,
    /// Mean over the runs of the worst display's grey balance.
    pub mean_worst_grey_balance: f64,
    /// Largest worst-display white ΔE2000 of any run.
    pub worst_white_de: f64,
    /// Largest ΔE2000 of any run.
    pub max_de: f64,
    /// Largest median ΔE2000 of any run.
    pub worst_median_de: f64,
}

/// One [`ClassSummary`] per meter model and budget among `rows`, in the order first
/// seen.
pub fn class_summaries(rows: &[ReadingsRow]) -> Vec<ClassSummary> {
    let mut keys: Vec<(Noise, u32)> = Vec::new();
    for r in rows {
        if !keys.contains(&(r.noise, r.budget)) {
            keys.push((r.noise, r.budget));
        }
    }
    keys.into_iter()
        .map(|(noise, budget)| {
            let of: Vec<&ReadingsRow> = rows
                .iter()
                .filter(|r| r.noise == noise && r.budget == budget)
                .collect();
            let largest = |f: fn(&ReadingsRow) -> f64| of.iter().map(|r| f(r)).fold(0.0, f64::max);
            ClassSummary {
                noise,
                budget,
                runs: of.len(),
                within: of.iter().filter(|r| r.meets_limits()).count(),
                mean_worst_grey_balance: of.iter().map(|r| r.worst_grey_balance).sum::<f64>()
                    / of.len() as f64,
                worst_white_de: largest(|r| r.worst_white_de),
                max_de: largest(|r| r.truth.max_de),
                worst_median_de: largest(|r| r.truth.median_de),
            }
        })
        .collect()
}

/// The wall of `bench` for one run: the file's, or built with `seed` in its place.
fn open_station(
    bench: &ReadingsBench,
    seed: Option<u64>,
    noise: Noise,
) -> Result<Station, ReadingsError> {
    let opts = StationOptions::new(bench.meter.clone(), noise);
    let Some(seed) = seed else {
        return Ok(Station::open(&bench.wall, &opts)?);
    };
    let wall = VirtualWall::from_toml_file_with_seed(&bench.wall, seed).map_err(|source| {
        ReadingsError::Wall {
            path: bench.wall.clone(),
            seed,
            source,
        }
    })?;
    Ok(Station::with_wall(wall, &opts)?)
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

/// The scratch folder of one run: `noise-budget` under [`ReadingsBench::out`], under
/// `seed-N` for a seed of [`ReadingsBench::seeds`] (removed after the run:
/// [`remove_scratch`]).
fn run_dir(bench: &ReadingsBench, seed: Option<u64>, noise: Noise, budget: u32) -> PathBuf {
    let run = format!("{}-{budget}", noise.name());
    match seed {
        Some(seed) => bench.out.join(format!("seed-{seed}")).join(run),
        None => bench.out.join(run),
    }
}

/// Removes the scratch folder `dir` of a seed's run once its row is taken, and its
/// seed's folder once empty: over a range of seeds only the class table is kept (the
/// profiles, reports and run state of 60 seeds of heyewall-48 at two budgets and
/// two meter models are gigabytes). A folder that cannot be removed is only warned of.
fn remove_scratch(dir: &std::path::Path) {
    if let Err(e) = std::fs::remove_dir_all(dir) {
        tracing::warn!("cannot remove the scratch folder {}: {e}", dir.display());
        return;
    }
    if let Some(seed_dir) = dir.parent() {
        // Left where other runs of the seed are still in it.
        let _ = std::fs::remove_dir(seed_dir);
    }
}

/// The commissioning of one run: `budget` readings per display, the meter matched by
/// `meter_matrix`, the bench's solve, warm-up, warm check and grey levels, no resume
/// and no additivity-based meter correction.
fn commission_options(
    bench: &ReadingsBench,
    budget: u32,
    meter_matrix: Option<MeterMatrices>,
) -> CommissionOptions {
    CommissionOptions {
        measure: MeasureOptions {
            budget,
            meter_matrix,
            averaging: bench.averaging,
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
    }
}

/// Commissions the wall with `budget` readings per display (after matching a noisy
/// meter to the reference) and verifies the chart against the truth.
fn run_one(
    bench: &ReadingsBench,
    seed: Option<u64>,
    noise: Noise,
    budget: u32,
) -> Result<ReadingsRow, ReadingsError> {
    let started = Instant::now();
    let mut station = open_station(bench, seed, noise)?;
    let per_display = bench
        .per_display_matrix
        .unwrap_or_else(|| station.per_display_matrices_by_default());
    let meter_matrix = match_meter(&mut station, noise, &bench.reference, per_display)?;
    let out = run_dir(bench, seed, noise, budget);
    let opts = commission_options(bench, budget, meter_matrix);
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
        .map(MeasuredDisplay::meter_readings)
        .max()
        .unwrap_or(0);
    let wall_white_cd_m2 = outcome.solution.white_xyz_cd_m2.y;
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
    if seed.is_some() {
        remove_scratch(&out);
    }
    let worst = |f: fn(&Summary) -> Option<f64>| {
        report
            .per_display
            .iter()
            .map(|(_, s)| f(s).unwrap_or(f64::NAN))
            .fold(0.0, |a: f64, b| if b.is_nan() || b > a { b } else { a })
    };
    Ok(ReadingsRow {
        seed,
        noise,
        budget,
        max_readings,
        wall_white_cd_m2,
        worst_white_de: worst(|s| s.white_de),
        worst_grey_balance: worst(|s| s.grey_balance),
        truth: report.overall,
        limits: Limits::for_noise(noise),
        elapsed: started.elapsed(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A realistic row of `budget` readings with these figures.
    fn row(seed: u64, budget: u32, max_de: f64, white: f64, grey: f64) -> ReadingsRow {
        ReadingsRow {
            seed: Some(seed),
            noise: Noise::Realistic,
            budget,
            max_readings: budget,
            wall_white_cd_m2: 12.0,
            truth: Summary {
                patches: 51,
                median_de: 0.5,
                max_de,
                mean_de: 0.5,
                p95_de: 0.8,
                white_de: Some(white),
                white_dl_percent: Some(0.0),
                grey_balance: Some(grey),
                median_abs_dl_percent: 0.1,
                max_abs_dl_percent: 1.0,
                median_dxy: 0.001,
                max_dxy: 0.002,
            },
            worst_white_de: white,
            worst_grey_balance: grey,
            limits: Limits::for_noise(Noise::Realistic),
            elapsed: Duration::ZERO,
        }
    }

    #[test]
    fn a_class_summary_counts_the_runs_within_the_limits_per_budget() {
        let rows = [
            row(1, 40, 1.0, 0.5, 0.4),
            row(1, 64, 1.0, 0.5, 0.3),
            row(2, 40, 3.5, 0.5, 0.4),
            row(2, 64, 1.2, 0.9, 0.2),
            row(3, 40, 1.0, 1.1, 0.7),
            row(3, 64, 1.1, 0.4, 0.6),
        ];
        let s = class_summaries(&rows);
        assert_eq!(s.len(), 2);
        assert_eq!((s[0].budget, s[0].runs, s[0].within), (40, 3, 1));
        assert!((s[0].mean_worst_grey_balance - 0.5).abs() < 1e-12);
        assert_eq!((s[0].worst_white_de, s[0].max_de), (1.1, 3.5));
        assert_eq!((s[1].budget, s[1].runs, s[1].within), (64, 3, 2));
        assert_eq!((s[1].worst_white_de, s[1].max_de), (0.9, 1.2));
    }

    #[test]
    fn seed_ranges_that_are_empty_or_too_long_are_refused_before_any_run() {
        let bench = |seeds| ReadingsBench {
            wall: PathBuf::from("no-such-wall.toml"),
            budgets: vec![40],
            meter: MeterChoice::Direct,
            solve: SolveOptions::default(),
            patches: 20,
            out: PathBuf::from("out"),
            warm_up: false,
            warm_check: false,
            per_display_matrix: None,
            reference: default_reference(),
            grey_levels: None,
            averaging: Averaging::Fixed(1),
            noises: vec![Noise::None],
            seeds: Some(seeds),
        };
        for seeds in [RangeInclusive::new(5, 4), 0..=MAX_SEEDS] {
            let err = run(&bench(seeds), &mut |_| {}).unwrap_err();
            assert!(matches!(err, ReadingsError::Seeds { .. }), "{err}");
        }
        // A workable range goes on to open the wall, which is missing here.
        let err = run(&bench(1..=MAX_SEEDS), &mut |_| {}).unwrap_err();
        assert!(matches!(err, ReadingsError::Wall { seed: 1, .. }), "{err}");
    }
}
