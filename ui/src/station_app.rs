//! `lumiwall station`: the station app for the technician (egui/eframe).
//!
//! A wall map with every tile and eye coloured by its last verification, reserve or
//! drift; commission, verify and recalibrate with live progress, stop and resume; the
//! gamut plot and channel usage; drift charts and the lamp-life forecast from the
//! store; the report. Every action is a `lumiwall` command line, shown in the window,
//! parsed by the command line's parser and run by the same function the command runs
//! ([`jobs`]); what is shown is read from the files those commands write ([`data`]).
//! Against the virtual wall by default.

mod data;
mod jobs;
#[cfg(test)]
mod tests;
mod views;

use std::path::PathBuf;

use eframe::egui;

use lumiwall_calib::station::MeterChoice;
use lumiwall_profiles::DisplayKey;

use crate::CliError;
use crate::cmd_commission::NoiseArg;
use data::WallData;
use jobs::Job;
use views::MapColour;

/// Arguments of `lumiwall station`.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct StationArgs {
    /// Wall description (TOML).
    #[arg(long, default_value = "fixtures/walls/heyewall-48.toml")]
    wall: PathBuf,
    /// Profile folder: `commission` writes it, `verify` and `recalibrate` read it.
    #[arg(long, default_value = "out/station")]
    profiles: PathBuf,
    /// Profile store: drift charts and the forecast; recalibrations are recorded in it.
    #[arg(long)]
    store: Option<PathBuf>,
    /// Meter: emulated, direct or serial:PATH.
    #[arg(long, default_value = "emulated")]
    meter: MeterChoice,
    /// Error model of the simulated meter.
    #[arg(long, value_enum, default_value = "realistic")]
    noise: NoiseArg,
    /// Camera (`virtual`, or a V4L2/UVC device) for the commissioning's camera stage
    /// (`commission --camera`) and the nightly flat-field check (`recalibrate
    /// --camera`, once the folder has a camera stage): a "Camera" box appears beside
    /// the actions. Needs a build with the `camera` feature.
    #[arg(long)]
    camera: Option<String>,
}

/// Opens the station window.
pub(crate) fn run(args: StationArgs) -> Result<(), CliError> {
    let app = StationApp::new(args);
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default().with_inner_size([1280.0, 820.0]),
        ..Default::default()
    };
    eframe::run_native("lumiwall station", options, Box::new(|_| Ok(Box::new(app)))).map_err(|e| {
        CliError::failure(format!(
            "cannot open the station window: {e} (it needs a display: DISPLAY or \
             WAYLAND_DISPLAY, and a Vulkan or GL driver)"
        ))
    })
}

/// The views.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum View {
    Wall,
    Gamut,
    Forecast,
    Log,
}

/// The app's state.
pub(crate) struct StationApp {
    args: StationArgs,
    data: WallData,
    view: View,
    colour: MapColour,
    selected: Option<DisplayKey>,
    job: Option<Job>,
    log: Vec<String>,
    /// Whether runs aim the meter with the technician (`--aim guided`): the prompts and
    /// live readings appear in the window.
    guided: bool,
    /// Whether runs use `args.camera` (the "Camera" box).
    use_camera: bool,
}

/// The actions, each a `lumiwall` command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Action {
    Commission { resume: bool },
    Verify,
    Recalibrate,
}

impl StationApp {
    /// The app on `args`, with the files read.
    pub(crate) fn new(args: StationArgs) -> Self {
        let data = WallData::load(&args.wall, &args.profiles, args.store.as_deref());
        // a real meter is aimed by hand (as the command line's `--aim auto`)
        let guided = matches!(args.meter, MeterChoice::Serial(_));
        let use_camera = args.camera.is_some();
        Self {
            args,
            data,
            view: View::Wall,
            colour: MapColour::Verification,
            selected: None,
            job: None,
            log: Vec::new(),
            guided,
            use_camera,
        }
    }

    /// Whether a run is in progress.
    pub(crate) fn busy(&self) -> bool {
        self.job.as_ref().is_some_and(|j| j.finished.is_none())
    }

    /// The camera `action` runs with: the commissioning's camera stage, and the nightly
    /// check where the folder has a camera stage to check against.
    fn camera_for(&self, action: Action) -> Option<&String> {
        let camera = self.args.camera.as_ref().filter(|_| self.use_camera)?;
        match action {
            Action::Commission { .. } => Some(camera),
            Action::Recalibrate => self
                .args
                .profiles
                .join(crate::cmd_commission::CAMERA_FILE)
                .is_file()
                .then_some(camera),
            Action::Verify => None,
        }
    }

