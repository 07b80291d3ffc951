//! The mean of a patch's readings where the instrument refused some as below its floor.
//!
//! A colorimeter refuses a reading whose luminance falls below its floor (a CS-100A
//! class meter: 0.01 cd/m²). Near the floor, the readings it gives are the ones its
//! noise lifted: their plain mean is biased high. On a 6 cd/m² LCD wall, whose black is
//! 0.008 cd/m² against a zero-light noise of 0.004 cd/m² in Y, two readings in three are
//! refused and the mean of the rest is 0.012 cd/m², half as much again as the truth; the
//! chart's 2 % grey then comes out 0.007 off in xy.
//!
//! The readings given and the count refused are a censored normal sample, and its
//! maximum-likelihood mean (Tobit, with the instrument's stated noise) is the estimate
//! to take: [`CensoredReadings::mean`]. The plain mean's bias stays however many
//! readings there are; this one's shrinks with them (a few percent at four readings
//! that are not all refused). Only Y is censored: X and Z come from their own sensors,
//! whose noise is independent of Y's, so their mean over the readings given stands.
//!
//! The readings are the instrument's own: a reading that is itself a mean of several
//! ([`crate::AveragingMeter`]) hands over the readings behind it
//! ([`crate::Colorimeter::readings_behind_last`]), so each refusal counts once, at one
//! reading's noise.

use serde::{Deserialize, Serialize};

use crate::{ReadingNoise, Xyz};

/// The readings of one patch as they come: the sum of those the instrument gave, and
/// how many it refused as too dark, with its floor.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct CensoredReadings {
    sum: Xyz,
    given: u32,
    refused: u32,
    floor_cd_m2: f64,
}

impl CensoredReadings {
    /// Adds a reading the instrument gave.
    pub fn add(&mut self, xyz: Xyz) {
        self.sum = self.sum + xyz;
        self.given += 1;
    }

    /// Adds a reading the instrument refused as below its floor of `floor_cd_m2` (the
    /// highest floor seen is kept).
    pub fn add_refused(&mut self, floor_cd_m2: f64) {
        self.refused += 1;
        if floor_cd_m2.is_finite() {
            self.floor_cd_m2 = self.floor_cd_m2.max(floor_cd_m2);
        }
    }

    /// Adds the readings of `other` (the same patch read again).
    pub fn merge(&mut self, other: &CensoredReadings) {
        self.sum = self.sum + other.sum;
        self.given += other.given;
        self.refused += other.refused;
        self.floor_cd_m2 = self.floor_cd_m2.max(other.floor_cd_m2);
    }

    /// True when nothing was read.
    pub fn is_empty(&self) -> bool {
        self.given == 0 && self.refused == 0
    }

    /// Readings the instrument gave.
    pub fn given(&self) -> u32 {
        self.given
    }

    /// Readings it refused as too dark.
    pub fn refused(&self) -> u32 {
        self.refused
    }

    /// The mean of the readings given, Y estimated with the refused ones
    /// ([`censored_mean_y`]) where there were any and `noise` states the noise of one of
    /// the instrument's readings (without it, for an exact instrument or without a
    /// known floor, the plain mean). `None` when every reading was refused: the
    /// readings then say only that the light is below the floor
    /// ([`CensoredReadings::below_floor_y`]).
    pub fn mean(&self, noise: Option<&ReadingNoise>) -> Option<Xyz> {
        if self.given == 0 {
            return None;
        }
        let mean = self.sum * (1.0 / f64::from(self.given));
        let Some(sigma_y) = self.sigma_y_at_floor(noise).filter(|_| self.refused > 0) else {
            return Some(mean);
        };
        let y = censored_mean_y(
            self.sum.y,
            self.given,
            self.refused,
            self.floor_cd_m2,
            sigma_y,
        );
        Some(Xyz::new(mean.x, y, mean.z))
    }

    /// Where every reading was refused, the luminance they leave likeliest on average:
    /// the mean of the light's luminance given only that each of the refused readings
    /// fell below the floor, over a flat prior on luminances from 0 up
    /// ([`below_floor_mean_y`]). `None` where a reading was given (then
    /// [`CensoredReadings::mean`]), none was refused, or `noise` states none.
    pub fn below_floor_y(&self, noise: Option<&ReadingNoise>) -> Option<f64> {
        if self.given > 0 || self.refused == 0 {
            return None;
        }
        let sigma_y = self.sigma_y_at_floor(noise)?;
        Some(below_floor_mean_y(self.refused, self.floor_cd_m2, sigma_y))
    }

