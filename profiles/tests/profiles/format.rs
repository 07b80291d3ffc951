//! The profile file format: JSON round trip, version refusal, LUT validation,
//! atomic save and the `wall.json` manifest of a `ProfileSet`.

use std::path::{Path, PathBuf};

use crate::common::{power_curve, profile};
use lumiwall_profiles::{
    BlackMode, DisplayModel, DisplayProfile, Eye, FORMAT_VERSION, FlatField, MIN_LUT_ENTRIES,
    OutOfGamut, ProfileError, ProfileSet, ToneCurve,
};
use proptest::prelude::*;

fn json_with_version(p: &DisplayProfile, version: u64) -> String {
    let mut v: serde_json::Value = serde_json::from_str(&p.to_json()).unwrap();
    v["format_version"] = serde_json::json!(version);
    serde_json::to_string(&v).unwrap()
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn hand_built_profile_is_valid_and_round_trips_through_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = profile("hall-a", 7);
    p.validate().unwrap();
    let path = dir.path().join("p.json");
    p.save(&path).unwrap();
    assert_eq!(DisplayProfile::load(&path).unwrap(), p);
}

#[test]
fn the_json_document_has_the_documented_field_names() {
    // FORMAT.md documents these names; a rename is a format change.
    let v: serde_json::Value = serde_json::from_str(&profile("w", 1).to_json()).unwrap();
    let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    for k in [
        "format_version",
        "display",
        "created_utc",
        "primaries_xyz_cd_m2",
        "black_xyz_cd_m2",
        "display_model",
        "black_mode",
        "shown_black_xyz_cd_m2",
        "target_white_xyz_cd_m2",
        "common_primaries_xy",
        "xyz_to_drive",
        "drive_offset",
        "channel_usage",
        "headroom",
        "curves",
        "flat_field",
        "out_of_gamut",
        "bit_depth",
        "measurement",
    ] {
        assert!(keys.contains(&k), "missing {k} in {keys:?}");
        let format_md = include_str!("../../FORMAT.md");
        assert!(
            format_md.contains(&format!("`{k}`")) || format_md.contains(&format!("`{k}.")),
            "{k} is not documented in FORMAT.md"
        );
    }
    assert_eq!(keys.len(), 19, "undocumented field in {keys:?}");
    assert_eq!(v["display_model"]["kind"], "additive");
    assert_eq!(v["display"]["eye"], "mono");
    assert_eq!(v["black_mode"], "individual");
    assert_eq!(v["out_of_gamut"], "clip");
    assert_eq!(v["format_version"], FORMAT_VERSION);
}

