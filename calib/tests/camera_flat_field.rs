//! The camera stage end to end on the virtual wall: commission with the meter, measure
//! flat fields with the virtual camera, and judge the wall between the tile centres
//! with the simulator's truth (not with the calibrated camera).
#![cfg(feature = "camera")]

mod camera_common;

use camera_common::wall;
use lumiwall_calib::camera::{Checkpoint, FlatFieldOptions, measure_flat_fields};
use lumiwall_calib::commission::CommissionOptions;
use lumiwall_calib::measure::MeasureOptions;
use lumiwall_calib::spatial::{
    GridOptions, Truth, dense_truth, fit_white_to_flat_fields, verify_grid,
};
use lumiwall_calib::station::{MeterChoice, Noise, Station, StationOptions};
use lumiwall_devices::sim::{VirtualCamera, VirtualWall};
use lumiwall_profiles::DisplayProfile;

struct Figures {
    grid_before: (f64, f64),
    grid_after: (f64, f64),
    uniformity_after: (f64, f64),
    seams_after: f64,
    dense_dy: f64,
    dense_dxy: f64,
    iterations: u32,
    camera_vs_meter: (f64, f64),
}

/// The commissioning options of the command line's defaults (white 8500 K, the
/// design's target for these walls).
fn commission_options() -> CommissionOptions {
    CommissionOptions {
        measure: MeasureOptions::default(),
        solve: lumiwall_calib::solve::SolveOptions {
            white: lumiwall_calib::solve::WhiteTarget::Cct(8500.0),
            ..Default::default()
        },
        resume: false,
        meter_correction: true,
        grey_levels: lumiwall_calib::measure::grey_drives::default_levels(),
        // the walls here are warm: measured at once, as before the check existed
        warm_check: None,
    }
}

/// The three worst cells, for the log.
fn print_worst(after: &lumiwall_calib::spatial::SpatialReport) {
    let mut worst: Vec<_> = after.cells.iter().collect();
    worst.sort_by(|a, b| b.delta_e2000.total_cmp(&a.delta_e2000));
    for c in worst.iter().take(3) {
        let (e, m) = (c.expected, c.measured);
        eprintln!(
            "worst cell #{} {:?}: ΔY {:+.2} % Δx {:+.4} Δy {:+.4} ΔE {:.2}",
            c.display,
            c.uv,
            100.0 * (m.y / e.y - 1.0),
            m.xy().unwrap()[0] - e.xy().unwrap()[0],
            m.xy().unwrap()[1] - e.xy().unwrap()[1],
            c.delta_e2000
        );
    }
}

/// Per display: the worst cell against its own centre, the gains and the residuals.
fn print_per_display(
    after: &lumiwall_calib::spatial::SpatialReport,
    flats: &lumiwall_calib::camera::FlatFieldOutcome,
    profiles: &[DisplayProfile],
) {
    for (f, p) in flats.displays.iter().zip(profiles) {
        let cells: Vec<_> = after
            .cells
            .iter()
            .filter(|c| c.display == f.display)
            .collect();
        let centre = cells
            .iter()
            .min_by(|a, b| {
                let d = |x: &[f64; 2]| (x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2);
                d(&a.uv).total_cmp(&d(&b.uv))
            })
            .expect("centre");
        let worst = cells
            .iter()
            .max_by(|a, b| a.delta_e2000.total_cmp(&b.delta_e2000))
            .expect("cells");
        let (c, w) = (centre.measured, worst.measured);
        let e = centre.expected;
        let max_gain: Vec<f32> = (0..3)
            .map(|k| {
                p.flat_field
                    .as_ref()
                    .map(|ff| ff.gain.iter().map(|g| g[k]).fold(0.0, f32::max))
                    .unwrap_or(0.0)
            })
            .collect();
        eprintln!(
            "#{:2} {} centre ΔY {:+.2}% Δxy {:+.4},{:+.4} | worst {:?} ΔE {:.2} ΔY {:+.2}% Δxy {:+.4},{:+.4} | min gain {:.3?} max gain {:.3?} res {:.4?} it {:?}",
            f.display,
            centre.eye,
            100.0 * (c.y / e.y - 1.0),
            c.xy().unwrap()[0] - e.xy().unwrap()[0],
            c.xy().unwrap()[1] - e.xy().unwrap()[1],
            worst.uv,
            worst.delta_e2000,
            100.0 * (w.y / e.y - 1.0),
            w.xy().unwrap()[0] - e.xy().unwrap()[0],
            w.xy().unwrap()[1] - e.xy().unwrap()[1],
            f.min_gain,
            max_gain,
            f.residual_final,
            f.iterations
        );
    }
}

