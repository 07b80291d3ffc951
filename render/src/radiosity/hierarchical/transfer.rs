//! Links and their transfer coefficients (Kresse 2.6.1) for every pair of sender and
//! receiver kinds: the coefficient averaged over the receiver and at its shape
//! samples, its extrema over the receiver (the analytic form-factor maximum of 2.6.1
//! where one exists), and the visible fraction: the classification first, shadow rays
//! only for pairs it cannot declare fully visible (2.7), and "fully visible" inherited
//! by every sub-link without a new test.

use std::sync::atomic::Ordering;

use crate::scene::{Scene, V3};

use super::super::RayCounters;
use super::super::form_factor::{point_to_polygon, point_to_small_polygon, targets_in_front};
use super::super::quadrature;
use super::super::visibility::{Visibility, point_in_convex};
use super::emitters::Emitter;
use super::nodes::{Hierarchy, Kind, Node, Patch, link_seed};
use super::sampling::{NS, Samples};

/// Random points per cluster end for the shadow rays of a cluster link.
const CLUSTER_RAYS: usize = 4;

/// What link evaluation needs besides the hierarchy.
pub(super) struct Ctx<'a> {
    pub scene: &'a Scene,
    pub emitters: &'a [Emitter],
    pub vis: &'a dyn Visibility,
    /// A length beyond the scene, for rays towards distant sources.
    pub far: f64,
    pub counters: RayCounters,
}

/// A link whose receiver is a patch element. The irradiance it brings is `k·σ` with σ
/// the sender's strength: radiosity B (lm/m²) of a patch, intensity I (cd) towards
/// the receiver of a cluster, the colour of an emitter (k then in lux).
#[derive(Debug, Clone, Copy)]
pub(super) struct PLink {
    pub src: Node,
    /// Receiver average, with visibility.
    pub k: f32,
    /// At the shape samples (corners, centre), with visibility (read them with
    /// [`PLink::ks`]). Not quantised further: 16-bit steps of the link's peak, times
    /// the 1/(1 − ρ) of a stiff room, made every receiver look uneven (the ρ = 0.999
    /// furnace refined without end).
    pub ks: [f32; NS],
    /// Largest value over the receiver, unoccluded (criterion).
    pub kmax: f32,
    /// For a cluster sender, ∂k/∂(sender position): its light leaves from the flux
    /// centroid of its contents, which moves as the solution does; k was evaluated
    /// at the area centroid and is corrected to first order.
    pub grad: [f32; 3],
    /// Relative uncertainty of k·σ from sampling a partial visibility.
    pub rel_vis: f32,
    /// Classified fully visible (children inherit it).
    pub visible: bool,
    /// The coefficient is not valid at this level (the receiver lies inside a sender
    /// cluster's bounds): the sender must be split.
    pub overlap: bool,
}

/// A link whose receiver is a cluster. Its light reaches each contained polygon by
/// the polygon's own distance and orientation (see `sweep`): `k·v·σ` is the normal
/// irradiance at the cluster's centre, facing the sender.
#[derive(Debug, Clone, Copy)]
pub(super) struct CLink {
    pub src: Node,
    /// Distance from the receiver's centre to the sender (infinite for a distant
    /// source).
    pub d: f32,
    /// Normal-irradiance coefficient at the centre, unoccluded.
    pub k: f32,
    /// Visible fraction (shadow rays between contents and sender).
    pub v: f32,
    /// Relative uncertainty from the sender's extent.
    pub rel_src: f32,
    /// Uncertainty of the visible fraction taken for every polygon inside, relative
    /// to the unoccluded transfer: how unevenly the visible part falls on the
    /// receiver, and the sampling error of the fraction. The segments join random
    /// points, fresh for every link, so the fraction is unbiased and its errors are
    /// independent between links.
    pub rel_vis: f32,
    /// Whether the pair is too close for a cluster link.
    pub overlap: Overlap,
}

/// Why a cluster link cannot carry light at its level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Overlap {
    /// It can.
    None,
    /// The bounding spheres meet: split the larger end.
    Near,
    /// The sender patch's plane cuts the receiver's box (a support-plane split, Kresse
    /// 2.6.2): only splitting the receiver resolves it.
    Plane,
}

