//! Documented ceilings on what a scene may ask for. Every float that reaches the
//! camera, a light or a material is checked against them when the scene is loaded,
//! so that the solver's sums (f64) and the image (f32, max ≈ 3.4e38) stay finite and
//! sizes derived from the input are refused before anything is allocated.

/// Highest luminance of an area emitter or a sky zenith, cd/m². The sun's disc is
/// about 1.6e9 cd/m²; with reflectances below 1 and every other ceiling here, the
/// solution and the f32 image stay many orders of magnitude below overflow.
pub const MAX_LUMINANCE_CD_M2: f64 = 1e12;

/// Highest luminous intensity of a point, spot or goniometric light (and of any value
/// of an IES/EULUMDAT table after its multipliers), cd. Searchlights reach ~1e9 cd.
pub const MAX_INTENSITY_CD: f64 = 1e12;

/// Highest total flux of a light, lm (4π · [`MAX_INTENSITY_CD`]).
pub const MAX_FLUX_LM: f64 = 4.0 * std::f64::consts::PI * MAX_INTENSITY_CD;

/// Highest normal illuminance of the sun, lx (the solar constant is ~1.3e5 lx).
pub const MAX_ILLUMINANCE_LUX: f64 = 1e7;

/// Smallest `unit_m` (metres per file unit): a nanometre.
pub const MIN_UNIT_M: f64 = 1e-9;

/// Largest `unit_m`: a kilometre per file unit.
pub const MAX_UNIT_M: f64 = 1e3;

/// Largest absolute coordinate of a vertex, light or camera, in metres (1000 km):
/// areas (≤ 1e12 m² per axis pair) and fluxes stay finite in f64 and f32.
pub const MAX_COORDINATE_M: f64 = 1e6;

/// Most frames an animation may have (about an hour at 30 frames per second); the
/// sequence solver also checks its memory for the frames asked for before allocating.
pub const MAX_FRAMES: usize = 100_000;

/// Most pixels a camera may have: 2^26 (e.g. 8192 × 8192). The image and its depth
/// buffer take 20 bytes a pixel, so this bounds them at about 1.3 GB.
pub const MAX_CAMERA_PIXELS: u64 = 1 << 26;

/// Smallest sine of the angle between a camera's `up` and its view direction; below
/// it `up` counts as parallel and the image frame is undefined.
pub const MIN_UP_VIEW_SINE: f64 = 1e-6;
