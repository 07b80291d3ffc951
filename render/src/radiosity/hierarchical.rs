//! Hierarchical radiosity (Hanrahan et al.; Kresse 2003, 2.5–2.6): a quadtree over each
//! input polygon, links between elements at the level the error bound asks for, Jacobi
//! gathering (rayon) with pull of area averages and radiosity extrema, and refinement
//! driven by the receiver's radiosity-function bound (the "form" error of 2.5.2,
//! cancellation-aware: summed over links before taking the spread) and the transfer
//! error of each link (source radiosity extrema × form factor bounds, partial
//! visibility). Shadow rays are cast only for links the visibility classification
//! cannot declare fully visible (2.7).
//!
//! Links are kept on receiver leaves: splitting an element moves its links to its
//! children, so push is the identity and, in a closed scene, the form factors of every
//! leaf sum to one to rounding (a furnace stays exact). Clustering is not implemented:
//! initial linking is quadratic in the number of input polygons.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::scene::{Scene, V3, polygon_area_m2, polygon_normal};

use super::RadiosityError;
use super::curve::{CurvePoint, ErrorCurve, StopReason, StopRule};
use super::form_factor::point_to_polygon;
use super::quadrature;
use super::solution::{Patch, Solution, SolveStats};
use super::visibility::Visibility;

const NONE: u32 = u32::MAX;
/// New links of one element after a refinement round.
type Relinked = (u32, Vec<Link>, Vec<LightLink>);
/// Gauss–Legendre order (per direction) of the receiver average of every link.
const FF_ORDER: usize = 3;

/// Options of the hierarchical solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HierarchicalOptions {
    /// Stop rule (target relative error, time, iterations).
    pub stop: StopRule,
    /// Smallest element area in m²; 0 = 1e-4 of the scene's total area.
    pub min_area_m2: f64,
    /// Deepest quadtree level.
    pub max_level: u8,
    /// Geometric-series (Lyusternik) extrapolation of the Jacobi iteration.
    pub accelerate: bool,
}

impl Default for HierarchicalOptions {
    fn default() -> Self {
        Self {
            stop: StopRule::default(),
            min_area_m2: 0.0,
            max_level: 12,
            accelerate: true,
        }
    }
}

#[derive(Debug, Clone)]
struct Elem {
    verts: Vec<V3>,
    normal: V3,

    area: f64,
    polygon: u32,
    first_child: u32,
    level: u8,
}

/// A link: the receiver (the leaf holding it) gathers from `src`.
#[derive(Debug, Clone, Copy)]
struct Link {
    src: u32,
    /// Area-averaged form factor with visibility.
    ff: f64,
    /// Point form factors with visibility at the receiver's 2×2 Gauss points.
    fk: [f32; 4],
}

#[derive(Debug, Clone, Copy)]
struct LightLink {
    light: u32,
    /// Area-averaged illuminance in lux (per unit light colour Y).
    irr: f64,
    /// Illuminance at the 2×2 Gauss points.
    hk: [f32; 4],
}

struct Ctx<'a> {
    scene: &'a Scene,
    vis: &'a dyn Visibility,
    rho: Vec<[f64; 3]>,
    emit: Vec<[f64; 3]>,
    rays: AtomicU64,
    skipped: AtomicU64,
    tested: AtomicU64,
}

struct Tree {
    elems: Vec<Elem>,
    b: Vec<[f64; 3]>,
    h: Vec<[f64; 3]>,
    bmin: Vec<f64>,
    bmax: Vec<f64>,
    links: Vec<Vec<Link>>,
    llinks: Vec<Vec<LightLink>>,
}

fn make_elem(verts: Vec<V3>, polygon: u32, level: u8) -> Elem {
    let normal = polygon_normal(&verts).unwrap_or_else(V3::z);
    let area = polygon_area_m2(&verts);
    Elem {
        verts,
        normal,

        area,
        polygon,
        first_child: NONE,
        level,
    }
}

