//! Receiver bases (Kresse 2.5.3): a plane (ρ = 0.5, nothing else to reflect from)
//! under a point light has the exact exitance B(x) = ρ·I·cos θ / r². Each basis is
//! judged by the function it represents (mean per patch, or the vertex values
//! interpolated as Gouraud shading shows them) against that law, sampled densely; the
//! linear basis reaches the same error with fewer patches, and the automatic choice
//! uses it only where a constant does not meet the bound.

use std::time::Duration;

use crate::support::plane_under;
use lumiwall_render::radiosity::hierarchical::Basis;
use lumiwall_render::radiosity::{
    HierarchicalOptions, NoOccluders, Solution, StopRule, solve_hierarchical,
};
use lumiwall_render::scene::{Light, LightKind, Scene, V3};

const RHO: f64 = 0.5;
const I_CD: f64 = 300.0;

fn scene() -> Scene {
    plane_under(
        Light {
            name: "bulb".into(),
            position: V3::new(0.4, -0.3, 1.2),
            color_xyz: [1.0; 3],
            kind: LightKind::Isotropic { intensity_cd: I_CD },
        },
        RHO,
    )
}

fn exact(x: &V3) -> f64 {
    let d = V3::new(0.4, -0.3, 1.2) - x;
    RHO * I_CD * d.z / d.norm().powi(3)
}

/// Relative L1 error of the represented exitance over the plane (a 200 × 200 grid).
fn represented_error(sol: &Solution) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    let n = 200;
    for i in 0..n {
        for j in 0..n {
            let x = V3::new(
                -2.0 + 4.0 * (i as f64 + 0.5) / n as f64,
                -2.0 + 4.0 * (j as f64 + 0.5) / n as f64,
                0.0,
            );
            let b = sol.patch_at(0, &x).unwrap().exitance_at(&x)[1];
            let e = exact(&x);
            num += (b - e).abs();
            den += e;
        }
    }
    num / den
}

fn solve(basis: Basis, target: f64) -> Solution {
    solve_hierarchical(
        &scene(),
        &NoOccluders,
        &HierarchicalOptions {
            stop: StopRule {
                target_error: target,
                time_limit: Some(Duration::from_secs(60)),
                max_iterations: 1000,
            },
            min_area_m2: 1e-5,
            basis,
            ..HierarchicalOptions::default()
        },
    )
    .unwrap()
}

#[test]
fn bases_meet_the_bound_and_linear_needs_fewer_patches() {
    let target = 0.01;
    let mut patches = Vec::new();
    for basis in [Basis::Constant, Basis::Linear, Basis::Auto] {
        let sol = solve(basis, target);
        let est = sol.curve.last().unwrap().estimated_error;
        let err = represented_error(&sol);
        println!(
            "{basis:?}: {} patches ({} linear), estimated {:.3} %, represented error {:.3} %, {:.3} s",
            sol.stats.patches,
            sol.stats.linear_patches,
            100.0 * est,
            100.0 * err,
            sol.stats.time_s
        );
        assert!(est <= target, "{basis:?} did not converge: {est}");
        // the estimate is of the right size for the represented function
        assert!(
            (err - est).abs() < 0.25 * est,
            "{basis:?}: represented error {err}, estimated {est}"
        );
        match basis {
            Basis::Constant => assert_eq!(sol.stats.linear_patches, 0),
            Basis::Linear => assert_eq!(sol.stats.linear_patches, sol.stats.patches),
            Basis::Auto => assert!(sol.stats.linear_patches < sol.stats.patches),
        }
        // linear patches carry vertex values that follow the point law
        for p in sol
            .patches
            .iter()
            .filter(|p| !p.vertex_exitance_xyz.is_empty())
            .take(50)
        {
            for (v, b) in p.vertices.iter().zip(&p.vertex_exitance_xyz) {
                let e = exact(v);
                assert!(
                    (b[1] - e).abs() < 0.05 * e + 1e-9,
                    "vertex {v:?}: {} vs {e}",
                    b[1]
                );
            }
        }
        patches.push(sol.stats.patches);
    }
    assert!(
        patches[1] < patches[0],
        "linear {} vs constant {}",
        patches[1],
        patches[0]
    );
    assert!(
        patches[2] <= patches[0],
        "auto {} vs constant {}",
        patches[2],
        patches[0]
    );
}