impl PLink {
    /// The coefficients at the shape samples (corners, centre), with visibility.
    pub(crate) fn ks(&self) -> [f64; NS] {
        self.ks.map(f64::from)
    }

    /// The coefficient for a sender whose light now leaves `shift` away from where
    /// the link was evaluated (first order, clamped at zero), and the factor that
    /// scales the shape samples alike.
    pub(crate) fn corrected(&self, shift: &V3) -> (f64, f64) {
        let k = f64::from(self.k);
        if *shift == V3::zeros() || k <= 0.0 {
            return (k, 1.0);
        }
        let g = V3::new(
            f64::from(self.grad[0]),
            f64::from(self.grad[1]),
            f64::from(self.grad[2]),
        );
        let kc = (k + g.dot(shift)).clamp(0.0, 2.0 * k);
        (kc, kc / k)
    }
}

/// Irradiance of a uniform spherical source of angular radius σ on a surface whose
/// normal makes the angle θ with the source's centre, relative to the normal
/// irradiance (Snyder 1996): cos θ while the source is wholly above the horizon, a
/// smooth closed form while the horizon cuts it, 0 below. Using max(0, cos θ) of the
/// centre instead underestimates grazing receivers (Jensen's inequality).
pub(super) fn effective_cos(cos_theta: f64, sin2_sigma: f64) -> f64 {
    let c = cos_theta.clamp(-1.0, 1.0);
    let s2 = sin2_sigma.clamp(0.0, 1.0);
    if s2 <= 0.0 || c * c > s2 {
        return c.max(0.0);
    }
    let st = (1.0 - c * c).sqrt();
    let x = (1.0 / s2 - 1.0).sqrt();
    let y = if st > 0.0 { -x * c / st } else { -1.0 };
    let y = y.clamp(-1.0, 1.0);
    let z = st * (1.0 - y * y).sqrt();
    let e = (c * y.acos() - x * z) * s2 + (z / x).atan();
    (e / (std::f64::consts::PI * s2)).max(0.0)
}

fn faces(a: &Patch, b: &Patch) -> bool {
    let scale = (a.area + b.area).sqrt() * 1e-9;
    b.verts()
        .iter()
        .any(|v| a.normal.dot(&(v - a.verts[0])) > scale)
        && a.verts()
            .iter()
            .any(|v| b.normal.dot(&(v - b.verts[0])) > scale)
}

impl Ctx<'_> {
    fn classify(&self, a: &[V3], a_poly: usize, b: &[V3], b_poly: usize) -> bool {
        let partial = self.vis.may_occlude(a, a_poly, b, b_poly);
        let c = if partial {
            &self.counters.tested
        } else {
            &self.counters.skipped
        };
        c.fetch_add(1, Ordering::Relaxed);
        !partial
    }

    /// Fraction of the segments from `x` to `targets` that are unblocked.
    fn fraction(&self, x: &V3, targets: &[V3], skip: [usize; 2]) -> f64 {
        if targets.is_empty() {
            return 1.0;
        }
        self.counters
            .rays
            .fetch_add(targets.len() as u64, Ordering::Relaxed);
        let seen = targets
            .iter()
            .filter(|t| !self.vis.occluded(x, t, skip))
            .count();
        seen as f64 / targets.len() as f64
    }
}

/// Relative visibility uncertainty of a receiver from its per-point fractions: half the
/// mean deviation, zero where every point agrees.
fn vis_uncertainty(v: &[f64]) -> f64 {
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    if hi <= lo { 0.0 } else { 0.25 * (hi - lo) }
}

