//! Fuzz targets of the profiles crate's parsers (see `fuzz/mutate.rs`): the profile
//! JSON document (`DisplayProfile::from_json`, which validates) and the store's time
//! parser. Each starts from its corpus in `fuzz/corpus/<parser>/`, runs for
//! `LUMIWALL_FUZZ_SECONDS` (default 5 s) and asserts for every mutated input: no
//! panic, no hang, and either `Ok` with a value that passes validation and survives
//! its own round trip, or a typed error.

#[path = "../../fuzz/mutate.rs"]
#[allow(
    dead_code,
    reason = "each fuzz test binary uses only part of the harness"
)]
mod mutate;

use std::path::Path;

use lumiwall_profiles::store::{StoreError, parse_time};
use lumiwall_profiles::{DisplayProfile, ProfileError};

/// A profile that loads is valid, saves as JSON that loads back to the same profile,
/// bit for bit; a refusal is a parse, version or validation error naming the file.
fn check_profile(input: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(input);
    let origin = Path::new("fuzz.json");
    match DisplayProfile::from_json(&text, origin) {
        Ok(p) => {
            p.validate()
                .map_err(|e| format!("loaded but invalid: {e}"))?;
            let back = DisplayProfile::from_json(&p.to_json(), origin)
                .map_err(|e| format!("loaded, saved, and the saved text is refused: {e}"))?;
            let bits = |q: &DisplayProfile| {
                q.xyz_to_drive
                    .iter()
                    .flatten()
                    .chain(q.common_primaries_xy.iter().flatten())
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>()
            };
            if back != p || bits(&back) != bits(&p) {
                return Err("the profile does not survive its own JSON".into());
            }
            Ok(())
        }
        Err(ProfileError::Parse { path, .. } | ProfileError::Version { path, .. })
            if path == origin =>
        {
            Ok(())
        }
        Err(ProfileError::Invalid { reason, .. }) if !reason.is_empty() => Ok(()),
        Err(other) => Err(format!("unexpected error {other:?}")),
    }
}

#[test]
fn fuzz_profile_json_never_panics_and_loads_only_valid_profiles_that_round_trip() {
    let cases = mutate::fuzz("profile_json", check_profile);
    assert!(cases > 0);
}

/// A time that parses prints as RFC 3339 and parses back to itself; a refusal is a
/// `BadTime` error quoting the text.
fn check_time(input: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(input);
    match parse_time(&text) {
        Ok(t) => {
            let again = parse_time(&t.to_string())
                .map_err(|e| format!("{t} (from {text:?}) does not parse back: {e}"))?;
            if again != t {
                return Err(format!("{text:?} -> {t} -> {again}"));
            }
            Ok(())
        }
        Err(StoreError::BadTime { text: quoted, .. }) if quoted == text.trim() => Ok(()),
        Err(other) => Err(format!("unexpected error {other:?}")),
    }
}

#[test]
fn fuzz_store_time_never_panics_and_parses_only_times_that_round_trip() {
    let cases = mutate::fuzz("store_time", check_time);
    assert!(cases > 0);
}
