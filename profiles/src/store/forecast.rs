//! Lamp-life forecast from a display's profile history: when will each display stop
//! reaching the wall's common white?
//!
//! Each profile in the store records the display's measured primaries at full drive
//! (`primaries_xyz_cd_m2`, black removed; a recalibration that rewrote nothing stores
//! the same readings as a [`LampReading`]) and the linear channel intensities the
//! common white needs (`channel_usage`). When a lamp loses the fraction `1 − f` of a
//! channel's light, the same white needs `usage / f` of that channel; the display
//! leaves its headroom when `usage / f` exceeds the profile's `headroom` (the reserve
//! the solve kept is used up) and cannot show the common white at all past
//! `usage / f > 1` (full drive).
//!
//! **Model.** Per channel, the channel's luminance against the hours since the lamp
//! went in, fitted by linear least squares (SVD) over the current lamp's segment of the
//! history, in one of two laws ([`DecayLaw`]): the light itself (relative to the newest
//! reading) for discharge lamps (UHP, xenon), whose light falls by about the same amount
//! every hour after the burn-in, or its logarithm for LEDs and lasers (IES TM-21):
//!
//! `v(s) = a + b·s + c·exp(−s/τ) + d·exp(−2s/τ)`, `v = Y/Y_newest` or `v = ln Y`
//!
//! `b` is the slow, steady decay; the `c` and `d` terms are a UHP lamp's burn-in, the
//! large loss of its first 100–200 hours. For a given time constant `τ` the model is
//! linear; `τ` itself is the one that leaves the smallest residual (a log-grid search
//! refined by golden section, from twice the spacing of the runs to a third of the
//! segment's span), and the burn-in terms are kept only where Akaike's criterion prefers
//! them to the plain line. In the logarithm a burn-in that multiplies the light by
//! `1 + B·exp(−s/τ)` is `B·e − B²e²/2 + …` (e = exp(−s/τ)): the second term keeps a
//! burn-in of B = 0.3 from biasing the steady slope (the forecast 46 days ahead is 5 days
//! early with `c` alone, 0.3 days with both; tests/profiles/forecast.rs). The burn-in terms are
//! fitted only when the segment has at least [`MIN_POINTS_BURN_IN`] points; otherwise
//! the two-parameter line is used.
//!
//! The forecast is the first time after the newest profile at which the fitted curve
//! reaches `usage / headroom` (or `usage`) of the light measured at the newest profile
//! (the usage was solved from that reading), with a 95 % interval: for each plausible
//! τ (residual within the profile-likelihood bound ΔRSS ≤ 4σ̂² of the best) the fit's
//! covariance propagated to that time (delta method: the model's standard error over
//! its slope there, times Student's t for the fit's degrees of freedom), and the
//! envelope of those intervals.
//!
//! **Lamp changes.** A rise of the native white's luminance (sum of the primaries) by
//! more than `lamp_change_step` from one profile to the next is a new lamp (or a lamp
//! that was replaced, re-aligned or switched to another power mode): the history before
//! it is not fitted.
//!
//! **Time axis.** Hours are calendar hours between runs: the fitted rates are per
//! calendar hour, so the forecast holds while the wall keeps its daily use pattern.

use jiff::{SignedDuration, Timestamp};
use nalgebra::{DMatrix, DVector};

use lumiwall_core::Channel;

use crate::{DisplayKey, DisplayProfile};

/// Fewest profiles of one lamp segment that a forecast is made from.
pub const MIN_POINTS: usize = 3;

/// Fewest profiles of one segment for the four-parameter (burn-in) model.
pub const MIN_POINTS_BURN_IN: usize = 6;

/// What the forecast assumes; [`Default`] suits UHP lamps run every day.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForecastOptions {
    /// Relative rise of the native white luminance between two profiles that counts
    /// as a lamp change (0.10 = 10 %).
    pub lamp_change_step: f64,
    /// Fit a burn-in (UHP lamps); `false` for lamps without one (LED, laser), which
    /// keeps noise from being read as one.
    pub burn_in: bool,
    /// How the light falls after the burn-in.
    pub decay: DecayLaw,
    /// No date is predicted beyond this many days after the newest profile.
    pub horizon_days: f64,
}

impl Default for ForecastOptions {
    fn default() -> Self {
        Self {
            lamp_change_step: 0.10,
            burn_in: true,
            decay: DecayLaw::Linear,
            horizon_days: 730.0,
        }
    }
}

