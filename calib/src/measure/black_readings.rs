//! How often a display's black is read: often enough for the darkest grey a
//! verification checks, within a share of the display's budget.
//!
//! Why: with individual black every colour the profile shows rides on the display's
//! black as measured, so the black's error is added whole to every patch, and it weighs
//! most in the darkest. On a wall of about 12 cd/m² the verification chart's 2 % grey is
//! 0.24 cd/m², and a CS-100A class meter's zero-light noise is 0.008 cd/m² in X per
//! reading: the four readings the black used to get left it 0.011 cd/m² off in X on
//! one display (a `mono-2x1` whose lamps give a 12.7 cd/m² white, seed 107, 120
//! readings), and that display's 2 % grey 0.008 off in xy (ΔE2000 2.5). A bright wall
//! needs no more than the four: there the black's noise is a small part of that grey.

use lumiwall_devices::{ReadingNoise, Xyz};

/// The darkest grey the verification chart (`verify --chart 51`) gives as a share of
/// the target white's luminance: the grey whose colour the black's error moves most on a
/// dim wall. (Above 50 cd/m² the chart's 1 cd/m² grey is darker, but there four
/// readings are more than this share's grey needs and nothing changes.)
pub const DARKEST_GREY_SHARE: f64 = 0.02;

/// Standard error of the black's mean in each of X, Y and Z that its readings aim at,
/// relative to that tristimulus value of the darkest grey (1.5 % moves a 2 % grey by
/// about 0.003 in x or y at most). Realistic meter, `bench/walls/`, unseen seeds, runs
/// within every limit of issue 12 with four readings always / 1 % / 1.5 %:
/// dim-mono-2x1 (20 seeds) at 40 readings 4 / 11 / 11, at 64 13 / 17 / 18;
/// dim-infitec-pair (20) at 40 8 / 8 / 8 (mean worst grey balance 0.58 / 0.54 / 0.54),
/// at 64 17 / 15 / 17; weak-green-infitec-2x2 (10) at 64 0 / 1 / 1 (grey balance
/// 0.69 / 0.59 / 0.59), at 40 none of 10 either way (1.15 / 1.30 / 1.30: there the
/// ramps need the readings more, and no share of 40 meets). Of the fixture walls only
/// weak-channel-3x1 (white ≈ 15 cd/m²) changes: its black gets five readings at 1 %
/// (mean worst grey balance at 40 0.32 → 0.28) and hardly more at 1.5 % (0.319 →
/// 0.318; 40 of 40 seeds each).
pub const BLACK_REL_SE: f64 = 0.015;

/// The black takes at most this share of a display's budget (in readings, rounded
/// down): the ramps need the rest (at 40 readings, eight for the black instead of four
/// took dim-lcd-3x2's mean worst grey balance from 0.45 to 1.6 on ten seeds, its toes
/// unsampled; a tenth instead of an eighth: dim-mono-2x1 at 40 back to 4 of 20).
pub const BLACK_BUDGET_SHARE: f64 = 0.125;

/// The XYZ of the darkest grey ([`DARKEST_GREY_SHARE`]) of a target white of
/// chromaticity `white_xy` and luminance `white_y_cd_m2`.
pub fn darkest_grey(white_xy: [f64; 2], white_y_cd_m2: f64) -> Xyz {
    Xyz::from_xy_luminance(white_xy[0], white_xy[1], DARKEST_GREY_SHARE * white_y_cd_m2)
}

/// Readings of the black, averaged, that put its mean within [`BLACK_REL_SE`] of
/// `darkest_grey` in every tristimulus value with a meter of this stated noise, and the
/// most [`BLACK_BUDGET_SHARE`] of `budget` allows: `(needed, allowed)`. Needed is 0 for
/// an exact meter, or a grey that is not above 0 in every value.
pub fn for_darkest_grey(
    noise: &ReadingNoise,
    black: Xyz,
    darkest_grey: Xyz,
    budget: u32,
) -> (u32, u32) {
    let allowed = (f64::from(budget) * BLACK_BUDGET_SHARE).floor() as u32;
    let grey = darkest_grey.to_array();
    if noise.is_exact() || grey.iter().any(|g| !g.is_finite() || *g <= 0.0) {
        return (0, allowed);
    }
    let sigma = noise.sigma_xyz(black);
    let needed = (0..3)
        .map(|k| (sigma[k] / (BLACK_REL_SE * grey[k])).powi(2))
        .fold(0.0, f64::max)
        .ceil()
        .min(f64::from(u32::MAX));
    (needed as u32, allowed)
}

#[cfg(test)]
mod tests {
    use super::*;

    const D65: [f64; 2] = [0.3127, 0.3290];

    #[test]
    fn a_dim_wall_reads_its_black_more_often_than_a_bright_one() {
        let black = Xyz::new(0.018, 0.016, 0.05);
        let (dim, _) = for_darkest_grey(
            &ReadingNoise::CS100A_CLASS,
            black,
            darkest_grey(D65, 12.0),
            120,
        );
        let (bright, _) = for_darkest_grey(
            &ReadingNoise::CS100A_CLASS,
            black,
            darkest_grey(D65, 47.0),
            120,
        );
        // 12 cd/m²: a 0.24 cd/m² grey, X 0.228; 0.008 / (0.015 · 0.228) squared is 5.5.
        assert_eq!(dim, 6);
        assert!(bright <= 1, "{bright}");
    }

    #[test]
    fn the_black_takes_at_most_an_eighth_of_the_budget() {
        let black = Xyz::new(0.05, 0.03, 0.15);
        let grey = darkest_grey(D65, 8.0);
        // An 8 cd/m² white: X of its 2 % grey 0.152, 0.008 / (0.015 · 0.152) squared 12.3.
        assert_eq!(
            for_darkest_grey(&ReadingNoise::CS100A_CLASS, black, grey, 40),
            (13, 5)
        );
        assert_eq!(
            for_darkest_grey(&ReadingNoise::CS100A_CLASS, black, grey, 64),
            (13, 8)
        );
    }

    #[test]
    fn an_exact_meter_or_a_grey_without_light_needs_no_more_readings() {
        let exact = ReadingNoise::EXACT;
        let black = Xyz::new(0.05, 0.03, 0.15);
        let grey = darkest_grey(D65, 8.0);
        assert_eq!(for_darkest_grey(&exact, black, grey, 120).0, 0);
        assert_eq!(
            for_darkest_grey(&ReadingNoise::CS100A_CLASS, black, Xyz::default(), 120).0,
            0
        );
    }
}
