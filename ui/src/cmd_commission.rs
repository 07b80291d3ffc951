//! `lumiwall commission` (measure a wall, solve, write profiles and report) and
//! `lumiwall bench readings` (verify accuracy against meter readings per display).
//!
//! Also holds the station set-up shared with `lumiwall verify`: the virtual wall and
//! the meter path (`--meter emulated` serves the simulated meter through the Klein
//! K-10A protocol on a pseudo-terminal and reads it with the real serial driver;
//! `--meter direct` skips the pty; `--meter serial:/dev/ttyUSB0` opens a real meter).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use lumiwall_calib::colorimetry::cct_to_xy;
use lumiwall_calib::commission::{CommissionOptions, CommissionOutcome, commission};
use lumiwall_calib::measure::{LowLight, MeasureOptions, Progress, Rig};
use lumiwall_calib::solve::{SolveOptions, WhiteTarget};
use lumiwall_calib::verify::{VerifyOptions, default_targets, verify_wall};
use lumiwall_devices::serial::{Emulator, EmulatorOptions, FaultPlan, K10aConfig, KleinK10a};
use lumiwall_devices::sim::{MeterModel, SimPatternOutput, SimPositioner, VirtualWall};
use lumiwall_devices::{Colorimeter, DisplayInfo};
use lumiwall_profiles::{BlackMode, MIN_LUT_ENTRIES, OutOfGamut, ProfileSet};

use crate::CliError;

/// Which meter the station reads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MeterChoice {
    /// The simulated meter served on a pty by the instrument emulator, read by the
    /// serial driver (the default: exercises the real protocol).
    Emulated,
    /// The simulated meter called directly (fast; for comparisons and big benches).
    Direct,
    /// A real Klein K-10A on this serial port.
    Serial(String),
}

impl std::str::FromStr for MeterChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "emulated" => Ok(Self::Emulated),
            "direct" => Ok(Self::Direct),
            _ => match s.strip_prefix("serial:") {
                Some(p) if !p.is_empty() => Ok(Self::Serial(p.to_string())),
                _ => Err(format!(
                    "unknown meter '{s}': use emulated, direct or serial:/dev/ttyUSB0"
                )),
            },
        }
    }
}

/// Error model of the simulated meter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Noise {
    /// The instrument's datasheet error model (CS-100A class: 2 % luminance, ±0.004 xy,
    /// worse below 1 cd/m²).
    Realistic,
    /// Exact readings.
    None,
}

impl Noise {
    /// The simulated meter's model; `seed` plays the instrument's serial number.
    pub fn model(self, seed: u64) -> MeterModel {
        match self {
            Noise::Realistic => MeterModel::cs100a(seed),
            Noise::None => MeterModel::noiseless(),
        }
    }
}

/// Black handling (Kresse 3.3.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BlackArg {
    /// Ignore black: every display adds its own.
    Ignore,
    /// Subtract each display's own black.
    Individual,
    /// Raise every display to the common (worst) black.
    Common,
}

impl From<BlackArg> for BlackMode {
    fn from(b: BlackArg) -> Self {
        match b {
            BlackArg::Ignore => BlackMode::Ignore,
            BlackArg::Individual => BlackMode::Individual,
            BlackArg::Common => BlackMode::Common,
        }
    }
}

/// Parses `8500K`, `xy:0.291,0.300` or `native:3`.
pub fn parse_white(s: &str) -> Result<WhiteTarget, String> {
    let t = s.trim();
    if let Some(k) = t.strip_suffix(['K', 'k']) {
        let kelvin: f64 = k
            .trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a colour temperature like 8500K"))?;
        return Ok(WhiteTarget::Cct(kelvin));
    }
    if let Some(xy) = t.strip_prefix("xy:") {
        let v: Vec<f64> = xy
            .split(',')
            .map(|p| p.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("'{s}' is not a chromaticity like xy:0.291,0.300"))?;
        if v.len() != 2 || !(v[0] > 0.0 && v[1] > 0.0 && v[0] + v[1] < 1.0) {
            return Err(format!(
                "'{s}' is not a valid chromaticity like xy:0.291,0.300"
            ));
        }
        return Ok(WhiteTarget::Xy([v[0], v[1]]));
    }
    if let Some(n) = t.strip_prefix("native:") {
        let i: usize = n
            .trim()
            .parse()
            .map_err(|_| format!("'{s}' does not name a display like native:3"))?;
        return Ok(WhiteTarget::NativeOf(i));
    }
    Err(format!(
        "white '{s}' not understood: use 8500K, xy:0.291,0.300 or native:3"
    ))
}

