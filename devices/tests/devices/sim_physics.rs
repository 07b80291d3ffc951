//! Physics of the simulated projectors and screen: determinism, black, transfer
//! curves, Infitec primaries, additivity, falloff, ageing, warm-up, screen gain.

use std::path::PathBuf;

use lumiwall_core::Xy;
use lumiwall_devices::sim::VirtualWall;
use lumiwall_devices::{DeviceError, DisplayId, Xyz};

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/walls")
        .join(name)
}

fn wall(name: &str) -> VirtualWall {
    VirtualWall::from_toml_file(&fixture(name)).unwrap()
}

/// A one-projector mono wall without scatter; `extra` is appended to the TOML.
fn simple_wall(lamp_hours: f64, minutes_on: f64, extra: &str) -> VirtualWall {
    let text = format!(
        r#"
name = "simple"
seed = 1
stereo = "mono"
[tiles]
cols = 1
rows = 1
[clock]
seconds_per_reading = 1.0
minutes_since_switch_on = {minutes_on}
[projector]
bit_depth = 10
lamp_hours = {lamp_hours}
[projector.lamp]
kind = "uhp"
white_cd_m2 = 300.0
{extra}
"#
    );
    VirtualWall::from_toml_str(&text).unwrap()
}

const C: [f64; 2] = [0.5, 0.5];
const D0: DisplayId = DisplayId(0);

fn xy(x: Xyz) -> [f64; 2] {
    x.xy().unwrap()
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    Xy::from(a).distance(Xy::from(b))
}

#[test]
fn same_seed_same_wall_other_seed_other_wall() {
    let text = std::fs::read_to_string(fixture("heyewall-48.toml")).unwrap();
    let a = VirtualWall::from_toml_str(&text).unwrap();
    let b = VirtualWall::from_toml_str(&text).unwrap();
    let c = VirtualWall::from_toml_str(&text.replace("seed = 2003", "seed = 2004")).unwrap();
    let mut differs = 0;
    for d in a.displays() {
        for drive in [[1.0, 0.0, 0.0], [0.3, 0.7, 0.1], [0.0; 3]] {
            for uv in [C, [0.1, 0.9]] {
                let (x, y, z) = (
                    a.emitted_xyz(d.id, drive, uv).unwrap(),
                    b.emitted_xyz(d.id, drive, uv).unwrap(),
                    c.emitted_xyz(d.id, drive, uv).unwrap(),
                );
                assert_eq!(x, y, "same seed must give identical values");
                if (x.y - z.y).abs() > 1e-6 * x.y {
                    differs += 1;
                }
            }
        }
    }
    assert!(
        differs > 250,
        "another seed changed only {differs} of 288 values"
    );
}

#[test]
fn black_is_not_a_scaled_white() {
    for name in ["mono-2x1.toml", "heyewall-48.toml", "dlp-nonadditive.toml"] {
        let w = wall(name);
        for d in w.displays() {
            let p = w.true_primaries(d.id).unwrap();
            assert!(
                p.black.y > 0.0 && p.black.y < 0.01 * p.white.y,
                "{name} {}",
                d.id
            );
            let gap = dist(xy(p.black), xy(p.white));
            assert!(
                gap > 0.02,
                "{name} {}: black xy only {gap} from white",
                d.id
            );
        }
    }
}

fn curve(w: &VirtualWall, c: usize, n: usize) -> Vec<(f64, f64)> {
    (0..=n)
        .map(|i| {
            let d = i as f64 / n as f64;
            (d, w.true_relative_intensity(D0, c, d).unwrap())
        })
        .collect()
}