/// How a lamp's light falls after its burn-in: the steady part of the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecayLaw {
    /// By the same amount every hour: `Y = a + b·s (+ burn-in terms)`. Discharge lamps
    /// (UHP, xenon) after their burn-in, as the virtual wall models them; an exponential
    /// fitted to such a lamp over a month forecasts its end about 10 % of the lead time
    /// late (`lumiwall bench season`).
    Linear,
    /// By the same fraction every hour: `ln Y = a + b·s (+ burn-in terms)`. LEDs and
    /// laser phosphors (the IES TM-21 lumen-maintenance projection).
    Exponential,
}

impl DecayLaw {
    /// The light as the model is fitted to it: relative to `newest` (linear) or its
    /// logarithm (exponential).
    fn fitted_value(self, light: f64, newest: f64) -> f64 {
        match self {
            Self::Linear => light / newest,
            Self::Exponential => light.ln(),
        }
    }
}

/// When one channel reaches a limit: the predicted time and its 95 % interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// Predicted time.
    pub utc: Timestamp,
    /// Earliest time within the 95 % interval.
    pub earliest_utc: Timestamp,
    /// Latest time within the 95 % interval (capped at the horizon).
    pub latest_utc: Timestamp,
}

/// One channel's fit and forecast.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelForecast {
    /// The channel.
    pub channel: Channel,
    /// Channel usage of the newest profile (linear intensity for the common white).
    pub usage: f64,
    /// The steady decay now, percent of the light per 1000 hours (positive = losing
    /// light), from the fitted curve's slope at the newest profile.
    pub decay_pct_per_1000_h: f64,
    /// The fitted burn-in time constant (hours), when the burn-in terms were fitted.
    pub burn_in_tau_h: Option<f64>,
    /// RMS residual of the fit, percent of the light.
    pub fit_rms_pct: f64,
    /// When `usage / f` exceeds the headroom: from then on a re-solve within the
    /// headroom must lower the common white for this display. The display that limits
    /// the common white today is there already (its most used channel is at the
    /// headroom). `None` if not within the horizon.
    pub leaves_headroom: Option<Crossing>,
    /// When `usage / f` exceeds 1 (full drive): from then on the display cannot show
    /// today's common white at all, the reserve is used up. `None` if not within the
    /// horizon.
    pub beyond_full_drive: Option<Crossing>,
}

/// The forecast of one display and eye.
#[derive(Debug, Clone, PartialEq)]
pub enum DisplayForecast {
    /// Every channel fitted.
    Fitted {
        /// The display.
        display: DisplayKey,
        /// The profile's headroom (largest usage the solve may use).
        headroom: f64,
        /// Time of the newest profile.
        newest_utc: Timestamp,
        /// First profile of the current lamp segment.
        segment_start_utc: Timestamp,
        /// Profiles in that segment.
        points: usize,
        /// Lamp changes found in the history (times of the first profile after each).
        lamp_changes: Vec<Timestamp>,
        /// R, G, B.
        channels: Vec<ChannelForecast>,
    },
    /// Too few profiles since the last lamp change.
    NotEnoughHistory {
        /// The display.
        display: DisplayKey,
        /// Profiles in the current segment.
        points: usize,
        /// Lamp changes found in the history.
        lamp_changes: Vec<Timestamp>,
    },
}

impl DisplayForecast {
    /// The display.
    pub fn display(&self) -> &DisplayKey {
        match self {
            Self::Fitted { display, .. } | Self::NotEnoughHistory { display, .. } => display,
        }
    }

    /// The earliest headroom crossing of any channel, with the channel.
    pub fn first_to_leave_headroom(&self) -> Option<(Channel, Crossing)> {
        self.first(|c| c.leaves_headroom)
    }

    /// The earliest full-drive crossing of any channel (from then on the display
    /// cannot show the common white), with the channel.
    pub fn first_beyond_full_drive(&self) -> Option<(Channel, Crossing)> {
        self.first(|c| c.beyond_full_drive)
    }

    fn first(&self, pick: fn(&ChannelForecast) -> Option<Crossing>) -> Option<(Channel, Crossing)> {
        let Self::Fitted { channels, .. } = self else {
            return None;
        };
        channels
            .iter()
            .filter_map(|c| pick(c).map(|x| (c.channel, x)))
            .min_by_key(|(_, x)| x.utc)
    }
}

