//! Fuzz targets for what a pattern server or station parses from the other side or
//! from its configuration (issue 9): images sent with ShowImage or read back
//! (`Framebuffer::from_png`, `Framebuffer::read_png`), output addresses
//! (`tcp://HOST:PORT/OUTPUT`) and output specifications (`NAME=WxH@BITS[/S]`). The
//! protobuf messages themselves are decoded by prost, with the size limits of
//! `lumiwall_pattern::limits`. Harness: `fuzz/mutate.rs` (see `fuzz/README.md`).

use lumiwall_pattern::server::OutputSpec;
use lumiwall_pattern::{Framebuffer, OutputAddress, max_code};

#[path = "../../fuzz/mutate.rs"]
#[allow(
    dead_code,
    reason = "each fuzz test binary uses only part of the harness"
)]
mod mutate;

use mutate::fuzz;

/// A decoded frame has the size asked for and codes within its depth.
fn check_frame(f: &Framebuffer, bits: u32) -> Result<(), String> {
    if f.codes.len() != f.width as usize * f.height as usize {
        return Err(format!(
            "{}×{} frame with {} pixels",
            f.width,
            f.height,
            f.codes.len()
        ));
    }
    let top = max_code(bits) as u16;
    match f.codes.iter().flatten().find(|c| **c > top) {
        Some(c) => Err(format!("code {c} above {top}")),
        None => Ok(()),
    }
}

#[test]
fn fuzz_pattern_images_never_panic_and_decode_only_to_the_output_size() {
    fuzz("png", |input| {
        match Framebuffer::from_png(input, 5, 3, 10) {
            Ok(f) if (f.width, f.height) != (5, 3) => Err("wrong size accepted".into()),
            Ok(f) => check_frame(&f, 10),
            Err(e) if e.is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }?;
        match Framebuffer::read_png(input, 8) {
            Ok(f) => check_frame(&f, 8),
            Err(e) if e.is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }
    });
}

#[test]
fn fuzz_output_addresses_and_specs_never_panic_and_round_trip() {
    fuzz("pattern_address", |input| {
        let text = String::from_utf8_lossy(input);
        if let Ok(a) = text.parse::<OutputAddress>() {
            let again: OutputAddress = a
                .to_string()
                .parse()
                .map_err(|e| format!("{a} does not parse back: {e}"))?;
            if again != a {
                return Err(format!("{a} round-trips to {again}"));
            }
        }
        if let Ok(o) = text.parse::<OutputSpec>() {
            let pixels = u64::from(o.width_px) * u64::from(o.height_px);
            if pixels == 0 || pixels > lumiwall_pattern::limits::MAX_OUTPUT_PIXELS {
                return Err(format!("output {o:?} accepted"));
            }
        }
        Ok(())
    });
}
