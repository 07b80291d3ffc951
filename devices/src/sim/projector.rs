//! One simulated display (one projector, one eye): its spectra reduced to per-channel
//! XYZ once at construction, and the per-reading model (quantisation, transfer
//! curves, falloff, ageing, warm-up, non-additivity).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::curve::TransferCurve;
use super::observer::{Spectrum, cie1931};
use super::spectra::{self, Band};
use super::wall_file::{AgeingSpec, FalloffSpec, ProjectorSpec, ScatterSpec, WallFile, WarmupSpec};
use crate::{DeviceError, DisplayId, DisplayInfo, Eye};
use lumiwall_core::{BitDepth, Channel, dither};

/// Everything the simulator knows about one display, fixed at construction.
#[derive(Debug, Clone)]
pub struct SimDisplay {
    /// Static facts.
    pub info: DisplayInfo,
    /// `info.bit_depth`, checked.
    depth: BitDepth,
    /// XYZ (cd/m², Y = luminance) of each channel at full drive, black excluded, at
    /// the centre, new lamp, warmed up, head-on on a gain-1 screen.
    pub channel_xyz: [[f64; 3]; 3],
    /// XYZ of black (all channels at drive 0), same conditions.
    pub black_xyz: [f64; 3],
    /// XYZ of the full DLP white segment (multiplied by min of the channel intensities).
    pub white_segment_xyz: [f64; 3],
    /// The spectra behind `channel_xyz`, `black_xyz` and `white_segment_xyz`.
    pub spectra: DisplaySpectra,
    /// Transfer curves, R, G, B.
    pub curves: [TransferCurve; 3],
    /// Falloff (after scatter).
    pub falloff: FalloffSpec,
    /// Lamp ageing model.
    pub ageing: AgeingSpec,
    /// Warm-up model.
    pub warmup: WarmupSpec,
    /// Lamp hours at simulation start.
    pub lamp_hours_at_start: f64,
    /// Relative lamp power after scatter and overrides.
    pub lamp_power: f64,
    /// Tile geometry: lower-left corner (m) and size (m) on the wall.
    pub tile_origin_m: [f64; 2],
    /// Tile size (m).
    pub tile_size_m: [f64; 2],
    /// Throw distance behind the screen (m).
    pub throw_m: f64,
}

/// Conditions of one reading besides drive and spot.
#[derive(Debug, Clone, Copy)]
pub struct Conditions {
    /// Lamp hours now.
    pub lamp_hours: f64,
    /// Minutes since switch-on now.
    pub minutes_on: f64,
}

fn uniform(rng: &mut ChaCha8Rng, half_width: f64) -> f64 {
    if half_width > 0.0 {
        rng.random_range(-half_width..=half_width)
    } else {
        0.0
    }
}

fn check_finite_nonneg(what: &str, v: f64) -> Result<(), DeviceError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(DeviceError::Config(format!(
            "{what} must be a finite number >= 0, got {v}"
        )))
    }
}

/// Brightest bare-lamp luminance a wall file may ask for (cd/m²): far above any
/// projector, far below where the simulation's products overflow.
pub const MAX_WHITE_CD_M2: f64 = 1.0e6;

/// Smallest and largest lamp colour temperature a wall file may ask for (K).
const LAMP_CCT_RANGE_K: std::ops::RangeInclusive<f64> = 1000.0..=30000.0;
/// Smallest transfer-curve γ the manufacturing scatter may leave (keeps curves rising).
const MIN_SCATTERED_GAMMA: f64 = 0.3;
/// Range the scattered S-curve centre is kept in, away from the curve's ends.
const S_CENTRE_RANGE: (f64, f64) = (0.05, 0.95);
/// The shoulder scatters relatively this many times more than `scatter.curve_shape`.
const SHOULDER_SCATTER_FACTOR: f64 = 4.0;

/// Floor of the hotspot width and of the ageing and warm-up time constants, so that
/// a zero in a hand-made model divides by something.
const MIN_LENGTH: f64 = 1e-6;
/// Least output an aged lamp keeps per channel (the model never goes fully dark).
const MIN_AGEING_FACTOR: f64 = 0.02;

