//! Issue 9, items 4, 5 and 8 (scene side): every float that reaches the camera, a
//! light or a material is refused at load time when it would give a silent wrong
//! result (black or inf image), and sizes derived from the input are refused before
//! any work, each with a message that names the field, the value and what is allowed.

use std::path::Path;

use lumiwall_render::scene::{
    MAX_CAMERA_PIXELS, MAX_COORDINATE_M, MAX_INTENSITY_CD, MAX_LUMINANCE_CD_M2, Scene, SceneError,
    parse_scene_toml,
};

fn parse(text: &str) -> Result<Scene, SceneError> {
    parse_scene_toml(text, Path::new("."), Path::new("test.toml")).map(|(s, _)| s)
}

/// A lit unit square; `extra` is appended (lights, camera, …).
fn scene(emission: &str, extra: &str) -> String {
    format!(
        r#"
[materials.lamp]
reflectance_y = 0.5
emission_cd_m2 = {emission}
[[polygons]]
material = "lamp"
vertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
{extra}"#
    )
}

fn camera(position: &str, look_at: &str, up: &str, size: (u64, u64)) -> String {
    format!(
        "[camera]\nposition = {position}\nlook_at = {look_at}\nup = {up}\nvfov_deg = 40\nwidth = {}\nheight = {}\n",
        size.0, size.1
    )
}

/// The error message, which must contain every one of `parts`.
fn refused(text: &str, parts: &[&str]) -> String {
    let e = parse(text)
        .expect_err("the scene must be refused")
        .to_string();
    for p in parts {
        assert!(e.contains(p), "message {e:?} lacks {p:?}");
    }
    e
}

const GOOD_CAMERA: (&str, &str, &str) = ("[0.5, 0.5, 3]", "[0.5, 0.5, 0]", "[0, 1, 0]");

#[test]
fn a_valid_camera_and_lights_still_load() {
    let (p, l, u) = GOOD_CAMERA;
    let s = parse(&scene(
        "100",
        &format!(
            "{}[[lights]]\ntype = \"spot\"\nposition = [0, 0, 2]\naxis = [0, 0, -1]\nintensity_cd = 100\n",
            camera(p, l, u, (64, 48))
        ),
    ))
    .unwrap();
    assert_eq!(s.camera.unwrap().width_px, 64);
    assert_eq!(s.lights.len(), 1);
}

#[test]
fn nan_or_infinite_camera_position_is_refused_naming_the_field() {
    let (_, l, u) = GOOD_CAMERA;
    for bad in ["[nan, 0.5, 3]", "[0.5, inf, 3]", "[0.5, 0.5, -inf]"] {
        refused(
            &scene("100", &camera(bad, l, u, (8, 8))),
            &["camera", "`position`", "not finite"],
        );
    }
    let (p, _, u) = GOOD_CAMERA;
    refused(
        &scene("100", &camera(p, "[nan, 0, 0]", u, (8, 8))),
        &["camera", "`look_at`", "not finite"],
    );
}

#[test]
fn camera_position_equal_to_look_at_is_refused() {
    let (p, _, u) = GOOD_CAMERA;
    refused(
        &scene("100", &camera(p, p, u, (8, 8))),
        &["camera", "same point", "look_at"],
    );
}

#[test]
fn camera_up_parallel_to_the_view_direction_or_zero_is_refused() {
    let (p, l, _) = GOOD_CAMERA;
    for up in ["[0, 0, 1]", "[0, 0, -7]"] {
        refused(
            &scene("100", &camera(p, l, up, (8, 8))),
            &["camera", "`up`", "parallel to the view direction"],
        );
    }
    refused(
        &scene("100", &camera(p, l, "[0, 0, 0]", (8, 8))),
        &["camera", "`up`", "zero length"],
    );
    refused(
        &scene("100", &camera(p, l, "[0, nan, 0]", (8, 8))),
        &["camera", "`up`", "not finite"],
    );
}

#[test]
fn camera_over_the_pixel_limit_is_refused_before_any_geometry_is_read() {
    let (p, l, u) = GOOD_CAMERA;
    let e = refused(
        &scene("100", &camera(p, l, u, (100_000, 100_000))),
        &["camera", "100000 × 100000", &MAX_CAMERA_PIXELS.to_string()],
    );
    assert!(e.contains("lower width or height"), "{e}");
    // before the geometry: a missing OBJ is not even looked at
    let text = format!(
        "geometry = \"does-not-exist.obj\"\n{}",
        scene("100", &camera(p, l, u, (100_000, 100_000)))
    );
    assert!(parse(&text).unwrap_err().to_string().contains("pixels"));
    // zero size too
    refused(
        &scene("100", &camera(p, l, u, (0, 10))),
        &["camera", "0 × 10"],
    );
    // the limit itself is accepted
    let side = 1u64 << 13;
    assert_eq!(side * side, MAX_CAMERA_PIXELS);
    parse(&scene("100", &camera(p, l, u, (side, side)))).unwrap();
}

#[test]
fn spot_light_with_nan_infinite_or_zero_axis_is_refused() {
    for (axis, why) in [
        ("[nan, 0, -1]", "not finite"),
        ("[0, 0, -inf]", "not finite"),
        ("[0, 0, 0]", "zero length"),
    ] {
        refused(
            &scene(
                "100",
                &format!(
                    "[[lights]]\nname = \"s1\"\ntype = \"spot\"\nposition = [0, 0, 2]\naxis = {axis}\nintensity_cd = 100\n"
                ),
            ),
            &["light `s1`", "`axis`", why],
        );
    }
    // NaN cone angles name both values
    refused(
        &scene(
            "100",
            "[[lights]]\nname = \"s2\"\ntype = \"spot\"\nposition = [0, 0, 2]\naxis = [0, 0, -1]\nintensity_cd = 100\ninner_deg = nan\n",
        ),
        &[
            "light `s2`",
            "inner_deg = NaN",
            "0 < inner_deg ≤ outer_deg ≤ 180",
        ],
    );
}

