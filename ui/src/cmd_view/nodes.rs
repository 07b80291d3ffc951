//! `lumiwall view --show-on NODE`: a render node shows its own tiles. It renders only
//! the displays the wall file routes to its pattern server, and each frame goes to
//! its outputs together (ShowFrame); on a wall of several nodes every frame first
//! waits at the swap barrier one node hosts (SwapBarrier), so that no node presents a
//! frame before every node has it ready.

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use lumiwall_pattern::client::{NodeClient, NodeOptions};
use lumiwall_pattern::{OutputAddress, Token};
use lumiwall_profiles::{DisplayProfile, Eye};

use crate::CliError;

/// A node that cannot be reached or refuses is a failure (exit 1), named in the message.
fn node_error(e: lumiwall_devices::DeviceError) -> CliError {
    CliError::failure(e.to_string())
}

/// Longest wait at the swap barrier for one frame.
const BARRIER_WAIT: Duration = Duration::from_secs(30);

/// One display's route from the wall file (`[[output]]`).
struct OutputRoute {
    tile: [u32; 2],
    eye: Eye,
    address: OutputAddress,
}

/// The wall file's `[network]` and `[[output]]` tables.
struct WallNetwork {
    token_file: String,
    /// The nodes' certificate authority (PEM file beside the wall file): TLS.
    ca_file: Option<String>,
    deadline_ms: u64,
    routes: Vec<OutputRoute>,
}

