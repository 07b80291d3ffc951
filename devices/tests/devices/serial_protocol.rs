//! The K-10 wire format against independent references (a captured answer quoted in
//! Klein's SDK, hand-computed values of the documented number format), and fuzzing:
//! no byte sequence from the "instrument" may panic the parser or the driver.

#![cfg(feature = "serial")]

use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use lumiwall_devices::serial::k10_protocol::{
    self as proto, Command, MeasureSpeed, StatusCode, decode_kfloat, decode_ranges, encode_kfloat,
    parse_measurement,
};
use lumiwall_devices::serial::{K10aConfig, KleinK10a};
use lumiwall_devices::{Colorimeter, DeviceError, Xyz};
use proptest::prelude::*;
use serialport::{SerialPort, TTYPort};

/// The `N5` answer quoted (as decimal character codes) in a comment of Klein
/// Instruments' SDK, `KClmtr.cpp`, `parseAndPrintXYZ`.
const KLEIN_SDK_N5: [u8; 15] = [78, 53, 93, 90, 7, 102, 173, 7, 77, 42, 7, 128, 60, 48, 62];

#[test]
fn decodes_the_answer_quoted_in_kleins_sdk() {
    let a = parse_measurement(MeasureSpeed::Normal, &KLEIN_SDK_N5).unwrap();
    // By hand from the format (sign bit, 15-bit mantissa m, exponent e; m·2^(e−16)):
    // X: m = 93·256 + 90 = 23898, e = 7 → 23898 / 512 = 46.67578125
    // Y: m = 102·256 + 173 = 26285 → 51.337890625
    // Z: m = 77·256 + 42 = 19754 → 38.58203125
    assert_eq!(a.xyz, Xyz::new(46.67578125, 51.337890625, 38.58203125));
    assert_eq!(a.status, StatusCode::Ok);
    // Range byte 0x80: bit 7 set (X low bit), base-3 digits 0 → X range 2, Y 1, Z 1.
    assert_eq!(a.ranges, [2, 1, 1]);
    // A plausible white: x ≈ 0.342, y ≈ 0.376.
    let [x, y] = a.xyz.xy().unwrap();
    assert!(
        (x - 0.34174).abs() < 1e-4 && (y - 0.37588).abs() < 1e-4,
        "{x} {y}"
    );
}

#[test]
fn number_format_edge_cases() {
    // Sign bit.
    assert_eq!(decode_kfloat([0x80 | 93, 90, 7]), -46.67578125);
    // Exponent is two's complement: 0xff = −1 → 16384 · 2^-17 = 0.125.
    assert_eq!(decode_kfloat([0x40, 0x00, 0xff]), 0.125);
    // Largest and smallest representable magnitudes stay finite.
    assert!(decode_kfloat([0x7f, 0xff, 0x7f]).is_finite());
    assert!(decode_kfloat([0x00, 0x01, 0x80]) > 0.0);
    // Saturation and NaN in the encoder.
    assert_eq!(encode_kfloat(f64::INFINITY), [0x7f, 0xff, 0x7f]);
    assert_eq!(encode_kfloat(f64::NAN), [0, 0, 0]);
    assert_eq!(
        decode_kfloat(encode_kfloat(1e300)),
        decode_kfloat([0x7f, 0xff, 0x7f])
    );
    // Exact powers of two survive exactly.
    for k in -20..20 {
        let v = 2f64.powi(k);
        assert_eq!(decode_kfloat(encode_kfloat(v)), v, "2^{k}");
    }
}

