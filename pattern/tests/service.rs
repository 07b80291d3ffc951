//! The pattern service end to end on 127.0.0.1: a headless server, the station's
//! client, and the refusals a technician meets (wrong token, busy node, protocol
//! mismatch, bad codes, oversized images, a node that is gone).

use std::sync::Arc;
use std::time::Duration;

use lumiwall_core::dither;
use lumiwall_devices::{DeviceError, DisplayId, DisplayInfo, Eye, PatternOutput};
use lumiwall_pattern::client::{NodeClient, NodeOptions, RemotePatternOutput, Route};
use lumiwall_pattern::server::{
    HeadlessServer, OutputSpec, ServerConfig, TlsIdentity, spawn_headless,
};
use lumiwall_pattern::{Framebuffer, OutputAddress, Token, proto};

const TOKEN: &str = "test-token-0123456789";

fn start(outputs: &[&str], settle_ms: u64) -> HeadlessServer {
    start_with(outputs, settle_ms, None)
}

fn start_with(outputs: &[&str], settle_ms: u64, tls: Option<TlsIdentity>) -> HeadlessServer {
    let outputs: Vec<OutputSpec> = outputs.iter().map(|s| s.parse().unwrap()).collect();
    let config = ServerConfig {
        listen: "127.0.0.1:0".parse().unwrap(),
        token: Token::new(TOKEN).unwrap(),
        outputs: outputs.clone(),
        settle: Duration::from_millis(settle_ms),
        node_name: "test-node".into(),
        tls,
    };
    spawn_headless(config).unwrap()
}

fn display(id: u32, bits: u32) -> DisplayInfo {
    DisplayInfo {
        id: DisplayId(id),
        name: format!("tile c{id}r0 mono"),
        tile_col: id,
        tile_row: 0,
        eye: Eye::Mono,
        bit_depth: bits,
    }
}

fn route(id: u32, server: &HeadlessServer, output: &str) -> Route {
    Route {
        display: DisplayId(id),
        address: format!("tcp://{}/{output}", server.addr()).parse().unwrap(),
    }
}

fn opts(station: &str) -> NodeOptions {
    NodeOptions {
        deadline: Duration::from_secs(3),
        retries: 0,
        ..NodeOptions::new(Token::new(TOKEN).unwrap(), station.into())
    }
}

fn node_message(e: DeviceError) -> String {
    match e {
        DeviceError::Node { message, .. } => message,
        other => panic!("expected a node error, got {other:?}"),
    }
}

#[test]
fn uniform_codes_are_presented_exactly_and_the_other_outputs_are_black() {
    let s = start(&["L=8x4@10", "R=8x4@10/8"], 0);
    let displays = vec![display(0, 10), display(1, 10)];
    let routes = vec![route(0, &s, "L"), route(1, &s, "R")];
    let mut out = RemotePatternOutput::connect(displays, &routes, &opts("station-a")).unwrap();
    out.show(DisplayId(0), [1.0, 512.0 / 1023.0, 0.0]).unwrap();
    assert_eq!(
        out.read_back(DisplayId(0)).unwrap().uniform_code(),
        Some([1023, 512, 0])
    );
    assert_eq!(
        out.read_back(DisplayId(1)).unwrap().uniform_code(),
        Some([0, 0, 0])
    );
    // The 10-bit display behind an 8-bit surface: codes are rounded to 8 bit.
    out.show(DisplayId(1), [1.0, 512.0 / 1023.0, 3.0 / 1023.0])
        .unwrap();
    let f = out.read_back(DisplayId(1)).unwrap();
    assert_eq!((f.bits, f.uniform_code()), (8, Some([255, 128, 1])));
    assert_eq!(
        out.read_back(DisplayId(0)).unwrap().uniform_code(),
        Some([0, 0, 0])
    );
}

#[test]
fn a_drive_between_codes_is_presented_as_the_post_pass_dither_whose_cell_mean_is_the_drive() {
    let s = start(&["L=40x20@8"], 0);
    let mut out = RemotePatternOutput::connect(
        vec![display(0, 8)],
        &[route(0, &s, "L")],
        &opts("station-a"),
    )
    .unwrap();
    let drive = [0.5, 100.25 / 255.0, 3.0 / 255.0];
    out.show(DisplayId(0), drive).unwrap();
    let f = out.read_back(DisplayId(0)).unwrap();
    assert_eq!(f.uniform_code(), None);
    let mut sum = [0.0f64; 3];
    for y in 0..f.height {
        for x in 0..f.width {
            let t = dither::dither_threshold(x, y);
            let want = drive.map(|d| dither::quantise(d as f32, 255, t));
            assert_eq!(f.codes[(y * f.width + x) as usize], want, "pixel {x},{y}");
            if x < 16 && y < 16 {
                for c in 0..3 {
                    sum[c] += f64::from(want[c]) / 256.0;
                }
            }
        }
    }
    for c in 0..3 {
        assert!(
            (sum[c] - drive[c] * 255.0).abs() <= 0.5 / 256.0 + 1e-9,
            "{c}: {sum:?}"
        );
    }
    assert_eq!(f.codes[0][2], 3, "a drive on a code stays on it");
}

