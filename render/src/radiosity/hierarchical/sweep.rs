//! One Jacobi sweep of the hierarchical solver (Kresse 2.5.4 "Gathering und
//! PushPull"): every node gathers over its own links, the irradiance is pushed down
//! (clusters distribute each link's light to the contained polygons by their own
//! orientation; patches pass their mean on unchanged and their shape samples through
//! the parent's affine function, the vertex-radiosity push), and radiosity is pulled
//! up as area means, extrema and, for clusters, the moments of the emitted light.
//!
//! A cluster's emitted intensity towards ω is (1/π) Σ Bᵢ Aᵢ max(0, nᵢ·ω). It is kept
//! as the moments S = Σ BA, V = Σ BA n, M = Σ BA nnᵀ: exact when its normal cone lies
//! wholly in front of (or behind) ω; otherwise the degree-2 Legendre expansion of
//! max(0, t) estimates it, inside the rigorous bounds
//! max(0, V·ω, (V·ω + ωᵀMω)/2) ≤ Σ BA max(0, n·ω) ≤ min(S, (V·ω + √(S ωᵀMω))/2).

use rayon::prelude::*;

use crate::scene::{Scene, V3};

use super::emitters::Emitter;
use super::nodes::{Cluster, Hierarchy, Kind, NONE, Node, error_weight};
use super::sampling::{NS, linear_error, mean_shift, push_to_child, shape_error};
use super::transfer::{CLink, Overlap, PLink, effective_cos};

/// Irradiance of a patch element: mean and shape samples (XYZ, lux), plus the
/// estimated error (Y, lux) of the links that brought it: a part that adds up
/// (biases and bounds) and the variance of the part that does not (independent
/// zero-mean sampling errors of different links add in quadrature).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Irr {
    pub avg: [f64; 3],
    pub s: [[f64; 3]; NS],
    pub err: f64,
    pub var: f64,
}

/// Light a cluster received over one link from a surface sender this sweep: the
/// normal irradiance `e` at the cluster's centre (distance `d_c`) from a sender at
/// `origin`, with the sender's normal for a patch (zero for a cluster).
#[derive(Debug, Clone, Copy)]
pub(super) struct Entry {
    pub origin: V3,
    /// Bounding radius of the sender (its angular size at a polygon).
    pub r_s: f64,
    pub d_c: f64,
    pub sn: V3,
    pub cos_sc: f64,
    pub e: [f64; 3],
    /// Relative uncertainty (the sender's extent).
    pub rel: f64,
    /// Absolute uncertainty (Y, lux at the centre): the sender's spread (adding
    /// up) …
    pub err: f64,
    /// … and the zero-mean visibility sampling error.
    pub sd: f64,
}

impl Entry {
    /// The entry's irradiance scale factor at a polygon (centroid `x`, normal `n`):
    /// the polygon's own distance, direction and the sender's cosine towards it.
    fn factor(&self, x: &V3, n: &V3) -> (f64, f64) {
        let w = self.origin - x;
        let dp = w.norm();
        if dp <= 0.0 {
            return (0.0, dp);
        }
        let u = w / dp;
        let cos_p = effective_cos(n.dot(&u), (self.r_s / dp).powi(2));
        if cos_p <= 0.0 {
            return (0.0, dp);
        }
        let mut f = (self.d_c / dp).powi(2) * cos_p;
        if self.cos_sc > 0.0 {
            let cos_sp = -self.sn.dot(&u);
            if cos_sp <= 0.0 {
                return (0.0, dp);
            }
            f *= cos_sp / self.cos_sc;
        }
        (f, dp)
    }
}

/// Emission moments of a cluster, per XYZ channel.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Moments {
    pub s: [f64; 3],
    pub v: [V3; 3],
    /// xx, yy, zz, xy, xz, yz.
    pub m: [[f64; 6]; 3],
}

impl Moments {
    fn add_surface(&mut self, area: f64, b: &[f64; 3], n: &V3) {
        for c in 0..3 {
            let w = area * b[c];
            self.s[c] += w;
            self.v[c] += n * w;
            let m = &mut self.m[c];
            m[0] += w * n.x * n.x;
            m[1] += w * n.y * n.y;
            m[2] += w * n.z * n.z;
            m[3] += w * n.x * n.y;
            m[4] += w * n.x * n.z;
            m[5] += w * n.y * n.z;
        }
    }

