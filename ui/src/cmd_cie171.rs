//! `lumiwall bench cie171`: the CIE 171:2006 analytical test cases against their
//! closed forms (run by `lumiwall_bench::cie171`), printed as one table.

use std::path::PathBuf;

use lumiwall_bench::cie171::{self, CIE_POINT_LIMIT, CaseRow, Cie171Error, OUR_LIMIT, Quantity};

use crate::CliError;
use crate::values;

/// Arguments of `lumiwall bench cie171`.
#[derive(Debug, clap::Args)]
pub(crate) struct Cie171Args {
    /// The case index (scenes, sensor grids and expected values beside it).
    #[arg(long, default_value = "fixtures/scenes/cie171/cases.toml")]
    cases: PathBuf,
    /// Requested relative error of every solve (the default is `lumiwall render`'s).
    #[arg(long, allow_negative_numbers = true, default_value = "1%", value_parser = values::fraction)]
    error: f64,
}

impl From<Cie171Error> for CliError {
    /// A missing or malformed fixture is input (exit 2); a failed solve a failure.
    fn from(e: Cie171Error) -> Self {
        match e {
            Cie171Error::Radiosity(_) => Self::failure(e.to_string()),
            _ => Self::input(e.to_string()),
        }
    }
}

/// Runs the cases and prints the table; exit code 3 when one misses our limit.
pub(crate) fn bench(args: Cie171Args) -> Result<(), CliError> {
    println!(
        "CIE 171:2006 test cases, hierarchical radiosity at --error {:.3} %; CIE's criterion {:.0} % per point, ours {:.0} %",
        100.0 * args.error,
        100.0 * CIE_POINT_LIMIT,
        100.0 * OUR_LIMIT
    );
    println!(
        "{:<12} {:<22} {:>12} {:>10} {:>10} {:>10} {:>9} {:>8} {:>8}  {:<6} what",
        "case",
        "quantity",
        "expected",
        "computed",
        "max_err",
        "mean_err",
        "estimate",
        "patches",
        "time_s",
        "result"
    );
    let rows = cie171::run(&args.cases, args.error, print_row)?;
    let failed: Vec<&str> = rows
        .iter()
        .filter(|r| !r.passes())
        .map(|r| r.id.as_str())
        .collect();
    if failed.is_empty() {
        println!(
            "all {} cases meet {:.0} % (inter-reflection: the total mean and the indirect \
             part alone)",
            rows.len(),
            100.0 * OUR_LIMIT,
        );
        Ok(())
    } else {
        Err(CliError::tolerance(format!(
            "CIE 171 cases above {:.0} %: {}",
            100.0 * OUR_LIMIT,
            failed.join(", ")
        )))
    }
}

fn print_row(r: &CaseRow) {
    let (quantity, unit) = match r.quantity {
        Quantity::PointIlluminance { points } => (format!("E at {points} points"), "lx max"),
        Quantity::ReceivedFlux => ("received flux".to_string(), "lm"),
        Quantity::MeanIndirect => ("mean indirect E".to_string(), "lx"),
    };
    println!(
        "{:<12} {:<22} {:>9.3} {:<2} {:>10} {:>9.4}% {:>9.4}% {:>8.3}% {:>8} {:>8.2}  {:<6} {}",
        r.id,
        quantity,
        r.expected,
        unit.split(' ').next().unwrap_or(unit),
        r.measured.map_or("-".to_string(), |m| format!("{m:.3}")),
        100.0 * r.max_rel_error,
        100.0 * r.mean_rel_error,
        100.0 * r.estimated_error,
        r.patches,
        r.time_s,
        if r.passes() { "meet" } else { "FAIL" },
        r.title
    );
    if let Some(total) = r.total_rel_error {
        println!(
            "{:<12} {:<22} error of the total mean illuminance (direct + indirect): {:.4} %",
            "",
            "",
            100.0 * total
        );
    }
}