/// One measurement of a display's light in its lamp's life: what the forecast fits.
/// Every stored profile is one ([`LampReading::of_profile`]); a nightly recalibration
/// that found nothing to rewrite stores its readings as one too
/// ([`super::ProfileStore::record_lamp_readings`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LampReading {
    /// The display.
    pub display: DisplayKey,
    /// When it was measured.
    pub utc: Timestamp,
    /// Luminance of each primary at full drive, black removed (cd/m²).
    pub primaries_y_cd_m2: [f64; 3],
    /// Linear intensity of each channel that the common white needs with these
    /// primaries.
    pub channel_usage: [f64; 3],
    /// The largest usage the wall's solve allows (the profile's headroom).
    pub headroom: f64,
}

impl LampReading {
    /// The reading a profile records, measured at `utc`.
    pub fn of_profile(utc: Timestamp, p: &DisplayProfile) -> Self {
        Self {
            display: p.display.clone(),
            utc,
            primaries_y_cd_m2: std::array::from_fn(|c| p.primaries_xyz_cd_m2[c][1]),
            channel_usage: p.channel_usage,
            headroom: p.headroom,
        }
    }

    /// Whether the forecast can use the reading: positive finite luminances, finite
    /// usages that are not negative, a positive finite headroom.
    pub fn is_usable(&self) -> bool {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        self.primaries_y_cd_m2.iter().all(|&v| positive(v))
            && self
                .channel_usage
                .iter()
                .all(|&v| v.is_finite() && v >= 0.0)
            && positive(self.headroom)
    }

    /// Luminance of the native white (the three primaries at full drive), cd/m².
    pub fn native_white_y_cd_m2(&self) -> f64 {
        self.primaries_y_cd_m2.iter().sum()
    }
}

/// Forecasts every display and eye in `history` (as [`super::ProfileStore::history`]
/// returns it, oldest first), one entry per display and eye.
pub fn forecast(
    history: &[(Timestamp, DisplayProfile)],
    opts: &ForecastOptions,
) -> Vec<DisplayForecast> {
    let readings: Vec<LampReading> = history
        .iter()
        .map(|(t, p)| LampReading::of_profile(*t, p))
        .collect();
    forecast_readings(&readings, opts)
}

/// Forecasts every display and eye in `readings` (any order), one entry per display
/// and eye, in display order.
pub fn forecast_readings(readings: &[LampReading], opts: &ForecastOptions) -> Vec<DisplayForecast> {
    let mut keys: Vec<&DisplayKey> = readings.iter().map(|r| &r.display).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .map(|key| {
            let mut own: Vec<&LampReading> =
                readings.iter().filter(|r| &r.display == key).collect();
            own.sort_by_key(|r| r.utc);
            forecast_one(key, &own, opts)
        })
        .collect()
}

/// The forecast of one display and eye from its readings, oldest first.
fn forecast_one(key: &DisplayKey, own: &[&LampReading], opts: &ForecastOptions) -> DisplayForecast {
    let (segment, lamp_changes) = current_segment(own, opts.lamp_change_step);
    if segment.len() < MIN_POINTS {
        return DisplayForecast::NotEnoughHistory {
            display: key.clone(),
            points: segment.len(),
            lamp_changes,
        };
    }
    let start = segment[0].utc;
    let newest = segment[segment.len() - 1];
    let hours: Vec<f64> = segment
        .iter()
        .map(|r| hours_between(start, r.utc))
        .collect();
    let channels = Channel::ALL
        .iter()
        .map(|&channel| {
            let c = channel.index();
            let light: Vec<f64> = segment.iter().map(|r| r.primaries_y_cd_m2[c]).collect();
            let newest_light = light[light.len() - 1];
            let values: Vec<f64> = light
                .iter()
                .map(|&y| opts.decay.fitted_value(y, newest_light))
                .collect();
            let fits = (light.iter().all(|&y| y > 0.0 && y.is_finite()))
                .then(|| DecayFit::best(&hours, &values, opts.burn_in))
                .flatten();
            let fit = fits.as_ref().map(|(best, _)| best);
            let limits = Limits {
                start,
                from_h: hours[hours.len() - 1],
                horizon_h: horizon_hours(opts.horizon_days),
                newest_light,
                law: opts.decay,
            };
            let usage = newest.channel_usage[c];
            ChannelForecast {
                channel,
                usage,
                decay_pct_per_1000_h: fit
                    .map_or(f64::NAN, |f| -100.0 * 1000.0 * f.slope_per_h(limits.from_h)),
                burn_in_tau_h: fit.and_then(|f| f.tau_h),
                fit_rms_pct: fit.map_or(f64::NAN, |f| 100.0 * f.rms),
                leaves_headroom: fits
                    .as_ref()
                    .and_then(|f| crossing(f, usage / newest.headroom, &limits)),
                beyond_full_drive: fits.as_ref().and_then(|f| crossing(f, usage, &limits)),
            }
        })
        .collect();
    DisplayForecast::Fitted {
        display: key.clone(),
        headroom: newest.headroom,
        newest_utc: newest.utc,
        segment_start_utc: start,
        points: segment.len(),
        lamp_changes,
        channels,
    }
}

