//! The V4L2/UVC camera driver without hardware: listing works (and is empty) on a
//! machine without cameras, and asking for a camera that is not there fails with
//! [`DeviceError::NoCamera`] naming what was asked for. Where a camera is present,
//! it reports a positive frame size and refuses captures it cannot expose manually.

#![cfg(feature = "camera-uvc")]

use lumiwall_devices::uvc::{UvcCamera, list_cameras};
use lumiwall_devices::{Camera, DeviceError};

#[test]
fn list_cameras_returns_ok_even_without_any_camera() {
    let list = list_cameras().expect("listing cameras must not fail when there are none");
    eprintln!("{} camera(s): {list:?}", list.len());
    let mut indexes: Vec<u32> = list.iter().map(|c| c.index).collect();
    indexes.dedup();
    assert_eq!(indexes.len(), list.len(), "each V4L2 index is listed once");
}

#[test]
fn opening_a_missing_camera_by_name_gives_no_camera_naming_the_request() {
    let asked = "lumiwall-test-camera-that-does-not-exist";
    match UvcCamera::open(asked) {
        Err(DeviceError::NoCamera(msg)) => assert!(msg.contains(asked), "{msg}"),
        other => panic!("expected DeviceError::NoCamera, got {other:?}"),
    }
}

#[test]
fn opening_a_missing_camera_by_index_gives_no_camera_naming_the_index() {
    let list = list_cameras().expect("list");
    let missing = (0..u32::MAX)
        .rev()
        .find(|i| list.iter().all(|c| c.index != *i))
        .expect("a free index");
    let asked = missing.to_string();
    match UvcCamera::open(&asked) {
        Err(DeviceError::NoCamera(msg)) => {
            assert!(msg.contains(&format!("{asked:?}")), "{msg}");
            if list.is_empty() {
                assert!(msg.contains("no video devices found"), "{msg}");
            }
        }
        other => panic!("expected DeviceError::NoCamera, got {other:?}"),
    }
}

#[test]
fn a_present_camera_that_opens_reports_a_positive_frame_size_and_8_bits() {
    let list = list_cameras().expect("list");
    if list.is_empty() {
        eprintln!("no camera on this machine: nothing to open");
        return;
    }
    for listing in &list {
        // Metadata nodes, busy or MJPEG-only devices may refuse; report and go on.
        let cam = match UvcCamera::open(&listing.index.to_string()) {
            Ok(cam) => cam,
            Err(e) => {
                eprintln!("{listing} did not open: {e}");
                continue;
            }
        };
        let info = cam.info();
        eprintln!("{listing}: {info:?}");
        for line in cam.controls().expect("controls") {
            eprintln!("  {line}");
        }
        assert!(info.width_px > 0 && info.height_px > 0, "{info:?}");
        assert_eq!(info.bit_depth, 8);
    }
}

#[test]
fn a_present_camera_without_manual_exposure_refuses_capture_with_auto_exposure_only() {
    let list = list_cameras().expect("list");
    for listing in &list {
        let Ok(mut cam) = UvcCamera::open(&listing.index.to_string()) else {
            continue;
        };
        if cam.info().manual_exposure {
            continue;
        }
        match cam.capture(0.01, 1.0) {
            Err(DeviceError::AutoExposureOnly(_)) => {}
            other => panic!("{listing}: expected AutoExposureOnly, got {other:?}"),
        }
    }
}
