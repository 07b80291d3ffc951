//! The virtual wall.