/// The devices of a station: the virtual wall's pattern output and positioner and a
/// meter (possibly behind the pty emulator).
pub struct Station {
    /// The virtual wall.
    pub wall: VirtualWall,
    /// Pattern output.
    pub pattern: SimPatternOutput,
    /// Positioner.
    pub positioner: SimPositioner,
    /// The meter as the calibration sees it.
    pub meter: Box<dyn Colorimeter + Send>,
    /// The emulator serving the pty, if any (stopped on drop of the station).
    _emulator: Option<Emulator>,
}

impl Station {
    /// Opens the wall file and the chosen meter.
    /// `time_scale` scales the emulated instrument's measurement time (1 = real).
    pub fn open(
        wall_path: &Path,
        meter: &MeterChoice,
        noise: Noise,
        time_scale: f64,
    ) -> Result<Self, CliError> {
        Self::open_with_faults(wall_path, meter, noise, time_scale, FaultPlan::default())
    }

    /// Like [`Station::open`], with faults injected into the emulated meter.
    pub fn open_with_faults(
        wall_path: &Path,
        meter: &MeterChoice,
        noise: Noise,
        time_scale: f64,
        faults: FaultPlan,
    ) -> Result<Self, CliError> {
        let wall = VirtualWall::from_toml_file(wall_path).map_err(|e| {
            CliError::input(format!("cannot load wall {}: {e}", wall_path.display()))
        })?;
        let model = noise.model(wall.seed());
        let (meter, emulator): (Box<dyn Colorimeter + Send>, Option<Emulator>) = match meter {
            MeterChoice::Direct => (Box::new(wall.meter(model)), None),
            MeterChoice::Emulated => {
                let sim = Box::new(wall.meter(model));
                let (emu, port) =
                    Emulator::spawn_with(sim, faults, EmulatorOptions::with_time_scale(time_scale))
                        .map_err(|e| {
                            CliError::failure(format!("cannot start the meter emulator: {e}"))
                        })?;
                let driver = port.open(driver_config()).map_err(|e| {
                    CliError::failure(format!("cannot open the emulated meter: {e}"))
                })?;
                (Box::new(driver), Some(emu))
            }
            MeterChoice::Serial(path) => {
                let driver = KleinK10a::open(path, driver_config()).map_err(|e| {
                    CliError::failure(format!("cannot open the meter on {path}: {e}"))
                })?;
                (Box::new(driver), None)
            }
        };
        let pattern = wall.pattern_output();
        let positioner = wall.positioner();
        Ok(Self {
            wall,
            pattern,
            positioner,
            meter,
            _emulator: emulator,
        })
    }

    /// The displays of the wall.
    pub fn displays(&self) -> Vec<DisplayInfo> {
        self.wall.displays()
    }

    /// The three devices as the calibration sees them.
    pub fn rig(&mut self) -> Rig<'_> {
        Rig {
            pattern: &mut self.pattern,
            meter: self.meter.as_mut(),
            positioner: &mut self.positioner,
        }
    }
}

/// Driver settings: the calibration retries transient errors itself, so the driver
/// does not (a dead meter is reported after one timeout per attempt).
fn driver_config() -> K10aConfig {
    K10aConfig {
        retries: 0,
        read_timeout: Duration::from_secs(2),
        ..K10aConfig::default()
    }
}

