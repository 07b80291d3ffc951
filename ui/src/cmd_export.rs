//! `lumiwall export`: a commissioning's results in formats other tools read:
//! `--format ti3`, each display's measurements as an ArgyllCMS `.ti3` (`colprof`,
//! `profcheck`, DisplayCAL); `--format cube`, each display's profile as a `.cube` 3D LUT
//! (media servers, projectors); `--format argyll-cal`, each display's grey axis as
//! ArgyllCMS `.cal` curves; `--format mpcdi`, the whole wall as a VESA MPCDI v2.0
//! package.

use std::path::PathBuf;

use lumiwall_calib::commission::load_measurement;
use lumiwall_calib::export::cal::to_cal;
use lumiwall_calib::export::cube::{CUBE_INPUT_GAMMA, CUBE_SIZES, to_cube};
use lumiwall_calib::export::mpcdi::{MpcdiOptions, to_mpcdi};
use lumiwall_calib::export::ti3::to_ti3;
use lumiwall_profiles::{DisplayProfile, ProfileSet};

use crate::CliError;
use crate::values;

/// Export formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Format {
    /// ArgyllCMS `.ti3`: RGB → XYZ of every sample as read (the mean of its readings),
    /// one file per display and eye.
    Ti3,
    /// `.cube` 3D LUT: common-gamut RGB (encoded with a 2.2 power, 1 = the target
    /// white) → the post pass's drive at the display centre, one file per display and eye.
    Cube,
    /// ArgyllCMS `.cal`: per-channel curves of the grey axis (the `.cube`'s R = G = B),
    /// for a video card's gamma table; one file per display and eye.
    ArgyllCal,
    /// VESA MPCDI v2.0 package (`<wall>.mpcdi`): profile 2d, colour level 4 (5 with a
    /// DLP white segment): RGB alpha maps from the flat fields, beta maps from the
    /// black handling, 1D LUTs and 3×3 primaries; measurements in an extension.
    Mpcdi,
}

/// Arguments of `lumiwall export`.
#[derive(Debug, clap::Args)]
pub(crate) struct ExportArgs {
    /// What to write.
    #[arg(long, value_enum)]
    format: Format,
    /// A commissioning's output folder (`commission --out`).
    #[arg(long)]
    commission: PathBuf,
    /// Folder the files go to (created if missing).
    #[arg(long)]
    out_dir: PathBuf,
    /// Grid points per axis of a `.cube` (2..=129).
    #[arg(long, default_value_t = 65)]
    cube_size: usize,
    /// Each projector's raster for `--format mpcdi`, WIDTHxHEIGHT (e.g. 1920x1200).
    #[arg(long, value_parser = parse_raster)]
    projector_resolution: Option<[u32; 2]>,
}

/// Parses `WIDTHxHEIGHT`.
fn parse_raster(s: &str) -> Result<[u32; 2], String> {
    let bad = || format!("`{s}` is not WIDTHxHEIGHT in pixels, e.g. 1920x1200");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let max = lumiwall_calib::export::mpcdi::MAX_REGION_PX;
    let px = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|p| (2..=max).contains(p))
            .ok_or_else(|| format!("{} (each side 2..={max})", bad()))
    };
    Ok([px(w)?, px(h)?])
}

/// Runs `lumiwall export`.
pub(crate) fn run(args: ExportArgs) -> Result<(), CliError> {
    match args.format {
        Format::Ti3 => run_ti3(&args),
        Format::Cube => run_cube(&args),
        Format::ArgyllCal => run_cal(&args),
        Format::Mpcdi => run_mpcdi(&args),
    }
}

/// `--format mpcdi`: the whole wall as one `<wall>.mpcdi`, with the last verification
/// (`verify.json` in the profile folder) when there is one.
fn run_mpcdi(args: &ExportArgs) -> Result<(), CliError> {
    let Some(region_px) = args.projector_resolution else {
        return Err(CliError::input(
            "--format mpcdi needs each projector's raster: --projector-resolution 1920x1200"
                .to_string(),
        ));
    };
    let (wall, profiles) = ProfileSet::load_dir(&args.commission)?;
    values::check_output_dir("--out-dir", &args.out_dir)?;
    let verification = load_verification(&args.commission);
    let options = MpcdiOptions {
        region_px,
        date: mpcdi_now(),
        verification,
    };
    let package =
        to_mpcdi(&wall, &profiles, &options).map_err(|e| CliError::input(e.to_string()))?;
    std::fs::create_dir_all(&args.out_dir)?;
    let name: String = wall
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    let path = args.out_dir.join(format!("{name}.mpcdi"));
    lumiwall_profiles::write_atomic(&path, &package.bytes)
        .map_err(|e| CliError::failure(format!("cannot write {}: {e}", path.display())))?;
    println!(
        "written: {} (MPCDI 2.0, profile 2d, colour level {}, {} regions{})",
        path.display(),
        package.color_level,
        package.regions,
        if options.verification.is_some() {
            ", with the last verification"
        } else {
            ""
        }
    );
    println!("  note: geometry is each tile's nominal rectangle (lumiwall calibrates no warp)");
    if package.largest_scale > 1.0 {
        println!(
            "  note: encode LUTs scale their input by up to {:.4} (linear values above 1 \
             before the white-segment step or the black offset)",
            package.largest_scale
        );
    }
    Ok(())
}

