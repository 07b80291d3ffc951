//! One render node as the station sees it.

use std::sync::Arc;
use std::time::Duration;

use lumiwall_devices::DeviceError;
use tonic::metadata::MetadataValue;
use tonic::transport::{Channel, Endpoint};
use tonic::{Code, Request, Status};

use crate::framebuffer::Framebuffer;
use crate::limits::{DEFAULT_DEADLINE, MAX_MESSAGE_BYTES, PROTOCOL};
use crate::proto;
use crate::proto::pattern_service_client::PatternServiceClient;
use crate::token::Token;

/// How the station talks to its nodes.
#[derive(Debug, Clone)]
pub struct NodeOptions {
    /// The wall's token.
    pub token: Token,
    /// Who the station is (shown to other stations that find the node busy).
    pub station: String,
    /// Deadline of every call.
    pub deadline: Duration,
    /// Extra attempts after a transient failure (unreachable, deadline passed).
    pub retries: u32,
    /// TLS: the certificate authority (PEM) the nodes' certificates are checked
    /// against. `None`: plain TCP.
    pub tls_ca_pem: Option<Vec<u8>>,
}

impl NodeOptions {
    /// `token` and `station` with the default deadline and two retries.
    pub fn new(token: Token, station: String) -> Self {
        NodeOptions {
            token,
            station,
            deadline: DEFAULT_DEADLINE,
            retries: 2,
            tls_ca_pem: None,
        }
    }
}

/// A connected node holding this station's lease.
pub struct NodeClient {
    rt: Arc<tokio::runtime::Runtime>,
    client: PatternServiceClient<Channel>,
    node: String,
    auth: MetadataValue<tonic::metadata::Ascii>,
    opts: NodeOptions,
    lease: Option<String>,
    outputs: Vec<proto::Output>,
}

impl std::fmt::Debug for NodeClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NodeClient")
            .field("node", &self.node)
            .field("outputs", &self.outputs.len())
            .finish()
    }
}

/// The device error for a failed call to `node`.
pub(crate) fn node_error(
    node: &str,
    what: &str,
    status: &Status,
    deadline: Duration,
) -> DeviceError {
    // The channel's own timeout arrives as a cancelled or unknown call.
    let timed_out = status.code() == Code::DeadlineExceeded
        || status
            .message()
            .to_ascii_lowercase()
            .contains("timeout expired");
    let (message, transient) = match status.code() {
        _ if timed_out => (
            format!(
                "{what}: no answer within {} ms; check the node and the network",
                deadline.as_millis()
            ),
            true,
        ),
        Code::Unauthenticated => (status.message().to_string(), false),
        Code::FailedPrecondition | Code::InvalidArgument => {
            (format!("{what}: {}", status.message()), false)
        }
        Code::Unavailable | Code::Cancelled | Code::Unknown => (
            format!(
                "{what}: cannot be reached ({}); is `lumiwall pattern-server` running there \
                 and the port open?",
                status.message()
            ),
            true,
        ),
        Code::Unimplemented => (
            format!(
                "{what}: not implemented ({}); is it a {PROTOCOL} pattern server?",
                status.message()
            ),
            false,
        ),
        _ => (format!("{what}: {}", status.message()), false),
    };
    DeviceError::Node {
        node: node.to_string(),
        message,
        transient,
    }
}

impl NodeClient {
    /// Connects to `node` (`HOST:PORT`; `host` alone names it in its certificate),
    /// lists its outputs and takes its lease. With [`NodeOptions::tls_ca_pem`] the
    /// connection is TLS and the node's certificate must be signed by that authority
    /// for `host`.
    pub fn connect(
        rt: Arc<tokio::runtime::Runtime>,
        node: &str,
        host: &str,
        opts: NodeOptions,
    ) -> Result<NodeClient, DeviceError> {
        let mut me = Self::connect_unleased(rt, node, host, opts)?;
        let acquired = me.call(
            "taking the node",
            proto::AcquireRequest {
                station: me.opts.station.clone(),
                protocol: PROTOCOL.to_string(),
            },
            |mut c, r| async move { c.acquire(r).await },
        )?;
        me.lease = Some(acquired.lease);
        Ok(me)
    }

