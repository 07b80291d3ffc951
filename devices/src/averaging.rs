//! A meter whose every reading is the mean of several: what an instrument's driver
//! does in the dark (ArgyllCMS's K-10 driver averages up to 20 readings below
//! 0.2 cd/m²), here for every reading of a run, so that a dim wall's calibration sees
//! a meter `√n` times quieter at `n` times the reading time.
//!
//! The stated noise ([`MeterInfo::noise`]) is the mean's: every term divided by `√n`
//! (the high-light repeatability and the sensors' zero-light noise are independent
//! from reading to reading). The reliable limit stays the instrument's.

use crate::{CensoredReadings, Colorimeter, DeviceError, MeterInfo, ReadingNoise, Xyz};

/// Most readings one averaged reading may take.
pub const MAX_AVERAGED: u32 = 64;

impl ReadingNoise {
    /// The noise of the mean of `n` independent readings (`n` ≥ 1): every term over `√n`.
    pub fn averaged(&self, n: u32) -> ReadingNoise {
        let s = 1.0 / f64::from(n.max(1)).sqrt();
        ReadingNoise {
            luminance_rel: self.luminance_rel * s,
            xy: self.xy * s,
            dark_xyz_cd_m2: self.dark_xyz_cd_m2.map(|v| v * s),
        }
    }

    /// 1σ of the chromaticity x and y of one reading of `xyz`, from the sensors' noise
    /// ([`ReadingNoise::sigma_xyz`]) carried through `x = X/(X+Y+Z)`, `y = Y/(X+Y+Z)`;
    /// `None` for light without a chromaticity (X + Y + Z not above 0).
    pub fn sigma_xy(&self, xyz: Xyz) -> Option<[f64; 2]> {
        let [x, y, z] = xyz.to_array();
        let sum = x + y + z;
        if sum.is_nan() || sum <= 0.0 {
            return None;
        }
        let [sx, sy, sz] = self.sigma_xyz(xyz);
        let sum_sq = sum * sum;
        let dx = ((y + z) * sx).hypot(x * sy).hypot(x * sz) / sum_sq;
        let dy = (y * sx).hypot((x + z) * sy).hypot(y * sz) / sum_sq;
        Some([dx, dy])
    }
}

/// A meter read `n` times for each reading, the readings averaged in XYZ.
pub struct AveragingMeter<'m> {
    inner: &'m mut dyn Colorimeter,
    n: u32,
    /// The instrument's stated noise of one reading, for the mean of readings some of
    /// which it refused.
    noise: Option<ReadingNoise>,
    /// The instrument's readings behind the last reading.
    last: CensoredReadings,
}

impl<'m> AveragingMeter<'m> {
    /// `inner` averaged over `n` readings (clamped to 1..=[`MAX_AVERAGED`]).
    pub fn new(inner: &'m mut dyn Colorimeter, n: u32) -> Self {
        let noise = inner.info().noise;
        Self {
            inner,
            n: n.clamp(1, MAX_AVERAGED),
            noise,
            last: CensoredReadings::default(),
        }
    }

    /// Readings of the instrument in each reading.
    pub fn readings_per_reading(&self) -> u32 {
        self.n
    }
}

