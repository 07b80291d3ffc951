//! `lumiwall view`: a radiosity solution shown on a wall, headless: every display and
//! eye renders the solution through its own tile from the viewer's eye (off-axis
//! frustum, [`lumiwall_render::view`]), the luminance scale is applied and printed, and
//! the display's profile converts the frame to drive values (the post pass), written as
//! one PNG per display and eye with the frame time.

use std::path::{Path, PathBuf};
use std::time::Instant;

use lumiwall_core::files::FolderLock;
use lumiwall_profiles::apply::PreparedProfile;
use lumiwall_profiles::{DisplayProfile, ProfileSet};
use lumiwall_render::post::io::write_png;
use lumiwall_render::post::scale::LuminanceScale;
use lumiwall_render::post::wall::FrameSize;
use lumiwall_render::post::{CodeImage, XyzFrame};
use lumiwall_render::scene::{Camera, V3, load_scene};
use lumiwall_render::view::tracking::{HeadPose, PoseReceiver};
use lumiwall_render::view::{
    DEFAULT_EYE_SEPARATION_M, LitMesh, OffAxis, WallGeometry, WallPlacement, eye_offset_m,
    render_tile,
};

#[cfg(feature = "pattern-server")]
mod nodes;

use crate::CliError;
use crate::cmd_apply::{Engine, OogArg, post_options, scale_frames, stamp_scale};

/// Arguments of `lumiwall view`.
#[derive(Debug, clap::Args)]
pub(crate) struct ViewArgs {
    /// Scene file (TOML) whose `[camera]` places the wall in the scene: the camera
    /// stands where the reference viewer stands and looks at the wall's centre.
    scene: PathBuf,
    /// The solution `lumiwall render` wrote for the scene (`.ply`: per-vertex
    /// luminance, view-independent).
    #[cfg_attr(feature = "voxel-gi", arg(long, required_unless_present = "voxel_gi"))]
    #[cfg_attr(not(feature = "voxel-gi"), arg(long, required = true))]
    solution: Option<PathBuf>,
    /// Light the scene itself by voxel-based GI (direct light and one bounce, as
    /// `render --method voxel-gi`) and show it through every display's own view,
    /// instead of a solution.
    #[cfg(feature = "voxel-gi")]
    #[arg(long, conflicts_with = "solution")]
    voxel_gi: bool,
    #[cfg(feature = "voxel-gi")]
    #[command(flatten)]
    gi: crate::cmd_render::voxel::GiArgs,
    /// Wall description (TOML): its `[tiles]` give the tile size in metres.
    #[arg(long)]
    wall: PathBuf,
    /// The wall's profile folder (`lumiwall commission`).
    #[arg(long)]
    profiles: PathBuf,
    /// Output folder: one `<display>.png` per display and eye.
    #[arg(long)]
    out_dir: PathBuf,
    /// Viewer position in the wall frame, `X,Y,Z` metres (x right and y up from the
    /// wall's lower-left corner, z towards the viewer); default: before the wall's
    /// centre at `--viewer-distance`.
    #[arg(long, value_parser = parse_point)]
    viewer: Option<[f64; 3]>,
    /// Distance of the reference viewer from the wall (m): where the scene camera
    /// stands.
    #[arg(long, default_value_t = 2.0, value_parser = parse_positive_m)]
    viewer_distance: f64,
    /// Eye separation for a stereo wall (m).
    #[arg(long, default_value_t = DEFAULT_EYE_SEPARATION_M, value_parser = parse_separation_m)]
    eye_separation: f64,
    /// Pixels of each display, `WIDTHxHEIGHT` (default: 1024 wide, the tile's aspect).
    #[arg(long)]
    display_size: Option<FrameSize>,
    /// Scene luminance to wall luminance: `1` (1:1), a factor such as `0.25`, or
    /// `auto` / `auto:P` (the largest factor at which P %, default 99, of the pixels of
    /// all displays fit into the wall's common gamut). Always printed; a scaled image
    /// is marked in its top left corner.
    #[arg(long, default_value = "1")]
    luminance_scale: LuminanceScale,
    /// Out-of-gamut handling (default: the profile's; false colours mark over range).
    #[arg(long, value_enum)]
    out_of_gamut: Option<OogArg>,
    /// Rasterise and run the post pass on the CPU (the references) even where a GPU
    /// adapter exists.
    #[arg(long)]
    cpu: bool,
    /// The wall is a virtual one: emit every display's image through the simulator and
    /// compare the luminance on both sides of every border between two tiles of one
    /// eye (blocks of 16×16 pixels, what the scene changes between the sides taken
    /// out); fails above a 1 % step. Keeps every image in memory until the end.
    #[cfg(feature = "station")]
    #[arg(long, conflicts_with = "tracking")]
    seams_through_simulator: bool,
    /// Head tracking: listen for poses on this UDP address (e.g. `0.0.0.0:7000`),
    /// one datagram `LWPOSE 1 <seq> <x_m> <y_m> <z_m> [<qw> <qx> <qy> <qz>]` per pose
    /// in the wall frame (render/src/view/tracking.rs), and render every display for
    /// each pose taken into `OUT_DIR/pose_NNNN/`.
    #[arg(long, conflicts_with = "viewer")]
    tracking: Option<String>,
    /// With --tracking: poses to render before stopping.
    #[arg(long, default_value_t = 1, requires = "tracking",
          value_parser = clap::value_parser!(u32).range(1..=MAX_TRACKED_POSES))]
    poses: u32,
    /// Show the frames on this render node's outputs instead of writing images:
    /// `HOST:PORT` of its pattern server as the wall file's `[[output]]` addresses
    /// name it. Only the displays routed there are rendered, each frame goes to its
    /// outputs together, and on a wall of several nodes every frame first waits at the
    /// swap barrier (--barrier). Needs a luminance factor, not `auto`.
    #[cfg(feature = "pattern-server")]
    #[arg(long)]
    show_on: Option<String>,
    /// With --show-on: the node (`HOST:PORT`) that hosts the swap barrier; default the
    /// first node of the wall file.
    #[cfg(feature = "pattern-server")]
    #[arg(long, requires = "show_on")]
    barrier: Option<String>,
    /// With --tracking: the longest wait for a pose, e.g. `30s`.
    #[arg(long, default_value = "30s", requires = "tracking", value_parser = crate::values::duration)]
    tracking_timeout: std::time::Duration,
}

