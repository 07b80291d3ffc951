//! The gRPC service of a node: token on every call, one station's lease at a time,
//! every size and value checked before it is used, one output lit and the others black.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use tonic::{Request, Response, Status};

use crate::framebuffer::{Framebuffer, max_code, requantise};
use crate::limits::{LEASE_IDLE_EXPIRY, PROTOCOL, valid_name};
use crate::proto;
use crate::proto::pattern_service_server::PatternService;

use super::barrier::SwapBarrier;
use super::{OutputSpec, Presenter, ServerConfig};

/// A station's hold on the node.
#[derive(Debug, Clone)]
struct Lease {
    id: String,
    station: String,
    since_utc: String,
    last_used: Instant,
}

/// What the service changes: the presenter, the lease, the frame counter.
struct NodeState {
    presenter: Box<dyn Presenter>,
    lease: Option<Lease>,
    frames: u64,
    leases_made: u64,
}

impl NodeState {
    /// The current lease if it is `id` and still alive; renews its idle time.
    fn check_lease(&mut self, id: &str) -> Result<(), Status> {
        match &mut self.lease {
            Some(l) if l.id == id && l.last_used.elapsed() < LEASE_IDLE_EXPIRY => {
                l.last_used = Instant::now();
                Ok(())
            }
            Some(l) if l.id != id && l.last_used.elapsed() < LEASE_IDLE_EXPIRY => Err(busy(l)),
            _ => Err(Status::failed_precondition(
                "no lease: call Acquire first (a lease unused for 15 minutes expires)",
            )),
        }
    }
}

/// The status a station gets for a node another station holds.
fn busy(l: &Lease) -> Status {
    Status::failed_precondition(format!(
        "busy (held by {} since {})",
        l.station, l.since_utc
    ))
}

/// The pattern service of one node.
#[derive(Clone)]
pub struct PatternNode {
    config: Arc<ServerConfig>,
    state: Arc<Mutex<NodeState>>,
    barrier: SwapBarrier,
}

impl PatternNode {
    /// The service for `config`, presenting through `presenter`.
    pub fn new(config: ServerConfig, presenter: Box<dyn Presenter>) -> Self {
        PatternNode {
            config: Arc::new(config),
            state: Arc::new(Mutex::new(NodeState {
                presenter,
                lease: None,
                frames: 0,
                leases_made: 0,
            })),
            barrier: SwapBarrier::default(),
        }
    }

    fn lock(&self) -> MutexGuard<'_, NodeState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Fails unless the call carries the wall's token.
    fn authorize<T>(&self, req: &Request<T>) -> Result<(), Status> {
        let ok = req
            .metadata()
            .get("authorization")
            .is_some_and(|v| self.config.token.accepts(v.as_bytes()));
        if ok {
            Ok(())
        } else {
            Err(Status::unauthenticated(format!(
                "node {} refused the token: the wall's token file and this node's --token-file \
                 must hold the same token",
                self.config.node_name
            )))
        }
    }

    /// The configured output named `name`, with its index.
    fn output(&self, name: &str) -> Result<(usize, &OutputSpec), Status> {
        self.config
            .outputs
            .iter()
            .enumerate()
            .find(|(_, o)| o.name == name)
            .ok_or_else(|| {
                let have: Vec<&str> = self
                    .config
                    .outputs
                    .iter()
                    .map(|o| o.name.as_str())
                    .collect();
                Status::invalid_argument(format!(
                    "node {} has no output {name:?}; it has {}",
                    self.config.node_name,
                    have.join(", ")
                ))
            })
    }

    /// Frames with output `lit` showing `frame` and every other output black.
    fn frames_with(&self, lit: Option<(usize, Framebuffer)>) -> Vec<Framebuffer> {
        let mut lit = lit;
        self.config
            .outputs
            .iter()
            .enumerate()
            .map(|(i, o)| match lit.take_if(|(j, _)| *j == i) {
                Some((_, f)) => f,
                None => Framebuffer::black(o.width_px, o.height_px, o.surface_bit_depth),
            })
            .collect()
    }

