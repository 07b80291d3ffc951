//! `lumiwall bench cie171`: the CIE 171:2006 analytical test cases (point and area
//! sources, flux conservation, reflection off a floor, inter-reflection in a cube up
//! to ρ = 0.95) solved as `lumiwall render` solves a scene, each compared with its
//! closed form. The expected values come from `fixtures/scenes/cie171/make_cie171.py`,
//! which derives them from the formulas (and cross-checks them by quadrature); no
//! lumiwall code computes them.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use lumiwall_render::radiosity::sensors::{
    SensorError, SensorReading, illuminance_at_sensors, read_sensors_csv,
};
use lumiwall_render::radiosity::{
    HierarchicalOptions, RadiosityError, SceneOccluders, Solution, StopRule, solve_hierarchical,
};
use lumiwall_render::scene::{SceneError, load_scene};

/// CIE 171's own criterion per point, as a fraction (ours is [`OUR_LIMIT`]).
pub const CIE_POINT_LIMIT: f64 = 0.05;

/// Our criterion per point and for the averages, as a fraction, at the default target.
pub const OUR_LIMIT: f64 = 0.01;

/// Why the benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum Cie171Error {
    /// A fixture file is missing or malformed.
    #[error("{path}: {message}")]
    Fixture {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A case's scene cannot be loaded.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A case's sensor file cannot be read.
    #[error(transparent)]
    Sensors(#[from] SensorError),
    /// The solver failed.
    #[error(transparent)]
    Radiosity(#[from] RadiosityError),
}

/// One case of `cases.toml`: a scene and what to compare.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseSpec {
    id: String,
    title: String,
    scene: PathBuf,
    sensors: Option<PathBuf>,
    expected: Option<PathBuf>,
    received_flux_lm: Option<f64>,
    direct_mean_lx: Option<f64>,
    indirect_mean_lx: Option<f64>,
}

#[derive(Debug, serde::Deserialize)]
struct CasesFile {
    case: Vec<CaseSpec>,
}

/// What one case compares.
#[derive(Debug, Clone, PartialEq)]
pub enum Quantity {
    /// Illuminance at sensor points (lx).
    PointIlluminance {
        /// Number of points.
        points: usize,
    },
    /// Flux received by all surfaces of a black room (lm).
    ReceivedFlux,
    /// Area-mean indirect illuminance over all surfaces (lx).
    MeanIndirect,
}

/// One row of the table.
#[derive(Debug, Clone)]
pub struct CaseRow {
    /// The case, e.g. `5.8 ρ=0.95`.
    pub id: String,
    /// What the case is.
    pub title: String,
    /// What was compared.
    pub quantity: Quantity,
    /// Expected value (one point's or the mean's, for orientation; the largest for
    /// point sets).
    pub expected: f64,
    /// The computed value of a single-valued quantity (flux, mean); `None` for point
    /// sets.
    pub measured: Option<f64>,
    /// Largest relative error over the points (or of the single value).
    pub max_rel_error: f64,
    /// Mean relative error over the points (or of the single value).
    pub mean_rel_error: f64,
    /// For the mean indirect illuminance: the relative error of the total mean
    /// (direct + indirect), the quantity the solver's estimate is relative to.
    pub total_rel_error: Option<f64>,
    /// The solver's own estimate of its relative error at the end.
    pub estimated_error: f64,
    /// Leaf patches of the solution.
    pub patches: usize,
    /// Solve plus evaluation time in seconds.
    pub time_s: f64,
}

impl CaseRow {
    /// Whether the case meets our criterion: every value within [`OUR_LIMIT`]; for
    /// inter-reflection, the total mean (what the solver's estimate is relative to)
    /// within the limit and within the estimate, and the indirect part within the limit
    /// at every ρ (at ρ = 0.05 it is 5 % of the total).
    pub fn passes(&self) -> bool {
        match (self.quantity.clone(), self.total_rel_error) {
            (Quantity::MeanIndirect, Some(total)) => {
                total <= OUR_LIMIT
                    && total <= self.estimated_error
                    && self.max_rel_error <= OUR_LIMIT
            }
            _ => self.max_rel_error <= OUR_LIMIT,
        }
    }
}

/// Runs every case of `cases_file` (`fixtures/scenes/cie171/cases.toml`) at the
/// relative target error `target_error` with the hierarchical solver's defaults,
/// calling `row` for each result as it comes.
pub fn run(
    cases_file: &Path,
    target_error: f64,
    row: impl FnMut(&CaseRow),
) -> Result<Vec<CaseRow>, Cie171Error> {
    run_selected(cases_file, target_error, |_| true, row)
}

/// [`run`] for the cases whose id `select` accepts (tests split the stiff cases off to
/// run beside the others).
pub fn run_selected(
    cases_file: &Path,
    target_error: f64,
    select: impl Fn(&str) -> bool,
    mut row: impl FnMut(&CaseRow),
) -> Result<Vec<CaseRow>, Cie171Error> {
    let dir = cases_file.parent().unwrap_or(Path::new("."));
    let text = std::fs::read_to_string(cases_file).map_err(|e| fixture(cases_file, e))?;
    let cases: CasesFile = toml::from_str(&text).map_err(|e| fixture(cases_file, e))?;
    let mut rows = Vec::new();
    for spec in cases.case.iter().filter(|c| select(&c.id)) {
        let r = run_case(dir, spec, target_error)?;
        row(&r);
        rows.push(r);
    }
    Ok(rows)
}

fn fixture(path: &Path, e: impl std::fmt::Display) -> Cie171Error {
    Cie171Error::Fixture {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// What a comparison found, before the row is assembled.
struct Comparison {
    quantity: Quantity,
    expected: f64,
    measured: Option<f64>,
    total_rel_error: Option<f64>,
    errors: Vec<f64>,
}

/// Solves one case and compares it.
fn run_case(dir: &Path, spec: &CaseSpec, target_error: f64) -> Result<CaseRow, Cie171Error> {
    let start = Instant::now();
    let (scene, _) = load_scene(&dir.join(&spec.scene))?;
    let occluders = SceneOccluders::new(&scene);
    let opts = HierarchicalOptions {
        stop: StopRule {
            target_error,
            time_limit: None,
            max_iterations: usize::MAX,
        },
        ..HierarchicalOptions::default()
    };
    let sol = solve_hierarchical(&scene, &occluders, &opts)?;
    let c = match (&spec.sensors, &spec.expected) {
        (Some(sensors), Some(expected)) => {
            let sensors = read_sensors_csv(&dir.join(sensors))?;
            let truth = read_expected(&dir.join(expected))?;
            let readings = illuminance_at_sensors(&scene, &sol, &occluders, &sensors);
            compare_points(&readings, &truth, &dir.join(expected))?
        }
        _ => compare_totals(spec, &sol).ok_or_else(|| {
            fixture(
                &dir.join(&spec.scene),
                format!("case `{}` names nothing to compare", spec.id),
            )
        })?,
    };
    Ok(CaseRow {
        id: spec.id.clone(),
        title: spec.title.clone(),
        quantity: c.quantity,
        expected: c.expected,
        measured: c.measured,
        total_rel_error: c.total_rel_error,
        max_rel_error: c.errors.iter().copied().fold(0.0, f64::max),
        mean_rel_error: c.errors.iter().sum::<f64>() / c.errors.len().max(1) as f64,
        estimated_error: sol.curve.points.last().map_or(0.0, |p| p.estimated_error),
        patches: sol.stats.patches,
        time_s: start.elapsed().as_secs_f64(),
    })
}

/// Illuminance at the sensors against the expected values (`expected` names the file).
fn compare_points(
    readings: &[SensorReading],
    truth: &HashMap<String, f64>,
    expected: &Path,
) -> Result<Comparison, Cie171Error> {
    let mut errors = Vec::new();
    let mut largest: f64 = 0.0;
    for r in readings {
        let want = *truth
            .get(&r.name)
            .ok_or_else(|| fixture(expected, format!("no value for sensor `{}`", r.name)))?;
        largest = largest.max(want);
        errors.push(relative(r.illuminance_lx(), want));
    }
    Ok(Comparison {
        quantity: Quantity::PointIlluminance {
            points: errors.len(),
        },
        expected: largest,
        measured: None,
        total_rel_error: None,
        errors,
    })
}

/// The received flux or the mean indirect illuminance against the case's value;
/// `None` when the case gives neither.
fn compare_totals(spec: &CaseSpec, sol: &Solution) -> Option<Comparison> {
    if let Some(flux) = spec.received_flux_lm {
        let got = sol.received_flux_lm();
        return Some(Comparison {
            quantity: Quantity::ReceivedFlux,
            expected: flux,
            measured: Some(got),
            total_rel_error: None,
            errors: vec![relative(got, flux)],
        });
    }
    let (direct, indirect) = (spec.direct_mean_lx?, spec.indirect_mean_lx?);
    let total = mean_irradiance_lx(sol);
    let got = total - direct;
    Some(Comparison {
        quantity: Quantity::MeanIndirect,
        expected: indirect,
        measured: Some(got),
        total_rel_error: Some(relative(total, direct + indirect)),
        errors: vec![relative(got, indirect)],
    })
}

fn relative(got: f64, want: f64) -> f64 {
    if want == 0.0 {
        got.abs()
    } else {
        ((got - want) / want).abs()
    }
}

/// Area-mean illuminance Y over every patch (lx).
fn mean_irradiance_lx(sol: &Solution) -> f64 {
    sol.received_flux_lm() / sol.total_area_m2().max(f64::MIN_POSITIVE)
}

/// `name,illuminance_lx` rows.
fn read_expected(path: &Path) -> Result<HashMap<String, f64>, Cie171Error> {
    #[derive(serde::Deserialize)]
    struct Row {
        name: String,
        illuminance_lx: f64,
    }
    let mut rdr = csv::Reader::from_path(path).map_err(|e| fixture(path, e))?;
    rdr.deserialize::<Row>()
        .map(|r| {
            r.map(|r| (r.name, r.illuminance_lx))
                .map_err(|e| fixture(path, e))
        })
        .collect()
}
