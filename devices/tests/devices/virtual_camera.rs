//! The virtual camera photographs the virtual wall as the meter sees it: where the
//! projector is brighter the frame is brighter, points land where the pinhole model
//! says, noise and saturation behave, and a camera without manual exposure is refused.

use lumiwall_devices::sim::{CameraSpec, VirtualCamera, VirtualWall};
use lumiwall_devices::{Camera, DeviceError, DisplayId, DriveImage, Frame, PatternOutput};

fn wall(extra: &str) -> VirtualWall {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/walls/mono-2x1.toml"
    );
    let text = std::fs::read_to_string(path).expect("fixture");
    VirtualWall::from_toml_str(&format!("{text}\n{extra}")).expect("wall")
}

fn mean_around(f: &Frame, at: [f64; 2], c: usize) -> f64 {
    let (x0, y0) = (at[0] as i64, at[1] as i64);
    let mut sum = 0.0;
    let mut n = 0.0;
    for y in y0 - 2..=y0 + 2 {
        for x in x0 - 2..=x0 + 2 {
            if let Some(p) = f.at(x as u32, y as u32) {
                sum += f64::from(p[c]);
                n += 1.0;
            }
        }
    }
    sum / n
}

#[test]
fn lit_display_is_brighter_at_its_centre_than_its_corner_and_its_dark_neighbour() {
    let w = wall("");
    let mut cam = VirtualCamera::new(&w, false).expect("camera");
    let mut pat = w.pattern_output();
    pat.show(DisplayId(0), [1.0; 3]).expect("show");
    let t = std::time::Instant::now();
    let f = cam.capture(1.0e-4, 1.0).expect("capture");
    eprintln!("capture {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
    let centre = mean_around(&f, cam.project(DisplayId(0), [0.5, 0.5]).unwrap(), 1);
    let corner = mean_around(&f, cam.project(DisplayId(0), [0.05, 0.05]).unwrap(), 1);
    let other = mean_around(&f, cam.project(DisplayId(1), [0.5, 0.5]).unwrap(), 1);
    eprintln!("centre {centre} corner {corner} other {other}");
    assert!(centre > corner + 5.0, "centre {centre} corner {corner}");
    assert!(
        corner > other + 20.0,
        "corner {corner} dark display {other}"
    );
    assert!(
        centre < 250.0,
        "the default exposure should not saturate: {centre}"
    );
}

#[test]
fn a_small_square_shows_up_where_the_pinhole_model_projects_it() {
    let w = wall("");
    let mut cam = VirtualCamera::new(&w, false).expect("camera");
    let uv0 = [0.3, 0.6];
    let img = DriveImage::from_fn(400, 300, |u, v| {
        if (u - uv0[0]).abs() < 0.02 && (v - uv0[1]).abs() < 0.02 {
            [1.0; 3]
        } else {
            [0.0; 3]
        }
    })
    .expect("image");
    w.pattern_output()
        .show_image(DisplayId(1), &img)
        .expect("show");
    let f = cam.capture(1.0e-4, 1.0).expect("capture");
    let (mut sx, mut sy, mut sw) = (0.0, 0.0, 0.0);
    for y in 0..f.height_px {
        for x in 0..f.width_px {
            let v = f64::from(f.at(x, y).unwrap()[1]);
            if v > 100.0 {
                sx += (f64::from(x) + 0.5) * v;
                sy += (f64::from(y) + 0.5) * v;
                sw += v;
            }
        }
    }
    let truth = cam.project(DisplayId(1), uv0).unwrap();
    let (cx, cy) = (sx / sw, sy / sw);
    eprintln!("centroid {cx:.2},{cy:.2} truth {truth:?}");
    assert!((cx - truth[0]).abs() < 0.5 && (cy - truth[1]).abs() < 0.5);
}

#[test]
fn long_exposure_saturates_at_the_top_code() {
    let w = wall("");
    let mut cam = VirtualCamera::new(&w, true).expect("camera");
    w.pattern_output()
        .show(DisplayId(0), [1.0; 3])
        .expect("show");
    let f = cam.capture(1.0, 1.0).expect("capture");
    let p = cam.project(DisplayId(0), [0.5, 0.5]).unwrap();
    assert_eq!(f.at(p[0] as u32, p[1] as u32).unwrap(), [255; 3]);
}

#[test]
fn camera_with_automatic_exposure_only_is_refused() {
    let w = wall("[camera]\nmanual_exposure = false\n");
    let mut cam = VirtualCamera::new(&w, false).expect("camera");
    let err = cam.capture(0.01, 1.0).unwrap_err();
    assert!(matches!(err, DeviceError::AutoExposureOnly(_)), "{err}");
    assert!(err.to_string().contains("manual exposure"), "{err}");
}

#[test]
fn camera_settings_out_of_range_are_refused_before_capturing() {
    let w = wall("");
    let mut cam = VirtualCamera::new(&w, false).expect("camera");
    let t0 = w.elapsed_s();
    for (t, g) in [
        (0.0, 1.0),
        (100.0, 1.0),
        (f64::NAN, 1.0),
        (0.01, 0.5),
        (0.01, 1e9),
    ] {
        assert!(cam.capture(t, g).is_err(), "exposure {t} gain {g} accepted");
    }
    assert_eq!(w.elapsed_s(), t0, "a refused capture advanced the clock");
    let huge = "[camera]\nwidth_px = 100000\nheight_px = 100000\n";
    let err = VirtualWall::from_toml_str(&format!(
        "{}\n{huge}",
        std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../fixtures/walls/mono-2x1.toml"
        ))
        .unwrap()
    ))
    .unwrap_err();
    assert!(err.to_string().contains("camera.width_px"), "{err}");
}

#[test]
fn response_curve_inverse_round_trips() {
    let s = CameraSpec::default();
    for c in 0..3 {
        for i in 0..=100 {
            let x = f64::from(i) / 100.0;
            assert!((s.inverse_response(c, s.response(c, x)) - x).abs() < 1e-9);
        }
    }
}
