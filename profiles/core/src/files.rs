//! Files written so that nothing is lost or half-written: [`write_atomic`] (temporary
//! file, sync, rename; temporaries of dead writers are cleaned up) and [`FolderLock`]
//! (one writer per output folder).

use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` through a temporary file `.NAME.tmp-PID` in the same
/// folder, synced, then renamed over `path`: a crash never leaves a half-written
/// `path`. On every failure (create, write, sync, rename) the temporary file is
/// removed again, so a full disk is not kept full by leftovers.
///
/// Before writing, temporary files that writers which are no longer running left in
/// the folder (`.*.tmp-PID` of a dead PID, see [`remove_stale_temp_files`]) are
/// removed: a kill -9 or a power cut between create and rename leaves one behind.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    if let Some(dir) = dir {
        std::fs::create_dir_all(dir)?;
    }
    // Best effort: a folder that cannot be listed still gets its file written.
    let _ = remove_stale_temp_files(dir.unwrap_or(Path::new(".")));
    let mut tmp: PathBuf = path.to_path_buf();
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "file".into());
    tmp.set_file_name(format!(".{name}{TEMP_MARK}{}", std::process::id()));
    let written = write_and_sync(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if let Err(e) = written {
        // Our own temporary name (a file, or a link, which is not followed); never a
        // folder that holds the name.
        if std::fs::symlink_metadata(&tmp).is_ok_and(|m| !m.is_dir()) {
            let _ = std::fs::remove_file(&tmp);
        }
        return Err(e);
    }
    Ok(())
}

/// What separates the file name from the writer's PID in a temporary file name.
const TEMP_MARK: &str = ".tmp-";

/// Creates (or truncates) `tmp`, writes `bytes` and syncs it to the disk.
fn write_and_sync(tmp: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::fs::File::create(tmp)?;
    f.write_all(bytes)?;
    f.sync_all()
}

/// The PID of the writer of a temporary file named by [`write_atomic`]
/// (`.NAME.tmp-PID`), or `None` for any other name.
fn temp_file_pid(file_name: &str) -> Option<u32> {
    let rest = file_name.strip_prefix('.')?;
    let (stem, pid) = rest.rsplit_once(TEMP_MARK)?;
    if stem.is_empty() || pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    pid.parse().ok()
}

/// How old a temporary file must be before it counts as stale (it may belong to a
/// writer in another PID namespace sharing the folder, whose PID we cannot see).
pub const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(60);

/// How old a temporary file must be to count as stale where the liveness of its
/// writer cannot be checked (no `/proc`).
pub const STALE_TEMP_AGE_UNCHECKED: std::time::Duration = std::time::Duration::from_secs(24 * 3600);

/// Whether process `pid` is known to have ended: `Some(true)` when it has (Linux,
/// through `/proc`), `Some(false)` when it runs, `None` when this cannot be told.
fn process_ended(pid: u32) -> Option<bool> {
    if !Path::new("/proc/self").exists() {
        return None;
    }
    Some(!Path::new("/proc").join(pid.to_string()).exists())
}

/// Removes the temporary files (`.NAME.tmp-PID`, regular files only) that
/// [`write_atomic`] left in `dir` when its writer died between creating and renaming
/// them: those whose writer process has ended (checked through `/proc`, Linux) and
/// that are older than [`STALE_TEMP_AGE`]; where process liveness cannot be
/// checked, those older than [`STALE_TEMP_AGE_UNCHECKED`]. Files of this process and
/// of running processes are kept. Returns the removed paths.
pub fn remove_stale_temp_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let me = std::process::id();
    let now = std::time::SystemTime::now();
    let mut removed = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let Ok(entry) = entry else { continue };
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(temp_file_pid) else {
            continue;
        };
        if pid == me {
            continue;
        }
        let Ok(meta) = std::fs::symlink_metadata(entry.path()) else {
            continue;
        };
        if !meta.is_file() {
            continue;
        }
        let age = meta
            .modified()
            .ok()
            .and_then(|m| now.duration_since(m).ok())
            .unwrap_or_default();
        let stale = match process_ended(pid) {
            Some(ended) => ended && age >= STALE_TEMP_AGE,
            None => age >= STALE_TEMP_AGE_UNCHECKED,
        };
        if stale && std::fs::remove_file(entry.path()).is_ok() {
            removed.push(entry.path());
        }
    }
    Ok(removed)
}

/// Name of the lock file [`FolderLock`] keeps in a folder.
pub const LOCK_FILE: &str = ".lumiwall.lock";

/// An exclusive advisory lock on an output folder, held until dropped: a second
/// lumiwall writing into the same folder fails at once with [`LockError::Busy`]
/// instead of mixing its files with the first one's. The lock is the operating
/// system's file lock on `FOLDER/.lumiwall.lock` (released by the kernel when the
/// process dies, so a kill -9 never leaves the folder locked); the file holds the
/// holder's PID and command for the message.
#[derive(Debug)]
pub struct FolderLock {
    file: std::fs::File,
    path: PathBuf,
}

/// Why an output folder could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process holds the lock.
    #[error(
        "{folder} is in use by another lumiwall ({holder}); wait for it to finish or choose \
         another output folder"
    )]
    Busy {
        /// The folder.
        folder: PathBuf,
        /// Who holds it, as written in the lock file (PID and command), if readable.
        holder: String,
    },
    /// The folder or its lock file cannot be created or locked.
    #[error("cannot lock output folder {folder}: {source}")]
    Io {
        /// The folder.
        folder: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl FolderLock {
    /// Creates `folder` if needed and locks it for this process, or fails at once when
    /// another process holds it. `what` names the holder in the other's message (e.g.
    /// `"commission"`).
    pub fn acquire(folder: &Path, what: &str) -> Result<FolderLock, LockError> {
        let io = |source| LockError::Io {
            folder: folder.to_path_buf(),
            source,
        };
        std::fs::create_dir_all(folder).map_err(io)?;
        let path = folder.join(LOCK_FILE);
        let mut file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .map_err(io)?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                return Err(LockError::Busy {
                    folder: folder.to_path_buf(),
                    holder: read_holder(&mut file),
                });
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(io(e)),
        }
        write_holder(&mut file, what).map_err(io)?;
        Ok(FolderLock { file, path })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        // Closing the file releases the lock as well; unlocking first makes it explicit.
        let _ = self.file.unlock();
    }
}

/// The holder written in a lock file, or a placeholder.
fn read_holder(file: &mut std::fs::File) -> String {
    use std::io::Read;
    let mut s = String::new();
    let _ = file.read_to_string(&mut s);
    let s = s.trim();
    if s.is_empty() {
        "holder unknown".into()
    } else {
        s.chars().take(200).collect()
    }
}

/// Replaces the lock file's content with this process's PID and command.
fn write_holder(file: &mut std::fs::File, what: &str) -> std::io::Result<()> {
    use std::io::{Seek, Write};
    file.set_len(0)?;
    file.seek(std::io::SeekFrom::Start(0))?;
    write!(file, "pid {}, {what}", std::process::id())?;
    file.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn second_lock_on_a_folder_is_busy_and_names_the_holder() {
        let dir = std::env::temp_dir().join(format!("lumiwall-lock-{}", std::process::id()));
        let first = FolderLock::acquire(&dir, "commission").unwrap();
        match FolderLock::acquire(&dir, "apply") {
            Err(LockError::Busy { holder, .. }) => {
                assert!(holder.contains("commission"), "{holder}");
                assert!(holder.contains(&std::process::id().to_string()), "{holder}");
            }
            other => panic!("expected Busy, got {other:?}"),
        }
        drop(first);
        let again = FolderLock::acquire(&dir, "apply");
        assert!(again.is_ok(), "{again:?}");
        drop(again);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn write_atomic_replaces_the_whole_file_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("lumiwall-atomic-{}", std::process::id()));
        let path = dir.join("a.txt");
        write_atomic(&path, b"first version, longer").unwrap();
        write_atomic(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("a.txt")]);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