/// The one-tile `infitec-pair` wall with its painted-wood highlight removed (a
/// Lambertian screen), with `extra` TOML appended.
fn lambertian_infitec_pair(extra: &str) -> VirtualWall {
    let path = format!(
        "{}/../fixtures/walls/infitec-pair.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(path).expect("fixture");
    assert!(text.contains("specular_gain = 0.35"));
    let lambertian = text.replace("specular_gain = 0.35", "specular_gain = 0.0");
    VirtualWall::from_toml_str(&format!("{lambertian}\n{extra}")).expect("wall")
}

/// A station on `w` with the direct meter (`noise`) and the wall commissioned with
/// [`commission_options`] into a temporary folder: the station and its profiles. A
/// noisy meter is matched first to a CS-2000 whose wavelengths a Hg-Ar lamp checked,
/// one matrix per display (`lumiwall meter-matrix --per-display`), as an Infitec
/// station would.
fn commissioned(w: &VirtualWall, noise: Noise) -> (Station, Vec<DisplayProfile>) {
    let mut station =
        Station::with_wall(w.clone(), &StationOptions::new(MeterChoice::Direct, noise))
            .expect("station");
    let mut opts = commission_options();
    if noise == Noise::Realistic {
        let model = lumiwall_devices::sim::SpectroModel::cs2000(2000);
        let matrices = station
            .meter_matrices_against_simulated(model, true)
            .expect("meter matrices against the lamp-checked reference");
        opts.measure.meter_matrix = Some(matrices);
    }
    let dir = tempfile::tempdir().expect("tmp");
    let outcome = station
        .commission(dir.path(), &opts, &mut |_| {})
        .expect("commission");
    (station, outcome.solution.profiles)
}

fn run(name: &str, extra: &str, noise: Noise, camera_noise: bool) -> Figures {
    let w = wall(name, extra);
    let (mut station, mut profiles) = commissioned(&w, noise);
    let displays = w.displays();
    let grid = GridOptions::default();
    let before = verify_grid(&mut Truth(&w), &displays, &profiles, &grid).expect("grid before");
    let mut cam = VirtualCamera::new(&w, camera_noise).expect("camera");
    let flats = measure_flat_fields(
        &mut cam,
        &mut station.rig(),
        &displays,
        &profiles,
        &FlatFieldOptions::default(),
        &mut |l| eprintln!("{l}"),
    )
    .expect("flat fields");
    for (p, f) in profiles.iter_mut().zip(&flats.displays) {
        p.flat_field = Some(f.flat.clone());
    }
    let cost = fit_white_to_flat_fields(&mut profiles);
    let after = verify_grid(&mut Truth(&w), &displays, &profiles, &grid).expect("grid after");
    let dense = dense_truth(&w, &displays, &profiles, [64, 32]).expect("dense");
    print_worst(&after);
    if std::env::var_os("LUMIWALL_CAMERA_DIAG").is_some() {
        print_per_display(&after, &flats, &profiles);
    }
    eprintln!("{name} {extra:?}: before {}", before.overall_line());
    eprintln!("{name}: after  {}", after.overall_line());
    eprintln!(
        "white {:.2} → {:.2} cd/m²; frames per display {:?}; {:.1} s",
        cost.before_cd_m2,
        cost.after_cd_m2,
        flats.displays.iter().map(|d| d.frames).collect::<Vec<_>>(),
        flats.seconds
    );
    let stat = |r: &lumiwall_calib::spatial::SpatialReport| {
        let mut v: Vec<f64> = r.cells.iter().map(|c| c.delta_e2000).collect();
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2], v[v.len() - 1])
    };
    Figures {
        grid_before: stat(&before),
        grid_after: stat(&after),
        uniformity_after: {
            let mut v = after.uniformity_delta_e();
            v.sort_by(f64::total_cmp);
            (v[v.len() / 2], v[v.len() - 1])
        },
        seams_after: after
            .seams
            .iter()
            .map(|s| s.delta_e2000)
            .fold(0.0, f64::max),
        dense_dy: dense.iter().map(|d| d.1).fold(0.0, f64::max),
        dense_dxy: dense.iter().map(|d| d.2).fold(0.0, f64::max),
        iterations: flats
            .displays
            .iter()
            .flat_map(|d| d.iterations)
            .max()
            .unwrap_or(0),
        camera_vs_meter: flats.photometry.worst(),
    }
}

