//! `lumiwall commission --camera`: the camera stage after the meter (response curve,
//! registration, meter-anchored photometry, closed-loop flat fields), then the common
//! white lowered to the darkest texel and the profiles written again.

use std::path::Path;

use lumiwall_calib::camera::{Checkpoint, FlatFieldOptions, FlatFieldOutcome, measure_flat_fields};
use lumiwall_calib::commission::CommissionOutcome;
use lumiwall_calib::commission::final_white::resample_at_final_white;
use lumiwall_calib::spatial::{
    GridOptions, SpatialReport, Truth, Uniformity, UniformityCost, apply_uniformity, verify_grid,
};
use lumiwall_calib::station::Station;
use lumiwall_core::files::{FolderLock, write_atomic};
use lumiwall_devices::Camera;
use lumiwall_devices::sim::{VirtualCamera, WallFile};
use lumiwall_profiles::{DisplayProfile, ProfileSet};

use crate::CliError;
use crate::cmd_commission::{CommissionArgs, NoiseArg, UniformityArg};

use crate::cmd_commission::CAMERA_FILE;

/// The camera stage of the commissioning in the profile folder `dir` (its
/// camera.json), for the nightly check.
pub(crate) fn load_stage(dir: &Path) -> Result<FlatFieldOutcome, CliError> {
    let path = dir.join(CAMERA_FILE);
    let text = std::fs::read(&path).map_err(|e| {
        CliError::input(format!(
            "--camera: cannot read {} ({e}); the nightly camera check needs the camera \
             calibration of `lumiwall commission --camera`",
            path.display()
        ))
    })?;
    serde_json::from_slice(&text)
        .map_err(|e| CliError::input(format!("{}: not a camera stage: {e}", path.display())))
}

/// Writes the camera stage (tonight's refitted flat fields in it) back to camera.json.
pub(crate) fn save_stage(dir: &Path, stage: &FlatFieldOutcome) -> Result<(), CliError> {
    let json = serde_json::to_vec_pretty(stage).map_err(|e| CliError::failure(e.to_string()))?;
    write_atomic(&dir.join(CAMERA_FILE), &json)
        .map_err(|e| CliError::failure(format!("cannot write {CAMERA_FILE}: {e}")))
}

/// Opens the camera `choice` names and checks it can take photometric frames.
pub(crate) fn open_photometric(
    station: &Station,
    choice: &str,
    noiseless: bool,
) -> Result<Box<dyn Camera>, CliError> {
    let cam = open_camera(station, choice, noiseless)?;
    refuse_auto_exposure(cam.as_ref(), choice)?;
    Ok(cam)
}

fn refuse_auto_exposure(cam: &dyn Camera, choice: &str) -> Result<(), CliError> {
    let info = cam.info();
    if !info.manual_exposure {
        return Err(CliError::input(format!(
            "camera {choice}: {}",
            lumiwall_devices::DeviceError::AutoExposureOnly(info.name)
        )));
    }
    Ok(())
}

/// Opens the camera `choice` names: `virtual` (the wall's simulated camera; noiseless
/// with `noiseless`) or a device (index, `/dev/videoN` or name).
fn open_camera(
    station: &Station,
    choice: &str,
    noiseless: bool,
) -> Result<Box<dyn Camera>, CliError> {
    if choice == "virtual" {
        let cam = VirtualCamera::new(&station.wall, !noiseless)
            .map_err(|e| CliError::input(format!("virtual camera: {e}")))?;
        return Ok(Box::new(cam));
    }
    let cam = lumiwall_devices::uvc::UvcCamera::open(choice)
        .map_err(|e| CliError::failure(format!("camera {choice}: {e}")))?;
    Ok(Box::new(cam))
}

/// Opens the camera and checks it can take photometric frames (manual exposure).
pub(crate) fn check(station: &Station, choice: &str, noiseless: bool) -> Result<(), CliError> {
    open_photometric(station, choice, noiseless).map(|_| ())
}

/// Folder (inside the profile folder) where the camera stage keeps what it has
/// finished, for `--resume`.
pub(crate) const CAMERA_RUN_DIR: &str = "camera-run";

