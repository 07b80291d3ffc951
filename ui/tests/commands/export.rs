//! `lumiwall export --format cube`: the files, their layout, and what is refused. The
//! values are checked against the post pass by colour-science in
//! `tests/python/test_cube_export.py`.

use crate::common::{commission_small_wall, export, lumiwall, xy_distance};
use predicates::str::contains;

#[test]
fn cube_export_writes_one_size_cubed_lut_per_display_in_cube_order() {
    let tmp = tempfile::TempDir::new().unwrap();
    let profiles = commission_small_wall(tmp.path());
    let out = tmp.path().join("cube");
    export("cube", &profiles, &out)
        .args(["--cube-size", "17"])
        .assert()
        .success()
        .stdout(contains("d000-c0r0-mono.cube"))
        .stdout(contains("d001-c1r0-mono.cube"));
    let text = std::fs::read_to_string(out.join("d000-c0r0-mono.cube")).unwrap();
    assert!(text.contains("LUT_3D_SIZE 17\n"), "{}", &text[..400]);
    let rows: Vec<[f64; 3]> = text
        .lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
        .map(numbers)
        .collect();
    assert_eq!(rows.len(), 17 * 17 * 17);
    assert!(rows.iter().flatten().all(|d| (0.0..=1.0).contains(d)));
    // red runs fastest: the second entry is a dim red, its green and blue drives
    // below its red drive; the last entry (the target white) drives every channel
    assert!(
        rows[1][0] > rows[1][1] && rows[1][0] > rows[1][2],
        "{:?}",
        rows[1]
    );
    assert!(rows[17 * 17 * 17 - 1].iter().all(|d| *d > 0.3));
}

#[test]
fn cube_export_refuses_a_size_outside_2_to_129_and_a_folder_without_profiles() {
    let tmp = tempfile::TempDir::new().unwrap();
    export("cube", tmp.path(), &tmp.path().join("out"))
        .args(["--cube-size", "1"])
        .assert()
        .code(2)
        .stderr(contains("2..=129"));
    export("cube", tmp.path(), &tmp.path().join("out"))
        .assert()
        .code(2);
    assert!(
        !tmp.path().join("out").exists(),
        "nothing written on refusal"
    );
}

/// The numbers of a line of whitespace-separated numbers.
fn numbers<const N: usize>(line: &str) -> [f64; N] {
    let v: Vec<f64> = line
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    v.try_into().unwrap()
}

/// The rows `[v, R, G, B]` of a `.cal`.
fn cal_rows(text: &str) -> Vec<[f64; 4]> {
    let data = text.split("BEGIN_DATA\n").nth(1).unwrap();
    data.lines()
        .take_while(|l| !l.starts_with("END_DATA"))
        .map(numbers)
        .collect()
}

/// What the virtual wall's display 0 shows at each of `drives`, by the meter
/// emulator's noiseless truth (the simulator, not the post pass).
fn shown_on_display_0(drives: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let script: String = drives
        .iter()
        .map(|d| format!("show 0 {} {} {}\ntruth\n", d[0], d[1], d[2]))
        .chain(std::iter::once("quit\n".to_string()))
        .collect();
    let out = lumiwall()
        .args(["meter-emulator", "--noise", "none", "--wall"])
        .arg(crate::common::small_wall())
        .write_stdin(script)
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.strip_prefix("ok XYZ "))
        .map(numbers)
        .collect()
}

#[test]
fn argyll_cal_greys_show_the_target_white_at_v_to_the_2_2_on_the_simulated_display() {
    let tmp = tempfile::TempDir::new().unwrap();
    let profiles = commission_small_wall(tmp.path());
    let out = tmp.path().join("cal");
    export("argyll-cal", &profiles, &out)
        .assert()
        .success()
        .stdout(contains("d000-c0r0-mono.cal"));
    let rows = cal_rows(&std::fs::read_to_string(out.join("d000-c0r0-mono.cal")).unwrap());
    assert_eq!(rows.len(), 256);
    assert!(
        rows.windows(2).all(|w| (1..4).all(|c| w[1][c] >= w[0][c])),
        "curves rise"
    );
    let profile: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(profiles.join("d000-c0r0-mono.json")).unwrap(),
    )
    .unwrap();
    let white: Vec<f64> = profile["target_white_xyz_cd_m2"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    // greys above the display's black floor (measured: Y within 0.2–0.8 %, Δxy ≤ 0.0022)
    let picked = [64, 128, 191, 255].map(|i| rows[i]);
    let shown = shown_on_display_0(&picked.map(|r| [r[1], r[2], r[3]]));
    assert_eq!(shown.len(), picked.len());
    for (row, got) in picked.iter().zip(shown) {
        let target = [0, 1, 2].map(|c| white[c] * row[0].powf(2.2));
        let dxy = xy_distance(got, target);
        let rel_y = got[1] / target[1] - 1.0;
        println!(
            "grey {:.3}: Y {:.3} vs {:.3} cd/m² ({:+.2} %), Δxy {dxy:.4}",
            row[0],
            got[1],
            target[1],
            100.0 * rel_y
        );
        assert!(
            rel_y.abs() < 0.01 && dxy < 0.003,
            "grey {}: {got:?} vs {target:?}",
            row[0]
        );
    }
}

/// `--format mpcdi` needs the projectors' raster, names a bad one, and writes one
/// package for the wall (its structure and colour are checked against the standard
/// in `tests/python/test_mpcdi_export.py`).
#[test]
fn mpcdi_export_needs_the_projector_raster_and_writes_one_package_for_the_wall() {
    let tmp = tempfile::TempDir::new().unwrap();
    let profiles = commission_small_wall(tmp.path());
    let out = tmp.path().join("mpcdi");
    export("mpcdi", &profiles, &out)
        .assert()
        .code(2)
        .stderr(contains("--projector-resolution 1920x1200"));
    export("mpcdi", &profiles, &out)
        .args(["--projector-resolution", "1920by1200"])
        .assert()
        .code(2)
        .stderr(contains("WIDTHxHEIGHT"));
    assert!(!out.exists(), "nothing written on refusal");
    export("mpcdi", &profiles, &out)
        .args(["--projector-resolution", "1920x1200"])
        .assert()
        .success()
        .stdout(contains(
            "mono-2x1.mpcdi (MPCDI 2.0, profile 2d, colour level 4, 2 regions)",
        ));
    let bytes = std::fs::read(out.join("mono-2x1.mpcdi")).unwrap();
    assert_eq!(&bytes[..4], b"PK\x03\x04", "a ZIP archive");
}
