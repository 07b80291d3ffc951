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
    #[arg(long)]
    listen: SocketAddr,
    /// The wall's token file (the same file the station's wall file names).
    #[arg(long)]
    token_file: PathBuf,
    /// Render off-screen (no window): frames are kept in memory and can be read back.
    #[arg(long)]
    headless: bool,
    /// An output: NAME=WIDTHxHEIGHT@BITS[/SURFACE_BITS], e.g. DP-1=1920x1200@10
    /// (repeat for each output of the node).
    #[arg(long = "output", required = true)]
    outputs: Vec<OutputSpec>,
    /// Wait after presenting before answering (projector processing, LCD response),
    /// e.g. 100ms (at most 10 s).
    #[arg(long, default_value = "100ms", value_parser = values::duration_or_zero)]
    settle: Duration,
    /// The node's name in messages (default: this machine's host name).
    #[arg(long)]
    node_name: Option<String>,
}

/// This machine's host name, or `node`.
fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|h| h.trim().to_string())
        .filter(|h| lumiwall_pattern::limits::valid_name(h))
        .unwrap_or_else(|| "node".into())
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
    if !args.headless {
        return Err(CliError::input(
            "this build shows patterns off-screen only: pass --headless (the windowed \
             presenter needs the `window` feature)",
        ));
    }
    let token = Token::from_file(&args.token_file).map_err(|e| CliError::input(e.to_string()))?;
    let node_name = args.node_name.clone().unwrap_or_else(host_name);
    let config = ServerConfig {
        listen: args.listen,
        token,
        outputs: args.outputs.clone(),
        settle: args.settle,
        node_name: node_name.clone(),
    };
    config.validate().map_err(CliError::input)?;
    let presenter = Box::new(HeadlessPresenter::new(&config.outputs));
    let rt = tokio::runtime::Runtime::new()
        .map_err(|e| CliError::failure(format!("cannot start the server runtime: {e}")))?;
    let outputs: Vec<String> = args.outputs.iter().map(describe).collect();
    rt.block_on(serve(
        config,
        presenter,
        |addr| {
            println!(
                "pattern server {node_name} listening on {addr} (headless; outputs {})",
                outputs.join(", ")
            );
        },
        interrupted(),
    ))
    .map_err(|e| match e {
        lumiwall_pattern::server::ServeError::Config(m) => CliError::input(m),
        other => CliError::failure(other.to_string()),
    })?;
    println!("pattern server {node_name} stopped");
    Ok(())
}

/// `NAME WxH BITS-bit` of an output.
fn describe(o: &OutputSpec) -> String {
    format!(
        "{} {}×{} {}-bit (surface {}-bit)",
        o.name, o.width_px, o.height_px, o.bit_depth, o.surface_bit_depth
    )
}