/// Most poses one tracked run renders.
const MAX_TRACKED_POSES: i64 = 1_000_000;

/// Largest pixel count of one display.
const MAX_DISPLAY_PIXELS: u64 = 8192 * 8192;

fn parse_positive_m(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("{s:?}: give a distance in metres greater than 0")),
    }
}

fn parse_separation_m(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("{s:?}: give the eye separation in metres, 0 to 1")),
    }
}

fn parse_point(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|w| {
            w.trim()
                .parse::<f64>()
                .map_err(|_| format!("{w:?} is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) && *z > 0.0 => Ok([*x, *y, *z]),
        _ => Err(format!(
            "{s:?}: give X,Y,Z in metres with Z > 0 (in front of the wall)"
        )),
    }
}

/// The wall's name and tile geometry from its file (`name`, `[tiles]` cols, rows,
/// width_m, height_m).
fn wall_geometry(path: &Path) -> Result<(String, WallGeometry), CliError> {
    let err = |m: String| CliError::input(format!("wall file {}: {m}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
    let t: toml::Table = toml::from_str(&text).map_err(|e| err(e.to_string()))?;
    let name = t
        .get("name")
        .and_then(|v| v.as_str())
        .ok_or_else(|| err("no name".into()))?
        .to_string();
    let tiles = t.get("tiles").and_then(|v| v.as_table());
    let int = |k: &str| {
        tiles
            .and_then(|t| t.get(k))
            .and_then(|v| v.as_integer())
            .and_then(|v| u32::try_from(v).ok())
            .filter(|v| *v >= 1)
    };
    let metres = |k: &str| {
        tiles
            .and_then(|t| t.get(k))
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
            .filter(|v| v.is_finite() && *v > 0.0)
    };
    match (
        int("cols"),
        int("rows"),
        metres("width_m"),
        metres("height_m"),
    ) {
        (Some(cols), Some(rows), Some(w), Some(h)) => Ok((
            name,
            WallGeometry {
                cols,
                rows,
                tile_width_m: w,
                tile_height_m: h,
            },
        )),
        _ => Err(err(
            "[tiles] needs cols, rows ≥ 1 and width_m, height_m > 0".into(),
        )),
    }
}

/// Pixels of each display: as given, or 1024 wide at the tile's aspect.
fn display_size(args: &ViewArgs, g: &WallGeometry) -> Result<(usize, usize), CliError> {
    let s = args.display_size.unwrap_or_else(|| FrameSize {
        width: 1024,
        height: ((1024.0 * g.tile_height_m / g.tile_width_m).round() as u32).max(1),
    });
    if s.width == 0
        || s.height == 0
        || u64::from(s.width) * u64::from(s.height) > MAX_DISPLAY_PIXELS
    {
        return Err(CliError::input(format!(
            "--display-size {s}: at most {MAX_DISPLAY_PIXELS} pixels and at least one"
        )));
    }
    Ok((s.width as usize, s.height as usize))
}

/// The rasteriser of this run: wgpu when an adapter exists (and `--cpu` is not given),
/// else the CPU reference.
enum Raster {
    Cpu,
    #[cfg(feature = "gpu")]
    Gpu(Box<lumiwall_render::view::gpu::GpuRaster>),
    /// Voxel GI: the scene lit per view.
    #[cfg(feature = "voxel-gi")]
    VoxelGi(Box<crate::cmd_render::voxel::VoxelView>),
}

impl Raster {
    fn choose(mesh: &LitMesh, cpu_only: bool) -> Raster {
        if cpu_only {
            return Raster::Cpu;
        }
        #[cfg(feature = "gpu")]
        match lumiwall_render::view::gpu::GpuRaster::new(mesh) {
            Ok(g) => return Raster::Gpu(Box::new(g)),
            Err(e) => eprintln!("lumiwall: rasterising on the CPU ({e})"),
        }
        #[cfg(not(feature = "gpu"))]
        let _ = mesh;
        Raster::Cpu
    }

    fn name(&self) -> String {
        match self {
            Raster::Cpu => format!("CPU ({} threads)", rayon::current_num_threads()),
            #[cfg(feature = "gpu")]
            Raster::Gpu(g) => format!("GPU {}", g.adapter_name()),
            #[cfg(feature = "voxel-gi")]
            Raster::VoxelGi(v) => v.name(),
        }
    }

    fn render(&self, mesh: &LitMesh, view: &OffAxis) -> Result<Vec<[f32; 3]>, CliError> {
        match self {
            Raster::Cpu => Ok(render_tile(mesh, view)),
            #[cfg(feature = "gpu")]
            Raster::Gpu(g) => Ok(g.render(view)?),
            #[cfg(feature = "voxel-gi")]
            Raster::VoxelGi(v) => v.render(view),
        }
    }
}

/// What every display renders: the mesh, where the wall stands in the scene, the
/// viewer (wall frame) and the displays' size.
struct ViewSetup<'a> {
    mesh: &'a LitMesh,
    raster: &'a Raster,
    place: WallPlacement,
    geometry: WallGeometry,
    head: HeadPose,
    eye_separation_m: f64,
    size: (usize, usize),
}

/// Every display's frame: the solution through its tile from its eye, with the time
/// each took.
fn render_frames(
    v: &ViewSetup<'_>,
    profiles: &[DisplayProfile],
) -> Result<Vec<(XyzFrame, f64)>, CliError> {
    let g = &v.geometry;
    profiles
        .iter()
        .map(|p| {
            let key = &p.display;
            if key.tile_col >= g.cols || key.tile_row >= g.rows {
                return Err(CliError::input(format!(
                    "{key}: tile col {} row {} is outside the wall file's {}×{} tiles",
                    key.tile_col, key.tile_row, g.cols, g.rows
                )));
            }
            let t0 = Instant::now();
            let eye = v.head.eye_m(eye_offset_m(key.eye, v.eye_separation_m));
            let view = v
                .place
                .tile_view(g, key.tile_col, key.tile_row, eye, v.size);
            let pixels = v.raster.render(v.mesh, &view)?;
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            let frame = XyzFrame::new(v.size.0 as u32, v.size.1 as u32, pixels)
                .map_err(|e| CliError::input(format!("{key}: {e}")))?;
            Ok((frame, ms))
        })
        .collect()
}

/// The profiles of the wall the wall file describes (refused when they belong to
/// another).
fn wall_profiles(args: &ViewArgs, wall_name: &str) -> Result<Vec<DisplayProfile>, CliError> {
    let (wall, profiles) = ProfileSet::load_dir(&args.profiles)?;
    if wall != wall_name {
        return Err(CliError::input(format!(
            "the profiles in {} are of wall {wall}, the wall file {} is {wall_name}",
            args.profiles.display(),
            args.wall.display()
        )));
    }
    if profiles.is_empty() {
        return Err(CliError::input(format!(
            "profile folder {} lists no display",
            args.profiles.display()
        )));
    }
    Ok(profiles)
}

/// The scene's camera, which places the wall in the scene.
fn scene_camera(path: &Path) -> Result<Camera, CliError> {
    let (scene, _) = load_scene(path)?;
    scene.camera.ok_or_else(|| {
        CliError::input(format!(
            "{}: the scene has no [camera]; it places the wall in the scene",
            path.display()
        ))
    })
}

/// A display's frame and the codes the post pass made of it.
type Shown = (XyzFrame, CodeImage);

/// Raster and post-pass time of one display (ms).
type FrameTime = (f64, f64);

/// The post pass over every display's frame, each image written and its line printed;
/// returns the frames and images when `keep` (for the seam check) and the times.
fn post_and_write(
    args: &ViewArgs,
    profiles: &[DisplayProfile],
    frames: Vec<(XyzFrame, f64)>,
    label: Option<&str>,
    engine: &Engine,
    sink: &mut Sink<'_>,
) -> Result<(Vec<Shown>, Vec<FrameTime>), CliError> {
    let opts = post_options(args.out_of_gamut, None, true);
    let mut kept = Vec::new();
    let mut times = Vec::with_capacity(profiles.len());
    let mut pngs = Vec::new();
    for (profile, (frame, raster_ms)) in profiles.iter().zip(frames) {
        let t0 = Instant::now();
        let pp = PreparedProfile::new(profile, &opts)?;
        let frame = stamp_scale(frame, label, profile);
        let img = engine.run(&pp, &frame)?;
        let post_ms = t0.elapsed().as_secs_f64() * 1e3;
        let put = sink.put(profile, &img, &mut pngs)?;
        let c = img.counts;
        println!(
            "{}: {put} (raster {raster_ms:.1} ms, post pass {post_ms:.1} ms on {}); \
             pixels out of gamut {}, over range {}",
            profile.display,
            engine.name(),
            c.out_of_gamut,
            c.over_range
        );
        if keep_images(args) {
            kept.push((frame, img));
        }
        times.push((raster_ms, post_ms));
    }
    sink.present(pngs)?;
    Ok((kept, times))
}

/// Where the displays' images go: PNG files in a folder, or (`--show-on`) this
/// render node's outputs, one frame for all of them.
struct Sink<'a> {
    dir: PathBuf,
    #[cfg(feature = "pattern-server")]
    node: Option<&'a mut nodes::NodeShow>,
    _node: std::marker::PhantomData<&'a ()>,
}

impl Sink<'_> {
    /// Writes `img` (or keeps its PNG for the node's frame); says where it went.
    fn put(
        &mut self,
        profile: &DisplayProfile,
        img: &CodeImage,
        pngs: &mut Vec<Vec<u8>>,
    ) -> Result<String, CliError> {
        #[cfg(feature = "pattern-server")]
        if self.node.is_some() {
            let png = lumiwall_render::post::io::encode_png(img)
                .map_err(|e| CliError::input(format!("{}: {e}", profile.display)))?;
            pngs.push(png);
            return Ok("rendered for this node's output".into());
        }
        let _ = pngs;
        let out = self
            .dir
            .join(format!("{}.png", profile.display.file_stem()));
        write_png(&out, img)?;
        Ok(format!("wrote {}", out.display()))
    }

    /// Presents the node's frame (nothing for files).
    fn present(&mut self, pngs: Vec<Vec<u8>>) -> Result<(), CliError> {
        #[cfg(feature = "pattern-server")]
        if let Some(node) = self.node.as_deref_mut() {
            return node.present(pngs);
        }
        let _ = pngs;
        Ok(())
    }

    /// Pose `k` of a tracked run goes to `out_dir/pose_NNNN/` (files only).
    fn for_pose(&mut self, out_dir: &Path, k: u32) -> Result<(), CliError> {
        #[cfg(feature = "pattern-server")]
        if self.node.is_some() {
            return Ok(());
        }
        self.dir = out_dir.join(format!("pose_{k:04}"));
        std::fs::create_dir_all(&self.dir)
            .map_err(|e| CliError::input(format!("{}: {e}", self.dir.display())))
    }

    fn files<'a>(dir: PathBuf) -> Sink<'a> {
        Sink {
            dir,
            #[cfg(feature = "pattern-server")]
            node: None,
            _node: std::marker::PhantomData,
        }
    }
}

/// Runs `lumiwall view`.
pub(crate) fn run(args: ViewArgs) -> Result<(), CliError> {
    let (wall, g) = wall_geometry(&args.wall)?;
    #[cfg_attr(
        not(feature = "pattern-server"),
        expect(unused_mut, reason = "--show-on")
    )]
    let mut profiles = wall_profiles(&args, &wall)?;
    #[cfg(feature = "pattern-server")]
    let mut node = show_on_node(&args, &wall, &mut profiles)?;
    let size = display_size(&args, &g)?;
    let camera = scene_camera(&args.scene)?;
    let _lock = FolderLock::acquire(&args.out_dir, &format!("view of wall {wall}"))?;
    let (mesh, raster, shown) = what_to_show(&args)?;
    let reference = g.centred_viewer(args.viewer_distance);
    let viewer = args.viewer.map_or(reference, |[x, y, z]| V3::new(x, y, z));
    let place = WallPlacement::from_camera(&camera, reference).ok_or_else(|| {
        CliError::input("the scene camera's look_at and up are degenerate".to_string())
    })?;
    println!(
        "viewing {shown} on {wall}: {} displays of {}×{} px, viewer at {:.3}, {:.3}, {:.3} m",
        profiles.len(),
        size.0,
        size.1,
        viewer.x,
        viewer.y,
        viewer.z
    );
    println!("rasteriser: {}", raster.name());
    let mut setup = ViewSetup {
        mesh: &mesh,
        raster: &raster,
        place,
        geometry: g,
        head: HeadPose {
            seq: 0,
            position_m: viewer,
            orientation: None,
        },
        eye_separation_m: args.eye_separation,
        size,
    };
    let engine = Engine::choose(args.cpu);
    let mut sink = Sink::files(args.out_dir.clone());
    #[cfg(feature = "pattern-server")]
    {
        sink.node = node.as_mut();
    }
    if let Some(addr) = &args.tracking {
        return run_tracked(&args, &mut setup, &profiles, &engine, addr, &mut sink);
    }
    let (frames, label, _) = render_scaled(&setup, &profiles, args.luminance_scale)?;
    let (kept, times) = post_and_write(
        &args,
        &profiles,
        frames,
        label.as_deref(),
        &engine,
        &mut sink,
    )?;
    println!("{}", frame_times(&times, &raster.name(), &engine.name()));
    check_seams(&args, &profiles, &kept)
}

