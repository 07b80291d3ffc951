//! Photometric light sources: goniometric intensity distributions (isotropic, spot,
//! IES LM-63 and EULUMDAT files), the CIE overcast and clear skies with the sun, and
//! the direct-illuminance law E = I(θ)·cos ε / d² that the radiosity solver uses for
//! point-like sources.
//!
//! # Frames
//! A luminaire's *local frame* is right-handed with −z pointing to the nadir (down,
//! the photometric axis of a downlight, γ = 0°), +x along C = 0° and +y along
//! C = 90° (IES "type C" / CIE C-plane convention: C is measured counter-clockwise
//! from +x when seen from above, γ from the nadir). [`LightFrame`] maps this frame
//! into the world. The sky uses world coordinates with +z up (zenith).

mod distribution;
mod error;
mod eulumdat;
mod frame;
mod ies;
mod illuminance;
mod scene_light;
mod sky;

pub use distribution::{IntensityDistribution, PhotometricSource};
pub use error::PhotometryError;
pub use frame::LightFrame;
pub use illuminance::{PointLight, direct_illuminance_lux};
pub use scene_light::to_scene_light;
pub use sky::{CLEAR_SKY_EXTINCTION, SOLAR_ILLUMINANCE_CONSTANT_LUX, Sky, SkyModel, SkyPatch, Sun};
