//! A windowed presenter (feature `window`): one borderless fullscreen window per output
//! on its chosen monitor, each with a wgpu surface that shows the frame's exact codes.
//!
//! winit wants its event loop on one thread for the whole process, so
//! [`run_with_windows`] runs that loop on the calling thread and hands the service a
//! [`WindowPresenter`] on a thread of its own; each `present` travels to the loop and
//! back through an [`EventLoopProxy`] and a reply channel. winit allows one event loop
//! per process: call [`run_with_windows`] or [`list_monitors`] once.

mod gpu;

use std::str::FromStr;
use std::sync::Arc;
use std::sync::mpsc;
use std::thread::JoinHandle;

use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop, EventLoopProxy, OwnedDisplayHandle};
use winit::monitor::MonitorHandle;
use winit::window::{Fullscreen, Window, WindowId};

use crate::framebuffer::Framebuffer;

use super::{OutputSpec, Presenter};

use gpu::Screens;

/// Why windows could not be opened or kept open.
#[derive(Debug, thiserror::Error)]
pub enum WindowError {
    /// Neither an X11 nor a Wayland display is reachable.
    #[error("no X/Wayland display: set DISPLAY or use --headless")]
    NoDisplay,
    /// The window system refused to start or failed while running.
    #[error("the window system failed: {0}")]
    EventLoop(String),
    /// The outputs and monitors given do not fit together.
    #[error("window configuration: {0}")]
    Config(String),
    /// The chosen monitor does not exist.
    #[error("output {output}: there is no monitor {choice}; the monitors are: {available}")]
    NoMonitor {
        /// The output's name.
        output: String,
        /// The monitor asked for.
        choice: String,
        /// The monitors there are (`--list-outputs` shows them too).
        available: String,
    },
    /// The monitor's mode is not the output's size.
    #[error(
        "output {output} is {output_w}×{output_h} but monitor {monitor} shows {monitor_w}×{monitor_h}: \
         set the monitor's mode to {output_w}×{output_h} (xrandr, the desktop's display settings) \
         or correct the output's size"
    )]
    ModeMismatch {
        /// The output's name.
        output: String,
        /// The monitor's index and name.
        monitor: String,
        /// The monitor's width in pixels.
        monitor_w: u32,
        /// The monitor's height in pixels.
        monitor_h: u32,
        /// The output's width in pixels.
        output_w: u32,
        /// The output's height in pixels.
        output_h: u32,
    },
    /// A window could not be opened.
    #[error("output {output}: cannot open a window: {reason}")]
    Window {
        /// The output's name.
        output: String,
        /// The window system's reason.
        reason: String,
    },
    /// The GPU cannot present to the windows.
    #[error("GPU: {0}")]
    Gpu(String),
    /// A window was closed (or destroyed) while serving.
    #[error("the window of output {0} was closed; the pattern server stops")]
    Closed(String),
    /// The serving function failed.
    #[error("{0}")]
    Serve(String),
}

/// A monitor as the window system reports it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MonitorInfo {
    /// Its position in the window system's list ([`MonitorChoice::Index`]).
    pub index: usize,
    /// Its connector name (e.g. `DP-1`), or `monitor N` when it has none.
    pub name: String,
    /// Width of its current mode in pixels.
    pub width_px: u32,
    /// Height of its current mode in pixels.
    pub height_px: u32,
    /// Refresh rate of its current mode in millihertz, when known.
    pub refresh_mhz: Option<u32>,
}

impl std::fmt::Display for MonitorInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} {}×{}",
            self.index, self.name, self.width_px, self.height_px
        )?;
        match self.refresh_mhz {
            Some(mhz) => write!(f, " @ {:.3} Hz", f64::from(mhz) / 1e3),
            None => Ok(()),
        }
    }
}

/// Which monitor an output's window goes on.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MonitorChoice {
    /// The monitor at this index of [`list_monitors`].
    Index(usize),
    /// The monitor with this connector name (e.g. `DP-1`).
    Name(String),
}

