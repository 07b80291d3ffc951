//! `lumiwall render --method voxel-gi` and `lumiwall view --voxel-gi`: voxel-based GI
//! of a dynamic scene, per frame, and through every display of a wall.

use predicates::str::contains;
use tempfile::TempDir;

use crate::common::{cornell, fixture, lumiwall, small_wall};
use crate::view::lit_in_column;

/// Y of an EXR's pixels.
fn luminance(path: &std::path::Path) -> Vec<f32> {
    let opts = lumiwall_render::post::io::ReadOptions {
        allow_negative: false,
        sanitize: false,
        white_for_luminance_xyz: [0.9505, 1.0, 1.089],
    };
    let (frame, _) = lumiwall_render::post::io::read_exr(path, &opts).unwrap();
    frame.pixels.iter().map(|p| p[1]).collect()
}

#[test]
fn the_dynamic_scene_asks_for_voxel_gi_and_each_frame_is_lit_and_timed() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("d.exr");
    lumiwall()
        .arg("render")
        .arg(fixture("scenes/cornell/cornell_dynamic.toml"))
        .args([
            "--frames",
            "0..1",
            "--voxels",
            "32",
            "--light-samples",
            "16",
            "--vpls",
            "16",
        ])
        .args(["--image-size", "32x32", "--cpu", "--out"])
        .arg(&out)
        .assert()
        .success()
        .stdout(contains(
            "voxel GI: 32³ voxels, 16 emitter samples, 16 VPL paths, 32×32 px",
        ))
        .stdout(contains("mean per frame over 2 frames: voxelize"));
    for f in ["d_0000.exr", "d_0001.exr"] {
        let y = luminance(&tmp.path().join(f));
        assert_eq!(y.len(), 32 * 32, "{f}");
        let lit = y.iter().filter(|v| **v > 0.0).count();
        assert!(lit > 32 * 32 * 3 / 4, "{f}: only {lit} lit pixels");
        // the light itself (10 000 cd/m²) is in view, the walls far dimmer
        assert!(
            y.iter().any(|v| *v > 9000.0),
            "{f}: the emitter is not seen"
        );
    }
}

#[test]
fn voxel_gi_refuses_a_bad_resolution_no_camera_frames_without_animation_and_sensors() {
    let tmp = TempDir::new().unwrap();
    lumiwall()
        .arg("render")
        .arg(cornell())
        .args(["--method", "voxel-gi", "--voxels", "100", "--out"])
        .arg(tmp.path().join("a.exr"))
        .assert()
        .code(2)
        .stderr(contains("voxel resolution 100 is not a power of two"));
    lumiwall()
        .arg("render")
        .arg(fixture("scenes/cie171/5.2-point-cosine.toml"))
        .args(["--method", "voxel-gi", "--voxels", "32", "--cpu", "--out"])
        .arg(tmp.path().join("b.exr"))
        .assert()
        .code(2)
        .stderr(contains("has no [camera]"));
    lumiwall()
        .arg("render")
        .arg(cornell())
        .args(["--method", "voxel-gi", "--frames", "0..1", "--out"])
        .arg(tmp.path().join("c.exr"))
        .assert()
        .code(2)
        .stderr(contains("has no [animation] entry"));
    lumiwall()
        .arg("render")
        .arg(fixture("scenes/cornell/cornell_dynamic.toml"))
        .arg("--sensors")
        .arg(fixture("scenes/cornell/grid.sensors.csv"))
        .arg("--sensors-out")
        .arg(tmp.path().join("s.csv"))
        .arg("--out")
        .arg(tmp.path().join("d.exr"))
        .assert()
        .code(2)
        .stderr(contains("--sensors needs a radiosity solution"));
    assert!(!tmp.path().join("a.exr").exists());
}

/// As the radiosity solution in view.rs: the box continues across the seam of
/// mono-2x1 and the far borders look past the box.
#[test]
fn view_lights_the_scene_by_voxel_gi_through_every_display() {
    let tmp = TempDir::new().unwrap();
    let profiles = crate::common::commission_small_wall(tmp.path());
    let out = tmp.path().join("view");
    lumiwall()
        .arg("view")
        .arg(cornell())
        .args([
            "--voxel-gi",
            "--voxels",
            "32",
            "--light-samples",
            "16",
            "--vpls",
            "16",
        ])
        .arg("--wall")
        .arg(small_wall())
        .arg("--profiles")
        .arg(&profiles)
        .arg("--out-dir")
        .arg(&out)
        .args([
            "--viewer-distance",
            "0.8",
            "--display-size",
            "160x120",
            "--cpu",
        ])
        .assert()
        .success()
        .stdout(contains("lit by voxel GI (32³ voxels, 16 emitter samples"))
        .stdout(contains("2 displays of 160×120 px"));
    let left = out.join("d000-c0r0-mono.png");
    let right = out.join("d001-c1r0-mono.png");
    assert!(lit_in_column(&left, 159) > 20, "left display at the seam");
    assert!(lit_in_column(&right, 0) > 20, "right display at the seam");
    assert_eq!(lit_in_column(&left, 0), 0, "left display's far border");
    assert_eq!(lit_in_column(&right, 159), 0, "right display's far border");
    lumiwall()
        .arg("view")
        .arg(cornell())
        .args(["--voxel-gi", "--solution", "x.ply", "--wall"])
        .arg(small_wall())
        .arg("--profiles")
        .arg(&profiles)
        .arg("--out-dir")
        .arg(tmp.path().join("v2"))
        .assert()
        .code(2)
        .stderr(contains("cannot be used with"));
}
