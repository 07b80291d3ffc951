//! Head tracking for the wall viewer: a pose stream over UDP, one text datagram per
//! pose, as a tracker bridge (VRPN, ART DTrack, OptiTrack) can send it with a few
//! lines of code:
//!
//! ```text
//! LWPOSE 1 <seq> <x_m> <y_m> <z_m> [<qw> <qx> <qy> <qz>]
//! ```
//!
//! - `LWPOSE 1`: the format and its version;
//! - `seq`: an unsigned counter the sender increases with every pose; a datagram whose
//!   counter is not above the last one taken is stale (UDP may reorder) and dropped;
//! - `x_m y_m z_m`: the head (the point between the eyes) in the wall frame, metres:
//!   x right and y up from the wall's lower-left corner, z towards the viewer (> 0);
//! - optional `qw qx qy qz`: the head's orientation as a unit quaternion in the wall
//!   frame (identity: looking at the wall, upright); the eyes sit on the head's x
//!   axis. Without it the eyes stay level and parallel to the wall.
//!
//! Fields are separated by ASCII whitespace, numbers are decimal (`1.5`, `-2e-3`); a
//! datagram is at most [`MAX_DATAGRAM_BYTES`]. Anything else is a bad datagram: counted
//! and skipped, never fatal. The receiver keeps the newest pose of what has queued up.

use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

use nalgebra::{Quaternion, UnitQuaternion};

use crate::scene::V3;

/// Longest datagram read (a pose line is under 200 bytes).
pub const MAX_DATAGRAM_BYTES: usize = 512;

/// Largest head coordinate accepted, metres (a tracking volume, not a city).
pub const MAX_HEAD_COORDINATE_M: f64 = 1000.0;

/// A tracked head pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadPose {
    /// The sender's counter.
    pub seq: u64,
    /// The point between the eyes, wall frame, metres.
    pub position_m: V3,
    /// The head's orientation (None: level, facing the wall).
    pub orientation: Option<UnitQuaternion<f64>>,
}

impl HeadPose {
    /// Where an eye is: `offset_m` along the head's x axis (−half the separation for
    /// the left eye, +half for the right, 0 for a mono wall).
    pub fn eye_m(&self, offset_m: f64) -> V3 {
        let x = self.orientation.map_or(V3::x(), |q| q * V3::x());
        self.position_m + x * offset_m
    }
}

/// Why a datagram is not a pose.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PoseError {
    /// Not `LWPOSE 1 …`.
    #[error("not a pose datagram (expected `LWPOSE 1 <seq> <x> <y> <z> [qw qx qy qz]`)")]
    NotAPose,
    /// A field is missing, extra or not a number.
    #[error("pose datagram: {0}")]
    Malformed(String),
    /// The numbers are not a head in front of the wall.
    #[error("pose datagram: {0}")]
    OutOfRange(String),
}

/// Parses one datagram.
pub fn parse_pose(datagram: &[u8]) -> Result<HeadPose, PoseError> {
    let text = std::str::from_utf8(datagram).map_err(|_| PoseError::NotAPose)?;
    let fields: Vec<&str> = text.split_ascii_whitespace().collect();
    if fields.len() < 2 || fields[0] != "LWPOSE" || fields[1] != "1" {
        return Err(PoseError::NotAPose);
    }
    let numbers = &fields[2..];
    if numbers.len() != 4 && numbers.len() != 8 {
        return Err(PoseError::Malformed(format!(
            "{} fields after `LWPOSE 1`, expected 4 (seq x y z) or 8 (with qw qx qy qz)",
            numbers.len()
        )));
    }
    let seq: u64 = numbers[0]
        .parse()
        .map_err(|_| PoseError::Malformed(format!("seq `{}` is not a counter", numbers[0])))?;
    let values = numbers[1..]
        .iter()
        .map(|w| {
            w.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| PoseError::Malformed(format!("`{w}` is not a finite number")))
        })
        .collect::<Result<Vec<f64>, _>>()?;
    let position_m = head_position(&values[..3])?;
    let orientation = values.get(3..7).map(head_orientation).transpose()?;
    Ok(HeadPose {
        seq,
        position_m,
        orientation,
    })
}

