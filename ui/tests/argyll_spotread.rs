//! An independent client against `lumiwall meter-emulator`: ArgyllCMS `spotread`
//! (Debian `argyll`; its Klein K-10 driver was written against the real instrument)
//! finds the emulated K-10-A, starts it up (P0, D7, L0, J8, P2, the T2 flicker read)
//! and reads the virtual wall; the XYZ it prints must equal the simulator's noiseless
//! truth at the meter's spot to the K-10's number precision.
//!
//! Argyll lists only `/dev/ttyUSB*`-like names, so `/dev/ttyUSB-lumiwall` must lead
//! to the pseudo-terminal (made here when running as root, else made once by root as
//! a link to `/tmp/lumiwall-argyll-pty`, which the test points at the emulator), and
//! it needs a non-empty `/dev/bus/usb` (else Argyll probes every device in /dev as USB
//! and hangs on a serial port). Without them, or without `spotread`, the test is
//! skipped unless `LUMIWALL_REQUIRE_ARGYLL=1` (then it fails with what to do).

use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

mod common;
use common::*;
use lumiwall_devices::SpectralRadiance;

/// The name Argyll scans (`ttyUSB` prefix) that the test points at the emulator.
const LINK: &str = "/dev/ttyUSB-lumiwall";

/// Where [`LINK`] points when it was made once by root (`.ci/run`, or the command
/// `scripts/test` prints): the test, unprivileged, points this at the emulator.
const HOP: &str = "/tmp/lumiwall-argyll-pty";

/// The tests share the device link: one at a time within this program...
static LINE: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// ...and across programs (`scripts/test` runs this one beside the other tests, and a
/// second run of it would fight over [`LINK`]): an advisory lock on this file.
const LINE_LOCK: &str = "/tmp/lumiwall-argyll-line.lock";

/// Holds the device link for one test.
struct Line {
    _in_process: std::sync::MutexGuard<'static, ()>,
    _across_processes: std::fs::File,
}

/// Relative agreement with the truth: the K-10's 15-bit mantissa (3·10⁻⁵) and
/// Argyll's printing to six decimals.
const TOLERANCE: f64 = 1e-4;

struct Emulator {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
}

impl Emulator {
    fn start(extra: &[&str]) -> (Self, String) {
        Self::start_on(&small_wall(), &["--noise", "none"], extra)
    }

    fn start_on(wall: &Path, noise: &[&str], extra: &[&str]) -> (Self, String) {
        let mut child = Command::new(assert_cmd::cargo::cargo_bin("lumiwall"))
            .arg("meter-emulator")
            .args(noise)
            .arg("--wall")
            .arg(wall)
            .args(extra)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let stdin = child.stdin.take().unwrap();
        let mut stdout = BufReader::new(child.stdout.take().unwrap());
        let mut path = String::new();
        stdout.read_line(&mut path).unwrap();
        (
            Self {
                child,
                stdin,
                stdout,
            },
            path.trim().to_string(),
        )
    }

    /// Sends one stdin command and returns its answer line.
    fn ask(&mut self, command: &str) -> String {
        writeln!(self.stdin, "{command}").unwrap();
        self.stdin.flush().unwrap();
        let mut line = String::new();
        self.stdout.read_line(&mut line).unwrap();
        assert!(line.starts_with("ok"), "{command}: {line}");
        line
    }

    fn truth(&mut self) -> [f64; 3] {
        let line = self.ask("truth");
        numbers_after(&line, "XYZ")
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        let _ = writeln!(self.stdin, "quit");
        let _ = self.child.wait();
        let _ = std::fs::remove_file(HOP);
    }
}

fn numbers_after(line: &str, key: &str) -> [f64; 3] {
    let rest = line
        .split(key)
        .nth(1)
        .unwrap_or_else(|| panic!("{key} in {line}"));
    let v: Vec<f64> = rest
        .split(|c: char| c.is_whitespace() || matches!(c, ',' | ':' | '"'))
        .filter_map(|w| w.parse().ok())
        .take(3)
        .collect();
    [v[0], v[1], v[2]]
}

