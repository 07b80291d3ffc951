//! Tests of the voxel grid, its traversal and the GI against closed forms.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::gi::{GiOptions, render_frame};
use super::*;
use crate::mesh::Bvh;
use crate::scene::{Camera, Light, LightKind, Material, Polygon, Scene, V3, load_scene};

pub(crate) fn cornell() -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/scenes/cornell/cornell.toml");
    load_scene(&path).expect("cornell fixture").0
}

pub(crate) fn grid_of(scene: &Scene, n: u32) -> (VoxelGrid, Vec<[[f64; 3]; 3]>) {
    let (tris, _) = scene_triangles(scene);
    let (lo, hi) = gi::bounds(&tris);
    let mut g = VoxelGrid::empty(lo, hi, n).unwrap();
    voxelize(&mut g, &tris);
    (g, tris)
}

/// Random segments between points inside the scene's box, in world metres.
pub(crate) fn random_segments(
    grid: &VoxelGrid,
    count: usize,
    seed: u64,
) -> Vec<([f64; 3], [f64; 3])> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let span = grid.voxel_m * f64::from(grid.n);
    let pick = |rng: &mut ChaCha8Rng| -> [f64; 3] {
        std::array::from_fn(|a| grid.origin[a] + span * rng.random_range(0.02..0.98))
    };
    (0..count)
        .map(|_| (pick(&mut rng), pick(&mut rng)))
        .collect()
}

fn to_grid32(grid: &VoxelGrid, p: [f64; 3]) -> [f32; 3] {
    grid.to_grid(&p.into()).map(|v| v as f32)
}

