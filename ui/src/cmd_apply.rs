//! `lumiwall apply`: display profiles applied to an XYZ (cd/m²) frame, one output image
//! per display and eye; and `lumiwall bench apply`: post-pass throughput and banding.

use std::path::{Path, PathBuf};

use lumiwall_bench::apply::ApplyBenchOptions;
use lumiwall_core::files::FolderLock;
use lumiwall_profiles::apply::srgb::SRGB_PRIMARIES_XY;
use lumiwall_profiles::apply::{ApplyOptions, PreparedProfile, mat3, rgb_to_xyz_matrix};
use lumiwall_profiles::{DisplayKey, DisplayProfile, OutOfGamut, ProfileSet};
use lumiwall_render::post::io::{ReadOptions, read_exr, read_png_srgb, write_png};
use lumiwall_render::post::scale::{self, LuminanceScale};
use lumiwall_render::post::wall::{
    EyeFrames, FrameSize, WallError, WallTiling, check_display_size,
};
use lumiwall_render::post::{CodeImage, PostError, XyzFrame, apply_cpu};

use crate::CliError;

/// Out-of-gamut handling chosen on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum OogArg {
    /// Move out-of-gamut colours toward white, scale over-range ones down.
    Clip,
    /// Mark them: magenta out of gamut, cyan over range, yellow NaN/Inf.
    FalseColour,
}

/// Primaries assumed for sRGB/PNG input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum SrgbPrimaries {
    /// The wall's common primaries (Kresse 3.3.5: uncalibrated input fills the common gamut).
    Common,
    /// The sRGB / Rec. 709 primaries (colorimetric; colours outside the wall gamut clip).
    Srgb,
}

/// Arguments of `lumiwall apply`.
#[derive(Debug, clap::Args)]
pub(crate) struct ApplyArgs {
    /// One display's profile (JSON); the whole input frame goes to that display.
    #[arg(
        long,
        required_unless_present = "profiles",
        conflicts_with = "profiles"
    )]
    profile: Option<PathBuf>,
    /// A wall's profile folder (`wall.json` + one profile per display and eye); each
    /// display gets its tile of the frame.
    #[arg(long)]
    profiles: Option<PathBuf>,
    /// Input frame: OpenEXR (X,Y,Z or R,G,B holding X,Y,Z, or Y only; cd/m²) or an
    /// sRGB PNG (decoded with the ideal sRGB curve).
    #[arg(long = "in")]
    input: PathBuf,
    /// Right-eye frame of a stereo wall (`--in` is then the left eye).
    #[arg(long = "in-right")]
    input_right: Option<PathBuf>,
    /// Output PNG (with `--profile`).
    #[arg(long, conflicts_with = "out_dir")]
    out: Option<PathBuf>,
    /// Output folder (with `--profiles`): one `<display>.png` per display and eye.
    #[arg(long)]
    out_dir: Option<PathBuf>,
    /// Use the CPU reference only (the GPU is used when an adapter exists).
    #[arg(long)]
    cpu: bool,
    /// Round every pixel to its nearest code instead of the default ordered dither
    /// (the 16×16 Bayer dither that lets a display's few used codes show the drives
    /// between them on average, as the calibration's verification patches do).
    #[arg(long)]
    no_dither: bool,
    /// Ordered dithering before quantisation (the default; kept for scripts).
    #[arg(long, hide = true, conflicts_with = "no_dither")]
    dither: bool,
    /// Out-of-gamut handling (default: the profile's).
    #[arg(long, value_enum)]
    out_of_gamut: Option<OogArg>,
    /// Output bit depth 8, 10, 12 or 16 (default: the profile's).
    #[arg(long)]
    bit_depth: Option<u32>,
    /// Let negative values through (shown as out of gamut) instead of failing.
    #[arg(long)]
    allow_negative: bool,
    /// Replace NaN, Inf and negative values by 0 instead of failing.
    #[arg(long)]
    sanitize: bool,
    /// Resolution each display expects, `WIDTHxHEIGHT`; a tile of another size fails.
    #[arg(long)]
    display_size: Option<FrameSize>,
    /// Primaries assumed for PNG input.
    #[arg(long, value_enum, default_value = "common")]
    srgb_primaries: SrgbPrimaries,
    /// Scene luminance to wall luminance: `1` (1:1, the scene as it is; what the wall
    /// cannot show is over range), a factor such as `0.25`, or `auto` / `auto:P` (the
    /// largest factor at which P %, default 99, of the pixels fit into the wall's common
    /// gamut). Always printed; a scaled image is marked in its top left corner.
    #[arg(long, default_value = "1")]
    luminance_scale: LuminanceScale,
}