fn wall_network(path: &Path) -> Result<WallNetwork, CliError> {
    let err = |m: String| CliError::input(format!("wall file {}: {m}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
    let t: toml::Table = toml::from_str(&text).map_err(|e| err(e.to_string()))?;
    let net = t
        .get("network")
        .and_then(|v| v.as_table())
        .ok_or_else(|| err("--show-on needs a [network] section and [[output]] routes".into()))?;
    let token_file = net
        .get("token_file")
        .and_then(|v| v.as_str())
        .ok_or_else(|| err("[network] has no token_file".into()))?
        .to_string();
    let ca_file = net
        .get("ca_file")
        .and_then(|v| v.as_str())
        .map(str::to_string);
    let deadline_ms = net
        .get("deadline_ms")
        .and_then(|v| v.as_integer())
        .and_then(|v| u64::try_from(v).ok())
        .unwrap_or(10_000);
    let outputs = t
        .get("output")
        .and_then(|v| v.as_array())
        .cloned()
        .unwrap_or_default();
    let routes = outputs
        .iter()
        .map(|o| output_route(o).map_err(&err))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(WallNetwork {
        token_file,
        ca_file,
        deadline_ms,
        routes,
    })
}

fn output_route(o: &toml::Value) -> Result<OutputRoute, String> {
    let tile: Vec<u32> = o
        .get("tile")
        .and_then(|v| v.as_array())
        .map(|a| {
            a.iter()
                .filter_map(|x| x.as_integer())
                .filter_map(|x| u32::try_from(x).ok())
                .collect()
        })
        .unwrap_or_default();
    let [col, row] = tile[..] else {
        return Err("an [[output]] needs tile = [col, row]".into());
    };
    let eye = match o.get("eye").and_then(|v| v.as_str()).unwrap_or("mono") {
        "mono" => Eye::Mono,
        "left" => Eye::Left,
        "right" => Eye::Right,
        other => {
            return Err(format!(
                "[[output]] eye {other:?}: give left, right or mono"
            ));
        }
    };
    let to = o
        .get("to")
        .and_then(|v| v.as_str())
        .ok_or("an [[output]] needs to = \"tcp://HOST:PORT/OUTPUT\"")?;
    let address: OutputAddress = to.parse().map_err(|e| format!("{to}: {e}"))?;
    Ok(OutputRoute {
        tile: [col, row],
        eye,
        address,
    })
}

/// This node's displays and their outputs, and how many nodes the wall has.
pub(super) struct NodeShow {
    client: NodeClient,
    barrier: Option<(NodeClient, u32)>,
    group: String,
    /// (index into the wall's profiles, output name) of this node's displays.
    pub(super) displays: Vec<(usize, String)>,
    frame: u64,
}

impl NodeShow {
    /// Connects to this node's pattern server (`node`, `HOST:PORT` as the wall file
    /// names it) and, on a wall of several nodes, to the barrier host (`barrier`,
    /// default: the first node of the wall file).
    pub(super) fn connect(
        wall: &Path,
        wall_name: &str,
        node: &str,
        barrier: Option<&str>,
        profiles: &[DisplayProfile],
    ) -> Result<Self, CliError> {
        let net = wall_network(wall)?;
        let displays = node_displays(&net, node, profiles)?;
        let mut nodes: Vec<String> = net.routes.iter().map(|r| r.address.node()).collect();
        nodes.dedup();
        nodes.sort();
        nodes.dedup();
        let beside = |f: &str| wall.parent().unwrap_or(Path::new(".")).join(f);
        let token = Token::from_file(&beside(&net.token_file))
            .map_err(|e| CliError::input(e.to_string()))?;
        let tls_ca_pem = match &net.ca_file {
            Some(f) => Some(std::fs::read(beside(f)).map_err(|e| {
                CliError::input(format!("network.ca_file {}: {e}", beside(f).display()))
            })?),
            None => None,
        };
        let opts = NodeOptions {
            deadline: Duration::from_millis(net.deadline_ms),
            tls_ca_pem,
            ..NodeOptions::new(token, format!("view@{node}"))
        };
        let rt = Arc::new(
            tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .map_err(|e| CliError::input(format!("cannot start the network runtime: {e}")))?,
        );
        let host = node.rsplit_once(':').map_or(node, |(h, _)| h);
        let client =
            NodeClient::connect(Arc::clone(&rt), node, host, opts.clone()).map_err(node_error)?;
        let barrier = if nodes.len() > 1 {
            let at = barrier.map_or(nodes[0].clone(), str::to_string);
            let host = at
                .rsplit_once(':')
                .map_or(at.as_str(), |(h, _)| h)
                .to_string();
            let waiting = NodeOptions {
                deadline: BARRIER_WAIT + opts.deadline,
                ..opts
            };
            let c = NodeClient::connect_unleased(rt, &at, &host, waiting).map_err(node_error)?;
            Some((c, nodes.len() as u32))
        } else {
            None
        };
        Ok(Self {
            client,
            barrier,
            group: wall_name.to_string(),
            displays,
            frame: 0,
        })
    }

    /// Waits at the barrier (on a wall of several nodes) and presents one PNG per
    /// display of this node together; prints the waits.
    pub(super) fn present(&mut self, pngs: Vec<Vec<u8>>) -> Result<(), CliError> {
        self.frame += 1;
        let waited = match &self.barrier {
            Some((b, parties)) => b
                .swap_barrier(&self.group, self.frame, *parties, BARRIER_WAIT)
                .map_err(node_error)?,
            None => 0.0,
        };
        let t0 = Instant::now();
        let images = self
            .displays
            .iter()
            .map(|(_, o)| o.clone())
            .zip(pngs)
            .collect();
        let presented = self.client.show_frame(images).map_err(node_error)?;
        println!(
            "frame {} on {}: swap barrier wait {waited:.1} ms, presented on {} outputs in {:.1} ms (node frame {})",
            self.frame,
            self.client.node(),
            self.displays.len(),
            t0.elapsed().as_secs_f64() * 1e3,
            presented.frame
        );
        Ok(())
    }
}

/// The profiles (by index) routed to `node` with their output names.
fn node_displays(
    net: &WallNetwork,
    node: &str,
    profiles: &[DisplayProfile],
) -> Result<Vec<(usize, String)>, CliError> {
    let mine: Vec<(usize, String)> = net
        .routes
        .iter()
        .filter(|r| r.address.node() == node)
        .filter_map(|r| {
            profiles
                .iter()
                .position(|p| {
                    [p.display.tile_col, p.display.tile_row] == r.tile && p.display.eye == r.eye
                })
                .map(|i| (i, r.address.output.clone()))
        })
        .collect();
    if mine.is_empty() {
        return Err(CliError::input(format!(
            "the wall file routes no display of these profiles to {node}; --show-on takes \
             HOST:PORT as the [[output]] `to` addresses name this node"
        )));
    }
    Ok(mine)
}
