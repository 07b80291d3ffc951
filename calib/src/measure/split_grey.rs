//! Dark greys read whole and split into their channels' intensities.
//!
//! A grey shown at drives `d = (d_R, d_G, d_B)` reads `XYZ = K + P·a` on an additive
//! display (`K` the black, `P` the black-subtracted primaries as columns, `a` the
//! channels' relative intensities at their drives), or `K + P·a + W·min(a)` with a white
//! colour-wheel segment ([`DisplayModel`]). One reading of it therefore gives all three
//! channels' intensities, `m = P⁻¹·(XYZ − K)` and `a` from the model's own inverse
//! ([`DisplayModel::channels_for`]): three toe samples for the price of one.
//!
//! Why, on a dim wall: the chart's darkest greys (2 % and 5 % of the white) sit in the
//! tone curves' toes, which the ramps left unsampled at 40 readings when every dark
//! reading was averaged four times (a 12 cd/m² wall's green below drive 0.2; a dark
//! channel sample now averages at most [`super::DARK_CHANNEL_REPEATS`]). Read
//! channel by channel, each sample carries the black's error once, so a grey mixed from
//! three of them carries it twice (`R + G + B − 2K`); read whole, the grey is `K + P·a`
//! with the same `K` subtracted and added back, and the black's error cancels at the
//! grey itself. The channels' samples still carry the meter's noise, propagated through
//! `P⁻¹` (and the model's inverse): a dim red, whose X is a tenth of the grey's, comes
//! out noisier than the same red read alone, and its sample is weighted by that
//! ([`SplitSample::sigma_rel`]).

use lumiwall_core::Channel;
use lumiwall_devices::{ReadingNoise, Xyz};
use lumiwall_profiles::DisplayModel;
use nalgebra::{Matrix3, Vector3};

use super::{MeasureLog, Patch};
use crate::solve::rows;

/// A display as the split needs it: black, full-drive primaries (black included) and
/// how its channels mix.
#[derive(Debug, Clone, Copy)]
pub struct SplitDisplay {
    /// The display's black (cd/m²).
    pub black: Xyz,
    /// The channels at full drive, black included (cd/m²).
    pub primaries: [Xyz; 3],
    /// How the channels mix ([`DisplayModel::Additive`] or a white segment, whose `W`
    /// is put in channel intensities through the split's own `P⁻¹`).
    pub model: DisplayModel,
}

/// Whether a channel's `drive` in a grey lies below every one of its ramp samples
/// (`samples`, drives; those at 0 not counted) by at least `gap`: its tone curve is
/// extrapolated toward black there. A grey is read whole to be split only where one of
/// its channels is (`grey_drives`), and only such channels take its samples
/// (`commission`): between ramp samples the curve is interpolated, and the split's
/// noise, a dim channel's through `P⁻¹` several times its own, would only add to it. On
/// the dim bench walls the rule changed no run's verdict at 40 or 64 readings (their
/// split greys sit below the samples); on a bright wall it saves the reading.
pub fn below_the_samples(drive: f64, samples: &[f64], gap: f64) -> bool {
    let lowest = samples
        .iter()
        .copied()
        .filter(|d| *d > 0.0)
        .fold(1.0, f64::min);
    drive > 0.0 && drive < lowest - gap
}

/// One channel sample taken from a grey read whole.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplitSample {
    /// The channel's drive in the grey.
    pub drive: f64,
    /// The channel's light at that drive, black included, on its line:
    /// `K + a·(P_c − K)` (cd/m²).
    pub xyz: Xyz,
    /// Relative intensity `a` (1 at full drive).
    pub intensity: f64,
    /// Relative standard error of `intensity` under the meter's stated noise (0 when the
    /// meter states no noise or states that it is exact).
    pub sigma_rel: f64,
}

/// Every grey of `log` read whole to be split ([`Patch::Grey`]), split into each
/// channel's sample at its drive, in the order read. A channel at drive 0 or 1 gives
/// none (black and full drive are read as such), nor does one whose intensity comes out
/// at or below 0 (the grey is too dark for the meter there). Empty when the primaries
/// are degenerate.
pub fn split_greys(
    log: &MeasureLog,
    display: &SplitDisplay,
    noise: Option<ReadingNoise>,
) -> [Vec<SplitSample>; 3] {
    let mut out: [Vec<SplitSample>; 3] = Default::default();
    let Some(p_inv) = super::drive_matrix(display.black, &display.primaries) else {
        return out;
    };
    for r in &log.samples {
        let (Patch::Grey(drive), Some(xyz)) = (r.patch, r.xyz) else {
            continue;
        };
        let n = f64::from(r.repeats.max(1));
        for (c, s) in split_one(display, &p_inv, drive, xyz, n, noise) {
            out[c.index()].push(s);
        }
    }
    out
}