/// Arguments of `lumiwall commission`.
#[derive(Debug, clap::Args)]
pub struct CommissionArgs {
    /// Wall description (TOML), e.g. fixtures/walls/heyewall-48.toml.
    #[arg(long)]
    pub wall: PathBuf,
    /// Output folder: profiles, report and the run folder (for --resume).
    #[arg(long)]
    pub out: PathBuf,
    /// Target white: a CCT (8500K, CIE daylight locus), xy:0.291,0.300, or native:N
    /// (the native white of display N).
    #[arg(long, default_value = "8500K", value_parser = parse_white)]
    pub white: WhiteTarget,
    /// Black handling.
    #[arg(long, value_enum, default_value = "individual")]
    pub black: BlackArg,
    /// Largest channel usage for the common white (e.g. 0.9 leaves room for lamp ageing).
    #[arg(long, default_value_t = 1.0)]
    pub headroom: f64,
    /// Meter: emulated (simulated meter through the serial protocol on a pty), direct,
    /// or serial:PATH for a real Klein K-10A.
    #[arg(long, default_value = "emulated")]
    pub meter: MeterChoice,
    /// Error model of the simulated meter.
    #[arg(long, value_enum, default_value = "realistic")]
    pub noise: Noise,
    /// Speed of the emulated instrument: factor on its real measurement time
    /// (1 = a real K-10A's timing).
    #[arg(long, default_value_t = 0.1)]
    pub time_scale: f64,
    /// Meter readings allowed per display.
    #[arg(long, default_value_t = 40)]
    pub budget: u32,
    /// Below the meter's reliable limit: average N readings (avg:N) or skip ramp
    /// samples (skip).
    #[arg(long, default_value = "avg:4", value_parser = parse_low_light)]
    pub low_light: LowLight,
    /// Continue an interrupted run from the measurements saved in OUT/run.
    #[arg(long)]
    pub resume: bool,
    /// Fault injection for demonstrations and tests: the emulated meter stops answering
    /// after this many readings (`--meter emulated` only).
    #[arg(long, hide = true)]
    pub fault_stop_after: Option<u32>,
    /// Do not estimate and correct the meter's systematic xy offset from the displays'
    /// additivity (use for walls of non-additive displays such as DLP).
    #[arg(long)]
    pub no_meter_correction: bool,
}

/// Parses `avg:N` or `skip`.
pub fn parse_low_light(s: &str) -> Result<LowLight, String> {
    if s == "skip" {
        return Ok(LowLight::Skip);
    }
    s.strip_prefix("avg:")
        .and_then(|n| n.parse::<u32>().ok())
        .filter(|n| *n >= 1)
        .map(|repeats| LowLight::Average { repeats })
        .ok_or_else(|| format!("'{s}': use avg:N (N ≥ 1) or skip"))
}

/// Solve options from the command line.
pub fn solve_options(
    white: WhiteTarget,
    black: BlackArg,
    headroom: f64,
) -> Result<SolveOptions, CliError> {
    if !(headroom > 0.0 && headroom <= 1.0) {
        return Err(CliError::input(format!(
            "--headroom {headroom} must be in (0, 1]"
        )));
    }
    if let WhiteTarget::Cct(k) = white {
        cct_to_xy(k).map_err(|e| CliError::input(e.to_string()))?;
    }
    Ok(SolveOptions {
        white,
        headroom,
        black_mode: black.into(),
        out_of_gamut: OutOfGamut::Clip,
        lut_entries: MIN_LUT_ENTRIES.max(4096),
        max_additivity_error: 0.02,
    })
}

/// Prints a line above the progress bar, or plainly when the bar is hidden (output
/// not a terminal).
fn say(pb: &ProgressBar, line: String) {
    if pb.is_hidden() {
        println!("{line}");
    } else {
        pb.println(line);
    }
}

fn progress_bar(len: u64) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} readings {msg} [{elapsed}, eta {eta}]")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb
}

