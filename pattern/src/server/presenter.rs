//! What shows frames on a node's outputs.

use crate::framebuffer::Framebuffer;

use super::OutputSpec;

/// Shows one frame per output, all outputs changing together.
pub trait Presenter: Send {
    /// Presents `frames` (one per output, in the configured order) and returns once
    /// they are on screen (after vsync for a window).
    fn present(&mut self, frames: Vec<Framebuffer>) -> Result<(), String>;
    /// The last presented frame of output `index`, if this presenter can read back.
    fn read_back(&self, index: usize) -> Option<Framebuffer>;
}

/// Off-screen presenter: keeps the presented frames in memory (CI, tests, and the
/// virtual wall's sink). It has no display, so "presented" means "stored".
#[derive(Debug)]
pub struct HeadlessPresenter {
    frames: Vec<Framebuffer>,
}

impl HeadlessPresenter {
    /// Black frames of the outputs' sizes at their surface depths.
    pub fn new(outputs: &[OutputSpec]) -> Self {
        HeadlessPresenter {
            frames: outputs
                .iter()
                .map(|o| Framebuffer::black(o.width_px, o.height_px, o.surface_bit_depth))
                .collect(),
        }
    }
}

impl Presenter for HeadlessPresenter {
    fn present(&mut self, frames: Vec<Framebuffer>) -> Result<(), String> {
        if frames.len() != self.frames.len() {
            return Err(format!(
                "{} frames for {} outputs",
                frames.len(),
                self.frames.len()
            ));
        }
        self.frames = frames;
        Ok(())
    }

    fn read_back(&self, index: usize) -> Option<Framebuffer> {
        self.frames.get(index).cloned()
    }
}
