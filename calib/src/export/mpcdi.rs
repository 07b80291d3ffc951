//! A commissioned wall as a VESA MPCDI v2.0 package (`.mpcdi`), profile `2d`, geometry
//! level 1, colour level 4 (5 where a display has a colour wheel's white segment).
//! The structure follows `fixtures/formats/mpcdi-v2.md` (the standard's sections are
//! cited there).
//!
//! Each display is one region; each eye one buffer (the whole wall, tiles at their
//! columns and rows). The MPCDI colour pipeline per region is
//! `encode(α·(1 − β)·correct(decode(e)) + β)` in linear light; lumiwall's post pass is
//! `drive(white_step((M·xyz)/g + o))`. They agree with:
//! - **decode**: input RGB in the wall's common gamut relative to the target white,
//!   `linear = e^2.2` (as the `.cube` export; at level 5 the 3D correction LUT does it);
//! - **correct**: the 3×3 `primaries` `P_c = (M·RGB→XYZ)_c / (s·g_min,c·(1 − β_c))` after
//!   an identity 1D LUT (level 4); with a white segment (level 5) a 3D LUT of the post
//!   pass's white-segment step over the encoded input;
//! - **alpha** (RGB, linear, `gammaEmbedded` 1.0): `α_c = g_min,c / g_c(u, v)` from the
//!   flat field (1 without one);
//! - **beta** (RGB): `β_c = o_c / s` where the black offset `o_c` is positive (a beta
//!   map can only raise black); a negative offset goes into the encode LUT;
//! - **encode**: `drive(s·a + min(o, 0))`: the tone curves' inverse LUTs (1D; the
//!   level is an upper bound, so level 5 keeps a 1D encode, which resolves the dark end
//!   where a 3D LUT of linear input could not).
//!
//! `s ≥ 1` keeps every stage within [0, 1]: the largest value the post pass reaches
//! before its white-segment step (above 1 on a DLP whose white segment adds light).
//!
//! lumiwall calibrates no geometry: each warp is the identity onto the tile's nominal
//! rectangle of the buffer (17×17, no error estimate). The measured XYZ of primaries,
//! black and white, the instrument and the verification travel in the extension
//! `org.lumiwall.calibration` (`lumiwall-calibration.json`).

use std::io::Write;

use lumiwall_profiles::apply::{ApplyOptions, PreparedProfile, rgb_to_xyz_matrix};
use lumiwall_profiles::{DisplayModel, DisplayProfile, Eye};
use serde_json::json;

use super::cube::CUBE_INPUT_GAMMA;

/// Samples per axis of the identity warp (the standard allows 2..=32 at geometry 1).
const WARP_GRID: usize = 17;
/// Entries of the decode LUT.
const DECODE_LUT_SIZE: usize = 4096;
/// Grid of the level-5 correction LUT (piecewise linear: the white-segment step bends
/// where the smallest channel changes).
const CORRECT_LUT3D_SIZE: usize = 33;
/// Largest region raster the exporter accepts (pixels per side).
pub const MAX_REGION_PX: u32 = 16_384;
/// Name of the extension carrying lumiwall's calibration record.
pub const EXTENSION_NAME: &str = "org.lumiwall.calibration";
/// The extension's file.
pub const EXTENSION_FILE: &str = "lumiwall-calibration.json";

/// Why a wall cannot become an MPCDI package.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("MPCDI export: {0}")]
pub struct MpcdiError(pub String);

/// What the package is written with.
#[derive(Debug, Clone, PartialEq)]
pub struct MpcdiOptions {
    /// Each projector's raster (pixels), e.g. `[1920, 1200]`.
    pub region_px: [u32; 2],
    /// Generation time, `yyyy-MM-dd HH:mm:ss` (UTC).
    pub date: String,
    /// The wall's last verification, carried in the extension if known.
    pub verification: Option<serde_json::Value>,
}

