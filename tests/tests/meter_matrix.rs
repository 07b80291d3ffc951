//! Issue 12 item 6: the station meter's systematic error is a filter colorimeter's
//! (spectrum-dependent, additive), and a correction matrix per eye made against a
//! reference spectroradiometer brings its readings to the simulator's truth (the CIE
//! observer) on colours it was not fitted to.
//!
//! `cargo test -p lumiwall-tests --test meter_matrix -- --nocapture` prints the figures.

mod support;

use lumiwall_calib::measure::meter_matrix;
use lumiwall_calib::station::Noise;
use lumiwall_devices::{DisplayId, Xyz};

/// Colours the matrices were not fitted to: greys, secondaries, a skin tone.
const CHECK: [[f64; 3]; 6] = [
    [0.5, 0.5, 0.5],
    [0.8, 0.8, 0.8],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.9, 0.6, 0.45],
];

/// Mean of `n` readings of `drive` on display `id` at its centre.
fn read(station: &mut lumiwall_calib::station::Station, id: DisplayId, drive: [f64; 3]) -> Xyz {
    let n = 8;
    station.pattern.show(id, drive).expect("show");
    station.positioner.aim(id, [0.5, 0.5]).expect("aim");
    let mut sum = Xyz::default();
    for _ in 0..n {
        sum = sum + station.meter.measure().expect("reading");
    }
    sum * (1.0 / f64::from(n))
}

fn dxy(a: Xyz, b: Xyz) -> f64 {
    let (a, b) = (a.xy().expect("light"), b.xy().expect("light"));
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[test]
fn a_meter_matrix_per_eye_brings_the_colorimeter_to_the_truth_on_colours_it_was_not_fitted_to() {
    let mut station = support::direct_station("infitec-pair.toml", Noise::Realistic);
    let matrices = station
        .meter_matrices(2000, [0.5, 0.5], false)
        .expect("matrices");
    assert_eq!(matrices.matrices.len(), 2, "one per eye");
    let (mut raw_sum, mut corrected_sum, mut n) = (0.0, 0.0, 0.0);
    let mut worst_corrected: f64 = 0.0;
    for d in station.displays() {
        let m = matrices
            .for_display(d.id.0, d.eye)
            .expect("a matrix for the eye");
        for drive in CHECK {
            let truth = station
                .wall
                .emitted_xyz(d.id, drive, [0.5, 0.5])
                .expect("truth");
            let raw = read(&mut station, d.id, drive);
            let corrected = meter_matrix::apply(&m, raw);
            let (e_raw, e_cor) = (dxy(raw, truth), dxy(corrected, truth));
            eprintln!(
                "{} {drive:?}: Δxy as read {e_raw:.4}, corrected {e_cor:.4}, ΔY corrected {:+.2} %",
                d.name,
                100.0 * (corrected.y / truth.y - 1.0)
            );
            raw_sum += e_raw;
            corrected_sum += e_cor;
            worst_corrected = worst_corrected.max(e_cor);
            n += 1.0;
        }
    }
    let (raw_mean, corrected_mean) = (raw_sum / n, corrected_sum / n);
    eprintln!("mean Δxy as read {raw_mean:.4}, corrected {corrected_mean:.4}");
    assert!(
        corrected_mean < 0.5 * raw_mean && corrected_mean < 0.0015,
        "as read {raw_mean:.4}, corrected {corrected_mean:.4}"
    );
    assert!(
        worst_corrected < 0.004,
        "worst corrected {worst_corrected:.4}"
    );
}

/// On the Infitec primaries the correction brings the colorimeter to its reference's
/// own accuracy, no further: the reference (a CS-2000 with up to 0.3 nm wavelength
/// error) is itself up to 0.004 off on the narrow-band green, and what the matrix
/// leaves tracks it (measured on dlp-infitec-2x1 with references 1, 7, 2000: green
/// corrected 0.0044/0.0013/0.0025 vs the reference's own 0.0037/0.0016/0.0026).
#[test]
fn on_infitec_primaries_the_corrected_colorimeter_is_as_close_to_the_truth_as_its_reference() {
    let mut station = support::direct_station("dlp-infitec-2x1.toml", Noise::Realistic);
    let matrices = station
        .meter_matrices(2000, [0.5, 0.5], false)
        .expect("matrices");
    let errors = station
        .meter_matrix_xy_errors(&matrices, 2000, [0.5, 0.5])
        .expect("errors");
    assert_eq!(errors.len(), 4 * station.displays().len());
    for e in &errors {
        eprintln!(
            "{} {}: Δxy meter {:.4}, corrected {:.4}, reference {:.4}",
            e.display, e.patch, e.meter, e.corrected, e.reference
        );
        // noise (8 readings each), the fit's residual, and the display-to-display
        // difference of the Infitec combs (measured: +0.0010 on the white of the display
        // the matrix was not fitted on; `--per-display` removes it)
        assert!(
            e.corrected <= e.reference + 0.0015,
            "{} {}: corrected {:.4} vs the reference's own {:.4}",
            e.display,
            e.patch,
            e.corrected,
            e.reference
        );
    }
    let green = |f: fn(&meter_matrix::PatchXyError) -> f64| {
        errors
            .iter()
            .filter(|e| e.patch == "green")
            .map(f)
            .fold(0.0, f64::max)
    };
    assert!(
        green(|e| e.meter) > 0.01,
        "the filter mismatch shows on green"
    );
    assert!(green(|e| e.corrected) < green(|e| e.meter) / 4.0);
    assert!(
        green(|e| e.corrected) <= green(|e| e.reference) + 0.0005,
        "on the green the correction should reach the reference's accuracy"
    );
}

/// Matrices belong to one instrument (serial included), and a run whose readings were
/// corrected with matrices is not resumed without them (that would mix corrected and
/// raw readings in one solve).
#[test]
fn matrices_of_another_instrument_and_a_resume_without_them_are_refused() {
    use lumiwall_calib::commission::CommissionError;
    use lumiwall_calib::measure::MeasureOptions;
    use lumiwall_calib::measure::meter_matrix::MeterMatrixError;
    use lumiwall_profiles::BlackMode;

    let mut station = support::direct_station("infitec-pair.toml", Noise::Realistic);
    let matrices = station
        .meter_matrices(2000, [0.5, 0.5], false)
        .expect("matrices");
    matrices
        .check_instrument(station.meter.as_ref())
        .expect("made with this meter");
    let other = meter_matrix::MeterMatrices {
        instrument: format!("{}-other", matrices.instrument),
        ..matrices.clone()
    };
    assert!(matches!(
        other.check_instrument(station.meter.as_ref()),
        Err(MeterMatrixError::OtherInstrument { .. })
    ));

    let out = tempfile::tempdir().expect("tmp");
    let with = MeasureOptions {
        meter_matrix: Some(matrices),
        ..MeasureOptions::default()
    };
    station
        .commission(
            out.path(),
            &support::options_8500k(with, BlackMode::Individual, false),
            &mut |_| {},
        )
        .expect("commission with matrices");
    let err = station
        .commission(
            out.path(),
            &support::options_8500k(MeasureOptions::default(), BlackMode::Individual, true),
            &mut |_| {},
        )
        .expect_err("a resume without the matrices");
    assert!(
        matches!(err, CommissionError::ResumeMismatch { .. }),
        "{err}"
    );
}
