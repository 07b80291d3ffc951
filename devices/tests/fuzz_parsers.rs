//! Fuzz targets of the devices crate's parsers (see `fuzz/mutate.rs`): the wall file
//! (TOML) loader and the K-10-A serial answers. Each starts from its corpus in
//! `fuzz/corpus/<parser>/`, runs for `LUMIWALL_FUZZ_SECONDS` (default 5 s) and asserts
//! for every mutated input: no panic, no hang, and either `Ok` with a value that
//! passes the checks below or a typed error.

#[path = "../../fuzz/mutate.rs"]
#[allow(
    dead_code,
    reason = "each fuzz test binary uses only part of the harness"
)]
mod mutate;

use lumiwall_core::BitDepth;
use lumiwall_devices::serial::k10_protocol::{
    self as proto, AnswerError, Command, MeasureSpeed, StatusCode,
};
use lumiwall_devices::sim::VirtualWall;
use lumiwall_devices::{DeviceError, DisplayId};

/// A wall that loads must be usable: its size within the limits, a name, a bit
/// depth a profile can hold, and finite, non-negative light from its first and last
/// display at black, mid grey and white, at the centre and in a corner.
fn check_wall(input: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(input);
    let wall = match VirtualWall::from_toml_str(&text) {
        Ok(w) => w,
        Err(DeviceError::Config(m)) if !m.is_empty() => return Ok(()),
        Err(other) => return Err(format!("not a configuration error: {other:?}")),
    };
    let displays = wall.displays();
    if displays.is_empty() || displays.len() > 8192 {
        return Err(format!("wall of {} displays", displays.len()));
    }
    if wall.name().trim().is_empty() {
        return Err("wall with an empty name loaded".into());
    }
    let last = DisplayId(displays.len() as u32 - 1);
    for d in &displays {
        if !BitDepth::is_profile_depth(d.bit_depth) {
            return Err(format!("{} has bit depth {}", d.name, d.bit_depth));
        }
    }
    for id in [DisplayId(0), last] {
        for drive in [[0.0; 3], [0.5; 3], [1.0; 3], [1.0, 0.0, 0.0]] {
            for uv in [[0.5, 0.5], [0.0, 1.0]] {
                match wall.emitted_xyz(id, drive, uv) {
                    Ok(xyz) => {
                        let v = xyz.to_array();
                        if v.iter().any(|c| !c.is_finite() || *c < 0.0) {
                            return Err(format!("{id} emits {v:?} for {drive:?} at {uv:?}"));
                        }
                    }
                    Err(DeviceError::Config(_)) => {}
                    Err(e) => return Err(format!("{id} at {uv:?}: {e:?}")),
                }
            }
        }
    }
    Ok(())
}

#[test]
fn fuzz_wall_toml_never_panics_or_hangs_and_loads_only_usable_walls() {
    let cases = mutate::fuzz("wall_toml", check_wall);
    assert!(cases > 0);
}

const SPEEDS: [MeasureSpeed; 4] = [
    MeasureSpeed::Fast,
    MeasureSpeed::Normal,
    MeasureSpeed::Slow,
    MeasureSpeed::Slowest,
];

/// Every parser on every input: a typed error, or a value that the encoder gives
/// back (the same echo and status byte, the same values).
fn check_k10a(input: &[u8]) -> Result<(), String> {
    for speed in SPEEDS {
        match proto::parse_measurement(speed, input) {
            Ok(a) => {
                let xyz = a.xyz.to_array();
                if xyz.iter().any(|v| !v.is_finite()) {
                    return Err(format!("measurement {xyz:?} not finite"));
                }
                if a.ranges.iter().any(|r| !(1..=6).contains(r)) {
                    return Err(format!("ranges {:?} outside 1..=6", a.ranges));
                }
                // The range byte is not compared: bytes with digits 27..=31 decode to
                // ranges in 1..=6 that encode differently, and the protocol tests hold
                // that every framed payload parses.
                let again = proto::encode_measurement(speed, a.xyz, a.ranges, a.status);
                if again[13] != input[13] || again[..2] != input[..2] {
                    return Err(format!("re-encoded as {}", again.escape_ascii()));
                }
                let back = proto::parse_measurement(speed, &again)
                    .map_err(|e| format!("re-encoded answer refused: {e}"))?;
                if back.xyz != a.xyz {
                    return Err(format!("{:?} re-encodes to {:?}", a.xyz, back.xyz));
                }
            }
            Err(
                AnswerError::Length { .. } | AnswerError::Echo { .. } | AnswerError::StatusFrame,
            ) => {}
        }
    }
    for command in [Command::AutoRange, Command::LightsOff, Command::LightsOn] {
        if let Ok(status) = proto::parse_ack(command, input)
            && proto::encode_ack(command, status)[..] != *input
        {
            return Err(format!("{status:?} re-encodes differently"));
        }
    }
    if let Ok(info) = proto::parse_device_info(input) {
        if info.status != StatusCode::from_byte(input[19]) {
            return Err(format!("status {:?} is not byte 19", info.status));
        }
        if info.model.trim() != info.model || info.serial.trim() != info.serial {
            return Err(format!("untrimmed {info:?}"));
        }
    }
    Ok(())
}

#[test]
fn fuzz_k10a_answers_never_panic_and_parse_only_what_re_encodes() {
    let cases = mutate::fuzz("k10a_answers", check_k10a);
    assert!(cases > 0);
}
