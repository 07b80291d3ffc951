//! The wall file (TOML): what a virtual wall is made of. Documented field by field in
//! `fixtures/walls/README.md`.

use serde::{Deserialize, Serialize};

use super::curve::TransferCurve;
use super::spectra::{Band, LampKind};

/// Whole wall description.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallFile {
    /// Name of the wall (goes into display keys and profiles).
    pub name: String,
    /// Seed of all manufacturing scatter and meter noise.
    pub seed: u64,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Mono (one projector per tile) or Infitec (left and right projector per tile).
    pub stereo: Stereo,
    /// Tile grid and geometry.
    pub tiles: TileSpec,
    /// Simulation clock.
    #[serde(default)]
    pub clock: ClockSpec,
    /// Screen reflection/transmission.
    #[serde(default)]
    pub screen: ScreenSpec,
    /// Where the meter stands.
    #[serde(default)]
    pub meter: MeterPlacement,
    /// The camera that sees the whole wall (`[camera]`; defaults: centred in front).
    #[serde(default)]
    pub camera: super::camera::CameraSpec,
    /// The projector model every projector is built from.
    pub projector: ProjectorSpec,
    /// Infitec comb filters (used when `stereo = "infitec"`).
    #[serde(default)]
    pub infitec: InfitecSpec,
    /// Seeded manufacturing scatter between projectors of the same model.
    #[serde(default)]
    pub scatter: ScatterSpec,
    /// Per-projector overrides (`[[override]]` tables).
    #[serde(default, rename = "override")]
    pub overrides: Vec<OverrideSpec>,
    /// Where each display's patterns go on a real wall (`[[output]]` tables): an
    /// output of a render node's pattern server. None: the patterns go to this
    /// simulator.
    #[serde(default, rename = "output")]
    pub outputs: Vec<OutputRoute>,
    /// How the station reaches the render nodes (`[network]`); needed with outputs.
    #[serde(default)]
    pub network: Option<NetworkSpec>,
}

/// One display's output (`[[output]]`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputRoute {
    /// Tile `[col, row]`, 0-based from the top left.
    pub tile: [u32; 2],
    /// Eye (`left`/`right` on an Infitec wall; omitted or `mono` on a mono wall).
    #[serde(default)]
    pub eye: Option<lumiwall_core::Eye>,
    /// The output: `tcp://HOST:PORT/OUTPUT`, e.g. `tcp://node03:50051/DP-1`.
    pub to: String,
}

/// How the station reaches the render nodes (`[network]`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NetworkSpec {
    /// The wall's pre-shared token, a file beside the wall file (or an absolute path);
    /// every node runs with the same file.
    pub token_file: String,
    /// Deadline of one call to a node, ms (presenting plus settling must fit).
    #[serde(default = "d_deadline_ms")]
    pub deadline_ms: u64,
    /// The station's name shown to other stations that find a node busy (default:
    /// this machine's host name).
    #[serde(default)]
    pub station: Option<String>,
    /// TLS: the certificate authority (PEM, beside the wall file) that signed every
    /// node's certificate; absent: plain TCP (the token travels in clear).
    #[serde(default)]
    pub ca_file: Option<String>,
}

fn d_deadline_ms() -> u64 {
    10_000
}

/// Stereo mode of the wall.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Stereo {
    /// One projector per tile, no comb filter.
    Mono,
    /// Two projectors per tile with Infitec comb filters; displays 0..n are the left
    /// eye (tiles row by row), n..2n the right eye.
    Infitec,
}

/// Tile grid.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TileSpec {
    /// Columns.
    pub cols: u32,
    /// Rows.
    pub rows: u32,
    /// Width of one tile on the screen (m).
    #[serde(default = "d_tile_w")]
    pub width_m: f64,
    /// Height of one tile on the screen (m).
    #[serde(default = "d_tile_h")]
    pub height_m: f64,
}

/// Simulation clock.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClockSpec {
    /// Simulated seconds each meter reading takes (the clock advances by this).
    #[serde(default = "d_spr")]
    pub seconds_per_reading: f64,
    /// Minutes since the projectors were switched on when the simulation starts.
    #[serde(default = "d_on")]
    pub minutes_since_switch_on: f64,
}

