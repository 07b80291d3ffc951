//! Nothing lost on kill -9, on two writers at once or on sizes a file claims: `apply`
//! tiles are never half-written, one commission at a time writes an output folder, a
//! folder that mixes two solves or two walls is refused by every command, and input
//! sizes are checked before anything is allocated.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::common::{commission_small, commission_small_wall, cornell, fixture, lumiwall};
use predicates::prelude::*;
use predicates::str::contains;
use tempfile::TempDir;

/// A `width`×`height` sRGB test frame with a little of everything.
fn write_frame(path: &Path, width: u32, height: u32) {
    let img = image::RgbImage::from_fn(width, height, |x, y| {
        image::Rgb([(x % 251) as u8, (y % 241) as u8, ((x ^ y) % 239) as u8])
    });
    img.save(path).unwrap();
}

/// `lumiwall apply` on the CPU of `frame` through `profiles` into `out`.
fn apply_args(profiles: &Path, frame: &Path, out: &Path) -> Vec<std::ffi::OsString> {
    let mut v: Vec<std::ffi::OsString> = ["apply", "--cpu", "--profiles"]
        .iter()
        .map(Into::into)
        .collect();
    v.push(profiles.into());
    v.push("--in".into());
    v.push(frame.into());
    v.push("--out-dir".into());
    v.push(out.into());
    v
}

/// The PNG files of a folder and their bytes, sorted by name.
fn pngs(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    v.sort();
    v
}

/// Names in `dir` that look like leftovers of an interrupted write (`.NAME.tmp-PID`).
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect()
}

#[test]
fn apply_killed_at_any_moment_leaves_every_tile_complete() {
    let tmp = TempDir::new().unwrap();
    let profiles = commission_small_wall(tmp.path());
    let frame = tmp.path().join("frame.png");
    write_frame(&frame, 3840, 1080);
    let out = tmp.path().join("tiles");
    let binary = assert_cmd::cargo::cargo_bin("lumiwall");
    let started = Instant::now();
    let status = std::process::Command::new(&binary)
        .args(apply_args(&profiles, &frame, &out))
        .output()
        .unwrap();
    assert!(status.status.success(), "{status:?}");
    let full_run = started.elapsed();
    let complete = pngs(&out);
    assert_eq!(complete.len(), 2);

    // Kill -9 at times spread over the whole run; every tile must stay the complete
    // one (the same frame gives the same bytes), never a truncated file.
    let trials = 12u32;
    for k in 0..trials {
        let at = full_run.mul_f64(f64::from(k) / f64::from(trials)) + Duration::from_millis(5);
        let mut child = std::process::Command::new(&binary)
            .args(apply_args(&profiles, &frame, &out))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(at);
        let _ = child.kill();
        let _ = child.wait();
        let now = pngs(&out);
        assert_eq!(now.len(), 2, "kill at {at:?}");
        for ((path, bytes), (_, want)) in now.iter().zip(&complete) {
            assert!(
                bytes == want,
                "kill at {at:?}: {} is {} bytes, the complete tile {}",
                path.display(),
                bytes.len(),
                want.len()
            );
        }
    }
    // A later run removes what the killed ones left behind.
    std::thread::sleep(Duration::from_millis(10));
    let status = std::process::Command::new(&binary)
        .args(apply_args(&profiles, &frame, &out))
        .output()
        .unwrap();
    assert!(status.status.success());
    assert_eq!(pngs(&out), complete);
    let left = temporaries(&out);
    // Temporaries of dead writers younger than a minute are kept (another machine may
    // share the folder); none may be a tile's final name.
    assert!(left.iter().all(|n| n.starts_with('.')), "{left:?}");
}

#[test]
fn second_commission_into_a_folder_in_use_is_refused_at_once() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("profiles");
    let binary = assert_cmd::cargo::cargo_bin("lumiwall");
    // The first commission reads the emulated meter at a real K-10A's pace: long
    // enough for the second to start while it runs.
    let mut first = std::process::Command::new(&binary)
        .args(["commission", "--meter", "emulated", "--time-scale", "1"])
        .arg("--wall")
        .arg(crate::common::small_wall())
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !out.join("run").exists() {
        assert!(Instant::now() < deadline, "first commission never started");
        assert!(
            first.try_wait().unwrap().is_none(),
            "first commission ended early"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let started = Instant::now();
    commission_small(&out, &["--white", "6500K", "--noise", "none"])
        .assert()
        .code(1)
        .stderr(contains("in use by another lumiwall"))
        .stderr(contains("commission of wall mono-2x1"));
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "refused at once"
    );
    let _ = first.kill();
    let _ = first.wait();
    // The killed holder's lock is gone with its process.
    commission_small(&out, &["--noise", "none"])
        .assert()
        .success();
}

/// Commissions the small wall into `dir/profiles` and returns it with its files.
fn commissioned(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let profiles = commission_small_wall(dir);
    let a = profiles.join("d000-c0r0-mono.json");
    let b = profiles.join("d001-c1r0-mono.json");
    assert!(a.is_file() && b.is_file());
    (profiles, a, b)
}

