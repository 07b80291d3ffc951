//! Typed value parsers of the command line's numeric options, and the check of output
//! paths before any work.
//!
//! Every option whose value reaches a tolerance, a size or a time limit is parsed by
//! one of these functions (`#[arg(value_parser = …)]`), so a bad value (NaN, ±inf, a
//! negative number, 0 where 0 means nothing, a size beyond its documented limit) is
//! refused by clap with exit code 2 before anything is opened, measured or solved.
//! clap names the option and the value (`invalid value 'NaN' for '--max-de <MAX_DE>'`);
//! the messages here say what is allowed.
//!
//! The station's own counts (reading budget, verify patches) are parsed by
//! `lumiwall_calib::cli_values`, next to the limits they enforce.

use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::CliError;

/// Longest wall-time limit a command accepts (`render --time`, `bench radiosity
/// --time-limit-s`): 7 days.
pub(crate) const MAX_DURATION: Duration = Duration::from_secs(7 * 24 * 3600);

/// Parses a finite number.
fn finite(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{s} is not a finite number"))
    }
}

/// A finite number greater than 0 (tolerances, lengths, speed factors).
pub(crate) fn positive_finite(s: &str) -> Result<f64, String> {
    let v = finite(s).map_err(|e| format!("{e}; use a finite number greater than 0"))?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{s} must be a finite number greater than 0"))
    }
}

/// A finite number of at least 0 (`0` meaning "automatic" where documented).
pub(crate) fn non_negative_finite(s: &str) -> Result<f64, String> {
    let v = finite(s).map_err(|e| format!("{e}; use a finite number of at least 0"))?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("{s} must be a finite number of at least 0"))
    }
}

/// A finite number in `(0, max]`.
#[cfg_attr(
    not(feature = "station"),
    expect(dead_code, reason = "used by the station commands only")
)]
pub(crate) fn positive_at_most(s: &str, max: f64) -> Result<f64, String> {
    let v = positive_finite(s).map_err(|e| format!("{e} and at most {max}"))?;
    if v <= max {
        Ok(v)
    } else {
        Err(format!("{s} is too large: use a number in (0, {max}]"))
    }
}

/// A whole number in `min..=max`.
pub(crate) fn count_in(s: &str, min: usize, max: usize) -> Result<usize, String> {
    let v: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number; use {min} to {max}"))?;
    if (min..=max).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} is outside the allowed {min} to {max}"))
    }
}

/// A range of seeds, `101-160` or one seed `101`: first at or below last, at most
/// `max` of them.
pub(crate) fn seed_range(s: &str, max: u64) -> Result<std::ops::RangeInclusive<u64>, String> {
    let t = s.trim();
    let seed = |v: &str| {
        v.trim()
            .parse::<u64>()
            .map_err(|_| format!("`{s}` is not a seed range like 101-160 or one seed like 101"))
    };
    let (first, last) = match t.split_once('-') {
        Some((a, b)) => (seed(a)?, seed(b)?),
        None => (seed(t)?, seed(t)?),
    };
    if first > last {
        return Err(format!("seeds {first}-{last}: give the first seed first"));
    }
    if last - first >= max {
        return Err(format!(
            "seeds {first}-{last}: at most {max} seeds at a time"
        ));
    }
    Ok(first..=last)
}

/// A relative error in (0, 100 %): `1%` or `0.01`.
pub(crate) fn fraction(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let v = if let Some(p) = t.strip_suffix('%') {
        p.trim().parse::<f64>().map(|v| v / 100.0)
    } else {
        t.parse::<f64>()
    }
    .map_err(|e| format!("`{s}` is not an error like 1% or 0.01: {e}"))?;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(format!("error {s} must be between 0 and 100 %"))
    }
}

/// A duration such as `250ms`, `60s`, `2m`, `1h` (plain numbers are seconds), greater
/// than 0 and at most [`MAX_DURATION`]; the conversion is checked, never panics.
pub(crate) fn duration(s: &str) -> Result<Duration, String> {
    let t = s.trim();
    let (num, unit_s) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else if let Some(n) = t.strip_suffix('m') {
        (n, 60.0)
    } else if let Some(n) = t.strip_suffix('h') {
        (n, 3600.0)
    } else {
        (t, 1.0)
    };
    let v: f64 = num
        .trim()
        .parse()
        .map_err(|e| format!("`{s}` is not a duration like 60s or 2m: {e}"))?;
    seconds(v * unit_s).map_err(|e| format!("duration {s} {e}"))
}

