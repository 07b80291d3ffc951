//! The profile store: every commissioning or nightly run of a wall, with the
//! profiles it produced, in one SQLite file (WAL mode, busy timeout), so that the
//! current profiles, a display's history and its drift can be asked for.
//!
//! A run is recorded in one transaction: either the run and all its profiles are
//! stored, or nothing is. Profiles are stored as their JSON document (the file format
//! of `FORMAT.md`, compact and zlib-compressed, see [`document`]) and validated again
//! when read back. The schema is versioned
//! (table `lumiwall_schema`, see [`schema`]); a store written by a newer lumiwall, a
//! foreign SQLite file or a damaged file is refused with a [`StoreError`] that says
//! what to do, and never changed.
//!
//! ```no_run
//! # use lumiwall_profiles::store::{ProfileStore, CommissionRun, parse_time};
//! # fn demo(profiles: &[lumiwall_profiles::DisplayProfile]) -> Result<(), Box<dyn std::error::Error>> {
//! let mut store = ProfileStore::open("wall.lumistore".as_ref())?;
//! let run = CommissionRun::new("hall-a", parse_time("2026-11-20T02:00:00Z")?);
//! store.record(&run, profiles)?;
//! let now = store.latest("hall-a")?;
//! let drift = store.drift_wall("hall-a", Some(parse_time("2026-11-01")?))?;
//! # Ok(()) }
//! ```

pub mod document;
pub mod drift;
pub mod error;
pub mod forecast;
mod lamp;
pub mod schema;

use std::collections::HashSet;
use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Duration;

pub use jiff::Timestamp;
use rusqlite::{Connection, ErrorCode, OpenFlags, OptionalExtension, params};

pub use drift::{Drift, DriftLimits};
pub use error::StoreError;
pub use forecast::{
    ChannelForecast, Crossing, DecayLaw, DisplayForecast, ForecastOptions, LampReading,
};

use crate::{DisplayProfile, Eye, ProfileError};

/// How long a store call waits for another process's lock before giving up.
pub const BUSY_TIMEOUT: Duration = Duration::from_secs(10);

/// Maps an SQLite error to the store's error, naming what the store was doing.
pub(crate) fn sql_err(path: &Path, action: &'static str, e: rusqlite::Error) -> StoreError {
    sql_err_after(path, BUSY_TIMEOUT, action, e)
}

/// [`sql_err`] for a connection whose busy timeout is `busy`.
fn sql_err_after(
    path: &Path,
    busy: Duration,
    action: &'static str,
    e: rusqlite::Error,
) -> StoreError {
    match e.sqlite_error_code() {
        Some(ErrorCode::NotADatabase | ErrorCode::DatabaseCorrupt) => StoreError::NotADatabase {
            path: path.to_path_buf(),
            detail: e.to_string(),
        },
        Some(ErrorCode::DatabaseBusy | ErrorCode::DatabaseLocked) => StoreError::Busy {
            path: path.to_path_buf(),
            action,
            waited_s: busy.as_secs_f64(),
        },
        _ => StoreError::Sqlite {
            path: path.to_path_buf(),
            action,
            source: Box::new(e),
        },
    }
}

/// Reads a user's time: an RFC 3339 time (`2026-11-20T02:00:00Z`,
/// `2026-11-20T03:00:00+01:00`) or a date (`2026-11-20`, taken as 00:00 UTC).
pub fn parse_time(text: &str) -> Result<Timestamp, StoreError> {
    let text = text.trim();
    let bad = |message: String| StoreError::BadTime {
        text: text.to_string(),
        message,
    };
    match text.parse::<Timestamp>() {
        Ok(t) => Ok(t),
        Err(e_ts) => {
            let date = text
                .parse::<jiff::civil::Date>()
                .map_err(|_| bad(e_ts.to_string()))?;
            jiff::tz::TimeZone::UTC
                .to_timestamp(date.to_datetime(jiff::civil::Time::midnight()))
                .map_err(|e| bad(e.to_string()))
        }
    }
}

/// Identifier of a recorded run inside one store.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RunId(pub i64);

impl fmt::Display for RunId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// One commissioning or nightly run of a wall, as recorded with its profiles.
#[derive(Debug, Clone, PartialEq)]
pub struct CommissionRun {
    /// Wall name; every profile of the run must belong to this wall.
    pub wall: String,
    /// When the run measured the wall (UTC).
    pub started_utc: Timestamp,
    /// What made the run: `commission`, `nightly`, `import`, …
    pub source: String,
    /// Free text for the technician (service done, lamp changed, …).
    pub note: String,
}

