//! The Klein K-10-A driver against its emulator, through a real pseudo-terminal:
//! round trip of readings, every injected fault, the retry and resync policy.
#![cfg(feature = "serial")]

use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use lumiwall_devices::serial::{
    EmulatedPort, Emulator, EmulatorOptions, FaultPlan, K10aConfig, KleinK10a, LineDrop,
    SlowAnswer, StatusFault,
};
use lumiwall_devices::{Colorimeter, DeviceError, MeterInfo, Xyz};

/// A fake meter that answers a fixed list of readings in turn (cycling) and counts
/// how often it was asked.
struct ListMeter {
    values: Vec<Xyz>,
    calls: Arc<AtomicU32>,
}

impl Colorimeter for ListMeter {
    fn info(&self) -> MeterInfo {
        MeterInfo {
            model: "list".into(),
            serial: "0".into(),
            min_reliable_cd_m2: 0.0,
            max_cd_m2: f64::INFINITY,
            noise: None,
        }
    }
    fn measure(&mut self) -> Result<Xyz, DeviceError> {
        let i = self.calls.fetch_add(1, Ordering::SeqCst) as usize;
        Ok(self.values[i % self.values.len()])
    }
}

/// Reading k (0-based) of the default fake: distinct, realistic values.
fn value(k: usize) -> Xyz {
    let y = 10.0 + 7.0 * k as f64;
    Xyz::from_xy_luminance(0.3127, 0.3290, y)
}

fn start(faults: FaultPlan) -> (Emulator, EmulatedPort, Arc<AtomicU32>) {
    start_with(faults, (0..50).map(value).collect())
}

/// Instrument time scale of the fault tests: 1 % of the real K-10-A timing.
const FAST_TIME_SCALE: f64 = 0.01;

fn start_with(faults: FaultPlan, values: Vec<Xyz>) -> (Emulator, EmulatedPort, Arc<AtomicU32>) {
    spawn_scaled(faults, values, FAST_TIME_SCALE)
}

/// An emulator of a [`ListMeter`] answering `values`, its instrument time scaled by
/// `time_scale`, and the meter's call counter.
fn spawn_scaled(
    faults: FaultPlan,
    values: Vec<Xyz>,
    time_scale: f64,
) -> (Emulator, EmulatedPort, Arc<AtomicU32>) {
    let calls = Arc::new(AtomicU32::new(0));
    let meter = ListMeter {
        values,
        calls: Arc::clone(&calls),
    };
    let (emu, port) = Emulator::spawn_with(
        Box::new(meter),
        faults,
        EmulatorOptions::with_time_scale(time_scale),
    )
    .unwrap();
    (emu, port, calls)
}

/// An emulator of the default fake with `faults`, and the driver opened on it.
fn open_meter(faults: FaultPlan, config: K10aConfig) -> (Emulator, KleinK10a) {
    let (emu, port, _calls) = start(faults);
    let meter = port.open(config).unwrap();
    (emu, meter)
}

fn config(timeout_ms: u64, retries: u32) -> K10aConfig {
    K10aConfig {
        read_timeout: Duration::from_millis(timeout_ms),
        resync_timeout: Duration::from_millis(600),
        retries,
        ..K10aConfig::default()
    }
}

/// Relative precision of the K-10 number format: a 15-bit mantissa normalised to
/// [2^14, 2^15) and rounded, so the error is at most half a unit in 2^14.
const KFLOAT_REL: f64 = 1.0 / 32768.0;

fn assert_close(got: Xyz, want: Xyz) {
    for (g, w) in got.to_array().iter().zip(want.to_array()) {
        assert!(
            (g - w).abs() <= w.abs() * KFLOAT_REL + 1e-300,
            "got {got:?}, want {want:?}"
        );
    }
}

#[test]
fn identifies_itself_and_round_trips_readings() {
    let values = vec![
        Xyz::new(95.047, 100.0, 108.883),
        Xyz::new(0.0123, 0.0131, 0.0207),
        Xyz::new(3100.5, 3999.0, 1.0e-3),
        Xyz::new(41.24, 21.26, 1.93),
        Xyz::new(-0.004, 0.0, 0.002),
    ];
    let (emu, port, calls) = start_with(FaultPlan::default(), values.clone());
    let mut meter = port.open(config(1000, 0)).unwrap();
    let info = meter.info();
    assert_eq!(info.model, "Klein K-10-A");
    assert_eq!(info.serial, "EMU000001");
    assert_eq!(
        meter.device_name(),
        format!("Klein K-10-A #EMU000001 on {}", port.path())
    );
    for want in &values {
        let got = meter.measure().unwrap();
        assert_close(got, *want);
    }
    assert_eq!(calls.load(Ordering::SeqCst) as usize, values.len());
    assert_eq!(emu.readings_requested() as usize, values.len());
    emu.stop();
}

