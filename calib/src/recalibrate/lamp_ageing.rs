//! How a display's lamp ages, learned from its full checks, and the channel factors a
//! white reading shows along it.
//!
//! One white reading has three numbers, and inverting it for three free channel factors
//! carries its colour noise into them about threefold: with a CS-100A class meter
//! (0.0005 in x and y) one reading left the factors 1–1.5 % apart where the lamp had
//! aged alike in all three, and the white shown through the refitted profile up to
//! 2.9 ΔE2000 off (heyewall-48, `bench season --noise realistic`). A lamp, though,
//! ages along one direction: each channel is the same lamp through the same filters
//! every night, so each keeps its share of the loss (a UHP lamp loses blue faster than
//! red). The full checks measure that share ([`LampAgeing::learn`]); a white check
//! then infers one number, the loss along it, from the white's luminance, and takes
//! the white's colour as the check of the model ([`channel_factors`]): where the colour
//! moved off the direction by more than the meter's noise explains (plus
//! [`DIRECTION_TOLERANCE_XY`]), something other than ageing happened and the display
//! is measured in full. Before a direction is learned every channel is taken to lose
//! alike, checked the same way. A meter whose colour noise is below what the direction
//! may miss (a noiseless one) keeps the inversion: its white is the better evidence
//! (with it the season's lamp-life forecast stays within 0.7 % of its horizon, where
//! the direction gave 2.9 %).

use lumiwall_core::Xyz;
use lumiwall_devices::ReadingNoise;
use serde::{Deserialize, Serialize};

use crate::measure::FullReading;

/// How a display's lamp ages: the full reading the current span of its ageing is
/// counted from, and each channel's loss over the last span that showed the direction.
/// A span ends at the first full check whose loss since its start reaches
/// [`LOSS_TO_USE_SIGMAS`] times the meter's luminance repeatability on the mean (the
/// shares drift as a lamp ages, its most depleted channel losing ever faster in
/// relative terms, so the last span is the one that counts; small losses add up
/// within a span, the readings between cancelling). A channel brighter than
/// [`BRIGHTER_SIGMAS`] since the span's start (a lamp change, or a fault) starts the
/// learning again from that reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LampAgeing {
    /// The full reading the current span started at.
    pub since: FullReading,
    /// Relative loss `1 − Y_end / Y_start` of red, green and blue over the last span
    /// that showed the direction (0.01: 1 % of the light); `None`: none yet.
    pub loss: Option<[f64; 3]>,
}

/// A channel this many times the meter's luminance repeatability (1σ of one reading)
/// brighter than at the span's start is not ageing: a lamp change or a fault (0.5 %
/// for a CS-100A class meter's 0.1 %; any gain for a noiseless meter).
pub const BRIGHTER_SIGMAS: f64 = 5.0;

/// Smallest mean loss over a span whose direction the white checks follow, in the
/// meter's luminance repeatability: at 20σ (2 % for a CS-100A class meter) a channel's
/// share is known to a few percent of itself, which over a week's further loss is well
/// inside the meter's own colour noise. A noiseless meter's every loss shows it.
pub const LOSS_TO_USE_SIGMAS: f64 = 20.0;

/// What the model of the white's colour may miss besides the meter's noise once the
/// lamp's shares are learned (CIE 1931 xy): they drift slowly as the lamp ages. About
/// 0.15 ΔE2000 at the white. A meter whose colour noise is below it gets the free
/// inversion instead ([`channel_factors`]); before the shares are learned a colour
/// change beyond the meter's noise goes to the full check, which learns them.
pub const DIRECTION_TOLERANCE_XY: f64 = 0.0002;

impl LampAgeing {
    /// Each channel's share of the loss over the last span that showed it, normalised
    /// to a mean of 1; `None` before one did, or where a share is not positive (a
    /// channel that gained light while the others aged is not a lamp's ageing).
    pub fn direction(&self) -> Option<[f64; 3]> {
        let loss = self.loss?;
        let mean = loss.iter().sum::<f64>() / 3.0;
        let u = loss.map(|l| l / mean);
        let ok = mean > 0.0 && loss.iter().all(|l| *l > 0.0);
        (ok && u.iter().all(|v| v.is_finite())).then_some(u)
    }

