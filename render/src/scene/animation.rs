//! Rigid-body animation of a scene (Hahn 2000, ch. 4): objects and lights follow
//! keyframed translations and rotations; every frame is the base scene with those
//! motions applied. The `[animation]` entry of a scene file is documented in
//! `fixtures/scenes/README.md`.

use nalgebra::{Rotation3, Unit};
use serde::Deserialize;

use super::error::SceneError;
use super::geom::V3;
use super::limits::{MAX_COORDINATE_M, MAX_FRAMES};
use super::types::{LightKind, Scene};

/// The `[animation]` entry as written in the scene file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnimationFile {
    /// Number of frames (frames 0 … frames − 1).
    pub frames: usize,
    /// Frames per second, for the times printed beside frame numbers.
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// One track per moving object or light.
    #[serde(default)]
    pub tracks: Vec<TrackFile>,
}

fn default_fps() -> f64 {
    30.0
}

/// One `[[animation.tracks]]` entry: what moves and its keys.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackFile {
    /// OBJ object (or inline polygon name) that moves; exactly one of `object`, `light`.
    pub object: Option<String>,
    /// Name of a `[[lights]]` entry that moves.
    pub light: Option<String>,
    /// Rotation centre in file units; default: the object's bounding-box centre or the
    /// light's position.
    pub pivot: Option<[f64; 3]>,
    /// Rotation axis (world); needed when a key rotates.
    pub axis: Option<[f64; 3]>,
    /// Keys in increasing frame order; the pose is interpolated linearly between them
    /// and held before the first and after the last.
    pub keys: Vec<KeyFile>,
}

/// One key of a track.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeyFile {
    /// Frame number of the key.
    pub frame: usize,
    /// Translation from the base pose, file units.
    #[serde(default)]
    pub translate: [f64; 3],
    /// Rotation about the track's axis through its pivot, degrees (right hand).
    #[serde(default)]
    pub rotate_deg: f64,
}

/// A rigid motion: rotation about `pivot`, then translation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMotion {
    /// Rotation about the pivot.
    pub rotation: Rotation3<f64>,
    /// Centre of the rotation, metres.
    pub pivot: V3,
    /// Translation after the rotation, metres.
    pub translation: V3,
}

impl RigidMotion {
    /// No motion.
    pub fn identity() -> Self {
        Self {
            rotation: Rotation3::identity(),
            pivot: V3::zeros(),
            translation: V3::zeros(),
        }
    }

    /// Whether it moves nothing.
    pub fn is_identity(&self) -> bool {
        self.translation == V3::zeros() && self.rotation == Rotation3::identity()
    }

    /// Where the point `p` goes.
    pub fn point(&self, p: &V3) -> V3 {
        self.pivot + self.rotation * (p - self.pivot) + self.translation
    }

    /// Where the direction `d` turns.
    pub fn direction(&self, d: &V3) -> V3 {
        self.rotation * d
    }
}

/// What a track moves.
#[derive(Debug, Clone, PartialEq)]
enum Target {
    /// Indices of the scene's polygons of one object.
    Polygons(Vec<usize>),
    /// Index of a light.
    Light(usize),
}

/// A key in scene units: frame, translation (m), rotation angle (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Key {
    frame: usize,
    translation: V3,
    angle_rad: f64,
}

/// One moving object or light.
#[derive(Debug, Clone, PartialEq)]
struct Track {
    name: String,
    target: Target,
    pivot: V3,
    axis: Unit<V3>,
    keys: Vec<Key>,
}

impl Track {
    /// The interpolated motion at frame `f`.
    fn motion(&self, f: usize) -> RigidMotion {
        let (a, b) = self.bracket(f);
        let t = if b.frame > a.frame {
            (f as f64 - a.frame as f64) / (b.frame - a.frame) as f64
        } else {
            0.0
        };
        let translation = a.translation + (b.translation - a.translation) * t;
        let angle = a.angle_rad + (b.angle_rad - a.angle_rad) * t;
        RigidMotion {
            rotation: Rotation3::from_axis_angle(&self.axis, angle),
            pivot: self.pivot,
            translation,
        }
    }

    /// The keys at or before and at or after frame `f` (the same key outside them).
    fn bracket(&self, f: usize) -> (Key, Key) {
        let after = self.keys.iter().position(|k| k.frame >= f);
        match after {
            None => {
                let last = self.keys[self.keys.len() - 1];
                (last, last)
            }
            Some(0) => (self.keys[0], self.keys[0]),
            Some(i) => (self.keys[i - 1], self.keys[i]),
        }
    }
}

/// A keyframed rigid-body animation of a scene's objects and lights.
#[derive(Debug, Clone, PartialEq)]
pub struct Animation {
    frames: usize,
    fps: f64,
    tracks: Vec<Track>,
}

