//! The radiosity tests, one test program (linking one is most of its build time):
//! each module checks the solver against a closed form or an independent answer.

mod support;

mod basis;
mod clusters;
mod cornell;
mod daylight;
mod enclosed;
mod energy;
mod form_factors;
mod furnace;
mod lights;
mod scene;
mod senders;
mod sequence;
mod visibility;
