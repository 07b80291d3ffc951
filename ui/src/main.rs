//! `lumiwall`: the command line of the calibration station and renderer.
//!
//! Each subcommand lives in its own module (`cmd_*`); this file only parses the
//! command line, sets up logging and maps errors to exit codes.

mod cmd_apply;
#[cfg(feature = "station")]
#[cfg(feature = "camera")]
mod cmd_camera;
mod cmd_cie171;
#[cfg(feature = "station")]
mod cmd_commission;
#[cfg(feature = "station")]
mod cmd_export;
mod cmd_forecast;
#[cfg(feature = "station")]
mod cmd_meter_emulator;
#[cfg(feature = "pattern-server")]
mod cmd_pattern_server;
mod cmd_profiles;
#[cfg(feature = "station")]
mod cmd_random_walls;
#[cfg(feature = "station")]
mod cmd_recalibrate;
mod cmd_render;
#[cfg(feature = "station")]
mod cmd_season;
#[cfg(feature = "station")]
mod cmd_verify;
mod cmd_view;
mod error;
#[cfg(feature = "station-app")]
mod station_app;
mod values;
#[cfg(feature = "station")]
mod view_seams;

use clap::{Parser, Subcommand};

use error::CliError;

/// Multi-projector wall calibration station and photometric renderer.
#[derive(Debug, Parser)]
#[command(name = "lumiwall", version, about)]
struct Cli {
    /// More log output (repeat for more).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Measure every display of a wall and write one profile per display and eye.
    #[cfg(feature = "station")]
    Commission(cmd_commission::CommissionArgs),
    /// The nightly run: re-read black, primaries and white of every display, and when a
    /// display drifted, refit, solve the common white again and write new profiles.
    /// Exit 0: nothing drifted; 10: recalibrated; 11: a display left the headroom (the
    /// wall's white was lowered); 12: a device failed; 13: the wall was not ready (a
    /// display kept drifting or showed no light while the run waited for it to warm up).
    #[cfg(feature = "station")]
    Recalibrate(cmd_recalibrate::RecalibrateArgs),
    /// Show target colours through the profiles and read them back with the meter.
    #[cfg(feature = "station")]
    Verify(cmd_verify::VerifyArgs),
    /// Match the meter to a reference spectroradiometer: one correction matrix per
    /// display type (eye), for `commission` and `verify --meter-matrix`.
    #[cfg(feature = "station")]
    MeterMatrix(cmd_commission::MeterMatrixArgs),
    /// Serve the virtual wall's meter as a Klein K-10-A on a pseudo-terminal (first
    /// line of stdout: its path) for third-party software such as ArgyllCMS.
    #[cfg(feature = "station")]
    MeterEmulator(cmd_meter_emulator::MeterEmulatorArgs),
    /// Write a commissioning's results in formats other tools read (ArgyllCMS .ti3).
    #[cfg(feature = "station")]
    Export(cmd_export::ExportArgs),
    /// Apply display profiles to an XYZ (cd/m²) frame: one output per display and eye.
    Apply(cmd_apply::ApplyArgs),
    /// Render a scene to an XYZ float image in cd/m².
    Render(cmd_render::RenderArgs),
    /// Show a rendered solution on a wall, headless: each display and eye renders it
    /// through its tile from the viewer (off-axis), through its profile, to a PNG.
    View(cmd_view::ViewArgs),
    /// Inspect the profile store: history and drift.
    Profiles(cmd_profiles::ProfilesArgs),
    /// Serve this render node's outputs to calibration stations (gRPC pattern service).
    #[cfg(feature = "pattern-server")]
    PatternServer(cmd_pattern_server::PatternServerArgs),
    /// The station app: wall map, commission / verify / recalibrate with progress,
    /// gamut, drift and forecast (a window; the same commands as the command line).
    #[cfg(feature = "station-app")]
    Station(station_app::StationArgs),
    /// Benchmarks that print a table.
    #[command(subcommand)]
    Bench(BenchCommand),
}

#[derive(Debug, Subcommand)]
enum BenchCommand {
    /// Post-pass throughput (CPU reference, GPU, memcpy) and quantisation steps.
    Apply(cmd_apply::BenchArgs),
    /// Radiosity solvers: error against time, patches, links, memory.
    Radiosity(cmd_render::BenchArgs),
    /// Wall viewer: frame time per display (raster and post pass) on a generated scene.
    View(cmd_view::BenchArgs),
    /// CIE 171:2006 analytical test cases against their closed forms.
    Cie171(cmd_cie171::Cie171Args),
    /// Calibration accuracy against the number of meter readings per display.
    #[cfg(feature = "station")]
    Readings(cmd_commission::BenchArgs),
    /// Issue 12's acceptance on walls drawn at random from its classes: one row per
    /// wall, the counts per class.
    #[cfg(feature = "station")]
    RandomWalls(cmd_random_walls::RandomWallsArgs),
    /// A season of nightly recalibrations on the virtual wall (lamps ageing, one lamp
    /// changed) against the simulator's truth; the forecast checked.
    #[cfg(feature = "station")]
    Season(cmd_season::SeasonArgs),
    /// Pattern service: time per pattern change on loopback against a raw TCP round
    /// trip; the share of a 48-projector commissioning.
    #[cfg(all(feature = "station", feature = "pattern-server"))]
    Patterns(cmd_pattern_server::BenchArgs),
}

fn main() {
    let cli = Cli::parse();
    let level = match cli.verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();

    let result = match cli.command {
        #[cfg(feature = "station")]
        Command::Commission(a) => cmd_commission::run(a),
        #[cfg(feature = "station")]
        Command::Verify(a) => cmd_verify::run(a),
        #[cfg(feature = "station")]
        Command::Recalibrate(a) => match cmd_recalibrate::run(a) {
            Ok(code) => std::process::exit(code),
            Err(e) => Err(e),
        },
        #[cfg(feature = "station")]
        Command::MeterMatrix(a) => cmd_commission::meter_matrix(a),
        #[cfg(feature = "station")]
        Command::MeterEmulator(a) => cmd_meter_emulator::run(a),
        #[cfg(feature = "station")]
        Command::Export(a) => cmd_export::run(a),
        Command::Apply(a) => cmd_apply::run(a),
        Command::Render(a) => cmd_render::run(a),
        Command::View(a) => cmd_view::run(a),
        Command::Profiles(a) => cmd_profiles::run(a),
        #[cfg(feature = "pattern-server")]
        Command::PatternServer(a) => cmd_pattern_server::run(a),
        #[cfg(feature = "station-app")]
        Command::Station(a) => station_app::run(a),
        Command::Bench(BenchCommand::Apply(a)) => cmd_apply::bench(a),
        Command::Bench(BenchCommand::Radiosity(a)) => cmd_render::bench(a),
        Command::Bench(BenchCommand::View(a)) => cmd_view::bench(a),
        Command::Bench(BenchCommand::Cie171(a)) => cmd_cie171::bench(a),
        #[cfg(feature = "station")]
        Command::Bench(BenchCommand::Readings(a)) => cmd_commission::bench(a),
        #[cfg(feature = "station")]
        Command::Bench(BenchCommand::RandomWalls(a)) => cmd_random_walls::run(a),
        #[cfg(feature = "station")]
        Command::Bench(BenchCommand::Season(a)) => cmd_season::bench(a),
        #[cfg(all(feature = "station", feature = "pattern-server"))]
        Command::Bench(BenchCommand::Patterns(a)) => cmd_pattern_server::bench(a),
    };
    if let Err(e) = result {
        eprintln!("lumiwall: error: {e}");
        std::process::exit(e.exit_code());
    }
}
