//! Triangle geometry for the renderer: indexed meshes, input checks and repair
//! (Kresse 2.2.6: degenerate triangles, vertex welding, non-manifold edges, normal
//! orientation, T-vertices), a SAH bounding-volume hierarchy for ray casts and
//! shadow rays, and the seeded architectural scene generator for the scale bench.

mod bvh;
mod indexed;
mod repair;
mod scale_scene;

pub use bvh::{Bvh, BvhStats, Hit};
pub use indexed::IndexedMesh;
pub(crate) use indexed::{cross, dot};
pub use repair::{MeshReport, RepairOptions, check_and_repair, check_and_repair_with};
pub use scale_scene::{
    GeneratedLight, GeneratedLightKind, GeneratedMaterial, GeneratedScene, generate_scale_scene,
};
