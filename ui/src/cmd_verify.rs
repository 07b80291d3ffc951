//! `lumiwall verify` (being written).

use crate::CliError;

/// Arguments of `lumiwall verify`.
#[derive(Debug, clap::Args)]
pub struct VerifyArgs {}

/// Runs `lumiwall verify`.
pub fn run(_args: VerifyArgs) -> Result<(), CliError> {
    Err(CliError::failure("`lumiwall verify` is not built yet"))
}
