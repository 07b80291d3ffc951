//! Spectra on a fixed 1 nm grid and the CIE 1931 2° observer that integrates them.
//!
//! The observer and the D65 table are the published CIE 015:2018 tables as shipped by
//! colour-science, exported to `fixtures/cie/` (see `fixtures/cie/export.py`) and
//! embedded here with `include_str!` and parsed once.

use std::sync::OnceLock;

use crate::{CoreError, Xy};

/// Shortest wavelength of the grid (nm).
pub const WL_MIN_NM: f64 = 360.0;
/// Longest wavelength of the grid (nm).
pub const WL_MAX_NM: f64 = 830.0;
/// Grid step (nm).
pub const WL_STEP_NM: f64 = 1.0;
/// Number of grid samples (360..=830 nm at 1 nm).
pub const N_SAMPLES: usize = 471;

const CIE1931_CSV: &str = include_str!("../../../fixtures/cie/cie1931_2deg_1nm.csv");
const D65_CSV: &str = include_str!("../../../fixtures/cie/d65_5nm.csv");

/// A spectral quantity sampled on the 360–830 nm, 1 nm grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// One value per grid wavelength, `values[i]` at `WL_MIN_NM + i` nm.
    pub values: Vec<f64>,
}

impl Spectrum {
    /// Builds a spectrum by evaluating `f(wavelength_nm)` on the grid.
    pub fn from_fn(f: impl Fn(f64) -> f64) -> Self {
        Self {
            values: (0..N_SAMPLES).map(|i| f(wavelength_nm(i))).collect(),
        }
    }

    /// A flat spectrum of constant `value`.
    pub fn constant(value: f64) -> Self {
        Self {
            values: vec![value; N_SAMPLES],
        }
    }

    /// Product with another spectrum, sample by sample.
    pub fn mul(&self, other: &Spectrum) -> Spectrum {
        Spectrum {
            values: self
                .values
                .iter()
                .zip(&other.values)
                .map(|(a, b)| a * b)
                .collect(),
        }
    }

    /// Sum with another spectrum, sample by sample.
    pub fn add(&self, other: &Spectrum) -> Spectrum {
        Spectrum {
            values: self
                .values
                .iter()
                .zip(&other.values)
                .map(|(a, b)| a + b)
                .collect(),
        }
    }

    /// The spectrum scaled by `k`.
    pub fn scaled(&self, k: f64) -> Spectrum {
        Spectrum {
            values: self.values.iter().map(|v| v * k).collect(),
        }
    }

    /// Value at `wavelength_nm`, linearly interpolated; 0 outside the grid.
    pub fn at(&self, wavelength_nm: f64) -> f64 {
        let t = (wavelength_nm - WL_MIN_NM) / WL_STEP_NM;
        if !(0.0..=(N_SAMPLES - 1) as f64).contains(&t) {
            return 0.0;
        }
        let i = (t.floor() as usize).min(N_SAMPLES - 2);
        let f = t - i as f64;
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }
}

/// Wavelength (nm) of grid sample `i`.
pub fn wavelength_nm(i: usize) -> f64 {
    WL_MIN_NM + i as f64 * WL_STEP_NM
}

/// The CIE 1931 2° standard colorimetric observer on the grid.
#[derive(Debug, Clone)]
pub struct Observer {
    /// x̄(λ).
    pub x_bar: Spectrum,
    /// ȳ(λ) (the photopic luminous efficiency V(λ)).
    pub y_bar: Spectrum,
    /// z̄(λ).
    pub z_bar: Spectrum,
}

impl Observer {
    /// Tristimulus sums `Σ S(λ)·[x̄, ȳ, z̄](λ)·Δλ` of a spectrum (relative units).
    pub fn tristimulus(&self, s: &Spectrum) -> [f64; 3] {
        let mut acc = [0.0; 3];
        for (i, v) in s.values.iter().enumerate() {
            acc[0] += v * self.x_bar.values[i];
            acc[1] += v * self.y_bar.values[i];
            acc[2] += v * self.z_bar.values[i];
        }
        acc.map(|a| a * WL_STEP_NM)
    }