#[test]
fn garbage_gives_garbled_then_next_reading_is_clean() {
    let (_emu, mut meter) = open_meter(
        FaultPlan {
            garbage_on: vec![1],
            ..FaultPlan::default()
        },
        config(500, 0),
    );
    match meter.measure() {
        Err(DeviceError::Garbled { command, .. }) => assert_eq!(command, "N5"),
        other => panic!("expected Garbled, got {other:?}"),
    }
    // The backing meter was not asked for reading 1, so reading 2 carries value 0.
    assert_close(meter.measure().unwrap(), value(0));
    assert_close(meter.measure().unwrap(), value(1));
}

#[test]
fn silent_meter_times_out_within_the_configured_time() {
    let (_emu, port, _calls) = start(FaultPlan {
        stop_after_readings: Some(1),
        ..FaultPlan::default()
    });
    let timeout = Duration::from_millis(300);
    let mut meter = port.open(config(300, 0)).unwrap();
    assert_close(meter.measure().unwrap(), value(0));
    let t0 = Instant::now();
    let err = meter.measure().unwrap_err();
    let elapsed = t0.elapsed();
    match err {
        DeviceError::Timeout { timeout_ms, .. } => assert_eq!(timeout_ms, 300),
        other => panic!("expected Timeout, got {other:?}"),
    }
    assert!(elapsed >= timeout, "gave up early after {elapsed:?}");
    assert!(
        elapsed < timeout + Duration::from_millis(400),
        "took {elapsed:?} for a {timeout:?} timeout"
    );
    // Still dead: the resync itself times out, again as a typed error.
    assert!(matches!(meter.measure(), Err(DeviceError::Timeout { .. })));
}

#[test]
fn over_range_is_reported() {
    // Reading 1 by injected status, reading 3 because the light exceeds the
    // K-10-A's 4000 cd/m² range.
    let values = vec![
        Xyz::new(50.0, 52.0, 60.0),
        Xyz::new(4200.0, 4500.0, 3900.0),
        Xyz::new(20.0, 21.0, 22.0),
    ];
    let (_emu, port, _calls) = start_with(
        FaultPlan {
            over_range_on: vec![1],
            ..FaultPlan::default()
        },
        values.clone(),
    );
    let mut meter = port.open(config(500, 2)).unwrap();
    assert!(matches!(
        meter.measure(),
        Err(DeviceError::OverRange { .. })
    ));
    assert_close(meter.measure().unwrap(), values[0]);
    assert!(matches!(
        meter.measure(),
        Err(DeviceError::OverRange { .. })
    ));
    assert_close(meter.measure().unwrap(), values[2]);
    // Over-range is not transient: no retries were spent on it.
    assert_eq!(meter.stats().retries, 0);
}

#[test]
fn retry_recovers_from_one_transient_fault() {
    let (emu, mut meter) = open_meter(
        FaultPlan {
            garbage_on: vec![1],
            stop_after_readings: None,
            slow_on: vec![SlowAnswer {
                reading: 3,
                delay_ms: 400,
            }],
            ..FaultPlan::default()
        },
        config(150, 1),
    );
    assert_close(meter.measure().unwrap(), value(0));
    assert_eq!(meter.stats().retries, 1);
    assert_eq!(emu.readings_requested(), 2);
    // Reading 3 answers after 400 ms (value 1) — too late; the retry must not take
    // that stale answer for its own but wait for the fresh one (value 2).
    assert_close(meter.measure().unwrap(), value(2));
    assert_eq!(meter.stats().retries, 2);
}

#[test]
fn no_retry_when_retries_is_zero() {
    let (emu, mut meter) = open_meter(
        FaultPlan {
            garbage_on: vec![1],
            ..FaultPlan::default()
        },
        config(500, 0),
    );
    assert!(matches!(meter.measure(), Err(DeviceError::Garbled { .. })));
    assert_eq!(emu.readings_requested(), 1);
    assert_eq!(meter.stats().retries, 0);
}

