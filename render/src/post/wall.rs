//! A wall's frame cut into the tiles of its displays, and which eye's frame each
//! display (profile) gets.
//!
//! [`WallTiling::plan`] reads the grid from the profiles (columns and rows are one more
//! than the largest tile index); [`EyeFrames`] holds the frame of each eye (one for a
//! mono wall, which then does no per-eye work); [`WallTiling::jobs`] pairs every
//! profile with its tile of its eye's frame.

use std::fmt;
use std::str::FromStr;

use lumiwall_profiles::{DisplayKey, DisplayProfile, Eye};

use super::{PostError, XyzFrame};

/// What does not fit together between a wall, its frames and its displays.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum WallError {
    /// The wall has no display (profile) at all.
    #[error("the wall lists no display")]
    NoDisplay,
    /// A right-eye frame was given for a wall without stereo displays.
    #[error("wall {wall} is mono: --in-right has no display to go to")]
    MonoWithRightFrame {
        /// The wall's name.
        wall: String,
    },
    /// The two eyes' frames differ in size.
    #[error("size mismatch: left frame {left}, right frame {right}")]
    EyeSizeMismatch {
        /// Size of the left (or only) frame.
        left: FrameSize,
        /// Size of the right frame.
        right: FrameSize,
    },
    /// A display's tile is not the size the display expects.
    #[error("size mismatch: {display} expects {expected} but its image is {actual}")]
    DisplaySize {
        /// The display concerned.
        display: DisplayKey,
        /// The resolution the display expects.
        expected: FrameSize,
        /// The size of its tile.
        actual: FrameSize,
    },
}

/// A frame or display resolution in pixels; parsed from `WIDTHxHEIGHT` (`x`, `X` or `×`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSize {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl FrameSize {
    /// The size of `frame`.
    pub fn of(frame: &XyzFrame) -> Self {
        FrameSize {
            width: frame.width,
            height: frame.height,
        }
    }
}

impl fmt::Display for FrameSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}×{}", self.width, self.height)
    }
}

/// `WIDTHxHEIGHT` that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0:?} is not WIDTHxHEIGHT, e.g. 1920x1080")]
pub struct FrameSizeParseError(pub String);

impl FromStr for FrameSize {
    type Err = FrameSizeParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || FrameSizeParseError(s.to_string());
        let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
        Ok(FrameSize {
            width: w.trim().parse().map_err(|_| bad())?,
            height: h.trim().parse().map_err(|_| bad())?,
        })
    }
}

/// Fails with [`WallError::DisplaySize`] when `expected` is given and `frame` differs.
pub fn check_display_size(
    frame: &XyzFrame,
    expected: Option<FrameSize>,
    display: &DisplayKey,
) -> Result<(), WallError> {
    match expected {
        Some(expected) if FrameSize::of(frame) != expected => Err(WallError::DisplaySize {
            display: display.clone(),
            expected,
            actual: FrameSize::of(frame),
        }),
        _ => Ok(()),
    }
}

/// The input frame of each eye: `main` is the left eye of a stereo wall (and the frame
/// of every display of a mono wall), `right` the right eye's if given.
#[derive(Debug, Clone)]
pub struct EyeFrames {
    main: XyzFrame,
    right: Option<XyzFrame>,
}

impl EyeFrames {
    /// Checks that a right-eye frame has displays to go to and matches the main frame.
    pub fn new(
        tiling: &WallTiling,
        main: XyzFrame,
        right: Option<XyzFrame>,
    ) -> Result<Self, WallError> {
        if let Some(r) = &right {
            if !tiling.stereo {
                return Err(WallError::MonoWithRightFrame {
                    wall: tiling.wall.clone(),
                });
            }
            if FrameSize::of(r) != FrameSize::of(&main) {
                return Err(WallError::EyeSizeMismatch {
                    left: FrameSize::of(&main),
                    right: FrameSize::of(r),
                });
            }
        }
        Ok(EyeFrames { main, right })
    }

    /// The frame a display of `eye` shows: the right frame for right-eye displays when
    /// there is one, the main frame otherwise.
    pub fn for_eye(&self, eye: Eye) -> &XyzFrame {
        match (eye, &self.right) {
            (Eye::Right, Some(r)) => r,
            _ => &self.main,
        }
    }
}

/// The tile grid of a wall, planned from its displays' profiles.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WallTiling {
    /// The wall's name.
    pub wall: String,
    /// Tile columns (largest `tile_col` + 1).
    pub cols: u32,
    /// Tile rows (largest `tile_row` + 1).
    pub rows: u32,
    /// Whether any display shows one eye only.
    pub stereo: bool,
}

/// One display's share of the work: its profile and its tile of its eye's frame.
#[derive(Debug, Clone)]
pub struct TileJob<'a> {
    /// The display's profile.
    pub profile: &'a DisplayProfile,
    /// The part of the frame the display shows.
    pub tile: XyzFrame,
}

impl WallTiling {
    /// The grid spanned by `profiles`' tile indices; [`WallError::NoDisplay`] when empty.
    pub fn plan(wall: &str, profiles: &[DisplayProfile]) -> Result<Self, WallError> {
        let span = |index: fn(&DisplayKey) -> u32| {
            profiles
                .iter()
                .map(|p| index(&p.display))
                .max()
                .map(|m| m + 1)
        };
        let (Some(cols), Some(rows)) = (span(|k| k.tile_col), span(|k| k.tile_row)) else {
            return Err(WallError::NoDisplay);
        };
        Ok(WallTiling {
            wall: wall.to_string(),
            cols,
            rows,
            stereo: profiles.iter().any(|p| p.display.eye != Eye::Mono),
        })
    }

    /// The tile of `display` cut from `frames`, checked against `expected` if given.
    pub fn tile(
        &self,
        frames: &EyeFrames,
        display: &DisplayKey,
        expected: Option<FrameSize>,
    ) -> Result<XyzFrame, PostError> {
        let tile = frames.for_eye(display.eye).tile(
            self.cols,
            self.rows,
            display.tile_col,
            display.tile_row,
        )?;
        check_display_size(&tile, expected, display)?;
        Ok(tile)
    }

    /// One job per profile, in the profiles' order, each cut only when reached.
    pub fn jobs<'a>(
        &'a self,
        profiles: &'a [DisplayProfile],
        frames: &'a EyeFrames,
        expected: Option<FrameSize>,
    ) -> impl Iterator<Item = Result<TileJob<'a>, PostError>> + 'a {
        profiles.iter().map(move |profile| {
            Ok(TileJob {
                profile,
                tile: self.tile(frames, &profile.display, expected)?,
            })
        })
    }
}

#[cfg(test)]
mod tests;
