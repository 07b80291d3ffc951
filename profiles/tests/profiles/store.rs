//! The SQLite profile store: three simulated nightly runs, latest and history, drift
//! against hand-computed numbers, all-or-nothing recording, and refusal of newer,
//! foreign and damaged files.

#![cfg(feature = "store")]

use std::path::Path;
use std::time::{Duration, Instant};

use crate::common::{PRIMARIES, profile_with};
use lumiwall_profiles::store::{
    CommissionRun, ProfileStore, StoreError, Timestamp, document, parse_time, schema,
};
use lumiwall_profiles::{DisplayProfile, Eye, ProfileError};

const WALL: &str = "hall-a";

fn t(s: &str) -> Timestamp {
    parse_time(s).unwrap()
}

fn scaled(scale: [f64; 3]) -> [[f64; 3]; 3] {
    let mut p = PRIMARIES;
    for (c, row) in p.iter_mut().enumerate() {
        for v in row.iter_mut() {
            *v *= scale[c];
        }
    }
    p
}

/// One night: 2 projectors × 2 eyes. Projector 1's left eye is the one whose
/// numbers the drift tests check; the others drift less.
struct Night {
    time: &'static str,
    scale: [f64; 3],
    black: [f64; 3],
    usage: [f64; 3],
}

const NIGHTS: [Night; 3] = [
    Night {
        time: "2026-11-20T02:00:00Z",
        scale: [1.0, 1.0, 1.0],
        black: [0.30, 0.50, 0.60],
        usage: [0.90, 1.0, 0.85],
    },
    Night {
        time: "2026-11-21T02:00:00Z",
        scale: [0.95, 0.95, 0.95],
        black: [0.31, 0.52, 0.62],
        usage: [0.92, 1.0, 0.88],
    },
    Night {
        time: "2026-11-22T02:00:00Z",
        scale: [0.92, 0.92, 0.90],
        black: [0.33, 0.55, 0.66],
        usage: [0.95, 1.0, 0.93],
    },
];

fn night_profiles(n: &Night) -> Vec<DisplayProfile> {
    let mut out = Vec::new();
    for d in 0..2 {
        for eye in [Eye::Left, Eye::Right] {
            let tracked = d == 1 && eye == Eye::Left;
            let (scale, black, usage) = if tracked {
                (n.scale, n.black, n.usage)
            } else {
                ([1.0; 3], [0.3, 0.5, 0.6], [0.9, 1.0, 0.85])
            };
            let mut p = profile_with(WALL, d, eye, scaled(scale), black, usage);
            p.created_utc = n.time.to_string();
            out.push(p);
        }
    }
    out
}

fn nightly_run(n: &Night) -> CommissionRun {
    CommissionRun {
        wall: WALL.into(),
        started_utc: t(n.time),
        source: "nightly".into(),
        note: String::new(),
    }
}

fn store_with_three_nights() -> ProfileStore {
    let mut store = ProfileStore::open_in_memory().unwrap();
    for n in &NIGHTS {
        store.record(&nightly_run(n), &night_profiles(n)).unwrap();
    }
    store
}

