//! `lumiwall meter-emulator --wall W`: the virtual wall's meter served as a Klein
//! K-10-A (or, with `--instrument specbos`, its spectroradiometer served as a JETI
//! specbos 1211) on a pseudo-terminal, so that third-party software (ArgyllCMS
//! `spotread`, `dispread`) can measure the virtual wall. The first line of stdout is the
//! pseudo-terminal's path; commands on stdin choose what the wall shows and where
//! the meter points (see [`COMMANDS`]).

use std::io::{BufRead, Write};
use std::path::PathBuf;

use lumiwall_calib::station::Noise;
use lumiwall_devices::serial::{
    Emulator, EmulatorOptions, FaultPlan, SpecbosEmulator, SpecbosEmulatorOptions,
};
use lumiwall_devices::sim::{SpectroModel, VirtualWall};
use lumiwall_devices::{DeviceError, DisplayId, MeterPositioner, PatternOutput};

use crate::CliError;
use crate::cmd_commission::NoiseArg;
use crate::values;

/// What stdin accepts, printed on stderr at the start.
const COMMANDS: &str = "commands on stdin, one per line:\n  \
    show D R G B   display D (index in the list above) shows drive R G B (0..1)\n  \
    aim D U V      the meter points at display D, position U V (0..1, 0.5 0.5 = centre)\n  \
    truth          prints the noiseless XYZ (cd/m²) the meter's spot sends now\n  \
    quit           stops (so does the end of stdin)";

/// Arguments of `lumiwall meter-emulator`.
#[derive(Debug, clap::Args)]
pub(crate) struct MeterEmulatorArgs {
    /// Virtual wall file (TOML).
    #[arg(long)]
    wall: PathBuf,
    /// The instrument to emulate: the Klein K-10-A colorimeter, or the JETI specbos
    /// 1211 spectroradiometer.
    #[arg(long, value_enum, default_value = "k10a")]
    instrument: InstrumentArg,
    /// Error model of the simulated instrument behind the emulated one.
    #[arg(long, value_enum, default_value = "realistic")]
    noise: NoiseArg,
    /// Factor on the instrument's measurement and transmission time (1 = a real
    /// K-10-A at 9600 baud).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1.0, value_parser = values::non_negative_finite)]
    time_scale: f64,
    /// Show what an ArgyllCMS web display (`dispread -dweb:PORT`) shows, on display
    /// 0 of the wall: HOST:PORT of its server, polled as a browser would.
    #[arg(long)]
    follow_webdisp: Option<String>,
}

/// The instruments `lumiwall meter-emulator` serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum InstrumentArg {
    /// Klein K-10-A colorimeter (9600 baud).
    K10a,
    /// JETI specbos 1211 spectroradiometer (921 600 baud).
    Specbos,
}

/// A running emulator of either kind.
enum Running {
    K10a(Emulator),
    Specbos(SpecbosEmulator),
}

impl Running {
    fn stop(self) {
        match self {
            Running::K10a(e) => e.stop(),
            Running::Specbos(e) => e.stop(),
        }
    }
}

/// The wall, what it shows and where the meter points.
struct Bench {
    wall: VirtualWall,
    displays: Vec<DisplayId>,
    shown: (usize, [f64; 3]),
    aimed: (usize, [f64; 2]),
}

/// Runs `lumiwall meter-emulator`.
pub(crate) fn run(args: MeterEmulatorArgs) -> Result<(), CliError> {
    let wall = VirtualWall::from_toml_file(&args.wall)
        .map_err(|e| CliError::input(format!("{}: {e}", args.wall.display())))?;
    let displays: Vec<DisplayId> = wall.displays().iter().map(|d| d.id).collect();
    if displays.is_empty() {
        return Err(CliError::input(format!(
            "{} has no displays",
            args.wall.display()
        )));
    }
    let mut bench = Bench {
        wall,
        displays,
        shown: (0, [1.0; 3]),
        aimed: (0, [0.5, 0.5]),
    };
    bench.show(0, [1.0; 3])?;
    bench.aim(0, [0.5, 0.5])?;
    let noise: Noise = args.noise.into();
    let (emulator, path) = start(&bench.wall, args.instrument, noise, args.time_scale)
        .map_err(|e| CliError::failure(format!("cannot start the emulator: {e}")))?;
    println!("{path}");
    std::io::stdout().flush()?;
    let what = match args.instrument {
        InstrumentArg::K10a => "Klein K-10-A emulator (9600 baud 8N1)",
        InstrumentArg::Specbos => "JETI specbos 1211 emulator (921 600 baud 8N1)",
    };
    eprintln!(
        "{what} on {path}; for ArgyllCMS link a /dev/ttyUSBn name to it; noise {}",
        noise.name()
    );
    for (i, d) in bench.wall.displays().iter().enumerate() {
        eprintln!("  display {i}: {}", d.name);
    }
    eprintln!("{COMMANDS}");
    if let Some(addr) = &args.follow_webdisp {
        follow_webdisp(addr.clone(), bench.wall.clone(), bench.displays[0]);
    }
    serve_stdin(&mut bench)?;
    emulator.stop();
    Ok(())
}

