//! `lumiwall view`: a rendered solution on the small wall, one image per display.

use std::path::Path;

use predicates::str::contains;
use tempfile::TempDir;

use crate::common::{cornell, fixture, lumiwall, small_wall};

/// The Cornell box solution, rendered coarsely into `dir`.
fn cornell_solution(dir: &Path) -> std::path::PathBuf {
    lumiwall()
        .args(["render", "--error", "20%", "--out"])
        .arg(dir.join("cornell.exr"))
        .arg(cornell())
        .assert()
        .success();
    dir.join("cornell.ply")
}

/// `lumiwall view` of the Cornell box `solution` on `wall` through `profiles` into `out`.
fn view(wall: &Path, profiles: &Path, solution: &Path, out: &Path) -> assert_cmd::Command {
    let mut cmd = lumiwall();
    cmd.arg("view")
        .arg(cornell())
        .arg("--solution")
        .arg(solution)
        .arg("--wall")
        .arg(wall)
        .arg("--profiles")
        .arg(profiles)
        .arg("--out-dir")
        .arg(out);
    cmd
}

/// Lit pixels (any drive above 0) in column `x` of a PNG.
pub(crate) fn lit_in_column(path: &Path, x: u32) -> usize {
    let img = image::open(path).unwrap().to_rgb16();
    (0..img.height())
        .filter(|&y| img.get_pixel(x, y).0.iter().any(|v| *v > 0))
        .count()
}

/// The box stands before the wall's centre, which is the seam of mono-2x1: both
/// displays show part of it, lit up to the border they share and dark at the far one.
#[test]
fn view_writes_each_displays_image_with_its_frame_time_and_the_box_continues_across_the_seam() {
    let tmp = TempDir::new().unwrap();
    let profiles = crate::common::commission_small_wall(tmp.path());
    let solution = cornell_solution(tmp.path());
    let out = tmp.path().join("view");
    view(&small_wall(), &profiles, &solution, &out)
        .args([
            "--viewer-distance",
            "0.8",
            "--display-size",
            "160x120",
            "--cpu",
        ])
        .assert()
        .success()
        .stdout(contains("luminance scale 1:1"))
        .stdout(contains("2 displays of 160×120 px"))
        .stdout(contains("(raster ").count(2))
        .stdout(contains(
            "frame time per display (2 displays): raster median",
        ));
    let left = out.join("d000-c0r0-mono.png");
    let right = out.join("d001-c1r0-mono.png");
    assert!(lit_in_column(&left, 159) > 20, "left display at the seam");
    assert!(lit_in_column(&right, 0) > 20, "right display at the seam");
    assert_eq!(lit_in_column(&left, 0), 0, "left display's far border");
    assert_eq!(lit_in_column(&right, 159), 0, "right display's far border");
}

#[test]
fn view_refuses_profiles_of_another_wall_a_broken_solution_file_and_a_viewer_on_the_wall() {
    let tmp = TempDir::new().unwrap();
    let profiles = crate::common::commission_small_wall(tmp.path());
    let solution = cornell_solution(tmp.path());
    let infitec = fixture("walls/infitec-pair.toml");
    view(&infitec, &profiles, &solution, &tmp.path().join("a"))
        .assert()
        .failure()
        .stderr(contains("are of wall mono-2x1"));
    let broken = tmp.path().join("broken.ply");
    std::fs::write(&broken, "ply\nformat ascii 1.0\nelement vertex 2\n").unwrap();
    view(&small_wall(), &profiles, &broken, &tmp.path().join("b"))
        .assert()
        .failure()
        .stderr(contains("broken.ply"))
        .stderr(contains("no end_header"));
    view(&small_wall(), &profiles, &solution, &tmp.path().join("c"))
        .args(["--viewer-distance", "0"])
        .assert()
        .code(2)
        .stderr(contains("greater than 0"));
}