/// A store file at `path` holding the first night's run, open.
fn file_store_with_first_night(path: &Path) -> ProfileStore {
    let mut store = ProfileStore::open(path).unwrap();
    store
        .record(&nightly_run(&NIGHTS[0]), &night_profiles(&NIGHTS[0]))
        .unwrap();
    store
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn record_latest_and_history_over_three_nights() {
    let store = store_with_three_nights();
    assert_eq!(store.schema_version().unwrap(), schema::SCHEMA_VERSION);

    let latest = store.latest(WALL).unwrap();
    assert_eq!(latest, night_profiles(&NIGHTS[2]));

    let hist = store.history(WALL, 1).unwrap();
    assert_eq!(hist.len(), 6, "3 nights × 2 eyes");
    for (i, n) in NIGHTS.iter().enumerate() {
        let expected = night_profiles(n);
        assert_eq!(hist[2 * i].0, t(n.time));
        assert_eq!(hist[2 * i].1, expected[2], "night {i} left");
        assert_eq!(hist[2 * i + 1].1, expected[3], "night {i} right");
    }
    assert!(store.history(WALL, 5).unwrap().is_empty());
    assert!(store.history("other-wall", 1).unwrap().is_empty());
    assert!(store.latest("other-wall").unwrap().is_empty());

    let walls = store.walls().unwrap();
    assert_eq!(walls.len(), 1);
    assert_eq!(walls[0].wall, WALL);
    assert_eq!(walls[0].runs, 3);
    assert_eq!(walls[0].first_utc, t(NIGHTS[0].time));
    assert_eq!(walls[0].last_utc, t(NIGHTS[2].time));
    let runs = store.runs(WALL).unwrap();
    assert_eq!(runs.len(), 3);
    assert!(
        runs.iter()
            .all(|r| r.profiles == 4 && r.run.source == "nightly")
    );
    assert_eq!(runs[1].run.started_utc, t(NIGHTS[1].time));
}

#[test]
fn latest_keeps_displays_missing_from_the_last_run_and_orders_by_time_not_insertion() {
    let mut store = ProfileStore::open_in_memory().unwrap();
    // Recorded out of order: night 3 first, then night 1 (a late import).
    store
        .record(&nightly_run(&NIGHTS[2]), &night_profiles(&NIGHTS[2]))
        .unwrap();
    store
        .record(&nightly_run(&NIGHTS[0]), &night_profiles(&NIGHTS[0]))
        .unwrap();
    assert_eq!(store.latest(WALL).unwrap(), night_profiles(&NIGHTS[2]));
    // A service run the day after that re-measures only projector 0, left eye.
    let mut serviced = night_profiles(&NIGHTS[2])[0].clone();
    serviced.black_xyz_cd_m2 = [0.2, 0.25, 0.3];
    serviced.created_utc = "2026-11-23T10:00:00Z".into();
    let mut run = CommissionRun::new(WALL, t("2026-11-23T10:00:00Z"));
    run.note = "lamp changed".into();
    store.record(&run, std::slice::from_ref(&serviced)).unwrap();
    let latest = store.latest(WALL).unwrap();
    assert_eq!(latest.len(), 4);
    assert_eq!(latest[0], serviced);
    assert_eq!(latest[1..], night_profiles(&NIGHTS[2])[1..]);
    let hist = store.history(WALL, 0).unwrap();
    let times: Vec<Timestamp> = hist.iter().map(|h| h.0).collect();
    assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");
    assert_eq!(store.runs(WALL).unwrap()[2].run.note, "lamp changed");
}

#[test]
fn drift_over_all_nights_matches_hand_computation() {
    // Hand computation (see FORMAT.md, drift): native white = R + G + B primaries.
    // Night 1: W = (90, 100, 92), xy = (0.3191489, 0.3546099).
    // Night 3: R, G × 0.92, B × 0.90: W = (82.5, 91.8, 83.04), xy = (0.3205875, 0.3567265).
    // ΔY = (91.8 − 100) / 100 = −8.2 %; Δxy = hypot(0.0014386, 0.0021166) = 0.0025592.
    let store = store_with_three_nights();
    let d = store.drift(WALL, 1, Eye::Left, None).unwrap();
    assert_eq!(d.display.display, 1);
    assert_eq!(d.display.eye, Eye::Left);
    assert_eq!(d.baseline_utc, t(NIGHTS[0].time));
    assert_eq!(d.current_utc, t(NIGHTS[2].time));
    assert_eq!(d.profiles, 3);
    assert!(close(d.baseline_white_y_cd_m2, 100.0, 1e-12));
    assert!(close(d.current_white_y_cd_m2, 91.8, 1e-12));
    let pct = d.white_luminance_change_pct.unwrap();
    assert!(close(pct, -8.2, 1e-9), "{pct}");
    let dxy = d.white_delta_xy.unwrap();
    assert!(close(dxy, 0.002_559_203_366_387_69, 1e-12), "{dxy}");
    assert!(
        close(d.black_change_cd_m2, 0.05, 1e-12),
        "{}",
        d.black_change_cd_m2
    );
    let du = d.channel_usage_change;
    assert!(close(du[0], 0.05, 1e-12) && close(du[1], 0.0, 1e-12) && close(du[2], 0.08, 1e-12));
    assert_eq!(d.current_channel_usage, [0.95, 1.0, 0.93]);
}

#[test]
fn drift_since_a_date_starts_at_the_first_run_of_that_day() {
    // Since 2026-11-21 (00:00 UTC): baseline night 2, W = 0.95 × (90, 100, 92), same
    // xy as night 1. ΔY = (91.8 − 95) / 95 = −3.368421 %; Δxy as above.
    let store = store_with_three_nights();
    for since in [
        "2026-11-21",
        "2026-11-21T02:00:00Z",
        "2026-11-21T03:00:00+01:00",
    ] {
        let d = store.drift(WALL, 1, Eye::Left, Some(t(since))).unwrap();
        assert_eq!(d.baseline_utc, t(NIGHTS[1].time), "{since}");
        assert_eq!(d.profiles, 2);
        let pct = d.white_luminance_change_pct.unwrap();
        assert!(close(pct, -3.368_421_052_631_567, 1e-9), "{pct}");
        assert!(close(
            d.white_delta_xy.unwrap(),
            0.002_559_203_366_387_69,
            1e-12
        ));
        assert!(close(d.black_change_cd_m2, 0.03, 1e-12));
        let du = d.channel_usage_change;
        assert!(close(du[0], 0.03, 1e-12) && close(du[1], 0.0, 1e-12) && close(du[2], 0.05, 1e-12));
    }
    // Between night 1 and night 2 the white only dims: chromaticity unchanged.
    let mut store2 = ProfileStore::open_in_memory().unwrap();
    for n in &NIGHTS[..2] {
        store2.record(&nightly_run(n), &night_profiles(n)).unwrap();
    }
    let d = store2.drift(WALL, 1, Eye::Left, None).unwrap();
    assert!(close(d.white_luminance_change_pct.unwrap(), -5.0, 1e-9));
    assert!(d.white_delta_xy.unwrap() < 1e-15);
    // Undrifted displays report zero.
    let all = store.drift_wall(WALL, None).unwrap();
    assert_eq!(all.len(), 4);
    for d in all
        .iter()
        .filter(|d| !(d.display.display == 1 && d.display.eye == Eye::Left))
    {
        assert_eq!(d.white_luminance_change_pct, Some(0.0));
        assert_eq!(d.white_delta_xy, Some(0.0));
        assert_eq!(d.black_change_cd_m2, 0.0);
    }
}

#[test]
fn drift_without_profiles_in_the_window_is_a_clear_error() {
    let store = store_with_three_nights();
    let err = store
        .drift(WALL, 1, Eye::Left, Some(t("2026-11-23")))
        .unwrap_err();
    assert!(
        matches!(err, StoreError::NoHistory { display: 1, .. }),
        "{err:?}"
    );
    assert!(
        err.to_string().contains("since 2026-11-23T00:00:00Z"),
        "{err}"
    );
    assert!(matches!(
        store.drift(WALL, 9, Eye::Mono, None),
        Err(StoreError::NoHistory { .. })
    ));
    assert!(
        store
            .drift_wall(WALL, Some(t("2026-12-01")))
            .unwrap()
            .is_empty()
    );
}

#[test]
fn drift_with_a_dark_baseline_reports_no_percentage_instead_of_inf() {
    let mut store = ProfileStore::open_in_memory().unwrap();
    let dark = profile_with(WALL, 0, Eye::Mono, [[0.0; 3]; 3], [0.0; 3], [1.0; 3]);
    store
        .record(&CommissionRun::new(WALL, t("2026-11-20")), &[dark])
        .unwrap();
    let lit = profile_with(WALL, 0, Eye::Mono, PRIMARIES, [0.0; 3], [1.0; 3]);
    store
        .record(&CommissionRun::new(WALL, t("2026-11-21")), &[lit])
        .unwrap();
    let d = store.drift(WALL, 0, Eye::Mono, None).unwrap();
    assert_eq!(d.white_luminance_change_pct, None);
    assert_eq!(d.white_delta_xy, None);
    assert_eq!(d.current_white_y_cd_m2, 100.0);
}

/// Makes every insert of a profile of display 1 fail inside SQLite, as a full disk
/// or an I/O error in the middle of a run would.
fn inject_failure(path: &Path) {
    let raw = rusqlite::Connection::open(path).unwrap();
    raw.execute_batch(
        "CREATE TRIGGER fail_display_1 BEFORE INSERT ON profiles WHEN NEW.display = 1
         BEGIN SELECT RAISE(ABORT, 'injected write failure'); END;",
    )
    .unwrap();
}

#[test]
fn failure_in_the_middle_of_a_run_leaves_the_previous_state() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wall.lumistore");
    let mut store = file_store_with_first_night(&path);
    inject_failure(&path);

    // Display 0's two profiles and the run row are written before display 1 fails.
    let err = store
        .record(&nightly_run(&NIGHTS[1]), &night_profiles(&NIGHTS[1]))
        .unwrap_err();
    assert!(matches!(err, StoreError::Sqlite { .. }), "{err:?}");
    assert!(err.to_string().contains("injected write failure"), "{err}");

    for s in [&store, &ProfileStore::open(&path).unwrap()] {
        assert_eq!(s.runs(WALL).unwrap().len(), 1);
        assert_eq!(s.latest(WALL).unwrap(), night_profiles(&NIGHTS[0]));
        assert_eq!(s.history(WALL, 0).unwrap().len(), 2);
    }
    let raw = rusqlite::Connection::open(&path).unwrap();
    let rows: i64 = raw
        .query_row("SELECT COUNT(*) FROM profiles", [], |r| r.get(0))
        .unwrap();
    assert_eq!(rows, 4, "only night 1's profiles");
    raw.execute_batch("DROP TRIGGER fail_display_1").unwrap();
    drop(raw);

    // The same run records fine once the fault is gone.
    store
        .record(&nightly_run(&NIGHTS[1]), &night_profiles(&NIGHTS[1]))
        .unwrap();
    assert_eq!(store.latest(WALL).unwrap(), night_profiles(&NIGHTS[1]));
}

