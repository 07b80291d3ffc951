//! A channel's colour from every reading of it, not from its full-drive reading alone.
//!
//! The model of an additive display says a channel's light above black keeps its
//! chromaticity at every drive (`R(d) − K = c(d)·P`), so each ramp sample bright enough
//! to read well is another reading of the channel's colour: a filter colorimeter's
//! chromaticity noise (about 0.0005 in x and y per reading for a CS-100A class meter)
//! is the same at a quarter of the channel's light as at full drive. With 40 readings
//! per display the full-drive primaries are read twice; their ramps add four to six
//! bright samples each, so the pooled colour of a channel is known two to three times
//! better, and with it the white and every grey the solve mixes from the three
//! (realistic meter, 40 readings per display, 40 unseen seeds each of mono-2x1,
//! offaxis-gain-2x1, infitec-pair and weak-channel-3x1, verified against the truth:
//! mean white ΔE2000 0.83–1.21 → 0.69–0.94, runs within every limit 82 → 102 of 160).
//! The measurement pools them once its ramps are read, and the commissioning again
//! after the grey-drive pass has added its samples at the white's drives.
//!
//! [`pool`] fits each channel's black-subtracted colour `P` by weighted
//! least squares over the full-drive reading (at intensity 1 by definition) and the
//! ramp samples (each at the intensity its reading has along `P`), X, Y and Z weighted
//! by the inverse of their variance under the meter's stated noise (the black's
//! included: it is subtracted from each). The size of `P` is the full-drive reading's
//! own component along the pooled colour, weighted as each sample's intensity is, so
//! that the full drive sits at intensity 1 as each sample sits at its own (the tone
//! curves are normalised to it). Taking the full-drive reading's Y instead let a weak
//! blue's full drive follow its Y (0.9 cd/m², read to 0.45 %) while its samples
//! followed their Z (read to 0.2 %): the white, where that blue is at full drive, and
//! the greys below it disagreed (realistic meter, 40 readings, weak-channel-3x1 over
//! 40 unseen seeds: largest white ΔE2000 1.20 → 0.84, runs within every limit of
//! issue 12 32 → 34; the other classes within a seed's noise). A
//! pooled colour farther from the full-drive reading than its noise allows
//! ([`MAX_DEVIATION_SIGMAS`]) means the channel's colour does change with drive (or
//! the display changed during the run), and the full-drive reading is kept.

use lumiwall_core::Channel;
use lumiwall_devices::{ReadingNoise, Xyz};

use super::{ChannelLine, MeasureLog, Patch, relative_intensity};

/// Smallest intensity (share of the full drive's light above black) of a ramp sample
/// that counts for the channel's colour: below it black's noise and the sample's own
/// zero-light noise outweigh what it adds.
pub const MIN_POOLED_INTENSITY: f64 = 0.1;

/// How far (in standard errors of the full-drive reading's own chromaticity) the pooled
/// colour may lie from it before it is taken for a colour that changes with drive.
pub const MAX_DEVIATION_SIGMAS: f64 = 4.0;

/// Rounds of re-estimating the samples' intensities along the pooled colour.
const ROUNDS: usize = 3;

/// One averaged reading of a channel: its drive, XYZ (black included) and readings
/// averaged.
#[derive(Debug, Clone, Copy)]
struct Averaged {
    drive: f64,
    xyz: Xyz,
    readings: u32,
}

/// A display's channels as the solve takes them: the full-drive primaries (black
/// included) with each channel's colour pooled over its ramp samples in `log`
/// (module docs), and every ramp sample of `log` put on its channel's pooled line
/// ([`ChannelLine::reading`]), in the order taken. The full-drive readings are the
/// log's (the last of each primary; `primaries` where the log has none). Without a
/// stated, non-zero noise, or for a channel without a bright ramp sample, a channel's
/// colour is its full-drive reading's.
pub fn pool(
    log: &MeasureLog,
    black: Xyz,
    primaries: [Xyz; 3],
    noise: Option<ReadingNoise>,
) -> ([Xyz; 3], [Vec<(f64, Xyz)>; 3]) {
    let full: [Averaged; 3] = std::array::from_fn(|i| {
        let c = Channel::ALL[i];
        last_record(log, Patch::Primary(c)).unwrap_or(Averaged {
            drive: 1.0,
            xyz: primaries[i],
            readings: 1,
        })
    });
    let pooled = match noise.filter(|n| !n.is_exact()) {
        Some(n) => {
            let black = Averaged {
                drive: 0.0,
                xyz: black,
                readings: log.readings_of(Patch::Black).max(1),
            };
            std::array::from_fn(|i| {
                let samples = ramp_samples(log, Channel::ALL[i]);
                pooled_channel(black, full[i], &samples, &n)
                    .map_or(full[i].xyz, |p| black.xyz + Xyz::from_array(p))
            })
        }
        None => full.map(|f| f.xyz),
    };
    let ramps = std::array::from_fn(|i| {
        let line = ChannelLine {
            black,
            full: pooled[i],
            noise,
        };
        ramp_samples(log, Channel::ALL[i])
            .into_iter()
            .map(|s| (s.drive, line.reading(s.xyz)))
            .collect()
    });
    (pooled, ramps)
}

