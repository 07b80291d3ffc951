//! `lumiwall apply` (being written).

use crate::CliError;

/// Arguments of `lumiwall apply`.
#[derive(Debug, clap::Args)]
pub struct ApplyArgs {}

/// Runs `lumiwall apply`.
pub fn run(_args: ApplyArgs) -> Result<(), CliError> {
    Err(CliError::failure("`lumiwall apply` is not built yet"))
}

/// Arguments of the matching `lumiwall bench` subcommand.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {}

/// Runs the matching `lumiwall bench` subcommand.
pub fn bench(_args: BenchArgs) -> Result<(), CliError> {
    Err(CliError::failure("this benchmark is not built yet"))
}
