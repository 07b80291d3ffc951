//! Published performance figures of the serial instruments, in one place, so that
//! the simulator's meter error model can be configured to match the instrument the
//! emulator pretends to be. Sources and the reasoning behind every number are in
//! `fixtures/instruments/klein-k10a.md`.

use serde::Serialize;

/// Range, low-light behaviour, accuracy and timing of a spot colorimeter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InstrumentSpec {
    /// Model name as the instrument reports it.
    pub model: &'static str,
    /// Lowest luminance the instrument resolves at all (cd/m²).
    pub min_cd_m2: f64,
    /// Below this luminance a single reading is unreliable and should be averaged
    /// (cd/m²).
    pub min_reliable_cd_m2: f64,
    /// Highest luminance it reads; above this it reports over-range (cd/m²).
    pub max_cd_m2: f64,
    /// Luminance accuracy, relative (0.03 = ±3 %), for a white above the reliable limit.
    pub luminance_accuracy_rel: f64,
    /// Chromaticity accuracy, ± in CIE 1931 x and y, for a white above the reliable limit.
    pub xy_accuracy: f64,
    /// Size of the zero-light noise on Y of one default-speed reading (cd/m²); X and Z
    /// are noisier by `xz_noise_factor`.
    pub noise_floor_y_cd_m2: f64,
    /// Ratio of X/Z to Y zero-light noise.
    pub xz_noise_factor: f64,
    /// 1σ relative luminance repeatability of one reading at high luminance.
    pub repeatability_lum_rel: f64,
    /// 1σ repeatability of x and y of one reading at high luminance.
    pub repeatability_xy: f64,
    /// Time of one default-speed reading in the instrument (s).
    pub measurement_time_s: f64,
    /// Serial line speed (baud).
    pub baud_rate: u32,
}

impl InstrumentSpec {
    /// 1σ zero-light noise of Y for one reading (cd/m²), taking the SDK's
    /// negative-reading threshold `noise_floor_y_cd_m2` as a 2σ bound.
    pub fn dark_sigma_y_cd_m2(&self) -> f64 {
        self.noise_floor_y_cd_m2 / 2.0
    }

    /// The simulator's meter error model for this instrument, `seed` playing the
    /// serial number. Systematic bounds are the accuracy figures; the low-light noise
    /// terms are the dark noise referred to `min_reliable_cd_m2`: relative luminance
    /// σ_Y/Y and, for a white (x ≈ y ≈ 1/3) with X/Z noise `k`·σ_Y, the
    /// chromaticity σ_x ≈ σ_Y·√(5k²+1)/(9·Y).
    #[cfg(feature = "sim")]
    pub fn sim_meter_model(&self, seed: u64) -> crate::sim::MeterModel {
        let sigma = self.dark_sigma_y_cd_m2();
        let k = self.xz_noise_factor;
        let y_ref = self.min_reliable_cd_m2;
        let mut m = crate::sim::MeterModel::noiseless();
        m.model = format!("Klein {} (simulated)", self.model);
        m.seed = seed;
        m.lum_systematic_rel = self.luminance_accuracy_rel;
        m.xy_systematic = self.xy_accuracy;
        m.lum_noise_rel = self.repeatability_lum_rel;
        m.xy_noise = self.repeatability_xy;
        m.low_light_cd_m2 = y_ref;
        m.lum_low_light_rel = sigma / y_ref;
        m.xy_low_light = sigma * (5.0 * k * k + 1.0).sqrt() / (9.0 * y_ref);
        m.min_reliable_cd_m2 = self.min_reliable_cd_m2;
        m.floor_cd_m2 = self.min_cd_m2;
        m.max_cd_m2 = self.max_cd_m2;
        m.display_digits = None;
        m
    }

    /// The noise of one reading: the high-light repeatability and the zero-light
    /// noise of Y, X and Z `xz_noise_factor` times Y's.
    pub fn reading_noise(&self) -> crate::ReadingNoise {
        let sy = self.dark_sigma_y_cd_m2();
        let sxz = sy * self.xz_noise_factor;
        crate::ReadingNoise {
            luminance_rel: self.repeatability_lum_rel,
            xy: self.repeatability_xy,
            dark_xyz_cd_m2: [sxz, sy, sxz],
        }
    }

    /// Time to send `bytes` bytes at the line speed with 8N1 framing (10 bits a byte), s.
    pub fn transmit_time_s(&self, bytes: usize) -> f64 {
        bytes as f64 * 10.0 / f64::from(self.baud_rate)
    }
}

/// Klein Instruments K-10-A.
///
/// * Range 0.001 to 4000 cd/m²: the K-10-A driver documentation of the Brainard
///   lab (Psychtoolbox-style MEX driver `K10A_device`) states "0.001 to 4000+ cd/m²".
/// * Reliable single readings from 0.2 cd/m²: ArgyllCMS `kleink10.c` averages up to
///   20 readings below 0.2 cd/m² and 10 between 0.2 and 2 cd/m².
/// * Noise: Klein's own SDK (`KClmtr.cpp`) flags a negative Y below
///   −0.02 · (1/3 for the K-10-A) · √(32/4) ≈ −0.019 cd/m² for one 8-per-second
///   reading as a fault, and uses three times that for X and Z.
/// * Accuracy: the maker's datasheet was not available; ±3 % luminance and
///   ±0.004 xy are chosen conservatively (no better than the CS-100A figures in
///   DESIGN.md). High-light repeatability (1σ 0.1 % and 0.0005 xy) is likewise
///   assumed equal to the CS-100A's.
/// * Timing: `N5` gives 8 readings a second (Klein SDK `COLOR_8PERSECOND`); 9600 baud
///   8N1 (Klein SDK and ArgyllCMS).
pub const KLEIN_K10A: InstrumentSpec = InstrumentSpec {
    model: "K-10-A",
    min_cd_m2: 0.001,
    min_reliable_cd_m2: 0.2,
    max_cd_m2: 4000.0,
    luminance_accuracy_rel: 0.03,
    xy_accuracy: 0.004,
    noise_floor_y_cd_m2: 0.019,
    xz_noise_factor: 3.0,
    repeatability_lum_rel: 0.001,
    repeatability_xy: 0.0005,
    measurement_time_s: 0.125,
    baud_rate: 9600,
};
