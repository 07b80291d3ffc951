//! post (being written).
