//! The voxel GI on wgpu compute passes: voxelisation, OR-mipmaps, ray traversal and
//! shading (`voxel_build.wgsl`, `voxel_trace.wgsl`), with the CPU code of
//! [`super::voxelize`], [`super::trace`] and [`super::gi::shade`] as reference.

use std::sync::mpsc;
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::gi::{GiError, GiFrame, GiLight, GiOptions, GiView, Prepared, prepare};
use super::grid::VoxelGrid;
use super::voxelize::voxel_box;
use crate::scene::{Camera, Scene};

const BUILD_SHADER: &str = include_str!("voxel_build.wgsl");
const TRACE_SHADER: &str = include_str!("voxel_trace.wgsl");
const WORKGROUP: u32 = 64;
/// Levels the shaders' offset table holds (1024³ has 11).
const MAX_LEVELS: usize = 12;

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct BuildParams {
    n: u32,
    levels: u32,
    count: u32,
    level: u32,
    offsets: [[u32; 4]; 3],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct TraceParams {
    n: u32,
    levels: u32,
    count: u32,
    light_count: u32,
    vpl_count: u32,
    first: u32,
    last: u32,
    point_count: u32,
    inv_voxel: [f32; 4],
    shading: [f32; 4],
    offsets: [[u32; 4]; 3],
}

/// A ray's first set voxel on the GPU: entry t and the voxel, `None` for a miss.
pub type RayHit = Option<(f32, [u32; 3])>;

/// The samples one shading dispatch sums: `[first, last)` of the emitter samples
/// followed by the VPLs.
#[derive(Debug, Clone, Copy, Default)]
struct Samples {
    lights: u32,
    vpls: u32,
    points: u32,
    first: u32,
    last: u32,
}

/// One compute job over `count` items: the pipeline, its inputs and its dispatches.
struct Job<'a> {
    pipe: &'a wgpu::ComputePipeline,
    items: &'a [[f32; 4]],
    count: usize,
    dispatches: &'a [Samples],
    shading: [f32; 4],
    /// The point lights' tables (binding 4 of `shade`).
    tables: Option<&'a [f32]>,
}

/// A GPU device with the voxel GI's four compute pipelines.
pub struct GpuVoxelGi {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    voxelize: wgpu::ComputePipeline,
    mip: wgpu::ComputePipeline,
    trace_rays: wgpu::ComputePipeline,
    shade: wgpu::ComputePipeline,
    max_groups: u32,
    max_binding: u64,
}

/// A voxel hierarchy in GPU memory.
pub struct GpuGrid {
    buffer: wgpu::Buffer,
    words: u64,
    n: u32,
    levels: u32,
    offsets: [[u32; 4]; 3],
    inv_voxel: f32,
}

fn gpu_err(e: impl std::fmt::Display) -> GiError {
    GiError::Gpu(e.to_string())
}

fn pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    entry: &str,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: None,
        module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions::default(),
        cache: None,
    })
}