#[test]
fn other_format_version_is_refused_with_found_and_expected() {
    let p = profile("hall-a", 0);
    for found in [0u64, u64::from(FORMAT_VERSION) + 1, 99] {
        let text = json_with_version(&p, found);
        match DisplayProfile::from_json(&text, Path::new("x.json")) {
            Err(ProfileError::Version {
                found: f,
                expected,
                path,
            }) => {
                assert_eq!(u64::from(f), found);
                assert_eq!(expected, FORMAT_VERSION);
                assert_eq!(path, Path::new("x.json"));
            }
            other => panic!("version {found}: expected Version error, got {other:?}"),
        }
    }
    // And from a file on disk, naming the file.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("old.json");
    std::fs::write(&path, json_with_version(&p, 7)).unwrap();
    let err = DisplayProfile::load(&path).unwrap_err();
    let msg = err.to_string();
    assert!(
        matches!(
            err,
            ProfileError::Version {
                found: 7,
                expected: FORMAT_VERSION,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        msg.contains("old.json") && msg.contains('7') && msg.contains(&FORMAT_VERSION.to_string()),
        "{msg}"
    );
}

#[test]
fn a_version_1_profile_is_read_as_an_additive_version_2_profile() {
    let p = profile("hall-a", 3);
    let mut v: serde_json::Value = serde_json::from_str(&json_with_version(&p, 1)).unwrap();
    v.as_object_mut().unwrap().remove("display_model");
    let read = DisplayProfile::from_json(&v.to_string(), Path::new("v1.json")).unwrap();
    assert_eq!(read.format_version, FORMAT_VERSION);
    assert_eq!(read.display_model, DisplayModel::Additive);
    assert_eq!(read, p);
}

#[test]
fn a_white_segment_profile_round_trips_and_an_uninvertible_one_is_refused() {
    let mut p = profile("hall-a", 4);
    let white = [0, 1, 2].map(|k| p.primaries_xyz_cd_m2.iter().map(|c| c[k]).sum::<f64>() * 0.2);
    p.display_model = DisplayModel::WhiteSegment {
        white_xyz_cd_m2: white,
    };
    p.validate().unwrap();
    let read = DisplayProfile::from_json(&p.to_json(), Path::new("w.json")).unwrap();
    assert_eq!(read, p);
    // Negative luminance, or a "segment" that takes away more than the whole red
    // channel (u = (−1.5, 3, 0)): refused, naming the field.
    let [r, g, _] = p.primaries_xyz_cd_m2;
    for w in [
        [0.0, -1.0, 0.0],
        [0, 1, 2].map(|k| -1.5 * r[k] + 3.0 * g[k]),
    ] {
        p.display_model = DisplayModel::WhiteSegment { white_xyz_cd_m2: w };
        let err = p.validate().unwrap_err().to_string();
        assert!(err.contains("display_model"), "{w:?}: {err}");
    }
}

#[test]
fn missing_version_or_broken_json_is_a_parse_error() {
    let p = profile("hall-a", 0);
    let mut v: serde_json::Value = serde_json::from_str(&p.to_json()).unwrap();
    v.as_object_mut().unwrap().remove("format_version");
    let err = DisplayProfile::from_json(&v.to_string(), Path::new("a.json")).unwrap_err();
    assert!(matches!(err, ProfileError::Parse { .. }), "{err:?}");
    let text = p.to_json();
    let err = DisplayProfile::from_json(&text[..text.len() / 2], Path::new("a.json")).unwrap_err();
    assert!(matches!(err, ProfileError::Parse { .. }), "{err:?}");
}

fn reason(err: ProfileError) -> String {
    match err {
        ProfileError::Invalid { reason, .. } => reason,
        other => panic!("expected Invalid, got {other:?}"),
    }
}

#[test]
fn non_monotone_lut_is_rejected() {
    let mut p = profile("hall-a", 0);
    p.curves[1].inverse_lut.swap(500, 501);
    assert!(reason(p.validate().unwrap_err()).contains("green inverse LUT is not monotone"));
}

#[test]
fn short_lut_is_rejected() {
    let mut p = profile("hall-a", 0);
    p.curves[2].inverse_lut.truncate(MIN_LUT_ENTRIES - 1);
    let r = reason(p.validate().unwrap_err());
    assert!(r.contains("blue inverse LUT has 1023 entries"), "{r}");
    // A 17-entry "LUT" of a classic ramp is far too short.
    p.curves[2].inverse_lut = (0..17).map(|i| i as f32 / 16.0).collect();
    assert!(reason(p.validate().unwrap_err()).contains("17 entries"));
}

#[test]
fn nan_or_out_of_range_lut_entry_is_rejected() {
    for bad in [f32::NAN, f32::INFINITY, -0.01, 1.01] {
        let mut p = profile("hall-a", 0);
        p.curves[0].inverse_lut[700] = bad;
        let r = reason(p.validate().unwrap_err());
        assert!(
            r.contains("red inverse LUT has a value outside 0..=1"),
            "{bad}: {r}"
        );
    }
}

#[test]
fn invalid_profile_is_not_saved_and_not_loaded() {
    let dir = tempfile::tempdir().unwrap();
    let mut p = profile("hall-a", 0);
    p.curves[0].inverse_lut.swap(10, 11);
    let path = dir.path().join("bad.json");
    assert!(matches!(p.save(&path), Err(ProfileError::Invalid { .. })));
    assert!(!path.exists());
    // The same document written by something else is refused on load.
    std::fs::write(&path, p.to_json()).unwrap();
    assert!(matches!(
        DisplayProfile::load(&path),
        Err(ProfileError::Invalid { .. })
    ));
}

#[test]
fn save_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d000-c0r0-mono.json");
    profile("hall-a", 0).save(&path).unwrap();
    profile("hall-a", 1).save(&path).unwrap();
    assert_eq!(
        files_in(dir.path()),
        vec!["d000-c0r0-mono.json".to_string()]
    );
    assert_eq!(DisplayProfile::load(&path).unwrap().display.display, 1);
}

/// `p.json` in `dir`, saved with display 3's profile, and that profile.
fn saved_old_profile(dir: &Path) -> (PathBuf, DisplayProfile) {
    let path = dir.join("p.json");
    let old = profile("hall-a", 3);
    old.save(&path).unwrap();
    (path, old)
}

#[test]
fn failed_save_keeps_the_old_file_intact() {
    let dir = tempfile::tempdir().unwrap();
    let (path, old) = saved_old_profile(dir.path());
    let before = std::fs::read(&path).unwrap();

    // Make the write of the temporary file fail: the name `save` writes to is taken
    // by a folder. (A read-only folder would not stop the tests when run as root.)
    let tmp = dir
        .path()
        .join(format!(".p.json.tmp-{}", std::process::id()));
    std::fs::create_dir(&tmp).unwrap();
    let new = profile("hall-a", 4);
    let err = new.save(&path).unwrap_err();
    assert!(matches!(err, ProfileError::Io { .. }), "{err:?}");
    assert_eq!(std::fs::read(&path).unwrap(), before);
    assert_eq!(DisplayProfile::load(&path).unwrap(), old);
    std::fs::remove_dir(&tmp).unwrap();
    assert_eq!(files_in(dir.path()), vec!["p.json".to_string()]);
}

#[cfg(unix)]
#[test]
fn save_into_read_only_folder_fails_and_keeps_the_old_file_unless_root() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let (path, old) = saved_old_profile(dir.path());
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o555)).unwrap();
    let probe = dir.path().join("probe");
    let root_ignores_modes = std::fs::write(&probe, b"x").is_ok();
    let result = profile("hall-a", 4).save(&path);
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    if root_ignores_modes {
        // Running as root: permissions do not stop writes; the test above covers this.
        std::fs::remove_file(&probe).unwrap();
        return;
    }
    assert!(matches!(result, Err(ProfileError::Io { .. })), "{result:?}");
    assert_eq!(DisplayProfile::load(&path).unwrap(), old);
    assert_eq!(files_in(dir.path()), vec!["p.json".to_string()]);
}