/// The readings since the last lamp change, and the times of every lamp change.
fn current_segment<'a>(
    own: &[&'a LampReading],
    step: f64,
) -> (Vec<&'a LampReading>, Vec<Timestamp>) {
    let mut changes = Vec::new();
    let mut first = 0;
    for i in 1..own.len() {
        let before = own[i - 1].native_white_y_cd_m2();
        let after = own[i].native_white_y_cd_m2();
        if before > 0.0 && after > before * (1.0 + step) {
            changes.push(own[i].utc);
            first = i;
        }
    }
    (own[first..].to_vec(), changes)
}

fn hours_between(a: Timestamp, b: Timestamp) -> f64 {
    b.duration_since(a).as_secs_f64() / 3600.0
}

/// Where a crossing is searched: hours after `start`, from the newest profile to the
/// horizon after it.
struct Limits {
    start: Timestamp,
    from_h: f64,
    horizon_h: f64,
    /// The light measured at the newest reading (its usage was solved from it).
    newest_light: f64,
    /// The law the fit follows.
    law: DecayLaw,
}

/// Longest horizon searched: 100 years.
const MAX_HORIZON_H: f64 = 100.0 * 365.25 * 24.0;

/// The horizon in hours, 0 for a horizon that is not a positive finite number.
fn horizon_hours(days: f64) -> f64 {
    if days.is_finite() && days > 0.0 {
        (days * 24.0).min(MAX_HORIZON_H)
    } else {
        0.0
    }
}

impl Limits {
    fn time(&self, h: f64) -> Timestamp {
        SignedDuration::try_from_secs_f64(h * 3600.0)
            .ok()
            .and_then(|d| self.start.checked_add(d).ok())
            .unwrap_or(Timestamp::MAX)
    }
}

/// `ln Y(s) = a + b·s + c·exp(−s/τ) + d·exp(−2s/τ)` fitted to one channel's light (or
/// without the burn-in terms), with the parameters' covariance.
struct DecayFit {
    params: Vec<f64>,
    covariance: DMatrix<f64>,
    /// The burn-in time constant, when the burn-in terms are fitted.
    tau_h: Option<f64>,
    /// Two-sided 95 % quantile of Student's t for the fit's degrees of freedom.
    t95: f64,
    rms: f64,
    rss: f64,
}

