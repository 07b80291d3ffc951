//! Guided meter aiming: a technician aims a handheld or tripod meter, prompted in the
//! terminal, with an aiming pattern on the display and live readings.

use std::io::{BufRead, Write};

use crate::{AimingAids, DeviceError, DisplayId, MeterPositioner};

/// Asks a technician to aim the meter at each display: shows the aiming pattern,
/// prints the spot and a reading, and waits for an answer on `input`:
/// Enter (aimed), `r` (read again), `s` (skip this display; `--resume` measures it
/// later), `q` (stop; `--resume` continues here). Another positioner (the simulator's,
/// so that a simulated meter reads the display being aimed at) is aimed first. The
/// display and spot answered last, and not aimed away from since (the warm-up check or
/// wait, then that display's measurement), is not asked for again: aimed stays aimed,
/// skipped stays skipped.
pub struct GuidedPositioner {
    inner: Box<dyn MeterPositioner + Send>,
    input: Box<dyn BufRead + Send>,
    output: Box<dyn Write + Send>,
    /// The display and spot the technician answered last, while nothing was aimed
    /// elsewhere since, and whether the answer was aimed (else skipped).
    answered: Option<(DisplayId, [f64; 2], bool)>,
}

impl std::fmt::Debug for GuidedPositioner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("GuidedPositioner")
    }
}

/// What the technician answered.
enum Answer {
    Aimed,
    ReadAgain,
    Skip,
    Stop,
}

impl GuidedPositioner {
    /// Prompts on `output`, reads answers from `input`, and aims `inner` first.
    pub fn new(
        inner: Box<dyn MeterPositioner + Send>,
        input: Box<dyn BufRead + Send>,
        output: Box<dyn Write + Send>,
    ) -> Self {
        GuidedPositioner {
            inner,
            input,
            output,
            answered: None,
        }
    }

    /// The technician's next answer; the end of the input counts as stop.
    fn answer(&mut self) -> Result<Answer, DeviceError> {
        let mut line = String::new();
        let n = self
            .input
            .read_line(&mut line)
            .map_err(|source| DeviceError::Io {
                device: "the technician's terminal".into(),
                source,
            })?;
        Ok(match (n, line.trim()) {
            (0, _) => Answer::Stop,
            (_, "") => Answer::Aimed,
            (_, "r" | "R") => Answer::ReadAgain,
            (_, "s" | "S") => Answer::Skip,
            (_, "q" | "Q") => Answer::Stop,
            _ => Answer::ReadAgain,
        })
    }

    /// Prints one live reading (or why there is none).
    fn print_reading(&mut self, aids: &mut AimingAids<'_>) -> std::io::Result<()> {
        match aids.meter.measure() {
            Ok(xyz) => match xyz.xy() {
                Some([x, y]) => writeln!(
                    self.output,
                    "  live: Y = {:.3} cd/m², x = {x:.4}, y = {y:.4}",
                    xyz.y
                ),
                None => writeln!(self.output, "  live: Y = {:.3} cd/m²", xyz.y),
            },
            Err(e) => writeln!(self.output, "  live: no reading ({e})"),
        }
    }
}

/// Where to look, said the way a technician stands in front of the wall.
fn prompt_for(label: &str, uv: [f64; 2]) -> String {
    let filter = if label.contains("left") {
        ", through the left-eye filter"
    } else if label.contains("right") {
        ", through the right-eye filter"
    } else {
        ""
    };
    format!(
        "aim the meter at {label}{filter}, on the cross at {:.0} % across and {:.0} % down \
         (white on the display); Enter = aimed, r = read again, s = skip, q = stop",
        uv[0] * 100.0,
        uv[1] * 100.0
    )
}

impl MeterPositioner for GuidedPositioner {
    fn aim(&mut self, display: DisplayId, uv: [f64; 2]) -> Result<(), DeviceError> {
        if self
            .answered
            .is_some_and(|(d, at, _)| (d, at) != (display, uv))
        {
            self.answered = None;
        }
        self.inner.aim(display, uv)
    }

    /// Every visit is the technician's walk to the display.
    fn revisits_cheaply(&self) -> bool {
        false
    }

