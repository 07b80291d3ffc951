//! Form factors of one shot in every pose at once. A pair of static elements is
//! evaluated once: its point-to-polygon kernels and its shadow rays against the
//! static polygons serve every pose. Its rays are tested against the moving
//! polygons only in the poses in which a moving object's box meets the pair's shaft
//! (a tree of each object's boxes over ranges of poses: Hahn's time intervals, 4.3.3),
//! and there only at key poses, bisecting where two keys differ (Hahn 4.3.4,
//! [`super::coherence`]). A pair with a moving end has its kernels evaluated in every
//! pose and its rays sampled at key poses the same way (Hahn 4.3.5).

use std::sync::atomic::Ordering;

use crate::radiosity::RayCounters;
use crate::radiosity::form_factor::{point_to_polygon, targets_in_front};
use crate::radiosity::progressive::{MeshElem, facing};
use crate::radiosity::shaft::{Shaft, bounds};
use crate::radiosity::visibility::{Both, Visibility};
use crate::scene::V3;

use super::coherence::{runs_of, sample_run};
use super::frames::{PoseGeometry, SweptBoxes, poses_meeting_any};

/// What the gains of one shot need.
pub(crate) struct ShotContext<'a> {
    /// Shadow rays against the polygons that never move.
    pub(crate) static_vis: &'a dyn Visibility,
    /// Every distinct pose.
    pub(crate) poses: &'a [PoseGeometry],
    /// Each moving polygon's boxes over poses (empty when no polygon moves).
    pub(crate) swept: &'a [SweptBoxes],
    /// Which poses have light to shoot from the shooter.
    pub(crate) shooting: &'a [bool],
    /// Poses between two visibility keys.
    pub(crate) key_spacing: usize,
    /// Margin of the shaft tests, metres.
    pub(crate) eps: f64,
    /// Ray counters of the solve.
    pub(crate) counters: &'a RayCounters,
}

impl ShotContext<'_> {
    /// Form factors from the static shooter `s` to the static receiver `r` in every
    /// pose, into `out` (one per pose).
    pub(crate) fn static_pair(&self, r: &MeshElem, s: &MeshElem, out: &mut [f64]) {
        out.fill(0.0);
        if !facing(r, s) {
            return;
        }
        let static_candidate = self
            .static_vis
            .may_occlude(&r.verts, r.polygon, &s.verts, s.polygon);
        let counter = if static_candidate {
            &self.counters.tested
        } else {
            &self.counters.skipped
        };
        counter.fetch_add(1, Ordering::Relaxed);
        let near = runs_of(&self.poses_a_mover_may_reach(r, s));
        if !static_candidate && near.is_empty() {
            out.fill(unoccluded(r, s));
            return;
        }
        let targets: Vec<V3> = s.points.iter().map(|(y, _)| *y).collect();
        let skip = [r.polygon, s.polygon];
        let mut shared = 0.0;
        for (x, w) in &r.points {
            let fp = point_to_polygon(x, &r.normal, &s.verts, &s.normal);
            if fp <= 0.0 {
                continue;
            }
            let front = targets_in_front(x, &r.normal, &targets, &s.verts);
            if front.is_empty() && !static_candidate {
                // nothing of s in front of x to aim at: unblocked, as mesh_ff counts it
                shared += w * fp;
                continue;
            }
            let seen: Vec<V3> = if static_candidate {
                self.count_rays(front.len());
                front
                    .iter()
                    .filter(|y| !self.static_vis.occluded(x, y, skip))
                    .copied()
                    .collect()
            } else {
                front.clone()
            };
            let share = w * fp / front.len().max(1) as f64;
            shared += share * seen.len() as f64;
            for y in &seen {
                self.subtract_where_blocked(x, y, skip, &near, share, out);
            }
        }
        for g in out.iter_mut() {
            *g = (*g + shared).max(0.0);
        }
    }

    /// The poses (ascending) in which a moving object's box meets the shaft between
    /// `r` and `s`.
    fn poses_a_mover_may_reach(&self, r: &MeshElem, s: &MeshElem) -> Vec<usize> {
        let mut poses = Vec::new();
        if !self.swept.is_empty() {
            let shaft = Shaft::new(bounds(&r.verts), bounds(&s.verts), self.eps);
            poses_meeting_any(self.swept, &shaft, &mut poses);
        }
        poses
    }

    /// Subtracts `share` from the gain of every pose of the runs `near` in which a
    /// moving polygon blocks the segment `x`–`y`, sampled at key poses.
    fn subtract_where_blocked(
        &self,
        x: &V3,
        y: &V3,
        skip: [usize; 2],
        near: &[(usize, usize)],
        share: f64,
        out: &mut [f64],
    ) {
        if near.is_empty() {
            return;
        }
        let mut blocked = vec![false; self.poses.len()];
        let mut test = |p: usize| {
            self.count_rays(1);
            self.poses[p].moving_occluders.occluded(x, y, skip)
        };
        for &(a, b) in near {
            sample_run(a, b, self.key_spacing, &mut test, &mut blocked);
            for (g, &hit) in out[a..=b].iter_mut().zip(&blocked[a..=b]) {
                if hit {
                    *g -= share;
                }
            }
        }
    }

    /// Form factors from `s` to `r` when one of them moves, `elem(i, pose)` giving
    /// an element where it is in a pose: kernels in every shooting pose, rays at key
    /// poses.
    pub(crate) fn moving_pair<'m>(
        &self,
        r: usize,
        s: usize,
        elem: impl Fn(usize, usize) -> &'m MeshElem,
        out: &mut [f64],
    ) {
        out.fill(0.0);
        let facing_poses: Vec<usize> = (0..self.poses.len())
            .filter(|&p| self.shooting[p] && facing(elem(r, p), elem(s, p)))
            .collect();
        if facing_poses.is_empty() {
            return;
        }
        let mut pair = MovingPair {
            ctx: self,
            r: |p| elem(r, p),
            s: |p| elem(s, p),
            candidate: vec![None; self.poses.len()],
        };
        let visible = pair.ray_visibility(&runs_of(&facing_poses));
        for p in facing_poses {
            out[p] = pair.gain(p, &visible);
        }
    }

    fn count_rays(&self, n: usize) {
        self.counters.rays.fetch_add(n as u64, Ordering::Relaxed);
    }
}

