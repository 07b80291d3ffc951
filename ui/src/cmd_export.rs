//! `lumiwall export`: a commissioning's results in formats other tools read:
//! `--format ti3`, each display's measurements as an ArgyllCMS `.ti3` (`colprof`,
//! `profcheck`, DisplayCAL); `--format cube`, each display's profile as a `.cube` 3D LUT
//! (media servers, projectors); `--format argyll-cal`, each display's grey axis as
//! ArgyllCMS `.cal` curves.

use std::path::PathBuf;

use lumiwall_calib::commission::load_measurement;
use lumiwall_calib::export::cal::to_cal;
use lumiwall_calib::export::cube::{CUBE_INPUT_GAMMA, CUBE_SIZES, to_cube};
use lumiwall_calib::export::ti3::to_ti3;
use lumiwall_profiles::{DisplayProfile, ProfileSet};

use crate::CliError;
use crate::values;

/// Export formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Format {
    /// ArgyllCMS `.ti3`: RGB → XYZ of every reading, one file per display and eye.
    Ti3,
    /// `.cube` 3D LUT: common-gamut RGB (encoded with a 2.2 power, 1 = the target
    /// white) → the post pass's drive at the display centre, one file per display and eye.
    Cube,
    /// ArgyllCMS `.cal`: per-channel curves of the grey axis (the `.cube`'s R = G = B),
    /// for a video card's gamma table; one file per display and eye.
    ArgyllCal,
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
}

/// Runs `lumiwall export`.
pub(crate) fn run(args: ExportArgs) -> Result<(), CliError> {
    match args.format {
        Format::Ti3 => run_ti3(&args),
        Format::Cube => run_cube(&args),
        Format::ArgyllCal => run_cal(&args),
    }
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
        let text = to_ti3(m, &created).map_err(|e| CliError::input(e.to_string()))?;
        let path = args.out_dir.join(format!("{}.ti3", m.key.file_stem()));
        lumiwall_profiles::write_atomic(&path, text.as_bytes())
            .map_err(|e| CliError::failure(format!("cannot write {}: {e}", path.display())))?;
        println!(
            "written: {} ({} readings)",
            path.display(),
            text.lines()
                .filter(|l| l.chars().next().is_some_and(|c| c.is_ascii_digit()))
                .count()
        );
    }
    Ok(())
}