impl Default for ClockSpec {
    fn default() -> Self {
        Self {
            seconds_per_reading: d_spr(),
            minutes_since_switch_on: d_on(),
        }
    }
}

/// Screen model: `gain(θ) = diffuse_gain + specular_gain · exp(−θ²/(2σ²))`, θ the
/// angle between the (continued) projector ray and the direction to the meter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScreenSpec {
    /// Angle-independent (Lambertian) part of the gain.
    #[serde(default = "one")]
    pub diffuse_gain: f64,
    /// Peak of the view-dependent hotspot (0 = Lambertian).
    #[serde(default)]
    pub specular_gain: f64,
    /// σ of the hotspot lobe (degrees).
    #[serde(default = "d_spec_w")]
    pub specular_width_deg: f64,
}

impl Default for ScreenSpec {
    fn default() -> Self {
        Self {
            diffuse_gain: 1.0,
            specular_gain: 0.0,
            specular_width_deg: d_spec_w(),
        }
    }
}

/// Where the meter stands when it reads a spot.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeterPlacement {
    /// Head-on distance from the aimed spot (m), used when `position_m` is absent.
    #[serde(default = "d_meter_dist")]
    pub distance_m: f64,
    /// Fixed meter position in wall coordinates (m): x right, y up from the wall's
    /// lower-left corner, z toward the audience. Absent: head-on at every spot.
    #[serde(default)]
    pub position_m: Option<[f64; 3]>,
}

impl Default for MeterPlacement {
    fn default() -> Self {
        Self {
            distance_m: d_meter_dist(),
            position_m: None,
        }
    }
}

/// The projector model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProjectorSpec {
    /// Free text ("Christie LX-UXT1-like LCD").
    #[serde(default)]
    pub model: String,
    /// Input bits per channel (8, 10, 16).
    #[serde(default = "d_bits")]
    pub bit_depth: u32,
    /// Rear-projection throw distance (m) behind the screen.
    #[serde(default = "d_throw")]
    pub throw_m: f64,
    /// Lamp.
    pub lamp: LampSpec,
    /// Panel/dichroic filters per channel.
    #[serde(default)]
    pub panel: PanelSpec,
    /// Transfer curves per channel.
    #[serde(default)]
    pub curves: CurvesSpec,
    /// Black level (light leak).
    #[serde(default)]
    pub black: BlackSpec,
    /// DLP white segment: extra white light ∝ min(r, g, b) relative intensity, as a
    /// fraction of the unfiltered lamp; 0 = additive (default).
    #[serde(default)]
    pub white_segment: f64,
    /// Per-channel gains ("service menu" contrast), per eye.
    #[serde(default)]
    pub channel_gain: ChannelGainSpec,
    /// Spatial falloff and hotspot of the lens.
    #[serde(default)]
    pub falloff: FalloffSpec,
    /// Lamp ageing.
    #[serde(default)]
    pub ageing: AgeingSpec,
    /// Warm-up after switch-on.
    #[serde(default)]
    pub warmup: WarmupSpec,
    /// Lamp operating hours at the start (unless scattered or overridden).
    #[serde(default)]
    pub lamp_hours: f64,
}

/// Lamp of the projector model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LampSpec {
    /// UHP or xenon.
    pub kind: LampKind,
    /// Continuum temperature (K).
    #[serde(default = "d_cct")]
    pub cct_k: f64,
    /// Width of the pressure-broadened Hg lines (nm, UHP only).
    #[serde(default = "d_line")]
    pub line_fwhm_nm: f64,
    /// Fraction of the continuum missing in the red (UHP only).
    #[serde(default = "d_red_deficit")]
    pub red_deficit: f64,
    /// Luminance (cd/m²) the bare lamp light (no panel filter, no comb) would give at
    /// the screen centre seen head-on on a gain-1 screen, new lamp, warmed up.
    pub white_cd_m2: f64,
}

/// Panel filters (dichroic band-passes) per channel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PanelSpec {
    /// Red channel.
    pub red: Band,
    /// Green channel.
    pub green: Band,
    /// Blue channel.
    pub blue: Band,
}