fn head_position(v: &[f64]) -> Result<V3, PoseError> {
    if v.iter().any(|c| c.abs() > MAX_HEAD_COORDINATE_M) {
        return Err(PoseError::OutOfRange(format!(
            "head at {v:?} m is beyond ±{MAX_HEAD_COORDINATE_M} m"
        )));
    }
    if v[2] <= 0.0 {
        return Err(PoseError::OutOfRange(format!(
            "head at z = {} m is not in front of the wall (z > 0)",
            v[2]
        )));
    }
    Ok(V3::new(v[0], v[1], v[2]))
}

/// Largest deviation of a received quaternion's norm from 1.
const MAX_QUATERNION_NORM_ERROR: f64 = 0.01;

fn head_orientation(q: &[f64]) -> Result<UnitQuaternion<f64>, PoseError> {
    let quaternion = Quaternion::new(q[0], q[1], q[2], q[3]);
    let norm = quaternion.norm();
    if (norm - 1.0).abs() > MAX_QUATERNION_NORM_ERROR {
        return Err(PoseError::OutOfRange(format!(
            "orientation {q:?} has norm {norm:.4}, not a unit quaternion"
        )));
    }
    Ok(UnitQuaternion::from_quaternion(quaternion))
}

/// Why no pose came.
#[derive(Debug, thiserror::Error)]
pub enum TrackingError {
    /// The socket failed.
    #[error("tracking socket {addr}: {source}")]
    Socket {
        /// The address.
        addr: String,
        /// What failed.
        source: std::io::Error,
    },
    /// Nothing usable arrived in time.
    #[error(
        "no head pose on {addr} within {timeout_s:.1} s ({bad} bad and {stale} stale datagrams); \
         is the tracker bridge sending `LWPOSE 1 <seq> <x> <y> <z>` there?{last_error}"
    )]
    Timeout {
        /// The address listened on.
        addr: SocketAddr,
        /// How long it waited.
        timeout_s: f64,
        /// Bad datagrams so far.
        bad: u64,
        /// Stale datagrams so far.
        stale: u64,
        /// The last bad datagram's reason, if any.
        last_error: String,
    },
}

/// What one read from the socket gave.
enum Datagram {
    /// Nothing arrived.
    Nothing,
    /// A bad or stale datagram.
    Skipped,
    /// A newer pose.
    Pose(HeadPose),
}

/// The receiving end of a pose stream.
#[derive(Debug)]
pub struct PoseReceiver {
    socket: UdpSocket,
    addr: SocketAddr,
    last_seq: Option<u64>,
    /// Datagrams that were not poses.
    pub bad: u64,
    /// Poses older than one already taken.
    pub stale: u64,
    last_error: Option<PoseError>,
}

impl PoseReceiver {
    /// Listens on `addr` (port 0: any free port, see [`PoseReceiver::local_addr`]).
    pub fn bind(addr: &str) -> Result<Self, TrackingError> {
        let socket_err = |source| TrackingError::Socket {
            addr: addr.to_string(),
            source,
        };
        let socket = UdpSocket::bind(addr).map_err(socket_err)?;
        let addr = socket.local_addr().map_err(socket_err)?;
        Ok(Self {
            socket,
            addr,
            last_seq: None,
            bad: 0,
            stale: 0,
            last_error: None,
        })
    }

