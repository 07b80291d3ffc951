//! Loading a scene: a TOML scene file (materials, lights, camera, optional inline
//! polygons) that names an optional OBJ file for the geometry (read with `tobj`).

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use super::animation::{Animation, AnimationFile, animation_of};
use super::check::{CheckReport, check_polygons};
use super::error::SceneError;
use super::geom::V3;
use super::limits::{
    MAX_CAMERA_PIXELS, MAX_COORDINATE_M, MAX_FLUX_LM, MAX_ILLUMINANCE_LUX, MAX_INTENSITY_CD,
    MAX_LUMINANCE_CD_M2, MAX_UNIT_M, MIN_UNIT_M, MIN_UP_VIEW_SINE,
};
use super::types::{Camera, Light, LightKind, Material, Polygon, Scene};

/// The TOML scene file as written on disk (see `fixtures/scenes/README.md`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// OBJ file, relative to the scene file.
    pub geometry: Option<String>,
    /// Metres per file unit; multiplies every coordinate (OBJ, polygons, lights, camera).
    #[serde(default = "one")]
    pub unit_m: f64,
    /// Material for objects that neither `[objects]` nor `usemtl` assign.
    pub default_material: Option<String>,
    /// OBJ object/group name → material name.
    #[serde(default)]
    pub objects: BTreeMap<String, String>,
    /// Materials by name.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialFile>,
    /// Inline polygons (in addition to the OBJ).
    #[serde(default)]
    pub polygons: Vec<PolygonFile>,
    /// Point-like lights.
    #[serde(default)]
    pub lights: Vec<LightFile>,
    /// Camera.
    pub camera: Option<CameraFile>,
    /// Daylight: a CIE sky (with sun for the clear sky).
    pub sky: Option<SkyFile>,
    /// Keyframed rigid-body motion of objects and lights.
    pub animation: Option<AnimationFile>,
    /// The lighting method that suits the scene, used when `lumiwall render` is not
    /// given `--method` ([`scene_method`]).
    pub method: Option<MethodHint>,
}

/// The scene file's `method`: how the scene is best lit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodHint {
    /// Hierarchical radiosity (static scenes, error-bounded).
    Radiosity,
    /// Progressive refinement (animations solved as one sequence).
    Progressive,
    /// Voxel-based GI, direct light and one bounce, every frame from scratch
    /// (fully dynamic scenes).
    VoxelGi,
}

/// The `method` a scene file asks for, if any (read without loading the geometry).
pub fn scene_method(path: &Path) -> Result<Option<MethodHint>, SceneError> {
    #[derive(Deserialize)]
    struct Only {
        method: Option<MethodHint>,
    }
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    toml::from_str::<Only>(&text)
        .map(|o| o.method)
        .map_err(|e| SceneError::Toml {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

/// The `[sky]` entry: a CIE standard sky, discretised into distant cells.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkyFile {
    /// `overcast` (CIE standard overcast, Moon & Spencer) or `clear` (CIE clear sky,
    /// ISO 15469 type 12, with sun).
    pub model: String,
    /// Zenith luminance in cd/m².
    pub zenith_luminance_cd_m2: f64,
    /// Clear sky: sun position, azimuth (degrees from north towards east) and
    /// elevation (degrees above the horizon).
    pub sun_azimuth_deg: Option<f64>,
    /// See `sun_azimuth_deg`.
    pub sun_elevation_deg: Option<f64>,
    /// Clear sky: the sun's normal illuminance in lux (default: the IES clear-sky
    /// model from the elevation).
    pub sun_normal_illuminance_lux: Option<f64>,
    /// Zenith-angle bands of the sky's discretisation (cells of about equal solid
    /// angle per band).
    #[serde(default = "sky_bands")]
    pub bands: usize,
    /// World up (zenith) direction.
    #[serde(default = "z_up")]
    pub up: [f64; 3],
    /// World north (made orthogonal to `up`).
    #[serde(default = "y_north")]
    pub north: [f64; 3],
    /// Sky chromaticity (default D65: 0.3127, 0.3290).
    pub sky_xy: Option<[f64; 2]>,
    /// Sun chromaticity (default 0.3324, 0.3474, about 5500 K).
    pub sun_xy: Option<[f64; 2]>,
}

fn sky_bands() -> usize {
    8
}

fn z_up() -> [f64; 3] {
    [0.0, 0.0, 1.0]
}

fn y_north() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

fn one() -> f64 {
    1.0
}

/// A material entry.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialFile {
    /// Reflectance per XYZ channel (Y = luminous reflectance).
    pub reflectance_xyz: Option<[f64; 3]>,
    /// Spectrally flat reflectance (all channels equal).
    pub reflectance_y: Option<f64>,
    /// Emitted luminance Y in cd/m² (area emitter).
    pub emission_cd_m2: Option<f64>,
    /// Emitter chromaticity xy (default: equal-energy white 1/3, 1/3).
    pub emission_xy: Option<[f64; 2]>,
}

/// An inline polygon.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolygonFile {
    /// 3 or more vertices, counter-clockwise seen from the front.
    pub vertices: Vec<[f64; 3]>,
    /// Material name.
    pub material: String,
    /// Name for messages.
    #[serde(default)]
    pub name: String,
}