impl GpuVoxelGi {
    /// Opens the first GPU adapter (hardware preferred, lavapipe accepted).
    pub fn new() -> Result<Self, GiError> {
        let (device, queue, info) =
            crate::post::gpu::open_device("lumiwall voxel GI").map_err(gpu_err)?;
        let module = |src: &str, label: &str| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(src.into()),
            })
        };
        let build = module(BUILD_SHADER, "voxel build");
        let trace = module(TRACE_SHADER, "voxel trace");
        let limits = device.limits();
        Ok(Self {
            voxelize: pipeline(&device, &build, "voxelize"),
            mip: pipeline(&device, &build, "mip"),
            trace_rays: pipeline(&device, &trace, "trace_rays"),
            shade: pipeline(&device, &trace, "shade"),
            max_groups: limits.max_compute_workgroups_per_dimension,
            max_binding: limits
                .max_storage_buffer_binding_size
                .min(limits.max_buffer_size),
            device,
            queue,
            info,
        })
    }

    /// Name and backend of the adapter.
    pub fn adapter_name(&self) -> String {
        format!("{} ({:?})", self.info.name, self.info.backend)
    }

    fn buffer(&self, label: &str, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage,
            })
    }

    fn check_binding(&self, what: &str, bytes: u64) -> Result<(), GiError> {
        if bytes > self.max_binding {
            return Err(GiError::Gpu(format!(
                "{what} needs {bytes} bytes, more than this GPU binds ({}): lower the resolution or the image size",
                self.max_binding
            )));
        }
        Ok(())
    }

    /// Workgroups (x, y) for `invocations`, or an error past the dispatch limits.
    fn groups(&self, invocations: u64) -> Result<(u32, u32), GiError> {
        let groups = invocations.div_ceil(u64::from(WORKGROUP)).max(1);
        let gx = groups.min(u64::from(self.max_groups));
        let gy = groups.div_ceil(gx);
        if gy > u64::from(self.max_groups) {
            return Err(GiError::Gpu(format!(
                "{invocations} invocations exceed the dispatch limits"
            )));
        }
        Ok((gx as u32, gy as u32))
    }

    fn dispatch(
        &self,
        enc: &mut wgpu::CommandEncoder,
        pipe: &wgpu::ComputePipeline,
        entries: &[wgpu::BindGroupEntry],
        invocations: u64,
    ) -> Result<(), GiError> {
        let (gx, gy) = self.groups(invocations)?;
        let bind = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipe.get_bind_group_layout(0),
            entries,
        });
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: None,
            timestamp_writes: None,
        });
        pass.set_pipeline(pipe);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(gx, gy, 1);
        Ok(())
    }

    /// Runs `f` in an error scope: a validation or out-of-memory error of the GPU (a
    /// buffer past a limit, a device without memory) becomes [`GiError::Gpu`] instead
    /// of a log line and an empty result.
    fn scoped<T>(&self, what: &str, f: impl FnOnce() -> Result<T, GiError>) -> Result<T, GiError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let invalid = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let r = f();
        let errors = [
            pollster::block_on(invalid.pop()),
            pollster::block_on(oom.pop()),
        ];
        if let Some(e) = errors.into_iter().flatten().next() {
            return Err(GiError::Gpu(format!("{what}: {e}")));
        }
        r
    }

    fn wait(&self) -> Result<(), GiError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .map(|_| ())
            .map_err(gpu_err)
    }

    /// Copies `bytes` of `src` back to the CPU.
    fn read_back(&self, src: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>, GiError> {
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxel readback"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(src, 0, &staging, 0, bytes);
        self.queue.submit([enc.finish()]);
        let (tx, rx) = mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv().map_err(gpu_err)?.map_err(gpu_err)?;
        let data = staging
            .get_mapped_range(0..bytes)
            .map_err(gpu_err)?
            .to_vec();
        staging.unmap();
        Ok(data)
    }

    /// Voxelises `tris` (world metres) into a grid laid out as `layout` (an empty
    /// [`VoxelGrid`]) and builds its mipmaps, all on the GPU; returns when done.
    pub fn voxelize(&self, layout: &VoxelGrid, tris: &[[[f64; 3]; 3]]) -> Result<GpuGrid, GiError> {
        self.scoped("voxelising on the GPU", || {
            self.voxelize_unscoped(layout, tris)
        })
    }

    fn voxelize_unscoped(
        &self,
        layout: &VoxelGrid,
        tris: &[[[f64; 3]; 3]],
    ) -> Result<GpuGrid, GiError> {
        let (words, offsets) = level_layout(layout);
        self.check_binding("the voxel grid", words * 4)?;
        let grid = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxel grid"),
            size: words * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let (corners, boxes, first_row) = triangle_rows(layout, tris)?;
        self.check_binding("the triangles", corners.len() as u64 * 4)?;
        let total_rows = u64::from(*first_row.last().unwrap_or(&0));
        let mut enc = self.device.create_command_encoder(&Default::default());
        let storage = wgpu::BufferUsages::STORAGE;
        if total_rows > 0 {
            let params = self.build_params(layout, tris.len() as u32, 0, offsets);
            let c = self.buffer("triangles", bytemuck::cast_slice(&corners), storage);
            let b = self.buffer("boxes", bytemuck::cast_slice(&boxes), storage);
            let f = self.buffer("rows", bytemuck::cast_slice(&first_row), storage);
            let entries = [
                entry(0, &params),
                entry(1, &grid),
                entry(2, &c),
                entry(3, &b),
                entry(4, &f),
            ];
            self.dispatch(&mut enc, &self.voxelize, &entries, total_rows)?;
        }
        let levels = layout.level_count() as u32;
        for k in 1..levels {
            let params = self.build_params(layout, 0, k, offsets);
            let m = u64::from(layout.n >> k);
            let entries = [entry(0, &params), entry(1, &grid)];
            self.dispatch(&mut enc, &self.mip, &entries, m * m * m)?;
        }
        self.queue.submit([enc.finish()]);
        self.wait()?;
        Ok(GpuGrid {
            buffer: grid,
            words,
            n: layout.n,
            levels,
            offsets,
            inv_voxel: layout.inv_voxel_f32(),
        })
    }

    fn build_params(
        &self,
        g: &VoxelGrid,
        count: u32,
        level: u32,
        offsets: [[u32; 4]; 3],
    ) -> wgpu::Buffer {
        let p = BuildParams {
            n: g.n,
            levels: g.level_count() as u32,
            count,
            level,
            offsets,
        };
        self.buffer(
            "voxel build params",
            bytemuck::bytes_of(&p),
            wgpu::BufferUsages::UNIFORM,
        )
    }

    fn trace_params(
        &self,
        g: &GpuGrid,
        count: u32,
        samples: Samples,
        shading: [f32; 4],
    ) -> wgpu::Buffer {
        let p = TraceParams {
            n: g.n,
            levels: g.levels,
            count,
            light_count: samples.lights,
            vpl_count: samples.vpls,
            first: samples.first,
            last: samples.last,
            point_count: samples.points,
            inv_voxel: [g.inv_voxel, 0.0, 0.0, 0.0],
            shading,
            offsets: g.offsets,
        };
        self.buffer(
            "voxel trace params",
            bytemuck::bytes_of(&p),
            wgpu::BufferUsages::UNIFORM,
        )
    }

    /// A grid voxelised on the CPU, uploaded as it is.
    pub fn upload(&self, g: &VoxelGrid) -> Result<GpuGrid, GiError> {
        let (words, offsets) = level_layout(g);
        self.check_binding("the voxel grid", words * 4)?;
        let (packed, _) = g.packed();
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        Ok(GpuGrid {
            buffer: self.buffer("voxel grid", bytemuck::cast_slice(&packed), usage),
            words,
            n: g.n,
            levels: g.level_count() as u32,
            offsets,
            inv_voxel: g.inv_voxel_f32(),
        })
    }

    /// Set voxels of level 0 (reads the grid back).
    pub fn occupied_voxels(&self, g: &GpuGrid) -> Result<u64, GiError> {
        let words0 = super::grid::words(g.n);
        let all = self.read_grid(g)?;
        Ok(all[..words0]
            .iter()
            .map(|w| u64::from(w.count_ones()))
            .sum())
    }

    /// The grid's words, all levels (the layout of [`VoxelGrid::packed`]).
    pub fn read_grid(&self, g: &GpuGrid) -> Result<Vec<u32>, GiError> {
        Ok(bytemuck::pod_collect_to_vec(
            &self.read_back(&g.buffer, g.words * 4)?,
        ))
    }

    /// Traces rays (grid coordinates: origin, direction, t_min, t_max) through the
    /// hierarchy: the first set voxel's entry t and the voxel, as [`super::trace`].
    pub fn trace_rays(
        &self,
        g: &GpuGrid,
        rays: &[([f32; 3], [f32; 3], f32, f32)],
    ) -> Result<Vec<RayHit>, GiError> {
        if rays.is_empty() {
            return Ok(Vec::new());
        }
        let items: Vec<[f32; 4]> = rays
            .iter()
            .flat_map(|(o, d, t0, t1)| [[o[0], o[1], o[2], *t0], [d[0], d[1], d[2], *t1]])
            .collect();
        let job = Job {
            pipe: &self.trace_rays,
            items: &items,
            count: rays.len(),
            dispatches: &[Samples::default()],
            shading: [0.0; 4],
            tables: None,
        };
        let out = self.run_items(g, &job)?;
        Ok(out
            .iter()
            .map(|v| (v[0] >= 0.0).then(|| (v[0], [v[1] as u32, v[2] as u32, v[3] as u32])))
            .collect())
    }

    /// Shades every pixel of `view` in `s`'s light (as [`super::gi::shade`]): XYZ in
    /// cd/m².
    pub fn shade(&self, g: &GpuGrid, s: &GiLight, view: &GiView) -> Result<Vec<[f32; 3]>, GiError> {
        let item_count =
            4 * view.surfels.len() + 3 * (s.lights.len() + s.vpls.len()) + 2 * s.points.len();
        self.check_binding("the pixels and samples", item_count as u64 * 16)?;
        let mut items: Vec<[f32; 4]> = Vec::with_capacity(item_count);
        let v4 = |v: [f32; 3]| [v[0], v[1], v[2], 0.0];
        for p in &view.surfels {
            items.extend([v4(p.p), v4(p.n), v4(p.rho), v4(p.le)]);
        }
        for l in &s.lights {
            items.extend([v4(l.p), v4(l.n), v4(l.w)]);
        }
        for v in &s.vpls {
            items.extend([v4(v.p), v4(v.n), v4(v.flux)]);
        }
        for q in &s.points {
            // the table's offset (< 2^24) is exact in f32
            items.extend([[q.p[0], q.p[1], q.p[2], q.table as f32], v4(q.color)]);
        }
        let (lights, vpls, points) = (
            s.lights.len() as u32,
            s.vpls.len() as u32,
            s.points.len() as u32,
        );
        let chunk = super::gi::shade_chunk(g.n) as u32;
        let all = lights + vpls + points;
        let chunks: Vec<Samples> = (0..all.div_ceil(chunk).max(1))
            .map(|c| Samples {
                lights,
                vpls,
                points,
                first: c * chunk,
                last: ((c + 1) * chunk).min(all),
            })
            .collect();
        let shading = [s.offset_m, s.vpl_clamp2_m2, 0.0, 0.0];
        let job = Job {
            pipe: &self.shade,
            items: &items,
            count: view.surfels.len(),
            dispatches: &chunks,
            shading,
            tables: Some(&s.tables),
        };
        let out = self.run_items(g, &job)?;
        let total = all as f32;
        if let Some(k) =
            (0..out.len()).find(|&k| view.surfels[k].n != [0.0; 3] && out[k][3] != total)
        {
            return Err(GiError::Gpu(format!(
                "{} cut the shading of pixel {k} short ({} of {total} samples): its shader \
                 loops are capped; use --cpu",
                self.adapter_name(),
                out[k][3]
            )));
        }
        Ok(out.iter().map(|v| [v[0], v[1], v[2]]).collect())
    }

    fn run_items(&self, g: &GpuGrid, job: &Job<'_>) -> Result<Vec<[f32; 4]>, GiError> {
        self.scoped("computing on the GPU", || self.run_items_unscoped(g, job))
    }

    fn run_items_unscoped(&self, g: &GpuGrid, job: &Job<'_>) -> Result<Vec<[f32; 4]>, GiError> {
        let out_bytes = job.count as u64 * 16;
        self.check_binding("the inputs", job.items.len() as u64 * 16)?;
        self.check_binding("the output", out_bytes)?;
        let storage = wgpu::BufferUsages::STORAGE;
        let input = self.buffer("voxel items", bytemuck::cast_slice(job.items), storage);
        let tables = match job.tables {
            Some(t) => {
                self.check_binding("the light tables", t.len() as u64 * 4)?;
                Some(self.buffer("light tables", bytemuck::cast_slice(t), storage))
            }
            None => None,
        };
        let out = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("voxel out"),
            size: out_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        for samples in job.dispatches {
            let params = self.trace_params(g, job.count as u32, *samples, job.shading);
            let mut entries = vec![
                entry(0, &params),
                entry(1, &g.buffer),
                entry(2, &input),
                entry(3, &out),
            ];
            entries.extend(tables.as_ref().map(|t| entry(4, t)));
            self.dispatch(&mut enc, job.pipe, &entries, job.count as u64)?;
        }
        self.queue.submit([enc.finish()]);
        Ok(bytemuck::pod_collect_to_vec(
            &self.read_back(&out, out_bytes)?,
        ))
    }
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// Words of all levels and each level's first word, as the shaders' offset table.
fn level_layout(g: &VoxelGrid) -> (u64, [[u32; 4]; 3]) {
    let mut offsets = [[0u32; 4]; 3];
    let mut words = 0u64;
    for k in 0..g.level_count().min(MAX_LEVELS) {
        offsets[k / 4][k % 4] = words as u32;
        words += super::grid::words(g.cells(k)) as u64;
    }
    (words, offsets)
}

type Rows = (Vec<f32>, Vec<u32>, Vec<u32>);

/// Per triangle its corners in grid coordinates, its voxel box and loop axis (the
/// box's longest side), and the exclusive prefix sum of its rows (voxel lines along
/// the loop axis), with the total last.
fn triangle_rows(g: &VoxelGrid, tris: &[[[f64; 3]; 3]]) -> Result<Rows, GiError> {
    let mut corners = Vec::with_capacity(9 * tris.len());
    let mut boxes = Vec::with_capacity(7 * tris.len());
    let mut first = Vec::with_capacity(tris.len() + 1);
    let mut total = 0u64;
    for t in tris {
        let tg = t.map(|p| g.to_grid(&p.into()));
        first.push(total as u32);
        corners.extend(tg.iter().flatten().map(|&v| v as f32));
        let Some((lo, hi)) = voxel_box(&tg, g.n) else {
            boxes.extend([1, 1, 1, 0, 0, 0, 0]);
            continue;
        };
        let ext: [u64; 3] = std::array::from_fn(|a| u64::from(hi[a] - lo[a]) + 1);
        let axis = (0..3).max_by_key(|&a| ext[a]).unwrap_or(0);
        boxes.extend(lo.iter().chain(hi.iter()).copied().chain([axis as u32]));
        total += ext[(axis + 1) % 3] * ext[(axis + 2) % 3];
        if total > u64::from(u32::MAX) {
            return Err(GiError::Gpu(format!(
                "the triangles cover more than {} voxel rows: lower the resolution",
                u32::MAX
            )));
        }
    }
    first.push(total as u32);
    Ok((corners, boxes, first))
}

/// A frame on the GPU: lights and the G-buffer prepared on the CPU ([`prepare`]),
/// then voxelisation, hierarchy and shading as compute passes.
pub fn render_frame_gpu(
    gpu: &GpuVoxelGi,
    scene: &Scene,
    camera: &Camera,
    opts: &GiOptions,
) -> Result<GiFrame, GiError> {
    let Prepared { light, tris, hits } = prepare(scene, opts)?;
    let mut timings = light.timings;
    let started = Instant::now();
    let grid = gpu.voxelize(&light.grid, &tris)?;
    timings.voxelize_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let view = hits.pinhole(camera)?;
    timings.gbuffer_s = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let xyz = gpu.shade(&grid, &light, &view)?;
    timings.shade_s = started.elapsed().as_secs_f64();
    Ok(GiFrame {
        width: view.width,
        height: view.height,
        xyz,
        timings,
        occupied_voxels: gpu.occupied_voxels(&grid)?,
        vpls: light.vpls.len(),
    })
}
