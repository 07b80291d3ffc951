//! What is lit and by what: polygons with photometric materials, area emitters,
//! point/spot/goniometric lights and a camera, loaded from OBJ plus a TOML scene file.
//!
//! All light quantities are photometric and carried as CIE XYZ triples in which Y is
//! the photometric quantity (luminance in cd/m², luminous intensity in cd, luminous
//! reflectance). The file format is documented in `fixtures/scenes/README.md`.

pub mod animation;
mod check;
mod error;
mod geom;
pub mod limits;
mod load;
mod types;

pub use animation::{Animation, RigidMotion};
pub use check::{CheckReport, check_polygons};
pub use error::SceneError;
pub use geom::{V3, polygon_area_m2, polygon_normal};
pub use limits::{
    MAX_CAMERA_PIXELS, MAX_COORDINATE_M, MAX_FLUX_LM, MAX_FRAMES, MAX_ILLUMINANCE_LUX,
    MAX_INTENSITY_CD, MAX_LUMINANCE_CD_M2, MAX_UNIT_M, MIN_UNIT_M,
};
pub use load::{
    GoniometricLightFile, LightFile, LightKindFile, LightOutputFile, MethodHint, SceneFile,
    load_animated_scene, load_scene, parse_animated_scene_toml, parse_scene_toml, scene_method,
};
pub use types::{
    Camera, Daylight, DirectionalSource, IntensityFn, Light, LightKind, Material, Polygon, Scene,
};
