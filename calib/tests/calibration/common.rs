//! Helpers shared by the calib integration tests.

/// Deterministic pseudo-random numbers for the tests: a 64-bit linear congruential
/// generator (Knuth's MMIX constants), so every run sees the same "noise".
pub(crate) struct Lcg(u64);

impl Lcg {
    /// Generator starting from `seed`.
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Next number, uniform in [-1, 1) (the top 53 bits of the state).
    pub(crate) fn signed(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}
