//! The post pass as a wgpu compute shader (WGSL), headless.
//!
//! Two pipeline variants are built from `post.wgsl`: one with the flat-field texture
//! (`flat_texture.wgsl`, a storage buffer read with the same bilinear arithmetic as the
//! CPU path) and one without (`flat_none.wgsl`: no binding, no fetch, no division). A
//! profile without a texture runs the second. Frames go up in bands of rows so that no
//! buffer exceeds the adapter's storage-buffer limit.
//!
//! Resources live as long as what they depend on: the device, pipelines and bind-group
//! layouts in [`GpuPost`] (once); the uniform block, LUT and flat-field buffers of one
//! profile in a [`GpuProfile`] (once per profile, from [`GpuPost::prepare`]); the band
//! buffers and the bind group in its band cache, reused while the frame width is
//! unchanged.

use std::sync::mpsc;

use lumiwall_profiles::OutOfGamut;
use lumiwall_profiles::apply::{MAX_INPUT_CD_M2, PreparedProfile};
use wgpu::util::DeviceExt;

use super::{CodeImage, FlagCounts, PostError, XyzFrame};

const SHADER_MAIN: &str = include_str!("post.wgsl");
const SHADER_FLAT: &str = include_str!("flat_texture.wgsl");
const SHADER_NONE: &str = include_str!("flat_none.wgsl");
const WORKGROUP: u32 = 256;

/// Uniform block of the shader. Mirrored field by field by `struct Params` in
/// `post.wgsl` (WGSL cannot share the Rust definition): change both together. `m` is the
/// shader's `m0`, `m1`, `m2`; `pad` its `pad0`, `pad1` (16-byte alignment).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    m: [[f32; 4]; 3],
    offset: [f32; 4],
    white_dir: [f32; 4],
    white_u: [f32; 4],
    white_k: [f32; 4],
    lut_scale: [f32; 4],
    lut_len: [u32; 4],
    lut_base: [u32; 4],
    lut_slope: [u32; 4],
    width: u32,
    height: u32,
    row0: u32,
    npix: u32,
    max_code: u32,
    dither: u32,
    false_colour: u32,
    flat_w: u32,
    flat_h: u32,
    max_input: f32,
    pad: [u32; 2],
}

/// The three inverse LUTs packed into one buffer: bases then slopes of R, G, B, with
/// each table's offset, length and scale for the uniform block.
struct PackedLuts {
    data: Vec<f32>,
    base: [u32; 4],
    slope: [u32; 4],
    len: [u32; 4],
    scale: [f32; 4],
}

impl PackedLuts {
    fn new(pp: &PreparedProfile) -> Self {
        let mut packed = PackedLuts {
            data: Vec::new(),
            base: [0; 4],
            slope: [0; 4],
            len: [0; 4],
            scale: [0.0; 4],
        };
        for (c, lut) in pp.luts.iter().enumerate() {
            packed.base[c] = packed.data.len() as u32;
            packed.data.extend_from_slice(&lut.base);
            packed.slope[c] = packed.data.len() as u32;
            packed.data.extend_from_slice(&lut.slope);
            packed.len[c] = lut.base.len() as u32;
            packed.scale[c] = lut.scale;
        }
        packed
    }
}

impl Params {
    /// The profile's part of the block; frame size and band are set per dispatch.
    fn for_profile(pp: &PreparedProfile, luts: &PackedLuts) -> Self {
        let m = pp.matrix;
        let xyz0 = |v: [f32; 3]| [v[0], v[1], v[2], 0.0];
        Params {
            m: [xyz0(m[0]), xyz0(m[1]), xyz0(m[2])],
            offset: xyz0(pp.offset),
            white_dir: xyz0(pp.white_dir),
            white_u: xyz0(pp.white_u),
            white_k: xyz0(pp.white_k),
            lut_scale: luts.scale,
            lut_len: luts.len,
            lut_base: luts.base,
            lut_slope: luts.slope,
            width: 0,
            height: 0,
            row0: 0,
            npix: 0,
            max_code: pp.max_code(),
            dither: u32::from(pp.dither),
            false_colour: u32::from(pp.out_of_gamut == OutOfGamut::FalseColour),
            flat_w: pp.flat.as_ref().map_or(1, |f| f.width),
            flat_h: pp.flat.as_ref().map_or(1, |f| f.height),
            max_input: MAX_INPUT_CD_M2,
            pad: [0; 2],
        }
    }
}