/// The device link for one test, or `None` when Argyll is not ready (see
/// [`argyll_ready`]). The readiness check is made holding the link: `spotread -?`
/// probes every serial port, so run beside another test it would talk into that
/// test's session with the emulator and break it ("Instrument Access Failed").
fn take_line() -> Option<Line> {
    let in_process = LINE.lock().unwrap_or_else(|e| e.into_inner());
    // read-only where it exists (another user may own it), made where it does not
    let file = std::fs::File::open(LINE_LOCK)
        .or_else(|_| std::fs::File::create(LINE_LOCK))
        .unwrap_or_else(|e| panic!("{LINE_LOCK}: {e}"));
    file.lock()
        .unwrap_or_else(|e| panic!("locking {LINE_LOCK}: {e}"));
    argyll_ready().then_some(Line {
        _in_process: in_process,
        _across_processes: file,
    })
}

/// Skips (or, when required, fails) when Argyll or the device links are missing.
fn argyll_ready() -> bool {
    let required = std::env::var("LUMIWALL_REQUIRE_ARGYLL").is_ok_and(|v| v == "1");
    let have_spotread = Command::new("spotread")
        .arg("-?")
        .env("ARGYLL_NOT_INTERACTIVE", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok();
    let bus = Path::new("/dev/bus/usb/001");
    let can_link = std::fs::create_dir_all(bus).is_ok() && (hop_in_place() || writable("/dev"));
    let ready = have_spotread && can_link;
    if !ready {
        let why = format!(
            "spotread found: {have_spotread}; /dev/bus/usb/001 and {LINK} can be made: {can_link} \
             (install Debian `argyll`; run as root)"
        );
        assert!(!required, "LUMIWALL_REQUIRE_ARGYLL=1 but {why}");
        eprintln!("skipped: {why}");
    }
    ready
}

/// Whether [`LINK`] already leads through [`HOP`].
fn hop_in_place() -> bool {
    std::fs::read_link(LINK).is_ok_and(|t| t == Path::new(HOP))
}

/// Makes [`LINK`] lead to `pty`: through [`HOP`] when root made it so, else directly.
fn link_to(pty: &str) {
    let _ = std::fs::remove_file(HOP);
    std::os::unix::fs::symlink(pty, HOP).unwrap();
    if !hop_in_place() {
        let _ = std::fs::remove_file(LINK);
        std::os::unix::fs::symlink(HOP, LINK).unwrap();
    }
}

fn writable(dir: &str) -> bool {
    let probe = Path::new(dir).join(".lumiwall-write-probe");
    let ok = std::fs::write(&probe, b"").is_ok();
    let _ = std::fs::remove_file(&probe);
    ok
}

/// `spotread -?` lists the ports; the number of ours, identified as a Klein K-10.
fn port_number() -> String {
    port_number_of("Klein K-10")
}

/// `spotread -?` lists the ports; the number of ours, identified as `instrument`.
fn port_number_of(instrument: &str) -> String {
    let out = Command::new("timeout")
        .args(["60", "spotread", "-?"])
        .env("ARGYLL_NOT_INTERACTIVE", "1")
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stderr).to_string() + &String::from_utf8_lossy(&out.stdout);
    let line = text
        .lines()
        .find(|l| l.contains(LINK))
        .unwrap_or_else(|| panic!("spotread does not list {LINK}:\n{text}"));
    assert!(
        line.contains(instrument),
        "not identified as a {instrument}: {line}"
    );
    line.split('=').next().unwrap().trim().to_string()
}

/// One `spotread` reading (emissive, one reading and exit): the XYZ it prints.
fn spotread_xyz(port: &str) -> [f64; 3] {
    spotread_xyz_with(port, &[])
}

