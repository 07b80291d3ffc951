//! The `lumiwall` command's tests in one test program (linking one is most of a test
//! program's build time): arguments and bad inputs, every subcommand on the virtual
//! wall, exports, interruptions, a wall behind network pattern servers, calculation
//! grids and the spatial verification. The ArgyllCMS tests stay a program of their
//! own (`scripts/test` runs them beside the others).

#[path = "../common/mod.rs"]
mod common;

mod bad_inputs;
mod cli;
mod export;
mod interruptions;
mod meter_matrix;
mod network_wall;
mod sensors;
mod spatial_verify;
mod view;
#[cfg(feature = "voxel-gi")]
mod voxel_gi;