/// The point of the receiver's plane where the form factor from an infinitesimal
/// sender at `ms` (unit normal `ns`) peaks (Kresse 2.6.1, derived for the plane spanned
/// by both normals), moved to the closest point of the receiver polygon.
fn ff_max_point(recv: &Patch, ms: &V3, ns: &V3) -> Option<V3> {
    let ne = recv.normal;
    let h = ne.dot(&(ms - recv.verts[0]));
    if h <= 0.0 {
        return None;
    }
    let cos = ns.dot(&ne).clamp(-1.0, 1.0);
    let t = ns - ne * cos;
    let s = t.norm();
    let foot = ms - ne * h;
    let p = if s > 1e-9 {
        foot + (t / s) * (h * (2.0 * cos + (cos * cos + 3.0).sqrt()) / (3.0 * s))
    } else {
        foot
    };
    Some(closest_on_polygon(recv, &p))
}

/// Closest point of the (convex) patch to `p`, with `p` in its plane.
fn closest_on_polygon(recv: &Patch, p: &V3) -> V3 {
    let v = recv.verts();
    if point_in_convex(v, &recv.normal, p) {
        return *p;
    }
    let mut best = v[0];
    let mut bd = f64::INFINITY;
    for i in 0..v.len() {
        let (a, b) = (v[i], v[(i + 1) % v.len()]);
        let e = b - a;
        let t = ((p - a).dot(&e) / e.norm_squared().max(1e-300)).clamp(0.0, 1.0);
        let q = a + e * t;
        let d = (q - p).norm_squared();
        if d < bd {
            bd = d;
            best = q;
        }
    }
    best
}

/// A patch sender whose radius is below this fraction of its distance from the
/// receiver is seen by one ray from each receiver point, to its centre: its Gauss
/// points lie within a few degrees of each other there, and the receiver's nine points
/// still sample a shadow edge (and their spread still refines it). A third of the
/// rays on the Cornell box at 1 %, the same measured error against Mitsuba (0.81 %).
/// Its form factors come from the kernel at its Gauss points
/// ([`point_to_small_polygon`]) instead of the contour integral.
const SMALL_SENDER: f64 = 0.1;

/// Samples for rays on a patch sender: its 2×2 Gauss points.
fn patch_targets(p: &Patch) -> Vec<V3> {
    let mut buf = Vec::with_capacity(4);
    quadrature::points(p.verts(), 2, &mut buf);
    buf.into_iter().map(|(x, _)| x).collect()
}

/// Visibility of an area sender from the receiver's points: every quadrature point
/// is a shape sample (`Samples::shape` covers them all), so each sees the sender's
/// points in front of its tangent plane ([`targets_in_front`]).
fn area_visibility(
    ctx: &Ctx,
    smp: &Samples,
    pv: &mut PointValues,
    (normal, sender, targets): (&V3, &[V3], &[V3]),
    skip: [usize; 2],
) {
    for i in 0..smp.n {
        if pv.f[i] > 0.0 {
            let front = targets_in_front(&smp.pts[i], normal, targets, sender);
            pv.v[i] = ctx.fraction(&smp.pts[i], &front, skip);
        }
    }
}

/// Evaluates the values of a patch-receiver link from per-point coefficients.
struct PointValues {
    f: [f64; 9],
    v: [f64; 9],
}

fn finish_plink(
    src: Node,
    recv: &PatchReceiver,
    mut pv: PointValues,
    extra_max: f64,
    visible: bool,
    grad: V3,
) -> Option<PLink> {
    recv.fill_enclosed(&mut pv);
    let smp = &recv.samples;
    let mut k = 0.0;
    for i in 0..smp.n {
        k += smp.w[i] * pv.f[i] * pv.v[i];
    }
    let mut ks = [0f32; NS];
    let mut kmax = extra_max;
    for (j, out) in ks.iter_mut().enumerate() {
        let i = smp.shape[j];
        *out = (pv.f[i] * pv.v[i]) as f32;
        kmax = kmax.max(pv.f[i]);
    }
    if kmax <= 0.0 || !kmax.is_finite() {
        return None;
    }
    let rel_vis = if visible {
        0.0
    } else {
        vis_uncertainty(&pv.v[..smp.n])
    };
    Some(PLink {
        src,
        k: k as f32,
        ks,
        kmax: kmax as f32,
        grad: [grad.x as f32, grad.y as f32, grad.z as f32],
        rel_vis: rel_vis as f32,
        visible,
        overlap: false,
    })
}