#[test]
fn failed_rename_removes_the_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    // The target name is a non-empty folder: writing the temp file works, the
    // rename over the folder fails.
    let path = dir.path().join("p.json");
    std::fs::create_dir(&path).unwrap();
    std::fs::write(path.join("keep"), b"x").unwrap();
    assert!(profile("hall-a", 0).save(&path).is_err());
    assert_eq!(files_in(dir.path()), vec!["p.json".to_string()]);
}

#[test]
fn profile_set_round_trips_through_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    let mut profiles = Vec::new();
    for d in 0..3 {
        for eye in [Eye::Left, Eye::Right] {
            let mut p = profile("hall-a", d);
            p.display.eye = eye;
            profiles.push(p);
        }
    }
    ProfileSet::save_dir(dir.path(), "hall-a", &profiles).unwrap();
    let (wall, back) = ProfileSet::load_dir(dir.path()).unwrap();
    assert_eq!(wall, "hall-a");
    assert_eq!(back, profiles);

    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("wall.json")).unwrap())
            .unwrap();
    assert_eq!(manifest["format_version"], FORMAT_VERSION);
    assert_eq!(manifest["wall"], "hall-a");
    assert_eq!(manifest["files"][0], "d000-c0r0-left.json");
    assert_eq!(manifest["files"][5], "d002-c2r0-right.json");
    assert_eq!(
        files_in(dir.path()).len(),
        7,
        "6 profiles + wall.json, no temp files"
    );
}

#[test]
fn profile_set_of_other_version_or_missing_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let profiles = vec![profile("hall-a", 0), profile("hall-a", 1)];
    ProfileSet::save_dir(dir.path(), "hall-a", &profiles).unwrap();
    let manifest = dir.path().join("wall.json");
    let text = std::fs::read_to_string(&manifest).unwrap();

    let newer = text.replace(
        &format!("\"format_version\": {FORMAT_VERSION}"),
        "\"format_version\": 7",
    );
    assert_ne!(newer, text);
    std::fs::write(&manifest, newer).unwrap();
    let err = ProfileSet::load_dir(dir.path()).unwrap_err();
    assert!(
        matches!(
            err,
            ProfileError::Version {
                found: 7,
                expected: FORMAT_VERSION,
                ..
            }
        ),
        "{err:?}"
    );

    std::fs::write(&manifest, &text).unwrap();
    std::fs::remove_file(dir.path().join("d001-c1r0-mono.json")).unwrap();
    let err = ProfileSet::load_dir(dir.path()).unwrap_err();
    assert!(matches!(err, ProfileError::Io { .. }), "{err:?}");
}