/// A written package.
#[derive(Debug, Clone, PartialEq)]
pub struct MpcdiPackage {
    /// The `.mpcdi` (ZIP) bytes.
    pub bytes: Vec<u8>,
    /// The colour level declared (4, or 5 with a white segment).
    pub color_level: u8,
    /// Regions (displays).
    pub regions: usize,
    /// Largest factor an encode LUT multiplies its input by (1: none; above 1 where
    /// the post pass's linear values exceed 1 before its white-segment step or offset).
    pub largest_scale: f64,
}

/// One display's place in the package.
struct Region<'a> {
    profile: &'a DisplayProfile,
    id: String,
    buffer: &'static str,
    /// `[x, y, xSize, ySize]` in the buffer's normalized coordinates (origin bottom-left).
    rect: [f64; 4],
}

/// What the colour pipeline needs of one display.
struct ColourFit {
    /// Smallest flat-field gain per channel (1 without a flat field).
    g_min: [f64; 3],
    /// β per channel: the black offset where it raises black (≥ 0).
    beta: [f64; 3],
    /// The rest of the black offset (≤ 0), which the encode LUT takes: a beta map can
    /// only raise black.
    encode_shift: [f64; 3],
    /// The correction.
    correct: Correction,
    /// The factor the encode LUT multiplies its input by (≥ 1): correction and beta are
    /// divided by it so that every stage stays within [0, 1].
    scale: f64,
}

/// The correction stage of one region.
enum Correction {
    /// Level 4: an identity 1D LUT and this matrix (rows: output channel).
    Primaries([[f64; 3]; 3]),
    /// Level 5: a 3D LUT (`CORRECT_LUT3D_SIZE`³, red fastest).
    Lut3d(Vec<[f64; 3]>),
}

/// The whole wall as one MPCDI package.
pub fn to_mpcdi(
    wall: &str,
    profiles: &[DisplayProfile],
    options: &MpcdiOptions,
) -> Result<MpcdiPackage, MpcdiError> {
    check_options(profiles, options)?;
    let regions = layout(profiles);
    let color_level = if profiles
        .iter()
        .all(|p| p.display_model == DisplayModel::Additive)
    {
        4
    } else {
        5
    };
    // level 4 decodes e^2.2 here; level 5 keeps the encoded input for its 3D LUT,
    // whose grid is then dense where the eye is sensitive (as the .cube export's)
    let mut files: Vec<(String, Vec<u8>)> =
        vec![("identity.cube".into(), identity_lut().into_bytes())];
    if color_level == 4 {
        files.push(("decode.cube".into(), decode_lut().into_bytes()));
    }
    let mut fits = Vec::with_capacity(regions.len());
    for r in &regions {
        let fit = colour_fit(r.profile, color_level)?;
        files.extend(region_files(r, &fit)?);
        fits.push(fit);
    }
    files.push((
        EXTENSION_FILE.into(),
        extension_json(wall, &regions, options).into_bytes(),
    ));
    let xml = mpcdi_xml(&regions, &fits, color_level, options);
    files.insert(0, ("mpcdi.xml".into(), xml.into_bytes()));
    let largest_scale = fits.iter().map(|f| f.scale).fold(1.0, f64::max);
    Ok(MpcdiPackage {
        bytes: zip(&files)?,
        color_level,
        regions: regions.len(),
        largest_scale,
    })
}

fn check_options(profiles: &[DisplayProfile], options: &MpcdiOptions) -> Result<(), MpcdiError> {
    if profiles.is_empty() {
        return Err(MpcdiError("no profiles to export".into()));
    }
    let [w, h] = options.region_px;
    if !(2..=MAX_REGION_PX).contains(&w) || !(2..=MAX_REGION_PX).contains(&h) {
        return Err(MpcdiError(format!(
            "projector raster {w}×{h} is outside 2..={MAX_REGION_PX} pixels per side"
        )));
    }
    Ok(())
}

