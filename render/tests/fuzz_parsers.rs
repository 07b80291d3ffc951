//! Fuzz targets for the renderer's parsers (issue 9): the scene TOML, OBJ geometry
//! (through the scene loader), IES LM-63, EULUMDAT, and the post pass's image readers
//! (OpenEXR and PNG, headers and pixels).
//!
//! The harness is the workspace's shared one (`fuzz/mutate.rs`, see `fuzz/README.md`):
//! every corpus file of `fuzz/corpus/<parser>/` first as it is, then proptest-made
//! mutations for `LUMIWALL_FUZZ_SECONDS` (default 5, as in CI). Every case must end
//! without panicking or hanging, with either a typed error or a result whose every
//! float is finite (and within the documented ceilings).

use std::path::Path;

use lumiwall_render::photometry::IntensityDistribution;
use lumiwall_render::scene::{
    LightKind, MAX_INTENSITY_CD, MAX_LUMINANCE_CD_M2, Scene, V3, parse_scene_toml,
};

#[path = "../../fuzz/mutate.rs"]
#[allow(
    dead_code,
    reason = "each fuzz test binary uses only part of the harness"
)]
mod mutate;

use mutate::{Mutation, apply, corpus_dir, fuzz, numbers};

fn finite3(v: &V3) -> bool {
    v.iter().all(|c| c.is_finite())
}

/// Directions to probe distributions and lights with.
fn probe_directions() -> Vec<[f64; 3]> {
    let mut d = Vec::new();
    for i in 0..7 {
        for j in 0..12 {
            let g = std::f64::consts::PI * i as f64 / 6.0;
            let c = std::f64::consts::TAU * j as f64 / 12.0;
            d.push([g.sin() * c.cos(), g.sin() * c.sin(), -g.cos()]);
        }
    }
    d
}

/// Every float of a loaded scene is finite and within the documented ceilings.
fn validate_scene(s: &Scene) -> Result<(), String> {
    if s.polygons.is_empty() {
        return Err("a scene without polygons was accepted".into());
    }
    for p in &s.polygons {
        if p.vertices.len() < 3 || !p.vertices.iter().all(finite3) {
            return Err(format!(
                "polygon of `{}` is not finite or degenerate",
                p.object
            ));
        }
        if p.material >= s.materials.len() {
            return Err(format!("polygon of `{}` has no material", p.object));
        }
    }
    for m in &s.materials {
        if !m.reflectance_xyz.iter().all(|r| (0.0..1.0).contains(r)) {
            return Err(format!(
                "material `{}` reflectance {:?}",
                m.name, m.reflectance_xyz
            ));
        }
        if !m.emission_cd_m2.iter().all(|e| e.is_finite() && *e >= 0.0)
            || m.emission_cd_m2[1] > MAX_LUMINANCE_CD_M2
        {
            return Err(format!(
                "material `{}` emission {:?}",
                m.name, m.emission_cd_m2
            ));
        }
    }
    for l in &s.lights {
        if !finite3(&l.position) || !l.color_xyz.iter().all(|c| c.is_finite()) {
            return Err(format!("light `{}` position or colour not finite", l.name));
        }
        if let LightKind::Spot { axis, .. } = &l.kind
            && !(finite3(axis) && (axis.norm() - 1.0).abs() < 1e-9)
        {
            return Err(format!("spot `{}` axis {axis:?}", l.name));
        }
        let flux = l.total_flux_lm();
        if !(flux.is_finite() && flux >= 0.0) {
            return Err(format!("light `{}` flux {flux}", l.name));
        }
        for d in probe_directions() {
            let i = l.intensity_cd(&V3::new(d[0], d[1], d[2]));
            if !(i.is_finite() && (0.0..=MAX_INTENSITY_CD * (1.0 + 1e-9)).contains(&i)) {
                return Err(format!("light `{}` intensity {i} towards {d:?}", l.name));
            }
        }
    }
    if let Some(c) = &s.camera {
        let fwd = c.look_at - c.position;
        if !(finite3(&c.position) && finite3(&c.look_at) && finite3(&c.up))
            || fwd.norm() <= 0.0
            || fwd.normalize().cross(&c.up.normalize()).norm() <= 0.0
            || !(c.vfov_deg > 0.0 && c.vfov_deg < 180.0)
            || u64::from(c.width_px) * u64::from(c.height_px)
                > lumiwall_render::scene::MAX_CAMERA_PIXELS
        {
            return Err(format!("camera {c:?}"));
        }
    }
    if let Some(sky) = &s.sky {
        for src in sky.sources() {
            if !(finite3(&src.direction)
                && src.normal_illuminance_lux.is_finite()
                && src.color_xyz.iter().all(|c| c.is_finite()))
            {
                return Err(format!("sky source {src:?}"));
            }
        }
    }
    let phi = s.emitted_flux_xyz_lm();
    if !phi.iter().all(|f| f.is_finite()) {
        return Err(format!("emitted flux {phi:?}"));
    }
    Ok(())
}