    /// What is known after the full reading `now`, read by a meter of `noise`:
    /// `previous`'s span (or one starting at `before`, the display's last full reading,
    /// where nothing was learned yet) ended, continued or started again (see
    /// [`LampAgeing`]). `previous` where a reading has no light.
    pub fn learn(
        previous: Option<LampAgeing>,
        before: &FullReading,
        now: &FullReading,
        noise: Option<&ReadingNoise>,
    ) -> Option<LampAgeing> {
        let start = previous.map_or(*before, |p| p.since);
        let loss: [f64; 3] = std::array::from_fn(|c| {
            let was = (start.primaries[c] - start.black).y;
            let is = (now.primaries[c] - now.black).y;
            1.0 - is / was
        });
        if !loss.iter().all(|l| l.is_finite()) {
            return previous;
        }
        let sigma = luminance_sigma(noise);
        let restart = LampAgeing {
            since: *now,
            loss: None,
        };
        if loss.iter().any(|l| -l > BRIGHTER_SIGMAS * sigma) {
            return Some(restart);
        }
        let mean = loss.iter().sum::<f64>() / 3.0;
        if mean > 0.0 && mean >= LOSS_TO_USE_SIGMAS * sigma {
            return Some(LampAgeing {
                loss: Some(loss),
                ..restart
            });
        }
        Some(LampAgeing {
            since: start,
            loss: previous.and_then(|p| p.loss),
        })
    }
}

/// The largest difference two readings of the same light show for a meter of 1σ
/// repeatability `sigma` without anything having changed: 3σ of their difference.
pub(crate) fn two_reading_limit(sigma: f64) -> f64 {
    3.0 * std::f64::consts::SQRT_2 * sigma
}

/// A full reading's channels at full drive (black removed) and what its white holds
/// beyond them (the black, a white segment, non-additivity; the black alone without a
/// white): the parts the white-check model scales, each channel by its factor and the
/// rest by their mean.
fn channels_and_rest(old: &FullReading) -> ([Xyz; 3], Xyz) {
    let p: [Xyz; 3] = std::array::from_fn(|c| old.primaries[c] - old.black);
    let rest = match old.white {
        Some(w) => w - (p[0] + p[1] + p[2]),
        None => old.black,
    };
    (p, rest)
}

/// The white the model shows with channel factors `s` on the full reading `old`:
/// `Σ s_c·p_c + mean(s)·rest` ([`channels_and_rest`]).
pub(crate) fn modelled_white(old: &FullReading, s: [f64; 3]) -> Xyz {
    let (p, rest) = channels_and_rest(old);
    let lamp = (s[0] + s[1] + s[2]) / 3.0;
    (0..3).fold(rest * lamp, |acc, c| acc + p[c] * s[c])
}

/// The meter's 1σ relative luminance repeatability (0 for a noiseless meter).
fn luminance_sigma(noise: Option<&ReadingNoise>) -> f64 {
    noise.map_or(0.0, |n| n.luminance_rel)
}