/// The bit depth of a projector model, refused unless a display profile can hold it
/// (8, 10, 12 or 16 bits), so that a wall file is refused when loaded rather than
/// after all its displays were measured.
fn bit_depth(p: &ProjectorSpec) -> Result<BitDepth, DeviceError> {
    let refused = || {
        DeviceError::Config(format!(
            "projector.bit_depth must be 8, 10, 12 or 16 (the depths a display profile \
             can hold), got {}",
            p.bit_depth
        ))
    };
    if !BitDepth::is_profile_depth(p.bit_depth) {
        return Err(refused());
    }
    BitDepth::new(p.bit_depth).map_err(|_| refused())
}

fn check_positive(what: &str, v: f64) -> Result<(), DeviceError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(DeviceError::Config(format!("{what} must be > 0")))
    }
}

/// Validates the projector model of a wall file.
pub fn validate_spec(p: &ProjectorSpec) -> Result<(), DeviceError> {
    bit_depth(p)?;
    if !(p.lamp.white_cd_m2.is_finite()
        && p.lamp.white_cd_m2 > 0.0
        && p.lamp.white_cd_m2 <= MAX_WHITE_CD_M2)
    {
        return Err(DeviceError::Config(format!(
            "projector.lamp.white_cd_m2 must be > 0 and <= {MAX_WHITE_CD_M2:e} cd/m², got {}",
            p.lamp.white_cd_m2
        )));
    }
    check_positive("projector.lamp.line_fwhm_nm", p.lamp.line_fwhm_nm)?;
    if !(0.0..=1.0).contains(&p.lamp.red_deficit) {
        return Err(DeviceError::Config(format!(
            "projector.lamp.red_deficit must be in 0..=1, got {}",
            p.lamp.red_deficit
        )));
    }
    if let Some(d) = p.warmup.deficit.iter().find(|d| !(0.0..=1.0).contains(*d)) {
        return Err(DeviceError::Config(format!(
            "projector.warmup.deficit must be in 0..=1 per channel, got {d}"
        )));
    }
    if !LAMP_CCT_RANGE_K.contains(&p.lamp.cct_k) {
        return Err(DeviceError::Config(format!(
            "projector.lamp.cct_k must be in 1000..=30000 K, got {}",
            p.lamp.cct_k
        )));
    }
    for (channel, c) in Channel::ALL.into_iter().zip(p.curves.curves()) {
        c.validate()
            .map_err(|e| DeviceError::Config(format!("projector.curves.{channel}: {e}")))?;
    }
    for (what, v) in [
        ("projector.white_segment", p.white_segment),
        ("projector.lamp_hours", p.lamp_hours),
        ("projector.throw_m", p.throw_m),
    ] {
        check_finite_nonneg(what, v)?;
    }
    for v in p.black.leak.iter().chain([&p.black.stray]) {
        check_finite_nonneg("projector.black leak/stray", *v)?;
    }
    for v in p.falloff.vignetting {
        check_finite_nonneg("projector.falloff.vignetting", v)?;
    }
    for (what, v) in [
        ("projector.falloff.hotspot_gain", p.falloff.hotspot_gain),
        ("projector.ageing.fast_loss", p.ageing.fast_loss),
        (
            "projector.ageing.slow_loss_per_1000h",
            p.ageing.slow_loss_per_1000h,
        ),
    ] {
        check_finite_nonneg(what, v)?;
    }
    check_positive("projector.ageing.fast_hours", p.ageing.fast_hours)?;
    check_positive("projector.warmup.minutes", p.warmup.minutes)?;
    for v in p.warmup.deficit.iter().chain(&p.ageing.channel_weight) {
        check_finite_nonneg("projector.warmup.deficit / ageing.channel_weight", *v)?;
    }
    for v in p
        .channel_gain
        .mono
        .iter()
        .chain(&p.channel_gain.left)
        .chain(&p.channel_gain.right)
    {
        check_finite_nonneg("projector.channel_gain", *v)?;
    }
    Ok(())
}

