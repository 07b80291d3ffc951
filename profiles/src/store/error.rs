//! Errors of the profile store, each with a message that says what to do.

use std::path::PathBuf;

use crate::{Eye, ProfileError};

/// Everything that can go wrong opening, reading or writing the profile store.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// `open_existing` was asked for a store file that is not there.
    #[error(
        "profile store {path} does not exist; check --store, or record a run first \
         (`lumiwall profiles import --store {path} --dir PROFILE_DIR`)"
    )]
    Missing {
        /// Store file asked for.
        path: PathBuf,
    },
    /// SQLite could not open the file at all.
    #[error("cannot open profile store {path}: {source}; check the path and its permissions")]
    Open {
        /// Store file.
        path: PathBuf,
        /// SQLite's error.
        #[source]
        source: Box<rusqlite::Error>,
    },
    /// The file is not an SQLite database, or it is damaged.
    #[error(
        "{path} is not a readable SQLite database (not a database, or corrupt: {detail}); \
         point --store at a lumiwall profile store, or restore it from a backup \
         (a new store is created only where no file exists)"
    )]
    NotADatabase {
        /// Store file.
        path: PathBuf,
        /// SQLite's message.
        detail: String,
    },
    /// The file is an SQLite database of some other program.
    #[error(
        "{path} is an SQLite database but not a lumiwall profile store ({detail}); \
         lumiwall will not write into it: choose another --store path"
    )]
    Foreign {
        /// Store file.
        path: PathBuf,
        /// What gave it away (its tables, its application id).
        detail: String,
    },
    /// The store was written by a newer lumiwall with a schema this build does not know.
    #[error(
        "profile store {path} has schema version {found}, this lumiwall knows versions up to \
         {supported}; update lumiwall to read it (the store was not changed)"
    )]
    NewerSchema {
        /// Store file.
        path: PathBuf,
        /// Schema version found in the store.
        found: u32,
        /// Newest schema version this build knows.
        supported: u32,
    },
    /// Another process held the store locked for longer than the busy timeout.
    #[error(
        "profile store {path} is locked by another process (waited {waited_s} s while {action}); \
         wait for the other lumiwall (e.g. a running commission) to finish and retry"
    )]
    Busy {
        /// Store file.
        path: PathBuf,
        /// What the store was doing.
        action: &'static str,
        /// How long it waited, in seconds.
        waited_s: f64,
    },
    /// Any other SQLite failure.
    #[error("profile store {path}: {action} failed: {source}")]
    Sqlite {
        /// Store file.
        path: PathBuf,
        /// What the store was doing.
        action: &'static str,
        /// SQLite's error.
        #[source]
        source: Box<rusqlite::Error>,
    },
    /// A profile stored in the database no longer parses or validates.
    #[error(
        "profile store {path}: the stored profile of wall {wall} display {display} ({eye}) \
         in run {run} cannot be read: {source}; the store may have been edited by hand \
         or needs a migration by a newer lumiwall"
    )]
    StoredProfile {
        /// Store file.
        path: PathBuf,
        /// Run the profile belongs to.
        run: i64,
        /// Wall name.
        wall: String,
        /// Display index.
        display: u32,
        /// Eye.
        eye: String,
        /// Why it cannot be read.
        #[source]
        source: Box<ProfileError>,
    },
    /// A row of the store holds a value that cannot be right (edited by hand, damaged).
    #[error("profile store {path}: {what}; the store may have been edited by hand or damaged")]
    BadRow {
        /// Store file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// A profile handed to `record` failed validation; nothing was written.
    #[error("run not recorded, a profile is invalid: {0}")]
    InvalidProfile(#[source] Box<ProfileError>),
    /// A run handed to `record` is inconsistent; nothing was written.
    #[error("run not recorded: {0}")]
    InvalidRun(String),
    /// The wall already has a run at exactly this time (the same run recorded twice).
    #[error(
        "wall {wall} already has run {existing} at {time}; it is probably already recorded \
         (give another time if it really is a different run)"
    )]
    DuplicateRun {
        /// Wall name.
        wall: String,
        /// Time of the run, RFC 3339.
        time: String,
        /// Id of the run already stored.
        existing: i64,
    },
    /// A date or time given by the user could not be read.
    #[error(
        "cannot read time {text:?}: {message}; give a date (2026-11-20, midnight UTC) or an \
         RFC 3339 time (2026-11-20T02:00:00Z)"
    )]
    BadTime {
        /// What was given.
        text: String,
        /// Parser message.
        message: String,
    },
    /// There is no profile of the asked display in the asked time window.
    #[error(
        "profile store {path} holds no profile of wall {wall} display {display} ({eye}){window}; \
         list what is stored with `lumiwall profiles history`"
    )]
    NoHistory {
        /// Store file.
        path: PathBuf,
        /// Wall name.
        wall: String,
        /// Display index.
        display: u32,
        /// Eye.
        eye: Eye,
        /// " since `<time>`" or empty.
        window: String,
    },
}

impl From<StoreError> for ProfileError {
    fn from(e: StoreError) -> Self {
        ProfileError::Store(e.to_string())
    }
}
