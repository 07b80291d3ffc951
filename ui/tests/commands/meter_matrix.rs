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
    let succeed = |cmd: &mut assert_cmd::Command| {
        let out = cmd.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
    };
    succeed(
        lumiwall()
            .args(["meter-matrix", "--meter", "direct", "--wall"])
            .arg(&wall)
            .arg("--out")
            .arg(&mm),
    );
    succeed(
        lumiwall()
            .args([
                "commission",
                "--meter",
                "direct",
                "--budget",
                "64",
                "--wall",
            ])
            .arg(&wall)
            .arg("--meter-matrix")
            .arg(&mm)
            .arg("--out")
            .arg(&profiles),
    );
    assert!(profiles.join("meter-matrix.json").exists());
    let verify = |extra: &[&std::ffi::OsStr]| {
        lumiwall()
            .args([
                "verify", "--meter", "direct", "--noise", "none", "--chart", "51",
            ])
            .args(["--max-de", "3", "--median-de", "1", "--mean-de", "1"])
            .args(["--white-de", "1.5", "--grey-balance", "1", "--wall"])
            .arg(&wall)
            .arg("--profiles")
            .arg(&profiles)
            .args(extra)
            .output()
            .unwrap()
    };
    let out = verify(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("meter-matrix.json not applied"), "{stderr}");
    assert!(
        out.status.success(),
        "{}\n{stderr}",
        String::from_utf8_lossy(&out.stdout)
    );
    let out = verify(&["--meter-matrix".as_ref(), mm.as_os_str()]);
    assert_eq!(out.status.code(), Some(2), "refused as a bad input");
    assert!(String::from_utf8_lossy(&out.stderr).contains("leave out --meter-matrix"));
}