/// The profile folder's last verification, summarised for the MPCDI extension; an
/// unreadable one is left out with a warning.
fn load_verification(dir: &std::path::Path) -> Option<serde_json::Value> {
    let path = dir.join(crate::cmd_verify::VERIFY_FILE);
    let parsed = std::fs::read_to_string(&path).map(|text| {
        serde_json::from_str::<lumiwall_calib::verify::VerifyReport>(&text)
            .map_err(|e| e.to_string())
    });
    let report = match parsed {
        Ok(Ok(r)) => r,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
        Err(e) => return warn_unreadable(&path, &e.to_string()),
        Ok(Err(e)) => return warn_unreadable(&path, &e),
    };
    Some(serde_json::json!({
        "patches_per_display": report.targets.len(),
        "readings": report.readings,
        "meter_readings_per_reading": report.readings_per_reading,
        "overall": report.overall,
        "per_display": report.per_display.iter().map(|(k, s)| serde_json::json!({
            "display": k.file_stem(), "summary": s
        })).collect::<Vec<_>>(),
        "eyes_delta_e2000": report.eyes_delta_e2000,
    }))
}

fn warn_unreadable(path: &std::path::Path, why: &str) -> Option<serde_json::Value> {
    println!(
        "  warning: {} is unreadable ({why}); the package goes without a verification",
        path.display()
    );
    None
}

/// Now as `yyyy-MM-dd HH:mm:ss` (UTC), MPCDI's date format.
fn mpcdi_now() -> String {
    lumiwall_calib::solve::now_rfc3339()
        .replace('T', " ")
        .chars()
        .take(19)
        .collect()
}

/// `--format argyll-cal`: one `.cal` per profile of the commissioning's profile folder.
fn run_cal(args: &ExportArgs) -> Result<(), CliError> {
    let created = lumiwall_calib::solve::now_rfc3339();
    let what = format!("ArgyllCMS .cal (grey axis: the target white at v^{CUBE_INPUT_GAMMA})");
    export_profiles(args, &what, "cal", |profile| {
        let text = to_cal(profile, &created).map_err(|e| CliError::input(e.to_string()))?;
        Ok((text, None))
    })
}

/// `--format cube`: one `.cube` per profile of the commissioning's profile folder.
fn run_cube(args: &ExportArgs) -> Result<(), CliError> {
    if !CUBE_SIZES.contains(&args.cube_size) {
        return Err(CliError::input(format!(
            "--cube-size {} is outside {}..={}",
            args.cube_size,
            CUBE_SIZES.start(),
            CUBE_SIZES.end()
        )));
    }
    let what = format!(
        "{}³ .cube (input: common-gamut RGB, linear = e^{CUBE_INPUT_GAMMA})",
        args.cube_size
    );
    export_profiles(args, &what, "cube", |profile| {
        let cube = to_cube(profile, args.cube_size).map_err(|e| CliError::input(e.to_string()))?;
        let note = cube.flat_field_left_out.then_some(
            "its flat field is not in the .cube (a uniform LUT: the display centre's drives)",
        );
        Ok((cube.text, note))
    })
}

/// Writes one `<display>.<extension>` per profile of the commissioning's profile
/// folder into `--out-dir`, each atomically: `make` gives its text and, where the
/// format leaves something of the profile out, a note saying what.
fn export_profiles(
    args: &ExportArgs,
    what: &str,
    extension: &str,
    make: impl Fn(&DisplayProfile) -> Result<(String, Option<&'static str>), CliError>,
) -> Result<(), CliError> {
    let (wall, profiles) = ProfileSet::load_dir(&args.commission)?;
    values::check_output_dir("--out-dir", &args.out_dir)?;
    std::fs::create_dir_all(&args.out_dir)?;
    println!("wall {wall}: {} profiles → {what}", profiles.len());
    for profile in &profiles {
        let (text, note) = make(profile)?;
        let path = args
            .out_dir
            .join(format!("{}.{extension}", profile.display.file_stem()));
        lumiwall_profiles::write_atomic(&path, text.as_bytes())
            .map_err(|e| CliError::failure(format!("cannot write {}: {e}", path.display())))?;
        println!("written: {}", path.display());
        if let Some(note) = note {
            println!("  note: {note}");
        }
    }
    Ok(())
}

/// `--format ti3`: one `.ti3` per display measurement of the commissioning.
fn run_ti3(args: &ExportArgs) -> Result<(), CliError> {
    let run_dir = args.commission.join("run");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&run_dir)
        .map_err(|e| {
            CliError::input(format!(
                "{}: {e}; give the folder `lumiwall commission --out` wrote",
                run_dir.display()
            ))
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().ends_with(".measurement.json"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(CliError::input(format!(
            "{} holds no display measurements",
            run_dir.display()
        )));
    }
    values::check_output_dir("--out-dir", &args.out_dir)?;
    std::fs::create_dir_all(&args.out_dir)?;
    let created = lumiwall_calib::solve::now_rfc3339();
    for f in files {
        let Some(measured) = load_measurement(&f).map_err(|e| CliError::input(e.to_string()))?
        else {
            continue;
        };
        let m = &measured.measurement;
        let text = to_ti3(&measured, &created).map_err(|e| CliError::input(e.to_string()))?;
        if lumiwall_calib::export::ti3::refitted_since_read(&measured) {
            eprintln!(
                "lumiwall: warning: {}: refitted by a nightly recalibration since it was \
                 measured; the .ti3 holds the commissioning's readings, not the ones the \
                 profile stands on now",
                m.key
            );
        }
        let path = args.out_dir.join(format!("{}.ti3", m.key.file_stem()));
        lumiwall_profiles::write_atomic(&path, text.as_bytes())
            .map_err(|e| CliError::failure(format!("cannot write {}: {e}", path.display())))?;
        println!(
            "written: {} ({} samples as read)",
            path.display(),
            text.lines()
                .filter(|l| l.chars().next().is_some_and(|c| c.is_ascii_digit()))
                .count()
        );
    }
    Ok(())
}