/// Relative standard error of each ramp sample's intensity, per channel in the order
/// [`pool`] gives the ramps: one reading's error along the channel's line
/// ([`ChannelLine::intensity_sigma`], `primaries`: the pooled ones) over the square root
/// of the `n` readings averaged, divided by the sample's intensity along the line,
/// times the share of the stated noise the log's repeated readings showed
/// ([`super::noise_seen::NoiseSeen::scale`]). The black's own noise is left out: it
/// moves every sample of a channel alike, which no smoothing removes. Empty without a
/// stated, non-zero noise (the curves then pass through the samples:
/// [`crate::tone::smoothing`]); 0 for a sample with no light along `p`, and for every
/// sample where the repeated readings showed no noise at all.
pub fn ramp_sigma_rel(
    log: &MeasureLog,
    black: Xyz,
    primaries: [Xyz; 3],
    noise: Option<ReadingNoise>,
) -> [Vec<f64>; 3] {
    let Some(noise) = noise.filter(|n| !n.is_exact()) else {
        return Default::default();
    };
    let seen = log.noise_seen.scale();
    std::array::from_fn(|i| {
        let line = ChannelLine {
            black,
            full: primaries[i],
            noise: Some(noise),
        };
        ramp_samples(log, Channel::ALL[i])
            .into_iter()
            .map(|s| {
                let Some(one) = line.intensity_sigma(s.xyz) else {
                    return 0.0;
                };
                let r = relative_intensity(s.xyz, black, primaries[i]);
                let rel = seen * one / (f64::from(s.readings).sqrt() * r);
                if rel.is_finite() && rel > 0.0 {
                    rel
                } else {
                    0.0
                }
            })
            .collect()
    })
}

/// The last reading of `patch` in `log` ([`MeasureLog::last_read`]).
fn last_record(log: &MeasureLog, patch: Patch) -> Option<Averaged> {
    let r = log.last_read(patch)?;
    Some(Averaged {
        drive: 1.0,
        xyz: r.xyz?,
        readings: r.repeats.max(1),
    })
}

/// Channel `c`'s ramp readings in `log`, as read (black included), in the order taken.
fn ramp_samples(log: &MeasureLog, c: Channel) -> Vec<Averaged> {
    log.samples
        .iter()
        .filter_map(|r| match (r.patch, r.xyz) {
            (Patch::Ramp(rc, drive), Some(xyz)) if rc == c => Some(Averaged {
                drive,
                xyz,
                readings: r.repeats.max(1),
            }),
            _ => None,
        })
        .collect()
}

/// Variance of X, Y and Z of `a` minus `black` under `noise`.
fn variance_above_black(a: Averaged, black: Averaged, noise: &ReadingNoise) -> [f64; 3] {
    let sa = noise.sigma_xyz(a.xyz);
    let sk = noise.sigma_xyz(black.xyz);
    std::array::from_fn(|k| {
        sa[k] * sa[k] / f64::from(a.readings) + sk[k] * sk[k] / f64::from(black.readings)
    })
}

/// Weighted least-squares intensity of `v` along `p` (X, Y, Z weighted by `1/var`).
fn intensity_along(v: [f64; 3], p: [f64; 3], var: [f64; 3]) -> Option<f64> {
    let (mut num, mut den) = (0.0, 0.0);
    for k in 0..3 {
        if var[k] > 0.0 {
            num += p[k] * v[k] / var[k];
            den += p[k] * p[k] / var[k];
        }
    }
    (den > 0.0 && num.is_finite()).then(|| num / den)
}

