//! Seeded architectural test scene for the radiosity scale bench: a nave of bays with
//! floor, vaulted ceiling, walls, columns and arches, lit by a mix of point, spot and
//! goniometric lights (Kresse's Siena cathedral scale: 150 000 polygons, 500 lights).

use super::indexed::{IndexedMesh, add, cross, dot, len, scale, sub};
use crate::photometry::{IntensityDistribution, LightFrame};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{PI, TAU};

/// Kind of a generated light.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GeneratedLightKind {
    /// Isotropic point source.
    Point,
    /// Analytic spot.
    Spot,
    /// Goniometric (tabulated) luminaire.
    Goniometric,
}

/// A light of a [`GeneratedScene`].
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedLight {
    /// Kind.
    pub kind: GeneratedLightKind,
    /// Position, metres.
    pub position: [f64; 3],
    /// Orientation of the distribution's local frame.
    pub frame: LightFrame,
    /// Intensity distribution (cd).
    pub distribution: IntensityDistribution,
}

/// A named diffuse material.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedMaterial {
    /// Name (floor, wall, column …).
    pub name: String,
    /// Diffuse luminous reflectance (Y), 0…1.
    pub reflectance: f64,
}

/// Output of [`generate_scale_scene`].
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedScene {
    /// Geometry; front faces point into the interior.
    pub mesh: IndexedMesh,
    /// Material index per triangle.
    pub triangle_material: Vec<u32>,
    /// Materials.
    pub materials: Vec<GeneratedMaterial>,
    /// Lights.
    pub lights: Vec<GeneratedLight>,
}

impl GeneratedScene {
    /// The scene as the solver's [`crate::scene::Scene`]: one triangle polygon per
    /// triangle (object name = material name), grey materials with the generated Y
    /// reflectance, every light as a goniometric `scene::Light` (see
    /// [`crate::photometry::to_scene_light`]), no camera, no sky.
    pub fn to_scene(&self) -> crate::scene::Scene {
        use crate::scene::{Material, Polygon, Scene, V3};
        let materials = self
            .materials
            .iter()
            .map(|m| Material {
                name: m.name.clone(),
                reflectance_xyz: [m.reflectance; 3],
                emission_cd_m2: [0.0; 3],
            })
            .collect();
        let polygons = self
            .mesh
            .triangles
            .iter()
            .zip(&self.triangle_material)
            .filter_map(|(t, &m)| {
                let p = |i: u32| {
                    self.mesh
                        .positions
                        .get(i as usize)
                        .map(|q| V3::new(q[0], q[1], q[2]))
                };
                Some(Polygon {
                    vertices: vec![p(t[0])?, p(t[1])?, p(t[2])?],
                    material: m as usize,
                    object: self
                        .materials
                        .get(m as usize)
                        .map(|x| x.name.clone())
                        .unwrap_or_default(),
                })
            })
            .collect();
        let lights = self
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| {
                crate::photometry::to_scene_light(
                    &format!("{:?} {i}", l.kind),
                    &l.distribution,
                    l.position,
                    &l.frame,
                )
            })
            .collect();
        Scene {
            polygons,
            materials,
            lights,
            camera: None,
            sky: None,
        }
    }
}