    fn add(&mut self, o: &Moments) {
        for c in 0..3 {
            self.s[c] += o.s[c];
            self.v[c] += o.v[c];
            for k in 0..6 {
                self.m[c][k] += o.m[c][k];
            }
        }
    }
}

/// Intensity (cd per channel) of a cluster towards the unit direction `w`, and the
/// bounds (lo, hi) of its Y channel.
pub(super) fn cluster_intensity(cl: &Cluster, mom: &Moments, w: &V3) -> ([f64; 3], f64, f64) {
    let inv_pi = std::f64::consts::FRAC_1_PI;
    // all normals within the cone face w (angle to the axis ≤ 90° − half) or all
    // face away (≥ 90° + half); possible only for half angles below 90°
    let ca = cl.cone_axis.dot(w);
    let narrow = cl.cone_cos > 0.0;
    let front = narrow && ca >= cl.cone_sin;
    let back = narrow && ca <= -cl.cone_sin;
    let mut est = [0.0; 3];
    let (mut lo_y, mut hi_y) = (0.0, 0.0);
    for c in 0..3 {
        let t = mom.v[c].dot(w);
        let (e, lo, hi) = if back {
            (0.0, 0.0, 0.0)
        } else if front {
            (t.max(0.0), t.max(0.0), t.max(0.0))
        } else {
            let m = &mom.m[c];
            let q = (m[0] * w.x * w.x
                + m[1] * w.y * w.y
                + m[2] * w.z * w.z
                + 2.0 * (m[3] * w.x * w.y + m[4] * w.x * w.z + m[5] * w.y * w.z))
                .max(0.0);
            let s = mom.s[c].max(0.0);
            let lo = 0f64.max(t).max(0.5 * (t + q));
            let hi = s.min(0.5 * (t + (s * q).sqrt())).max(lo);
            let e = 0.25 * s + 0.5 * t + 5.0 / 32.0 * (3.0 * q - s);
            (e.clamp(lo, hi), lo, hi)
        };
        est[c] = e * inv_pi;
        if c == 1 {
            lo_y = lo * inv_pi;
            hi_y = hi * inv_pi;
        }
    }
    (est, lo_y, hi_y)
}

/// The solution state.
pub(super) struct State {
    /// Per patch: mean exitance (lm/m², XYZ), the sender strength.
    pub b: Vec<[f64; 3]>,
    /// Per patch: Y exitance extrema over the sub-tree (at the shape samples).
    pub bmin: Vec<f64>,
    pub bmax: Vec<f64>,
    /// Per patch: irradiance gathered over its own links this sweep.
    pub own: Vec<Irr>,
    /// Per patch: irradiance of its own and every ancestor's links (pushed).
    pub tot: Vec<Irr>,
    /// Per cluster: light received over its own surface links this sweep.
    pub entries: Vec<Vec<Entry>>,
    /// Per root polygon: light of emitters linked to its clusters (constant; baked
    /// after each refinement).
    pub cluster_direct: Vec<([f64; 3], f64, f64)>,
    /// Per cluster: emission moments, mean exitance and largest Y exitance inside.
    pub mom: Vec<Moments>,
    /// Per cluster: flux (Y) centroid of the contents.
    pub cpos: Vec<V3>,
    pub cb: Vec<[f64; 3]>,
    pub cbmax: Vec<f64>,
    /// Patches by quadtree level.
    pub levels: Vec<Vec<u32>>,
    /// Per polygon: reflectance and emitted exitance (π·L).
    pub rho: Vec<[f64; 3]>,
    pub emit: Vec<[f64; 3]>,
}

impl State {
    pub(crate) fn new(scene: &Scene, h: &Hierarchy) -> Self {
        let rho: Vec<[f64; 3]> = scene
            .polygons
            .iter()
            .map(|p| scene.materials[p.material].reflectance_xyz)
            .collect();
        let emit: Vec<[f64; 3]> = scene
            .polygons
            .iter()
            .map(|p| {
                scene.materials[p.material]
                    .emission_cd_m2
                    .map(|l| std::f64::consts::PI * l)
            })
            .collect();
        let np = h.patches.len();
        let nc = h.clusters.len();
        let mut st = Self {
            b: (0..np)
                .map(|p| emit[h.patches[p].polygon as usize])
                .collect(),
            bmin: (0..np)
                .map(|p| emit[h.patches[p].polygon as usize][1])
                .collect(),
            bmax: (0..np)
                .map(|p| emit[h.patches[p].polygon as usize][1])
                .collect(),
            own: vec![Irr::default(); np],
            tot: vec![Irr::default(); np],
            entries: vec![Vec::new(); nc],
            cluster_direct: vec![([0.0; 3], 0.0, 0.0); scene.polygons.len()],
            mom: vec![Moments::default(); nc],
            cpos: h.clusters.iter().map(|c| c.centre).collect(),
            cb: vec![[0.0; 3]; nc],
            cbmax: vec![0.0; nc],
            levels: vec![(0..np as u32).collect()],
            rho,
            emit,
        };
        st.pull_clusters(h);
        st
    }