/// A light entry: what every light has, and what its `type` adds.
///
/// Read from the flat `[[lights]]` table of the file; fields that belong to another
/// `type` are accepted and ignored, as they always were.
#[derive(Debug, Clone, Deserialize)]
#[serde(try_from = "LightEntry")]
pub struct LightFile {
    /// Name for messages (empty: numbered).
    pub name: String,
    /// Position (file units).
    pub position: [f64; 3],
    /// Chromaticity xy (default equal-energy white).
    pub color_xy: Option<[f64; 2]>,
    /// The kind of light and its own fields (the file's `type`).
    pub kind: LightKindFile,
}

/// The kind-specific part of a [`LightFile`], tagged by the file's `type`.
#[derive(Debug, Clone, PartialEq)]
pub enum LightKindFile {
    /// `type = "point"`: isotropic.
    Point {
        /// Luminous intensity in cd, or total flux in lm (exactly one of the two).
        output: LightOutputFile,
    },
    /// `type = "spot"`: linear angular fall-off from `inner_deg` to `outer_deg`.
    Spot {
        /// Luminous intensity on the axis in cd, or total flux in lm.
        output: LightOutputFile,
        /// Spot axis.
        axis: Option<[f64; 3]>,
        /// Half angle of full intensity in degrees.
        inner_deg: Option<f64>,
        /// Half angle where the intensity reaches zero in degrees.
        outer_deg: Option<f64>,
    },
    /// `type = "goniometric"`: an IES LM-63 `.ies` or EULUMDAT `.ldt` file.
    Goniometric(GoniometricLightFile),
}

/// The fields of a goniometric light entry.
#[derive(Debug, Clone, PartialEq)]
pub struct GoniometricLightFile {
    /// The photometric file, relative to the scene file.
    pub file: Option<String>,
    /// World direction of the photometric axis (nadir, γ = 0°).
    pub aim: Option<[f64; 3]>,
    /// World direction of the C0° plane (default: chosen from `aim`).
    pub c0: Option<[f64; 3]>,
    /// Multiplies the file's intensities (e.g. a dimming factor).
    pub scale: Option<f64>,
    /// Scales the file's intensities to this total flux in lm.
    pub flux_lm: Option<f64>,
}

/// How bright a point or spot light is: `intensity_cd` and/or `flux_lm` as written
/// (the loader requires exactly one of the two).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightOutputFile {
    /// Luminous intensity in cd (on the axis for spots).
    pub intensity_cd: Option<f64>,
    /// Total luminous flux in lm.
    pub flux_lm: Option<f64>,
}

/// A `[[lights]]` table exactly as written: one flat table whose `type` selects
/// which of the other fields matter.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct LightEntry {
    /// Name for messages.
    #[serde(default)]
    name: String,
    /// `point`, `spot`, or `goniometric` (an IES LM-63 `.ies` or EULUMDAT `.ldt`
    /// file).
    #[serde(rename = "type")]
    kind: String,
    /// Goniometric: the photometric file, relative to the scene file.
    file: Option<String>,
    /// Goniometric: world direction of the photometric axis (nadir, γ = 0°).
    aim: Option<[f64; 3]>,
    /// Goniometric: world direction of the C0° plane (default: chosen from `aim`).
    c0: Option<[f64; 3]>,
    /// Goniometric: multiplies the file's intensities (e.g. a dimming factor); use
    /// `flux_lm` instead to set the total flux.
    scale: Option<f64>,
    /// Position (file units).
    position: [f64; 3],
    /// Luminous intensity in cd (on the axis for spots).
    intensity_cd: Option<f64>,
    /// Total luminous flux in lm (alternative to `intensity_cd`).
    flux_lm: Option<f64>,
    /// Chromaticity xy (default equal-energy white).
    color_xy: Option<[f64; 2]>,
    /// Spot axis.
    axis: Option<[f64; 3]>,
    /// Spot: half angle of full intensity in degrees.
    inner_deg: Option<f64>,
    /// Spot: half angle where the intensity reaches zero in degrees.
    outer_deg: Option<f64>,
}

impl TryFrom<LightEntry> for LightFile {
    type Error = String;

