//! Photometry acceptance tests: inverse-square cosine law for a point and an IES light,
//! flux integrals, IES/EULUMDAT parsing and symmetry unfolding, CIE skies. References
//! are analytic or computed here independently of the library's code paths.

use lumiwall_render::photometry::{
    IntensityDistribution, LightFrame, PhotometryError, PointLight, Sky, direct_illuminance_lux,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

fn fixture(name: &str) -> String {
    let path = format!(
        "{}/../fixtures/scenes/lights/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// An intensity law I(C°, γ°) used to write test files.
type Law = Box<dyn Fn(f64, f64) -> f64>;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

/// Five receiver points on the floor plane z = 0 (normal +z).
const FLOOR_POINTS: [[f64; 3]; 5] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.7, 1.1, 0.0],
    [-1.3, 0.4, 0.0],
    [0.5, -1.6, 0.0],
];

/// Direct illuminance at `point` on a floor (normal +z) from `light` at `source`,
/// axes of the light equal to world axes.
fn floor_illuminance_lux(
    light: &IntensityDistribution,
    source: [f64; 3],
    point: [f64; 3],
    visibility: f64,
) -> f64 {
    direct_illuminance_lux(
        light,
        source,
        &LightFrame::identity(),
        point,
        [0.0, 0.0, 1.0],
        visibility,
    )
}

#[test]
fn isotropic_point_light_over_plane_follows_inverse_square_cosine_law() {
    let light = IntensityDistribution::isotropic(250.0);
    let pos = [0.2, -0.1, 2.5];
    for p in FLOOR_POINTS {
        let e = floor_illuminance_lux(&light, pos, p, 1.0);
        let (dx, dy, dz) = (pos[0] - p[0], pos[1] - p[1], pos[2] - p[2]);
        let d2 = dx * dx + dy * dy + dz * dz;
        let reference = 250.0 * (dz / d2.sqrt()) / d2;
        println!(
            "point light {p:?}: E = {e:.6} lx, law {reference:.6} lx, rel err {:.2e}",
            rel(e, reference)
        );
        assert!(rel(e, reference) < 0.01, "{p:?}: {e} vs {reference}");
        assert!(rel(e, reference) < 1e-12);
    }
    // behind the plane, fully shadowed, and at the source: 0
    let below = [0.0, 0.0, -1.0];
    assert_eq!(floor_illuminance_lux(&light, below, [0.0; 3], 1.0), 0.0);
    assert_eq!(floor_illuminance_lux(&light, pos, [0.0; 3], 0.0), 0.0);
    assert_eq!(floor_illuminance_lux(&light, pos, pos, 1.0), 0.0);
}

/// The distribution the IES fixture was generated from (see its README).
fn ies_fixture_law(c_deg: f64, gamma_deg: f64) -> f64 {
    if gamma_deg > 90.0 {
        return 0.0;
    }
    900.0 * gamma_deg.to_radians().cos().powf(1.5) * (1.0 + 0.2 * c_deg.to_radians().cos())
}

#[test]
fn ies_light_over_plane_follows_inverse_square_cosine_law() {
    let dist = IntensityDistribution::from_ies_lm63(&fixture("downlight_bilateral.ies")).unwrap();
    let pos = [0.3, 0.2, 3.0];
    let light = PointLight {
        distribution: dist,
        position: pos,
        frame: LightFrame::identity(),
    };
    for p in FLOOR_POINTS {
        let e = light.illuminance_lux(p, [0.0, 0.0, 1.0], 1.0);
        // independent reference: angles in the luminaire frame (identity: −z nadir, +x C0)
        let v = [p[0] - pos[0], p[1] - pos[1], p[2] - pos[2]];
        let d = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let gamma = (-v[2] / d).acos().to_degrees();
        let c = v[1].atan2(v[0]).to_degrees().rem_euclid(360.0);
        let cos_e = -v[2] / d;
        let reference = ies_fixture_law(c, gamma) * cos_e / (d * d);
        println!(
            "IES light {p:?}: E = {e:.4} lx, law {reference:.4} lx, rel err {:.2e}",
            rel(e, reference)
        );
        assert!(
            rel(e, reference) < 0.01,
            "{p:?} (C {c:.1}°, γ {gamma:.1}°): {e} vs {reference}"
        );
    }
}

#[test]
fn rotated_frame_aims_the_photometric_axis() {
    // a narrow spot aimed along +x hits a wall at x = 4 (normal −x) head-on
    let spot = IntensityDistribution::spot(1000.0, 0.1, 0.2);
    let frame = LightFrame::aimed([1.0, 0.0, 0.0]);
    // on the wall x = 4 (normal −x), unshadowed, from the origin
    let wall_illuminance_lux = |point: [f64; 3]| {
        direct_illuminance_lux(&spot, [0.0; 3], &frame, point, [-1.0, 0.0, 0.0], 1.0)
    };
    let e = wall_illuminance_lux([4.0, 0.0, 0.0]);
    assert!(rel(e, 1000.0 / 16.0) < 1e-12, "{e}");
    // outside the cone: dark
    let e_off = wall_illuminance_lux([4.0, 2.0, 0.0]);
    assert_eq!(e_off, 0.0);
}

#[test]
fn isotropic_flux_is_four_pi_intensity() {
    let flux = IntensityDistribution::isotropic(100.0).total_flux_lm();
    println!(
        "isotropic 100 cd: {flux:.9} lm vs 400π = {:.9} lm, rel err {:.1e}",
        400.0 * PI,
        rel(flux, 400.0 * PI)
    );
    assert!(rel(flux, 400.0 * PI) < 1e-4, "{flux}");
}

#[test]
fn spot_flux_matches_cone_solid_angle_and_rescales() {
    // hard-edged cone: Φ = 2π I (1 − cos θ)
    let theta: f64 = 0.5;
    let hard = IntensityDistribution::spot(300.0, theta, theta);
    let want = 2.0 * PI * 300.0 * (1.0 - theta.cos());
    assert!(
        rel(hard.total_flux_lm(), want) < 1e-4,
        "{} vs {want}",
        hard.total_flux_lm()
    );
    // soft edge: smoothstep in cos γ integrates to half the band: Φ = 2πI[(1−cos θi) + (cos θi − cos θo)/2]
    let (ti, to) = (0.3f64, 0.7f64);
    let soft = IntensityDistribution::spot(300.0, ti, to);
    let want = 2.0 * PI * 300.0 * ((1.0 - ti.cos()) + 0.5 * (ti.cos() - to.cos()));
    assert!(
        rel(soft.total_flux_lm(), want) < 1e-6,
        "{} vs {want}",
        soft.total_flux_lm()
    );
    let scaled = soft.scaled_to_flux(1234.0);
    assert!(rel(scaled.total_flux_lm(), 1234.0) < 1e-12);
}

/// Prints the integrated flux of `d` against the `declared` flux and asserts they
/// agree within 0.5 %.
fn assert_integral_within_half_percent(d: &IntensityDistribution, what: &str, declared: f64) {
    println!(
        "{what}: integral {:.2} lm vs {declared:.2} lm, rel err {:.1e}",
        d.total_flux_lm(),
        rel(d.total_flux_lm(), declared)
    );
    assert!(
        rel(d.total_flux_lm(), declared) < 0.005,
        "{what}: {} vs {declared}",
        d.total_flux_lm()
    );
}

#[test]
fn ies_fixture_flux_matches_header_lumens() {
    let d = IntensityDistribution::from_ies_lm63(&fixture("downlight_bilateral.ies")).unwrap();
    let header = d.declared_flux_lm().unwrap();
    assert!((header - 2262.7).abs() < 1e-9);
    assert_integral_within_half_percent(&d, "IES fixture: header", header);
    // and against the analytic flux of the formula the file was made from: 2π·900/2.5
    assert!(rel(d.total_flux_lm(), 2.0 * PI * 900.0 / 2.5) < 0.005);
    assert!(d.name().contains("bilateral"));
}

#[test]
fn eulumdat_fixture_flux_matches_lamp_flux_times_lor() {
    let d = IntensityDistribution::from_eulumdat(&fixture("wallwasher_sym2.ldt")).unwrap();
    let declared = d.declared_flux_lm().unwrap();
    assert_integral_within_half_percent(&d, "EULUMDAT fixture: lamp flux × LORL", declared);
    // node check: C30 (given) and its mirror C330, γ 40°: 2000 lm/1000 × formula
    let law = |c: f64, g: f64| {
        let (cr, gr) = (c.to_radians(), g.to_radians());
        220.0 * gr.cos() + 90.0 * (2.0 * gr).sin().powi(2) * (1.0 + cr.cos()) / 2.0
    };
    for c in [30.0, 330.0, 195.0] {
        let want = 2.0 * (law(c, 40.0) * 10.0).round() / 10.0;
        let got = d.intensity_cd(dir(c, 40.0));
        assert!(rel(got, want) < 1e-9, "C{c}: {got} vs {want}");
    }
}

/// Local direction for C, γ in degrees (γ from the nadir −z, C from +x towards +y).
fn dir(c_deg: f64, g_deg: f64) -> [f64; 3] {
    let (c, g) = (c_deg.to_radians(), g_deg.to_radians());
    [g.sin() * c.cos(), g.sin() * c.sin(), -g.cos()]
}

fn ies_text(
    h_angles: &[f64],
    v_angles: &[f64],
    f: &dyn Fn(f64, f64) -> f64,
    multiplier: f64,
) -> String {
    let mut s = String::from("IESNA:LM-63-2002\n[LUMINAIRE] test\nTILT=NONE\n");
    s += &format!(
        "1 -1 {multiplier} {} {} 1 2 0 0 0\n1.0 1.0 10\n",
        v_angles.len(),
        h_angles.len()
    );
    for v in v_angles {
        s += &format!("{v} ");
    }
    s += "\n";
    for h in h_angles {
        s += &format!("{h}\n");
    }
    for h in h_angles {
        for v in v_angles {
            s += &format!("{},", f(*h, *v) / multiplier);
        }
        s += "\n";
    }
    s
}

fn random_dirs(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let z: f64 = rng.random_range(-1.0..1.0);
            let phi: f64 = rng.random_range(0.0..2.0 * PI);
            let s = (1.0 - z * z).sqrt();
            [s * phi.cos(), s * phi.sin(), z]
        })
        .collect()
}