/// One projector's manufacturing scatter and overrides applied to the wall's model.
struct Individual {
    /// Relative lamp power.
    lamp_power: f64,
    /// Shift of each panel filter band (nm).
    panel_shift: [f64; 3],
    /// Shift of the comb filter bands, by band index mod 3 (nm).
    comb_shift: [f64; 3],
    /// Per-channel gain (scatter × eye × overrides).
    gain: [f64; 3],
    /// Transfer curves, R, G, B.
    curves: [TransferCurve; 3],
    /// Falloff after scatter.
    falloff: FalloffSpec,
    /// Lamp hours at simulation start.
    lamp_hours: f64,
    /// DLP white segment.
    white_segment: f64,
}

impl Individual {
    /// Draws the manufacturing scatter, always in the same order (the order is part of
    /// what a seed means).
    fn draw(p: &ProjectorSpec, sc: &ScatterSpec, rng: &mut ChaCha8Rng) -> Self {
        let lamp_power = 1.0 + uniform(rng, sc.lamp_power_rel);
        let panel_shift: [f64; 3] = std::array::from_fn(|_| uniform(rng, sc.panel_shift_nm));
        let comb_shift: [f64; 3] = std::array::from_fn(|_| uniform(rng, sc.comb_shift_nm));
        let gain: [f64; 3] = std::array::from_fn(|_| 1.0 + uniform(rng, sc.channel_gain_rel));
        let mut curves = p.curves.curves();
        for c in &mut curves {
            c.gamma = (c.gamma + uniform(rng, sc.gamma)).max(MIN_SCATTERED_GAMMA);
            c.s_weight = (c.s_weight + uniform(rng, sc.curve_shape)).clamp(0.0, 1.0);
            c.s_centre = (c.s_centre + uniform(rng, sc.curve_shape))
                .clamp(S_CENTRE_RANGE.0, S_CENTRE_RANGE.1);
        }
        let mut falloff = p.falloff;
        for a in &mut falloff.vignetting {
            *a = (*a * (1.0 + uniform(rng, sc.vignetting_rel))).max(0.0);
        }
        falloff.hotspot_offset[0] += uniform(rng, sc.hotspot_offset);
        falloff.hotspot_offset[1] += uniform(rng, sc.hotspot_offset);
        let lamp_hours = match sc.lamp_hours {
            Some([lo, hi]) if hi > lo => rng.random_range(lo..=hi),
            Some([lo, _]) => lo,
            None => p.lamp_hours,
        };
        for c in &mut curves {
            let k = 1.0 + uniform(rng, SHOULDER_SCATTER_FACTOR * sc.curve_shape);
            c.shoulder = (c.shoulder * k).max(0.0);
        }
        Self {
            lamp_power,
            panel_shift,
            comb_shift,
            gain,
            curves,
            falloff,
            lamp_hours,
            white_segment: p.white_segment,
        }
    }

    /// Applies the eye's channel gains and the wall file's overrides of display
    /// `index`, and checks what they leave.
    fn adjust(&mut self, wall: &WallFile, index: u32, eye: Eye) -> Result<(), DeviceError> {
        let cg = &wall.projector.channel_gain;
        let eye_gain = match eye {
            Eye::Mono => cg.mono,
            Eye::Left => cg.left,
            Eye::Right => cg.right,
        };
        self.scale_gain(eye_gain);
        for o in wall.overrides.iter().filter(|o| o.display == index) {
            if let Some(h) = o.lamp_hours {
                self.lamp_hours = h;
            }
            if let Some(k) = o.lamp_power {
                self.lamp_power *= k;
            }
            if let Some(g) = o.channel_gain {
                self.scale_gain(g);
            }
            if let Some(w) = o.white_segment {
                self.white_segment = w;
            }
            if let Some([du, dv]) = o.hotspot_shift {
                self.falloff.hotspot_offset[0] += du;
                self.falloff.hotspot_offset[1] += dv;
            }
        }
        for v in self.falloff.hotspot_offset {
            if !v.is_finite() {
                return Err(DeviceError::Config(format!(
                    "[[override]] hotspot_shift of display {index} must be finite"
                )));
            }
        }
        check_finite_nonneg("override lamp_hours", self.lamp_hours)?;
        check_finite_nonneg(
            &format!("[[override]] white_segment of display {index}"),
            self.white_segment,
        )?;
        check_finite_nonneg("lamp power after overrides", self.lamp_power)?;
        for g in self.gain {
            check_finite_nonneg("channel gain after overrides", g)?;
        }
        Ok(())
    }