#[test]
fn a_drive_image_is_resampled_to_the_output_and_presented_at_its_codes() {
    let s = start(&["L=8x4@10"], 0);
    let mut out = RemotePatternOutput::connect(
        vec![display(0, 10)],
        &[route(0, &s, "L")],
        &opts("station-a"),
    )
    .unwrap();
    // Left half 0, right half full red; a 2×1 image becomes the 8×4 output's halves.
    let img = lumiwall_devices::DriveImage::from_fn(2, 1, |u, _| {
        if u < 0.5 { [0.0; 3] } else { [1.0, 0.0, 0.0] }
    })
    .unwrap();
    PatternOutput::show_image(&mut out, DisplayId(0), &img).unwrap();
    let f = out.read_back(DisplayId(0)).unwrap();
    for y in 0..4 {
        for x in 0..8 {
            let want = if x < 4 { [0, 0, 0] } else { [1023, 0, 0] };
            assert_eq!(f.codes[y * 8 + x], want, "pixel {x},{y}");
        }
    }
}

#[test]
fn a_second_station_is_told_who_holds_the_node_and_gets_it_after_release() {
    let s = start(&["0=4x4@8"], 0);
    let routes = vec![route(0, &s, "0")];
    let first =
        RemotePatternOutput::connect(vec![display(0, 8)], &routes, &opts("station-a")).unwrap();
    let err =
        RemotePatternOutput::connect(vec![display(0, 8)], &routes, &opts("station-b")).unwrap_err();
    let msg = node_message(err);
    assert!(msg.contains("busy (held by station-a since 20"), "{msg}");
    drop(first);
    RemotePatternOutput::connect(vec![display(0, 8)], &routes, &opts("station-b")).unwrap();
}

#[test]
fn a_wrong_token_is_refused_and_the_server_keeps_serving() {
    let s = start(&["0=4x4@8"], 0);
    let routes = vec![route(0, &s, "0")];
    let wrong = NodeOptions {
        token: Token::new("another-token-987654321").unwrap(),
        ..opts("station-a")
    };
    let err = RemotePatternOutput::connect(vec![display(0, 8)], &routes, &wrong).unwrap_err();
    assert!(!err.is_transient());
    assert!(node_message(err).contains("refused the token"));
    RemotePatternOutput::connect(vec![display(0, 8)], &routes, &opts("station-a")).unwrap();
}

