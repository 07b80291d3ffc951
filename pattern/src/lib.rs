//! The pattern service: how a calibration station makes the render nodes of a wall
//! show its patterns.
//!
//! - [`proto`]: the gRPC contract, generated from `proto/lumiwall/pattern/v1/pattern.proto`
//!   (the published file any render engine can implement);
//! - [`server`] (feature `server`): `lumiwall pattern-server`, the node side;
//! - [`client`] (feature `client`): the station side, a `PatternOutput` over the nodes;
//! - [`OutputAddress`], [`Token`], [`Framebuffer`] and the [`limits`] both sides share.

mod address;
mod framebuffer;
pub mod limits;
mod token;

#[cfg(feature = "client")]
pub mod client;
#[cfg(feature = "server")]
pub mod server;

pub use address::{AddressError, OutputAddress};
pub use framebuffer::{Framebuffer, max_code, requantise};
pub use token::{Token, TokenError};

/// The generated gRPC messages, client and server of `lumiwall.pattern.v1`.
#[allow(
    missing_docs,
    unreachable_pub,
    clippy::all,
    clippy::allow_attributes_without_reason,
    reason = "generated code"
)]
pub mod proto {
    tonic::include_proto!("lumiwall.pattern.v1");
}