impl DecayFit {
    /// The best fit: without burn-in, or (when `burn_in` and the segment allows) with
    /// the burn-in time constant that leaves the smallest residual, searched on a log
    /// grid and refined by golden section (variable projection: for a fixed τ the
    /// model is linear). Also returns every fit on the way whose residual is within
    /// the profile-likelihood bound of the best (ΔRSS ≤ 4σ̂²: τ within about 2σ), whose
    /// forecasts widen the interval by the uncertainty of τ.
    fn best(hours: &[f64], light: &[f64], burn_in: bool) -> Option<(Self, Vec<Self>)> {
        let plain = Self::with_tau(hours, light, None)?;
        let Some((lo, hi)) = burn_in.then(|| tau_range(hours)).flatten() else {
            return Some((plain, Vec::new()));
        };
        let (lo, hi) = (lo.ln(), hi.ln());
        let step = (hi - lo) / f64::from(TAU_GRID - 1);
        let grid: Vec<Self> = (0..TAU_GRID)
            .filter_map(|i| Self::with_tau(hours, light, Some((lo + step * f64::from(i)).exp())))
            .collect();
        let rss = |ln_tau: f64| {
            Self::with_tau(hours, light, Some(ln_tau.exp())).map_or(f64::INFINITY, |f| f.rss)
        };
        let Some(grid_best) = grid.iter().min_by(|a, b| a.rss.total_cmp(&b.rss)) else {
            return Some((plain, Vec::new()));
        };
        let ln_best = grid_best.tau_h.map_or(lo, f64::ln);
        let ln_tau = golden_min(rss, (ln_best - step).max(lo), (ln_best + step).min(hi));
        // the burn-in model (three more parameters: c, d, τ) only where Akaike's
        // criterion prefers it: n·ln(RSS) + 2k smaller
        let n = hours.len() as f64;
        let prefers = |b: &Self| n * (b.rss / plain.rss).ln() + 6.0 < 0.0;
        let best = match Self::with_tau(hours, light, Some(ln_tau.exp())) {
            Some(f) if prefers(&f) => f,
            _ => return Some((plain, Vec::new())),
        };
        let dof = hours.len().saturating_sub(best.params.len()).max(1) as f64;
        let bound = best.rss * (1.0 + 4.0 / dof);
        let plausible = grid.into_iter().filter(|f| f.rss <= bound).collect();
        Some((best, plausible))
    }

    /// The linear fit for a given burn-in time constant (`None`: no burn-in terms);
    /// `None` where the light is not positive or the points do not determine the model.
    fn with_tau(hours: &[f64], light: &[f64], tau_h: Option<f64>) -> Option<Self> {
        if light.iter().any(|y| !y.is_finite()) {
            return None;
        }
        let columns = if tau_h.is_some() { 4 } else { 2 };
        let tau = tau_h.unwrap_or(f64::INFINITY);
        let x = DMatrix::from_fn(hours.len(), columns, |i, j| basis(hours[i], tau, j));
        let y = DVector::from_iterator(light.len(), light.iter().copied());
        let svd = x.clone().svd(true, true);
        if svd.singular_values.min() <= 1e-9 * svd.singular_values.max() {
            return None;
        }
        let params = svd.solve(&y, 1e-12).ok()?;
        let residual = &y - &x * &params;
        let rss = residual.norm_squared();
        let dof = hours.len().saturating_sub(columns).max(1);
        // (XᵀX)⁻¹ = V Σ⁻² Vᵀ from the SVD: forming XᵀX would square the condition number
        let v_t = svd.v_t.as_ref()?;
        let inv_sq = DMatrix::from_diagonal(&svd.singular_values.map(|s| 1.0 / (s * s)));
        let covariance = v_t.transpose() * inv_sq * v_t * (rss / dof as f64);
        Some(Self {
            params: params.iter().copied().collect(),
            covariance,
            t95: student_t_975(dof),
            tau_h,
            rms: (rss / hours.len() as f64).sqrt(),
            rss,
        })
    }

    fn row(&self, h: f64) -> DVector<f64> {
        let tau = self.tau_h.unwrap_or(f64::INFINITY);
        DVector::from_fn(self.params.len(), |j, _| basis(h, tau, j))
    }

    /// The fitted value (relative light or its logarithm, by the law) at `h`.
    fn fitted(&self, h: f64) -> f64 {
        self.row(h)
            .iter()
            .zip(&self.params)
            .map(|(x, p)| x * p)
            .sum()
    }

    /// Slope of the fitted value at `h` (per hour): d ln Y / ds, or dY/ds relative to
    /// the newest light.
    fn slope_per_h(&self, h: f64) -> f64 {
        let burn = self.tau_h.map_or(0.0, |tau| {
            -(self.params[2] * (-h / tau).exp() + 2.0 * self.params[3] * (-2.0 * h / tau).exp())
                / tau
        });
        self.params[1] + burn
    }

    /// Standard error of the fitted value's change from `from` to `h` under the fit's
    /// covariance.
    fn sigma_change(&self, h: f64, from: f64) -> f64 {
        let g = self.row(h) - self.row(from);
        (g.transpose() * &self.covariance * &g)[(0, 0)]
            .max(0.0)
            .sqrt()
    }