#[test]
fn invalid_runs_write_nothing() {
    let mut store = store_with_three_nights();
    let before = store.runs(WALL).unwrap();
    let run = nightly_run(&NIGHTS[2]);

    let mut bad_lut = night_profiles(&NIGHTS[2]);
    bad_lut[3].curves[1].inverse_lut[600] = f32::NAN;
    let err = store.record(&run, &bad_lut).unwrap_err();
    match &err {
        StoreError::InvalidProfile(e) => assert!(matches!(**e, ProfileError::Invalid { .. })),
        other => panic!("{other:?}"),
    }

    let mut dup = night_profiles(&NIGHTS[2]);
    dup[1] = dup[0].clone();
    let err = store.record(&run, &dup).unwrap_err();
    assert!(
        err.to_string().contains("two profiles of display 0 (left)"),
        "{err}"
    );

    let mut foreign = night_profiles(&NIGHTS[2]);
    foreign[2].display.wall = "hall-b".into();
    let err = store.record(&run, &foreign).unwrap_err();
    assert!(matches!(err, StoreError::InvalidRun(_)), "{err:?}");

    assert!(matches!(
        store.record(&run, &[]),
        Err(StoreError::InvalidRun(_))
    ));
    assert_eq!(store.runs(WALL).unwrap(), before);
}