#[test]
fn routes_to_missing_outputs_or_other_bit_depths_are_configuration_errors() {
    let s = start(&["0=4x4@8"], 0);
    let err =
        RemotePatternOutput::connect(vec![display(0, 8)], &[route(0, &s, "DP-9")], &opts("a"))
            .unwrap_err()
            .to_string();
    assert!(
        err.contains("does not exist") && err.contains("has outputs 0"),
        "{err}"
    );
    let err = RemotePatternOutput::connect(vec![display(0, 10)], &[route(0, &s, "0")], &opts("a"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("10-bit in the wall file") && err.contains("8-bit codes"),
        "{err}"
    );
    let err = RemotePatternOutput::connect(
        vec![display(0, 8), display(1, 8)],
        &[route(0, &s, "0")],
        &opts("a"),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("no output for 1 display"), "{err}");
}

#[test]
fn a_node_that_is_gone_is_a_transient_error_naming_it() {
    let s = start(&["0=4x4@8"], 0);
    let routes = vec![route(0, &s, "0")];
    let mut out = RemotePatternOutput::connect(vec![display(0, 8)], &routes, &opts("a")).unwrap();
    let node = s.addr().to_string();
    drop(s);
    let err = out.show(DisplayId(0), [0.5; 3]).unwrap_err();
    assert!(err.is_transient(), "{err}");
    let text = err.to_string();
    assert!(
        text.contains(&node) && text.contains("pattern-server"),
        "{text}"
    );
}

/// A raw protocol client with the token, for requests the station never sends.
fn raw(
    s: &HeadlessServer,
) -> (
    tokio::runtime::Runtime,
    proto::pattern_service_client::PatternServiceClient<tonic::transport::Channel>,
) {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let c = rt
        .block_on(
            proto::pattern_service_client::PatternServiceClient::connect(format!(
                "http://{}",
                s.addr()
            )),
        )
        .unwrap();
    (rt, c)
}

fn authed<T>(msg: T) -> tonic::Request<T> {
    let mut r = tonic::Request::new(msg);
    r.metadata_mut()
        .insert("authorization", format!("Bearer {TOKEN}").parse().unwrap());
    r
}

#[test]
fn protocol_mismatch_bad_codes_and_wrong_sized_images_are_refused_with_the_reason() {
    let s = start(&["0=4x4@8"], 0);
    let (rt, mut c) = raw(&s);
    let err = rt
        .block_on(c.acquire(authed(proto::AcquireRequest {
            station: "old".into(),
            protocol: "lumiwall.pattern.v0".into(),
        })))
        .unwrap_err();
    assert_eq!(err.code(), tonic::Code::FailedPrecondition);
    assert!(
        err.message().contains("speaks lumiwall.pattern.v1"),
        "{}",
        err.message()
    );
    let lease = rt
        .block_on(c.acquire(authed(proto::AcquireRequest {
            station: "raw".into(),
            protocol: "lumiwall.pattern.v1".into(),
        })))
        .unwrap()
        .into_inner()
        .lease;
    let show = |code: Vec<u32>, bits: u32| proto::ShowUniformRequest {
        lease: lease.clone(),
        output: "0".into(),
        code,
        bit_depth: bits,
    };
    for (req, says) in [
        (show(vec![256, 0, 0], 8), "above 255"),
        (show(vec![1, 2], 8), "2 code values"),
        (show(vec![1, 2, 3], 10), "takes 8 bit"),
    ] {
        let err = rt.block_on(c.show_uniform(authed(req))).unwrap_err();
        assert_eq!(err.code(), tonic::Code::InvalidArgument);
        assert!(err.message().contains(says), "{}", err.message());
    }
    let png = Framebuffer::black(5, 4, 8).to_png().unwrap();
    let err = rt
        .block_on(c.show_image(authed(proto::ShowImageRequest {
            lease: lease.clone(),
            output: "0".into(),
            png,
        })))
        .unwrap_err();
    assert!(err.message().contains("5×4"), "{}", err.message());
    // Still serving.
    rt.block_on(c.show_uniform(authed(show(vec![1, 2, 3], 8))))
        .unwrap();
}

#[test]
fn acknowledgement_comes_after_the_settle_time() {
    let s = start(&["0=4x4@8"], 150);
    let rt = Arc::new(tokio::runtime::Runtime::new().unwrap());
    let node = NodeClient::connect(rt, &s.addr().to_string(), "127.0.0.1", opts("a")).unwrap();
    let t = std::time::Instant::now();
    let p = node.show_uniform("0", [9, 9, 9], 8).unwrap();
    assert!(t.elapsed() >= Duration::from_millis(150));
    assert_eq!(p.settle_ms, 150.0);
    assert!(p.present_latency_ms >= 0.0 && p.present_latency_ms < 1000.0);
    let _ = OutputAddress::clone;
}

#[test]
fn a_node_slower_than_the_deadline_is_a_transient_error_saying_how_long_was_waited() {
    // The settle time stands in for a slow link or a stalled presenter.
    let s = start(&["0=4x4@8"], 600);
    let rt = Arc::new(tokio::runtime::Runtime::new().unwrap());
    let slow = NodeOptions {
        deadline: Duration::from_millis(200),
        retries: 1,
        ..opts("a")
    };
    let node = NodeClient::connect(rt, &s.addr().to_string(), "127.0.0.1", slow).unwrap();
    let t = std::time::Instant::now();
    let err = node.show_uniform("0", [1, 2, 3], 8).unwrap_err();
    assert!(err.is_transient(), "{err}");
    let text = err.to_string();
    assert!(text.contains("no answer within 200 ms"), "{text}");
    assert!(text.contains(&s.addr().to_string()), "{text}");
    // One retry: two deadlines and the pause between them, not an endless wait.
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
}

/// A CA and a node certificate for `localhost` signed by it (PEM): (ca, identity).
fn certificates() -> (Vec<u8>, TlsIdentity) {
    let ca_key = rcgen::KeyPair::generate().unwrap();
    let mut ca_params = rcgen::CertificateParams::new(Vec::<String>::new()).unwrap();
    ca_params.is_ca = rcgen::IsCa::Ca(rcgen::BasicConstraints::Unconstrained);
    let ca = ca_params.self_signed(&ca_key).unwrap();
    let issuer = rcgen::Issuer::new(ca_params, ca_key);
    let node_key = rcgen::KeyPair::generate().unwrap();
    let node = rcgen::CertificateParams::new(vec!["localhost".to_string()])
        .unwrap()
        .signed_by(&node_key, &issuer)
        .unwrap();
    (
        ca.pem().into_bytes(),
        TlsIdentity {
            cert_pem: node.pem().into_bytes(),
            key_pem: node_key.serialize_pem().into_bytes(),
        },
    )
}

#[test]
fn tls_nodes_accept_stations_that_trust_their_authority_and_refuse_the_rest() {
    let (ca, identity) = certificates();
    let s = start_with(&["0=4x4@8"], 0, Some(identity));
    let route = Route {
        display: DisplayId(0),
        address: format!("tcp://localhost:{}/0", s.addr().port())
            .parse()
            .unwrap(),
    };
    let with_ca = |ca: Option<Vec<u8>>| NodeOptions {
        tls_ca_pem: ca,
        ..opts("a")
    };
    {
        let mut out = RemotePatternOutput::connect(
            vec![display(0, 8)],
            std::slice::from_ref(&route),
            &with_ca(Some(ca.clone())),
        )
        .unwrap();
        out.show(DisplayId(0), [1.0, 0.0, 0.0]).unwrap();
        assert_eq!(
            out.read_back(DisplayId(0)).unwrap().uniform_code(),
            Some([255, 0, 0])
        );
    }
    // A station speaking plain TCP, and one trusting another authority, get nowhere.
    assert!(
        RemotePatternOutput::connect(
            vec![display(0, 8)],
            std::slice::from_ref(&route),
            &with_ca(None)
        )
        .is_err()
    );
    let (other_ca, _) = certificates();
    let err = RemotePatternOutput::connect(vec![display(0, 8)], &[route], &with_ca(Some(other_ca)))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(&format!("localhost:{}", s.addr().port())),
        "{err}"
    );
}