    fn confirm(
        &mut self,
        display: DisplayId,
        label: &str,
        uv: [f64; 2],
        mut aids: AimingAids<'_>,
    ) -> Result<(), DeviceError> {
        let io = |source| DeviceError::Io {
            device: "the technician's terminal".into(),
            source,
        };
        match self.answered.take() {
            Some((d, at, aimed)) if (d, at) == (display, uv) => {
                self.answered = Some((d, at, aimed));
                return if aimed {
                    writeln!(self.output, "still aimed at {label}").map_err(io)?;
                    Ok(())
                } else {
                    writeln!(self.output, "{label}: skipped, as answered").map_err(io)?;
                    Err(DeviceError::AimSkipped(label.to_string()))
                };
            }
            _ => {}
        }
        aids.pattern.show_aim_marker(display, uv)?;
        writeln!(self.output, "{}", prompt_for(label, uv)).map_err(io)?;
        loop {
            self.print_reading(&mut aids).map_err(io)?;
            self.output.flush().map_err(io)?;
            match self.answer()? {
                Answer::Aimed => {
                    self.answered = Some((display, uv, true));
                    return Ok(());
                }
                Answer::ReadAgain => continue,
                Answer::Skip => {
                    self.answered = Some((display, uv, false));
                    return Err(DeviceError::AimSkipped(label.to_string()));
                }
                Answer::Stop => return Err(DeviceError::AimStopped(label.to_string())),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Colorimeter, DisplayInfo, MeterInfo, PatternOutput, Xyz};

    /// Counts what the positioner asked of the aids.
    #[derive(Default)]
    struct Probe {
        markers: u32,
    }

    impl PatternOutput for Probe {
        fn displays(&self) -> Vec<DisplayInfo> {
            Vec::new()
        }
        fn show(&mut self, _: DisplayId, _: [f64; 3]) -> Result<(), DeviceError> {
            Ok(())
        }
        fn show_aim_marker(&mut self, _: DisplayId, _: [f64; 2]) -> Result<(), DeviceError> {
            self.markers += 1;
            Ok(())
        }
    }

    struct Meter(u32);

    impl Colorimeter for Meter {
        fn info(&self) -> MeterInfo {
            MeterInfo {
                model: "probe".into(),
                serial: "1".into(),
                min_reliable_cd_m2: 1.0,
                max_cd_m2: 1e4,
                noise: None,
            }
        }
        fn measure(&mut self) -> Result<Xyz, DeviceError> {
            self.0 += 1;
            Ok(Xyz::new(95.0, 100.0, 108.0))
        }
    }

    struct Still;

    impl MeterPositioner for Still {
        fn aim(&mut self, _: DisplayId, _: [f64; 2]) -> Result<(), DeviceError> {
            Ok(())
        }
    }

    /// Runs one confirmation with `typed` as the technician's input.
    fn confirm(typed: &str) -> (Result<(), DeviceError>, String, u32, u32) {
        let out = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        struct Shared(std::sync::Arc<std::sync::Mutex<Vec<u8>>>);
        impl Write for Shared {
            fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
                self.0.lock().unwrap().extend_from_slice(b);
                Ok(b.len())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let mut g = GuidedPositioner::new(
            Box::new(Still),
            Box::new(std::io::Cursor::new(typed.as_bytes().to_vec())),
            Box::new(Shared(out.clone())),
        );
        let (mut probe, mut meter) = (Probe::default(), Meter(0));
        let aids = AimingAids {
            pattern: &mut probe,
            meter: &mut meter,
        };
        let r = g.confirm(DisplayId(3), "tile c1r0 left", [0.5, 0.5], aids);
        let text = String::from_utf8(out.lock().unwrap().clone()).unwrap();
        (r, text, probe.markers, meter.0)
    }

    #[test]
    fn enter_confirms_r_reads_again_s_skips_and_q_or_end_of_input_stops() {
        let (r, text, markers, readings) = confirm("r\n\n");
        assert!(r.is_ok());
        assert_eq!((markers, readings), (1, 2));
        assert!(
            text.contains("aim the meter at tile c1r0 left, through the left-eye filter"),
            "{text}"
        );
        assert_eq!(
            text.matches("live: Y = 100.000 cd/m², x = 0.3135, y = 0.3300")
                .count(),
            2,
            "{text}"
        );
        assert!(
            matches!(confirm("s\n").0, Err(DeviceError::AimSkipped(d)) if d == "tile c1r0 left")
        );
        assert!(matches!(confirm("q\n").0, Err(DeviceError::AimStopped(_))));
        assert!(matches!(confirm("").0, Err(DeviceError::AimStopped(_))));
    }

    /// A positioner answered by `typed`, prompting into nothing.
    fn answering(typed: &[u8]) -> GuidedPositioner {
        GuidedPositioner::new(
            Box::new(Still),
            Box::new(std::io::Cursor::new(typed.to_vec())),
            Box::new(std::io::sink()),
        )
    }

    /// One session's aiming at display `d`: aim, then confirm.
    fn visit(g: &mut GuidedPositioner, d: u32, probe: &mut Probe) -> Result<(), DeviceError> {
        g.aim(DisplayId(d), [0.5, 0.5])?;
        let aids = AimingAids {
            pattern: probe,
            meter: &mut Meter(0),
        };
        g.confirm(DisplayId(d), "tile", [0.5, 0.5], aids)
    }

    #[test]
    fn a_spot_confirmed_last_is_not_asked_for_again_until_the_meter_is_aimed_elsewhere() {
        // one answer per prompt: display 3, then display 4, then display 3 again
        let (mut g, mut probe) = (answering(b"\n\n\n"), Probe::default());
        // the warm check on display 3, then its measurement: one prompt
        assert!(visit(&mut g, 3, &mut probe).is_ok());
        assert!(visit(&mut g, 3, &mut probe).is_ok());
        // another display, then display 3 again (the drift re-read): asked each time
        assert!(visit(&mut g, 4, &mut probe).is_ok());
        assert!(visit(&mut g, 3, &mut probe).is_ok());
        assert_eq!(probe.markers, 3, "three prompts for four visits");
        // every answer was used: a fifth visit elsewhere finds the input ended
        assert!(matches!(
            visit(&mut g, 4, &mut probe),
            Err(DeviceError::AimStopped(_))
        ));
    }

    #[test]
    fn a_spot_skipped_last_stays_skipped_until_the_meter_is_aimed_elsewhere() {
        let (mut g, mut probe) = (answering(b"s\n\n"), Probe::default());
        assert!(matches!(
            visit(&mut g, 3, &mut probe),
            Err(DeviceError::AimSkipped(_))
        ));
        assert!(matches!(
            visit(&mut g, 3, &mut probe),
            Err(DeviceError::AimSkipped(_))
        ));
        assert!(visit(&mut g, 4, &mut probe).is_ok());
        assert_eq!(probe.markers, 2, "asked once per display");
    }
}