/// As [`spotread_xyz`] with extra options (`-X file.ccmx`).
fn spotread_xyz_with(port: &str, extra: &[&str]) -> [f64; 3] {
    let text = spotread(port, extra);
    let line = text
        .lines()
        .find(|l| l.contains("Result is XYZ"))
        .unwrap_or_else(|| panic!("spotread gave no reading:\n{text}"));
    numbers_after(line, "XYZ:")
}

/// What one `spotread` reading (emissive, one reading and exit) prints.
fn spotread(port: &str, extra: &[&str]) -> String {
    let out = Command::new("timeout")
        .args(["120", "spotread", "-c", port, "-e", "-O", "-x"])
        .args(extra)
        .env("ARGYLL_NOT_INTERACTIVE", "1")
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr)
}

fn assert_close(got: [f64; 3], truth: [f64; 3], what: &str) {
    for c in 0..3 {
        let rel = (got[c] - truth[c]).abs() / truth[c].abs().max(1e-3);
        assert!(rel < TOLERANCE, "{what}: spotread {got:?}, truth {truth:?}");
    }
}

#[test]
fn argyll_spotread_reads_the_virtual_wall_through_the_emulated_k10a_as_the_simulator_says() {
    let Some(_one_at_a_time) = take_line() else {
        return;
    };
    let (mut emu, pty) = Emulator::start(&[]);
    link_to(&pty);
    let port = port_number();
    // white at the centre of display 0 (bright: one reading)
    let truth = emu.truth();
    assert_close(spotread_xyz(&port), truth, "white, display 0 centre");
    // a dim red off-centre on display 1 (Argyll averages 10–20 readings below 2 cd/m²)
    emu.ask("show 1 0.08 0.01 0.01");
    emu.ask("aim 1 0.3 0.7");
    let truth = emu.truth();
    assert!(truth[1] < 2.0, "{truth:?} should be dim");
    assert_close(spotread_xyz(&port), truth, "dim red, display 1 off-centre");
}

/// The spectrum `spotread -s` prints (mW·sr⁻¹·m⁻²·nm⁻¹ after "Spectrum from A to B
/// nm in N steps") as lumiwall's spectral radiance (W).
fn printed_spectrum(text: &str) -> SpectralRadiance {
    let (head, values) = text
        .split_once("Spectrum from ")
        .and_then(|(_, rest)| rest.split_once('\n'))
        .unwrap_or_else(|| panic!("no spectrum in\n{text}"));
    let words: Vec<f64> = head
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    let (start, end, n) = (words[0], words[1], words[2] as usize);
    let mw: Vec<f64> = values
        .lines()
        .next()
        .unwrap_or("")
        .split(',')
        .filter_map(|v| v.trim().parse().ok())
        .collect();
    assert_eq!(mw.len(), n, "{n} values announced");
    SpectralRadiance {
        start_nm: start,
        step_nm: (end - start) / (n as f64 - 1.0),
        w_sr_m2_nm: mw.iter().map(|v| v / 1000.0).collect(),
    }
}

#[test]
fn argyll_spotread_detects_the_emulated_specbos_and_reads_xyz_and_spectrum_as_the_simulator_says() {
    let Some(_one_at_a_time) = take_line() else {
        return;
    };
    let wall = fixture("walls/infitec-pair.toml");
    let (mut emu, pty) = Emulator::start_on(
        &wall,
        &["--noise", "none"],
        &["--instrument", "specbos", "--time-scale", "0.1"],
    );
    link_to(&pty);
    let port = port_number_of("JETI specbos");
    for (show, aim) in [
        ("show 0 1 1 1", "aim 0 0.5 0.5"),
        ("show 1 0.05 0.6 0.02", "aim 1 0.2 0.8"),
    ] {
        emu.ask(show);
        emu.ask(aim);
        let truth = emu.truth();
        let text = spotread(&port, &["-s"]);
        let line = text
            .lines()
            .find(|l| l.contains("Result is XYZ"))
            .unwrap_or_else(|| panic!("spotread gave no reading:\n{text}"));
        assert_close(numbers_after(line, "XYZ:"), truth, show);
        // the spectrum Argyll received (6 significant digits) integrates to the truth
        let spectrum = printed_spectrum(&text);
        assert_eq!((spectrum.start_nm, spectrum.w_sr_m2_nm.len()), (360.0, 471));
        let xyz = spectrum.xyz().unwrap();
        assert_close([xyz.x, xyz.y, xyz.z], truth, &format!("{show}: spectrum"));
    }
}

