//! `lumiwall render SCENE --method voxel-gi`: voxel-based GI (Thiedemann 2010), every
//! frame voxelised and lit from scratch, on the GPU or (`--cpu`) the CPU; one XYZ
//! OpenEXR per frame and the time of each part per frame.

use std::path::{Path, PathBuf};

use lumiwall_render::radiosity::output::write_exr;
use lumiwall_render::scene::{Animation, Camera, Scene, load_animated_scene};
use lumiwall_render::voxel::{GiFrame, GiOptions, render_frame};

use super::{RenderArgs, with_ext};
use crate::CliError;

/// The options of `--method voxel-gi` (`render`).
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct VoxelArgs {
    #[command(flatten)]
    gi: GiArgs,
    /// voxel-gi: compute on the CPU instead of the GPU.
    #[arg(long)]
    cpu: bool,
    /// voxel-gi: image size WxH instead of the scene camera's.
    #[arg(long, value_parser = image_size)]
    image_size: Option<(u32, u32)>,
}

/// The voxel GI's options (`render --method voxel-gi`, `view --voxel-gi`).
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct GiArgs {
    /// voxel-gi: voxels along the scene's longest axis (a power of two, 8 to 1024).
    #[arg(long, default_value_t = 128)]
    voxels: u32,
    /// voxel-gi: fixed sample points on the area emitters (direct light), 1 to 65536.
    #[arg(long, default_value_t = 256)]
    light_samples: u32,
    /// voxel-gi: light paths leaving VPLs (one bounce), 1 to 65536.
    #[arg(long, default_value_t = 256)]
    vpls: u32,
    /// voxel-gi: distance below which a VPL's light stops growing (m; default 5 % of
    /// the scene's extent).
    #[arg(long, allow_negative_numbers = true, value_parser = crate::values::positive_finite)]
    vpl_clamp_m: Option<f64>,
}

fn image_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not an image size; write WxH, e.g. 256x256");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("{s}: each side must be 1 to 16384 pixels"));
    }
    Ok((w, h))
}

impl GiArgs {
    /// The options of the GI.
    pub(crate) fn options(&self) -> GiOptions {
        GiOptions {
            resolution: self.voxels,
            light_samples: self.light_samples,
            vpl_paths: self.vpls,
            vpl_clamp_m: self.vpl_clamp_m,
        }
    }
}

/// How frames are computed.
enum Engine {
    Cpu,
    #[cfg(feature = "gpu")]
    Gpu(Box<lumiwall_render::voxel::gpu::GpuVoxelGi>),
}

impl Engine {
    fn open(cpu: bool) -> Result<Self, CliError> {
        if cpu {
            return Ok(Engine::Cpu);
        }
        #[cfg(feature = "gpu")]
        {
            let gpu = lumiwall_render::voxel::gpu::GpuVoxelGi::new()?;
            println!("voxel GI on {}", gpu.adapter_name());
            Ok(Engine::Gpu(Box::new(gpu)))
        }
        #[cfg(not(feature = "gpu"))]
        Err(CliError::input(
            "this lumiwall was built without the GPU (cargo feature gpu); give --cpu",
        ))
    }

    fn frame(&self, scene: &Scene, camera: &Camera, opts: &GiOptions) -> Result<GiFrame, CliError> {
        Ok(match self {
            Engine::Cpu => render_frame(scene, camera, opts)?,
            #[cfg(feature = "gpu")]
            Engine::Gpu(g) => {
                lumiwall_render::voxel::gpu::render_frame_gpu(g, scene, camera, opts)?
            }
        })
    }
}