/// Runs the camera stage on a commissioned wall and rewrites its profiles; with
/// `resume`, continues a stopped camera stage from its checkpoint.
pub(crate) fn run(
    station: &mut Station,
    outcome: &CommissionOutcome,
    args: &CommissionArgs,
    choice: &str,
) -> Result<(), CliError> {
    let out = args.out.as_path();
    let noiseless = matches!(args.meter.noise, NoiseArg::None);
    let resume = args.resume;
    let _lock =
        FolderLock::acquire(out, "camera stage").map_err(|e| CliError::input(e.to_string()))?;
    let mut cam = open_camera(station, choice, noiseless)?;
    let displays = station.displays();
    let profiles = &outcome.solution.profiles;
    let grid = GridOptions::default();
    let virtual_wall = choice == "virtual";
    let before = virtual_wall
        .then(|| verify_grid(&mut Truth(&station.wall), &displays, profiles, &grid))
        .transpose()
        .map_err(CliError::failure)?;
    let flats = measure_flat_fields(
        cam.as_mut(),
        &mut station.rig(),
        &displays,
        profiles,
        &FlatFieldOptions {
            checkpoint: Some(Checkpoint::new(out.join(CAMERA_RUN_DIR))),
            resume,
            ..FlatFieldOptions::default()
        },
        &mut |line| println!("{line}"),
    )
    .map_err(|e| {
        CliError::failure(format!(
            "{e}\n(what the camera stage finished is kept in {}; re-run with --resume)",
            out.join(CAMERA_RUN_DIR).display()
        ))
    })?;
    let mode = match args.uniformity {
        UniformityArg::Strict => Uniformity::Strict,
        UniformityArg::Perceptual => Uniformity::PERCEPTUAL_DEFAULT,
    };
    let (profiles, cost) = final_profiles(station, outcome, args, &flats, mode)?;
    print_stage(&flats, cost, mode);
    let after = virtual_wall
        .then(|| verify_grid(&mut Truth(&station.wall), &displays, &profiles, &grid))
        .transpose()
        .map_err(CliError::failure)?;
    if let (Some(b), Some(a)) = (&before, &after) {
        println!(
            "5x5 grid as the simulator sees it, before the flat field: {}",
            b.overall_line()
        );
        println!(
            "5x5 grid as the simulator sees it, after the flat field:  {}",
            a.overall_line()
        );
    }
    save(out, &outcome.wall, &profiles, &flats)?;
    append_report(
        out,
        &flats,
        cost,
        mode,
        before.as_ref().zip(after.as_ref()),
        tile_grid(station),
    )
}

/// The wall's tile grid (columns, rows).
fn tile_grid(station: &Station) -> [u32; 2] {
    let wf = station.wall.wall_file();
    [wf.tiles.cols, wf.tiles.rows]
}

/// The profiles the camera stage writes: the flat fields and the uniformity choice
/// applied, the tone curves read again at the white that leaves
/// ([`resample_at_final_white`]) and the wall solved again, then the flat fields and
/// the uniformity applied to the new solution; with what the uniformity cost.
fn final_profiles(
    station: &mut Station,
    outcome: &CommissionOutcome,
    args: &CommissionArgs,
    flats: &FlatFieldOutcome,
    mode: Uniformity,
) -> Result<(Vec<DisplayProfile>, UniformityCost), CliError> {
    let wall = station.wall.wall_file();
    let mut profiles = outcome.solution.profiles.clone();
    with_flat_fields(&mut profiles, flats, mode, &wall);
    let displays = station.displays();
    let resampled = resample_at_final_white(
        &displays,
        &mut station.rig(),
        outcome,
        &profiles,
        &args.commission_options()?,
        &mut |_| {},
    )
    .map_err(|e| CliError::failure(e.to_string()))?;
    if resampled.readings > 0 {
        println!(
            "tone curves read again at the final white: {} readings over the wall, wall solved \
             again",
            resampled.readings
        );
    }
    let mut profiles = resampled.outcome.solution.profiles;
    let cost = with_flat_fields(&mut profiles, flats, mode, &wall);
    Ok((profiles, cost))
}

