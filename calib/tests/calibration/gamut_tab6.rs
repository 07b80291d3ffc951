//! Acceptance: Kresse 2003 Tab. 6 (two Infitec projectors). From the printed R, G, B and
//! black readings the common-gamut solve reproduces the published common gamut to
//! ±0.005 xy on the raw readings, and to ±0.0056 xy on the black-subtracted readings that
//! `commission` solves on; the white luminance is printed beside the published
//! 77.86 cd/m² and must be within 5 % of it.
//! See `fixtures/kresse/tab6.toml` for what reproduces the table and what does not.
//!
//! `cargo test -p lumiwall-calib --test calibration gamut_tab6 -- --nocapture` prints the numbers.

use std::path::PathBuf;

use lumiwall_calib::gamut::{common_gamut, common_gamut_named};
use lumiwall_calib::solve::{DisplayMeasurement, WhiteTarget, primaries_xy, solve_white};
use lumiwall_devices::Xyz;
use lumiwall_profiles::{BlackMode, DisplayKey, Eye};

struct Tab6 {
    projectors: Vec<(String, [Xyz; 3], Xyz)>,
    published: [[f64; 2]; 3],
    published_white: (f64, [f64; 2]),
    target_white: [f64; 2],
}

fn lxy(v: &toml::Value) -> (f64, f64, f64) {
    let f = |k: &str| v.get(k).and_then(|x| x.as_float()).unwrap();
    (f("l"), f("x"), f("y"))
}

fn xyz(v: &toml::Value) -> Xyz {
    let (l, x, y) = lxy(v);
    Xyz::from_xy_luminance(x, y, l)
}

fn load() -> Tab6 {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/kresse/tab6.toml");
    let doc: toml::Value = toml::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let projectors = doc["projector"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            (
                p["name"].as_str().unwrap().to_string(),
                [xyz(&p["r"]), xyz(&p["g"]), xyz(&p["b"])],
                xyz(&p["black"]),
            )
        })
        .collect();
    let c = &doc["published"]["common"];
    let xy = |v: &toml::Value| {
        let (_, x, y) = lxy(v);
        [x, y]
    };
    let (wl, wx, wy) = lxy(&c["w"]);
    let t = &doc["target_white"];
    Tab6 {
        projectors,
        published: [xy(&c["r"]), xy(&c["g"]), xy(&c["b"])],
        published_white: (wl, [wx, wy]),
        target_white: [t["x"].as_float().unwrap(), t["y"].as_float().unwrap()],
    }
}

fn measurement(i: usize, name: &str, primaries: [Xyz; 3], black: Xyz) -> DisplayMeasurement {
    DisplayMeasurement {
        key: DisplayKey {
            wall: "kresse-tab6".into(),
            display: i as u32,
            tile_col: 0,
            tile_row: 0,
            eye: if i == 0 { Eye::Left } else { Eye::Right },
        },
        bit_depth: 8,
        black,
        primaries,
        white: None,
        ramps: [vec![], vec![], vec![]],
        readings: 0,
        instrument: format!("Minolta CS-100A ({name}, Kresse 2003 Tab. 6)"),
        composites: Vec::new(),
        ramp_sigma_rel: Default::default(),
    }
}

/// Each primary's XYZ above `black` is taken with no negative component, as the solve
/// does: Kresse's own readings give a red whose Z is below the black's, x + y = 1.0006.
fn triangle(primaries: &[Xyz; 3], black: Xyz) -> [[f64; 2]; 3] {
    [0, 1, 2].map(|c| {
        let d = primaries[c] - black;
        Xyz::new(d.x.max(0.0), d.y.max(0.0), d.z.max(0.0))
            .xy()
            .unwrap()
    })
}

/// Agreement with the published common gamut through the raw readings: the printed
/// 3 decimals (half a unit of the last digit is 0.0005; 0.005 leaves room for rounding
/// of the inputs).
const RAW_TOLERANCE_XY: f64 = 0.005;

/// Agreement with the published common gamut through the black-subtracted readings
/// (what `commission` solves on): the measured worst case is G y, 0.0051 off (see
/// `fixtures/kresse/tab6.toml`), plus half a unit of the printed last digit.
const BLACK_SUBTRACTED_TOLERANCE_XY: f64 = 0.0056;

/// Published white luminance `Y` (cd/m²) the luminance split is normalised by: the sum
/// 16.26 + 57.45 + 4.14 of the published common primaries.
const PUBLISHED_SPLIT_SUM: f64 = 77.85;

const NAMES: [&str; 3] = ["R", "G", "B"];

/// Asserts each of `ours` within `tolerance` (x and y) of `published`, printing both.
fn assert_gamut_near(label: &str, ours: [[f64; 2]; 3], published: [[f64; 2]; 3], tolerance: f64) {
    println!("Kresse Tab. 6 common gamut ({label})   ours        published");
    for c in 0..3 {
        let (o, p) = (ours[c], published[c]);
        println!(
            "  {}                                          {:.4}/{:.4}  {:.3}/{:.3}",
            NAMES[c], o[0], o[1], p[0], p[1]
        );
        assert!(
            (o[0] - p[0]).abs() <= tolerance && (o[1] - p[1]).abs() <= tolerance,
            "{label}: {} {:?} vs published {:?}",
            NAMES[c],
            o,
            p
        );
    }
}

/// Common gamut of the raw readings (black not subtracted).
fn raw_gamut(tab: &Tab6) -> [[f64; 2]; 3] {
    let raw: Vec<[[f64; 2]; 3]> = tab
        .projectors
        .iter()
        .map(|(_, p, _)| triangle(p, Xyz::default()))
        .collect();
    common_gamut(&raw).unwrap()
}

