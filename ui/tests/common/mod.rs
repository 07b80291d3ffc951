//! What the command-line tests share: the fixtures, the binary, the small wall's
//! commissioning, and the check of a refused option.
#![allow(
    dead_code,
    reason = "each command-line test binary uses only part of the shared helpers"
)]

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use predicates::str::contains;

/// A file or folder of the repository's fixtures.
pub(crate) fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures")
        .join(rel)
}

/// The smallest wall: two mono projectors.
pub(crate) fn small_wall() -> PathBuf {
    fixture("walls/mono-2x1.toml")
}

/// The Cornell box scene.
pub(crate) fn cornell() -> PathBuf {
    fixture("scenes/cornell/cornell.toml")
}

/// The `lumiwall` binary of this build.
pub(crate) fn lumiwall() -> Command {
    Command::cargo_bin("lumiwall").unwrap()
}

/// `lumiwall commission` of the small wall into `out` with the direct meter and the
/// options `extra`.
pub(crate) fn commission_small(out: &Path, extra: &[&str]) -> Command {
    let mut cmd = lumiwall();
    cmd.args(["commission", "--meter", "direct"])
        .args(extra)
        .arg("--wall")
        .arg(small_wall())
        .arg("--out")
        .arg(out);
    cmd
}

/// `lumiwall recalibrate` of `wall` with the exact, direct meter on the profiles in
/// `profiles`, with `extra` arguments.
pub(crate) fn recalibrate_noiseless(wall: &Path, profiles: &Path, extra: &[&str]) -> Command {
    let mut cmd = lumiwall();
    cmd.args(["recalibrate", "--meter", "direct", "--noise", "none"])
        .args(extra)
        .arg("--wall")
        .arg(wall)
        .arg("--profiles")
        .arg(profiles);
    cmd
}

/// Commissions the small wall with the exact, direct meter into `dir/profiles`.
pub(crate) fn commission_small_wall(dir: &Path) -> PathBuf {
    let out = dir.join("profiles");
    commission_small(&out, &["--noise", "none"])
        .assert()
        .success()
        .stdout(contains("commissioning mono-2x1: 2 displays"))
        .stdout(contains("profiles: "));
    out
}

/// `cmd` must be refused as a usage error (exit 2) naming `option` and what is `allowed`.
pub(crate) fn assert_refused(cmd: &mut Command, option: &str, allowed: &str) {
    cmd.assert()
        .code(2)
        .stderr(contains(option.to_string()))
        .stderr(contains(allowed.to_string()));
}

/// Chromaticity distance Δxy of two XYZ.
pub(crate) fn xy_distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    let xy = |v: [f64; 3]| {
        let s = v[0] + v[1] + v[2];
        [v[0] / s, v[1] / s]
    };
    let (a, b) = (xy(a), xy(b));
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// `lumiwall export --format FORMAT --commission DIR --out-dir OUT`.
pub(crate) fn export(format: &str, commission: &Path, out_dir: &Path) -> Command {
    let mut cmd = lumiwall();
    cmd.args(["export", "--format", format, "--commission"])
        .arg(commission)
        .arg("--out-dir")
        .arg(out_dir);
    cmd
}