    /// 1σ of one reading's Y at the floor by the stated `noise`, what the refusals are
    /// weighed with: `None` without a stated noise, for an exact instrument (σ 0) or
    /// without a known floor.
    fn sigma_y_at_floor(&self, noise: Option<&ReadingNoise>) -> Option<f64> {
        let floor = self.floor_cd_m2;
        let sigma_y = noise?.sigma_xyz(Xyz::new(0.0, floor, 0.0))[1];
        (floor > 0.0 && sigma_y > 0.0).then_some(sigma_y)
    }
}

/// The mean luminance, over a flat prior on `[0, ∞)`, of a light whose `refused`
/// readings of normal noise `sigma` (> 0) all fell below `floor`: the likelihood
/// `Φ((floor − μ)/σ)^refused` integrated by the trapezoid rule out to `floor + 10σ`.
/// Below a 0.01 cd/m² floor at σ 0.004 cd/m²: one refusal leaves 0.006 cd/m², and
/// each more lowers it (four: 0.0036; 64: 0.0011).
pub fn below_floor_mean_y(refused: u32, floor: f64, sigma: f64) -> f64 {
    const STEPS: u32 = 4000;
    let top = floor.max(0.0) + 10.0 * sigma;
    let h = top / f64::from(STEPS);
    let (mut weight, mut moment) = (0.0, 0.0);
    for i in 0..=STEPS {
        let mu = h * f64::from(i);
        let end = if i == 0 || i == STEPS { 0.5 } else { 1.0 };
        let p = end * normal_cdf((floor - mu) / sigma).powi(refused.min(i32::MAX as u32) as i32);
        weight += p;
        moment += p * mu;
    }
    if weight > 0.0 { moment / weight } else { 0.0 }
}