impl CommissionRun {
    /// A `commission` run of `wall` at `started_utc`, without a note.
    pub fn new(wall: impl Into<String>, started_utc: Timestamp) -> Self {
        Self {
            wall: wall.into(),
            started_utc,
            source: "commission".into(),
            note: String::new(),
        }
    }
}

/// A run as listed by [`ProfileStore::runs`].
#[derive(Debug, Clone, PartialEq)]
pub struct RunInfo {
    /// Store identifier.
    pub id: RunId,
    /// The run as recorded.
    pub run: CommissionRun,
    /// Version of lumiwall that recorded it.
    pub lumiwall_version: String,
    /// Number of profiles (displays × eyes) in the run.
    pub profiles: usize,
}

/// A wall as listed by [`ProfileStore::walls`].
#[derive(Debug, Clone, PartialEq)]
pub struct WallInfo {
    /// Wall name.
    pub wall: String,
    /// Number of recorded runs.
    pub runs: usize,
    /// Time of the first run.
    pub first_utc: Timestamp,
    /// Time of the latest run.
    pub last_utc: Timestamp,
}

/// One profile row read back from the store.
struct Row {
    run: i64,
    utc: String,
    display: u32,
    eye: String,
    document: Vec<u8>,
}

const ROW_COLUMNS: &str = "p.run_id, r.started_utc, p.display, p.eye, p.document";

fn read_row(r: &rusqlite::Row<'_>) -> rusqlite::Result<Row> {
    Ok(Row {
        run: r.get(0)?,
        utc: r.get(1)?,
        display: r.get(2)?,
        eye: r.get(3)?,
        document: r.get(4)?,
    })
}

fn eye_text(eye: Eye) -> &'static str {
    match eye {
        Eye::Mono => "mono",
        Eye::Left => "left",
        Eye::Right => "right",
    }
}