/// Regions on their tiles: one buffer per eye, the tile grid from the profiles.
fn layout(profiles: &[DisplayProfile]) -> Vec<Region<'_>> {
    let cols = profiles
        .iter()
        .map(|p| p.display.tile_col)
        .max()
        .unwrap_or(0)
        + 1;
    let rows = profiles
        .iter()
        .map(|p| p.display.tile_row)
        .max()
        .unwrap_or(0)
        + 1;
    let (w, h) = (1.0 / f64::from(cols), 1.0 / f64::from(rows));
    profiles
        .iter()
        .map(|p| Region {
            profile: p,
            id: p.display.file_stem(),
            buffer: buffer_id(p.display.eye),
            // tile row 0 is the top; the buffer's origin is bottom-left
            rect: [
                f64::from(p.display.tile_col) * w,
                f64::from(rows - 1 - p.display.tile_row) * h,
                w,
                h,
            ],
        })
        .collect()
}

fn buffer_id(eye: Eye) -> &'static str {
    match eye {
        Eye::Mono => "mono",
        Eye::Left => "left",
        Eye::Right => "right",
    }
}

/// g_min, β, the correction and the encode scale of one display, for colour `level`.
fn colour_fit(p: &DisplayProfile, level: u8) -> Result<ColourFit, MpcdiError> {
    let stem = p.display.file_stem();
    let g_min = smallest_gains(p)?;
    let offset = p.drive_offset;
    if let Some(c) = (0..3).find(|&c| !(offset[c].is_finite() && offset[c] < 1.0)) {
        return Err(MpcdiError(format!(
            "{stem}: black offset {} on channel {c} is not below 1",
            offset[c]
        )));
    }
    let to_xyz = rgb_to_xyz_matrix(&p.common_primaries_xy, &p.target_white_xyz_cd_m2)
        .map_err(|e| MpcdiError(format!("{stem}: the common gamut: {e}")))?;
    let m = p.xyz_to_drive;
    // M·RGB→XYZ / g_min: the post pass's m/g at the texel where g is smallest
    let direct: [[f64; 3]; 3] = std::array::from_fn(|c| {
        std::array::from_fn(|j| (0..3).map(|i| m[c][i] * to_xyz[i][j]).sum::<f64>() / g_min[c])
    });
    let raised = offset.map(|o| o.max(0.0));
    if level == 4 {
        Ok(fit_primaries(g_min, direct, offset, raised))
    } else {
        fit_lut3d(p, g_min, direct, raised)
    }
}

/// Smallest flat-field gain per channel (1 without a flat field).
fn smallest_gains(p: &DisplayProfile) -> Result<[f64; 3], MpcdiError> {
    let g_min = match &p.flat_field {
        Some(ff) => std::array::from_fn(|c| {
            ff.gain
                .iter()
                .map(|g| f64::from(g[c]))
                .fold(f64::INFINITY, f64::min)
        }),
        None => [1.0; 3],
    };
    if g_min.iter().any(|g| !(g.is_finite() && *g > 0.0)) {
        return Err(MpcdiError(format!(
            "{}: flat-field gains {g_min:?}",
            p.display.file_stem()
        )));
    }
    Ok(g_min)
}

/// Level 4 (additive): `encode(s·a + o⁻)` after `a = P·rgb·α·(1 − β) + β` reproduces
/// `m/g + o` exactly, with `β = o⁺/s` and `P = direct / (s·(1 − β))`; `s` is the largest
/// `m/g_min + o⁺` over the input cube (at least 1).
fn fit_primaries(
    g_min: [f64; 3],
    direct: [[f64; 3]; 3],
    offset: [f64; 3],
    raised: [f64; 3],
) -> ColourFit {
    let scale = (0..3)
        .map(|c| direct[c].iter().map(|v| v.max(0.0)).sum::<f64>() + raised[c])
        .fold(1.0, f64::max);
    let beta = raised.map(|b| b / scale);
    let primaries = std::array::from_fn(|c| direct[c].map(|v| v / (scale * (1.0 - beta[c]))));
    ColourFit {
        g_min,
        beta,
        encode_shift: offset.map(|o| o.min(0.0)),
        correct: Correction::Primaries(primaries),
        scale,
    }
}