/// Clearance factor: a cluster sender whose bounding sphere (times this) reaches a
/// receiver point overlaps the receiver.
const CLUSTER_CLEARANCE: f64 = 1.05;

/// The receiving patch of a link being evaluated.
struct PatchReceiver<'a> {
    /// Index of the patch.
    index: usize,
    patch: &'a Patch,
    samples: Samples,
}

impl PatchReceiver<'_> {
    /// Coefficients all zero, visibility all one.
    fn blank_values() -> PointValues {
        PointValues {
            f: [0.0; 9],
            v: [1.0; 9],
        }
    }

    /// Whether quadrature point `i` lies inside a closed solid.
    fn is_enclosed(&self, i: usize) -> bool {
        self.patch.is_enclosed(i)
    }

    /// Gives the enclosed points the mean of the open ones (weighted by the rule):
    /// no surface is there, so the element's mean and shape are those of its open
    /// part. Rays to an enclosed point of a sender are blocked by the solid, so the
    /// light it would send is not counted twice.
    fn fill_enclosed(&self, pv: &mut PointValues) {
        if self.patch.enclosed == 0 {
            return;
        }
        let smp = &self.samples;
        let (mut sum, mut weight) = (0.0, 0.0);
        for i in (0..smp.n).filter(|&i| !self.is_enclosed(i)) {
            sum += smp.w[i] * pv.f[i] * pv.v[i];
            weight += smp.w[i];
        }
        let mean = if weight > 0.0 { sum / weight } else { 0.0 };
        for i in (0..smp.n).filter(|&i| self.is_enclosed(i)) {
            pv.f[i] = mean;
            pv.v[i] = 1.0;
        }
    }
}

/// A link to the patch `r` from `src`; `visible` when the parent link was classified
/// fully visible. `None` when nothing can be transferred.
pub(super) fn eval_plink(
    ctx: &Ctx,
    h: &Hierarchy,
    r: usize,
    src: Node,
    visible: bool,
) -> Option<PLink> {
    let patch = &h.patches[r];
    let recv = PatchReceiver {
        index: r,
        patch,
        samples: Samples::of(patch.verts()),
    };
    if patch.enclosed.count_ones() as usize >= recv.samples.n {
        return None; // inside a solid: no surface to light
    }
    match src.kind() {
        Kind::Patch(s) => plink_from_patch(ctx, &recv, &h.patches[s], src, visible),
        Kind::Cluster(c) => plink_from_cluster(ctx, h, &recv, c, src),
        Kind::Emitter(e) => plink_from_emitter(ctx, &recv, &ctx.emitters[e], src, visible),
    }
}

/// A patch-to-patch link: exact point-to-polygon factors, shadow rays to the
/// sender's Gauss points unless classified fully visible.
fn plink_from_patch(
    ctx: &Ctx,
    recv: &PatchReceiver,
    sp: &Patch,
    src: Node,
    visible: bool,
) -> Option<PLink> {
    let (rp, smp) = (recv.patch, &recv.samples);
    if sp.polygon == rp.polygon || !faces(rp, sp) {
        return None;
    }
    let visible = visible
        || ctx.classify(
            rp.verts(),
            rp.polygon as usize,
            sp.verts(),
            sp.polygon as usize,
        );
    let small = sp.radius < SMALL_SENDER * (sp.centre - rp.centre).norm();
    let gauss = small.then(|| {
        let mut pts = Vec::with_capacity(4);
        quadrature::points(sp.verts(), 2, &mut pts);
        pts
    });
    let mut pv = PatchReceiver::blank_values();
    for i in (0..smp.n).filter(|&i| !recv.is_enclosed(i)) {
        let x = smp.pts[i];
        pv.f[i] = gauss
            .as_deref()
            .and_then(|g| point_to_small_polygon(&x, &rp.normal, g, sp.area, &sp.normal))
            .unwrap_or_else(|| point_to_polygon(&x, &rp.normal, sp.verts(), &sp.normal));
    }
    if !visible {
        let skip = [rp.polygon as usize, sp.polygon as usize];
        let targets = if small {
            vec![sp.centre]
        } else {
            patch_targets(sp)
        };
        area_visibility(ctx, smp, &mut pv, (&rp.normal, sp.verts(), &targets), skip);
    }
    let extra = ff_max_point(rp, &sp.centre, &sp.normal).map_or(0.0, |x| {
        point_to_polygon(&x, &rp.normal, sp.verts(), &sp.normal)
    });
    finish_plink(src, recv, pv, extra, visible, V3::zeros())
}