    /// Connects to `node` and lists its outputs without taking its lease: for the
    /// calls that need none (another node's swap barrier). Every call, the barrier's
    /// wait included, must fit the options' deadline.
    pub fn connect_unleased(
        rt: Arc<tokio::runtime::Runtime>,
        node: &str,
        host: &str,
        opts: NodeOptions,
    ) -> Result<NodeClient, DeviceError> {
        let config = |message: String| DeviceError::Node {
            node: node.to_string(),
            message,
            transient: false,
        };
        let scheme = if opts.tls_ca_pem.is_some() {
            "https"
        } else {
            "http"
        };
        let uri = format!("{scheme}://{node}");
        let mut endpoint = Endpoint::from_shared(uri.clone())
            .map_err(|e| config(format!("bad address {uri}: {e}")))?
            .connect_timeout(opts.deadline)
            .timeout(opts.deadline);
        if let Some(ca) = &opts.tls_ca_pem {
            let tls = tonic::transport::ClientTlsConfig::new()
                .ca_certificate(tonic::transport::Certificate::from_pem(ca))
                .domain_name(host.trim_start_matches('[').trim_end_matches(']'));
            endpoint = endpoint
                .tls_config(tls)
                .map_err(|e| config(format!("TLS settings: {e}")))?;
        }
        let channel = rt.block_on(endpoint.connect()).map_err(|e| DeviceError::Node {
            node: node.to_string(),
            message: format!(
                "cannot connect ({e}); is `lumiwall pattern-server` running there and the port open?"
            ),
            transient: true,
        })?;
        let auth = MetadataValue::try_from(opts.token.header_value())
            .map_err(|e| config(format!("the token cannot be sent: {e}")))?;
        let client = PatternServiceClient::new(channel)
            .max_decoding_message_size(MAX_MESSAGE_BYTES)
            .max_encoding_message_size(MAX_MESSAGE_BYTES);
        let mut me = NodeClient {
            rt,
            client,
            node: node.to_string(),
            auth,
            opts,
            lease: None,
            outputs: Vec::new(),
        };
        let listed = me.call(
            "listing outputs",
            proto::ListOutputsRequest {},
            |mut c, r| async move { c.list_outputs(r).await },
        )?;
        me.outputs = listed.outputs;
        Ok(me)
    }

    /// The node, `HOST:PORT`.
    pub fn node(&self) -> &str {
        &self.node
    }

    /// The node's outputs.
    pub fn outputs(&self) -> &[proto::Output] {
        &self.outputs
    }

    fn lease(&self) -> String {
        self.lease.clone().unwrap_or_default()
    }

    /// One call with the token, the deadline and bounded retries of transient
    /// failures.
    fn call<Q, A, F, Fut>(&self, what: &str, msg: Q, f: F) -> Result<A, DeviceError>
    where
        Q: Clone,
        F: Fn(PatternServiceClient<Channel>, Request<Q>) -> Fut,
        Fut: std::future::Future<Output = Result<tonic::Response<A>, Status>>,
    {
        let mut attempt = 0;
        loop {
            let mut req = Request::new(msg.clone());
            req.set_timeout(self.opts.deadline);
            req.metadata_mut()
                .insert("authorization", self.auth.clone());
            let result = self.rt.block_on(f(self.client.clone(), req));
            match result {
                Ok(r) => return Ok(r.into_inner()),
                Err(status) => {
                    let err = node_error(&self.node, what, &status, self.opts.deadline);
                    if err.is_transient() && attempt < self.opts.retries {
                        attempt += 1;
                        tracing::warn!(node = %self.node, "retrying after: {err}");
                        std::thread::sleep(Duration::from_millis(200 * u64::from(attempt)));
                        continue;
                    }
                    return Err(err);
                }
            }
        }
    }