/// A saved two-display set of wall `hall-a` in `dir`.
fn saved_set(dir: &Path) -> Vec<DisplayProfile> {
    let profiles = vec![profile("hall-a", 0), profile("hall-a", 1)];
    ProfileSet::save_dir(dir, "hall-a", &profiles).unwrap();
    profiles
}

/// The reason of a [`ProfileError::MixedFolder`], or a panic naming the error.
fn mixed_reason(err: ProfileError) -> String {
    match err {
        ProfileError::MixedFolder { reason, .. } => reason,
        other => panic!("expected MixedFolder, got {other:?}"),
    }
}

#[test]
fn profile_set_of_two_solves_is_refused_naming_both_files() {
    let dir = tempfile::tempdir().unwrap();
    let mut profiles = saved_set(dir.path());
    // What a kill -9 during a re-commission leaves: one profile of the new solve.
    profiles[1].created_utc = "2031-01-01T00:00:00Z".into();
    profiles[1]
        .save(&dir.path().join("d001-c1r0-mono.json"))
        .unwrap();
    let reason = mixed_reason(ProfileSet::load_dir(dir.path()).unwrap_err());
    assert!(reason.contains("d001-c1r0-mono.json"), "{reason}");
    assert!(reason.contains("d000-c0r0-mono.json"), "{reason}");
    assert!(reason.contains("creation times"), "{reason}");

    // Same time, another target white: still two solves.
    profiles[1].created_utc = profiles[0].created_utc.clone();
    profiles[1].target_white_xyz_cd_m2[1] *= 1.01;
    profiles[1]
        .save(&dir.path().join("d001-c1r0-mono.json"))
        .unwrap();
    let reason = mixed_reason(ProfileSet::load_dir(dir.path()).unwrap_err());
    assert!(reason.contains("target whites"), "{reason}");
}

#[test]
fn profile_of_another_wall_in_the_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    saved_set(dir.path());
    let other = profile("hall-b", 1);
    other.save(&dir.path().join("d001-c1r0-mono.json")).unwrap();
    let reason = mixed_reason(ProfileSet::load_dir(dir.path()).unwrap_err());
    assert!(reason.contains("\"hall-b\""), "{reason}");
    assert!(reason.contains("\"hall-a\""), "{reason}");
}

#[test]
fn manifest_naming_a_path_outside_the_folder_or_a_display_twice_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    saved_set(dir.path());
    let manifest = dir.path().join("wall.json");
    let text = std::fs::read_to_string(&manifest).unwrap();
    for bad in ["../d000-c0r0-mono.json", "/etc/passwd", ".hidden.json"] {
        std::fs::write(&manifest, text.replace("d001-c1r0-mono.json", bad)).unwrap();
        let reason = mixed_reason(ProfileSet::load_dir(dir.path()).unwrap_err());
        assert!(
            reason.contains("not a file name inside the folder"),
            "{bad}: {reason}"
        );
    }
    std::fs::write(
        &manifest,
        text.replace("d001-c1r0-mono.json", "d000-c0r0-mono.json"),
    )
    .unwrap();
    let reason = mixed_reason(ProfileSet::load_dir(dir.path()).unwrap_err());
    assert!(reason.contains("appears twice"), "{reason}");
}

#[test]
fn interrupted_save_leaves_a_folder_that_is_refused_with_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let mut profiles = saved_set(dir.path());
    // A re-save removes the manifest first; an interruption before it is written
    // again leaves the folder without one.
    profiles[0].created_utc = "2031-01-01T00:00:00Z".into();
    profiles[0]
        .save(&dir.path().join("d000-c0r0-mono.json"))
        .unwrap();
    std::fs::remove_file(dir.path().join("wall.json")).unwrap();
    let err = ProfileSet::load_dir(dir.path()).unwrap_err();
    assert!(matches!(err, ProfileError::NoManifest { .. }), "{err:?}");
    assert!(err.to_string().contains("--resume"), "{err}");
    // A complete re-save is accepted again.
    profiles[1].created_utc = profiles[0].created_utc.clone();
    ProfileSet::save_dir(dir.path(), "hall-a", &profiles).unwrap();
    assert_eq!(ProfileSet::load_dir(dir.path()).unwrap().1, profiles);
}

// ---- property test: any valid profile survives JSON exactly ----

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![
        -1.0e4..1.0e4,
        -1.0e-6..1.0e-6,
        Just(0.0),
        Just(-0.0),
        1.0e-300..1.0e-290,
        any::<f64>().prop_filter("finite", |v| v.is_finite()),
    ]
}