/// The projectors as measurements with their black (`with_black`) or with black 0.
fn measurements(tab: &Tab6, with_black: bool) -> Vec<DisplayMeasurement> {
    tab.projectors
        .iter()
        .enumerate()
        .map(|(i, (n, p, k))| {
            let black = if with_black { *k } else { Xyz::default() };
            measurement(i, n, *p, black)
        })
        .collect()
}

#[test]
fn kresse_tab6_raw_common_gamut_matches_published_to_0_005() {
    let tab = load();
    assert_eq!(tab.projectors.len(), 2);
    // Raw readings (black not subtracted): what reproduces Tab. 6.
    assert_gamut_near(
        "raw readings",
        raw_gamut(&tab),
        tab.published,
        RAW_TOLERANCE_XY,
    );
}

#[test]
fn kresse_tab6_black_subtracted_common_gamut_as_commission_solves_is_near_published() {
    let tab = load();
    // The production path: `solve_wall` (used by `commission`) takes the common gamut of
    // `primaries_xy`, the black-subtracted primaries, with `common_gamut_named`.
    let gamut = common_gamut_named(&primaries_xy(&measurements(&tab, true)).unwrap()).unwrap();
    let by_hand: Vec<[[f64; 2]; 3]> = tab
        .projectors
        .iter()
        .map(|(_, p, k)| triangle(p, *k))
        .collect();
    assert_eq!(gamut, common_gamut(&by_hand).unwrap());
    assert_gamut_near(
        "black subtracted",
        gamut,
        tab.published,
        BLACK_SUBTRACTED_TOLERANCE_XY,
    );
}

#[test]
fn kresse_tab6_white_at_target_limited_by_projector_1_red_within_5_percent_of_published() {
    let tab = load();
    // White: the target chromaticity is the text's input; luminance from the solve.
    let wt = WhiteTarget::Xy(tab.target_white);
    let (pub_l, pub_xy) = tab.published_white;
    assert!((tab.target_white[0] - pub_xy[0]).abs() <= 0.005);
    assert!((tab.target_white[1] - pub_xy[1]).abs() <= 0.005);
    let with_black = measurements(&tab, true);
    let raw_meas = measurements(&tab, false);
    println!(
        "White at xy {:.3}/{:.3}: published {pub_l:.2} cd/m²",
        tab.target_white[0], tab.target_white[1]
    );
    let mut lums = Vec::new();
    for (label, meas, mode) in [
        (
            "raw matrix, black ignored      ",
            &raw_meas,
            BlackMode::Ignore,
        ),
        (
            "black-subtracted, ignore       ",
            &with_black,
            BlackMode::Ignore,
        ),
        (
            "black-subtracted, individual   ",
            &with_black,
            BlackMode::Individual,
        ),
        (
            "black-subtracted, common black ",
            &with_black,
            BlackMode::Common,
        ),
    ] {
        let ws = solve_white(meas, wt, 1.0, mode).unwrap();
        let w = ws.white_xyz_cd_m2;
        let xy = w.xy().unwrap();
        let (d, c) = ws.limiting.as_tuple();
        println!(
            "  {label} ours {:.2} cd/m² at {:.4}/{:.4} ({:+.1} % vs 77.86), limited by {} {}",
            w.y,
            xy[0],
            xy[1],
            100.0 * (w.y / pub_l - 1.0),
            tab.projectors[d].0,
            NAMES[c]
        );
        assert!((xy[0] - pub_xy[0]).abs() <= 0.005 && (xy[1] - pub_xy[1]).abs() <= 0.005);
        // Projector 1's red (13.41 cd/m²) limits the wall, as its tiny red suggests.
        assert_eq!((d, c), (0, 0));
        // The most limited channel is at exactly the headroom.
        let max = ws
            .channel_usage
            .iter()
            .flatten()
            .fold(0.0_f64, |a, b| a.max(*b));
        assert!((max - 1.0).abs() < 1e-12);
        lums.push(w.y);
    }
    // Stated, not tuned: within 5 % of the published 77.86 cd/m².
    assert!(lums.iter().all(|l| (l / pub_l - 1.0).abs() < 0.05));
}

#[test]
fn kresse_tab6_luminance_split_of_raw_common_primaries_matches_published_fractions() {
    let tab = load();
    let gamut = raw_gamut(&tab);
    let wt = WhiteTarget::Xy(tab.target_white);
    // Our common primaries' share of the white luminance vs the published 16.26/57.45/4.14.
    let ws = solve_white(&measurements(&tab, true), wt, 1.0, BlackMode::Individual).unwrap();
    let m = nalgebra::Matrix3::from_columns(
        &gamut.map(|p| Xyz::from_xy_luminance(p[0], p[1], 1.0).to_vector()),
    );
    let w = ws.white_xyz_cd_m2;
    let split = m.try_inverse().unwrap() * w.to_vector();
    let published_split = [16.26, 57.45, 4.14];
    println!(
        "  luminance split R/G/B: ours {:.2}/{:.2}/{:.2} (fractions {:.3}/{:.3}/{:.3}), published 16.26/57.45/4.14 ({:.3}/{:.3}/{:.3})",
        split[0],
        split[1],
        split[2],
        split[0] / w.y,
        split[1] / w.y,
        split[2] / w.y,
        16.26 / PUBLISHED_SPLIT_SUM,
        57.45 / PUBLISHED_SPLIT_SUM,
        4.14 / PUBLISHED_SPLIT_SUM
    );
    for c in 0..3 {
        assert!((split[c] / w.y - published_split[c] / PUBLISHED_SPLIT_SUM).abs() < 0.005);
    }
}
