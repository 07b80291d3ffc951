//! Daylight (Kresse 2.4.4): a CIE sky as distant cells and the sun, from the scene
//! file's `[sky]`. An open black plane must receive the sky's horizontal illuminance
//! (an independent numerical integral of the CIE luminance, `photometry::Sky`); a
//! room lit through a roof opening is checked against the Monte Carlo path tracer;
//! goniometric lights come from IES/EULUMDAT files named in the scene file.

use std::path::{Path, PathBuf};

use crate::support::{solve_hierarchical_with, stop_rule};
use lumiwall_render::photometry::Sky;
use lumiwall_render::radiosity::montecarlo::MonteCarloReference;
use lumiwall_render::radiosity::{
    BvhOccluders, NoOccluders, ProgressiveOptions, Solution, StopRule, solve_progressive,
};
use lumiwall_render::scene::{LightKind, V3, parse_scene_toml};

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/scenes")
}

fn parse(toml: &str) -> lumiwall_render::scene::Scene {
    parse_scene_toml(toml, &fixtures(), Path::new("test.toml"))
        .unwrap()
        .0
}

fn stop(target: f64) -> StopRule {
    stop_rule(target, 60, 10_000)
}

const PLANE: &str = r#"
[materials.black]
reflectance_y = 0.0
[[polygons]]
name = "ground"
material = "black"
vertices = [[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]]
"#;

#[test]
fn open_plane_receives_the_skys_horizontal_illuminance() {
    for (sky_toml, sky) in [
        (
            "[sky]\nmodel = \"overcast\"\nzenith_luminance_cd_m2 = 8000\nbands = 16\n",
            Sky::cie_overcast(8000.0),
        ),
        (
            "[sky]\nmodel = \"clear\"\nzenith_luminance_cd_m2 = 5000\nsun_azimuth_deg = 135\nsun_elevation_deg = 35\nbands = 16\n",
            Sky::cie_clear(
                [
                    135f64.to_radians().sin() * 35f64.to_radians().cos(),
                    135f64.to_radians().cos() * 35f64.to_radians().cos(),
                    35f64.to_radians().sin(),
                ],
                5000.0,
            ),
        ),
    ] {
        let scene = parse(&format!("{PLANE}{sky_toml}"));
        let d = scene.sky.as_ref().unwrap();
        let sol = solve_hierarchical_with(&scene, &NoOccluders, stop(0.01));
        let want = sky.global_horizontal_illuminance_lux();
        let cells = d.illuminance_on_plane_xyz(&V3::z())[1];
        for p in &sol.patches {
            let e = p.irradiance_xyz[1];
            // links store f32 coefficients
            assert!(
                (e - cells).abs() / cells < 1e-6,
                "{e} vs the cells' sum {cells}"
            );
        }
        let e = sol.patches[0].irradiance_xyz[1];
        println!(
            "{}: {} cells{}, solved {e:.1} lx, CIE integral {want:.1} lx ({:+.2} %)",
            if d.sun.is_some() { "clear" } else { "overcast" },
            d.sky_cells.len(),
            if d.sun.is_some() { " + sun" } else { "" },
            100.0 * (e / want - 1.0)
        );
        assert!((e - want).abs() / want < 0.01, "{e} vs {want}");
        // the sun is where the scene file says (from the south-east, 35° up)
        if let Some(sun) = &d.sun {
            assert!((sun.direction.z - 35f64.to_radians().sin()).abs() < 1e-12);
            assert!(sun.direction.x > 0.0 && sun.direction.y < 0.0);
        }
    }
}

/// A 4 × 4 × 3 m room, its roof open over 1.5 × 1.5 m, under an overcast sky.
const ROOF_ROOM: &str = r#"
[materials.wall]
reflectance_y = 0.6
[[polygons]]
name = "floor"
material = "wall"
vertices = [[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0]]
[[polygons]]
name = "west"
material = "wall"
vertices = [[0, 0, 0], [0, 4, 0], [0, 4, 3], [0, 0, 3]]
[[polygons]]
name = "east"
material = "wall"
vertices = [[4, 0, 0], [4, 0, 3], [4, 4, 3], [4, 4, 0]]
[[polygons]]
name = "south"
material = "wall"
vertices = [[0, 0, 0], [0, 0, 3], [4, 0, 3], [4, 0, 0]]
[[polygons]]
name = "north"
material = "wall"
vertices = [[0, 4, 0], [4, 4, 0], [4, 4, 3], [0, 4, 3]]
[[polygons]]
name = "roof south"
material = "wall"
vertices = [[0, 0, 3], [0, 1.25, 3], [4, 1.25, 3], [4, 0, 3]]
[[polygons]]
name = "roof north"
material = "wall"
vertices = [[0, 2.75, 3], [0, 4, 3], [4, 4, 3], [4, 2.75, 3]]
[[polygons]]
name = "roof west"
material = "wall"
vertices = [[0, 1.25, 3], [0, 2.75, 3], [1.25, 2.75, 3], [1.25, 1.25, 3]]
[[polygons]]
name = "roof east"
material = "wall"
vertices = [[2.75, 1.25, 3], [2.75, 2.75, 3], [4, 2.75, 3], [4, 1.25, 3]]
[sky]
model = "overcast"
zenith_luminance_cd_m2 = 6000
bands = 8
"#;