#[test]
fn status_codes_and_frames() {
    let mut a = KLEIN_SDK_N5;
    a[13] = b'w';
    assert_eq!(
        parse_measurement(MeasureSpeed::Normal, &a).unwrap().status,
        StatusCode::OverHighRange
    );
    // any byte in the frame is a status, as ArgyllCMS reads the real instrument: an
    // undocumented (even non-text) one is an instrument error, not a garbled line
    a[13] = 0x07;
    assert_eq!(
        parse_measurement(MeasureSpeed::Normal, &a).unwrap().status,
        StatusCode::Unknown(0x07)
    );
    a[12] = b'['; // the frame itself broken: garbled
    assert!(parse_measurement(MeasureSpeed::Normal, &a).is_err());
    let mut b = KLEIN_SDK_N5;
    b[1] = b'4'; // echo of N4, not N5
    assert!(parse_measurement(MeasureSpeed::Normal, &b).is_err());
    assert!(parse_measurement(MeasureSpeed::Fast, &b).is_ok());
    assert!(parse_measurement(MeasureSpeed::Normal, &KLEIN_SDK_N5[..14]).is_err());
    let info = proto::parse_device_info(b"P0K-10-A 123456789<0>").unwrap();
    assert_eq!(
        (info.model.as_str(), info.serial.as_str()),
        ("K-10-A", "123456789")
    );
    assert_eq!(
        proto::parse_ack(Command::AutoRange, b"J8<0>"),
        Ok(StatusCode::Ok)
    );
}

#[test]
fn start_up_answers_have_the_lengths_and_layouts_argyll_reads() {
    // P2: echo + 8-character version + <c> = 13 bytes
    let p2 = proto::encode_firmware("LWEMU-01");
    assert_eq!(p2.len(), 13);
    assert_eq!(&p2, b"P2LWEMU-01<0>");
    assert_eq!(
        proto::parse_firmware(&p2),
        Ok(("LWEMU-01".to_string(), StatusCode::Ok))
    );
    // D7: echo + 96 slots × 20 bytes + <c> = 1925; 0xFF marks an empty slot
    let d7 = proto::encode_calibration_list(*b"D7", &["Klein DLP Lux", "lumiwall"]);
    assert_eq!(d7.len(), 1925);
    assert_eq!(d7[2 + 40], 0xff);
    assert_eq!(
        proto::parse_calibration_list(&d7).unwrap(),
        vec![
            (1, "Klein DLP Lux".to_string()),
            (2, "lumiwall".to_string())
        ]
    );
    // the answer to the identification probe starts with D4 and three non-NUL bytes
    let d4 = proto::encode_calibration_list(*b"D4", &[]);
    assert!(d4.starts_with(b"D4") && d4[..3].iter().all(|&b| b != 0));
    // J1..J7 and T2 parse from their codes and back
    for n in 1..=7u8 {
        let c = Command::from_code([b'J', b'0' + n]).unwrap();
        assert_eq!(c, Command::FixRange(n));
        assert_eq!(c.code(), [b'J', b'0' + n]);
        assert_eq!(c.answer_len(), 5);
    }
    // T2 packet: 32 triplets, side channel T2 + XYZ + range + <0> + '_', status at 39
    let xyz = lumiwall_devices::Xyz::new(46.67578125, 51.337890625, 38.58203125);
    let pkt = proto::encode_flicker_packet(&[0x1234; 32], xyz, [2, 3, 4]);
    assert_eq!(
        (pkt[0], pkt[3], pkt[36], pkt[39], pkt[42], pkt[45]),
        (b'T', b'2', b'<', b'0', b'>', b'_')
    );
    assert_eq!((pkt[1], pkt[2]), (0x12, 0x34));
    assert_eq!(pkt[33], proto::encode_ranges([2, 3, 4]).unwrap());
    let (samples, status) = proto::parse_flicker_packet(&pkt);
    assert_eq!((samples[31], status), (0x1234, StatusCode::Ok));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Any bytes at all: the parsers return a result, never panic, and whatever they
    /// accept has the frame of the protocol.
    #[test]
    fn parsers_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
        if let Ok(a) = parse_measurement(MeasureSpeed::Normal, &bytes) {
            prop_assert_eq!(bytes.len(), 15);
            prop_assert_eq!(&bytes[..2], b"N5");
            prop_assert!(a.xyz.is_finite());
            prop_assert!(a.ranges.iter().all(|r| (1..=6).contains(r)));
        }
        let _ = proto::parse_device_info(&bytes);
        let _ = proto::parse_ack(Command::LightsOff, &bytes);
    }

    /// Well-framed answers with arbitrary payload bytes always parse to finite values.
    #[test]
    fn framed_payloads_parse(payload in proptest::array::uniform10(any::<u8>())) {
        let mut a = [0u8; 15];
        a[..2].copy_from_slice(b"N5");
        a[2..12].copy_from_slice(&payload);
        a[12..].copy_from_slice(b"<0>");
        let parsed = parse_measurement(MeasureSpeed::Normal, &a).unwrap();
        prop_assert!(parsed.xyz.is_finite());
    }

    /// Encoding then decoding keeps 15 significant bits: relative error ≤ 2^-15.
    #[test]
    fn kfloat_round_trip(mag in -12.0f64..12.0, negative in any::<bool>()) {
        let v = if negative { -(10f64.powf(mag)) } else { 10f64.powf(mag) };
        let back = decode_kfloat(encode_kfloat(v));
        prop_assert!((back - v).abs() <= v.abs() / 32768.0, "{} -> {}", v, back);
    }

    #[test]
    fn ranges_decode_in_1_to_6(b in any::<u8>()) {
        prop_assert!(decode_ranges(b).iter().all(|r| (1..=6).contains(r)));
    }
}