#[test]
fn apply_and_import_refuse_a_folder_that_mixes_two_solves() {
    let tmp = TempDir::new().unwrap();
    let (profiles, _, b) = commissioned(tmp.path());
    // Another solve's profile of display 1, as a kill -9 during a re-commission leaves.
    let other = tmp.path().join("other");
    commission_small(&other, &["--noise", "none", "--white", "6500K"])
        .assert()
        .success();
    std::fs::copy(other.join("d001-c1r0-mono.json"), &b).unwrap();
    let frame = tmp.path().join("frame.png");
    write_frame(&frame, 8, 2);
    let out = tmp.path().join("tiles");
    lumiwall()
        .args(apply_args(&profiles, &frame, &out))
        .assert()
        .code(2)
        .stderr(contains("different solves"))
        .stderr(contains("d001-c1r0-mono.json"));
    assert!(!out.join("d000-c0r0-mono.png").exists(), "nothing written");
    let store = tmp.path().join("store.db");
    lumiwall()
        .args(["profiles", "import", "--store"])
        .arg(&store)
        .arg("--dir")
        .arg(&profiles)
        .assert()
        .code(2)
        .stderr(contains("different solves"));
}

#[test]
fn apply_refuses_profiles_of_another_wall_than_wall_json_names() {
    let tmp = TempDir::new().unwrap();
    let (profiles, _, _) = commissioned(tmp.path());
    let manifest = profiles.join("wall.json");
    let text = std::fs::read_to_string(&manifest).unwrap();
    std::fs::write(&manifest, text.replace("\"mono-2x1\"", "\"hall-b\"")).unwrap();
    let frame = tmp.path().join("frame.png");
    write_frame(&frame, 8, 2);
    lumiwall()
        .args(apply_args(&profiles, &frame, &tmp.path().join("tiles")))
        .assert()
        .code(2)
        .stderr(contains("profile of wall \"mono-2x1\""))
        .stderr(contains("wall.json is wall \"hall-b\""));
}

/// Writes a 2×2 XYZ EXR whose header then claims `side`×`side` pixels.
fn exr_claiming(path: &Path, side: i32) {
    let frame = lumiwall_render::post::XyzFrame::new(2, 2, vec![[1.0, 1.0, 1.0]; 4]).unwrap();
    lumiwall_render::post::io::write_exr(path, &frame, false).unwrap();
    let mut bytes = std::fs::read(path).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes
        .windows(key.len())
        .position(|w| w == key)
        .expect("dataWindow attribute")
        + key.len()
        + 4;
    for (i, v) in [0, 0, side - 1, side - 1].into_iter().enumerate() {
        bytes[at + 4 * i..at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
    }
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn apply_refuses_an_exr_whose_header_claims_a_huge_image_before_allocating() {
    let tmp = TempDir::new().unwrap();
    let (profiles, _, _) = commissioned(tmp.path());
    let exr = tmp.path().join("huge.exr");
    exr_claiming(&exr, 100_000);
    assert!(std::fs::metadata(&exr).unwrap().len() < 4096);
    let started = Instant::now();
    lumiwall()
        .args(apply_args(&profiles, &exr, &tmp.path().join("tiles")))
        .assert()
        .code(2)
        .stderr(contains("100000×100000"))
        .stderr(contains("at most 65536 pixels a side"));
    assert!(started.elapsed() < Duration::from_secs(20));
}

#[test]
fn progressive_render_with_a_tiny_max_edge_is_refused_before_meshing() {
    let tmp = TempDir::new().unwrap();
    let started = Instant::now();
    lumiwall()
        .args(["render", "--method", "progressive", "--max-edge-m", "1e-6"])
        .args(["--time", "10s"])
        .arg(cornell())
        .arg("--out")
        .arg(tmp.path().join("f.exr"))
        .assert()
        .code(2)
        .stderr(contains("--max-edge-m"))
        .stderr(contains("elements"));
    assert!(started.elapsed() < Duration::from_secs(10));
    assert!(fixture("scenes/cornell/cornell.toml").is_file());
}

/// The small wall with its lamp at `white_cd_m2`, written into `dir`.
fn dim_wall(dir: &Path, white_cd_m2: f64) -> PathBuf {
    let text = std::fs::read_to_string(crate::common::small_wall()).unwrap();
    let dim = text.replace(
        "white_cd_m2 = 250.0",
        &format!("white_cd_m2 = {white_cd_m2:?}"),
    );
    assert_ne!(dim, text, "the lamp line of the fixture changed");
    let path = dir.join(format!("dim-{white_cd_m2}.toml"));
    std::fs::write(&path, dim).unwrap();
    path
}

#[test]
fn a_lamp_too_dim_for_the_meter_is_blamed_on_the_meter_range_not_the_display() {
    let tmp = TempDir::new().unwrap();
    // Nothing readable at all, and primaries readable but every blue ramp sample
    // below the meter's limit.
    for (white, says) in [
        (
            0.05,
            "reads 0.0000 cd/m², below the reliable limit of the meter",
        ),
        // A blue of 0.015 cd/m² (its Z about 0.2): each ramp sample would need more
        // than a hundred readings of the Z sensor's zero-light noise.
        (
            0.3,
            "ramp reading was below the reliable limit of the meter",
        ),
    ] {
        let mut cmd = lumiwall();
        // without the warm check's readings of the white, whose noise would move the
        // realistic meter's readings of the 0.3 cd/m² wall to other draws
        cmd.args(["commission", "--meter", "direct", "--no-warm-check"])
            .arg("--wall")
            .arg(dim_wall(tmp.path(), white))
            .arg("--out")
            .arg(tmp.path().join(format!("out-{white}")));
        cmd.assert()
            .code(1)
            .stderr(contains(says))
            .stderr(contains("lamp"))
            .stderr(contains("more sensitive meter"))
            .stderr(contains("usable ramp samples").not())
            .stderr(contains("check that the display is on").not());
    }
}
