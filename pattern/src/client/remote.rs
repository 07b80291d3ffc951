//! The station's pattern output over the render nodes of a wall.

use std::collections::HashMap;
use std::sync::Arc;

use lumiwall_core::dither;
use lumiwall_devices::traits::check_drive;
use lumiwall_devices::{DeviceError, DisplayId, DisplayInfo, DriveImage, PatternOutput};

use crate::address::OutputAddress;
use crate::framebuffer::{Framebuffer, max_code};
use crate::proto;

use super::{NodeClient, NodeOptions};

/// Where one display's patterns go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Route {
    /// The display.
    pub display: DisplayId,
    /// Its node and output.
    pub address: OutputAddress,
}

/// Shows patterns on the displays of a wall through their nodes' pattern servers:
/// the display's output gets the uniform field, every other output of its node black,
/// and the node that showed the previous pattern (if another) black as well.
pub struct RemotePatternOutput {
    displays: Vec<DisplayInfo>,
    nodes: Vec<NodeClient>,
    routes: HashMap<DisplayId, (usize, String)>,
    lit_node: Option<usize>,
}

impl std::fmt::Debug for RemotePatternOutput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RemotePatternOutput")
            .field("displays", &self.displays.len())
            .field("nodes", &self.nodes)
            .finish()
    }
}

/// Fails unless every display has exactly one route and no output serves two displays.
fn check_routes(displays: &[DisplayInfo], routes: &[Route]) -> Result<(), DeviceError> {
    let mut missing = Vec::new();
    for d in displays {
        match routes.iter().filter(|r| r.display == d.id).count() {
            0 => missing.push(d.name.clone()),
            1 => {}
            n => {
                return Err(DeviceError::Config(format!(
                    "display {} ({}) has {n} outputs in the wall file; give it one",
                    d.id, d.name
                )));
            }
        }
    }
    if !missing.is_empty() {
        return Err(DeviceError::Config(format!(
            "the wall file gives no output for {} display(s): {}; add an [[output]] for each",
            missing.len(),
            missing.join(", ")
        )));
    }
    for (i, r) in routes.iter().enumerate() {
        if let Some(other) = routes[..i].iter().find(|o| o.address == r.address) {
            return Err(DeviceError::Config(format!(
                "{} is given to displays {} and {}; one output shows one display",
                r.address, other.display, r.display
            )));
        }
        if !displays.iter().any(|d| d.id == r.display) {
            return Err(DeviceError::NoSuchDisplay(r.display.to_string()));
        }
    }
    Ok(())
}

impl RemotePatternOutput {
    /// Connects to every node the routes name, takes their leases, and checks that
    /// every output exists with the display's bit depth.
    pub fn connect(
        displays: Vec<DisplayInfo>,
        routes: &[Route],
        opts: &NodeOptions,
    ) -> Result<Self, DeviceError> {
        check_routes(&displays, routes)?;
        let rt = Arc::new(
            tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .map_err(|e| {
                    DeviceError::Config(format!("cannot start the network runtime: {e}"))
                })?,
        );
        let mut nodes: Vec<NodeClient> = Vec::new();
        let mut index: HashMap<String, usize> = HashMap::new();
        let mut table = HashMap::new();
        for r in routes {
            let node = r.address.node();
            let n = match index.get(&node) {
                Some(n) => *n,
                None => {
                    let c =
                        NodeClient::connect(Arc::clone(&rt), &node, &r.address.host, opts.clone())?;
                    nodes.push(c);
                    index.insert(node.clone(), nodes.len() - 1);
                    nodes.len() - 1
                }
            };
            let info = displays
                .iter()
                .find(|d| d.id == r.display)
                .ok_or_else(|| DeviceError::NoSuchDisplay(r.display.to_string()))?;
            check_output(&nodes[n], &r.address, info)?;
            table.insert(r.display, (n, r.address.output.clone()));
        }
        Ok(RemotePatternOutput {
            displays,
            nodes,
            routes: table,
            lit_node: None,
        })
    }

