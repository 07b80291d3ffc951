//! tone (being written).