/// Puts each display's flat field into its profile and applies the uniformity choice
/// over the tiles of `wall`.
fn with_flat_fields(
    profiles: &mut [DisplayProfile],
    flats: &FlatFieldOutcome,
    mode: Uniformity,
    wall: &WallFile,
) -> UniformityCost {
    for (p, f) in profiles.iter_mut().zip(&flats.displays) {
        p.flat_field = Some(f.flat.clone());
    }
    let t = &wall.tiles;
    apply_uniformity(profiles, mode, [t.cols, t.rows], [t.width_m, t.height_m])
}

/// Appends the camera stage to `report.md` and writes its pictures beside it: the
/// response curves and (virtual wall) the 5×5 heat maps before and after.
fn append_report(
    out: &Path,
    flats: &FlatFieldOutcome,
    cost: UniformityCost,
    mode: Uniformity,
    grids: Option<(&SpatialReport, &SpatialReport)>,
    tiles: [u32; 2],
) -> Result<(), CliError> {
    let write = |name: &str, text: &str| {
        write_atomic(&out.join(name), text.as_bytes())
            .map_err(|e| CliError::failure(format!("cannot write {name}: {e}")))
    };
    let response = response_svg(&flats.response);
    write("response-curve.svg", &response)?;
    let mut figures = vec![(
        "camera response curves (ln exposure against code)".to_string(),
        response,
    )];
    let (dy, dxy) = flats.photometry.worst();
    let (ay, axy) = flats.photometry.worst_all();
    let mut md = format!(
        "\n## Camera stage\n\n![response curves](response-curve.svg)\n\n\
         - response curve: {} exposures, {} sampled pixels (Debevec–Malik, codes 15..250)\n\
         - registration: reprojection error rms {:.3} px, max {:.3} px; distortion κ {:?}\n\
         - camera vs meter at the white spots (each predicted from its display's other spots): worst ΔY {dy:.2} %, Δxy {dxy:.4}; all patterns ΔY {ay:.2} %, Δxy {axy:.4}\n\
         - camera vignetting correction exp({:.4}ρ² + {:.4}ρ⁴); camera moved {:.2} px during the stage\n\
         - uniformity {mode:?}: solved white {:.2} cd/m², strict {:.2}, perceptual mean {:.2} (min {:.2})\n\
         - the flat fields are right for the camera's position; on a gain screen another viewer sees another hotspot\n\
         - {:.1} s\n\n| display | iterations R/G/B | RMS residual before → after | frames |\n|---|---|---|---|\n",
        flats.response.exposures_s.len(),
        flats.response.samples,
        flats.registration.rms_px,
        flats.registration.max_px,
        flats.registration.kappa,
        flats.photometry.vignetting[0],
        flats.photometry.vignetting[1],
        flats.movement_px,
        cost.solved_cd_m2,
        cost.strict_cd_m2,
        cost.perceptual_mean_cd_m2,
        cost.perceptual_min_cd_m2,
        flats.seconds,
    );
    md.push_str(&display_rows(flats));
    if let Some((b, a)) = grids {
        let (before, after) = (b.heat_map_svg(tiles, [5, 5]), a.heat_map_svg(tiles, [5, 5]));
        write("uniformity-before.svg", &before)?;
        write("uniformity-after.svg", &after)?;
        figures.push(("ΔE2000 per 5×5 cell before the flat field".into(), before));
        figures.push(("ΔE2000 per 5×5 cell after the flat field".into(), after));
        md.push_str(&format!(
            "\nAs the simulator sees it (5×5 grid per display):\n\n- before: `{}`\n- after: `{}`\n\n\
             ![before](uniformity-before.svg) ![after](uniformity-after.svg)\n",
            b.overall_line(),
            a.overall_line()
        ));
    }
    let path = out.join("report.md");
    let mut text = std::fs::read_to_string(&path).unwrap_or_default();
    text.push_str(&md);
    write("report.md", &text)?;
    let page = std::fs::read_to_string(out.join("report.html")).unwrap_or_default();
    let figures: Vec<(&str, &str)> = figures
        .iter()
        .map(|(c, s)| (c.as_str(), s.as_str()))
        .collect();
    write(
        "report.html",
        &lumiwall_calib::report::html_with_section(&page, &md, &figures),
    )
}

