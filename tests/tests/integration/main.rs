//! The workspace's integration tests in one test program (linking one is most of a
//! test program's build time): commissioning, resume, meter matrices, the post pass
//! round trip, recalibration, the season, verification drift and the wall classes.

mod support;

mod commission_heyewall;
mod commission_resume;
mod final_white;
mod meter_matrix;
mod post_roundtrip;
mod recalibrate;
mod season;
mod verify_drift;
mod wall_classes;
