//! Loading a scene: a TOML scene file (materials, lights, camera, optional inline
//! polygons) that names an optional OBJ file for the geometry (read with `tobj`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::check::{CheckReport, check_polygons};
use super::error::SceneError;
use super::geom::V3;
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

/// A light entry.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightFile {
    /// Name for messages.
    #[serde(default)]
    pub name: String,
    /// `point` or `spot`.
    #[serde(rename = "type")]
    pub kind: String,
    /// Position (file units).
    pub position: [f64; 3],
    /// Luminous intensity in cd (on the axis for spots).
    pub intensity_cd: Option<f64>,
    /// Total luminous flux in lm (alternative to `intensity_cd`).
    pub flux_lm: Option<f64>,
    /// Chromaticity xy (default equal-energy white).
    pub color_xy: Option<[f64; 2]>,
    /// Spot axis.
    pub axis: Option<[f64; 3]>,
    /// Spot: half angle of full intensity in degrees.
    pub inner_deg: Option<f64>,
    /// Spot: half angle where the intensity reaches zero in degrees.
    pub outer_deg: Option<f64>,
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
    if !(l.is_finite() && l >= 0.0) {
        return Err(invalid(what, format!("emission {l} cd/m² must be ≥ 0")));
    }
    let c = xy_to_xyz(&what, m.emission_xy)?;
    Ok(Material {
        name: name.to_string(),
        reflectance_xyz,
        emission_cd_m2: [l * c[0], l * c[1], l * c[2]],
    })
}

fn light(i: usize, l: &LightFile, unit_m: f64) -> Result<Light, SceneError> {
    let name = if l.name.is_empty() {
        format!("light {i}")
    } else {
        l.name.clone()
    };
    let what = format!("light `{name}`");
    let position = v3(l.position) * unit_m;
    if !position.iter().all(|c| c.is_finite()) {
        return Err(invalid(what, "position is not finite"));
    }
    let color_xyz = xy_to_xyz(&what, l.color_xy)?;
    let kind = match l.kind.as_str() {
        "point" => {
            let i_cd = match (l.intensity_cd, l.flux_lm) {
                (Some(i), None) => i,
                (None, Some(f)) => f / (4.0 * std::f64::consts::PI),
                _ => return Err(invalid(what, "give exactly one of intensity_cd or flux_lm")),
            };
            LightKind::Isotropic { intensity_cd: i_cd }
        }
        "spot" => {
            let axis = v3(l
                .axis
                .ok_or_else(|| invalid(&what, "a spot needs `axis`"))?);
            let axis = axis
                .try_normalize(1e-12)
                .ok_or_else(|| invalid(&what, "spot axis has zero length"))?;
            let inner = l.inner_deg.unwrap_or(30.0).to_radians();
            let outer = l
                .outer_deg
                .unwrap_or(l.inner_deg.unwrap_or(30.0))
                .to_radians();
            if !(inner > 0.0 && outer >= inner && outer <= std::f64::consts::PI) {
                return Err(invalid(what, "need 0 < inner_deg ≤ outer_deg ≤ 180"));
            }
            let i_cd = match (l.intensity_cd, l.flux_lm) {
                (Some(i), None) => i,
                (None, Some(f)) => f / super::types::spot_flux_per_cd(inner, outer),
                _ => return Err(invalid(what, "give exactly one of intensity_cd or flux_lm")),
            };
            LightKind::Spot {
                axis,
                intensity_cd: i_cd,
                inner_half_angle_rad: inner,
                outer_half_angle_rad: outer,
            }
        }
        other => {
            return Err(invalid(
                what,
                format!(
                    "type `{other}` is not known; use `point` or `spot` (goniometric lights are added through the API)"
                ),
            ));
        }
    };
    let cd = match &kind {
        LightKind::Isotropic { intensity_cd } | LightKind::Spot { intensity_cd, .. } => {
            *intensity_cd
        }
        LightKind::Goniometric { .. } => 0.0,
    };
    if !(cd.is_finite() && cd >= 0.0) {
        return Err(invalid(what, format!("intensity {cd} cd must be ≥ 0")));
    }
    Ok(Light {
        name,
        position,
        color_xyz,
        kind,
    })
}

