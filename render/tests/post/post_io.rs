//! Image I/O of the post pass: EXR conventions and refusals, PNG code packing, sRGB
//! input, tiles.
#![allow(
    clippy::needless_range_loop,
    reason = "pixel and channel indices address several arrays at once"
)]

use lumiwall_profiles::apply::decode_srgb;
use lumiwall_profiles::apply::srgb::SRGB_PRIMARIES_XY;
use lumiwall_render::post::io::{
    ReadOptions, read_exr, read_png_codes, read_png_srgb, write_exr, write_png,
};
use lumiwall_render::post::{CodeImage, FlagCounts, PostError, XyzFrame};

const WHITE: [f64; 3] = [76.0, 80.0, 90.0];

fn opts() -> ReadOptions {
    ReadOptions {
        allow_negative: false,
        sanitize: false,
        white_for_luminance_xyz: WHITE,
    }
}

fn frame() -> XyzFrame {
    let pixels = (0..12)
        .map(|i| [i as f32, 2.0 * i as f32, 0.5 + i as f32])
        .collect();
    XyzFrame::new(4, 3, pixels).unwrap()
}

/// Writes an uncompressed 2×2 OpenEXR file with the given channels.
fn write_2x2_exr(
    path: &std::path::Path,
    channels: Vec<exr::prelude::AnyChannel<exr::prelude::FlatSamples>>,
) {
    use exr::prelude::*;
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::from_vec(channels);
    let layer = Layer::new(
        (2, 2),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(list),
    );
    Image::from_layer(layer).write().to_file(path).unwrap();
}

#[test]
fn exr_xyz_and_rgb_named_channels_read_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    for rgb in [false, true] {
        let p = dir.path().join(format!("f{rgb}.exr"));
        write_exr(&p, &frame(), rgb).unwrap();
        let (f, report) = read_exr(&p, &opts()).unwrap();
        assert_eq!(f, frame());
        assert!(!report.luminance_only);
    }
}

#[test]
fn exr_luminance_only_is_shown_in_the_white_chromaticity() {
    use exr::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("y.exr");
    let y: Vec<f32> = vec![0.0, 10.0, 80.0, 160.0];
    write_2x2_exr(&p, vec![AnyChannel::new("Y", FlatSamples::F32(y.clone()))]);
    let (f, report) = read_exr(&p, &opts()).unwrap();
    assert!(report.luminance_only);
    for (px, lum) in f.pixels.iter().zip(&y) {
        assert_eq!(px[1], *lum);
        assert!((f64::from(px[0]) - WHITE[0] / WHITE[1] * f64::from(*lum)).abs() < 1e-3);
        assert!((f64::from(px[2]) - WHITE[2] / WHITE[1] * f64::from(*lum)).abs() < 1e-3);
    }
}