    fn try_from(l: LightEntry) -> Result<Self, String> {
        let output = LightOutputFile {
            intensity_cd: l.intensity_cd,
            flux_lm: l.flux_lm,
        };
        let kind = match l.kind.as_str() {
            "point" => LightKindFile::Point { output },
            "spot" => LightKindFile::Spot {
                output,
                axis: l.axis,
                inner_deg: l.inner_deg,
                outer_deg: l.outer_deg,
            },
            "goniometric" => {
                if l.intensity_cd.is_some() {
                    return Err(format!(
                        "light `{}`: a goniometric light takes `flux_lm` or `scale`, not `intensity_cd`",
                        l.name
                    ));
                }
                LightKindFile::Goniometric(GoniometricLightFile {
                    file: l.file,
                    aim: l.aim,
                    c0: l.c0,
                    scale: l.scale,
                    flux_lm: l.flux_lm,
                })
            }
            other => {
                return Err(format!(
                    "light `{}`: type `{other}` is not known; use `point`, `spot` or `goniometric`",
                    l.name
                ));
            }
        };
        Ok(LightFile {
            name: l.name,
            position: l.position,
            color_xy: l.color_xy,
            kind,
        })
    }
}

/// The camera entry.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraFile {
    /// Eye position (file units).
    pub position: [f64; 3],
    /// Point looked at (file units).
    pub look_at: [f64; 3],
    /// Up vector.
    #[serde(default = "up")]
    pub up: [f64; 3],
    /// Vertical field of view in degrees.
    pub vfov_deg: f64,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

fn up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

fn v3(a: [f64; 3]) -> V3 {
    V3::new(a[0], a[1], a[2])
}

fn invalid(what: impl Into<String>, message: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        what: what.into(),
        message: message.into(),
    }
}

/// A position given in file units, in metres: every coordinate finite and within
/// ±[`MAX_COORDINATE_M`] once scaled by `unit_m`.
fn point_m(what: &str, field: &str, a: [f64; 3], unit_m: f64) -> Result<V3, SceneError> {
    if !a.iter().all(|c| c.is_finite()) {
        return Err(invalid(
            what,
            format!("`{field}` = {a:?} is not finite; give three finite numbers (file units)"),
        ));
    }
    let p = v3(a) * unit_m;
    if p.iter().any(|c| c.abs() > MAX_COORDINATE_M) {
        return Err(invalid(
            what,
            format!(
                "`{field}` = {a:?} × unit_m {unit_m} = [{:e}, {:e}, {:e}] m lies beyond ±{MAX_COORDINATE_M:e} m; check unit_m and the coordinates",
                p.x, p.y, p.z
            ),
        ));
    }
    Ok(p)
}

/// A unit direction from a file vector: finite and not zero.
fn direction(what: &str, field: &str, a: [f64; 3]) -> Result<V3, SceneError> {
    if !a.iter().all(|c| c.is_finite()) {
        return Err(invalid(
            what,
            format!("`{field}` = {a:?} is not finite; give a non-zero direction of finite numbers"),
        ));
    }
    // scale first so that huge components do not overflow the norm
    let big = a.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    let d = if big > 0.0 { v3(a) / big } else { v3(a) };
    d.try_normalize(MIN_DIRECTION_LENGTH).ok_or_else(|| {
        invalid(
            what,
            format!("`{field}` = {a:?} has zero length; give a non-zero direction"),
        )
    })
}

fn xy_to_xyz(what: &str, xy: Option<[f64; 2]>) -> Result<[f64; 3], SceneError> {
    let [x, y] = xy.unwrap_or([1.0 / 3.0, 1.0 / 3.0]);
    if !(x.is_finite() && y.is_finite() && x >= 0.0 && y > 1e-6 && x + y <= 1.0) {
        return Err(invalid(
            what,
            format!("chromaticity ({x}, {y}) is outside the xy diagram"),
        ));
    }
    Ok([x / y, 1.0, (1.0 - x - y) / y])
}

fn material(name: &str, m: &MaterialFile) -> Result<Material, SceneError> {
    let what = format!("material `{name}`");
    let reflectance_xyz = match (m.reflectance_xyz, m.reflectance_y) {
        (Some(r), None) => r,
        (None, Some(y)) => [y; 3],
        (None, None) => [0.0; 3],
        (Some(_), Some(_)) => {
            return Err(invalid(
                what,
                "give either reflectance_xyz or reflectance_y, not both",
            ));
        }
    };
    if !reflectance_xyz
        .iter()
        .all(|r| r.is_finite() && (0.0..1.0).contains(r))
    {
        return Err(invalid(
            what,
            format!(
                "reflectance {reflectance_xyz:?} must lie in [0, 1) per channel (ρ = 1 never converges)"
            ),
        ));
    }
    let l = m.emission_cd_m2.unwrap_or(0.0);
    if !(l.is_finite() && (0.0..=MAX_LUMINANCE_CD_M2).contains(&l)) {
        return Err(invalid(
            what,
            format!(
                "emission {l:?} cd/m² must be ≥ 0 and at most {MAX_LUMINANCE_CD_M2:e} cd/m² (the sun's disc is about 1.6e9 cd/m²)"
            ),
        ));
    }
    let c = xy_to_xyz(&what, m.emission_xy)?;
    Ok(Material {
        name: name.to_string(),
        reflectance_xyz,
        emission_cd_m2: [l * c[0], l * c[1], l * c[2]],
    })
}