/// A pair with a moving end, its elements by pose and its classification per pose
/// (computed when first asked for).
struct MovingPair<'c, 'a, R, S> {
    ctx: &'c ShotContext<'a>,
    r: R,
    s: S,
    candidate: Vec<Option<bool>>,
}

impl<'m, R, S> MovingPair<'_, '_, R, S>
where
    R: Fn(usize) -> &'m MeshElem,
    S: Fn(usize) -> &'m MeshElem,
{
    /// Occluders of pose `p`: the static polygons and that pose's moving ones.
    fn occluders(&self, p: usize) -> Both<'_> {
        Both(
            self.ctx.static_vis,
            self.ctx.poses[p].moving_occluders.as_ref(),
        )
    }

    /// Whether anything may block a segment between the pair in pose `p`.
    fn candidate(&mut self, p: usize) -> bool {
        if let Some(c) = self.candidate[p] {
            return c;
        }
        let (r, s) = ((self.r)(p), (self.s)(p));
        let c = self
            .occluders(p)
            .may_occlude(&r.verts, r.polygon, &s.verts, s.polygon);
        let counter = if c {
            &self.ctx.counters.tested
        } else {
            &self.ctx.counters.skipped
        };
        counter.fetch_add(1, Ordering::Relaxed);
        self.candidate[p] = Some(c);
        c
    }

    /// Whether ray (receiver point j, sender point t) is unblocked in pose p, at
    /// `[(j · targets + t) · poses + p]`, sampled at key poses over the runs of
    /// poses `runs` (first, last).
    fn ray_visibility(&mut self, runs: &[(usize, usize)]) -> Vec<bool> {
        let m = self.ctx.poses.len();
        let (nj, nt) = (
            (self.r)(runs[0].0).points.len(),
            (self.s)(runs[0].0).points.len(),
        );
        let mut visible = vec![true; nj * nt * m];
        let spacing = self.ctx.key_spacing;
        for j in 0..nj {
            for t in 0..nt {
                let out = &mut visible[(j * nt + t) * m..(j * nt + t + 1) * m];
                let mut test = |p: usize| self.ray_unblocked(p, j, t);
                for &(a, b) in runs {
                    sample_run(a, b, spacing, &mut test, out);
                }
            }
        }
        visible
    }

    /// Whether the ray from receiver point `j` to sender point `t` is unblocked in pose `p`.
    fn ray_unblocked(&mut self, p: usize, j: usize, t: usize) -> bool {
        if !self.candidate(p) {
            return true;
        }
        let (r, s) = ((self.r)(p), (self.s)(p));
        let (x, y) = (&r.points[j].0, &s.points[t].0);
        if r.normal.dot(&(y - x)) <= 0.0 {
            // behind the receiver's plane in this pose: not aimed at here, and a ray
            // through the receiver's own solid would carry a false shadow to the
            // poses around it
            return true;
        }
        self.ctx.count_rays(1);
        !self.occluders(p).occluded(x, y, [r.polygon, s.polygon])
    }

    /// The form factor in pose `p` from the kernels there and the sampled rays.
    fn gain(&mut self, p: usize, visible: &[bool]) -> f64 {
        let m = self.ctx.poses.len();
        let (r, s) = ((self.r)(p), (self.s)(p));
        let nt = s.points.len();
        let mut g = 0.0;
        for (j, (x, w)) in r.points.iter().enumerate() {
            let fp = point_to_polygon(x, &r.normal, &s.verts, &s.normal);
            if fp <= 0.0 {
                continue;
            }
            let front: Vec<usize> = (0..nt)
                .filter(|&t| r.normal.dot(&(s.points[t].0 - x)) > 0.0)
                .collect();
            // the rays say 1 where nothing may block (see `ray_unblocked`)
            let v = if front.is_empty() {
                if self.candidate(p) {
                    self.clipped_visibility(p, x)
                } else {
                    1.0
                }
            } else {
                let seen = front
                    .iter()
                    .filter(|&&t| visible[(j * nt + t) * m + p])
                    .count();
                seen as f64 / front.len() as f64
            };
            g += w * fp * v;
        }
        g
    }

    /// Visibility of the part of the sender in front of the receiver point `x` when
    /// none of its quadrature points is (one ray to that part's centroid).
    fn clipped_visibility(&self, p: usize, x: &V3) -> f64 {
        let (r, s) = ((self.r)(p), (self.s)(p));
        let targets: Vec<V3> = s.points.iter().map(|(y, _)| *y).collect();
        let front = targets_in_front(x, &r.normal, &targets, &s.verts);
        self.ctx.count_rays(front.len());
        let vis = self.occluders(p);
        let seen = front
            .iter()
            .filter(|y| !vis.occluded(x, y, [r.polygon, s.polygon]))
            .count();
        seen as f64 / front.len().max(1) as f64
    }
}

/// The form factor from `s` to `r` with nothing between them.
fn unoccluded(r: &MeshElem, s: &MeshElem) -> f64 {
    r.points
        .iter()
        .map(|(x, w)| w * point_to_polygon(x, &r.normal, &s.verts, &s.normal).max(0.0))
        .sum()
}
