//! gamut (being written).