/// Default spot half angle in degrees when the file gives neither `inner_deg` nor
/// `outer_deg` (documented in `fixtures/scenes/README.md`).
const DEFAULT_SPOT_HALF_ANGLE_DEG: f64 = 30.0;

/// Shortest direction vector the loader normalises; shorter counts as zero.
const MIN_DIRECTION_LENGTH: f64 = 1e-12;

fn light(i: usize, l: &LightFile, unit_m: f64, base_dir: &Path) -> Result<Light, SceneError> {
    let name = if l.name.is_empty() {
        format!("light {i}")
    } else {
        l.name.clone()
    };
    let what = format!("light `{name}`");
    let position = point_m(&what, "position", l.position, unit_m)?;
    let color_xyz = xy_to_xyz(&what, l.color_xy)?;
    let kind = match &l.kind {
        LightKindFile::Point { output } => LightKind::Isotropic {
            intensity_cd: intensity_cd(&what, *output, |f| f / (4.0 * std::f64::consts::PI))?,
        },
        LightKindFile::Spot {
            output,
            axis,
            inner_deg,
            outer_deg,
        } => spot(&what, *output, *axis, *inner_deg, *outer_deg)?,
        LightKindFile::Goniometric(photometry) => {
            return goniometric(&name, photometry, position, color_xyz, base_dir);
        }
    };
    Ok(Light {
        name,
        position,
        color_xyz,
        kind,
    })
}

/// The intensity in cd of a point or spot: `intensity_cd` as given, or `flux_lm`
/// through `cd_from_flux`; it must be finite and ≥ 0.
fn intensity_cd(
    what: &str,
    output: LightOutputFile,
    cd_from_flux: impl Fn(f64) -> f64,
) -> Result<f64, SceneError> {
    let cd = match (output.intensity_cd, output.flux_lm) {
        (Some(i), None) => i,
        (None, Some(f)) => {
            if !(f.is_finite() && (0.0..=MAX_FLUX_LM).contains(&f)) {
                return Err(invalid(
                    what,
                    format!("flux {f:?} lm must be ≥ 0 and at most {MAX_FLUX_LM:e} lm"),
                ));
            }
            cd_from_flux(f)
        }
        _ => return Err(invalid(what, "give exactly one of intensity_cd or flux_lm")),
    };
    if !(cd.is_finite() && (0.0..=MAX_INTENSITY_CD).contains(&cd)) {
        return Err(invalid(
            what,
            format!("intensity {cd:?} cd must be ≥ 0 and at most {MAX_INTENSITY_CD:e} cd"),
        ));
    }
    Ok(cd)
}

/// A spot light from its file fields.
fn spot(
    what: &str,
    output: LightOutputFile,
    axis: Option<[f64; 3]>,
    inner_deg: Option<f64>,
    outer_deg: Option<f64>,
) -> Result<LightKind, SceneError> {
    let axis = direction(
        what,
        "axis",
        axis.ok_or_else(|| invalid(what, "a spot needs `axis`"))?,
    )?;
    let inner_deg = inner_deg.unwrap_or(DEFAULT_SPOT_HALF_ANGLE_DEG);
    let outer_deg = outer_deg.unwrap_or(inner_deg);
    let inner = inner_deg.to_radians();
    let outer = outer_deg.to_radians();
    if !(inner > 0.0 && outer >= inner && outer <= std::f64::consts::PI) {
        return Err(invalid(
            what,
            format!(
                "inner_deg = {inner_deg:?}, outer_deg = {outer_deg:?}: need 0 < inner_deg ≤ outer_deg ≤ 180"
            ),
        ));
    }
    let intensity_cd = intensity_cd(what, output, |f| {
        f / super::types::spot_flux_per_cd(inner, outer)
    })?;
    Ok(LightKind::Spot {
        axis,
        intensity_cd,
        inner_half_angle_rad: inner,
        outer_half_angle_rad: outer,
    })
}

/// Default photometric axis of a goniometric light: straight down in a z-up scene.
const DEFAULT_AIM: [f64; 3] = [0.0, 0.0, -1.0];