impl Default for PanelSpec {
    fn default() -> Self {
        Self {
            red: Band {
                lo_nm: 592.0,
                hi_nm: 720.0,
                edge_nm: 4.0,
                peak: 0.92,
                floor: 0.0,
            },
            green: Band {
                lo_nm: 502.0,
                hi_nm: 582.0,
                edge_nm: 4.0,
                peak: 0.9,
                floor: 0.0,
            },
            blue: Band {
                lo_nm: 410.0,
                hi_nm: 495.0,
                edge_nm: 4.0,
                peak: 0.9,
                floor: 0.0,
            },
        }
    }
}

impl PanelSpec {
    /// The three bands in R, G, B order.
    pub fn bands(&self) -> [Band; 3] {
        [self.red, self.green, self.blue]
    }
}

/// Transfer curves per channel.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurvesSpec {
    /// Red.
    pub red: TransferCurve,
    /// Green.
    pub green: TransferCurve,
    /// Blue.
    pub blue: TransferCurve,
}

impl Default for CurvesSpec {
    fn default() -> Self {
        Self {
            red: TransferCurve {
                gamma: 2.45,
                s_weight: 0.30,
                s_centre: 0.56,
                s_steepness: 9.0,
                shoulder: 1.3,
            },
            green: TransferCurve {
                gamma: 2.25,
                s_weight: 0.25,
                s_centre: 0.50,
                s_steepness: 10.0,
                shoulder: 1.6,
            },
            blue: TransferCurve {
                gamma: 2.05,
                s_weight: 0.38,
                s_centre: 0.62,
                s_steepness: 8.0,
                shoulder: 1.1,
            },
        }
    }
}

impl CurvesSpec {
    /// The three curves in R, G, B order.
    pub fn curves(&self) -> [TransferCurve; 3] {
        [self.red, self.green, self.blue]
    }
}

/// Black level: light that leaks through each channel's panel at drive 0, plus stray
/// light, both as fractions of the unfiltered lamp. The leak is spectral (panels
/// leak most in the blue), so black is not a scaled white.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlackSpec {
    /// Leak through the red, green and blue panels.
    #[serde(default = "d_leak")]
    pub leak: [f64; 3],
    /// Stray light that bypasses the panels (through the comb filter).
    #[serde(default = "d_stray")]
    pub stray: f64,
}

impl Default for BlackSpec {
    fn default() -> Self {
        Self {
            leak: d_leak(),
            stray: d_stray(),
        }
    }
}

/// Per-channel gains (R, G, B) per eye.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelGainSpec {
    /// Mono displays.
    #[serde(default = "ones3")]
    pub mono: [f64; 3],
    /// Left-eye displays.
    #[serde(default = "ones3")]
    pub left: [f64; 3],
    /// Right-eye displays.
    #[serde(default = "ones3")]
    pub right: [f64; 3],
}

impl Default for ChannelGainSpec {
    fn default() -> Self {
        Self {
            mono: ones3(),
            left: ones3(),
            right: ones3(),
        }
    }
}

/// Spatial falloff: per channel vignetting `1/(1 + a_c·r²)²` (r = 1 at the corners)
/// times a lens hotspot `1 + h·exp(−|uv − uv_h|²/(2σ²))`; normalised so that the
/// centre uv = (0.5, 0.5) is the reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FalloffSpec {
    /// a_c per channel (different values shift the colour toward the corners).
    #[serde(default = "d_vignetting")]
    pub vignetting: [f64; 3],
    /// Hotspot amplitude h.
    #[serde(default = "d_hot")]
    pub hotspot_gain: f64,
    /// Hotspot σ in uv units.
    #[serde(default = "d_hot_sigma")]
    pub hotspot_sigma: f64,
    /// Hotspot centre offset from the image centre (uv units).
    #[serde(default)]
    pub hotspot_offset: [f64; 2],
}

impl Default for FalloffSpec {
    fn default() -> Self {
        Self {
            vignetting: d_vignetting(),
            hotspot_gain: d_hot(),
            hotspot_sigma: d_hot_sigma(),
            hotspot_offset: [0.0, 0.0],
        }
    }
}