fn faces(a: &Elem, b: &Elem) -> bool {
    let scale = (a.area + b.area).sqrt() * 1e-9;
    b.verts
        .iter()
        .any(|v| a.normal.dot(&(v - a.verts[0])) > scale)
        && a.verts
            .iter()
            .any(|v| b.normal.dot(&(v - b.verts[0])) > scale)
}

fn eval_points(verts: &[V3], order: usize) -> Vec<(V3, f64)> {
    let mut pts = Vec::new();
    quadrature::points(verts, order, &mut pts);
    pts
}

fn eval_link(ctx: &Ctx, elems: &[Elem], r: u32, s: u32) -> Link {
    let re = &elems[r as usize];
    let se = &elems[s as usize];
    let candidate = ctx.vis.may_occlude(
        &re.verts,
        re.polygon as usize,
        &se.verts,
        se.polygon as usize,
    );
    if candidate {
        ctx.tested.fetch_add(1, Ordering::Relaxed);
    } else {
        ctx.skipped.fetch_add(1, Ordering::Relaxed);
    }
    let src_pts = if candidate {
        eval_points(&se.verts, 2)
    } else {
        Vec::new()
    };
    let skip = [re.polygon as usize, se.polygon as usize];
    let point_ff = |x: &V3| -> f64 {
        let f = point_to_polygon(x, &re.normal, &se.verts, &se.normal);
        if f <= 0.0 || !candidate {
            return f;
        }
        let mut visible = 0usize;
        for (y, _) in &src_pts {
            if !ctx.vis.occluded(x, y, skip) {
                visible += 1;
            }
        }
        ctx.rays.fetch_add(src_pts.len() as u64, Ordering::Relaxed);
        f * visible as f64 / src_pts.len() as f64
    };
    let p2 = eval_points(&re.verts, 2);
    let mut fk = [0f32; 4];
    let mut ff = 0.0;
    for (k, (x, w)) in p2.iter().enumerate().take(4) {
        let f = point_ff(x);
        fk[k] = f as f32;
        ff += w * f;
    }
    // the same order for every link of a receiver keeps Σ F = 1 exact in closed scenes
    if FF_ORDER != 2 {
        ff = eval_points(&re.verts, FF_ORDER)
            .iter()
            .map(|(x, w)| w * point_ff(x))
            .sum();
    }
    Link { src: s, ff, fk }
}

fn eval_light(ctx: &Ctx, elems: &[Elem], r: u32, light: u32) -> LightLink {
    let re = &elems[r as usize];
    let l = &ctx.scene.lights[light as usize];
    let candidate = ctx
        .vis
        .may_occlude(&[l.position], usize::MAX, &re.verts, re.polygon as usize);
    let irr_at = |x: &V3| -> f64 {
        let d = l.position - x;
        let d2 = d.norm_squared();
        if d2 <= 0.0 {
            return 0.0;
        }
        let dn = d / d2.sqrt();
        let cos_r = re.normal.dot(&dn);
        if cos_r <= 0.0 {
            return 0.0;
        }
        if candidate {
            ctx.rays.fetch_add(1, Ordering::Relaxed);
            if ctx
                .vis
                .occluded(&l.position, x, [usize::MAX, re.polygon as usize])
            {
                return 0.0;
            }
        }
        l.intensity_cd(&(-dn)) * cos_r / d2
    };
    let mut hk = [0f32; 4];
    for (k, (x, _)) in eval_points(&re.verts, 2).iter().enumerate().take(4) {
        hk[k] = irr_at(x) as f32;
    }
    let irr = eval_points(&re.verts, 3)
        .iter()
        .map(|(x, w)| w * irr_at(x))
        .sum();
    LightLink { light, irr, hk }
}

impl Tree {
    fn is_leaf(&self, e: usize) -> bool {
        self.elems[e].first_child == NONE
    }

    fn leaves(&self) -> Vec<u32> {
        (0..self.elems.len() as u32)
            .filter(|&e| self.is_leaf(e as usize))
            .collect()
    }

