//! `lumiwall verify --grid`: the spatial verification on the command line, and the
//! camera stage of `lumiwall commission --camera virtual` (with the `camera` feature).

use predicates::str::contains;
use tempfile::TempDir;

use crate::common::*;

#[test]
fn verify_grid_prints_the_overall_line_and_fails_the_tolerance_of_an_uncorrected_wall() {
    let dir = TempDir::new().expect("tmp");
    let profiles = commission_small_wall(dir.path());
    let svg = dir.path().join("heat.svg");
    lumiwall()
        .args(["verify", "--wall"])
        .arg(small_wall())
        .arg("--profiles")
        .arg(&profiles)
        .args(["--noise", "none", "--grid", "5x5", "--heat-map"])
        .arg(&svg)
        .assert()
        .code(3)
        .stdout(contains("OVERALL cells 50 median ΔE"))
        .stdout(contains("as the simulator sees it"))
        .stderr(contains("spatial verification outside tolerance"));
    let text = std::fs::read_to_string(&svg).expect("heat map written");
    assert!(
        text.starts_with("<svg") && text.matches("<rect x=").count() == 50,
        "{text}"
    );
}

#[test]
fn verify_grid_refuses_a_malformed_grid() {
    let dir = TempDir::new().expect("tmp");
    lumiwall()
        .args(["verify", "--wall"])
        .arg(small_wall())
        .arg("--profiles")
        .arg(dir.path())
        .args(["--grid", "5by5"])
        .assert()
        .code(2)
        .stderr(contains("must be COLSxROWS"));
}

#[cfg(feature = "camera")]
#[test]
fn commission_with_the_virtual_camera_writes_flat_fields_and_passes_a_looser_grid() {
    let dir = TempDir::new().expect("tmp");
    let out = dir.path().join("out");
    commission_small(&out, &["--noise", "none", "--camera", "virtual"])
        .assert()
        .success()
        .stdout(contains("camera stage:"))
        .stdout(contains("tone curves read again at the final white"))
        .stdout(contains("after the flat field:"));
    assert!(out.join("camera.json").is_file());
    // `--resume` takes the finished camera stage from its checkpoint: no capture for
    // either display's loop.
    commission_small(
        &out,
        &["--noise", "none", "--camera", "virtual", "--resume"],
    )
    .assert()
    .success()
    .stdout(contains("camera: resuming from"))
    .stdout(contains("tile c0r0 mono flat field from the stopped run"))
    .stdout(contains("tile c1r0 mono flat field from the stopped run"));
    let html = std::fs::read_to_string(out.join("report.html")).expect("report.html");
    let camera = html
        .find("<h2>Camera stage</h2>")
        .expect("camera section in report.html");
    assert!(
        html[camera..].matches("<svg").count() == 3 && html.trim_end().ends_with("</html>"),
        "the camera section inlines the response curves and both heat maps, inside the page"
    );
    lumiwall()
        .args(["verify", "--wall"])
        .arg(small_wall())
        .arg("--profiles")
        .arg(&out)
        .args([
            "--noise",
            "none",
            "--grid",
            "5x5",
            "--median-de",
            "1.0",
            "--max-de",
            "2.2",
        ])
        .assert()
        .success();
}

#[cfg(not(feature = "camera"))]
#[test]
fn commission_with_a_camera_without_the_camera_feature_says_how_to_build_it() {
    use predicates::prelude::*;
    let dir = TempDir::new().expect("tmp");
    commission_small(
        &dir.path().join("out"),
        &["--noise", "none", "--camera", "virtual"],
    )
    .assert()
    .code(2)
    .stderr(contains("--features camera"))
    .stdout(contains("commissioning").not());
}