/// The factors `s` by which each channel's light changed since the full reading `old`,
/// from one white reading by a meter of `noise` (`None`: noiseless), along the lamp's ageing (`ageing`'s direction `u`, or every
/// channel alike before one is learned): `s_c = 1 + k·u_c`, with `k` from the white's
/// luminance. The white is `W = Σ s_c·p_c + mean(s)·(b + e)` with `p_c` the old
/// primaries less the black, `b` the old black and `e` what the old white had beyond
/// black and primaries (a white segment, or the display's non-additivity), both falling
/// with the lamp's mean. `None` where the white's chromaticity is further from that
/// model's than `3·√2` times the meter's xy repeatability (the difference of two
/// readings, 3σ), plus
/// [`DIRECTION_TOLERANCE_XY`] where the direction is learned: the white shows
/// something the lamp's ageing (as known) does not do, and the display needs its full
/// check. `None` too where the model has no light. A meter more precise than the
/// direction's own tolerance (a noiseless one) gets three free factors instead, the
/// white's three tristimulus values inverted (all alike where its colour moved within
/// the noise).
pub fn channel_factors(
    old: &FullReading,
    white: Xyz,
    noise: Option<&ReadingNoise>,
    ageing: Option<&LampAgeing>,
) -> Option<[f64; 3]> {
    let noise_xy = two_reading_limit(noise.map_or(0.0, |n| n.xy));
    if noise_xy < DIRECTION_TOLERANCE_XY {
        return inverted_factors(old, white, noise_xy);
    }
    let learned = ageing.and_then(LampAgeing::direction);
    let u = learned.unwrap_or([1.0; 3]);
    let (p, rest) = channels_and_rest(old);
    let share = |c: usize| p[c] + rest * (1.0 / 3.0);
    let unchanged = share(0) + share(1) + share(2);
    let along = (0..3).fold(Xyz::new(0.0, 0.0, 0.0), |acc, c| acc + share(c) * u[c]);
    if along.y <= 0.0 {
        return None;
    }
    let k = (white.y - unchanged.y) / along.y;
    let model = unchanged + along * k;
    let moved = white.chromaticity()?.distance(model.chromaticity()?);
    let model_tolerance = if learned.is_some() {
        DIRECTION_TOLERANCE_XY
    } else {
        0.0
    };
    let tolerance = noise_xy + model_tolerance;
    let s = u.map(|uc| 1.0 + k * uc);
    (moved <= tolerance && s.iter().all(|v| v.is_finite())).then_some(s)
}