#[test]
fn ies_symmetries_agree_with_full_table() {
    let v: Vec<f64> = (0..=36).map(|k| k as f64 * 5.0).collect();
    let full_h: Vec<f64> = (0..=24).map(|k| k as f64 * 15.0).collect();
    let cases: [(&str, Vec<f64>, Law); 4] = [
        (
            "quadrant",
            (0..=6).map(|k| k as f64 * 15.0).collect(),
            Box::new(|c: f64, g: f64| 100.0 + 50.0 * (2.0 * c.to_radians()).cos() + g),
        ),
        (
            "C0-C180",
            (0..=12).map(|k| k as f64 * 15.0).collect(),
            Box::new(|c: f64, g: f64| 100.0 + 50.0 * c.to_radians().cos() + g),
        ),
        (
            "C90-C270",
            (6..=18).map(|k| k as f64 * 15.0).collect(),
            Box::new(|c: f64, g: f64| 100.0 + 50.0 * c.to_radians().sin() + g),
        ),
        (
            "rotational",
            vec![0.0],
            Box::new(|_c: f64, g: f64| 100.0 + (g / 30.0).sin()),
        ),
    ];
    for (name, h, f) in cases {
        let full = IntensityDistribution::from_ies_lm63(&ies_text(&full_h, &v, &*f, 1.0)).unwrap();
        let reduced = IntensityDistribution::from_ies_lm63(&ies_text(&h, &v, &*f, 2.5)).unwrap();
        for d in random_dirs(500, 7) {
            let (a, b) = (full.intensity_cd(d), reduced.intensity_cd(d));
            assert!(
                (a - b).abs() < 1e-9 * a.max(1.0),
                "{name} {d:?}: full {a} reduced {b}"
            );
        }
        assert!(
            rel(full.total_flux_lm(), reduced.total_flux_lm()) < 1e-12,
            "{name}"
        );
        assert_eq!(
            full.declared_flux_lm(),
            None,
            "absolute photometry has no lamp lumens"
        );
    }
}

