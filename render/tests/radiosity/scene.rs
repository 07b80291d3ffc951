//! Scene files: typed errors with actionable messages, input repair, photometric units.

use std::path::Path;

use lumiwall_render::scene::{LightKind, SceneError, parse_scene_toml};

fn parse(text: &str) -> Result<lumiwall_render::scene::Scene, SceneError> {
    parse_scene_toml(text, Path::new("."), Path::new("test.toml")).map(|(s, _)| s)
}

const SQUARE: &str = r#"
[[polygons]]
material = "grey"
vertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
"#;

#[test]
fn materials_lights_and_units() {
    let text = format!(
        r#"
unit_m = 0.5
[materials.grey]
reflectance_y = 0.5
emission_cd_m2 = 100.0
emission_xy = [0.3127, 0.3290]
[[lights]]
type = "point"
position = [0, 0, 4]
flux_lm = 1000.0
[[lights]]
type = "spot"
position = [0, 0, 2]
axis = [0, 0, -2]
inner_deg = 30
outer_deg = 30
flux_lm = 500.0
{SQUARE}"#
    );
    let s = parse(&text).unwrap();
    // coordinates scaled by unit_m
    assert_eq!(s.polygons[0].vertices[2].x, 0.5);
    assert_eq!(s.lights[0].position.z, 2.0);
    // D65 chromaticity → X/Y = x/y
    let e = s.materials[0].emission_cd_m2;
    assert!((e[1] - 100.0).abs() < 1e-12 && (e[0] / e[1] - 0.3127 / 0.3290).abs() < 1e-12);
    // isotropic: I = Φ / 4π
    match s.lights[0].kind {
        LightKind::Isotropic { intensity_cd } => {
            assert!((intensity_cd - 1000.0 / (4.0 * std::f64::consts::PI)).abs() < 1e-9)
        }
        _ => panic!("expected isotropic"),
    }
    // uniform cone: Φ = 2π (1 − cos θ) I
    let spot = &s.lights[1];
    let cone = std::f64::consts::TAU * (1.0 - 30f64.to_radians().cos());
    assert!((spot.total_flux_lm() - 500.0).abs() < 1e-6);
    assert!(
        (spot.intensity_cd(&lumiwall_render::scene::V3::new(0., 0., -1.)) - 500.0 / cone).abs()
            < 1e-6
    );
    // area emitter flux: π L A (A = 0.25 m²) + lights
    let phi = s.emitted_flux_xyz_lm()[1];
    assert!((phi - (std::f64::consts::PI * 100.0 * 0.25 + 1500.0)).abs() < 1e-6);
}

#[test]
fn bad_inputs_are_typed_errors_that_name_the_item() {
    let e = parse("this is = not toml [").unwrap_err();
    assert!(matches!(e, SceneError::Toml { .. }));
    let e = parse(&format!("[materials.grey]\nreflectance_y = 1.0\n{SQUARE}")).unwrap_err();
    assert!(
        e.to_string().contains("grey") && e.to_string().contains("[0, 1)"),
        "{e}"
    );
    let e = parse("[materials.grey]\nreflectance_y = 0.5\n[[polygons]]\nmaterial = \"gold\"\nvertices = [[0,0,0],[1,0,0],[0,1,0]]\n").unwrap_err();
    assert!(matches!(e, SceneError::UnknownMaterial { ref material, .. } if material == "gold"));
    let e = parse(&format!("[materials.grey]\nreflectance_y = 0.5\n[[lights]]\ntype = \"laser\"\nposition = [0,0,1]\nintensity_cd = 1\n{SQUARE}")).unwrap_err();
    assert!(e.to_string().contains("laser"));
    let e = parse(&format!("[materials.grey]\nreflectance_y = 0.5\n[[lights]]\ntype = \"point\"\nposition = [0,0,1]\n{SQUARE}")).unwrap_err();
    assert!(e.to_string().contains("intensity_cd or flux_lm"));
    let e = parse("[materials.grey]\nreflectance_y = 0.5\n").unwrap_err();
    assert!(matches!(e, SceneError::Empty(_)));
    let e = parse_scene_toml(
        "geometry = \"missing.obj\"\n",
        Path::new("/nonexistent"),
        Path::new("x.toml"),
    )
    .unwrap_err();
    assert!(matches!(e, SceneError::Obj { .. }));
}