#[test]
fn newer_schema_is_refused_and_left_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wall.lumistore");
    drop(file_store_with_first_night(&path));
    let future = schema::SCHEMA_VERSION + 4;
    {
        let raw = rusqlite::Connection::open(&path).unwrap();
        raw.execute(
            "INSERT INTO lumiwall_schema (version, applied_utc) VALUES (?1, '2031-01-01T00:00:00Z')",
            [future],
        )
        .unwrap();
    }
    for open in [ProfileStore::open, ProfileStore::open_existing] {
        let err = open(&path).unwrap_err();
        match &err {
            StoreError::NewerSchema {
                found, supported, ..
            } => {
                assert_eq!(*found, future);
                assert_eq!(*supported, schema::SCHEMA_VERSION);
            }
            other => panic!("expected NewerSchema, got {other:?}"),
        }
        let msg = err.to_string();
        assert!(msg.contains("update lumiwall"), "{msg}");
    }
    let raw = rusqlite::Connection::open(&path).unwrap();
    let max: i64 = raw
        .query_row("SELECT MAX(version) FROM lumiwall_schema", [], |r| r.get(0))
        .unwrap();
    assert_eq!(max, i64::from(future));
}

#[test]
fn older_store_is_migrated_on_open() {
    // A store made by a build that had applied no migration yet (schema table only).
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("old.lumistore");
    {
        let raw = rusqlite::Connection::open(&path).unwrap();
        raw.execute_batch(
            "CREATE TABLE lumiwall_schema (version INTEGER PRIMARY KEY, applied_utc TEXT NOT NULL);",
        )
        .unwrap();
    }
    let mut store = ProfileStore::open(&path).unwrap();
    assert_eq!(store.schema_version().unwrap(), schema::SCHEMA_VERSION);
    store
        .record(&nightly_run(&NIGHTS[0]), &night_profiles(&NIGHTS[0]))
        .unwrap();
    drop(store);
    // Re-opening does not migrate again and finds the data.
    let store = ProfileStore::open_existing(&path).unwrap();
    assert_eq!(store.latest(WALL).unwrap().len(), 4);
    let raw = rusqlite::Connection::open(&path).unwrap();
    let app: i32 = raw
        .query_row("PRAGMA application_id", [], |r| r.get(0))
        .unwrap();
    assert_eq!(app, schema::APPLICATION_ID);
    let mode: String = raw
        .query_row("PRAGMA journal_mode", [], |r| r.get(0))
        .unwrap();
    assert_eq!(mode, "wal");
}

