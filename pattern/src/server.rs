//! The node side: `lumiwall pattern-server`. A [`Presenter`] shows frames on the node's
//! outputs (off-screen in [`HeadlessPresenter`]); [`PatternNode`] is the gRPC service
//! (token, lease, limits, one output lit and the others black); [`serve`] runs it on
//! the address given, with the standard gRPC health service beside it. With feature
//! `window`, [`window::run_with_windows`] shows the frames in fullscreen windows.

pub mod barrier;
mod config;
mod presenter;
mod run;
mod service;
mod spawn;
#[cfg(feature = "window")]
pub mod window;

pub use config::{OutputSpec, ServerConfig, TlsIdentity};
pub use presenter::{HeadlessPresenter, Presenter};
pub use run::{ServeError, serve};
pub use service::PatternNode;
pub use spawn::{HeadlessServer, spawn_headless};
