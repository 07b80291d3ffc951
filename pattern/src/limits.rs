//! Documented ceilings of the pattern service: every size a request or a
//! configuration carries is checked against them before anything is allocated.

use std::time::Duration;

/// The protocol a station and a node must both speak (the proto package name).
pub const PROTOCOL: &str = "lumiwall.pattern.v1";

/// Largest gRPC message either side decodes (an 8K 16-bit PNG fits).
pub const MAX_MESSAGE_BYTES: usize = 256 << 20;

/// Largest width or height of an output, pixels.
pub const MAX_OUTPUT_SIDE: u32 = 16_384;

/// Most pixels of one output (an 8192 × 8192 frame).
pub const MAX_OUTPUT_PIXELS: u64 = 1 << 26;

/// Most outputs one node serves (a node with several GPUs has up to 16 heads; virtual
/// and test nodes may serve a whole wall).
pub const MAX_OUTPUTS: usize = 64;

/// Longest output, node or station name, characters.
pub const MAX_NAME_CHARS: usize = 64;

/// Shortest accepted token, characters (a guessable token is no protection).
pub const MIN_TOKEN_CHARS: usize = 16;

/// Longest accepted token file, bytes.
pub const MAX_TOKEN_FILE_BYTES: u64 = 4096;

/// Longest settle time a node may be configured with.
pub const MAX_SETTLE: Duration = Duration::from_secs(10);

/// Default deadline of one call from the station (presenting plus settling fit in it).
pub const DEFAULT_DEADLINE: Duration = Duration::from_secs(10);

/// A lease not used for this long is given up: a station that died does not hold its
/// nodes forever (a technician aiming the meter uses the lease every few seconds).
pub const LEASE_IDLE_EXPIRY: Duration = Duration::from_secs(15 * 60);

/// Whether `name` is a usable output, node or station name: 1 to
/// [`MAX_NAME_CHARS`] characters, letters, digits and `-_.:@` only.
pub fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.chars().count() <= MAX_NAME_CHARS
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.:@".contains(c))
}

/// This machine's host name if it is a [`valid_name`], else `fallback`: how a station
/// or a node names itself in the other side's messages.
pub fn host_name_or(fallback: &str) -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|h| h.trim().to_string())
        .filter(|h| valid_name(h))
        .unwrap_or_else(|| fallback.into())
}