/// Runs `lumiwall commission`.
pub fn run(args: CommissionArgs) -> Result<(), CliError> {
    let solve = solve_options(args.white, args.black, args.headroom)?;
    let faults = FaultPlan {
        stop_after_readings: args.fault_stop_after,
        ..FaultPlan::default()
    };
    let mut station =
        Station::open_with_faults(&args.wall, &args.meter, args.noise, args.time_scale, faults)?;
    let displays = station.displays();
    let wall = station.wall.name();
    let opts = CommissionOptions {
        measure: MeasureOptions {
            budget: args.budget,
            low_light: args.low_light,
            ..MeasureOptions::default()
        },
        solve,
        resume: args.resume,
        meter_correction: !args.no_meter_correction,
    };
    println!(
        "commissioning {wall}: {} displays, budget {} readings per display, meter {:?}",
        displays.len(),
        args.budget,
        args.meter
    );
    let pb = progress_bar(displays.len() as u64 * u64::from(args.budget));
    let names: Vec<(u32, String)> = displays.iter().map(|d| (d.id.0, d.name.clone())).collect();
    let name_of = |id: u32| {
        names
            .iter()
            .find(|(i, _)| *i == id)
            .map(|(_, n)| n.clone())
            .unwrap_or_default()
    };
    let budget = u64::from(args.budget);
    let mut done_readings = 0u64;
    let started = Instant::now();
    let mut on_progress = |p: Progress| match p {
        Progress::Reading {
            display, readings, ..
        } => {
            pb.set_position(done_readings + u64::from(readings));
            pb.set_message(format!("display {}", name_of(display.0)));
        }
        Progress::DisplayDone { display, readings } => {
            done_readings += budget;
            pb.set_position(done_readings);
            say(
                &pb,
                format!("{:<28} {readings:>3} readings", name_of(display.0)),
            );
        }
        Progress::Resumed { display, readings } => {
            done_readings += budget;
            pb.set_position(done_readings);
            say(
                &pb,
                format!(
                    "{:<28} {readings:>3} readings (saved by the interrupted run)",
                    name_of(display.0)
                ),
            );
        }
    };
    let mut rig = station.rig();
    let outcome = commission(
        &wall,
        &displays,
        &mut rig,
        &args.out,
        &opts,
        &mut on_progress,
    );
    pb.finish_and_clear();
    let outcome = outcome.map_err(|e| CliError::failure(e.to_string()))?;
    print_outcome(&outcome, started.elapsed());
    Ok(())
}

fn print_outcome(o: &CommissionOutcome, elapsed: Duration) {
    let s = &o.solution;
    let per: Vec<u32> = o.measured.iter().map(|m| m.measurement.readings).collect();
    let max = per.iter().copied().max().unwrap_or(0);
    let total: u32 = per.iter().sum();
    let w = s.white_xyz_cd_m2;
    let wxy = w.xy().unwrap_or([f64::NAN; 2]);
    println!(
        "measured {} displays ({} resumed) in {:.1} s: {total} readings, at most {max} per display",
        o.measured.len(),
        o.resumed.len(),
        elapsed.as_secs_f64()
    );
    println!(
        "common white: xy {:.4} {:.4}, {:.2} cd/m²; common gamut R {:.3}/{:.3} G {:.3}/{:.3} B {:.3}/{:.3}",
        wxy[0],
        wxy[1],
        w.y,
        s.common_primaries_xy[0][0],
        s.common_primaries_xy[0][1],
        s.common_primaries_xy[1][0],
        s.common_primaries_xy[1][1],
        s.common_primaries_xy[2][0],
        s.common_primaries_xy[2][1]
    );
    if let Some(p) = s.profiles.get(s.limiting.display) {
        println!(
            "limiting: {} {} channel",
            p.display,
            s.limiting.channel.name()
        );
    }
    if let Some(c) = &o.meter_correction {
        println!(
            "meter xy correction: x {:+.4} y {:+.4} (median additivity error {:.2} % -> {:.2} %)",
            c.xy_offset[0],
            c.xy_offset[1],
            c.additivity_before * 100.0,
            c.additivity_after * 100.0
        );
    }
    for w in &s.warnings {
        println!("warning: {w}");
    }
    println!("profiles: {}/{}", o.out_dir.display(), ProfileSet::MANIFEST);
    for r in &o.reports {
        println!("report: {}", r.display());
    }
}

