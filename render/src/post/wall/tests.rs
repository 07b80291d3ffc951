//! Unit tests of wall tiling and eye routing.

use super::*;
use lumiwall_profiles::apply::model::{AnalyticDisplay, ModelProfileSpec};
use lumiwall_profiles::{BlackMode, OutOfGamut};

fn profile(col: u32, row: u32, eye: Eye) -> DisplayProfile {
    let d = AnalyticDisplay::infitec_example();
    d.profile(&ModelProfileSpec {
        display: DisplayKey {
            wall: "w".into(),
            display: col + 10 * row,
            tile_col: col,
            tile_row: row,
            eye,
        },
        black_mode: BlackMode::Individual,
        common_black_xyz_cd_m2: d.black_xyz_cd_m2,
        target_white_xyz_cd_m2: d.full_white_xyz().map(|v| v * 0.9),
        lut_entries: 1024,
        flat_field: None,
        out_of_gamut: OutOfGamut::Clip,
        bit_depth: 10,
    })
    .unwrap()
}

/// A `w × h` frame whose pixel X holds its index, Y its eye marker.
fn frame(w: u32, h: u32, marker: f32) -> XyzFrame {
    let pixels = (0..w * h).map(|i| [i as f32, marker, 0.0]).collect();
    XyzFrame::new(w, h, pixels).unwrap()
}

#[test]
fn plan_spans_the_largest_tile_indices_and_detects_stereo() {
    let mono = [profile(0, 0, Eye::Mono), profile(2, 1, Eye::Mono)];
    let t = WallTiling::plan("w", &mono).unwrap();
    assert_eq!((t.cols, t.rows, t.stereo), (3, 2, false));
    let stereo = [profile(0, 0, Eye::Left), profile(0, 0, Eye::Right)];
    let t = WallTiling::plan("w", &stereo).unwrap();
    assert_eq!((t.cols, t.rows, t.stereo), (1, 1, true));
}

#[test]
fn plan_of_no_display_fails() {
    assert_eq!(WallTiling::plan("w", &[]), Err(WallError::NoDisplay));
}

#[test]
fn right_frame_on_a_mono_wall_or_of_another_size_fails() {
    let mono = WallTiling::plan("w", &[profile(0, 0, Eye::Mono)]).unwrap();
    let err = EyeFrames::new(&mono, frame(4, 2, 0.0), Some(frame(4, 2, 1.0))).unwrap_err();
    assert_eq!(
        err.to_string(),
        "wall w is mono: --in-right has no display to go to"
    );
    let stereo = WallTiling::plan("w", &[profile(0, 0, Eye::Left)]).unwrap();
    let err = EyeFrames::new(&stereo, frame(4, 2, 0.0), Some(frame(2, 2, 1.0))).unwrap_err();
    assert_eq!(
        err.to_string(),
        "size mismatch: left frame 4×2, right frame 2×2"
    );
}

#[test]
fn right_eye_displays_get_the_right_frame_and_all_others_the_main_one() {
    let profiles = [
        profile(0, 0, Eye::Left),
        profile(0, 0, Eye::Right),
        profile(1, 0, Eye::Mono),
    ];
    let tiling = WallTiling::plan("w", &profiles).unwrap();
    let frames = EyeFrames::new(&tiling, frame(4, 2, 0.0), Some(frame(4, 2, 1.0))).unwrap();
    let markers: Vec<f32> = tiling
        .jobs(&profiles, &frames, None)
        .map(|job| job.unwrap().tile.pixels[0][1])
        .collect();
    assert_eq!(markers, [0.0, 1.0, 0.0]);
    // Without a right frame every eye shows the main frame.
    let frames = EyeFrames::new(&tiling, frame(4, 2, 0.0), None).unwrap();
    assert_eq!(frames.for_eye(Eye::Right).pixels[0][1], 0.0);
}

#[test]
fn jobs_cut_each_display_its_tile_of_the_grid() {
    let profiles = [profile(0, 0, Eye::Mono), profile(1, 1, Eye::Mono)];
    let tiling = WallTiling::plan("w", &profiles).unwrap();
    let frames = EyeFrames::new(&tiling, frame(4, 2, 0.0), None).unwrap();
    let tiles: Vec<XyzFrame> = tiling
        .jobs(
            &profiles,
            &frames,
            Some(FrameSize {
                width: 2,
                height: 1,
            }),
        )
        .map(|job| job.unwrap().tile)
        .collect();
    let index = |t: &XyzFrame| t.pixels.iter().map(|p| p[0]).collect::<Vec<_>>();
    assert_eq!(index(&tiles[0]), [0.0, 1.0]);
    assert_eq!(index(&tiles[1]), [6.0, 7.0]);
}

#[test]
fn tile_of_an_unexpected_size_fails_with_both_sizes() {
    let profiles = [profile(0, 0, Eye::Mono)];
    let tiling = WallTiling::plan("w", &profiles).unwrap();
    let frames = EyeFrames::new(&tiling, frame(4, 2, 0.0), None).unwrap();
    let expected = Some(FrameSize {
        width: 1920,
        height: 1080,
    });
    let err = tiling
        .jobs(&profiles, &frames, expected)
        .next()
        .unwrap()
        .unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "size mismatch: {} expects 1920×1080 but its image is 4×2",
            profiles[0].display
        )
    );
}

#[test]
fn frame_size_parses_width_by_height_with_any_separator() {
    for s in ["1920x1080", "1920X1080", "1920×1080", " 1920 x 1080 "] {
        assert_eq!(
            s.parse::<FrameSize>(),
            Ok(FrameSize {
                width: 1920,
                height: 1080
            }),
            "{s:?}"
        );
    }
    for s in ["1920", "1920x", "ax1080", "-1x2"] {
        let err = s.parse::<FrameSize>().unwrap_err();
        assert_eq!(
            err.to_string(),
            format!("{s:?} is not WIDTHxHEIGHT, e.g. 1920x1080")
        );
    }
}
