//! The vocabulary every lumiwall crate shares, on the ground floor of the workspace.
//!
//! - colour: [`Xyz`] (absolute CIE 1931 tristimulus, Y in cd/m²), [`Xy`] (chromaticity),
//!   [`Lab`] (CIELAB against an absolute reference white) with CIEDE2000 in [`lab`];
//! - displays: [`Channel`] (red, green, blue), [`BitDepth`] (max code, quantisation),
//!   [`dither`] (how a drive between codes is shown),
//!   [`Headroom`] (largest planned channel usage), [`Eye`], [`DisplayId`] and [`DisplayKey`];
//! - data: the CIE 1931 2° observer and D65 ([`observer`], parsed once), the sRGB
//!   decoding curve ([`srgb`]) and row-major 3×3 matrices ([`Mat3`], [`mat3`]);
//! - files: atomic writes and output-folder locks ([`files`]).
//!
//! ```
//! use lumiwall_core::{Xy, Xyz};
//! let white = Xy::new(0.3127, 0.3290).with_luminance(12.0);
//! assert!((white.y - 12.0).abs() < 1e-12);
//! let back = white.chromaticity().unwrap();
//! assert!((back.x - 0.3127).abs() < 1e-12);
//! ```

mod bit_depth;
mod channel;
mod display;
pub mod dither;
mod error;
pub mod files;
mod headroom;
pub mod lab;
mod macros;
pub mod mat3;
pub mod observer;
pub mod srgb;
mod xyz;

pub use bit_depth::BitDepth;
pub use channel::Channel;
pub use display::{DisplayId, DisplayKey, Eye};
pub use error::CoreError;
pub use headroom::Headroom;
pub use lab::Lab;
pub use mat3::Mat3;
pub use xyz::{Xy, Xyz};