fn v3() -> impl Strategy<Value = [f64; 3]> {
    [finite(), finite(), finite()]
}

fn curve() -> impl Strategy<Value = ToneCurve> {
    (
        0.3f64..4.0,
        MIN_LUT_ENTRIES..MIN_LUT_ENTRIES + 300,
        prop::collection::vec(0.0f64..1.0, 0..30),
    )
        .prop_map(|(gamma, n, mut knots)| {
            let mut c = power_curve(gamma);
            c.inverse_lut = (0..n)
                .map(|i| ((i as f64) / ((n - 1) as f64)).powf(1.0 / gamma) as f32)
                .collect();
            knots.sort_by(f64::total_cmp);
            c.forward = std::iter::once([0.0, 0.0])
                .chain(knots.into_iter().map(|d| [d, d.powf(gamma)]))
                .chain(std::iter::once([1.0, 1.0]))
                .collect();
            c
        })
}

/// A valid chromaticity (x ≥ 0, y > 0, x + y ≤ 1), as `validate` requires of the
/// common primaries.
fn chromaticity() -> impl Strategy<Value = [f64; 2]> {
    (0.0f64..0.8, 0.01f64..0.99).prop_map(|(x, f)| [x, f * (1.0 - x)])
}

fn flat_field() -> impl Strategy<Value = Option<FlatField>> {
    prop::option::of((1u32..9, 1u32..5).prop_flat_map(|(w, h)| {
        prop::collection::vec(
            [0.01f32..=1.0, 0.01f32..=1.0, 0.01f32..=1.0],
            (w * h) as usize,
        )
        .prop_map(move |gain| FlatField {
            width: w,
            height: h,
            gain,
        })
    }))
}

prop_compose! {
    fn any_profile()(
        display in 0u32..48,
        eye in prop_oneof![Just(Eye::Mono), Just(Eye::Left), Just(Eye::Right)],
        wall in "[a-zA-Z0-9 _äöü-]{1,20}",
        prim in [v3(), v3(), v3()],
        black in v3(), shown in v3(), white in v3(),
        xy in [chromaticity(), chromaticity(), chromaticity()],
        m in [v3(), v3(), v3()],
        offset in v3(), usage in v3(),
        headroom in prop_oneof![Just(1.0), 0.01f64..=1.0],
        curves in [curve(), curve(), curve()],
        ff in flat_field(),
        black_mode in prop_oneof![Just(BlackMode::Ignore), Just(BlackMode::Individual), Just(BlackMode::Common)],
        oog in prop_oneof![Just(OutOfGamut::Clip), Just(OutOfGamut::FalseColour)],
        bits in prop_oneof![Just(8u32), Just(10), Just(12), Just(16)],
        readings in any::<u32>(),
        add in prop::option::of(finite()),
        instrument in ".{0,30}",
    ) -> DisplayProfile {
        let mut p = profile(&wall, display);
        p.display.eye = eye;
        p.primaries_xyz_cd_m2 = prim;
        p.black_xyz_cd_m2 = black;
        p.shown_black_xyz_cd_m2 = shown;
        p.target_white_xyz_cd_m2 = white;
        p.common_primaries_xy = xy;
        p.xyz_to_drive = m;
        p.drive_offset = offset;
        p.channel_usage = usage;
        p.headroom = headroom;
        p.curves = curves;
        p.flat_field = ff;
        p.black_mode = black_mode;
        p.out_of_gamut = oog;
        p.bit_depth = bits;
        p.measurement.readings = readings;
        p.measurement.additivity_error = add;
        p.measurement.instrument = instrument;
        p
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn any_valid_profile_round_trips_exactly(p in any_profile()) {
        prop_assert!(p.validate().is_ok(), "{:?}", p.validate());
        let back = DisplayProfile::from_json(&p.to_json(), Path::new("prop.json")).unwrap();
        // Bit-exact, not approximately equal: a profile must read back as written.
        prop_assert_eq!(&back, &p);
        let bits = |q: &DisplayProfile| q.xyz_to_drive.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
        prop_assert_eq!(bits(&back), bits(&p));
    }
}

#[test]
fn profile_that_saves_also_loads() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.json");
    let mut p = profile("hall-a", 0);
    p.common_primaries_xy[1][0] = f64::NAN;
    p.curves[0].forward[3][1] = f64::NAN;
    if p.save(&path).is_ok() {
        DisplayProfile::load(&path).unwrap();
    }
}