/// A duration like [`duration`] that may also be zero (`0s`, `0ms`), e.g. a settle
/// time.
#[cfg_attr(
    not(feature = "pattern-server"),
    expect(dead_code, reason = "used by the pattern server's options only")
)]
pub(crate) fn duration_or_zero(s: &str) -> Result<Duration, String> {
    let zero = s.trim().trim_end_matches(['m', 's', 'h']).trim();
    if zero.parse::<f64>().is_ok_and(|v| v == 0.0) {
        return Ok(Duration::ZERO);
    }
    duration(s)
}

/// `secs` seconds as a duration in (0, [`MAX_DURATION`]].
pub(crate) fn seconds(secs: f64) -> Result<Duration, String> {
    let max = MAX_DURATION.as_secs();
    let allowed = format!("must be greater than 0 and at most {} days", max / 86_400);
    if !(secs.is_finite() && secs > 0.0) {
        return Err(allowed);
    }
    match Duration::try_from_secs_f64(secs) {
        Ok(d) if !d.is_zero() && d <= MAX_DURATION => Ok(d),
        _ => Err(allowed),
    }
}

/// A duration in seconds (`bench radiosity --time-limit-s 300`), see [`seconds`].
pub(crate) fn duration_s(s: &str) -> Result<Duration, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    seconds(v).map_err(|e| format!("{s} s {e}"))
}

/// Whether `p` names a folder rather than a file: it ends with a path separator, `.`
/// or `..`, or is an existing folder.
fn names_a_folder(p: &Path) -> bool {
    let s = p.as_os_str().to_string_lossy();
    s.ends_with(std::path::MAIN_SEPARATOR)
        || s.ends_with('/')
        || matches!(
            p.components().next_back(),
            None | Some(std::path::Component::CurDir | std::path::Component::ParentDir)
        )
        || p.is_dir()
}