#[test]
fn transfer_curves_are_monotone_s_shaped_and_differ_per_channel() {
    let w = simple_wall(0.0, 60.0, "");
    let mut curves = Vec::new();
    for c in 0..3 {
        // Monotone over every 10-bit code.
        let all = curve(&w, c, 1023);
        assert_eq!(all[0].1, 0.0);
        assert!((all[1023].1 - 1.0).abs() < 1e-12);
        assert!(
            all.windows(2).all(|p| p[1].1 > p[0].1),
            "channel {c} not increasing"
        );
        // Log-log slope varies: not a power law.
        let slope = |a: f64, b: f64| {
            let (fa, fb) = (
                w.true_relative_intensity(D0, c, a).unwrap(),
                w.true_relative_intensity(D0, c, b).unwrap(),
            );
            (fb / fa).ln() / (b / a).ln()
        };
        let (low, mid, high) = (slope(0.02, 0.05), slope(0.3, 0.5), slope(0.85, 1.0));
        println!("channel {c}: log-log slope {low:.2} / {mid:.2} / {high:.2}");
        assert!(
            mid - low > 0.4 && mid - high > 0.3,
            "channel {c}: {low} {mid} {high}"
        );
        // S-shaped: convex low, concave high (second differences change sign).
        let coarse = curve(&w, c, 20);
        let dd: Vec<f64> = coarse
            .windows(3)
            .map(|p| p[2].1 - 2.0 * p[1].1 + p[0].1)
            .collect();
        assert!(
            dd[..8].iter().all(|&v| v > 0.0),
            "channel {c} not convex low: {dd:?}"
        );
        assert!(
            dd[dd.len() - 2..].iter().all(|&v| v < 0.0),
            "channel {c} not concave high: {dd:?}"
        );
        curves.push(coarse);
    }
    for (a, b) in [(0, 1), (1, 2), (0, 2)] {
        let gap = curves[a]
            .iter()
            .zip(&curves[b])
            .map(|(p, q)| (p.1 - q.1).abs())
            .fold(0.0, f64::max);
        assert!(gap > 0.01, "channels {a} and {b} have the same curve");
    }
}

#[test]
fn a_drive_between_codes_is_shown_dithered_and_reads_as_the_mean_of_its_two_codes() {
    let w = wall("mono-2x1.toml"); // 8-bit
    let e = |code: f64| w.emitted_xyz(D0, [code / 255.0, 0.0, 0.0], C).unwrap();
    let (lo, hi) = (e(127.0), e(128.0));
    assert!(hi.y > lo.y);
    // 127.3: the upper code where the Bayer threshold (k + 0.5)/256 is at least 0.7,
    // k = 179..=255, 77 of the cell's 256 pixels.
    for (code, upper_share) in [
        (127.0, 0.0),
        (127.5, 0.5),
        (127.3, 77.0 / 256.0),
        (128.0, 1.0),
    ] {
        let want = lo * (1.0 - upper_share) + hi * upper_share;
        let got = e(code);
        for (a, b) in got.to_array().iter().zip(want.to_array()) {
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                "code {code}: {a} vs {b}"
            );
        }
    }
}

/// Kresse Tab. 6 / 3.1.5: the right-eye ("green") filter gives a bright, saturated
/// green, the left-eye filter a much weaker, bluer green; reds differ too.
#[test]
fn infitec_left_and_right_primaries_differ_like_kresse() {
    let w = wall("heyewall-48.toml");
    for t in 0..24u32 {
        let l = w.true_primaries(DisplayId(t)).unwrap();
        let r = w.true_primaries(DisplayId(t + 24)).unwrap();
        assert!(
            r.green.y > 4.0 * l.green.y,
            "tile {t}: right green not much brighter"
        );
        let (lg, rg) = (xy(l.green), xy(r.green));
        assert!(
            rg[0] > 0.28 && rg[1] > 0.67,
            "right green {rg:?} not like .305/.685"
        );
        assert!(lg[0] < 0.16, "left green {lg:?} not bluish");
        assert!(dist(xy(l.red), xy(r.red)) > 0.03);
        assert!(
            r.red.y < 0.5 * l.red.y,
            "right red should be the dim deep red"
        );
        // White through each filter: reddish/magenta left, greenish right.
        assert!(xy(l.white)[1] < 0.33 && xy(r.white)[1] > 0.42);
    }
}