/// A noiseless two-tile wall judged by the simulator (with a 1° meter field): the
/// issue's acceptance for the flat field — every cell within ΔE2000 0.5 (median) and
/// 1.5 (max) of its display's centre, seams ≤ 1.0, ±2 % and Δxy ≤ 0.003 at every texel
/// centre of a 64×32 grid, camera vs meter ≤ 3 % and 0.004 at the white spots, at most
/// 3 iterations — and against the target white (which adds the meter calibration's own
/// error at the centres) median ≤ 0.6, max ≤ 1.5.
#[test]
fn flat_fields_meet_the_acceptance_on_a_noiseless_two_tile_wall() {
    let f = run("mono-2x1", "", Noise::None, false);
    eprintln!(
        "dense ΔY {:.2} % Δxy {:.4}; iterations {}; camera vs meter {:?}",
        f.dense_dy, f.dense_dxy, f.iterations, f.camera_vs_meter
    );
    assert!(
        f.grid_before.0 > 3.0,
        "the wall was already uniform: {:?}",
        f.grid_before
    );
    assert!(
        f.uniformity_after.0 <= 0.5 && f.uniformity_after.1 <= 1.5,
        "uniformity {:?}",
        f.uniformity_after
    );
    assert!(
        f.grid_after.0 <= 0.6 && f.grid_after.1 <= 1.5,
        "grid {:?}",
        f.grid_after
    );
    assert!(f.seams_after <= 1.0, "seams {}", f.seams_after);
    assert!(
        f.dense_dy <= 2.0 && f.dense_dxy <= 0.003,
        "dense {} % {}",
        f.dense_dy,
        f.dense_dxy
    );
    assert!(
        f.camera_vs_meter.0 <= 3.0 && f.camera_vs_meter.1 <= 0.004,
        "camera vs meter {:?}",
        f.camera_vs_meter
    );
    assert!(f.iterations <= 3);
}

/// A camera that stops answering after `limit` captures (a cable pulled), counting.
struct StopsAfter<C> {
    inner: C,
    captures: u32,
    limit: u32,
}

impl<C: lumiwall_devices::Camera> lumiwall_devices::Camera for StopsAfter<C> {
    fn info(&self) -> lumiwall_devices::CameraInfo {
        self.inner.info()
    }
    fn capture(
        &mut self,
        t: f64,
        g: f64,
    ) -> Result<lumiwall_devices::Frame, lumiwall_devices::DeviceError> {
        if self.captures >= self.limit {
            return Err(lumiwall_devices::DeviceError::Timeout {
                device: "test camera".into(),
                timeout_ms: 5000,
            });
        }
        self.captures += 1;
        self.inner.capture(t, g)
    }
}

/// One camera stage on `w` with a camera that stops after `limit` captures: the
/// outcome, the captures taken and the progress lines.
fn stage_stopping_after(
    w: &VirtualWall,
    station: &mut Station,
    profiles: &[DisplayProfile],
    limit: u32,
    opts: &FlatFieldOptions,
) -> (
    Result<lumiwall_calib::camera::FlatFieldOutcome, lumiwall_calib::camera::CameraCalibError>,
    u32,
    Vec<String>,
) {
    let mut cam = StopsAfter {
        inner: VirtualCamera::new(w, false).expect("camera"),
        captures: 0,
        limit,
    };
    let mut lines = Vec::new();
    let outcome = measure_flat_fields(
        &mut cam,
        &mut station.rig(),
        &w.displays(),
        profiles,
        opts,
        &mut |l| lines.push(l.to_string()),
    );
    (outcome, cam.captures, lines)
}