#[test]
fn slow_answer_times_out_and_the_stale_answer_is_not_used() {
    let (_emu, mut meter) = open_meter(
        FaultPlan {
            slow_on: vec![SlowAnswer {
                reading: 1,
                delay_ms: 400,
            }],
            ..FaultPlan::default()
        },
        config(150, 0),
    );
    assert!(matches!(meter.measure(), Err(DeviceError::Timeout { .. })));
    // The late answer to reading 1 carries value 0; the next reading must be value 1.
    assert_close(meter.measure().unwrap(), value(1));
}

#[test]
fn uniformly_slow_meter_works_with_a_long_enough_timeout() {
    let (_emu, mut meter) = open_meter(
        FaultPlan {
            answer_delay_ms: 120,
            ..FaultPlan::default()
        },
        config(600, 0),
    );
    let t0 = Instant::now();
    assert_close(meter.measure().unwrap(), value(0));
    assert!(t0.elapsed() >= Duration::from_millis(120));
}

#[test]
fn dropped_line_comes_back_and_retries_resume() {
    let (_emu, mut meter) = open_meter(
        FaultPlan {
            line_drops: vec![LineDrop {
                at_reading: 2,
                duration_ms: 250,
            }],
            ..FaultPlan::default()
        },
        config(150, 3),
    );
    assert_close(meter.measure().unwrap(), value(0));
    assert_close(meter.measure().unwrap(), value(1));
    assert!(meter.stats().retries >= 1);
    assert_close(meter.measure().unwrap(), value(2));
}

#[test]
fn instrument_status_codes_are_mapped() {
    let codes = [
        ('b', "black calibration"),
        ('X', "firmware"),
        ('L', "aiming lights"),
        ('q', "not documented"),
    ];
    let status_on = codes
        .iter()
        .enumerate()
        .map(|(i, &(code, _))| StatusFault {
            reading: i as u32 + 1,
            code,
        })
        .collect();
    let (_emu, mut meter) = open_meter(
        FaultPlan {
            status_on,
            ..FaultPlan::default()
        },
        config(500, 2),
    );
    for (code, meaning) in codes {
        match meter.measure() {
            Err(DeviceError::Instrument {
                code: got,
                meaning: m,
                ..
            }) => {
                assert_eq!(got, code.to_string());
                assert!(m.contains(meaning), "{code}: {m}");
            }
            other => panic!("status {code}: expected Instrument, got {other:?}"),
        }
    }
    // Instrument errors are not transient: nothing was retried.
    assert_eq!(meter.stats().retries, 0);
    assert_close(meter.measure().unwrap(), value(0));
}

#[test]
fn auto_ranging_status_is_repeated_then_reported() {
    let (_emu, mut meter) = open_meter(
        FaultPlan {
            status_on: vec![
                StatusFault {
                    reading: 1,
                    code: 'v',
                },
                StatusFault {
                    reading: 2,
                    code: 'u',
                },
                StatusFault {
                    reading: 4,
                    code: 'v',
                },
            ],
            ..FaultPlan::default()
        },
        config(500, 0),
    );
    // Readings 1 and 2 are range changes, reading 3 succeeds.
    assert_close(meter.measure().unwrap(), value(0));
    assert_eq!(meter.stats().range_repeats, 2);
    let mut strict = meter.config().clone();
    strict.range_change_retries = 0;
    meter.set_config(strict);
    match meter.measure() {
        Err(DeviceError::Instrument { code, meaning, .. }) => {
            assert_eq!(code, "v");
            assert!(meaning.contains("range"));
        }
        other => panic!("expected Instrument v, got {other:?}"),
    }
}

#[test]
fn too_dark_limit_is_enforced_when_configured() {
    let values = vec![Xyz::new(0.09, 0.1, 0.11), Xyz::new(9.0, 10.0, 11.0)];
    let (_emu, port, _calls) = start_with(FaultPlan::default(), values);
    let mut cfg = config(500, 0);
    cfg.too_dark_below_cd_m2 = Some(0.2);
    let mut meter = port.open(cfg).unwrap();
    match meter.measure() {
        Err(DeviceError::TooDark {
            y_cd_m2,
            limit_cd_m2,
            ..
        }) => {
            assert!((y_cd_m2 - 0.1).abs() < 1e-5);
            assert_eq!(limit_cd_m2, 0.2);
        }
        other => panic!("expected TooDark, got {other:?}"),
    }
    assert!(meter.measure().is_ok());
}