#[test]
fn additive_without_white_segment_not_with() {
    let w = wall("mono-2x1.toml");
    for d in w.displays() {
        for uv in [C, [0.05, 0.1], [0.9, 0.7]] {
            for drive in [[1.0, 1.0, 1.0], [0.3, 0.6, 0.9]] {
                let e = |v: [f64; 3]| w.emitted_xyz(d.id, v, uv).unwrap();
                let k = e([0.0; 3]);
                let sum =
                    e([drive[0], 0.0, 0.0]) + e([0.0, drive[1], 0.0]) + e([0.0, 0.0, drive[2]])
                        - k * 2.0;
                let mix = e(drive);
                for (a, b) in mix.to_array().iter().zip(sum.to_array()) {
                    assert!((a - b).abs() <= 1e-9 * a.abs().max(1.0), "{a} vs {b}");
                }
            }
        }
    }
    let dlp = wall("dlp-nonadditive.toml");
    let p = dlp.true_primaries(D0).unwrap();
    let sum = p.red + p.green + p.blue - p.black * 2.0;
    assert!(
        p.white.y > 1.1 * sum.y,
        "white {} vs R+G+B-2K {}",
        p.white.y,
        sum.y
    );
    // Single channels are unaffected by the white segment (min(r, g, b) = 0).
    let plain = VirtualWall::from_toml_str(
        &std::fs::read_to_string(fixture("dlp-nonadditive.toml"))
            .unwrap()
            .replace("white_segment = 0.25", "white_segment = 0.0"),
    )
    .unwrap();
    assert_eq!(plain.true_primaries(D0).unwrap().red, p.red);
}

#[test]
fn falloff_lowers_luminance_toward_the_corners_with_a_colour_shift() {
    let w = wall("heyewall-48.toml");
    for d in w.displays() {
        let centre = w.emitted_xyz(d.id, [1.0; 3], C).unwrap();
        assert_eq!(centre, w.true_primaries(d.id).unwrap().white);
        for corner in [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]] {
            let c = w.emitted_xyz(d.id, [1.0; 3], corner).unwrap();
            let ratio = c.y / centre.y;
            assert!(
                (0.5..0.9).contains(&ratio),
                "{}: corner/centre {ratio}",
                d.id
            );
            let shift = dist(xy(c), xy(centre));
            assert!(
                (1e-4..0.02).contains(&shift),
                "{}: corner colour shift {shift}",
                d.id
            );
        }
    }
}

#[test]
fn lamp_ageing_is_mostly_in_the_first_200_hours() {
    let w = simple_wall(0.0, 600.0, "");
    let y = |w: &VirtualWall| w.emitted_xyz(D0, [1.0; 3], C).unwrap().y;
    let y0 = y(&w);
    w.advance_hours(200.0);
    let y200 = y(&w);
    w.advance_hours(1800.0);
    let y2000 = y(&w);
    let (early, late) = (y0 - y200, y200 - y2000);
    println!("white {y0:.1} → {y200:.1} (200 h) → {y2000:.1} cd/m² (2000 h)");
    assert!(early > 0.08 * y0 && early < 0.25 * y0, "early loss {early}");
    assert!(
        late > 0.0 && early > 2.0 * late,
        "early {early} late {late}"
    );
    assert!((w.lamp_hours(D0).unwrap() - 2000.0).abs() < 1e-9);
}

#[test]
fn warm_up_drift_settles_within_half_an_hour() {
    let w = simple_wall(100.0, 0.0, "");
    let y = |w: &VirtualWall| w.emitted_xyz(D0, [1.0; 3], C).unwrap();
    let cold = y(&w);
    w.advance_seconds(120.0);
    let two = y(&w);
    w.advance_seconds(1680.0);
    let warm = y(&w);
    assert!(cold.y < two.y && two.y < warm.y);
    assert!(warm.y / cold.y > 1.05, "warm-up too small");
    assert!(
        dist(xy(cold), xy(warm)) > 1e-3,
        "warm-up should shift colour"
    );
    w.advance_seconds(1800.0);
    assert!((y(&w).y / warm.y - 1.0).abs() < 1e-3);
}

