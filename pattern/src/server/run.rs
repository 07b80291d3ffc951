//! Running a node's service: bind the one address given, serve the pattern service
//! and the gRPC health service, stop on a signal.

use std::future::Future;
use std::net::SocketAddr;
use std::time::Duration;

use crate::limits::{DEFAULT_DEADLINE, MAX_MESSAGE_BYTES};
use crate::proto::pattern_service_server::PatternServiceServer;

use super::{PatternNode, Presenter, ServerConfig};

/// Why a pattern server could not run.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The configuration is not usable.
    #[error("pattern server configuration: {0}")]
    Config(String),
    /// The address cannot be bound.
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The cause.
        source: std::io::Error,
    },
    /// The server failed while running.
    #[error("pattern server failed: {0}")]
    Transport(String),
}

/// Longest time one request may take on the node (presenting plus settling).
const REQUEST_TIMEOUT: Duration = DEFAULT_DEADLINE;

/// Binds `config.listen`, tells `on_listening` the bound address (port 0 picks one),
/// and serves until `shutdown` completes.
pub async fn serve(
    config: ServerConfig,
    presenter: Box<dyn Presenter>,
    on_listening: impl FnOnce(SocketAddr),
    shutdown: impl Future<Output = ()>,
) -> Result<(), ServeError> {
    config.validate().map_err(ServeError::Config)?;
    let addr = config.listen;
    let listener = tokio::net::TcpListener::bind(addr)
        .await
        .map_err(|source| ServeError::Bind { addr, source })?;
    let bound = listener
        .local_addr()
        .map_err(|source| ServeError::Bind { addr, source })?;
    let tls = config.tls.clone();
    let (reporter, health) = tonic_health::server::health_reporter();
    reporter
        .set_serving::<PatternServiceServer<PatternNode>>()
        .await;
    let service = PatternServiceServer::new(PatternNode::new(config, presenter))
        .max_decoding_message_size(MAX_MESSAGE_BYTES)
        .max_encoding_message_size(MAX_MESSAGE_BYTES);
    let mut builder = tonic::transport::Server::builder().timeout(REQUEST_TIMEOUT);
    if let Some(tls) = &tls {
        let identity = tonic::transport::Identity::from_pem(&tls.cert_pem, &tls.key_pem);
        builder = builder
            .tls_config(tonic::transport::ServerTlsConfig::new().identity(identity))
            .map_err(|e| ServeError::Config(format!("TLS certificate or key: {e}")))?;
    }
    on_listening(bound);
    builder
        .add_service(health)
        .add_service(service)
        .serve_with_incoming_shutdown(
            tokio_stream::wrappers::TcpListenerStream::new(listener),
            shutdown,
        )
        .await
        .map_err(|e| ServeError::Transport(e.to_string()))
}
