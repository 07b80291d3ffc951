//! The wall fixtures are what they claim to be (Kresse 3.3.8 HEyeWall, Tab. 6 pair).

use std::path::PathBuf;

use lumiwall_core::Xy;
use lumiwall_devices::sim::VirtualWall;
use lumiwall_devices::{DisplayId, Eye, Xyz};
use nalgebra::{Matrix3, Vector3};

fn wall(name: &str) -> VirtualWall {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/walls")
        .join(name);
    VirtualWall::from_toml_file(&p).unwrap()
}

fn sub(a: Xyz, b: Xyz) -> Vector3<f64> {
    (a - b).to_vector()
}

/// Channel drive (relative intensity) each display needs for white `xy` at Y = 1.
fn white_mix(w: &VirtualWall, id: DisplayId, xy: [f64; 2]) -> Vector3<f64> {
    let p = w.true_primaries(id).unwrap();
    let m = Matrix3::from_columns(&[
        sub(p.red, p.black),
        sub(p.green, p.black),
        sub(p.blue, p.black),
    ]);
    m.try_inverse().unwrap() * Xy::from(xy).with_luminance(1.0).to_vector()
}

/// Channel usage for the common white (largest channel over all displays = 1) and
/// the common white luminance.
fn usage(w: &VirtualWall, xy: [f64; 2]) -> (Vec<Vector3<f64>>, f64) {
    let mixes: Vec<_> = w
        .displays()
        .iter()
        .map(|d| white_mix(w, d.id, xy))
        .collect();
    let max = mixes
        .iter()
        .flat_map(|m| m.iter().copied())
        .fold(0.0, f64::max);
    (mixes.iter().map(|m| m / max).collect(), 1.0 / max)
}

const WHITE_8500K: [f64; 2] = [0.291, 0.300];

#[test]
fn heyewall_48_is_kresse_like() {
    let w = wall("heyewall-48.toml");
    let d = w.displays();
    assert_eq!(d.len(), 48);
    assert!(d[..24].iter().all(|x| x.eye == Eye::Left));
    assert!(d[24..].iter().all(|x| x.eye == Eye::Right));
    assert!(d.iter().all(|x| x.bit_depth == 10));
    let (u, y_white) = usage(&w, WHITE_8500K);
    for (i, ui) in u.iter().enumerate() {
        println!(
            "display {i:2} usage for the common 8500 K white: r {:.3} g {:.3} b {:.3}, lamp {:.0} h",
            ui[0],
            ui[1],
            ui[2],
            w.lamp_hours(DisplayId(i as u32)).unwrap()
        );
    }
    println!("common white {y_white:.2} cd/m²");
    // Every display reaches the common white with all channels in (0, 1].
    assert!(
        u.iter()
            .all(|m| m.iter().all(|&c| c > 0.0 && c <= 1.0 + 1e-12))
    );
    assert!(y_white > 30.0, "common white only {y_white} cd/m²");
    // Kresse Abb. 27: the red of projector 26 limits the wall (100 %).
    assert!((u[26][0] - 1.0).abs() < 1e-12);
    // Left greens (0–23) need 58–95 %.
    let lg: Vec<f64> = u[..24].iter().map(|m| m[1]).collect();
    let (lo, hi) = (
        lg.iter().copied().fold(1.0, f64::min),
        lg.iter().copied().fold(0.0, f64::max),
    );
    assert!(
        (0.55..=0.65).contains(&lo) && (0.85..=0.97).contains(&hi),
        "left green {lo}..{hi}"
    );
    // Right greens: only ~10 % usable.
    let mut rg: Vec<f64> = u[24..].iter().map(|m| m[1]).collect();
    rg.sort_by(f64::total_cmp);
    assert!(
        rg.iter().all(|&g| (0.06..=0.15).contains(&g)),
        "right green {rg:?}"
    );
    assert!(
        (0.08..=0.13).contains(&rg[12]),
        "median right green {}",
        rg[12]
    );
    // Lamp hours differ.
    let hours: Vec<f64> = d.iter().map(|x| w.lamp_hours(x.id).unwrap()).collect();
    assert!(
        hours.iter().copied().fold(0.0, f64::max) - hours.iter().copied().fold(1e9, f64::min)
            > 1000.0
    );
}