/// Without flat fields each display is calibrated at its centre only, and its
/// vignetting shows at the seam: the check through the simulator finds a step of
/// several per cent there and fails, naming it.
#[test]
fn the_seam_check_through_the_simulator_fails_on_a_wall_without_flat_fields() {
    let tmp = TempDir::new().unwrap();
    let profiles = crate::common::commission_small_wall(tmp.path());
    let solution = cornell_solution(tmp.path());
    let out = view(
        &small_wall(),
        &profiles,
        &solution,
        &tmp.path().join("view"),
    )
    .args([
        "--viewer-distance",
        "3",
        "--display-size",
        "320x240",
        "--cpu",
    ])
    .args(["--seams-through-simulator", "--luminance-scale", "auto"])
    .assert()
    .failure()
    .stderr(contains("across a seam (limit 1 %)"))
    .get_output()
    .stdout
    .clone();
    let text = String::from_utf8(out).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("seams through the simulator"))
        .expect("seam line");
    let max: f64 = line
        .split("max ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .expect("max step");
    assert!(max > 3.0, "{line}");
    assert!(line.contains("FAIL"), "{line}");
}

/// Reads `child`'s stdout line by line until a line contains `what`; returns it.
fn line_with(lines: &mut impl Iterator<Item = std::io::Result<String>>, what: &str) -> String {
    for line in lines.by_ref() {
        let line = line.expect("stdout");
        if line.contains(what) {
            return line;
        }
    }
    panic!("the viewer ended without printing {what:?}");
}

