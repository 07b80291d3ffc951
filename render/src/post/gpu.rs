//! The post pass as a wgpu compute shader (WGSL), headless.
//!
//! Two pipeline variants are built from `post.wgsl`: one with the flat-field texture
//! (`flat_texture.wgsl`, a storage buffer read with the same bilinear arithmetic as the
//! CPU path) and one without (`flat_none.wgsl`: no binding, no fetch, no division). A
//! profile without a texture runs the second. Frames go up in bands of rows so that no
//! buffer exceeds the adapter's storage-buffer limit.

use std::sync::mpsc;

use lumiwall_profiles::OutOfGamut;
use lumiwall_profiles::apply::{MAX_INPUT_CD_M2, PreparedProfile};
use wgpu::util::DeviceExt;

use super::{CodeImage, FlagCounts, PostError, XyzFrame};

const SHADER_MAIN: &str = include_str!("post.wgsl");
const SHADER_FLAT: &str = include_str!("flat_texture.wgsl");
const SHADER_NONE: &str = include_str!("flat_none.wgsl");
const WORKGROUP: u32 = 256;

/// Uniform block of the shader (layout of `Params` in `post.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    m: [[f32; 4]; 3],
    offset: [f32; 4],
    white_dir: [f32; 4],
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

/// A headless GPU device with the two post-pass pipelines.
pub struct GpuPost {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    with_flat: wgpu::ComputePipeline,
    without_flat: wgpu::ComputePipeline,
    max_band_pixels: usize,
}

fn pipeline(device: &wgpu::Device, variant: &str, label: &str) -> wgpu::ComputePipeline {
    let source = format!("{SHADER_MAIN}\n{variant}");
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: wgpu::PipelineCompilationOptions::default(),
        cache: None,
    })
}

