//! Typed device errors, each with a message a technician can act on.

/// Errors from instruments and pattern outputs.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// The instrument did not answer within the timeout.
    #[error("{device} did not answer within {timeout_ms} ms; check cable, power and port")]
    Timeout {
        /// Device name (model and port).
        device: String,
        /// Timeout that expired.
        timeout_ms: u64,
    },
    /// The instrument answered something that is not in its protocol.
    #[error("{device} sent an unreadable answer {answer:?} to {command:?}")]
    Garbled {
        /// Device name.
        device: String,
        /// Command sent.
        command: String,
        /// What came back.
        answer: String,
    },
    /// The reading is above the instrument's range.
    #[error("{device} is over range; reduce the pattern level or use a neutral-density filter")]
    OverRange {
        /// Device name.
        device: String,
    },
    /// The reading is below the level the instrument can measure reliably.
    #[error("{device} reads {y_cd_m2:.4} cd/m², below its reliable limit {limit_cd_m2} cd/m²")]
    TooDark {
        /// Device name.
        device: String,
        /// What it read.
        y_cd_m2: f64,
        /// Its reliable lower limit.
        limit_cd_m2: f64,
    },
    /// The instrument reported an error code.
    #[error("{device} reported error {code}: {meaning}")]
    Instrument {
        /// Device name.
        device: String,
        /// Error code as sent by the instrument.
        code: String,
        /// What the manual says the code means.
        meaning: String,
    },
    /// Port or pty I/O failed.
    #[error("I/O error on {device}: {source}")]
    Io {
        /// Device name.
        device: String,
        /// Underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The display asked for does not exist.
    #[error("no display {0} on this wall")]
    NoSuchDisplay(String),
    /// A render node (pattern server) refused or failed a request, or cannot be
    /// reached.
    #[error("render node {node}: {message}")]
    Node {
        /// The node's address (`host:port`) and output, as the wall file names it.
        node: String,
        /// What went wrong and what to do about it.
        message: String,
        /// Whether retrying the same request can succeed (unreachable, deadline).
        transient: bool,
    },
    /// The technician stopped while aiming the meter.
    #[error("stopped by the technician while aiming the meter at {0}")]
    AimStopped(String),
    /// The technician stopped the run (the station app's Stop): what was measured
    /// before is kept, the run can be resumed.
    #[error("stopped by the technician before showing a pattern on {0}")]
    Stopped(String),
    /// The technician skipped a display while aiming the meter.
    #[error("skipped by the technician while aiming the meter at {0}")]
    AimSkipped(String),
    /// The camera cannot set its exposure: photometry needs a known exposure time.
    #[error(
        "camera {0} offers automatic exposure only; photometry needs a fixed exposure time: \
         choose a camera (or a driver mode) with manual exposure"
    )]
    AutoExposureOnly(String),
    /// No camera was found, or the one named is not there.
    #[error("camera: {0}")]
    NoCamera(String),
    /// The pattern output cannot show images, only uniform colours.
    #[error(
        "pattern output {0} shows uniform colours only; flat fields and registration need images"
    )]
    NoImages(String),
    /// A wall description or device configuration is wrong.
    #[error("configuration error: {0}")]
    Config(String),
}

impl From<lumiwall_core::CoreError> for DeviceError {
    fn from(e: lumiwall_core::CoreError) -> Self {
        DeviceError::Config(e.to_string())
    }
}

impl DeviceError {
    /// True for errors after which retrying the same reading can succeed
    /// (timeouts and garbled answers); false for errors a retry will not fix.
    pub fn is_transient(&self) -> bool {
        matches!(
            self,
            DeviceError::Timeout { .. }
                | DeviceError::Garbled { .. }
                | DeviceError::Node {
                    transient: true,
                    ..
                }
        )
    }
}
