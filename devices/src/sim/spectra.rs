//! Model spectra of the projector's optical path: lamps, panel (dichroic) band-pass
//! filters and Infitec interference comb filters. Shapes and parameters are documented
//! in `fixtures/spectra/README.md`.

use serde::{Deserialize, Serialize};

use super::observer::Spectrum;

/// Which lamp a projector has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LampKind {
    /// Ultra-high-pressure mercury lamp: pressure-broadened Hg lines on a continuum,
    /// short of red.
    Uhp,
    /// Xenon arc: close to a black body at the configured CCT.
    Xenon,
}

/// Planck's law, relative spectral radiance at `wavelength_nm` for temperature `t_k`.
pub fn planck(wavelength_nm: f64, t_k: f64) -> f64 {
    const C2_M_K: f64 = 1.438_776_877e-2;
    let l_m = wavelength_nm * 1e-9;
    1.0 / (l_m.powi(5) * ((C2_M_K / (l_m * t_k)).exp_m1()))
}

fn gaussian(x: f64, centre: f64, fwhm: f64) -> f64 {
    let sigma = fwhm / (8.0_f64 * std::f64::consts::LN_2).sqrt();
    (-0.5 * ((x - centre) / sigma).powi(2)).exp()
}

/// UHP mercury lines (nm, relative weight to the continuum peak).
pub const UHP_LINES: [(f64, f64); 5] = [
    (404.7, 0.45),
    (435.8, 0.85),
    (546.1, 1.00),
    (577.0, 0.45),
    (579.1, 0.45),
];

/// Relative lamp spectrum, peak-normalised continuum. `cct_k` is the continuum
/// temperature, `line_fwhm_nm` the pressure-broadened width of the Hg lines, and
/// `red_deficit` in 0..1 the fraction of continuum missing above ~600 nm (UHP).
pub fn lamp(kind: LampKind, cct_k: f64, line_fwhm_nm: f64, red_deficit: f64) -> Spectrum {
    let peak_wl = 2.897_771_955e6 / cct_k; // Wien, nm
    let norm = planck(peak_wl.clamp(360.0, 830.0), cct_k);
    match kind {
        LampKind::Xenon => Spectrum::from_fn(|wl| planck(wl, cct_k) / norm),
        LampKind::Uhp => Spectrum::from_fn(|wl| {
            let cont = 0.45 * planck(wl, cct_k) / norm;
            let red_cut = 1.0 - red_deficit * logistic((wl - 610.0) / 12.0);
            let lines: f64 = UHP_LINES
                .iter()
                .map(|&(c, w)| w * gaussian(wl, c, line_fwhm_nm))
                .sum();
            cont * red_cut + lines
        }),
    }
}

/// The logistic function 1/(1+e^-x).
pub fn logistic(x: f64) -> f64 {
    1.0 / (1.0 + (-x).exp())
}

/// A smooth band-pass: transmission `peak` between `lo_nm` and `hi_nm`, logistic
/// edges of width `edge_nm` (10 %–90 % rise ≈ 4.4 · edge).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Band {
    /// Lower half-power wavelength (nm).
    pub lo_nm: f64,
    /// Upper half-power wavelength (nm).
    pub hi_nm: f64,
    /// Edge softness (nm).
    pub edge_nm: f64,
    /// In-band transmission, 0..=1.
    pub peak: f64,
    /// Out-of-band transmission (imperfect dichroic), 0..=peak; default 0.
    #[serde(default)]
    pub floor: f64,
}

impl Band {
    /// Transmission at `wavelength_nm`.
    pub fn transmission(&self, wavelength_nm: f64) -> f64 {
        let e = self.edge_nm.max(1e-3);
        self.floor
            + (self.peak - self.floor)
                * logistic((wavelength_nm - self.lo_nm) / e)
                * logistic((self.hi_nm - wavelength_nm) / e)
    }

    /// The band moved by `shift_nm` (manufacturing scatter).
    pub fn shifted(&self, shift_nm: f64) -> Band {
        Band {
            lo_nm: self.lo_nm + shift_nm,
            hi_nm: self.hi_nm + shift_nm,
            ..*self
        }
    }

    /// As a spectrum.
    pub fn spectrum(&self) -> Spectrum {
        Spectrum::from_fn(|wl| self.transmission(wl))
    }
}

/// A comb filter: the sum of its pass bands plus a flat out-of-band leak.
pub fn comb(bands: &[Band], leak: f64) -> Spectrum {
    Spectrum::from_fn(|wl| {
        let t: f64 = bands.iter().map(|b| b.transmission(wl)).sum();
        (t + leak).min(1.0)
    })
}
