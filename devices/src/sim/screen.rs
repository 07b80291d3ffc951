//! The projection screen: view-dependent gain of a rear-projection screen.

use super::wall_file::{MeterPlacement, ScreenSpec};

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn angle_between(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let na = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let nb = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    if na <= 0.0 || nb <= 0.0 {
        return 0.0;
    }
    (dot / (na * nb)).clamp(-1.0, 1.0).acos()
}

/// Where the meter is when it reads `spot_m`.
pub fn meter_position_m(placement: &MeterPlacement, spot_m: [f64; 3]) -> [f64; 3] {
    placement
        .position_m
        .unwrap_or([spot_m[0], spot_m[1], placement.distance_m.max(1e-3)])
}

/// Screen gain toward the meter for light from `lens_m` passing the screen at `spot_m`:
/// `diffuse + specular · exp(−θ²/(2σ²))`, θ the angle between the continued projector
/// ray and the direction to the meter. A Lambertian screen (specular = 0) returns
/// `diffuse` for every geometry.
pub fn gain(screen: &ScreenSpec, lens_m: [f64; 3], spot_m: [f64; 3], meter_m: [f64; 3]) -> f64 {
    if screen.specular_gain == 0.0 {
        return screen.diffuse_gain;
    }
    let theta = angle_between(sub(spot_m, lens_m), sub(meter_m, spot_m));
    let sigma = screen.specular_width_deg.to_radians().max(1e-6);
    screen.diffuse_gain + screen.specular_gain * (-(theta * theta) / (2.0 * sigma * sigma)).exp()
}