/// The pooled full-drive light of one channel above black, or `None` when no ramp
/// sample is bright enough, the numbers are not finite, or the pooled colour is
/// implausibly far from the full-drive reading.
fn pooled_channel(
    black: Averaged,
    full: Averaged,
    samples: &[Averaged],
    noise: &ReadingNoise,
) -> Option<[f64; 3]> {
    let above = |a: Averaged| (a.xyz - black.xyz).to_array();
    let p0 = above(full);
    if p0[1] <= 0.0 {
        return None;
    }
    let full_var = variance_above_black(full, black, noise);
    let vars: Vec<[f64; 3]> = samples
        .iter()
        .map(|s| variance_above_black(*s, black, noise))
        .collect();
    let mut p = p0;
    let mut used = 0;
    for _ in 0..ROUNDS {
        let mut num: [f64; 3] = std::array::from_fn(|k| p0[k] / full_var[k]);
        let mut den = full_var.map(|v| 1.0 / v);
        used = 0;
        for (s, var) in samples.iter().zip(&vars) {
            let v = above(*s);
            let Some(k_i) = intensity_along(v, p, *var).filter(|k| *k >= MIN_POOLED_INTENSITY)
            else {
                continue;
            };
            used += 1;
            for k in 0..3 {
                num[k] += k_i * v[k] / var[k];
                den[k] += k_i * k_i / var[k];
            }
        }
        let pooled: [f64; 3] = std::array::from_fn(|k| num[k] / den[k]);
        if pooled.iter().any(|v| !v.is_finite()) {
            return None;
        }
        // A channel adds no negative light: a saturated channel's near-zero component
        // (an Infitec red's Z) may come out below zero from the black's noise.
        let pooled = pooled.map(|v| v.max(0.0));
        // The full-drive reading sits at intensity 1 as every sample sits at its own:
        // its weighted component along the pooled colour, not its Y alone.
        let scale = intensity_along(p0, pooled, full_var)?;
        p = pooled.map(|v| v * scale);
    }
    let plausible = p.iter().all(|v| v.is_finite())
        && used > 0
        && deviation_sigmas(p0, p, full, noise) <= MAX_DEVIATION_SIGMAS;
    plausible.then_some(p)
}

/// Chromaticity distance of the pooled colour `p` from the full-drive colour `p0`, in
/// standard errors of the full-drive reading's x (or y).
fn deviation_sigmas(p0: [f64; 3], p: [f64; 3], full: Averaged, noise: &ReadingNoise) -> f64 {
    let (Some(a), Some(b)) = (Xyz::from_array(p0).xy(), Xyz::from_array(p).xy()) else {
        return f64::INFINITY;
    };
    let se = noise.xy / f64::from(full.readings).sqrt();
    if se <= 0.0 {
        return f64::INFINITY;
    }
    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
    d / (se * std::f64::consts::SQRT_2)
}

#[cfg(test)]
mod tests {
    use super::super::ReadingRecord;
    use super::*;
    use lumiwall_core::Xy;

    const BLACK: [f64; 3] = [0.2, 0.2, 0.3];
    const RED: [f64; 3] = [40.0, 21.0, 2.0];

    fn record(patch: Patch, xyz: Xyz) -> ReadingRecord {
        ReadingRecord {
            patch,
            xyz: Some(xyz),
            repeats: 1,
            low_light: false,
        }
    }

    /// Black, full-drive red and red ramp samples at `drives` whose light above black
    /// is `colour(d)` scaled to `d²` of the red's luminance.
    fn log_with_red_ramp(drives: &[f64], colour: impl Fn(f64) -> [f64; 3]) -> MeasureLog {
        let black = Xyz::from_array(BLACK);
        let mut samples = vec![
            record(Patch::Black, black),
            record(Patch::Primary(Channel::Red), black + Xyz::from_array(RED)),
        ];
        for &d in drives {
            let c = Xyz::from_array(colour(d));
            samples.push(record(
                Patch::Ramp(Channel::Red, d),
                black + c * (d * d * RED[1] / c.y),
            ));
        }
        MeasureLog {
            samples,
            ..MeasureLog::default()
        }
    }

    fn primaries() -> [Xyz; 3] {
        let black = Xyz::from_array(BLACK);
        [
            black + Xyz::from_array(RED),
            black + Xyz::new(30.0, 60.0, 10.0),
            black + Xyz::new(15.0, 6.0, 80.0),
        ]
    }

    #[test]
    fn a_ramp_samples_relative_error_grows_in_the_dark_and_falls_with_its_readings() {
        let black = Xyz::from_array(BLACK);
        let mut log = log_with_red_ramp(&[0.05, 0.5], |_| RED);
        let sigma = ramp_sigma_rel(&log, black, primaries(), Some(ReadingNoise::CS100A_CLASS));
        let [dark, bright] = [sigma[0][0], sigma[0][1]];
        // At 0.5 the red is 5 cd/m² (X and Y at 0.2 % and 0.1 %); at 0.05 it is 0.05
        // cd/m², where the sensors' zero-light noise dominates.
        assert!(bright > 0.0005 && bright < 0.002, "{bright}");
        assert!(dark > 10.0 * bright, "{dark} vs {bright}");
        assert!(sigma[1].is_empty() && sigma[2].is_empty());
        // Four readings averaged halve it.
        log.samples[2].repeats = 4;
        let four = ramp_sigma_rel(&log, black, primaries(), Some(ReadingNoise::CS100A_CLASS))[0][0];
        assert!((four / dark - 0.5).abs() < 1e-9, "{four} vs {dark}");
        // An exact meter's samples state no error: the curve goes through them.
        let exact = ReadingNoise::EXACT;
        assert!(
            ramp_sigma_rel(&log, black, primaries(), Some(exact))
                .iter()
                .all(Vec::is_empty)
        );
        assert!(
            ramp_sigma_rel(&log, black, primaries(), None)
                .iter()
                .all(Vec::is_empty)
        );
    }

