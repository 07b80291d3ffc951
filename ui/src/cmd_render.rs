//! `lumiwall render` (being written).

use crate::CliError;

/// Arguments of `lumiwall render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {}

/// Runs `lumiwall render`.
pub fn run(_args: RenderArgs) -> Result<(), CliError> {
    Err(CliError::failure("`lumiwall render` is not built yet"))
}

/// Arguments of the matching `lumiwall bench` subcommand.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {}

/// Runs the matching `lumiwall bench` subcommand.
pub fn bench(_args: BenchArgs) -> Result<(), CliError> {
    Err(CliError::failure("this benchmark is not built yet"))
}