impl FromStr for MonitorChoice {
    type Err = String;

    /// A number is an index, anything else a connector name.
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        if s.is_empty() {
            return Err("a monitor is an index (0, 1, …) or a connector name (DP-1)".into());
        }
        Ok(match s.parse::<usize>() {
            Ok(i) => MonitorChoice::Index(i),
            Err(_) => MonitorChoice::Name(s.to_string()),
        })
    }
}

impl std::fmt::Display for MonitorChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MonitorChoice::Index(i) => write!(f, "#{i}"),
            MonitorChoice::Name(n) => write!(f, "{n:?}"),
        }
    }
}

/// The monitors of the display (for `pattern-server --list-outputs`). Opens the
/// process's one winit event loop: do not call [`run_with_windows`] afterwards.
pub fn list_monitors() -> Result<Vec<MonitorInfo>, WindowError> {
    struct Lister(Option<Vec<MonitorInfo>>);
    impl ApplicationHandler<Request> for Lister {
        fn resumed(&mut self, event_loop: &ActiveEventLoop) {
            let all: Vec<MonitorHandle> = event_loop.available_monitors().collect();
            self.0 = Some(all.iter().enumerate().map(monitor_info).collect());
            event_loop.exit();
        }
        fn window_event(&mut self, _: &ActiveEventLoop, _: WindowId, _: WindowEvent) {}
    }
    let event_loop = build_event_loop()?;
    let mut lister = Lister(None);
    event_loop
        .run_app(&mut lister)
        .map_err(|e| WindowError::EventLoop(e.to_string()))?;
    lister
        .0
        .ok_or_else(|| WindowError::EventLoop("the event loop never started".into()))
}

/// The function that serves with the windows' presenter.
type ServeFn = Box<dyn FnOnce(Box<dyn Presenter>) -> Result<(), String> + Send + 'static>;

/// Opens one borderless fullscreen window per output (output `i` on `monitors[i]`;
/// with no monitors given, output `i` goes on monitor `i`), then calls `serve` on a new
/// thread with a [`WindowPresenter`] and runs the window event loop on this thread
/// until `serve` returns. Returns `serve`'s outcome, or why the windows failed (a
/// window closed, no display, a monitor whose mode is not the output's size, no GPU).
///
/// `serve` typically builds a tokio runtime and runs [`serve`](super::serve) with the
/// presenter until a signal. When a window closes or the window system fails, this
/// returns that error while `serve` may still run: end the process then.
///
/// Call it from the main thread (macOS and Windows require it; on Linux and the BSDs
/// any thread works), outside any async runtime, and once per process.
pub fn run_with_windows(
    outputs: &[OutputSpec],
    monitors: &[MonitorChoice],
    serve: impl FnOnce(Box<dyn Presenter>) -> Result<(), String> + Send + 'static,
) -> Result<(), WindowError> {
    let monitors = monitors_for(outputs, monitors)?;
    let event_loop = build_event_loop()?;
    let mut app = App {
        outputs: outputs.to_vec(),
        monitors,
        serve: Some(Box::new(serve)),
        proxy: event_loop.create_proxy(),
        display: event_loop.owned_display_handle(),
        screens: None,
        serving: None,
        outcome: None,
    };
    let ran = event_loop.run_app(&mut app);
    // Surfaces before windows, and both before the serving thread is joined.
    app.screens = None;
    let outcome = match ran {
        Err(e) => Err(WindowError::EventLoop(e.to_string())),
        Ok(()) => app.outcome.take().unwrap_or_else(|| {
            Err(WindowError::EventLoop(
                "the event loop ended before serving did".into(),
            ))
        }),
    };
    if outcome.is_ok()
        && let Some(t) = app.serving.take()
    {
        let _ = t.join();
    }
    outcome
}