/// A goniometric light from an IES LM-63 or EULUMDAT file.
fn goniometric(
    name: &str,
    l: &GoniometricLightFile,
    position: V3,
    color_xyz: [f64; 3],
    base_dir: &Path,
) -> Result<Light, SceneError> {
    use crate::photometry::{LightFrame, to_scene_light};
    let what = format!("light `{name}`");
    let file = l
        .file
        .as_deref()
        .ok_or_else(|| invalid(&what, "a goniometric light needs `file` (.ies or .ldt)"))?;
    let mut dist = read_distribution(&what, &base_dir.join(file))?;
    match (l.flux_lm, l.scale) {
        (Some(_), Some(_)) => return Err(invalid(&what, "give `flux_lm` or `scale`, not both")),
        (Some(f), None) => {
            if !(f.is_finite() && f > 0.0 && f <= MAX_FLUX_LM) {
                return Err(invalid(
                    &what,
                    format!("flux {f:?} lm must be positive and at most {MAX_FLUX_LM:e} lm"),
                ));
            }
            dist = dist.scaled_to_flux(f);
        }
        (None, Some(k)) => {
            if !(k.is_finite() && k >= 0.0) {
                return Err(invalid(&what, format!("scale {k} must be ≥ 0")));
            }
            dist = dist.scaled_by(k);
        }
        (None, None) => {}
    }
    let (peak, flux) = (dist.max_intensity_cd(), dist.total_flux_lm());
    if !(peak.is_finite() && peak <= MAX_INTENSITY_CD && flux.is_finite()) {
        return Err(invalid(
            &what,
            format!(
                "{file}: the scaled distribution peaks at {peak:e} cd (flux {flux:e} lm); at most {MAX_INTENSITY_CD:e} cd is accepted, lower `scale` or `flux_lm`"
            ),
        ));
    }
    let aim_v = direction(&what, "aim", l.aim.unwrap_or(DEFAULT_AIM))?;
    let aim = [aim_v.x, aim_v.y, aim_v.z];
    let frame = match l.c0 {
        Some(c0) => {
            let c0_v = direction(&what, "c0", c0)?;
            if c0_v.cross(&aim_v).norm() < MIN_UP_VIEW_SINE {
                return Err(invalid(
                    &what,
                    format!(
                        "`c0` = {c0:?} is parallel to `aim` {aim:?}; give a C0° direction across the axis"
                    ),
                ));
            }
            LightFrame::from_axis([c0_v.x, c0_v.y, c0_v.z], aim)
        }
        None => LightFrame::aimed(aim),
    };
    let mut light = to_scene_light(name, &dist, [position.x, position.y, position.z], &frame);
    light.color_xyz = color_xyz;
    Ok(light)
}

/// Reads an `.ies` (LM-63) or `.ldt` (EULUMDAT) photometric file.
fn read_distribution(
    what: &str,
    path: &Path,
) -> Result<crate::photometry::IntensityDistribution, SceneError> {
    use crate::photometry::IntensityDistribution;
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let parsed = match ext.as_deref() {
        Some("ies") => IntensityDistribution::from_ies_lm63(&text),
        Some("ldt") => IntensityDistribution::from_eulumdat(&text),
        _ => {
            return Err(invalid(
                what,
                format!(
                    "{}: the file must end in .ies (LM-63) or .ldt (EULUMDAT)",
                    path.display()
                ),
            ));
        }
    };
    parsed.map_err(|e| invalid(what, format!("{}: {e}", path.display())))
}

/// Most zenith bands of a sky's discretisation (one band per degree of zenith angle).
const MAX_SKY_BANDS: usize = 90;

/// Daylight from a `[sky]` entry, in world coordinates.
fn daylight(s: &SkyFile) -> Result<super::types::Daylight, SceneError> {
    use super::types::{Daylight, DirectionalSource};
    check_sky_numbers(s)?;
    let world = sky_to_world(s)?;
    let sky_col = xy_to_xyz("sky colour", Some(s.sky_xy.unwrap_or([0.3127, 0.3290])))?;
    let sun_col = xy_to_xyz("sun colour", Some(s.sun_xy.unwrap_or([0.3324, 0.3474])))?;
    let sky = sky_model(s)?;
    let sky_cells = sky
        .patches(s.bands)
        .into_iter()
        .map(|c| DirectionalSource {
            direction: world(c.direction),
            normal_illuminance_lux: c.luminance_cd_m2 * c.solid_angle_sr,
            color_xyz: sky_col,
        })
        .collect();
    let sun = sky.sun().map(|sun| DirectionalSource {
        direction: world(sun.direction),
        normal_illuminance_lux: sun.normal_illuminance_lux,
        color_xyz: sun_col,
    });
    Ok(Daylight { sky_cells, sun })
}

/// The sky's zenith luminance and band count within their limits.
fn check_sky_numbers(s: &SkyFile) -> Result<(), SceneError> {
    let zl = s.zenith_luminance_cd_m2;
    if !(zl.is_finite() && zl > 0.0 && zl <= MAX_LUMINANCE_CD_M2) {
        return Err(invalid(
            "sky",
            format!(
                "zenith_luminance_cd_m2 = {zl:?} must be positive and at most {MAX_LUMINANCE_CD_M2:e} cd/m²"
            ),
        ));
    }
    if !(1..=MAX_SKY_BANDS).contains(&s.bands) {
        return Err(invalid(
            "sky",
            format!("bands {} must be in 1..={MAX_SKY_BANDS}", s.bands),
        ));
    }
    Ok(())
}