/// Parses a scene from TOML text; `base_dir` resolves the OBJ path.
pub fn parse_scene_toml(
    text: &str,
    base_dir: &Path,
    source: &Path,
) -> Result<(Scene, CheckReport), SceneError> {
    let file: SceneFile = toml::from_str(text).map_err(|e| SceneError::Toml {
        path: source.to_path_buf(),
        message: e.to_string(),
    })?;
    if !(file.unit_m.is_finite() && file.unit_m > 0.0) {
        return Err(invalid(
            "unit_m",
            "must be a positive number of metres per unit",
        ));
    }
    let mut materials = Vec::new();
    let mut index = BTreeMap::new();
    for (name, m) in &file.materials {
        index.insert(name.clone(), materials.len());
        materials.push(material(name, m)?);
    }
    let lookup = |object: &str, name: &str| {
        index
            .get(name)
            .copied()
            .ok_or_else(|| SceneError::UnknownMaterial {
                object: object.to_string(),
                material: name.to_string(),
            })
    };
    let mut raw = Vec::new();
    if let Some(obj) = &file.geometry {
        let path: PathBuf = base_dir.join(obj);
        let opts = tobj::LoadOptions {
            single_index: false,
            triangulate: false,
            ignore_points: true,
            ignore_lines: true,
        };
        let (models, mtl) = tobj::load_obj(&path, &opts).map_err(|e| SceneError::Obj {
            path: path.clone(),
            message: e.to_string(),
        })?;
        let mtl_names: Vec<String> = mtl
            .map(|m| m.into_iter().map(|m| m.name).collect())
            .unwrap_or_default();
        for model in models {
            let mesh = &model.mesh;
            let mat_name = file
                .objects
                .get(&model.name)
                .cloned()
                .or_else(|| mesh.material_id.and_then(|i| mtl_names.get(i).cloned()))
                .or_else(|| file.default_material.clone())
                .ok_or_else(|| SceneError::UnknownMaterial {
                    object: model.name.clone(),
                    material: "(none: no [objects] entry, usemtl or default_material)".into(),
                })?;
            let mat = lookup(&model.name, &mat_name)?;
            let vertex = |k: u32| -> Option<V3> {
                let k = k as usize * 3;
                let p = mesh.positions.get(k..k + 3)?;
                Some(V3::new(p[0] as f64, p[1] as f64, p[2] as f64) * file.unit_m)
            };
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
                    .ok_or_else(|| SceneError::Obj {
                        path: path.clone(),
                        message: format!(
                            "object `{}` has a face past the end of its index list",
                            model.name
                        ),
                    })?;
                at += a as usize;
                let vertices: Option<Vec<V3>> = idx.iter().map(|&k| vertex(k)).collect();
                let vertices = vertices.ok_or_else(|| SceneError::Obj {
                    path: path.clone(),
                    message: format!(
                        "object `{}` refers to a vertex that does not exist",
                        model.name
                    ),
                })?;
                raw.push(Polygon {
                    vertices,
                    material: mat,
                    object: model.name.clone(),
                });
            }
        }
    }
    for (i, p) in file.polygons.iter().enumerate() {
        let name = if p.name.is_empty() {
            format!("polygon {i}")
        } else {
            p.name.clone()
        };
        raw.push(Polygon {
            vertices: p.vertices.iter().map(|&v| v3(v) * file.unit_m).collect(),
            material: lookup(&name, &p.material)?,
            object: name,
        });
    }
    let (polygons, report) = check_polygons(raw);
    if polygons.is_empty() {
        return Err(SceneError::Empty(report.summary()));
    }
    let lights = file
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| light(i, l, file.unit_m))
        .collect::<Result<Vec<_>, _>>()?;
    let camera = match &file.camera {
        None => None,
        Some(c) => {
            if !(c.vfov_deg > 0.0 && c.vfov_deg < 179.0 && c.width > 0 && c.height > 0) {
                return Err(invalid(
                    "camera",
                    "need 0 < vfov_deg < 179 and width, height > 0",
                ));
            }
            Some(Camera {
                position: v3(c.position) * file.unit_m,
                look_at: v3(c.look_at) * file.unit_m,
                up: v3(c.up),
                vfov_deg: c.vfov_deg,
                width_px: c.width,
                height_px: c.height,
            })
        }
    };
    Ok((
        Scene {
            polygons,
            materials,
            lights,
            camera,
            sky: None,
        },
        report,
    ))
}

/// Loads a scene file from disk.
pub fn load_scene(path: &Path) -> Result<(Scene, CheckReport), SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse_scene_toml(&text, base, path)
}
