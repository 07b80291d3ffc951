//! The station app's runs: each action is a `lumiwall` command line, parsed by the
//! command line's own parser and run by the same function the command runs, on a
//! worker thread that reports progress to the window.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};

use clap::Parser;
use lumiwall_calib::measure::Progress;
use lumiwall_calib::station::{StopFlag, TechnicianLink};

use crate::cmd_commission::CommissionStep;
use crate::cmd_recalibrate::Recalibrated;
use crate::{Cli, Command};

/// What a run tells the window.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum JobEvent {
    /// Fraction done (0..=1) and what is being measured.
    Progress {
        /// Fraction done.
        fraction: f32,
        /// Readings so far.
        readings: u64,
    },
    /// A line for the run log.
    Line(String),
    /// The run ended: a summary, or what failed.
    Finished(Result<String, String>),
}

/// A run in progress.
pub(crate) struct Job {
    /// The command line it runs (shown, and what a technician types for the same).
    pub(crate) argv: Vec<String>,
    events: Receiver<JobEvent>,
    stop: StopFlag,
    /// Latest progress.
    pub(crate) fraction: f32,
    /// Readings so far.
    pub(crate) readings: u64,
    /// Set once the run has ended.
    pub(crate) finished: Option<Result<String, String>>,
    /// Guided aiming: the technician's answers go to the run, its prompts come back.
    aiming: Aiming,
}

/// The window's side of guided aiming ([`TechnicianLink`]): the answers the buttons
/// give, as lines a technician would type, and the prompt and live readings since the
/// last answer.
struct Aiming {
    answers: Sender<String>,
    prompt: Arc<Mutex<Vec<String>>>,
}

/// The run's side of the answers: lines from the window; the end (the window gone)
/// reads as the end of the input, which guided aiming takes as stop.
struct Answers {
    lines: Receiver<String>,
    pending: Vec<u8>,
}

impl Read for Answers {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.pending.is_empty() {
            match self.lines.recv() {
                Ok(line) => self.pending = format!("{line}\n").into_bytes(),
                Err(_) => return Ok(0),
            }
        }
        let n = buf.len().min(self.pending.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }
}

/// The run's side of the prompts: whole lines into the window's prompt, which is
/// repainted.
struct Prompts {
    prompt: Arc<Mutex<Vec<String>>>,
    partial: String,
    wake: Arc<dyn Fn() + Send + Sync>,
}

impl Write for Prompts {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.partial.push_str(&String::from_utf8_lossy(buf));
        while let Some(end) = self.partial.find('\n') {
            let line: String = self.partial.drain(..=end).collect();
            if let Ok(mut p) = self.prompt.lock() {
                p.push(line.trim_end().to_string());
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        (self.wake)();
        Ok(())
    }
}

impl Aiming {
    /// Both sides: the window's, and the link the run's station takes.
    fn new(wake: Arc<dyn Fn() + Send + Sync>) -> (Self, TechnicianLink) {
        let (answers, lines) = channel();
        let prompt = Arc::new(Mutex::new(Vec::new()));
        let link = TechnicianLink::new(
            Box::new(std::io::BufReader::new(Answers {
                lines,
                pending: Vec::new(),
            })),
            Box::new(Prompts {
                prompt: prompt.clone(),
                partial: String::new(),
                wake,
            }),
        );
        (Self { answers, prompt }, link)
    }
}

/// What the technician answers to an aiming prompt.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum AimAnswer {
    /// The meter is on the cross.
    Aimed,
    /// Read again (the live reading).
    ReadAgain,
    /// Skip this display (`--resume` measures it later).
    Skip,
    /// Stop the run (`--resume` continues here).
    Stop,
}

impl AimAnswer {
    /// The line a technician types at the terminal for it.
    fn typed(self) -> &'static str {
        match self {
            Self::Aimed => "",
            Self::ReadAgain => "r",
            Self::Skip => "s",
            Self::Stop => "q",
        }
    }
}