/// A free local TCP port for Argyll's web display.
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// One .ti3 row: RGB (0..100) and XYZ (white Y = 100).
type Ti3Row = ([f64; 3], [f64; 3]);

/// The rows of a .ti3 and its white's luminance (cd/m²).
fn read_ti3(path: &Path) -> (Vec<Ti3Row>, f64) {
    let text = std::fs::read_to_string(path).unwrap();
    let white_y = numbers_after(
        text.lines()
            .find(|l| l.starts_with("LUMINANCE_XYZ_CDM2"))
            .unwrap(),
        "CDM2",
    )[1];
    let data = text.split("BEGIN_DATA\n").nth(1).unwrap();
    let rows = data
        .lines()
        .take_while(|l| !l.starts_with("END_DATA"))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
            ([v[1], v[2], v[3]], [v[4], v[5], v[6]])
        })
        .collect();
    (rows, white_y)
}

#[test]
fn argyll_dispread_measures_a_chart_on_the_virtual_wall_through_its_web_display() {
    let Some(_one_at_a_time) = take_line() else {
        return;
    };
    let tmp = tempfile::TempDir::new().unwrap();
    // 13 patches: white, black, primaries at 50 and 100 %, greys (targen's own choice)
    let made = Command::new("targen")
        .args(["-v0", "-d3", "-G", "-e2", "-s3", "-g3", "-f8", "chart"])
        .current_dir(tmp.path())
        .status()
        .unwrap();
    assert!(made.success());
    let port = free_port();
    let web = format!("127.0.0.1:{port}");
    let (mut emu, pty) = Emulator::start(&["--time-scale", "0.2", "--follow-webdisp", &web]);
    link_to(&pty);
    let meter = port_number();
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "yes '' | timeout 300 dispread -dweb:{port} -c {meter} chart"
        ))
        .env("ARGYLL_NOT_INTERACTIVE", "1")
        .current_dir(tmp.path())
        .output()
        .unwrap();
    let log =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    let ti3 = tmp.path().join("chart.ti3");
    assert!(ti3.is_file(), "dispread wrote no .ti3:\n{log}");
    let (rows, white_y) = read_ti3(&ti3);
    assert_eq!(rows.len(), 13);
    for (rgb, xyz) in rows {
        // the web display sends 8-bit colours: the drive the wall showed
        let drive = rgb.map(|c| (c / 100.0 * 255.0).round() / 255.0);
        emu.ask(&format!("show 0 {} {} {}", drive[0], drive[1], drive[2]));
        let truth = emu.truth();
        let got = xyz.map(|v| v * white_y / 100.0);
        assert_close(got, truth, &format!("patch RGB {rgb:?}"));
    }
}

