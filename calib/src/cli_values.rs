//! Text forms of calibration options, as the command line and configuration files
//! write them: white targets (`8500K`, `xy:0.291,0.300`, `native:3`) and low-light
//! handling (`avg:4`, `skip`) — and the bounded counts of the station's options: the
//! reading budget per display ([`parse_budget`]) and the verify patches per display
//! ([`parse_patches`]), for clap's `value_parser`.

use std::str::FromStr;

use crate::measure::grey_drives::GreyLevel;
use crate::measure::{LowLight, MeasureOptions};
use crate::solve::WhiteTarget;

/// Largest reading budget per display accepted: 10 000 readings (hours per display at
/// a real meter's pace; the adaptive ramps stop long before).
pub const MAX_BUDGET: u32 = 10_000;

/// Largest number of verify patches per display accepted: 100 000 (each is a reading;
/// the targets of a whole wall then stay within a few hundred MB).
pub const MAX_PATCHES: usize = 100_000;

/// Parses a reading budget per display in
/// [`MeasureOptions::MIN_BUDGET`]`..=`[`MAX_BUDGET`].
pub fn parse_budget(s: &str) -> Result<u32, String> {
    let min = MeasureOptions::MIN_BUDGET;
    let n: u32 = s.trim().parse().map_err(|_| {
        format!("`{s}` is not a number of readings; use {min} to {MAX_BUDGET} per display")
    })?;
    if n < min {
        Err(format!(
            "a budget of {n} readings per display is too small: every display needs at least \
             {min} (black, R, G, B, W and two ramp samples per channel); raise --budget to {min} \
             or more"
        ))
    } else if n > MAX_BUDGET {
        Err(format!(
            "a budget of {n} readings per display is more than the {MAX_BUDGET} allowed"
        ))
    } else {
        Ok(n)
    }
}

/// Parses `--grey-levels`: `none`, or comma-separated grey levels, each a share of the
/// target white's luminance in (0, 1], a luminance such as `1.5cd` or `gap` (each
/// channel's widest gap) ([`crate::measure::grey_drives`]).
pub fn parse_grey_levels(s: &str) -> Result<GreyLevels, String> {
    if s.trim().eq_ignore_ascii_case("none") {
        return Ok(GreyLevels(Vec::new()));
    }
    let levels = s
        .split(',')
        .map(str::parse)
        .collect::<Result<Vec<GreyLevel>, _>>()?;
    crate::measure::grey_drives::check_levels(&levels)?;
    Ok(GreyLevels(levels))
}

/// Grey levels of the grey-drive pass (empty: none).
#[derive(Debug, Clone, PartialEq)]
pub struct GreyLevels(pub Vec<GreyLevel>);

/// Parses a number of verify patches per display in `1..=`[`MAX_PATCHES`].
pub fn parse_patches(s: &str) -> Result<usize, String> {
    let n: usize = s.trim().parse().map_err(|_| {
        format!("`{s}` is not a number of patches; use 1 to {MAX_PATCHES} per display")
    })?;
    if (1..=MAX_PATCHES).contains(&n) {
        Ok(n)
    } else {
        Err(format!(
            "{n} patches per display: use 1 to {MAX_PATCHES} (0 would verify nothing)"
        ))
    }
}

impl FromStr for WhiteTarget {
    type Err = String;

    /// Parses `8500K`, `xy:0.291,0.300` or `native:3`.
    fn from_str(s: &str) -> Result<Self, String> {
        let t = s.trim();
        if let Some(k) = t.strip_suffix(['K', 'k']) {
            let kelvin: f64 = k
                .trim()
                .parse()
                .map_err(|_| format!("'{s}' is not a colour temperature like 8500K"))?;
            return Ok(WhiteTarget::Cct(kelvin));
        }
        if let Some(xy) = t.strip_prefix("xy:") {
            return parse_xy(s, xy).map(WhiteTarget::Xy);
        }
        if let Some(n) = t.strip_prefix("native:") {
            let i: usize = n
                .trim()
                .parse()
                .map_err(|_| format!("'{s}' does not name a display like native:3"))?;
            return Ok(WhiteTarget::NativeOf(i));
        }
        Err(format!(
            "white '{s}' not understood: use 8500K, xy:0.291,0.300 or native:3"
        ))
    }
}

/// The chromaticity `x,y` of the white target `whole` (for the messages).
fn parse_xy(whole: &str, xy: &str) -> Result<[f64; 2], String> {
    let v: Vec<f64> = xy
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{whole}' is not a chromaticity like xy:0.291,0.300"))?;
    match v[..] {
        // Strictly inside the bounding triangle of the chromaticity diagram.
        [x, y] if x > 0.0 && y > 0.0 && x + y < 1.0 => Ok([x, y]),
        _ => Err(format!(
            "'{whole}' is not a valid chromaticity like xy:0.291,0.300"
        )),
    }
}

impl FromStr for LowLight {
    type Err = String;

    /// Parses `avg:N` (N ≥ 1) or `skip`.
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "skip" {
            return Ok(LowLight::Skip);
        }
        s.strip_prefix("avg:")
            .and_then(|n| n.parse::<u32>().ok())
            .filter(|n| *n >= 1)
            .map(|repeats| LowLight::Average { repeats })
            .ok_or_else(|| format!("'{s}': use avg:N (N ≥ 1) or skip"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_targets_parse_from_kelvin_xy_and_native() {
        assert_eq!("8500K".parse(), Ok(WhiteTarget::Cct(8500.0)));
        assert_eq!(" 6504k ".parse(), Ok(WhiteTarget::Cct(6504.0)));
        assert_eq!(
            "xy:0.291,0.300".parse(),
            Ok(WhiteTarget::Xy([0.291, 0.300]))
        );
        assert_eq!("native:3".parse(), Ok(WhiteTarget::NativeOf(3)));
        for bad in ["warmK", "xy:0.3", "xy:0.8,0.5", "xy:a,b", "native:x", "D65"] {
            assert!(bad.parse::<WhiteTarget>().is_err(), "{bad}");
        }
    }

    #[test]
    fn low_light_parses_average_counts_from_one_and_skip() {
        assert_eq!("skip".parse(), Ok(LowLight::Skip));
        assert_eq!("avg:4".parse(), Ok(LowLight::Average { repeats: 4 }));
        for bad in ["avg:0", "avg:", "avg:x", "average"] {
            assert!(bad.parse::<LowLight>().is_err(), "{bad}");
        }
    }

    #[test]
    fn budgets_and_patches_are_bounded() {
        assert_eq!(parse_budget("40"), Ok(40));
        assert_eq!(parse_budget("11"), Ok(MeasureOptions::MIN_BUDGET));
        assert!(parse_budget("10").unwrap_err().contains("raise --budget"));
        for bad in ["0", "10001", "-1", "x", "4000000000000"] {
            assert!(parse_budget(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_patches("20"), Ok(20));
        assert_eq!(parse_patches("100000"), Ok(MAX_PATCHES));
        for bad in ["0", "100001", "4000000000", "-3", "5.5"] {
            assert!(parse_patches(bad).is_err(), "{bad}");
        }
    }
}
