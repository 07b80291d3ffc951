//! solve (being written).