#[test]
fn emission_above_the_physical_ceiling_is_refused_so_no_inf_pixel_is_written() {
    for e in ["1e300", "inf", "1.1e12"] {
        refused(
            &scene(e, ""),
            &["material `lamp`", "emission", "at most 1e12 cd/m²"],
        );
    }
    assert_eq!(MAX_LUMINANCE_CD_M2, 1e12);
    // the ceiling itself loads, and the emitted flux stays finite
    let s = parse(&scene("1e12", "")).unwrap();
    assert!(s.emitted_flux_xyz_lm().iter().all(|f| f.is_finite()));
}

#[test]
fn light_intensity_or_flux_above_the_ceiling_or_not_finite_is_refused() {
    for (field, v, part) in [
        ("intensity_cd", "1e300", "at most 1e12 cd"),
        ("intensity_cd", "nan", "at most 1e12 cd"),
        ("flux_lm", "1e300", "lm"),
        ("flux_lm", "-inf", "lm"),
    ] {
        refused(
            &scene(
                "100",
                &format!(
                    "[[lights]]\nname = \"p\"\ntype = \"point\"\nposition = [0, 0, 2]\n{field} = {v}\n"
                ),
            ),
            &["light `p`", part],
        );
    }
    assert_eq!(MAX_INTENSITY_CD, 1e12);
}

#[test]
fn light_position_not_finite_or_beyond_the_coordinate_limit_is_refused() {
    for pos in ["[nan, 0, 2]", "[0, 0, 1e300]"] {
        refused(
            &scene(
                "100",
                &format!(
                    "[[lights]]\nname = \"p\"\ntype = \"point\"\nposition = {pos}\nintensity_cd = 1\n"
                ),
            ),
            &["light `p`", "`position`"],
        );
    }
    assert_eq!(MAX_COORDINATE_M, 1e6);
}

#[test]
fn absurd_unit_m_is_refused_instead_of_nothing_emits_light() {
    for u in ["1e200", "0", "-1", "nan", "inf", "1e-20"] {
        let e = refused(
            &format!("unit_m = {u}\n{}", scene("100", "")),
            &["unit_m", "metres per file unit", "0.001 for millimetres"],
        );
        assert!(!e.contains("emits"), "{e}");
    }
    // millimetres and kilometres still load
    parse(&format!("unit_m = 0.001\n{}", scene("100", ""))).unwrap();
    parse(&format!("unit_m = 1000\n{}", scene("100", ""))).unwrap();
}

#[test]
fn geometry_whose_coordinates_in_metres_exceed_the_limit_is_refused_naming_the_polygon() {
    let text = r#"
unit_m = 1000
[materials.lamp]
reflectance_y = 0.5
emission_cd_m2 = 1
[[polygons]]
name = "far"
material = "lamp"
vertices = [[0, 0, 0], [1e5, 0, 0], [1e5, 1e5, 0], [0, 1e5, 0]]
"#;
    refused(text, &["polygon `far`", "beyond ±1e6 m", "unit_m"]);
}

#[test]
fn sky_with_nan_up_or_absurd_luminance_is_refused() {
    refused(
        &scene(
            "0",
            "[sky]\nmodel = \"overcast\"\nzenith_luminance_cd_m2 = 8000\nup = [nan, 0, 1]\n",
        ),
        &["sky", "`up`", "not finite"],
    );
    refused(
        &scene(
            "0",
            "[sky]\nmodel = \"overcast\"\nzenith_luminance_cd_m2 = 1e300\n",
        ),
        &["sky", "zenith_luminance_cd_m2 = 1e300", "at most"],
    );
    refused(
        &scene(
            "0",
            "[sky]\nmodel = \"clear\"\nzenith_luminance_cd_m2 = 8000\nsun_azimuth_deg = 10\nsun_elevation_deg = 40\nsun_normal_illuminance_lux = 1e300\n",
        ),
        &["sky", "sun_normal_illuminance_lux", "at most"],
    );
}

#[test]
fn goniometric_light_with_nan_aim_c0_parallel_to_aim_or_huge_scale_is_refused() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/scenes");
    let light = |extra: &str| {
        scene(
            "100",
            &format!(
                "[[lights]]\nname = \"g\"\ntype = \"goniometric\"\nfile = \"lights/downlight_bilateral.ies\"\nposition = [0.5, 0.5, 2]\n{extra}\n"
            ),
        )
    };
    let run = |text: &str| parse_scene_toml(text, &dir, Path::new("t.toml")).map(|(s, _)| s);
    run(&light("aim = [0, 0, -1]\nc0 = [1, 0, 0]")).unwrap();
    for (extra, parts) in [
        (
            "aim = [nan, 0, -1]",
            &["light `g`", "`aim`", "not finite"][..],
        ),
        (
            "aim = [0, 0, -1]\nc0 = [0, 0, 2]",
            &["light `g`", "`c0`", "parallel"][..],
        ),
        (
            "aim = [0, 0, -1]\nc0 = [inf, 0, 0]",
            &["light `g`", "`c0`", "not finite"][..],
        ),
        (
            "scale = 1e300",
            &["light `g`", "at most 1e12 cd", "scale"][..],
        ),
        ("flux_lm = 1e300", &["light `g`", "flux"][..]),
    ] {
        let e = run(&light(extra)).expect_err(extra).to_string();
        for p in parts {
            assert!(e.contains(p), "{extra}: {e:?} lacks {p:?}");
        }
    }
}
