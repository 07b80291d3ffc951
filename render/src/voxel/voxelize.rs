//! Conservative voxelisation: every voxel a triangle touches is set.

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

use super::grid::VoxelGrid;
use crate::scene::Scene;

/// How much a voxel is grown for the overlap test (grid units): a triangle lying
/// exactly on a voxel face sets the voxels on both sides, whatever the rounding.
pub const OVERLAP_MARGIN: f64 = 1e-4;

/// The scene's polygons fanned into triangles (world metres), with the polygon each
/// came from.
pub fn scene_triangles(scene: &Scene) -> (Vec<[[f64; 3]; 3]>, Vec<u32>) {
    let mut tris = Vec::new();
    let mut owner = Vec::new();
    for (i, p) in scene.polygons.iter().enumerate() {
        let v = &p.vertices;
        for k in 1..v.len().saturating_sub(1) {
            tris.push([v[0], v[k], v[k + 1]].map(|q| [q.x, q.y, q.z]));
            owner.push(i as u32);
        }
    }
    (tris, owner)
}

/// Sets every level-0 voxel of `grid` that one of `tris` (world metres) touches and
/// rebuilds the mipmaps. Triangles are voxelised in parallel.
pub fn voxelize(grid: &mut VoxelGrid, tris: &[[[f64; 3]; 3]]) {
    let bits: Vec<AtomicU32> = grid.levels[0].iter().map(|_| AtomicU32::new(0)).collect();
    let n = grid.n;
    let g = &*grid;
    tris.par_iter().for_each(|t| {
        let t = t.map(|p| g.to_grid(&p.into()));
        for_each_touched_voxel(&t, n, |c| {
            let i = c[0] as usize + n as usize * (c[1] as usize + n as usize * c[2] as usize);
            bits[i >> 5].fetch_or(1 << (i & 31), Ordering::Relaxed);
        });
    });
    grid.levels[0] = bits.into_iter().map(AtomicU32::into_inner).collect();
    grid.build_mips();
}

/// Calls `f` for every voxel of an `n³` grid whose box (grown by
/// [`OVERLAP_MARGIN`]) the triangle `t` (grid coordinates) overlaps.
fn for_each_touched_voxel(t: &[[f64; 3]; 3], n: u32, mut f: impl FnMut([u32; 3])) {
    let Some((lo, hi)) = voxel_box(t, n) else {
        return;
    };
    for z in lo[2]..=hi[2] {
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                let c = [f64::from(x) + 0.5, f64::from(y) + 0.5, f64::from(z) + 0.5];
                if tri_box_overlap(t, c, 0.5 + OVERLAP_MARGIN) {
                    f([x, y, z]);
                }
            }
        }
    }
}

/// The voxels (inclusive corners) a triangle in grid coordinates can touch, clamped
/// to the grid; `None` for a triangle with a non-finite corner.
pub(crate) fn voxel_box(t: &[[f64; 3]; 3], n: u32) -> Option<([u32; 3], [u32; 3])> {
    if !t.iter().flatten().all(|v| v.is_finite()) {
        return None;
    }
    let lo = std::array::from_fn(|a| {
        let m = t[0][a].min(t[1][a]).min(t[2][a]) - OVERLAP_MARGIN;
        m.floor().clamp(0.0, f64::from(n - 1)) as u32
    });
    let hi = std::array::from_fn(|a| {
        let m = t[0][a].max(t[1][a]).max(t[2][a]) + OVERLAP_MARGIN;
        m.floor().clamp(0.0, f64::from(n - 1)) as u32
    });
    Some((lo, hi))
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Akenine-Möller's triangle–box overlap test by separating axes: the box (centre
/// `c`, half edge `h`) and the triangle `t` overlap unless one of 13 axes (the box's
/// 3 normals, the triangle's normal and the 9 edge cross products) separates them.
pub fn tri_box_overlap(t: &[[f64; 3]; 3], c: [f64; 3], h: f64) -> bool {
    let v = [sub(t[0], c), sub(t[1], c), sub(t[2], c)];
    let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    let separates = |axis: [f64; 3]| {
        let p = v.map(|q| dot(q, axis));
        let r = h * (axis[0].abs() + axis[1].abs() + axis[2].abs());
        let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
        lo > r || hi < -r
    };
    let unit = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if unit.iter().any(|&u| separates(u)) {
        return false;
    }
    if separates(cross(e[0], e[1])) {
        return false;
    }
    !e.iter()
        .flat_map(|&ei| unit.iter().map(move |&u| cross(u, ei)))
        .any(separates)
}
