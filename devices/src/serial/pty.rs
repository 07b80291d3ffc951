//! A pseudo-terminal served by a thread: what every instrument emulator runs on.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use crate::DeviceError;

/// A running pty server thread; stops it (and closes the pty) when stopped or
/// dropped.
pub(crate) struct PtyThread {
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
    // Kept open so the pty survives the driver closing and reopening it.
    _slave: TTYPort,
    path: String,
    what: &'static str,
}

impl PtyThread {
    /// Opens a pty pair and runs `serve(master, stop)` on a thread named after `what`
    /// (`"K-10-A emulator"`); `serve` should return soon after `stop` becomes true.
    pub(crate) fn spawn(
        what: &'static str,
        serve: impl FnOnce(TTYPort, Arc<AtomicBool>) + Send + 'static,
    ) -> Result<Self, DeviceError> {
        let pty_err = |e: serialport::Error| DeviceError::Io {
            device: format!("{what} pseudo-terminal"),
            source: std::io::Error::from(e),
        };
        let (mut master, slave) = TTYPort::pair().map_err(pty_err)?;
        master
            .set_timeout(Duration::from_millis(20))
            .map_err(pty_err)?;
        let path = slave
            .name()
            .ok_or_else(|| DeviceError::Config("the pseudo-terminal has no path".to_string()))?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let handle = std::thread::Builder::new()
            .name(format!("{what} {path}"))
            .spawn(move || serve(master, flag))
            .map_err(|e| DeviceError::Io {
                device: format!("{what} thread"),
                source: e,
            })?;
        Ok(Self {
            stop,
            handle: Some(handle),
            _slave: slave,
            path,
            what,
        })
    }

    /// Path of the pseudo-terminal (`/dev/pts/N`).
    pub(crate) fn path(&self) -> &str {
        &self.path
    }

    /// Stops the thread and waits for it.
    pub(crate) fn shutdown(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(h) = self.handle.take()
            && h.join().is_err()
        {
            tracing::error!("{} thread on {} panicked", self.what, self.path);
        }
    }
}

impl Drop for PtyThread {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// Sleeps `d` in small steps, returning early once `stop` is set.
pub(crate) fn pause(stop: &AtomicBool, d: Duration) {
    let end = Instant::now() + d;
    loop {
        let now = Instant::now();
        if now >= end || stop.load(Ordering::SeqCst) {
            return;
        }
        std::thread::sleep((end - now).min(Duration::from_millis(10)));
    }
}

/// Fails unless an emulator's time scale (factor on the instrument's timing) is a
/// finite number ≥ 0.
pub(crate) fn check_time_scale(time_scale: f64) -> Result<(), DeviceError> {
    if time_scale.is_finite() && time_scale >= 0.0 {
        Ok(())
    } else {
        Err(DeviceError::Config(format!(
            "emulator time scale must be a finite number >= 0, got {time_scale}"
        )))
    }
}