    /// The node and output of `display`.
    fn route(&self, display: DisplayId) -> Result<(usize, &str), DeviceError> {
        self.routes
            .get(&display)
            .map(|(n, o)| (*n, o.as_str()))
            .ok_or_else(|| DeviceError::NoSuchDisplay(display.to_string()))
    }

    fn info(&self, display: DisplayId) -> Result<&DisplayInfo, DeviceError> {
        self.displays
            .iter()
            .find(|d| d.id == display)
            .ok_or_else(|| DeviceError::NoSuchDisplay(display.to_string()))
    }

    /// The output that shows `display`.
    fn output_of(&self, display: DisplayId) -> Result<proto::Output, DeviceError> {
        let (n, output) = self.route(display)?;
        self.nodes[n]
            .outputs()
            .iter()
            .find(|o| o.name == output)
            .cloned()
            .ok_or_else(|| DeviceError::NoSuchDisplay(display.to_string()))
    }

    /// Blacks out the node that shows the previous pattern if it is not `next`.
    fn blank_previous(&mut self, next: usize) -> Result<(), DeviceError> {
        if let Some(prev) = self.lit_node.filter(|p| *p != next) {
            self.nodes[prev].blank()?;
        }
        self.lit_node = Some(next);
        Ok(())
    }

    /// Shows a PNG (the output's size) on `display`'s output.
    pub fn show_image(&mut self, display: DisplayId, png: Vec<u8>) -> Result<(), DeviceError> {
        let (n, output) = self.route(display)?;
        let output = output.to_string();
        self.blank_previous(n)?;
        self.nodes[n].show_image(&output, png).map(|_| ())
    }

    /// The frame `display`'s output last presented.
    pub fn read_back(&self, display: DisplayId) -> Result<Framebuffer, DeviceError> {
        let (n, output) = self.route(display)?;
        self.nodes[n].read_back(output)
    }
}

/// Fails unless `address`'s output exists on the node with `info`'s bit depth.
fn check_output(
    node: &NodeClient,
    address: &OutputAddress,
    info: &DisplayInfo,
) -> Result<(), DeviceError> {
    let o = node
        .outputs()
        .iter()
        .find(|o| o.name == address.output)
        .ok_or_else(|| {
            let have: Vec<&str> = node.outputs().iter().map(|o| o.name.as_str()).collect();
            DeviceError::Config(format!(
                "{address} (display {}) does not exist: node {} has outputs {}",
                info.name,
                node.node(),
                have.join(", ")
            ))
        })?;
    if o.bit_depth != info.bit_depth {
        return Err(DeviceError::Config(format!(
            "display {} is {}-bit in the wall file, but {address} takes {}-bit codes",
            info.name, info.bit_depth, o.bit_depth
        )));
    }
    if o.surface_bit_depth < o.bit_depth {
        tracing::warn!(
            "{address}: only a {}-bit surface for a {}-bit display; codes are rounded to {} bit \
             (steps {}× coarser)",
            o.surface_bit_depth,
            o.bit_depth,
            o.surface_bit_depth,
            1u32 << (o.bit_depth - o.surface_bit_depth)
        );
    }
    Ok(())
}

impl PatternOutput for RemotePatternOutput {
    fn displays(&self) -> Vec<DisplayInfo> {
        self.displays.clone()
    }

    /// A white crosshair (lines a hundredth of the height wide, at least 2 pixels) on
    /// black through the spot, with a white square at the spot.
    fn show_aim_marker(&mut self, display: DisplayId, uv: [f64; 2]) -> Result<(), DeviceError> {
        let o = self.output_of(display)?;
        let png = crosshair(o.width_px, o.height_px, o.bit_depth, uv)
            .to_png()
            .map_err(|e| DeviceError::Config(format!("aiming pattern: {e}")))?;
        self.show_image(display, png)
    }

