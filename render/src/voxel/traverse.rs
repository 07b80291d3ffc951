//! Ray traversal of the voxel hierarchy, in f32 and in the same steps as the WGSL
//! shader (`voxel.wgsl`, `trace`), so that the CPU is the GPU's reference.
//!
//! The ray walks the cells of the current level in order. An empty cell is skipped
//! whole: the ray moves to where it leaves the cell and goes one level up. An occupied
//! cell is descended into; an occupied cell of level 0 is the hit. The cell entered
//! after an exit is found from the exit face (the integer coordinate on the exit axis,
//! the others clamped to the cell just left), not from the rounded exit point, so that
//! no cell is skipped or visited twice by rounding.

use super::grid::VoxelGrid;

/// Where a ray first enters a set voxel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelHit {
    /// Ray parameter of the entry into the voxel.
    pub t: f32,
    /// The voxel (level 0).
    pub voxel: [u32; 3],
    /// Traversal steps taken.
    pub steps: u32,
}

/// Most steps of one traversal before it gives up (reported as a miss): far more
/// than any ray needs (about `2·levels` per level-0 cell crossed).
pub fn step_cap(n: u32) -> u32 {
    16 * n + 64
}

/// First set voxel along `o + t·d` for `t` in `[t_min, t_max]`, in grid coordinates
/// (level-0 voxels; see [`VoxelGrid::to_grid`]), through the hierarchy; `None` also
/// for `t_min < 0`, `t_min > t_max` or non-finite input.
pub fn trace(
    grid: &VoxelGrid,
    o: [f32; 3],
    d: [f32; 3],
    t_min: f32,
    t_max: f32,
) -> Option<VoxelHit> {
    walk(grid, o, d, t_min, t_max, grid.level_count() - 1)
}

/// As [`trace`] but level 0 only (a plain voxel walk): what the hierarchy must find.
pub fn trace_flat(
    grid: &VoxelGrid,
    o: [f32; 3],
    d: [f32; 3],
    t_min: f32,
    t_max: f32,
) -> Option<VoxelHit> {
    walk(grid, o, d, t_min, t_max, 0)
}

/// The segment of the ray inside the grid box `[0, n]³` within `[t_min, t_max]`.
fn clip(
    n: f32,
    o: [f32; 3],
    d: [f32; 3],
    inv: [f32; 3],
    t_min: f32,
    t_max: f32,
) -> Option<(f32, f32)> {
    let mut t0 = t_min;
    let mut t1 = t_max;
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < 0.0 || o[a] > n {
                return None;
            }
            continue;
        }
        let ta = (0.0 - o[a]) * inv[a];
        let tb = (n - o[a]) * inv[a];
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    (t0 <= t1).then_some((t0, t1))
}

fn walk(
    grid: &VoxelGrid,
    o: [f32; 3],
    d: [f32; 3],
    t_min: f32,
    t_max: f32,
    top: usize,
) -> Option<VoxelHit> {
    // t ≥ 0 only (the GPU marks a miss by a negative t), finite rays only
    if !(t_min >= 0.0 && t_min <= t_max && o.iter().chain(&d).all(|v| v.is_finite())) {
        return None;
    }
    let n = grid.n as i32;
    let inv = d.map(|v| if v == 0.0 { 0.0 } else { 1.0 / v });
    let (mut t, t_end) = clip(n as f32, o, d, inv, t_min, t_max)?;
    let mut pi: [i32; 3] =
        std::array::from_fn(|a| ((o[a] + d[a] * t).floor() as i32).clamp(0, n - 1));
    let mut level = top;
    let cap = step_cap(grid.n);
    for steps in 1..=cap {
        let cell = pi.map(|v| (v >> level) as u32);
        if grid.occupied(level, cell) {
            if level == 0 {
                return Some(VoxelHit {
                    t,
                    voxel: cell,
                    steps,
                });
            }
            level -= 1;
            continue;
        }
        let size = 1i32 << level;
        let (axis, bound, t_exit) = exit_face(o, d, inv, cell, size);
        if t_exit > t_end {
            return None;
        }
        t = t.max(t_exit);
        for b in 0..3 {
            let lo = cell[b] as i32 * size;
            pi[b] = ((o[b] + d[b] * t).floor() as i32).clamp(lo, lo + size - 1);
        }
        pi[axis] = if d[axis] > 0.0 { bound } else { bound - 1 };
        if pi[axis] < 0 || pi[axis] >= n {
            return None;
        }
        // one level up when the ray left its parent cell too (a parent it stays in
        // is occupied: the ray came down through it)
        if level < top && pi[axis] >> (level + 1) != cell[axis] as i32 >> 1 {
            level += 1;
        }
    }
    None
}

/// The face through which the ray leaves `cell` (cells of `size` voxels): its axis,
/// its coordinate in voxels and the ray parameter there.
fn exit_face(
    o: [f32; 3],
    d: [f32; 3],
    inv: [f32; 3],
    cell: [u32; 3],
    size: i32,
) -> (usize, i32, f32) {
    let mut best = (0, 0, f32::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            continue;
        }
        let c = cell[a] as i32;
        let bound = if d[a] > 0.0 { (c + 1) * size } else { c * size };
        let ta = (bound as f32 - o[a]) * inv[a];
        if ta < best.2 {
            best = (a, bound, ta);
        }
    }
    best
}
