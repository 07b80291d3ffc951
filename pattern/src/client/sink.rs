//! The virtual wall behind real pattern servers: what a node presented is read back
//! and shown by the simulated projector of that display, so a commissioning run goes
//! through the network, the servers and their presentation while the (simulated) meter
//! reads the virtual wall.

use lumiwall_core::dither::CELL;
use lumiwall_devices::{DeviceError, DisplayId, DisplayInfo, DriveImage, PatternOutput};

use crate::framebuffer::{Framebuffer, max_code};

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

    /// The frame the node presented must repeat one 16×16 dither cell (a uniform
    /// field is the case of one code); the simulator shows the cell's mean drive,
    /// which it dithers into the same codes.
    fn show(&mut self, display: DisplayId, drive: [f64; 3]) -> Result<(), DeviceError> {
        self.remote.show(display, drive)?;
        let frame = self.remote.read_back(display)?;
        let mean = dither_cell_mean(&frame).ok_or_else(|| {
            DeviceError::Config(format!(
                "display {display}: the node presented a frame that is neither uniform nor \
                 one repeated 16×16 dither cell"
            ))
        })?;
        self.simulator.show(display, mean)
    }
}

/// The mean drive (code / max code) of the frame's top-left 16×16 cell, if the whole
/// frame repeats that cell.
fn dither_cell_mean(frame: &Framebuffer) -> Option<[f64; 3]> {
    let at = |x: u32, y: u32| frame.codes.get((y * frame.width + x) as usize).copied();
    for y in 0..frame.height {
        for x in 0..frame.width {
            if at(x, y)? != at(x % CELL, y % CELL)? {
                return None;
            }
        }
    }
    let (w, h) = (frame.width.min(CELL), frame.height.min(CELL));
    let mut sum = [0u64; 3];
    for y in 0..h {
        for x in 0..w {
            let c = at(x, y)?;
            for (s, v) in sum.iter_mut().zip(c) {
                *s += u64::from(v);
            }
        }
    }
    let n = f64::from(w * h) * f64::from(max_code(frame.bits));
    Some(sum.map(|s| s as f64 / n))
}