impl Animation {
    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Frames per second.
    pub fn fps(&self) -> f64 {
        self.fps
    }

    /// Names of the moving objects and lights.
    pub fn track_names(&self) -> Vec<&str> {
        self.tracks.iter().map(|t| t.name.as_str()).collect()
    }

    /// The motion of every track at frame `f`, in track order.
    pub fn track_motions(&self, f: usize) -> Vec<RigidMotion> {
        self.tracks.iter().map(|t| t.motion(f)).collect()
    }

    /// The scene polygons each track moves, in track order (none for a light).
    pub fn track_polygons(&self) -> Vec<&[usize]> {
        self.tracks
            .iter()
            .map(|t| match &t.target {
                Target::Polygons(p) => p.as_slice(),
                Target::Light(_) => &[],
            })
            .collect()
    }

    /// The motion of every polygon of `base` at frame `f` (identity when it is not
    /// animated).
    pub fn polygon_motions(&self, base: &Scene, f: usize) -> Vec<RigidMotion> {
        let mut out = vec![RigidMotion::identity(); base.polygons.len()];
        for t in &self.tracks {
            if let Target::Polygons(polys) = &t.target {
                let m = t.motion(f);
                for &p in polys {
                    out[p] = m;
                }
            }
        }
        out
    }

    /// The motion of every light of `base` at frame `f`.
    pub fn light_motions(&self, base: &Scene, f: usize) -> Vec<RigidMotion> {
        let mut out = vec![RigidMotion::identity(); base.lights.len()];
        for t in &self.tracks {
            if let Target::Light(l) = t.target {
                out[l] = t.motion(f);
            }
        }
        out
    }

    /// The scene at frame `f`: `base` with every track's motion applied.
    pub fn frame_scene(&self, base: &Scene, f: usize) -> Scene {
        let mut s = base.clone();
        for (p, m) in s.polygons.iter_mut().zip(self.polygon_motions(base, f)) {
            if !m.is_identity() {
                p.vertices.iter_mut().for_each(|v| *v = m.point(v));
            }
        }
        for (l, m) in s.lights.iter_mut().zip(self.light_motions(base, f)) {
            if !m.is_identity() {
                l.position = m.point(&l.position);
                turn_light(&mut l.kind, &m);
            }
        }
        s
    }
}

/// Turns a light's axis or photometric frame with a motion's rotation.
fn turn_light(kind: &mut LightKind, m: &RigidMotion) {
    match kind {
        LightKind::Isotropic { .. } => {}
        LightKind::Spot { axis, .. } => *axis = m.direction(axis),
        LightKind::Goniometric { frame, .. } => {
            for v in frame.iter_mut() {
                *v = m.direction(v);
            }
        }
    }
}

fn invalid(track: &str, message: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        what: format!("animation track `{track}`"),
        message: message.into(),
    }
}

/// Checks an `[animation]` entry and binds its tracks to `scene`'s polygons and lights.
pub fn animation_of(
    file: &AnimationFile,
    scene: &Scene,
    unit_m: f64,
) -> Result<Animation, SceneError> {
    check_frames(file)?;
    let tracks = file
        .tracks
        .iter()
        .map(|t| track(t, scene, unit_m, file.frames))
        .collect::<Result<Vec<_>, _>>()?;
    for (i, t) in tracks.iter().enumerate() {
        if tracks[..i].iter().any(|o| o.target == t.target) {
            return Err(invalid(
                &t.name,
                "moves what an earlier track moves; give one track per object or light",
            ));
        }
    }
    Ok(Animation {
        frames: file.frames,
        fps: file.fps,
        tracks,
    })
}

fn check_frames(file: &AnimationFile) -> Result<(), SceneError> {
    if file.frames == 0 || file.frames > MAX_FRAMES {
        return Err(SceneError::Invalid {
            what: "animation".into(),
            message: format!(
                "frames = {} must be between 1 and {MAX_FRAMES}",
                file.frames
            ),
        });
    }
    if !(file.fps.is_finite() && file.fps > 0.0) {
        return Err(SceneError::Invalid {
            what: "animation".into(),
            message: format!("fps = {} must be positive", file.fps),
        });
    }
    Ok(())
}

/// One track bound to the scene, its keys in metres and radians.
fn track(t: &TrackFile, scene: &Scene, unit_m: f64, frames: usize) -> Result<Track, SceneError> {
    let (name, target, centre) = target_of(t, scene)?;
    let keys = keys_of(&name, &t.keys, unit_m, frames)?;
    let pivot = match t.pivot {
        Some(p) => finite_point(&name, "pivot", p)? * unit_m,
        None => centre,
    };
    let rotates = keys.iter().any(|k| k.angle_rad != 0.0);
    let axis = match (t.axis, rotates) {
        (Some(a), _) => Unit::try_new(finite_point(&name, "axis", a)?, 1e-12)
            .ok_or_else(|| invalid(&name, "axis must not be zero"))?,
        (None, false) => Unit::new_unchecked(V3::y()),
        (None, true) => return Err(invalid(&name, "a key rotates; give the rotation `axis`")),
    };
    check_reach(&name, &target, scene, pivot, &keys)?;
    Ok(Track {
        name,
        target,
        pivot,
        axis,
        keys,
    })
}

