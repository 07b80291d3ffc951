//! The windowed presenter on a virtual X server: Xvfb (Debian package `xvfb`), Mesa's
//! lavapipe for Vulkan (`mesa-vulkan-drivers`), and `xwd` (`x11-apps`) for screenshots
//! of the root window, whose every pixel must equal the codes presented.
//!
//! winit allows one event loop per process, so each case runs in a child process of
//! this test binary (the `child_case` test, idle unless `LUMIWALL_WINDOW_CASE` is set)
//! with its own Xvfb. Without Xvfb or xwd the tests print a skip line and pass, unless
//! `LUMIWALL_REQUIRE_XVFB=1`, where they fail.
#![cfg(feature = "window")]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use lumiwall_pattern::server::window::{
    MonitorChoice, WindowError, list_monitors, run_with_windows,
};
use lumiwall_pattern::server::{OutputSpec, Presenter};
use lumiwall_pattern::{Framebuffer, max_code, requantise};

const WIDTH: u32 = 320;
const HEIGHT: u32 = 240;
const CASE_VAR: &str = "LUMIWALL_WINDOW_CASE";

/// A running Xvfb; stopped when dropped.
struct Xvfb {
    child: Child,
    display: String,
    /// Its stdout, kept open so that a late message does not kill it (SIGPIPE).
    _stdout: Option<std::io::BufReader<std::process::ChildStdout>>,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // SIGTERM lets Xvfb remove its lock file and socket; SIGKILL if it does not stop.
        let _ = Command::new("kill")
            .arg(self.child.id().to_string())
            .status();
        for _ in 0..100 {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Where `tool` is on PATH.
fn on_path(tool: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join(tool))
        .find(|p| p.is_file())
}

/// Whether the tools are there; otherwise prints a skip line (or fails when
/// `LUMIWALL_REQUIRE_XVFB=1`).
fn tools_or_skip(test: &str) -> bool {
    for (tool, package) in [("Xvfb", "xvfb"), ("xwd", "x11-apps")] {
        if on_path(tool).is_none() {
            let why = format!("{tool} is not installed (Debian package {package})");
            if std::env::var("LUMIWALL_REQUIRE_XVFB").as_deref() == Ok("1") {
                panic!("LUMIWALL_REQUIRE_XVFB=1 but {why}");
            }
            println!("SKIP {test}: {why}");
            return false;
        }
    }
    true
}

/// Starts Xvfb at `depth` bits on a display number it picks itself (`-displayfd`, no
/// race between tests) and waits until it accepts connections.
fn start_xvfb(depth: u32) -> Xvfb {
    let mut child = Command::new("Xvfb")
        .args(["-displayfd", "1"])
        .args(["-screen", "0", &format!("{WIDTH}x{HEIGHT}x{depth}")])
        .args(["-nolisten", "tcp"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("Xvfb cannot be started");
    let mut line = String::new();
    let mut stdout = child.stdout.take().map(std::io::BufReader::new);
    if let Some(out) = &mut stdout {
        let _ = std::io::BufRead::read_line(out, &mut line);
    }
    let x = Xvfb {
        child,
        display: format!(":{}", line.trim()),
        _stdout: stdout,
    };
    assert!(
        line.trim().parse::<u32>().is_ok(),
        "Xvfb did not report a display number (it wrote {line:?})"
    );
    x
}

/// Runs `case` in a child process of this test binary on a fresh Xvfb of `depth` bits;
/// passes its output on and fails when it fails.
fn in_child(test: &str, case: &str, depth: u32) {
    if !tools_or_skip(test) {
        return;
    }
    let x = start_xvfb(depth);
    let runtime = tempfile::tempdir().expect("a temporary XDG_RUNTIME_DIR");
    let out = Command::new(std::env::current_exe().expect("the test binary"))
        .args(["--exact", "child_case", "--nocapture", "--test-threads=1"])
        .env(CASE_VAR, case)
        .env("DISPLAY", &x.display)
        .env("XDG_RUNTIME_DIR", runtime.path())
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .expect("the test binary runs again");
    let lines = |b: &[u8]| {
        String::from_utf8_lossy(b)
            .lines()
            .map(|l| l.trim_start_matches("test child_case ... "))
            .filter(|l| !l.is_empty() && *l != "ok" && !l.starts_with("running "))
            .filter(|l| !l.starts_with("test result:"))
            .map(|l| format!("  [{case} on Xvfb {} depth {depth}] {l}", x.display))
            .collect::<Vec<_>>()
            .join("\n")
    };
    println!("{}\n{}", lines(&out.stdout), lines(&out.stderr));
    assert!(out.status.success(), "case {case} failed ({})", out.status);
}

/// An RGB screenshot, `bits` per channel (8 on a 24-bit screen, 10 on a 30-bit one).
struct Shot {
    width: u32,
    height: u32,
    bits: u32,
    pixels: Vec<[u16; 3]>,
}

/// The root window of `$DISPLAY`, through `xwd -root -silent`.
fn screenshot() -> Result<Shot, String> {
    let out = Command::new("xwd")
        .args(["-root", "-silent"])
        .output()
        .map_err(|e| format!("xwd: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "xwd failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    parse_xwd(&out.stdout)
}

/// Decodes an XWD file (version 7, ZPixmap, 32 bits per pixel, TrueColor masks).
fn parse_xwd(b: &[u8]) -> Result<Shot, String> {
    let field = |i: usize| -> Result<u32, String> {
        let s = b.get(i * 4..i * 4 + 4).ok_or("XWD header cut short")?;
        Ok(u32::from_be_bytes([s[0], s[1], s[2], s[3]]))
    };
    let (header_size, version, format) = (field(0)?, field(1)?, field(2)?);
    let (width, height, byte_order) = (field(4)?, field(5)?, field(7)?);
    let (bpp, line) = (field(11)?, field(12)? as usize);
    if version != 7 || format != 2 || bpp != 32 {
        return Err(format!(
            "XWD version {version}, format {format}, {bpp} bit per pixel; expected 7, 2 (ZPixmap), 32"
        ));
    }
    let masks = [field(14)?, field(15)?, field(16)?];
    let start = header_size as usize + field(19)? as usize * 12;
    let mut pixels = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height as usize {
        for x in 0..width as usize {
            let at = start + y * line + x * 4;
            let raw: [u8; 4] = b
                .get(at..at + 4)
                .and_then(|r| r.try_into().ok())
                .ok_or("XWD pixels cut short")?;
            let px = match byte_order {
                0 => u32::from_le_bytes(raw),
                _ => u32::from_be_bytes(raw),
            };
            pixels.push(masks.map(|m| ((px & m) >> m.trailing_zeros()) as u16));
        }
    }
    Ok(Shot {
        width,
        height,
        bits: masks[0].count_ones(),
        pixels,
    })
}

/// Whether every pixel of `shot` is what `frame` asks, or what differs.
fn check(shot: &Shot, frame: &Framebuffer) -> Result<(), String> {
    if (shot.width, shot.height, shot.bits) != (frame.width, frame.height, frame.bits) {
        return Err(format!(
            "the screen is {}×{} at {} bit, the frame {}×{} at {} bit",
            shot.width, shot.height, shot.bits, frame.width, frame.height, frame.bits
        ));
    }
    let wrong: Vec<usize> = (0..shot.pixels.len())
        .filter(|&i| shot.pixels[i] != frame.codes[i])
        .collect();
    match wrong.first() {
        None => Ok(()),
        Some(&i) => Err(format!(
            "{} of {} pixels differ; the first, at ({}, {}), is {:?} instead of {:?}",
            wrong.len(),
            shot.pixels.len(),
            i % frame.width as usize,
            i / frame.width as usize,
            shot.pixels[i],
            frame.codes[i]
        )),
    }
}

/// Screenshots until the screen shows `frame` (at most 2 s), and how many it took.
fn wait_for(frame: &Framebuffer) -> Result<(Shot, u32), String> {
    let mut last = String::new();
    for shots in 1..=40 {
        let shot = screenshot()?;
        match check(&shot, frame) {
            Ok(()) => return Ok((shot, shots)),
            Err(e) => last = e,
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Err(format!("after 2 s of screenshots: {last}"))
}

/// Writes `shot` as an 8-bit PNG (to look at).
fn save_png(shot: &Shot, path: &Path) -> Result<(), String> {
    let shift = shot.bits.saturating_sub(8);
    let data: Vec<u8> = shot
        .pixels
        .iter()
        .flatten()
        .map(|v| (v >> shift) as u8)
        .collect();
    image::RgbImage::from_raw(shot.width, shot.height, data)
        .ok_or("screenshot size and pixels differ")?
        .save(path)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// A frame whose every pixel differs from its neighbours (orientation, offsets).
fn gradient(bits: u32) -> Framebuffer {
    let top = max_code(bits);
    let mut f = Framebuffer::black(WIDTH, HEIGHT, bits);
    for (i, c) in f.codes.iter_mut().enumerate() {
        let (x, y) = (i as u32 % WIDTH, i as u32 / WIDTH);
        *c = [x * 3, y * 5, x + 2 * y].map(|v| (v % (top + 1)) as u16);
    }
    f
}

/// `frame` as an 8-bit screen shows it (each code rounded to the nearest 8-bit code).
fn on_8_bit(frame: &Framebuffer) -> Framebuffer {
    Framebuffer {
        bits: 8,
        codes: frame
            .codes
            .iter()
            .map(|c| c.map(|v| requantise(u32::from(v), frame.bits, 8)))
            .collect(),
        ..frame.clone()
    }
}

/// Presents each frame and checks the screen (of `screen_bits`) shows exactly its codes.
fn present_and_look(
    p: &mut dyn Presenter,
    name: &str,
    screen_bits: u32,
    frames: Vec<Framebuffer>,
) -> Result<(), String> {
    for (i, frame) in frames.into_iter().enumerate() {
        let what = match frame.uniform_code() {
            Some(c) => format!("uniform {c:?}"),
            None => "gradient".to_string(),
        };
        let started = Instant::now();
        p.present(vec![frame.clone()])?;
        let took = started.elapsed();
        let seen = if screen_bits == 8 {
            on_8_bit(&frame)
        } else {
            frame.clone()
        };
        let (shot, shots) = wait_for(&seen)?;
        let png = std::env::temp_dir().join(format!("lumiwall-window-{name}-{i}.png"));
        save_png(&shot, &png)?;
        println!(
            "present {what} at {} bit: returned after {:.1} ms; all {} pixels of the {}-bit \
             root window equal the codes{} (screenshot {shots}, {})",
            frame.bits,
            took.as_secs_f64() * 1e3,
            shot.pixels.len(),
            shot.bits,
            if frame.bits > shot.bits {
                " rounded to 8 bit"
            } else {
                ""
            },
            png.display()
        );
        if p.read_back(0).as_ref() != Some(&frame) {
            return Err("read_back does not give the frame presented".into());
        }
    }
    Ok(())
}

/// One output at `bits` on monitor 0 of an 8-bit screen, showing `frames`.
fn show(name: &'static str, bits: u32, frames: Vec<Framebuffer>) -> Result<(), WindowError> {
    let output: OutputSpec = format!("xvfb-0={WIDTH}x{HEIGHT}@{bits}").parse().unwrap();
    run_with_windows(&[output], &[MonitorChoice::Index(0)], move |mut p| {
        present_and_look(p.as_mut(), name, 8, frames)
    })
}

/// The case `LUMIWALL_WINDOW_CASE` names, in this child process.
fn run_case(case: &str) -> Result<(), String> {
    let uniform = |bits, code| Framebuffer::uniform(WIDTH, HEIGHT, bits, code);
    match case {
        "codes8" => show(
            "codes8",
            8,
            vec![
                uniform(8, [200, 100, 50]),
                uniform(8, [10, 250, 128]),
                gradient(8),
            ],
        )
        .map_err(|e| e.to_string()),
        "codes10" => show(
            "codes10",
            10,
            vec![uniform(10, [801, 402, 203]), gradient(10)],
        )
        .map_err(|e| e.to_string()),
        "monitors" => {
            let all = list_monitors().map_err(|e| e.to_string())?;
            println!("list_monitors: {all:?}");
            match all.as_slice() {
                [m] if (m.index, m.width_px, m.height_px) == (0, WIDTH, HEIGHT) => Ok(()),
                _ => Err(format!(
                    "expected one {WIDTH}×{HEIGHT} monitor, got {all:?}"
                )),
            }
        }
        "mismatch" => {
            let big: OutputSpec = "big=640x480@8".parse().unwrap();
            match run_with_windows(&[big], &[], |_| Ok(())) {
                Err(e @ WindowError::ModeMismatch { .. }) => {
                    println!("refused: {e}");
                    let text = e.to_string();
                    let ok = text.contains("640×480") && text.contains("320×240");
                    ok.then_some(()).ok_or(text)
                }
                other => Err(format!("expected a mode mismatch, got {other:?}")),
            }
        }
        "missing" => {
            let o: OutputSpec = format!("xvfb-0={WIDTH}x{HEIGHT}@8").parse().unwrap();
            match run_with_windows(&[o], &["DP-7".parse().unwrap()], |_| Ok(())) {
                Err(e @ WindowError::NoMonitor { .. }) => {
                    println!("refused: {e}");
                    Ok(())
                }
                other => Err(format!("expected no such monitor, got {other:?}")),
            }
        }
        _ => Err(format!("unknown case {case:?}")),
    }
}

/// Not a test of its own: runs the case a parent test asked for in this process.
#[test]
fn child_case() {
    let Ok(case) = std::env::var(CASE_VAR) else {
        return;
    };
    let _ = tracing_subscriber::fmt()
        .with_env_filter("info")
        .with_ansi(false)
        .with_writer(std::io::stderr)
        .try_init();
    if let Err(e) = run_case(&case) {
        panic!("{e}");
    }
}

#[test]
fn an_8_bit_output_shows_exactly_its_codes() {
    in_child("an_8_bit_output_shows_exactly_its_codes", "codes8", 24);
}

#[test]
fn a_10_bit_output_on_an_8_bit_screen_shows_its_codes_rounded_to_8_bit() {
    in_child(
        "a_10_bit_output_on_an_8_bit_screen_shows_its_codes_rounded_to_8_bit",
        "codes10",
        24,
    );
}

#[test]
fn the_monitors_are_listed() {
    in_child("the_monitors_are_listed", "monitors", 24);
}

#[test]
fn a_monitor_of_another_size_is_refused() {
    in_child("a_monitor_of_another_size_is_refused", "mismatch", 24);
}

#[test]
fn a_missing_monitor_is_refused_with_the_monitors_there_are() {
    in_child(
        "a_missing_monitor_is_refused_with_the_monitors_there_are",
        "missing",
        24,
    );
}