/// The frames scaled by `args.luminance_scale` for a wall whose common white is
/// `profile`'s, the scale printed; returns the label to stamp (none at 1:1).
fn apply_scale(
    args: &ApplyArgs,
    profile: &DisplayProfile,
    frames: &mut [&mut XyzFrame],
) -> Result<Option<String>, CliError> {
    scale_frames(args.luminance_scale, profile, frames).map(|(label, _)| label)
}

/// The frames scaled by `scale` for a wall whose common white is `profile`'s (an
/// automatic scale resolved over all of them together), the scale printed; returns
/// the label to stamp (none at 1:1) and the factor.
pub(crate) fn scale_frames(
    scale: LuminanceScale,
    profile: &DisplayProfile,
    frames: &mut [&mut XyzFrame],
) -> Result<(Option<String>, f64), CliError> {
    let to_rgb = rgb_to_xyz_matrix(
        &profile.common_primaries_xy,
        &profile.target_white_xyz_cd_m2,
    )
    .ok()
    .and_then(|m| mat3::inverse(&m))
    .ok_or_else(|| {
        CliError::input(format!(
            "{}: the common primaries and white give no RGB matrix; commission the wall again",
            profile.display
        ))
    })?;
    let resolved = {
        let views: Vec<&XyzFrame> = frames.iter().map(|f| &**f).collect();
        scale::resolve(scale, &views, &to_rgb)
            .map_err(|e| CliError::input(format!("--luminance-scale: {e}")))?
    };
    println!("{resolved}");
    if resolved.is_true_scale() {
        return Ok((None, resolved.factor));
    }
    for f in frames.iter_mut() {
        scale::scale_frame(f, resolved.factor);
    }
    Ok((Some(resolved.label()), resolved.factor))
}

/// `frame` with `label` (if any) in its corner, in `profile`'s target white.
pub(crate) fn stamp_scale(
    mut frame: XyzFrame,
    label: Option<&str>,
    profile: &DisplayProfile,
) -> XyzFrame {
    if let Some(text) = label {
        let white = profile.target_white_xyz_cd_m2.map(|v| v as f32);
        scale::stamp_label(&mut frame, text, white);
    }
    frame
}

/// The post pass engine chosen for this run.
pub(crate) enum Engine {
    Cpu,
    #[cfg(feature = "gpu")]
    Gpu(Box<lumiwall_render::post::GpuPost>),
}

impl Engine {
    /// The GPU when an adapter exists and `cpu_only` is false, else the CPU reference.
    pub(crate) fn choose(cpu_only: bool) -> Engine {
        if cpu_only {
            return Engine::Cpu;
        }
        #[cfg(feature = "gpu")]
        {
            match lumiwall_render::post::GpuPost::new() {
                Ok(g) => {
                    tracing::info!("post pass on GPU adapter {}", g.adapter_name());
                    return Engine::Gpu(Box::new(g));
                }
                Err(e) => eprintln!("lumiwall: no GPU adapter, using the CPU path ({e})"),
            }
        }
        #[cfg(not(feature = "gpu"))]
        eprintln!("lumiwall: built without GPU support, using the CPU path");
        Engine::Cpu
    }