#[test]
fn argyll_spotread_applies_lumiwalls_ccmx_and_the_infitec_green_error_shrinks() {
    let Some(_one_at_a_time) = take_line() else {
        return;
    };
    let tmp = tempfile::TempDir::new().unwrap();
    let wall = fixture("walls/dlp-infitec-2x1.toml");
    // the realistic meter's filters err most on the narrow-band Infitec primaries
    lumiwall()
        .args(["meter-matrix", "--wall"])
        .arg(&wall)
        .arg("--out")
        .arg(tmp.path().join("mm.json"))
        .assert()
        .success();
    let ccmx = tmp.path().join("mm.left.ccmx");
    assert!(ccmx.is_file());
    let (mut emu, pty) = Emulator::start_on(&wall, &[], &["--time-scale", "0.2"]);
    link_to(&pty);
    let port = port_number();
    emu.ask("show 0 0 1 0");
    let truth = emu.truth();
    let raw = spotread_xyz(&port);
    let corrected = spotread_xyz_with(&port, &["-X", ccmx.to_str().unwrap()]);
    let (before, after) = (xy_distance(raw, truth), xy_distance(corrected, truth));
    println!("Infitec left green: Δxy {before:.4} without the CCMX, {after:.4} with it");
    assert!(before > 0.008, "the filter mismatch should show: {before}");
    // the figure: after the spectral correction ≤ 0.002 (the reference's
    // wavelength scale checked with a Hg-Ar lamp first, `meter-matrix`'s default)
    assert!(after <= 0.002 && after < before / 3.0, "{before} → {after}");
}

/// Whether an ArgyllCMS tool is installed (skip, or fail when required).
fn have_tool(tool: &str) -> bool {
    let found = Command::new(tool)
        .arg("-?")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok();
    let required = std::env::var("LUMIWALL_REQUIRE_ARGYLL").is_ok_and(|v| v == "1");
    assert!(
        found || !required,
        "LUMIWALL_REQUIRE_ARGYLL=1 but `{tool}` is missing"
    );
    found
}

#[test]
fn argyll_colprof_builds_a_profile_from_lumiwalls_ti3_export_and_applycal_takes_its_cal() {
    if !(have_tool("colprof") && have_tool("profcheck") && have_tool("applycal")) {
        return;
    }
    let tmp = tempfile::TempDir::new().unwrap();
    let commissioned = commission_small_wall(tmp.path());
    let out = tmp.path().join("ti3");
    export("ti3", &commissioned, &out)
        .assert()
        .success()
        .stdout(predicates::str::contains("d000-c0r0-mono.ti3"));
    std::fs::copy(out.join("d000-c0r0-mono.ti3"), tmp.path().join("d0.ti3")).unwrap();
    // shaper + matrix display profile from the commissioning's 39 samples as read
    let colprof = Command::new("colprof")
        .args(["-v", "-qm", "-as", "d0"])
        .current_dir(tmp.path())
        .output()
        .unwrap();
    assert!(
        colprof.status.success() && tmp.path().join("d0.icc").is_file(),
        "colprof refused the export:\n{}",
        String::from_utf8_lossy(&colprof.stderr)
    );
    let check = Command::new("profcheck")
        .args(["d0.ti3", "d0.icc"])
        .current_dir(tmp.path())
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&check.stdout).to_string()
        + &String::from_utf8_lossy(&check.stderr);
    let line = report
        .lines()
        .find(|l| l.contains("avg."))
        .unwrap_or_else(|| panic!("no profcheck summary:\n{report}"));
    println!("profcheck of the exported .ti3: {line}");
    let avg: f64 = line
        .split("avg. =")
        .nth(1)
        .and_then(|r| r.split(',').next())
        .and_then(|v| v.trim().parse().ok())
        .unwrap();
    // measured: average 2.8, largest 7.6 (a shaper/matrix fit of the ramps; the
    // largest errors are near black)
    assert!(avg < 5.0, "profcheck average ΔE {avg}");
    // the grey-axis curves as a .cal: applycal reads them into the profile
    let cal = tmp.path().join("cal");
    export("argyll-cal", &commissioned, &cal).assert().success();
    let applied = Command::new("applycal")
        .arg(cal.join("d000-c0r0-mono.cal"))
        .args(["d0.icc", "d0-cal.icc"])
        .current_dir(tmp.path())
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&applied.stdout).to_string()
        + &String::from_utf8_lossy(&applied.stderr);
    assert!(
        applied.status.success() && tmp.path().join("d0-cal.icc").is_file(),
        "applycal refused the .cal:\n{log}"
    );
    assert!(
        log.contains("Created calibrated output curve for chan 2"),
        "{log}"
    );
}