    fn scale_gain(&mut self, k: [f64; 3]) {
        for (g, k) in self.gain.iter_mut().zip(k) {
            *g *= k;
        }
    }
}

/// XYZ (cd/m²) of a display's channels, black and white segment at full drive.
struct Tristimuli {
    /// Each channel at full drive, black excluded.
    channel_xyz: [[f64; 3]; 3],
    /// All channels at drive 0.
    black_xyz: [f64; 3],
    /// The full white segment.
    white_segment_xyz: [f64; 3],
    /// The spectra these were integrated from.
    spectra: DisplaySpectra,
}

/// Spectral radiance of one display at the centre, new lamp, warmed up, head-on on a
/// gain-1 screen, scaled so that the CIE 1931 observer gives Y in cd/m²: what a
/// camera with other spectral sensitivities integrates.
#[derive(Debug, Clone)]
pub struct DisplaySpectra {
    /// R, G, B at full drive, black excluded.
    pub channel: [Spectrum; 3],
    /// All channels at drive 0.
    pub black: Spectrum,
    /// The full white segment.
    pub white_segment: Spectrum,
}

impl DisplaySpectra {
    /// The five spectra integrated by `integrate`: `[R, G, B, black, white segment]`.
    pub fn integrated(&self, integrate: impl Fn(&Spectrum) -> [f64; 3]) -> [[f64; 3]; 5] {
        [
            integrate(&self.channel[0]),
            integrate(&self.channel[1]),
            integrate(&self.channel[2]),
            integrate(&self.black),
            integrate(&self.white_segment),
        ]
    }

    /// `Σ weights[j] · spectra[j]` over `[R, G, B, black, white segment]`.
    pub fn combined(&self, weights: [f64; 5]) -> Spectrum {
        let parts = [
            &self.channel[0],
            &self.channel[1],
            &self.channel[2],
            &self.black,
            &self.white_segment,
        ];
        parts
            .iter()
            .zip(weights)
            .fold(Spectrum::constant(0.0), |sum, (s, w)| sum.add(&s.scaled(w)))
    }
}

/// Transmission of the stereo comb filter in front of `eye` (none for mono), its
/// bands shifted by this projector's scatter.
fn comb_filter(wall: &WallFile, eye: Eye, comb_shift: [f64; 3]) -> Spectrum {
    let spec = match eye {
        Eye::Mono => return Spectrum::constant(1.0),
        Eye::Left => &wall.infitec.left,
        Eye::Right => &wall.infitec.right,
    };
    let bands: Vec<Band> = spec
        .bands
        .iter()
        .enumerate()
        .map(|(i, b)| b.shifted(comb_shift[i % 3]))
        .collect();
    spectra::comb(&bands, spec.leak)
}

/// Integrates the lamp through the comb filter and each panel filter.
fn tristimuli(wall: &WallFile, eye: Eye, ind: &Individual) -> Result<Tristimuli, DeviceError> {
    let p = &wall.projector;
    let obs = cie1931()?;
    let lamp = spectra::lamp(
        p.lamp.kind,
        p.lamp.cct_k,
        p.lamp.line_fwhm_nm,
        p.lamp.red_deficit,
    );
    let comb = comb_filter(wall, eye, ind.comb_shift);
    let lamp_y = obs.tristimulus(&lamp)[1];
    if lamp_y.is_nan() || lamp_y <= 0.0 {
        return Err(DeviceError::Config(
            "lamp spectrum has no luminance in 360–830 nm".into(),
        ));
    }
    let scale = p.lamp.white_cd_m2 * ind.lamp_power / lamp_y;
    let through_comb = lamp.mul(&comb);
    let panels: Vec<Spectrum> = p
        .panel
        .bands()
        .iter()
        .zip(ind.panel_shift)
        .map(|(b, s)| b.shifted(s).spectrum())
        .collect();
    let channel: [Spectrum; 3] =
        std::array::from_fn(|c| through_comb.mul(&panels[c]).scaled(scale * ind.gain[c]));
    let leak = panels
        .iter()
        .zip(p.black.leak)
        .fold(Spectrum::constant(p.black.stray), |acc, (s, k)| {
            acc.add(&s.scaled(k))
        });
    let spectra = DisplaySpectra {
        channel,
        black: through_comb.mul(&leak).scaled(scale),
        white_segment: through_comb.scaled(scale * ind.white_segment),
    };
    let [r, g, b, black_xyz, white_segment_xyz] = spectra.integrated(|s| obs.tristimulus(s));
    Ok(Tristimuli {
        channel_xyz: [r, g, b],
        black_xyz,
        white_segment_xyz,
        spectra,
    })
}