/// Maps an SQLite error of the named action to the store's error.
type SqlErr<'a> = &'a dyn Fn(&'static str, rusqlite::Error) -> StoreError;

/// Checks a run and its profiles and returns each profile's compressed document, in
/// order. Every document is read back as `latest`/`history` will: this catches values
/// `validate` does not check and JSON cannot hold (a NaN is written as `null`), so the
/// store never holds an unreadable row.
fn documents_of_run(
    run: &CommissionRun,
    profiles: &[DisplayProfile],
) -> Result<Vec<Vec<u8>>, StoreError> {
    if run.wall.trim().is_empty() {
        return Err(StoreError::InvalidRun("the run has no wall name".into()));
    }
    if profiles.is_empty() {
        return Err(StoreError::InvalidRun(format!(
            "the run of wall {} holds no profile",
            run.wall
        )));
    }
    let mut seen = HashSet::new();
    let mut documents = Vec::with_capacity(profiles.len());
    for p in profiles {
        documents.push(document_of(p)?);
        if p.display.wall != run.wall {
            return Err(StoreError::InvalidRun(format!(
                "profile of {} belongs to wall {:?}, the run is of wall {:?}",
                p.display, p.display.wall, run.wall
            )));
        }
        if !seen.insert((p.display.display, p.display.eye)) {
            return Err(StoreError::InvalidRun(format!(
                "the run holds two profiles of display {} ({})",
                p.display.display, p.display.eye
            )));
        }
    }
    Ok(documents)
}

/// One profile validated, written as its compact document, read back and compressed.
fn document_of(p: &DisplayProfile) -> Result<Vec<u8>, StoreError> {
    let invalid = |e| StoreError::InvalidProfile(Box::new(e));
    p.validate().map_err(invalid)?;
    let origin = PathBuf::from(format!("{} (being recorded)", p.display.file_stem()));
    let json = document::compact_json(p).map_err(|e| {
        invalid(ProfileError::Parse {
            path: origin.clone(),
            message: e.to_string(),
        })
    })?;
    DisplayProfile::from_json(&json, &origin).map_err(invalid)?;
    document::compress(&json).map_err(|e| {
        StoreError::InvalidRun(format!("cannot compress the profile of {}: {e}", p.display))
    })
}

/// Refuses a second run of the same wall at the same time.
fn refuse_same_run(
    tx: &rusqlite::Transaction<'_>,
    run: &CommissionRun,
    e: SqlErr<'_>,
) -> Result<(), StoreError> {
    let existing: Option<i64> = tx
        .query_row(
            "SELECT id FROM runs WHERE wall = ?1 AND started_unix_ms = ?2",
            params![run.wall, run.started_utc.as_millisecond()],
            |r| r.get(0),
        )
        .optional()
        .map_err(|err| e("looking for the same run", err))?;
    match existing {
        Some(existing) => Err(StoreError::DuplicateRun {
            wall: run.wall.clone(),
            time: run.started_utc.to_string(),
            existing,
        }),
        None => Ok(()),
    }
}

/// Inserts the run's row and returns its id.
fn insert_run(tx: &rusqlite::Transaction<'_>, run: &CommissionRun) -> rusqlite::Result<i64> {
    tx.execute(
        "INSERT INTO runs (wall, started_utc, started_unix_ms, source, note, lumiwall_version)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
        params![
            run.wall,
            run.started_utc.to_string(),
            run.started_utc.as_millisecond(),
            run.source,
            run.note,
            env!("CARGO_PKG_VERSION"),
        ],
    )?;
    Ok(tx.last_insert_rowid())
}

/// Inserts one row per profile of run `id`, with its compressed document.
fn insert_profiles(
    tx: &rusqlite::Transaction<'_>,
    id: i64,
    profiles: &[DisplayProfile],
    documents: &[Vec<u8>],
    e: SqlErr<'_>,
) -> Result<(), StoreError> {
    let mut stmt = tx
        .prepare(
            "INSERT INTO profiles
             (run_id, display, eye, tile_col, tile_row, format_version, created_utc, document)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
        )
        .map_err(|err| e("preparing the profile insert", err))?;
    for (p, blob) in profiles.iter().zip(documents) {
        stmt.execute(params![
            id,
            p.display.display,
            eye_text(p.display.eye),
            p.display.tile_col,
            p.display.tile_row,
            p.format_version,
            p.created_utc,
            blob,
        ])
        .map_err(|err| e("recording a profile", err))?;
    }
    Ok(())
}

/// The SQLite profile store. One value per open connection; several processes may
/// open the same file (WAL mode lets readers run beside one writer).
#[derive(Debug)]
pub struct ProfileStore {
    conn: Connection,
    path: PathBuf,
    busy_timeout: Duration,
}

impl ProfileStore {
    /// Opens the store at `path`, creating it if no file is there, and migrates an
    /// older schema. Refuses foreign, damaged or newer-schema files without changing them.
    pub fn open(path: &Path) -> Result<Self, StoreError> {
        let conn = Connection::open(path).map_err(|source| StoreError::Open {
            path: path.to_path_buf(),
            source: Box::new(source),
        })?;
        Self::prepare(conn, path.to_path_buf())
    }

    /// Like [`open`](Self::open), but a missing file is an error instead of a new store
    /// (for commands that only read, so a mistyped path is not silently created).
    pub fn open_existing(path: &Path) -> Result<Self, StoreError> {
        if !path.is_file() {
            return Err(StoreError::Missing {
                path: path.to_path_buf(),
            });
        }
        let flags = OpenFlags::SQLITE_OPEN_READ_WRITE
            | OpenFlags::SQLITE_OPEN_URI
            | OpenFlags::SQLITE_OPEN_NO_MUTEX;
        let conn = Connection::open_with_flags(path, flags).map_err(|source| StoreError::Open {
            path: path.to_path_buf(),
            source: Box::new(source),
        })?;
        Self::prepare(conn, path.to_path_buf())
    }

    /// A new, empty store that lives in memory (tests, dry runs).
    pub fn open_in_memory() -> Result<Self, StoreError> {
        let path = PathBuf::from(":memory:");
        let conn = Connection::open_in_memory().map_err(|source| StoreError::Open {
            path: path.clone(),
            source: Box::new(source),
        })?;
        Self::prepare(conn, path)
    }

    fn prepare(mut conn: Connection, path: PathBuf) -> Result<Self, StoreError> {
        conn.busy_timeout(BUSY_TIMEOUT)
            .map_err(|e| sql_err(&path, "setting the busy timeout", e))?;
        schema::prepare(&mut conn, &path)?;
        Ok(Self {
            conn,
            path,
            busy_timeout: BUSY_TIMEOUT,
        })
    }

    /// Changes how long calls wait for another process's lock (default [`BUSY_TIMEOUT`]).
    pub fn set_busy_timeout(&mut self, timeout: Duration) -> Result<(), StoreError> {
        self.conn
            .busy_timeout(timeout)
            .map_err(|e| self.err("setting the busy timeout", e))?;
        self.busy_timeout = timeout;
        Ok(())
    }

    /// The store's file (`:memory:` for an in-memory store).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Schema version of the open store (always [`schema::SCHEMA_VERSION`] once open).
    pub fn schema_version(&self) -> Result<u32, StoreError> {
        let v: i64 = self
            .conn
            .query_row("SELECT MAX(version) FROM lumiwall_schema", [], |r| r.get(0))
            .map_err(|e| self.err("reading the schema version", e))?;
        u32::try_from(v).map_err(|_| self.bad(format!("schema version {v} is not valid")))
    }

    fn err(&self, action: &'static str, e: rusqlite::Error) -> StoreError {
        sql_err_after(&self.path, self.busy_timeout, action, e)
    }

    fn bad(&self, what: String) -> StoreError {
        StoreError::BadRow {
            path: self.path.clone(),
            what,
        }
    }

    /// Records a run and all its profiles in one transaction and returns its id.
    /// Every profile is validated first; nothing is written if any check or any
    /// write fails.
    pub fn record(
        &mut self,
        run: &CommissionRun,
        profiles: &[DisplayProfile],
    ) -> Result<RunId, StoreError> {
        let documents = documents_of_run(run, profiles)?;
        let (path, busy) = (self.path.clone(), self.busy_timeout);
        let e = |action, err| sql_err_after(&path, busy, action, err);
        let tx = self
            .conn
            .transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)
            .map_err(|err| e("starting the transaction", err))?;
        refuse_same_run(&tx, run, &e)?;
        let id = insert_run(&tx, run).map_err(|err| e("recording the run", err))?;
        insert_profiles(&tx, id, profiles, &documents, &e)?;
        tx.commit().map_err(|err| e("committing the run", err))?;
        Ok(RunId(id))
    }

    fn parse_row(&self, wall: &str, row: Row) -> Result<(Timestamp, DisplayProfile), StoreError> {
        let t = row.utc.parse::<Timestamp>().map_err(|e| {
            self.bad(format!(
                "run {} has an unreadable time {:?}: {e}",
                row.run, row.utc
            ))
        })?;
        let origin = PathBuf::from(format!(
            "{}#run{}/d{:03}-{}",
            self.path.display(),
            row.run,
            row.display,
            row.eye
        ));
        let stored = |source: ProfileError| StoreError::StoredProfile {
            path: self.path.clone(),
            run: row.run,
            wall: wall.to_string(),
            display: row.display,
            eye: row.eye.clone(),
            source: Box::new(source),
        };
        let json = document::decompress(&row.document).map_err(|e| {
            self.bad(format!(
                "run {} profile of display {} ({}) of wall {wall} does not decompress: {e}",
                row.run, row.display, row.eye
            ))
        })?;
        let p = DisplayProfile::from_json(&json, &origin).map_err(stored)?;
        if p.display.wall != wall
            || p.display.display != row.display
            || eye_text(p.display.eye) != row.eye
        {
            return Err(self.bad(format!(
                "run {} row for display {} ({}) of wall {wall} holds the profile of {}",
                row.run, row.display, row.eye, p.display
            )));
        }
        Ok((t, p))
    }

    /// Runs `sql` with `params` and maps every row; errors name `action`.
    fn query_all<T>(
        &self,
        action: &'static str,
        sql: &str,
        params: impl rusqlite::Params,
        map: impl FnMut(&rusqlite::Row<'_>) -> rusqlite::Result<T>,
    ) -> Result<Vec<T>, StoreError> {
        let mut stmt = self.conn.prepare(sql).map_err(|e| self.err(action, e))?;
        stmt.query_map(params, map)
            .and_then(|rows| rows.collect::<Result<Vec<_>, _>>())
            .map_err(|e| self.err(action, e))
    }

    fn query_rows(
        &self,
        wall: &str,
        action: &'static str,
        sql: &str,
        params: &[&dyn rusqlite::ToSql],
    ) -> Result<Vec<(Timestamp, DisplayProfile)>, StoreError> {
        let rows = self.query_all(action, sql, params, read_row)?;
        rows.into_iter().map(|r| self.parse_row(wall, r)).collect()
    }

    /// The newest profile of every display and eye of `wall`, in display order. A
    /// display missing from the latest run keeps its newest earlier profile.
    pub fn latest(&self, wall: &str) -> Result<Vec<DisplayProfile>, StoreError> {
        let sql = format!(
            "SELECT run_id, started_utc, display, eye, document FROM (
                 SELECT {ROW_COLUMNS}, ROW_NUMBER() OVER (
                     PARTITION BY p.display, p.eye
                     ORDER BY r.started_unix_ms DESC, r.id DESC) AS rn
                 FROM profiles p JOIN runs r ON r.id = p.run_id
                 WHERE r.wall = ?1)
             WHERE rn = 1"
        );
        let mut out: Vec<DisplayProfile> = self
            .query_rows(wall, "reading the latest profiles", &sql, &[&wall])?
            .into_iter()
            .map(|(_, p)| p)
            .collect();
        out.sort_by(|a, b| a.display.cmp(&b.display));
        Ok(out)
    }

    /// Every stored profile of projector `display` of `wall` (all its eyes), oldest
    /// first, each with the time of the run that measured it.
    pub fn history(
        &self,
        wall: &str,
        display: u32,
    ) -> Result<Vec<(Timestamp, DisplayProfile)>, StoreError> {
        let sql = format!(
            "SELECT {ROW_COLUMNS} FROM profiles p JOIN runs r ON r.id = p.run_id
             WHERE r.wall = ?1 AND p.display = ?2
             ORDER BY r.started_unix_ms, r.id,
                      CASE p.eye WHEN 'mono' THEN 0 WHEN 'left' THEN 1 ELSE 2 END"
        );
        self.query_rows(
            wall,
            "reading a display's history",
            &sql,
            &[&wall, &display],
        )
    }

    /// Displays and eyes of `wall` with at least one profile at or after `since`.
    pub fn displays(
        &self,
        wall: &str,
        since: Option<Timestamp>,
    ) -> Result<Vec<(u32, Eye)>, StoreError> {
        let since_ms = since.map_or(i64::MIN, |t| t.as_millisecond());
        let rows = self.query_all(
            "listing displays",
            "SELECT DISTINCT p.display, p.eye FROM profiles p JOIN runs r ON r.id = p.run_id
             WHERE r.wall = ?1 AND r.started_unix_ms >= ?2",
            params![wall, since_ms],
            |r| Ok((r.get::<_, u32>(0)?, r.get::<_, String>(1)?)),
        )?;
        let mut out = rows
            .into_iter()
            .map(|(d, eye)| {
                let eye = match eye.as_str() {
                    "mono" => Eye::Mono,
                    "left" => Eye::Left,
                    "right" => Eye::Right,
                    other => return Err(self.bad(format!("display {d} has unknown eye {other:?}"))),
                };
                Ok((d, eye))
            })
            .collect::<Result<Vec<_>, _>>()?;
        out.sort();
        Ok(out)
    }

    /// Drift of one display and eye: its earliest profile at or after `since` (the
    /// earliest of all if `since` is `None`) against its newest profile.
    pub fn drift(
        &self,
        wall: &str,
        display: u32,
        eye: Eye,
        since: Option<Timestamp>,
    ) -> Result<Drift, StoreError> {
        let since_ms = since.map_or(i64::MIN, |t| t.as_millisecond());
        let eye_s = eye_text(eye);
        let base = format!(
            "SELECT {ROW_COLUMNS} FROM profiles p JOIN runs r ON r.id = p.run_id
             WHERE r.wall = ?1 AND p.display = ?2 AND p.eye = ?3 AND r.started_unix_ms >= ?4"
        );
        let pick = |order: &str| -> Result<Option<(Timestamp, DisplayProfile)>, StoreError> {
            let sql = format!("{base} ORDER BY r.started_unix_ms {order}, r.id {order} LIMIT 1");
            let row = self
                .conn
                .query_row(&sql, params![wall, display, eye_s, since_ms], read_row)
                .optional()
                .map_err(|e| self.err("reading a display's drift", e))?;
            row.map(|r| self.parse_row(wall, r)).transpose()
        };
        let (Some(first), Some(last)) = (pick("ASC")?, pick("DESC")?) else {
            return Err(StoreError::NoHistory {
                path: self.path.clone(),
                wall: wall.to_string(),
                display,
                eye,
                window: since.map_or(String::new(), |t| format!(" since {t}")),
            });
        };
        let count: i64 = self
            .conn
            .query_row(
                "SELECT COUNT(*) FROM profiles p JOIN runs r ON r.id = p.run_id
                 WHERE r.wall = ?1 AND p.display = ?2 AND p.eye = ?3 AND r.started_unix_ms >= ?4",
                params![wall, display, eye_s, since_ms],
                |r| r.get(0),
            )
            .map_err(|e| self.err("counting a display's profiles", e))?;
        Ok(Drift::between(
            &first.1,
            first.0,
            &last.1,
            last.0,
            usize::try_from(count).unwrap_or(0),
        ))
    }

    /// [`drift`](Self::drift) of every display and eye of `wall` that has a profile
    /// at or after `since`, in display order.
    pub fn drift_wall(
        &self,
        wall: &str,
        since: Option<Timestamp>,
    ) -> Result<Vec<Drift>, StoreError> {
        self.displays(wall, since)?
            .into_iter()
            .map(|(d, eye)| self.drift(wall, d, eye, since))
            .collect()
    }

    /// The projector numbers of `wall` that have profiles (each once, whatever its
    /// eyes), in order.
    pub fn display_numbers(&self, wall: &str) -> Result<Vec<u32>, StoreError> {
        let mut numbers: Vec<u32> = self
            .displays(wall, None)?
            .into_iter()
            .map(|(d, _)| d)
            .collect();
        numbers.dedup();
        Ok(numbers)
    }

    /// Lamp-life forecast of every display and eye of `wall` from its whole history,
    /// the profiles and the lamp readings of nightly checks (see [`forecast`]), in
    /// display order.
    pub fn forecast_wall(
        &self,
        wall: &str,
        opts: &ForecastOptions,
    ) -> Result<Vec<DisplayForecast>, StoreError> {
        let mut out = Vec::new();
        for d in self.display_numbers(wall)? {
            out.extend(forecast::forecast_readings(
                &self.lamp_readings(wall, d)?,
                opts,
            ));
        }
        Ok(out)
    }

    /// Every wall in the store, by name.
    pub fn walls(&self) -> Result<Vec<WallInfo>, StoreError> {
        let rows = self.query_all(
            "listing walls",
            "SELECT wall, COUNT(*), MIN(started_unix_ms), MAX(started_unix_ms)
             FROM runs GROUP BY wall ORDER BY wall",
            [],
            |r| {
                Ok((
                    r.get::<_, String>(0)?,
                    r.get::<_, i64>(1)?,
                    r.get::<_, i64>(2)?,
                    r.get::<_, i64>(3)?,
                ))
            },
        )?;
        rows.into_iter()
            .map(|(wall, runs, first, last)| {
                let t = |ms: i64| {
                    Timestamp::from_millisecond(ms)
                        .map_err(|e| self.bad(format!("wall {wall} has a run time {ms} ms: {e}")))
                };
                Ok(WallInfo {
                    runs: usize::try_from(runs).unwrap_or(0),
                    first_utc: t(first)?,
                    last_utc: t(last)?,
                    wall,
                })
            })
            .collect()
    }

    /// Every run of `wall`, oldest first.
    pub fn runs(&self, wall: &str) -> Result<Vec<RunInfo>, StoreError> {
        let rows = self.query_all(
            "listing runs",
            "SELECT r.id, r.started_utc, r.source, r.note, r.lumiwall_version,
                    (SELECT COUNT(*) FROM profiles p WHERE p.run_id = r.id)
             FROM runs r WHERE r.wall = ?1 ORDER BY r.started_unix_ms, r.id",
            [wall],
            |r| {
                Ok((
                    r.get::<_, i64>(0)?,
                    r.get::<_, String>(1)?,
                    r.get::<_, String>(2)?,
                    r.get::<_, String>(3)?,
                    r.get::<_, String>(4)?,
                    r.get::<_, i64>(5)?,
                ))
            },
        )?;
        rows.into_iter()
            .map(|(id, utc, source, note, version, n)| {
                let started_utc = utc.parse::<Timestamp>().map_err(|e| {
                    self.bad(format!("run {id} has an unreadable time {utc:?}: {e}"))
                })?;
                Ok(RunInfo {
                    id: RunId(id),
                    run: CommissionRun {
                        wall: wall.to_string(),
                        started_utc,
                        source,
                        note,
                    },
                    lumiwall_version: version,
                    profiles: usize::try_from(n).unwrap_or(0),
                })
            })
            .collect()
    }
}
