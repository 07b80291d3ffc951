//! The camera's response curve, recovered from an exposure series of the virtual wall,
//! against the virtual camera's true curve (the simulator's, not the calibration's).
#![cfg(feature = "camera")]

mod camera_common;

use camera_common::wall;
use lumiwall_calib::camera::calibrate_response;
use lumiwall_devices::sim::VirtualCamera;

fn recovered_error(extra: &str, noisy: bool) -> f64 {
    let w = wall("mono-2x1", extra);
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

/// The exposure stack and the recovered curve for the OpenCV-Python cross-check
/// (`tests/python/test_camera_response_opencv.py` runs this test with
/// `LUMIWALL_STACK_DIR` set and compares OpenCV's `CalibrateDebevec` on the same
/// frames); without the variable it checks the stack it would write.
#[test]
fn exposure_stack_for_the_opencv_cross_check() {
    use lumiwall_calib::camera::{response_from_series, response_series};
    let w = wall("mono-2x1", "");
    let mut cam = VirtualCamera::new(&w, true).expect("camera");
    let spec = cam.spec().clone();
    let mut pat = w.pattern_output();
    let d = &w.displays()[0];
    let frames = response_series(&mut cam, &mut pat, d).expect("series");
    let curve = response_from_series(&frames, &d.name).expect("curve");
    assert!(frames.len() >= 8 && frames.windows(2).all(|f| f[1].exposure_s > f[0].exposure_s));
    let Ok(dir) = std::env::var("LUMIWALL_STACK_DIR") else {
        return;
    };
    let dir = std::path::PathBuf::from(dir);
    std::fs::create_dir_all(&dir).expect("stack folder");
    let mut names = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        let bytes: Vec<u8> = f.rgb.iter().flat_map(|p| p.map(|c| c as u8)).collect();
        let img = image::RgbImage::from_raw(f.width_px, f.height_px, bytes).expect("frame");
        let name = format!("frame{k:02}.png");
        img.save(dir.join(&name)).expect("png");
        names.push(name);
    }
    let truth: Vec<Vec<f64>> = (0..3)
        .map(|c| {
            (0..256)
                .map(|z| spec.inverse_response(c, f64::from(z) / 255.0))
                .collect()
        })
        .collect();
    let json = serde_json::json!({
        "frames": names,
        "exposures_s": frames.iter().map(|f| f.exposure_s).collect::<Vec<_>>(),
        "ln_exposure": curve.ln_exposure,
        "true_relative_exposure": truth,
    });
    std::fs::write(dir.join("stack.json"), json.to_string()).expect("json");
}

/// An HDR capture of a scene with saturating white and black bands: every band is
/// measured (no saturated pixel left unmeasured, the black bands from the longer
/// exposures), the bands come out in the order of their drive, and the white-to-grey
/// ratio matches the simulator's.
#[test]
fn hdr_capture_measures_saturated_and_black_bands_in_order() {
    use lumiwall_calib::camera::capture_hdr;
    use lumiwall_devices::{DriveImage, PatternOutput};
    let w = wall("mono-2x1", "");
    let mut cam = VirtualCamera::new(&w, true).expect("camera");
    let mut pat = w.pattern_output();
    let d = w.displays()[0].clone();
    let curve = calibrate_response(&mut cam, &mut pat, &d).expect("response");
    let drives = [0.0, 0.02, 0.1, 0.3, 0.6, 1.0];
    let img =
        DriveImage::from_fn(600, 100, |u, _| [drives[((u * 6.0) as usize).min(5)]; 3]).unwrap();
    pat.show_image(d.id, &img).unwrap();
    let all: Vec<usize> = (0..(cam.spec().width_px * cam.spec().height_px) as usize).collect();
    let hdr = capture_hdr(&mut cam, &curve, &all, "bands").expect("hdr");
    assert!(
        hdr.exposures_s.len() >= 3,
        "one exposure cannot hold black and white: {:?}",
        hdr.exposures_s
    );
    // The camera's own lens vignetting (the simulator's model) divided out.
    let spec = cam.spec().clone();
    let (cx, cy) = (
        0.5 * f64::from(spec.width_px),
        0.5 * f64::from(spec.height_px),
    );
    let band = |k: usize| {
        let uv = [(k as f64 + 0.5) / 6.0, 0.5];
        let p = cam.project(d.id, uv).unwrap();
        let rho2 = ((p[0] - cx).powi(2) + (p[1] - cy).powi(2)) / (cx * cx + cy * cy);
        hdr.sample(p).expect("measured")[1] * (1.0 + spec.vignetting * rho2).powi(2)
    };
    let values: Vec<f64> = (0..6).map(band).collect();
    assert!(
        values.windows(2).all(|v| v[1] > v[0]),
        "bands out of order: {values:?}"
    );
    let truth = |k: usize| {
        let uv = [(k as f64 + 0.5) / 6.0, 0.5];
        w.emitted_xyz(d.id, [drives[k]; 3], uv).unwrap().y
    };
    let (ratio, true_ratio) = (values[5] / values[3], truth(5) / truth(3));
    assert!(
        (ratio / true_ratio - 1.0).abs() < 0.02,
        "white/grey {ratio} against {true_ratio}"
    );
}
