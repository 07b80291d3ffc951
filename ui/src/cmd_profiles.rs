//! `lumiwall profiles` (being written).

use crate::CliError;

/// Arguments of `lumiwall profiles`.
#[derive(Debug, clap::Args)]
pub struct ProfilesArgs {}

/// Runs `lumiwall profiles`.
pub fn run(_args: ProfilesArgs) -> Result<(), CliError> {
    Err(CliError::failure("`lumiwall profiles` is not built yet"))
}