/// One monitor choice per output: the ones given, or monitor `i` for output `i`.
fn monitors_for(
    outputs: &[OutputSpec],
    monitors: &[MonitorChoice],
) -> Result<Vec<MonitorChoice>, WindowError> {
    if outputs.is_empty() {
        return Err(WindowError::Config("no outputs to open windows for".into()));
    }
    if monitors.is_empty() {
        return Ok((0..outputs.len()).map(MonitorChoice::Index).collect());
    }
    if monitors.len() != outputs.len() {
        return Err(WindowError::Config(format!(
            "{} monitors given for {} outputs: give one monitor per output, in the outputs' order",
            monitors.len(),
            outputs.len()
        )));
    }
    for (i, m) in monitors.iter().enumerate() {
        if monitors[..i].contains(m) {
            return Err(WindowError::Config(format!(
                "monitor {m} is given for two outputs"
            )));
        }
    }
    Ok(monitors.to_vec())
}

/// Whether the environment names a display winit can open.
fn display_set(var: impl Fn(&str) -> Option<String>) -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"]
        .into_iter()
        .any(|k| var(k).is_some_and(|v| !v.is_empty()))
}

/// The process's winit event loop (any thread on Linux and the BSDs).
fn build_event_loop() -> Result<EventLoop<Request>, WindowError> {
    if cfg!(all(
        unix,
        not(target_vendor = "apple"),
        not(target_os = "android")
    )) && !display_set(|k| std::env::var(k).ok())
    {
        return Err(WindowError::NoDisplay);
    }
    let mut builder = EventLoop::<Request>::with_user_event();
    #[cfg(all(unix, not(target_vendor = "apple"), not(target_os = "android")))]
    {
        use winit::platform::x11::EventLoopBuilderExtX11;
        builder.with_any_thread(true);
    }
    builder.build().map_err(|e| match e {
        winit::error::EventLoopError::RecreationAttempt => WindowError::EventLoop(
            "winit allows one event loop per process: list_monitors or run_with_windows was \
             already called"
                .into(),
        ),
        e => WindowError::EventLoop(format!(
            "{e} (DISPLAY={:?}, WAYLAND_DISPLAY={:?}: is that display running and may this \
             user open it?)",
            std::env::var("DISPLAY").unwrap_or_default(),
            std::env::var("WAYLAND_DISPLAY").unwrap_or_default()
        )),
    })
}

/// What the serving thread asks of the event loop.
enum Request {
    /// Show these frames; the reply gives them back with the outcome.
    Present {
        frames: Vec<Framebuffer>,
        reply: mpsc::SyncSender<(Vec<Framebuffer>, Result<(), String>)>,
    },
    /// `serve` returned.
    ServeDone(Result<(), String>),
}

/// The service's presenter: forwards each `present` to the window event loop and
/// waits until the frames were drawn, queued for presentation with vsync (FIFO) and
/// the GPU finished; the flip itself happens at the display's next vertical blank,
/// within one refresh (the node's settle time covers it).
///
/// `read_back` gives the last frames presented as they were given to `present` (which
/// is what was drawn, code for code); it does not read the screen.
pub struct WindowPresenter {
    proxy: EventLoopProxy<Request>,
    last: Vec<Framebuffer>,
}

impl Presenter for WindowPresenter {
    fn present(&mut self, frames: Vec<Framebuffer>) -> Result<(), String> {
        let (reply, answer) = mpsc::sync_channel(1);
        self.proxy
            .send_event(Request::Present { frames, reply })
            .map_err(|_| "the window event loop has stopped".to_string())?;
        let (frames, outcome) = answer
            .recv()
            .map_err(|_| "the window event loop stopped before presenting".to_string())?;
        outcome?;
        self.last = frames;
        Ok(())
    }

    fn read_back(&self, index: usize) -> Option<Framebuffer> {
        self.last.get(index).cloned()
    }
}

/// The event loop's state.
struct App {
    outputs: Vec<OutputSpec>,
    monitors: Vec<MonitorChoice>,
    serve: Option<ServeFn>,
    proxy: EventLoopProxy<Request>,
    display: OwnedDisplayHandle,
    screens: Option<Screens>,
    serving: Option<JoinHandle<()>>,
    outcome: Option<Result<(), WindowError>>,
}