    /// Presents `frames` under `lease`, waits the settle time, and says when.
    async fn present(
        &self,
        lease: String,
        frames: Vec<Framebuffer>,
        surface_bit_depth: u32,
    ) -> Result<Response<proto::Presented>, Status> {
        let started = Instant::now();
        let state = Arc::clone(&self.state);
        let frame = tokio::task::spawn_blocking(move || {
            let mut st = state.lock().unwrap_or_else(|e| e.into_inner());
            st.check_lease(&lease)?;
            st.presenter
                .present(frames)
                .map_err(|e| Status::internal(format!("presenting failed: {e}")))?;
            st.frames += 1;
            Ok::<u64, Status>(st.frames)
        })
        .await
        .map_err(|e| Status::internal(format!("presenter task failed: {e}")))??;
        let latency = started.elapsed();
        tokio::time::sleep(self.config.settle).await;
        Ok(Response::new(proto::Presented {
            frame,
            present_latency_ms: latency.as_secs_f64() * 1e3,
            settle_ms: self.config.settle.as_secs_f64() * 1e3,
            surface_bit_depth,
        }))
    }
}

/// A PNG for output `o`, checked against its size and bit depth and requantised to
/// its surface.
fn output_frame(o: &OutputSpec, png: &[u8]) -> Result<Framebuffer, Status> {
    let frame = Framebuffer::from_png(png, o.width_px, o.height_px, o.bit_depth)
        .map_err(|e| Status::invalid_argument(format!("output {}: {e}", o.name)))?;
    Ok(Framebuffer {
        codes: frame
            .codes
            .iter()
            .map(|c| c.map(|v| requantise(u32::from(v), o.bit_depth, o.surface_bit_depth)))
            .collect(),
        bits: o.surface_bit_depth,
        ..frame
    })
}

/// The time now, RFC 3339 UTC to the second.
fn now_utc() -> String {
    jiff::Timestamp::now()
        .strftime("%Y-%m-%dT%H:%M:%SZ")
        .to_string()
}

/// A uniform frame for `req` on output `o`, or why not.
fn uniform_frame(o: &OutputSpec, req: &proto::ShowUniformRequest) -> Result<Framebuffer, Status> {
    let [r, g, b] = <[u32; 3]>::try_from(req.code.as_slice()).map_err(|_| {
        Status::invalid_argument(format!(
            "{} code values given; a uniform field needs red, green and blue",
            req.code.len()
        ))
    })?;
    if req.bit_depth != o.bit_depth {
        return Err(Status::invalid_argument(format!(
            "codes given at {} bit, output {} takes {} bit",
            req.bit_depth, o.name, o.bit_depth
        )));
    }
    let top = max_code(o.bit_depth);
    if let Some(c) = [r, g, b].into_iter().find(|c| *c > top) {
        return Err(Status::invalid_argument(format!(
            "code {c} is above {top}, the largest {}-bit code",
            o.bit_depth
        )));
    }
    let code = [r, g, b].map(|c| requantise(c, o.bit_depth, o.surface_bit_depth));
    Ok(Framebuffer::uniform(
        o.width_px,
        o.height_px,
        o.surface_bit_depth,
        code,
    ))
}

#[tonic::async_trait]
impl PatternService for PatternNode {
    async fn list_outputs(
        &self,
        request: Request<proto::ListOutputsRequest>,
    ) -> Result<Response<proto::ListOutputsResponse>, Status> {
        self.authorize(&request)?;
        Ok(Response::new(proto::ListOutputsResponse {
            outputs: self
                .config
                .outputs
                .iter()
                .map(OutputSpec::to_proto)
                .collect(),
            node: self.config.node_name.clone(),
        }))
    }

    async fn acquire(
        &self,
        request: Request<proto::AcquireRequest>,
    ) -> Result<Response<proto::AcquireResponse>, Status> {
        self.authorize(&request)?;
        let req = request.into_inner();
        if req.protocol != PROTOCOL {
            return Err(Status::failed_precondition(format!(
                "the station speaks protocol {:?}, node {} speaks {PROTOCOL}; update one of them",
                req.protocol, self.config.node_name
            )));
        }
        if !valid_name(&req.station) {
            return Err(Status::invalid_argument(
                "the station name must be 1 to 64 letters, digits or -_.:@",
            ));
        }
        let mut st = self.lock();
        if let Some(l) = &st.lease
            && l.station != req.station
            && l.last_used.elapsed() < LEASE_IDLE_EXPIRY
        {
            return Err(busy(l));
        }
        st.leases_made += 1;
        let since_utc = match &st.lease {
            Some(l) if l.station == req.station => l.since_utc.clone(),
            _ => now_utc(),
        };
        let id = format!("{}-{}-{}", req.station, std::process::id(), st.leases_made);
        st.lease = Some(Lease {
            id: id.clone(),
            station: req.station.clone(),
            since_utc,
            last_used: Instant::now(),
        });
        tracing::info!(station = %req.station, "node acquired");
        Ok(Response::new(proto::AcquireResponse {
            lease: id,
            settle_ms: self.config.settle.as_secs_f64() * 1e3,
        }))
    }