/// A cluster-to-patch link: the cluster as a small sphere at its centre, rays to
/// random points of its contents, and the coefficient's gradient in the sender
/// position. An overlap link when the cluster reaches the receiver.
fn plink_from_cluster(
    ctx: &Ctx,
    h: &Hierarchy,
    recv: &PatchReceiver,
    c: usize,
    src: Node,
) -> Option<PLink> {
    let (rp, smp) = (recv.patch, &recv.samples);
    let cl = &h.clusters[c];
    let dmin = (0..smp.n)
        .map(|i| (cl.centre - smp.pts[i]).norm())
        .fold(f64::INFINITY, f64::min);
    if dmin <= cl.radius * CLUSTER_CLEARANCE {
        return Some(PLink {
            src,
            k: 0.0,
            ks: [0.0; NS],
            kmax: f32::INFINITY,
            grad: [0.0; 3],
            rel_vis: 0.0,
            visible: false,
            overlap: true,
        });
    }
    // the contents are inside the shaft: rays to random points of the cluster
    // (those facing the point: a ray to the far side of a solid would be
    // blocked by the sender itself)
    let targets = h.random_points(c, CLUSTER_RAYS, link_seed(Node::patch(recv.index), src));
    let mut pv = PatchReceiver::blank_values();
    let mut grad = V3::zeros();
    for i in 0..smp.n {
        let x = smp.pts[i];
        let d = cl.centre - x;
        let d2 = d.norm_squared();
        let dl = d2.sqrt();
        let nd = rp.normal.dot(&d);
        let ec = effective_cos(nd / dl, (cl.radius / dl).powi(2));
        if ec > 0.0 && !recv.is_enclosed(i) {
            // cos θ / d² = n·d / |d|³ (with the sender's extent at the horizon),
            // and its gradient in the sender position
            pv.f[i] = ec / d2;
            let seen: Vec<V3> = targets
                .iter()
                .filter(|(t, n)| n.dot(&(x - t)) > 0.0 && rp.normal.dot(&(t - x)) > 0.0)
                .map(|(t, _)| *t)
                .collect();
            pv.v[i] = ctx.fraction(&x, &seen, [rp.polygon as usize, usize::MAX]);
            let g = rp.normal / (d2 * dl) - d * (3.0 * nd / (d2 * d2 * dl));
            grad += g * (smp.w[i] * pv.v[i]);
        }
    }
    finish_plink(src, recv, pv, 0.0, false, grad)
}

/// An emitter-to-patch link: the emitter's irradiance at the receiver's points, one
/// ray each unless classified fully visible; the mean carries the energy when fully
/// visible.
fn plink_from_emitter(
    ctx: &Ctx,
    recv: &PatchReceiver,
    em: &Emitter,
    src: Node,
    visible: bool,
) -> Option<PLink> {
    let (rp, smp) = (recv.patch, &recv.samples);
    let visible = visible
        || ctx.classify(
            rp.verts(),
            rp.polygon as usize,
            &em.shaft_end(rp.verts(), ctx.far),
            usize::MAX,
        );
    let skip = [rp.polygon as usize, usize::MAX];
    let mut pv = PatchReceiver::blank_values();
    for i in (0..smp.n).filter(|&i| !recv.is_enclosed(i)) {
        let x = smp.pts[i];
        pv.f[i] = em.irradiance(ctx.scene, &x, &rp.normal);
        if pv.f[i] > 0.0 && !visible {
            pv.v[i] = ctx.fraction(&x, &[em.ray_end(&x, ctx.far)], skip);
        }
    }
    // the foot of the perpendicular: the peak of cos θ / d² for a point light
    let extra = em.position().map_or(0.0, |lp| {
        let height = rp.normal.dot(&(lp - rp.verts[0]));
        if height <= 0.0 {
            return 0.0;
        }
        let foot = closest_on_polygon(rp, &(lp - rp.normal * height));
        em.irradiance(ctx.scene, &foot, &rp.normal)
    });
    let mut l = finish_plink(src, recv, pv, extra, visible, V3::zeros())?;
    if visible {
        // the mean carries the energy: the flux into the patch's solid angle
        l.k = em.mean_irradiance(ctx.scene, rp.verts(), &rp.normal, rp.area) as f32;
    }
    Some(l)
}