impl Job {
    /// Starts `argv` (a `lumiwall` command line) on a worker thread; `wake` is called
    /// after every event (the window repaints).
    pub(crate) fn start(argv: Vec<String>, wake: impl Fn() + Send + Sync + 'static) -> Self {
        let (tx, rx) = channel();
        let stop: StopFlag = Arc::new(AtomicBool::new(false));
        let wake: Arc<dyn Fn() + Send + Sync> = Arc::new(wake);
        let (aiming, link) = Aiming::new(wake.clone());
        let (args, flag) = (argv.clone(), stop.clone());
        std::thread::spawn(move || {
            let send = |e: JobEvent| {
                // the window may be gone: nothing is left to tell
                let _ = tx.send(e);
                wake();
            };
            let result = run_command(&args, flag, link, &send);
            send(JobEvent::Finished(result));
        });
        Self {
            argv,
            events: rx,
            stop,
            fraction: 0.0,
            readings: 0,
            finished: None,
            aiming,
        }
    }

    /// Asks the run to stop before its next pattern (what was measured is kept); a
    /// run waiting at an aiming prompt is answered "stop".
    pub(crate) fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
        if !self.aim_prompt().is_empty() {
            self.answer(AimAnswer::Stop);
        }
    }

    /// The aiming prompt the run waits at, with its live readings (empty: none).
    pub(crate) fn aim_prompt(&self) -> Vec<String> {
        if self.finished.is_some() {
            return Vec::new();
        }
        self.aiming.prompt.lock().map_or(Vec::new(), |p| p.clone())
    }

    /// Answers the aiming prompt.
    pub(crate) fn answer(&self, a: AimAnswer) {
        if let Ok(mut p) = self.aiming.prompt.lock() {
            p.clear();
        }
        // a run that has ended reads no more answers
        let _ = self.aiming.answers.send(a.typed().to_string());
    }

    /// Whether a stop was asked for.
    pub(crate) fn stopping(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Takes the events that arrived; returns the log lines among them.
    pub(crate) fn poll(&mut self) -> Vec<String> {
        let mut lines = Vec::new();
        loop {
            let e = match self.events.try_recv() {
                Ok(e) => e,
                Err(std::sync::mpsc::TryRecvError::Empty) => break,
                Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                    // the worker is gone without a word (it panicked): say so, free the buttons
                    if self.finished.is_none() {
                        self.finished = Some(Err("the run ended without a result".into()));
                    }
                    break;
                }
            };
            match e {
                JobEvent::Progress { fraction, readings } => {
                    self.fraction = fraction;
                    self.readings = readings;
                }
                JobEvent::Line(l) => lines.push(l),
                JobEvent::Finished(r) => {
                    if r.is_ok() {
                        self.fraction = 1.0;
                    }
                    self.finished = Some(r);
                }
            }
        }
        lines
    }
}

/// Counts readings and finished displays into progress events.
struct Counter<'a> {
    send: &'a dyn Fn(JobEvent),
    readings: u64,
    displays_done: u64,
}

impl Counter<'_> {
    fn on(&mut self, p: &Progress, displays: u64, readings_total: Option<u64>) {
        match p {
            Progress::Reading { .. } => self.readings += 1,
            Progress::DisplayDone { display, readings } => {
                self.displays_done += 1;
                (self.send)(JobEvent::Line(format!("{display}: {readings} readings")));
            }
            Progress::Resumed { display, .. } => {
                self.displays_done += 1;
                (self.send)(JobEvent::Line(format!(
                    "{display}: kept from the stopped run"
                )));
            }
            Progress::WarmCheck(r) => (self.send)(JobEvent::Line(r.summary())),
            Progress::WarmedUp(r) => (self.send)(JobEvent::Line(r.summary())),
            Progress::Averaging(c) => (self.send)(JobEvent::Line(c.summary())),
            _ => {}
        }
        let fraction = match readings_total {
            Some(t) if t > 0 => self.readings as f32 / t as f32,
            _ => self.displays_done as f32 / displays.max(1) as f32,
        };
        (self.send)(JobEvent::Progress {
            fraction: fraction.min(1.0),
            readings: self.readings,
        });
    }
}