/// Refuses keys that would carry any point of the target beyond
/// [`MAX_COORDINATE_M`] (a rotation about the pivot keeps each point within its
/// distance of the pivot).
fn check_reach(
    name: &str,
    target: &Target,
    scene: &Scene,
    pivot: V3,
    keys: &[Key],
) -> Result<(), SceneError> {
    let radius = match target {
        Target::Polygons(polys) => polys
            .iter()
            .flat_map(|&p| &scene.polygons[p].vertices)
            .map(|v| (v - pivot).norm())
            .fold(0.0, f64::max),
        Target::Light(l) => (scene.lights[*l].position - pivot).norm(),
    };
    let farthest = keys
        .iter()
        .map(|k| pivot.norm() + radius + k.translation.norm())
        .fold(0.0, f64::max);
    if farthest.is_nan() || farthest > MAX_COORDINATE_M {
        return Err(invalid(
            name,
            format!(
                "its keys carry it up to {farthest:e} m from the origin, beyond the \
                 {MAX_COORDINATE_M:e} m a scene may reach"
            ),
        ));
    }
    Ok(())
}

/// The track's name, what it moves and the default pivot (bounding-box centre or the
/// light's position).
fn target_of(t: &TrackFile, scene: &Scene) -> Result<(String, Target, V3), SceneError> {
    match (&t.object, &t.light) {
        (Some(o), None) => {
            let polys: Vec<usize> = (0..scene.polygons.len())
                .filter(|&i| &scene.polygons[i].object == o)
                .collect();
            if polys.is_empty() {
                return Err(invalid(o, "no object of the geometry has this name"));
            }
            let (mut lo, mut hi) = (V3::repeat(f64::INFINITY), V3::repeat(f64::NEG_INFINITY));
            for v in polys.iter().flat_map(|&i| &scene.polygons[i].vertices) {
                lo = lo.inf(v);
                hi = hi.sup(v);
            }
            Ok((o.clone(), Target::Polygons(polys), (lo + hi) / 2.0))
        }
        (None, Some(l)) => {
            let i = scene
                .lights
                .iter()
                .position(|x| &x.name == l)
                .ok_or_else(|| invalid(l, "no [[lights]] entry has this name"))?;
            Ok((l.clone(), Target::Light(i), scene.lights[i].position))
        }
        _ => Err(SceneError::Invalid {
            what: "animation track".into(),
            message: "give exactly one of `object` and `light`".into(),
        }),
    }
}

/// The keys in metres and radians, checked: at least one, frames strictly increasing
/// and inside the animation, finite values.
fn keys_of(
    name: &str,
    keys: &[KeyFile],
    unit_m: f64,
    frames: usize,
) -> Result<Vec<Key>, SceneError> {
    if keys.is_empty() {
        return Err(invalid(name, "has no keys"));
    }
    let mut out: Vec<Key> = Vec::with_capacity(keys.len());
    for k in keys {
        if k.frame >= frames {
            return Err(invalid(
                name,
                format!(
                    "key at frame {} is past the last frame {}",
                    k.frame,
                    frames - 1
                ),
            ));
        }
        if out.last().is_some_and(|p| p.frame >= k.frame) {
            return Err(invalid(name, "key frames must be strictly increasing"));
        }
        if !k.rotate_deg.is_finite() {
            return Err(invalid(name, "rotate_deg must be finite"));
        }
        out.push(Key {
            frame: k.frame,
            translation: finite_point(name, "translate", k.translate)? * unit_m,
            angle_rad: k.rotate_deg.to_radians(),
        });
    }
    Ok(out)
}

