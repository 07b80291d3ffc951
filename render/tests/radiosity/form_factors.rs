//! Form factors against closed forms from Howell's catalogue (C-11, C-14, B-13, C-41).

use std::f64::consts::PI;

use lumiwall_render::radiosity::form_factor::{
    point_to_polygon, point_to_small_polygon, polygon_to_polygon,
};
use lumiwall_render::radiosity::quadrature;
use lumiwall_render::rng::SplitMix64;
use lumiwall_render::scene::V3;

/// Howell C-11: parallel, directly opposed rectangles a×b at distance c.
fn howell_parallel(a: f64, b: f64, c: f64) -> f64 {
    let x = a / c;
    let y = b / c;
    let x1 = (1.0 + x * x).sqrt();
    let y1 = (1.0 + y * y).sqrt();
    2.0 / (PI * x * y)
        * ((x1 * x1 * y1 * y1 / (1.0 + x * x + y * y)).sqrt().ln()
            + x * y1 * (x / y1).atan()
            + y * x1 * (y / x1).atan()
            - x * x.atan()
            - y * y.atan())
}

/// Howell C-14: perpendicular rectangles with a common edge of length l; receiver
/// (surface 1) has width w, the other height h. F from 1 to 2.
fn howell_perpendicular(l: f64, w: f64, h: f64) -> f64 {
    let hh = h / l;
    let ww = w / l;
    let a = 1.0 + ww * ww;
    let b = 1.0 + hh * hh;
    let c = ww * ww + hh * hh;
    let t1 = ww * (1.0 / ww).atan() + hh * (1.0 / hh).atan() - c.sqrt() * (1.0 / c.sqrt()).atan();
    let t2 = 0.25
        * ((a * b / (1.0 + c)).ln()
            + ww * ww * (ww * ww * (1.0 + c) / (a * c)).ln()
            + hh * hh * (hh * hh * (1.0 + c) / (b * c)).ln());
    (t1 + t2) / (PI * ww)
}

fn disk(center: V3, r: f64, n: usize, facing_down: bool) -> Vec<V3> {
    let mut v: Vec<V3> = (0..n)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / n as f64;
            center + V3::new(r * t.cos(), r * t.sin(), 0.0)
        })
        .collect();
    if facing_down {
        v.reverse();
    }
    v
}

#[test]
fn catalogue_sanity_values() {
    // published table values: unit squares 0.1998 (parallel, distance 1), 0.2000 (perpendicular)
    assert!((howell_parallel(1.0, 1.0, 1.0) - 0.19982).abs() < 1e-4);
    assert!((howell_perpendicular(1.0, 1.0, 1.0) - 0.20004).abs() < 1e-4);
}

/// The quadrilateral `[o, o + u, o + u + v, o + v]` (normal along u × v).
fn quad(o: V3, u: V3, v: V3) -> [V3; 4] {
    [o, o + u, o + u + v, o + v]
}

/// Polygon-to-polygon form factor of `recv` from `src`, checked against `exact` to 1e-3.
fn form_factor_matches(recv: &[V3; 4], src: &[V3; 4], exact: f64, case: &str) -> f64 {
    let f = polygon_to_polygon(recv, src, 1e-5);
    assert!(
        (f.value - exact).abs() < 1e-3,
        "{case}: {} vs {exact}",
        f.value
    );
    f.error
}

#[test]
fn parallel_rectangles_match_howell() {
    for &(a, b, c) in &[
        (1.0, 1.0, 1.0),
        (2.0, 1.0, 0.5),
        (0.3, 3.0, 1.7),
        (1.0, 1.0, 0.1),
    ] {
        // receiver at z = 0 facing up, source at z = c facing down (both a × b)
        let (along_x, along_y) = (V3::new(a, 0., 0.), V3::new(0., b, 0.));
        let recv = quad(V3::new(0., 0., 0.), along_x, along_y);
        let src = quad(V3::new(0., 0., c), along_y, along_x);
        let case = format!("a={a} b={b} c={c}");
        let error = form_factor_matches(&recv, &src, howell_parallel(a, b, c), &case);
        assert!(error < 1e-3, "{case}: error estimate {error}");
    }
}

#[test]
fn perpendicular_rectangles_match_howell() {
    for &(l, w, h) in &[
        (1.0, 1.0, 1.0),
        (1.0, 2.0, 0.5),
        (2.0, 0.5, 3.0),
        (0.2, 1.0, 1.0),
    ] {
        // common edge along x from 0 to l; receiver in z = 0 (y from 0 to w, facing +z),
        // source in y = 0 (z from 0 to h, facing +y)
        let origin = V3::new(0., 0., 0.);
        let recv = quad(origin, V3::new(l, 0., 0.), V3::new(0., w, 0.));
        let src = quad(origin, V3::new(0., 0., h), V3::new(l, 0., 0.));
        let case = format!("l={l} w={w} h={h}");
        form_factor_matches(&recv, &src, howell_perpendicular(l, w, h), &case);
    }
}