/// Level 5 (white segment): the decode is the identity and the correction LUT, over
/// the encoded input `e` (linear = e^2.2), holds the post pass's
/// `w = white_step(m/g_min + o)` as `(w − f)⁺ / (s − f)` with `β = f/s`, `f` the
/// smallest `w` of each channel (within `[0, o⁺]`: the black's), so that at `α = 1`
/// the blend gives `w/s` and `encode(s·a)` the post pass's drive. Where a flat
/// field makes `α < 1`, the white step is taken before it instead of after (the
/// standard's order): exact without a flat field.
fn fit_lut3d(
    p: &DisplayProfile,
    g_min: [f64; 3],
    direct: [[f64; 3]; 3],
    raised: [f64; 3],
) -> Result<ColourFit, MpcdiError> {
    let pp = PreparedProfile::new(p, &ApplyOptions::default())
        .map_err(|e| MpcdiError(format!("{}: {e}", p.display.file_stem())))?;
    let offset = p.drive_offset;
    let w: Vec<[f64; 3]> = grid_3d(CORRECT_LUT3D_SIZE)
        .map(|encoded| {
            let rgb = encoded.map(|e| e.powf(CUBE_INPUT_GAMMA));
            let a: [f32; 3] = std::array::from_fn(|c| {
                (direct[c][0] * rgb[0] + direct[c][1] * rgb[1] + direct[c][2] * rgb[2] + offset[c])
                    as f32
            });
            pp.white_step(a).map(f64::from)
        })
        .collect();
    let scale = w.iter().flat_map(|v| v.iter().copied()).fold(1.0, f64::max);
    // β: the smallest value each channel takes (the black's, where the white step
    // already acts on a raised black), so that the LUT's zero is the post pass's
    let floor: [f64; 3] = std::array::from_fn(|c| {
        w.iter()
            .map(|v| v[c])
            .fold(f64::INFINITY, f64::min)
            .clamp(0.0, raised[c])
    });
    let lut = w
        .iter()
        .map(|v| std::array::from_fn(|c| (v[c] - floor[c]).max(0.0) / (scale - floor[c])))
        .collect();
    Ok(ColourFit {
        g_min,
        beta: floor.map(|b| b / scale),
        encode_shift: [0.0; 3],
        correct: Correction::Lut3d(lut),
        scale,
    })
}

/// The files of one region: warp, alpha and beta maps, correction and encode LUTs.
fn region_files(r: &Region<'_>, fit: &ColourFit) -> Result<Vec<(String, Vec<u8>)>, MpcdiError> {
    let id = &r.id;
    let mut files = vec![
        (format!("{id}.pfm"), warp_pfm(r.rect)),
        (format!("{id}_alpha.png"), alpha_png(r.profile, fit)?),
        (format!("{id}_beta.png"), constant_png(fit.beta)?),
    ];
    if let Correction::Lut3d(lut) = &fit.correct {
        files.push((
            format!("{id}_correct.cube"),
            correct_lut_3d(lut).into_bytes(),
        ));
    }
    files.push((
        format!("{id}_encode.cube"),
        encode_lut_1d(r.profile, fit).into_bytes(),
    ));
    Ok(files)
}

/// The identity warp onto `rect`, PFM (netpbm: little-endian by a negative scale,
/// bottom row first); R, G the buffer's normalized u, v of each cell centre, B NaN (no
/// error estimate).
fn warp_pfm(rect: [f64; 4]) -> Vec<u8> {
    let n = WARP_GRID;
    let mut out = format!("PF\n{n} {n}\n-1.0\n").into_bytes();
    for row in 0..n {
        // stored first = bottom of the region
        let v = rect[1] + rect[3] * (row as f64 + 0.5) / n as f64;
        for col in 0..n {
            let u = rect[0] + rect[2] * (col as f64 + 0.5) / n as f64;
            for value in [u as f32, v as f32, f32::NAN] {
                out.extend_from_slice(&value.to_le_bytes());
            }
        }
    }
    out
}