/// Generates a scene with at least `triangles` triangles and exactly `lights`
/// lights (cycling point, spot, goniometric), deterministic for a given `seed`.
///
/// Layout: a nave along +x made of bays 6 m long and 12 m wide, each with floor,
/// side walls up to the springing line at 9 m, a barrel vault, two columns (radius
/// 0.4 m) carrying arches of the arcade towards the next bay, and on alternating
/// sides a closed side chapel (room) 4 m deep. Both ends of the nave are closed by
/// walls and lunettes. Surfaces facing into air are front faces: room surfaces face
/// inwards, columns and arches outwards. The tessellation density is raised until the
/// triangle count reaches `triangles`; lights are placed at random in the nave (90 %)
/// and in the chapels.
pub fn generate_scale_scene(triangles: usize, lights: usize, seed: u64) -> GeneratedScene {
    let target = triangles.max(1);
    let build = |bays: usize, n: usize| {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut b = Builder::new(&mut rng);
        b.nave(bays, n);
        let count = b.mesh.triangles.len();
        (count, b.mesh, b.tri_mat, b.materials)
    };
    let count = |bays: usize, n: usize| build(bays, n).0;
    // about sqrt(target/500) bays; then the smallest density reaching the target,
    // then the fewest bays at that density (overshoot below one bay).
    let max_bays =
        ((target as f64 / BAY_COUNT_DIVISOR).sqrt().round() as usize).clamp(MIN_BAYS, MAX_BAYS);
    let per_bay = target as f64 / max_bays as f64;
    let mut n = (((per_bay / TRIANGLES_PER_BAY_PER_N2).sqrt()) as usize)
        .saturating_sub(2)
        .max(MIN_DENSITY);
    while n < MAX_DENSITY && count(max_bays, n) < target {
        n += 1.max(n / 32);
    }
    let (mut lo, mut hi) = (MIN_BAYS, max_bays);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if count(mid, n) >= target {
            hi = mid
        } else {
            lo = mid + 1
        }
    }
    let bays = lo;
    let (_, mesh, triangle_material, materials) = build(bays, n);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ LIGHT_SEED_MIX);
    let lights = lights_for(&mut rng, lights, bays);
    GeneratedScene {
        mesh,
        triangle_material,
        materials,
        lights,
    }
}

/// The nave gets about √(triangles / this) bays, so that bay count and tessellation
/// density grow together.
const BAY_COUNT_DIVISOR: f64 = 500.0;
/// Fewest bays of the nave.
const MIN_BAYS: usize = 2;
/// Most bays of the nave.
const MAX_BAYS: usize = 400;
/// Approximate triangles of one bay per squared tessellation density n (first guess
/// of n, refined by counting).
const TRIANGLES_PER_BAY_PER_N2: f64 = 23.0;
/// Lowest tessellation density (quads per unit edge of a bay's patch grid).
const MIN_DENSITY: usize = 2;
/// The density search stops here even if the target is not reached.
const MAX_DENSITY: usize = 4000;
/// Mixed into the seed for the lights' random stream (2⁶⁴ / golden ratio), so that
/// it differs from the materials' stream.
const LIGHT_SEED_MIX: u64 = 0x9E37_79B9_7F4A_7C15;
/// Twice the area (m²) below which a patch triangle counts as collapsed (e.g. at
/// the centre of a lunette) and is skipped.
const COLLAPSED_TRIANGLE_AREA2: f64 = 1e-12;

/// Length of one bay along the nave (x), metres.
const BAY_LEN: f64 = 6.0;
/// Width of the nave (y), metres.
const NAVE_W: f64 = 12.0;
/// Height of the springing line where the barrel vault starts, metres.
const SPRING_Z: f64 = 9.0;
/// Distance of the column axes from the nave's centre line, metres.
const COLUMN_Y: f64 = 4.0;
/// Column radius, metres.
const COLUMN_R: f64 = 0.4;
/// Column height (the arches rest on the column tops), metres.
const COLUMN_H: f64 = 6.0;
/// Depth of a side chapel beyond the wall, metres.
const CHAPEL_D: f64 = 4.0;
/// Height of a side chapel, metres.
const CHAPEL_H: f64 = 6.0;
/// Wall thickness between the nave and a side chapel, metres.
const WALL_T: f64 = 0.3;
/// Gap between a side chapel and either end of its bay along x, metres.
const CHAPEL_INSET: f64 = 0.5;

#[derive(Clone, Copy)]
enum Mat {
    Floor = 0,
    Wall = 1,
    Vault = 2,
    Column = 3,
    Arch = 4,
    Chapel = 5,
}

struct Builder {
    mesh: IndexedMesh,
    tri_mat: Vec<u32>,
    materials: Vec<GeneratedMaterial>,
}

impl Builder {
    fn new(rng: &mut ChaCha8Rng) -> Self {
        let base = [
            ("floor", 0.3),
            ("wall", 0.6),
            ("vault", 0.7),
            ("column", 0.5),
            ("arch", 0.55),
            ("chapel", 0.65),
        ];
        let materials = base
            .iter()
            .map(|(name, r)| GeneratedMaterial {
                name: (*name).to_string(),
                reflectance: (r + rng.random_range(-0.05f64..0.05)).clamp(0.05, 0.95),
            })
            .collect();
        Self {
            mesh: IndexedMesh::default(),
            tri_mat: Vec::new(),
            materials,
        }
    }