#[test]
fn differential_area_to_parallel_disk_matches_howell() {
    // Howell B-13: F = R² / (H² + R²) for a coaxial disk of radius R at height H
    for &(r, h) in &[(1.0, 1.0), (0.1, 2.0), (3.0, 0.5)] {
        let d = disk(V3::new(0., 0., h), r, 4096, true);
        let n_src = V3::new(0., 0., -1.);
        let f = point_to_polygon(&V3::zeros(), &V3::z(), &d, &n_src);
        let exact = r * r / (h * h + r * r);
        assert!(
            (f - exact).abs() < 1e-3 * exact.max(1e-3),
            "R={r} H={h}: {f} vs {exact}"
        );
    }
}

#[test]
fn coaxial_disks_match_howell() {
    // Howell C-41: parallel coaxial disks r1 (receiver) and r2 at distance h
    for &(r1, r2, h) in &[(1.0f64, 1.0f64, 1.0f64), (0.5, 1.5, 1.0)] {
        let (a1, a2) = (r1 / h, r2 / h);
        let x = 1.0 + (1.0 + a2 * a2) / (a1 * a1);
        let exact = 0.5 * (x - (x * x - 4.0 * (r2 / r1).powi(2)).sqrt());
        let recv = disk(V3::zeros(), r1, 256, false);
        let src = disk(V3::new(0., 0., h), r2, 256, true);
        let f = polygon_to_polygon(&recv, &src, 1e-5);
        assert!((f.value - exact).abs() < 1e-3, "{} vs {exact}", f.value);
    }
}

#[test]
fn source_behind_receiver_or_backfacing_gives_zero() {
    let sq = |z: f64, up: bool| {
        let mut v = vec![
            V3::new(0., 0., z),
            V3::new(1., 0., z),
            V3::new(1., 1., z),
            V3::new(0., 1., z),
        ];
        if !up {
            v.reverse();
        }
        v
    };
    // source below the receiver's plane
    assert_eq!(
        polygon_to_polygon(&sq(0.0, true), &sq(-1.0, true), 1e-5).value,
        0.0
    );
    // source above but facing away
    assert_eq!(
        polygon_to_polygon(&sq(0.0, true), &sq(1.0, true), 1e-5).value,
        0.0
    );
}

/// A unit vector from two uniform numbers.
fn direction(rng: &mut SplitMix64) -> V3 {
    let z = 2.0 * rng.unit() - 1.0;
    let phi = std::f64::consts::TAU * rng.unit();
    let s = (1.0 - z * z).sqrt();
    V3::new(s * phi.cos(), s * phi.sin(), z)
}

#[test]
fn small_far_polygons_by_gauss_points_are_within_1e_3_of_the_exact_factor() {
    let mut rng = SplitMix64(11);
    let (mut worst, mut compared) = (0.0f64, 0);
    for _ in 0..4000 {
        // a quad or triangle of radius ≤ d/10 at distance d = 1, turned at random
        let centre = direction(&mut rng);
        let normal = direction(&mut rng);
        let u = normal.cross(&direction(&mut rng)).normalize();
        let v = normal.cross(&u);
        let corners = if rng.unit() < 0.5 { 4 } else { 3 };
        let poly: Vec<V3> = (0..corners)
            .map(|k| {
                let a = std::f64::consts::TAU * (k as f64 + 0.3 * rng.unit()) / corners as f64;
                let r = 0.1 * (0.5 + 0.5 * rng.unit());
                centre + (u * a.cos() + v * a.sin()) * r
            })
            .collect();
        let pn = (poly[1] - poly[0]).cross(&(poly[2] - poly[0])).normalize();
        let area = match corners {
            4 => 0.5 * (poly[2] - poly[0]).cross(&(poly[3] - poly[1])).norm(),
            _ => 0.5 * (poly[1] - poly[0]).cross(&(poly[2] - poly[0])).norm(),
        };
        let radius = poly.iter().map(|p| (p - centre).norm()).fold(0.0, f64::max);
        assert!(radius <= 0.1 * centre.norm() + 1e-12);
        let n = direction(&mut rng);
        let mut pts = Vec::new();
        quadrature::points(&poly, 2, &mut pts);
        let Some(gauss) = point_to_small_polygon(&V3::zeros(), &n, &pts, area, &pn) else {
            continue;
        };
        let exact = point_to_polygon(&V3::zeros(), &n, &poly, &pn);
        // relative to the factor of the polygon seen head-on, so that grazing
        // polygons (factors near zero) do not blow the ratio up
        let head_on = area / (std::f64::consts::PI * centre.norm_squared());
        worst = worst.max((gauss - exact).abs() / head_on);
        compared += 1;
    }
    println!("{compared} polygons, worst difference {worst:.2e} of the head-on factor");
    assert!(compared > 500);
    assert!(worst <= 1e-3, "{worst}"); // measured 8.0e-4
}