impl Colorimeter for AveragingMeter<'_> {
    fn info(&self) -> MeterInfo {
        let mut info = self.inner.info();
        if self.n > 1 {
            info.model = format!("{} (each reading the mean of {})", info.model, self.n);
            info.noise = info.noise.map(|noise| noise.averaged(self.n));
        }
        info
    }

    /// The mean of the readings the instrument gives. Where it refused some as too dark,
    /// their luminance is estimated with the refused ones and the instrument's stated
    /// noise ([`CensoredReadings::mean`]): near its floor the readings it gives are the
    /// brighter ones, and their plain mean is biased high. Only when all are refused is
    /// the reading refused. Any other error ends the reading, so a retry of a transient
    /// error reads all `n` again.
    fn measure(&mut self) -> Result<Xyz, DeviceError> {
        self.last = CensoredReadings::default();
        let mut refused = None;
        for _ in 0..self.n {
            match self.inner.measure() {
                Ok(xyz) => self.last.add(xyz),
                Err(e @ DeviceError::TooDark { limit_cd_m2, .. }) => {
                    self.last.add_refused(limit_cd_m2);
                    refused = Some(e);
                }
                Err(e) => {
                    self.last = CensoredReadings::default();
                    return Err(e);
                }
            }
        }
        match (self.last.mean(self.noise.as_ref()), refused) {
            (Some(mean), _) => Ok(mean),
            (None, Some(e)) => Err(e),
            (None, None) => Err(DeviceError::Config(
                "an averaged reading took no readings".into(),
            )),
        }
    }

    /// The instrument's readings behind the last reading (every one of the `n`), where
    /// it averages more than one.
    fn readings_behind_last(&self) -> Option<CensoredReadings> {
        (self.n > 1 && !self.last.is_empty()).then_some(self.last)
    }

    /// The instrument's own stated noise of one reading.
    fn instrument_noise(&self) -> Option<ReadingNoise> {
        self.noise
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gives the values in turn, `None` as a too-dark refusal.
    struct Scripted(Vec<Option<f64>>, usize);

    impl Colorimeter for Scripted {
        fn info(&self) -> MeterInfo {
            MeterInfo {
                model: "scripted".into(),
                serial: "0".into(),
                min_reliable_cd_m2: 1.0,
                max_cd_m2: 1000.0,
                noise: Some(ReadingNoise::CS100A_CLASS),
            }
        }

        fn measure(&mut self) -> Result<Xyz, DeviceError> {
            let v = self.0[self.1 % self.0.len()];
            self.1 += 1;
            v.map(|y| Xyz::new(y, y, y)).ok_or(DeviceError::TooDark {
                device: "scripted".into(),
                y_cd_m2: 0.0,
                limit_cd_m2: 0.01,
            })
        }
    }

    #[test]
    fn a_reading_is_the_mean_of_n_and_states_the_noise_of_that_mean() {
        let mut inner = Scripted(vec![Some(1.0), Some(2.0), Some(3.0), Some(6.0)], 0);
        let mut m = AveragingMeter::new(&mut inner, 4);
        assert_eq!(m.measure().unwrap(), Xyz::new(3.0, 3.0, 3.0));
        let noise = m.info().noise.unwrap();
        let one = ReadingNoise::CS100A_CLASS;
        assert!((noise.xy - one.xy / 2.0).abs() < 1e-15);
        assert!((noise.dark_xyz_cd_m2[1] - one.dark_xyz_cd_m2[1] / 2.0).abs() < 1e-15);
        assert!(m.info().model.contains("mean of 4"));
        assert_eq!(inner.1, 4);
    }

    #[test]
    fn readings_refused_as_too_dark_lower_the_luminance_of_the_mean_and_all_refused_is_a_refusal() {
        let mut inner = Scripted(vec![Some(0.02), None, Some(0.04), None], 0);
        let mut m = AveragingMeter::new(&mut inner, 4);
        let mean = m.measure().unwrap();
        // X and Z: the mean of the readings given; Y: the censored estimate with the
        // two refused below the 0.01 cd/m² floor (σ_Y 0.004 there).
        assert!((mean.x - 0.03).abs() < 1e-12 && (mean.z - 0.03).abs() < 1e-12);
        let sigma_y = ReadingNoise::CS100A_CLASS.sigma_xyz(Xyz::new(0.0, 0.01, 0.0))[1];
        let expected = crate::censored::censored_mean_y(0.06, 2, 2, 0.01, sigma_y);
        assert!(expected < 0.025, "{expected}");
        assert!((mean.y - expected).abs() < 1e-12, "{mean:?}");
        let mut dark = Scripted(vec![None], 0);
        let mut m = AveragingMeter::new(&mut dark, 3);
        assert!(matches!(m.measure(), Err(DeviceError::TooDark { .. })));
    }

    #[test]
    fn an_averaged_reading_hands_over_the_readings_behind_it_and_the_noise_of_one() {
        let mut inner = Scripted(vec![Some(0.02), None, Some(0.04), None], 0);
        let mut m = AveragingMeter::new(&mut inner, 4);
        assert_eq!(m.readings_behind_last(), None, "nothing read yet");
        m.measure().unwrap();
        let behind = m.readings_behind_last().expect("four readings behind it");
        assert_eq!((behind.given(), behind.refused()), (2, 2));
        assert_eq!(m.instrument_noise(), Some(ReadingNoise::CS100A_CLASS));
        let mut once = Scripted(vec![Some(0.02)], 0);
        let mut m = AveragingMeter::new(&mut once, 1);
        m.measure().unwrap();
        assert_eq!(
            m.readings_behind_last(),
            None,
            "one reading is the instrument's own"
        );
        // Every reading refused: the refusals are handed over all the same.
        let mut dark = Scripted(vec![None], 0);
        let mut m = AveragingMeter::new(&mut dark, 3);
        assert!(m.measure().is_err());
        let behind = m.readings_behind_last().expect("three refusals behind it");
        assert_eq!((behind.given(), behind.refused()), (0, 3));
    }

    /// Gives one reading, then times out.
    struct Failing(u32);

    impl Colorimeter for Failing {
        fn info(&self) -> MeterInfo {
            Scripted(vec![], 0).info()
        }

        fn measure(&mut self) -> Result<Xyz, DeviceError> {
            self.0 += 1;
            if self.0 == 1 {
                Ok(Xyz::new(1.0, 1.0, 1.0))
            } else {
                Err(DeviceError::Timeout {
                    device: "failing".into(),
                    timeout_ms: 10,
                })
            }
        }
    }

    #[test]
    fn a_reading_ended_by_an_error_hands_over_nothing() {
        let mut inner = Failing(0);
        let mut m = AveragingMeter::new(&mut inner, 4);
        assert!(matches!(m.measure(), Err(DeviceError::Timeout { .. })));
        assert_eq!(m.readings_behind_last(), None);
    }

    #[test]
    fn one_reading_each_is_the_instrument_unchanged() {
        let mut inner = Scripted(vec![Some(5.0)], 0);
        let info = inner.info();
        let m = AveragingMeter::new(&mut inner, 1);
        assert_eq!(m.info(), info);
        assert_eq!(m.readings_per_reading(), 1);
    }

    #[test]
    fn xy_noise_of_a_dim_grey_follows_the_sensors_zero_light_noise() {
        let noise = ReadingNoise::CS100A_CLASS;
        let bright = noise
            .sigma_xy(Xyz::from_xy_luminance(0.29, 0.30, 100.0))
            .unwrap();
        let dim = noise
            .sigma_xy(Xyz::from_xy_luminance(0.29, 0.30, 0.25))
            .unwrap();
        // At 100 cd/m² the repeatability (about 0.0005 on illuminant A); at 0.25 cd/m²
        // the 0.008 cd/m² of X and Z noise over X + Y + Z ≈ 0.83 cd/m².
        assert!(bright[0] < 0.0008 && bright[1] < 0.0008, "{bright:?}");
        assert!(dim[0] > 0.006 && dim[0] < 0.009, "{dim:?}");
        let averaged = noise
            .averaged(4)
            .sigma_xy(Xyz::from_xy_luminance(0.29, 0.30, 0.25));
        assert!((averaged.unwrap()[0] - dim[0] / 2.0).abs() < 1e-12);
        assert!(noise.sigma_xy(Xyz::new(0.0, 0.0, 0.0)).is_none());
    }
}
