//! `lumiwall bench apply`: post-pass throughput against a memory copy, and banding.
//!
//! [`run`] measures and returns an [`ApplyBench`]; its `Display` is the table the
//! command line prints.

use std::fmt;
use std::time::Instant;

use rayon::prelude::*;

use lumiwall_profiles::apply::model::{AnalyticDisplay, ModelProfileSpec};
use lumiwall_profiles::apply::{ApplyOptions, PreparedProfile};
use lumiwall_profiles::{BlackMode, DisplayKey, DisplayProfile, Eye, FlatField, OutOfGamut};
use lumiwall_render::post::{PostError, XyzFrame, apply_cpu, apply_cpu_into};

/// What to measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ApplyBenchOptions {
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// Timed repetitions per row (the best is reported).
    pub repeats: u32,
    /// Measure the GPU rows too (when built with the `gpu` feature).
    pub gpu: bool,
}

/// One timed path of the throughput table.
#[derive(Debug, Clone, PartialEq)]
pub struct ThroughputRow {
    /// What ran.
    pub name: String,
    /// Best wall-clock seconds of the repeats.
    pub seconds: f64,
    /// Mean CPU seconds (user + system) per run.
    pub cpu_seconds: f64,
    /// Threads the path can use.
    pub threads: f64,
}

/// One output setting of the banding table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandingRow {
    /// Output bit depth.
    pub bit_depth: u32,
    /// Ordered dithering (luminance as the mean of a 16×16 patch).
    pub dither: bool,
    /// Largest luminance step (cd/m²) between neighbouring output levels.
    pub largest_step_cd_m2: f64,
    /// Distinct output levels over the ramp.
    pub levels: usize,
}

/// Results of `lumiwall bench apply`.
#[derive(Debug, Clone, PartialEq)]
pub struct ApplyBench {
    /// `/proc/loadavg`'s 1, 5 and 15 minute load averages (empty elsewhere).
    pub load_average: String,
    /// The options measured with.
    pub options: ApplyBenchOptions,
    /// Rayon threads.
    pub threads: usize,
    /// Cores of the machine.
    pub cores: f64,
    /// The faster memory copy, Mpx/s: the reference of both % columns.
    pub memcpy_mpx_s: f64,
    /// The memory copies, then the CPU paths, then the GPU paths.
    pub rows: Vec<ThroughputRow>,
    /// Why there are no GPU rows, if the GPU was asked for but not found.
    pub gpu_note: Option<String>,
    /// The banding table.
    pub banding: Vec<BandingRow>,
}

/// Profile settings of the throughput rows: (flat field, dither, smooth frame).
const CPU_CASES: [(bool, bool, bool); 5] = [
    (false, false, false),
    (true, false, false),
    (true, true, false),
    (false, false, true),
    (true, true, true),
];

/// Output settings of the banding table: (bit depth, dither).
const BANDING_CASES: [(u32, bool); 5] =
    [(8, false), (8, true), (10, false), (10, true), (16, false)];

/// Grey-ramp steps of the banding table.
const RAMP_STEPS: usize = 4096;

/// Bit depth of the throughput rows.
const THROUGHPUT_BITS: u32 = 10;

/// Runs the benchmark.
pub fn run(opts: ApplyBenchOptions) -> Result<ApplyBench, PostError> {
    let d = AnalyticDisplay::infitec_example();
    let frame = random_frame(&d, opts.width, opts.height)?;
    let smooth = smooth_frame(&d, opts.width, opts.height)?;
    let threads = rayon::current_num_threads();
    let (mut rows, memcpy_mpx_s) = memcpy_rows(&frame, opts.repeats, threads);
    rows.extend(cpu_rows(&d, &frame, &smooth, opts.repeats)?);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
    let mut gpu_note = None;
    if opts.gpu {
        match gpu_rows(&d, &frame, opts.repeats, cores)? {
            Ok(gpu) => rows.extend(gpu),
            Err(note) => gpu_note = Some(note),
        }
    }
    let banding = BANDING_CASES
        .iter()
        .map(|&(bit_depth, dither)| banding(&d, bit_depth, dither))
        .collect::<Result<_, _>>()?;
    Ok(ApplyBench {
        load_average: load_average(),
        options: opts,
        threads,
        cores,
        memcpy_mpx_s,
        rows,
        gpu_note,
        banding,
    })
}