/// The factors of [`channel_factors`] for a meter whose colour noise (`noise_xy`, 3σ of
/// two readings) is below what the direction may miss ([`DIRECTION_TOLERANCE_XY`]: a
/// noiseless meter): the white's own colour is the better evidence, and the three
/// tristimulus values are inverted for three free factors; all alike where the
/// chromaticity moved within `noise_xy`. `None` where the old primaries do not span
/// the white.
fn inverted_factors(old: &FullReading, white: Xyz, noise_xy: f64) -> Option<[f64; 3]> {
    let (p, rest) = channels_and_rest(old);
    let unchanged = p[0] + p[1] + p[2] + rest;
    let moved = white.chromaticity()?.distance(unchanged.chromaticity()?);
    if moved <= noise_xy && unchanged.y > 0.0 {
        let k = white.y / unchanged.y;
        return k.is_finite().then_some([k; 3]);
    }
    let cols: [[f64; 3]; 3] = std::array::from_fn(|c| (p[c] + rest * (1.0 / 3.0)).to_array());
    let inv = lumiwall_core::mat3::inverse(&lumiwall_core::mat3::from_columns(&cols))?;
    let s = lumiwall_core::mat3::mul_vec(&inv, &white.to_array());
    s.iter().all(|v| v.is_finite()).then_some(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recalibrate::tests::{commissioned, white_moved};

    /// A CS-100A class meter's stated noise (0.0005 xy, 0.1 % in Y).
    const CS100A: Option<&ReadingNoise> = Some(&ReadingNoise::CS100A_CLASS);

    /// Red, green and blue's shares of a UHP lamp's loss (blue fastest).
    const SHARES: [f64; 3] = [0.8, 0.9, 1.3];

    /// `old` with each channel's light scaled by `s` (black and the white's rest by
    /// their mean), as a lamp's ageing does.
    fn aged(old: &FullReading, s: [f64; 3]) -> FullReading {
        let mean = (s[0] + s[1] + s[2]) / 3.0;
        let black = old.black * mean;
        let p: [Xyz; 3] = std::array::from_fn(|c| old.primaries[c] - old.black);
        let rest = old.white.map(|w| w - (p[0] + p[1] + p[2]));
        let primaries = std::array::from_fn(|c| black + p[c] * s[c]);
        let white = rest.map(|r| (0..3).fold(r * mean, |acc, c| acc + p[c] * s[c]));
        FullReading {
            black,
            primaries,
            white,
        }
    }

    /// Factors of a lamp that lost `loss` along [`SHARES`].
    fn along_shares(loss: f64) -> [f64; 3] {
        SHARES.map(|w| 1.0 - w * loss)
    }

    /// What a full check 4 % into the lamp's loss teaches.
    fn learned() -> LampAgeing {
        let before = commissioned();
        LampAgeing::learn(None, &before, &aged(&before, along_shares(0.04)), CS100A).unwrap()
    }

    /// `w` with its chromaticity moved by `dx` in x at the same luminance.
    fn moved_x(w: Xyz, dx: f64) -> Xyz {
        let xy = w.chromaticity().unwrap();
        Xyz::from_xy_luminance(xy.x + dx, xy.y, w.y)
    }

    #[test]
    fn an_unchanged_white_gives_factors_of_one_with_or_without_a_learned_direction() {
        let w = commissioned().white.unwrap();
        for ageing in [None, Some(learned())] {
            let s = channel_factors(&commissioned(), w, CS100A, ageing.as_ref()).unwrap();
            for k in s {
                assert!((k - 1.0).abs() < 1e-12, "{s:?}");
            }
        }
    }

    #[test]
    fn a_white_whose_colour_moved_within_the_meter_noise_scales_all_channels_alike() {
        // one reading 1σ off in x (K-10-A, CS-100A: 0.0005), 1 % darker
        let s = channel_factors(&commissioned(), white_moved(0.0005, 0.99), CS100A, None).unwrap();
        for k in s {
            assert!((k - 0.99).abs() < 1e-12, "{s:?}");
        }
    }

    #[test]
    fn a_white_whose_colour_moved_beyond_the_meter_noise_before_a_direction_is_learned_needs_the_full_check()
     {
        let white = white_moved(0.004, 0.99);
        assert_eq!(channel_factors(&commissioned(), white, CS100A, None), None);
        // a noiseless meter's white is inverted for the three factors instead
        let white = white_moved(1e-6, 1.0);
        let s = channel_factors(&commissioned(), white, None, None);
        assert_eq!(s, Some(free_inversion(&commissioned(), white)));
        assert_ne!(s.unwrap()[0], s.unwrap()[2]);
    }

    #[test]
    fn a_white_aged_along_the_learned_direction_gives_each_channel_its_share() {
        let old = commissioned();
        let truth = along_shares(0.05);
        let white = aged(&old, truth).white.unwrap();
        let s = channel_factors(&old, white, CS100A, Some(&learned())).unwrap();
        for c in 0..3 {
            assert!((s[c] - truth[c]).abs() < 1e-9, "{s:?} vs {truth:?}");
        }
        // the same white read 1σ off in x (0.0005) and in Y (0.1 %): the factors move
        // by the luminance error alone, where the free inversion of the three
        // tristimulus values moves them by the colour error too
        let noisy = moved_x(white, 0.0005) * 1.001;
        let s = channel_factors(&old, noisy, CS100A, Some(&learned())).unwrap();
        let worst = (0..3).fold(0.0f64, |m, c| m.max((s[c] - truth[c]).abs()));
        let free = free_inversion(&old, noisy);
        let free_worst = (0..3).fold(0.0f64, |m, c| m.max((free[c] - truth[c]).abs()));
        println!("along the direction {s:?}, free {free:?}, truth {truth:?}");
        assert!(worst < 0.0015, "{s:?} vs {truth:?}");
        assert!(free_worst > 2.0 * worst, "{free:?} vs {s:?}");
    }

    /// The three factors that reproduce `white` exactly (the model with a free factor
    /// per channel).
    fn free_inversion(old: &FullReading, white: Xyz) -> [f64; 3] {
        let p: [Xyz; 3] = std::array::from_fn(|c| old.primaries[c] - old.black);
        let rest = old.white.unwrap() - (p[0] + p[1] + p[2]);
        let cols: [[f64; 3]; 3] = std::array::from_fn(|c| (p[c] + rest * (1.0 / 3.0)).to_array());
        let inv = lumiwall_core::mat3::inverse(&lumiwall_core::mat3::from_columns(&cols)).unwrap();
        lumiwall_core::mat3::mul_vec(&inv, &white.to_array())
    }

    #[test]
    fn a_white_off_the_learned_direction_beyond_the_meter_noise_needs_the_full_check() {
        let old = commissioned();
        let white = aged(&old, along_shares(0.05)).white.unwrap();
        let off = moved_x(white, 0.004);
        assert_eq!(channel_factors(&old, off, CS100A, Some(&learned())), None);
        // a meter of a fifth of that noise: beyond the model's own tolerance, and
        // within it
        let precise = ReadingNoise {
            xy: 0.0001,
            ..ReadingNoise::CS100A_CLASS
        };
        let tolerance = two_reading_limit(precise.xy) + DIRECTION_TOLERANCE_XY;
        let off = moved_x(white, 1.2 * tolerance);
        assert_eq!(
            channel_factors(&old, off, Some(&precise), Some(&learned())),
            None
        );
        let near = moved_x(white, 0.8 * tolerance);
        assert!(channel_factors(&old, near, Some(&precise), Some(&learned())).is_some());
    }

    #[test]
    fn a_full_check_learns_each_channel_share_of_the_loss() {
        let d = learned().direction().unwrap();
        let mean = SHARES.iter().sum::<f64>() / 3.0;
        for c in 0..3 {
            assert!((d[c] - SHARES[c] / mean).abs() < 1e-12, "{d:?}");
        }
    }

    #[test]
    fn a_lamp_change_starts_the_learning_again_from_its_reading() {
        let before = commissioned();
        let known = Some(learned());
        let span_start = learned().since;
        // a new lamp: every channel brighter
        let brighter = aged(&span_start, [1.3, 1.25, 1.4]);
        let after = LampAgeing::learn(known, &before, &brighter, CS100A).unwrap();
        assert_eq!((after.since, after.direction()), (brighter, None));
        // one channel brighter while the others fell: not ageing either
        let odd = aged(&span_start, [1.01, 0.95, 0.95]);
        let after = LampAgeing::learn(known, &before, &odd, CS100A).unwrap();
        assert_eq!((after.since, after.direction()), (odd, None));
    }

    #[test]
    fn small_losses_add_up_from_the_span_start_until_they_show_the_direction() {
        let before = commissioned();
        // 0.2 %, then 1 % more, then 1 % more: the span runs from the commissioning
        let little = aged(&before, along_shares(0.002));
        let first = LampAgeing::learn(None, &before, &little, CS100A).unwrap();
        assert_eq!((first.since, first.direction()), (before, None));
        let more = aged(&little, along_shares(0.01));
        let second = LampAgeing::learn(Some(first), &little, &more, CS100A).unwrap();
        assert_eq!(
            (second.since, second.direction()),
            (before, None),
            "1.2 % lost"
        );
        let later = aged(&more, along_shares(0.01));
        let third = LampAgeing::learn(Some(second), &more, &later, CS100A).unwrap();
        assert_eq!(third.since, later, "2.2 % lost: the span ends");
        let d = third.direction().expect("shown");
        let mean = SHARES.iter().sum::<f64>() / 3.0;
        for c in 0..3 {
            assert!((d[c] - SHARES[c] / mean).abs() < 0.01, "{d:?}");
        }
        // a noiseless meter's every loss shows it
        let exact = LampAgeing::learn(None, &before, &little, None).unwrap();
        assert!(exact.direction().is_some(), "{exact:?}");
    }

    #[test]
    fn the_last_span_that_showed_the_direction_replaces_the_one_before() {
        let first = learned();
        let now = first.since;
        let later = aged(&now, [0.95; 3]);
        let second = LampAgeing::learn(Some(first), &now, &later, CS100A).unwrap();
        let d = second.direction().unwrap();
        assert!(d.iter().all(|u| (u - 1.0).abs() < 1e-12), "{d:?}");
    }
}
