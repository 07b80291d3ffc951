//! Serial instrument drivers and their pty emulators.
//!
//! The colorimeter is the Klein Instruments K-10-A (protocol shared by the K-10 and
//! KV-10-A): [`KleinK10a`] opens a serial port with the `serialport` crate and
//! implements [`Colorimeter`](crate::Colorimeter); [`Emulator`] serves the same
//! protocol on a pseudo-terminal, backed by any colorimeter (normally the virtual
//! wall's meter), with injectable faults ([`FaultPlan`]). The wire format is in
//! [`k10_protocol`]; the instrument's published figures are in [`spec`]. Sources:
//! `fixtures/instruments/klein-k10a.md`.
//!
//! The spectroradiometer is the JETI specbos 1201/1211: [`JetiSpecbos`] implements
//! [`Spectroradiometer`](crate::Spectroradiometer), [`SpecbosEmulator`] serves its
//! protocol ([`specbos_protocol`]) backed by any spectroradiometer. Sources:
//! `fixtures/instruments/jeti-specbos.md`.
//!
//! ```no_run
//! use lumiwall_devices::serial::{K10aConfig, KleinK10a};
//! use lumiwall_devices::Colorimeter;
//! let mut meter = KleinK10a::open("/dev/ttyUSB0", K10aConfig::default())?;
//! let xyz = meter.measure()?;
//! println!("Y = {:.3} cd/m²", xyz.y);
//! # Ok::<(), lumiwall_devices::DeviceError>(())
//! ```

pub mod emulator;
pub mod k10_protocol;
pub mod k10a;
mod pty;
pub mod spec;
pub mod specbos;
pub mod specbos_emulator;
pub mod specbos_protocol;

pub use emulator::{
    EmulatedPort, Emulator, EmulatorOptions, FaultPlan, LineDrop, SlowAnswer, StatusFault,
};
pub use k10_protocol::MeasureSpeed;
pub use k10a::{ExchangeStats, K10aConfig, KleinK10a};
pub use spec::{InstrumentSpec, KLEIN_K10A};
pub use specbos::{JetiSpecbos, SpecbosConfig};
pub use specbos_emulator::{EmulatedSpecbos, SpecbosEmulator, SpecbosEmulatorOptions};
