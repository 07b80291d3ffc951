//! The station app driven through its own widgets (egui_kittest: clicks by label,
//! AccessKit queries) on the virtual wall, and screenshots of its main views compared
//! with the ones checked in (`ui/tests/snapshots`; `UPDATE_SNAPSHOTS=1` writes new
//! ones). Screenshots need a wgpu adapter (Mesa's lavapipe in CI); without one they are
//! skipped with a message unless `LUMIWALL_REQUIRE_GPU=1`.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};

use super::{StationApp, StationArgs};
use crate::cmd_commission::NoiseArg;
use lumiwall_calib::station::MeterChoice;

/// A wall file, relative to the crate (the tests' working folder), so that the path
/// shown in the screenshots is the same on every machine.
fn fixture(wall: &str) -> PathBuf {
    let path = Path::new("../fixtures/walls").join(wall);
    assert!(
        path.is_file(),
        "run from the ui crate's folder: {} not found",
        path.display()
    );
    path
}

/// A fresh profile folder at a fixed path (it is shown in the window, so the
/// screenshots must not depend on a random name).
fn fresh_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir()
        .join("lumiwall-station-app-test")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn app(wall: &str, profiles: PathBuf) -> StationApp {
    StationApp::new(StationArgs {
        wall: fixture(wall),
        profiles,
        store: None,
        meter: MeterChoice::Direct,
        noise: NoiseArg::None,
        camera: None,
    })
}

fn harness(app: StationApp) -> Harness<'static, StationApp> {
    Harness::builder()
        .with_size(egui::vec2(1280.0, 820.0))
        .build_ui_state(|ui, app: &mut StationApp| app.show(ui), app)
}

/// Steps the window until the run has ended (at most two minutes).
fn wait_for_run(h: &mut Harness<'static, StationApp>) {
    let deadline = Instant::now() + Duration::from_secs(120);
    while h.state().busy() {
        assert!(
            Instant::now() < deadline,
            "the run did not end: {:?}",
            h.state().log
        );
        h.step();
        std::thread::sleep(Duration::from_millis(20));
    }
    // one more frame takes the end of the run and reloads the files
    h.step();
    h.run_steps(3);
}

fn click(h: &mut Harness<'static, StationApp>, label: &str) {
    h.get_by_label(label).click();
    h.run_steps(2);
}

fn log_has(h: &Harness<'static, StationApp>, text: &str) -> bool {
    h.state().log.iter().any(|l| l.contains(text))
}

/// Compares a screenshot with the checked-in one, or says why it cannot.
fn screenshot(h: &mut Harness<'static, StationApp>, name: &str) {
    screenshot_within(h, name, 0);
}

/// [`screenshot`], allowing `max_failed_pixels` pixels to differ.
fn screenshot_within(h: &mut Harness<'static, StationApp>, name: &str, max_failed_pixels: usize) {
    match h.render() {
        Ok(image) => egui_kittest::image_snapshot_options(
            &image,
            name,
            &egui_kittest::SnapshotOptions::default().max_failed_pixels(max_failed_pixels),
        ),
        Err(e) if std::env::var("LUMIWALL_REQUIRE_GPU").as_deref() != Ok("1") => {
            eprintln!(
                "skipping screenshot {name}: no wgpu adapter ({e}); LUMIWALL_REQUIRE_GPU=1 requires one"
            );
        }
        Err(e) => panic!("screenshot {name}: no wgpu adapter: {e}"),
    }
}

