//! A display's grey axis as ArgyllCMS per-channel calibration curves (`.cal`, CGATS
//! `CAL`, the layout `dispcal` writes and `dispwin`, `applycal` and DisplayCAL load
//! into a video card's gamma table).
//!
//! Entry `v` of channel c is the post pass's drive of c for the grey `v` of the
//! `.cube`'s input (common-gamut RGB relative to the target white, linear =
//! v^[`CUBE_INPUT_GAMMA`](super::cube::CUBE_INPUT_GAMMA)): with these curves loaded,
//! equal R = G = B = v shows the target white's chromaticity at v^2.2 of its
//! luminance. Curves cannot carry the 3×3 part: colours off the grey axis need the
//! `.cube` or the post pass.

use lumiwall_profiles::DisplayProfile;

use super::cube::{CubeError, drives_at};

/// Entries per curve (8-bit video card tables; Argyll interpolates between them).
pub const CAL_ENTRIES: usize = 256;

/// The `.cal` text of `profile`, dated `created`.
pub fn to_cal(profile: &DisplayProfile, created: &str) -> Result<String, CubeError> {
    let step = 1.0 / (CAL_ENTRIES - 1) as f64;
    let greys = (0..CAL_ENTRIES).map(|i| [i as f64 * step; 3]);
    let drives = drives_at(profile, greys)?;
    let mut out = String::from("CAL    \n\n");
    out += "DESCRIPTOR \"Argyll Device Calibration Curves\"\n";
    out += &format!(
        "ORIGINATOR \"lumiwall export {}\"\n",
        profile.display.file_stem()
    );
    out += &format!("CREATED \"{}\"\n", created.replace('"', "'"));
    out += "DEVICE_CLASS \"DISPLAY\"\nCOLOR_REP \"RGB\"\n\n";
    out += "NUMBER_OF_FIELDS 4\nBEGIN_DATA_FORMAT\nRGB_I RGB_R RGB_G RGB_B\nEND_DATA_FORMAT\n\n";
    out += &format!("NUMBER_OF_SETS {CAL_ENTRIES}\nBEGIN_DATA\n");
    for (i, d) in drives.iter().enumerate() {
        out += &format!(
            "{:.7} {:.7} {:.7} {:.7}\n",
            i as f64 * step,
            d[0],
            d[1],
            d[2]
        );
    }
    out += "END_DATA\n";
    Ok(out)
}
