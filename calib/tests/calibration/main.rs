//! The calibration's tests in one test program (linking one is most of a test
//! program's build time): colorimetry, gamut, tone curves, measuring, the solve and
//! the commissioning report. The camera tests (feature `camera`) are programs of
//! their own; `scripts/test` runs `camera_response` by name.

mod common;

mod colorimetry;
mod commission_report;
mod gamut;
mod gamut_tab6;
mod measure;
mod solve;
mod tone;
