//! The windows' wgpu side: a surface per window in a UNORM format (10-bit when the
//! output needs more than 8 and the surface offers it), and a pass that writes each
//! pixel's code as `code / (2^bits − 1)` so the display receives the codes unchanged.

use std::sync::Arc;
use std::time::Duration;

use winit::dpi::PhysicalSize;
use winit::event_loop::OwnedDisplayHandle;
use winit::window::{Window, WindowId};

use crate::framebuffer::{Framebuffer, max_code};
use crate::server::OutputSpec;

use super::WindowError;

/// Longest wait for the GPU to finish one present.
const GPU_WAIT: Duration = Duration::from_secs(10);

/// Draws the source texture's codes 1:1: red, green, blue are codes, alpha the largest
/// code at the frame's depth, so `rgb / a` is the UNORM value of each code. Pixels
/// beyond the frame (a window bigger than its output) are black.
const SHADER: &str = r"
@group(0) @binding(0) var codes: texture_2d<u32>;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(i & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let size = textureDimensions(codes);
    let xy = vec2<u32>(p.xy);
    if xy.x >= size.x || xy.y >= size.y {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let c = textureLoad(codes, xy, 0);
    return vec4<f32>(vec3<f32>(c.rgb) / f32(max(c.a, 1u)), 1.0);
}
";

/// The device and the draw pipelines (one per surface format).
struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter: wgpu::Adapter,
    shader: wgpu::ShaderModule,
    layout: wgpu::BindGroupLayout,
    pipelines: Vec<(wgpu::TextureFormat, wgpu::RenderPipeline)>,
}

/// One output's window, surface and source texture.
struct Screen {
    name: String,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    view_format: wgpu::TextureFormat,
    source: wgpu::Texture,
    bind: wgpu::BindGroup,
    last: Option<Framebuffer>,
    window: Arc<Window>,
}

/// All outputs' windows on one GPU.
pub(super) struct Screens {
    // Screens (surfaces) drop before the device.
    screens: Vec<Screen>,
    gpu: Gpu,
}

impl Screens {
    /// Opens the GPU that can present to every window and configures a surface for each.
    pub(super) fn new(
        display: OwnedDisplayHandle,
        windows: Vec<(OutputSpec, Arc<Window>)>,
    ) -> Result<Self, WindowError> {
        let instance = wgpu::Instance::new(
            wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(display)),
        );
        let mut surfaces = Vec::with_capacity(windows.len());
        for (spec, window) in windows {
            let surface = instance.create_surface(Arc::clone(&window)).map_err(|e| {
                WindowError::Gpu(format!(
                    "cannot create a surface for output {}: {e}",
                    spec.name
                ))
            })?;
            surfaces.push((spec, window, surface));
        }
        let first = surfaces.first().map(|(_, _, s)| s);
        let mut gpu = Gpu::open(&instance, first)?;
        let mut screens = Vec::with_capacity(surfaces.len());
        for (spec, window, surface) in surfaces {
            screens.push(Screen::new(&mut gpu, spec, window, surface)?);
        }
        Ok(Screens { screens, gpu })
    }

    /// Uploads `frames` (one per output), draws and presents them together, and waits
    /// until the GPU finished.
    pub(super) fn present(&mut self, frames: &[Framebuffer]) -> Result<(), String> {
        if frames.len() != self.screens.len() {
            return Err(format!(
                "{} frames for {} outputs",
                frames.len(),
                self.screens.len()
            ));
        }
        for (screen, frame) in self.screens.iter().zip(frames) {
            screen.upload(&self.gpu, frame)?;
        }
        let all: Vec<usize> = (0..self.screens.len()).collect();
        self.draw(&all)?;
        for (screen, frame) in self.screens.iter_mut().zip(frames) {
            screen.last = Some(frame.clone());
        }
        Ok(())
    }

    /// Draws window `id`'s last frame again (after an expose).
    pub(super) fn redraw(&mut self, id: WindowId) -> Result<(), String> {
        match self.screens.iter().position(|s| s.window.id() == id) {
            Some(i) if self.screens[i].last.is_some() => self.draw(&[i]),
            _ => Ok(()),
        }
    }

    /// The output shown in window `id`.
    pub(super) fn output_of(&self, id: WindowId) -> Option<&str> {
        self.screens
            .iter()
            .find(|s| s.window.id() == id)
            .map(|s| s.name.as_str())
    }

    /// Follows a window resized by the window manager (and says it is not 1:1 any more).
    pub(super) fn resized(&mut self, id: WindowId, size: PhysicalSize<u32>) {
        let Some(s) = self.screens.iter_mut().find(|s| s.window.id() == id) else {
            return;
        };
        if (size.width, size.height) == (s.config.width, s.config.height)
            || size.width == 0
            || size.height == 0
        {
            return;
        }
        tracing::warn!(
            "the window of output {} was resized to {}×{} (its output is {}×{}): frames are \
             drawn 1:1 from the top left corner; check the monitor's mode and the window manager",
            s.name,
            size.width,
            size.height,
            s.source.width(),
            s.source.height()
        );
        s.config.width = size.width;
        s.config.height = size.height;
        if let Err(e) = s.configure(&self.gpu.device) {
            tracing::warn!("reconfiguring output {}: {e}", s.name);
        }
    }

    /// Draws the source textures of screens `which` to their surfaces in one submission,
    /// presents them, and waits for the GPU.
    fn draw(&mut self, which: &[usize]) -> Result<(), String> {
        let scope = self
            .gpu
            .device
            .push_error_scope(wgpu::ErrorFilter::Validation);
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("pattern frame"),
            });
        let mut targets = Vec::with_capacity(which.len());
        for &i in which {
            let Some(screen) = self.screens.get(i) else {
                continue;
            };
            let target = screen.acquire(&self.gpu.device)?;
            screen.encode(&self.gpu, &mut encoder, &target)?;
            targets.push(target);
        }
        let index = self.gpu.queue.submit([encoder.finish()]);
        for t in targets {
            self.gpu.queue.present(t);
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(format!("the GPU refused the frame: {e}"));
        }
        self.gpu
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: Some(GPU_WAIT),
            })
            .map(|_| ())
            .map_err(|e| format!("waiting for the GPU: {e}"))
    }
}