/// Maps a direction of the sky model's frame (x east, y north, z up) to the world.
fn sky_to_world(s: &SkyFile) -> Result<impl Fn([f64; 3]) -> V3, SceneError> {
    let up = direction("sky", "up", s.up)?;
    let north = direction("sky", "north", s.north)?;
    let north = north - up * up.dot(&north);
    let north = north
        .try_normalize(MIN_DIRECTION_LENGTH)
        .ok_or_else(|| invalid("sky", "`north` must not be parallel to `up`"))?;
    let east = north.cross(&up);
    Ok(move |d: [f64; 3]| east * d[0] + north * d[1] + up * d[2])
}

/// The CIE sky of the file: overcast (no sun) or clear with its sun.
fn sky_model(s: &SkyFile) -> Result<crate::photometry::Sky, SceneError> {
    use crate::photometry::Sky;
    let what = "sky";
    match s.model.as_str() {
        "overcast" => {
            if s.sun_azimuth_deg.is_some() || s.sun_elevation_deg.is_some() {
                return Err(invalid(what, "the overcast sky has no sun; remove sun_*"));
            }
            Ok(Sky::cie_overcast(s.zenith_luminance_cd_m2))
        }
        "clear" => {
            let (Some(az), Some(el)) = (s.sun_azimuth_deg, s.sun_elevation_deg) else {
                return Err(invalid(
                    what,
                    "the clear sky needs sun_azimuth_deg and sun_elevation_deg",
                ));
            };
            if !(az.is_finite() && el.is_finite() && (-90.0..=90.0).contains(&el)) {
                return Err(invalid(what, "sun elevation must lie in [−90°, 90°]"));
            }
            let (az, el) = (az.to_radians(), el.to_radians());
            let dir = [az.sin() * el.cos(), az.cos() * el.cos(), el.sin()];
            let sky = Sky::cie_clear(dir, s.zenith_luminance_cd_m2);
            match s.sun_normal_illuminance_lux {
                Some(e) if e.is_finite() && (0.0..=MAX_ILLUMINANCE_LUX).contains(&e) => {
                    Ok(sky.with_sun_normal_illuminance_lux(e))
                }
                Some(e) => Err(invalid(
                    what,
                    format!(
                        "sun_normal_illuminance_lux = {e:?} must be ≥ 0 and at most {MAX_ILLUMINANCE_LUX:e} lx"
                    ),
                )),
                None => Ok(sky),
            }
        }
        other => Err(invalid(
            what,
            format!("model `{other}` is not known; use `overcast` or `clear`"),
        )),
    }
}

/// Parses a scene from TOML text; `base_dir` resolves the OBJ path. An `[animation]`
/// entry is checked and left out: the scene is the base pose (see
/// [`parse_animated_scene_toml`]).
pub fn parse_scene_toml(
    text: &str,
    base_dir: &Path,
    source: &Path,
) -> Result<(Scene, CheckReport), SceneError> {
    parse_animated_scene_toml(text, base_dir, source).map(|(s, _, r)| (s, r))
}

/// Parses a scene and its animation, if it has one, from TOML text.
pub fn parse_animated_scene_toml(
    text: &str,
    base_dir: &Path,
    source: &Path,
) -> Result<(Scene, Option<Animation>, CheckReport), SceneError> {
    let file: SceneFile = toml::from_str(text).map_err(|e| SceneError::Toml {
        path: source.to_path_buf(),
        message: e.to_string(),
    })?;
    let u = file.unit_m;
    if !(u.is_finite() && (MIN_UNIT_M..=MAX_UNIT_M).contains(&u)) {
        return Err(invalid(
            "unit_m",
            format!(
                "unit_m = {u:?} must be the metres per file unit, between {MIN_UNIT_M:e} and {MAX_UNIT_M:e} (e.g. 1 for metres, 0.001 for millimetres)"
            ),
        ));
    }
    // refuse an image too large to allocate before any geometry is read or solved
    if let Some(c) = &file.camera {
        camera_size(c)?;
    }
    let materials = Materials::of(&file)?;
    let mut raw = match &file.geometry {
        Some(obj) => obj_polygons(&file, &materials, &base_dir.join(obj))?,
        None => Vec::new(),
    };
    raw.extend(inline_polygons(&file, &materials)?);
    let (polygons, report) = check_polygons(raw);
    if polygons.is_empty() {
        return Err(SceneError::Empty(report.summary()));
    }
    let lights = file
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| light(i, l, file.unit_m, base_dir))
        .collect::<Result<Vec<_>, _>>()?;
    let camera = file
        .camera
        .as_ref()
        .map(|c| camera(c, file.unit_m))
        .transpose()?;
    let sky = file.sky.as_ref().map(daylight).transpose()?;
    let scene = Scene {
        polygons,
        materials: materials.list,
        lights,
        camera,
        sky,
    };
    let animation = file
        .animation
        .as_ref()
        .map(|a| animation_of(a, &scene, file.unit_m))
        .transpose()?;
    Ok((scene, animation, report))
}

/// The scene's materials, in name order, and their indices by name.
struct Materials {
    list: Vec<Material>,
    index: BTreeMap<String, usize>,
}

