//! Link refinement (Kresse 2.6.4). A link is kept when the energy exchange it
//! describes may be taken as constant, ΔE = ρ_E·A_E·(F_max·B_max − F_min·B_min) ≤ ε;
//! otherwise the sender is split when its radiosity varies more than the form factor
//! (F_max·B_min < F_min·B_max), else the receiver. For a cluster receiver F_min = 0,
//! which reduces the test to the transferred energy, and the larger of the two ends
//! is split. On a patch receiver, the variations of its links may cancel (a furnace,
//! a room lit evenly from several sides): when the sum of all its links is flat
//! within ε, the receiver is not split for their sake (the "global" refinement Kresse
//! cites from [SSS00b]).
//!
//! A patch receiver takes light from patch senders only at their leaves
//! ([`Limits::leaf_senders`], the default). A sweep sends a patch's area-mean
//! radiosity; where its children differ, the mean misses how the radiosity and the form
//! factor towards the receiver vary together across it (their covariance), and that
//! error has one sign over a whole room: with subdivided senders the CIE 171 5.8 cube
//! at ρ = 0.05 lost 1.5 % of its inter-reflected light at a 1 % target (0.42 % with
//! leaf senders), and the estimate did not see it. Leaf senders also cost less
//! (measured): the Cornell box at 1 % took 28–41 s and 628 MiB, now 1.8 s and 34 MiB
//! (0.82 % and 0.90 % measured against Mitsuba); the 100 000-triangle scale scene
//! reached 13.2 % and 13.0 % after 300 s (target 5 %).
//!
//! Refinement runs in rounds: decide every link in parallel, split the chosen
//! elements, evaluate the new links in parallel, until nothing changes.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use super::nodes::{Hierarchy, Kind, Node, error_weight};
use super::sampling::{NS, linear_error, shape_error};
use super::sweep::{Basis, State};
use super::transfer::{CLink, Ctx, Overlap, PLink, eval_clink, eval_plink};