impl Gpu {
    /// The adapter that can present to `surface` and its device.
    fn open(
        instance: &wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Self, WindowError> {
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surface,
            ..Default::default()
        }))
        .map_err(|e| {
            WindowError::Gpu(format!(
                "no GPU adapter can present to the windows ({e}); install the GPU's Vulkan \
                 driver (software: Mesa's lavapipe, package mesa-vulkan-drivers)"
            ))
        })?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("lumiwall pattern windows"),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| WindowError::Gpu(format!("cannot open {}: {e}", info.name)))?;
        device.on_uncaptured_error(Arc::new(|e| tracing::error!("wgpu: {e}")));
        tracing::info!("pattern windows on {} ({:?})", info.name, info.backend);
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("pattern codes"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pattern codes"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Uint,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        Ok(Gpu {
            device,
            queue,
            adapter,
            shader,
            layout,
            pipelines: Vec::new(),
        })
    }

    /// The draw pipeline for surfaces viewed as `format`.
    fn pipeline(&mut self, format: wgpu::TextureFormat) -> wgpu::RenderPipeline {
        if let Some((_, p)) = self.pipelines.iter().find(|(f, _)| *f == format) {
            return p.clone();
        }
        let layout = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("pattern codes"),
                bind_group_layouts: &[Some(&self.layout)],
                immediate_size: 0,
            });
        let pipeline = self
            .device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("pattern codes"),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &self.shader,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &self.shader,
                    entry_point: Some("fs"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            });
        self.pipelines.push((format, pipeline.clone()));
        pipeline
    }
}

/// The surface format for an output of `bits` bits per channel among `offered`, and
/// the bits per channel it carries: 10-bit UNORM when `bits > 8` and offered, else
/// 8-bit UNORM (an sRGB format is used through its UNORM view, never encoded).
fn choose_format(offered: &[wgpu::TextureFormat], bits: u32) -> Option<(wgpu::TextureFormat, u32)> {
    use wgpu::TextureFormat as F;
    if bits > 8 && offered.contains(&F::Rgb10a2Unorm) {
        return Some((F::Rgb10a2Unorm, 10));
    }
    let eight = [
        F::Bgra8Unorm,
        F::Rgba8Unorm,
        F::Bgra8UnormSrgb,
        F::Rgba8UnormSrgb,
    ];
    eight
        .into_iter()
        .find(|f| offered.contains(f))
        .map(|f| (f, 8))
}