#[test]
fn the_app_commissions_and_verifies_the_virtual_wall_and_colours_the_map_by_the_verification() {
    let dir = fresh_dir("mono");
    let mut h = harness(app("mono-2x1.toml", dir.clone()));
    h.run_steps(2);
    assert!(h.state().data.profiles.is_empty());
    // Verify needs profiles: disabled before the commissioning
    assert!(h.get_by_label("Verify").accesskit_node().is_disabled());
    click(&mut h, "Commission");
    assert!(
        log_has(&h, "$ lumiwall commission --out"),
        "the command line is shown: {:?}",
        h.state().log
    );
    wait_for_run(&mut h);
    assert!(
        log_has(&h, "commissioned mono-2x1: 2 displays"),
        "{:?}",
        h.state().log
    );
    assert_eq!(
        h.state().data.profiles.len(),
        2,
        "the new profiles are read back"
    );
    click(&mut h, "Verify");
    wait_for_run(&mut h);
    assert!(
        log_has(&h, "verified: median ΔE2000"),
        "{:?}",
        h.state().log
    );
    let verified = h
        .state()
        .data
        .verify
        .as_ref()
        .expect("verify.json read back");
    assert_eq!(verified.per_display.len(), 2);
    click(&mut h, "Wall");
    // each tile is coloured by its display's largest ΔE2000 in the verification
    let data = &h.state().data;
    for info in &data.displays {
        let key = lumiwall_profiles::DisplayKey {
            wall: data.name.clone(),
            display: info.id.0,
            tile_col: info.tile_col,
            tile_row: info.tile_row,
            eye: info.eye,
        };
        let max = data.verified(info.id.0, info.eye).map(|s| s.max_de);
        let (shown, colour) =
            super::views::status(data, &key, super::views::MapColour::Verification);
        assert_eq!(shown, max);
        assert_eq!(
            colour == super::views::GOOD,
            max.is_some_and(|m| m <= 1.5),
            "{key}: {max:?}"
        );
    }
    screenshot(&mut h, "station_wall");
    click(&mut h, "Gamut & usage");
    screenshot(&mut h, "station_gamut");
}

#[test]
fn a_stopped_commissioning_says_so_and_resume_finishes_it() {
    let dir = fresh_dir("stop");
    let mut h = harness(app("heyewall-48.toml", dir.clone()));
    h.run_steps(2);
    click(&mut h, "Commission");
    // stop before the first pattern is shown: the run ends with the technician's stop
    h.state().job.as_ref().expect("a run").stop();
    wait_for_run(&mut h);
    assert!(
        log_has(&h, "stopped by the technician"),
        "{:?}",
        h.state().log
    );
    assert!(h.state().data.profiles.is_empty());
    click(&mut h, "Resume");
    assert!(log_has(&h, "--resume"), "{:?}", h.state().log);
    wait_for_run(&mut h);
    assert!(
        log_has(&h, "commissioned heyewall-48: 48 displays"),
        "{:?}",
        h.state().log
    );
    assert_eq!(h.state().data.profiles.len(), 48);
    // the README's screenshot: the 48-projector wall after its verification
    click(&mut h, "Verify");
    wait_for_run(&mut h);
    click(&mut h, "Wall");
    // Where the stop lands depends on the machine's load (a few readings may be taken
    // first, and the virtual wall's warm-up clock moves on), so a verification value
    // may differ in its last digit (one glyph, 6 pixels, in a CI run): 40 pixels, less
    // than a word, may differ.
    screenshot_within(&mut h, "station_heyewall", 40);
}

#[test]
fn the_forecast_view_lists_every_display_of_the_store_and_charts_the_selected_one() {
    use lumiwall_bench::season::{self, SeasonBench};
    use lumiwall_calib::recalibrate::DriftLimits;
    use lumiwall_calib::solve::SolveOptions;
    use lumiwall_calib::station::Noise;
    use lumiwall_calib::verify::Tolerances;
    use lumiwall_profiles::store::ForecastOptions;

    // a short season writes the profiles and the store the app reads
    let out = fresh_dir("season");
    let bench = SeasonBench {
        wall: fixture("mono-2x1.toml"),
        nights: 8,
        lamp_hours_per_day: 24.0,
        lamp_change_night: None,
        lamp_change_display: None,
        forecast_night: 4,
        forecast: ForecastOptions::default(),
        noise: Noise::None,
        meter: MeterChoice::Direct,
        solve: SolveOptions {
            headroom: 0.85,
            ..SolveOptions::default()
        },
        limits: DriftLimits::default(),
        full_check_every_nights: 1,
        tolerances: Tolerances::default(),
        averaging: lumiwall_calib::measure::averaging::Averaging::Fixed(1),
        out: out.clone(),
        start_utc: "2026-01-01T02:00:00Z".parse().expect("a time"),
    };
    season::run(&bench, &mut |_| {}).expect("the season runs");
    let mut a = app("mono-2x1.toml", out.join("profiles"));
    a.args.store = Some(out.join("season.lumistore"));
    a = StationApp::new(a.args);
    assert_eq!(a.data.forecast.len(), 2, "{:?}", a.data.problems);
    assert_eq!(
        a.data.readings.values().map(Vec::len).sum::<usize>(),
        18,
        "9 nights × 2 displays"
    );
    let mut h = harness(a);
    h.run_steps(2);
    click(&mut h, "Drift & forecast");
    for d in 0..2 {
        let name = format!("mono-2x1 display {d} (tile col {d} row 0, mono)");
        assert!(h.query_by_label(&name).is_some(), "{name} listed");
    }
    let key = h.state().data.forecast[1].display().clone();
    h.state_mut().selected = Some(key);
    h.run_steps(2);
    assert!(
        h.query_by_label_contains("native white of mono-2x1 display 1")
            .is_some()
    );
    screenshot(&mut h, "station_forecast");
}

