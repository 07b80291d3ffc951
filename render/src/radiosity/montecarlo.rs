//! An independent reference for scenes too large for the dense solver: Monte Carlo
//! estimates of the mean irradiance over given patches, by path tracing with
//! next-event estimation (one light per vertex, picked in proportion to its
//! unoccluded contribution, with one shadow ray), cosine-weighted bounces and Russian
//! roulette on the reflectance. It shares nothing with the radiosity solvers but the
//! scene: its own BVH, no form factors, no links.

// per-channel XYZ arithmetic reads clearest with channel indices
#![allow(
    clippy::needless_range_loop,
    reason = "per-channel XYZ arithmetic reads clearest with channel indices"
)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::mesh::Bvh;
use crate::scene::{Scene, V3, polygon_normal};

/// A light as the path tracer samples it.
enum Source {
    Point { light: usize, position: V3 },
    Distant { direction: V3, normal_lux: f64 },
}

/// The path tracer over one scene.
pub struct MonteCarloReference<'a> {
    scene: &'a Scene,
    bvh: Bvh,
    tri_polygon: Vec<u32>,
    normals: Vec<V3>,
    sources: Vec<(Source, [f64; 3])>,
    /// Offset of ray origins off their surface (m).
    eps: f64,
    far: f64,
}

/// A patch-mean estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PatchEstimate {
    /// Mean irradiance over the patch, XYZ (Y in lux).
    pub irradiance_xyz: [f64; 3],
    /// Standard error of the Y mean (lux).
    pub std_error_y: f64,
}