impl SimDisplay {
    /// Builds display `index` of `wall` on tile (`col`, `row`) for `eye`, drawing its
    /// manufacturing scatter from `rng`.
    pub fn build(
        wall: &WallFile,
        index: u32,
        col: u32,
        row: u32,
        eye: Eye,
        rng: &mut ChaCha8Rng,
    ) -> Result<Self, DeviceError> {
        let p = &wall.projector;
        let depth = bit_depth(p)?;
        let mut ind = Individual::draw(p, &wall.scatter, rng);
        ind.adjust(wall, index, eye)?;
        let tri = tristimuli(wall, eye, &ind)?;
        let light = tri
            .channel_xyz
            .iter()
            .flatten()
            .chain(&tri.black_xyz)
            .chain(&tri.white_segment_xyz);
        if let Some(v) = light.into_iter().find(|v| !v.is_finite()) {
            return Err(DeviceError::Config(format!(
                "display #{index} ({eye}) would emit {v} cd/m²: projector.lamp.white_cd_m2, \
                 projector.white_segment, projector.channel_gain and the [[override]] \
                 lamp_power/channel_gain multiply to more than a number can hold"
            )));
        }
        let (cols, rows) = (wall.tiles.cols, wall.tiles.rows);
        let (w, h) = (wall.tiles.width_m, wall.tiles.height_m);
        let info = DisplayInfo {
            id: DisplayId(index),
            name: format!("tile c{col}r{row} {eye}"),
            tile_col: col,
            tile_row: row,
            eye,
            bit_depth: p.bit_depth,
        };
        debug_assert!(col < cols && row < rows);
        Ok(Self {
            info,
            depth,
            channel_xyz: tri.channel_xyz,
            black_xyz: tri.black_xyz,
            white_segment_xyz: tri.white_segment_xyz,
            spectra: tri.spectra,
            curves: ind.curves,
            falloff: ind.falloff,
            ageing: p.ageing,
            warmup: p.warmup,
            lamp_hours_at_start: ind.lamp_hours,
            lamp_power: ind.lamp_power,
            tile_origin_m: [col as f64 * w, (rows - 1 - row) as f64 * h],
            tile_size_m: [w, h],
            throw_m: p.throw_m,
        })
    }

    /// Relative intensity (black removed, 1 at full drive) of channel `c` for a drive,
    /// as the display shows it: a drive between two codes is shown as the post pass's
    /// ordered dither of the two ([`lumiwall_core::dither`]) and this is the mean over a
    /// dither cell.
    pub fn relative_intensity(&self, c: usize, drive: f64) -> f64 {
        dither::mix([drive; 3], self.depth.max_code())
            .iter()
            .map(|(codes, share)| share * self.curves[c].intensity(codes[c]))
            .sum()
    }

    /// Spatial factor per channel at `uv` (1 at the centre).
    pub fn falloff_factor(&self, uv: [f64; 2]) -> [f64; 3] {
        let f = &self.falloff;
        let r2 = ((uv[0] - 0.5).powi(2) + (uv[1] - 0.5).powi(2)) / 0.5;
        let hot = |u: f64, v: f64| {
            let du = u - 0.5 - f.hotspot_offset[0];
            let dv = v - 0.5 - f.hotspot_offset[1];
            let s = f.hotspot_sigma.max(MIN_LENGTH);
            1.0 + f.hotspot_gain * (-(du * du + dv * dv) / (2.0 * s * s)).exp()
        };
        let h = hot(uv[0], uv[1]) / hot(0.5, 0.5);
        std::array::from_fn(|c| h / (1.0 + f.vignetting[c] * r2).powi(2))
    }

