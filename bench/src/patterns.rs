//! `lumiwall bench patterns`: what the pattern service costs per pattern change on
//! loopback (station call → frame presented by a headless server → answer), against a
//! raw TCP round trip on the same loopback measured in the same run, and what that
//! means for commissioning the 48-projector wall with a real K-10-A's timing.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::time::{Duration, Instant};

use lumiwall_devices::serial::KLEIN_K10A;
use lumiwall_devices::{DeviceError, DisplayId, DisplayInfo, Eye, PatternOutput};
use lumiwall_pattern::Token;
use lumiwall_pattern::client::{NodeOptions, RemotePatternOutput, Route};
use lumiwall_pattern::server::{HeadlessServer, OutputSpec, ServerConfig, spawn_headless};

/// What to measure.
#[derive(Debug, Clone)]
pub struct PatternsBenchOptions {
    /// The output's size and depth, e.g. `0=1920x1200@10`.
    pub output: OutputSpec,
    /// Pattern changes timed.
    pub changes: u32,
    /// Meter readings per display of the commissioning estimate.
    pub readings_per_display: u32,
    /// Displays of the commissioning estimate.
    pub displays: u32,
}

/// Why the benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum PatternsBenchError {
    /// The server or the client failed.
    #[error("pattern service: {0}")]
    Service(String),
    /// The loopback peer failed.
    #[error("loopback TCP peer: {0}")]
    Peer(#[from] std::io::Error),
}

impl From<DeviceError> for PatternsBenchError {
    fn from(e: DeviceError) -> Self {
        PatternsBenchError::Service(e.to_string())
    }
}

/// Median and 95th percentile of a sample, ms.
#[derive(Debug, Clone, Copy)]
pub struct Spread {
    /// Median, ms.
    pub median_ms: f64,
    /// 95th percentile, ms.
    pub p95_ms: f64,
}

fn spread(mut v: Vec<f64>) -> Spread {
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    Spread {
        median_ms: at(0.5),
        p95_ms: at(0.95),
    }
}

/// The results.
#[derive(Debug, Clone)]
pub struct PatternsReport {
    /// The options measured with.
    pub options: PatternsBenchOptions,
    /// Station → presented → answer per pattern change.
    pub pattern: Spread,
    /// Raw TCP round trip of 64 bytes on loopback (the peer).
    pub tcp_round_trip: Spread,
    /// Time of one K-10-A reading: measurement plus the answer at its baud rate, s.
    pub meter_reading_s: f64,
}

const TOKEN: &str = "bench-token-0123456789abcdef";

/// Runs a headless server for `output` on 127.0.0.1 with no settle time.
fn start_server(output: &OutputSpec) -> Result<HeadlessServer, PatternsBenchError> {
    let token = Token::new(TOKEN).map_err(PatternsBenchError::Service)?;
    let config = ServerConfig {
        listen: SocketAddr::from(([127, 0, 0, 1], 0)),
        token,
        outputs: vec![output.clone()],
        settle: Duration::ZERO,
        node_name: "bench".into(),
        tls: None,
    };
    spawn_headless(config).map_err(|e| PatternsBenchError::Service(e.to_string()))
}

