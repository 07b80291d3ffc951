//! `lumiwall commission --camera`: the camera stage after the meter (response curve,
//! registration, meter-anchored photometry, closed-loop flat fields), then the common
//! white lowered to the darkest texel and the profiles written again.

use std::path::Path;

use lumiwall_calib::camera::{FlatFieldOptions, FlatFieldOutcome, measure_flat_fields};
use lumiwall_calib::commission::CommissionOutcome;
use lumiwall_calib::spatial::{
    GridOptions, Truth, Uniformity, UniformityCost, apply_uniformity, verify_grid,
};
use lumiwall_calib::station::Station;
use lumiwall_core::files::{FolderLock, write_atomic};
use lumiwall_devices::Camera;
use lumiwall_devices::sim::VirtualCamera;
use lumiwall_profiles::{DisplayProfile, ProfileSet};

use crate::CliError;
use crate::cmd_commission::UniformityArg;

/// File of the camera stage's results in the profile folder.
pub(crate) const CAMERA_FILE: &str = "camera.json";

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
    let cam = open_camera(station, choice, noiseless)?;
    let info = cam.info();
    if !info.manual_exposure {
        return Err(CliError::input(format!(
            "camera {choice}: {}",
            lumiwall_devices::DeviceError::AutoExposureOnly(info.name)
        )));
    }
    Ok(())
}

/// Runs the camera stage on a commissioned wall and rewrites its profiles.
pub(crate) fn run(
    station: &mut Station,
    outcome: &CommissionOutcome,
    out: &Path,
    choice: &str,
    noiseless: bool,
    uniformity: UniformityArg,
) -> Result<(), CliError> {
    let _lock =
        FolderLock::acquire(out, "camera stage").map_err(|e| CliError::input(e.to_string()))?;
    let mut cam = open_camera(station, choice, noiseless)?;
    let displays = station.displays();
    let mut profiles = outcome.solution.profiles.clone();
    let grid = GridOptions::default();
    let virtual_wall = choice == "virtual";
    let before = virtual_wall
        .then(|| verify_grid(&mut Truth(&station.wall), &displays, &profiles, &grid))
        .transpose()
        .map_err(CliError::failure)?;
    let flats = measure_flat_fields(
        cam.as_mut(),
        &mut station.rig(),
        &displays,
        &profiles,
        &FlatFieldOptions::default(),
        &mut |line| println!("{line}"),
    )
    .map_err(|e| CliError::failure(e.to_string()))?;
    for (p, f) in profiles.iter_mut().zip(&flats.displays) {
        p.flat_field = Some(f.flat.clone());
    }
    let wf = station.wall.wall_file();
    let mode = match uniformity {
        UniformityArg::Strict => Uniformity::Strict,
        UniformityArg::Perceptual => Uniformity::PERCEPTUAL_DEFAULT,
    };
    let cost = apply_uniformity(
        &mut profiles,
        mode,
        [wf.tiles.cols, wf.tiles.rows],
        [wf.tiles.width_m, wf.tiles.height_m],
    );
    print_stage(&flats, cost, mode);
    if let Some(before) = before {
        let after = verify_grid(&mut Truth(&station.wall), &displays, &profiles, &grid)
            .map_err(CliError::failure)?;
        println!(
            "5x5 grid as the simulator sees it, before the flat field: {}",
            before.overall_line()
        );
        println!(
            "5x5 grid as the simulator sees it, after the flat field:  {}",
            after.overall_line()
        );
    }
    save(out, &outcome.wall, &profiles, &flats)
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
    let json = serde_json::to_vec_pretty(flats).map_err(|e| CliError::failure(e.to_string()))?;
    write_atomic(&out.join(CAMERA_FILE), &json)
        .map_err(|e| CliError::failure(format!("cannot write {CAMERA_FILE}: {e}")))?;
    println!(
        "profiles with flat fields: {}/{}",
        out.display(),
        ProfileSet::MANIFEST
    );
    println!("camera calibration: {}/{CAMERA_FILE}", out.display());
    Ok(())
}