/// Limits of the patch quadtrees.
#[derive(Debug, Clone, Copy)]
pub(super) struct Limits {
    pub min_area: f64,
    pub max_level: u8,
    pub basis: Basis,
    /// Patch receivers take light from patch senders only at their leaves.
    pub leaf_senders: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Split {
    Receiver,
    Sender,
}

fn splittable(h: &Hierarchy, n: Node, lim: &Limits) -> bool {
    match n.kind() {
        Kind::Patch(p) => {
            let pa = &h.patches[p];
            !pa.is_leaf() || (0.25 * pa.area >= lim.min_area && pa.level < lim.max_level)
        }
        Kind::Cluster(_) => true,
        Kind::Emitter(_) => false,
    }
}

fn area(h: &Hierarchy, n: Node) -> f64 {
    h.sphere(n).2
}

/// The part of a link's variation over the receiver that the basis must absorb:
/// the range for constant receivers, a bound of the same size for what the linear
/// representation misses (its mean deviation from the samples' quadratic fit, times
/// the range-to-mean ratio of a linear function at these samples).
fn receiver_variation(corners: usize, ks: &[f64; NS], basis: Basis) -> f64 {
    let (lo, hi) = ks
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let range = hi - lo;
    if basis == Basis::Constant {
        return range;
    }
    let bend = 3.0 * linear_error(corners, ks, shape_error(corners, ks, false));
    if basis == Basis::Linear {
        bend
    } else {
        bend.min(range)
    }
}

/// A link's contribution to the receiver's error (lux, Y) on the receiver side:
/// what the basis cannot follow of the coefficient across the receiver (visibility
/// included: Kresse's F_min weighted by the visible part), a peak between the samples
/// (the analytic maximum), and the visibility sampling. The same mean (L1) deviations
/// the estimate reports.
fn receiver_error(l: &PLink, corners: usize, scale: f64, strength_max: f64, basis: Basis) -> f64 {
    let ks: [f64; NS] = l.ks().map(|v| scale * v);
    let k = scale * f64::from(l.k);
    // A shadow edge across the receiver (the samples' visibility differs) is no
    // polynomial: the linear basis cannot be trusted to follow it.
    let shadowed = l.rel_vis > 0.0;
    let constant = shape_error(corners, &ks, false);
    let shape = match basis {
        Basis::Constant => constant,
        _ if shadowed => constant,
        Basis::Linear => linear_error(corners, &ks, constant),
        Basis::Auto => constant.min(linear_error(corners, &ks, constant)),
    };
    let peak = (scale * f64::from(l.kmax) - ks.iter().fold(0.0, |a: f64, &b| a.max(b))).max(0.0);
    (shape + 0.25 * peak + k * f64::from(l.rel_vis)) * strength_max
}

/// A cluster's intensity is taken toward the receiver's centre; across a receiver that
/// straddles the plane of one of the cluster's faces (a wall beside a block's top) it
/// changes from the face's full light to none. Half the range of the intensity toward
/// the receiver's corners and centre, so that such a link is refined (the cluster split
/// into its patches, which are evaluated per receiver point). Zero for other senders.
fn cluster_spread_over_receiver(
    h: &Hierarchy,
    st: &State,
    ctx: &Ctx,
    src: Node,
    pa: &super::nodes::Patch,
    at_centre: f64,
) -> f64 {
    if !matches!(src.kind(), Kind::Cluster(_)) {
        return 0.0;
    }
    let (lo, hi) = pa
        .verts()
        .iter()
        .map(|v| st.sender(h, ctx.emitters, src, v).sig[1])
        .fold((at_centre, at_centre), |(a, b), x| (a.min(x), b.max(x)));
    0.5 * (hi - lo)
}

#[allow(
    clippy::too_many_arguments,
    reason = "the receiver, its link and the round's tolerance and flatness decide together"
)]
fn decide_plink(
    h: &Hierarchy,
    st: &State,
    ctx: &Ctx,
    r: usize,
    l: &PLink,
    eps: f64,
    lim: &Limits,
    flat: bool,
) -> Option<Split> {
    if l.overlap {
        return Some(Split::Sender);
    }
    if lim.leaf_senders
        && let Kind::Patch(s) = l.src.kind()
        && !h.patches[s].is_leaf()
    {
        // only leaves send to patches (see the module's doc)
        return Some(Split::Sender);
    }
    let pa = &h.patches[r];
    let weighted_area = error_weight(st.rho[pa.polygon as usize][1]) * pa.area;
    // Kresse's ΔE = ρA(F_max·B_max − F_min·B_min), taken apart into its receiver
    // part (the form factor's variation) and its sender part (the radiosity's)
    let t = st.sender(h, ctx.emitters, l.src, &pa.centre);
    let (k, scale) = l.corrected(&t.shift);
    let receiver_error_lm = weighted_area * receiver_error(l, pa.nv.min(4), scale, t.hi, lim.basis);
    let spread = t.spread.max(cluster_spread_over_receiver(
        h, st, ctx, l.src, pa, t.sig[1],
    ));
    let sender_error_lm = weighted_area * k * (spread + t.sig[1] * t.rel);
    if receiver_error_lm + sender_error_lm <= eps {
        return None;
    }
    let sender_splittable = splittable(h, l.src, lim);
    if sender_splittable && sender_error_lm >= receiver_error_lm {
        return Some(Split::Sender);
    }
    if flat && sender_error_lm <= 0.5 * eps {
        // the variations of the receiver's links cancel
        return None;
    }
    if splittable(h, Node::patch(r), lim) {
        Some(Split::Receiver)
    } else if sender_splittable {
        Some(Split::Sender)
    } else {
        None
    }
}

fn decide_clink(
    h: &Hierarchy,
    st: &State,
    ctx: &Ctx,
    r: usize,
    l: &CLink,
    eps: f64,
    lim: &Limits,
) -> Option<Split> {
    let sender_splittable = splittable(h, l.src, lim);
    match l.overlap {
        Overlap::Near => {
            return Some(
                if sender_splittable && area(h, l.src) > h.clusters[r].area {
                    Split::Sender
                } else {
                    Split::Receiver
                },
            );
        }
        Overlap::Plane => return Some(Split::Receiver),
        Overlap::None => {}
    }
    let cl = &h.clusters[r];
    let t = st.sender(h, ctx.emitters, l.src, &cl.centre);
    let hi = t.hi;
    // the light reaching the cluster unoccluded (half its area faces a given
    // direction, on average)
    let energy = cl.w_max * 0.5 * cl.area * f64::from(l.k) * hi;
    if matches!(l.src.kind(), Kind::Emitter(_)) {
        // direct light casts sharp shadows inside a cluster that a few rays cannot
        // resolve: Kresse's F_min = 0, the whole energy is the error
        return (energy > eps).then_some(Split::Receiver);
    }
    // sender side: its extent and the spread of its radiosity (intensity bounds)
    let rel_send = f64::from(l.rel_src) + t.rel + if hi > 0.0 { t.spread / hi } else { 0.0 };
    // receiver side: one visible fraction for every polygon inside, and constant
    // light across each polygon
    let v = f64::from(l.v);
    let rel_shape = 0.5 * cl.poly_radius_max / f64::from(l.d).max(1e-300);
    let rel_recv = f64::from(l.rel_vis) + v * rel_shape;
    if energy * (v * rel_send + rel_recv) <= eps {
        return None;
    }
    let rel_send = v * rel_send;
    Some(if sender_splittable && rel_send > rel_recv {
        Split::Sender
    } else {
        Split::Receiver
    })
}

