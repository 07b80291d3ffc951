//! `lumiwall apply`: display profiles applied to an XYZ (cd/m²) frame, one output image
//! per display and eye; and `lumiwall bench apply`: post-pass throughput and banding.

use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

use lumiwall_profiles::apply::model::{AnalyticDisplay, ModelProfileSpec, ToneShape};
use lumiwall_profiles::apply::srgb::SRGB_PRIMARIES_XY;
use lumiwall_profiles::apply::{ApplyOptions, PreparedProfile, rgb_to_xyz_matrix};
use lumiwall_profiles::{
    BlackMode, DisplayKey, DisplayProfile, Eye, FlatField, OutOfGamut, ProfileError, ProfileSet,
};
use lumiwall_render::post::io::{ReadOptions, read_exr, read_png_srgb, write_png};
use lumiwall_render::post::{CodeImage, PostError, XyzFrame, apply_cpu, apply_cpu_into};

use crate::CliError;

/// Out-of-gamut handling chosen on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OogArg {
    /// Move out-of-gamut colours toward white, scale over-range ones down.
    Clip,
    /// Mark them: magenta out of gamut, cyan over range, yellow NaN/Inf.
    FalseColour,
}

/// Primaries assumed for sRGB/PNG input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SrgbPrimaries {
    /// The wall's common primaries (Kresse 3.3.5: uncalibrated input fills the common gamut).
    Common,
    /// The sRGB / Rec. 709 primaries (colorimetric; colours outside the wall gamut clip).
    Srgb,
}

/// Arguments of `lumiwall apply`.
#[derive(Debug, clap::Args)]
pub struct ApplyArgs {
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
    /// Use the GPU (the default when an adapter exists).
    #[arg(long, conflicts_with = "cpu")]
    gpu: bool,
    /// Use the CPU reference only.
    #[arg(long)]
    cpu: bool,
    /// Ordered dithering before quantisation.
    #[arg(long)]
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
    display_size: Option<String>,
    /// Primaries assumed for PNG input.
    #[arg(long, value_enum, default_value = "common")]
    srgb_primaries: SrgbPrimaries,
}

fn post_err(e: PostError) -> CliError {
    match e {
        PostError::Gpu(_) => CliError::failure(e.to_string()),
        _ => CliError::input(e.to_string()),
    }
}

fn profile_err(e: ProfileError) -> CliError {
    CliError::input(e.to_string())
}

fn parse_size(s: &str) -> Result<(u32, u32), CliError> {
    let bad = || {
        CliError::input(format!(
            "--display-size {s:?} is not WIDTHxHEIGHT, e.g. 1920x1080"
        ))
    };
    let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    Ok((
        w.trim().parse().map_err(|_| bad())?,
        h.trim().parse().map_err(|_| bad())?,
    ))
}

/// The post pass engine chosen for this run.
enum Engine {
    Cpu,
    #[cfg(feature = "gpu")]
    Gpu(Box<lumiwall_render::post::GpuPost>),
}

