use super::*;
use lumiwall_profiles::Eye;

fn geometry() -> WallGeometry {
    WallGeometry {
        cols: 2,
        rows: 1,
        tile_width_m: 1.0,
        tile_height_m: 0.75,
    }
}

fn camera() -> Camera {
    Camera {
        position: V3::new(0.0, 1.0, 5.0),
        look_at: V3::new(0.0, 1.0, 0.0),
        up: V3::new(0.0, 1.0, 0.0),
        vfov_deg: 40.0,
        width_px: 64,
        height_px: 48,
    }
}

/// A quad behind the wall, facing the viewer, with luminance varying along x and y.
fn gradient_quad(z: f64) -> LitMesh {
    let p = [
        V3::new(-3.0, -2.0, z),
        V3::new(3.0, -2.0, z),
        V3::new(3.0, 4.0, z),
        V3::new(-3.0, 4.0, z),
    ];
    let lum = |v: &V3| {
        let y = 10.0 + 2.0 * v.x + 3.0 * v.y;
        [0.95 * y, y, 1.09 * y]
    };
    LitMesh {
        luminance_xyz: p.iter().map(lum).collect(),
        positions: p.to_vec(),
        faces: vec![vec![0, 1, 2, 3]],
    }
}

#[test]
fn the_wall_centre_lies_on_the_cameras_axis_at_the_viewers_distance() {
    let g = geometry();
    let viewer = g.centred_viewer(2.0);
    let place = WallPlacement::from_camera(&camera(), viewer).unwrap();
    let centre = place.to_scene(V3::new(1.0, 0.375, 0.0));
    assert!((centre - V3::new(0.0, 1.0, 3.0)).norm() < 1e-12, "{centre}");
    assert!((place.to_scene(viewer) - camera().position).norm() < 1e-12);
}

#[test]
fn a_point_on_the_seam_projects_to_the_right_edge_of_one_tile_and_the_left_edge_of_the_next() {
    let g = geometry();
    let viewer = g.centred_viewer(2.0) + V3::new(0.3, -0.1, 0.4);
    let place = WallPlacement::from_camera(&camera(), viewer).unwrap();
    let eye = viewer + V3::new(eye_offset_m(Eye::Left, DEFAULT_EYE_SEPARATION_M), 0.0, 0.0);
    let left = place.tile_view(&g, 0, 0, eye, (640, 480));
    let right = place.tile_view(&g, 1, 0, eye, (640, 480));
    // A scene point behind the seam's middle, seen through it from the eye.
    let seam = place.to_scene(V3::new(1.0, 0.3, 0.0));
    let behind = left.eye + (seam - left.eye) * 1.7;
    let (a, b) = (
        left.project(&behind).unwrap(),
        right.project(&behind).unwrap(),
    );
    assert!(
        (a.0 - 640.0).abs() < 1e-9 && b.0.abs() < 1e-9,
        "{a:?} {b:?}"
    );
    assert!((a.1 - b.1).abs() < 1e-9 && (a.1 - 480.0 * (1.0 - 0.3 / 0.75)).abs() < 1e-9);
    assert!((a.2 - b.2).abs() < 1e-12);
}

/// The two tiles of a wall show one continuous picture: a luminance gradient behind
/// the wall is continued across the seam pixel for pixel (the last column of the left
/// tile and the first of the right tile differ by one pixel's step of the gradient,
/// as neighbouring columns inside a tile do).
#[test]
fn a_gradient_continues_across_the_seam_as_it_does_between_neighbouring_columns() {
    let g = geometry();
    let viewer = g.centred_viewer(2.5);
    let place = WallPlacement::from_camera(&camera(), viewer).unwrap();
    let mesh = gradient_quad(-1.0);
    let size = (200, 150);
    let left = render_tile(&mesh, &place.tile_view(&g, 0, 0, viewer, size));
    let right = render_tile(&mesh, &place.tile_view(&g, 1, 0, viewer, size));
    let y = |img: &[[f32; 3]], x: usize, row: usize| f64::from(img[row * size.0 + x][1]);
    for row in [10, 75, 140] {
        let inside = y(&left, size.0 - 1, row) - y(&left, size.0 - 2, row);
        let across = y(&right, 0, row) - y(&left, size.0 - 1, row);
        assert!(inside > 0.0, "row {row}: {inside}");
        assert!(
            (across - inside).abs() < 1e-3 * inside.abs(),
            "row {row}: step across the seam {across} vs inside {inside}"
        );
    }
}

#[test]
fn a_face_turned_away_from_the_eye_is_not_drawn() {
    let g = geometry();
    let viewer = g.centred_viewer(2.5);
    let place = WallPlacement::from_camera(&camera(), viewer).unwrap();
    let mut mesh = gradient_quad(-1.0);
    mesh.faces[0].reverse();
    let img = render_tile(&mesh, &place.tile_view(&g, 0, 0, viewer, (40, 30)));
    assert!(img.iter().all(|p| *p == [0.0; 3]));
}