/// Maximum-likelihood mean of a normal sample of known `sigma` (> 0) where `given`
/// values summing to `sum_given` were seen and `refused` more fell below `floor` unseen
/// (a left-censored sample), at least 0 (light is not negative). The log-likelihood is
/// concave in the mean, its slope `(Σy − k·μ)/σ − r·φ(z)/Φ(z)` with `z = (floor − μ)/σ`
/// falls from +∞ to below 0 at the plain mean of the values seen, so bisection finds
/// its one root (the bracket reaches down at most 1000σ below that mean, where a floor
/// that far below the values seen leaves the refusals unexplained anyway). Without a
/// value seen (`given` 0: NaN) or a noise (`sigma` not above 0), the plain mean.
pub fn censored_mean_y(sum_given: f64, given: u32, refused: u32, floor: f64, sigma: f64) -> f64 {
    if given == 0 || sigma.is_nan() || sigma <= 0.0 {
        return sum_given / f64::from(given);
    }
    let k = f64::from(given);
    let r = f64::from(refused);
    let plain = sum_given / k;
    let slope = |mu: f64| (sum_given - k * mu) / sigma - r * inverse_mills((floor - mu) / sigma);
    let mut hi = plain;
    let mut lo = plain.min(floor) - sigma;
    while slope(lo) <= 0.0 && lo > plain - 1e3 * sigma {
        lo -= 2.0 * (hi - lo);
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if slope(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * sigma {
            break;
        }
    }
    (0.5 * (lo + hi)).max(0.0)
}

/// φ(z)/Φ(z), the standard normal density over its distribution function: 0 for large
/// positive `z`, and for large negative `z` (Φ underflowing) −z, its limit.
fn inverse_mills(z: f64) -> f64 {
    let cdf = normal_cdf(z);
    let pdf = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
    if cdf > 1e-300 { pdf / cdf } else { -z }
}

/// Φ(z), the standard normal distribution function.
fn normal_cdf(z: f64) -> f64 {
    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Normal draws from a fixed linear congruential sequence (Box–Muller), so the test
    /// needs no random crate.
    fn normals(n: usize) -> Vec<f64> {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (u, v) = (uniform(), uniform());
                (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
            })
            .collect()
    }

    fn censor(truth: f64, sigma: f64, floor: f64, draws: &[f64]) -> CensoredReadings {
        let mut r = CensoredReadings::default();
        for d in draws {
            let y = truth + sigma * d;
            if y < floor {
                r.add_refused(floor);
            } else {
                r.add(Xyz::new(0.02, y, 0.03));
            }
        }
        r
    }

    #[test]
    fn a_black_below_the_floor_is_estimated_without_the_bias_of_the_readings_given() {
        // A CS-100A class meter on a 0.008 cd/m² black: σ_Y 0.004, floor 0.01.
        let noise = ReadingNoise::CS100A_CLASS;
        let r = censor(0.008, 0.004, 0.01, &normals(20_000));
        assert!(r.refused() > r.given(), "most readings are refused");
        let plain = r.mean(None).unwrap().y;
        let censored = r.mean(Some(&noise)).unwrap().y;
        assert!(plain > 0.0115, "the plain mean is biased high: {plain}");
        assert!(
            (censored - 0.008).abs() < 0.0002,
            "censored mean {censored} against 0.008"
        );
        // X and Z are the plain means of the readings given.
        let m = r.mean(Some(&noise)).unwrap();
        assert!((m.x - 0.02).abs() < 1e-12 && (m.z - 0.03).abs() < 1e-12);
    }

    #[test]
    fn readings_none_of_which_were_refused_average_plainly() {
        let mut r = CensoredReadings::default();
        r.add(Xyz::new(1.0, 2.0, 3.0));
        r.add(Xyz::new(3.0, 4.0, 5.0));
        let m = r.mean(Some(&ReadingNoise::CS100A_CLASS)).unwrap();
        assert_eq!(m, Xyz::new(2.0, 3.0, 4.0));
    }

    #[test]
    fn every_reading_refused_gives_no_mean_and_an_exact_meter_the_plain_one() {
        let mut r = CensoredReadings::default();
        r.add_refused(0.01);
        r.add_refused(0.01);
        assert_eq!(r.mean(Some(&ReadingNoise::CS100A_CLASS)), None);
        let below = r.below_floor_y(Some(&ReadingNoise::CS100A_CLASS)).unwrap();
        assert!((0.0..0.01).contains(&below), "{below}");
        assert_eq!(r.below_floor_y(None), None);
        r.add(Xyz::new(0.01, 0.012, 0.01));
        assert_eq!(r.below_floor_y(Some(&ReadingNoise::CS100A_CLASS)), None);
        assert_eq!(r.mean(Some(&ReadingNoise::EXACT)).unwrap().y, 0.012);
        assert_eq!(r.mean(None).unwrap().y, 0.012);
    }

    #[test]
    fn the_censored_mean_holds_across_the_floor_from_mostly_given_to_mostly_refused() {
        let draws = normals(40_000);
        for truth in [0.002, 0.005, 0.01, 0.015, 0.03] {
            let r = censor(truth, 0.004, 0.01, &draws);
            let y = r.mean(Some(&ReadingNoise::CS100A_CLASS)).unwrap().y;
            assert!((y - truth).abs() < 0.0003, "{truth}: {y}");
        }
    }

    #[test]
    fn readings_merged_and_saved_estimate_as_if_taken_together() {
        let draws = normals(400);
        let (a, b) = draws.split_at(150);
        let mut merged = censor(0.008, 0.004, 0.01, a);
        merged.merge(&censor(0.008, 0.004, 0.01, b));
        let together = censor(0.008, 0.004, 0.01, &draws);
        assert_eq!(
            (merged.given(), merged.refused()),
            (together.given(), together.refused())
        );
        let noise = Some(&ReadingNoise::CS100A_CLASS);
        let (m, t) = (merged.mean(noise).unwrap(), together.mean(noise).unwrap());
        assert!((m.y - t.y).abs() < 1e-12 && (m.x - t.x).abs() < 1e-12);
        let text = serde_json::to_string(&merged).unwrap();
        let back: CensoredReadings = serde_json::from_str(&text).unwrap();
        assert_eq!(back, merged);
        assert!(CensoredReadings::default().is_empty() && !merged.is_empty());
    }

    #[test]
    fn refusals_without_a_known_floor_leave_the_plain_mean() {
        let mut r = CensoredReadings::default();
        r.add(Xyz::new(0.02, 0.02, 0.02));
        r.add_refused(f64::NAN);
        let m = r.mean(Some(&ReadingNoise::CS100A_CLASS)).unwrap();
        assert_eq!(m.y, 0.02);
    }

    #[test]
    fn readings_all_refused_leave_a_luminance_below_the_floor_that_falls_with_their_number() {
        let one = below_floor_mean_y(1, 0.01, 0.004);
        let four = below_floor_mean_y(4, 0.01, 0.004);
        let many = below_floor_mean_y(64, 0.01, 0.004);
        assert!(
            one > four && four > many && many > 0.0,
            "{one} {four} {many}"
        );
        assert!((0.004..0.008).contains(&one), "{one}");
        assert!(many < 0.003, "{many}");
        // Without noise above the floor, nothing below it is ruled out: about half of
        // the floor for a noise much smaller than it.
        let quiet = below_floor_mean_y(4, 0.01, 1e-5);
        assert!((quiet - 0.005).abs() < 1e-4, "{quiet}");
    }

    #[test]
    fn one_reading_given_of_many_refused_stays_finite_and_not_negative() {
        let y = censored_mean_y(0.0101, 1, 63, 0.01, 0.004);
        assert!(y.is_finite() && (0.0..0.01).contains(&y), "{y}");
        // One reading at 5 and one refused below 0.01 at a noise of 1e-6: each lies
        // equally many noise widths from the mean, which is halfway.
        let far = censored_mean_y(5.0, 1, 1, 0.01, 1e-6);
        assert!((far - 2.505).abs() < 1e-3, "{far}");
    }
}