/// The solution's mesh and its rasteriser, or (`--voxel-gi`) an empty mesh and the
/// scene lit by voxel GI; and what is shown, for the first line.
fn what_to_show(args: &ViewArgs) -> Result<(LitMesh, Raster, String), CliError> {
    #[cfg(feature = "voxel-gi")]
    if args.voxel_gi {
        let v =
            crate::cmd_render::voxel::VoxelView::new(&args.scene, &args.gi.options(), args.cpu)?;
        let shown = format!("{} lit by voxel GI ({})", args.scene.display(), v.summary());
        return Ok((LitMesh::default(), Raster::VoxelGi(Box::new(v)), shown));
    }
    let path = args
        .solution
        .as_ref()
        .ok_or_else(|| CliError::input("give --solution (the .ply lumiwall render wrote)"))?;
    let mesh = LitMesh::read_ply(path).map_err(|e| CliError::input(e.to_string()))?;
    let raster = Raster::choose(&mesh, args.cpu);
    let shown = format!("{} ({} faces)", path.display(), mesh.faces.len());
    Ok((mesh, raster, shown))
}

/// Every display's frame with its raster time, the label to stamp and the factor.
type ScaledFrames = (Vec<(XyzFrame, f64)>, Option<String>, f64);

/// Every display's frame from the setup's head, scaled: the frames, the label to stamp
/// and the factor.
fn render_scaled(
    setup: &ViewSetup<'_>,
    profiles: &[DisplayProfile],
    scale: LuminanceScale,
) -> Result<ScaledFrames, CliError> {
    let mut frames = render_frames(setup, profiles)?;
    let (label, factor) = {
        let mut refs: Vec<&mut XyzFrame> = frames.iter_mut().map(|(f, _)| f).collect();
        scale_frames(scale, &profiles[0], &mut refs)?
    };
    Ok((frames, label, factor))
}

