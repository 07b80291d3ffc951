//! The report's spectral locus against published CIE 1931 chromaticities (CIE 015,
//! Table of the 2° observer: 520 nm x 0.0743 y 0.8338; 700 nm x 0.7347 y 0.2653;
//! 450 nm x 0.1566 y 0.0177).

use lumiwall_calib::report::cie1931_locus;

#[test]
fn locus_matches_published_chromaticities() {
    let locus = cie1931_locus();
    assert_eq!(locus.len(), 321, "380..=700 nm in 1 nm steps");
    for (nm, x, y) in [
        (520.0, 0.0743, 0.8338),
        (700.0, 0.7347, 0.2653),
        (450.0, 0.1566, 0.0177),
    ] {
        let p = locus.iter().find(|(w, _)| *w == nm).expect("wavelength").1;
        assert!(
            (p[0] - x).abs() < 2e-4 && (p[1] - y).abs() < 2e-4,
            "{nm}: {p:?}"
        );
    }
}
