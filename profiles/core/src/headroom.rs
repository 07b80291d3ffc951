//! The largest channel usage a calibration may plan for.

use serde::{Deserialize, Serialize};

use crate::CoreError;
use crate::macros::validated_number;

/// Largest linear channel intensity the solve may use, in (0, 1]: 1 drives the most
/// limited channel to full; less keeps a reserve (e.g. for lamp ageing until the next
/// recalibration). Serialised as the plain number.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize)]
#[serde(try_from = "f64", into = "f64")]
pub struct Headroom(f64);

impl Headroom {
    /// No reserve: the most limited channel reaches full drive.
    pub const FULL: Headroom = Headroom(1.0);

    /// A headroom of `fraction`, which must be in (0, 1] (NaN refused).
    pub fn new(fraction: f64) -> Result<Self, CoreError> {
        if fraction > 0.0 && fraction <= 1.0 {
            Ok(Self(fraction))
        } else {
            Err(CoreError::Headroom(fraction))
        }
    }

    /// The fraction in (0, 1].
    pub const fn get(self) -> f64 {
        self.0
    }
}

impl Default for Headroom {
    fn default() -> Self {
        Self::FULL
    }
}

validated_number!(Headroom, f64);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headroom_accepts_zero_to_one_exclusive_of_zero() {
        assert_eq!(Headroom::new(1.0).map(Headroom::get), Ok(1.0));
        assert_eq!(Headroom::new(0.01).map(Headroom::get), Ok(0.01));
        for bad in [0.0, -0.5, 1.0 + 1e-12, f64::NAN, f64::INFINITY] {
            assert!(Headroom::new(bad).is_err(), "{bad}");
        }
        assert_eq!(
            Headroom::new(1.5).unwrap_err().to_string(),
            "headroom 1.5 is not in (0, 1]"
        );
    }
}
