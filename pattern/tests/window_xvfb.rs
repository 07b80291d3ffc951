//! The windowed presenter on a virtual X server: Xvfb (package `xvfb`) at 320×240×24,
//! Mesa's lavapipe for Vulkan (`mesa-vulkan-drivers`), and `xwd` (`x11-apps`) for
//! screenshots of the root window, whose every pixel must equal the codes presented.
//!
//! Without Xvfb or xwd the test prints a skip line and passes, unless
//! `LUMIWALL_REQUIRE_XVFB=1`, where it fails.
#![cfg(feature = "window")]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use lumiwall_pattern::Framebuffer;
use lumiwall_pattern::server::OutputSpec;
use lumiwall_pattern::server::window::{MonitorChoice, run_with_windows};

const WIDTH: u32 = 320;
const HEIGHT: u32 = 240;

/// A running Xvfb; killed when dropped.
struct Xvfb {
    child: Child,
    display: String,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
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

/// The tools this test needs, or why it cannot run.
fn tools() -> Result<(), String> {
    for (tool, package) in [("Xvfb", "xvfb"), ("xwd", "x11-apps")] {
        if on_path(tool).is_none() {
            return Err(format!("{tool} is not installed (Debian package {package})"));
        }
    }
    Ok(())
}

/// Starts Xvfb on the first free display from :99 and waits for its socket.
fn start_xvfb() -> Xvfb {
    for n in 99..200 {
        let lock = format!("/tmp/.X{n}-lock");
        let socket = format!("/tmp/.X11-unix/X{n}");
        if Path::new(&lock).exists() || Path::new(&socket).exists() {
            continue;
        }
        let child = Command::new("Xvfb")
            .arg(format!(":{n}"))
            .args(["-screen", "0", &format!("{WIDTH}x{HEIGHT}x24")])
            .args(["-nolisten", "tcp"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb cannot be started");
        let mut x = Xvfb {
            child,
            display: format!(":{n}"),
        };
        let started = Instant::now();
        while started.elapsed() < Duration::from_secs(10) {
            if Path::new(&socket).exists() {
                return x;
            }
            if let Ok(Some(_)) = x.child.try_wait() {
                break; // another server took the number meanwhile
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    panic!("no free X display number from :99 to :199 (or Xvfb does not start)");
}

/// An RGB screenshot.
struct Shot {
    width: u32,
    height: u32,
    pixels: Vec<[u8; 3]>,
}

/// The root window of `display`, through `xwd -root -silent`.
fn screenshot(display: &str) -> Result<Shot, String> {
    let out = Command::new("xwd")
        .args(["-root", "-silent", "-display", display])
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

/// Decodes an XWD file (version 7, ZPixmap, 24 or 32 bits per pixel, TrueColor).
fn parse_xwd(b: &[u8]) -> Result<Shot, String> {
    let field = |i: usize| -> Result<u32, String> {
        let s = b.get(i * 4..i * 4 + 4).ok_or("XWD header cut short")?;
        Ok(u32::from_be_bytes([s[0], s[1], s[2], s[3]]))
    };
    let (header_size, version, format) = (field(0)?, field(1)?, field(2)?);
    if version != 7 || format != 2 {
        return Err(format!("XWD version {version} format {format}, expected 7 and 2 (ZPixmap)"));
    }
    let (width, height, byte_order) = (field(4)?, field(5)?, field(7)?);
    let (bpp, line) = (field(11)?, field(12)? as usize);
    let masks = [field(14)?, field(15)?, field(16)?];
    let ncolors = field(19)? as usize;
    let start = header_size as usize + ncolors * 12;
    let step = match bpp {
        32 => 4,
        24 => 3,
        _ => return Err(format!("XWD with {bpp} bits per pixel")),
    };
    let mut pixels = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height as usize {
        for x in 0..width as usize {
            let at = start + y * line + x * step;
            let raw = b.get(at..at + step).ok_or("XWD pixels cut short")?;
            let mut v = [0u8; 4];
            v[..step].copy_from_slice(raw);
            let px = if byte_order == 0 {
                u32::from_le_bytes(v)
            } else {
                u32::from_be_bytes(v) >> (8 * (4 - step))
            };
            pixels.push(masks.map(|m| ((px & m) >> m.trailing_zeros()) as u8));
        }
    }
    Ok(Shot {
        width,
        height,
        pixels,
    })
}

/// Whether every pixel of `shot` is `code`, or what differs.
fn check(shot: &Shot, code: [u16; 3]) -> Result<(), String> {
    if (shot.width, shot.height) != (WIDTH, HEIGHT) {
        return Err(format!("the screenshot is {}×{}", shot.width, shot.height));
    }
    let want = code.map(|c| c as u8);
    let wrong: Vec<usize> = (0..shot.pixels.len())
        .filter(|&i| shot.pixels[i] != want)
        .collect();
    match wrong.first() {
        None => Ok(()),
        Some(&i) => Err(format!(
            "{} of {} pixels differ from {want:?}; the first, at ({}, {}), is {:?}",
            wrong.len(),
            shot.pixels.len(),
            i % WIDTH as usize,
            i / WIDTH as usize,
            shot.pixels[i]
        )),
    }
}

/// Screenshots until the screen shows `code` (at most 2 s), and how many it took.
fn wait_for(display: &str, code: [u16; 3]) -> Result<(Shot, u32), String> {
    let mut last = Err(String::new());
    for shots in 1..=40 {
        let shot = screenshot(display)?;
        last = check(&shot, code);
        if last.is_ok() {
            return Ok((shot, shots));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Err(format!("after 2 s of screenshots: {}", last.err().unwrap_or_default()))
}

/// Writes `shot` as an 8-bit PNG.
fn save_png(shot: &Shot, path: &Path) -> Result<(), String> {
    let data: Vec<u8> = shot.pixels.iter().flatten().copied().collect();
    image::RgbImage::from_raw(shot.width, shot.height, data)
        .ok_or("screenshot size and pixels differ")?
        .save(path)
        .map_err(|e| format!("{}: {e}", path.display()))
}

#[test]
fn the_window_shows_exactly_the_codes_presented() {
    if let Err(why) = tools() {
        if std::env::var("LUMIWALL_REQUIRE_XVFB").as_deref() == Ok("1") {
            panic!("LUMIWALL_REQUIRE_XVFB=1 but {why}");
        }
        println!("SKIP the_window_shows_exactly_the_codes_presented: {why}");
        return;
    }
    let x = start_xvfb();
    // SAFETY: this test binary has this one test; nothing else reads the environment
    // while it is changed.
    unsafe {
        std::env::set_var("DISPLAY", &x.display);
        std::env::remove_var("WAYLAND_DISPLAY");
        std::env::remove_var("WAYLAND_SOCKET");
    }
    let output: OutputSpec = format!("xvfb-0={WIDTH}x{HEIGHT}@8").parse().unwrap();
    let display = x.display.clone();
    let outcome = run_with_windows(&[output], &[MonitorChoice::Index(0)], move |mut p| {
        for (i, code) in [[200, 100, 50], [10, 250, 128]].into_iter().enumerate() {
            let started = Instant::now();
            p.present(vec![Framebuffer::uniform(WIDTH, HEIGHT, 8, code)])?;
            let took = started.elapsed();
            let (shot, shots) = wait_for(&display, code)?;
            let png = std::env::temp_dir().join(format!("lumiwall-window-xvfb-{i}.png"));
            save_png(&shot, &png)?;
            println!(
                "present {code:?}: returned after {:.1} ms; every pixel of the root window is \
                 {code:?} (screenshot {shots}, {})",
                took.as_secs_f64() * 1e3,
                png.display()
            );
            let back = p.read_back(0).and_then(|f| f.uniform_code());
            if back != Some(code) {
                return Err(format!("read_back gives {back:?}"));
            }
        }
        Ok(())
    });
    if let Err(e) = outcome {
        panic!("{e}");
    }
}
