//! `lumiwall commission` (being written).

use crate::CliError;

/// Arguments of `lumiwall commission`.
#[derive(Debug, clap::Args)]
pub struct CommissionArgs {}

/// Runs `lumiwall commission`.
pub fn run(_args: CommissionArgs) -> Result<(), CliError> {
    Err(CliError::failure("`lumiwall commission` is not built yet"))
}

/// Arguments of the matching `lumiwall bench` subcommand.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {}

/// Runs the matching `lumiwall bench` subcommand.
pub fn bench(_args: BenchArgs) -> Result<(), CliError> {
    Err(CliError::failure("this benchmark is not built yet"))
}
