//! The binary voxel grid and its OR-mip hierarchy.

use crate::scene::V3;

/// Smallest grid resolution (voxels along the longest axis of the scene).
pub const MIN_RESOLUTION: u32 = 8;
/// Largest grid resolution: 1024³ bits are 128 MiB at level 0.
pub const MAX_RESOLUTION: u32 = 1024;

/// Why a grid could not be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GridError {
    /// The resolution is not a power of two in range.
    #[error(
        "voxel resolution {0} is not a power of two between {MIN_RESOLUTION} and \
         {MAX_RESOLUTION}; use e.g. 64, 128, 256 or 512"
    )]
    Resolution(u32),
    /// The scene has no extent to voxelise.
    #[error("the scene has no geometry with a finite, non-zero extent to voxelise")]
    Empty,
}

/// A cubic grid of `n³` binary voxels over a scene and its OR-mipmaps.
///
/// Level `k` has `n >> k` cells per axis; cell `(x, y, z)` of a level is bit
/// `x + m·(y + m·z)` (m cells per axis) of that level's words, bit `i & 31` of word
/// `i >> 5`. A cell of level `k + 1` is set when any of its eight children is. Grid
/// coordinates are `(p − origin) / voxel_m`: voxel `(i, j, k)` of level 0 covers
/// `[i, i+1) × [j, j+1) × [k, k+1)`.
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelGrid {
    /// World position of the grid's corner (m).
    pub origin: [f64; 3],
    /// Edge of a level-0 voxel (m).
    pub voxel_m: f64,
    /// Voxels per axis at level 0 (a power of two).
    pub n: u32,
    /// Bits of each level, level 0 first, down to a single cell.
    pub levels: Vec<Vec<u32>>,
}

impl VoxelGrid {
    /// An empty grid of resolution `n` over the box `[min, max]`: cubic voxels, the
    /// longest axis spanning `n − 1` voxels and centred, so that the box's faces on
    /// that axis lie half a voxel inside the grid.
    pub fn empty(min: V3, max: V3, n: u32) -> Result<Self, GridError> {
        if !(MIN_RESOLUTION..=MAX_RESOLUTION).contains(&n) || !n.is_power_of_two() {
            return Err(GridError::Resolution(n));
        }
        let extent = (max - min).max();
        if !(extent.is_finite() && extent > 0.0) {
            return Err(GridError::Empty);
        }
        let voxel_m = extent / f64::from(n - 1);
        let centre = (min + max) * 0.5;
        let half = 0.5 * f64::from(n) * voxel_m;
        let levels = (0..=n.trailing_zeros())
            .map(|k| vec![0u32; words(n >> k)])
            .collect();
        Ok(Self {
            origin: [centre.x - half, centre.y - half, centre.z - half],
            voxel_m,
            n,
            levels,
        })
    }

    /// Number of levels (level 0 up to the single top cell).
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Cells per axis of level `k`.
    pub fn cells(&self, k: usize) -> u32 {
        self.n >> k
    }

    /// True when cell `c` of level `k` is set (`c` must be inside the level).
    pub fn occupied(&self, k: usize, c: [u32; 3]) -> bool {
        let m = self.cells(k) as usize;
        let i = c[0] as usize + m * (c[1] as usize + m * c[2] as usize);
        self.levels[k][i >> 5] >> (i & 31) & 1 == 1
    }

    /// Sets voxel `c` of level 0 (the mipmaps are rebuilt by [`VoxelGrid::build_mips`]).
    pub fn set(&mut self, c: [u32; 3]) {
        let m = self.n as usize;
        let i = c[0] as usize + m * (c[1] as usize + m * c[2] as usize);
        self.levels[0][i >> 5] |= 1 << (i & 31);
    }

    /// Rebuilds every level above 0 by OR-ing 2×2×2 children.
    pub fn build_mips(&mut self) {
        for k in 1..self.levels.len() {
            let m = self.cells(k);
            let mut next = vec![0u32; words(m)];
            for z in 0..m {
                for y in 0..m {
                    for x in 0..m {
                        if self.any_child(k - 1, [x, y, z]) {
                            let i = (x + m * (y + m * z)) as usize;
                            next[i >> 5] |= 1 << (i & 31);
                        }
                    }
                }
            }
            self.levels[k] = next;
        }
    }

    fn any_child(&self, k: usize, parent: [u32; 3]) -> bool {
        (0..8u32).any(|c| {
            let child = [
                2 * parent[0] + (c & 1),
                2 * parent[1] + (c >> 1 & 1),
                2 * parent[2] + (c >> 2),
            ];
            self.occupied(k, child)
        })
    }

    /// Set voxels of level 0.
    pub fn occupied_count(&self) -> u64 {
        self.levels[0]
            .iter()
            .map(|w| u64::from(w.count_ones()))
            .sum()
    }

    /// Heap bytes of all levels.
    pub fn memory_bytes(&self) -> usize {
        self.levels.iter().map(|l| l.len() * 4).sum()
    }

    /// 1 / voxel edge (1/m) in f32, the one value the CPU and the GPU scale by.
    pub fn inv_voxel_f32(&self) -> f32 {
        (1.0 / self.voxel_m) as f32
    }

    /// A world point in grid coordinates (level-0 voxels).
    pub fn to_grid(&self, p: &V3) -> [f64; 3] {
        std::array::from_fn(|a| (p[a] - self.origin[a]) / self.voxel_m)
    }

    /// All levels in one word array, level 0 first, and each level's first word: the
    /// layout of the GPU's storage buffer.
    pub fn packed(&self) -> (Vec<u32>, Vec<u32>) {
        let mut offsets = Vec::with_capacity(self.levels.len());
        let mut all = Vec::with_capacity(self.levels.iter().map(Vec::len).sum());
        for l in &self.levels {
            offsets.push(all.len() as u32);
            all.extend_from_slice(l);
        }
        (all, offsets)
    }
}

/// Words holding `m³` bits.
pub(crate) fn words(m: u32) -> usize {
    (m as usize).pow(3).div_ceil(32)
}