/// Lamp ageing: per channel `1 − w_c·(fast·(1 − e^(−h/τ)) + slow·h/1000)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AgeingSpec {
    /// Fraction lost in the first ~3τ hours.
    #[serde(default = "d_fast")]
    pub fast_loss: f64,
    /// τ of the early loss (h).
    #[serde(default = "d_fast_h")]
    pub fast_hours: f64,
    /// Slow loss per 1000 h.
    #[serde(default = "d_slow")]
    pub slow_loss_per_1000h: f64,
    /// Per-channel weights w_c (UHP lamps lose blue fastest).
    #[serde(default = "d_age_w")]
    pub channel_weight: [f64; 3],
}

impl Default for AgeingSpec {
    fn default() -> Self {
        Self {
            fast_loss: d_fast(),
            fast_hours: d_fast_h(),
            slow_loss_per_1000h: d_slow(),
            channel_weight: d_age_w(),
        }
    }
}

/// Warm-up: per channel `1 − deficit_c · e^(−t/τ)`, t minutes since switch-on.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarmupSpec {
    /// Output missing right after switch-on, per channel.
    #[serde(default = "d_warm")]
    pub deficit: [f64; 3],
    /// τ (minutes).
    #[serde(default = "d_warm_min")]
    pub minutes: f64,
}

impl Default for WarmupSpec {
    fn default() -> Self {
        Self {
            deficit: d_warm(),
            minutes: d_warm_min(),
        }
    }
}

/// Infitec comb filters, three pass bands each (blue, green, red order is free).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InfitecSpec {
    /// Left-eye filter.
    pub left: CombSpec,
    /// Right-eye filter.
    pub right: CombSpec,
}

/// One comb filter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CombSpec {
    /// Pass bands.
    pub bands: Vec<Band>,
    /// Out-of-band transmission.
    #[serde(default = "d_comb_leak")]
    pub leak: f64,
}

impl Default for InfitecSpec {
    fn default() -> Self {
        // Kresse's HEyeWall: the left filter gives a reddish, the right a greenish
        // image (3.3.8, Tab. 6); band positions in the style of the Infitec A/B combs.
        let band = |lo_nm, hi_nm, peak| Band {
            lo_nm,
            hi_nm,
            edge_nm: 1.5,
            peak,
            floor: 0.0,
        };
        Self {
            left: CombSpec {
                bands: vec![
                    band(446.0, 462.0, 0.9),
                    band(518.0, 528.0, 0.75),
                    band(600.0, 626.0, 0.9),
                ],
                leak: d_comb_leak(),
            },
            right: CombSpec {
                bands: vec![
                    band(460.0, 478.0, 0.9),
                    band(538.0, 566.0, 0.9),
                    band(626.0, 640.0, 0.8),
                ],
                leak: d_comb_leak(),
            },
        }
    }
}

/// Seeded scatter between projectors (each drawn uniformly in ±value).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScatterSpec {
    /// Relative lamp power.
    #[serde(default)]
    pub lamp_power_rel: f64,
    /// Panel-filter band shift (nm).
    #[serde(default)]
    pub panel_shift_nm: f64,
    /// Comb-filter band shift (nm).
    #[serde(default)]
    pub comb_shift_nm: f64,
    /// Per-channel relative gain.
    #[serde(default)]
    pub channel_gain_rel: f64,
    /// Absolute change of each curve's γ.
    #[serde(default)]
    pub gamma: f64,
    /// Absolute change of each curve's s_weight and s_centre; relative change of its
    /// shoulder is 4× this.
    #[serde(default)]
    pub curve_shape: f64,
    /// Relative change of the vignetting coefficients.
    #[serde(default)]
    pub vignetting_rel: f64,
    /// Hotspot offset (uv units).
    #[serde(default)]
    pub hotspot_offset: f64,
    /// Lamp hours drawn uniformly in [min, max] (absent: `projector.lamp_hours`).
    #[serde(default)]
    pub lamp_hours: Option<[f64; 2]>,
}

