//! The wall loader refuses sizes and values that come from the wall file before it
//! allocates or builds anything (issue 9, items 1 and 6): a huge tile grid, tile
//! sizes that are not finite and positive, bit depths a profile cannot hold, an
//! empty name.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use lumiwall_devices::DeviceError;
use lumiwall_devices::sim::VirtualWall;

fn fixture_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/walls")
        .join(name)
}

fn mono_2x1() -> String {
    std::fs::read_to_string(fixture_path("mono-2x1.toml")).unwrap()
}

/// The configuration message of loading `text`, which must be refused.
fn refused(text: &str) -> String {
    match VirtualWall::from_toml_str(text) {
        Err(DeviceError::Config(m)) => m,
        Err(other) => panic!("expected a configuration error, got {other:?}"),
        Ok(w) => panic!("accepted a wall of {} displays", w.displays().len()),
    }
}

fn replaced(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "fixture lacks {from:?}");
    text.replace(from, to)
}

#[test]
fn a_65536_by_65536_wall_is_refused_at_once_naming_cols_and_rows() {
    let text = replaced(&mono_2x1(), "cols = 2\n", "cols = 65536\n");
    let text = replaced(&text, "rows = 1\n", "rows = 65536\n");
    let t0 = Instant::now();
    let m = refused(&text);
    assert!(
        t0.elapsed() < Duration::from_secs(1),
        "took {:?}",
        t0.elapsed()
    );
    assert!(
        m.contains("tiles.cols × tiles.rows = 65536 × 65536 = 4294967296 tiles")
            && m.contains("4096"),
        "{m}"
    );
}

#[test]
fn tile_products_that_wrap_u32_or_exceed_4096_are_refused_and_4096_loads_its_size() {
    let base = mono_2x1();
    for (cols, rows) in [
        (u32::MAX, u32::MAX),
        (u32::MAX, 1),
        (65536, 65537),
        (4097, 1),
        (2049, 2),
        (1, 4097),
    ] {
        let text = replaced(&base, "cols = 2\n", &format!("cols = {cols}\n"));
        let text = replaced(&text, "rows = 1\n", &format!("rows = {rows}\n"));
        let m = refused(&text);
        assert!(m.contains("tiles.cols × tiles.rows"), "{cols}×{rows}: {m}");
    }
    for (cols, rows) in [(0, 1), (2, 0)] {
        let text = replaced(&base, "cols = 2\n", &format!("cols = {cols}\n"));
        let text = replaced(&text, "rows = 1\n", &format!("rows = {rows}\n"));
        let m = refused(&text);
        assert!(m.contains("at least 1"), "{cols}×{rows}: {m}");
    }
    // 2³² does not fit the u32 field: a TOML error, not a panic.
    let text = replaced(&base, "cols = 2\n", "cols = 4294967296\n");
    assert!(VirtualWall::from_toml_str(&text).is_err());
    // 64 × 64 = 4096 tiles is the largest wall, and it loads.
    let text = replaced(&base, "cols = 2\n", "cols = 64\n");
    let text = replaced(&text, "rows = 1\n", "rows = 64\n");
    let w = VirtualWall::from_toml_str(&text).unwrap();
    assert_eq!(w.displays().len(), 4096);
}

#[test]
fn non_finite_or_non_positive_tile_size_is_refused_when_the_file_is_loaded() {
    for bad in ["inf", "-inf", "nan", "0.0", "-1.6", "1e308", "1001.0"] {
        let text = replaced(&mono_2x1(), "width_m = 1.6", &format!("width_m = {bad}"));
        let m = refused(&text);
        assert!(
            m.contains("tiles.width_m must be a finite number > 0 and <= 1000 m, got"),
            "{bad}: {m}"
        );
        let text = replaced(&mono_2x1(), "height_m = 1.2", &format!("height_m = {bad}"));
        let m = refused(&text);
        assert!(m.contains("tiles.height_m must be"), "{bad}: {m}");
    }
}

