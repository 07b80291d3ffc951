//! `lumiwall pattern-server`: the render node's side of the pattern service. It serves
//! the node's outputs on the one address given (gRPC, `pattern/proto`), to stations
//! that hold the wall's token, until interrupted (Ctrl-C or SIGTERM).

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use lumiwall_pattern::Token;
use lumiwall_pattern::server::{HeadlessPresenter, OutputSpec, ServerConfig, serve};

use crate::CliError;
use crate::values;

/// Arguments of `lumiwall pattern-server`.
#[derive(Debug, clap::Args)]
pub(crate) struct PatternServerArgs {
    /// The one address to listen on, e.g. 0.0.0.0:50051 or 10.0.0.3:50051 (port 0: any
    /// free port, printed at start).
    #[arg(long, required_unless_present = "list_outputs")]
    listen: Option<SocketAddr>,
    /// The wall's token file (the same file the station's wall file names).
    #[arg(long, required_unless_present = "list_outputs")]
    token_file: Option<PathBuf>,
    /// Print the monitors of this node (index, connector name, mode) and exit.
    #[cfg(feature = "window")]
    #[arg(long)]
    list_outputs: bool,
    /// The monitor of each output, in --output order: an index or a connector name
    /// (default: output i on monitor i).
    #[cfg(feature = "window")]
    #[arg(long = "monitor")]
    monitors: Vec<lumiwall_pattern::server::window::MonitorChoice>,
    /// Render off-screen (no window): frames are kept in memory and can be read back.
    #[arg(long)]
    headless: bool,
    /// An output: NAME=WIDTHxHEIGHT@BITS[/SURFACE_BITS], e.g. DP-1=1920x1200@10
    /// (repeat for each output of the node).
    #[arg(long = "output", required_unless_present = "list_outputs")]
    outputs: Vec<OutputSpec>,
    /// Wait after presenting before answering (projector processing, LCD response),
    /// e.g. 100ms (at most 10 s).
    #[arg(long, default_value = "100ms", value_parser = values::duration_or_zero)]
    settle: Duration,
    /// The node's name in messages (default: this machine's host name).
    #[arg(long)]
    node_name: Option<String>,
    /// TLS: this node's certificate chain (PEM), signed by the CA the wall file's
    /// network.ca_file names, for the host name the station uses. Without it the
    /// server speaks plain TCP (the token then travels in clear).
    #[arg(long, requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// TLS: this node's private key (PEM).
    #[arg(long, requires = "tls_cert")]
    tls_key: Option<PathBuf>,
}

/// Resolves once Ctrl-C or SIGTERM arrives.
async fn interrupted() {
    let term = async {
        #[cfg(unix)]
        if let Ok(mut s) = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
        {
            s.recv().await;
            return;
        }
        std::future::pending::<()>().await;
    };
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        () = term => {}
    }
}

/// Runs `lumiwall pattern-server`.
pub(crate) fn run(args: PatternServerArgs) -> Result<(), CliError> {
    #[cfg(feature = "window")]
    if args.list_outputs {
        for m in lumiwall_pattern::server::window::list_monitors()
            .map_err(|e| CliError::failure(e.to_string()))?
        {
            println!("{m}");
        }
        return Ok(());
    }
    let config = config(&args)?;
    let node_name = config.node_name.clone();
    let outputs: Vec<String> = args.outputs.iter().map(describe).collect();
    let mode = if args.headless {
        "headless"
    } else {
        "windowed"
    };
    let on_listening = move |addr: SocketAddr| {
        println!(
            "pattern server {node_name} listening on {addr} ({mode}; outputs {})",
            outputs.join(", ")
        );
    };
    if args.headless {
        let presenter = Box::new(HeadlessPresenter::new(&config.outputs));
        return serve_until_interrupted(config, presenter, on_listening).map_err(|e| match e {
            lumiwall_pattern::server::ServeError::Config(m) => CliError::input(m),
            other => CliError::failure(other.to_string()),
        });
    }
    run_windowed(&args, config, on_listening)
}