impl App {
    /// Ends the event loop with `outcome` (the first one set wins).
    fn finish(&mut self, event_loop: &ActiveEventLoop, outcome: Result<(), WindowError>) {
        if self.outcome.is_none() {
            self.outcome = Some(outcome);
        }
        event_loop.exit();
    }

    /// Opens the windows and their surfaces and shows black on each.
    fn open(&self, event_loop: &ActiveEventLoop) -> Result<Screens, WindowError> {
        let all: Vec<MonitorHandle> = event_loop.available_monitors().collect();
        let mut windows = Vec::with_capacity(self.outputs.len());
        for (output, choice) in self.outputs.iter().zip(&self.monitors) {
            let monitor = pick_monitor(&all, output, choice)?;
            windows.push((output.clone(), open_window(event_loop, output, &monitor)?));
        }
        let mut screens = Screens::new(self.display.clone(), windows)?;
        let black: Vec<Framebuffer> = self
            .outputs
            .iter()
            .map(|o| Framebuffer::black(o.width_px, o.height_px, o.surface_bit_depth))
            .collect();
        screens.present(&black).map_err(WindowError::Gpu)?;
        Ok(screens)
    }

    /// Starts `serve` on its own thread with a presenter that talks to this loop.
    fn start_serving(&mut self) -> Result<(), WindowError> {
        let Some(serve) = self.serve.take() else {
            return Ok(());
        };
        let presenter = WindowPresenter {
            proxy: self.proxy.clone(),
            last: self
                .outputs
                .iter()
                .map(|o| Framebuffer::black(o.width_px, o.height_px, o.surface_bit_depth))
                .collect(),
        };
        let proxy = self.proxy.clone();
        let thread = std::thread::Builder::new()
            .name("pattern-serve".into())
            .spawn(move || {
                let run = std::panic::AssertUnwindSafe(|| serve(Box::new(presenter)));
                let outcome = std::panic::catch_unwind(run)
                    .unwrap_or_else(|_| Err("the serving thread panicked".into()));
                let _ = proxy.send_event(Request::ServeDone(outcome));
            })
            .map_err(|e| WindowError::EventLoop(format!("cannot start serving: {e}")))?;
        self.serving = Some(thread);
        Ok(())
    }
}

impl ApplicationHandler<Request> for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.screens.is_some() || self.outcome.is_some() {
            return;
        }
        match self.open(event_loop) {
            Ok(screens) => {
                self.screens = Some(screens);
                if let Err(e) = self.start_serving() {
                    self.finish(event_loop, Err(e));
                }
            }
            Err(e) => self.finish(event_loop, Err(e)),
        }
    }

    fn user_event(&mut self, event_loop: &ActiveEventLoop, request: Request) {
        match request {
            Request::Present { frames, reply } => {
                let outcome = match &mut self.screens {
                    Some(s) => s.present(&frames),
                    None => Err("the windows are not open".into()),
                };
                let _ = reply.send((frames, outcome));
            }
            Request::ServeDone(outcome) => {
                self.finish(event_loop, outcome.map_err(WindowError::Serve));
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, id: WindowId, event: WindowEvent) {
        let Some(screens) = &mut self.screens else {
            return;
        };
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => {
                let name = screens.output_of(id).unwrap_or("?").to_string();
                self.finish(event_loop, Err(WindowError::Closed(name)));
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = screens.redraw(id) {
                    tracing::warn!("redrawing a pattern window failed: {e}");
                }
            }
            WindowEvent::Resized(size) => screens.resized(id, size),
            _ => {}
        }
    }
}

/// What [`list_monitors`] says of monitor `index`.
fn monitor_info((index, m): (usize, &MonitorHandle)) -> MonitorInfo {
    let size = m.size();
    MonitorInfo {
        index,
        name: m.name().unwrap_or_else(|| format!("monitor {index}")),
        width_px: size.width,
        height_px: size.height,
        refresh_mhz: m.refresh_rate_millihertz(),
    }
}