/// A EULUMDAT text with Mc = 24 C planes (15°), γ 0…180° in 10°, lamp flux 1000 lm,
/// intensities f(C, γ) in cd/klm for the C planes the symmetry indicator selects.
fn ldt_text(isym: u32, f: &dyn Fn(f64, f64) -> f64) -> String {
    let mc = 24usize;
    let ng = 19usize;
    let mut l: Vec<String> = vec![
        "test".into(),
        "1".into(),
        isym.to_string(),
        mc.to_string(),
        "15".into(),
        ng.to_string(),
        "10".into(),
        "report".into(),
        "name".into(),
        "number".into(),
        "file.ldt".into(),
        "date".into(),
    ];
    for _ in 13..=21 {
        l.push("0".into());
    }
    l.extend(
        [
            "100", "80", "1.0", "0", "1", "1", "LED", "1000", "3000", "80", "10",
        ]
        .map(String::from),
    );
    for k in 0..10 {
        l.push(format!("0.{}", k + 1));
    }
    for k in 0..mc {
        l.push(format!("{}", k as f64 * 15.0));
    }
    for k in 0..ng {
        l.push(format!("{}", k as f64 * 10.0));
    }
    // planes per the EULUMDAT spec: Mc1..Mc2 (1-based)
    let planes: Vec<usize> = match isym {
        0 => (0..mc).collect(),
        1 => vec![0],
        2 => (0..=mc / 2).collect(),
        3 => (3 * mc / 4..=3 * mc / 4 + mc / 2).map(|i| i % mc).collect(),
        _ => (0..=mc / 4).collect(),
    };
    for p in planes {
        for k in 0..ng {
            l.push(format!("{}", f(p as f64 * 15.0, k as f64 * 10.0)));
        }
    }
    l.join("\n")
}