/// `--tracking`: every display rendered for each pose taken from the stream, into
/// `OUT_DIR/pose_NNNN/`; an automatic luminance scale is resolved at the first pose
/// and held, so that the wall does not pump as the head moves.
fn run_tracked(
    args: &ViewArgs,
    setup: &mut ViewSetup<'_>,
    profiles: &[DisplayProfile],
    engine: &Engine,
    addr: &str,
    sink: &mut Sink<'_>,
) -> Result<(), CliError> {
    let mut rx = PoseReceiver::bind(addr).map_err(|e| CliError::input(e.to_string()))?;
    println!(
        "tracking: listening on {} for {} poses (LWPOSE 1 <seq> <x> <y> <z> [qw qx qy qz])",
        rx.local_addr(),
        args.poses
    );
    flush_stdout();
    let mut scale = args.luminance_scale;
    for k in 0..args.poses {
        setup.head = rx
            .next(args.tracking_timeout)
            .map_err(|e| CliError::input(e.to_string()))?;
        let p = setup.head.position_m;
        println!(
            "pose {k} (seq {}): head at {:.3}, {:.3}, {:.3} m",
            setup.head.seq, p.x, p.y, p.z
        );
        let (frames, label, factor) = render_scaled(setup, profiles, scale)?;
        scale = LuminanceScale::Factor(factor);
        sink.for_pose(&args.out_dir, k)?;
        let (_, times) = post_and_write(args, profiles, frames, label.as_deref(), engine, sink)?;
        println!(
            "{}",
            frame_times(&times, &setup.raster.name(), &engine.name())
        );
        flush_stdout();
    }
    println!(
        "tracking: {} poses rendered; {} bad and {} stale datagrams skipped",
        args.poses, rx.bad, rx.stale
    );
    Ok(())
}