/// Whether the sum of a patch's own links is flat within ε at the current
/// strengths (their variations cancel). While one of its links still waits for its
/// sender to be split, the sum is incomplete: receiver splits wait (`true`).
fn links_flat(
    h: &Hierarchy,
    st: &State,
    ctx: &Ctx,
    r: usize,
    links: &[PLink],
    eps: f64,
    basis: Basis,
) -> bool {
    if links.iter().any(|l| l.overlap) {
        return true;
    }
    if links.len() < 2 {
        return false;
    }
    let pa = &h.patches[r];
    let w = error_weight(st.rho[pa.polygon as usize][1]);
    let mut t = [0.0; NS];
    for l in links {
        let (sig, _, _) = st.strength(h, ctx.emitters, l.src, &pa.centre);
        for (v, kj) in t.iter_mut().zip(l.ks()) {
            *v += kj * sig[1];
        }
    }
    w * pa.area * receiver_variation(pa.nv.min(4), &t, basis) <= eps
}

/// New link from `recv` to `src` (either may be a cluster or a patch).
fn make_link(ctx: &Ctx, h: &Hierarchy, recv: Node, src: Node, visible: bool) -> Option<NewLink> {
    match recv.kind() {
        Kind::Patch(r) => eval_plink(ctx, h, r, src, visible).map(|l| NewLink::P(r, l)),
        Kind::Cluster(r) => eval_clink(ctx, h, r, src).map(|l| NewLink::C(r, l)),
        Kind::Emitter(_) => None,
    }
}

enum NewLink {
    P(usize, PLink),
    C(usize, CLink),
}

/// Refinement rounds before giving up on a fixed point (each round splits at least
/// one element, so this only bounds pathological cases).
const MAX_ROUNDS: usize = 200;

/// What one refinement holds fixed.
pub(super) struct RefineParams<'a, 'c> {
    /// Link evaluation.
    pub ctx: &'a Ctx<'c>,
    /// The tolerance ε (lm).
    pub eps: f64,
    /// Limits of the patch quadtrees.
    pub lim: Limits,
    /// When to stop refining.
    pub deadline: Option<Instant>,
}

/// Split decisions of one round: per receiver, (index of the link, what to split).
type Decisions = Vec<(usize, Vec<(usize, Split)>)>;

/// One round's decisions for patch and cluster receivers.
struct RoundDecisions {
    patch: Decisions,
    cluster: Decisions,
}

/// What one refinement did.
pub(super) struct Refined {
    /// Links replaced.
    pub changed: usize,
    /// The deadline passed before every link was refined to ε: the links are a valid
    /// but incomplete hierarchy, and the error estimate of the next sweeps does not
    /// cover what was left unrefined.
    pub cut_short: bool,
}