/// Arguments of `lumiwall bench readings`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Wall description (TOML).
    #[arg(long, default_value = "fixtures/walls/heyewall-48.toml")]
    pub wall: PathBuf,
    /// Reading budgets per display to compare (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "16,24,40,80")]
    pub budgets: Vec<u32>,
    /// Meter path (direct is fastest; emulated goes through the pty).
    #[arg(long, default_value = "direct")]
    pub meter: MeterChoice,
    /// Target white.
    #[arg(long, default_value = "8500K", value_parser = parse_white)]
    pub white: WhiteTarget,
    /// Black handling.
    #[arg(long, value_enum, default_value = "individual")]
    pub black: BlackArg,
    /// Largest channel usage for the common white.
    #[arg(long, default_value_t = 1.0)]
    pub headroom: f64,
    /// Verify patches per display.
    #[arg(long, default_value_t = 20)]
    pub patches: usize,
    /// Scratch folder for the profiles of each run.
    #[arg(long, default_value = "out/bench-readings")]
    pub out: PathBuf,
}

/// Runs `lumiwall bench readings`: for each budget and each meter error model,
/// commissions the wall and verifies it with the same meter model.
pub fn bench(args: BenchArgs) -> Result<(), CliError> {
    let solve = solve_options(args.white, args.black, args.headroom)?;
    println!(
        "verify accuracy against meter readings per display ({}; {} patches per display)",
        args.wall.display(),
        args.patches
    );
    println!(
        "{:<10} {:>7} {:>16} {:>14} {:>10} {:>8} {:>9}",
        "noise", "budget", "readings/display", "ΔE2000 median", "ΔE2000 max", "max ΔL %", "time s"
    );
    for noise in [Noise::None, Noise::Realistic] {
        for &budget in &args.budgets {
            let started = Instant::now();
            let mut station = Station::open(&args.wall, &args.meter, noise, 0.1)?;
            let displays = station.displays();
            let wall = station.wall.name();
            let out = args.out.join(format!("{noise:?}-{budget}").to_lowercase());
            let opts = CommissionOptions {
                measure: MeasureOptions {
                    budget,
                    ..MeasureOptions::default()
                },
                solve,
                resume: false,
                meter_correction: true,
            };
            let mut rig = station.rig();
            let o = commission(&wall, &displays, &mut rig, &out, &opts, &mut |_| {})
                .map_err(|e| CliError::failure(format!("budget {budget}: {e}")))?;
            let max_readings = o
                .measured
                .iter()
                .map(|m| m.measurement.readings)
                .max()
                .unwrap_or(0);
            let profiles = &o.solution.profiles;
            let targets = default_targets(profiles, args.patches)
                .map_err(|e| CliError::failure(e.to_string()))?;
            let vopts = VerifyOptions {
                meter_xy_offset: o.meter_correction.as_ref().map(|c| c.xy_offset),
                ..VerifyOptions::default()
            };
            let report = verify_wall(&mut rig, &displays, profiles, &targets, &vopts, &mut |_| {})
                .map_err(|e| CliError::failure(e.to_string()))?;
            println!(
                "{:<10} {:>7} {:>16} {:>14.3} {:>10.3} {:>8.2} {:>9.1}",
                format!("{noise:?}").to_lowercase(),
                budget,
                max_readings,
                report.overall.median_de,
                report.overall.max_de,
                report.overall.max_abs_dl_percent,
                started.elapsed().as_secs_f64()
            );
        }
    }
    Ok(())
}
