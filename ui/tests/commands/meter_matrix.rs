//! `lumiwall meter-matrix`: the reference's wavelength check as the command prints it.

use tempfile::TempDir;

use crate::common::*;

/// `meter-matrix`'s stdout for the simulated CS-2000 with serial number `seed` on the
/// Infitec DLP wall, with `extra` options.
fn meter_matrix_stdout(seed: &str, extra: &[&str]) -> String {
    let tmp = TempDir::new().unwrap();
    let out = lumiwall()
        .args(["meter-matrix", "--wall"])
        .arg(fixture("walls/dlp-infitec-2x1.toml"))
        .arg("--out")
        .arg(tmp.path().join("mm.json"))
        .args(["--per-display", "--reference-seed", seed])
        .args(extra)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// The number after `key` in `line` (e.g. "offset +0.268 nm").
fn number_after(line: &str, key: &str) -> f64 {
    let rest = &line[line.find(key).expect(key) + key.len()..];
    rest.split_whitespace()
        .next()
        .unwrap()
        .trim_end_matches(',')
        .parse()
        .unwrap()
}

/// The largest corrected Δxy of the primaries in the printed table.
fn worst_corrected_primary(stdout: &str) -> f64 {
    stdout
        .lines()
        .filter(|l| {
            ["red", "green", "blue"]
                .iter()
                .any(|p| l.contains(&format!(" {p} ")))
        })
        .map(|l| l.split_whitespace().nth(3).unwrap().parse::<f64>().unwrap())
        .fold(0.0, f64::max)
}

#[test]
fn meter_matrix_checks_the_references_wavelengths_first_and_brings_every_infitec_primary_within_0_002()
 {
    let checked = meter_matrix_stdout("1", &[]);
    let line = checked
        .lines()
        .find(|l| l.starts_with("wavelength check (Hg-Ar pen lamp"))
        .unwrap_or_else(|| panic!("{checked}"));
    let (found, truth) = (
        number_after(line, "offset "),
        number_after(line, "true offset: "),
    );
    assert!((found - truth).abs() < 0.01 && truth.abs() > 0.1, "{line}");
    let unchecked = meter_matrix_stdout("1", &["--wavelength-check", "none"]);
    assert!(!unchecked.contains("wavelength check"));
    let (after, before) = (
        worst_corrected_primary(&checked),
        worst_corrected_primary(&unchecked),
    );
    assert!(
        after <= 0.002 && before > 0.002,
        "{after} vs {before}\n{checked}"
    );
}

/// The truth is not corrected: after a commissioning with the realistic meter and its
/// meter matrices, `verify --noise none` leaves the matrices kept in the profile folder
/// out (and says so), and an explicit `--meter-matrix` with `--noise none` is refused.
/// Applying them moved the exact readings of dlp-infitec-2x1's right eye by ΔE2000 3.
#[test]
fn verify_against_the_truth_leaves_the_commissioning_meters_matrices_out() {
    let tmp = TempDir::new().unwrap();
    let wall = fixture("walls/dlp-infitec-2x1.toml");
    let mm = tmp.path().join("mm.json");
    let profiles = tmp.path().join("profiles");
    let run = |args: &[&std::ffi::OsStr]| lumiwall().args(args).output().unwrap();
    let os = |s: &'static str| std::ffi::OsStr::new(s);
    let out = run(&[
        os("meter-matrix"),
        os("--wall"),
        wall.as_os_str(),
        os("--meter"),
        os("direct"),
        os("--out"),
        mm.as_os_str(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = run(&[
        os("commission"),
        os("--wall"),
        wall.as_os_str(),
        os("--meter"),
        os("direct"),
        os("--meter-matrix"),
        mm.as_os_str(),
        os("--budget"),
        os("64"),
        os("--out"),
        profiles.as_os_str(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(profiles.join("meter-matrix.json").exists());
    let verify = |extra: &[&std::ffi::OsStr]| {
        let mut args = vec![
            os("verify"),
            os("--wall"),
            wall.as_os_str(),
            os("--meter"),
            os("direct"),
            os("--noise"),
            os("none"),
            os("--profiles"),
            profiles.as_os_str(),
            os("--chart"),
            os("51"),
            os("--max-de"),
            os("3"),
            os("--median-de"),
            os("1"),
            os("--mean-de"),
            os("1"),
            os("--white-de"),
            os("1.5"),
            os("--grey-balance"),
            os("1"),
        ];
        args.extend_from_slice(extra);
        run(&args)
    };
    let out = verify(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("meter-matrix.json not applied"), "{stderr}");
    assert!(
        out.status.success(),
        "{}\n{stderr}",
        String::from_utf8_lossy(&out.stdout)
    );
    let out = verify(&[os("--meter-matrix"), mm.as_os_str()]);
    assert_eq!(out.status.code(), Some(2), "refused as a bad input");
    assert!(String::from_utf8_lossy(&out.stderr).contains("leave out --meter-matrix"));
}
