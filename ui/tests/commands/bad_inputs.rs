//! Bad inputs that used to get through (issue 9): each is refused with exit code 2
//! before any work, with a message that names the option and the value and says what
//! is allowed, and nothing is written.

use std::path::{Path, PathBuf};

use predicates::prelude::*;
use predicates::str::contains;
use tempfile::TempDir;

use crate::common::*;

/// The entries of `dir` (empty when it does not exist).
fn entries(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .map(|d| d.map(|e| e.unwrap().path()).collect())
        .unwrap_or_default()
}

/// `verify` of the small wall's `profiles` with `args` must fail with exit 2, naming
/// `option` and `allowed`. The profiles are not needed to exist: options are refused
/// before anything is read.
fn verify_refuses(profiles: &Path, args: &[&str], option: &str, allowed: &str) {
    lumiwall()
        .args(["verify", "--meter", "direct", "--noise", "none", "--wall"])
        .arg(small_wall())
        .arg("--profiles")
        .arg(profiles)
        .args(args)
        .assert()
        .code(2)
        .stdout(contains("PASS").not())
        .stderr(contains(option))
        .stderr(contains(args[1]))
        .stderr(contains(allowed));
}

#[test]
fn verify_refuses_tolerances_that_would_switch_the_check_off() {
    let tmp = TempDir::new().unwrap();
    let profiles = tmp.path().join("p");
    for v in ["NaN", "inf", "-1", "0"] {
        verify_refuses(
            &profiles,
            &["--max-de", v],
            "--max-de",
            "finite number greater than 0",
        );
    }
    for opt in ["--median-de", "--black-dl", "--black-dxy"] {
        verify_refuses(&profiles, &[opt, "NaN"], opt, "finite number");
    }
    verify_refuses(
        &profiles,
        &["--time-scale", "1e300"],
        "--time-scale",
        "(0, 10]",
    );
}

#[test]
fn verify_refuses_zero_and_huge_patch_counts() {
    let tmp = TempDir::new().unwrap();
    let profiles = tmp.path().join("p");
    verify_refuses(
        &profiles,
        &["--patches", "0"],
        "--patches",
        "use 1 to 100000",
    );
    verify_refuses(
        &profiles,
        &["--patches", "4000000000"],
        "--patches",
        "use 1 to 100000",
    );
}

#[test]
fn verify_with_real_profiles_still_refuses_nan() {
    // With profiles that would pass, NaN must not print PASS.
    let tmp = TempDir::new().unwrap();
    let profiles = commission_small_wall(tmp.path());
    verify_refuses(&profiles, &["--max-de", "NaN"], "--max-de", "finite");
}

#[test]
fn profiles_drift_refuses_nan_and_negative_limits() {
    let tmp = TempDir::new().unwrap();
    for opt in ["--max-delta-xy", "--max-luminance-change-pct"] {
        for v in ["NaN", "-0.01", "inf"] {
            lumiwall()
                .args(["profiles", "drift", "--wall", "w", "--store"])
                .arg(tmp.path().join("s.lumistore"))
                .args([opt, v])
                .assert()
                .code(2)
                .stderr(contains(opt))
                .stderr(contains(v))
                .stderr(contains("finite number greater than 0"));
        }
    }
}

#[test]
fn render_refuses_huge_durations_and_bad_sizes_before_solving() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("frame.exr");
    let refuses = |args: &[&str], allowed: &str| {
        let mut cmd = lumiwall();
        cmd.arg("render")
            .args(args)
            .arg("--out")
            .arg(&out)
            .arg(cornell());
        assert_refused(&mut cmd, args[0], allowed);
    };
    refuses(&["--time", "1e30h"], "at most 7 days");
    refuses(&["--time", "169h"], "at most 7 days");
    refuses(&["--time", "0s"], "greater than 0");
    refuses(&["--time", "NaNs"], "greater than 0");
    for v in ["NaN", "0", "0%", "-0.5", "100%", "inf"] {
        refuses(&["--error", v], "between 0 and 100 %");
    }
    refuses(&["--max-edge-m", "NaN"], "greater than 0");
    refuses(&["--max-edge-m", "-1"], "greater than 0");
    refuses(&["--min-area-m2", "-1"], "at least 0");
    assert!(entries(tmp.path()).is_empty(), "{:?}", entries(tmp.path()));
}