    /// The command line of `action`.
    fn argv(&self, action: Action) -> Vec<String> {
        let a = &self.args;
        let path = |p: &PathBuf| p.display().to_string();
        let mut v: Vec<String> = vec!["lumiwall".into()];
        match action {
            Action::Commission { resume } => {
                v.extend(["commission".into(), "--out".into(), path(&a.profiles)]);
                if resume {
                    v.push("--resume".into());
                }
            }
            Action::Verify => v.extend(["verify".into(), "--profiles".into(), path(&a.profiles)]),
            Action::Recalibrate => {
                v.extend(["recalibrate".into(), "--profiles".into(), path(&a.profiles)]);
                if let Some(s) = &a.store {
                    v.extend(["--store".into(), path(s)]);
                }
            }
        }
        if self.guided {
            v.extend(["--aim".into(), "guided".into()]);
        }
        if let Some(camera) = self.camera_for(action) {
            v.extend(["--camera".into(), camera.clone()]);
        }
        let meter = match &a.meter {
            MeterChoice::Emulated => "emulated".to_string(),
            MeterChoice::Direct => "direct".to_string(),
            MeterChoice::Serial(p) => format!("serial:{p}"),
        };
        let noise = match a.noise {
            NoiseArg::Realistic => "realistic",
            NoiseArg::None => "none",
        };
        v.extend([
            "--wall".into(),
            path(&a.wall),
            "--meter".into(),
            meter,
            "--noise".into(),
            noise.into(),
        ]);
        v
    }

    fn start(&mut self, action: Action, ctx: &egui::Context) {
        let argv = self.argv(action);
        self.log.push(format!("$ {}", argv.join(" ")));
        let ctx = ctx.clone();
        self.job = Some(Job::start(argv, move || ctx.request_repaint()));
        self.view = View::Log;
    }

    /// Takes the run's news; reloads the files when it has ended.
    fn poll(&mut self) {
        let Some(job) = &mut self.job else {
            return;
        };
        let was_running = job.finished.is_none();
        self.log.extend(job.poll());
        if let (true, Some(done)) = (was_running, &job.finished) {
            self.log.push(match done {
                Ok(s) => s.clone(),
                Err(e) => format!("FAILED: {e}"),
            });
            self.data = WallData::load(
                &self.args.wall,
                &self.args.profiles,
                self.args.store.as_deref(),
            );
        }
    }

    /// Draws the whole window into `ui`.
    pub(crate) fn show(&mut self, ui: &mut egui::Ui) {
        self.poll();
        egui::Panel::top("actions").show(ui, |ui| self.actions(ui));
        if let Some(job) = &self.job {
            let prompt = job.aim_prompt();
            if !prompt.is_empty() {
                egui::Panel::top("aiming").show(ui, |ui| views::aiming(ui, job, &prompt));
            }
        }
        egui::Panel::left("details")
            .default_size(300.0)
            .show(ui, |ui| self.details(ui));
        egui::CentralPanel::default_margins().show(ui, |ui| self.central(ui));
    }