/// One grey `xyz` (the mean of `n` readings) shown at `drive`, split into its channels.
fn split_one(
    display: &SplitDisplay,
    p_inv: &Matrix3<f64>,
    drive: [f64; 3],
    xyz: Xyz,
    n: f64,
    noise: Option<ReadingNoise>,
) -> Vec<(Channel, SplitSample)> {
    let m = p_inv * (xyz - display.black).to_vector();
    let a = display.model.channels_for(&rows(p_inv), [m[0], m[1], m[2]]);
    let sigma = noise
        .filter(|n| !n.is_exact())
        .map(|noise| intensity_sigmas(display, p_inv, [m[0], m[1], m[2]], xyz, n, noise));
    Channel::ALL
        .into_iter()
        .filter_map(|c| {
            let (d, ai) = (drive[c.index()], a[c.index()]);
            let inside = d > 0.0 && d < 1.0 && ai > 0.0 && ai.is_finite();
            inside.then(|| {
                let line = display.primaries[c.index()] - display.black;
                let rel = sigma.map_or(0.0, |s| s[c.index()] / ai);
                let sample = SplitSample {
                    drive: d,
                    xyz: display.black + line * ai,
                    intensity: ai,
                    sigma_rel: if rel.is_finite() { rel } else { 0.0 },
                };
                (c, sample)
            })
        })
        .collect()
}

/// Standard errors of the three intensities split from a grey `xyz` averaged over `n`
/// readings: the meter's noise in X, Y and Z ([`ReadingNoise::sigma_xyz`]) through
/// `P⁻¹` and, with a white segment, through its inverse at `m` (linear where the
/// smallest channel stays the smallest). The black's own noise is left out as it is
/// for a channel read alone ([`super::channel_colour::ramp_sigma_rel`]), though `P⁻¹`
/// moves a split sample by the black's error otherwise than the projection moves that
/// channel's ramp samples; the black is read as often as this grey needs for 1.5 %
/// ([`super::black_readings`]).
fn intensity_sigmas(
    display: &SplitDisplay,
    p_inv: &Matrix3<f64>,
    m: [f64; 3],
    xyz: Xyz,
    n: f64,
    noise: ReadingNoise,
) -> [f64; 3] {
    let s = noise.sigma_xyz(xyz);
    let reading =
        Matrix3::from_diagonal(&(Vector3::new(s[0] * s[0], s[1] * s[1], s[2] * s[2]) / n));
    let cov_m = p_inv * reading * p_inv.transpose();
    let j = white_segment_jacobian(display, p_inv, m);
    let cov_a = j * cov_m * j.transpose();
    std::array::from_fn(|c| cov_a[(c, c)].max(0.0).sqrt())
}