/// The alpha map: `g_min / g` per texel and channel (16-bit RGB, first row = top).
fn alpha_png(p: &DisplayProfile, fit: &ColourFit) -> Result<Vec<u8>, MpcdiError> {
    let Some(ff) = &p.flat_field else {
        return constant_png([1.0; 3]);
    };
    let alpha = |g: &[f32; 3]| -> [f64; 3] {
        std::array::from_fn(|c| (fit.g_min[c] / f64::from(g[c])).min(1.0))
    };
    // a map has at least 2×2 texels: a 1-texel side is repeated (the same bilinear
    // values with texel centres at (i + 0.5)/size)
    let (fw, fh) = (ff.width.max(1), ff.height.max(1));
    let (w, h) = (fw.max(2), fh.max(2));
    let pixels: Vec<[f64; 3]> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x.min(fw - 1), y.min(fh - 1))))
        .map(|(x, y)| ff.gain.get((y * fw + x) as usize).map_or([1.0; 3], alpha))
        .collect();
    png_rgb16(w, h, &pixels)
}

/// A 2×2 map of one value per channel.
fn constant_png(v: [f64; 3]) -> Result<Vec<u8>, MpcdiError> {
    png_rgb16(2, 2, &[v; 4])
}

/// 16-bit RGB PNG of fractions in [0, 1], row-major, first row at the top.
fn png_rgb16(width: u32, height: u32, pixels: &[[f64; 3]]) -> Result<Vec<u8>, MpcdiError> {
    use image::ImageEncoder;
    let mut raw = Vec::with_capacity(pixels.len() * 6);
    for px in pixels {
        for v in px {
            let code = (v.clamp(0.0, 1.0) * 65535.0).round() as u16;
            // the encoder takes 16-bit samples in native byte order
            raw.extend_from_slice(&code.to_ne_bytes());
        }
    }
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&raw, width, height, image::ExtendedColorType::Rgb16)
        .map_err(|e| MpcdiError(format!("PNG: {e}")))?;
    Ok(out)
}

/// A 1D `.cube` with three columns from `f(i / (n − 1))`.
fn lut_1d(title: &str, n: usize, f: impl Fn(f64) -> [f64; 3]) -> String {
    let mut out = format!(
        "TITLE \"{title}\"\nLUT_1D_SIZE {n}\nDOMAIN_MIN 0.0 0.0 0.0\nDOMAIN_MAX 1.0 1.0 1.0\n"
    );
    for i in 0..n {
        let v = f(i as f64 / (n - 1) as f64);
        out += &format!("{:.8} {:.8} {:.8}\n", v[0], v[1], v[2]);
    }
    out
}

/// Decode: `linear = e^2.2` on every channel.
fn decode_lut() -> String {
    lut_1d("lumiwall decode e^2.2", DECODE_LUT_SIZE, |e| {
        [e.powf(CUBE_INPUT_GAMMA); 3]
    })
}

/// The correction's 1D LUT: identity (everything is in the primaries).
fn identity_lut() -> String {
    lut_1d("lumiwall identity", 4, |v| [v; 3])
}

/// Encode (level 4): each channel's inverse tone curve of `scale·a + shift` (the part
/// of the black offset below 0), on its own LUT's nodes where the three share a
/// length (then, without shift and scale, exactly the post pass's interpolation).
fn encode_lut_1d(p: &DisplayProfile, fit: &ColourFit) -> String {
    let n = p
        .curves
        .iter()
        .map(|c| c.inverse_lut.len())
        .max()
        .unwrap_or(4)
        .clamp(4, 65_536);
    lut_1d(
        &format!("lumiwall encode {}", p.display.file_stem()),
        n,
        |a| {
            std::array::from_fn(|c| {
                let linear = fit.scale * a + fit.encode_shift[c];
                f64::from(p.curves[c].drive_for(linear as f32))
            })
        },
    )
}

/// The inputs of an `n`³ grid over [0, 1]³ in `.cube` order (red fastest).
fn grid_3d(n: usize) -> impl Iterator<Item = [f64; 3]> {
    let step = 1.0 / (n - 1) as f64;
    (0..n).flat_map(move |b| {
        (0..n).flat_map(move |g| (0..n).map(move |r| [r, g, b].map(|i| i as f64 * step)))
    })
}

