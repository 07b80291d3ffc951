//! radiosity (being written).