    async fn release(
        &self,
        request: Request<proto::ReleaseRequest>,
    ) -> Result<Response<proto::ReleaseResponse>, Status> {
        self.authorize(&request)?;
        let lease = request.into_inner().lease;
        let frames = self.frames_with(None);
        let mut st = self.lock();
        st.check_lease(&lease)?;
        st.presenter
            .present(frames)
            .map_err(|e| Status::internal(format!("presenting black failed: {e}")))?;
        st.lease = None;
        Ok(Response::new(proto::ReleaseResponse {}))
    }

    async fn show_uniform(
        &self,
        request: Request<proto::ShowUniformRequest>,
    ) -> Result<Response<proto::Presented>, Status> {
        self.authorize(&request)?;
        let req = request.into_inner();
        let (index, o) = self.output(&req.output)?;
        let frame = uniform_frame(o, &req)?;
        let surface = o.surface_bit_depth;
        let frames = self.frames_with(Some((index, frame)));
        self.present(req.lease, frames, surface).await
    }

    async fn show_image(
        &self,
        request: Request<proto::ShowImageRequest>,
    ) -> Result<Response<proto::Presented>, Status> {
        self.authorize(&request)?;
        let req = request.into_inner();
        let (index, o) = self.output(&req.output)?;
        let frame = output_frame(o, &req.png)?;
        let surface = o.surface_bit_depth;
        let frames = self.frames_with(Some((index, frame)));
        self.present(req.lease, frames, surface).await
    }

    async fn blank(
        &self,
        request: Request<proto::BlankRequest>,
    ) -> Result<Response<proto::Presented>, Status> {
        self.authorize(&request)?;
        let lease = request.into_inner().lease;
        let surface = self
            .config
            .outputs
            .iter()
            .map(|o| o.surface_bit_depth)
            .max()
            .unwrap_or(8);
        let frames = self.frames_with(None);
        self.present(lease, frames, surface).await
    }

    async fn show_frame(
        &self,
        request: Request<proto::ShowFrameRequest>,
    ) -> Result<Response<proto::Presented>, Status> {
        self.authorize(&request)?;
        let req = request.into_inner();
        let mut frames = self.frames_with(None);
        let mut named = vec![false; frames.len()];
        for image in &req.images {
            let (index, o) = self.output(&image.output)?;
            if std::mem::replace(&mut named[index], true) {
                return Err(Status::invalid_argument(format!(
                    "output {} has two images in one frame",
                    o.name
                )));
            }
            frames[index] = output_frame(o, &image.png)?;
        }
        let surface = frames.iter().map(|f| f.bits).max().unwrap_or(8);
        self.present(req.lease, frames, surface).await
    }

    async fn swap_barrier(
        &self,
        request: Request<proto::SwapBarrierRequest>,
    ) -> Result<Response<proto::SwapBarrierResponse>, Status> {
        self.authorize(&request)?;
        let req = request.into_inner();
        let timeout = std::time::Duration::from_millis(u64::from(req.timeout_ms));
        let waited = self
            .barrier
            .arrive(&req.group, req.frame, req.parties, timeout)
            .await?;
        Ok(Response::new(proto::SwapBarrierResponse {
            frame: req.frame,
            waited_ms: waited.as_secs_f64() * 1e3,
        }))
    }

    async fn read_back(
        &self,
        request: Request<proto::ReadBackRequest>,
    ) -> Result<Response<proto::ReadBackResponse>, Status> {
        self.authorize(&request)?;
        let req = request.into_inner();
        let (index, o) = self.output(&req.output)?;
        let (frame, count) = {
            let mut st = self.lock();
            st.check_lease(&req.lease)?;
            (st.presenter.read_back(index), st.frames)
        };
        let frame = frame.ok_or_else(|| {
            Status::unimplemented("this node's presenter cannot read back its frames")
        })?;
        let png = frame
            .to_png()
            .map_err(|e| Status::internal(format!("encoding the frame failed: {e}")))?;
        Ok(Response::new(proto::ReadBackResponse {
            width_px: frame.width,
            height_px: frame.height,
            surface_bit_depth: o.surface_bit_depth,
            png,
            frame: count,
        }))
    }
}