#[test]
fn guided_aiming_prompts_in_the_window_and_the_buttons_answer_it() {
    let dir = fresh_dir("guided");
    let mut h = harness(app("mono-2x1.toml", dir.clone()));
    h.run_steps(2);
    click(&mut h, "Guided aiming");
    click(&mut h, "Commission");
    assert!(log_has(&h, "--aim guided"), "{:?}", h.state().log);
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut prompts = Vec::new();
    while h.state().busy() {
        assert!(Instant::now() < deadline, "{:?}", h.state().log);
        h.step();
        let prompt = h
            .state()
            .job
            .as_ref()
            .map(|j| j.aim_prompt())
            .unwrap_or_default();
        if prompt.iter().any(|l| l.contains("live:")) {
            h.run_steps(2);
            if prompts.is_empty() {
                screenshot(&mut h, "station_aiming");
            }
            prompts.push(prompt);
            // the first display is read again once: a second live reading follows
            if prompts.len() == 1 {
                click(&mut h, "Read again");
                continue;
            }
            click(&mut h, "Aimed");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    h.step();
    h.run_steps(3);
    assert!(
        log_has(&h, "commissioned mono-2x1: 2 displays"),
        "{:?}",
        h.state().log
    );
    println!("{prompts:#?}");
    assert!(prompts[0][0].contains("aim the meter at"), "{prompts:?}");
    assert!(prompts[0][1].contains("live: Y ="), "{prompts:?}");
    // read again: the same prompt, one live reading more is not kept (cleared by the
    // answer), so the next prompt shows a fresh reading for the same display
    assert!(prompts[1][0].contains("live: Y ="), "{prompts:?}");
    let aimed = prompts
        .iter()
        .filter(|p| p[0].contains("aim the meter at"))
        .count();
    assert!(aimed >= 2, "one prompt per display at least: {prompts:?}");
    assert_eq!(h.state().data.profiles.len(), 2);
}

/// With `--camera`, the "Camera" box gives the commissioning its camera stage and the
/// nightly run its flat-field check, the latter only once the folder has a camera
/// stage to check against; unticked, neither.
#[test]
fn the_camera_box_adds_the_camera_to_commission_and_to_recalibrate_once_the_folder_has_a_camera_stage()
 {
    use super::Action;
    let dir = fresh_dir("camera-box");
    let mut a = app("mono-2x1.toml", dir.clone());
    a.args.camera = Some("virtual".into());
    a.use_camera = true;
    let has_camera = |a: &StationApp, action| {
        a.argv(action)
            .windows(2)
            .any(|w| w[0] == "--camera" && w[1] == "virtual")
    };
    assert!(has_camera(&a, Action::Commission { resume: false }));
    assert!(!has_camera(&a, Action::Recalibrate));
    assert!(!has_camera(&a, Action::Verify));
    std::fs::create_dir_all(&dir).expect("folder");
    std::fs::write(dir.join(crate::cmd_commission::CAMERA_FILE), "{}").expect("camera.json");
    assert!(has_camera(&a, Action::Recalibrate));
    a.use_camera = false;
    assert!(!has_camera(&a, Action::Commission { resume: false }));
    assert!(!has_camera(&a, Action::Recalibrate));
}
