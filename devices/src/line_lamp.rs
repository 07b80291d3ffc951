//! Wavelength-calibration lamps: a low-pressure discharge lamp (e.g. a mercury–argon
//! pen lamp) emits lines whose wavelengths are atomic constants, so a spectroradiometer
//! that measures one can check and correct its own wavelength scale. A grating
//! instrument's scale is specified only to ±0.3–0.5 nm, and on a narrow-band Infitec
//! green 0.3 nm is already 0.002 in xy.
//!
//! The lamp's data are here ([`LineLamp`]); the [`LampHolder`] puts it before the
//! instrument's entrance optics (a technician, prompted; on the virtual wall, the
//! simulated instrument's own lamp).

use std::io::{BufRead, Write};

use crate::DeviceError;

/// One emission line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmissionLine {
    /// Wavelength in standard air (nm).
    pub wavelength_nm: f64,
    /// Radiance relative to the lamp's strongest line (approximate: it depends on the
    /// lamp's current and temperature). It shapes the simulated lamp and decides
    /// which neighbours count ([`LineLamp::isolated_lines`]).
    pub relative_intensity: f64,
}

/// A line lamp: its name and every line it shows between 380 and 780 nm.
#[derive(Debug, Clone, PartialEq)]
pub struct LineLamp {
    /// The lamp, e.g. "Hg-Ar pen lamp".
    pub name: String,
    /// Its lines, ascending in wavelength.
    pub lines: Vec<EmissionLine>,
}

impl LineLamp {
    /// A mercury–argon pen lamp (e.g. Ocean Insight HG-1, Newport 6035): the Hg I and
    /// Ar I lines between 380 and 780 nm, wavelengths in air from the NIST Atomic
    /// Spectra Database (`fixtures/instruments/hg-ar-lamp.md`); the relative intensities
    /// are rough values of such a lamp warmed up, and include the weak lines that blend
    /// with strong ones (407.8 beside 404.7 nm, 751.5 beside 750.4 nm) so that a check
    /// does not take a blend for a clean line.
    pub fn hg_ar() -> Self {
        let lines = [
            (404.6563, 0.35),
            (407.7837, 0.05),
            (435.8328, 1.0),
            (546.0735, 0.9),
            (576.9598, 0.15),
            (579.0663, 0.15),
            (696.5431, 0.08),
            (706.7218, 0.06),
            (714.7042, 0.02),
            (727.2936, 0.03),
            (738.3980, 0.06),
            (750.3869, 0.10),
            (751.4652, 0.06),
            (763.5106, 0.15),
            (772.3761, 0.05),
            (772.4207, 0.03),
        ];
        LineLamp {
            name: "Hg-Ar pen lamp".into(),
            lines: lines
                .iter()
                .map(|&(wavelength_nm, relative_intensity)| EmissionLine {
                    wavelength_nm,
                    relative_intensity,
                })
                .collect(),
        }
    }

    /// The lines an instrument of resolution `fwhm_nm` (slit full width at half
    /// maximum) sampled every `step_nm` sees apart from every other line of at least
    /// 1 % of its intensity, within `range_nm`, when each line is looked for within
    /// ±`search_nm` of its wavelength: no neighbour closer than `2·fwhm + step` (a
    /// window of ±(fwhm + step/2) around the line's peak pixel holds none of the
    /// neighbour's light inside its FWHM) nor closer than `fwhm + 2·search` (the
    /// search cannot land on the neighbour's flank).
    pub fn isolated_lines(
        &self,
        fwhm_nm: f64,
        step_nm: f64,
        search_nm: f64,
        range_nm: [f64; 2],
    ) -> Vec<f64> {
        let reach = (2.0 * fwhm_nm + step_nm).max(fwhm_nm + 2.0 * search_nm);
        let margin = fwhm_nm + step_nm + search_nm;
        self.lines
            .iter()
            .filter(|l| {
                l.wavelength_nm - margin >= range_nm[0] && l.wavelength_nm + margin <= range_nm[1]
            })
            .filter(|l| {
                !self.lines.iter().any(|o| {
                    o != *l
                        && o.relative_intensity >= 0.01 * l.relative_intensity
                        && (o.wavelength_nm - l.wavelength_nm).abs() < reach
                })
            })
            .map(|l| l.wavelength_nm)
            .collect()
    }
}