    /// Registers patches created by splits (they start with their parent's values).
    pub(crate) fn grow(&mut self, h: &Hierarchy) {
        for p in self.b.len()..h.patches.len() {
            let parent = h.patches[p].parent as usize;
            self.b.push(self.b[parent]);
            self.bmin.push(self.bmin[parent]);
            self.bmax.push(self.bmax[parent]);
            self.own.push(Irr::default());
            self.tot.push(self.tot[parent]);
            let level = h.patches[p].level as usize;
            if self.levels.len() <= level {
                self.levels.resize(level + 1, Vec::new());
            }
            self.levels[level].push(p as u32);
        }
    }

    /// Sender strength (XYZ) and Y bounds of `src` as seen from a receiver at `to`.
    pub(crate) fn strength(
        &self,
        h: &Hierarchy,
        emitters: &[Emitter],
        src: Node,
        to: &V3,
    ) -> ([f64; 3], f64, f64) {
        let t = self.sender(h, emitters, src, to);
        (t.sig, t.lo, t.hi)
    }

    /// What a sender brings to a receiver at `to`, with its sender-side errors.
    pub(crate) fn sender(
        &self,
        h: &Hierarchy,
        emitters: &[Emitter],
        src: Node,
        to: &V3,
    ) -> SenderTerms {
        match src.kind() {
            Kind::Patch(s) => {
                let sp = &h.patches[s];
                let d = (sp.centre - to).norm().max(1e-300);
                // the mean radiosity serves as long as the form factor is even across
                // the sender: the spread matters by the sender's angular size
                let (lo, hi) = (self.bmin[s], self.bmax[s]);
                SenderTerms {
                    sig: self.b[s],
                    lo,
                    hi,
                    origin: sp.centre,
                    shift: V3::zeros(),
                    spread: 0.25 * (hi - lo) * (2.0 * sp.radius / d).min(1.0),
                    rel: 0.0,
                }
            }
            Kind::Cluster(c) => {
                let cl = &h.clusters[c];
                let origin = self.cpos[c];
                let w = (to - origin).try_normalize(1e-300).unwrap_or_else(V3::z);
                let (sig, lo, hi) = cluster_intensity(cl, &self.mom[c], &w);
                let d = (origin - to).norm().max(1e-300);
                SenderTerms {
                    sig,
                    lo,
                    hi,
                    origin,
                    shift: origin - cl.centre,
                    // the intensity estimate lies within its bounds; light leaves from
                    // the flux centroid, the rest of the extent is second order
                    spread: 0.5 * (hi - lo),
                    rel: 2.0 * (cl.radius / d).powi(2),
                }
            }
            Kind::Emitter(e) => {
                let col = emitters[e].color();
                SenderTerms {
                    sig: col,
                    lo: col[1],
                    hi: col[1],
                    origin: emitters[e].position().unwrap_or(*to),
                    shift: V3::zeros(),
                    spread: 0.0,
                    rel: 0.0,
                }
            }
        }
    }