    /// Lamp-ageing factor per channel after `hours` of operation.
    pub fn ageing_factor(&self, hours: f64) -> [f64; 3] {
        let a = &self.ageing;
        let h = hours.max(0.0);
        let loss = a.fast_loss * (1.0 - (-h / a.fast_hours.max(MIN_LENGTH)).exp())
            + a.slow_loss_per_1000h * h / 1000.0;
        std::array::from_fn(|c| (1.0 - a.channel_weight[c] * loss).max(MIN_AGEING_FACTOR))
    }

    /// Warm-up factor per channel `minutes` after switch-on.
    pub fn warmup_factor(&self, minutes: f64) -> [f64; 3] {
        let w = &self.warmup;
        let e = (-minutes.max(0.0) / w.minutes.max(MIN_LENGTH)).exp();
        std::array::from_fn(|c| 1.0 - w.deficit[c] * e)
    }

    /// Spot position on the wall (m; x right, y up from the wall's lower-left
    /// corner, z = 0 on the screen); `uv` has v = 0 at the top of the image.
    pub fn spot_m(&self, uv: [f64; 2]) -> [f64; 3] {
        [
            self.tile_origin_m[0] + uv[0] * self.tile_size_m[0],
            self.tile_origin_m[1] + (1.0 - uv[1]) * self.tile_size_m[1],
            0.0,
        ]
    }

    /// Lens position (m), behind the tile centre.
    pub fn lens_m(&self) -> [f64; 3] {
        [
            self.tile_origin_m[0] + 0.5 * self.tile_size_m[0],
            self.tile_origin_m[1] + 0.5 * self.tile_size_m[1],
            -self.throw_m,
        ]
    }

    /// Noiseless XYZ (cd/m², black included) for quantised `drive` at `uv`, before
    /// the screen's view-dependent gain.
    pub fn emitted(&self, drive: [f64; 3], uv: [f64; 2], cond: Conditions) -> [f64; 3] {
        let basis = [
            self.channel_xyz[0],
            self.channel_xyz[1],
            self.channel_xyz[2],
            self.black_xyz,
            self.white_segment_xyz,
        ];
        self.emitted_in(&basis, drive, uv, cond)
    }

    /// Like [`SimDisplay::emitted`] but in the units of `basis`, the display's five
    /// spectra (`[R, G, B, black, white segment]`, see [`DisplaySpectra::integrated`])
    /// integrated by some instrument: the CIE observer gives XYZ, a camera its RGB.
    pub fn emitted_in(
        &self,
        basis: &[[f64; 3]; 5],
        drive: [f64; 3],
        uv: [f64; 2],
        cond: Conditions,
    ) -> [f64; 3] {
        let w = self.weights(drive, uv, cond);
        std::array::from_fn(|i| (0..5).map(|j| w[j] * basis[j][i]).sum())
    }

    /// How much of each of the five spectra (`[R, G, B, black, white segment]`, see
    /// [`DisplaySpectra`]) the display emits at `drive` and `uv`: its light is
    /// `Σ weights[j] · spectra[j]`.
    ///
    /// A drive between codes is shown dithered ([`lumiwall_core::dither`]); the weights
    /// are the mean over a dither cell (the white segment per pixel, then averaged).
    pub fn weights(&self, drive: [f64; 3], uv: [f64; 2], cond: Conditions) -> [f64; 5] {
        let fall = self.falloff_factor(uv);
        let age = self.ageing_factor(cond.lamp_hours);
        let warm = self.warmup_factor(cond.minutes_on);
        let k: [f64; 3] = std::array::from_fn(|c| fall[c] * age[c] * warm[c]);
        let k_mean = (k[0] + k[1] + k[2]) / 3.0;
        let mut w = [0.0, 0.0, 0.0, k_mean, 0.0];
        for (codes, share) in dither::mix(drive, self.depth.max_code()) {
            let f: [f64; 3] = std::array::from_fn(|c| self.curves[c].intensity(codes[c]));
            for c in 0..3 {
                w[c] += share * f[c] * k[c];
            }
            w[4] += share * f[0].min(f[1]).min(f[2]) * k_mean;
        }
        w
    }
}