/// What evaluating a cluster link found.
enum ClusterEval {
    /// Nothing can be transferred.
    Nothing,
    /// The pair is too close for a link at this level.
    Overlap(Overlap),
    /// A far-field transfer.
    Transfer(ClusterTransfer),
}

/// The terms of a far-field cluster link.
struct ClusterTransfer {
    /// Distance from the receiver's centre to the sender.
    distance: f64,
    /// Normal-irradiance coefficient at the centre, unoccluded.
    k: f64,
    /// Relative uncertainty from the sender's extent.
    rel_src: f64,
    visibility: PairVisibility,
}

/// The receiving cluster of a link being evaluated.
struct ClusterReceiver<'a> {
    /// Index of the cluster.
    index: usize,
    centre: V3,
    radius: f64,
    lo: V3,
    hi: V3,
    h: &'a Hierarchy,
    /// Seed of the link's random points.
    seed: u64,
}

impl ClusterReceiver<'_> {
    /// Random points of the receiver facing direction `u`, for rays.
    fn facing(&self, u: &V3) -> Vec<(V3, V3)> {
        facing_points(self.h, self.index, u, self.seed)
    }
}

/// A link to the cluster `r` from `src`. `None` when nothing can be transferred.
pub(super) fn eval_clink(ctx: &Ctx, h: &Hierarchy, r: usize, src: Node) -> Option<CLink> {
    let rc = &h.clusters[r];
    let recv = ClusterReceiver {
        index: r,
        centre: rc.centre,
        radius: rc.radius,
        lo: rc.lo,
        hi: rc.hi,
        h,
        seed: link_seed(Node::cluster(r), src),
    };
    let eval = match src.kind() {
        Kind::Patch(s) => clink_from_patch(ctx, &recv, &h.patches[s]),
        Kind::Cluster(s) => clink_from_cluster(ctx, &recv, s),
        Kind::Emitter(e) => clink_from_emitter(ctx, &recv, &ctx.emitters[e]),
    };
    match eval {
        ClusterEval::Nothing => None,
        ClusterEval::Overlap(why) => Some(CLink {
            src,
            d: 0.0,
            k: 0.0,
            v: 0.0,
            rel_src: 0.0,
            rel_vis: 0.0,
            overlap: why,
        }),
        ClusterEval::Transfer(t) => Some(CLink {
            src,
            d: t.distance as f32,
            k: t.k as f32,
            v: t.visibility.v as f32,
            rel_src: t.rel_src as f32,
            rel_vis: t.visibility.uncertainty() as f32,
            overlap: Overlap::None,
        }),
    }
}

/// A patch sender of a cluster: the sender's form factor to the receiver's centre.
fn clink_from_patch(ctx: &Ctx, recv: &ClusterReceiver, sp: &Patch) -> ClusterEval {
    // the sender's plane through the receiver's box: only part of it is lit
    let corners = box_corners(&recv.lo, &recv.hi);
    let front = corners
        .iter()
        .filter(|c| sp.normal.dot(&(*c - sp.verts[0])) > 0.0)
        .count();
    if front == 0 {
        return ClusterEval::Nothing;
    }
    if front < 8 {
        return ClusterEval::Overlap(Overlap::Plane);
    }
    let dv = sp.centre - recv.centre;
    let d = dv.norm();
    if d <= recv.radius + sp.radius {
        return ClusterEval::Overlap(Overlap::Near);
    }
    let u = dv / d;
    let k0 = point_to_polygon(&recv.centre, &u, sp.verts(), &sp.normal);
    if k0 <= 0.0 {
        return ClusterEval::Nothing;
    }
    let pts = recv.facing(&u);
    let targets: Vec<(V3, V3)> = patch_targets(sp)
        .into_iter()
        .map(|t| (t, sp.normal))
        .collect();
    let visibility = sample_visibility(ctx, &pts, &targets, sp.polygon as usize);
    // far field from the centre: the first-order terms of a uniform patch cancel
    ClusterEval::Transfer(ClusterTransfer {
        distance: d,
        k: k0,
        rel_src: 2.0 * (sp.radius / d).powi(2),
        visibility,
    })
}