/// The monitor `choice` names for `output`, checked against the output's size.
fn pick_monitor(
    all: &[MonitorHandle],
    output: &OutputSpec,
    choice: &MonitorChoice,
) -> Result<MonitorHandle, WindowError> {
    let infos: Vec<MonitorInfo> = all.iter().enumerate().map(monitor_info).collect();
    let found = infos.iter().position(|m| match choice {
        MonitorChoice::Index(i) => m.index == *i,
        MonitorChoice::Name(n) => m.name == *n,
    });
    let (Some(i), Some(handle)) = (found, found.and_then(|i| all.get(i))) else {
        let available: Vec<String> = infos.iter().map(ToString::to_string).collect();
        return Err(WindowError::NoMonitor {
            output: output.name.clone(),
            choice: choice.to_string(),
            available: if available.is_empty() {
                "none (the window system reports no monitor)".into()
            } else {
                available.join("; ")
            },
        });
    };
    let m = &infos[i];
    if (m.width_px, m.height_px) != (output.width_px, output.height_px) {
        return Err(WindowError::ModeMismatch {
            output: output.name.clone(),
            monitor: format!("{} ({})", m.index, m.name),
            monitor_w: m.width_px,
            monitor_h: m.height_px,
            output_w: output.width_px,
            output_h: output.height_px,
        });
    }
    Ok(handle.clone())
}

/// A borderless fullscreen window of the output's size on `monitor`, cursor hidden.
fn open_window(
    event_loop: &ActiveEventLoop,
    output: &OutputSpec,
    monitor: &MonitorHandle,
) -> Result<Arc<Window>, WindowError> {
    let attributes = Window::default_attributes()
        .with_title(format!("lumiwall pattern {}", output.name))
        .with_inner_size(PhysicalSize::new(output.width_px, output.height_px))
        .with_position(monitor.position())
        .with_decorations(false)
        .with_resizable(false)
        .with_fullscreen(Some(Fullscreen::Borderless(Some(monitor.clone()))));
    let window = event_loop
        .create_window(attributes)
        .map_err(|e| WindowError::Window {
            output: output.name.clone(),
            reason: e.to_string(),
        })?;
    window.set_cursor_visible(false);
    Ok(Arc::new(window))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monitor_choices_parse_as_an_index_or_a_name() {
        assert_eq!("0".parse(), Ok(MonitorChoice::Index(0)));
        assert_eq!(" 2 ".parse(), Ok(MonitorChoice::Index(2)));
        assert_eq!("DP-1".parse(), Ok(MonitorChoice::Name("DP-1".into())));
        assert!("".parse::<MonitorChoice>().is_err());
    }

    #[test]
    fn monitors_default_to_one_per_output_and_must_match_the_outputs() {
        let o: OutputSpec = "a=320x240@8".parse().unwrap();
        let p: OutputSpec = "b=320x240@8".parse().unwrap();
        let two = [o.clone(), p];
        assert_eq!(
            monitors_for(&two, &[]).unwrap(),
            [MonitorChoice::Index(0), MonitorChoice::Index(1)]
        );
        let err = monitors_for(&two, &[MonitorChoice::Index(0)]).unwrap_err();
        assert!(
            err.to_string().contains("1 monitors given for 2 outputs"),
            "{err}"
        );
        let same = [MonitorChoice::Index(1), MonitorChoice::Index(1)];
        assert!(monitors_for(&two, &same).is_err());
        assert!(monitors_for(&[], &[]).is_err());
    }

    #[test]
    fn no_display_is_told_before_winit_is_asked() {
        assert!(!display_set(|_| None));
        assert!(!display_set(|_| Some(String::new())));
        assert!(display_set(|k| (k == "DISPLAY").then(|| ":0".into())));
        assert!(display_set(
            |k| (k == "WAYLAND_DISPLAY").then(|| "wayland-0".into())
        ));
        assert_eq!(
            WindowError::NoDisplay.to_string(),
            "no X/Wayland display: set DISPLAY or use --headless"
        );
    }
}