/// Refines at tolerance `eps` (lm) until no link asks for a split or the deadline
/// passes.
pub(super) fn refine(
    params: &RefineParams,
    h: &mut Hierarchy,
    st: &mut State,
    plinks: &mut Vec<Vec<PLink>>,
    clinks: &mut [Vec<CLink>],
) -> Refined {
    let mut changed = 0usize;
    let mut cut_short = false;
    // receivers whose links may decide differently than in the last round: all at
    // first, then those that gained or lost links or had decisions deferred (nothing
    // else changes within one refinement: the strengths stay until the next sweep)
    let mut dirty = Dirty {
        patch: vec![true; plinks.len()],
        cluster: vec![true; clinks.len()],
    };
    for _round in 0..MAX_ROUNDS {
        if past(params.deadline) {
            cut_short = true;
            break;
        }
        // 1. decide
        let decisions = decide_all(params, h, st, plinks, clinks, &dirty);
        if decisions.patch.is_empty() && decisions.cluster.is_empty() {
            break;
        }
        let decisions = dirty.defer_bottom_up(decisions, plinks);
        // 2. split the patches that must be (clusters have their children already)
        let first_new = h.patches.len();
        split_elements(h, &decisions, plinks, clinks);
        h.mark_enclosed(first_new, params.ctx.vis);
        changed += decisions.patch.iter().map(|(_, d)| d.len()).sum::<usize>()
            + decisions
                .cluster
                .iter()
                .map(|(_, d)| d.len())
                .sum::<usize>();
        st.grow(h);
        plinks.resize(h.patches.len(), Vec::new());
        // 3. the replacement links; past the deadline the round is given up and the
        // old links stay (the new children then receive through their parents)
        let jobs = replacement_jobs(h, &decisions, plinks, clinks);
        let Some(made) = make_links(params, h, &jobs) else {
            cut_short = true;
            break;
        };
        // the old links go
        drop_decided(plinks, &decisions.patch);
        drop_decided(clinks, &decisions.cluster);
        dirty.patch.resize(plinks.len(), true);
        for m in made {
            match m {
                NewLink::P(r, l) => {
                    plinks[r].push(l);
                    dirty.patch[r] = true;
                }
                NewLink::C(r, l) => {
                    clinks[r].push(l);
                    dirty.cluster[r] = true;
                }
            }
        }
    }
    Refined { changed, cut_short }
}

/// A link to make: receiver, sender, and whether the parent link was unoccluded.
type ReplacementJob = (Node, Node, bool);

/// Makes the replacement links in parallel, or `None` when the deadline passes
/// before all are made (so that a time limit is kept within one link's work).
fn make_links(
    params: &RefineParams,
    h: &Hierarchy,
    jobs: &[ReplacementJob],
) -> Option<Vec<NewLink>> {
    let late = AtomicBool::new(false);
    let made: Vec<NewLink> = jobs
        .par_iter()
        .filter_map(|&(recv, src, vis)| {
            if late.load(Ordering::Relaxed) || past(params.deadline) {
                late.store(true, Ordering::Relaxed);
                return None;
            }
            make_link(params.ctx, h, recv, src, vis)
        })
        .collect();
    (!late.load(Ordering::Relaxed)).then_some(made)
}

/// Whether `deadline` is set and has passed.
fn past(deadline: Option<Instant>) -> bool {
    deadline.is_some_and(|d| Instant::now() > d)
}

/// Receivers whose links must be decided again in the next round.
struct Dirty {
    patch: Vec<bool>,
    cluster: Vec<bool>,
}

impl Dirty {
    /// Top-down: while clusters still hand links down (cluster receivers, cluster
    /// senders of patches), the patches' own link sets are incomplete and their
    /// receiver tests would judge partial sums; those wait for later rounds. Marks
    /// every receiver with a decision (or a deferred one) dirty, the rest clean.
    fn defer_bottom_up(
        &mut self,
        decisions: RoundDecisions,
        plinks: &[Vec<PLink>],
    ) -> RoundDecisions {
        let RoundDecisions { patch, cluster } = decisions;
        let from_cluster = |r: usize, i: usize, s: Split| {
            s == Split::Sender && matches!(plinks[r][i].src.kind(), Kind::Cluster(_))
        };
        let top_down = !cluster.is_empty()
            || patch
                .iter()
                .any(|(r, d)| d.iter().any(|&(i, s)| from_cluster(*r, i, s)));
        self.patch.iter_mut().for_each(|d| *d = false);
        self.cluster.iter_mut().for_each(|d| *d = false);
        let patch: Decisions = if top_down {
            patch
                .into_iter()
                .filter_map(|(r, d)| {
                    let all = d.len();
                    let d: Vec<(usize, Split)> = d
                        .into_iter()
                        .filter(|&(i, s)| from_cluster(r, i, s))
                        .collect();
                    if d.len() < all {
                        self.patch[r] = true; // deferred
                    }
                    (!d.is_empty()).then_some((r, d))
                })
                .collect()
        } else {
            patch
        };
        for (r, _) in &patch {
            self.patch[*r] = true;
        }
        for (r, _) in &cluster {
            self.cluster[*r] = true;
        }
        RoundDecisions { patch, cluster }
    }
}