impl Materials {
    fn of(file: &SceneFile) -> Result<Self, SceneError> {
        let mut list = Vec::new();
        let mut index = BTreeMap::new();
        for (name, m) in &file.materials {
            index.insert(name.clone(), list.len());
            list.push(material(name, m)?);
        }
        Ok(Self { list, index })
    }

    /// Index of material `name`, used by `object`.
    fn lookup(&self, object: &str, name: &str) -> Result<usize, SceneError> {
        self.index
            .get(name)
            .copied()
            .ok_or_else(|| SceneError::UnknownMaterial {
                object: object.to_string(),
                material: name.to_string(),
            })
    }
}

/// Every face of the OBJ file at `path`, in metres, with its material from
/// `[objects]`, `usemtl` or `default_material` (in that order).
fn obj_polygons(
    file: &SceneFile,
    materials: &Materials,
    path: &Path,
) -> Result<Vec<Polygon>, SceneError> {
    let opts = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // tobj 4 overflows on absurd indices (a panic in debug builds): a malformed file
    // must be an error that names it, never a crash
    let loaded = std::panic::catch_unwind(|| tobj::load_obj(path, &opts)).map_err(|_| {
        SceneError::Obj {
            path: path.to_path_buf(),
            message: "the OBJ reader failed on a malformed face or index; check the file's `f` lines (indices must refer to existing v/vt/vn entries)".into(),
        }
    })?;
    let (models, mtl) = loaded.map_err(|e| SceneError::Obj {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let mtl_names: Vec<String> = mtl
        .map(|m| m.into_iter().map(|m| m.name).collect())
        .unwrap_or_default();
    let mut raw = Vec::new();
    for model in models {
        let mat_name = file
            .objects
            .get(&model.name)
            .cloned()
            .or_else(|| {
                model
                    .mesh
                    .material_id
                    .and_then(|i| mtl_names.get(i).cloned())
            })
            .or_else(|| file.default_material.clone())
            .ok_or_else(|| SceneError::UnknownMaterial {
                object: model.name.clone(),
                material: "(none: no [objects] entry, usemtl or default_material)".into(),
            })?;
        let material = materials.lookup(&model.name, &mat_name)?;
        model_faces(&model, material, file.unit_m, path, &mut raw)?;
    }
    Ok(raw)
}

/// Appends the faces of one OBJ model (scaled by `unit_m`) to `raw`.
fn model_faces(
    model: &tobj::Model,
    material: usize,
    unit_m: f64,
    path: &Path,
    raw: &mut Vec<Polygon>,
) -> Result<(), SceneError> {
    let mesh = &model.mesh;
    let obj_error = |message: &str| SceneError::Obj {
        path: path.to_path_buf(),
        message: format!("object `{}` {message}", model.name),
    };
    let vertex = |k: u32| -> Option<V3> {
        let k = k as usize * 3;
        let p = mesh.positions.get(k..k + 3)?;
        Some(V3::new(p[0] as f64, p[1] as f64, p[2] as f64) * unit_m)
    };
    if let Some(c) = mesh
        .positions
        .iter()
        .map(|&c| c as f64 * unit_m)
        .find(|c| c.is_finite() && c.abs() > MAX_COORDINATE_M)
    {
        return Err(obj_error(&format!(
            "has a vertex coordinate of {c:e} m (file value × unit_m {unit_m}), beyond ±{MAX_COORDINATE_M:e} m; check unit_m and the OBJ's units"
        )));
    }
    let arities: Vec<u32> = if mesh.face_arities.is_empty() {
        vec![3; mesh.indices.len() / 3]
    } else {
        mesh.face_arities.clone()
    };
    let mut at = 0usize;
    for a in arities {
        let idx = mesh
            .indices
            .get(at..at + a as usize)
            .ok_or_else(|| obj_error("has a face past the end of its index list"))?;
        at += a as usize;
        let vertices: Option<Vec<V3>> = idx.iter().map(|&k| vertex(k)).collect();
        let vertices =
            vertices.ok_or_else(|| obj_error("refers to a vertex that does not exist"))?;
        raw.push(Polygon {
            vertices,
            material,
            object: model.name.clone(),
        });
    }
    Ok(())
}

/// The scene file's `[[polygons]]`, in metres.
fn inline_polygons(file: &SceneFile, materials: &Materials) -> Result<Vec<Polygon>, SceneError> {
    let mut raw = Vec::with_capacity(file.polygons.len());
    for (i, p) in file.polygons.iter().enumerate() {
        let name = if p.name.is_empty() {
            format!("polygon {i}")
        } else {
            p.name.clone()
        };
        let vertices: Vec<V3> = p.vertices.iter().map(|&v| v3(v) * file.unit_m).collect();
        if let Some(v) = vertices.iter().find(|v| {
            v.iter()
                .any(|c| c.is_finite() && c.abs() > MAX_COORDINATE_M)
        }) {
            return Err(invalid(
                format!("polygon `{name}`"),
                format!(
                    "vertex [{:e}, {:e}, {:e}] m (file value × unit_m {}) lies beyond ±{MAX_COORDINATE_M:e} m; check unit_m and the coordinates",
                    v.x, v.y, v.z, file.unit_m
                ),
            ));
        }
        raw.push(Polygon {
            vertices,
            material: materials.lookup(&name, &p.material)?,
            object: name,
        });
    }
    Ok(raw)
}

/// Widest vertical field of view a camera may have, degrees (exclusive).
const MAX_VFOV_DEG: f64 = 179.0;

/// The `[camera]` entry, in metres.
fn camera(c: &CameraFile, unit_m: f64) -> Result<Camera, SceneError> {
    let what = "camera";
    if !(c.vfov_deg > 0.0 && c.vfov_deg < MAX_VFOV_DEG) {
        return Err(invalid(
            what,
            format!("vfov_deg = {:?} must lie in (0, 179) degrees", c.vfov_deg),
        ));
    }
    camera_size(c)?;
    let position = point_m(what, "position", c.position, unit_m)?;
    let look_at = point_m(what, "look_at", c.look_at, unit_m)?;
    let up = direction(what, "up", c.up)?;
    let view = look_at - position;
    let Some(fwd) = view.try_normalize(MIN_DIRECTION_LENGTH * unit_m) else {
        return Err(invalid(
            what,
            format!(
                "`position` {:?} and `look_at` {:?} are the same point, so the view direction is undefined; set look_at to the point the camera faces",
                c.position, c.look_at
            ),
        ));
    };
    if fwd.cross(&up).norm() < MIN_UP_VIEW_SINE {
        return Err(invalid(
            what,
            format!(
                "`up` = {:?} is parallel to the view direction look_at − position = [{}, {}, {}]; give an up vector across it (e.g. [0, 0, 1] in a z-up scene)",
                c.up, fwd.x, fwd.y, fwd.z
            ),
        ));
    }
    Ok(Camera {
        position,
        look_at,
        up,
        vfov_deg: c.vfov_deg,
        width_px: c.width,
        height_px: c.height,
    })
}

/// Checks the camera's image size against [`MAX_CAMERA_PIXELS`].
fn camera_size(c: &CameraFile) -> Result<(), SceneError> {
    let pixels = u64::from(c.width) * u64::from(c.height);
    if pixels == 0 || pixels > MAX_CAMERA_PIXELS {
        return Err(invalid(
            "camera",
            format!(
                "width × height = {} × {} = {pixels} pixels; need width, height > 0 and at most {MAX_CAMERA_PIXELS} pixels (2^26, e.g. 8192 × 8192); lower width or height",
                c.width, c.height
            ),
        ));
    }
    Ok(())
}

/// Loads a scene file from disk.
pub fn load_scene(path: &Path) -> Result<(Scene, CheckReport), SceneError> {
    load_animated_scene(path).map(|(s, _, r)| (s, r))
}

/// Loads a scene file with its animation, if it has one.
pub fn load_animated_scene(
    path: &Path,
) -> Result<(Scene, Option<Animation>, CheckReport), SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse_animated_scene_toml(&text, base, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light_entry(body: &str) -> Result<LightFile, String> {
        #[derive(Deserialize)]
        struct Lights {
            lights: Vec<LightFile>,
        }
        toml::from_str::<Lights>(&format!("[[lights]]\n{body}"))
            .map(|mut l| l.lights.remove(0))
            .map_err(|e| e.to_string())
    }

    #[test]
    fn light_type_selects_the_kind_and_fields_of_other_types_are_ignored() {
        let l =
            light_entry("type = \"point\"\nposition = [0, 0, 1]\nflux_lm = 10\naxis = [0, 0, -1]")
                .unwrap();
        assert_eq!(
            l.kind,
            LightKindFile::Point {
                output: LightOutputFile {
                    intensity_cd: None,
                    flux_lm: Some(10.0)
                }
            }
        );
        let l =
            light_entry("type = \"spot\"\nposition = [0, 0, 1]\nintensity_cd = 5\ninner_deg = 20")
                .unwrap();
        assert!(matches!(
            l.kind,
            LightKindFile::Spot {
                inner_deg: Some(20.0),
                ..
            }
        ));
    }

    #[test]
    fn unknown_light_type_and_unknown_field_are_rejected_with_the_name() {
        let e = light_entry("name = \"x\"\ntype = \"laser\"\nposition = [0, 0, 1]").unwrap_err();
        assert!(e.contains("light `x`: type `laser` is not known"), "{e}");
        let e = light_entry("type = \"point\"\nposition = [0, 0, 1]\nintensity = 1").unwrap_err();
        assert!(e.contains("intensity"), "{e}");
        let e = light_entry("type = \"goniometric\"\nposition = [0, 0, 1]\nintensity_cd = 1")
            .unwrap_err();
        assert!(e.contains("not `intensity_cd`"), "{e}");
    }
}
