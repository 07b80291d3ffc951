//! How a profile is kept in the store: its JSON document (`FORMAT.md` §2) in compact
//! form, zlib-compressed (RFC 1950). A 64 × 32 flat field and three 1024-entry LUTs
//! make a pretty-printed document of ~290 kB; compact and compressed it is a few
//! tens of kB, which matters for a wall of 96 displays recorded every night.

use std::io::{Read, Write};

use flate2::Compression;
use flate2::read::ZlibDecoder;
use flate2::write::ZlibEncoder;

use crate::DisplayProfile;

/// Largest decompressed document accepted (a damaged or crafted row cannot make the
/// reader allocate without bound).
pub const MAX_DOCUMENT_BYTES: u64 = 256 << 20;

/// The compact JSON document of a profile.
pub fn compact_json(p: &DisplayProfile) -> Result<String, serde_json::Error> {
    serde_json::to_string(p)
}

/// Compresses a JSON document for the `profiles.document` column.
pub fn compress(json: &str) -> std::io::Result<Vec<u8>> {
    let mut enc = ZlibEncoder::new(Vec::with_capacity(json.len() / 4), Compression::default());
    enc.write_all(json.as_bytes())?;
    enc.finish()
}

/// Decompresses a `profiles.document` value back to its JSON text.
pub fn decompress(blob: &[u8]) -> std::io::Result<String> {
    let mut text = String::new();
    let mut limited = ZlibDecoder::new(blob).take(MAX_DOCUMENT_BYTES + 1);
    limited.read_to_string(&mut text)?;
    if text.len() as u64 > MAX_DOCUMENT_BYTES {
        return Err(std::io::Error::other(format!(
            "document larger than {MAX_DOCUMENT_BYTES} bytes"
        )));
    }
    Ok(text)
}