    fn split(&mut self, e: usize) {
        if !self.is_leaf(e) {
            return;
        }
        let first = self.elems.len() as u32;
        let kids = quadrature::split4(&self.elems[e].verts);
        let (poly, level) = (self.elems[e].polygon, self.elems[e].level + 1);
        for k in kids {
            self.elems.push(make_elem(k, poly, level));
            self.b.push(self.b[e]);
            self.h.push(self.h[e]);
            self.bmin.push(self.bmin[e]);
            self.bmax.push(self.bmax[e]);
            self.links.push(Vec::new());
            self.llinks.push(Vec::new());
        }
        self.elems[e].first_child = first;
    }

    fn children(&self, e: usize) -> std::ops::Range<u32> {
        let f = self.elems[e].first_child;
        f..f + 4
    }

    /// Point irradiance (Y) at the 2×2 points, the averaged irradiance (XYZ) and the
    /// transfer error from non-uniform sources.
    fn leaf_estimate(&self, ctx: &Ctx, r: usize) -> ([f64; 4], [f64; 3], f64) {
        let mut hk = [0.0f64; 4];
        let mut h = [0.0f64; 3];
        let mut src_err = 0.0;
        for l in &self.links[r] {
            let s = l.src as usize;
            let bs = self.b[s];
            for c in 0..3 {
                h[c] += l.ff * bs[c];
            }
            for (acc, f) in hk.iter_mut().zip(&l.fk) {
                *acc += f64::from(*f) * bs[1];
            }
            src_err += 0.5 * l.ff * (self.bmax[s] - self.bmin[s]);
        }
        for l in &self.llinks[r] {
            let col = ctx.scene.lights[l.light as usize].color_xyz;
            for c in 0..3 {
                h[c] += l.irr * col[c];
            }
            for (acc, v) in hk.iter_mut().zip(&l.hk) {
                *acc += f64::from(*v) * col[1];
            }
        }
        (hk, h, src_err)
    }

    /// Reflectance below which a receiver's error is measured as illuminance (lux)
    /// instead of radiosity: black measuring planes must still be resolved.
    const DARK: f64 = 0.05;

    /// Weight of the illuminance deviation in a leaf's error: ρ (radiosity error) for
    /// visible surfaces, 1 (illuminance error) for dark ones.
    fn error_weight(ctx: &Ctx, polygon: u32) -> f64 {
        let rho = ctx.rho[polygon as usize][1];
        if rho > Self::DARK { rho } else { 1.0 }
    }

    /// The quantity a leaf's error is relative to: its radiosity Y (lm/m²), or its
    /// illuminance (lux) on dark surfaces.
    fn error_norm(&self, ctx: &Ctx, r: usize) -> f64 {
        if ctx.rho[self.elems[r].polygon as usize][1] > Self::DARK {
            self.b[r][1]
        } else {
            self.h[r][1]
        }
    }

    /// Estimated mean absolute deviation of the leaf's true radiosity (or, on dark
    /// surfaces, illuminance) from its constant value: ρ times the spread of the summed
    /// point irradiances at the 2×2 Gauss points (for a linear variation this matches
    /// the L1 error of the constant basis) plus a quarter of the transfer bound of
    /// non-uniform sources (the mean absolute deviation of a value spread uniformly
    /// between the extrema).
    fn leaf_error(&self, ctx: &Ctx, r: usize) -> f64 {
        let (hk, _, src_err) = self.leaf_estimate(ctx, r);
        let mean = hk.iter().sum::<f64>() / 4.0;
        let mad = hk.iter().map(|v| (v - mean).abs()).sum::<f64>() / 4.0;
        Self::error_weight(ctx, self.elems[r].polygon) * (mad + 0.25 * src_err)
    }

    fn pull(&mut self) {
        for e in (0..self.elems.len()).rev() {
            if self.is_leaf(e) {
                self.bmin[e] = self.b[e][1];
                self.bmax[e] = self.b[e][1];
                continue;
            }
            let mut b = [0.0; 3];
            let mut h = [0.0; 3];
            let mut lo = f64::INFINITY;
            let mut hi = f64::NEG_INFINITY;
            for c in self.children(e) {
                let c = c as usize;
                let a = self.elems[c].area;
                for k in 0..3 {
                    b[k] += a * self.b[c][k];
                    h[k] += a * self.h[c][k];
                }
                lo = lo.min(self.bmin[c]);
                hi = hi.max(self.bmax[c]);
            }
            let a = self.elems[e].area.max(1e-300);
            self.b[e] = b.map(|v| v / a);
            self.h[e] = h.map(|v| v / a);
            self.bmin[e] = lo;
            self.bmax[e] = hi;
        }
    }