/// Correct (level 5): the 3D LUT's values, in grid order.
fn correct_lut_3d(values: &[[f64; 3]]) -> String {
    let n = CORRECT_LUT3D_SIZE;
    let mut out = format!(
        "TITLE \"lumiwall correct\"\nLUT_3D_SIZE {n}\nDOMAIN_MIN 0.0 0.0 0.0\nDOMAIN_MAX 1.0 1.0 1.0\n"
    );
    for v in values {
        out += &format!("{:.8} {:.8} {:.8}\n", v[0], v[1], v[2]);
    }
    out
}

/// Escapes text for an XML attribute or element.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// `mpcdi.xml`.
fn mpcdi_xml(regions: &[Region<'_>], fits: &[ColourFit], level: u8, o: &MpcdiOptions) -> String {
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n");
    x += &format!(
        "<MPCDI profile=\"2d\" geometry=\"1\" color=\"{level}\" date=\"{}\" version=\"2.0\">\n  <display>\n",
        escape(&o.date)
    );
    for buffer in ["mono", "left", "right"] {
        let of: Vec<usize> = (0..regions.len())
            .filter(|&i| regions[i].buffer == buffer)
            .collect();
        if of.is_empty() {
            continue;
        }
        let [cols, rows] = grid_size(regions);
        x += &format!(
            "    <buffer id=\"{buffer}\" xResolution=\"{}\" yResolution=\"{}\">\n",
            u64::from(cols) * u64::from(o.region_px[0]),
            u64::from(rows) * u64::from(o.region_px[1])
        );
        for i in of {
            x += &region_xml(&regions[i], &fits[i], o);
        }
        x += "    </buffer>\n";
    }
    x += "  </display>\n  <files>\n";
    for r in regions {
        x += &fileset_xml(r, level == 4);
    }
    x += "  </files>\n  <extensionSet>\n";
    x += &format!(
        "    <extension name=\"{EXTENSION_NAME}\" hasExternalFiles=\"true\">\n      \
         <definitions><format>lumiwall-calibration-1</format></definitions>\n      \
         <fileSet><file id=\"calibration\">{EXTENSION_FILE}</file></fileSet>\n    \
         </extension>\n  </extensionSet>\n</MPCDI>\n"
    );
    x
}

fn grid_size(regions: &[Region<'_>]) -> [u32; 2] {
    let cols = regions
        .iter()
        .map(|r| r.profile.display.tile_col)
        .max()
        .unwrap_or(0)
        + 1;
    let rows = regions
        .iter()
        .map(|r| r.profile.display.tile_row)
        .max()
        .unwrap_or(0)
        + 1;
    [cols, rows]
}

fn region_xml(r: &Region<'_>, fit: &ColourFit, o: &MpcdiOptions) -> String {
    let [x, y, w, h] = r.rect;
    let mut s = format!(
        "      <region id=\"{}\" x=\"{x:.10}\" y=\"{y:.10}\" xSize=\"{w:.10}\" ySize=\"{h:.10}\" \
         xResolution=\"{}\" yResolution=\"{}\">\n        <color>\n          \
         <decode type=\"lut1d\"></decode>\n",
        r.id, o.region_px[0], o.region_px[1]
    );
    if let Correction::Primaries(primaries) = &fit.correct {
        s += "          <correct type=\"lut1d-primary\">\n            <primaries>\n";
        for (name, row) in ["redPrimary", "greenPrimary", "bluePrimary"]
            .iter()
            .zip(primaries)
        {
            s += &format!(
                "              <{name}><red>{:.10}</red><green>{:.10}</green><blue>{:.10}</blue></{name}>\n",
                row[0], row[1], row[2]
            );
        }
        s += "            </primaries>\n          </correct>\n          <encode type=\"lut1d\"></encode>\n";
    } else {
        s += "          <correct type=\"lut3d\"></correct>\n          <encode type=\"lut1d\"></encode>\n";
    }
    s += "        </color>\n      </region>\n";
    s
}

fn fileset_xml(r: &Region<'_>, primaries: bool) -> String {
    let id = &r.id;
    let (decode, correct) = if primaries {
        ("decode.cube", "identity.cube".to_string())
    } else {
        ("identity.cube", format!("{id}_correct.cube"))
    };
    format!(
        "    <fileset region=\"{id}\">\n      <geometryWarpFile>\n        \
         <geometricUnit>unknown</geometricUnit>\n        <originOf3DData>unknown</originOf3DData>\n        \
         <path>{id}.pfm</path>\n        <interpolation>linear</interpolation>\n      </geometryWarpFile>\n      \
         <alphaMap>\n        <bitDepth>16</bitDepth>\n        <componentDepth>3</componentDepth>\n        \
         <gammaEmbedded>1.0</gammaEmbedded>\n        <path>{id}_alpha.png</path>\n      </alphaMap>\n      \
         <betaMap>\n        <bitDepth>16</bitDepth>\n        <componentDepth>3</componentDepth>\n        \
         <path>{id}_beta.png</path>\n      </betaMap>\n      \
         <decodeLUT><path>{decode}</path><interpolation>linear</interpolation></decodeLUT>\n      \
         <correctLUT><path>{correct}</path><interpolation>linear</interpolation></correctLUT>\n      \
         <encodeLUT><path>{id}_encode.cube</path><interpolation>linear</interpolation></encodeLUT>\n    \
         </fileset>\n"
    )
}

/// The extension's record: per region what was measured and with what, and the
/// verification.
fn extension_json(wall: &str, regions: &[Region<'_>], o: &MpcdiOptions) -> String {
    let records: Vec<serde_json::Value> = regions
        .iter()
        .map(|r| {
            let p = r.profile;
            let [pr, pg, pb] = p.primaries_xyz_cd_m2;
            let b = p.black_xyz_cd_m2;
            let white: [f64; 3] = std::array::from_fn(|i| pr[i] + pg[i] + pb[i] + b[i]);
            json!({
                "region": r.id,
                "buffer": r.buffer,
                "display": p.display,
                "instrument": p.measurement.instrument,
                "readings": p.measurement.readings,
                "additivity_error": p.measurement.additivity_error,
                "display_model": p.display_model,
                "black_mode": p.black_mode,
                "red_xyz_cd_m2": pr,
                "green_xyz_cd_m2": pg,
                "blue_xyz_cd_m2": pb,
                "black_xyz_cd_m2": b,
                "white_xyz_cd_m2": white,
                "target_white_xyz_cd_m2": p.target_white_xyz_cd_m2,
                "shown_black_xyz_cd_m2": p.shown_black_xyz_cd_m2,
                "common_primaries_xy": p.common_primaries_xy,
                "flat_field_texels": p.flat_field.as_ref().map(|f| [f.width, f.height]),
                "bit_depth": p.bit_depth,
                "profile_created_utc": p.created_utc,
            })
        })
        .collect();
    let doc = json!({
        "format": "lumiwall-calibration-1",
        "wall": wall,
        "created": o.date,
        "units": "XYZ in cd/m² (CIE 1931 2°), xy chromaticity",
        "input_encoding": format!(
            "RGB in the common gamut relative to the target white, linear = e^{CUBE_INPUT_GAMMA}"
        ),
        "regions": records,
        "verification": o.verification,
    });
    serde_json::to_string_pretty(&doc).unwrap_or_else(|_| "{}".into())
}

/// The files as a ZIP, all at the root, deflated.
fn zip(files: &[(String, Vec<u8>)]) -> Result<Vec<u8>, MpcdiError> {
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated);
    let err = |e: &dyn std::fmt::Display| MpcdiError(format!("ZIP: {e}"));
    for (name, bytes) in files {
        w.start_file(name.as_str(), options).map_err(|e| err(&e))?;
        w.write_all(bytes).map_err(|e| err(&e))?;
    }
    Ok(w.finish().map_err(|e| err(&e))?.into_inner())
}