#[test]
fn bit_depths_a_profile_cannot_hold_are_refused_when_the_file_is_loaded() {
    for bits in [0u32, 1, 6, 9, 11, 14, 15, 17, 32] {
        let text = replaced(&mono_2x1(), "bit_depth = 8", &format!("bit_depth = {bits}"));
        let m = refused(&text);
        assert!(
            m.contains("projector.bit_depth must be 8, 10, 12 or 16")
                && m.contains(&format!("got {bits}")),
            "{bits}: {m}"
        );
    }
    for bits in [8u32, 10, 12, 16] {
        let text = replaced(&mono_2x1(), "bit_depth = 8", &format!("bit_depth = {bits}"));
        let w = VirtualWall::from_toml_str(&text).unwrap();
        assert!(w.displays().iter().all(|d| d.bit_depth == bits));
    }
}

#[test]
fn empty_or_blank_wall_name_is_refused_when_the_file_is_loaded() {
    for name in ["", " ", "\\t"] {
        let text = replaced(
            &mono_2x1(),
            "name = \"mono-2x1\"",
            &format!("name = \"{name}\""),
        );
        let m = refused(&text);
        assert!(m.contains("name is empty"), "{name:?}: {m}");
    }
}

#[test]
fn the_wall_file_path_is_named_in_a_refusal() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.toml");
    let text = replaced(&mono_2x1(), "width_m = 1.6", "width_m = inf");
    std::fs::write(&path, text).unwrap();
    let err = VirtualWall::from_toml_file(&path).unwrap_err().to_string();
    assert!(
        err.contains("big.toml") && err.contains("tiles.width_m") && err.contains("inf"),
        "{err}"
    );
}

#[test]
fn too_many_comb_bands_or_overrides_are_refused() {
    let pair = std::fs::read_to_string(fixture_path("infitec-pair.toml")).unwrap();
    let many: String = (0..65)
        .map(|i| {
            format!(
                "{{ lo_nm = {}.0, hi_nm = {}.5, edge_nm = 0.1, peak = 0.5 }},\n",
                400 + i,
                400 + i
            )
        })
        .collect();
    let text = replaced(
        &pair,
        "[infitec.left]\nleak = 0.002\nbands = [\n",
        &format!("[infitec.left]\nleak = 0.002\nbands = [\n{many}"),
    );
    let m = refused(&text);
    assert!(
        m.contains("infitec.left has 68 pass bands, at most 64 allowed"),
        "{m}"
    );
    let mut text = mono_2x1();
    for _ in 0..8193 {
        text.push_str("\n[[override]]\ndisplay = 0\nlamp_power = 1.0\n");
    }
    let m = refused(&text);
    assert!(m.contains("[[override]] tables, at most 8192"), "{m}");
}

#[test]
fn scatter_of_1e308_is_refused_instead_of_panicking_in_the_sampler() {
    // Found by fuzz_parsers (corpus file crash-scatter-gamma-1e308.toml).
    for field in [
        "gamma = 0.08",
        "panel_shift_nm = 2.0",
        "curve_shape = 0.04",
        "vignetting_rel = 0.25",
        "hotspot_offset = 0.05",
    ] {
        let name = field.split(' ').next().unwrap();
        let text = replaced(&mono_2x1(), field, &format!("{name} = 1e308"));
        let m = refused(&text);
        assert!(
            m.contains(&format!("scatter.{name} must be <= 1e6, got 1e308")),
            "{field}: {m}"
        );
    }
}

#[test]
fn negative_override_white_segment_is_refused_instead_of_emitting_negative_light() {
    // Found by fuzz_parsers (crash-override-white-segment-negative.toml).
    let text = format!(
        "{}\n[[override]]\ndisplay = 1\nwhite_segment = -1\n",
        mono_2x1()
    );
    let m = refused(&text);
    assert!(
        m.contains("[[override]] white_segment of display 1 must be a finite number >= 0, got -1"),
        "{m}"
    );
}