    /// Gathers over every link (parallel over receivers).
    pub(crate) fn gather(
        &mut self,
        h: &Hierarchy,
        emitters: &[Emitter],
        plinks: &[Vec<PLink>],
        clinks: &[Vec<CLink>],
    ) {
        let me = &*self;
        let own: Vec<Irr> = plinks
            .par_iter()
            .enumerate()
            .map(|(r, links)| {
                let mut irr = Irr::default();
                let to = h.patches[r].centre;
                for l in links {
                    let t = me.sender(h, emitters, l.src, &to);
                    let (k, scale) = l.corrected(&t.shift);
                    let ks = l.ks();
                    for c in 0..3 {
                        irr.avg[c] += k * t.sig[c];
                        for j in 0..NS {
                            irr.s[j][c] += scale * ks[j] * t.sig[c];
                        }
                    }
                    irr.err += k * (t.spread + t.sig[1] * t.rel);
                    irr.var += (k * t.sig[1] * f64::from(l.rel_vis)).powi(2);
                }
                irr
            })
            .collect();
        let entries: Vec<Vec<Entry>> = clinks
            .par_iter()
            .enumerate()
            .map(|(r, links)| {
                let cr = h.clusters[r].centre;
                links
                    .iter()
                    .filter(|l| l.overlap == Overlap::None)
                    .filter_map(|l| {
                        // emitters are baked per polygon, see `bake_cluster_direct`
                        if matches!(l.src.kind(), Kind::Emitter(_)) {
                            return None;
                        }
                        let t = me.sender(h, emitters, l.src, &cr);
                        let d_c = (t.origin - cr).norm();
                        let r_s = h.sphere(l.src).1;
                        let (sn, cos_sc, k) = match l.src.kind() {
                            Kind::Patch(s) => {
                                let sn = h.patches[s].normal;
                                (sn, sn.dot(&(cr - t.origin)) / d_c, f64::from(l.k))
                            }
                            // a point-like sender at its flux centroid
                            _ => (V3::zeros(), 0.0, 1.0 / (d_c * d_c)),
                        };
                        let kv = k * f64::from(l.v);
                        Some(Entry {
                            origin: t.origin,
                            r_s,
                            d_c,
                            sn,
                            cos_sc,
                            e: t.sig.map(|s| kv * s),
                            rel: f64::from(l.rel_src) + t.rel,
                            err: kv * t.spread,
                            sd: k * t.sig[1] * f64::from(l.rel_vis),
                        })
                    })
                    .collect()
            })
            .collect();
        self.own = own;
        self.entries = entries;
    }

    /// Diagnostics: Σ A·w·error of the patches' own links by kind (patch-sender
    /// spread, cluster-sender bound width, cluster extent, visibility) and of the
    /// cluster receivers' surface links (half the area facing), and their light.
    pub(crate) fn error_breakdown(
        &self,
        h: &Hierarchy,
        emitters: &[Emitter],
        plinks: &[Vec<PLink>],
        clinks: &[Vec<CLink>],
    ) -> [f64; 6] {
        let mut out = [0.0; 6];
        for (r, links) in plinks.iter().enumerate() {
            let pa = &h.patches[r];
            let weighted_area = error_weight(self.rho[pa.polygon as usize][1]) * pa.area;
            for l in links {
                let t = self.sender(h, emitters, l.src, &pa.centre);
                let (k, _) = l.corrected(&t.shift);
                match l.src.kind() {
                    Kind::Patch(_) => out[0] += weighted_area * k * t.spread,
                    Kind::Cluster(_) => {
                        out[1] += weighted_area * k * t.spread;
                        out[2] += weighted_area * k * t.sig[1] * t.rel;
                    }
                    Kind::Emitter(_) => {}
                }
                out[3] += weighted_area * k * t.sig[1] * f64::from(l.rel_vis);
            }
        }
        for (r, _) in clinks.iter().enumerate() {
            let cl = &h.clusters[r];
            for e in &self.entries[r] {
                out[4] += cl.w_max * cl.area * 0.5 * (e.err + e.sd + e.rel * e.e[1]);
                out[5] += cl.w_max * cl.area * 0.5 * e.e[1];
            }
        }
        out
    }

    /// Evaluates, for every root polygon, the light of the emitters linked to its
    /// clusters: the emitter's own intensity, distance and cosine at the polygon's
    /// centroid, times the link's visible fraction.
    pub(crate) fn bake_cluster_direct(
        &mut self,
        scene: &Scene,
        h: &Hierarchy,
        emitters: &[Emitter],
        clinks: &[Vec<CLink>],
    ) {
        let n = self.cluster_direct.len();
        self.cluster_direct = (0..n)
            .into_par_iter()
            .map(|p| {
                let pa = &h.patches[p];
                let mut e = [0.0; 3];
                let err = 0.0;
                let mut var = 0.0;
                let mut c = pa.cluster;
                while c != NONE {
                    for l in &clinks[c as usize] {
                        let Kind::Emitter(i) = l.src.kind() else {
                            continue;
                        };
                        if l.overlap != Overlap::None {
                            continue;
                        }
                        let em = &emitters[i];
                        let unocc = em.mean_irradiance(scene, pa.verts(), &pa.normal, pa.area);
                        if unocc <= 0.0 {
                            continue;
                        }
                        let irr = unocc * f64::from(l.v);
                        let col = em.color();
                        for k in 0..3 {
                            e[k] += irr * col[k];
                        }
                        let shape = em.position().map_or(0.0, |lp| {
                            0.5 * pa.radius / (lp - pa.centre).norm().max(1e-300)
                        });
                        var += (col[1] * (unocc * f64::from(l.rel_vis) + irr * shape)).powi(2);
                    }
                    c = h.clusters[c as usize].parent;
                }
                (e, err, var)
            })
            .collect();
    }

