//! The wgpu rasteriser of [`super::render_tile`]: the lit mesh uploaded once, then one
//! render pass per display and eye with that tile's off-axis projection (a 4×4 matrix
//! built from [`OffAxis`], Kooima's generalised perspective projection), a 32-bit depth
//! buffer, XYZ interpolated perspective-correctly into an `Rgba32Float` target, read
//! back for the post pass. Faces turned away from the eye are culled (counter-clockwise
//! seen from the lit side, as [`LitMesh`] winds them). The CPU rasteriser stays the
//! reference: the two agree to f32 rounding inside triangles (test); pixels on a
//! triangle's edge may go to either neighbour.

use std::sync::mpsc;

use wgpu::util::DeviceExt;

use super::{LitMesh, OffAxis};
use crate::post::PostError;

const SHADER: &str = r#"
struct Params { m: mat4x4<f32> };
@group(0) @binding(0) var<uniform> params: Params;

struct Out {
    @builtin(position) pos: vec4<f32>,
    @location(0) xyz: vec3<f32>,
};

@vertex
fn vs(@location(0) p: vec3<f32>, @location(1) xyz: vec3<f32>) -> Out {
    var o: Out;
    o.pos = params.m * vec4<f32>(p, 1.0);
    o.xyz = xyz;
    return o;
}

@fragment
fn fs(i: Out) -> @location(0) vec4<f32> {
    return vec4<f32>(i.xyz, 1.0);
}
"#;

/// Bytes per vertex: position and XYZ, six f32.
const VERTEX_BYTES: u64 = 24;

/// A headless wgpu device with the view pipeline and one uploaded mesh.
pub struct GpuRaster {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    pipeline: wgpu::RenderPipeline,
    vertices: wgpu::Buffer,
    vertex_count: u32,
    /// Farthest distance of a vertex from the mesh's bounding-box centre plus that
    /// centre, for the far plane.
    centre: [f64; 3],
    radius: f64,
}

impl GpuRaster {
    /// Opens the first adapter (hardware preferred, lavapipe accepted) and uploads
    /// `mesh`, its faces fanned into triangles.
    pub fn new(mesh: &LitMesh) -> Result<Self, PostError> {
        let (device, queue, info) = crate::post::gpu::open_device("lumiwall view")?;
        let data = triangles(mesh);
        let bytes = data.len() as u64 * 4;
        if bytes > device.limits().max_buffer_size {
            return Err(PostError::Gpu(format!(
                "a mesh of {} triangles does not fit this GPU's buffers",
                data.len() as u64 * 4 / (3 * VERTEX_BYTES)
            )));
        }
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("view mesh"),
            contents: bytemuck::cast_slice(&data),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let pipeline = pipeline(&device);
        let (centre, radius) = bounds(mesh);
        Ok(Self {
            device,
            queue,
            info,
            pipeline,
            vertices,
            vertex_count: (bytes / VERTEX_BYTES) as u32,
            centre,
            radius,
        })
    }

    /// Name and backend of the adapter.
    pub fn adapter_name(&self) -> String {
        format!("{} ({:?})", self.info.name, self.info.backend)
    }