/// The report table's rows: per display its iterations, residuals and frames.
fn display_rows(flats: &FlatFieldOutcome) -> String {
    let worst = |r: [f64; 3]| 100.0 * r.iter().copied().fold(0.0, f64::max);
    flats
        .displays
        .iter()
        .map(|d| {
            format!(
                "| {} | {:?} | {:.2} % → {:.2} % | {} |\n",
                d.name,
                d.iterations,
                worst(d.residual_open),
                worst(d.residual_final),
                d.frames
            )
        })
        .collect()
}

/// The response curves as an SVG plot: ln relative exposure against code, R, G, B.
fn response_svg(r: &lumiwall_calib::camera::ResponseCurve) -> String {
    let (w, h) = (420.0, 260.0);
    let all: Vec<f64> = r
        .ln_exposure
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let lo = all.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let span = (hi - lo).max(1e-9);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"30\" y=\"14\">camera response: ln relative exposure (up) against code 0..255</text>\n"
    );
    for (c, colour) in ["#c00", "#080", "#00c"].iter().enumerate() {
        let pts: Vec<String> = r.ln_exposure[c]
            .iter()
            .enumerate()
            .map(|(z, v)| {
                format!(
                    "{:.1},{:.1}",
                    30.0 + z as f64 * (w - 40.0) / 255.0,
                    h - 20.0 - (v - lo) / span * (h - 40.0)
                )
            })
            .collect();
        svg.push_str(&format!(
            "<polyline fill=\"none\" stroke=\"{colour}\" points=\"{}\"/>\n",
            pts.join(" ")
        ));
    }
    svg.push_str("</svg>\n");
    svg
}

fn print_stage(flats: &FlatFieldOutcome, cost: UniformityCost, mode: Uniformity) {
    let frames: Vec<u32> = flats.displays.iter().map(|d| d.frames).collect();
    let iters = flats
        .displays
        .iter()
        .flat_map(|d| d.iterations)
        .max()
        .unwrap_or(0);
    let (dy, dxy) = flats.photometry.worst();
    println!(
        "camera stage: {:.1} s, frames per display {}..{}, closed-loop iterations at most {iters}, \
         registration rms {:.3} px, camera vs meter worst ΔY {dy:.2} % Δxy {dxy:.4}, camera moved {:.2} px",
        flats.seconds,
        frames.iter().min().unwrap_or(&0),
        frames.iter().max().unwrap_or(&0),
        flats.registration.rms_px,
        flats.movement_px
    );
    let solved = cost.solved_cd_m2.max(1e-12);
    println!(
        "uniformity: solved white {:.2} cd/m²; strict keeps {:.2} cd/m² everywhere (costs {:.2} cd/m², {:.1} %); \
         perceptual keeps {:.2} cd/m² on average, {:.2} at the darkest point (costs {:.2} cd/m² on average)",
        cost.solved_cd_m2,
        cost.strict_cd_m2,
        cost.solved_cd_m2 - cost.strict_cd_m2,
        100.0 * (1.0 - cost.strict_cd_m2 / solved),
        cost.perceptual_mean_cd_m2,
        cost.perceptual_min_cd_m2,
        cost.solved_cd_m2 - cost.perceptual_mean_cd_m2
    );
    match mode {
        Uniformity::Strict => println!("applied: strict"),
        Uniformity::Perceptual { .. } => println!(
            "applied: perceptual (verify --grid compares with one uniform white, so it shows the designed gradient as ΔE)"
        ),
    }
}

fn save(
    out: &Path,
    wall: &str,
    profiles: &[DisplayProfile],
    flats: &FlatFieldOutcome,
) -> Result<(), CliError> {
    ProfileSet::save_dir(out, wall, profiles).map_err(|e| {
        CliError::failure(format!("cannot write the profiles with flat fields: {e}"))
    })?;
    save_stage(out, flats)?;
    println!(
        "profiles with flat fields: {}/{}",
        out.display(),
        ProfileSet::MANIFEST
    );
    println!("camera calibration: {}/{CAMERA_FILE}", out.display());
    Ok(())
}
