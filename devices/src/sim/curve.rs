//! Per-channel electro-optical transfer curves of a simulated projector.
//!
//! `f(d) = h((1 − β)·d^γ + β·S(d))` where `S` is a logistic ramp rescaled to run
//! from 0 at d = 0 to 1 at d = 1 and `h(x) = (1 − e^(−s·x))/(1 − e^(−s))` a
//! shoulder. The logistic part gives a near-linear toe at black, the shoulder
//! compresses the top, so the curve is S-shaped (convex low, concave high) and its
//! log-log slope varies along the ramp: it is not a pure power law (Kresse 3.3.1).

use serde::{Deserialize, Serialize};

use super::spectra::logistic;

/// Shape parameters of one channel's transfer curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransferCurve {
    /// Exponent γ of the power-law part (> 0).
    pub gamma: f64,
    /// Weight β of the logistic part, 0..=1.
    pub s_weight: f64,
    /// Drive at the logistic's inflection, 0..=1.
    pub s_centre: f64,
    /// Steepness k of the logistic (per unit drive, > 0).
    pub s_steepness: f64,
    /// Shoulder strength s (>= 0; 0 = no shoulder).
    #[serde(default)]
    pub shoulder: f64,
}

impl TransferCurve {
    /// Relative intensity (black removed, 1 at full drive) for a drive in 0..=1.
    pub fn intensity(&self, drive: f64) -> f64 {
        let d = if drive.is_finite() {
            drive.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let power = d.powf(self.gamma);
        let s = |x: f64| logistic(self.s_steepness * (x - self.s_centre));
        let (s0, s1) = (s(0.0), s(1.0));
        let ramp = if s1 > s0 { (s(d) - s0) / (s1 - s0) } else { d };
        let x = (1.0 - self.s_weight) * power + self.s_weight * ramp;
        if self.shoulder > 1e-9 {
            (-(self.shoulder * x)).exp_m1() / (-self.shoulder).exp_m1()
        } else {
            x
        }
    }

    /// Checks the parameters; returns a description of the first problem.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.gamma.is_finite() && self.gamma > 0.0) {
            return Err(format!("curve gamma must be > 0, got {}", self.gamma));
        }
        if !(0.0..=1.0).contains(&self.s_weight) {
            return Err(format!(
                "curve s_weight must be in 0..=1, got {}",
                self.s_weight
            ));
        }
        if !(0.0..=1.0).contains(&self.s_centre) {
            return Err(format!(
                "curve s_centre must be in 0..=1, got {}",
                self.s_centre
            ));
        }
        if !(self.s_steepness.is_finite() && self.s_steepness > 0.0) {
            return Err(format!(
                "curve s_steepness must be > 0, got {}",
                self.s_steepness
            ));
        }
        if !(self.shoulder.is_finite() && (0.0..=20.0).contains(&self.shoulder)) {
            return Err(format!(
                "curve shoulder must be in 0..=20, got {}",
                self.shoulder
            ));
        }
        Ok(())
    }
}
