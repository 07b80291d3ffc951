//! Registration of the displays in the camera image against the virtual camera's true
//! projection (the simulator's pinhole and distortion, not the fitted model).
#![cfg(feature = "camera")]

mod camera_common;

use camera_common::wall;
use lumiwall_calib::camera::{DotGrid, calibrate_response, check_still, register_displays};
use lumiwall_devices::sim::{VirtualCamera, VirtualWall};

fn worst_against_truth(w: &VirtualWall, noisy: bool) -> (f64, f64) {
    let mut cam = VirtualCamera::new(w, noisy).expect("camera");
    let mut pat = w.pattern_output();
    let curve = calibrate_response(&mut cam, &mut pat, &w.displays()[0]).expect("response");
    let displays = w.displays();
    let reg = register_displays(&mut cam, &mut pat, &curve, &displays, DotGrid::default())
        .expect("registration");
    let mut worst: f64 = 0.0;
    for d in &displays {
        for j in 0..=10 {
            for i in 0..=10 {
                let uv = [0.02 + 0.096 * f64::from(i), 0.02 + 0.096 * f64::from(j)];
                let est = reg.to_camera(d.id, uv).expect("mapped");
                let truth = cam.project(d.id, uv).expect("truth");
                worst =
                    worst.max(((est[0] - truth[0]).powi(2) + (est[1] - truth[1]).powi(2)).sqrt());
            }
        }
    }
    eprintln!(
        "reprojection rms {:.3} px max {:.3} px; against truth max {worst:.3} px; kappa {:?}",
        reg.rms_px, reg.max_px, reg.kappa
    );
    (reg.rms_px, worst)
}

#[test]
fn registration_within_half_a_pixel_of_the_true_projection_noiseless() {
    let (rms, worst) = worst_against_truth(&wall("mono-2x1", ""), false);
    assert!(rms <= 0.5 && worst <= 0.5, "rms {rms} worst {worst}");
}

#[test]
fn registration_within_half_a_pixel_of_the_true_projection_with_noise_and_off_axis_camera() {
    let w = wall(
        "mono-2x1",
        "[camera]\nposition_m = [1.0, 0.9, 4.0]\nlook_at_m = [1.6, 0.6, 0.0]\n",
    );
    let (rms, worst) = worst_against_truth(&w, true);
    assert!(rms <= 0.5 && worst <= 0.5, "rms {rms} worst {worst}");
}

#[test]
fn a_camera_moved_after_registration_is_detected() {
    let w = wall("mono-2x1", "");
    let mut cam = VirtualCamera::new(&w, true).expect("camera");
    let mut pat = w.pattern_output();
    let curve = calibrate_response(&mut cam, &mut pat, &w.displays()[0]).expect("response");
    let displays = w.displays();
    let reg = register_displays(&mut cam, &mut pat, &curve, &displays, DotGrid::default())
        .expect("registration");
    let still =
        check_still(&reg, &mut cam, &mut pat, &curve, &displays[0], 1.0).expect("not moved");
    assert!(still < 0.3, "an unmoved camera shifted by {still} px");
    let mut pose = cam.pose();
    pose.position_m[0] += 0.02;
    cam.set_pose(pose);
    let err = check_still(&reg, &mut cam, &mut pat, &curve, &displays[0], 1.0).unwrap_err();
    assert!(err.to_string().contains("the camera moved"), "{err}");
}
