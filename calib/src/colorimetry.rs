//! colorimetry (being written).