    /// The mesh through `view`: XYZ per pixel (cd/m²), row major from the top-left,
    /// background 0, as [`super::render_tile`] gives it.
    pub fn render(&self, view: &OffAxis) -> Result<Vec<[f32; 3]>, PostError> {
        let (w, h) = (view.width_px as u32, view.height_px as u32);
        let max = self.device.limits().max_texture_dimension_2d;
        if w == 0 || h == 0 || w > max || h > max {
            return Err(PostError::SizeMismatch(format!(
                "{w}×{h} px: this GPU renders at most {max} px each way"
            )));
        }
        let matrix = projection(view, self.near_far(view));
        let params = self
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("view projection"),
                contents: bytemuck::cast_slice(&matrix),
                usage: wgpu::BufferUsages::UNIFORM,
            });
        let bind = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view projection"),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: params.as_entire_binding(),
            }],
        });
        let target = self.texture(w, h, wgpu::TextureFormat::Rgba32Float, true);
        let depth = self.texture(w, h, wgpu::TextureFormat::Depth32Float, false);
        let row_bytes = (w * 16).div_ceil(256) * 256;
        if u64::from(row_bytes) * u64::from(h) > self.device.limits().max_buffer_size {
            return Err(PostError::SizeMismatch(format!(
                "{w}×{h} px of 16 bytes each do not fit this GPU's largest buffer"
            )));
        }
        let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view readback"),
            size: u64::from(row_bytes) * u64::from(h),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("view"),
            });
        self.draw(&mut encoder, &target, &depth, &bind);
        encoder.copy_texture_to_buffer(
            target.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row_bytes),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        self.queue.submit([encoder.finish()]);
        self.read(&readback, w as usize, h as usize, row_bytes as usize)
    }

    /// Near and far plane distances (m along the screen normal) that hold the mesh.
    fn near_far(&self, view: &OffAxis) -> (f64, f64) {
        let c = crate::scene::V3::from(self.centre);
        let depth = -(c - view.eye).dot(&view.normal);
        let far = (depth + self.radius).max(2.0 * super::NEAR_M) * 1.01;
        let near = ((depth - self.radius) * 0.5).clamp(super::NEAR_M, far * 0.5);
        (near, far)
    }

    fn texture(&self, w: u32, h: u32, format: wgpu::TextureFormat, copy: bool) -> wgpu::Texture {
        let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
        if copy {
            usage |= wgpu::TextureUsages::COPY_SRC;
        }
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("view target"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    }

    fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::Texture,
        depth: &wgpu::Texture,
        bind: &wgpu::BindGroup,
    ) {
        let color_view = target.create_view(&wgpu::TextureViewDescriptor::default());
        let depth_view = depth.create_view(&wgpu::TextureViewDescriptor::default());
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("view"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        if self.vertex_count == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.draw(0..self.vertex_count, 0..1);
    }

    fn read(
        &self,
        readback: &wgpu::Buffer,
        w: usize,
        h: usize,
        row_bytes: usize,
    ) -> Result<Vec<[f32; 3]>, PostError> {
        let (tx, rx) = mpsc::channel();
        readback.map_async(wgpu::MapMode::Read, .., move |r| {
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
        let mut out = Vec::with_capacity(w * h);
        {
            let view = readback
                .get_mapped_range(..)
                .map_err(|e| PostError::Gpu(format!("readback mapping: {e}")))?;
            for row in view.chunks(row_bytes).take(h) {
                let texels: &[f32] = bytemuck::cast_slice(&row[..w * 16]);
                out.extend(texels.chunks(4).map(|t| [t[0], t[1], t[2]]));
            }
        }
        readback.unmap();
        Ok(out)
    }
}

fn pipeline(device: &wgpu::Device) -> wgpu::RenderPipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("view"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("view"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: VERTEX_BYTES,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &attributes,
            })],
        },
        primitive: wgpu::PrimitiveState {
            front_face: wgpu::FrontFace::Ccw,
            cull_mode: Some(wgpu::Face::Back),
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        }),
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: wgpu::TextureFormat::Rgba32Float,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The faces fanned into triangles: position and XYZ per vertex, f32.
fn triangles(mesh: &LitMesh) -> Vec<f32> {
    let mut out = Vec::new();
    for face in &mesh.faces {
        for t in 1..face.len().saturating_sub(1) {
            for k in [face[0], face[t], face[t + 1]] {
                let p = mesh.positions[k as usize];
                let l = mesh.luminance_xyz[k as usize];
                out.extend([p.x, p.y, p.z, l[0], l[1], l[2]].map(|v| v as f32));
            }
        }
    }
    out
}

/// Centre of the mesh's bounding box and the largest distance of a vertex from it.
fn bounds(mesh: &LitMesh) -> ([f64; 3], f64) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for (k, v) in [p.x, p.y, p.z].into_iter().enumerate() {
            lo[k] = lo[k].min(v);
            hi[k] = hi[k].max(v);
        }
    }
    if mesh.positions.is_empty() {
        return ([0.0; 3], 1.0);
    }
    let c: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let r = mesh
        .positions
        .iter()
        .map(|p| ((p.x - c[0]).powi(2) + (p.y - c[1]).powi(2) + (p.z - c[2]).powi(2)).sqrt())
        .fold(0.0, f64::max);
    (c, r)
}

/// Column-major clip matrix of `view` with depth in `near..far` mapped to 0..1:
/// clip = P·V·(p, 1) with view coordinates `x = (p − eye)·right`, `y = (p − eye)·up`,
/// `z = (p − eye)·normal` (negative in front of the eye) and the tile's edges seen
/// from the eye at `l, r, b, t` on the screen plane `d` away.
pub fn projection(view: &OffAxis, (near, far): (f64, f64)) -> [f32; 16] {
    let to_corner = view.corner - view.eye;
    let d = -to_corner.dot(&view.normal);
    let l = to_corner.dot(&view.right);
    let r = l + view.width_m;
    let b = to_corner.dot(&view.up);
    let t = b + view.height_m;
    // Rows of P acting on (x, y, z, 1) in view coordinates.
    let px = [2.0 * d / (r - l), 0.0, (r + l) / (r - l), 0.0];
    let py = [0.0, 2.0 * d / (t - b), (t + b) / (t - b), 0.0];
    let pz = [0.0, 0.0, -far / (far - near), -far * near / (far - near)];
    let pw = [0.0, 0.0, -1.0, 0.0];
    // V's rows: right, up, normal with the eye's translation.
    let e = view.eye;
    let v = [
        [
            view.right.x,
            view.right.y,
            view.right.z,
            -view.right.dot(&e),
        ],
        [view.up.x, view.up.y, view.up.z, -view.up.dot(&e)],
        [
            view.normal.x,
            view.normal.y,
            view.normal.z,
            -view.normal.dot(&e),
        ],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let p = [px, py, pz, pw];
    let mut m = [0f32; 16];
    for col in 0..4 {
        for row in 0..4 {
            let s: f64 = (0..4).map(|k| p[row][k] * v[k][col]).sum();
            m[col * 4 + row] = s as f32;
        }
    }
    m
}