/// The wall viewer's frame: every output of a node gets its own image, presented
/// together; two images for one output or a wrong-sized one are refused.
#[test]
fn a_frame_shows_one_image_per_output_together() {
    let s = start(&["L=4x2@8", "R=4x2@8", "X=4x2@8"], 0);
    let rt = Arc::new(tokio::runtime::Runtime::new().unwrap());
    let node = NodeClient::connect(rt, &s.addr().to_string(), "127.0.0.1", opts("a")).unwrap();
    let png = |code| Framebuffer::uniform(4, 2, 8, code).to_png().unwrap();
    node.show_frame(vec![
        ("L".into(), png([10, 20, 30])),
        ("R".into(), png([40, 50, 60])),
    ])
    .unwrap();
    let code = |o: &str| node.read_back(o).unwrap().uniform_code();
    assert_eq!(code("L"), Some([10, 20, 30]));
    assert_eq!(code("R"), Some([40, 50, 60]));
    assert_eq!(code("X"), Some([0, 0, 0]), "an output not named is black");
    let twice = node.show_frame(vec![
        ("L".into(), png([1, 1, 1])),
        ("L".into(), png([2, 2, 2])),
    ]);
    assert!(node_message(twice.unwrap_err()).contains("two images in one frame"));
    let small = Framebuffer::uniform(2, 2, 8, [1, 1, 1]).to_png().unwrap();
    assert!(node.show_frame(vec![("R".into(), small)]).is_err());
    assert_eq!(
        code("R"),
        Some([40, 50, 60]),
        "a refused frame changes nothing"
    );
}

/// Two nodes of a wall meet at the barrier one of them hosts: the first waits until
/// the second is ready with the same frame, then both go on; a missing node is a
/// deadline that says how many were missing.
#[test]
fn nodes_meet_at_the_swap_barrier_before_presenting() {
    let host = start(&["0=4x4@8"], 0);
    let connect = |station: &str| {
        let rt = Arc::new(tokio::runtime::Runtime::new().unwrap());
        NodeClient::connect_unleased(rt, &host.addr().to_string(), "127.0.0.1", opts(station))
            .unwrap()
    };
    let (a, b) = (connect("node-a"), connect("node-b"));
    let early = std::thread::spawn(move || {
        let t = std::time::Instant::now();
        let waited = a
            .swap_barrier("wall", 1, 2, Duration::from_secs(5))
            .unwrap();
        (t.elapsed(), waited)
    });
    std::thread::sleep(Duration::from_millis(200));
    let late = b
        .swap_barrier("wall", 1, 2, Duration::from_secs(5))
        .unwrap();
    let (elapsed, waited) = early.join().unwrap();
    assert!(
        elapsed >= Duration::from_millis(190),
        "the first node waited for the second"
    );
    assert!(
        waited >= 190.0 && late < 100.0,
        "waited {waited} ms and {late} ms"
    );
    let e = b
        .swap_barrier("wall", 2, 2, Duration::from_millis(100))
        .unwrap_err();
    assert!(e.to_string().contains("1 of 2 nodes did not arrive"), "{e}");
}