#[test]
fn degenerate_and_non_planar_input_is_repaired_and_reported() {
    let text = r#"
[materials.grey]
reflectance_y = 0.5
[[polygons]]
material = "grey"
vertices = [[0, 0, 0], [1, 0, 0], [2, 0, 0]]
[[polygons]]
material = "grey"
vertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0.3], [0, 1, 0]]
[[polygons]]
material = "grey"
vertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0.5, 1.5, 0], [0, 1, 0]]
[[polygons]]
material = "grey"
vertices = [[0, 0, 0], [1, 0, 0], [1, 0, 0], [0, 1, 0]]
"#;
    let (s, report) = parse_scene_toml(text, Path::new("."), Path::new("t.toml")).unwrap();
    assert_eq!(report.dropped_degenerate, 1);
    assert_eq!(report.split_quads, 1);
    assert_eq!(report.triangulated_ngons, 1);
    // 2 from the split quad, 3 from the pentagon, 1 triangle after removing the duplicate
    assert_eq!(s.polygons.len(), 6);
    assert!(s.polygons.iter().all(|p| p.vertices.len() == 3));
}

/// Kresse 2.2.6: a T-vertex (two small quads beside one large one) is fixed by
/// splitting, a face wound against its neighbours is flipped, a deliberate back face
/// (same corners, opposite winding) is kept, an edge shared by three faces is
/// reported; all counted in the report, the repaired area unchanged.
#[test]
fn topology_is_repaired_or_reported_per_object() {
    let text = r#"
[materials.grey]
reflectance_y = 0.5
# object "floor": a 2 × 1 quad below two 1 × 1 quads → T-vertex at (1, 1, 0); a
# fourth quad on the right wound the other way
[[polygons]]
name = "floor"
material = "grey"
vertices = [[0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]]
[[polygons]]
name = "floor"
material = "grey"
vertices = [[0, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0]]
[[polygons]]
name = "floor"
material = "grey"
vertices = [[1, 1, 0], [2, 1, 0], [2, 2, 0], [1, 2, 0]]
[[polygons]]
name = "floor"
material = "grey"
vertices = [[2, 0, 0], [2, 1, 0], [3, 1, 0], [3, 0, 0]]
# object "sheet": front and back of a panel (both kept)
[[polygons]]
name = "sheet"
material = "grey"
vertices = [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]
[[polygons]]
name = "sheet"
material = "grey"
vertices = [[0, 1, 1], [1, 1, 1], [1, 0, 1], [0, 0, 1]]
# object "fin": three faces on one edge (non-manifold, reported)
[[polygons]]
name = "fin"
material = "grey"
vertices = [[5, 0, 0], [6, 0, 0], [5, 0, 1]]
[[polygons]]
name = "fin"
material = "grey"
vertices = [[6, 0, 0], [5, 0, 0], [5, 1, 0]]
[[polygons]]
name = "fin"
material = "grey"
vertices = [[5, 0, 0], [6, 0, 0], [5, -1, 0.2]]
"#;
    let (s, report) = parse_scene_toml(text, Path::new("."), Path::new("t.toml")).unwrap();
    println!("{}", report.summary());
    assert!(report.t_vertices_fixed >= 1, "{}", report.summary());
    assert_eq!(report.triangles_flipped, 2, "{}", report.summary());
    assert_eq!(report.duplicate_faces_removed, 0);
    assert!(report.non_manifold_edges >= 1);
    let area = |name: &str| -> f64 {
        s.polygons
            .iter()
            .filter(|p| p.object == name)
            .map(|p| lumiwall_render::scene::polygon_area_m2(&p.vertices))
            .sum()
    };
    assert!(
        (area("floor") - 5.0).abs() < 1e-9,
        "floor area {}",
        area("floor")
    );
    // all floor faces now face +z
    for p in s.polygons.iter().filter(|p| p.object == "floor") {
        let n = (p.vertices[1] - p.vertices[0]).cross(&(p.vertices[2] - p.vertices[0]));
        assert!(n.z > 0.0, "floor face {:?} faces down", p.vertices);
    }
    // both sides of the sheet survive
    let sheet: Vec<_> = s.polygons.iter().filter(|p| p.object == "sheet").collect();
    assert_eq!(sheet.len(), 2);
    assert!((area("sheet") - 2.0).abs() < 1e-9);
}