/// A tracker bridge sends two head poses over UDP (a bad datagram between them):
/// each pose is rendered into its own folder, and the moved head sees the box at
/// another place on the wall.
#[test]
fn a_tracked_head_moves_the_view_and_every_pose_is_rendered() {
    use std::io::BufRead;
    let tmp = TempDir::new().unwrap();
    let profiles = crate::common::commission_small_wall(tmp.path());
    let solution = cornell_solution(tmp.path());
    let out = tmp.path().join("tracked");
    let mut cmd = std::process::Command::new(assert_cmd::cargo::cargo_bin("lumiwall"));
    cmd.arg("view")
        .arg(cornell())
        .arg("--solution")
        .arg(&solution)
        .arg("--wall")
        .arg(small_wall())
        .arg("--profiles")
        .arg(&profiles)
        .arg("--out-dir")
        .arg(&out)
        .args([
            "--display-size",
            "160x120",
            "--cpu",
            "--viewer-distance",
            "0.8",
        ])
        .args([
            "--tracking",
            "127.0.0.1:0",
            "--poses",
            "2",
            "--tracking-timeout",
            "60s",
        ])
        .stdout(std::process::Stdio::piped());
    let mut child = cmd.spawn().unwrap();
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    let listening = line_with(&mut lines, "tracking: listening on ");
    let addr = listening
        .split("listening on ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .unwrap()
        .to_string();
    let tx = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    // the small wall is 2 × 1.6 m wide and 1.2 m high: first the reference viewer
    // before its centre, then 0.6 m to the left
    tx.send_to(b"LWPOSE 1 1 1.6 0.6 0.8", &addr).unwrap();
    line_with(&mut lines, "pose 0 (seq 1)");
    tx.send_to(b"LWPOSE 1 2 nonsense", &addr).unwrap();
    tx.send_to(b"LWPOSE 1 3 1.0 0.6 0.8", &addr).unwrap();
    let summary = line_with(&mut lines, "poses rendered");
    assert!(child.wait().unwrap().success());
    assert!(
        summary.contains("2 poses rendered; 1 bad and 0 stale"),
        "{summary}"
    );
    let first = out.join("pose_0000/d000-c0r0-mono.png");
    let second = out.join("pose_0001/d000-c0r0-mono.png");
    let lit = |p: &Path| (0..160).map(|x| lit_in_column(p, x)).sum::<usize>();
    assert!(lit(&first) > 0 && lit(&second) > 0);
    assert_ne!(
        image::open(&first).unwrap().to_rgb16().into_raw(),
        image::open(&second).unwrap().to_rgb16().into_raw(),
        "the head moved 0.6 m to the left: the left display shows the room from elsewhere"
    );
}

/// A headless pattern server with one 160×120 8-bit output `out`; killed on drop.
struct PatternNode {
    child: std::process::Child,
    addr: String,
}

impl Drop for PatternNode {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn pattern_node(token: &Path) -> PatternNode {
    use std::io::BufRead;
    let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("lumiwall"))
        .args([
            "pattern-server",
            "--headless",
            "--listen",
            "127.0.0.1:0",
            "--settle",
            "0s",
        ])
        .arg("--token-file")
        .arg(token)
        .args(["--output", "out=160x120@8"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let addr = line
        .split("listening on ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .unwrap_or_else(|| panic!("no address in {line:?}"))
        .to_string();
    PatternNode { child, addr }
}

/// Each render node of the two-tile wall renders its own tile and shows it on its
/// output; the node that starts first waits at the swap barrier until the other has
/// its frame ready, then both present.
#[test]
fn two_render_nodes_show_their_own_tiles_after_meeting_at_the_swap_barrier() {
    let tmp = TempDir::new().unwrap();
    let profiles = crate::common::commission_small_wall(tmp.path());
    let solution = cornell_solution(tmp.path());
    let token = tmp.path().join("wall.token");
    std::fs::write(&token, "view-token-0123456789\n").unwrap();
    let (a, b) = (pattern_node(&token), pattern_node(&token));
    let mut wall = std::fs::read_to_string(small_wall()).unwrap();
    wall.push_str("\n[network]\ntoken_file = \"wall.token\"\ndeadline_ms = 5000\n");
    for (col, node) in [(0, &a), (1, &b)] {
        wall.push_str(&format!(
            "\n[[output]]\ntile = [{col}, 0]\nto = \"tcp://{}/out\"\n",
            node.addr
        ));
    }
    let wall_path = tmp.path().join("mono-2x1-net.toml");
    std::fs::write(&wall_path, wall).unwrap();
    let show = |node: &PatternNode, out: &str| {
        let mut cmd = std::process::Command::new(assert_cmd::cargo::cargo_bin("lumiwall"));
        cmd.arg("view")
            .arg(cornell())
            .arg("--solution")
            .arg(&solution)
            .arg("--wall")
            .arg(&wall_path)
            .arg("--profiles")
            .arg(&profiles)
            .arg("--out-dir")
            .arg(tmp.path().join(out))
            .args([
                "--display-size",
                "160x120",
                "--cpu",
                "--viewer-distance",
                "0.8",
            ])
            .args(["--show-on", &node.addr])
            .stdout(std::process::Stdio::piped());
        cmd.spawn().unwrap()
    };
    let first = show(&a, "a");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let second = show(&b, "b");
    let (first, second) = (
        first.wait_with_output().unwrap(),
        second.wait_with_output().unwrap(),
    );
    let text = |o: &std::process::Output| String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        first.status.success() && second.status.success(),
        "{}\n{}",
        text(&first),
        text(&second)
    );
    let waited = |o: &std::process::Output| -> f64 {
        let t = text(o);
        let line = t
            .lines()
            .find(|l| l.contains("swap barrier wait"))
            .expect("a frame line");
        line.split("swap barrier wait ")
            .nth(1)
            .and_then(|s| s.split(' ').next())
            .and_then(|s| s.parse().ok())
            .unwrap()
    };
    assert!(waited(&first) > 500.0, "{}", text(&first));
    assert!(waited(&second) < waited(&first), "{}", text(&second));
    for o in [&first, &second] {
        assert!(text(o).contains("presented on 1 outputs"), "{}", text(o));
        assert!(text(o).contains("1 displays of 160×120 px"), "{}", text(o));
    }
}