    /// xy of the spectral locus at the grid wavelengths `from_nm..=to_nm`.
    pub fn spectral_locus(&self, from_nm: f64, to_nm: f64) -> Vec<(f64, Xy)> {
        (0..N_SAMPLES)
            .map(|i| (wavelength_nm(i), i))
            .filter(|(wl, _)| (from_nm..=to_nm).contains(wl))
            .filter_map(|(wl, i)| {
                let (x, y, z) = (
                    self.x_bar.values[i],
                    self.y_bar.values[i],
                    self.z_bar.values[i],
                );
                let s = x + y + z;
                (s > 0.0).then(|| (wl, Xy::new(x / s, y / s)))
            })
            .collect()
    }
}

fn data_rows(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'))
        .skip(1) // header row
}

fn parse_fields(line_no: usize, line: &str, n: usize) -> Result<Vec<f64>, String> {
    let fields: Result<Vec<f64>, _> = line.split(',').map(|f| f.trim().parse::<f64>()).collect();
    match fields {
        Ok(v) if v.len() == n => Ok(v),
        _ => Err(format!(
            "embedded table line {}: expected {n} numbers, got {line:?}",
            line_no + 1
        )),
    }
}

fn parse_observer() -> Result<Observer, String> {
    let mut x = vec![f64::NAN; N_SAMPLES];
    let mut y = x.clone();
    let mut z = x.clone();
    for (no, line) in data_rows(CIE1931_CSV) {
        let v = parse_fields(no, line, 4)?;
        let i = ((v[0] - WL_MIN_NM) / WL_STEP_NM).round();
        if !(0.0..N_SAMPLES as f64).contains(&i) {
            return Err(format!("observer table: wavelength {} off the grid", v[0]));
        }
        let i = i as usize;
        (x[i], y[i], z[i]) = (v[1], v[2], v[3]);
    }
    if x.iter().chain(&y).chain(&z).any(|v| !v.is_finite()) {
        return Err("observer table does not cover 360–830 nm in 1 nm steps".into());
    }
    Ok(Observer {
        x_bar: Spectrum { values: x },
        y_bar: Spectrum { values: y },
        z_bar: Spectrum { values: z },
    })
}

fn parse_d65() -> Result<Spectrum, String> {
    let mut columns = spectra_from_csv(D65_CSV, 1).map_err(|e| format!("D65 table: {e}"))?;
    Ok(columns.remove(0))
}

/// Parses a spectral table (`#` comment lines, one header line, rows of wavelength in
/// nm followed by `columns` values, wavelengths increasing, any step) onto the grid:
/// linear interpolation inside the table's range, 0 outside it. One spectrum per
/// column.
pub fn spectra_from_csv(text: &str, columns: usize) -> Result<Vec<Spectrum>, String> {
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for (no, line) in data_rows(text) {
        rows.push(parse_fields(no, line, columns + 1)?);
    }
    if rows.len() < 2 || rows.windows(2).any(|w| w[1][0] <= w[0][0]) {
        return Err("table is empty or not increasing in wavelength".into());
    }
    let (lo, hi) = (rows[0][0], rows[rows.len() - 1][0]);
    Ok((1..=columns)
        .map(|c| {
            Spectrum::from_fn(|wl| {
                if wl < lo || wl > hi {
                    return 0.0;
                }
                let k = rows
                    .partition_point(|r| r[0] <= wl)
                    .clamp(1, rows.len() - 1);
                let (a, b) = (&rows[k - 1], &rows[k]);
                a[c] + (b[c] - a[c]) * (wl - a[0]) / (b[0] - a[0])
            })
        })
        .collect())
}

/// The CIE 1931 2° observer (parsed once from the embedded table).
pub fn cie1931() -> Result<&'static Observer, CoreError> {
    static OBS: OnceLock<Result<Observer, String>> = OnceLock::new();
    OBS.get_or_init(parse_observer)
        .as_ref()
        .map_err(|e| CoreError::EmbeddedTable(e.clone()))
}

/// CIE illuminant D65 (relative power, published 300–780 nm at 5 nm, linearly
/// interpolated onto the grid, 0 above 780 nm).
pub fn d65() -> Result<&'static Spectrum, CoreError> {
    static D65: OnceLock<Result<Spectrum, String>> = OnceLock::new();
    D65.get_or_init(parse_d65)
        .as_ref()
        .map_err(|e| CoreError::EmbeddedTable(e.clone()))
}