    /// A parametric patch p(u, v), u, v ∈ [0, 1], `nu` × `nv` quads split in two;
    /// the winding is chosen so that the normal agrees with `facing(p)` at the patch
    /// centre.
    fn patch<F, G>(&mut self, f: F, nu: usize, nv: usize, mat: Mat, facing: G)
    where
        F: Fn(f64, f64) -> [f64; 3],
        G: Fn([f64; 3]) -> [f64; 3],
    {
        let (nu, nv) = (nu.max(1), nv.max(1));
        let base = self.mesh.positions.len() as u32;
        for j in 0..=nv {
            for i in 0..=nu {
                self.mesh
                    .positions
                    .push(f(i as f64 / nu as f64, j as f64 / nv as f64));
            }
        }
        let c = f(0.5, 0.5);
        let du = sub(
            f(0.5 + 0.25 / nu as f64, 0.5),
            f(0.5 - 0.25 / nu as f64, 0.5),
        );
        let dv = sub(
            f(0.5, 0.5 + 0.25 / nv as f64),
            f(0.5, 0.5 - 0.25 / nv as f64),
        );
        let flip = dot(cross(du, dv), facing(c)) < 0.0;
        let idx = |i: usize, j: usize| base + (j * (nu + 1) + i) as u32;
        for j in 0..nv {
            for i in 0..nu {
                let (a, b, cc, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                for t in [[a, b, cc], [a, cc, d]] {
                    let t = if flip { [t[0], t[2], t[1]] } else { t };
                    let p = |k: usize| self.mesh.positions[t[k] as usize];
                    if len(cross(sub(p(1), p(0)), sub(p(2), p(0)))) < COLLAPSED_TRIANGLE_AREA2 {
                        continue; // collapsed quad corner (e.g. the centre of a lunette)
                    }
                    self.mesh.triangles.push(t);
                    self.tri_mat.push(mat as u32);
                }
            }
        }
    }

    #[expect(
        clippy::too_many_arguments,
        reason = "a quad is origin, two edges, two tessellation counts, material and facing"
    )]
    fn quad(
        &mut self,
        o: [f64; 3],
        u: [f64; 3],
        v: [f64; 3],
        nu: usize,
        nv: usize,
        mat: Mat,
        facing: [f64; 3],
    ) {
        self.patch(
            |a, b| add(o, add(scale(u, a), scale(v, b))),
            nu,
            nv,
            mat,
            |_| facing,
        );
    }

    fn nave(&mut self, bays: usize, n: usize) {
        for bay in 0..bays {
            let x0 = bay as f64 * BAY_LEN;
            self.bay_shell(x0, n);
            self.bay_columns(x0, bay + 1 < bays, n);
            self.side_chapel(bay, x0, n);
        }
        self.end_walls(bays as f64 * BAY_LEN, n);
    }

    /// One bay's floor, side walls and barrel vault, starting at `x0`.
    fn bay_shell(&mut self, x0: f64, n: usize) {
        let r = NAVE_W / 2.0;
        self.quad(
            [x0, -r, 0.0],
            [BAY_LEN, 0.0, 0.0],
            [0.0, NAVE_W, 0.0],
            n,
            2 * n,
            Mat::Floor,
            [0.0, 0.0, 1.0],
        );
        for (y, facing) in [(-r, 1.0), (r, -1.0)] {
            self.quad(
                [x0, y, 0.0],
                [BAY_LEN, 0.0, 0.0],
                [0.0, 0.0, SPRING_Z],
                n,
                n,
                Mat::Wall,
                [0.0, facing, 0.0],
            );
        }
        self.patch(
            |u, v| {
                let phi = v * PI;
                [x0 + u * BAY_LEN, r * phi.cos(), SPRING_Z + r * phi.sin()]
            },
            n,
            2 * n,
            Mat::Vault,
            |p| [0.0, -p[1], SPRING_Z - p[2]],
        );
    }

    /// The two columns in the middle of the bay at `x0`, each with an arch towards
    /// the next bay's column when there is a next bay.
    fn bay_columns(&mut self, x0: f64, has_next_bay: bool, n: usize) {
        let xm = x0 + BAY_LEN / 2.0;
        for side in [-1.0, 1.0] {
            let (cx, cy) = (xm, side * COLUMN_Y);
            self.patch(
                |u, v| {
                    let th = u * TAU;
                    [
                        cx + COLUMN_R * th.cos(),
                        cy + COLUMN_R * th.sin(),
                        v * COLUMN_H,
                    ]
                },
                2 * n,
                2 * n,
                Mat::Column,
                |p| [p[0] - cx, p[1] - cy, 0.0],
            );
            if has_next_bay {
                self.arch(xm, xm + BAY_LEN, cy, n);
            }
        }
    }

    /// A side chapel outside the wall, on alternating sides by bay.
    fn side_chapel(&mut self, bay: usize, x0: f64, n: usize) {
        let r = NAVE_W / 2.0;
        let side = if bay.is_multiple_of(2) { 1.0 } else { -1.0 };
        let y_in = side * (r + WALL_T);
        let y_out = side * (r + WALL_T + CHAPEL_D);
        self.room(
            [x0 + CHAPEL_INSET, y_in.min(y_out), 0.0],
            [x0 + BAY_LEN - CHAPEL_INSET, y_in.max(y_out), CHAPEL_H],
            n.div_ceil(2),
        );
    }

    /// The end walls at x = 0 and `len_total`, with the lunettes under the vault.
    fn end_walls(&mut self, len_total: f64, n: usize) {
        let r = NAVE_W / 2.0;
        for (x, facing) in [(0.0, 1.0), (len_total, -1.0)] {
            self.quad(
                [x, -r, 0.0],
                [0.0, NAVE_W, 0.0],
                [0.0, 0.0, SPRING_Z],
                2 * n,
                n,
                Mat::Wall,
                [facing, 0.0, 0.0],
            );
            self.patch(
                |u, v| {
                    let phi = u * PI;
                    let rr = v * r;
                    [x, rr * phi.cos(), SPRING_Z + rr * phi.sin()]
                },
                2 * n,
                n,
                Mat::Wall,
                |_| [facing, 0.0, 0.0],
            );
        }
    }

    fn arch(&mut self, xa: f64, xb: f64, y: f64, n: usize) {
        let xm = 0.5 * (xa + xb);
        // the arch foot rests on the column top between 0.45 m and 0.05 m from the
        // column axis, 0.6 m wide: no column vertex lies on an arch edge (no
        // T-vertices) and neighbouring arches do not overlap
        let rad = 0.5 * (xb - xa) - 0.45;
        let depth = 0.4;
        let t = 0.3;
        let zc = COLUMN_H;
        let on = |theta: f64, rr: f64, yy: f64| [xm + rr * theta.cos(), yy, zc + rr * theta.sin()];
        let centre = [xm, y, zc];
        // intrados (underside), extrados (top), two faces
        self.patch(
            |u, v| on(u * PI, rad, y - t + 2.0 * t * v),
            2 * n,
            1,
            Mat::Arch,
            |p| sub(centre, [p[0], y, p[2]]),
        );
        self.patch(
            |u, v| on(u * PI, rad + depth, y - t + 2.0 * t * v),
            2 * n,
            1,
            Mat::Arch,
            |p| sub([p[0], y, p[2]], centre),
        );
        for s in [-1.0, 1.0] {
            self.patch(
                |u, v| on(u * PI, rad + depth * v, y + s * t),
                2 * n,
                1,
                Mat::Arch,
                |_| [0.0, s, 0.0],
            );
        }
    }

    /// Closed box room with inward-facing walls.
    fn room(&mut self, lo: [f64; 3], hi: [f64; 3], n: usize) {
        let d = sub(hi, lo);
        let m = Mat::Chapel;
        self.quad(
            lo,
            [d[0], 0.0, 0.0],
            [0.0, d[1], 0.0],
            n,
            n,
            m,
            [0.0, 0.0, 1.0],
        );
        self.quad(
            [lo[0], lo[1], hi[2]],
            [d[0], 0.0, 0.0],
            [0.0, d[1], 0.0],
            n,
            n,
            m,
            [0.0, 0.0, -1.0],
        );
        self.quad(
            lo,
            [d[0], 0.0, 0.0],
            [0.0, 0.0, d[2]],
            n,
            n,
            m,
            [0.0, 1.0, 0.0],
        );
        self.quad(
            [lo[0], hi[1], lo[2]],
            [d[0], 0.0, 0.0],
            [0.0, 0.0, d[2]],
            n,
            n,
            m,
            [0.0, -1.0, 0.0],
        );
        self.quad(
            lo,
            [0.0, d[1], 0.0],
            [0.0, 0.0, d[2]],
            n,
            n,
            m,
            [1.0, 0.0, 0.0],
        );
        self.quad(
            [hi[0], lo[1], lo[2]],
            [0.0, d[1], 0.0],
            [0.0, 0.0, d[2]],
            n,
            n,
            m,
            [-1.0, 0.0, 0.0],
        );
    }
}

