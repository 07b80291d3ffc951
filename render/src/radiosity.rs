//! Photometric radiosity: form factors, visibility classification, the hierarchical
//! solver (Kresse 2003, 2.5–2.7), progressive refinement (Southwell shooting) and a
//! brute-force dense reference, all reporting estimated error against wall time.
//!
//! Quantities: radiosity B is luminous exitance in lm/m² carried as XYZ (Y photometric);
//! for Lambertian surfaces the luminance is B/π in cd/m². Area emitters emit π·L.
//!
//! The hierarchical solver clusters the scene (a SAH tree over the input polygons)
//! so that initial linking is linear in their number, refines with Kresse's criterion
//! for every light type (area emitters, point, spot and goniometric lights, a CIE
//! sky with sun), represents receivers with a constant, linear or automatic basis,
//! and spends shadow rays only on partially visible links. An independent Monte
//! Carlo path tracer (`montecarlo`) checks its error estimate.
//! Animations are solved together by Hahn's simultaneous progressive refinement
//! (`sequence`).

pub mod curve;
pub mod form_factor;
pub mod hierarchical;
pub mod montecarlo;
pub mod output;
pub mod progressive;
pub mod quadrature;
pub mod reference;
pub mod sensors;
pub mod sequence;
pub mod shaft;
pub mod solution;
pub mod visibility;

pub use curve::{CurvePoint, ErrorCurve, StopReason, StopRule};
pub use hierarchical::{HierarchicalOptions, solve_hierarchical};
pub use progressive::{ProgressiveOptions, solve_progressive};
pub use reference::solve_dense_reference;
pub use sequence::{KeySpacing, SequenceSolution, solve_sequence};

pub use solution::{Patch, Solution, SolveStats};
pub use visibility::{Both, BvhOccluders, NoOccluders, SceneOccluders, Visibility, occluders_of};

use std::sync::atomic::AtomicU64;
use std::time::Instant;

use crate::scene::Scene;

/// Why a radiosity solve failed.
#[derive(Debug, thiserror::Error)]
pub enum RadiosityError {
    /// The scene cannot be solved as given.
    #[error("scene cannot be solved: {0}")]
    BadScene(String),
    /// A parameter is out of range.
    #[error("invalid solver option: {0}")]
    BadOption(String),
    /// The iteration produced non-finite values.
    #[error("the solve diverged: {0}; check reflectances < 1 and finite emission")]
    Diverged(String),
    /// Writing an output failed.
    #[error("cannot write {path}: {message}")]
    Output {
        /// The file.
        path: std::path::PathBuf,
        /// What failed.
        message: String,
    },
}

/// Visibility work of a solve, counted from parallel workers.
#[derive(Debug, Default)]
pub(crate) struct RayCounters {
    /// Shadow rays cast.
    pub(crate) rays: AtomicU64,
    /// Pairs classified possibly occluded (shadow rays needed).
    pub(crate) tested: AtomicU64,
    /// Pairs classified fully visible (no shadow rays).
    pub(crate) skipped: AtomicU64,
}

/// When a solve started and when its time limit runs out.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SolveClock {
    /// The start of the solve.
    pub(crate) start: Instant,
    /// Start plus the stop rule's time limit, if any.
    pub(crate) deadline: Option<Instant>,
}

impl SolveClock {
    /// Starts the clock and validates the scene and the target error.
    pub(crate) fn start(scene: &Scene, stop: &StopRule) -> Result<Self, RadiosityError> {
        let start = Instant::now();
        validate(scene, stop.target_error)?;
        Ok(Self {
            start,
            deadline: stop.time_limit.map(|t| start + t),
        })
    }

    /// Seconds since the start.
    pub(crate) fn elapsed_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Whether the time limit has passed.
    pub(crate) fn past_deadline(&self) -> bool {
        self.deadline.is_some_and(|d| Instant::now() > d)
    }
}

pub(crate) fn validate(scene: &Scene, target: f64) -> Result<(), RadiosityError> {
    if !(target.is_finite() && target > 0.0 && target < 1.0) {
        return Err(RadiosityError::BadOption(format!(
            "target error {target} must be in (0, 1), e.g. 0.01 for 1 %"
        )));
    }
    if scene.polygons.is_empty() {
        return Err(RadiosityError::BadScene("no polygons".into()));
    }
    for m in &scene.materials {
        if !m.reflectance_xyz.iter().all(|r| (0.0..1.0).contains(r)) {
            return Err(RadiosityError::BadScene(format!(
                "material `{}` has reflectance {:?}; each channel must be in [0, 1)",
                m.name, m.reflectance_xyz
            )));
        }
        if !m.emission_cd_m2.iter().all(|e| e.is_finite() && *e >= 0.0) {
            return Err(RadiosityError::BadScene(format!(
                "material `{}` has emission {:?}; must be finite and ≥ 0",
                m.name, m.emission_cd_m2
            )));
        }
    }
    if !scene.has_emission() {
        return Err(RadiosityError::BadScene(
            "nothing emits light (no emissive material, no light with flux, no daylight)".into(),
        ));
    }
    Ok(())
}
