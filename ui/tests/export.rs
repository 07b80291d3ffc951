//! `lumiwall export --format cube`: the files, their layout, and what is refused. The
//! values are checked against the post pass by colour-science in
//! `tests/python/test_cube_export.py`.

mod common;

use common::{commission_small_wall, lumiwall};
use predicates::str::contains;

#[test]
fn cube_export_writes_one_size_cubed_lut_per_display_in_cube_order() {
    let tmp = tempfile::TempDir::new().unwrap();
    let profiles = commission_small_wall(tmp.path());
    let out = tmp.path().join("cube");
    lumiwall()
        .args([
            "export",
            "--format",
            "cube",
            "--cube-size",
            "17",
            "--commission",
        ])
        .arg(&profiles)
        .arg("--out-dir")
        .arg(&out)
        .assert()
        .success()
        .stdout(contains("d000-c0r0-mono.cube"))
        .stdout(contains("d001-c1r0-mono.cube"));
    let text = std::fs::read_to_string(out.join("d000-c0r0-mono.cube")).unwrap();
    assert!(text.contains("LUT_3D_SIZE 17\n"), "{}", &text[..400]);
    let rows: Vec<[f64; 3]> = text
        .lines()
        .filter(|l| l.starts_with(|c: char| c.is_ascii_digit()))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
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
    lumiwall()
        .args([
            "export",
            "--format",
            "cube",
            "--cube-size",
            "1",
            "--commission",
        ])
        .arg(tmp.path())
        .arg("--out-dir")
        .arg(tmp.path().join("out"))
        .assert()
        .code(2)
        .stderr(contains("2..=129"));
    lumiwall()
        .args(["export", "--format", "cube", "--commission"])
        .arg(tmp.path())
        .arg("--out-dir")
        .arg(tmp.path().join("out"))
        .assert()
        .code(2);
    assert!(
        !tmp.path().join("out").exists(),
        "nothing written on refusal"
    );
}