#[test]
fn wrong_model_is_refused() {
    let meter = ListMeter {
        values: vec![value(0)],
        calls: Arc::new(AtomicU32::new(0)),
    };
    let options = EmulatorOptions {
        model: "CS-200".into(),
        ..EmulatorOptions::with_time_scale(0.01)
    };
    let (_emu, port) =
        Emulator::spawn_with(Box::new(meter), FaultPlan::default(), options).unwrap();
    match KleinK10a::open(port.path(), config(300, 0)) {
        Err(DeviceError::Config(msg)) => assert!(msg.contains("CS-200"), "{msg}"),
        other => panic!("expected Config error, got {other:?}"),
    }
}

#[test]
fn missing_port_is_an_io_error() {
    match KleinK10a::open("/dev/lumiwall-no-such-port", config(100, 0)) {
        Err(DeviceError::Io { device, .. }) => {
            assert!(device.contains("/dev/lumiwall-no-such-port"))
        }
        other => panic!("expected Io error, got {other:?}"),
    }
}

#[test]
fn fault_plan_round_trips_through_json_and_defaults_missing_fields() {
    let plan = FaultPlan {
        stop_after_readings: Some(7),
        garbage_on: vec![2],
        over_range_on: vec![3],
        status_on: vec![StatusFault {
            reading: 4,
            code: 'b',
        }],
        answer_delay_ms: 5,
        slow_on: vec![SlowAnswer {
            reading: 5,
            delay_ms: 100,
        }],
        line_drops: vec![LineDrop {
            at_reading: 6,
            duration_ms: 200,
        }],
    };
    let json = serde_json::to_string(&plan).unwrap();
    let back: FaultPlan = serde_json::from_str(&json).unwrap();
    assert_eq!(back, plan);
    let partial: FaultPlan = serde_json::from_str(r#"{"garbage_on":[3]}"#).unwrap();
    assert_eq!(partial.garbage_on, vec![3]);
    assert_eq!(partial.stop_after_readings, None);
}

#[test]
fn port_can_be_reopened_after_the_driver_is_dropped() {
    let (_emu, port, _calls) = start(FaultPlan::default());
    let mut first = port.open(config(500, 0)).unwrap();
    assert_close(first.measure().unwrap(), value(0));
    drop(first);
    let mut second = port.open(config(500, 0)).unwrap();
    assert_close(second.measure().unwrap(), value(1));
}

#[test]
fn emulator_takes_the_instruments_measurement_time() {
    // N5: 1/8 s per reading plus 15 bytes at 9600 baud 8N1 (15.625 ms) = 140.625 ms,
    // here at half speed.
    let (_emu, port, _calls) = spawn_scaled(FaultPlan::default(), vec![value(0)], 0.5);
    let mut meter = port.open(config(1000, 0)).unwrap();
    let t0 = Instant::now();
    for _ in 0..4 {
        meter.measure().unwrap();
    }
    let per_reading = t0.elapsed() / 4;
    assert!(
        per_reading >= Duration::from_micros(70_312),
        "{per_reading:?} per reading"
    );
    assert!(per_reading < Duration::from_millis(300), "{per_reading:?}");
}

#[test]
fn emulator_without_instrument_time_answers_200_readings_within_4_s() {
    let (_emu, port, _calls) =
        spawn_scaled(FaultPlan::default(), (0..10).map(value).collect(), 0.0);
    let mut meter = port.open(config(1000, 0)).unwrap();
    let n = 200;
    let t0 = Instant::now();
    for k in 0..n {
        assert_close(meter.measure().unwrap(), value(k % 10));
    }
    let elapsed = t0.elapsed();
    eprintln!("{n} readings through the pty in {elapsed:?}");
    assert!(elapsed < Duration::from_secs(4), "{elapsed:?}");
}

#[test]
fn a_read_timeout_of_u64_max_ms_does_not_overflow_the_deadline() {
    // `Instant::now() + read_timeout` panicked for a timeout read from a config file
    // as u64::MAX ms; the deadline is now capped.
    let huge = K10aConfig {
        read_timeout: Duration::from_millis(u64::MAX),
        resync_timeout: Duration::from_millis(u64::MAX),
        ..config(2000, 0)
    };
    let (_emu, mut meter) = open_meter(FaultPlan::default(), huge);
    assert_close(meter.measure().unwrap(), value(0));
}

use std::io::{Read as _, Write as _};

/// Raw bytes on the emulator's pty, as a third-party program sends them.
struct RawLine(Box<dyn serialport::SerialPort>);

impl RawLine {
    fn open(port: &EmulatedPort) -> Self {
        let p = serialport::new(port.path(), 9600)
            .timeout(Duration::from_millis(20))
            .open()
            .unwrap();
        Self(p)
    }

    fn send(&mut self, bytes: &[u8]) {
        self.0.write_all(bytes).unwrap();
    }

    /// Everything that arrives within `window`.
    fn collect(&mut self, window: Duration) -> Vec<u8> {
        let end = Instant::now() + window;
        let mut out = Vec::new();
        let mut buf = [0u8; 4096];
        while Instant::now() < end {
            if let Ok(n) = self.0.read(&mut buf) {
                out.extend_from_slice(&buf[..n]);
            }
        }
        out
    }
}

#[test]
fn the_emulator_speaks_argylls_k10_dialect_probe_start_up_and_flicker_stream() {
    let (emu, port, _) = spawn_scaled(FaultPlan::default(), vec![value(3)], 1.0);
    let mut line = RawLine::open(&port);
    // a lone `;` gets no answer (an echo would mean a Lumagen to Argyll)
    line.send(b";");
    assert!(line.collect(Duration::from_millis(150)).is_empty());
    // the identification probe: D4 and the calibration list, 1925 bytes
    line.send(b"D024\r\n");
    let d4 = line.collect(Duration::from_millis(400));
    assert_eq!(d4.len(), 1925);
    assert!(d4.starts_with(b"D4") && d4.ends_with(b"<0>"));
    // other instruments' probes are ignored
    line.send(b"*idn?\r");
    line.send(&[0x7e, 0x00, 0x02, 0x00]);
    assert!(line.collect(Duration::from_millis(100)).is_empty());
    // start-up: P0 (after the junk), D7, L0, J8, P2, N5, J7, J3
    for (cmd, len) in [
        ("P0", 21),
        ("D7", 1925),
        ("L0", 5),
        ("J8", 5),
        ("P2", 13),
        ("N5", 15),
        ("J7", 5),
        ("J3", 5),
    ] {
        line.send(format!("{cmd}\r").as_bytes());
        let a = line.collect(Duration::from_millis(if cmd == "D7" { 2500 } else { 300 }));
        assert_eq!(a.len(), len, "{cmd}: {}", a.escape_ascii());
        assert!(
            a.starts_with(cmd.as_bytes()) && a.ends_with(b"<0>"),
            "{cmd}"
        );
    }
    // T2: 96-byte packets, 8 a second, until the next command; N5 stops it and is answered
    line.send(b"T2\r");
    let stream = line.collect(Duration::from_millis(520));
    assert!(
        (4 * 96..=5 * 96).contains(&stream.len()),
        "{} bytes",
        stream.len()
    );
    assert_eq!(stream.len() % 96, 0);
    let first: [u8; 96] = stream[..96].try_into().unwrap();
    let (samples, status) = lumiwall_devices::serial::k10_protocol::parse_flicker_packet(&first);
    assert_eq!(
        status,
        lumiwall_devices::serial::k10_protocol::StatusCode::Ok
    );
    assert!(samples.iter().all(|&s| s == samples[0] && s > 0));
    line.send(b"N5\r");
    let tail = line.collect(Duration::from_millis(300));
    assert!(
        tail.ends_with(b"<0>") && tail.len() % 96 == 15,
        "{} bytes",
        tail.len()
    );
    assert!(
        line.collect(Duration::from_millis(300)).is_empty(),
        "the stream stopped"
    );
    emu.stop();
}

#[test]
fn an_over_range_answer_reports_the_least_sensitive_range() {
    use lumiwall_devices::serial::k10_protocol::{self as proto, StatusCode};
    let faults = FaultPlan {
        over_range_on: vec![1],
        ..FaultPlan::default()
    };
    let (emu, port, _) = spawn_scaled(faults, vec![value(0)], FAST_TIME_SCALE);
    let mut line = RawLine::open(&port);
    line.send(b"N5\r");
    let a = line.collect(Duration::from_millis(300));
    let m = proto::parse_measurement(proto::MeasureSpeed::Normal, &a).unwrap();
    assert_eq!((m.status, m.ranges), (StatusCode::OverHighRange, [1, 1, 1]));
    emu.stop();
}