fn close(what: &str, got: Xyz, lum: f64, xy: [f64; 2], lum_tol_rel: f64, xy_tol: f64) {
    let g = got.xy().unwrap();
    println!("{what}: {:.2} cd/m² {:.3?} (Kresse {lum} {xy:?})", got.y, g);
    assert!(
        (got.y / lum - 1.0).abs() < lum_tol_rel,
        "{what} luminance {} vs {lum}",
        got.y
    );
    assert!(
        (g[0] - xy[0]).abs() < xy_tol && (g[1] - xy[1]).abs() < xy_tol,
        "{what} xy {g:?} vs {xy:?}"
    );
}

/// Kresse Tab. 6 (two Eiki LC-UXT1 with Infitec): display 0 is his "Projektor 2"
/// (reddish, left), display 1 his "Projektor 1" (greenish, right).
#[test]
fn infitec_pair_reproduces_kresse_tab6() {
    let w = wall("infitec-pair.toml");
    assert_eq!(w.displays().len(), 2);
    let l = w.true_primaries(DisplayId(0)).unwrap();
    let r = w.true_primaries(DisplayId(1)).unwrap();
    close("left R", l.red, 118.72, [0.627, 0.371], 0.1, 0.025);
    close("left G", l.green, 67.82, [0.209, 0.668], 0.1, 0.025);
    close("left B", l.blue, 17.02, [0.139, 0.039], 0.1, 0.025);
    close("left W", l.white, 202.72, [0.357, 0.268], 0.1, 0.04);
    close("right R", r.red, 13.41, [0.668, 0.328], 0.1, 0.03);
    close("right G", r.green, 327.51, [0.305, 0.685], 0.1, 0.01);
    close("right B", r.blue, 11.31, [0.138, 0.044], 0.1, 0.025);
    close("right W", r.white, 351.51, [0.269, 0.458], 0.1, 0.04);
    // Black: sub-cd/m², and of another chromaticity than the white.
    for p in [l, r] {
        assert!(p.black.y > 0.1 && p.black.y < 1.0);
        let (k, wh) = (p.black.chromaticity(), p.white.chromaticity());
        assert!(k.unwrap().distance(wh.unwrap()) > 0.03);
    }
}

#[test]
fn every_fixture_loads() {
    for (name, n) in [
        ("heyewall-48.toml", 48),
        ("infitec-pair.toml", 2),
        ("mono-2x1.toml", 2),
        ("dlp-nonadditive.toml", 1),
    ] {
        let w = wall(name);
        assert_eq!(w.displays().len(), n, "{name}");
        assert_eq!(w.name(), name.trim_end_matches(".toml"));
    }
}

/// `from_toml_file_with_seed` builds another instance of the file's wall class: with
/// the file's own seed the same wall, with another seed other projectors (the
/// manufacturing scatter drawn again) of the same layout; a missing file names itself.
#[test]
fn a_wall_file_with_another_seed_is_another_instance_of_its_class() {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/walls/mono-2x1.toml");
    let file = wall("mono-2x1.toml");
    let same = VirtualWall::from_toml_file_with_seed(&p, file.seed()).unwrap();
    let other = VirtualWall::from_toml_file_with_seed(&p, file.seed() + 1).unwrap();
    assert_eq!(other.seed(), file.seed() + 1);
    assert_eq!(other.displays().len(), file.displays().len());
    for d in file.displays() {
        let (a, b, c) = (
            file.true_primaries(d.id).unwrap(),
            same.true_primaries(d.id).unwrap(),
            other.true_primaries(d.id).unwrap(),
        );
        assert_eq!(a, b, "display {:?}", d.id);
        assert!(
            (a.white.y / c.white.y - 1.0).abs() > 1e-6,
            "display {:?}",
            d.id
        );
    }
    let missing = p.with_file_name("no-such-wall.toml");
    let err = VirtualWall::from_toml_file_with_seed(&missing, 1).unwrap_err();
    assert!(err.to_string().contains("no-such-wall.toml"), "{err}");
}
