//! The profile format, the store and the drift forecast, in one test program (linking
//! one is most of a test program's build time). The parser fuzzing stays a program of
//! its own.

mod common;

mod forecast;
mod format;
mod store;