fn lights_for(rng: &mut ChaCha8Rng, count: usize, bays: usize) -> Vec<GeneratedLight> {
    {
        let len_total = bays as f64 * BAY_LEN;
        let gonio = batwing();
        (0..count)
            .map(|i| {
                let in_chapel = rng.random_bool(0.1);
                let position = if in_chapel {
                    let bay = rng.random_range(0..bays);
                    let side = if bay.is_multiple_of(2) { 1.0 } else { -1.0 };
                    let y = side * (NAVE_W / 2.0 + WALL_T + CHAPEL_D / 2.0);
                    [bay as f64 * BAY_LEN + BAY_LEN / 2.0, y, CHAPEL_H - 0.5]
                } else {
                    [
                        rng.random_range(0.5..len_total - 0.5),
                        rng.random_range(-2.5..2.5),
                        rng.random_range(3.0..SPRING_Z - 0.5),
                    ]
                };
                let flux_lm = rng.random_range(500.0..5000.0);
                let kind = match i % 3 {
                    0 => GeneratedLightKind::Point,
                    1 => GeneratedLightKind::Spot,
                    _ => GeneratedLightKind::Goniometric,
                };
                let tilt = [
                    rng.random_range(-0.5..0.5),
                    rng.random_range(-0.5..0.5),
                    -1.0,
                ];
                let (frame, distribution) = match kind {
                    GeneratedLightKind::Point => (
                        LightFrame::identity(),
                        IntensityDistribution::isotropic(1.0).scaled_to_flux(flux_lm),
                    ),
                    GeneratedLightKind::Spot => {
                        let outer = rng.random_range(0.3..0.8);
                        (
                            LightFrame::aimed(tilt),
                            IntensityDistribution::spot(1.0, 0.6 * outer, outer)
                                .scaled_to_flux(flux_lm),
                        )
                    }
                    GeneratedLightKind::Goniometric => (
                        LightFrame::aimed(tilt),
                        gonio.clone().scaled_to_flux(flux_lm),
                    ),
                };
                GeneratedLight {
                    kind,
                    position,
                    frame,
                    distribution,
                }
            })
            .collect()
    }
}

/// A batwing-like goniometric table (10° steps, mild C dependence), 1 cd peak scale.
fn batwing() -> IntensityDistribution {
    let c: Vec<f64> = (0..36).map(|k| k as f64 * 10.0).collect();
    let g: Vec<f64> = (0..=18).map(|k| k as f64 * 10.0).collect();
    let mut cd = Vec::with_capacity(c.len() * g.len());
    for cc in &c {
        for gg in &g {
            let (cr, gr) = (cc.to_radians(), gg.to_radians());
            let down = if *gg <= 90.0 {
                gr.cos() + 0.8 * (2.0 * gr).sin().powi(2)
            } else {
                0.05
            };
            cd.push(down * (1.0 + 0.2 * (2.0 * cr).cos()));
        }
    }
    IntensityDistribution::from_c_gamma_table(&c, &g, &cd)
        .unwrap_or_else(|_| IntensityDistribution::isotropic(1.0))
}