#[test]
fn eulumdat_symmetries_agree_with_full_table() {
    let cases: [(u32, Law); 4] = [
        (1, Box::new(|_c: f64, g: f64| 200.0 + g)),
        (
            2,
            Box::new(|c: f64, g: f64| 200.0 + 80.0 * c.to_radians().cos() + g),
        ),
        (
            3,
            Box::new(|c: f64, g: f64| 200.0 + 80.0 * c.to_radians().sin() + g),
        ),
        (
            4,
            Box::new(|c: f64, g: f64| 200.0 + 80.0 * (2.0 * c.to_radians()).cos() + g),
        ),
    ];
    for (isym, f) in cases {
        let full = IntensityDistribution::from_eulumdat(&ldt_text(0, &*f)).unwrap();
        let reduced = IntensityDistribution::from_eulumdat(&ldt_text(isym, &*f)).unwrap();
        for d in random_dirs(500, 11) {
            let (a, b) = (full.intensity_cd(d), reduced.intensity_cd(d));
            assert!(
                (a - b).abs() < 1e-9 * a,
                "Isym {isym} {d:?}: full {a} reduced {b}"
            );
        }
        // nodes reproduce the law itself (lamp flux 1000 lm → cd = cd/klm)
        for (c, g) in [(0.0, 0.0), (105.0, 40.0), (255.0, 130.0), (300.0, 180.0)] {
            let got = reduced.intensity_cd(dir(c, g));
            assert!(
                rel(got, f(c, g)) < 1e-9,
                "Isym {isym} C{c} γ{g}: {got} vs {}",
                f(c, g)
            );
        }
        assert!((reduced.declared_flux_lm().unwrap() - 800.0).abs() < 1e-9);
    }
}

