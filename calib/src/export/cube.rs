//! A display profile as a `.cube` 3D LUT (Adobe / Resolve "Cube LUT Specification
//! 1.0"), for media servers and projectors that take one.
//!
//! What the LUT maps, so a technician can feed it:
//! - **input**: RGB in the wall's common gamut (the profile's `common_primaries_xy`),
//!   relative to its target white (1, 1, 1 = the target white at its luminance),
//!   encoded with a pure power [`CUBE_INPUT_GAMMA`] (`linear = e^2.2`), so that the
//!   grid is dense where the eye is sensitive;
//! - **output**: the post pass's drive for that colour (code value / max code, not
//!   quantised), at the display's centre. The flat field does not fit a uniform LUT;
//!   where a profile has one, [`Cube::flat_field_left_out`] says so.
//!
//! Each entry is exactly [`PreparedProfile::apply`] (no dither) of the colour's XYZ,
//! so the LUT agrees with the post pass at its grid points and differs between them
//! only by the interpolation.

use lumiwall_profiles::DisplayProfile;
use lumiwall_profiles::apply::{ApplyOptions, PreparedProfile, rgb_to_xyz_matrix};

/// The input encoding: `linear = encoded^CUBE_INPUT_GAMMA`.
pub const CUBE_INPUT_GAMMA: f64 = 2.2;
/// Grid sizes a `.cube` may have here (the specification allows 2..=256; 65³ is
/// what media servers commonly take, 129³ is 2.1 M entries).
pub const CUBE_SIZES: std::ops::RangeInclusive<usize> = 2..=129;
/// The display centre, where the LUT's drives are taken.
const CENTRE_UV: [f32; 2] = [0.5, 0.5];

/// Why a profile cannot become a `.cube`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{display}: {message}")]
pub struct CubeError {
    /// The display (file stem).
    pub display: String,
    /// What is wrong.
    pub message: String,
}

/// A `.cube` text and what it leaves out.
#[derive(Debug, Clone, PartialEq)]
pub struct Cube {
    /// The file's text.
    pub text: String,
    /// True when the profile has a flat field, which a uniform LUT cannot carry.
    pub flat_field_left_out: bool,
}

/// The `size`³ `.cube` of `profile` (see the module documentation).
pub fn to_cube(profile: &DisplayProfile, size: usize) -> Result<Cube, CubeError> {
    let fail = |message: String| CubeError {
        display: profile.display.file_stem(),
        message,
    };
    if !CUBE_SIZES.contains(&size) {
        return Err(fail(format!(
            "LUT size {size} is outside {}..={}",
            CUBE_SIZES.start(),
            CUBE_SIZES.end()
        )));
    }
    let drives = drives_at(profile, grid(size))?;
    let mut text = header(profile, size);
    for d in drives {
        text += &format!("{:.6} {:.6} {:.6}\n", d[0], d[1], d[2]);
    }
    Ok(Cube {
        text,
        flat_field_left_out: profile.flat_field.is_some(),
    })
}

/// The post pass's drives (no dither, display centre) for encoded common-gamut RGB
/// inputs (see the module documentation); also the grey axis of a `.cal`.
pub fn drives_at(
    profile: &DisplayProfile,
    encoded: impl Iterator<Item = [f64; 3]>,
) -> Result<Vec<[f32; 3]>, CubeError> {
    let fail = |message: String| CubeError {
        display: profile.display.file_stem(),
        message,
    };
    let rgb_to_xyz = rgb_to_xyz_matrix(
        &profile.common_primaries_xy,
        &profile.target_white_xyz_cd_m2,
    )
    .map_err(|e| fail(format!("the common gamut: {e}")))?;
    let options = ApplyOptions {
        dither: false,
        ..ApplyOptions::default()
    };
    let pp = PreparedProfile::new(profile, &options).map_err(|e| fail(e.to_string()))?;
    Ok(encoded
        .map(|e| {
            let xyz = mul(&rgb_to_xyz, e.map(|v| v.powf(CUBE_INPUT_GAMMA)));
            pp.apply(xyz.map(|v| v as f32), CENTRE_UV).drive
        })
        .collect())
}

/// Title, the input's meaning as comments, size and domain.
fn header(profile: &DisplayProfile, size: usize) -> String {
    let [r, g, b] = profile.common_primaries_xy;
    let w = profile.target_white_xyz_cd_m2;
    let mut out = format!("TITLE \"lumiwall {}\"\n", profile.display.file_stem());
    out += &format!("# profile created {}\n", profile.created_utc);
    out += &format!(
        "# input: RGB in the common gamut R {:.4},{:.4} G {:.4},{:.4} B {:.4},{:.4} (xy), \
         white XYZ {:.4} {:.4} {:.4} cd/m2, encoded linear = e^{CUBE_INPUT_GAMMA}\n",
        r[0], r[1], g[0], g[1], b[0], b[1], w[0], w[1], w[2]
    );
    out += &format!(
        "# output: drive (code / max code) at the display centre, {}-bit display\n",
        profile.bit_depth
    );
    out += &format!("LUT_3D_SIZE {size}\nDOMAIN_MIN 0.0 0.0 0.0\nDOMAIN_MAX 1.0 1.0 1.0\n");
    out
}

/// The grid's encoded inputs in `.cube` order: red changes fastest, then green, blue.
fn grid(size: usize) -> impl Iterator<Item = [f64; 3]> {
    let step = 1.0 / (size - 1) as f64;
    (0..size).flat_map(move |b| {
        (0..size).flat_map(move |g| (0..size).map(move |r| [r, g, b].map(|i| i as f64 * step)))
    })
}

fn mul(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_runs_red_fastest_and_spans_the_domain() {
        let g: Vec<[f64; 3]> = grid(3).collect();
        assert_eq!(g.len(), 27);
        assert_eq!(g[0], [0.0; 3]);
        assert_eq!(g[1], [0.5, 0.0, 0.0]);
        assert_eq!(g[3], [0.0, 0.5, 0.0]);
        assert_eq!(g[9], [0.0, 0.0, 0.5]);
        assert_eq!(g[26], [1.0; 3]);
    }
}