impl Screen {
    /// Configures `surface` for `spec` and creates its source texture.
    fn new(
        gpu: &mut Gpu,
        spec: OutputSpec,
        window: Arc<Window>,
        surface: wgpu::Surface<'static>,
    ) -> Result<Self, WindowError> {
        let caps = surface.get_capabilities(&gpu.adapter);
        let bits = spec.surface_bit_depth;
        if caps.formats.is_empty() {
            return Err(WindowError::Gpu(format!(
                "output {}: {} cannot present to this window (it offers no surface format; \
                 with a 30-bit X screen, try a 24-bit one)",
                spec.name,
                gpu.adapter.get_info().name
            )));
        }
        let (format, shown) = choose_format(&caps.formats, bits).ok_or_else(|| {
            WindowError::Gpu(format!(
                "output {}: the surface offers no 8- or 10-bit UNORM format (it offers {:?})",
                spec.name, caps.formats
            ))
        })?;
        warn_if_shallow(&spec, shown, &caps.formats);
        let side = gpu.device.limits().max_texture_dimension_2d;
        if spec.width_px.max(spec.height_px) > side {
            return Err(WindowError::Gpu(format!(
                "output {} is {}×{} but {} takes textures of at most {side} pixels a side",
                spec.name,
                spec.width_px,
                spec.height_px,
                gpu.adapter.get_info().name
            )));
        }
        let view_format = format.remove_srgb_suffix();
        let config = surface_config(&spec, &caps, format, view_format);
        let (source, bind) = source_texture(gpu, &spec);
        gpu.pipeline(view_format);
        let screen = Screen {
            name: spec.name.clone(),
            surface,
            config,
            view_format,
            source,
            bind,
            last: None,
            window,
        };
        screen
            .configure(&gpu.device)
            .map_err(|e| WindowError::Gpu(format!("output {}: {e}", spec.name)))?;
        tracing::info!(
            "output {}: {}×{} surface {:?}, {shown} bit per channel ({} bit asked)",
            spec.name,
            spec.width_px,
            spec.height_px,
            format,
            bits
        );
        Ok(screen)
    }

    /// Configures the surface, turning wgpu's validation errors into an error.
    fn configure(&self, device: &wgpu::Device) -> Result<(), String> {
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        self.surface.configure(device, &self.config);
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(format!("the surface cannot be configured: {e}")),
            None => Ok(()),
        }
    }

    /// Writes `frame`'s codes to the source texture (alpha: the largest code).
    fn upload(&self, gpu: &Gpu, frame: &Framebuffer) -> Result<(), String> {
        let (w, h) = (self.source.width(), self.source.height());
        if (frame.width, frame.height) != (w, h) || frame.codes.len() != w as usize * h as usize {
            return Err(format!(
                "output {}: a {}×{} frame for a {w}×{h} output",
                self.name, frame.width, frame.height
            ));
        }
        let top = max_code(frame.bits) as u16;
        let mut bytes = Vec::with_capacity(frame.codes.len() * 8);
        for [r, g, b] in &frame.codes {
            for v in [*r, *g, *b, top] {
                bytes.extend_from_slice(&v.to_ne_bytes());
            }
        }
        gpu.queue.write_texture(
            self.source.as_image_copy(),
            &bytes,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(w * 8),
                rows_per_image: Some(h),
            },
            self.source.size(),
        );
        Ok(())
    }

    /// The surface's next texture, reconfiguring once if the surface is outdated.
    fn acquire(&self, device: &wgpu::Device) -> Result<wgpu::SurfaceTexture, String> {
        use wgpu::CurrentSurfaceTexture as C;
        for attempt in 0..2 {
            match self.surface.get_current_texture() {
                C::Success(t) | C::Suboptimal(t) => return Ok(t),
                C::Outdated | C::Lost if attempt == 0 => self.configure(device)?,
                C::Timeout => return Err(format!("output {}: the surface timed out", self.name)),
                C::Occluded => {
                    return Err(format!(
                        "output {}: the window is hidden (occluded or minimised)",
                        self.name
                    ));
                }
                _ => break,
            }
        }
        Err(format!(
            "output {}: the surface is lost (the display changed?)",
            self.name
        ))
    }

    /// Records the pass that draws the source codes to `target`.
    fn encode(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::SurfaceTexture,
    ) -> Result<(), String> {
        let pipeline = gpu
            .pipelines
            .iter()
            .find(|(f, _)| *f == self.view_format)
            .map(|(_, p)| p)
            .ok_or_else(|| {
                format!(
                    "output {}: no pipeline for {:?}",
                    self.name, self.view_format
                )
            })?;
        let view = target.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(self.view_format),
            ..Default::default()
        });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("pattern codes"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            ..Default::default()
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.bind, &[]);
        pass.draw(0..3, 0..1);
        Ok(())
    }
}

