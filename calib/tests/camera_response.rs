//! The camera's response curve, recovered from an exposure series of the virtual wall,
//! against the virtual camera's true curve (the simulator's, not the calibration's).
#![cfg(feature = "camera")]

use lumiwall_calib::camera::calibrate_response;
use lumiwall_devices::sim::{VirtualCamera, VirtualWall};

fn wall(extra: &str) -> VirtualWall {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/walls/mono-2x1.toml"
    );
    let text = std::fs::read_to_string(path).expect("fixture");
    VirtualWall::from_toml_str(&format!("{text}\n{extra}")).expect("wall")
}

fn recovered_error(extra: &str, noisy: bool) -> f64 {
    let w = wall(extra);
    let mut cam = VirtualCamera::new(&w, noisy).expect("camera");
    let spec = cam.spec().clone();
    let mut pat = w.pattern_output();
    let curve = calibrate_response(&mut cam, &mut pat, &w.displays()[0]).expect("response");
    let err = curve.max_error_against(|c, y| spec.inverse_response(c, y), [0.05, 0.95]);
    eprintln!(
        "{extra:?} noisy {noisy}: {} exposures, {} samples, max error {:.3} %",
        curve.exposures_s.len(),
        curve.samples,
        err * 100.0
    );
    err
}

#[test]
fn response_curve_within_one_percent_of_the_true_curve_noiseless_8_bit() {
    assert!(recovered_error("", false) <= 0.01);
}

#[test]
fn response_curve_within_one_percent_of_the_true_curve_with_noise_8_bit() {
    assert!(recovered_error("", true) <= 0.01);
}

#[test]
fn response_curve_within_one_percent_of_the_true_curve_12_bit() {
    assert!(recovered_error("[camera]\nbits = 12\n", true) <= 0.01);
}