#[test]
fn foreign_sqlite_file_is_refused_and_left_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("customers.db");
    {
        let raw = rusqlite::Connection::open(&path).unwrap();
        raw.execute_batch("CREATE TABLE customers (id INTEGER PRIMARY KEY, name TEXT);")
            .unwrap();
    }
    let before = std::fs::read(&path).unwrap();
    let err = ProfileStore::open(&path).unwrap_err();
    assert!(matches!(err, StoreError::Foreign { .. }), "{err:?}");
    assert!(err.to_string().contains("customers"), "{err}");
    assert_eq!(std::fs::read(&path).unwrap(), before);
    assert!(!dir.path().join("customers.db-wal").exists());

    // Another program's file that carries its own application id.
    let path2 = dir.path().join("other.db");
    {
        let raw = rusqlite::Connection::open(&path2).unwrap();
        raw.pragma_update(None, "application_id", 0x1234_5678)
            .unwrap();
        raw.execute_batch("CREATE TABLE lumiwall_schema (version INTEGER);")
            .unwrap();
    }
    let err = ProfileStore::open(&path2).unwrap_err();
    assert!(err.to_string().contains("0x12345678"), "{err}");
}

#[test]
fn garbage_or_damaged_file_is_a_clear_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("notes.txt");
    std::fs::write(&path, "shift notes: projector 7 flickers\n".repeat(200)).unwrap();
    let err = ProfileStore::open(&path).unwrap_err();
    assert!(matches!(err, StoreError::NotADatabase { .. }), "{err:?}");
    assert!(
        err.to_string().contains("not a readable SQLite database"),
        "{err}"
    );

    // A real store with its header overwritten.
    let path = dir.path().join("wall.lumistore");
    drop(file_store_with_first_night(&path));
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[..16].copy_from_slice(b"garbagegarbage!\0");
    std::fs::write(&path, &bytes).unwrap();
    let _ = std::fs::remove_file(dir.path().join("wall.lumistore-wal"));
    let _ = std::fs::remove_file(dir.path().join("wall.lumistore-shm"));
    let err = ProfileStore::open(&path).unwrap_err();
    assert!(matches!(err, StoreError::NotADatabase { .. }), "{err:?}");

    // A folder where the store file should be.
    let err = ProfileStore::open(dir.path()).unwrap_err();
    assert!(
        matches!(
            err,
            StoreError::Open { .. } | StoreError::NotADatabase { .. }
        ),
        "{err:?}"
    );
    // A missing file for a read-only command.
    let missing = dir.path().join("typo.lumistore");
    let err = ProfileStore::open_existing(&missing).unwrap_err();
    assert!(matches!(err, StoreError::Missing { .. }), "{err:?}");
    assert!(!missing.exists());
    // Converts to the crate's error for callers that only know ProfileError.
    let e: ProfileError = err.into();
    assert!(matches!(e, ProfileError::Store(m) if m.contains("typo.lumistore")));
}