/// Parses `argv` with the command line's parser and runs it as the command does.
fn run_command(
    argv: &[String],
    stop: StopFlag,
    technician: TechnicianLink,
    send: &dyn Fn(JobEvent),
) -> Result<String, String> {
    let cli = Cli::try_parse_from(argv).map_err(|e| e.to_string())?;
    let mut count = Counter {
        send,
        readings: 0,
        displays_done: 0,
    };
    match cli.command {
        Command::Commission(mut a) => {
            a.meter.stop = Some(stop);
            a.meter.technician = Some(technician);
            let mut displays = 1;
            let (_, outcome) = crate::cmd_commission::commission_with(&a, &mut |step| match step {
                CommissionStep::Started { displays: d, .. } => displays = d.len() as u64,
                CommissionStep::Progress(p) => count.on(&p, displays, None),
            })
            .map_err(|e| e.to_string())?;
            Ok(format!(
                "commissioned {}: {} displays, common white {:.2} cd/m²",
                outcome.wall,
                outcome.measured.len(),
                outcome
                    .solution
                    .profiles
                    .first()
                    .map_or(0.0, |p| p.target_white_xyz_cd_m2[1])
            ))
        }
        Command::Verify(mut a) => {
            a.meter.stop = Some(stop);
            a.meter.technician = Some(technician);
            let v =
                crate::cmd_verify::verify_with(&a, &mut |p, total| count.on(&p, 0, Some(total)))
                    .map_err(|e| e.to_string())?;
            let o = &v.report.overall;
            Ok(format!(
                "verified: median ΔE2000 {:.2}, max {:.2} over {} patches",
                o.median_de, o.max_de, o.patches
            ))
        }
        Command::Recalibrate(mut a) => {
            a.meter.stop = Some(stop);
            a.meter.technician = Some(technician);
            recalibrate(&a, &mut count, send)
        }
        _ => Err(format!(
            "the station app runs commission, verify and recalibrate, not {}",
            argv.get(1).map_or("", String::as_str)
        )),
    }
}

/// `lumiwall recalibrate` in the app: the display and camera lines as the job's lines,
/// the summary as its result.
fn recalibrate(
    a: &crate::cmd_recalibrate::RecalibrateArgs,
    count: &mut Counter<'_>,
    send: &dyn Fn(JobEvent),
) -> Result<String, String> {
    let displays =
        lumiwall_profiles::ProfileSet::load_dir(&a.profiles).map_or(1, |(_, p)| p.len() as u64);
    let done = crate::cmd_recalibrate::recalibrate_with(a, &mut |p| {
        count.on(&p, displays, None);
    })
    .map_err(|e| e.to_string())?;
    match done {
        Recalibrated::Done {
            outcome,
            recorded,
            camera,
        } => {
            for line in crate::cmd_recalibrate::display_lines(&outcome).lines() {
                send(JobEvent::Line(line.to_string()));
            }
            for line in camera.iter().flat_map(|c| &c.lines) {
                send(JobEvent::Line(line.clone()));
            }
            match recorded {
                Some(Ok(line)) => send(JobEvent::Line(line)),
                Some(Err(e)) => send(JobEvent::Line(format!("WARNING: not recorded: {e}"))),
                None => {}
            }
            Ok(crate::cmd_recalibrate::summary(
                &outcome,
                count.readings as u32,
                camera.as_ref().map(|c| c.frames),
            ))
        }
        Recalibrated::DeviceFailed { wall, error } => {
            Err(format!("recalibrate {wall}: DEVICE FAILED: {error}"))
        }
        Recalibrated::WallNotReady { wall, error } => Err(format!(
            "recalibrate {wall}: WALL NOT READY: {error}; no profile was written"
        )),
    }
}