impl Default for ScatterSpec {
    fn default() -> Self {
        Self {
            lamp_power_rel: 0.0,
            panel_shift_nm: 0.0,
            comb_shift_nm: 0.0,
            channel_gain_rel: 0.0,
            gamma: 0.0,
            curve_shape: 0.0,
            vignetting_rel: 0.0,
            hotspot_offset: 0.0,
            lamp_hours: None,
        }
    }
}

/// Per-projector override (applied after scatter).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OverrideSpec {
    /// Display index (wall order).
    pub display: u32,
    /// Lamp hours.
    #[serde(default)]
    pub lamp_hours: Option<f64>,
    /// Multiplier on the lamp power.
    #[serde(default)]
    pub lamp_power: Option<f64>,
    /// Multipliers on the channel gains.
    #[serde(default)]
    pub channel_gain: Option<[f64; 3]>,
    /// White segment (DLP non-additivity).
    #[serde(default)]
    pub white_segment: Option<f64>,
    /// Added to the hotspot's offset from the image centre (uv units): a lamp whose arc
    /// sits elsewhere in its reflector, as after a lamp change.
    #[serde(default)]
    pub hotspot_shift: Option<[f64; 2]>,
}

/// Defines the serde default functions of the wall file, one per defaulted value, each
/// returning its documented constant (serde's `default = "path"` needs a function).
macro_rules! serde_defaults {
    ($($(#[doc = $doc:literal])* $name:ident: $ty:ty = $value:expr;)*) => {
        $( $(#[doc = $doc])* fn $name() -> $ty { $value } )*
    };
}

serde_defaults! {
    /// A factor of 1 (no change).
    one: f64 = 1.0;
    /// Per-channel factors of 1 (no change).
    ones3: [f64; 3] = [1.0; 3];
    /// Width of one tile on the screen (m).
    d_tile_w: f64 = 5.0 / 6.0;
    /// Height of one tile on the screen (m).
    d_tile_h: f64 = 2.5 / 4.0;
    /// Simulated seconds per meter reading.
    d_spr: f64 = 1.0;
    /// Minutes since switch-on when the simulation starts.
    d_on: f64 = 30.0;
    /// σ of the screen's hotspot lobe (degrees).
    d_spec_w: f64 = 15.0;
    /// Head-on meter distance from the aimed spot (m).
    d_meter_dist: f64 = 2.0;
    /// Bits per channel of the projector input.
    d_bits: u32 = 8;
    /// Throw distance behind the screen (m).
    d_throw: f64 = 1.6;
    /// Lamp colour temperature (K).
    d_cct: f64 = 7500.0;
    /// Width of the pressure-broadened Hg lines of a UHP lamp (nm).
    d_line: f64 = 9.0;
    /// Fraction of the lamp continuum missing in the red (UHP).
    d_red_deficit: f64 = 0.35;
    /// Leak through the red, green and blue panels at black.
    d_leak: [f64; 3] = [0.0007, 0.0006, 0.0024];
    /// Stray light that bypasses the panels.
    d_stray: f64 = 0.0002;
    /// Vignetting coefficients, R, G, B.
    d_vignetting: [f64; 3] = [0.18, 0.20, 0.23];
    /// Hotspot amplitude.
    d_hot: f64 = 0.04;
    /// Hotspot σ (uv units).
    d_hot_sigma: f64 = 0.25;
    /// Fraction of lamp output lost early on.
    d_fast: f64 = 0.15;
    /// Time constant of the early loss (hours).
    d_fast_h: f64 = 50.0;
    /// Slow lamp loss per 1000 hours (fraction).
    d_slow: f64 = 0.025;
    /// Per-channel ageing weights (UHP lamps lose blue fastest).
    d_age_w: [f64; 3] = [0.9, 1.0, 1.25];
    /// Output missing right after switch-on, per channel.
    d_warm: [f64; 3] = [0.12, 0.08, 0.06];
    /// Warm-up time constant (minutes).
    d_warm_min: f64 = 4.0;
    /// Out-of-band transmission of the comb filters.
    d_comb_leak: f64 = 0.002;
}