/// Starts the emulator of `instrument` on `wall`; returns it and its pty's path.
fn start(
    wall: &VirtualWall,
    instrument: InstrumentArg,
    noise: Noise,
    time_scale: f64,
) -> Result<(Running, String), DeviceError> {
    match instrument {
        InstrumentArg::K10a => {
            let meter = wall.meter(noise.model(wall.seed()));
            let options = EmulatorOptions::with_time_scale(time_scale);
            let (emulator, port) =
                Emulator::spawn_with(Box::new(meter), FaultPlan::default(), options)?;
            Ok((Running::K10a(emulator), port.path().to_string()))
        }
        InstrumentArg::Specbos => {
            let model = match noise {
                Noise::None => SpectroModel::noiseless(),
                Noise::Realistic => SpectroModel::specbos_1211(wall.seed()),
            };
            let options = SpecbosEmulatorOptions {
                time_scale,
                ..SpecbosEmulatorOptions::default()
            };
            let emulator =
                SpecbosEmulator::spawn(Box::new(wall.spectroradiometer(model)?), options)?;
            let path = emulator.path().to_string();
            Ok((Running::Specbos(emulator), path))
        }
    }
}

/// Reads commands until `quit` or the end of stdin; each gets one line of answer.
fn serve_stdin(bench: &mut Bench) -> Result<(), CliError> {
    for line in std::io::stdin().lock().lines() {
        let line = line?;
        let words: Vec<&str> = line.split_whitespace().collect();
        let reply = match words.as_slice() {
            [] => continue,
            ["quit"] => break,
            _ => bench.command(&words),
        };
        match reply {
            Ok(text) => println!("ok {text}"),
            Err(e) => println!("error: {}", e.message),
        }
        std::io::stdout().flush()?;
    }
    Ok(())
}

impl Bench {
    fn command(&mut self, words: &[&str]) -> Result<String, CliError> {
        let num = |s: &str| {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| CliError::input(format!("`{s}` is not a number")))
        };
        let index = |s: &str| {
            s.parse::<usize>()
                .map_err(|_| CliError::input(format!("`{s}` is not a display index")))
        };
        match words {
            ["show", d, r, g, b] => {
                let drive = [num(r)?, num(g)?, num(b)?];
                self.show(index(d)?, drive)?;
                Ok(format!("display {d} shows {drive:?}"))
            }
            ["aim", d, u, v] => {
                let uv = [num(u)?, num(v)?];
                self.aim(index(d)?, uv)?;
                Ok(format!("meter at display {d} {uv:?}"))
            }
            ["truth"] => self.truth(),
            _ => Err(CliError::input(format!(
                "unknown command `{}`\n{COMMANDS}",
                words.join(" ")
            ))),
        }
    }

    fn display(&self, i: usize) -> Result<DisplayId, CliError> {
        self.displays.get(i).copied().ok_or_else(|| {
            CliError::input(format!(
                "display {i} does not exist (0..{})",
                self.displays.len() - 1
            ))
        })
    }

    fn show(&mut self, i: usize, drive: [f64; 3]) -> Result<(), CliError> {
        let id = self.display(i)?;
        self.wall
            .pattern_output()
            .show(id, drive)
            .map_err(|e| CliError::input(e.to_string()))?;
        self.shown = (i, drive);
        Ok(())
    }

    fn aim(&mut self, i: usize, uv: [f64; 2]) -> Result<(), CliError> {
        let id = self.display(i)?;
        self.wall
            .positioner()
            .aim(id, uv)
            .map_err(|e| CliError::input(e.to_string()))?;
        self.aimed = (i, uv);
        Ok(())
    }

    /// The simulator's noiseless XYZ at the meter's spot: the shown drive where the
    /// meter points at the showing display, black elsewhere.
    fn truth(&self) -> Result<String, CliError> {
        let (i, uv) = self.aimed;
        let drive = if self.shown.0 == i {
            self.shown.1
        } else {
            [0.0; 3]
        };
        let xyz = self
            .wall
            .emitted_xyz(self.display(i)?, drive, uv)
            .map_err(|e| CliError::failure(e.to_string()))?;
        Ok(format!("XYZ {:.6} {:.6} {:.6}", xyz.x, xyz.y, xyz.z))
    }
}

/// Polls an ArgyllCMS web display (`/ajax/messages`, answered with `#RRGGBB` when
/// the test colour changes) and shows each colour on `display`, in a thread. The
/// server may not be up yet: it is retried until it is.
fn follow_webdisp(addr: String, wall: VirtualWall, display: DisplayId) {
    std::thread::spawn(move || {
        let mut output = wall.pattern_output();
        let mut shown = String::new();
        loop {
            match webdisp_colour(&addr, &shown) {
                Ok(colour) => {
                    if let Some(drive) = parse_hex_colour(&colour)
                        && output.show(display, drive).is_ok()
                    {
                        shown = colour;
                    }
                }
                Err(_) => std::thread::sleep(std::time::Duration::from_millis(200)),
            }
        }
    });
}

/// One long poll of the web display: the colour it shows now (or next).
fn webdisp_colour(addr: &str, shown: &str) -> std::io::Result<String> {
    use std::io::Read;
    let mut s = std::net::TcpStream::connect(addr)?;
    s.set_read_timeout(Some(std::time::Duration::from_secs(600)))?;
    let shown = if shown.is_empty() { "none" } else { shown };
    write!(
        s,
        "GET /ajax/messages?{} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n",
        shown.trim_start_matches('#')
    )?;
    let mut reply = String::new();
    s.read_to_string(&mut reply)?;
    reply
        .rsplit("\r\n")
        .next()
        .map(|body| body.trim().to_string())
        .filter(|b| b.starts_with('#'))
        .ok_or_else(|| std::io::Error::other(format!("no colour in `{reply}`")))
}

/// `#RRGGBB` as drive values 0..1.
fn parse_hex_colour(c: &str) -> Option<[f64; 3]> {
    let hex = c.strip_prefix('#')?;
    if hex.len() != 6 {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(hex.get(i..i + 2)?, 16).ok();
    Some([byte(0)?, byte(2)?, byte(4)?].map(|b| f64::from(b) / 255.0))
}