    /// A uniform field of `code` (at `bit_depth`) on `output`, black elsewhere.
    pub fn show_uniform(
        &self,
        output: &str,
        code: [u32; 3],
        bit_depth: u32,
    ) -> Result<proto::Presented, DeviceError> {
        let msg = proto::ShowUniformRequest {
            lease: self.lease(),
            output: output.to_string(),
            code: code.to_vec(),
            bit_depth,
        };
        self.call(
            &format!("showing a pattern on {output}"),
            msg,
            |mut c, r| async move { c.show_uniform(r).await },
        )
    }

    /// A PNG image on `output`, black elsewhere.
    pub fn show_image(&self, output: &str, png: Vec<u8>) -> Result<proto::Presented, DeviceError> {
        let msg = proto::ShowImageRequest {
            lease: self.lease(),
            output: output.to_string(),
            png,
        };
        self.call(
            &format!("showing an image on {output}"),
            msg,
            |mut c, r| async move { c.show_image(r).await },
        )
    }

    /// One image per named output (PNG, the output's size), all presented together;
    /// outputs not named show black.
    pub fn show_frame(
        &self,
        images: Vec<(String, Vec<u8>)>,
    ) -> Result<proto::Presented, DeviceError> {
        let msg = proto::ShowFrameRequest {
            lease: self.lease(),
            images: images
                .into_iter()
                .map(|(output, png)| proto::OutputImage { output, png })
                .collect(),
        };
        self.call("showing a frame", msg, |mut c, r| async move {
            c.show_frame(r).await
        })
    }

    /// Waits at this node's swap barrier until `parties` nodes are ready with frame
    /// `frame` of `group` (at most `wait`, which the options' deadline must cover);
    /// returns how long it waited (ms). Not retried: a repeated arrival would count
    /// twice.
    pub fn swap_barrier(
        &self,
        group: &str,
        frame: u64,
        parties: u32,
        wait: Duration,
    ) -> Result<f64, DeviceError> {
        let msg = proto::SwapBarrierRequest {
            group: group.to_string(),
            frame,
            parties,
            timeout_ms: u32::try_from(wait.as_millis()).unwrap_or(u32::MAX),
            node: self.opts.station.clone(),
        };
        let mut req = Request::new(msg);
        req.set_timeout(wait + self.opts.deadline);
        req.metadata_mut()
            .insert("authorization", self.auth.clone());
        let mut client = self.client.clone();
        self.rt
            .block_on(async move { client.swap_barrier(req).await })
            .map(|r| r.into_inner().waited_ms)
            .map_err(|status| DeviceError::Node {
                node: self.node.clone(),
                message: format!("waiting at the swap barrier: {}", status.message()),
                transient: false,
            })
    }

    /// Black on every output.
    pub fn blank(&self) -> Result<proto::Presented, DeviceError> {
        let msg = proto::BlankRequest {
            lease: self.lease(),
        };
        self.call("blanking", msg, |mut c, r| async move { c.blank(r).await })
    }

    /// The last presented frame of `output`.
    pub fn read_back(&self, output: &str) -> Result<Framebuffer, DeviceError> {
        let msg = proto::ReadBackRequest {
            lease: self.lease(),
            output: output.to_string(),
        };
        let what = format!("reading back {output}");
        let r = self.call(&what, msg, |mut c, r| async move { c.read_back(r).await })?;
        Framebuffer::read_png(&r.png, r.surface_bit_depth).map_err(|e| DeviceError::Node {
            node: self.node.clone(),
            message: format!("{what}: {e}"),
            transient: false,
        })
    }
}

impl Drop for NodeClient {
    /// Gives the lease back (best effort: a node that is gone lets it expire).
    fn drop(&mut self) {
        if let Some(lease) = self.lease.take() {
            let opts = NodeOptions {
                retries: 0,
                deadline: Duration::from_secs(2).min(self.opts.deadline),
                ..self.opts.clone()
            };
            let me = NodeClient {
                rt: Arc::clone(&self.rt),
                client: self.client.clone(),
                node: self.node.clone(),
                auth: self.auth.clone(),
                opts,
                lease: None,
                outputs: Vec::new(),
            };
            let _ = me.call(
                "releasing",
                proto::ReleaseRequest { lease },
                |mut c, r| async move { c.release(r).await },
            );
        }
    }
}
