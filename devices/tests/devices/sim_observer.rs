//! The embedded CIE tables integrate reference spectra to their published
//! chromaticities (CIE 015:2018: E = 1/3, 1/3; D65 = 0.31272, 0.32903).

use lumiwall_devices::Xyz;
use lumiwall_devices::sim::observer::{N_SAMPLES, Spectrum, cie1931, d65, wavelength_nm};
use lumiwall_devices::sim::spectra::{Band, planck};

fn xy(t: [f64; 3]) -> [f64; 2] {
    Xyz::from_array(t).xy().unwrap()
}

#[test]
fn grid_is_360_to_830_nm() {
    assert_eq!(wavelength_nm(0), 360.0);
    assert_eq!(wavelength_nm(N_SAMPLES - 1), 830.0);
}

#[test]
fn equal_energy_is_one_third() {
    let obs = cie1931().unwrap();
    let e = xy(obs.tristimulus(&Spectrum::constant(1.0)));
    assert!((e[0] - 1.0 / 3.0).abs() < 1e-4, "{e:?}");
    assert!((e[1] - 1.0 / 3.0).abs() < 1e-4, "{e:?}");
}

#[test]
fn d65_is_3127_3290() {
    let obs = cie1931().unwrap();
    let w = xy(obs.tristimulus(d65().unwrap()));
    assert!((w[0] - 0.31272).abs() < 1e-4, "{w:?}");
    assert!((w[1] - 0.32903).abs() < 1e-4, "{w:?}");
}

#[test]
fn peak_of_y_bar_is_555_nm_and_one() {
    let obs = cie1931().unwrap();
    let (i, v) = obs
        .y_bar
        .values
        .iter()
        .enumerate()
        .fold((0, 0.0), |a, (i, &v)| if v > a.1 { (i, v) } else { a });
    assert!((wavelength_nm(i) - 555.0).abs() <= 1.0);
    assert!((v - 1.0).abs() < 1e-3);
}

/// A black body at 2856 K is illuminant A: colour-science gives x 0.44754, y 0.40743
/// (`sd_to_XYZ(sd_blackbody(2856))`); CIE 015 lists 0.44758, 0.40745.
#[test]
fn black_body_2856k_is_illuminant_a() {
    let obs = cie1931().unwrap();
    let a = xy(obs.tristimulus(&Spectrum::from_fn(|wl| planck(wl, 2856.0))));
    assert!((a[0] - 0.44754).abs() < 1e-4, "{a:?}");
    assert!((a[1] - 0.40743).abs() < 1e-4, "{a:?}");
}

/// A narrow band at 546 nm lands on the spectral locus there (x 0.27296, y 0.71806,
/// `colour.XYZ_to_xy(MSDS_CMFS["CIE 1931 2 Degree Standard Observer"][546])`).
#[test]
fn narrow_band_sits_on_the_spectral_locus() {
    let obs = cie1931().unwrap();
    let b = Band {
        lo_nm: 545.5,
        hi_nm: 546.5,
        edge_nm: 0.05,
        peak: 1.0,
        floor: 0.0,
    };
    let p = xy(obs.tristimulus(&b.spectrum()));
    let (x, y, z) = (
        obs.x_bar.at(546.0),
        obs.y_bar.at(546.0),
        obs.z_bar.at(546.0),
    );
    let locus = xy([x, y, z]);
    assert!(
        (p[0] - locus[0]).abs() < 2e-3 && (p[1] - locus[1]).abs() < 2e-3,
        "{p:?} {locus:?}"
    );
    assert!(
        (locus[0] - 0.27296).abs() < 1e-4 && (locus[1] - 0.71806).abs() < 1e-4,
        "{locus:?}"
    );
}

/// The whole spectral chain (UHP lamp, panel band-passes, Infitec combs, black leak,
/// observer integration) against an independent numpy + colour-science
/// implementation of the formulas in `fixtures/spectra/README.md`:
/// `python3 fixtures/spectra/crosscheck.py` (colour-science 0.4.7) printed these.
#[test]
fn projector_primaries_match_colour_science() {
    use lumiwall_devices::DisplayId;
    use lumiwall_devices::sim::VirtualWall;
    let w = VirtualWall::from_toml_str(
        r#"
name = "crosscheck"
seed = 1
stereo = "infitec"
[tiles]
cols = 1
rows = 1
[clock]
minutes_since_switch_on = 100000.0
[projector]
[projector.lamp]
kind = "uhp"
white_cd_m2 = 1000.0
"#,
    )
    .unwrap();
    let expected: [[[f64; 3]; 4]; 2] = [
        [
            [0.179764, 0.08667, 0.499949],
            [90.81969, 45.38710, 0.03510946],
            [5.360408, 37.746647, 3.287115],
            [34.879618, 5.186077, 189.604302],
        ],
        [
            [0.188799, 0.275895, 0.411572],
            [23.00059, 9.478575, 0.002092415],
            [126.158598, 291.165637, 3.38849],
            [24.346027, 10.538726, 155.853449],
        ],
    ];
    for (eye, exp) in expected.iter().enumerate() {
        let p = w.true_primaries(DisplayId(eye as u32)).unwrap();
        let got = [
            p.black,
            p.red - p.black,
            p.green - p.black,
            p.blue - p.black,
        ];
        for (g, e) in got.iter().zip(exp) {
            for (a, b) in g.to_array().iter().zip(e) {
                assert!(
                    (a - b).abs() <= 2e-5 * b.abs() + 1e-8,
                    "eye {eye}: {a} vs {b}"
                );
            }
        }
    }
}
