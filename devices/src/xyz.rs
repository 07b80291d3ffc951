//! The measured quantity: CIE 1931 XYZ tristimulus values in absolute units (the
//! shared vocabulary type).

pub use lumiwall_core::Xyz;