#[test]
fn lambertian_screen_is_view_independent_specular_is_not() {
    let meter_at = |x: f64| {
        format!(
            "[meter]\nposition_m = [{x}, 0.75, 2.0]\n[tiles]\ncols = 1\nrows = 1\nwidth_m = 2.0\nheight_m = 1.5"
        )
    };
    let build = |screen: &str, x: f64| {
        let text = format!(
            "name = \"s\"\nseed = 1\nstereo = \"mono\"\n{}\n{screen}\n[projector]\nthrow_m = 2.0\n[projector.lamp]\nkind = \"uhp\"\nwhite_cd_m2 = 300.0\n[projector.falloff]\nvignetting = [0.0, 0.0, 0.0]\nhotspot_gain = 0.0\n",
            meter_at(x)
        );
        VirtualWall::from_toml_str(&text).unwrap()
    };
    let edges = |w: &VirtualWall| {
        let l = w.emitted_xyz(D0, [1.0; 3], [0.1, 0.5]).unwrap().y;
        let r = w.emitted_xyz(D0, [1.0; 3], [0.9, 0.5]).unwrap().y;
        l / r
    };
    let lam = "[screen]\ndiffuse_gain = 1.0";
    assert!((edges(&build(lam, -1.0)) - 1.0).abs() < 1e-12);
    assert!((edges(&build(lam, 3.0)) - 1.0).abs() < 1e-12);
    let spec = "[screen]\ndiffuse_gain = 0.8\nspecular_gain = 1.0\nspecular_width_deg = 15.0";
    // Meter left of the tile: the left edge's continued projector ray points at it.
    let (left, right) = (edges(&build(spec, -1.0)), edges(&build(spec, 3.0)));
    assert!(
        left > 1.2 && right < 1.0 / 1.2,
        "hotspot follows the viewer: {left} {right}"
    );
}

#[test]
fn bad_inputs_are_refused_and_a_missing_file_is_an_io_error() {
    let w = wall("mono-2x1.toml");
    assert!(w.emitted_xyz(DisplayId(9), [0.0; 3], C).is_err());
    assert!(w.emitted_xyz(D0, [1.5, 0.0, 0.0], C).is_err());
    assert!(w.emitted_xyz(D0, [f64::NAN, 0.0, 0.0], C).is_err());
    assert!(w.emitted_xyz(D0, [0.0; 3], [1.2, 0.0]).is_err());
    assert!(VirtualWall::from_toml_str("name = 3").is_err());
    let text = std::fs::read_to_string(fixture("mono-2x1.toml")).unwrap();
    assert!(VirtualWall::from_toml_str(&text.replace("bit_depth = 8", "bit_depth = 40")).is_err());
    assert!(VirtualWall::from_toml_str(&format!("{text}\n[[override]]\ndisplay = 7\n")).is_err());
    let pair = std::fs::read_to_string(fixture("infitec-pair.toml")).unwrap();
    let bad = pair.replace(
        "lo_nm = 538.0, hi_nm = 566.0",
        "lo_nm = 566.0, hi_nm = 538.0",
    );
    assert!(
        matches!(VirtualWall::from_toml_str(&bad), Err(DeviceError::Config(m)) if m.contains("infitec.right"))
    );
    let bad = pair.replace("specular_width_deg = 12.0", "specular_width_deg = -1.0");
    assert!(VirtualWall::from_toml_str(&bad).is_err());
    let missing = VirtualWall::from_toml_file(&fixture("no-such-wall.toml")).unwrap_err();
    assert!(matches!(missing, DeviceError::Io { .. }), "{missing}");
}