/// A hand-driven instrument on a pty: answers J8, P0 and L0 properly and then
/// sends `reply` to every measurement command.
fn scripted_instrument(
    reply: Vec<u8>,
    stop: Arc<AtomicBool>,
) -> (TTYPort, String, std::thread::JoinHandle<()>) {
    let (mut master, slave) = TTYPort::pair().unwrap();
    let path = slave.name().unwrap();
    master.set_timeout(Duration::from_millis(5)).unwrap();
    let handle = std::thread::spawn(move || {
        let mut line = Vec::new();
        let mut buf = [0u8; 64];
        let start = std::time::Instant::now();
        while !stop.load(Ordering::SeqCst) && start.elapsed() < Duration::from_secs(5) {
            match master.read(&mut buf) {
                Ok(n) => line.extend_from_slice(&buf[..n]),
                Err(_) => continue,
            }
            while let Some(p) = line.iter().position(|&b| b == b'\r') {
                let cmd: Vec<u8> = line.drain(..=p).collect();
                let answer: Vec<u8> = match &cmd[..p] {
                    b"J8" => b"J8<0>".to_vec(),
                    b"L0" => b"L0<0>".to_vec(),
                    b"P0" => b"P0K-10-A FUZZ00001<0>".to_vec(),
                    b"N5" => reply.clone(),
                    _ => Vec::new(),
                };
                let _ = master.write_all(&answer);
            }
        }
    });
    (slave, path, handle)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Arbitrary bytes as the answer to a reading, through the real pty and driver:
    /// a typed result every time, never a panic, and a garbled or truncated answer is
    /// reported as a transient error.
    #[test]
    fn driver_survives_arbitrary_answers(reply in proptest::collection::vec(any::<u8>(), 0..24)) {
        let stop = Arc::new(AtomicBool::new(false));
        let (_slave, path, handle) = scripted_instrument(reply.clone(), Arc::clone(&stop));
        let cfg = K10aConfig {
            read_timeout: Duration::from_millis(100),
            resync_timeout: Duration::from_millis(100),
            retries: 0,
            range_change_retries: 1,
            ..K10aConfig::default()
        };
        let mut meter = KleinK10a::open(&path, cfg).unwrap();
        let result = meter.measure();
        drop(meter);
        stop.store(true, Ordering::SeqCst);
        handle.join().unwrap();
        match result {
            Ok(xyz) => {
                prop_assert!(xyz.is_finite());
                prop_assert!(reply.len() >= 15 && &reply[..2] == b"N5");
            }
            Err(DeviceError::Timeout { .. }) => prop_assert!(reply.is_empty()),
            Err(DeviceError::Garbled { .. })
            | Err(DeviceError::Instrument { .. })
            | Err(DeviceError::OverRange { .. }) => {}
            Err(other) => prop_assert!(false, "unexpected error {other:?}"),
        }
    }
}