/// Derivative of the model's inverse `a(m)` ([`DisplayModel::channels_for`]): the
/// identity for an additive display, or where no white light is shown; with a white
/// segment `u` (in channel intensities) and the smallest scaled channel `k`,
/// `a = m − u·m_k/(1 + u_k)`.
fn white_segment_jacobian(
    display: &SplitDisplay,
    p_inv: &Matrix3<f64>,
    m: [f64; 3],
) -> Matrix3<f64> {
    let u = display.model.white_in_channels(&rows(p_inv));
    let scaled = |c: usize| m[c] / (1.0 + u[c]);
    let k = (0..3)
        .min_by(|&a, &b| scaled(a).total_cmp(&scaled(b)))
        .unwrap_or(0);
    let mut j = Matrix3::identity();
    if scaled(k) > 0.0 {
        for c in 0..3 {
            j[(c, k)] -= u[c] / (1.0 + u[k]);
        }
    }
    j
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::ReadingRecord;

    fn display(model: DisplayModel) -> SplitDisplay {
        let black = Xyz::new(0.02, 0.02, 0.04);
        let primaries = [
            Xyz::new(4.4, 2.3, 0.1),
            Xyz::new(6.7, 13.9, 0.8),
            Xyz::new(3.7, 1.0, 20.3),
        ];
        SplitDisplay {
            black,
            primaries,
            model,
        }
    }

    fn grey(d: &SplitDisplay, a: [f64; 3]) -> Xyz {
        let mut xyz = d.black;
        for (p, ac) in d.primaries.iter().zip(a) {
            xyz = xyz + (*p - d.black) * ac;
        }
        if let DisplayModel::WhiteSegment { white_xyz_cd_m2: w } = d.model {
            let min = a.iter().copied().fold(f64::INFINITY, f64::min);
            xyz = xyz + Xyz::from_array(w) * min;
        }
        xyz
    }

    fn log_of(drive: [f64; 3], xyz: Xyz, repeats: u32) -> MeasureLog {
        MeasureLog {
            samples: vec![ReadingRecord {
                patch: Patch::Grey(drive),
                xyz: Some(xyz),
                repeats,
                low_light: true,
            }],
            readings: repeats,
            ..Default::default()
        }
    }

    #[test]
    fn a_grey_read_whole_splits_into_the_intensities_that_made_it_additive_and_white_segment() {
        let a = [0.011, 0.015, 0.019];
        let drive = [0.12, 0.13, 0.14];
        for model in [
            DisplayModel::Additive,
            DisplayModel::WhiteSegment {
                white_xyz_cd_m2: [2.9, 3.0, 3.4],
            },
        ] {
            let d = display(model);
            let split = split_greys(&log_of(drive, grey(&d, a), 4), &d, None);
            for c in 0..3 {
                assert_eq!(split[c].len(), 1, "{model:?} channel {c}");
                let s = split[c][0];
                assert_eq!(s.drive, drive[c]);
                assert!((s.intensity - a[c]).abs() < 1e-12, "{model:?} {c}: {s:?}");
                let on_line = d.black + (d.primaries[c] - d.black) * a[c];
                assert!((s.xyz - on_line).to_vector().norm() < 1e-12);
                assert_eq!(s.sigma_rel, 0.0);
            }
        }
    }

    #[test]
    fn a_split_samples_error_is_the_meters_noise_through_the_primaries_inverse() {
        let d = display(DisplayModel::Additive);
        let a = [0.011, 0.015, 0.019];
        let xyz = grey(&d, a);
        let noise = ReadingNoise::CS100A_CLASS;
        let one = split_greys(&log_of([0.1; 3], xyz, 1), &d, Some(noise));
        let four = split_greys(&log_of([0.1; 3], xyz, 4), &d, Some(noise));
        // Monte Carlo of the same split under the meter's stated noise.
        let sx = noise.sigma_xyz(xyz);
        let p_inv = crate::measure::drive_matrix(d.black, &d.primaries).unwrap();
        let mut rng = 12345u64;
        let mut gauss = || {
            // Box–Muller on a small LCG: deterministic.
            let mut u = || {
                rng = rng
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((rng >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (u1, u2) = (u(), u());
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        };
        let trials = 20_000;
        let mut var = [0.0; 3];
        for _ in 0..trials {
            let e = Vector3::new(sx[0] * gauss(), sx[1] * gauss(), sx[2] * gauss());
            let m = p_inv * ((xyz - d.black).to_vector() + e);
            for c in 0..3 {
                var[c] += (m[c] - a[c]).powi(2) / f64::from(trials);
            }
        }
        for c in 0..3 {
            let mc = var[c].sqrt() / a[c];
            let s1 = one[c][0].sigma_rel;
            assert!(
                (s1 / mc - 1.0).abs() < 0.03,
                "channel {c}: {s1} vs Monte Carlo {mc}"
            );
            assert!((four[c][0].sigma_rel * 2.0 / s1 - 1.0).abs() < 1e-9);
        }
        // The dim red, a tenth of the grey's X, is the noisiest of the three.
        assert!(one[0][0].sigma_rel > one[1][0].sigma_rel);
    }

    #[test]
    fn channels_at_black_or_full_drive_and_readings_of_other_patches_give_no_split_sample() {
        let d = display(DisplayModel::Additive);
        let mut log = log_of([0.0, 0.2, 1.0], grey(&d, [0.0, 0.03, 1.0]), 1);
        log.samples.push(ReadingRecord {
            patch: Patch::Drive([0.2; 3]),
            xyz: Some(grey(&d, [0.03; 3])),
            repeats: 1,
            low_light: false,
        });
        let split = split_greys(&log, &d, None);
        assert!(split[0].is_empty() && split[2].is_empty());
        assert_eq!(split[1].len(), 1);
        assert!((split[1][0].intensity - 0.03).abs() < 1e-12);
    }
}
