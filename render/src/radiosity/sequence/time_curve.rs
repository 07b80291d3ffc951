//! Radiosity as a piecewise-linear function of time (Hahn 2000, 4.4): an element's
//! exitance over the frames kept only at knot frames, linear in between. Where an
//! element sees no change (most of a room while a small object moves) two knots
//! hold all its frames.

/// One element's exitance over frames: knot frames (indices into the sequence's
/// frames, the first and the last always among them) and the XYZ exitance there.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeCurve {
    /// Knots in increasing frame order: (frame index, XYZ exitance in lm/m²).
    pub knots: Vec<(usize, [f64; 3])>,
}

impl TimeCurve {
    /// The exitance at frame index `k` (linear between the knots around it).
    pub fn at(&self, k: usize) -> [f64; 3] {
        let after = self.knots.partition_point(|(f, _)| *f < k);
        if after == 0 {
            return self.knots[0].1;
        }
        if after == self.knots.len() {
            return self.knots[after - 1].1;
        }
        let ((fa, a), (fb, b)) = (self.knots[after - 1], self.knots[after]);
        let t = (k - fa) as f64 / (fb - fa) as f64;
        std::array::from_fn(|c| a[c] + (b[c] - a[c]) * t)
    }
}

/// The fewest knots (greedily, from the first frame on) such that every frame's
/// value lies within `tolerance` (lm/m², per channel) of the line between its knots.
pub fn fit(values: &[[f64; 3]], tolerance: f64) -> TimeCurve {
    let mut knots = vec![(0, values[0])];
    let mut start = 0;
    while start + 1 < values.len() {
        let mut end = start + 1;
        while end + 1 < values.len() && spans(values, start, end + 1, tolerance) {
            end += 1;
        }
        knots.push((end, values[end]));
        start = end;
    }
    TimeCurve { knots }
}

/// Whether the line from frame `a` to frame `b` passes within `tolerance` of every
/// frame between them.
fn spans(values: &[[f64; 3]], a: usize, b: usize, tolerance: f64) -> bool {
    (a + 1..b).all(|k| {
        let t = (k - a) as f64 / (b - a) as f64;
        (0..3).all(|c| {
            let line = values[a][c] + (values[b][c] - values[a][c]) * t;
            (values[k][c] - line).abs() <= tolerance
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_needs_two_knots_and_a_ramp_with_a_step_keeps_the_step() {
        let flat = vec![[2.0, 3.0, 4.0]; 60];
        assert_eq!(fit(&flat, 1e-9).knots.len(), 2);
        let stepped: Vec<[f64; 3]> = (0..60)
            .map(|k| {
                let v = k as f64 * 0.1 + if k >= 30 { 5.0 } else { 0.0 };
                [v, v, v]
            })
            .collect();
        let curve = fit(&stepped, 1e-6);
        assert!(curve.knots.len() <= 4, "{:?}", curve.knots);
        for (k, v) in stepped.iter().enumerate() {
            assert!((curve.at(k)[1] - v[1]).abs() <= 1e-6, "frame {k}");
        }
    }

    #[test]
    fn every_frame_is_within_the_tolerance_of_a_curved_value() {
        let values: Vec<[f64; 3]> = (0..100)
            .map(|k| {
                let t = k as f64 / 99.0;
                [t.sin(), (3.0 * t).cos(), t * t]
            })
            .collect();
        for tol in [1e-2, 1e-3] {
            let curve = fit(&values, tol);
            assert!(curve.knots.len() < values.len());
            for (k, v) in values.iter().enumerate() {
                let got = curve.at(k);
                assert!(
                    (0..3).all(|c| (got[c] - v[c]).abs() <= tol),
                    "frame {k} at {tol}"
                );
            }
        }
    }
}