    fn memory_bytes(&self) -> usize {
        let links: usize = self.links.iter().map(|l| l.capacity()).sum();
        let llinks: usize = self.llinks.iter().map(|l| l.capacity()).sum();
        self.elems.len()
            * (std::mem::size_of::<Elem>() + 4 * std::mem::size_of::<V3>() + 2 * 24 + 16 + 2 * 24)
            + links * std::mem::size_of::<Link>()
            + llinks * std::mem::size_of::<LightLink>()
    }

    fn link_count(&self) -> usize {
        self.links.iter().map(Vec::len).sum::<usize>()
            + self.llinks.iter().map(Vec::len).sum::<usize>()
    }
}

/// One refinement round set: splits what the bounds ask for at the absolute radiosity
/// tolerance `eps` (lm/m²). Returns the number of elements split.
fn refine(
    tree: &mut Tree,
    ctx: &Ctx,
    eps: f64,
    min_area: f64,
    max_level: u8,
    deadline: Option<Instant>,
) -> usize {
    let mut total = 0;
    for _round in 0..64 {
        if deadline.is_some_and(|d| Instant::now() > d) {
            break;
        }
        let leaves = tree.leaves();
        let splittable = |e: usize| {
            let el = &tree.elems[e];
            el.first_child != NONE || (el.area * 0.25 >= min_area && el.level < max_level)
        };
        let decisions: Vec<(u32, bool, Vec<usize>)> = leaves
            .par_iter()
            .filter_map(|&r| {
                let ri = r as usize;
                let err = tree.leaf_error(ctx, ri);
                if err <= eps {
                    return None;
                }
                let can_r = splittable(ri);
                let mut split_r = false;
                let mut srcs = Vec::new();
                for (i, l) in tree.links[ri].iter().enumerate() {
                    let s = l.src as usize;
                    let (lo, hi) =
                        l.fk.iter()
                            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                                (a.min(v as f64), b.max(v as f64))
                            });
                    let e = Tree::error_weight(ctx, tree.elems[ri].polygon)
                        * (tree.b[s][1] * (hi - lo) + l.ff * (tree.bmax[s] - tree.bmin[s]));
                    if e > 0.25 * eps {
                        let can_s = splittable(s);
                        // sources are split only while larger than the receiver, which
                        // keeps the links per leaf bounded once receivers reach the
                        // minimum size
                        if can_s && tree.elems[s].area > tree.elems[ri].area {
                            srcs.push(i);
                        } else if can_r {
                            split_r = true;
                        }
                    }
                }
                if !split_r && srcs.is_empty() && can_r {
                    // the error comes from many small contributions or from lights
                    split_r = true;
                }
                if split_r || !srcs.is_empty() {
                    Some((r, split_r, srcs))
                } else {
                    None
                }
            })
            .collect();
        if decisions.is_empty() {
            break;
        }
        // elements to split: receivers, and leaf sources
        let mut to_split: Vec<usize> = Vec::new();
        for (r, split_r, srcs) in &decisions {
            if *split_r {
                to_split.push(*r as usize);
            }
            for &i in srcs {
                let s = tree.links[*r as usize][i].src as usize;
                if tree.is_leaf(s) {
                    to_split.push(s);
                }
            }
        }
        to_split.sort_unstable();
        to_split.dedup();
        let mut expand: Vec<Option<Vec<usize>>> = vec![None; tree.elems.len()];
        for (r, _, srcs) in decisions {
            expand[r as usize] = Some(srcs);
        }
        let split_set: std::collections::HashSet<usize> = to_split.iter().copied().collect();
        for &e in &to_split {
            tree.split(e);
        }
        total += to_split.len();
        // relink: every old leaf that was split or had sources expanded
        let jobs: Vec<usize> = leaves
            .iter()
            .map(|&r| r as usize)
            .filter(|r| split_set.contains(r) || expand[*r].is_some())
            .collect();
        let t = &*tree;
        let results: Vec<(usize, Vec<Relinked>)> = jobs
            .par_iter()
            .map(|&r| {
                let srcs_split: &[usize] = expand[r].as_deref().unwrap_or(&[]);
                // sources after expansion, with the links kept as they are
                let mut keep: Vec<Link> = Vec::new();
                let mut new_src: Vec<u32> = Vec::new();
                for (i, l) in t.links[r].iter().enumerate() {
                    if srcs_split.contains(&i) {
                        new_src.extend(t.children(l.src as usize));
                    } else {
                        keep.push(*l);
                    }
                }
                if split_set.contains(&r) {
                    let out = t
                        .children(r)
                        .map(|c| {
                            let ce = &t.elems[c as usize];
                            let links = keep
                                .iter()
                                .map(|l| l.src)
                                .chain(new_src.iter().copied())
                                .filter(|&s| faces(ce, &t.elems[s as usize]))
                                .map(|s| eval_link(ctx, &t.elems, c, s))
                                .filter(|l| l.ff > 0.0 || l.fk.iter().any(|&v| v > 0.0))
                                .collect();
                            let llinks = t.llinks[r]
                                .iter()
                                .map(|l| eval_light(ctx, &t.elems, c, l.light))
                                .collect();
                            (c, links, llinks)
                        })
                        .collect();
                    (r, out)
                } else {
                    let mut links = keep;
                    let re = &t.elems[r];
                    links.extend(
                        new_src
                            .iter()
                            .filter(|&&s| faces(re, &t.elems[s as usize]))
                            .map(|&s| eval_link(ctx, &t.elems, r as u32, s))
                            .filter(|l| l.ff > 0.0 || l.fk.iter().any(|&v| v > 0.0)),
                    );
                    (r, vec![(r as u32, links, t.llinks[r].clone())])
                }
            })
            .collect();
        for (r, outs) in results {
            if split_set.contains(&r) {
                tree.links[r] = Vec::new();
                tree.llinks[r] = Vec::new();
            }
            for (e, l, ll) in outs {
                tree.links[e as usize] = l;
                tree.llinks[e as usize] = ll;
            }
        }
    }
    total
}