#[test]
fn hand_edited_profile_row_is_reported_with_its_run() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wall.lumistore");
    let store = file_store_with_first_night(&path);
    // Edit display 1 right's stored document: claim format version 9.
    let raw = rusqlite::Connection::open(&path).unwrap();
    let blob: Vec<u8> = raw
        .query_row(
            "SELECT document FROM profiles WHERE display = 1 AND eye = 'right'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    let text = document::decompress(&blob).unwrap();
    let current = format!(
        "{{\"format_version\":{},",
        lumiwall_profiles::FORMAT_VERSION
    );
    assert!(text.starts_with(&current), "{}", &text[..40]);
    // A version-1 document (no display model) still reads: the upgrade on reading is
    // the store's migration of profile JSON.
    let mut v1: serde_json::Value = serde_json::from_str(&text).unwrap();
    v1["format_version"] = serde_json::json!(1);
    v1.as_object_mut().unwrap().remove("display_model");
    raw.execute(
        "UPDATE profiles SET document = ?1 WHERE display = 1 AND eye = 'right'",
        [document::compress(&v1.to_string()).unwrap()],
    )
    .unwrap();
    let read = store.latest(WALL).unwrap();
    assert!(read.iter().any(|p| p.display.display == 1
        && p.display_model == lumiwall_profiles::DisplayModel::Additive
        && p.format_version == lumiwall_profiles::FORMAT_VERSION));
    let edited = text.replacen(&current, "{\"format_version\":9,", 1);
    raw.execute(
        "UPDATE profiles SET document = ?1 WHERE display = 1 AND eye = 'right'",
        [document::compress(&edited).unwrap()],
    )
    .unwrap();
    let err = store.latest(WALL).unwrap_err();
    match &err {
        StoreError::StoredProfile {
            run,
            display,
            eye,
            source,
            ..
        } => {
            assert_eq!((*run, *display, eye.as_str()), (1, 1, "right"));
            assert!(matches!(**source, ProfileError::Version { found: 9, .. }));
        }
        other => panic!("{other:?}"),
    }
    // The other display still reads.
    assert_eq!(store.history(WALL, 0).unwrap().len(), 2);

    // A document that is not zlib data at all.
    raw.execute(
        "UPDATE profiles SET document = x'00112233' WHERE display = 0 AND eye = 'left'",
        [],
    )
    .unwrap();
    let err = store.history(WALL, 0).unwrap_err();
    assert!(matches!(err, StoreError::BadRow { .. }), "{err:?}");
    assert!(err.to_string().contains("does not decompress"), "{err}");
}

#[test]
fn a_writer_holding_the_lock_gives_a_busy_error_after_the_timeout() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wall.lumistore");
    let mut store = ProfileStore::open(&path).unwrap();
    store.set_busy_timeout(Duration::from_millis(200)).unwrap();
    let mut other = rusqlite::Connection::open(&path).unwrap();
    let tx = other
        .transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)
        .unwrap();
    let start = Instant::now();
    let err = store
        .record(&nightly_run(&NIGHTS[0]), &night_profiles(&NIGHTS[0]))
        .unwrap_err();
    let waited = start.elapsed();
    assert!(matches!(err, StoreError::Busy { .. }), "{err:?}");
    assert!(waited >= Duration::from_millis(150), "{waited:?}");
    assert!(
        err.to_string().contains("locked by another process"),
        "{err}"
    );
    // Readers are not blocked by the writer (WAL).
    assert!(store.runs(WALL).unwrap().is_empty());
    tx.rollback().unwrap();
    store
        .record(&nightly_run(&NIGHTS[0]), &night_profiles(&NIGHTS[0]))
        .unwrap();
}