    /// The engine's name for the summary lines.
    pub(crate) fn name(&self) -> String {
        match self {
            Engine::Cpu => format!("CPU ({} threads)", rayon::current_num_threads()),
            #[cfg(feature = "gpu")]
            Engine::Gpu(g) => format!("GPU {}", g.adapter_name()),
        }
    }

    /// Runs the post pass of `pp` over `frame`.
    pub(crate) fn run(
        &self,
        pp: &PreparedProfile,
        frame: &XyzFrame,
    ) -> Result<CodeImage, CliError> {
        match self {
            Engine::Cpu => Ok(apply_cpu(pp, frame)),
            #[cfg(feature = "gpu")]
            Engine::Gpu(g) => Ok(g.apply(pp, frame)?),
        }
    }
}

fn read_frame(
    path: &Path,
    args: &ApplyArgs,
    profile: &DisplayProfile,
) -> Result<XyzFrame, CliError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "exr" => {
            let opts = ReadOptions {
                allow_negative: args.allow_negative,
                sanitize: args.sanitize,
                white_for_luminance_xyz: profile.target_white_xyz_cd_m2,
            };
            let (frame, report) = read_exr(path, &opts)?;
            if args.sanitize && report.non_finite + report.negative > 0 {
                eprintln!(
                    "lumiwall: {}: replaced {} NaN/Inf and {} negative values by 0",
                    path.display(),
                    report.non_finite,
                    report.negative
                );
            }
            Ok(frame)
        }
        "png" => {
            let primaries = match args.srgb_primaries {
                SrgbPrimaries::Common => profile.common_primaries_xy,
                SrgbPrimaries::Srgb => SRGB_PRIMARIES_XY,
            };
            let m = rgb_to_xyz_matrix(&primaries, &profile.target_white_xyz_cd_m2)
                .map_err(|e| CliError::input(format!("PNG input: {e}")))?;
            Ok(read_png_srgb(path, &m)?)
        }
        _ => Err(CliError::input(format!(
            "{}: unknown input type; give an OpenEXR (.exr, XYZ in cd/m²) or an sRGB .png",
            path.display()
        ))),
    }
}

fn summary(key: &DisplayKey, out: &Path, img: &CodeImage, engine: &str) -> String {
    let c = img.counts;
    format!(
        "{key}: wrote {} ({}×{}, {} bit, {engine}); pixels out of gamut {}, over range {}, \
         NaN/Inf {}, below black {}",
        out.display(),
        img.width,
        img.height,
        img.bit_depth,
        c.out_of_gamut,
        c.over_range,
        c.invalid,
        c.below_black
    )
}

fn options(args: &ApplyArgs) -> ApplyOptions {
    post_options(args.out_of_gamut, args.bit_depth, !args.no_dither)
}

/// Post-pass options from the command line's choices.
pub(crate) fn post_options(
    oog: Option<OogArg>,
    bit_depth: Option<u32>,
    dither: bool,
) -> ApplyOptions {
    ApplyOptions {
        out_of_gamut: oog.map(|o| match o {
            OogArg::Clip => OutOfGamut::Clip,
            OogArg::FalseColour => OutOfGamut::FalseColour,
        }),
        bit_depth,
        dither,
    }
}

/// Applies `pp` to `frame`, writes the PNG to `out` and prints the summary line.
fn apply_and_write(
    engine: &Engine,
    pp: &PreparedProfile,
    frame: &XyzFrame,
    out: &Path,
) -> Result<(), CliError> {
    let img = engine.run(pp, frame)?;
    write_png(out, &img)?;
    println!("{}", summary(&pp.display, out, &img, &engine.name()));
    Ok(())
}