/// `--show-on`: this node's connection, the profiles narrowed to its displays.
#[cfg(feature = "pattern-server")]
fn show_on_node(
    args: &ViewArgs,
    wall: &str,
    profiles: &mut Vec<DisplayProfile>,
) -> Result<Option<nodes::NodeShow>, CliError> {
    let Some(node) = &args.show_on else {
        return Ok(None);
    };
    if matches!(args.luminance_scale, LuminanceScale::Auto { .. }) {
        return Err(CliError::input(
            "--show-on: an automatic luminance scale would differ between the nodes; give \
             a factor (--luminance-scale 0.25, or 1)",
        ));
    }
    if keep_images(args) {
        return Err(CliError::input(
            "--seams-through-simulator compares written images; leave out --show-on",
        ));
    }
    let show = nodes::NodeShow::connect(&args.wall, wall, node, args.barrier.as_deref(), profiles)?;
    *profiles = show
        .displays
        .iter()
        .map(|(i, _)| profiles[*i].clone())
        .collect();
    Ok(Some(show))
}

/// Lets a process reading the output see a line at once (the tracker bridge waits for
/// `listening`).
fn flush_stdout() {
    use std::io::Write;
    let _ = std::io::stdout().flush();
}

/// The summary of the displays' frame times: median and largest raster and post-pass
/// time, and the frame rate the slower median allows.
fn frame_times(times: &[FrameTime], raster: &str, post: &str) -> String {
    let stats = |k: usize| {
        let mut v: Vec<f64> = times
            .iter()
            .map(|t| if k == 0 { t.0 } else { t.1 })
            .collect();
        v.sort_by(f64::total_cmp);
        let median = v.get(v.len() / 2).copied().unwrap_or(0.0);
        (median, v.last().copied().unwrap_or(0.0))
    };
    let ((rm, rx), (pm, px)) = (stats(0), stats(1));
    format!(
        "frame time per display ({} displays): raster median {rm:.1} ms, max {rx:.1} ms ({raster}); \
         post pass median {pm:.1} ms, max {px:.1} ms ({post}); {:.1} frames/s at the median",
        times.len(),
        1e3 / (rm + pm).max(1e-9)
    )
}