#[test]
fn truncated_and_garbled_files_give_typed_errors_with_line_numbers() {
    let ies = fixture("downlight_bilateral.ies");
    let lines: Vec<&str> = ies.lines().collect();
    // cut in the middle of the candela block
    let cut = lines[..lines.len() - 3].join("\n");
    match IntensityDistribution::from_ies_lm63(&cut) {
        Err(PhotometryError::Truncated { line, expected, .. }) => {
            assert_eq!(line, lines.len() - 3);
            assert!(expected.contains("candela"), "{expected}");
        }
        other => panic!("expected Truncated, got {other:?}"),
    }
    // garble a vertical angle on line 15
    let mut garbled: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    garbled[14] = garbled[14].replacen("55.0", "5x5", 1);
    match IntensityDistribution::from_ies_lm63(&garbled.join("\n")) {
        Err(PhotometryError::Parse { line, message, .. }) => {
            assert_eq!(line, 15, "{message}");
        }
        other => panic!("expected Parse error, got {other:?}"),
    }
    // no TILT line
    assert!(matches!(
        IntensityDistribution::from_ies_lm63("IESNA:LM-63-2002\n[TEST] x\n"),
        Err(PhotometryError::Truncated { .. })
    ));
    // type B is rejected clearly; TILT=<file> too
    let type_b = ies.replacen("1 2262.7 2.0 19 7 1 2", "1 2262.7 2.0 19 7 2 2", 1);
    let err = IntensityDistribution::from_ies_lm63(&type_b).unwrap_err();
    assert!(
        matches!(err, PhotometryError::Unsupported { line: 12, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("type C"));
    let tilt_file = ies.replacen("TILT=NONE", "TILT=lamp.tlt", 1);
    assert!(matches!(
        IntensityDistribution::from_ies_lm63(&tilt_file),
        Err(PhotometryError::Unsupported { line: 11, .. })
    ));

    let ldt = fixture("wallwasher_sym2.ldt");
    let ll: Vec<&str> = ldt.lines().collect();
    match IntensityDistribution::from_eulumdat(&ll[..100].join("\n")) {
        Err(PhotometryError::Truncated { line: 100, .. }) => {}
        other => panic!("expected Truncated at 100, got {other:?}"),
    }
    let mut bad: Vec<String> = ll.iter().map(|s| s.to_string()).collect();
    bad[3] = "twenty-four".into();
    match IntensityDistribution::from_eulumdat(&bad.join("\n")) {
        Err(PhotometryError::Parse { line: 4, .. }) => {}
        other => panic!("expected Parse at line 4, got {other:?}"),
    }
    bad[3] = "24".into();
    bad[2] = "7".into();
    assert!(matches!(
        IntensityDistribution::from_eulumdat(&bad.join("\n")),
        Err(PhotometryError::Parse { line: 3, .. })
    ));
    // never panics on arbitrary prefixes
    for n in 0..ll.len() {
        let _ = IntensityDistribution::from_eulumdat(&ll[..n].join("\n"));
    }
    for n in 0..lines.len() {
        let _ = IntensityDistribution::from_ies_lm63(&lines[..n].join("\n"));
    }
}

#[test]
fn ies_tilt_include_is_read_and_applied_at_zero_tilt() {
    let f = |_c: f64, g: f64| 100.0 + g;
    let v: Vec<f64> = (0..=18).map(|k| k as f64 * 10.0).collect();
    let base = ies_text(&[0.0], &v, &f, 1.0);
    let with_tilt = base.replacen(
        "TILT=NONE\n",
        "TILT=INCLUDE\n1\n3\n0 45 90\n0.9 0.8 0.7\n",
        1,
    );
    let a = IntensityDistribution::from_ies_lm63(&base).unwrap();
    let b = IntensityDistribution::from_ies_lm63(&with_tilt).unwrap();
    let d = dir(0.0, 30.0);
    assert!(rel(b.intensity_cd(d), 0.9 * a.intensity_cd(d)) < 1e-12);
}

#[test]
fn cie_overcast_horizontal_illuminance_is_seven_ninths_pi_lz() {
    let lz = 3000.0;
    let sky = Sky::cie_overcast(lz);
    let e = sky.horizontal_illuminance_lux();
    let want = 7.0 / 9.0 * PI * lz;
    println!(
        "overcast Lz = {lz}: E_h = {e:.6} lx vs 7/9·π·Lz = {want:.6} lx, rel err {:.1e}",
        rel(e, want)
    );
    assert!(rel(e, want) < 1e-3, "{e} vs {want}");
    assert!(
        rel(e, want) < 1e-6,
        "quadrature should be near exact: {e} vs {want}"
    );
    assert!(rel(sky.luminance_cd_m2([0.0, 0.0, 1.0]), lz) < 1e-12);
    assert!(rel(sky.luminance_cd_m2([1.0, 0.0, 0.0]), lz / 3.0) < 1e-12);
    assert_eq!(sky.luminance_cd_m2([0.0, 0.0, -1.0]), 0.0);
    assert!(sky.sun().is_none());
    // vertical plane, black ground: E_v = Lz (π/6 + 4/9)
    let ev = sky.illuminance_on_plane_lux([1.0, 0.0, 0.0]);
    let want_v = lz * (PI / 6.0 + 4.0 / 9.0);
    assert!(rel(ev, want_v) < 1e-3, "{ev} vs {want_v}");
}

#[test]
fn cie_clear_sky_matches_the_1973_formula_and_has_a_sun() {
    let lz = 2000.0;
    let alt: f64 = 35f64.to_radians();
    let az: f64 = 20f64.to_radians();
    let sun_dir = [alt.cos() * az.cos(), alt.cos() * az.sin(), alt.sin()];
    let sky = Sky::cie_clear(sun_dir, lz);
    // CIE 1973 form: L/Lz = (0.91 + 10 e^{−3χ} + 0.45 cos²χ)(1 − e^{−0.32/cos Z}) / ((0.91 + 10 e^{−3Zs} + 0.45 cos² Zs)(1 − e^{−0.32}))
    let zs = PI / 2.0 - alt;
    let f = |x: f64| 0.91 + 10.0 * (-3.0 * x).exp() + 0.45 * x.cos().powi(2);
    let phi = |z: f64| 1.0 - (-0.32 / z.cos()).exp();
    for d in random_dirs(200, 3).into_iter().filter(|d| d[2] > 0.05) {
        let z = d[2].acos();
        let chi = (d[0] * sun_dir[0] + d[1] * sun_dir[1] + d[2] * sun_dir[2])
            .clamp(-1.0, 1.0)
            .acos();
        let want = lz * f(chi) * phi(z) / (f(zs) * phi(0.0));
        let got = sky.luminance_cd_m2(d);
        assert!(rel(got, want) < 2e-3, "{d:?}: {got} vs {want}");
    }
    assert!(rel(sky.luminance_cd_m2([0.0, 0.0, 1.0]), lz) < 1e-12);
    let sun = sky.sun().expect("sun above the horizon");
    // IES clear sky: E_n = 127.5 klx · exp(−0.21 m), m ≈ 1/sin(35°) = 1.743 → 88.5 klx
    let want = 127_500.0 * (-0.21 / alt.sin()).exp();
    assert!(
        rel(sun.normal_illuminance_lux, want) < 0.01,
        "{}",
        sun.normal_illuminance_lux
    );
    assert!(sky.horizontal_illuminance_lux() > 0.0);
    assert!(
        sky.global_horizontal_illuminance_lux() > sky.horizontal_illuminance_lux() + 0.5 * want
    );
    assert!(Sky::cie_clear([1.0, 0.0, -0.1], lz).sun().is_none());
}

#[test]
fn sky_patches_cover_the_hemisphere_and_reproduce_illuminance() {
    for sky in [
        Sky::cie_overcast(5000.0),
        Sky::cie_clear([0.5, 0.2, 0.6], 4000.0),
    ] {
        let patches = sky.patches(18);
        let omega: f64 = patches.iter().map(|p| p.solid_angle_sr).sum();
        assert!(rel(omega, 2.0 * PI) < 1e-12, "{omega}");
        let e: f64 = patches
            .iter()
            .map(|p| p.luminance_cd_m2 * p.solid_angle_sr * p.direction[2])
            .sum();
        let want = sky.horizontal_illuminance_lux();
        println!(
            "sky patches (18 bands, {} cells): E_h {e:.1} lx vs {want:.1} lx",
            patches.len()
        );
        assert!(rel(e, want) < 0.01, "{e} vs {want}");
    }
    // overcast against the analytic value too
    let e: f64 = Sky::cie_overcast(1.0)
        .patches(18)
        .iter()
        .map(|p| p.luminance_cd_m2 * p.solid_angle_sr * p.direction[2])
        .sum();
    assert!(rel(e, 7.0 / 9.0 * PI) < 0.005, "{e}");
}

#[test]
fn frame_from_axis_keeps_c0_and_is_right_handed() {
    // a wall washer aimed horizontally along +y with C0 along world +z
    let f = LightFrame::from_axis([0.0, 0.3, 1.0], [0.0, 2.0, 0.0]);
    let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12);
    assert!(
        close(f.to_local([0.0, 1.0, 0.0]), [0.0, 0.0, -1.0]),
        "axis is local −z"
    );
    assert!(close(f.x, [0.0, 0.0, 1.0]));
    // right-handed: x × y = z
    let c = [
        f.x[1] * f.y[2] - f.x[2] * f.y[1],
        f.x[2] * f.y[0] - f.x[0] * f.y[2],
        f.x[0] * f.y[1] - f.x[1] * f.y[0],
    ];
    assert!(close(c, f.z));
    // round trip
    let d = [0.3, -0.4, 0.5];
    assert!(close(f.to_world(f.to_local(d)), d));
}

#[test]
fn relative_photometry_scales_with_the_lamp_flux() {
    let d = IntensityDistribution::from_ies_lm63(&fixture("downlight_bilateral.ies")).unwrap();
    assert_eq!(d.rated_lamp_flux_lm(), Some(2262.7));
    let dir0 = dir(30.0, 20.0);
    let i0 = d.intensity_cd(dir0);
    let f0 = d.total_flux_lm();
    let d2 = d.with_lamp_flux_lm(2.0 * 2262.7).unwrap();
    assert!(rel(d2.intensity_cd(dir0), 2.0 * i0) < 1e-12);
    assert!(rel(d2.total_flux_lm(), 2.0 * f0) < 1e-12);
    let l = IntensityDistribution::from_eulumdat(&fixture("wallwasher_sym2.ldt")).unwrap();
    assert_eq!(l.rated_lamp_flux_lm(), Some(2000.0));
    assert!(
        IntensityDistribution::isotropic(1.0)
            .with_lamp_flux_lm(100.0)
            .is_err()
    );
    assert!(l.with_lamp_flux_lm(-1.0).is_err());
}

#[test]
fn ies_multibyte_character_in_the_first_bytes_of_a_header_line_is_no_panic() {
    // found by fuzz_parsers: `l[..5]` sliced inside a UTF-8 character
    let ies = fixture("downlight_bilateral.ies");
    let text = ies.replacen("[TEST]", "TIL\u{e9}[TEST]", 1);
    assert!(IntensityDistribution::from_ies_lm63(&text).is_ok());
    assert!(IntensityDistribution::from_ies_lm63("ab\u{e9}\u{e9}\n").is_err());
    // and a byte-order mark before TILT= still reads the TILT value
    let bom = ies.replacen("TILT=NONE", "\u{feff}TILT=NONE", 1);
    assert!(IntensityDistribution::from_ies_lm63(&bom).is_ok());
}