#[test]
fn nan_or_invalid_values_that_json_cannot_hold_are_refused_by_validate_naming_the_field() {
    type Spoil = fn(&mut DisplayProfile);
    let cases: [(&str, Spoil); 7] = [
        ("common_primaries_xy of green", |p| {
            p.common_primaries_xy[1][0] = f64::NAN
        }),
        ("common_primaries_xy of blue", |p| {
            p.common_primaries_xy[2] = [0.7, 0.5]
        }),
        ("common_primaries_xy of red", |p| {
            p.common_primaries_xy[0][1] = 0.0
        }),
        ("red forward curve sample 3", |p| {
            p.curves[0].forward[3][1] = f64::NAN
        }),
        ("blue forward curve sample 0", |p| {
            p.curves[2].forward[0][0] = f64::INFINITY
        }),
        ("measurement.additivity_error", |p| {
            p.measurement.additivity_error = Some(f64::NAN)
        }),
        ("display.wall", |p| p.display.wall = String::new()),
    ];
    for (field, spoil) in cases {
        let mut p = profile("hall-a", 0);
        spoil(&mut p);
        let r = reason(p.validate().unwrap_err());
        assert!(r.contains(field), "{field}: {r}");
        let dir = tempfile::tempdir().unwrap();
        assert!(p.save(&dir.path().join("p.json")).is_err(), "{field}");
        assert!(files_in(dir.path()).is_empty(), "{field}");
    }
}

#[cfg(unix)]
#[test]
fn failed_write_to_a_full_disk_removes_the_temporary_file() {
    // /dev/full answers every write with ENOSPC, like a full disk. The temporary
    // file is a symlink to it here, so the create succeeds and the write fails.
    if !Path::new("/dev/full").exists() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (path, old) = saved_old_profile(dir.path());
    let tmp = dir
        .path()
        .join(format!(".p.json.tmp-{}", std::process::id()));
    std::os::unix::fs::symlink("/dev/full", &tmp).unwrap();
    let err = profile("hall-a", 4).save(&path).unwrap_err();
    assert!(matches!(err, ProfileError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("p.json"), "{err}");
    assert_eq!(DisplayProfile::load(&path).unwrap(), old);
    // The link is removed, not followed.
    assert!(Path::new("/dev/full").exists());
    assert_eq!(files_in(dir.path()), vec!["p.json".to_string()]);
}

/// A PID that belonged to a process which has ended.
fn dead_pid() -> u32 {
    let mut child = std::process::Command::new("true").spawn().unwrap();
    let pid = child.id();
    child.wait().unwrap();
    pid
}

fn age(path: &Path, secs: u64) {
    let f = std::fs::File::options().write(true).open(path).unwrap();
    f.set_modified(std::time::SystemTime::now() - std::time::Duration::from_secs(secs))
        .unwrap();
}

#[cfg(target_os = "linux")]
#[test]
fn save_removes_stale_temporary_files_of_dead_writers_and_keeps_live_ones() {
    let dir = tempfile::tempdir().unwrap();
    let dead = dead_pid();
    let stale = dir.path().join(format!(".d001-c1r0-mono.json.tmp-{dead}"));
    let fresh_dead = dir.path().join(format!(".wall.json.tmp-{dead}"));
    let mine = dir
        .path()
        .join(format!(".other.json.tmp-{}", std::process::id()));
    let live = dir.path().join(".other.json.tmp-1");
    let not_ours = dir.path().join(format!(".notes.tmp-{dead}x"));
    let folder = dir.path().join(format!(".f.json.tmp-{dead}"));
    for f in [&stale, &fresh_dead, &mine, &live, &not_ours] {
        std::fs::write(f, b"half a profile").unwrap();
    }
    std::fs::create_dir(&folder).unwrap();
    for f in [&stale, &mine, &live, &not_ours] {
        age(f, 3600);
    }
    profile("hall-a", 0)
        .save(&dir.path().join("p.json"))
        .unwrap();
    let mut expected: Vec<String> = [&fresh_dead, &mine, &live, &not_ours, &folder]
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    expected.push("p.json".into());
    expected.sort();
    assert_eq!(files_in(dir.path()), expected);
    // Once old enough, the dead writer's second file goes too.
    age(&fresh_dead, 61);
    let removed = lumiwall_profiles::remove_stale_temp_files(dir.path()).unwrap();
    assert_eq!(removed, vec![fresh_dead.clone()]);
    assert!(!fresh_dead.exists());
}
