//! The geometry of an animation's frames for the sequence solver: which elements
//! move, where they are in each distinct frame, the moving polygons' occluders per
//! frame, and a tree of their bounding boxes over frames (Hahn's time intervals) that
//! names the frames in which a moving object can come between two static elements.

use crate::radiosity::RadiosityError;
use crate::radiosity::progressive::MeshElem;
use crate::radiosity::shaft::{Shaft, bounds};
use crate::radiosity::visibility::{Visibility, occluders_of};
use crate::scene::{Animation, RigidMotion, Scene, V3};

/// The frames asked for, reduced to the distinct poses among them.
pub(crate) struct FramePlan {
    /// The requested frame numbers, in order.
    pub(crate) requested: Vec<usize>,
    /// For each requested frame, its distinct pose (index into `poses`).
    pub(crate) pose_of: Vec<usize>,
    /// The frame number of each distinct pose (its first occurrence).
    pub(crate) poses: Vec<usize>,
    /// Per polygon: whether it moves between the requested frames.
    pub(crate) moving_polygon: Vec<bool>,
    /// The moving polygons grouped by object (one swept-box tree each).
    pub(crate) moving_objects: Vec<Vec<usize>>,
}

impl FramePlan {
    /// Groups `frames` by pose: a frame whose every polygon and light sits where an
    /// earlier frame's do reuses that frame's solution.
    pub(crate) fn new(base: &Scene, anim: &Animation, frames: &[usize]) -> Self {
        let motions: Vec<(Vec<RigidMotion>, Vec<RigidMotion>)> = frames
            .iter()
            .map(|&f| (anim.polygon_motions(base, f), anim.light_motions(base, f)))
            .collect();
        let mut poses: Vec<usize> = Vec::new();
        let mut pose_of = Vec::with_capacity(frames.len());
        for (k, m) in motions.iter().enumerate() {
            match poses.iter().position(|&p| motions[p] == *m) {
                Some(p) => pose_of.push(p),
                None => {
                    pose_of.push(poses.len());
                    poses.push(k);
                }
            }
        }
        let moving_polygon: Vec<bool> = (0..base.polygons.len())
            .map(|p| motions.iter().any(|m| m.0[p] != motions[0].0[p]))
            .collect();
        let mut moving_objects: Vec<Vec<usize>> = Vec::new();
        let mut names: Vec<&str> = Vec::new();
        for p in (0..base.polygons.len()).filter(|&p| moving_polygon[p]) {
            let name = base.polygons[p].object.as_str();
            match names.iter().position(|n| *n == name) {
                Some(k) => moving_objects[k].push(p),
                None => {
                    names.push(name);
                    moving_objects.push(vec![p]);
                }
            }
        }
        Self {
            requested: frames.to_vec(),
            pose_of,
            poses: poses.iter().map(|&k| frames[k]).collect(),
            moving_polygon,
            moving_objects,
        }
    }
}

/// One distinct pose: the moving elements there and the moving polygons' occluders.
pub(crate) struct PoseGeometry {
    /// The scene at this pose.
    pub(crate) scene: Scene,
    /// The moving elements at this pose, by moving slot.
    pub(crate) moved: Vec<MeshElem>,
    /// Shadow rays against the moving polygons only.
    pub(crate) moving_occluders: Box<dyn Visibility + Send>,
}

/// An element moved rigidly: vertices, normal and quadrature points.
pub(crate) fn moved_elem(e: &MeshElem, m: &RigidMotion) -> MeshElem {
    MeshElem {
        verts: e.verts.iter().map(|v| m.point(v)).collect(),
        normal: m.direction(&e.normal),
        area: e.area,
        polygon: e.polygon,
        points: e.points.iter().map(|(x, w)| (m.point(x), *w)).collect(),
    }
}

impl PoseGeometry {
    /// The pose of frame `frame`; `base_mesh` is the mesh of the unmoved scene and
    /// `moving` lists the moving elements' indices in it.
    pub(crate) fn new(
        base: &Scene,
        anim: &Animation,
        frame: usize,
        plan: &FramePlan,
        base_mesh: &[MeshElem],
        moving: &[usize],
    ) -> Self {
        let scene = anim.frame_scene(base, frame);
        let motions = anim.polygon_motions(base, frame);
        let moved = moving
            .iter()
            .map(|&i| moved_elem(&base_mesh[i], &motions[base_mesh[i].polygon]))
            .collect();
        let moving_occluders = occluders_of(&scene, &|p| plan.moving_polygon[p]);
        Self {
            scene,
            moved,
            moving_occluders,
        }
    }

    /// Bounding box of each moving object at this pose, in the order of
    /// `FramePlan::moving_objects`.
    pub(crate) fn moving_bounds(&self, plan: &FramePlan) -> Vec<(V3, V3)> {
        plan.moving_objects
            .iter()
            .map(|polys| {
                let verts: Vec<V3> = polys
                    .iter()
                    .flat_map(|&p| self.scene.polygons[p].vertices.iter().copied())
                    .collect();
                bounds(&verts)
            })
            .collect()
    }
}