/// True when the images are needed after they are written.
fn keep_images(args: &ViewArgs) -> bool {
    #[cfg(feature = "station")]
    {
        args.seams_through_simulator
    }
    #[cfg(not(feature = "station"))]
    {
        let _ = args;
        false
    }
}

/// `--seams-through-simulator`: the steps across every border, printed; an error above
/// [`crate::view_seams::MAX_SEAM_STEP`].
#[cfg(feature = "station")]
fn check_seams(
    args: &ViewArgs,
    profiles: &[DisplayProfile],
    kept: &[Shown],
) -> Result<(), CliError> {
    use crate::view_seams::{MAX_SEAM_STEP, seam_steps};
    if !args.seams_through_simulator {
        return Ok(());
    }
    let wall = lumiwall_devices::sim::VirtualWall::from_toml_file(&args.wall)
        .map_err(|e| CliError::input(e.to_string()))?;
    let shown: Vec<crate::view_seams::Shown<'_>> = profiles
        .iter()
        .zip(kept)
        .map(|(profile, (frame, codes))| crate::view_seams::Shown {
            profile,
            frame,
            codes,
        })
        .collect();
    let steps = seam_steps(&wall, &shown)?;
    let (median, max) = steps.median_max();
    let verdict = if max <= MAX_SEAM_STEP { "meet" } else { "FAIL" };
    println!(
        "seams through the simulator: {} borders, {} blocks with light on both sides, \
         luminance step median {:.2} %, max {:.2} % (limit {:.0} %): {verdict}",
        steps.borders,
        steps.steps.len(),
        100.0 * median,
        100.0 * max,
        100.0 * MAX_SEAM_STEP
    );
    if steps.steps.is_empty() {
        return Err(CliError::input(
            "no border has light on both sides: nothing to compare (move the viewer or \
             use a scene that fills the wall)",
        ));
    }
    if max > MAX_SEAM_STEP {
        return Err(CliError::tolerance(format!(
            "a luminance step of {:.2} % across a seam (limit {:.0} %)",
            100.0 * max,
            100.0 * MAX_SEAM_STEP
        )));
    }
    Ok(())
}

