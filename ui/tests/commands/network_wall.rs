//! The network path end to end (issue 10): `lumiwall pattern-server --headless`
//! processes on 127.0.0.1 serve the outputs of the 6×4 Infitec wall, the wall file
//! routes every display to them, and `lumiwall commission` drives them while the
//! emulated meter (on a pty) reads the virtual wall fed with what the servers
//! presented. The profiles must equal those of the direct simulator path; a server
//! killed mid-run is a typed error naming it, and `--resume` finishes the job.

use std::io::{BufRead, BufReader};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::{fixture, lumiwall};
use predicates::prelude::*;
use predicates::str::contains;
use tempfile::TempDir;

const TOKEN: &str = "wall-token-test-0123456789";

/// A headless pattern server process; killed when dropped.
struct Node {
    child: Child,
    addr: SocketAddr,
}

impl Drop for Node {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Output name of tile (`col`, `row`) and `eye`.
fn output_name(col: u32, row: u32, eye: &str) -> String {
    format!("c{col}r{row}-{eye}")
}

/// Starts `lumiwall pattern-server --headless` with the 24 outputs of one eye of the
/// 6×4 wall, on `listen`, and waits for its "listening on" line.
fn start_node(token: &Path, eye: &str, listen: &str) -> Node {
    let mut cmd = Command::new(assert_cmd::cargo::cargo_bin("lumiwall"));
    cmd.args([
        "pattern-server",
        "--headless",
        "--listen",
        listen,
        "--settle",
        "0s",
    ])
    .arg("--token-file")
    .arg(token)
    .args(["--node-name", &format!("node-{eye}")]);
    for row in 0..4 {
        for col in 0..6 {
            cmd.arg("--output")
                .arg(format!("{}=16x10@10", output_name(col, row, eye)));
        }
    }
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let addr = line
        .split("listening on ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .unwrap_or_else(|| panic!("no address in {line:?}"))
        .parse()
        .unwrap();
    Node { child, addr }
}

/// The heyewall-48 wall file with every display routed to `left` or `right`.
fn networked_wall(dir: &Path, left: SocketAddr, right: SocketAddr) -> PathBuf {
    let mut text = std::fs::read_to_string(fixture("walls/heyewall-48.toml")).unwrap();
    text.push_str("\n[network]\ntoken_file = \"wall.token\"\ndeadline_ms = 5000\nstation = \"test-station\"\n");
    for (eye, addr) in [("left", left), ("right", right)] {
        for row in 0..4 {
            for col in 0..6 {
                text.push_str(&format!(
                    "\n[[output]]\ntile = [{col}, {row}]\neye = \"{eye}\"\nto = \"tcp://{addr}/{}\"\n",
                    output_name(col, row, eye)
                ));
            }
        }
    }
    let path = dir.join("heyewall-net.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `lumiwall commission` with the emulated meter at a thousandth of real time.
fn commission(wall: &Path, out: &Path) -> assert_cmd::Command {
    let mut cmd = lumiwall();
    cmd.args(["commission", "--meter", "emulated", "--time-scale", "0.001"])
        .arg("--wall")
        .arg(wall)
        .arg("--out")
        .arg(out);
    cmd
}

/// The profiles `wall.json` of a folder lists, as JSON values without their creation
/// time.
fn profiles(dir: &Path) -> Vec<(String, serde_json::Value)> {
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let manifest = read(&dir.join("wall.json"));
    manifest["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            let name = f.as_str().unwrap().to_string();
            let mut j = read(&dir.join(&name));
            j["created_utc"] = serde_json::Value::Null;
            (name, j)
        })
        .collect()
}

fn token_file(dir: &Path) -> PathBuf {
    let p = dir.join("wall.token");
    std::fs::write(&p, format!("{TOKEN}\n")).unwrap();
    p
}

#[test]
fn commissioning_through_two_pattern_servers_gives_the_profiles_of_the_direct_path() {
    let tmp = TempDir::new().unwrap();
    let token = token_file(tmp.path());
    let left = start_node(&token, "left", "127.0.0.1:0");
    let right = start_node(&token, "right", "127.0.0.1:0");
    let wall = networked_wall(tmp.path(), left.addr, right.addr);
    let net_out = tmp.path().join("net");
    commission(&wall, &net_out)
        .assert()
        .success()
        .stdout(contains("commissioning heyewall-48: 48 displays"));
    let direct_out = tmp.path().join("direct");
    commission(&fixture("walls/heyewall-48.toml"), &direct_out)
        .assert()
        .success();
    let (net, direct) = (profiles(&net_out), profiles(&direct_out));
    assert_eq!(net.len(), 48);
    for ((name, a), (_, b)) in net.iter().zip(&direct) {
        assert_eq!(a, b, "{name}: network and direct profiles differ");
    }
}

#[test]
fn a_pattern_server_killed_mid_run_is_named_and_resume_finishes_the_job() {
    let tmp = TempDir::new().unwrap();
    let token = token_file(tmp.path());
    let left = start_node(&token, "left", "127.0.0.1:0");
    let right = start_node(&token, "right", "127.0.0.1:0");
    let right_addr = right.addr;
    let wall = networked_wall(tmp.path(), left.addr, right.addr);
    let out = tmp.path().join("out");
    let mut run = Command::new(assert_cmd::cargo::cargo_bin("lumiwall"))
        .args(["commission", "--meter", "emulated", "--time-scale", "0.001"])
        .arg("--wall")
        .arg(&wall)
        .arg("--out")
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Kill the right-eye node once the left eye (displays 0–23) is measured.
    let deadline = Instant::now() + Duration::from_secs(120);
    while !out
        .join("run")
        .join("d020-c2r3-left.measurement.json")
        .exists()
    {
        assert!(
            Instant::now() < deadline,
            "commission never got to display 20"
        );
        assert!(run.try_wait().unwrap().is_none(), "commission ended early");
        std::thread::sleep(Duration::from_millis(20));
    }
    drop(right);
    let output = run.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(&format!("render node {right_addr}")),
        "{stderr}"
    );
    assert!(stderr.contains("--resume"), "{stderr}");
    assert!(
        !out.join("wall.json").exists(),
        "no profiles from a broken run"
    );
    // The node comes back on the same address; the run resumes.
    let _right = start_node(&token, "right", &right_addr.to_string());
    commission(&wall, &out)
        .arg("--resume")
        .assert()
        .success()
        .stdout(contains("profiles: "));
    assert_eq!(profiles(&out).len(), 48);
}

#[test]
fn guided_aiming_prompts_per_display_and_stop_or_skip_resume_where_the_technician_left() {
    let tmp = TempDir::new().unwrap();
    let out = tmp.path().join("out");
    let guided = |typed: &str| {
        let mut cmd = lumiwall();
        cmd.args([
            "commission",
            "--meter",
            "direct",
            "--noise",
            "none",
            "--aim",
            "guided",
        ])
        .arg("--wall")
        .arg(fixture("walls/mono-2x1.toml"))
        .arg("--out")
        .arg(&out)
        .write_stdin(typed.to_string());
        cmd
    };
    // Aim display 0, stop at display 1.
    guided("r\n\nq\n")
        .assert()
        .code(1)
        .stdout(contains("aim the meter at mono-2x1 display 0"))
        .stdout(contains("live: Y = "))
        .stderr(contains(
            "stopped by the technician while aiming the meter at mono-2x1 display 1",
        ))
        .stderr(contains("--resume"));
    // Resume: display 0 is kept, display 1 is skipped this time.
    guided("s\n")
        .arg("--resume")
        .assert()
        .code(1)
        .stdout(contains("aim the meter at mono-2x1 display 0").not())
        .stderr(contains("the technician skipped 1 display: tile c1r0 mono"))
        .stderr(contains("Re-run with --resume"));
    guided("\n")
        .arg("--resume")
        .assert()
        .success()
        .stdout(contains("aim the meter at mono-2x1 display 1"))
        .stdout(contains("profiles: "));
}

#[test]
fn bench_patterns_prints_the_latency_against_the_tcp_peer_and_the_commissioning_share() {
    lumiwall()
        .args([
            "bench",
            "patterns",
            "--output",
            "0=64x40@8",
            "--changes",
            "20",
        ])
        .assert()
        .success()
        .stdout(contains("station → presented → answer"))
        .stdout(contains("peer: raw TCP round trip"))
        .stdout(contains("ratio pattern change / TCP round trip"))
        .stdout(contains("commissioning 48 displays × 40 readings"));
}