/// A camera stage stopped halfway through the last display's loop resumes from its
/// checkpoint: the calibration and the first display come from the stopped run
/// (fewer captures, no meter), and every flat field matches an uninterrupted run's.
#[test]
fn a_camera_stage_stopped_in_the_last_loop_resumes_to_the_same_flat_fields() {
    let w = wall("mono-2x1", "");
    let (mut station, profiles) = commissioned(&w, Noise::None);
    let plain = FlatFieldOptions::default();
    let (whole, total, _) = stage_stopping_after(&w, &mut station, &profiles, u32::MAX, &plain);
    let whole = whole.expect("uninterrupted");
    let last = whole.displays.last().expect("displays").frames;
    let dir = tempfile::tempdir().expect("tmp");
    let opts = FlatFieldOptions {
        checkpoint: Some(Checkpoint::new(dir.path().join("camera-run"))),
        ..FlatFieldOptions::default()
    };
    let (stopped, _, _) =
        stage_stopping_after(&w, &mut station, &profiles, total - last / 2, &opts);
    let err = stopped.expect_err("the camera stops");
    assert!(
        err.to_string().contains("test camera did not answer"),
        "{err}"
    );
    let resume = FlatFieldOptions {
        resume: true,
        ..opts
    };
    let (resumed, captures, lines) =
        stage_stopping_after(&w, &mut station, &profiles, u32::MAX, &resume);
    let resumed = resumed.expect("resumed");
    let first = format!("{} flat field from the stopped run", w.displays()[0].name);
    assert!(
        lines.iter().any(|l| l.contains("resuming from"))
            && lines.iter().any(|l| l.contains(&first)),
        "{lines:#?}"
    );
    assert!(
        captures < last + total / 4,
        "resumed with {captures} captures, the whole stage took {total}"
    );
    // The virtual wall keeps warming up between the runs, so the same loop lands a
    // little differently: every texel within the loop's own residual of 0.5 %.
    for (a, b) in resumed.displays.iter().zip(&whole.displays) {
        let worst = a
            .flat
            .gain
            .iter()
            .zip(&b.flat.gain)
            .flat_map(|(p, q)| (0..3).map(move |c| (p[c] / q[c] - 1.0).abs()))
            .fold(0.0_f32, f32::max);
        eprintln!(
            "{}: largest texel difference {:.3} %",
            a.name,
            100.0 * worst
        );
        assert!(a.flat.gain.len() == b.flat.gain.len() && worst < 0.005);
    }
    // Profiles solved anew (another white): the checkpoint is not theirs.
    let mut other = profiles.clone();
    for p in &mut other {
        p.channel_usage = p.channel_usage.map(|u| 0.9 * u);
    }
    let (_, _, lines) = stage_stopping_after(&w, &mut station, &other, u32::MAX, &resume);
    assert!(
        lines
            .iter()
            .any(|l| l.contains("belongs to other profiles")),
        "{lines:#?}"
    );
}

/// The loop's convergence with more iterations than the default, on the Lambertian
/// one-tile wall: the residual per iteration and channel, printed.
#[test]
#[ignore = "a probe: prints how the residual falls over eight iterations"]
fn closed_loop_residual_over_eight_iterations() {
    // LUMIWALL_PROBE_TOML adds to the wall file (e.g. "[camera]\nbits = 12").
    let extra = std::env::var("LUMIWALL_PROBE_TOML").unwrap_or_default();
    let w = lambertian_infitec_pair(&extra);
    let (mut station, profiles) = commissioned(&w, Noise::None);
    let mut cam = VirtualCamera::new(&w, false).expect("camera");
    let opts = FlatFieldOptions {
        max_iterations: 8,
        threshold: 1e-6,
        ..FlatFieldOptions::default()
    };
    let flats = measure_flat_fields(
        &mut cam,
        &mut station.rig(),
        &w.displays(),
        &profiles,
        &opts,
        &mut |_| {},
    )
    .expect("flat fields");
    for d in &flats.displays {
        for (c, h) in d.residual_history.iter().enumerate() {
            eprintln!("{} channel {c}: {:.5?}", d.name, h);
        }
    }
    let grid = GridOptions::default();
    let mut profiles = profiles;
    for (p, f) in profiles.iter_mut().zip(&flats.displays) {
        p.flat_field = Some(f.flat.clone());
    }
    fit_white_to_flat_fields(&mut profiles);
    let after = verify_grid(&mut Truth(&w), &w.displays(), &profiles, &grid).expect("grid");
    eprintln!("{}", after.overall_line());
}