/// Mean absolute difference of the solved patch irradiance (Y) from the path
/// tracer's, over patches drawn area-uniformly.
struct TracerComparison {
    /// Σ |solved − traced|.
    diff: f64,
    /// Σ traced.
    sum: f64,
    /// Σ standard error of the traced values.
    noise: f64,
}

/// Compares `samples` patches, chosen at evenly spaced cumulative areas, with the
/// tracer.
fn compare_with_tracer(
    sol: &Solution,
    mc: &MonteCarloReference,
    samples: usize,
) -> TracerComparison {
    let total: f64 = sol.patches.iter().map(|p| p.area_m2).sum();
    let mut acc = 0.0;
    let cum: Vec<f64> = sol
        .patches
        .iter()
        .map(|p| {
            acc += p.area_m2;
            acc
        })
        .collect();
    let (mut diff, mut sum, mut noise) = (0.0, 0.0, 0.0);
    for k in 0..samples {
        let u = (k as f64 + 0.5) / samples as f64 * total;
        let p = &sol.patches[cum.partition_point(|&c| c < u).min(cum.len() - 1)];
        let est = mc.patch_irradiance(&p.vertices, p.polygon, 8000, 5 + k as u64);
        diff += (p.irradiance_xyz[1] - est.irradiance_xyz[1]).abs();
        sum += est.irradiance_xyz[1];
        noise += est.std_error_y;
    }
    TracerComparison { diff, sum, noise }
}

/// Area-weighted mean irradiance (Y) of the floor (polygon 0).
fn floor_mean(s: &Solution) -> f64 {
    let (mut e, mut a) = (0.0, 0.0);
    for p in s.patches.iter().filter(|p| p.polygon == 0) {
        e += p.irradiance_xyz[1] * p.area_m2;
        a += p.area_m2;
    }
    e / a
}

#[test]
fn room_under_a_roof_opening_agrees_with_path_tracing() {
    let scene = parse(ROOF_ROOM);
    let vis = BvhOccluders::new(&scene);
    let sol = solve_hierarchical_with(&scene, &vis, stop(0.05));
    assert!(sol.stats.shadow_rays > 0);
    let mc = MonteCarloReference::new(&scene);
    // patches spread over the room by area, as patch means
    let TracerComparison { diff, sum, noise } = compare_with_tracer(&sol, &mc, 24);
    let est = sol.curve.last().unwrap().estimated_error;
    println!(
        "roof opening: {} patches, estimated {:.2} %, against the tracer {:.2} % (noise {:.2} %)",
        sol.stats.patches,
        100.0 * est,
        100.0 * diff / sum,
        100.0 * noise / sum
    );
    assert!(diff / sum < 2.0 * est + 2.0 * noise / sum);
    // the progressive solver takes daylight too and agrees on the floor's mean
    let pr = solve_progressive(
        &scene,
        &vis,
        &ProgressiveOptions {
            stop: stop(0.01),
            max_edge_m: 0.5,
        },
    )
    .unwrap();
    let (h, p) = (floor_mean(&sol), floor_mean(&pr));
    assert!((h - p).abs() / p < 0.05, "floor {h} vs progressive {p}");
}

#[test]
fn goniometric_lights_come_from_photometric_files() {
    let toml = r#"
[materials.black]
reflectance_y = 0.0
[[polygons]]
name = "floor"
material = "black"
vertices = [[-3, -3, 0], [3, -3, 0], [3, 3, 0], [-3, 3, 0]]
[[lights]]
name = "downlight"
type = "goniometric"
file = "lights/downlight_bilateral.ies"
position = [0, 0, 2.5]
aim = [0, 0, -1]
[[lights]]
name = "washer"
type = "goniometric"
file = "lights/wallwasher_sym2.ldt"
position = [1, 0, 2]
aim = [0, 0, -1]
flux_lm = 1000
"#;
    let scene = parse(toml);
    assert_eq!(scene.lights.len(), 2);
    for l in &scene.lights {
        assert!(matches!(l.kind, LightKind::Goniometric { .. }));
    }
    // straight down from the downlight: the file's γ = 0 row, 900·(1 + 0.2 cos C) cd,
    // lies between 720 and 1080 cd depending on the C plane the pole is read in
    let down = scene.lights[0].intensity_cd(&-V3::z());
    assert!((720.0 - 1e-6..=1080.0 + 1e-6).contains(&down), "{down}");
    // 40° off the axis in the C0 plane: 900·cos^1.5(40°)·1.2 cd
    let g = 40f64.to_radians();
    let dir = V3::new(g.sin(), 0.0, -g.cos());
    let want = 900.0 * g.cos().powf(1.5) * 1.2;
    let got = scene.lights[0].intensity_cd(&dir);
    assert!((got - want).abs() / want < 0.02, "{got} vs {want}");
    // flux_lm rescales the whole distribution
    assert!((scene.lights[1].total_flux_lm() - 1000.0).abs() < 1.0);
    // errors name the light and the file
    let bad = parse_scene_toml(
        &toml.replace("wallwasher_sym2.ldt", "missing.ldt"),
        &fixtures(),
        Path::new("t.toml"),
    );
    assert!(bad.unwrap_err().to_string().contains("missing.ldt"));
    let bad = parse_scene_toml(
        &toml.replace("downlight_bilateral.ies", "README.md"),
        &fixtures(),
        Path::new("t.toml"),
    );
    assert!(bad.unwrap_err().to_string().contains(".ies"));
}