    /// The address it listens on.
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// Waits up to `timeout` for a pose newer than the last one taken, then takes the
    /// newest of those already queued.
    pub fn next(&mut self, timeout: Duration) -> Result<HeadPose, TrackingError> {
        let deadline = Instant::now() + timeout;
        let mut newest = loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(self.timeout(timeout));
            }
            if let Datagram::Pose(p) = self.receive(Some(left))? {
                break p;
            }
        };
        loop {
            match self.receive(None)? {
                Datagram::Pose(p) => newest = p,
                Datagram::Skipped => {}
                Datagram::Nothing => return Ok(newest),
            }
        }
    }

    /// One datagram, waiting up to `wait` for it (None: not at all).
    fn receive(&mut self, wait: Option<Duration>) -> Result<Datagram, TrackingError> {
        let socket_err = |source| TrackingError::Socket {
            addr: self.addr.to_string(),
            source,
        };
        match wait {
            Some(w) => {
                self.socket.set_nonblocking(false).map_err(socket_err)?;
                self.socket.set_read_timeout(Some(w)).map_err(socket_err)?;
            }
            None => self.socket.set_nonblocking(true).map_err(socket_err)?,
        }
        let mut buf = [0u8; MAX_DATAGRAM_BYTES];
        let n = match self.socket.recv(&mut buf) {
            Ok(n) => n,
            Err(e) if is_no_data(&e) => return Ok(Datagram::Nothing),
            Err(e) => return Err(socket_err(e)),
        };
        Ok(self.take(&buf[..n]))
    }

    /// The pose in `datagram` if it is one and newer than the last taken.
    fn take(&mut self, datagram: &[u8]) -> Datagram {
        match parse_pose(datagram) {
            Err(e) => {
                self.bad += 1;
                self.last_error = Some(e);
                Datagram::Skipped
            }
            Ok(p) if self.last_seq.is_some_and(|s| p.seq <= s) => {
                self.stale += 1;
                Datagram::Skipped
            }
            Ok(p) => {
                self.last_seq = Some(p.seq);
                Datagram::Pose(p)
            }
        }
    }

    fn timeout(&self, timeout: Duration) -> TrackingError {
        TrackingError::Timeout {
            addr: self.addr,
            timeout_s: timeout.as_secs_f64(),
            bad: self.bad,
            stale: self.stale,
            last_error: self
                .last_error
                .as_ref()
                .map_or(String::new(), |e| format!(" Last bad one: {e}")),
        }
    }
}

fn is_no_data(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_with_and_without_orientation_parses_and_the_eyes_sit_on_the_heads_x_axis() {
        let p = parse_pose(b"LWPOSE 1 7 1.5 1.2 2.0\n").unwrap();
        assert_eq!((p.seq, p.position_m), (7, V3::new(1.5, 1.2, 2.0)));
        assert_eq!(p.eye_m(-0.0325), V3::new(1.4675, 1.2, 2.0));
        // head turned 90° about y (looking along −x): the eyes line up along z
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let text = format!("LWPOSE 1 8 1.5 1.2 2.0 {h} 0 {h} 0");
        let p = parse_pose(text.as_bytes()).unwrap();
        let right = p.eye_m(0.0325);
        assert!(
            (right - V3::new(1.5, 1.2, 2.0 - 0.0325)).norm() < 1e-12,
            "{right}"
        );
    }

    #[test]
    fn bad_datagrams_say_what_is_wrong() {
        let cases: [(&[u8], &str); 6] = [
            (b"hello", "not a pose"),
            (b"LWPOSE 2 1 0 0 1", "not a pose"),
            (b"LWPOSE 1 1 0 0", "3 fields"),
            (b"LWPOSE 1 1 0 NaN 1", "not a finite number"),
            (b"LWPOSE 1 1 0 0 -1", "not in front of the wall"),
            (b"LWPOSE 1 1 0 0 1 2 0 0 0", "not a unit quaternion"),
        ];
        for (d, why) in cases {
            let e = parse_pose(d).expect_err(why).to_string();
            assert!(e.contains(why), "{e}");
        }
    }

    #[test]
    fn the_receiver_takes_the_newest_queued_pose_and_drops_stale_and_bad_ones() {
        let mut rx = PoseReceiver::bind("127.0.0.1:0").unwrap();
        let tx = UdpSocket::bind("127.0.0.1:0").unwrap();
        for d in [
            "LWPOSE 1 5 1 1 1",
            "garbage",
            "LWPOSE 1 9 2 1 1",
            "LWPOSE 1 7 3 1 1",
        ] {
            tx.send_to(d.as_bytes(), rx.local_addr()).unwrap();
        }
        std::thread::sleep(Duration::from_millis(50));
        let p = rx.next(Duration::from_secs(5)).unwrap();
        assert_eq!(p.seq, 9, "the newest of the queue");
        assert_eq!((rx.bad, rx.stale), (1, 1));
        let e = rx.next(Duration::from_millis(100)).unwrap_err().to_string();
        assert!(e.contains("no head pose") && e.contains("1 bad"), "{e}");
    }
}