/// One shader variant: its pipeline and the layout of its bind group 0.
struct Variant {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

impl Variant {
    fn new(device: &wgpu::Device, flat_source: &str, label: &str) -> Self {
        let source = format!("{SHADER_MAIN}\n{flat_source}");
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: wgpu::PipelineCompilationOptions::default(),
            cache: None,
        });
        let layout = pipeline.get_bind_group_layout(0);
        Variant { pipeline, layout }
    }
}

/// A headless GPU device with the two post-pass pipelines.
pub struct GpuPost {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    with_flat: Variant,
    without_flat: Variant,
    max_band_pixels: usize,
    max_groups: u32,
}

/// Opens the first GPU adapter (hardware preferred, software such as Mesa's lavapipe
/// accepted) with its full limits: the device, its queue and what it is.
/// [`PostError::NoAdapter`] when there is none.
pub(crate) fn open_device(
    label: &str,
) -> Result<(wgpu::Device, wgpu::Queue, wgpu::AdapterInfo), PostError> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        ..Default::default()
    }))
    .map_err(|_| PostError::NoAdapter)?;
    let info = adapter.get_info();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some(label),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| PostError::Gpu(format!("cannot open device on {}: {e}", info.name)))?;
    device.on_uncaptured_error(std::sync::Arc::new(|e| {
        tracing::error!("wgpu: {e}");
    }));
    Ok((device, queue, info))
}

impl GpuPost {
    /// Opens the first GPU adapter (hardware preferred, software such as Mesa's lavapipe
    /// accepted). [`PostError::NoAdapter`] when there is none.
    pub fn new() -> Result<Self, PostError> {
        let (device, queue, info) = open_device("lumiwall post pass")?;
        let limits = device.limits();
        let with_flat = Variant::new(&device, SHADER_FLAT, "post pass (flat field)");
        let without_flat = Variant::new(&device, SHADER_NONE, "post pass (no flat field)");
        // Input is 12 bytes per pixel; keep every binding well under the limits.
        let max_binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
            .min(256 << 20);
        let by_groups =
            u64::from(limits.max_compute_workgroups_per_dimension) * u64::from(WORKGROUP);
        let max_band_pixels = (max_binding / INPUT_BYTES_PER_PIXEL as u64)
            .min(by_groups)
            .min(4 << 20) as usize;
        Ok(GpuPost {
            device,
            queue,
            info,
            with_flat,
            without_flat,
            max_band_pixels,
            max_groups: limits.max_compute_workgroups_per_dimension,
        })
    }

    /// Name and backend of the adapter, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)".
    pub fn adapter_name(&self) -> String {
        format!("{} ({:?})", self.info.name, self.info.backend)
    }

    /// True for a software rasteriser (lavapipe, llvmpipe, WARP).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Uploads one display's profile: its uniform block, LUTs and flat-field texture.
    /// Keep the result to run many frames through the same profile.
    pub fn prepare(&self, pp: &PreparedProfile) -> GpuProfile<'_> {
        let storage = |label: &str, bytes: &[u8]| {
            self.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: bytes,
                    usage: wgpu::BufferUsages::STORAGE,
                })
        };
        let luts = PackedLuts::new(pp);
        let lut_buf = storage("post lut", bytemuck::cast_slice(&luts.data));
        let flat_buf = pp.flat.as_ref().map(|ff| {
            let texels: Vec<f32> = ff.gain.iter().flatten().copied().collect();
            storage("post flat field", bytemuck::cast_slice(&texels))
        });
        let param_buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("post params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        GpuProfile {
            gpu: self,
            params: Params::for_profile(pp, &luts),
            bit_depth: pp.bit_depth,
            param_buf,
            lut_buf,
            flat_buf,
            band: None,
        }
    }

    /// Runs the post pass over a whole frame for one display (uploading the profile for
    /// this frame only; use [`GpuPost::prepare`] for many frames).
    pub fn apply(&self, pp: &PreparedProfile, frame: &XyzFrame) -> Result<CodeImage, PostError> {
        self.prepare(pp).apply(frame)
    }

    fn storage_buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: false,
        })
    }

    /// Waits for the GPU to finish what was submitted.
    fn wait(&self) -> Result<(), PostError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .map(|_| ())
            .map_err(|e| PostError::Gpu(format!("waiting for the GPU: {e}")))
    }
}