/// The texture that holds an output's codes (RGBA16 unsigned, alpha the largest code)
/// and its bind group.
fn source_texture(gpu: &Gpu, spec: &OutputSpec) -> (wgpu::Texture, wgpu::BindGroup) {
    let source = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("pattern codes"),
        size: wgpu::Extent3d {
            width: spec.width_px,
            height: spec.height_px,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba16Uint,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let bind = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("pattern codes"),
        layout: &gpu.layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::TextureView(&source.create_view(&Default::default())),
        }],
    });
    (source, bind)
}

/// The configuration of an output's surface: its size, FIFO (vsync), opaque.
fn surface_config(
    spec: &OutputSpec,
    caps: &wgpu::SurfaceCapabilities,
    format: wgpu::TextureFormat,
    view_format: wgpu::TextureFormat,
) -> wgpu::SurfaceConfiguration {
    let alpha_mode = if caps.alpha_modes.contains(&wgpu::CompositeAlphaMode::Opaque) {
        wgpu::CompositeAlphaMode::Opaque
    } else {
        wgpu::CompositeAlphaMode::Auto
    };
    wgpu::SurfaceConfiguration {
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        format,
        color_space: wgpu::SurfaceColorSpace::Auto,
        width: spec.width_px,
        height: spec.height_px,
        present_mode: wgpu::PresentMode::Fifo,
        desired_maximum_frame_latency: 1,
        alpha_mode,
        view_formats: if view_format == format {
            vec![]
        } else {
            vec![view_format]
        },
    }
}

/// Warns when an output deeper than 8 bits gets an 8-bit surface, and what it costs.
fn warn_if_shallow(spec: &OutputSpec, shown: u32, offered: &[wgpu::TextureFormat]) {
    if spec.surface_bit_depth > shown {
        tracing::warn!(
            "output {}: its surface depth is {} bit but the window's surface offers only {shown} \
             bit per channel ({offered:?}): each code is rounded to the nearest {shown}-bit \
             value, so {} neighbouring codes show the same level and fine steps of the \
             calibration are lost; enable 10-bit output (e.g. X11 DefaultDepth 30) or declare \
             the output's surface depth as {shown} (NAME=WxH@BITS/{shown})",
            spec.name,
            spec.surface_bit_depth,
            1u32 << (spec.surface_bit_depth - shown).min(16)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::TextureFormat as F;

    #[test]
    fn ten_bit_is_chosen_only_when_needed_and_offered_and_srgb_last() {
        let all = [F::Bgra8UnormSrgb, F::Bgra8Unorm, F::Rgb10a2Unorm];
        assert_eq!(choose_format(&all, 10), Some((F::Rgb10a2Unorm, 10)));
        assert_eq!(choose_format(&all, 8), Some((F::Bgra8Unorm, 8)));
        assert_eq!(choose_format(&all[..2], 10), Some((F::Bgra8Unorm, 8)));
        assert_eq!(
            choose_format(&[F::Rgba8UnormSrgb], 8),
            Some((F::Rgba8UnormSrgb, 8))
        );
        assert_eq!(choose_format(&[F::Rgba16Float], 8), None);
    }
}
