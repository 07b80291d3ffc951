//! The virtual wall behind real pattern servers: what a node presented is read back
//! and shown by the simulated projector of that display, so a commissioning run goes
//! through the network, the servers and their presentation while the (simulated) meter
//! reads the virtual wall.

use lumiwall_devices::{DeviceError, DisplayId, DisplayInfo, DriveImage, PatternOutput};

use crate::framebuffer::max_code;

use super::RemotePatternOutput;

/// Shows each pattern on the remote nodes, reads back the presented frame and shows
/// exactly those code values on the simulator.
#[derive(Debug)]
pub struct SimulatorSink<S> {
    remote: RemotePatternOutput,
    simulator: S,
}

impl<S: PatternOutput> SimulatorSink<S> {
    /// The remote output feeding `simulator`.
    pub fn new(remote: RemotePatternOutput, simulator: S) -> Self {
        SimulatorSink { remote, simulator }
    }
}

impl<S: PatternOutput> PatternOutput for SimulatorSink<S> {
    fn displays(&self) -> Vec<DisplayInfo> {
        self.remote.displays()
    }

    /// The crosshair on the node; the simulator shows white (it models uniform fields).
    fn show_aim_marker(&mut self, display: DisplayId, uv: [f64; 2]) -> Result<(), DeviceError> {
        self.remote.show_aim_marker(display, uv)?;
        self.simulator.show(display, [1.0; 3])
    }

    /// The image on the node; the simulator shows the frame the node presented.
    fn show_image(&mut self, display: DisplayId, image: &DriveImage) -> Result<(), DeviceError> {
        PatternOutput::show_image(&mut self.remote, display, image)?;
        let frame = self.remote.read_back(display)?;
        self.simulator
            .show_image(display, &super::remote::drive_image_of(&frame)?)
    }

    fn show(&mut self, display: DisplayId, drive: [f64; 3]) -> Result<(), DeviceError> {
        self.remote.show(display, drive)?;
        let frame = self.remote.read_back(display)?;
        let code = frame.uniform_code().ok_or_else(|| {
            DeviceError::Config(format!(
                "display {display}: the node presented a frame that is not uniform"
            ))
        })?;
        let top = f64::from(max_code(frame.bits));
        self.simulator
            .show(display, code.map(|c| f64::from(c) / top))
    }
}