/// Runs `lumiwall render --method voxel-gi` (with `--frames`: each frame of the
/// animation).
pub(crate) fn run(args: &RenderArgs) -> Result<(), CliError> {
    refuse_radiosity_options(args)?;
    let (scene, anim, report) = load_animated_scene(&args.scene)?;
    eprintln!("scene {}: {}", args.scene.display(), report.summary());
    let frames = frame_list(args, anim.as_ref())?;
    let opts = args.voxel.gi.options();
    lumiwall_render::voxel::check(&scene, &opts)?;
    let mut camera = scene.camera.clone().ok_or_else(|| {
        CliError::input(format!(
            "{} has no [camera]; --method voxel-gi renders the camera's view",
            args.scene.display()
        ))
    })?;
    if let Some((w, h)) = args.voxel.image_size {
        (camera.width_px, camera.height_px) = (w, h);
    }
    lumiwall_render::voxel::check_view_size(camera.width_px, camera.height_px)?;
    let paths: Vec<PathBuf> = frames.iter().map(|f| out_path(&args.out, *f)).collect();
    let refs: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    crate::values::check_output_files("--out", &refs)?;
    let engine = Engine::open(args.voxel.cpu)?;
    print_header(&opts, &camera);
    let mut sums = [0.0; 4];
    for (f, path) in frames.iter().zip(&paths) {
        let posed = match (&anim, f) {
            (Some(a), Some(f)) => a.frame_scene(&scene, *f),
            _ => scene.clone(),
        };
        let frame = engine.frame(&posed, &camera, &opts)?;
        print_row(*f, &frame);
        let t = frame.timings;
        for (s, v) in sums
            .iter_mut()
            .zip([t.voxelize_s, t.gbuffer_s, t.lights_s, t.shade_s])
        {
            *s += v;
        }
        write_exr(
            &frame.xyz,
            frame.width as usize,
            frame.height as usize,
            path,
        )?;
    }
    let k = frames.len() as f64;
    println!(
        "mean per frame over {} frames: voxelize {:.1} ms, GI {:.1} ms (lights {:.1} + shade {:.1}), G-buffer {:.1} ms",
        frames.len(),
        1e3 * sums[0] / k,
        1e3 * (sums[2] + sums[3]) / k,
        1e3 * sums[2] / k,
        1e3 * sums[3] / k,
        1e3 * sums[1] / k
    );
    println!("wrote {} …", paths[0].display());
    Ok(())
}

/// Options only a radiosity solution has are refused, not ignored (the scene file may
/// have chosen voxel GI without the user asking).
fn refuse_radiosity_options(args: &RenderArgs) -> Result<(), CliError> {
    let given = [
        ("--sensors", args.sensors.is_some()),
        ("--per-frame", args.per_frame),
        ("--visibility-keys", args.visibility_keys.is_some()),
    ];
    match given.iter().find(|(_, g)| *g) {
        Some((flag, _)) => Err(CliError::input(format!(
            "{flag} needs a radiosity solution, and {} is lit by voxel GI (--method \
             voxel-gi or the scene's method); add --method radiosity or progressive",
            args.scene.display()
        ))),
        None => Ok(()),
    }
}

/// `None` for a still image; the frames of `--frames` otherwise.
fn frame_list(args: &RenderArgs, anim: Option<&Animation>) -> Result<Vec<Option<usize>>, CliError> {
    let Some((first, last)) = args.frames else {
        return Ok(vec![None]);
    };
    let anim = anim.ok_or_else(|| {
        CliError::input(format!(
            "{} has no [animation] entry; --frames needs one (see fixtures/scenes/README.md)",
            args.scene.display()
        ))
    })?;
    if last >= anim.frames() {
        return Err(CliError::input(format!(
            "--frames {first}..{last}: the animation has frames 0..{}",
            anim.frames() - 1
        )));
    }
    Ok((first..=last).map(Some).collect())
}

fn out_path(out: &Path, frame: Option<usize>) -> PathBuf {
    match frame {
        None => out.to_path_buf(),
        Some(f) => {
            let ext = out.extension().and_then(|e| e.to_str()).unwrap_or("exr");
            with_ext(out, &format!("_{f:04}.{ext}"))
        }
    }
}

fn print_header(o: &GiOptions, c: &Camera) {
    println!(
        "voxel GI: {}³ voxels, {} emitter samples, {} VPL paths, {}×{} px",
        o.resolution, o.light_samples, o.vpl_paths, c.width_px, c.height_px
    );
    println!(
        "{:>6} {:>12} {:>12} {:>12} {:>10} {:>10} {:>12} {:>6}",
        "frame",
        "voxelize ms",
        "G-buffer ms",
        "lights ms",
        "shade ms",
        "GI ms",
        "voxels set",
        "VPLs"
    );
}