/// The folder a file `p` is written into.
fn parent_of(p: &Path) -> PathBuf {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A probe file name no other check running at the same time uses: the process
/// id alone is not enough, since the station app and the tests run several
/// commands at once in one process.
fn probe_name() -> String {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!(".lumiwall-write-test-{}-{n}", std::process::id())
}

/// Checks that files can be created in the existing folder `dir` by creating and
/// removing a probe file there.
fn check_writable_dir(dir: &Path, option: &str, what: &Path) -> Result<(), CliError> {
    if !dir.is_dir() {
        return Err(CliError::input(format!(
            "{option} {}: the folder {} does not exist; create it first or choose another {option}",
            what.display(),
            dir.display()
        )));
    }
    let probe = dir.join(probe_name());
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(f) => {
            drop(f);
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(CliError::input(format!(
            "{option} {}: cannot write in the folder {} ({e}); choose a writable {option}",
            what.display(),
            dir.display()
        ))),
    }
}

/// Checks, before any work, that the files `paths` (the file `option` names and its
/// siblings) can be written: each names a file, not a folder, and its folder exists
/// and is writable.
pub(crate) fn check_output_files(option: &str, paths: &[&Path]) -> Result<(), CliError> {
    for p in paths {
        if names_a_folder(p) {
            return Err(CliError::input(format!(
                "{option} {} is a folder; give a file name such as {}",
                p.display(),
                p.join("frame.exr").display()
            )));
        }
    }
    let mut checked: Vec<PathBuf> = Vec::new();
    for p in paths {
        let dir = parent_of(p);
        if !checked.contains(&dir) {
            check_writable_dir(&dir, option, p)?;
            checked.push(dir);
        }
    }
    Ok(())
}

/// Checks, before any work, that the output folder `dir` of `option` can be written:
/// it is an existing writable folder, or it does not exist yet and its nearest existing
/// ancestor is a writable folder (the command creates it).
#[cfg_attr(
    not(feature = "station"),
    expect(dead_code, reason = "used by the station commands only")
)]
pub(crate) fn check_output_dir(option: &str, dir: &Path) -> Result<(), CliError> {
    if dir.exists() && !dir.is_dir() {
        return Err(CliError::input(format!(
            "{option} {} is a file, not a folder; choose a folder",
            dir.display()
        )));
    }
    let mut existing = dir.to_path_buf();
    while !existing.exists() {
        existing = match existing.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
    }
    if !existing.is_dir() {
        return Err(CliError::input(format!(
            "{option} {}: {} is a file, not a folder; choose another {option}",
            dir.display(),
            existing.display()
        )));
    }
    check_writable_dir(&existing, option, dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_ranges_are_first_to_last_within_the_limit() {
        assert_eq!(seed_range("101-160", 10_000), Ok(101..=160));
        assert_eq!(seed_range(" 7 ", 10_000), Ok(7..=7));
        assert!(seed_range("160-101", 10_000).is_err());
        // 10 000 seeds are allowed, 10 001 are not.
        assert_eq!(seed_range("1-10000", 10_000), Ok(1..=10_000));
        assert!(seed_range("1-10001", 10_000).is_err());
        for bad in [
            "",
            "-",
            "a-b",
            "1-",
            "-5",
            "1.5",
            "1-2-3",
            "18446744073709551616",
        ] {
            assert!(seed_range(bad, 10_000).is_err(), "{bad}");
        }
    }

    #[test]
    fn floats_refuse_nan_inf_and_out_of_range() {
        assert_eq!(positive_finite("1.5"), Ok(1.5));
        for bad in ["NaN", "nan", "inf", "-inf", "0", "-1", "x", ""] {
            assert!(positive_finite(bad).is_err(), "{bad}");
        }
        assert_eq!(non_negative_finite("0"), Ok(0.0));
        assert!(non_negative_finite("-0.1").is_err());
        assert!(non_negative_finite("NaN").is_err());
        assert_eq!(positive_at_most("10", 10.0), Ok(10.0));
        assert!(positive_at_most("10.5", 10.0).is_err());
    }

    #[test]
    fn counts_and_fractions_stay_in_their_range() {
        assert_eq!(count_in("5", 1, 10), Ok(5));
        for bad in ["0", "11", "-1", "1.5", "4000000000000000000000"] {
            assert!(count_in(bad, 1, 10).is_err(), "{bad}");
        }
        assert_eq!(fraction("1%"), Ok(0.01));
        assert_eq!(fraction("0.5"), Ok(0.5));
        for bad in ["NaN", "0", "100%", "-1%", "inf"] {
            assert!(fraction(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn durations_are_checked_and_bounded_to_a_week() {
        assert_eq!(duration("250ms"), Ok(Duration::from_millis(250)));
        assert_eq!(duration("2m"), Ok(Duration::from_secs(120)));
        assert_eq!(duration("168h"), Ok(MAX_DURATION));
        for bad in ["1e30h", "169h", "inf", "NaN", "0s", "-1s", "1e-12s", "soon"] {
            assert!(duration(bad).is_err(), "{bad}");
        }
        assert!(duration_s("1e300").is_err());
        assert_eq!(duration_s("0.5"), Ok(Duration::from_millis(500)));
    }

    #[test]
    fn output_paths_must_be_files_in_writable_folders() {
        let tmp = tempfile::tempdir().unwrap();
        let ok = tmp.path().join("a.exr");
        assert!(check_output_files("--out", &[&ok]).is_ok());
        let dir_slash = PathBuf::from(format!("{}/", tmp.path().display()));
        assert!(check_output_files("--out", &[&dir_slash]).is_err());
        assert!(check_output_files("--out", &[tmp.path()]).is_err());
        let missing = tmp.path().join("no/a.exr");
        let e = check_output_files("--out", &[&missing]).unwrap_err();
        assert!(e.message.contains("does not exist"), "{}", e.message);
        assert!(check_output_dir("--out", &tmp.path().join("x/y")).is_ok());
        assert!(check_output_dir("--out", &ok).is_ok());
        std::fs::write(&ok, b"").unwrap();
        assert!(check_output_dir("--out", &ok).is_err());
        assert!(check_output_dir("--out", &ok.join("sub")).is_err());
    }

    #[test]
    fn writability_checks_of_one_folder_from_many_threads_at_once_all_pass() {
        let tmp = tempfile::tempdir().unwrap();
        let file = tmp.path().join("a.json");
        let failures: usize = std::thread::scope(|s| {
            let workers: Vec<_> = (0..8)
                .map(|_| {
                    s.spawn(|| {
                        (0..200)
                            .filter(|_| check_output_files("--out", &[&file]).is_err())
                            .count()
                    })
                })
                .collect();
            workers.into_iter().map(|w| w.join().unwrap()).sum()
        });
        assert_eq!(failures, 0, "checks refused a writable folder");
        let left = std::fs::read_dir(tmp.path()).unwrap().count();
        assert_eq!(left, 0, "probe files were left behind");
    }
}