fn load_average() -> String {
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    load.split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

/// XYZ of linear primary mixes `l` of display `d`, in f32.
fn mix(d: &AnalyticDisplay, l: [f32; 3]) -> [f32; 3] {
    let p = d.primaries_xyz_cd_m2;
    [0, 1, 2].map(|c| (p[0][c] as f32) * l[0] + (p[1][c] as f32) * l[1] + (p[2][c] as f32) * l[2])
}

/// Mostly in-gamut colours, a tenth out of gamut or over range.
fn random_frame(d: &AnalyticDisplay, w: u32, h: u32) -> Result<XyzFrame, PostError> {
    let mut rng = lumiwall_render::rng::SplitMix64(42);
    let pixels = (0..w as usize * h as usize)
        .map(|i| {
            let k = if i % 10 == 0 { 1.6 } else { 1.0 };
            let l = [rng.unit_f32() * k, rng.unit_f32() * k, rng.unit_f32() * k];
            mix(d, l)
        })
        .collect();
    XyzFrame::new(w, h, pixels)
}

/// A smooth frame (gradients, as rendered images mostly are).
fn smooth_frame(d: &AnalyticDisplay, w: u32, h: u32) -> Result<XyzFrame, PostError> {
    let pixels = (0..w as usize * h as usize)
        .map(|i| {
            let (x, y) = (
                (i % w as usize) as f32 / w as f32,
                (i / w as usize) as f32 / h as f32,
            );
            mix(d, [x, y, 0.5 * (x + y)])
        })
        .collect();
    XyzFrame::new(w, h, pixels)
}

/// The analytic display's profile with or without a vignetting flat field.
fn bench_profile(
    d: &AnalyticDisplay,
    flat: bool,
    bit_depth: u32,
) -> Result<DisplayProfile, PostError> {
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
    Ok(d.profile(&ModelProfileSpec {
        display: DisplayKey {
            wall: "bench".into(),
            display: 0,
            tile_col: 0,
            tile_row: 0,
            eye: Eye::Mono,
        },
        black_mode: BlackMode::Individual,
        common_black_xyz_cd_m2: d.black_xyz_cd_m2,
        target_white_xyz_cd_m2: d.full_white_xyz().map(|v| v * 0.9),
        lut_entries: 4096,
        flat_field,
        out_of_gamut: OutOfGamut::Clip,
        bit_depth,
    })?)
}

pub(crate) fn prepared(
    d: &AnalyticDisplay,
    flat: bool,
    bit_depth: u32,
    dither: bool,
) -> Result<PreparedProfile, PostError> {
    let prof = bench_profile(d, flat, bit_depth)?;
    let opts = ApplyOptions {
        dither,
        ..Default::default()
    };
    Ok(PreparedProfile::new(&prof, &opts)?)
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

/// The single- and multi-threaded copies of the frame, and the faster one's Mpx/s.
fn memcpy_rows(frame: &XyzFrame, repeats: u32, threads: usize) -> (Vec<ThroughputRow>, f64) {
    let n = frame.pixels.len();
    let mut dst = vec![[0f32; 3]; n];
    let t_copy1 = best_of(repeats, || {
        dst.copy_from_slice(&frame.pixels);
        std::hint::black_box(&dst);
    });
    let t_copy_n = best_of(repeats, || {
        let chunk = n.div_ceil(threads).max(1);
        dst.par_chunks_mut(chunk)
            .zip(frame.pixels.par_chunks(chunk))
            .for_each(|(d, s)| d.copy_from_slice(s));
        std::hint::black_box(&dst);
    });
    // The bandwidth limit is the faster of the two copies; both % columns refer to it.
    // (A copy of ~10 ms is below the clock tick of the CPU-time counter, so the
    // copies' wall-clock rate is the reference of both % columns.)
    let memcpy = n as f64 / 1e6 / t_copy_n.0.min(t_copy1.0);
    let rows = vec![
        ThroughputRow {
            name: "memcpy of the XYZ frame (12 B/px, 1 thread)".into(),
            seconds: t_copy1.0,
            cpu_seconds: t_copy1.0,
            threads: 1.0,
        },
        ThroughputRow {
            name: format!("memcpy of the XYZ frame ({threads} threads)"),
            seconds: t_copy_n.0,
            cpu_seconds: t_copy_n.0 * threads as f64,
            threads: threads as f64,
        },
    ];
    (rows, memcpy)
}

/// The CPU post pass for each of [`CPU_CASES`].
fn cpu_rows(
    d: &AnalyticDisplay,
    frame: &XyzFrame,
    smooth: &XyzFrame,
    repeats: u32,
) -> Result<Vec<ThroughputRow>, PostError> {
    let n = frame.pixels.len() as f64;
    let mut out = apply_cpu(&prepared(d, false, THROUGHPUT_BITS, false)?, frame);
    let mut rows = Vec::new();
    for (flat, dither, smooth_frame) in CPU_CASES {
        let pp = prepared(d, flat, THROUGHPUT_BITS, dither)?;
        let input = if smooth_frame { smooth } else { frame };
        let (seconds, cpu_seconds) = best_of(repeats, || {
            apply_cpu_into(&pp, input, &mut out);
            std::hint::black_box(&out);
        });
        let c = &out.counts;
        let name = format!(
            "CPU, 10 bit, {}{}{} [{:.0}% over range, {:.1}% out of gamut]",
            if smooth_frame {
                "smooth frame"
            } else {
                "random frame"
            },
            if flat { ", flat field" } else { ", no texture" },
            if dither { ", dither" } else { "" },
            100.0 * c.over_range as f64 / n,
            100.0 * c.out_of_gamut as f64 / n
        );
        rows.push(ThroughputRow {
            name,
            seconds,
            cpu_seconds,
            threads: rayon::current_num_threads() as f64,
        });
    }
    Ok(rows)
}

/// The GPU post pass with and without a flat field (each profile uploaded once, frames
/// up and codes back in every run); `Ok(Err(note))` when there is no GPU.
#[cfg(feature = "gpu")]
fn gpu_rows(
    d: &AnalyticDisplay,
    frame: &XyzFrame,
    repeats: u32,
    cores: f64,
) -> Result<Result<Vec<ThroughputRow>, String>, PostError> {
    let g = match lumiwall_render::post::GpuPost::new() {
        Ok(g) => g,
        Err(e) => return Ok(Err(format!("GPU: {e} (no GPU row)"))),
    };
    let mut rows = Vec::new();
    for flat in [false, true] {
        let pp = prepared(d, flat, THROUGHPUT_BITS, false)?;
        let mut gp = g.prepare(&pp);
        gp.apply(frame)?; // warm-up
        let (seconds, cpu_seconds) = best_of(repeats.min(3), || {
            let _ = std::hint::black_box(gp.apply(frame));
        });
        let name = format!(
            "GPU {}{} incl. transfers",
            g.adapter_name().chars().take(22).collect::<String>(),
            if flat { ", flat" } else { "" }
        );
        rows.push(ThroughputRow {
            name,
            seconds,
            cpu_seconds,
            threads: cores,
        });
    }
    Ok(Ok(rows))
}

/// Without the `gpu` feature there are no GPU rows (and no note).
#[cfg(not(feature = "gpu"))]
fn gpu_rows(
    _d: &AnalyticDisplay,
    _frame: &XyzFrame,
    _repeats: u32,
    _cores: f64,
) -> Result<Result<Vec<ThroughputRow>, String>, PostError> {
    Ok(Ok(Vec::new()))
}

/// Luminance (cd/m², above black) of each step of a 0–1 cd/m² grey ramp after
/// quantisation. With `dither`, each ramp value is a 16×16 patch and its mean is used.
fn ramp_luminances(
    d: &AnalyticDisplay,
    pp: &PreparedProfile,
    white: [f64; 3],
    dither: bool,
) -> Result<Vec<f64>, PostError> {
    let b = d.black_xyz_cd_m2;
    let max = f64::from(pp.max_code());
    let side = if dither { 16 } else { 1 };
    let mut lums = Vec::with_capacity(RAMP_STEPS + 1);
    for i in 0..=RAMP_STEPS {
        let y = i as f64 / RAMP_STEPS as f64;
        let xyz = [0, 1, 2].map(|c| (b[c] + white[c] / white[1] * y) as f32);
        let out = pp.apply(xyz, [0.5, 0.5]);
        let mut sum = 0.0;
        for py in 0..side {
            for px in 0..side {
                let codes = pp.quantise_pixel(out.drive, px, py);
                sum += d.emitted_xyz(codes.map(|c| f64::from(c) / max), [1.0; 3])?[1];
            }
        }
        lums.push(sum / f64::from(side * side) - b[1]);
    }
    Ok(lums)
}

/// Largest luminance step (cd/m²) between neighbouring output levels of a 0–1 cd/m²
/// grey ramp above the display's black, and the number of distinct levels.
fn banding(d: &AnalyticDisplay, bit_depth: u32, dither: bool) -> Result<BandingRow, PostError> {
    let prof = bench_profile(d, false, bit_depth)?;
    let opts = ApplyOptions {
        dither,
        ..Default::default()
    };
    let pp = PreparedProfile::new(&prof, &opts)?;
    let lums = ramp_luminances(d, &pp, prof.target_white_xyz_cd_m2, dither)?;
    let mut largest: f64 = 0.0;
    let mut levels = 1;
    for pair in lums.windows(2) {
        let step = (pair[1] - pair[0]).abs();
        if step > 1e-12 {
            levels += 1;
        }
        largest = largest.max(step);
    }
    Ok(BandingRow {
        bit_depth,
        dither,
        largest_step_cd_m2: largest,
        levels,
    })
}

impl ApplyBench {
    fn write_header(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (w, h) = (self.options.width, self.options.height);
        let n = w as usize * h as usize;
        let mp = n as f64 / 1e6;
        writeln!(
            f,
            "machine load average (1/5/15 min): {}",
            self.load_average
        )?;
        writeln!(
            f,
            "post pass on a {w}×{h} frame ({mp:.2} Mpx, XYZ f32 = {:.0} MB), best of {}, {} CPU threads",
            n as f64 * 12.0 / 1e6,
            self.options.repeats,
            self.threads
        )?;
        writeln!(
            f,
            "{:<80} {:>8} {:>8} {:>8} {:>9} {:>9} {:>8}",
            "path", "ms", "Mpx/s", "%memcpy", "Mpx/CPU-s", "idle est.", "%memcpy"
        )
    }

    /// Under load the wall clock depends on the other jobs; Mpx per CPU-second does not
    /// (much). "idle est." = Mpx/CPU-s × threads the path can use on this machine.
    fn write_row(&self, f: &mut fmt::Formatter<'_>, row: &ThroughputRow) -> fmt::Result {
        let mp = self.options.width as usize as f64 * self.options.height as usize as f64 / 1e6;
        let memcpy = self.memcpy_mpx_s;
        let t = row.seconds;
        let per_cpu = mp / row.cpu_seconds.max(1e-9);
        let idle = per_cpu * row.threads.min(self.cores);
        writeln!(
            f,
            "{:<80} {:>8.1} {:>8.1} {:>7.1}% {:>9.1} {:>9.1} {:>7.1}%",
            row.name,
            t * 1e3,
            mp / t,
            100.0 * (mp / t) / memcpy,
            per_cpu,
            idle,
            100.0 * idle / memcpy
        )
    }

    fn write_banding(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f)?;
        writeln!(
            f,
            "banding: 0–1 cd/m² grey ramp above black (4096 steps), luminance after quantisation"
        )?;
        writeln!(
            f,
            "{:<28} {:>22} {:>10}",
            "output", "largest step (cd/m²)", "levels"
        )?;
        for row in &self.banding {
            let label = format!(
                "{} bit{}",
                row.bit_depth,
                if row.dither {
                    ", dithered 16×16 mean"
                } else {
                    ""
                }
            );
            writeln!(
                f,
                "{:<28} {:>22.5} {:>10}",
                label, row.largest_step_cd_m2, row.levels
            )?;
        }
        Ok(())
    }
}

impl fmt::Display for ApplyBench {
    /// The tables as `lumiwall bench apply` prints them (every line ends in a newline).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write_header(f)?;
        for row in &self.rows {
            self.write_row(f, row)?;
        }
        if let Some(note) = &self.gpu_note {
            writeln!(f, "{note}")?;
        }
        self.write_banding(f)
    }
}
