//! The store's SQLite schema, how a file is recognised as a lumiwall store, and the
//! migrations that bring an older store up to date.
//!
//! Rule: the schema version only grows. Every change to tables, columns or to how
//! stored profile JSON must be read is a new entry at the end of [`MIGRATIONS`]; an
//! entry is never edited once released. A store whose version is newer than
//! [`SCHEMA_VERSION`] is refused without being touched.

use std::path::Path;
use std::time::{Duration, Instant};

use rusqlite::{Connection, ErrorCode, OptionalExtension, TransactionBehavior};

use super::StoreError;
use super::sql_err;

/// `PRAGMA application_id` of a lumiwall profile store: ASCII "LUMI".
pub const APPLICATION_ID: i32 = 0x4C55_4D49;

/// Name of the table that records which migrations were applied.
pub const VERSION_TABLE: &str = "lumiwall_schema";

/// The version table itself: one row per applied migration. Created before the
/// first migration and never changed (a store at version 0 has only this table).
pub const VERSION_TABLE_SQL: &str = "CREATE TABLE IF NOT EXISTS lumiwall_schema (
         version     INTEGER PRIMARY KEY,
         applied_utc TEXT NOT NULL
     );";

/// SQL of each migration; entry `i` takes the store from version `i` to `i + 1`.
pub const MIGRATIONS: &[&str] = &[
    // 1: runs and their profiles.
    "CREATE TABLE runs (
         id               INTEGER PRIMARY KEY,
         wall             TEXT NOT NULL,
         started_utc      TEXT NOT NULL,
         started_unix_ms  INTEGER NOT NULL,
         source           TEXT NOT NULL,
         note             TEXT NOT NULL,
         lumiwall_version TEXT NOT NULL
     );
     CREATE UNIQUE INDEX runs_by_wall_time ON runs (wall, started_unix_ms);
     CREATE TABLE profiles (
         run_id         INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
         display        INTEGER NOT NULL CHECK (display >= 0),
         eye            TEXT NOT NULL CHECK (eye IN ('mono', 'left', 'right')),
         tile_col       INTEGER NOT NULL,
         tile_row       INTEGER NOT NULL,
         format_version INTEGER NOT NULL,
         created_utc    TEXT NOT NULL,
         document       BLOB NOT NULL,
         PRIMARY KEY (run_id, display, eye)
     );
     CREATE INDEX profiles_by_display ON profiles (display, eye);",
    // 2: a nightly check's readings where no profile was rewritten (for the forecast).
    "CREATE TABLE lamp_readings (
         wall             TEXT NOT NULL,
         measured_utc     TEXT NOT NULL,
         measured_unix_ms INTEGER NOT NULL,
         display          INTEGER NOT NULL CHECK (display >= 0),
         eye              TEXT NOT NULL CHECK (eye IN ('mono', 'left', 'right')),
         tile_col         INTEGER NOT NULL,
         tile_row         INTEGER NOT NULL,
         red_cd_m2        REAL NOT NULL,
         green_cd_m2      REAL NOT NULL,
         blue_cd_m2       REAL NOT NULL,
         usage_red        REAL NOT NULL,
         usage_green      REAL NOT NULL,
         usage_blue       REAL NOT NULL,
         headroom         REAL NOT NULL,
         source           TEXT NOT NULL,
         PRIMARY KEY (wall, measured_unix_ms, display, eye)
     );
     CREATE INDEX lamp_readings_by_display ON lamp_readings (wall, display);",
];

/// Newest schema version this build knows.
pub const SCHEMA_VERSION: u32 = MIGRATIONS.len() as u32;

/// What an opened file turned out to be.
enum Found {
    /// No tables at all: a new store.
    Empty,
    /// A lumiwall store of this schema version.
    Store(u32),
}