    fn actions(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.heading(format!("lumiwall station — {}", self.data.name));
            ui.separator();
            let idle = !self.busy();
            let ctx = ui.ctx().clone();
            if ui
                .add_enabled(idle, egui::Button::new("Commission"))
                .clicked()
            {
                self.start(Action::Commission { resume: false }, &ctx);
            }
            if ui
                .add_enabled(idle, egui::Button::new("Resume"))
                .on_hover_text("continue a stopped commissioning")
                .clicked()
            {
                self.start(Action::Commission { resume: true }, &ctx);
            }
            let commissioned = !self.data.profiles.is_empty();
            if ui
                .add_enabled(idle && commissioned, egui::Button::new("Verify"))
                .clicked()
            {
                self.start(Action::Verify, &ctx);
            }
            if ui
                .add_enabled(idle && commissioned, egui::Button::new("Recalibrate"))
                .clicked()
            {
                self.start(Action::Recalibrate, &ctx);
            }
            ui.add_enabled(idle, egui::Checkbox::new(&mut self.guided, "Guided aiming"))
                .on_hover_text(
                    "aim the meter by hand at each display, prompted here (--aim guided)",
                );
            if let Some(camera) = &self.args.camera {
                ui.add_enabled(idle, egui::Checkbox::new(&mut self.use_camera, "Camera"))
                    .on_hover_text(format!(
                        "flat fields with camera {camera}: commission --camera, recalibrate --camera"
                    ));
            }
            if let Some(job) = self.job.as_ref().filter(|_| !idle) {
                let stop = egui::Button::new(if job.stopping() {
                    "Stopping…"
                } else {
                    "Stop"
                });
                if ui.add_enabled(!job.stopping(), stop).clicked() {
                    job.stop();
                }
                ui.add(
                    egui::ProgressBar::new(job.fraction)
                        .desired_width(200.0)
                        .text(format!("{} readings", job.readings)),
                );
            }
            if let Some(report) = &self.data.report
                && ui.button("Open report").clicked()
            {
                let opened = std::process::Command::new("xdg-open").arg(report).spawn();
                if let Err(e) = opened {
                    self.log
                        .push(format!("cannot open {}: {e}", report.display()));
                }
            }
        });
        ui.horizontal(|ui| {
            for (view, label) in [
                (View::Wall, "Wall"),
                (View::Gamut, "Gamut & usage"),
                (View::Forecast, "Drift & forecast"),
                (View::Log, "Run log"),
            ] {
                ui.selectable_value(&mut self.view, view, label);
            }
        });
    }

    fn details(&mut self, ui: &mut egui::Ui) {
        ui.label(format!("wall file {}", self.args.wall.display()));
        ui.label(format!("profiles {}", self.args.profiles.display()));
        ui.label(format!(
            "{} displays, {} profiles",
            self.data.displays.len(),
            self.data.profiles.len()
        ));
        if let Some(v) = &self.data.verify {
            let o = &v.overall;
            ui.label(format!(
                "last verification: median ΔE2000 {:.2}, max {:.2} ({} patches)",
                o.median_de, o.max_de, o.patches
            ));
        }
        for p in &self.data.problems {
            ui.colored_label(egui::Color32::from_rgb(230, 160, 60), p);
        }
        ui.separator();
        let Some(key) = self.selected.clone() else {
            ui.label("click a display on the wall map");
            return;
        };
        ui.strong(key.to_string());
        if let Some(p) = self.data.profile(key.display, key.eye) {
            let w = p.target_white_xyz_cd_m2;
            ui.label(format!("common white {:.2} cd/m²", w[1]));
            ui.label(format!(
                "usage R {:.3} G {:.3} B {:.3} (headroom {:.2})",
                p.channel_usage[0], p.channel_usage[1], p.channel_usage[2], p.headroom
            ));
        }
        if let Some(s) = self.data.verified(key.display, key.eye) {
            ui.label(format!(
                "verified: median {:.2}, max {:.2}, white {}",
                s.median_de,
                s.max_de,
                s.white_de.map_or("–".into(), |w| format!("{w:.2}"))
            ));
        }
        if let Some(d) = self.data.drift_pct(&key) {
            ui.label(format!(
                "native white {d:+.2} % since the first stored reading"
            ));
        }
        if let Some((c, x)) = self
            .data
            .forecast_of(&key)
            .and_then(|f| f.first_beyond_full_drive())
        {
            ui.label(format!(
                "forecast: {c:?} beyond full drive on {}",
                x.utc.strftime("%Y-%m-%d")
            ));
        }
    }

    fn central(&mut self, ui: &mut egui::Ui) {
        match self.view {
            View::Wall => {
                ui.horizontal(|ui| {
                    ui.label("colour by");
                    for c in MapColour::ALL {
                        ui.selectable_value(&mut self.colour, c, c.label());
                    }
                });
                if let Some(k) =
                    views::wall_map(ui, &self.data, self.colour, self.selected.as_ref())
                {
                    self.selected = Some(k);
                }
            }
            View::Gamut => {
                views::usage_bars(ui, &self.data);
                views::gamut_plot(ui, &self.data, self.selected.as_ref());
            }
            View::Forecast => views::drift_and_forecast(ui, &self.data, self.selected.as_ref()),
            View::Log => {
                if let Some(job) = &self.job {
                    ui.monospace(format!("$ {}", job.argv.join(" ")));
                }
                egui::ScrollArea::vertical()
                    .stick_to_bottom(true)
                    .show(ui, |ui| {
                        for line in &self.log {
                            ui.monospace(line);
                        }
                    });
            }
        }
    }
}

impl eframe::App for StationApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        self.show(ui);
    }
}