    /// First time after `limits.from_h` at which the fitted light falls to `fraction` of
    /// the light measured at the newest profile, within the horizon.
    fn crossing(&self, fraction: f64, limits: &Limits) -> Option<Crossing> {
        if !(fraction > 0.0 && fraction.is_finite()) {
            return None;
        }
        let target = limits
            .law
            .fitted_value(fraction * limits.newest_light, limits.newest_light)
            - self.fitted(limits.from_h);
        let from = limits.from_h;
        let end = from + limits.horizon_h;
        let drop = |h: f64| self.fitted(h) - self.fitted(from);
        let when = |margin: f64| first_below(|h| drop(h) + margin, target, from, end);
        let h = when(0.0)?;
        let slope = self.slope_per_h(h).abs().max(1e-12);
        let half_width_h = self.t95 * self.sigma_change(h, from) / slope;
        Some(Crossing {
            utc: limits.time(h),
            earliest_utc: limits.time((h - half_width_h).max(from)),
            latest_utc: limits.time((h + half_width_h).min(end)),
        })
    }
}

/// The best fit's crossing of `fraction`, its interval widened to every plausible
/// fit's (a plausible fit that does not cross within the horizon extends it there).
fn crossing(
    (best, plausible): &(DecayFit, Vec<DecayFit>),
    fraction: f64,
    limits: &Limits,
) -> Option<Crossing> {
    let mut x = best.crossing(fraction, limits)?;
    let horizon = limits.time(limits.from_h + limits.horizon_h);
    for f in plausible {
        match f.crossing(fraction, limits) {
            Some(o) => {
                x.earliest_utc = x.earliest_utc.min(o.earliest_utc);
                x.latest_utc = x.latest_utc.max(o.latest_utc);
            }
            None => x.latest_utc = horizon,
        }
    }
    Some(x)
}

/// The 97.5 % quantile of Student's t with `dof` degrees of freedom (a 95 % interval
/// from few points is wide: 12.7σ from three points of a two-parameter fit).
fn student_t_975(dof: usize) -> f64 {
    const TABLE: [f64; 10] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
    ];
    match dof {
        0 => f64::INFINITY,
        1..=10 => TABLE[dof - 1],
        11..=20 => 2.228 - (2.228 - 2.086) * (dof - 10) as f64 / 10.0,
        21..=60 => 2.086 - (2.086 - 2.000) * (dof - 20) as f64 / 40.0,
        _ => 1.96,
    }
}

/// Points of the log grid the burn-in time constant is first searched on.
const TAU_GRID: u32 = 24;

/// The burn-in time constants a segment can tell apart: from twice the median spacing
/// of its profiles (a faster burn-in is over before the second one) to a third of its
/// span (a slower one cannot be told from the steady decay yet); `None` when the
/// segment is too short or has too few profiles.
fn tau_range(hours: &[f64]) -> Option<(f64, f64)> {
    if hours.len() < MIN_POINTS_BURN_IN {
        return None;
    }
    let mut gaps: Vec<f64> = hours.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_by(f64::total_cmp);
    let lo = (2.0 * gaps[gaps.len() / 2]).max(MIN_BURN_IN_H);
    let hi = (hours[hours.len() - 1] - hours[0]) / 3.0;
    (hi > lo).then_some((lo, hi))
}

/// Shortest burn-in time constant searched (hours).
const MIN_BURN_IN_H: f64 = 12.0;

/// Minimum of `f` on `[a, b]` by golden-section search (40 steps).
fn golden_min(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..40 {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

/// Column `j` of the model at `h` hours: 1, s (in hours), exp(−s/τ), exp(−2s/τ).
fn basis(h: f64, tau_h: f64, j: usize) -> f64 {
    match j {
        0 => 1.0,
        1 => h,
        2 => (-h / tau_h).exp(),
        _ => (-2.0 * h / tau_h).exp(),
    }
}

/// First `h` in `(from, end]` where `f(h) ≤ target`: daily steps, then bisection to a
/// minute; `None` if it does not happen.
fn first_below(f: impl Fn(f64) -> f64, target: f64, from: f64, end: f64) -> Option<f64> {
    const STEP_H: f64 = 24.0;
    if f(from) <= target {
        return Some(from);
    }
    let mut lo = from;
    while lo < end {
        let hi = (lo + STEP_H).min(end);
        if f(hi) <= target {
            let (mut a, mut b) = (lo, hi);
            while b - a > 1.0 / 60.0 {
                let m = 0.5 * (a + b);
                if f(m) <= target { b = m } else { a = m }
            }
            return Some(b);
        }
        lo = hi;
    }
    None
}