fn finite_point(name: &str, field: &str, a: [f64; 3]) -> Result<V3, SceneError> {
    if a.iter().all(|x| x.is_finite()) {
        Ok(V3::new(a[0], a[1], a[2]))
    } else {
        Err(invalid(name, format!("{field} = {a:?} must be finite")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_animated_scene_toml;
    use std::path::Path;

    const SCENE: &str = r#"
unit_m = 0.001
[materials.white]
reflectance_y = 0.5
[materials.lamp]
reflectance_y = 0.5
emission_cd_m2 = 100.0
[[polygons]]
name = "box"
material = "white"
vertices = [[0, 0, 0], [100, 0, 0], [100, 100, 0], [0, 100, 0]]
[[polygons]]
name = "floor"
material = "lamp"
vertices = [[0, 0, -10], [100, 0, -10], [100, 100, -10], [0, 100, -10]]
[[lights]]
name = "spot"
type = "spot"
position = [0, 0, 1000]
intensity_cd = 10.0
axis = [0, 0, -1]
inner_deg = 10
outer_deg = 20
"#;

    fn parse(animation: &str) -> Result<(Scene, Option<Animation>), SceneError> {
        let text = format!("{SCENE}{animation}");
        parse_animated_scene_toml(&text, Path::new("."), Path::new("t.toml"))
            .map(|(s, a, _)| (s, a))
    }

    #[test]
    fn a_key_pose_is_reached_at_its_frame_and_interpolated_linearly_between_keys() {
        let (scene, anim) = parse(
            r#"
[animation]
frames = 11
[[animation.tracks]]
object = "box"
axis = [0, 0, 1]
keys = [{ frame = 0 }, { frame = 10, translate = [200, 0, 0], rotate_deg = 90 }]
"#,
        )
        .expect("valid");
        let anim = anim.expect("animated");
        let end = anim.frame_scene(&scene, 10);
        // the box's corner (0, 0) turns 90° about its centre (50, 50) to (100, 0), then
        // moves 0.2 m along x
        let v = end.polygons[0].vertices[0];
        assert!((v - V3::new(0.3, 0.0, 0.0)).norm() < 1e-12, "{v}");
        let mid = anim.frame_scene(&scene, 5).polygons[0].vertices[0];
        let centre = V3::new(0.05, 0.05, 0.0);
        let turned =
            Rotation3::from_axis_angle(&V3::z_axis(), 45f64.to_radians()) * (V3::zeros() - centre);
        assert!((mid - (centre + turned + V3::new(0.1, 0.0, 0.0))).norm() < 1e-12);
        assert_eq!(
            end.polygons[1], scene.polygons[1],
            "the floor does not move"
        );
    }

    #[test]
    fn a_light_track_moves_the_light_and_turns_its_spot_axis() {
        let (scene, anim) = parse(
            r#"
[animation]
frames = 3
[[animation.tracks]]
light = "spot"
axis = [1, 0, 0]
keys = [{ frame = 2, translate = [0, 0, -500], rotate_deg = 180 }]
"#,
        )
        .expect("valid");
        let s = anim.expect("animated").frame_scene(&scene, 2);
        assert!((s.lights[0].position - V3::new(0.0, 0.0, 0.5)).norm() < 1e-12);
        let LightKind::Spot { axis, .. } = s.lights[0].kind else {
            panic!("a spot")
        };
        assert!((axis - V3::z()).norm() < 1e-12, "{axis}");
    }

    #[test]
    fn bad_tracks_are_refused_with_the_reason() {
        let cases = [
            ("frames = 0\n", "between 1"),
            (
                "frames = 5\n[[animation.tracks]]\nobject = \"chair\"\nkeys = [{ frame = 0 }]\n",
                "no object",
            ),
            (
                "frames = 5\n[[animation.tracks]]\nobject = \"box\"\nkeys = [{ frame = 5 }]\n",
                "past the last frame",
            ),
            (
                "frames = 5\n[[animation.tracks]]\nobject = \"box\"\nkeys = [{ frame = 2 }, { frame = 2 }]\n",
                "strictly increasing",
            ),
            (
                "frames = 5\n[[animation.tracks]]\nobject = \"box\"\nkeys = [{ frame = 1, rotate_deg = 5 }]\n",
                "axis",
            ),
            (
                "frames = 5\n[[animation.tracks]]\nobject = \"box\"\nkeys = [{ frame = 1, translate = [1e306, 0, 0] }]\n",
                "beyond",
            ),
            (
                "frames = 5\n[[animation.tracks]]\nobject = \"box\"\npivot = [1e12, 0, 0]\nkeys = [{ frame = 1 }]\n",
                "beyond",
            ),
            (
                "frames = 5\n[[animation.tracks]]\nlight = \"spot\"\nobject = \"box\"\nkeys = [{ frame = 1 }]\n",
                "exactly one",
            ),
            (
                "frames = 5\n[[animation.tracks]]\nobject = \"box\"\nkeys = [{ frame = 1 }]\n[[animation.tracks]]\nobject = \"box\"\nkeys = [{ frame = 2 }]\n",
                "earlier track",
            ),
        ];
        for (body, why) in cases {
            let err = parse(&format!("[animation]\n{body}"))
                .expect_err(body)
                .to_string();
            assert!(err.contains(why), "{body}: {err}");
        }
    }

    #[test]
    fn a_scene_without_an_animation_entry_has_none() {
        assert!(parse("").expect("valid").1.is_none());
    }
}