    /// Pushes irradiance down and computes the new leaf radiosities; returns, for
    /// the leaves, (patch, new mean exitance) without storing them.
    pub(crate) fn push(&mut self, h: &Hierarchy) -> Vec<(u32, [f64; 3])> {
        let mut leaves = Vec::new();
        for level in 0..self.levels.len() {
            let me = &*self;
            let tots: Vec<Irr> = me.levels[level]
                .par_iter()
                .map(|&p| {
                    let p = p as usize;
                    let pa = &h.patches[p];
                    let mut t = me.own[p];
                    if pa.parent == NONE {
                        // light of the enclosing clusters, at this polygon's own
                        // distance and orientation
                        let (mut add, mut err, mut var) = me.cluster_direct[pa.polygon as usize];
                        let mut c = pa.cluster;
                        while c != NONE {
                            for e in &me.entries[c as usize] {
                                let (f, dp) = e.factor(&pa.centre, &pa.normal);
                                if f > 0.0 {
                                    for k in 0..3 {
                                        add[k] += e.e[k] * f;
                                    }
                                    // the polygon's own extent: a constant cannot
                                    // follow the variation across it
                                    err += f * (e.e[1] * e.rel + e.err);
                                    var += (f * (e.sd + e.e[1] * 0.5 * pa.radius / dp)).powi(2);
                                }
                            }
                            c = h.clusters[c as usize].parent;
                        }
                        for k in 0..3 {
                            t.avg[k] += add[k];
                            for j in 0..NS {
                                t.s[j][k] += add[k];
                            }
                        }
                        t.err += err;
                        t.var += var;
                    } else {
                        let q = pa.parent as usize;
                        let parent = &h.patches[q];
                        let pt = &me.tot[q];
                        let child = p - parent.first_child as usize;
                        let pushed = push_to_child(parent.nv.min(4), child, &pt.s);
                        // the parent's irradiance over this quarter: its mean plus
                        // the fit's gradient and bend (never below zero)
                        let shift = mean_shift(parent.nv.min(4), child, &pt.s);
                        for k in 0..3 {
                            t.avg[k] += pt.avg[k] + shift[k].max(-pt.avg[k]);
                        }
                        for j in 0..NS {
                            for k in 0..3 {
                                t.s[j][k] += pushed[j][k];
                            }
                        }
                        t.err += pt.err;
                        t.var += pt.var;
                    }
                    t
                })
                .collect();
            for (&p, t) in self.levels[level].iter().zip(tots) {
                self.tot[p as usize] = t;
                if h.patches[p as usize].is_leaf() {
                    let poly = h.patches[p as usize].polygon as usize;
                    let (rho, e) = (self.rho[poly], self.emit[poly]);
                    leaves.push((p, std::array::from_fn(|c| e[c] + rho[c] * t.avg[c])));
                }
            }
        }
        leaves
    }

    /// Pulls means and extrema up the quadtrees and the cluster tree.
    pub(crate) fn pull(&mut self, h: &Hierarchy) {
        for level in (0..self.levels.len()).rev() {
            let me = &*self;
            let vals: Vec<([f64; 3], f64, f64)> = me.levels[level]
                .par_iter()
                .map(|&p| {
                    let p = p as usize;
                    let pa = &h.patches[p];
                    if pa.is_leaf() {
                        let poly = pa.polygon as usize;
                        let (rho, e) = (me.rho[poly][1], me.emit[poly][1]);
                        let t = &me.tot[p];
                        let b = me.b[p][1];
                        let (mut lo, mut hi) = (b, b);
                        for j in 0..NS {
                            let v = e + rho * t.s[j][1];
                            lo = lo.min(v);
                            hi = hi.max(v);
                        }
                        (me.b[p], lo.max(0.0), hi)
                    } else {
                        let f = pa.first_child as usize;
                        let mut b = [0.0; 3];
                        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                        for c in f..f + 4 {
                            let a = h.patches[c].area;
                            for k in 0..3 {
                                b[k] += a * me.b[c][k];
                            }
                            lo = lo.min(me.bmin[c]);
                            hi = hi.max(me.bmax[c]);
                        }
                        let a = pa.area.max(1e-300);
                        (b.map(|v| v / a), lo, hi)
                    }
                })
                .collect();
            for (&p, (b, lo, hi)) in self.levels[level].iter().zip(vals) {
                let p = p as usize;
                self.b[p] = b;
                self.bmin[p] = lo;
                self.bmax[p] = hi;
            }
        }
        self.pull_clusters(h);
    }