fn print_row(frame: Option<usize>, f: &GiFrame) {
    let t = f.timings;
    println!(
        "{:>6} {:>12.2} {:>12.2} {:>12.2} {:>10.2} {:>10.2} {:>12} {:>6}",
        frame.map_or("-".to_string(), |f| f.to_string()),
        1e3 * t.voxelize_s,
        1e3 * t.gbuffer_s,
        1e3 * t.lights_s,
        1e3 * t.shade_s,
        1e3 * (t.lights_s + t.shade_s),
        f.occupied_voxels,
        f.vpls
    );
}

/// `lumiwall view --voxel-gi`: the scene's light prepared once (voxels, emitter
/// samples, VPLs) and every display's view lit through its own off-axis frustum.
pub(crate) struct VoxelView {
    light: lumiwall_render::voxel::GiLight,
    hits: lumiwall_render::voxel::SceneHits,
    #[cfg(feature = "gpu")]
    gpu: Option<(
        lumiwall_render::voxel::gpu::GpuVoxelGi,
        lumiwall_render::voxel::gpu::GpuGrid,
    )>,
}

impl VoxelView {
    /// Loads `scene`, prepares its light and voxelises it (on the GPU unless `cpu` or
    /// none opens).
    pub(crate) fn new(scene: &Path, opts: &GiOptions, cpu: bool) -> Result<Self, CliError> {
        let (scene, report) = lumiwall_render::scene::load_scene(scene)?;
        eprintln!("scene: {}", report.summary());
        let lumiwall_render::voxel::Prepared {
            mut light,
            tris,
            hits,
        } = lumiwall_render::voxel::prepare(&scene, opts)?;
        #[cfg(feature = "gpu")]
        if !cpu {
            match lumiwall_render::voxel::gpu::GpuVoxelGi::new() {
                Ok(g) => {
                    let grid = g.voxelize(&light.grid, &tris)?;
                    return Ok(Self {
                        light,
                        hits,
                        gpu: Some((g, grid)),
                    });
                }
                Err(e) => eprintln!("lumiwall: voxel GI on the CPU ({e})"),
            }
        }
        let _ = cpu;
        lumiwall_render::voxel::voxelize(&mut light.grid, &tris);
        Ok(Self {
            light,
            hits,
            #[cfg(feature = "gpu")]
            gpu: None,
        })
    }

    /// Voxels, samples and VPLs, for the first line.
    pub(crate) fn summary(&self) -> String {
        format!(
            "{}³ voxels, {} emitter samples, {} VPLs",
            self.light.grid.n,
            self.light.lights.len(),
            self.light.vpls.len()
        )
    }

    /// Where it runs.
    pub(crate) fn name(&self) -> String {
        #[cfg(feature = "gpu")]
        if let Some((g, _)) = &self.gpu {
            return format!("voxel GI on GPU {}", g.adapter_name());
        }
        format!(
            "voxel GI on the CPU ({} threads)",
            rayon::current_num_threads()
        )
    }

    /// The scene through `view`: XYZ per pixel (cd/m²), row major from the top left.
    pub(crate) fn render(
        &self,
        view: &lumiwall_render::view::OffAxis,
    ) -> Result<Vec<[f32; 3]>, CliError> {
        let (w, h) = (view.width_px as f64, view.height_px as f64);
        let o = [view.eye.x, view.eye.y, view.eye.z];
        let pixels = self
            .hits
            .view(view.width_px as u32, view.height_px as u32, |x, y| {
                let s = (f64::from(x) + 0.5) / w;
                let t = 1.0 - (f64::from(y) + 0.5) / h;
                let p =
                    view.corner + view.right * (s * view.width_m) + view.up * (t * view.height_m);
                let d = p - view.eye;
                (o, [d.x, d.y, d.z])
            })?;
        #[cfg(feature = "gpu")]
        if let Some((g, grid)) = &self.gpu {
            return Ok(g.shade(grid, &self.light, &pixels)?);
        }
        Ok(lumiwall_render::voxel::shade_view(&self.light, &pixels))
    }
}