/// Decides every link of the dirty receivers, in parallel.
fn decide_all(
    params: &RefineParams,
    h: &Hierarchy,
    st: &State,
    plinks: &[Vec<PLink>],
    clinks: &[Vec<CLink>],
    dirty: &Dirty,
) -> RoundDecisions {
    let (ctx, eps, lim) = (params.ctx, params.eps, &params.lim);
    let patch: Decisions = plinks
        .par_iter()
        .enumerate()
        .filter(|(r, ls)| dirty.patch[*r] && !ls.is_empty())
        .filter_map(|(r, ls)| {
            let flat = links_flat(h, st, ctx, r, ls, eps, lim.basis);
            let d: Vec<(usize, Split)> = ls
                .iter()
                .enumerate()
                .filter_map(|(i, l)| decide_plink(h, st, ctx, r, l, eps, lim, flat).map(|s| (i, s)))
                .collect();
            (!d.is_empty()).then_some((r, d))
        })
        .collect();
    let cluster: Decisions = clinks
        .par_iter()
        .enumerate()
        .filter(|(r, ls)| dirty.cluster[*r] && !ls.is_empty())
        .filter_map(|(r, ls)| {
            let d: Vec<(usize, Split)> = ls
                .iter()
                .enumerate()
                .filter_map(|(i, l)| decide_clink(h, st, ctx, r, l, eps, lim).map(|s| (i, s)))
                .collect();
            (!d.is_empty()).then_some((r, d))
        })
        .collect();
    RoundDecisions { patch, cluster }
}

/// Splits the leaf patches the decisions name (receivers and patch senders).
fn split_elements(
    h: &mut Hierarchy,
    decisions: &RoundDecisions,
    plinks: &[Vec<PLink>],
    clinks: &[Vec<CLink>],
) {
    let mut to_split: Vec<usize> = Vec::new();
    for (r, d) in &decisions.patch {
        for (i, s) in d {
            match s {
                Split::Receiver => to_split.push(*r),
                Split::Sender => {
                    if let Kind::Patch(p) = plinks[*r][*i].src.kind() {
                        to_split.push(p);
                    }
                }
            }
        }
    }
    for (r, d) in &decisions.cluster {
        for (i, s) in d {
            if *s == Split::Sender
                && let Kind::Patch(p) = clinks[*r][*i].src.kind()
            {
                to_split.push(p);
            }
        }
    }
    to_split.sort_unstable();
    to_split.dedup();
    for &p in &to_split {
        if h.patches[p].is_leaf() {
            h.split_patch(p);
        }
    }
}

/// The links (receiver, sender, inherited full visibility) that replace the decided
/// ones: from the receiver's children or to the sender's.
fn replacement_jobs(
    h: &Hierarchy,
    decisions: &RoundDecisions,
    plinks: &[Vec<PLink>],
    clinks: &[Vec<CLink>],
) -> Vec<ReplacementJob> {
    let mut jobs: Vec<ReplacementJob> = Vec::new();
    let mut push_jobs = |recv: Node, src: Node, visible: bool, split: Split| match split {
        Split::Receiver => {
            let (kids, n) = h.children(recv);
            for &c in &kids[..n] {
                jobs.push((c, src, visible));
            }
        }
        Split::Sender => {
            let (kids, n) = h.children(src);
            let keep = visible && matches!(src.kind(), Kind::Patch(_));
            for &c in &kids[..n] {
                jobs.push((recv, c, keep));
            }
        }
    };
    for (r, d) in &decisions.patch {
        for (i, s) in d {
            let l = &plinks[*r][*i];
            push_jobs(Node::patch(*r), l.src, l.visible, *s);
        }
    }
    for (r, d) in &decisions.cluster {
        for (i, s) in d {
            let l = &clinks[*r][*i];
            push_jobs(Node::cluster(*r), l.src, false, *s);
        }
    }
    jobs
}

/// Removes the decided links from their receivers, keeping the others in order.
fn drop_decided<L>(links: &mut [Vec<L>], decisions: &Decisions) {
    for (r, d) in decisions {
        let mut drop = vec![false; links[*r].len()];
        for (i, _) in d {
            drop[*i] = true;
        }
        let mut k = 0;
        links[*r].retain(|_| {
            k += 1;
            !drop[k - 1]
        });
    }
}
