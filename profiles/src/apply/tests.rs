//! Unit tests of the scalar post pass against analytic references.
#![allow(
    clippy::needless_range_loop,
    reason = "pixel and channel indices address several arrays at once"
)]

use super::model::{AnalyticDisplay, ModelProfileSpec, ToneShape, infitec_primaries, xyz_of};
use super::*;
use crate::{BlackMode, DisplayKey, DisplayProfile, Eye, FlatField};

fn key() -> DisplayKey {
    DisplayKey {
        wall: "test".into(),
        display: 0,
        tile_col: 0,
        tile_row: 0,
        eye: Eye::Mono,
    }
}

/// Primaries of Kresse's Infitec common gamut (Tab. 5), white ≈ 77.86 cd/m².
fn display(gamma: f64) -> AnalyticDisplay {
    AnalyticDisplay {
        primaries_xyz_cd_m2: infitec_primaries([20.0, 52.0, 6.0]),
        black_xyz_cd_m2: xyz_of(0.30, 0.32, 0.4),
        tone: [ToneShape { gamma, s_mix: 0.0 }; 3],
        white_segment_xyz_cd_m2: [0.0; 3],
    }
}

/// The same display without black light (for tests of the colour maths alone).
fn display_no_black(gamma: f64) -> AnalyticDisplay {
    AnalyticDisplay {
        black_xyz_cd_m2: [0.0; 3],
        ..display(gamma)
    }
}

fn spec(mode: BlackMode, oog: OutOfGamut, flat: Option<FlatField>) -> ModelProfileSpec {
    let d = display(1.0);
    let w = d.full_white_xyz().map(|v| v * 0.9);
    ModelProfileSpec {
        display: key(),
        black_mode: mode,
        common_black_xyz_cd_m2: [0.6, 0.6, 0.7],
        target_white_xyz_cd_m2: w,
        lut_entries: 4096,
        flat_field: flat,
        out_of_gamut: oog,
        bit_depth: 10,
    }
}

/// The profile of `d` for `spec` and its prepared form with default options.
fn prepared(d: &AnalyticDisplay, spec: ModelProfileSpec) -> (DisplayProfile, PreparedProfile) {
    let prof = d.profile(&spec).unwrap();
    let pp = PreparedProfile::new(&prof, &ApplyOptions::default()).unwrap();
    (prof, pp)
}

fn xy_of(v: [f64; 3]) -> [f64; 2] {
    let s = v[0] + v[1] + v[2];
    [v[0] / s, v[1] / s]
}

#[test]
fn linear_display_gives_the_matrix_drive() {
    let d = display_no_black(1.0);
    let (_, pp) = prepared(&d, spec(BlackMode::Ignore, OutOfGamut::Clip, None));
    // Drive (0.2, 0.5, 0.7) ↔ XYZ = P · drive (independent: primaries sum).
    let want = [0.2, 0.5, 0.7];
    let xyz = mat3::mul_vec(&d.primaries_matrix(), &want).map(|v| v as f32);
    let out = pp.apply(xyz, [0.5, 0.5]);
    assert!(out.flags.is_empty(), "{:?}", out.flags);
    for c in 0..3 {
        assert!(
            (f64::from(out.drive[c]) - want[c]).abs() < 1e-4,
            "{:?}",
            out.drive
        );
    }
}

#[test]
fn same_arithmetic_as_tone_curve_drive_for() {
    let d = display(2.2);
    let (prof, pp) = prepared(&d, spec(BlackMode::Individual, OutOfGamut::Clip, None));
    for i in 0..=1000 {
        let a = i as f32 / 1000.0;
        for c in 0..3 {
            assert_eq!(pp.luts[c].drive_for(a), prof.curves[c].drive_for(a));
        }
    }
}

