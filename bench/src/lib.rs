//! Benchmarks behind `lumiwall bench`: each measures one part of lumiwall against a peer
//! measured in the same run and returns a table; the command line only prints it.

pub mod apply;
pub mod cie171;
pub mod image_reference;
#[cfg(feature = "patterns")]
pub mod patterns;
pub mod radiosity;
#[cfg(feature = "readings")]
pub mod random_walls;
pub mod readings;
pub mod season;
pub mod view;
