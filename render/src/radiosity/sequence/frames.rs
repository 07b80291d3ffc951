//! The geometry of an animation's frames for the sequence solver: which elements
//! move, where they are in each distinct frame, the moving polygons' occluders per
//! frame, and a tree of their bounding boxes over frames (Hahn's time intervals) that
//! names the frames in which a moving object can come between two static elements.

use std::collections::HashMap;

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
    /// Groups `frames` by pose: a frame whose every track sits where an earlier
    /// frame's do reuses that frame's solution. Refuses more frames than
    /// [`MAX_SEQUENCE_STATE_BYTES`] of motions before looking at them.
    pub(crate) fn new(
        base: &Scene,
        anim: &Animation,
        frames: &[usize],
    ) -> Result<Self, RadiosityError> {
        check_bytes(
            "their motions",
            (frames.len() as u64)
                .saturating_mul(anim.track_names().len() as u64)
                .saturating_mul(std::mem::size_of::<RigidMotion>() as u64),
        )?;
        let tracks = anim.track_names().len();
        let first = anim.track_motions(frames[0]);
        let mut moving_track = vec![false; tracks];
        let mut index: HashMap<Vec<u64>, usize> = HashMap::new();
        let mut poses = Vec::new();
        let mut pose_of = Vec::with_capacity(frames.len());
        for &f in frames {
            let motions = anim.track_motions(f);
            for (t, m) in motions.iter().enumerate() {
                moving_track[t] |= *m != first[t];
            }
            let next = poses.len();
            let pose = *index.entry(motion_bits(&motions)).or_insert(next);
            if pose == next {
                poses.push(f);
            }
            pose_of.push(pose);
        }
        let mut moving_polygon = vec![false; base.polygons.len()];
        let mut moving_objects = Vec::new();
        for (t, polys) in anim.track_polygons().into_iter().enumerate() {
            if moving_track[t] && !polys.is_empty() {
                polys.iter().for_each(|&p| moving_polygon[p] = true);
                moving_objects.push(polys.to_vec());
            }
        }
        Ok(Self {
            requested: frames.to_vec(),
            pose_of,
            poses,
            moving_polygon,
            moving_objects,
        })
    }
}

/// The exact bits of a set of motions (equal poses have equal bits).
fn motion_bits(motions: &[RigidMotion]) -> Vec<u64> {
    motions
        .iter()
        .flat_map(|m| {
            let r = m.rotation.matrix();
            r.iter()
                .chain(m.pivot.iter())
                .chain(m.translation.iter())
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        })
        .collect()
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

/// Bytes a pose keeps per scene polygon (its moved copy of the scene) and per moving
/// element (a moved element with its quadrature points), about.
const BYTES_PER_POSE_POLYGON: u64 = 200;
const BYTES_PER_MOVED_ELEMENT: u64 = 320;

/// Bytes of one frame's patch in the output, about (a quad with its values).
const BYTES_PER_FRAME_PATCH: u64 = 260;

/// Most memory a sequence may take (8 GiB).
pub const MAX_SEQUENCE_STATE_BYTES: u64 = 8 << 30;

/// What a sequence of `poses` distinct poses and `frames` frames over a mesh of
/// `elements` elements (`moving` of them moving) and a scene of `polygons` polygons
/// needs: refused above [`MAX_SEQUENCE_STATE_BYTES`], before it is allocated.
pub(crate) fn check_state_size(
    elements: usize,
    moving: usize,
    polygons: usize,
    poses: usize,
    frames: usize,
) -> Result<(), RadiosityError> {
    let (n, m) = (elements as u64, poses as u64);
    let per_pose = (polygons as u64)
        .saturating_mul(BYTES_PER_POSE_POLYGON)
        .saturating_add((moving as u64).saturating_mul(BYTES_PER_MOVED_ELEMENT));
    let bytes = n
        .saturating_mul(m)
        .saturating_mul(BYTES_PER_ELEMENT_POSE)
        .saturating_add(m.saturating_mul(per_pose))
        .saturating_add(
            n.saturating_mul(frames as u64)
                .saturating_mul(BYTES_PER_FRAME_PATCH),
        );
    check_bytes(
        &format!("{elements} elements over {poses} distinct poses and {frames} frames"),
        bytes,
    )
}

fn check_bytes(what: &str, bytes: u64) -> Result<(), RadiosityError> {
    if bytes > MAX_SEQUENCE_STATE_BYTES {
        return Err(RadiosityError::BadOption(format!(
            "{what} need {:.1} GiB, more than the {} GiB allowed; solve fewer frames at \
             once or give a larger max edge",
            bytes as f64 / (1u64 << 30) as f64,
            MAX_SEQUENCE_STATE_BYTES >> 30
        )));
    }
    Ok(())
}