impl Engine {
    fn choose(cpu_only: bool) -> Engine {
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

    fn name(&self) -> String {
        match self {
            Engine::Cpu => format!("CPU ({} threads)", rayon::current_num_threads()),
            #[cfg(feature = "gpu")]
            Engine::Gpu(g) => format!("GPU {}", g.adapter_name()),
        }
    }

    fn run(&self, pp: &PreparedProfile, frame: &XyzFrame) -> Result<CodeImage, CliError> {
        match self {
            Engine::Cpu => Ok(apply_cpu(pp, frame)),
            #[cfg(feature = "gpu")]
            Engine::Gpu(g) => g.apply(pp, frame).map_err(post_err),
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
            let (frame, report) = read_exr(path, &opts).map_err(post_err)?;
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
            read_png_srgb(path, &m).map_err(post_err)
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
    ApplyOptions {
        out_of_gamut: args.out_of_gamut.map(|o| match o {
            OogArg::Clip => OutOfGamut::Clip,
            OogArg::FalseColour => OutOfGamut::FalseColour,
        }),
        bit_depth: args.bit_depth,
        dither: args.dither,
    }
}

fn check_size(
    frame: &XyzFrame,
    expected: Option<(u32, u32)>,
    key: &DisplayKey,
) -> Result<(), CliError> {
    match expected {
        Some((w, h)) if (frame.width, frame.height) != (w, h) => Err(CliError::input(format!(
            "size mismatch: {key} expects {w}×{h} but its image is {}×{}",
            frame.width, frame.height
        ))),
        _ => Ok(()),
    }
}

/// Runs `lumiwall apply`.
pub fn run(args: ApplyArgs) -> Result<(), CliError> {
    let expected = args.display_size.as_deref().map(parse_size).transpose()?;
    let opts = options(&args);
    if let Some(path) = &args.profile {
        let out = args
            .out
            .clone()
            .ok_or_else(|| CliError::input("--profile needs --out FILE.png"))?;
        if args.input_right.is_some() {
            return Err(CliError::input(
                "--in-right is for a wall folder (--profiles); one profile is one eye",
            ));
        }
        let profile = DisplayProfile::load(path).map_err(profile_err)?;
        let pp =
            PreparedProfile::new(&profile, &opts).map_err(|e| CliError::input(e.to_string()))?;
        let frame = read_frame(&args.input, &args, &profile)?;
        check_size(&frame, expected, &profile.display)?;
        let engine = Engine::choose(args.cpu);
        let img = engine.run(&pp, &frame)?;
        write_png(&out, &img).map_err(post_err)?;
        println!("{}", summary(&profile.display, &out, &img, &engine.name()));
        return Ok(());
    }
    let dir = args
        .profiles
        .clone()
        .ok_or_else(|| CliError::input("give --profile FILE or --profiles DIR"))?;
    let out_dir = args
        .out_dir
        .clone()
        .ok_or_else(|| CliError::input("--profiles needs --out-dir DIR"))?;
    let (wall, profiles) = ProfileSet::load_dir(&dir).map_err(profile_err)?;
    let first = profiles.first().ok_or_else(|| {
        CliError::input(format!("profile folder {} lists no display", dir.display()))
    })?;
    let stereo = profiles.iter().any(|p| p.display.eye != Eye::Mono);
    if !stereo && args.input_right.is_some() {
        return Err(CliError::input(format!(
            "wall {wall} is mono: --in-right has no display to go to"
        )));
    }
    let cols = profiles
        .iter()
        .map(|p| p.display.tile_col)
        .max()
        .unwrap_or(0)
        + 1;
    let rows = profiles
        .iter()
        .map(|p| p.display.tile_row)
        .max()
        .unwrap_or(0)
        + 1;
    // One frame per eye (mono walls: one frame, no per-eye work).
    let main = read_frame(&args.input, &args, first)?;
    let right = match &args.input_right {
        Some(p) => Some(read_frame(p, &args, first)?),
        None => None,
    };
    if let Some(r) = &right
        && (r.width, r.height) != (main.width, main.height)
    {
        return Err(CliError::input(format!(
            "size mismatch: left frame {}×{}, right frame {}×{}",
            main.width, main.height, r.width, r.height
        )));
    }
    let engine = Engine::choose(args.cpu);
    for profile in &profiles {
        let key = &profile.display;
        let frame = match (key.eye, &right) {
            (Eye::Right, Some(r)) => r,
            _ => &main,
        };
        let tile = frame
            .tile(cols, rows, key.tile_col, key.tile_row)
            .map_err(post_err)?;
        check_size(&tile, expected, key)?;
        let pp =
            PreparedProfile::new(profile, &opts).map_err(|e| CliError::input(e.to_string()))?;
        let img = engine.run(&pp, &tile)?;
        let out = out_dir.join(format!("{}.png", key.file_stem()));
        write_png(&out, &img).map_err(post_err)?;
        println!("{}", summary(key, &out, &img, &engine.name()));
    }
    Ok(())
}

/// Arguments of `lumiwall bench apply`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
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

fn bench_display() -> AnalyticDisplay {
    let p = |x: f64, y: f64, l: f64| [x / y * l, l, (1.0 - x - y) / y * l];
    AnalyticDisplay {
        primaries_xyz_cd_m2: [
            p(0.625, 0.370, 21.0),
            p(0.286, 0.613, 55.0),
            p(0.140, 0.045, 6.5),
        ],
        black_xyz_cd_m2: p(0.29, 0.31, 0.35),
        tone: [
            ToneShape {
                gamma: 2.1,
                s_mix: 0.3,
            },
            ToneShape {
                gamma: 2.3,
                s_mix: 0.4,
            },
            ToneShape {
                gamma: 1.9,
                s_mix: 0.2,
            },
        ],
    }
}

fn bench_profile(
    d: &AnalyticDisplay,
    flat: bool,
    bit_depth: u32,
) -> Result<DisplayProfile, CliError> {
    let full: [f64; 3] =
        [0, 1, 2].map(|i| (0..3).map(|c| d.primaries_xyz_cd_m2[c][i]).sum::<f64>());
    let flat_field = flat.then(|| {
        let (w, h) = (64u32, 32u32);
        let gain = (0..w * h)
            .map(|i| {
                let u = ((i % w) as f32 + 0.5) / w as f32 - 0.5;
                let v = ((i / w) as f32 + 0.5) / h as f32 - 0.5;
                [(1.0 - 0.9 * (u * u + v * v)).clamp(0.55, 1.0); 3]
            })
            .collect();
        FlatField {
            width: w,
            height: h,
            gain,
        }
    });
    d.profile(&ModelProfileSpec {
        display: DisplayKey {
            wall: "bench".into(),
            display: 0,
            tile_col: 0,
            tile_row: 0,
            eye: Eye::Mono,
        },
        black_mode: BlackMode::Individual,
        common_black_xyz_cd_m2: d.black_xyz_cd_m2,
        target_white_xyz_cd_m2: full.map(|v| v * 0.9),
        lut_entries: 4096,
        flat_field,
        out_of_gamut: OutOfGamut::Clip,
        bit_depth,
    })
    .map_err(|e| CliError::failure(e.to_string()))
}

/// CPU seconds (user + system) this process has used so far, from `/proc/self/stat`
/// (Linux; 0 elsewhere). Clock ticks are taken as 100 per second (the Linux default).
fn process_cpu_s() -> f64 {
    let text = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the parenthesised command name; utime and stime are fields 14, 15.
    let rest = text.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

/// Best wall-clock seconds of `repeats` runs, and mean CPU seconds per run.
fn best_of(repeats: u32, mut f: impl FnMut()) -> (f64, f64) {
    let mut best = f64::INFINITY;
    let cpu0 = process_cpu_s();
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        f();
        best = best.min(t.elapsed().as_secs_f64());
    }
    (best, (process_cpu_s() - cpu0) / f64::from(repeats.max(1)))
}

/// Largest luminance step (cd/m²) between neighbouring output levels of a 0–1 cd/m²
/// grey ramp above the display's black, and the number of distinct levels. With
/// `dither`, each ramp value is a 16×16 patch and its mean luminance is used.
fn banding(d: &AnalyticDisplay, bit_depth: u32, dither: bool) -> Result<(f64, usize), CliError> {
    let prof = bench_profile(d, false, bit_depth)?;
    let pp = PreparedProfile::new(
        &prof,
        &ApplyOptions {
            dither,
            ..Default::default()
        },
    )
    .map_err(|e| CliError::failure(e.to_string()))?;
    let w = prof.target_white_xyz_cd_m2;
    let b = d.black_xyz_cd_m2;
    let max = f64::from(pp.max_code());
    let steps = 4096;
    let side = if dither { 16 } else { 1 };
    let mut lums = Vec::with_capacity(steps + 1);
    for i in 0..=steps {
        let y = i as f64 / steps as f64;
        let xyz = [0, 1, 2].map(|c| (b[c] + w[c] / w[1] * y) as f32);
        let out = pp.apply(xyz, [0.5, 0.5]);
        let mut sum = 0.0;
        for py in 0..side {
            for px in 0..side {
                let codes = pp.quantise_pixel(out.drive, px, py);
                let e = d
                    .emitted_xyz(codes.map(|c| f64::from(c) / max), [1.0; 3])
                    .map_err(|e| CliError::failure(e.to_string()))?;
                sum += e[1];
            }
        }
        lums.push(sum / f64::from(side * side) - b[1]);
    }
    let mut largest: f64 = 0.0;
    let mut levels = 1;
    for pair in lums.windows(2) {
        let step = (pair[1] - pair[0]).abs();
        if step > 1e-12 {
            levels += 1;
        }
        largest = largest.max(step);
    }
    Ok((largest, levels))
}

/// Runs `lumiwall bench apply`.
pub fn bench(args: BenchArgs) -> Result<(), CliError> {
    let (w, h) = (args.width, args.height);
    let n = w as usize * h as usize;
    let mp = n as f64 / 1e6;
    let d = bench_display();
    // Mostly in-gamut colours, a tenth out of gamut or over range.
    let mut rng = lumiwall_render::rng::SplitMix64(42);
    let p = d.primaries_xyz_cd_m2;
    let pixels: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let k = if i % 10 == 0 { 1.6 } else { 1.0 };
            let l = [rng.unit_f32() * k, rng.unit_f32() * k, rng.unit_f32() * k];
            [0, 1, 2].map(|c| {
                (p[0][c] as f32) * l[0] + (p[1][c] as f32) * l[1] + (p[2][c] as f32) * l[2]
            })
        })
        .collect();
    let frame = XyzFrame::new(w, h, pixels).map_err(post_err)?;
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "machine load average (1/5/15 min): {}",
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!(
        "post pass on a {w}×{h} frame ({mp:.2} Mpx, XYZ f32 = {:.0} MB), best of {}, {} CPU threads",
        n as f64 * 12.0 / 1e6,
        args.repeats,
        rayon::current_num_threads()
    );
    println!(
        "{:<80} {:>8} {:>8} {:>8} {:>9} {:>9} {:>8}",
        "path", "ms", "Mpx/s", "%memcpy", "Mpx/CPU-s", "idle est.", "%memcpy"
    );
    let mut dst = vec![[0f32; 3]; n];
    let t_copy1 = best_of(args.repeats, || {
        dst.copy_from_slice(&frame.pixels);
        std::hint::black_box(&dst);
    });
    let threads = rayon::current_num_threads();
    let t_copy_n = best_of(args.repeats, || {
        let chunk = n.div_ceil(threads).max(1);
        dst.par_chunks_mut(chunk)
            .zip(frame.pixels.par_chunks(chunk))
            .for_each(|(d, s)| d.copy_from_slice(s));
        std::hint::black_box(&dst);
    });
    // The bandwidth limit is the faster of the two copies; both % columns refer to it.
    // (A copy of ~10 ms is below the clock tick of the CPU-time counter, so the
    // copies' wall-clock rate is the reference of both % columns.)
    let memcpy = mp / t_copy_n.0.min(t_copy1.0);
    // Under load the wall clock depends on the other jobs; Mpx per CPU-second does not
    // (much). "idle est." = Mpx/CPU-s × threads the path can use on this machine.
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
    let row = |name: &str, (t, cpu): (f64, f64), threads: f64| {
        let per_cpu = mp / cpu.max(1e-9);
        let idle = per_cpu * threads.min(cores);
        println!(
            "{:<80} {:>8.1} {:>8.1} {:>7.1}% {:>9.1} {:>9.1} {:>7.1}%",
            name,
            t * 1e3,
            mp / t,
            100.0 * (mp / t) / memcpy,
            per_cpu,
            idle,
            100.0 * idle / memcpy
        );
    };
    row(
        "memcpy of the XYZ frame (12 B/px, 1 thread)",
        (t_copy1.0, t_copy1.0),
        1.0,
    );
    row(
        &format!("memcpy of the XYZ frame ({threads} threads)"),
        (t_copy_n.0, t_copy_n.0 * threads as f64),
        threads as f64,
    );
    // A smooth frame (gradients, as rendered images mostly are) next to the random one.
    let smooth: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let (x, y) = (
                (i % w as usize) as f32 / w as f32,
                (i / w as usize) as f32 / h as f32,
            );
            let l = [x, y, 0.5 * (x + y)];
            [0, 1, 2].map(|c| {
                (p[0][c] as f32) * l[0] + (p[1][c] as f32) * l[1] + (p[2][c] as f32) * l[2]
            })
        })
        .collect();
    let smooth = XyzFrame::new(w, h, smooth).map_err(post_err)?;
    let mut out = apply_cpu(
        &PreparedProfile::new(&bench_profile(&d, false, 10)?, &ApplyOptions::default())
            .map_err(|e| CliError::failure(e.to_string()))?,
        &frame,
    );
    for (flat, dither, smooth_frame) in [
        (false, false, false),
        (true, false, false),
        (true, true, false),
        (false, false, true),
        (true, true, true),
    ] {
        let prof = bench_profile(&d, flat, 10)?;
        let pp = PreparedProfile::new(
            &prof,
            &ApplyOptions {
                dither,
                ..Default::default()
            },
        )
        .map_err(|e| CliError::failure(e.to_string()))?;
        let input = if smooth_frame { &smooth } else { &frame };
        let t = best_of(args.repeats, || {
            apply_cpu_into(&pp, input, &mut out);
            std::hint::black_box(&out);
        });
        let c = &out.counts;
        row(
            &format!(
                "CPU, 10 bit, {}{}{} [{:.0}% over range, {:.1}% out of gamut]",
                if smooth_frame {
                    "smooth frame"
                } else {
                    "random frame"
                },
                if flat { ", flat field" } else { ", no texture" },
                if dither { ", dither" } else { "" },
                100.0 * c.over_range as f64 / n as f64,
                100.0 * c.out_of_gamut as f64 / n as f64
            ),
            t,
            rayon::current_num_threads() as f64,
        );
    }
    #[cfg(feature = "gpu")]
    if !args.no_gpu {
        match lumiwall_render::post::GpuPost::new() {
            Ok(g) => {
                for flat in [false, true] {
                    let prof = bench_profile(&d, flat, 10)?;
                    let pp = PreparedProfile::new(&prof, &ApplyOptions::default())
                        .map_err(|e| CliError::failure(e.to_string()))?;
                    g.apply(&pp, &frame).map_err(post_err)?; // warm-up
                    let t = best_of(args.repeats.min(3), || {
                        let _ = std::hint::black_box(g.apply(&pp, &frame));
                    });
                    row(
                        &format!(
                            "GPU {}{} incl. transfers",
                            g.adapter_name().chars().take(22).collect::<String>(),
                            if flat { ", flat" } else { "" }
                        ),
                        t,
                        cores,
                    );
                }
            }
            Err(e) => println!("GPU: {e} (no GPU row)"),
        }
    }
    println!();
    println!("banding: 0–1 cd/m² grey ramp above black (4096 steps), luminance after quantisation");
    println!(
        "{:<28} {:>22} {:>10}",
        "output", "largest step (cd/m²)", "levels"
    );
    for (bits, dither) in [(8, false), (8, true), (10, false), (10, true), (16, false)] {
        let (step, levels) = banding(&d, bits, dither)?;
        println!(
            "{:<28} {:>22.5} {:>10}",
            format!(
                "{bits} bit{}",
                if dither { ", dithered 16×16 mean" } else { "" }
            ),
            step,
            levels
        );
    }
    Ok(())
}
