//! Inversion of a measured forward tone curve into the monotone inverse LUT of a
//! [`ToneCurve`](crate::ToneCurve), robust to flat and non-monotone regions.
//!
//! A real projector curve is S-shaped, may be flat at the ends (drive changes, light does
//! not) and, measured with noise, may dip. The inverse is taken of the running-maximum
//! envelope `F(d) = max_{d' ≤ d} f(d')`: entry `i` holds the *lowest* drive that reaches
//! relative intensity `i / (n − 1)`. Flat regions therefore map to their lower end and
//! dips are skipped; the result is non-decreasing by construction.

use super::ApplyError;

/// Builds an inverse LUT with `entries` entries from forward samples `[drive, light]`
/// (drive increasing; light in any unit, e.g. cd/m² or relative). Light is normalised so
/// that the first sample is 0 and the envelope's maximum is 1.
pub fn invert_forward(forward: &[[f64; 2]], entries: usize) -> Result<Vec<f32>, ApplyError> {
    if forward.len() < 2 {
        return Err(ApplyError::Curve(format!(
            "{} forward samples, at least 2 needed",
            forward.len()
        )));
    }
    if entries < 2 {
        return Err(ApplyError::Curve(format!(
            "{entries} LUT entries, at least 2 needed"
        )));
    }
    if let Some(i) = forward
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(ApplyError::Curve(format!(
            "sample {i} is not a finite number"
        )));
    }
    if let Some(i) = forward.windows(2).position(|w| w[1][0] <= w[0][0]) {
        return Err(ApplyError::Curve(format!(
            "drive does not increase between samples {i} and {}",
            i + 1
        )));
    }
    // Running-maximum envelope.
    let mut env = Vec::with_capacity(forward.len());
    let mut best = f64::NEG_INFINITY;
    for p in forward {
        best = best.max(p[1]);
        env.push(best);
    }
    let lo = forward[0][1];
    let hi = best;
    if hi <= lo {
        return Err(ApplyError::Curve(
            "light output never rises above its value at the lowest drive".into(),
        ));
    }
    let rel: Vec<f64> = env.iter().map(|v| (v - lo) / (hi - lo)).collect();
    let mut lut = Vec::with_capacity(entries);
    let mut prev = 0.0f32;
    for i in 0..entries {
        let target = i as f64 / (entries - 1) as f64;
        let k = rel.partition_point(|v| *v < target);
        let d = if k == 0 {
            forward[0][0]
        } else if k >= rel.len() {
            forward[rel.len() - 1][0]
        } else {
            // rel[k−1] < target ≤ rel[k], so the segment rises.
            let w = (target - rel[k - 1]) / (rel[k] - rel[k - 1]);
            forward[k - 1][0] + w * (forward[k][0] - forward[k - 1][0])
        };
        let d = (d.clamp(0.0, 1.0) as f32).max(prev);
        lut.push(d);
        prev = d;
    }
    Ok(lut)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampled(f: impl Fn(f64) -> f64, n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let d = i as f64 / (n - 1) as f64;
                [d, f(d)]
            })
            .collect()
    }

    #[test]
    fn inverts_a_power_law_analytically() {
        let lut = invert_forward(&sampled(|d| d.powf(2.2), 4097), 1024).unwrap();
        for (i, v) in lut.iter().enumerate() {
            let target = (i as f64 / 1023.0).powf(1.0 / 2.2);
            // Linear interpolation in a 4097-sample forward curve: error is largest at
            // the steep toe (first segment), tiny elsewhere.
            let tol = if i < 4 { 2e-2 } else { 2e-4 };
            assert!(
                (f64::from(*v) - target).abs() < tol,
                "entry {i}: {v} vs {target}"
            );
        }
        assert_eq!(lut[0], 0.0);
        assert_eq!(lut[1023], 1.0);
    }

    #[test]
    fn flat_regions_map_to_their_lower_end() {
        // Dead zone: no light until drive 0.2, saturation from drive 0.8.
        let f = |d: f64| ((d - 0.2) / 0.6).clamp(0.0, 1.0);
        let lut = invert_forward(&sampled(f, 1001), 1024).unwrap();
        // Intensity 0 → lowest drive giving it (0.0, the start of the flat foot).
        assert_eq!(lut[0], 0.0);
        // Just above 0 → just above 0.2 (the dead zone is skipped).
        assert!(
            (lut[1] - (0.2 + 0.6 / 1023.0) as f32).abs() < 1e-4,
            "{}",
            lut[1]
        );
        // Full intensity → 0.8, not 1.0 (saturation plateau is not used).
        assert!((lut[1023] - 0.8).abs() < 1e-6, "{}", lut[1023]);
        // Midpoint exact for this linear ramp.
        let mid = 0.2 + 0.6 * (511.0 / 1023.0);
        assert!((f64::from(lut[511]) - mid).abs() < 1e-5);
    }

    #[test]
    fn non_monotone_curves_give_a_monotone_inverse() {
        // A dip between 0.4 and 0.6 (noise or a DLP colour-wheel artefact).
        let f = |d: f64| {
            let base = d * d;
            if (0.4..0.6).contains(&d) {
                base - 0.1 * (1.0 - ((d - 0.5) / 0.1).powi(2))
            } else {
                base
            }
        };
        let lut = invert_forward(&sampled(f, 2001), 1024).unwrap();
        assert!(lut.windows(2).all(|w| w[1] >= w[0]));
        // Independent reference: brute-force lowest drive on a fine grid with f ≥ level.
        for i in (0..1024).step_by(7) {
            let level = i as f64 / 1023.0;
            let brute = (0..=1_000_000)
                .map(|k| k as f64 / 1e6)
                .find(|d| f(*d) >= level - 1e-12)
                .unwrap();
            assert!(
                (f64::from(lut[i]) - brute).abs() < 1.5e-3,
                "level {level}: {} vs {brute}",
                lut[i]
            );
        }
        // Level 0.161 is just above f(0.4) = 0.16, where the dip starts: it is first
        // reached after the dip (≈ 0.51), so the inverse jumps over the dip.
        let i = (0.161f64 * 1023.0).round() as usize;
        assert!(lut[i] > 0.5 && lut[i] < 0.52, "{}", lut[i]);
    }

    #[test]
    fn unusable_curves_are_errors() {
        assert!(invert_forward(&[[0.0, 0.0]], 1024).is_err());
        assert!(invert_forward(&[[0.0, 1.0], [1.0, 1.0]], 1024).is_err());
        assert!(invert_forward(&[[0.0, 0.0], [0.0, 1.0]], 1024).is_err());
        assert!(invert_forward(&[[0.0, 0.0], [1.0, f64::NAN]], 1024).is_err());
        assert!(invert_forward(&[[0.0, 0.0], [1.0, 1.0]], 1).is_err());
    }
}
