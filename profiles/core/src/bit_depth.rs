//! The number of bits per channel a display is driven with.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::CoreError;
use crate::macros::validated_number;

/// Bits per channel, 1 to 16. Serialised as the plain number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(try_from = "u32", into = "u32")]
pub struct BitDepth(u32);

impl BitDepth {
    /// Most bits per channel lumiwall drives (16-bit PNG output).
    pub const MAX_BITS: u32 = 16;
    /// 8 bits per channel.
    pub const EIGHT: BitDepth = BitDepth(8);
    /// 10 bits per channel.
    pub const TEN: BitDepth = BitDepth(10);
    /// The bit depths a display profile can hold (8, 10, 12 and 16 bits per channel:
    /// the depths of PNG/EXR output and of projector inputs). A wall file asking for
    /// another depth is refused when it is loaded, before any measuring.
    pub const PROFILE_BITS: [u32; 4] = [8, 10, 12, 16];

    /// A bit depth of `bits`, which must be 1..=16.
    pub fn new(bits: u32) -> Result<Self, CoreError> {
        if (1..=Self::MAX_BITS).contains(&bits) {
            Ok(Self(bits))
        } else {
            Err(CoreError::BitDepth(bits))
        }
    }

    /// True for the depths a display profile can hold ([`BitDepth::PROFILE_BITS`]).
    pub fn is_profile_depth(bits: u32) -> bool {
        Self::PROFILE_BITS.contains(&bits)
    }

    /// Bits per channel.
    pub const fn bits(self) -> u32 {
        self.0
    }

    /// Largest code value, 2^bits − 1.
    pub const fn max_code(self) -> u32 {
        (1u32 << self.0) - 1
    }

    /// Largest code value as f64.
    pub fn max_code_f64(self) -> f64 {
        f64::from(self.max_code())
    }

    /// Nearest code of a normalised drive (clamped to 0..=1), as an integer.
    pub fn code_of(self, drive: f64) -> u32 {
        (drive.clamp(0.0, 1.0) * self.max_code_f64()).round() as u32
    }

    /// `drive` rounded to the nearest representable code, back in 0..=1: what the
    /// display actually shows when asked for `drive`.
    pub fn quantise(self, drive: f64) -> f64 {
        let max = self.max_code_f64();
        (drive.clamp(0.0, 1.0) * max).round() / max
    }
}

validated_number!(BitDepth, u32);

impl fmt::Display for BitDepth {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} bit", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn max_code_and_quantisation_at_common_depths() {
        assert_eq!(BitDepth::EIGHT.max_code(), 255);
        assert_eq!(BitDepth::TEN.max_code(), 1023);
        assert_eq!(BitDepth::new(16).unwrap().max_code(), 65535);
        assert_eq!(BitDepth::EIGHT.code_of(0.5), 128);
        assert!((BitDepth::EIGHT.quantise(0.5) - 128.0 / 255.0).abs() < 1e-15);
        assert_eq!(BitDepth::TEN.quantise(1.7), 1.0);
        assert_eq!(BitDepth::TEN.quantise(-0.2), 0.0);
    }

    #[test]
    fn profile_depths_are_8_10_12_and_16_only() {
        let ok: Vec<u32> = (0..=40)
            .filter(|&b| BitDepth::is_profile_depth(b))
            .collect();
        assert_eq!(ok, vec![8, 10, 12, 16]);
    }

    #[test]
    fn depths_outside_one_to_sixteen_are_refused() {
        assert_eq!(BitDepth::new(0), Err(CoreError::BitDepth(0)));
        assert_eq!(BitDepth::new(17), Err(CoreError::BitDepth(17)));
        assert!(serde_json::from_str::<BitDepth>("32").is_err());
        assert_eq!(
            serde_json::from_str::<BitDepth>("10").unwrap(),
            BitDepth::TEN
        );
    }
}
