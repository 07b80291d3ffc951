//! scene (being written).
