//! photometry (being written).