    /// The image resampled (nearest pixel) to the output's size and codes, sent as PNG.
    fn show_image(&mut self, display: DisplayId, image: &DriveImage) -> Result<(), DeviceError> {
        let o = self.output_of(display)?;
        let png = framebuffer_of(image, o.width_px, o.height_px, o.bit_depth)
            .to_png()
            .map_err(|e| DeviceError::Config(format!("pattern image: {e}")))?;
        RemotePatternOutput::show_image(self, display, png)
    }

    /// A drive on codes as a uniform field; one between codes as the post pass's ordered
    /// dither of the neighbouring codes ([`dither`]), sent as an image.
    fn show(&mut self, display: DisplayId, drive: [f64; 3]) -> Result<(), DeviceError> {
        check_drive(drive)?;
        let bits = self.info(display)?.bit_depth;
        let top = max_code(bits);
        let cell = dither::mix(drive, top);
        let [(on_codes, _)] = cell.as_slice() else {
            let o = self.output_of(display)?;
            let uniform = DriveImage::from_fn(1, 1, |_, _| drive)?;
            let png = framebuffer_of(&uniform, o.width_px, o.height_px, o.bit_depth)
                .to_png()
                .map_err(|e| DeviceError::Config(format!("dithered pattern: {e}")))?;
            return RemotePatternOutput::show_image(self, display, png);
        };
        let code = on_codes.map(|d| (d * f64::from(top)).round() as u32);
        let (n, output) = self.route(display)?;
        let output = output.to_string();
        self.blank_previous(n)?;
        self.nodes[n].show_uniform(&output, code, bits).map(|_| ())
    }
}

/// `image` at `width` × `height` pixels (nearest pixel) in `bits`-bit codes, drives
/// between codes dithered as the post pass does.
pub(super) fn framebuffer_of(
    image: &DriveImage,
    width: u32,
    height: u32,
    bits: u32,
) -> Framebuffer {
    let mut f = Framebuffer::black(width, height, bits);
    let top = max_code(bits);
    for y in 0..height {
        for x in 0..width {
            let uv = [
                (f64::from(x) + 0.5) / f64::from(width),
                (f64::from(y) + 0.5) / f64::from(height),
            ];
            let t = dither::dither_threshold(x, y);
            let d = image.sample(uv);
            f.codes[(y * width + x) as usize] = d.map(|c| dither::quantise(c as f32, top, t));
        }
    }
    f
}

/// The codes of a presented frame as a drive image.
pub(super) fn drive_image_of(frame: &Framebuffer) -> Result<DriveImage, DeviceError> {
    let top = f64::from(max_code(frame.bits));
    let w = frame.width;
    DriveImage::from_fn(frame.width, frame.height, |u, v| {
        let x = ((u * f64::from(w)) as u32).min(w - 1);
        let y = ((v * f64::from(frame.height)) as u32).min(frame.height - 1);
        frame.codes[(y * w + x) as usize].map(|c| (f64::from(c) / top).min(1.0))
    })
}

/// A white crosshair through `uv` on black, at `bits` bits per channel.
fn crosshair(width: u32, height: u32, bits: u32, uv: [f64; 2]) -> Framebuffer {
    let mut f = Framebuffer::black(width, height, bits);
    let white = max_code(bits) as u16;
    let cx = (uv[0].clamp(0.0, 1.0) * f64::from(width - 1)).round() as i64;
    let cy = (uv[1].clamp(0.0, 1.0) * f64::from(height - 1)).round() as i64;
    let half = i64::from((height / 200).max(1));
    let square = 6 * half;
    for y in 0..i64::from(height) {
        for x in 0..i64::from(width) {
            let on_line = (x - cx).abs() <= half || (y - cy).abs() <= half;
            let in_square = (x - cx).abs() <= square && (y - cy).abs() <= square;
            if on_line || in_square {
                f.codes[(y * i64::from(width) + x) as usize] = [white; 3];
            }
        }
    }
    f
}