/// The vertex properties `write_ply` writes.
const PROPS: &str = "property float x\nproperty float y\nproperty float z\nproperty float lum_X\nproperty float lum_Y\nproperty float lum_Z\n";

#[test]
fn a_ply_in_the_format_render_writes_reads_back_as_the_same_mesh_and_a_bad_one_is_a_typed_error() {
    let mesh = gradient_quad(-1.0);
    let text = format!(
        "ply\nformat ascii 1.0\nelement vertex 4\n{PROPS}element face 1\nproperty list uchar int vertex_indices\nend_header\n{}\n4 0 1 2 3\n",
        mesh.positions
            .iter()
            .zip(&mesh.luminance_xyz)
            .map(|(p, l)| format!("{} {} {} {} {} {}", p.x, p.y, p.z, l[0], l[1], l[2]))
            .collect::<Vec<_>>()
            .join("\n")
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.ply");
    let header = |v: usize, f: usize| {
        format!("ply\nformat ascii 1.0\nelement vertex {v}\n{PROPS}element face {f}\nend_header\n")
    };
    std::fs::write(&path, text).unwrap();
    assert_eq!(LitMesh::read_ply(&path).unwrap(), mesh);
    let three = "0 0 0 1 1 1\n1 0 0 1 1 1\n0 1 0 1 1 1\n";
    for bad in [
        "ply\nformat binary_little_endian 1.0\nend_header\n".to_string(),
        header(99_999_999_999, 1),
        header(3, 0),
        format!("{}{three}3 0 1 7\n", header(3, 1)),
        format!("{}0 0 0 1 1 1\n1 0 0 1 1 nan\n", header(3, 1)),
        // normals where luminance belongs
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face 1\nend_header\n".to_string(),
    ] {
        std::fs::write(&path, bad).unwrap();
        let err = LitMesh::read_ply(&path).unwrap_err();
        assert!(matches!(err, MeshError::Format { .. }), "{err}");
    }
}

/// The wgpu rasteriser gives the CPU reference's picture: over a gradient quad with a
/// second quad half in front of it (depth test) seen off-axis from a moved head,
/// every pixel both cover agrees to 1e-4 relative, and the two differ in coverage only
/// along triangle edges (where the two rasterisation rules may pick different pixels);
/// faces seen from behind are culled.
#[cfg(feature = "gpu")]
#[test]
fn the_gpu_rasteriser_draws_what_the_cpu_reference_draws() {
    let g = geometry();
    let viewer = g.centred_viewer(2.5) + V3::new(-0.4, 0.2, 0.3);
    let place = WallPlacement::from_camera(&camera(), viewer).unwrap();
    let mut mesh = gradient_quad(-1.5);
    let front = gradient_quad(-0.5);
    let n = mesh.positions.len() as u32;
    mesh.positions.extend(
        front
            .positions
            .iter()
            .map(|p| V3::new(p.x * 0.3 + 0.5, p.y * 0.3, p.z)),
    );
    mesh.luminance_xyz
        .extend(front.luminance_xyz.iter().map(|l| l.map(|v| v * 2.0)));
    mesh.faces.push(vec![n, n + 1, n + 2, n + 3]);
    let raster = match gpu::GpuRaster::new(&mesh) {
        Ok(r) => r,
        Err(crate::post::PostError::NoAdapter) => {
            eprintln!("no GPU adapter: the GPU rasteriser is not compared");
            return;
        }
        Err(e) => panic!("{e}"),
    };
    let size = (160, 120);
    for col in 0..2 {
        let view = place.tile_view(&g, col, 0, viewer, size);
        let cpu = render_tile(&mesh, &view);
        let gpu = raster.render(&view).unwrap();
        let (mut both, mut coverage, mut worst) = (0, 0, 0.0f64);
        for (c, q) in cpu.iter().zip(&gpu) {
            match (c[1] > 0.0, q[1] > 0.0) {
                (true, true) => {
                    both += 1;
                    let rel = (f64::from(c[1]) / f64::from(q[1]) - 1.0).abs();
                    worst = worst.max(rel);
                }
                (false, false) => {}
                _ => coverage += 1,
            }
        }
        println!(
            "tile {col}: {both} pixels, worst relative difference {worst:.2e}, coverage differs at {coverage}"
        );
        assert!(both > size.0 * size.1 / 2, "tile {col}: {both}");
        assert!(worst < 1e-4, "tile {col}: {worst}");
        assert!(coverage <= 2 * (size.0 + size.1), "tile {col}: {coverage}");
    }
    // Seen from behind, nothing: the GPU culls as the CPU does.
    for f in &mut mesh.faces {
        f.reverse();
    }
    let back = gpu::GpuRaster::new(&mesh).unwrap();
    let img = back
        .render(&place.tile_view(&g, 0, 0, viewer, size))
        .unwrap();
    assert!(img.iter().all(|p| *p == [0.0; 3]));
}