/// A cluster sender of a cluster: 1/d² between the centres.
fn clink_from_cluster(ctx: &Ctx, recv: &ClusterReceiver, s: usize) -> ClusterEval {
    let sc = &recv.h.clusters[s];
    let dv = sc.centre - recv.centre;
    let d = dv.norm();
    if d <= recv.radius + sc.radius {
        return ClusterEval::Overlap(Overlap::Near);
    }
    let u = dv / d;
    let pts = recv.facing(&u);
    let targets = facing_points(recv.h, s, &(-u), recv.seed ^ 0x5555);
    let visibility = sample_visibility(ctx, &pts, &targets, usize::MAX);
    // light leaves from the flux centroid (used in the sweep): second order
    ClusterEval::Transfer(ClusterTransfer {
        distance: d,
        k: 1.0 / (d * d),
        rel_src: 2.0 * (sc.radius / d).powi(2),
        visibility,
    })
}

/// An emitter lighting a cluster: its normal irradiance at the centre, one ray per
/// receiver point.
fn clink_from_emitter(ctx: &Ctx, recv: &ClusterReceiver, em: &Emitter) -> ClusterEval {
    let kmax = em.max_normal_irradiance(ctx.scene, &recv.centre, recv.radius);
    if !kmax.is_finite() {
        return ClusterEval::Overlap(Overlap::Near);
    }
    if kmax <= 0.0 {
        return ClusterEval::Nothing;
    }
    let (en, u) = em.normal_irradiance(ctx.scene, &recv.centre);
    let pts = recv.facing(&u);
    let visibility = emitter_visibility(ctx, em, &pts);
    let d = em
        .position()
        .map_or(f64::INFINITY, |p| (p - recv.centre).norm());
    // each polygon gets the light's own intensity towards it: exact geometry
    ClusterEval::Transfer(ClusterTransfer {
        distance: d,
        k: en.max(0.5 * kmax),
        rel_src: 0.0,
        visibility,
    })
}

/// Visibility of an emitter from receiver points, one ray per point.
fn emitter_visibility(ctx: &Ctx, em: &Emitter, pts: &[(V3, V3)]) -> PairVisibility {
    if pts.is_empty() {
        return PairVisibility {
            v: 1.0,
            spread: 0.0,
            pairs: 0,
        };
    }
    ctx.counters
        .rays
        .fetch_add(pts.len() as u64, Ordering::Relaxed);
    ctx.counters.tested.fetch_add(1, Ordering::Relaxed);
    let seen = pts
        .iter()
        .filter(|(p, _)| {
            !ctx.vis
                .occluded(p, &em.ray_end(p, ctx.far), [usize::MAX; 2])
        })
        .count();
    let v = seen as f64 / pts.len() as f64;
    // one ray per point: each point is lit or not
    PairVisibility {
        v,
        spread: 2.0 * v * (1.0 - v),
        pairs: pts.len(),
    }
}

/// Up to [`CLUSTER_RAYS`] random points of cluster `c` on surfaces facing `u`.
fn facing_points(h: &Hierarchy, c: usize, u: &V3, seed: u64) -> Vec<(V3, V3)> {
    h.random_points_where(c, CLUSTER_RAYS, 4 * CLUSTER_RAYS, seed, |n| n.dot(u) > 0.0)
}