/// Times `changes` pattern changes through the service.
fn time_patterns(opts: &PatternsBenchOptions) -> Result<Spread, PatternsBenchError> {
    let server = start_server(&opts.output)?;
    let addr = server.addr();
    let display = DisplayInfo {
        id: DisplayId(0),
        name: "bench display".into(),
        tile_col: 0,
        tile_row: 0,
        eye: Eye::Mono,
        bit_depth: opts.output.bit_depth,
    };
    let route = Route {
        display: DisplayId(0),
        address: format!("tcp://{addr}/{}", opts.output.name)
            .parse()
            .map_err(|e: lumiwall_pattern::AddressError| {
                PatternsBenchError::Service(e.to_string())
            })?,
    };
    let node = NodeOptions::new(
        Token::new(TOKEN).map_err(PatternsBenchError::Service)?,
        "bench-station".into(),
    );
    let mut out = RemotePatternOutput::connect(vec![display], &[route], &node)?;
    let mut times = Vec::with_capacity(opts.changes as usize);
    for i in 0..opts.changes {
        let level = f64::from(i % 64) / 63.0;
        let t = Instant::now();
        out.show(DisplayId(0), [level, 1.0 - level, 0.5])?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    drop(out);
    drop(server);
    Ok(spread(times))
}

/// Times `n` round trips of 64 bytes to an echo thread on loopback.
fn time_tcp(n: u32) -> Result<Spread, PatternsBenchError> {
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let addr = listener.local_addr()?;
    let echo = std::thread::spawn(move || -> std::io::Result<()> {
        let (mut s, _) = listener.accept()?;
        s.set_nodelay(true)?;
        let mut buf = [0u8; 64];
        while s.read_exact(&mut buf).is_ok() {
            s.write_all(&buf)?;
        }
        Ok(())
    });
    let mut c = TcpStream::connect(addr)?;
    c.set_nodelay(true)?;
    let mut buf = [7u8; 64];
    let mut times = Vec::with_capacity(n as usize);
    for _ in 0..n {
        let t = Instant::now();
        c.write_all(&buf)?;
        c.read_exact(&mut buf)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    drop(c);
    let _ = echo.join();
    Ok(spread(times))
}

/// Runs the benchmark.
pub fn run(options: PatternsBenchOptions) -> Result<PatternsReport, PatternsBenchError> {
    let pattern = time_patterns(&options)?;
    let tcp_round_trip = time_tcp(options.changes.max(100))?;
    // A reading's answer is about 20 bytes of 10 bits (8N1) at the instrument's baud rate.
    let answer_s = 20.0 * 10.0 / f64::from(KLEIN_K10A.baud_rate);
    Ok(PatternsReport {
        options,
        pattern,
        tcp_round_trip,
        meter_reading_s: KLEIN_K10A.measurement_time_s + answer_s,
    })
}

impl std::fmt::Display for PatternsReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let o = &self.options;
        let ratio = self.pattern.median_ms / self.tcp_round_trip.median_ms.max(1e-9);
        writeln!(
            f,
            "pattern changes on loopback, headless server, output {}×{} {}-bit, settle 0, {} changes",
            o.output.width_px, o.output.height_px, o.output.bit_depth, o.changes
        )?;
        writeln!(
            f,
            "what                                   median ms    p95 ms"
        )?;
        writeln!(
            f,
            "station → presented → answer          {:>9.3} {:>9.3}",
            self.pattern.median_ms, self.pattern.p95_ms
        )?;
        writeln!(
            f,
            "peer: raw TCP round trip, 64 B        {:>9.3} {:>9.3}",
            self.tcp_round_trip.median_ms, self.tcp_round_trip.p95_ms
        )?;
        writeln!(f, "ratio pattern change / TCP round trip: {ratio:.1}")?;
        let readings = f64::from(o.displays) * f64::from(o.readings_per_display);
        let meter_s = readings * self.meter_reading_s;
        let patterns_s = readings * self.pattern.median_ms / 1e3;
        writeln!(
            f,
            "commissioning {} displays × {} readings with a K-10-A ({:.0} ms a reading): meter \
             {:.0} s, pattern changes {:.1} s ({:.1} % of the run)",
            o.displays,
            o.readings_per_display,
            self.meter_reading_s * 1e3,
            meter_s,
            patterns_s,
            100.0 * patterns_s / (meter_s + patterns_s)
        )?;
        let target = if self.pattern.median_ms < 5.0 {
            "met"
        } else {
            "NOT met"
        };
        writeln!(
            f,
            "target: protocol overhead under 5 ms per pattern on loopback: {target}"
        )
    }
}