    fn pull_clusters(&mut self, h: &Hierarchy) {
        for c in (0..h.clusters.len()).rev() {
            let cl = &h.clusters[c];
            let mut mom = Moments::default();
            let mut b = [0.0; 3];
            let mut bmax: f64 = 0.0;
            let mut fpos = V3::zeros();
            for k in 0..cl.n_children {
                match cl.children[k].kind() {
                    Kind::Patch(p) => {
                        let pa = &h.patches[p];
                        mom.add_surface(pa.area, &self.b[p], &pa.normal);
                        fpos += pa.centre * (pa.area * self.b[p][1]);
                        for (i, v) in b.iter_mut().enumerate() {
                            *v += pa.area * self.b[p][i];
                        }
                        bmax = bmax.max(self.bmax[p]);
                    }
                    Kind::Cluster(c2) => {
                        mom.add(&self.mom[c2]);
                        fpos += self.cpos[c2] * self.mom[c2].s[1];
                        for (i, v) in b.iter_mut().enumerate() {
                            *v += h.clusters[c2].area * self.cb[c2][i];
                        }
                        bmax = bmax.max(self.cbmax[c2]);
                    }
                    Kind::Emitter(_) => {}
                }
            }
            let a = cl.area.max(1e-300);
            self.cpos[c] = if mom.s[1] > 0.0 {
                fpos / mom.s[1]
            } else {
                cl.centre
            };
            self.mom[c] = mom;
            self.cb[c] = b.map(|v| v / a);
            self.cbmax[c] = bmax;
        }
    }

    /// Estimated error of a leaf: the shape error of its irradiance under the chosen
    /// representation plus its links' errors, weighted into exitance (lm/m², Y), and
    /// the value it is relative to. Also whether the linear representation is used.
    pub(crate) fn leaf_error(
        &self,
        h: &Hierarchy,
        p: usize,
        basis: Basis,
        eps_area: f64,
    ) -> LeafError {
        let pa = &h.patches[p];
        let poly = pa.polygon as usize;
        let rho = self.rho[poly][1];
        let w = error_weight(rho);
        let t = &self.tot[p];
        let n = pa.nv.min(4);
        let ys: [f64; NS] = std::array::from_fn(|j| t.s[j][1]);
        let constant = shape_error(n, &ys, false);
        let lin = linear_error(n, &ys, constant);
        let (shape, linear) = match basis {
            Basis::Constant => (constant, false),
            Basis::Linear => (lin, true),
            Basis::Auto => {
                if w * constant * pa.area <= eps_area {
                    (constant, false)
                } else {
                    (lin.min(constant), lin < constant)
                }
            }
        };
        let norm = if rho > super::nodes::DARK {
            self.b[p][1]
        } else {
            t.avg[1]
        };
        LeafError {
            error: w * (shape + t.err + t.var.sqrt()),
            shape: w * shape,
            norm,
            linear,
        }
    }
}

/// A sender as seen from one receiver (see [`State::sender`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct SenderTerms {
    /// Strength (XYZ): radiosity, intensity towards the receiver, or colour.
    pub sig: [f64; 3],
    /// Bounds of its Y channel.
    pub lo: f64,
    pub hi: f64,
    /// Where its light leaves from.
    pub origin: V3,
    /// For a cluster: flux centroid minus the centroid its links were evaluated at.
    pub shift: V3,
    /// Mean error (Y) of the strength per unit coefficient, from its spread.
    pub spread: f64,
    /// Relative error of what arrives, from the sender's extent.
    pub rel: f64,
}

/// Receiver representation (Kresse 2.5.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Basis {
    /// Constant receivers (lighting engineers: values, no shape).
    Constant,
    /// Linear receivers everywhere (vertex radiosities for Gouraud shading).
    Linear,
    /// Constant where it meets the error bound, linear only where it does not.
    #[default]
    Auto,
}

/// See [`State::leaf_error`].
#[derive(Debug, Clone, Copy)]
pub(super) struct LeafError {
    pub error: f64,
    /// The shape part of `error`.
    pub shape: f64,
    pub norm: f64,
    pub linear: bool,
}