/// `lumiwall apply --profile`: the whole frame to one display.
fn run_single(args: &ApplyArgs, path: &Path, opts: &ApplyOptions) -> Result<(), CliError> {
    let out = args
        .out
        .clone()
        .ok_or_else(|| CliError::input("--profile needs --out FILE.png"))?;
    if args.input_right.is_some() {
        return Err(CliError::input(
            "--in-right is for a wall folder (--profiles); one profile is one eye",
        ));
    }
    let profile = DisplayProfile::load(path)?;
    let pp = PreparedProfile::new(&profile, opts)?;
    let mut frame = read_frame(&args.input, args, &profile)?;
    check_display_size(&frame, args.display_size, &profile.display).map_err(PostError::from)?;
    let label = apply_scale(args, &profile, &mut [&mut frame])?;
    let frame = stamp_scale(frame, label.as_deref(), &profile);
    apply_and_write(&Engine::choose(args.cpu), &pp, &frame, &out)
}

/// `lumiwall apply --profiles`: each display of a wall gets its tile of its eye's frame.
fn run_wall(args: &ApplyArgs, dir: &Path, opts: &ApplyOptions) -> Result<(), CliError> {
    let out_dir = args
        .out_dir
        .clone()
        .ok_or_else(|| CliError::input("--profiles needs --out-dir DIR"))?;
    let (wall, profiles) = ProfileSet::load_dir(dir)?;
    // One writer per output folder, checked before any frame is read.
    let _lock = FolderLock::acquire(&out_dir, &format!("apply of wall {wall}"))?;
    let first = profiles.first().ok_or_else(|| {
        CliError::input(format!("profile folder {} lists no display", dir.display()))
    })?;
    let tiling = WallTiling::plan(&wall, &profiles).map_err(PostError::from)?;
    if !tiling.stereo && args.input_right.is_some() {
        // Checked before any frame is read.
        return Err(PostError::from(WallError::MonoWithRightFrame { wall }).into());
    }
    let mut main = read_frame(&args.input, args, first)?;
    let mut right = match &args.input_right {
        Some(p) => Some(read_frame(p, args, first)?),
        None => None,
    };
    let label = match right.as_mut() {
        Some(r) => apply_scale(args, first, &mut [&mut main, r])?,
        None => apply_scale(args, first, &mut [&mut main])?,
    };
    let frames = EyeFrames::new(&tiling, main, right).map_err(PostError::from)?;
    let engine = Engine::choose(args.cpu);
    for job in tiling.jobs(&profiles, &frames, args.display_size) {
        let job = job?;
        let pp = PreparedProfile::new(job.profile, opts)?;
        let out = out_dir.join(format!("{}.png", job.profile.display.file_stem()));
        let tile = stamp_scale(job.tile, label.as_deref(), job.profile);
        apply_and_write(&engine, &pp, &tile, &out)?;
    }
    Ok(())
}

/// Runs `lumiwall apply`.
pub(crate) fn run(args: ApplyArgs) -> Result<(), CliError> {
    let opts = options(&args);
    match (&args.profile, &args.profiles) {
        (Some(path), _) => run_single(&args, path, &opts),
        (None, Some(dir)) => run_wall(&args, dir, &opts),
        (None, None) => Err(CliError::input("give --profile FILE or --profiles DIR")),
    }
}

/// Arguments of `lumiwall bench apply`.
#[derive(Debug, clap::Args)]
pub(crate) struct BenchArgs {
    /// Frame width in pixels.
    #[arg(long, default_value_t = 3840)]
    width: u32,
    /// Frame height in pixels.
    #[arg(long, default_value_t = 2160)]
    height: u32,
    /// Timed repetitions per row (the best is reported).
    #[arg(long, default_value_t = 5)]
    repeats: u32,
    /// Skip the GPU rows.
    #[arg(long)]
    no_gpu: bool,
}

/// Runs `lumiwall bench apply`.
pub(crate) fn bench(args: BenchArgs) -> Result<(), CliError> {
    let report = lumiwall_bench::apply::run(ApplyBenchOptions {
        width: args.width,
        height: args.height,
        repeats: args.repeats,
        gpu: !args.no_gpu,
    })?;
    print!("{report}");
    Ok(())
}