#[cfg(not(feature = "station"))]
fn check_seams(_: &ViewArgs, _: &[DisplayProfile], _: &[Shown]) -> Result<(), CliError> {
    Ok(())
}

/// Arguments of `lumiwall bench view`.
#[derive(Debug, clap::Args)]
pub(crate) struct BenchArgs {
    /// Triangles of the generated scene (a vaulted nave; 100 000 is issue 16's target).
    #[arg(long, default_value_t = 100_000,
          value_parser = clap::value_parser!(u32).range(1..=MAX_BENCH_TRIANGLES))]
    triangles: u32,
    /// Tiles of the wall, `COLSxROWS`.
    #[arg(long, default_value = "6x4")]
    tiles: FrameSize,
    /// Pixels of each display, `WIDTHxHEIGHT`.
    #[arg(long, default_value = "1024x768")]
    display_size: FrameSize,
    /// Timed repetitions per display (the best counts).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeats: u32,
    /// Skip the GPU row.
    #[arg(long)]
    no_gpu: bool,
}

/// Largest generated scene of `bench view`.
const MAX_BENCH_TRIANGLES: i64 = 10_000_000;

/// Most tiles of `bench view`'s wall.
const MAX_BENCH_TILES: u32 = 256;

/// Runs `lumiwall bench view`.
pub(crate) fn bench(args: BenchArgs) -> Result<(), CliError> {
    let tiles = (args.tiles.width, args.tiles.height);
    if tiles.0 == 0 || tiles.1 == 0 || tiles.0 * tiles.1 > MAX_BENCH_TILES {
        return Err(CliError::input(format!(
            "--tiles {}: 1 to {MAX_BENCH_TILES} tiles",
            args.tiles
        )));
    }
    let s = args.display_size;
    if s.width == 0
        || s.height == 0
        || u64::from(s.width) * u64::from(s.height) > MAX_DISPLAY_PIXELS
    {
        return Err(CliError::input(format!(
            "--display-size {s}: at most {MAX_DISPLAY_PIXELS} pixels and at least one"
        )));
    }
    let report = lumiwall_bench::view::run(lumiwall_bench::view::ViewBenchOptions {
        triangles: args.triangles as usize,
        tiles,
        size: (s.width, s.height),
        repeats: args.repeats,
        gpu: !args.no_gpu,
    })?;
    print!("{report}");
    Ok(())
}
