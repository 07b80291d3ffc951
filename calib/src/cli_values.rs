//! Text forms of calibration options, as the command line and configuration files
//! write them: white targets (`8500K`, `xy:0.291,0.300`, `native:3`) and low-light
//! handling (`avg:4`, `skip`).

use std::str::FromStr;

use crate::measure::LowLight;
use crate::solve::WhiteTarget;

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
}
