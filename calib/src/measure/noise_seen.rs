//! The meter's repeatability as a display's repeated readings showed it, against the
//! noise the meter states.
//!
//! The solve smooths the ramp samples within the meter's *stated* noise
//! ([`crate::tone::smoothing`]). Where the meter is quieter than it says, that moves
//! good samples: the emulated K-10-A with exact readings (`--noise none`) states a dark
//! noise 2.4–3.6 times a CS-100A's, and weak-green-infitec-2x2 at 40 readings missed
//! the noiseless limits on 3 of seeds 101–110 (max ΔE2000 up to 2.15, worst grey
//! balance 0.54 on average) where the direct exact meter is exact; with this scale it
//! meets them on 10 of 10 (largest max 0.75, grey balance 0.16). Every patch read
//! more than once (the black, the primaries, the white, the low-light averages, the
//! split grey) shows the spread of its readings; [`NoiseSeen`] pools those spreads, each
//! sensor in units of its stated 1σ ([`ReadingNoise::sigma_xyz`]), and
//! [`NoiseSeen::scale`] is the share of the stated noise the readings showed, at most
//! 1: a meter is never taken as noisier than it says (the smoothing's share of the
//! noise was chosen for the stated noise), only as quieter where it shows it.
//!
//! One scale serves the whole display, from its black to its white. A meter that
//! rounds, clamps or averages its dark readings inside so that repeats come out
//! equal shows less noise than it has; its samples are then smoothed less, down to
//! not at all (the curves through the samples, as with an exact meter).
//!
//! What the readings show (dim-mono-2x1, 40 readings, first pass): the direct
//! simulated CS-100A 1.07 and 0.91 of its stated noise (so 1 and 0.91: the same
//! figures within a seed's noise, e.g. dim-mono-2x1 44 → 43 and dim-infitec-pair
//! 43 → 45 of seeds 101–160 within every limit); the emulated K-10-A with the
//! simulator's realistic noise 0.52 and 0.43 (its driver states the K-10-A's noise;
//! dim-mono-2x1 within every limit on 7 → 10 of seeds 101–120, dim-infitec-pair
//! 1 → 3 and weak-green-infitec-2x2 0 → 1 of seeds 101–110).

use lumiwall_devices::{ReadingNoise, Xyz};
use serde::{Deserialize, Serialize};

/// Degrees of freedom below which the readings say nothing about the noise
/// ([`NoiseSeen::scale`] is 1): one patch read four times, or three read twice each.
/// With 9 the scale's relative standard error is about 24 %; a display's first pass
/// at 40 readings pools about 40.
pub const MIN_DOF: u32 = 9;

/// Pooled spread of repeated readings, in units of the meter's stated noise.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct NoiseSeen {
    /// Sum over every patch read more than once of its readings' squared deviations
    /// from their mean, each sensor (X, Y, Z) in units of its stated 1σ at the patch.
    pub sum_sq: f64,
    /// Degrees of freedom in `sum_sq`: three per reading after a patch's first.
    pub dof: u32,
}

impl NoiseSeen {
    /// The share of the stated noise that the readings showed, `√(sum_sq / dof)` at
    /// most 1; 1 below [`MIN_DOF`].
    pub fn scale(&self) -> f64 {
        if self.dof < MIN_DOF {
            return 1.0;
        }
        let s = (self.sum_sq / f64::from(self.dof)).sqrt();
        if s.is_finite() { s.min(1.0) } else { 1.0 }
    }

    /// Adds the spreads of `other` (another pass on the same display).
    pub fn merge(&mut self, other: NoiseSeen) {
        self.sum_sq += other.sum_sq;
        self.dof += other.dof;
    }
}

/// The readings of the patch on show, accumulated as they come (Welford's update, in
/// units of the stated noise at the patch's first reading).
#[derive(Debug, Clone, Copy)]
pub(crate) struct PatchSpread {
    sigma: [f64; 3],
    mean: [f64; 3],
    n: u32,
}

impl PatchSpread {
    /// Adds `xyz`, a reading of the patch on show (`spread`: `None` for a new patch), to
    /// `seen`. Nothing without a stated, non-exact `noise`.
    pub(crate) fn add(
        spread: &mut Option<PatchSpread>,
        seen: &mut NoiseSeen,
        noise: Option<&ReadingNoise>,
        xyz: Xyz,
    ) {
        let Some(noise) = noise.filter(|n| !n.is_exact()) else {
            return;
        };
        let v = xyz.to_array();
        let s = spread.get_or_insert_with(|| PatchSpread {
            sigma: noise.sigma_xyz(xyz),
            mean: [0.0; 3],
            n: 0,
        });
        if s.sigma.iter().any(|x| !x.is_finite() || *x <= 0.0) {
            return;
        }
        s.n += 1;
        let mut m2 = 0.0;
        for (k, value) in v.iter().enumerate() {
            let z = value / s.sigma[k];
            let delta = z - s.mean[k];
            s.mean[k] += delta / f64::from(s.n);
            m2 += delta * (z - s.mean[k]);
        }
        if s.n > 1 && m2.is_finite() {
            seen.sum_sq += m2;
            seen.dof += 3;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_distr::StandardNormal;

    /// Reads `patches` patches `n` times each with noise `share` × the stated.
    fn seen_with(share: f64, patches: usize, n: usize) -> NoiseSeen {
        let noise = ReadingNoise::CS100A_CLASS;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut seen = NoiseSeen::default();
        for p in 0..patches {
            let truth = Xyz::new(0.05 + 0.3 * p as f64, 0.04 + 0.2 * p as f64, 0.1 + p as f64);
            let sigma = noise.sigma_xyz(truth);
            let mut spread = None;
            for _ in 0..n {
                let e: [f64; 3] = std::array::from_fn(|k| {
                    share * sigma[k] * rng.sample::<f64, _>(StandardNormal)
                });
                let x = Xyz::new(truth.x + e[0], truth.y + e[1], truth.z + e[2]);
                PatchSpread::add(&mut spread, &mut seen, Some(&noise), x);
            }
        }
        seen
    }

    #[test]
    fn readings_as_noisy_as_stated_keep_the_stated_noise_and_exact_ones_scale_it_to_zero() {
        let stated = seen_with(1.0, 12, 4);
        assert_eq!(stated.dof, 12 * 3 * 3);
        assert!(stated.scale() > 0.85, "scale {}", stated.scale());
        let half = seen_with(0.5, 12, 4);
        assert!((half.scale() - 0.5).abs() < 0.1, "scale {}", half.scale());
        assert_eq!(seen_with(0.0, 12, 4).scale(), 0.0);
        // A noisier meter than stated is not taken as noisier.
        assert_eq!(seen_with(2.0, 12, 4).scale(), 1.0);
    }

    #[test]
    fn too_few_repeats_or_no_stated_noise_say_nothing() {
        assert_eq!(seen_with(0.0, 1, 3).scale(), 1.0, "6 degrees of freedom");
        assert_eq!(seen_with(0.0, 12, 1).dof, 0, "patches read once");
        let mut seen = NoiseSeen::default();
        let mut spread = None;
        for _ in 0..5 {
            PatchSpread::add(&mut spread, &mut seen, None, Xyz::new(1.0, 1.0, 1.0));
            let exact = Some(&ReadingNoise::EXACT);
            PatchSpread::add(&mut spread, &mut seen, exact, Xyz::new(1.0, 1.0, 1.0));
        }
        assert_eq!(seen, NoiseSeen::default());
    }
}