fn closest_on_triangle(p: V3, t: &[[f64; 3]; 3]) -> V3 {
    // Ericson, Real-Time Collision Detection 5.1.5
    let (a, b, c) = (V3::from(t[0]), V3::from(t[1]), V3::from(t[2]));
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

fn distance_to_scene(p: V3, tris: &[[[f64; 3]; 3]]) -> f64 {
    tris.iter()
        .map(|t| (closest_on_triangle(p, t) - p).norm())
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn a_triangle_lying_on_a_voxel_face_sets_the_voxels_on_both_sides_and_no_farther() {
    let t = [[0.2, 0.3, 1.0], [0.9, 0.3, 1.0], [0.5, 0.8, 1.0]];
    let m = 0.5 + OVERLAP_MARGIN;
    assert!(tri_box_overlap(&t, [0.5, 0.5, 0.5], m));
    assert!(tri_box_overlap(&t, [0.5, 0.5, 1.5], m));
    assert!(!tri_box_overlap(&t, [0.5, 0.5, 2.5], m));
    assert!(
        !tri_box_overlap(&t, [1.5, 1.5, 0.5], m),
        "beside the triangle's corner"
    );
    // the edge-cross-product axes: a box beside the hypotenuse, inside the triangle's
    // bounding box, is separated by them only
    let diag = [[0.0, 0.0, 0.5], [4.0, 0.0, 0.5], [0.0, 4.0, 0.5]];
    assert!(!tri_box_overlap(&diag, [3.5, 3.5, 0.5], m));
    assert!(tri_box_overlap(&diag, [1.5, 1.5, 0.5], m));
}

#[test]
fn every_point_of_every_triangle_lies_in_a_set_voxel() {
    let (g, tris) = grid_of(&cornell(), 64);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for t in &tris {
        for _ in 0..200 {
            let (mut u, mut v) = (rng.random::<f64>(), rng.random::<f64>());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let p = V3::from(t[0]) * (1.0 - u - v) + V3::from(t[1]) * u + V3::from(t[2]) * v;
            let c = g.to_grid(&p).map(|x| x.floor() as u32);
            assert!(
                g.occupied(0, c),
                "point {p:?} of a triangle in empty voxel {c:?}"
            );
        }
    }
    // and the mipmaps are the OR of their children
    for k in 1..g.level_count() {
        let m = g.cells(k);
        for i in 0..m.pow(3) {
            let c = [i % m, i / m % m, i / (m * m)];
            let any = (0..8u32).any(|j| {
                g.occupied(
                    k - 1,
                    [
                        2 * c[0] + (j & 1),
                        2 * c[1] + (j >> 1 & 1),
                        2 * c[2] + (j >> 2),
                    ],
                )
            });
            assert_eq!(g.occupied(k, c), any, "level {k} cell {c:?}");
        }
    }
}

#[test]
fn the_hierarchy_finds_the_same_voxel_as_a_plain_walk_of_level_0() {
    let (g, _) = grid_of(&cornell(), 64);
    let mut hits = 0;
    let mut steps = [0u32; 2];
    for (a, b) in random_segments(&g, 4000, 11) {
        let (o, e) = (to_grid32(&g, a), to_grid32(&g, b));
        let d = [e[0] - o[0], e[1] - o[1], e[2] - o[2]];
        let h = trace(&g, o, d, 0.0, 1.0);
        let f = trace_flat(&g, o, d, 0.0, 1.0);
        assert_eq!(
            h.map(|h| h.voxel),
            f.map(|f| f.voxel),
            "segment {a:?} -> {b:?}"
        );
        if let (Some(h), Some(f)) = (h, f) {
            assert!((h.t - f.t).abs() <= 1e-5, "{} vs {}", h.t, f.t);
            hits += 1;
        }
        steps[0] += h.map_or(0, |h| h.steps);
        steps[1] += f.map_or(0, |f| f.steps);
    }
    assert!(hits > 1000, "only {hits} of 4000 segments hit: a weak test");
    eprintln!(
        "steps to the hits: hierarchy {}, level 0 {}",
        steps[0], steps[1]
    );
    // the box's walls set nearly every coarse cell, yet the empty inside is skipped:
    // 30001 against 47326 steps when this was written
    assert!(
        steps[0] * 4 < steps[1] * 3,
        "the hierarchy skips little: {steps:?}"
    );
}

/// The traversal check: at the voxel resolution, the hierarchy's hits agree
/// with exact ray–triangle tests. A segment the exact test sees hit at `t` is hit by
/// the voxels no later than `t` (no ray slips through), and where the voxels report
/// a hit the ray is within one voxel diagonal of a triangle (no hit out of nothing).
#[test]
fn voxel_hits_agree_with_exact_ray_triangle_tests_at_the_voxel_resolution() {
    let scene = cornell();
    let mut grazings = Vec::new();
    for n in [32, 128] {
        let (g, tris) = grid_of(&scene, n);
        let bvh = Bvh::build(&tris);
        let h = g.voxel_m;
        let (mut exact_hits, mut grazing) = (0, 0);
        for (a, b) in random_segments(&g, 3000, u64::from(n)) {
            let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let exact = bvh.intersect(a, d, 1.0);
            let (o, e) = (to_grid32(&g, a), to_grid32(&g, b));
            let dg = [e[0] - o[0], e[1] - o[1], e[2] - o[2]];
            let vox = trace(&g, o, dg, 0.0, 1.0);
            if let Some(x) = exact {
                exact_hits += 1;
                let v = vox.unwrap_or_else(|| {
                    panic!(
                        "n {n}: voxels missed the exact hit of {a:?} -> {b:?} at t {}",
                        x.t
                    )
                });
                let len = V3::from(d).norm();
                assert!(
                    f64::from(v.t) <= x.t + 1e-4 * h / len,
                    "n {n}: voxel hit at t {} after the exact one at {}",
                    v.t,
                    x.t
                );
            }
            if let Some(v) = vox {
                let p = V3::from(a) + V3::from(d) * f64::from(v.t);
                let dist = distance_to_scene(p, &tris);
                assert!(
                    dist <= 3f64.sqrt() * h * 1.001,
                    "n {n}: voxel hit {dist} m from any triangle (voxel {h} m)"
                );
                if exact.is_none() {
                    grazing += 1;
                }
            }
        }
        assert!(exact_hits > 1000, "n {n}: only {exact_hits} exact hits");
        eprintln!("n {n}: {exact_hits} exact hits, {grazing} segments hit by the voxels only");
        grazings.push(grazing);
    }
    // segments the voxels stop but the triangles do not pass within a voxel diagonal
    // of a surface: fewer as the voxels shrink (4× finer here)
    assert!(
        grazings[1] * 2 < grazings[0],
        "voxel-only hits {grazings:?}"
    );
}

#[test]
fn resolutions_outside_the_range_or_not_powers_of_two_are_refused() {
    let (lo, hi) = (V3::zeros(), V3::repeat(1.0));
    for n in [0, 4, 100, 2048] {
        assert_eq!(
            VoxelGrid::empty(lo, hi, n).unwrap_err(),
            GridError::Resolution(n)
        );
    }
    assert_eq!(VoxelGrid::empty(lo, lo, 64).unwrap_err(), GridError::Empty);
}

fn quad(corners: [[f64; 3]; 4], material: usize, object: &str) -> Polygon {
    Polygon {
        vertices: corners.iter().map(|&c| V3::from(c)).collect(),
        material,
        object: object.into(),
    }
}

/// A square emitter of side `a` at height `c` above the centre of a large floor.
fn emitter_over_floor(a: f64, c: f64) -> Scene {
    let h = a / 2.0;
    Scene {
        polygons: vec![
            // floor, facing up (+y)
            quad(
                [
                    [-2.0, 0.0, -2.0],
                    [-2.0, 0.0, 2.0],
                    [2.0, 0.0, 2.0],
                    [2.0, 0.0, -2.0],
                ],
                0,
                "floor",
            ),
            // emitter, facing down (−y)
            quad([[-h, c, -h], [h, c, -h], [h, c, h], [-h, c, h]], 1, "light"),
        ],
        materials: vec![
            Material {
                name: "floor".into(),
                reflectance_xyz: [0.5; 3],
                emission_cd_m2: [0.0; 3],
            },
            Material {
                name: "light".into(),
                reflectance_xyz: [0.0; 3],
                emission_cd_m2: [1000.0; 3],
            },
        ],
        lights: vec![],
        camera: None,
        sky: None,
    }
}

/// Illuminance under the centre of a parallel square emitter (side `a`, height `c`,
/// luminance `l`): four corner rectangles of the classic view factor.
fn closed_form_lux(a: f64, c: f64, l: f64) -> f64 {
    let (x, y) = (a / 2.0 / c, a / 2.0 / c);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    let f = (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI);
    4.0 * std::f64::consts::PI * l * f
}

#[test]
fn the_floor_under_a_square_emitter_shows_the_closed_form_luminance() {
    let (a, c) = (1.0, 1.0);
    let scene = emitter_over_floor(a, c);
    let camera = Camera {
        position: V3::new(0.0, 0.5, -0.01),
        look_at: V3::new(0.0, 0.0, 0.0),
        up: V3::new(0.0, 0.0, 1.0),
        vfov_deg: 2.0,
        width_px: 3,
        height_px: 3,
    };
    let opts = GiOptions {
        resolution: 64,
        light_samples: 1024,
        vpl_paths: 64,
        vpl_clamp_m: None,
    };
    let f = render_frame(&scene, &camera, &opts).unwrap();
    let expected = 0.5 / std::f64::consts::PI * closed_form_lux(a, c, 1000.0);
    let got = f64::from(f.xyz[4][1]);
    let rel = (got - expected).abs() / expected;
    assert!(
        rel < 0.005,
        "centre {got} cd/m² vs closed form {expected} ({:.3} %)",
        100.0 * rel
    );
    // nothing but the floor reflects towards the floor: no indirect light there
    assert!(f.vpls > 0);
}

/// Positions are kept relative to the grid, so a scene 100 km from the world's origin
/// (f32 steps of 8 mm there) is lit as at the origin.
#[test]
fn a_scene_far_from_the_world_origin_is_lit_as_at_the_origin() {
    let near = cornell();
    let shift = V3::new(1e5, -3e4, 2e5);
    let mut far = near.clone();
    far.polygons
        .iter_mut()
        .for_each(|p| p.vertices.iter_mut().for_each(|v| *v += shift));
    let mut camera = near.camera.clone().unwrap();
    (camera.width_px, camera.height_px) = (32, 32);
    let mut far_camera = camera.clone();
    far_camera.position += shift;
    far_camera.look_at += shift;
    let opts = GiOptions {
        resolution: 128,
        light_samples: 32,
        vpl_paths: 64,
        vpl_clamp_m: None,
    };
    let a = render_frame(&near, &camera, &opts).unwrap();
    let b = render_frame(&far, &far_camera, &opts).unwrap();
    let sum = |f: &gi::GiFrame| f.xyz.iter().map(|p| f64::from(p[1])).sum::<f64>();
    let (sa, sb) = (sum(&a), sum(&b));
    assert!(
        (sa - sb).abs() < 1e-3 * sa,
        "sum of Y {sa} at the origin, {sb} far from it"
    );
}

#[test]
fn an_emission_too_small_to_carry_flux_is_refused_as_no_emitter() {
    let mut scene = emitter_over_floor(1.0, 1.0);
    scene.materials[1].emission_cd_m2 = [1e-320, 0.0, 0.0];
    let camera = Camera {
        position: V3::new(0.0, 0.5, -0.01),
        look_at: V3::zeros(),
        up: V3::new(0.0, 0.0, 1.0),
        vfov_deg: 2.0,
        width_px: 2,
        height_px: 2,
    };
    let err = render_frame(&scene, &camera, &GiOptions::default()).unwrap_err();
    assert!(matches!(err, gi::GiError::NoEmitter), "{err}");
}

/// The floor alone under a point-like light: a camera looking straight down sees
/// `ρ/π · I(θ) · cos θ / r²` (no other surface, so no indirect light).
fn floor_under(light: LightKind, pixels: u32, vfov_deg: f64) -> (Vec<[f32; 3]>, Camera) {
    let mut scene = emitter_over_floor(1.0, 1.0);
    scene.polygons.truncate(1);
    scene.lights = vec![Light {
        name: "lamp".into(),
        position: V3::new(0.0, 1.0, 0.0),
        color_xyz: [1.0, 1.0, 1.0],
        kind: light,
    }];
    let camera = Camera {
        position: V3::new(0.0, 0.5, 0.0),
        look_at: V3::zeros(),
        up: V3::new(0.0, 0.0, 1.0),
        vfov_deg,
        width_px: pixels,
        height_px: 1,
    };
    let opts = GiOptions {
        resolution: 64,
        light_samples: 16,
        vpl_paths: 64,
        vpl_clamp_m: None,
    };
    (render_frame(&scene, &camera, &opts).unwrap().xyz, camera)
}

/// Where the ray through pixel column `x` of `floor_under`'s camera meets the floor:
/// the angle from the light's nadir (the light is 1 m above the floor).
fn floor_angle(camera: &Camera, x: u32) -> f64 {
    let w = f64::from(camera.width_px);
    let focal = 0.5 / (0.5 * camera.vfov_deg.to_radians()).tan();
    let dx = (f64::from(x) + 0.5 - 0.5 * w) / focal;
    // the camera 0.5 m up looks down: the floor point is dx·0.5 m aside
    (dx * 0.5).atan()
}

#[test]
fn an_isotropic_point_light_gives_the_floor_its_inverse_square_cosine_luminance() {
    let (img, camera) = floor_under(
        LightKind::Isotropic {
            intensity_cd: 1000.0,
        },
        9,
        40.0,
    );
    for x in 0..9 {
        let t = floor_angle(&camera, x);
        let expected = 0.5 / std::f64::consts::PI * 1000.0 * t.cos().powi(3);
        let got = f64::from(img[x as usize][1]);
        assert!(
            (got - expected).abs() < 1e-4 * expected,
            "pixel {x}: {got} vs {expected}"
        );
    }
}

#[test]
fn a_spot_lights_the_floor_inside_its_cone_and_not_outside() {
    let spot = LightKind::Spot {
        axis: V3::new(0.0, -1.0, 0.0),
        intensity_cd: 1000.0,
        inner_half_angle_rad: 25f64.to_radians(),
        outer_half_angle_rad: 35f64.to_radians(),
    };
    let (img, camera) = floor_under(spot, 21, 17.0);
    let (mut inside, mut outside) = (0, 0);
    for x in 0..21 {
        let t = floor_angle(&camera, x).abs().to_degrees();
        let full = 0.5 / std::f64::consts::PI * 1000.0 * t.to_radians().cos().powi(3);
        let got = f64::from(img[x as usize][1]);
        // the table blurs the edge over a texel (1.4°)
        if t < 23.5 {
            assert!((got - full).abs() < 1e-4 * full, "{t:.1}°: {got} vs {full}");
            inside += 1;
        } else if t > 36.5 {
            assert_eq!(got, 0.0, "{t:.1}°: lit outside the cone");
            outside += 1;
        }
    }
    assert!(
        inside >= 3 && outside >= 3,
        "{inside} inside, {outside} outside"
    );
}

#[cfg(feature = "gpu")]
mod on_gpu {
    use super::*;
    use crate::voxel::gi::{Prepared, prepare, shade};
    use crate::voxel::gpu::GpuVoxelGi;

    /// The GPU, or `None` (the test is skipped with a message) when this machine has
    /// none, unless `LUMIWALL_REQUIRE_GPU=1`.
    fn gpu() -> Option<GpuVoxelGi> {
        match GpuVoxelGi::new() {
            Ok(g) => Some(g),
            Err(e) if std::env::var("LUMIWALL_REQUIRE_GPU").as_deref() != Ok("1") => {
                eprintln!("skipped: no GPU ({e})");
                None
            }
            Err(e) => panic!("LUMIWALL_REQUIRE_GPU=1 but {e}"),
        }
    }

    fn any_overlap(tris: &[[[f64; 3]; 3]], g: &VoxelGrid, c: [u32; 3], h: f64) -> bool {
        let centre = c.map(|v| f64::from(v) + 0.5);
        tris.iter()
            .any(|t| tri_box_overlap(&t.map(|p| g.to_grid(&p.into())), centre, h))
    }

    #[test]
    fn the_gpu_voxelises_as_the_cpu_but_for_voxels_within_rounding_of_a_triangle() {
        let Some(gpu) = gpu() else { return };
        let scene = crate::scene::Scene {
            polygons: cornell()
                .polygons
                .into_iter()
                .map(|mut p| {
                    // tilt everything a little so that faces do not sit on voxel faces
                    let r = nalgebra::Rotation3::from_euler_angles(0.05, 0.1, 0.02);
                    p.vertices.iter_mut().for_each(|v| *v = r * *v);
                    p
                })
                .collect(),
            ..cornell()
        };
        let (cpu, tris) = grid_of(&scene, 64);
        let mut layout = cpu.clone();
        layout.levels.iter_mut().for_each(|l| l.fill(0));
        let on_gpu = gpu.voxelize(&layout, &tris).unwrap();
        let words = gpu.read_grid(&on_gpu).unwrap();
        let n = cpu.n;
        let mut from_gpu = layout.clone();
        from_gpu.levels[0] = words[..cpu.levels[0].len()].to_vec();
        let mut differ = 0;
        for i in 0..n.pow(3) {
            let c = [i % n, i / n % n, i / (n * n)];
            if from_gpu.occupied(0, c) != cpu.occupied(0, c) {
                differ += 1;
                let tight = any_overlap(&tris, &cpu, c, 0.5 + OVERLAP_MARGIN - 1e-5);
                let loose = any_overlap(&tris, &cpu, c, 0.5 + OVERLAP_MARGIN + 1e-5);
                assert!(
                    tight != loose,
                    "voxel {c:?} differs and is no rounding case"
                );
            }
        }
        eprintln!("{differ} of {} set voxels differ", cpu.occupied_count());
        assert!(differ * 1000 < cpu.occupied_count());
        // the GPU's mipmaps are the OR of its level 0
        from_gpu.build_mips();
        let (packed, _) = from_gpu.packed();
        assert_eq!(packed, words, "GPU mipmaps");
    }

    #[test]
    fn the_gpu_traversal_finds_the_voxels_the_cpu_reference_finds() {
        let Some(gpu) = gpu() else { return };
        let (g, _) = grid_of(&cornell(), 64);
        let on_gpu = gpu.upload(&g).unwrap();
        let rays: Vec<_> = random_segments(&g, 20000, 5)
            .into_iter()
            .map(|(a, b)| {
                let (o, e) = (to_grid32(&g, a), to_grid32(&g, b));
                (o, [e[0] - o[0], e[1] - o[1], e[2] - o[2]], 0.0f32, 1.0f32)
            })
            .collect();
        let hits = gpu.trace_rays(&on_gpu, &rays).unwrap();
        let (mut same, mut differ, mut hit_count) = (0, 0, 0);
        for (r, h) in rays.iter().zip(&hits) {
            let cpu = trace(&g, r.0, r.1, r.2, r.3).map(|h| (h.t, h.voxel));
            hit_count += usize::from(cpu.is_some());
            match (cpu, *h) {
                (None, None) => same += 1,
                (Some(a), Some(b)) if a.1 == b.1 && (a.0 - b.0).abs() <= 1e-5 => same += 1,
                (a, b) => {
                    differ += 1;
                    eprintln!("ray {r:?}: CPU {a:?} GPU {b:?}");
                }
            }
        }
        eprintln!("{same} rays agree, {differ} differ, {hit_count} hits");
        assert!(hit_count > 5000);
        assert!(
            differ * 2000 <= rays.len(),
            "{differ} of {} rays differ",
            rays.len()
        );
    }

    #[test]
    fn the_gpu_shading_matches_the_cpu_reference() {
        let Some(gpu) = gpu() else { return };
        let mut scene = cornell();
        let mut camera = scene.camera.clone().unwrap();
        (camera.width_px, camera.height_px) = (24, 24);
        scene.camera = None;
        // and a spot under the ceiling aimed at the tall block (point lights' tables)
        scene.lights.push(Light {
            name: "spot".into(),
            position: V3::new(0.2, 0.5, 0.3),
            color_xyz: [0.9, 1.0, 1.1],
            kind: LightKind::Spot {
                axis: V3::new(0.3, -1.0, 0.2).normalize(),
                intensity_cd: 50.0,
                inner_half_angle_rad: 0.3,
                outer_half_angle_rad: 0.5,
            },
        });
        // thousands of VPLs: more traversal steps than llvmpipe lets one invocation
        // loop, on a coarse and a fine grid (longer traversals, smaller chunks)
        for resolution in [64, 256] {
            let opts = GiOptions {
                resolution,
                light_samples: 64,
                vpl_paths: 2048,
                vpl_clamp_m: None,
            };
            let Prepared {
                mut light,
                tris,
                hits,
            } = prepare(&scene, &opts).unwrap();
            voxelize(&mut light.grid, &tris);
            let view = hits.pinhole(&camera).unwrap();
            let cpu: Vec<[f32; 3]> = view.surfels.iter().map(|s| shade(&light, s)).collect();
            let lit = cpu.iter().filter(|p| p[1] > 0.0).count();
            assert!(lit * 2 > cpu.len(), "{resolution}³: a dark image");
            let on_gpu = gpu.upload(&light.grid).unwrap();
            let got = gpu.shade(&on_gpu, &light, &view).unwrap();
            let mut worst = 0f32;
            let mut off = 0;
            for (a, b) in cpu.iter().zip(&got) {
                let rel = (a[1] - b[1]).abs() / a[1].max(1e-3);
                worst = worst.max(rel);
                off += usize::from(rel > 1e-4);
            }
            eprintln!("{resolution}³: worst relative difference {worst}, {off} pixels beyond 1e-4");
            // a sample whose visibility rounds the other way moves a pixel by its share
            assert!(off * 200 <= cpu.len(), "{resolution}³: {off} pixels differ");
        }
    }
}