/// Bounding boxes of one moving object over ranges of poses: level 0 one box per
/// pose, each higher level the union of two below. A query descends only into
/// ranges whose box meets the shaft between two elements.
pub(crate) struct SweptBoxes {
    levels: Vec<Vec<Option<(V3, V3)>>>,
}

/// One [`SweptBoxes`] per moving object, from each pose's boxes (`per_pose[p][k]`:
/// moving object k in pose p).
pub(crate) fn swept_per_object(per_pose: &[Vec<(V3, V3)>], eps: f64) -> Vec<SweptBoxes> {
    let count = per_pose.first().map_or(0, Vec::len);
    (0..count)
        .map(|k| SweptBoxes::new(per_pose.iter().map(|b| Some(b[k])).collect(), eps))
        .collect()
}

/// The poses in which any moving object's box may meet `shaft`, in order, once each.
pub(crate) fn poses_meeting_any(swept: &[SweptBoxes], shaft: &Shaft, out: &mut Vec<usize>) {
    for s in swept {
        s.poses_meeting(shaft, out);
    }
    sort_once(swept.len(), out);
}

fn sort_once(trees: usize, poses: &mut Vec<usize>) {
    if trees > 1 {
        poses.sort_unstable();
        poses.dedup();
    }
}

fn union(a: Option<(V3, V3)>, b: Option<(V3, V3)>) -> Option<(V3, V3)> {
    match (a, b) {
        (Some(a), Some(b)) => Some((a.0.inf(&b.0), a.1.sup(&b.1))),
        (a, None) => a,
        (None, b) => b,
    }
}

impl SweptBoxes {
    /// The tree over the poses' boxes (grown by `eps`).
    pub(crate) fn new(boxes: Vec<Option<(V3, V3)>>, eps: f64) -> Self {
        let grow = V3::repeat(eps);
        let mut levels = vec![
            boxes
                .into_iter()
                .map(|b| b.map(|(lo, hi)| (lo - grow, hi + grow)))
                .collect::<Vec<_>>(),
        ];
        while levels[levels.len() - 1].len() > 1 {
            let below = &levels[levels.len() - 1];
            let up = below
                .chunks(2)
                .map(|c| union(c[0], c.get(1).copied().flatten()))
                .collect();
            levels.push(up);
        }
        Self { levels }
    }

    /// Appends to `out` the poses in which the object's box may meet `shaft`.
    pub(crate) fn poses_meeting(&self, shaft: &Shaft, out: &mut Vec<usize>) {
        self.poses_where(
            &|lo, hi| !shaft.box_outside(&[lo.x, lo.y, lo.z], &[hi.x, hi.y, hi.z]),
            out,
        );
    }

    /// Appends the poses whose box `meets` accepts, descending only into accepted
    /// ranges.
    fn poses_where(&self, meets: &dyn Fn(&V3, &V3) -> bool, out: &mut Vec<usize>) {
        let top = self.levels.len() - 1;
        self.descend(top, 0, meets, out);
    }

    fn descend(
        &self,
        level: usize,
        i: usize,
        meets: &dyn Fn(&V3, &V3) -> bool,
        out: &mut Vec<usize>,
    ) {
        let Some(Some((lo, hi))) = self.levels[level].get(i) else {
            return;
        };
        if !meets(lo, hi) {
            return;
        }
        if level == 0 {
            out.push(i);
            return;
        }
        self.descend(level - 1, 2 * i, meets, out);
        self.descend(level - 1, 2 * i + 1, meets, out);
    }
}

/// Bytes of solver state per element and pose: irradiance, exitance and unshot
/// exitance (three XYZ triples) and one gain.
const BYTES_PER_ELEMENT_POSE: u64 = 3 * 24 + 8;

/// Most memory the per-pose state of a sequence may take (8 GiB).
pub const MAX_SEQUENCE_STATE_BYTES: u64 = 8 << 30;

/// Refuses a sequence whose per-pose state would not fit, before allocating it.
pub(crate) fn check_state_size(elements: usize, poses: usize) -> Result<(), RadiosityError> {
    let bytes = (elements as u64)
        .saturating_mul(poses as u64)
        .saturating_mul(BYTES_PER_ELEMENT_POSE);
    if bytes > MAX_SEQUENCE_STATE_BYTES {
        return Err(RadiosityError::BadOption(format!(
            "{elements} elements over {poses} distinct frames need {:.1} GiB of solver \
             state, more than the {} GiB allowed; solve fewer frames at once or give a \
             larger max edge",
            bytes as f64 / (1u64 << 30) as f64,
            MAX_SEQUENCE_STATE_BYTES >> 30
        )));
    }
    Ok(())
}