/// heyewall-48 noiseless (about 10 minutes in a debug build): the figures the issue's
/// acceptance names, printed; run with `--ignored --nocapture` and
/// `LUMIWALL_CAMERA_DIAG=1` for a line per display.
/// One tile, one display per eye, the camera centred on it: the centre and the four
/// corner spots lie at one distance from the image centre, so the meter reads four
/// more spots and the camera's vignetting is still fitted (it went wild before),
/// and the loop converges. The screen is made Lambertian: on a gain screen the meter
/// and the camera see different highlights, which the anchor cannot tell from the
/// lens (an open limit, noted in the closing note).
#[test]
fn a_one_tile_wall_gets_more_meter_spots_and_a_sound_vignetting_fit() {
    let w = lambertian_infitec_pair("");
    let (mut station, profiles) = commissioned(&w, Noise::None);
    let mut cam = VirtualCamera::new(&w, false).expect("camera");
    let mut lines = Vec::new();
    let flats = measure_flat_fields(
        &mut cam,
        &mut station.rig(),
        &w.displays(),
        &profiles,
        &FlatFieldOptions::default(),
        &mut |l| lines.push(l.to_string()),
    )
    .expect("flat fields");
    assert!(
        lines.iter().any(|l| l.contains("read at 13 spots")),
        "{lines:#?}"
    );
    // the fixture's camera is the default 8-bit one: the stage says what that costs
    assert_eq!(
        lines.first().map(String::as_str),
        Some(lumiwall_calib::camera::EIGHT_BIT_NOTE)
    );
    let v = &flats.photometry;
    // The virtual camera's lens keeps 1/(1 + 0.12ρ²)² of the light; the display
    // reaches ρ ≈ 0.9 (the far spots), where the correction is 20 %.
    let worst = (0..=18)
        .map(|k| {
            let rho = f64::from(k) / 20.0;
            (v.vignetting_factor(rho) / (1.0 + 0.12 * rho * rho).powi(2) - 1.0).abs()
        })
        .fold(0.0, f64::max);
    eprintln!(
        "vignetting {:?}: worst {:.2} % to ρ 0.9",
        v.vignetting,
        100.0 * worst
    );
    assert!(v.vignetting[1] != 0.0 && worst < 0.015);
    let (dy, dxy) = v.worst();
    assert!(dy <= 3.0 && dxy <= 0.004, "camera vs meter {dy} % {dxy}");
    for d in &flats.displays {
        assert!(
            d.residual_final.iter().all(|r| *r < 0.01),
            "{}: {:?}",
            d.name,
            d.residual_final
        );
    }
}

#[test]
#[ignore = "10 minutes: the 48-display camera stage"]
fn heyewall_flat_field_figures() {
    // LUMIWALL_PROBE_TOML adds to the wall file (e.g. "[camera]\nbits = 12");
    // LUMIWALL_PROBE_REALISTIC=1 takes the realistic camera and meter.
    let extra = std::env::var("LUMIWALL_PROBE_TOML").unwrap_or_default();
    let realistic = std::env::var_os("LUMIWALL_PROBE_REALISTIC").is_some();
    let noise = if realistic {
        Noise::Realistic
    } else {
        Noise::None
    };
    let f = run("heyewall-48", &extra, noise, realistic);
    eprintln!(
        "dense ΔY {:.2} % Δxy {:.4}; iterations {}; camera vs meter {:?}; grid {:?} seams {:.2}",
        f.dense_dy, f.dense_dxy, f.iterations, f.camera_vs_meter, f.grid_after, f.seams_after
    );
}

/// A pattern output whose display 1 stays dark (a projector that is off).
struct OneDisplayOff(lumiwall_devices::sim::SimPatternOutput);