#[test]
fn times_are_read_as_dates_or_rfc3339() {
    assert_eq!(t("2026-11-21"), t("2026-11-21T00:00:00Z"));
    assert_eq!(t(" 2026-11-21T03:00:00+01:00 "), t("2026-11-21T02:00:00Z"));
    for bad in ["yesterday", "2026-13-01", "21.11.2026", ""] {
        let err = parse_time(bad).unwrap_err();
        assert!(matches!(err, StoreError::BadTime { .. }), "{bad}: {err:?}");
        assert!(err.to_string().contains("RFC 3339"), "{err}");
    }
}

#[test]
fn the_same_run_recorded_twice_is_refused() {
    let mut store = store_with_three_nights();
    let err = store
        .record(&nightly_run(&NIGHTS[1]), &night_profiles(&NIGHTS[1]))
        .unwrap_err();
    assert!(
        matches!(err, StoreError::DuplicateRun { existing: 2, .. }),
        "{err:?}"
    );
    assert_eq!(store.runs(WALL).unwrap().len(), 3);
    // The same time on another wall is a different run.
    let mut other = night_profiles(&NIGHTS[1]);
    for p in &mut other {
        p.display.wall = "hall-b".into();
    }
    let mut run = nightly_run(&NIGHTS[1]);
    run.wall = "hall-b".into();
    store.record(&run, &other).unwrap();
    assert_eq!(store.walls().unwrap().len(), 2);
}

#[test]
fn four_connections_creating_the_same_store_at_once_migrate_it_once() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wall.lumistore");
    let handles: Vec<_> = (0..4)
        .map(|_| {
            let path = path.clone();
            std::thread::spawn(move || ProfileStore::open(&path).map(|s| s.schema_version()))
        })
        .collect();
    for h in handles {
        assert_eq!(h.join().unwrap().unwrap().unwrap(), schema::SCHEMA_VERSION);
    }
    let raw = rusqlite::Connection::open(&path).unwrap();
    let rows: i64 = raw
        .query_row("SELECT COUNT(*) FROM lumiwall_schema", [], |r| r.get(0))
        .unwrap();
    assert_eq!(rows, i64::from(schema::SCHEMA_VERSION));
}

#[test]
fn full_size_wall_of_96_profiles_with_flat_fields_records_and_reports_drift() {
    // HEyeWall size: 48 projectors × 2 eyes, 64 × 32 flat-field textures (Kresse).
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("heyewall.lumistore");
    let mut store = ProfileStore::open(&path).unwrap();
    let start = Instant::now();
    for (night, n) in NIGHTS.iter().enumerate() {
        let mut profiles = Vec::new();
        for d in 0..48 {
            for eye in [Eye::Left, Eye::Right] {
                let s = 1.0 - 0.01 * night as f64 * f64::from(d % 3);
                let mut p = profile_with(WALL, d, eye, scaled([s; 3]), n.black, n.usage);
                p.flat_field = Some(lumiwall_profiles::FlatField {
                    width: 64,
                    height: 32,
                    gain: (0..64 * 32)
                        .map(|i| {
                            let g = 0.6 + 0.4 * ((i % 64) as f32 / 63.0);
                            [g, g * 0.99, g * 0.98]
                        })
                        .collect(),
                });
                profiles.push(p);
            }
        }
        store.record(&nightly_run(n), &profiles).unwrap();
    }
    let latest = store.latest(WALL).unwrap();
    assert_eq!(latest.len(), 96);
    let drift = store.drift_wall(WALL, None).unwrap();
    assert_eq!(drift.len(), 96);
    // Display 2 (d % 3 = 2) lost 4 % over the three nights, display 0 nothing.
    let d2 = drift.iter().find(|d| d.display.display == 2).unwrap();
    assert!(close(d2.white_luminance_change_pct.unwrap(), -4.0, 1e-9));
    let d0 = drift.iter().find(|d| d.display.display == 0).unwrap();
    assert_eq!(d0.white_luminance_change_pct, Some(0.0));
    let elapsed = start.elapsed();
    eprintln!("3 runs × 96 profiles recorded, latest and drift read: {elapsed:?}");
    let size = std::fs::metadata(&path).unwrap().len()
        + std::fs::metadata(dir.path().join("heyewall.lumistore-wal"))
            .map(|m| m.len())
            .unwrap_or(0);
    eprintln!("store size {:.1} MB", size as f64 / 1e6);
}