/// Bytes of one input pixel (X, Y, Z as f32).
const INPUT_BYTES_PER_PIXEL: usize = 12;
/// Bytes of one output pixel (R, G packed in one u32; B and the flags in another).
const OUTPUT_BYTES_PER_PIXEL: usize = 8;

/// The buffers of one band of rows and the bind group that ties them to a profile's.
struct Band {
    width: u32,
    rows: usize,
    input: wgpu::Buffer,
    output: wgpu::Buffer,
    readback: wgpu::Buffer,
    bind: wgpu::BindGroup,
}

/// One display's profile on the GPU: built once by [`GpuPost::prepare`], then any number
/// of frames through [`GpuProfile::apply`].
pub struct GpuProfile<'g> {
    gpu: &'g GpuPost,
    params: Params,
    bit_depth: u32,
    param_buf: wgpu::Buffer,
    lut_buf: wgpu::Buffer,
    flat_buf: Option<wgpu::Buffer>,
    /// Band buffers of the last frame width.
    band: Option<Band>,
}

impl GpuProfile<'_> {
    /// Runs the post pass over a whole frame.
    pub fn apply(&mut self, frame: &XyzFrame) -> Result<CodeImage, PostError> {
        let n = frame.pixels.len();
        let mut img = CodeImage {
            width: frame.width,
            height: frame.height,
            bit_depth: self.bit_depth,
            codes: vec![[0u16; 3]; n],
            flags: vec![0u8; n],
            counts: FlagCounts::default(),
        };
        if n == 0 {
            return Ok(img);
        }
        let w = frame.width as usize;
        if w > self.gpu.max_band_pixels {
            return Err(PostError::SizeMismatch(format!(
                "a row of {w} pixels is too wide for this GPU's buffers"
            )));
        }
        self.ensure_band(frame.width);
        self.params.width = frame.width;
        self.params.height = frame.height;
        let rows_per_band = self.band.as_ref().map_or(1, |b| b.rows);
        let mut row0 = 0usize;
        while row0 < frame.height as usize {
            let rows = rows_per_band.min(frame.height as usize - row0);
            self.run_band(frame, row0, rows, &mut img)?;
            row0 += rows;
        }
        Ok(img)
    }

    fn variant(&self) -> &Variant {
        if self.flat_buf.is_some() {
            &self.gpu.with_flat
        } else {
            &self.gpu.without_flat
        }
    }

    /// (Re)builds the band buffers and bind group unless they fit frames `width` wide.
    fn ensure_band(&mut self, width: u32) {
        if self.band.as_ref().is_some_and(|b| b.width == width) {
            return;
        }
        let gpu = self.gpu;
        let rows = (gpu.max_band_pixels / width as usize).max(1);
        let band_pixels = rows * width as usize;
        let out_size = (band_pixels * OUTPUT_BYTES_PER_PIXEL) as u64;
        use wgpu::BufferUsages as U;
        let input = gpu.storage_buffer(
            "post input",
            (band_pixels * INPUT_BYTES_PER_PIXEL) as u64,
            U::STORAGE | U::COPY_DST,
        );
        let output = gpu.storage_buffer("post codes", out_size, U::STORAGE | U::COPY_SRC);
        let readback = gpu.storage_buffer("post readback", out_size, U::MAP_READ | U::COPY_DST);
        let bind = self.bind_group(&input, &output);
        self.band = Some(Band {
            width,
            rows,
            input,
            output,
            readback,
            bind,
        });
    }

    fn bind_group_entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
        wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        }
    }

    fn bind_group(&self, input: &wgpu::Buffer, output: &wgpu::Buffer) -> wgpu::BindGroup {
        let entry = Self::bind_group_entry;
        let mut entries = vec![
            entry(0, &self.param_buf),
            entry(1, input),
            entry(2, &self.lut_buf),
            entry(3, output),
        ];
        if let Some(flat) = &self.flat_buf {
            entries.push(entry(4, flat));
        }
        self.gpu
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("post bind group"),
                layout: &self.variant().layout,
                entries: &entries,
            })
    }

    /// Uploads, runs and reads back `rows` rows from `row0` into `img`.
    fn run_band(
        &mut self,
        frame: &XyzFrame,
        row0: usize,
        rows: usize,
        img: &mut CodeImage,
    ) -> Result<(), PostError> {
        let w = frame.width as usize;
        let (start, npix) = (row0 * w, rows * w);
        self.params.row0 = row0 as u32;
        self.params.npix = npix as u32;
        let band = self.band.as_ref().expect("ensure_band ran");
        let queue = &self.gpu.queue;
        queue.write_buffer(&self.param_buf, 0, bytemuck::bytes_of(&self.params));
        queue.write_buffer(
            &band.input,
            0,
            bytemuck::cast_slice(&frame.pixels[start..start + npix]),
        );
        let bytes = (npix * OUTPUT_BYTES_PER_PIXEL) as u64;
        self.dispatch(band, npix, bytes);
        self.read_back(band, bytes, start, img)
    }

    /// Records and submits the compute pass of `npix` pixels and the copy of their codes
    /// into the readback buffer.
    fn dispatch(&self, band: &Band, npix: usize, bytes: u64) {
        let groups = (npix as u32).div_ceil(WORKGROUP);
        let gx = groups.min(self.gpu.max_groups);
        let gy = groups.div_ceil(gx);
        let device = &self.gpu.device;
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("post pass"),
        });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("post pass"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.variant().pipeline);
            pass.set_bind_group(0, &band.bind, &[]);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        enc.copy_buffer_to_buffer(&band.output, 0, &band.readback, 0, bytes);
        self.gpu.queue.submit([enc.finish()]);
    }

    /// Maps the readback buffer and unpacks its codes and flags into `img` from pixel
    /// `start` on.
    fn read_back(
        &self,
        band: &Band,
        bytes: u64,
        start: usize,
        img: &mut CodeImage,
    ) -> Result<(), PostError> {
        let (tx, rx) = mpsc::channel();
        band.readback
            .map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
                let _ = tx.send(r);
            });
        self.gpu.wait()?;
        rx.recv()
            .map_err(|e| PostError::Gpu(format!("readback lost: {e}")))?
            .map_err(|e| PostError::Gpu(format!("readback failed: {e}")))?;
        {
            let view = band
                .readback
                .get_mapped_range(0..bytes)
                .map_err(|e| PostError::Gpu(format!("readback mapping: {e}")))?;
            unpack(bytemuck::cast_slice(&view), start, img);
        }
        band.readback.unmap();
        Ok(())
    }
}

/// Unpacks the shader's output words (`R | G << 16`, `B | flags << 16` per pixel) into
/// `img` from pixel `start` on.
fn unpack(words: &[u32], start: usize, img: &mut CodeImage) {
    for (i, pair) in words.chunks_exact(2).enumerate() {
        let (rg, bf) = (pair[0], pair[1]);
        img.codes[start + i] = [
            (rg & 0xffff) as u16,
            (rg >> 16) as u16,
            (bf & 0xffff) as u16,
        ];
        let f = (bf >> 16) as u8;
        img.flags[start + i] = f;
        img.counts
            .add(lumiwall_profiles::apply::PixelFlags(u32::from(f)));
    }
}