/// Every float a distribution reports is finite and within the ceilings.
fn validate_distribution(d: &IntensityDistribution) -> Result<(), String> {
    let flux = d.total_flux_lm();
    let peak = d.max_intensity_cd();
    if !(flux.is_finite() && flux >= 0.0) {
        return Err(format!("total flux {flux}"));
    }
    if !(peak.is_finite() && (0.0..=MAX_INTENSITY_CD).contains(&peak)) {
        return Err(format!("peak intensity {peak}"));
    }
    for f in [d.declared_flux_lm(), d.rated_lamp_flux_lm()]
        .into_iter()
        .flatten()
    {
        if !f.is_finite() {
            return Err(format!("declared/rated flux {f}"));
        }
    }
    for dir in probe_directions() {
        let i = d.intensity_cd(dir);
        if !(i.is_finite() && i >= 0.0 && i <= peak * (1.0 + 1e-9) + 1e-300) {
            return Err(format!("intensity {i} towards {dir:?} (peak {peak})"));
        }
    }
    Ok(())
}

#[test]
fn fuzz_scene_toml_parser_never_panics_and_accepts_only_finite_scenes() {
    let base = corpus_dir("scene");
    fuzz("scene", move |input| {
        let text = String::from_utf8_lossy(input);
        match parse_scene_toml(&text, &base, Path::new("fuzz.toml")) {
            Ok((scene, _)) => validate_scene(&scene),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }
    });
}

#[test]
fn fuzz_obj_geometry_through_the_scene_loader_never_panics_and_accepts_only_finite_scenes() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_path_buf();
    let toml = "geometry = \"fuzz.obj\"\ndefault_material = \"white\"\n\
                [materials.white]\nreflectance_y = 0.5\nemission_cd_m2 = 10\n";
    fuzz("obj", move |input| {
        std::fs::write(root.join("fuzz.obj"), input).map_err(|e| e.to_string())?;
        match parse_scene_toml(toml, &root, Path::new("fuzz.toml")) {
            Ok((scene, _)) => validate_scene(&scene),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }
    });
}

#[test]
fn fuzz_ies_parser_never_panics_and_accepts_only_finite_distributions() {
    fuzz("ies", |input| {
        match IntensityDistribution::from_ies_lm63(&String::from_utf8_lossy(input)) {
            Ok(d) => validate_distribution(&d),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }
    });
}

#[test]
fn fuzz_eulumdat_parser_never_panics_and_accepts_only_finite_distributions() {
    fuzz(
        "eulumdat",
        |input| match IntensityDistribution::from_eulumdat(&String::from_utf8_lossy(input)) {
            Ok(d) => validate_distribution(&d),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        },
    );
}

#[test]
fn line_mutations_duplicate_delete_and_swap_lines_and_numbers_are_found() {
    let mut m = b"x\ny".to_vec();
    apply(&mut m, &Mutation::DuplicateLine(1, 2), &[]);
    assert_eq!(m, b"x\ny\ny\ny");
    apply(&mut m, &Mutation::DeleteLine(0), &[]);
    assert_eq!(m, b"y\ny\ny");
    let mut m = b"a\nb\nc".to_vec();
    apply(&mut m, &Mutation::SwapLines(0, 5), &[]);
    assert_eq!(m, b"c\nb\na");
    assert_eq!(numbers(b"v 1e-5 -2 x3"), vec![(2, 6), (7, 9), (11, 12)]);
}

/// A frame the post pass read: within the input limits, one pixel per position, and
/// (sanitised) every value finite and non-negative.
fn validate_frame(f: &lumiwall_render::post::XyzFrame) -> Result<(), String> {
    use lumiwall_render::post::io::{MAX_INPUT_PIXELS, MAX_INPUT_SIDE};
    let (w, h) = (u64::from(f.width), u64::from(f.height));
    if w > MAX_INPUT_SIDE || h > MAX_INPUT_SIDE || w * h > MAX_INPUT_PIXELS {
        return Err(format!("a {w}×{h} frame was read"));
    }
    if f.pixels.len() as u64 != w * h {
        return Err(format!("{w}×{h} frame with {} pixels", f.pixels.len()));
    }
    if let Some(p) = f
        .pixels
        .iter()
        .find(|p| !p.iter().all(|v| v.is_finite() && *v >= 0.0))
    {
        return Err(format!("pixel {p:?} passed sanitising"));
    }
    Ok(())
}

#[test]
fn fuzz_exr_reader_never_panics_or_allocates_past_the_limits() {
    use lumiwall_render::post::io::{ReadOptions, read_exr};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fuzz.exr");
    let opts = ReadOptions {
        allow_negative: false,
        sanitize: true,
        white_for_luminance_xyz: [95.0, 100.0, 108.0],
    };
    fuzz("exr", move |input| {
        std::fs::write(&path, input).map_err(|e| e.to_string())?;
        match read_exr(&path, &opts) {
            Ok((frame, _)) => validate_frame(&frame),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }
    });
}

#[test]
fn fuzz_png_reader_never_panics_or_allocates_past_the_limits() {
    use lumiwall_render::post::io::read_png_srgb;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fuzz.png");
    let to_xyz = [
        [0.4124, 0.3576, 0.1805],
        [0.2126, 0.7152, 0.0722],
        [0.0193, 0.1192, 0.9505],
    ];
    fuzz("png", move |input| {
        std::fs::write(&path, input).map_err(|e| e.to_string())?;
        match read_png_srgb(&path, &to_xyz) {
            Ok(frame) => validate_frame(&frame),
            Err(e) if e.to_string().is_empty() => Err("an empty error message".into()),
            Err(_) => Ok(()),
        }
    });
}