#[test]
fn in_gamut_colours_round_trip_through_the_model() {
    for mode in [BlackMode::Ignore, BlackMode::Individual, BlackMode::Common] {
        let d = display(2.2);
        let (_, pp) = prepared(&d, spec(mode, OutOfGamut::Clip, None));
        for k in 1..50 {
            let lin = [k as f64 / 50.0, ((k * 7) % 50) as f64 / 50.0 + 0.01, 0.3];
            let xyz: [f64; 3] = mat3::mul_vec(&d.primaries_matrix(), &lin);
            // What the viewer should see for input xyz, per mode (Kresse 3.3.6).
            let (input, expect) = match mode {
                BlackMode::Ignore => (xyz, [0, 1, 2].map(|c| xyz[c] + d.black_xyz_cd_m2[c])),
                BlackMode::Individual => {
                    let v = [0, 1, 2].map(|c| xyz[c] + d.black_xyz_cd_m2[c]);
                    (v, v)
                }
                BlackMode::Common => {
                    let cb = [0.6, 0.6, 0.7];
                    (xyz, [0, 1, 2].map(|c| xyz[c] + cb[c]))
                }
            };
            let out = pp.apply(input.map(|v| v as f32), [0.5, 0.5]);
            if mode == BlackMode::Common && !out.flags.is_empty() {
                continue; // raised black may push bright colours over range
            }
            let shown = d.emitted_xyz(out.drive.map(f64::from), [1.0; 3]).unwrap();
            for c in 0..3 {
                let rel = (shown[c] - expect[c]).abs() / expect[1];
                assert!(rel < 2e-3, "{mode:?} {lin:?}: {shown:?} vs {expect:?}");
            }
        }
    }
}

/// Spectral-locus cyan (x .08, y .5) at 10 cd/m², outside every triangle here, shown by
/// `d` through its profile for `mode`: moved toward the target white at constant
/// luminance (relative tolerance `lum_tol`), on the segment from the input's xy to the
/// white's (cross product within `cross_tol`), and only as far as the gamut boundary
/// (one channel at zero), i.e. the smallest move. Returns the pixel's flags.
fn assert_moved_to_the_boundary_toward_white(
    d: &AnalyticDisplay,
    mode: BlackMode,
    lum_tol: f64,
    cross_tol: f64,
) -> PixelFlags {
    let (prof, pp) = prepared(d, spec(mode, OutOfGamut::Clip, None));
    let (x, y, lum) = (0.08, 0.5, 10.0);
    let xyz = xyz_of(x, y, lum);
    let out = pp.apply(xyz.map(|v| v as f32), [0.5, 0.5]);
    assert!(out.flags.contains(PixelFlags::OUT_OF_GAMUT));
    let shown = d.emitted_xyz(out.drive.map(f64::from), [1.0; 3]).unwrap();
    assert!(
        (shown[1] - lum).abs() < lum_tol * lum,
        "luminance {shown:?}"
    );
    let (p, w, s) = (xy_of(xyz), xy_of(prof.target_white_xyz_cd_m2), xy_of(shown));
    let cross = (w[0] - p[0]) * (s[1] - p[1]) - (w[1] - p[1]) * (s[0] - p[0]);
    assert!(cross.abs() < cross_tol, "not collinear: {p:?} {w:?} {s:?}");
    let min = out.drive.iter().cloned().fold(f32::INFINITY, f32::min);
    assert!(min.abs() < 1e-4, "{:?}", out.drive);
    out.flags
}

#[test]
fn out_of_gamut_moves_toward_white_at_constant_luminance() {
    // Linear display without black: drive is the linear intensity, shown = P · drive.
    let flags = assert_moved_to_the_boundary_toward_white(
        &display_no_black(1.0),
        BlackMode::Ignore,
        1e-3,
        1e-4,
    );
    assert!(!flags.contains(PixelFlags::OVER_RANGE));
}