    #[test]
    fn a_ramp_of_the_full_drive_colour_with_a_bright_sample_off_moves_the_colour_towards_it() {
        // One bright sample reads the red 0.001 redder in x (within the noise): the
        // pooled red moves part of the way, keeping its luminance.
        let shifted = |d: f64| {
            if d > 0.85 {
                let xy = Xyz::from_array(RED).xy().unwrap();
                Xy::new(xy[0] + 0.001, xy[1]).with_luminance(1.0).to_array()
            } else {
                RED
            }
        };
        let log = log_with_red_ramp(&[0.3, 0.6, 0.9], shifted);
        let black = Xyz::from_array(BLACK);
        let (p, ramps) = pool(&log, black, primaries(), Some(ReadingNoise::CS100A_CLASS));
        let x0 = Xyz::from_array(RED).xy().unwrap()[0];
        let x = (p[0] - black).xy().unwrap()[0];
        assert!(x > x0 + 0.0002 && x < x0 + 0.0008, "{x0} → {x}");
        assert!(((p[0] - black).y / RED[1] - 1.0).abs() < 1e-3);
        // The ramps lie on the pooled line.
        for (d, s) in &ramps[0] {
            let sx = (*s - black).xy().unwrap()[0];
            assert!((sx - x).abs() < 1e-9, "{d}: {sx} vs {x}");
        }
        assert_eq!(ramps[0].len(), 3);
    }

    #[test]
    fn a_weak_blues_full_drive_size_follows_its_precise_z_not_its_noisy_y() {
        // A failing blue of 0.9 cd/m²: the Y sensor's zero-light noise (0.004 cd/m²)
        // is 0.45 % of it, the Z sensor reads its 19 cd/m² to 0.2 %. The full-drive
        // reading's Y is 1 % high (2σ), its X and Z exact, and the ramp is exact: the
        // samples' intensities follow their Z, so the full drive's size must too, or
        // the white (the blue at full drive) and the greys below it disagree by 1 %.
        let black = Xyz::from_array(BLACK);
        let blue = [3.5, 0.9, 19.0];
        let read_full = black + Xyz::new(blue[0], blue[1] * 1.01, blue[2]);
        let mut samples = vec![
            record(Patch::Black, black),
            record(Patch::Primary(Channel::Blue), read_full),
        ];
        for d in [0.5_f64, 0.7, 0.85] {
            let k = d.powf(2.2);
            samples.push(record(
                Patch::Ramp(Channel::Blue, d),
                black + Xyz::from_array(blue) * k,
            ));
        }
        let log = MeasureLog {
            samples,
            ..MeasureLog::default()
        };
        let mut prims = primaries();
        prims[2] = read_full;
        let (p, ramps) = pool(&log, black, prims, Some(ReadingNoise::CS100A_CLASS));
        let z = (p[2] - black).z;
        assert!(
            (z / blue[2] - 1.0).abs() < 0.002,
            "Z {z} against {}",
            blue[2]
        );
        // Each sample then sits at its own intensity along the pooled blue.
        for (d, s) in &ramps[2] {
            let k = (*s - black).z / z;
            assert!((k / d.powf(2.2) - 1.0).abs() < 0.002, "{d}: {k}");
        }
    }

    #[test]
    fn a_colour_that_changes_with_drive_far_beyond_the_noise_keeps_the_full_drive_reading() {
        let drifting = |d: f64| {
            let xy = Xyz::from_array(RED).xy().unwrap();
            Xy::new(xy[0] - 0.02 * (1.0 - d), xy[1])
                .with_luminance(1.0)
                .to_array()
        };
        let log = log_with_red_ramp(&[0.3, 0.5, 0.7], drifting);
        let (p, _) = pool(
            &log,
            Xyz::from_array(BLACK),
            primaries(),
            Some(ReadingNoise::CS100A_CLASS),
        );
        assert_eq!(p[0], primaries()[0]);
    }

    #[test]
    fn without_stated_noise_or_with_an_exact_meter_the_primaries_are_the_full_drive_readings() {
        let off = |_: f64| [41.0, 21.0, 2.0];
        let log = log_with_red_ramp(&[0.4, 0.8], off);
        let exact = ReadingNoise::EXACT;
        for n in [None, Some(exact)] {
            let (p, ramps) = pool(&log, Xyz::from_array(BLACK), primaries(), n);
            assert_eq!(p, primaries(), "{n:?}");
            assert_eq!(ramps[0].len(), 2);
        }
    }
}
