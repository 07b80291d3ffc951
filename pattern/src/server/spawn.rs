//! A headless server on its own thread, for tests, benchmarks and a station that
//! drives its own outputs through loopback.

use std::net::SocketAddr;
use std::time::Duration;

use super::{HeadlessPresenter, ServeError, ServerConfig, serve};

/// A running headless server; stopped and joined when dropped.
#[derive(Debug)]
pub struct HeadlessServer {
    addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl HeadlessServer {
    /// The bound address (`config.listen` with port 0 gets a free port).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }
}

impl Drop for HeadlessServer {
    fn drop(&mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Starts `config` with a [`HeadlessPresenter`] on a new thread and waits (at most
/// 10 s) until it listens.
pub fn spawn_headless(config: ServerConfig) -> Result<HeadlessServer, ServeError> {
    let (addr_tx, addr_rx) = std::sync::mpsc::channel();
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let thread = std::thread::spawn(move || {
        let rt = match tokio::runtime::Runtime::new() {
            Ok(rt) => rt,
            Err(e) => {
                let _ = addr_tx.send(Err(ServeError::Transport(format!("runtime: {e}"))));
                return;
            }
        };
        let presenter = Box::new(HeadlessPresenter::new(&config.outputs));
        let started = addr_tx.clone();
        let served = rt.block_on(serve(
            config,
            presenter,
            move |a| {
                let _ = started.send(Ok(a));
            },
            async {
                let _ = stop_rx.await;
            },
        ));
        if let Err(e) = served {
            let _ = addr_tx.send(Err(e));
        }
    });
    let addr = addr_rx
        .recv_timeout(Duration::from_secs(10))
        .map_err(|_| ServeError::Transport("the server did not start within 10 s".into()))??;
    Ok(HeadlessServer {
        addr,
        stop: Some(stop_tx),
        thread: Some(thread),
    })
}