impl lumiwall_devices::PatternOutput for OneDisplayOff {
    fn displays(&self) -> Vec<lumiwall_devices::DisplayInfo> {
        self.0.displays()
    }
    fn show(
        &mut self,
        d: lumiwall_devices::DisplayId,
        drive: [f64; 3],
    ) -> Result<(), lumiwall_devices::DeviceError> {
        self.0.show(d, if d.0 == 1 { [0.0; 3] } else { drive })
    }
    fn show_image(
        &mut self,
        d: lumiwall_devices::DisplayId,
        img: &lumiwall_devices::DriveImage,
    ) -> Result<(), lumiwall_devices::DeviceError> {
        if d.0 == 1 {
            self.0.show(d, [0.0; 3])
        } else {
            self.0.show_image(d, img)
        }
    }
}

#[test]
fn a_display_that_is_off_stops_the_camera_stage_with_its_name() {
    let w = wall("mono-2x1", "");
    let (mut station, profiles) = commissioned(&w, Noise::None);
    let mut cam = VirtualCamera::new(&w, false).expect("camera");
    let mut pattern = OneDisplayOff(w.pattern_output());
    let mut rig = lumiwall_calib::measure::Rig {
        pattern: &mut pattern,
        meter: station.meter.as_mut(),
        positioner: station.positioner.as_mut(),
    };
    let err = measure_flat_fields(
        &mut cam,
        &mut rig,
        &w.displays(),
        &profiles,
        &FlatFieldOptions::default(),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("tile c1r0"), "{err}");
}

#[test]
fn a_camera_with_automatic_exposure_only_is_refused_before_any_measurement() {
    let w = wall("mono-2x1", "[camera]\nmanual_exposure = false\n");
    let mut station = Station::with_wall(
        w.clone(),
        &StationOptions::new(MeterChoice::Direct, Noise::None),
    )
    .expect("station");
    let mut cam = VirtualCamera::new(&w, false).expect("camera");
    let err = measure_flat_fields(
        &mut cam,
        &mut station.rig(),
        &w.displays(),
        &[],
        &FlatFieldOptions::default(),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("automatic exposure only"), "{err}");
}

/// A gain screen (specular lobe) seen from one place: the flat field is right for the
/// camera's position (where the meter also stands); seen head-on from 2 m at every spot
/// instead, the hotspot moves and the same profiles are visibly less uniform.
#[test]
fn on_a_gain_screen_the_flat_field_is_right_for_the_camera_position_only() {
    let screen = "[screen]\ndiffuse_gain = 0.8\nspecular_gain = 0.6\nspecular_width_deg = 25.0\n";
    let place = "position_m = [1.6, 0.6, 3.6]";
    let seen_from_camera = format!("{screen}[meter]\n{place}\n[camera]\n{place}\n");
    let w = wall("mono-2x1", &seen_from_camera);
    let (mut station, mut profiles) = commissioned(&w, Noise::None);
    let displays = w.displays();
    let mut cam = VirtualCamera::new(&w, false).expect("camera");
    let flats = measure_flat_fields(
        &mut cam,
        &mut station.rig(),
        &displays,
        &profiles,
        &FlatFieldOptions::default(),
        &mut |_| {},
    )
    .expect("flat fields");
    for (p, f) in profiles.iter_mut().zip(&flats.displays) {
        p.flat_field = Some(f.flat.clone());
    }
    fit_white_to_flat_fields(&mut profiles);
    let from_camera = dense_truth(&w, &displays, &profiles, [64, 32]).expect("dense");
    let head_on = wall("mono-2x1", &format!("{screen}[camera]\n{place}\n"));
    let from_front = dense_truth(&head_on, &displays, &profiles, [64, 32]).expect("dense");
    let worst = |d: &[(u32, f64, f64)]| d.iter().map(|v| v.1).fold(0.0, f64::max);
    eprintln!(
        "gain screen: worst ΔY from the camera position {:.2} %, head-on {:.2} %",
        worst(&from_camera),
        worst(&from_front)
    );
    assert!(
        worst(&from_camera) <= 2.5,
        "from the camera position {}",
        worst(&from_camera)
    );
    assert!(
        worst(&from_front) > 2.0 * worst(&from_camera),
        "the viewer position made no difference"
    );
}