/// Recognises the file without writing to it.
fn inspect(conn: &Connection, path: &Path) -> Result<Found, StoreError> {
    let app_id: i32 = conn
        .query_row("PRAGMA application_id", [], |r| r.get(0))
        .map_err(|e| sql_err(path, "reading the file header", e))?;
    let mut stmt = conn
        .prepare(
            "SELECT name FROM sqlite_master WHERE type = 'table' \
             AND name NOT LIKE 'sqlite_%' ORDER BY name",
        )
        .map_err(|e| sql_err(path, "listing tables", e))?;
    let tables = stmt
        .query_map([], |r| r.get::<_, String>(0))
        .and_then(|rows| rows.collect::<Result<Vec<_>, _>>())
        .map_err(|e| sql_err(path, "listing tables", e))?;
    if app_id != 0 && app_id != APPLICATION_ID {
        return Err(StoreError::Foreign {
            path: path.to_path_buf(),
            detail: format!("its application id is {app_id:#010x}, not lumiwall's"),
        });
    }
    if tables.is_empty() {
        return Ok(Found::Empty);
    }
    if !tables.iter().any(|t| t == VERSION_TABLE) {
        let mut shown = tables
            .iter()
            .take(5)
            .cloned()
            .collect::<Vec<_>>()
            .join(", ");
        if tables.len() > 5 {
            shown.push_str(", …");
        }
        return Err(StoreError::Foreign {
            path: path.to_path_buf(),
            detail: format!("it has tables {shown} and no {VERSION_TABLE} table"),
        });
    }
    let version: Option<i64> = conn
        .query_row("SELECT MAX(version) FROM lumiwall_schema", [], |r| r.get(0))
        .optional()
        .map_err(|e| sql_err(path, "reading the schema version", e))?
        .flatten();
    let version = version.unwrap_or(0);
    let version = u32::try_from(version).map_err(|_| StoreError::BadRow {
        path: path.to_path_buf(),
        what: format!("schema version {version} is not a valid version number"),
    })?;
    Ok(Found::Store(version))
}

/// The schema version of the file (0 when empty), refused when newer than this build's.
fn readable_version(conn: &Connection, path: &Path) -> Result<u32, StoreError> {
    let current = match inspect(conn, path)? {
        Found::Empty => 0,
        Found::Store(v) => v,
    };
    if current > SCHEMA_VERSION {
        return Err(StoreError::NewerSchema {
            path: path.to_path_buf(),
            found: current,
            supported: SCHEMA_VERSION,
        });
    }
    Ok(current)
}

/// Switches the file to WAL mode. Connections switching a new file at once can meet in
/// SQLite's deadlock avoidance (each holds a shared lock and wants the exclusive one):
/// SQLite then answers BUSY at once, without calling the busy handler. So a busy answer
/// is retried, with a growing pause, until the store's busy timeout has passed.
fn switch_to_wal(conn: &Connection, path: &Path) -> Result<(), StoreError> {
    let deadline = Instant::now() + super::BUSY_TIMEOUT;
    let mut pause = Duration::from_millis(2);
    loop {
        match conn.query_row("PRAGMA journal_mode = WAL", [], |r| r.get::<_, String>(0)) {
            Ok(_) => return Ok(()),
            Err(e)
                if matches!(
                    e.sqlite_error_code(),
                    Some(ErrorCode::DatabaseBusy | ErrorCode::DatabaseLocked)
                ) && Instant::now() < deadline =>
            {
                std::thread::sleep(pause);
                pause = (pause * 2).min(Duration::from_millis(50));
            }
            Err(e) => return Err(sql_err(path, "switching to WAL mode", e)),
        }
    }
}

/// Checks the file, refuses foreign or newer stores, and migrates an older or new
/// one to [`SCHEMA_VERSION`] in one transaction.
pub fn prepare(conn: &mut Connection, path: &Path) -> Result<(), StoreError> {
    let current = readable_version(conn, path)?;
    // Only now that the file is known to be ours (or empty) may it be changed.
    switch_to_wal(conn, path)?;
    conn.pragma_update(None, "foreign_keys", true)
        .map_err(|e| sql_err(path, "enabling foreign keys", e))?;
    if current == SCHEMA_VERSION {
        return Ok(());
    }
    let tx = conn
        .transaction_with_behavior(TransactionBehavior::Immediate)
        .map_err(|e| sql_err(path, "starting the schema migration", e))?;
    // Another process may have migrated between the check and the lock: look again.
    let current = readable_version(&tx, path)?;
    tx.execute_batch(VERSION_TABLE_SQL)
        .map_err(|e| sql_err(path, "creating the schema version table", e))?;
    let now = jiff::Timestamp::now().to_string();
    for (i, sql) in MIGRATIONS.iter().enumerate().skip(current as usize) {
        let version = i as u32 + 1;
        tx.execute_batch(sql)
            .map_err(|e| sql_err(path, "migrating the schema", e))?;
        tx.execute(
            "INSERT INTO lumiwall_schema (version, applied_utc) VALUES (?1, ?2)",
            rusqlite::params![version, now],
        )
        .map_err(|e| sql_err(path, "recording the schema version", e))?;
    }
    tx.pragma_update(None, "application_id", APPLICATION_ID)
        .map_err(|e| sql_err(path, "marking the file as a lumiwall store", e))?;
    tx.commit()
        .map_err(|e| sql_err(path, "committing the schema migration", e))
}