#[cfg(feature = "camera")]
#[test]
fn perceptual_uniformity_keeps_more_of_the_white_than_strict_and_says_so() {
    let dir = TempDir::new().expect("tmp");
    let out = dir.path().join("out");
    let assert = commission_small(
        &out,
        &[
            "--noise",
            "none",
            "--camera",
            "virtual",
            "--uniformity",
            "perceptual",
        ],
    )
    .assert()
    .success()
    .stdout(contains("applied: perceptual"));
    let stdout = String::from_utf8_lossy(&assert.get_output().stdout).to_string();
    let line = stdout
        .lines()
        .find(|l| l.starts_with("uniformity:"))
        .expect("uniformity line");
    let num = |after: &str| -> f64 {
        let rest = &line[line.find(after).expect(after) + after.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    let (strict, perceptual) = (num("strict keeps "), num("perceptual keeps "));
    assert!(perceptual > strict, "{line}");
}

#[test]
fn uniformity_without_a_camera_is_refused() {
    let dir = TempDir::new().expect("tmp");
    commission_small(&dir.path().join("out"), &["--uniformity", "perceptual"])
        .assert()
        .code(2)
        .stderr(contains("--camera"));
}

/// The grid verification of `profiles` on `wall` as the simulator sees it: max ΔE2000
/// over the cells (the exit status is not asserted: the tight default tolerance may
/// fail).
#[cfg(feature = "camera")]
fn grid_max_de(wall: &std::path::Path, profiles: &std::path::Path) -> f64 {
    let out = lumiwall()
        .args(["verify", "--wall"])
        .arg(wall)
        .arg("--profiles")
        .arg(profiles)
        .args(["--noise", "none", "--grid", "5x5"])
        .output()
        .expect("verify runs");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    let line = stdout
        .lines()
        .skip_while(|l| !l.contains("as the simulator sees it"))
        .find(|l| l.starts_with("OVERALL cells"))
        .unwrap_or_else(|| panic!("no simulator grid line in {stdout}"));
    let rest = &line[line.find("max ΔE ").expect("max ΔE") + "max ΔE ".len()..];
    rest.split_whitespace().next().unwrap().parse().unwrap()
}

/// The nightly camera check: a display whose hotspot moved (a new lamp's arc) is found
/// by the fixed camera and its flat field measured again, so the wall is as uniform as
/// commissioned again (simulator's grid); the unchanged display keeps its flat field,
/// and a second night with nothing changed writes nothing.
#[cfg(feature = "camera")]
#[test]
fn recalibrate_with_the_camera_measures_again_the_flat_field_of_a_display_whose_hotspot_moved() {
    let dir = TempDir::new().expect("tmp");
    let out = dir.path().join("out");
    commission_small(&out, &["--noise", "none", "--camera", "virtual"])
        .assert()
        .success();
    let commissioned = grid_max_de(&small_wall(), &out);
    let moved = dir.path().join("mono-2x1-new-lamp.toml");
    let text = std::fs::read_to_string(small_wall()).expect("wall file");
    std::fs::write(
        &moved,
        format!("{text}\n[[override]]\ndisplay = 0\nhotspot_shift = [0.3, 0.2]\n"),
    )
    .expect("write wall");
    let before = grid_max_de(&moved, &out);
    let recalibrate = |expect_code: i32| {
        let a = recalibrate_noiseless(
            &moved,
            &out,
            &["--camera", "virtual", "--full-check-every", "1"],
        )
        .assert()
        .code(expect_code);
        String::from_utf8_lossy(&a.get_output().stdout).to_string()
    };
    let night = recalibrate(10);
    println!("{night}");
    let line_of = |what: &str| {
        night
            .lines()
            .find(|l| l.contains(what))
            .unwrap_or_else(|| panic!("no line with {what} in {night}"))
    };
    assert!(
        line_of("camera: tile c0r0 mono flat field").contains("measured again")
            && line_of("display 0 (").ends_with("flat field measured again")
            && !line_of("camera: tile c1r0 mono flat field").contains("measured again")
            && line_of("display 1 (").ends_with(" ok")
            && line_of("recalibrate mono-2x1:").contains("camera captures"),
        "{night}"
    );
    let after = grid_max_de(&moved, &out);
    println!(
        "grid max ΔE: commissioned {commissioned:.2}, hotspot moved {before:.2}, after the night {after:.2}"
    );
    assert!(
        before > commissioned + 0.3,
        "the moved hotspot must show: {before} vs {commissioned}"
    );
    assert!(after < commissioned + 0.1, "{after} vs {commissioned}");
    let second = recalibrate(0);
    assert!(!second.contains("measured again"), "{second}");
}