/// The server configuration of `args`, checked.
fn config(args: &PatternServerArgs) -> Result<ServerConfig, CliError> {
    let (Some(listen), Some(token_file)) = (args.listen, args.token_file.as_ref()) else {
        return Err(CliError::input("give --listen ADDR and --token-file FILE"));
    };
    let token = Token::from_file(token_file).map_err(|e| CliError::input(e.to_string()))?;
    let config = ServerConfig {
        listen,
        token,
        outputs: args.outputs.clone(),
        settle: args.settle,
        node_name: args
            .node_name
            .clone()
            .unwrap_or_else(|| lumiwall_pattern::limits::host_name_or("node")),
        tls: tls_identity(args)?,
    };
    config.validate().map_err(CliError::input)?;
    Ok(config)
}

/// The TLS identity `--tls-cert`/`--tls-key` name, if given.
fn tls_identity(
    args: &PatternServerArgs,
) -> Result<Option<lumiwall_pattern::server::TlsIdentity>, CliError> {
    let (Some(cert), Some(key)) = (&args.tls_cert, &args.tls_key) else {
        return Ok(None);
    };
    let read = |p: &PathBuf| {
        std::fs::read(p).map_err(|e| CliError::input(format!("{}: {e}", p.display())))
    };
    Ok(Some(lumiwall_pattern::server::TlsIdentity {
        cert_pem: read(cert)?,
        key_pem: read(key)?,
    }))
}

/// Serves on a new runtime until Ctrl-C or SIGTERM.
fn serve_until_interrupted(
    config: ServerConfig,
    presenter: Box<dyn lumiwall_pattern::server::Presenter>,
    on_listening: impl FnOnce(SocketAddr),
) -> Result<(), lumiwall_pattern::server::ServeError> {
    let rt = tokio::runtime::Runtime::new().map_err(|e| {
        lumiwall_pattern::server::ServeError::Transport(format!("cannot start the runtime: {e}"))
    })?;
    rt.block_on(serve(config, presenter, on_listening, interrupted()))
}

/// Fullscreen windows on this node's monitors (feature `window`), served until
/// interrupted.
#[cfg(feature = "window")]
fn run_windowed(
    args: &PatternServerArgs,
    config: ServerConfig,
    on_listening: impl FnOnce(SocketAddr) + Send + 'static,
) -> Result<(), CliError> {
    let outputs = config.outputs.clone();
    lumiwall_pattern::server::window::run_with_windows(&outputs, &args.monitors, move |p| {
        serve_until_interrupted(config, p, on_listening).map_err(|e| e.to_string())
    })
    .map_err(|e| CliError::failure(e.to_string()))
}

/// Without the `window` feature there is no windowed presenter.
#[cfg(not(feature = "window"))]
fn run_windowed(
    _args: &PatternServerArgs,
    _config: ServerConfig,
    _on_listening: impl FnOnce(SocketAddr),
) -> Result<(), CliError> {
    Err(CliError::input(
        "this build has no windowed presenter (cargo feature `window`): pass --headless",
    ))
}

/// `NAME WxH BITS-bit` of an output.
fn describe(o: &OutputSpec) -> String {
    format!(
        "{} {}×{} {}-bit (surface {}-bit)",
        o.name, o.width_px, o.height_px, o.bit_depth, o.surface_bit_depth
    )
}

/// Arguments of `lumiwall bench patterns`.
#[cfg(feature = "station")]
#[derive(Debug, clap::Args)]
pub(crate) struct BenchArgs {
    /// The output served: NAME=WIDTHxHEIGHT@BITS.
    #[arg(long, default_value = "0=1920x1200@10")]
    output: OutputSpec,
    /// Pattern changes timed (10 to 100 000).
    #[arg(long, default_value_t = 500, value_parser = |s: &str| values::count_in(s, 10, 100_000).map(|v| v as u32))]
    changes: u32,
}

/// Runs `lumiwall bench patterns`.
#[cfg(feature = "station")]
pub(crate) fn bench(args: BenchArgs) -> Result<(), CliError> {
    let report = lumiwall_bench::patterns::run(lumiwall_bench::patterns::PatternsBenchOptions {
        output: args.output,
        changes: args.changes,
        readings_per_display: 40,
        displays: 48,
    })
    .map_err(|e| CliError::failure(e.to_string()))?;
    print!("{report}");
    Ok(())
}
