//! The station side: [`NodeClient`] talks to one node (blocking calls with deadlines,
//! the lease taken on connect and given back on drop); [`RemotePatternOutput`] is the
//! station's `PatternOutput` over all nodes of a wall; [`SimulatorSink`] feeds what the
//! nodes presented into the virtual wall, so the network path can be checked against
//! the simulator with no hardware.

mod node;
mod remote;
mod sink;

pub use node::{NodeClient, NodeOptions};
pub use remote::{RemotePatternOutput, Route};
pub use sink::SimulatorSink;
