//! `lumiwall view --seams-through-simulator`: the displays' images emitted by the
//! virtual wall and compared across every border between two tiles of one eye. The
//! same surface point seen across a border must have the same luminance on both
//! sides after the post pass; what the scene itself changes between the two sides is
//! taken out (the rendered frames' luminance in the same pixels), so what is left is
//! the displays' mismatch: vignetting and hotspot a flat field did not remove, two
//! profiles' different whites.

use lumiwall_devices::DisplayId;
use lumiwall_devices::sim::VirtualWall;
use lumiwall_profiles::DisplayProfile;
use lumiwall_render::post::{CodeImage, XyzFrame};

use crate::CliError;

/// Pixels along the border averaged per block: the ordered dither's period, so a block
/// shows the drive between two codes as its mean.
const BLOCK_ALONG: usize = 16;

/// Pixels inside each border averaged per block (from the border inwards): the
/// dither's period too, so a dark block's mean is not one code's step off.
const BLOCK_DEPTH: usize = 16;

/// Largest luminance step across a seam the issue accepts (relative).
pub(crate) const MAX_SEAM_STEP: f64 = 0.01;

/// One display's image on the wall: its profile (key), the frame it rendered and the
/// codes the post pass made of it.
pub(crate) struct Shown<'a> {
    pub(crate) profile: &'a DisplayProfile,
    pub(crate) frame: &'a XyzFrame,
    pub(crate) codes: &'a CodeImage,
}

/// Which side of a display a block lies against.
#[derive(Clone, Copy)]
enum Side {
    Right,
    Left,
    Bottom,
    Top,
}

/// The luminance steps of every block of every border.
pub(crate) struct SeamSteps {
    /// Borders between two displays of one eye.
    pub(crate) borders: usize,
    /// Relative luminance step of each block with light on both sides.
    pub(crate) steps: Vec<f64>,
}

impl SeamSteps {
    /// Median and largest step.
    pub(crate) fn median_max(&self) -> (f64, f64) {
        let mut v = self.steps.clone();
        v.sort_by(f64::total_cmp);
        let max = v.last().copied().unwrap_or(0.0);
        let median = if v.is_empty() { 0.0 } else { v[v.len() / 2] };
        (median, max)
    }
}

/// Mean emitted and rendered luminance of the block of `side` at `along` (pixels from
/// its start), or `None` where a pixel has no light in the frame or was flagged.
fn block(
    wall: &VirtualWall,
    s: &Shown<'_>,
    side: Side,
    along: usize,
) -> Result<Option<(f64, f64)>, CliError> {
    let (w, h) = (s.codes.width as usize, s.codes.height as usize);
    let max_code = f64::from((1u32 << s.codes.bit_depth) - 1);
    let id = DisplayId(s.profile.display.display);
    let (mut emitted, mut rendered) = (0.0, 0.0);
    for a in along..along + BLOCK_ALONG {
        for d in 0..BLOCK_DEPTH {
            let (x, y) = match side {
                Side::Right => (w - 1 - d, a),
                Side::Left => (d, a),
                Side::Bottom => (a, h - 1 - d),
                Side::Top => (a, d),
            };
            let i = y * w + x;
            let y_frame = f64::from(s.frame.pixels[i][1]);
            if y_frame <= 0.0 || s.codes.flags[i] != 0 {
                return Ok(None);
            }
            let drive = s.codes.codes[i].map(|c| f64::from(c) / max_code);
            let uv = [(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64];
            let xyz = wall
                .emitted_xyz(id, drive, uv)
                .map_err(|e| CliError::input(format!("{}: {e}", s.profile.display)))?;
            emitted += xyz.y;
            rendered += y_frame;
        }
    }
    Ok(Some((emitted, rendered)))
}

/// The steps across the border where `a`'s `side_a` meets `b`'s opposite side.
fn border(
    wall: &VirtualWall,
    a: &Shown<'_>,
    b: &Shown<'_>,
    horizontal_neighbours: bool,
    steps: &mut Vec<f64>,
) -> Result<(), CliError> {
    let (side_a, side_b, length) = if horizontal_neighbours {
        (Side::Right, Side::Left, a.codes.height as usize)
    } else {
        (Side::Bottom, Side::Top, a.codes.width as usize)
    };
    for along in (0..length.saturating_sub(BLOCK_ALONG - 1)).step_by(BLOCK_ALONG) {
        let (Some((ea, ra)), Some((eb, rb))) = (
            block(wall, a, side_a, along)?,
            block(wall, b, side_b, along)?,
        ) else {
            continue;
        };
        if ea > 0.0 && eb > 0.0 {
            steps.push(((ea / eb) / (ra / rb) - 1.0).abs());
        }
    }
    Ok(())
}

/// Every border between two displays of one eye, right and lower neighbours.
pub(crate) fn seam_steps(wall: &VirtualWall, shown: &[Shown<'_>]) -> Result<SeamSteps, CliError> {
    let small = |s: &&Shown<'_>| {
        (s.codes.width as usize) < 2 * BLOCK_DEPTH || (s.codes.height as usize) < 2 * BLOCK_DEPTH
    };
    if let Some(s) = shown.iter().find(small) {
        return Err(CliError::input(format!(
            "{}: {}×{} px is too small to compare its borders (at least {} px each way)",
            s.profile.display,
            s.codes.width,
            s.codes.height,
            2 * BLOCK_DEPTH
        )));
    }
    let mut out = SeamSteps {
        borders: 0,
        steps: Vec::new(),
    };
    for a in shown {
        let ka = &a.profile.display;
        for b in shown {
            let kb = &b.profile.display;
            let same_size = a.codes.width == b.codes.width && a.codes.height == b.codes.height;
            if kb.eye != ka.eye || !same_size {
                continue;
            }
            let right = kb.tile_row == ka.tile_row && kb.tile_col == ka.tile_col + 1;
            let below = kb.tile_col == ka.tile_col && kb.tile_row == ka.tile_row + 1;
            if right || below {
                out.borders += 1;
                border(wall, a, b, right, &mut out.steps)?;
            }
        }
    }
    Ok(out)
}