/// Visibility between the points of a cluster link's ends.
#[derive(Debug, Clone, Copy)]
struct PairVisibility {
    /// Unblocked fraction of the segments.
    v: f64,
    /// Mean deviation of the receiver points' own fractions from `v`: how unevenly
    /// the visible part falls on the receiver (the error of one `v` for all of it).
    spread: f64,
    /// Segments tested.
    pairs: usize,
}

impl PairVisibility {
    /// Zero-mean uncertainty relative to the unoccluded transfer: the uneven part
    /// and the sampling error of `v`, its variance by the rule of succession so that
    /// n agreeing segments still leave the chance of a shadow between them.
    fn uncertainty(&self) -> f64 {
        let n = self.pairs as f64;
        let p = (self.v * n + 1.0) / (n + 2.0);
        self.spread + (p * (1.0 - p) / (n + 2.0)).sqrt()
    }
}

/// Visibility of the segments between receiver and sender points (with their surface
/// normals) that face each other; fully visible when no pair does (orientation alone
/// then decides).
fn sample_visibility(
    ctx: &Ctx,
    pts: &[(V3, V3)],
    targets: &[(V3, V3)],
    sender_poly: usize,
) -> PairVisibility {
    let mut pairs = 0usize;
    let mut seen = 0usize;
    let mut per_point: Vec<f64> = Vec::with_capacity(pts.len());
    for (p, np) in pts {
        let (mut n, mut s) = (0usize, 0usize);
        for (t, nt) in targets {
            let d = t - p;
            if np.dot(&d) > 0.0 && nt.dot(&d) < 0.0 {
                n += 1;
                s += usize::from(!ctx.vis.occluded(p, t, [usize::MAX, sender_poly]));
            }
        }
        if n > 0 {
            per_point.push(s as f64 / n as f64);
        }
        pairs += n;
        seen += s;
    }
    if pairs == 0 {
        return PairVisibility {
            v: 1.0,
            spread: 0.0,
            pairs: 0,
        };
    }
    ctx.counters.tested.fetch_add(1, Ordering::Relaxed);
    ctx.counters.rays.fetch_add(pairs as u64, Ordering::Relaxed);
    let v = seen as f64 / pairs as f64;
    let spread = per_point.iter().map(|x| (x - v).abs()).sum::<f64>() / per_point.len() as f64;
    PairVisibility { v, spread, pairs }
}

fn box_corners(lo: &V3, hi: &V3) -> [V3; 8] {
    std::array::from_fn(|i| {
        V3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ over the cap of max(0, n·ω) dω relative to π sin²σ, by the midpoint rule in
    /// polar coordinates about the cap's centre (the normal tilted by θ from it).
    fn cap_integral(theta: f64, sigma: f64) -> f64 {
        let (na, nf) = (400, 800);
        let n = V3::new(theta.sin(), 0.0, theta.cos());
        let mut sum = 0.0;
        for i in 0..na {
            let a = (i as f64 + 0.5) / na as f64 * sigma;
            for j in 0..nf {
                let f = (j as f64 + 0.5) / nf as f64 * std::f64::consts::TAU;
                let w = V3::new(a.sin() * f.cos(), a.sin() * f.sin(), a.cos());
                sum += n.dot(&w).max(0.0) * a.sin();
            }
        }
        let d = (sigma / na as f64) * (std::f64::consts::TAU / nf as f64);
        sum * d / (std::f64::consts::PI * sigma.sin().powi(2))
    }

    #[test]
    fn effective_cosine_matches_the_integral_over_the_source() {
        for sigma_deg in [2.0f64, 20.0, 45.0, 80.0] {
            let sigma = sigma_deg.to_radians();
            let mut theta_deg = 0.0;
            while theta_deg <= 90.0 + sigma_deg + 1.0 {
                let theta = f64::to_radians(theta_deg);
                let want = cap_integral(theta, sigma);
                let got = effective_cos(theta.cos(), sigma.sin().powi(2));
                assert!(
                    (got - want).abs() < 2e-3,
                    "σ {sigma_deg}°, θ {theta_deg}°: {got} vs {want}"
                );
                theta_deg += 7.5;
            }
        }
    }
}