fn weighted(tree: &Tree, leaves: &[u32], f: impl Fn(usize) -> f64) -> f64 {
    leaves
        .iter()
        .map(|&e| tree.elems[e as usize].area * f(e as usize))
        .sum()
}

/// Solves a scene by hierarchical radiosity. `vis` answers visibility (use
/// [`super::visibility::SceneOccluders`] or a BVH).
pub fn solve_hierarchical(
    scene: &Scene,
    vis: &dyn Visibility,
    opts: &HierarchicalOptions,
) -> Result<Solution, RadiosityError> {
    let start = Instant::now();
    let deadline = opts.stop.time_limit.map(|t| start + t);
    super::validate(scene, opts.stop.target_error)?;
    let ctx = Ctx {
        scene,
        vis,
        rho: scene
            .polygons
            .iter()
            .map(|p| scene.materials[p.material].reflectance_xyz)
            .collect(),
        emit: scene
            .polygons
            .iter()
            .map(|p| {
                scene.materials[p.material]
                    .emission_cd_m2
                    .map(|l| std::f64::consts::PI * l)
            })
            .collect(),
        rays: AtomicU64::new(0),
        skipped: AtomicU64::new(0),
        tested: AtomicU64::new(0),
    };
    let n = scene.polygons.len();
    let mut tree = Tree {
        elems: scene
            .polygons
            .iter()
            .enumerate()
            .map(|(i, p)| make_elem(p.vertices.clone(), i as u32, 0))
            .collect(),
        b: ctx.emit.clone(),
        h: vec![[0.0; 3]; n],
        bmin: ctx.emit.iter().map(|e| e[1]).collect(),
        bmax: ctx.emit.iter().map(|e| e[1]).collect(),
        links: vec![Vec::new(); n],
        llinks: vec![Vec::new(); n],
    };
    let total_area: f64 = tree.elems.iter().map(|e| e.area).sum();
    let min_area = if opts.min_area_m2 > 0.0 {
        opts.min_area_m2
    } else {
        1e-4 * total_area
    };
    // initial links between all facing root pairs (no clustering)
    {
        let t = &tree;
        let init: Vec<(Vec<Link>, Vec<LightLink>)> = (0..n as u32)
            .into_par_iter()
            .map(|r| {
                let re = &t.elems[r as usize];
                let links = (0..n as u32)
                    .filter(|&s| s != r && faces(re, &t.elems[s as usize]))
                    .map(|s| eval_link(&ctx, &t.elems, r, s))
                    .filter(|l| l.ff > 0.0 || l.fk.iter().any(|&v| v > 0.0))
                    .collect();
                let llinks = (0..scene.lights.len() as u32)
                    .map(|l| eval_light(&ctx, &t.elems, r, l))
                    .filter(|l| l.irr > 0.0 || l.hk.iter().any(|&v| v > 0.0))
                    .collect();
                (links, llinks)
            })
            .collect();
        for (i, (l, ll)) in init.into_iter().enumerate() {
            tree.links[i] = l;
            tree.llinks[i] = ll;
        }
    }
    // reference exitance for the absolute tolerance: emitted flux spread over the area,
    // amplified by the mean reflectance
    let phi = scene.emitted_flux_xyz_lm()[1];
    let rho_mean = weighted(&tree, &tree.leaves(), |e| {
        ctx.rho[tree.elems[e].polygon as usize][1]
    }) / total_area;
    let b_ref0 = phi / total_area / (1.0 - rho_mean).max(1e-6);
    let target = opts.stop.target_error;
    let mut eps = target * b_ref0;
    let mut curve = ErrorCurve::default();
    let mut iterations = 0usize;
    let mut extrapolations = 0usize;
    let stop;
    let mut leaves = tree.leaves();
    let mut q_hist: Vec<f64> = Vec::new();
    let mut res_prev = f64::NAN;
    let mut idle_refines = 0usize;
    let mut needs_refine = true;
    loop {
        if needs_refine {
            let splits = refine(&mut tree, &ctx, eps, min_area, opts.max_level, deadline);
            leaves = tree.leaves();
            idle_refines = if splits == 0 { idle_refines + 1 } else { 0 };
            q_hist.clear();
            res_prev = f64::NAN;
            needs_refine = false;
        }
        // one Jacobi gather sweep over the leaves
        let t = &tree;
        let new: Vec<([f64; 3], [f64; 3])> = leaves
            .par_iter()
            .map(|&r| {
                let r = r as usize;
                let (_, h, _) = t.leaf_estimate(&ctx, r);
                let p = t.elems[r].polygon as usize;
                let (rho, e) = (ctx.rho[p], ctx.emit[p]);
                (
                    [
                        e[0] + rho[0] * h[0],
                        e[1] + rho[1] * h[1],
                        e[2] + rho[2] * h[2],
                    ],
                    h,
                )
            })
            .collect();
        let mut num = 0.0;
        let mut den = 0.0;
        let mut delta: Vec<[f64; 3]> = Vec::with_capacity(leaves.len());
        for (&r, (b, h)) in leaves.iter().zip(&new) {
            let r = r as usize;
            let a = tree.elems[r].area;
            let d = [
                b[0] - tree.b[r][0],
                b[1] - tree.b[r][1],
                b[2] - tree.b[r][2],
            ];
            num += a * d[1].abs();
            den += a * b[1].abs();
            delta.push(d);
            tree.b[r] = *b;
            tree.h[r] = *h;
        }
        iterations += 1;
        let res = if den > 0.0 { num / den } else { 0.0 };
        if !res.is_finite() {
            return Err(RadiosityError::Diverged(format!(
                "residual became {res} after {iterations} sweeps"
            )));
        }
        // contraction ratio of the absolute update (Jacobi: → spectral radius)
        let q = if res_prev.is_finite() && res_prev > 0.0 {
            num / res_prev
        } else {
            f64::NAN
        };
        res_prev = num;
        let rho_max = ctx.rho.iter().map(|r| r[1]).fold(0.0, f64::max);
        let q_est = if q.is_finite() && q < 1.0 {
            q.max(0.0)
        } else {
            rho_max
        };
        // remaining error of the geometric tail: |Δ| q / (1 − q)
        let solve_err = res * q_est / (1.0 - q_est).max(1e-12);
        if q.is_finite() {
            q_hist.push(q);
        }
        // geometric-series (Lyusternik) extrapolation once the ratio is stable; the
        // next sweep measures how well it worked
        if opts.accelerate && q_hist.len() >= 2 {
            let (q1, q2) = (q_hist[q_hist.len() - 2], q_hist[q_hist.len() - 1]);
            if q2 < 1.0 && q2 > 0.0 && (q2 - q1).abs() <= 0.01 * (1.0 - q2) {
                let g = q2 / (1.0 - q2);
                for (&r, d) in leaves.iter().zip(&delta) {
                    let r = r as usize;
                    let p = tree.elems[r].polygon as usize;
                    for ((b, dc), e) in tree.b[r].iter_mut().zip(d).zip(&ctx.emit[p]) {
                        *b = (*b + g * dc).max(*e);
                    }
                }
                extrapolations += 1;
                q_hist.clear();
                res_prev = f64::NAN;
            }
        }
        tree.pull();

        let nsum = weighted(&tree, &leaves, |e| tree.error_norm(&ctx, e)).max(1e-300);
        let disc = weighted(&tree, &leaves, |e| tree.leaf_error(&ctx, e)) / nsum;
        curve.points.push(CurvePoint {
            time_s: start.elapsed().as_secs_f64(),
            iteration: iterations,
            estimated_error: solve_err + disc,
            solve_error: solve_err,
            discretization_error: disc,
            patches: leaves.len(),
            links: tree.link_count(),
        });
        tracing::debug!(
            iterations,
            solve_err,
            disc,
            patches = leaves.len(),
            "hierarchical sweep"
        );
        if solve_err + disc <= target {
            stop = StopReason::Converged;
            break;
        }
        if deadline.is_some_and(|d| Instant::now() > d) {
            stop = StopReason::TimeLimit;
            break;
        }
        if iterations >= opts.stop.max_iterations {
            stop = StopReason::IterationLimit;
            break;
        }
        if solve_err <= 0.25 * target.min(disc.max(target * 0.1)) {
            // the linear solve is ahead of the mesh: refine
            if idle_refines >= 4 {
                stop = StopReason::RefinementExhausted;
                break;
            }
            let n_avg = nsum / total_area;
            eps = (0.5 * eps).min(target * n_avg);
            needs_refine = true;
        }
    }
    let stats = SolveStats {
        patches: leaves.len(),
        elements: tree.elems.len(),
        links: tree.link_count(),
        iterations,
        shadow_rays: ctx.rays.load(Ordering::Relaxed),
        visibility_skipped: ctx.skipped.load(Ordering::Relaxed),
        visibility_tested: ctx.tested.load(Ordering::Relaxed),
        memory_bytes: tree.memory_bytes(),
        time_s: start.elapsed().as_secs_f64(),
        extrapolations,
    };
    let patches: Vec<Patch> = leaves
        .iter()
        .map(|&e| {
            let el = &tree.elems[e as usize];
            Patch {
                polygon: el.polygon as usize,
                vertices: el.verts.clone(),
                normal: el.normal,
                area_m2: el.area,
                exitance_xyz: tree.b[e as usize],
                irradiance_xyz: tree.h[e as usize],
            }
        })
        .collect();
    let by_polygon = Solution::index(&patches, n);
    Ok(Solution {
        patches,
        by_polygon,
        curve,
        stop,
        stats,
    })
}