impl<'a> MonteCarloReference<'a> {
    /// Builds the tracer (BVH over every polygon, quads split).
    pub fn new(scene: &'a Scene) -> Self {
        let mut tris = Vec::new();
        let mut tri_polygon = Vec::new();
        let mut lo = V3::repeat(f64::INFINITY);
        let mut hi = V3::repeat(f64::NEG_INFINITY);
        for (pi, p) in scene.polygons.iter().enumerate() {
            for v in &p.vertices {
                lo = lo.inf(v);
                hi = hi.sup(v);
            }
            for k in 1..p.vertices.len().saturating_sub(1) {
                let t = [p.vertices[0], p.vertices[k], p.vertices[k + 1]];
                tris.push(t.map(|v| [v.x, v.y, v.z]));
                tri_polygon.push(pi as u32);
            }
        }
        let normals = scene
            .polygons
            .iter()
            .map(|p| polygon_normal(&p.vertices).unwrap_or_else(V3::z))
            .collect();
        let mut sources: Vec<(Source, [f64; 3])> = scene
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| {
                (
                    Source::Point {
                        light: i,
                        position: l.position,
                    },
                    l.color_xyz,
                )
            })
            .collect();
        if let Some(d) = &scene.sky {
            for s in d.sources() {
                sources.push((
                    Source::Distant {
                        direction: s.direction.normalize(),
                        normal_lux: s.normal_illuminance_lux,
                    },
                    s.color_xyz,
                ));
            }
        }
        let diag = (hi - lo).norm().max(1e-6);
        Self {
            scene,
            bvh: Bvh::build(&tris),
            tri_polygon,
            normals,
            sources,
            eps: 1e-7 * diag,
            far: 4.0 * diag,
        }
    }

    /// Direct illuminance (Y per unit colour) of every source at `x` with normal `n`,
    /// unoccluded.
    fn contributions(&self, x: &V3, n: &V3, out: &mut Vec<f64>) {
        out.clear();
        for (s, _) in &self.sources {
            out.push(match s {
                Source::Point { light, position } => {
                    let d = position - x;
                    let d2 = d.norm_squared();
                    let u = d / d2.sqrt();
                    let c = n.dot(&u);
                    if c <= 0.0 {
                        0.0
                    } else {
                        self.scene.lights[*light].intensity_cd(&(-u)) * c / d2
                    }
                }
                Source::Distant {
                    direction,
                    normal_lux,
                } => normal_lux * n.dot(direction).max(0.0),
            });
        }
    }

    /// One-sample estimate of the direct illuminance (XYZ) at `x`.
    fn direct(&self, x: &V3, n: &V3, rng: &mut ChaCha8Rng, buf: &mut Vec<f64>) -> [f64; 3] {
        self.contributions(x, n, buf);
        let total: f64 = buf.iter().sum();
        if total <= 0.0 {
            return [0.0; 3];
        }
        let mut pick = rng.random::<f64>() * total;
        let mut i = 0;
        while i + 1 < buf.len() && pick >= buf[i] {
            pick -= buf[i];
            i += 1;
        }
        let origin = x + n * self.eps;
        let end = match &self.sources[i].0 {
            Source::Point { position, .. } => *position,
            Source::Distant { direction, .. } => x + direction * self.far,
        };
        if self
            .bvh
            .occluded([origin.x, origin.y, origin.z], [end.x, end.y, end.z])
        {
            return [0.0; 3];
        }
        // c_i·V_i / p_i with p_i = c_i / Σc
        self.sources[i].1.map(|c| total * c)
    }

    /// One path from `x`: direct light plus everything a cosine-weighted bounce
    /// brings back (radiance L = B/π over a cosine-weighted direction integrates to
    /// the hit point's exitance).
    fn irradiance_sample(
        &self,
        x: V3,
        n: V3,
        rng: &mut ChaCha8Rng,
        buf: &mut Vec<f64>,
    ) -> [f64; 3] {
        let mut h = self.direct(&x, &n, rng, buf);
        let mut weight = [1.0; 3];
        let (mut x, mut n) = (x, n);
        for _bounce in 0..64 {
            let dir = cosine_direction(&n, rng);
            let o = x + n * self.eps;
            let Some(hit) =
                self.bvh
                    .intersect([o.x, o.y, o.z], [dir.x, dir.y, dir.z], f64::INFINITY)
            else {
                break;
            };
            if !hit.front_face {
                break; // surfaces are one-sided: their back is black
            }
            let poly = self.tri_polygon[hit.triangle as usize] as usize;
            let m = self.scene.material_of(poly);
            let y = o + dir * hit.t;
            let e = m.emission_cd_m2.map(|l| std::f64::consts::PI * l);
            for c in 0..3 {
                h[c] += weight[c] * e[c];
            }
            // continue with probability ρ_Y (Russian roulette), weight ρ/ρ_Y
            let rho = m.reflectance_xyz;
            let q = rho[1].clamp(0.0, 1.0);
            if q <= 0.0 || rng.random::<f64>() >= q {
                break;
            }
            for c in 0..3 {
                weight[c] *= rho[c] / q;
            }
            n = self.normals[poly];
            x = y;
            let d = self.direct(&x, &n, rng, buf);
            for c in 0..3 {
                h[c] += weight[c] * d[c];
            }
        }
        h
    }

    /// Mean irradiance over the patch `verts` (a triangle or quad on polygon `poly`)
    /// from `paths` paths started at uniformly distributed points.
    pub fn patch_irradiance(
        &self,
        verts: &[V3],
        poly: usize,
        paths: usize,
        seed: u64,
    ) -> PatchEstimate {
        let n = self.normals[poly];
        let chunks = 16usize;
        let per = paths.div_ceil(chunks).max(1);
        let sums: Vec<([f64; 3], f64, usize)> = (0..chunks)
            .into_par_iter()
            .map(|k| {
                let mut rng = ChaCha8Rng::seed_from_u64(
                    seed.wrapping_mul(0x9E37_79B9).wrapping_add(k as u64),
                );
                let mut buf = Vec::with_capacity(self.sources.len());
                let mut s = [0.0; 3];
                let mut s2 = 0.0;
                for _ in 0..per {
                    let x = uniform_point(verts, &mut rng);
                    let h = self.irradiance_sample(x, n, &mut rng, &mut buf);
                    for c in 0..3 {
                        s[c] += h[c];
                    }
                    s2 += h[1] * h[1];
                }
                (s, s2, per)
            })
            .collect();
        let total: usize = sums.iter().map(|x| x.2).sum();
        let mut mean = [0.0; 3];
        let mut sq = 0.0;
        for (s, s2, _) in &sums {
            for c in 0..3 {
                mean[c] += s[c];
            }
            sq += s2;
        }
        let nf = total as f64;
        let mean = mean.map(|v| v / nf);
        let var = (sq / nf - mean[1] * mean[1]).max(0.0);
        PatchEstimate {
            irradiance_xyz: mean,
            std_error_y: (var / nf).sqrt(),
        }
    }
}

/// A cosine-distributed unit direction about `n` (Malley's method).
fn cosine_direction(n: &V3, rng: &mut ChaCha8Rng) -> V3 {
    let u: f64 = rng.random();
    let v: f64 = rng.random();
    super::quadrature::cosine_direction(n, u, v).normalize()
}

/// A uniformly distributed point on a triangle or (planar convex) quad.
fn uniform_point(verts: &[V3], rng: &mut ChaCha8Rng) -> V3 {
    let r: [f64; 3] = [rng.random(), rng.random(), rng.random()];
    super::quadrature::uniform_point(verts, r[0], r[1], r[2])
}
