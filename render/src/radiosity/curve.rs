//! The error-against-time record every solver returns, and the stop rule.

use std::time::Duration;

/// One report of a running solve.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CurvePoint {
    /// Wall time since the solve started in seconds.
    pub time_s: f64,
    /// Iterations (gather sweeps or shots) so far.
    pub iteration: usize,
    /// Estimated relative error of the solution (solve + discretisation), area-weighted
    /// over Y (luminous exitance).
    pub estimated_error: f64,
    /// Estimated relative error of the linear solve alone (residual-based).
    pub solve_error: f64,
    /// Estimated relative discretisation error (link bounds / unshot energy).
    pub discretization_error: f64,
    /// Leaf elements (patches) at this point.
    pub patches: usize,
    /// Links (hierarchical) or form factors evaluated (progressive).
    pub links: usize,
}

/// The error/time curve of one solve.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ErrorCurve {
    /// Reports in time order.
    pub points: Vec<CurvePoint>,
}

impl ErrorCurve {
    /// The last report, if any.
    pub fn last(&self) -> Option<&CurvePoint> {
        self.points.last()
    }

    /// CSV text with a header line.
    pub fn to_csv(&self) -> String {
        let mut s = String::from(
            "time_s,iteration,estimated_error,solve_error,discretization_error,patches,links\n",
        );
        for p in &self.points {
            s.push_str(&format!(
                "{:.6},{},{:.6e},{:.6e},{:.6e},{},{}\n",
                p.time_s,
                p.iteration,
                p.estimated_error,
                p.solve_error,
                p.discretization_error,
                p.patches,
                p.links
            ));
        }
        s
    }
}

/// When a solve stops and how often it reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopRule {
    /// Requested relative error (e.g. 0.01 for 1 %).
    pub target_error: f64,
    /// Wall-time limit.
    pub time_limit: Option<Duration>,
    /// Hard cap on iterations (gather sweeps or shots).
    pub max_iterations: usize,
}

impl Default for StopRule {
    fn default() -> Self {
        Self {
            target_error: 0.01,
            time_limit: None,
            max_iterations: 100_000,
        }
    }
}

/// Why a solve stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum StopReason {
    /// The estimated error reached the target.
    Converged,
    /// The time limit was reached first.
    TimeLimit,
    /// The iteration cap was reached first.
    IterationLimit,
    /// The mesh cannot be refined further (minimum element size) and the solve has
    /// converged on it; the estimate stays above the target.
    RefinementExhausted,
}

/// Smallest interval between two curve points of a shooting solver, in seconds.
const REPORT_INTERVAL_S: f64 = 0.05;
/// The first shots are all reported, so that short solves still draw a curve.
const ALWAYS_REPORTED_SHOTS: usize = 10;

/// The error curve of a shooting solver (progressive, sequence), thinned: every one
/// of the first shots, then at most one point per [`REPORT_INTERVAL_S`], and the
/// last.
#[derive(Debug, Clone)]
pub(crate) struct ShotCurve {
    /// The points so far.
    pub(crate) curve: ErrorCurve,
    last_report_s: f64,
}

impl Default for ShotCurve {
    fn default() -> Self {
        Self {
            curve: ErrorCurve::default(),
            last_report_s: f64::NEG_INFINITY,
        }
    }
}

impl ShotCurve {
    /// Adds a point for the state after `shots` shots at `now_s` when it is due (or
    /// `last`): `error` estimated (all of it solve error), `patches` elements and
    /// `links` form factors evaluated.
    pub(crate) fn report(
        &mut self,
        now_s: f64,
        shots: usize,
        error: f64,
        (patches, links): (usize, usize),
        last: bool,
    ) {
        if last || now_s - self.last_report_s > REPORT_INTERVAL_S || shots < ALWAYS_REPORTED_SHOTS {
            self.last_report_s = now_s;
            self.curve.points.push(CurvePoint {
                time_s: now_s,
                iteration: shots,
                estimated_error: error,
                solve_error: error,
                discretization_error: 0.0,
                patches,
                links,
            });
        }
    }
}

/// What a shooting solver does after a step: whether to stop and why, and whether
/// the curve takes this step as its last point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ShotVerdict {
    /// The curve's last point (target met, time out or shots capped).
    pub(crate) last: bool,
    /// Why the solve stops here, if it does.
    pub(crate) stop: Option<StopReason>,
}

impl StopRule {
    /// The verdict after `shots` shots with `error` estimated: converged at the target
    /// or with `nothing_left` to shoot, else at the time limit (`past_deadline`), else
    /// at the shot cap.
    pub(crate) fn after_shots(
        &self,
        error: f64,
        nothing_left: bool,
        shots: usize,
        past_deadline: bool,
    ) -> ShotVerdict {
        let done = error <= self.target_error;
        let capped = shots >= self.max_iterations;
        let stop = if done || nothing_left {
            Some(StopReason::Converged)
        } else if past_deadline {
            Some(StopReason::TimeLimit)
        } else if capped {
            Some(StopReason::IterationLimit)
        } else {
            None
        };
        ShotVerdict {
            last: done || past_deadline || capped,
            stop,
        }
    }
}