/// Puts a line lamp before a spectroradiometer's entrance optics and takes it away.
pub trait LampHolder {
    /// Places `lamp` (lit) before the instrument; returns when it is there.
    fn place(&mut self, lamp: &LineLamp) -> Result<(), DeviceError>;

    /// Takes the lamp away again (the instrument sees the wall).
    fn remove(&mut self) -> Result<(), DeviceError>;
}

/// One answer line from the technician (`None`: the input ended).
type ReadLine = Box<dyn FnMut() -> std::io::Result<Option<String>> + Send>;

/// A technician holds the lamp: prompted on `output`, answering on `input` (Enter =
/// done, `q` = stop).
pub struct GuidedLampHolder {
    input: ReadLine,
    output: Box<dyn Write + Send>,
}

impl GuidedLampHolder {
    /// Prompts on `output` and reads answers from `input`.
    pub fn new(mut input: Box<dyn BufRead + Send>, output: Box<dyn Write + Send>) -> Self {
        let input = Box::new(move || {
            let mut line = String::new();
            Ok((input.read_line(&mut line)? > 0).then_some(line))
        });
        GuidedLampHolder { input, output }
    }

    /// Prompts on stdout and reads the process's stdin one line at a time, through its
    /// shared buffer, so that whatever reads stdin next (a guided meter positioner)
    /// still gets the lines after the answers.
    pub fn on_terminal() -> Self {
        let input = Box::new(|| {
            let mut line = String::new();
            Ok((std::io::stdin().read_line(&mut line)? > 0).then_some(line))
        });
        GuidedLampHolder {
            input,
            output: Box::new(std::io::stdout()),
        }
    }

    /// Prints `prompt` and waits for Enter; `q` or the end of the input stops.
    fn ask(&mut self, prompt: &str) -> Result<(), DeviceError> {
        let io = |source| DeviceError::Io {
            device: "the technician's terminal".into(),
            source,
        };
        writeln!(self.output, "{prompt}; Enter = done, q = stop").map_err(io)?;
        self.output.flush().map_err(io)?;
        match (self.input)().map_err(io)? {
            Some(line) if !line.trim().eq_ignore_ascii_case("q") => Ok(()),
            _ => Err(DeviceError::AimStopped(
                "the wavelength check's lamp".into(),
            )),
        }
    }
}

impl LampHolder for GuidedLampHolder {
    fn place(&mut self, lamp: &LineLamp) -> Result<(), DeviceError> {
        self.ask(&format!(
            "switch on the {} (warm it up for 5 minutes) and hold it before the \
             spectroradiometer's lens, filling its field",
            lamp.name
        ))
    }

    fn remove(&mut self) -> Result<(), DeviceError> {
        self.ask("take the lamp away; aim the spectroradiometer at the wall again")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_5_nm_instrument_sees_four_clean_hg_ar_lines_and_no_blend() {
        let lines = LineLamp::hg_ar().isolated_lines(5.0, 1.0, 2.0, [380.0, 780.0]);
        assert_eq!(lines, vec![435.8328, 546.0735, 727.2936, 738.3980]);
        let sharper = LineLamp::hg_ar().isolated_lines(4.5, 1.0, 2.0, [380.0, 780.0]);
        assert_eq!(
            sharper,
            vec![435.8328, 546.0735, 696.5431, 727.2936, 738.3980]
        );
        // a 1 nm instrument searching ±2 nm: the 404.7/407.8 pair (3.1 nm apart) is
        // too close for the search; 576.96/579.07, 750.39/751.47 and 772.38/772.42 too
        let fine = LineLamp::hg_ar().isolated_lines(1.0, 1.0, 2.0, [380.0, 780.0]);
        assert!(
            fine.contains(&435.8328) && fine.contains(&763.5106),
            "{fine:?}"
        );
        assert!(
            ![404.6563, 576.9598, 750.3869, 772.3761]
                .iter()
                .any(|l| fine.contains(l))
        );
    }

    #[test]
    fn the_guided_holder_waits_for_enter_and_stops_on_q_or_a_closed_terminal() {
        let holder = |answers: &'static str| {
            GuidedLampHolder::new(Box::new(answers.as_bytes()), Box::new(Vec::new()))
        };
        let lamp = LineLamp::hg_ar();
        assert!(holder("\n").place(&lamp).is_ok());
        assert!(holder("q\n").place(&lamp).is_err());
        assert!(holder("").remove().is_err());
    }
}
