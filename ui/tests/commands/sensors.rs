//! `lumiwall render --sensors`: a calculation grid on every scene fixture, and bad
//! sensor files refused before the solve with the line named.

use std::path::{Path, PathBuf};

use predicates::prelude::*;
use predicates::str::contains;
use tempfile::TempDir;

use crate::common::*;

/// Every scene file under fixtures/scenes with its calculation grid: `STEM.sensors.csv`
/// beside it, else the folder's `grid.sensors.csv`.
fn scenes_with_grids() -> Vec<(PathBuf, PathBuf)> {
    let mut out = Vec::new();
    let root = fixture("scenes");
    for dir in std::fs::read_dir(&root).unwrap() {
        let dir = dir.unwrap().path();
        if !dir.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&dir).unwrap() {
            let scene = f.unwrap().path();
            if scene.extension().is_none_or(|e| e != "toml") || scene.ends_with("cases.toml") {
                continue;
            }
            let stem = scene.file_stem().unwrap().to_string_lossy().to_string();
            let own = dir.join(format!("{stem}.sensors.csv"));
            let grid = if own.is_file() {
                own
            } else {
                dir.join("grid.sensors.csv")
            };
            assert!(grid.is_file(), "{} has no sensor grid", scene.display());
            out.push((scene, grid));
        }
    }
    out.sort();
    out
}

/// `name → (illuminance_lx, direct_lx, indirect_lx)` of a written sensor CSV.
fn read_readings(path: &Path) -> Vec<(String, [f64; 3])> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "name,illuminance_lx,direct_lx,indirect_lx,indirect_estimated_error_lx,chromaticity_x,chromaticity_y"
    );
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let v = |i: usize| f[i].parse::<f64>().unwrap();
            (f[0].to_string(), [v(1), v(2), v(3)])
        })
        .collect()
}

fn grid_rows(path: &Path) -> usize {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .count()
        - 1
}

#[test]
fn every_scene_fixture_renders_its_sensor_grid_with_direct_plus_indirect_illuminance() {
    let scenes = scenes_with_grids();
    assert!(scenes.len() >= 11, "{} scenes", scenes.len());
    let tmp = TempDir::new().unwrap();
    for (scene, grid) in scenes {
        let out = tmp.path().join("frame.exr");
        let csv = tmp.path().join("grid.csv");
        lumiwall()
            // radiosity even where the scene asks for voxel GI (cornell_dynamic):
            // only a radiosity solution has illuminance at sensors
            .args(["render", "--method", "radiosity", "--error", "20%", "--out"])
            .arg(&out)
            .arg("--sensors")
            .arg(&grid)
            .arg("--sensors-out")
            .arg(&csv)
            .arg(&scene)
            .assert()
            .success()
            .stdout(contains("sensors: "));
        let readings = read_readings(&csv);
        assert_eq!(readings.len(), grid_rows(&grid), "{}", scene.display());
        let mut lit = 0;
        for (name, [total, direct, indirect]) in &readings {
            assert!(
                direct.is_finite() && indirect.is_finite() && *direct >= 0.0 && *indirect >= 0.0,
                "{}: {name}",
                scene.display()
            );
            assert!((total - direct - indirect).abs() <= 1e-5 * total.max(1.0));
            lit += usize::from(*total > 0.0);
        }
        // every grid has points the scene's light reaches
        assert!(lit * 2 > readings.len(), "{}: {lit} lit", scene.display());
    }
}

#[test]
fn the_cornell_floor_under_both_blocks_is_dark_and_beside_them_lit() {
    let tmp = TempDir::new().unwrap();
    let csv = tmp.path().join("grid.csv");
    lumiwall()
        .args(["render", "--error", "10%", "--out"])
        .arg(tmp.path().join("frame.exr"))
        .arg("--sensors")
        .arg(fixture("scenes/cornell/grid.sensors.csv"))
        .arg("--sensors-out")
        .arg(&csv)
        .arg(cornell())
        .assert()
        .success();
    let r = read_readings(&csv);
    let get = |n: &str| r.iter().find(|(name, _)| name == n).unwrap().1;
    // floor_1_1 lies under the short block, floor_3_3 under the tall one, floor_2_2
    // in the open below the light
    assert_eq!(get("floor_1_1")[0], 0.0);
    assert_eq!(get("floor_3_3")[0], 0.0);
    assert!(get("floor_2_2")[1] > 100.0, "{:?}", get("floor_2_2"));
    assert!(get("floor_2_2")[2] > 10.0, "{:?}", get("floor_2_2"));
}

#[test]
fn bad_sensor_files_are_refused_before_the_solve_naming_the_line() {
    let tmp = TempDir::new().unwrap();
    let cases = [
        (
            "name,x_m,y_m,z_m,nx,ny,nz\na,0.2,0.1,0.2,0,1,0\nb,0.2,up,0.2,0,1,0\n",
            "line 3: `y_m` = `up` is not a finite number",
        ),
        (
            "name,x_m,y_m,z_m,nx,ny,nz\na,0.2,0.1,0.2,0,0,0\n",
            "line 2: normal [0.0, 0.0, 0.0] has no direction",
        ),
        ("name,x,y,z\n", "line 1: the header is `name,x,y,z`"),
        ("name,x_m,y_m,z_m,nx,ny,nz\n", "no sensors"),
    ];
    for (text, message) in cases {
        let grid = tmp.path().join("bad.csv");
        std::fs::write(&grid, text).unwrap();
        lumiwall()
            .args(["render", "--out"])
            .arg(tmp.path().join("frame.exr"))
            .arg("--sensors")
            .arg(&grid)
            .arg("--sensors-out")
            .arg(tmp.path().join("out.csv"))
            .arg(cornell())
            .assert()
            .code(2)
            .stderr(contains(message))
            .stdout(contains("est_error").not());
    }
    lumiwall()
        .args(["render", "--sensors"])
        .arg(fixture("scenes/cornell/grid.sensors.csv"))
        .arg(cornell())
        .assert()
        .code(2)
        .stderr(contains("--sensors-out"));
}