impl GpuPost {
    /// Opens the first GPU adapter (hardware preferred, software such as Mesa's lavapipe
    /// accepted). [`PostError::NoAdapter`] when there is none.
    pub fn new() -> Result<Self, PostError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            ..Default::default()
        }))
        .map_err(|_| PostError::NoAdapter)?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("lumiwall post pass"),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| PostError::Gpu(format!("cannot open device on {}: {e}", info.name)))?;
        device.on_uncaptured_error(std::sync::Arc::new(|e| {
            tracing::error!("wgpu: {e}");
        }));
        let with_flat = pipeline(&device, SHADER_FLAT, "post pass (flat field)");
        let without_flat = pipeline(&device, SHADER_NONE, "post pass (no flat field)");
        // Input is 12 bytes per pixel; keep every binding well under the limits.
        let max_binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
            .min(256 << 20);
        let by_groups =
            u64::from(limits.max_compute_workgroups_per_dimension) * u64::from(WORKGROUP);
        let max_band_pixels = (max_binding / 12).min(by_groups).min(4 << 20) as usize;
        Ok(GpuPost {
            device,
            queue,
            info,
            with_flat,
            without_flat,
            max_band_pixels,
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

    /// Runs the post pass over a whole frame for one display.
    pub fn apply(&self, pp: &PreparedProfile, frame: &XyzFrame) -> Result<CodeImage, PostError> {
        let w = frame.width as usize;
        let n = frame.pixels.len();
        let mut codes = vec![[0u16; 3]; n];
        let mut flags = vec![0u8; n];
        let mut counts = FlagCounts::default();
        if n == 0 {
            return Ok(CodeImage {
                width: frame.width,
                height: frame.height,
                bit_depth: pp.bit_depth,
                codes,
                flags,
                counts,
            });
        }
        let rows_per_band = (self.max_band_pixels / w).max(1);
        if w > self.max_band_pixels {
            return Err(PostError::SizeMismatch(format!(
                "a row of {w} pixels is too wide for this GPU's buffers"
            )));
        }
        let band_pixels = rows_per_band * w;

        // LUTs: bases then slopes of R, G, B in one buffer.
        let mut lut = Vec::new();
        let mut base = [0u32; 4];
        let mut slope = [0u32; 4];
        let mut len = [0u32; 4];
        let mut scale = [0f32; 4];
        for c in 0..3 {
            base[c] = lut.len() as u32;
            lut.extend_from_slice(&pp.luts[c].base);
            slope[c] = lut.len() as u32;
            lut.extend_from_slice(&pp.luts[c].slope);
            len[c] = pp.luts[c].base.len() as u32;
            scale[c] = pp.luts[c].scale;
        }
        let dev = &self.device;
        let storage = |label: &str, bytes: &[u8]| {
            dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let lut_buf = storage("post lut", bytemuck::cast_slice(&lut));
        let flat_buf = pp.flat.as_ref().map(|ff| {
            let texels: Vec<f32> = ff.gain.iter().flatten().copied().collect();
            storage("post flat field", bytemuck::cast_slice(&texels))
        });
        let in_buf = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("post input"),
            size: (band_pixels * 12) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let out_size = (band_pixels * 8) as u64;
        let out_buf = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("post codes"),
            size: out_size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let read_buf = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("post readback"),
            size: out_size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let m = pp.matrix;
        let mut params = Params {
            m: [
                [m[0][0], m[0][1], m[0][2], 0.0],
                [m[1][0], m[1][1], m[1][2], 0.0],
                [m[2][0], m[2][1], m[2][2], 0.0],
            ],
            offset: [pp.offset[0], pp.offset[1], pp.offset[2], 0.0],
            white_dir: [pp.white_dir[0], pp.white_dir[1], pp.white_dir[2], 0.0],
            lut_scale: scale,
            lut_len: len,
            lut_base: base,
            lut_slope: slope,
            width: frame.width,
            height: frame.height,
            row0: 0,
            npix: 0,
            max_code: pp.max_code(),
            dither: u32::from(pp.dither),
            false_colour: u32::from(pp.out_of_gamut == OutOfGamut::FalseColour),
            flat_w: pp.flat.as_ref().map_or(1, |f| f.width),
            flat_h: pp.flat.as_ref().map_or(1, |f| f.height),
            max_input: MAX_INPUT_CD_M2,
            pad: [0; 2],
        };
        let param_buf = dev.create_buffer(&wgpu::BufferDescriptor {
            label: Some("post params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pipeline = if flat_buf.is_some() {
            &self.with_flat
        } else {
            &self.without_flat
        };
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: param_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: in_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: lut_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: out_buf.as_entire_binding(),
            },
        ];
        if let Some(fb) = &flat_buf {
            entries.push(wgpu::BindGroupEntry {
                binding: 4,
                resource: fb.as_entire_binding(),
            });
        }
        let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("post bind group"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        let max_groups = self.device.limits().max_compute_workgroups_per_dimension;

        let mut row0 = 0usize;
        while row0 < frame.height as usize {
            let rows = rows_per_band.min(frame.height as usize - row0);
            let npix = rows * w;
            let start = row0 * w;
            params.row0 = row0 as u32;
            params.npix = npix as u32;
            self.queue
                .write_buffer(&param_buf, 0, bytemuck::bytes_of(&params));
            self.queue.write_buffer(
                &in_buf,
                0,
                bytemuck::cast_slice(&frame.pixels[start..start + npix]),
            );
            let groups = (npix as u32).div_ceil(WORKGROUP);
            let gx = groups.min(max_groups);
            let gy = groups.div_ceil(gx);
            let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("post pass"),
            });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("post pass"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &bind, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            }
            let bytes = (npix * 8) as u64;
            enc.copy_buffer_to_buffer(&out_buf, 0, &read_buf, 0, bytes);
            self.queue.submit([enc.finish()]);
            let (tx, rx) = mpsc::channel();
            read_buf.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
                let _ = tx.send(r);
            });
            self.device
                .poll(wgpu::PollType::Wait {
                    submission_index: None,
                    timeout: None,
                })
                .map_err(|e| PostError::Gpu(format!("waiting for the GPU: {e}")))?;
            rx.recv()
                .map_err(|e| PostError::Gpu(format!("readback lost: {e}")))?
                .map_err(|e| PostError::Gpu(format!("readback failed: {e}")))?;
            {
                let view = read_buf
                    .get_mapped_range(0..bytes)
                    .map_err(|e| PostError::Gpu(format!("readback mapping: {e}")))?;
                let words: &[u32] = bytemuck::cast_slice(&view);
                for (i, pair) in words.chunks_exact(2).enumerate() {
                    let (rg, bf) = (pair[0], pair[1]);
                    codes[start + i] = [
                        (rg & 0xffff) as u16,
                        (rg >> 16) as u16,
                        (bf & 0xffff) as u16,
                    ];
                    let f = (bf >> 16) as u8;
                    flags[start + i] = f;
                    counts.add(lumiwall_profiles::apply::PixelFlags(u32::from(f)));
                }
            }
            read_buf.unmap();
            row0 += rows;
        }
        Ok(CodeImage {
            width: frame.width,
            height: frame.height,
            bit_depth: pp.bit_depth,
            codes,
            flags,
            counts,
        })
    }
}
