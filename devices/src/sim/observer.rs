//! Spectra on a fixed 1 nm grid and the CIE 1931 2° observer that integrates them (the
//! shared vocabulary's tables, parsed once).

pub use lumiwall_core::observer::*;