#[test]
fn over_range_keeps_chromaticity_and_hits_full_drive() {
    let d = display_no_black(1.0);
    let (_, pp) = prepared(&d, spec(BlackMode::Ignore, OutOfGamut::Clip, None));
    for lum in [100.0f64, 1e3, 1e6, 1e20, 3e38] {
        let xyz = [0.31 / 0.33 * lum, lum, 0.36 / 0.33 * lum];
        let out = pp.apply(xyz.map(|v| v as f32), [0.5, 0.5]);
        assert!(out.flags.contains(PixelFlags::OVER_RANGE), "{lum}");
        let max = out.drive.iter().cloned().fold(0.0f32, f32::max);
        assert!((max - 1.0).abs() < 1e-5, "{:?}", out.drive);
        let shown = d.emitted_xyz(out.drive.map(f64::from), [1.0; 3]).unwrap();
        let (a, b) = (xy_of(xyz), xy_of(shown));
        assert!(
            (a[0] - b[0]).abs() < 1e-4 && (a[1] - b[1]).abs() < 1e-4,
            "{a:?} {b:?}"
        );
    }
}

#[test]
fn invalid_negative_and_zero_inputs() {
    let d = display(2.2);
    let (prof, pp) = prepared(&d, spec(BlackMode::Individual, OutOfGamut::Clip, None));
    for bad in [
        [f32::NAN, 1.0, 1.0],
        [1.0, f32::INFINITY, 1.0],
        [1.0, 1.0, f32::NEG_INFINITY],
    ] {
        let out = pp.apply(bad, [0.5, 0.5]);
        assert_eq!(out.flags, PixelFlags::INVALID);
        assert_eq!(out.drive, [0.0; 3]);
    }
    assert_eq!(
        pp.apply([1.0; 3], [f32::NAN, 0.5]).flags,
        PixelFlags::INVALID
    );
    // Zero input in individual mode: below the display's black → black, flagged so.
    let z = pp.apply([0.0; 3], [0.5, 0.5]);
    assert_eq!(z.drive, [0.0; 3]);
    assert!(z.flags.contains(PixelFlags::BELOW_BLACK));
    assert!(!z.flags.contains(PixelFlags::OUT_OF_GAMUT));
    // Negative luminance: out of gamut, black.
    let n = pp.apply([-5.0, -5.0, -5.0], [0.5, 0.5]);
    assert!(n.flags.contains(PixelFlags::OUT_OF_GAMUT));
    assert_eq!(n.drive, [0.0; 3]);
    // False colour: markers.
    let fc = PreparedProfile::new(
        &prof,
        &ApplyOptions {
            out_of_gamut: Some(OutOfGamut::FalseColour),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(fc.apply([f32::NAN; 3], [0.5, 0.5]).drive, MARKER_INVALID);
    assert_eq!(fc.apply([-5.0; 3], [0.5, 0.5]).drive, MARKER_OUT_OF_GAMUT);
    assert_eq!(fc.apply([1e6; 3], [0.5, 0.5]).drive, MARKER_OVER_RANGE);
    // Below black only is not marked in false-colour mode (it is the mode's behaviour).
    assert_eq!(fc.apply([0.0; 3], [0.5, 0.5]).drive, [0.0; 3]);
}

#[test]
fn near_singular_matrices() {
    let d = display(2.2);
    let mut prof = d
        .profile(&spec(BlackMode::Ignore, OutOfGamut::Clip, None))
        .unwrap();
    // Nearly collinear primaries: green a hair off the red–blue line → huge entries.
    let mut bad = prof.clone();
    bad.xyz_to_drive = [[1e19, -1e19, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let err = PreparedProfile::new(&bad, &ApplyOptions::default()).unwrap_err();
    assert!(matches!(err, ApplyError::Matrix { .. }), "{err}");
    assert!(err.to_string().contains("re-measure"));
    // Ill-conditioned but accepted: every output finite and in 0..=1 for wild inputs.
    prof.xyz_to_drive = [[1e6, -1e6 + 1.0, 0.0], [-1e6, 1e6, 0.01], [0.0, 0.0, 0.01]];
    prof.target_white_xyz_cd_m2 = [1.0, 1.0, 1.0];
    let pp = PreparedProfile::new(&prof, &ApplyOptions::default()).unwrap();
    for xyz in [
        [1.0f32, 1.0, 1.0],
        [1e6, 1e6, 1e6],
        [3e38, -3e38, 3e38],
        [-1.0, 2.0, -3.0],
        [1e-30, 1e-30, 1e-30],
        [0.0, 0.0, 0.0],
    ] {
        let out = pp.apply(xyz, [0.5, 0.5]);
        assert!(
            out.drive
                .iter()
                .all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
            "{xyz:?} → {out:?}"
        );
    }
}

#[test]
fn flat_field_divides_bilinearly() {
    let ff = FlatField {
        width: 2,
        height: 2,
        gain: vec![[1.0; 3], [0.5; 3], [0.8; 3], [0.4; 3]],
    };
    let d = display_no_black(1.0);
    let (_, pp) = prepared(&d, spec(BlackMode::Ignore, OutOfGamut::Clip, Some(ff)));
    // Texel centres at 0.25 / 0.75; centre of the display = average of the four gains.
    let g = pp.gain_at([0.5, 0.5]);
    assert!((g[0] - 0.675).abs() < 1e-6);
    assert_eq!(pp.gain_at([0.25, 0.25]), [1.0; 3]);
    assert_eq!(pp.gain_at([0.0, 1.0]), [0.8; 3]); // clamped edge
    let lin = [0.1, 0.2, 0.15];
    let xyz = mat3::mul_vec(&d.primaries_matrix(), &lin).map(|v| v as f32);
    let out = pp.apply(xyz, [0.75, 0.25]);
    // The display emits 0.5× at that texel: drive must be 2× to show the same light.
    let shown = d.emitted_xyz(out.drive.map(f64::from), [0.5; 3]).unwrap();
    let want = mat3::mul_vec(&d.primaries_matrix(), &lin);
    for c in 0..3 {
        assert!(
            (shown[c] - want[c]).abs() < 1e-4 * want[1],
            "{shown:?} {want:?}"
        );
    }
}

#[test]
fn quantisation_and_dither() {
    assert_eq!(quantise(0.0, 1023, 0.5), 0);
    assert_eq!(quantise(1.0, 1023, 0.5), 1023);
    assert_eq!(quantise(0.5, 255, 0.5), 128);
    assert_eq!(quantise(0.4999 / 255.0, 255, 0.5), 0);
    assert_eq!(quantise(f32::NAN, 255, 0.5), 0);
    assert_eq!(quantise(2.0, 255, 0.5), 255);
    let mut seen = [false; 256];
    for y in 0..16 {
        for x in 0..16 {
            let t = dither_threshold(x, y);
            let i = (t * 256.0 - 0.5).round() as usize;
            assert!(!seen[i]);
            seen[i] = true;
            assert_eq!(dither_threshold(x + 16, y + 32), t);
        }
    }
    // 2×2 corner follows the Bayer ordering 0 8 / 12 4 (of 16 in the 4×4 matrix, ×16).
    assert_eq!(dither_threshold(0, 0), 0.5 / 256.0);
    assert_eq!(dither_threshold(1, 0), 128.5 / 256.0);
    assert_eq!(dither_threshold(0, 1), 192.5 / 256.0);
    assert_eq!(dither_threshold(1, 1), 64.5 / 256.0);
    // Dithered mean over a tile reproduces a drive between codes.
    let drive = 100.3 / 255.0;
    let mean: f64 = (0..256)
        .map(|i| f64::from(quantise(drive, 255, dither_threshold(i % 16, i / 16))))
        .sum::<f64>()
        / 256.0;
    assert!((mean - 100.3).abs() < 0.01, "{mean}");
}

#[test]
fn unusable_profiles_are_typed_errors() {
    let d = display(2.2);
    let mut prof = d
        .profile(&spec(BlackMode::Ignore, OutOfGamut::Clip, None))
        .unwrap();
    prof.target_white_xyz_cd_m2 = [0.0, 0.0, 0.0];
    assert!(matches!(
        PreparedProfile::new(&prof, &ApplyOptions::default()),
        Err(ApplyError::White { .. })
    ));
    let prof = d
        .profile(&spec(BlackMode::Ignore, OutOfGamut::Clip, None))
        .unwrap();
    let opts = ApplyOptions {
        bit_depth: Some(9),
        ..Default::default()
    };
    assert!(matches!(
        PreparedProfile::new(&prof, &opts),
        Err(ApplyError::BitDepth(9))
    ));
    let mut bad = prof.clone();
    bad.curves[1].inverse_lut[10] = 0.9; // non-monotone LUT
    assert!(matches!(
        apply_pixel(&bad, [1.0; 3], [0.5; 2], &ApplyOptions::default()),
        Err(ApplyError::Profile(_))
    ));
}

#[test]
fn colours_on_the_gamut_boundary_are_not_marked() {
    let d = display_no_black(2.2);
    let (_, pp) = prepared(&d, spec(BlackMode::Ignore, OutOfGamut::FalseColour, None));
    // Edges and corners of the gamut: one or two channels exactly 0, or exactly 1.
    for lin in [
        [0.0, 0.4, 0.7],
        [0.5, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0; 3],
    ] {
        let xyz = mat3::mul_vec(&d.primaries_matrix(), &lin).map(|v| v as f32);
        let out = pp.apply(xyz, [0.5, 0.5]);
        assert!(out.flags.is_empty(), "{lin:?}: {:?}", out.flags);
        assert_ne!(out.drive, MARKER_OUT_OF_GAMUT);
    }
    // Just beyond the tolerance it is marked.
    let xyz = mat3::mul_vec(&d.primaries_matrix(), &[-1e-3, 0.4, 0.7]).map(|v| v as f32);
    assert_eq!(pp.apply(xyz, [0.5, 0.5]).drive, MARKER_OUT_OF_GAMUT);
}

/// A single-chip DLP: the display of the tests with a white segment of 25 % of R+G+B.
fn dlp(gamma: f64) -> AnalyticDisplay {
    display(gamma).with_white_segment(0.25)
}

/// The input that asks `d` for the shown colour `emitted` (black included) at a texel
/// of flat-field gain `gain`, per black mode (Kresse 3.3.6; common black of `spec`).
/// The lens attenuates the black like everything else it passes.
fn input_for(d: &AnalyticDisplay, mode: BlackMode, emitted: [f64; 3], gain: [f64; 3]) -> [f64; 3] {
    let p = d.primaries_matrix();
    let m = mat3::inverse(&p).unwrap();
    let through_lens = |xyz: [f64; 3]| {
        let lin = mat3::mul_vec(&m, &xyz);
        mat3::mul_vec(&p, &[0, 1, 2].map(|c| gain[c] * lin[c]))
    };
    let black_here = match mode {
        BlackMode::Ignore => through_lens(d.black_xyz_cd_m2),
        BlackMode::Individual => [0.0; 3],
        BlackMode::Common => through_lens([0.6, 0.6, 0.7]),
    };
    [0, 1, 2].map(|c| emitted[c] - black_here[c])
}

#[test]
fn a_white_segment_display_shows_every_colour_it_can_show_exactly_in_every_black_mode() {
    let d = dlp(2.2);
    let flat = Some(FlatField {
        width: 2,
        height: 1,
        gain: vec![[0.8, 0.7, 0.9], [0.8, 0.7, 0.9]],
    });
    for mode in [BlackMode::Ignore, BlackMode::Individual, BlackMode::Common] {
        for (ff, gain) in [(None, [1.0; 3]), (flat.clone(), [0.8, 0.7, 0.9])] {
            let mut s = spec(mode, OutOfGamut::Clip, ff);
            s.target_white_xyz_cd_m2 = d.full_white_xyz();
            let (_, pp) = prepared(&d, s);
            let mut checked = 0;
            for k in 0..400u32 {
                // Drives spread over the cube, including greys and pure secondaries,
                // where the white segment is all or nothing.
                let drive = [
                    f64::from((k * 37) % 101) / 100.0,
                    f64::from((k * 53 + 11) % 101) / 100.0,
                    if k % 5 == 0 {
                        f64::from((k * 37) % 101) / 100.0
                    } else {
                        f64::from((k * 71 + 29) % 101) / 100.0
                    },
                ];
                let target = d.emitted_xyz(drive, gain).unwrap();
                let input = input_for(&d, mode, target, gain);
                let out = pp.apply(input.map(|v| v as f32), [0.5, 0.5]);
                if !out.flags.is_empty() {
                    continue; // the raised common black is not below every colour
                }
                let shown = d.emitted_xyz(out.drive.map(f64::from), gain).unwrap();
                for c in 0..3 {
                    let rel = (shown[c] - target[c]).abs() / target[1].max(1.0);
                    assert!(
                        rel < 2e-3,
                        "{mode:?} gain {gain:?} drive {drive:?}: {shown:?} vs {target:?}"
                    );
                }
                checked += 1;
            }
            assert!(checked > 300, "{mode:?}: only {checked} colours in range");
        }
    }
}

#[test]
fn a_white_segment_display_scales_over_range_colours_at_constant_chromaticity() {
    let d = dlp(1.0);
    let (_, pp) = prepared(&d, spec(BlackMode::Individual, OutOfGamut::Clip, None));
    // Greys, a secondary (no white segment light) and a desaturated colour, far too bright.
    for (x, y) in [(0.3127, 0.329), (0.42, 0.5), (0.35, 0.3)] {
        let xyz = xyz_of(x, y, 500.0);
        let out = pp.apply(xyz.map(|v| v as f32), [0.5, 0.5]);
        assert!(out.flags.contains(PixelFlags::OVER_RANGE), "{x} {y}");
        let max = out.drive.iter().cloned().fold(0.0f32, f32::max);
        assert!((max - 1.0).abs() < 1e-5, "{:?}", out.drive);
        let shown = d.emitted_xyz(out.drive.map(f64::from), [1.0; 3]).unwrap();
        let s = xy_of(shown);
        assert!(
            (s[0] - x).abs() < 2e-4 && (s[1] - y).abs() < 2e-4,
            "({x}, {y}) shown at {s:?}"
        );
    }
}

#[test]
fn a_white_segment_display_maps_out_of_gamut_colours_to_the_boundary_at_constant_luminance() {
    assert_moved_to_the_boundary_toward_white(&dlp(1.0), BlackMode::Individual, 2e-3, 2e-4);
}

#[test]
fn the_additive_inverse_on_a_white_segment_display_is_off_by_the_segment() {
    // Guard for the tests above: without the white-segment step the same grey comes out far too
    // bright, so they can fail.
    let d = dlp(1.0);
    let (mut prof, _) = prepared(&d, spec(BlackMode::Ignore, OutOfGamut::Clip, None));
    prof.display_model = crate::DisplayModel::Additive;
    let pp = PreparedProfile::new(&prof, &ApplyOptions::default()).unwrap();
    let target = d.emitted_xyz([0.5; 3], [1.0; 3]).unwrap();
    let input = input_for(&d, BlackMode::Ignore, target, [1.0; 3]);
    let out = pp.apply(input.map(|v| v as f32), [0.5, 0.5]);
    let shown = d.emitted_xyz(out.drive.map(f64::from), [1.0; 3]).unwrap();
    assert!(shown[1] > 1.1 * target[1], "{shown:?} vs {target:?}");
}