#[test]
fn exr_with_nan_or_negative_values_is_refused_with_count_and_first_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let mut f = frame();
    f.pixels[6][1] = f32::NAN; // x=2, y=1
    f.pixels[9][0] = f32::INFINITY;
    f.pixels[11][2] = -1.0;
    let p = dir.path().join("bad.exr");
    write_exr(&p, &f, false).unwrap();
    match read_exr(&p, &opts()) {
        Err(PostError::BadValues {
            count,
            first_x,
            first_y,
            what,
            ..
        }) => {
            assert_eq!((count, first_x, first_y), (2, 2, 1));
            assert!(what.contains("NaN"));
        }
        other => panic!("{other:?}"),
    }
    let e = read_exr(&p, &opts()).unwrap_err().to_string();
    assert!(e.contains("--sanitize") && e.contains("x=2, y=1"), "{e}");
    // NaN stays fatal with --allow-negative; negatives alone pass with it.
    let allow = ReadOptions {
        allow_negative: true,
        ..opts()
    };
    assert!(read_exr(&p, &allow).is_err());
    let mut g = frame();
    g.pixels[5][2] = -3.0;
    let q = dir.path().join("neg.exr");
    write_exr(&q, &g, false).unwrap();
    match read_exr(&q, &opts()) {
        Err(PostError::BadValues {
            count: 1,
            first_x: 1,
            first_y: 1,
            what: "negative",
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    let (ok, rep) = read_exr(&q, &allow).unwrap();
    assert_eq!((ok.pixels[5][2], rep.negative), (-3.0, 1));
    // --sanitize replaces all by 0 and reports the counts.
    let (s, rep) = read_exr(
        &p,
        &ReadOptions {
            sanitize: true,
            ..opts()
        },
    )
    .unwrap();
    assert_eq!((rep.non_finite, rep.negative), (2, 1));
    assert_eq!(
        (s.pixels[6][1], s.pixels[9][0], s.pixels[11][2]),
        (0.0, 0.0, 0.0)
    );
}

#[test]
fn missing_or_unusable_exr_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let e = read_exr(&dir.path().join("nope.exr"), &opts()).unwrap_err();
    assert!(matches!(e, PostError::Io { .. }), "{e}");
    let junk = dir.path().join("junk.exr");
    std::fs::write(&junk, b"not an exr").unwrap();
    assert!(matches!(
        read_exr(&junk, &opts()),
        Err(PostError::Exr { .. })
    ));
    use exr::prelude::*;
    let p = dir.path().join("a.exr");
    write_2x2_exr(
        &p,
        vec![
            AnyChannel::new("A", FlatSamples::F32(vec![1.0; 4])),
            AnyChannel::new("Y", FlatSamples::F32(vec![1.0; 4])),
        ],
    );
    let e = read_exr(&p, &opts()).unwrap_err();
    assert!(
        matches!(e, PostError::Channels { .. }) && e.to_string().contains("A, Y"),
        "{e}"
    );
}

fn codes(bit_depth: u32) -> CodeImage {
    let max = (1u32 << bit_depth) - 1;
    let codes: Vec<[u16; 3]> = (0..6u32)
        .map(|i| [(i * max / 5) as u16, max as u16, (max / 3) as u16])
        .collect();
    CodeImage {
        width: 3,
        height: 2,
        bit_depth,
        codes,
        flags: vec![0; 6],
        counts: FlagCounts::default(),
    }
}

#[test]
fn png_output_packs_codes_as_documented() {
    let dir = tempfile::tempdir().unwrap();
    for bits in [8, 10, 12, 16] {
        let img = codes(bits);
        let p = dir.path().join(format!("c{bits}.png"));
        write_png(&p, &img).unwrap();
        let (w, h, back) = read_png_codes(&p, bits).unwrap();
        assert_eq!((w, h), (3, 2));
        assert_eq!(back, img.codes);
        let raw = image::open(&p).unwrap();
        if bits == 8 {
            assert_eq!(raw.color(), image::ColorType::Rgb8);
        } else {
            // 10-bit code 1023 is stored MSB-aligned as 1023 << 6 = 65472.
            assert_eq!(raw.color(), image::ColorType::Rgb16);
            let px = raw.to_rgb16().get_pixel(0, 0).0;
            assert_eq!(px[1], ((1u32 << bits) - 1) as u16 * (1u16 << (16 - bits)));
        }
    }
}

#[test]
fn srgb_png_is_decoded_with_the_ideal_curve_to_the_wall_white() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("in.png");
    let img = image::RgbImage::from_raw(3, 1, vec![255, 255, 255, 128, 128, 128, 0, 0, 0]).unwrap();
    img.save(&p).unwrap();
    let m = lumiwall_profiles::apply::rgb_to_xyz_matrix(&SRGB_PRIMARIES_XY, &WHITE).unwrap();
    let f = read_png_srgb(&p, &m).unwrap();
    let grey = f64::from(decode_srgb(128.0 / 255.0));
    assert!((grey - 0.215_861).abs() < 1e-5); // IEC 61966-2-1 at code 128
    for c in 0..3 {
        assert!((f64::from(f.pixels[0][c]) - WHITE[c]).abs() < 1e-3);
        assert!((f64::from(f.pixels[1][c]) - WHITE[c] * grey).abs() < 1e-3);
        assert_eq!(f.pixels[2][c], 0.0);
    }
}

#[test]
fn tiles_and_size_mismatches() {
    let pixels = (0..24).map(|i| [i as f32; 3]).collect();
    let f = XyzFrame::new(6, 4, pixels).unwrap();
    let t = f.tile(3, 2, 2, 1).unwrap();
    assert_eq!((t.width, t.height), (2, 2));
    assert_eq!(t.pixels, vec![[16.0; 3], [17.0; 3], [22.0; 3], [23.0; 3]]);
    assert!(matches!(
        f.tile(4, 2, 0, 0),
        Err(PostError::SizeMismatch(_))
    ));
    assert!(matches!(
        f.tile(3, 2, 3, 0),
        Err(PostError::SizeMismatch(_))
    ));
    assert!(matches!(
        XyzFrame::new(2, 2, vec![[0.0; 3]; 3]),
        Err(PostError::SizeMismatch(_))
    ));
}