#[test]
fn render_checks_every_output_path_before_the_solve() {
    let tmp = TempDir::new().unwrap();
    let render = |out: &Path| {
        let mut c = lumiwall();
        // A solve that would take long: refused before it starts.
        c.args(["render", "--error", "0.1%", "--out"])
            .arg(out)
            .arg(cornell());
        c
    };
    // A missing folder.
    render(&tmp.path().join("no-such-dir/frame.exr"))
        .assert()
        .code(2)
        .stderr(contains("--out"))
        .stderr(contains("does not exist"))
        .stdout(contains("est_error").not());
    // A folder, with and without a trailing separator (the siblings would land next
    // to it).
    let dir = tmp.path().join("renders");
    std::fs::create_dir(&dir).unwrap();
    let slash = PathBuf::from(format!("{}/", dir.display()));
    for out in [&slash, &dir] {
        render(out)
            .assert()
            .code(2)
            .stderr(contains("is a folder; give a file name"));
    }
    assert!(entries(&dir).is_empty());
    assert_eq!(entries(tmp.path()), vec![dir.clone()]);
}

#[cfg(unix)]
#[test]
fn render_refuses_a_read_only_folder_before_the_solve() {
    use std::os::unix::fs::PermissionsExt;
    let tmp = TempDir::new().unwrap();
    let ro = tmp.path().join("ro");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    // Root writes anywhere: nothing to check then.
    let probe = ro.join("probe");
    if std::fs::write(&probe, b"").is_ok() {
        let _ = std::fs::remove_file(&probe);
        return;
    }
    lumiwall()
        .args(["render", "--error", "0.1%", "--out"])
        .arg(ro.join("frame.exr"))
        .arg(cornell())
        .assert()
        .code(2)
        .stderr(contains("cannot write in the folder"))
        .stdout(contains("est_error").not());
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
    assert!(entries(&ro).is_empty());
}

#[test]
fn commission_refuses_a_too_small_budget_without_suggesting_resume() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("p");
    for budget in ["0", "10"] {
        commission_small(&out, &["--budget", budget])
            .assert()
            .code(2)
            .stderr(contains("--budget"))
            .stderr(contains("at least 11"))
            .stderr(contains("raise --budget"))
            .stderr(contains("--resume").not());
    }
    commission_small(&out, &["--budget", "4000000000"])
        .assert()
        .code(2)
        .stderr(contains("10000"));
    assert!(!out.exists());
}

#[test]
fn commission_refuses_an_out_that_is_a_file_before_measuring() {
    let tmp = TempDir::new().unwrap();
    let file = tmp.path().join("f");
    std::fs::write(&file, b"keep").unwrap();
    for out in [file.clone(), file.join("sub")] {
        commission_small(&out, &[])
            .assert()
            .code(2)
            .stderr(contains("--out"))
            .stderr(contains("is a file, not a folder"))
            .stdout(contains("commissioning").not());
    }
    assert_eq!(std::fs::read(&file).unwrap(), b"keep");
}

#[test]
fn bench_options_are_bounded() {
    let tmp = TempDir::new().unwrap();
    lumiwall()
        .args(["bench", "readings", "--budgets", "16,5", "--out"])
        .arg(tmp.path().join("b"))
        .assert()
        .code(2)
        .stderr(contains("--budgets"))
        .stderr(contains("raise --budget"));
    lumiwall()
        .args(["bench", "readings", "--patches", "0"])
        .assert()
        .code(2)
        .stderr(contains("--patches"));
    let radiosity = |args: &[&str], allowed: &str| {
        let mut cmd = lumiwall();
        cmd.args(["bench", "radiosity"]).args(args);
        assert_refused(&mut cmd, args[0], allowed);
    };
    radiosity(&["--time-limit-s", "1e300"], "at most 7 days");
    radiosity(&["--time-limit-s", "-1"], "greater than 0");
    radiosity(&["--reference-edge-m", "NaN"], "greater than 0");
    radiosity(&["--scale-error", "NaN"], "between 0 and 100 %");
    radiosity(&["--sizes", "0"], "1 to 10000000");
    radiosity(&["--lights", "0"], "1 to 100000");
    radiosity(&["--check-paths", "0"], "1 to 10000000");
    radiosity(&["--check-patches", "1000000"], "0 to 100000");
    radiosity(
        &["--plot", tmp.path().join("none/p.png").to_str().unwrap()],
        "does not exist",
    );
    assert!(!tmp.path().join("b").exists());
}

#[test]
fn profiles_import_checks_the_store_folder_first() {
    let tmp = TempDir::new().unwrap();
    lumiwall()
        .args(["profiles", "import", "--dir"])
        .arg(tmp.path())
        .arg("--store")
        .arg(tmp.path().join("none/s.lumistore"))
        .assert()
        .code(2)
        .stderr(contains("--store"))
        .stderr(contains("does not exist"));
}
