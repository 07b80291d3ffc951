// Voxelisation and OR-mipmaps of lumiwall's voxel GI (render/src/voxel/gpu.rs).
// The CPU reference is voxelize.rs (tri_box_overlap) and grid.rs (build_mips).

struct Params {
    n: u32,
    levels: u32,
    count: u32,
    level: u32,
    offsets: array<vec4<u32>, 3>,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var<storage, read_write> grid: array<atomic<u32>>;
// per triangle: 3 corners in grid coordinates (9 floats)
@group(0) @binding(2) var<storage, read> tris: array<f32>;
// per triangle: lo.xyz, hi.xyz of its voxel box and the loop axis
@group(0) @binding(3) var<storage, read> boxes: array<u32>;
// exclusive prefix sum of the rows (voxel lines along the loop axis) per triangle
@group(0) @binding(4) var<storage, read> first_row: array<u32>;

const MARGIN: f32 = 1e-4;

fn level_offset(level: u32) -> u32 {
    return P.offsets[level / 4u][level % 4u];
}

fn set_bit(level: u32, c: vec3<u32>) {
    let m = P.n >> level;
    let i = c.x + m * (c.y + m * c.z);
    atomicOr(&grid[level_offset(level) + (i >> 5u)], 1u << (i & 31u));
}

fn separates(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, axis: vec3<f32>, h: f32) -> bool {
    let p0 = dot(v0, axis);
    let p1 = dot(v1, axis);
    let p2 = dot(v2, axis);
    let r = h * (abs(axis.x) + abs(axis.y) + abs(axis.z));
    return min(min(p0, p1), p2) > r || max(max(p0, p1), p2) < -r;
}

// Akenine-Möller's separating-axis test, as tri_box_overlap in voxelize.rs.
fn overlaps(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, centre: vec3<f32>, h: f32) -> bool {
    let v0 = a - centre;
    let v1 = b - centre;
    let v2 = c - centre;
    let e0 = v1 - v0;
    let e1 = v2 - v1;
    let e2 = v0 - v2;
    let ex = vec3<f32>(1.0, 0.0, 0.0);
    let ey = vec3<f32>(0.0, 1.0, 0.0);
    let ez = vec3<f32>(0.0, 0.0, 1.0);
    if separates(v0, v1, v2, ex, h) || separates(v0, v1, v2, ey, h) || separates(v0, v1, v2, ez, h) {
        return false;
    }
    if separates(v0, v1, v2, cross(e0, e1), h) {
        return false;
    }
    var es = array<vec3<f32>, 3>(e0, e1, e2);
    var us = array<vec3<f32>, 3>(ex, ey, ez);
    for (var i = 0u; i < 3u; i++) {
        for (var j = 0u; j < 3u; j++) {
            if separates(v0, v1, v2, cross(us[j], es[i]), h) {
                return false;
            }
        }
    }
    return true;
}

// One invocation per row of a triangle's voxel box along its loop axis (the box's
// longest side): the triangle is found by binary search in first_row.
@compute @workgroup_size(64)
fn voxelize(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let row = id.x + id.y * groups.x * 64u;
    if row >= first_row[P.count] {
        return;
    }
    var lo = 0u;
    var hi = P.count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if first_row[mid] <= row {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let t = lo;
    let a = vec3<f32>(tris[9u * t], tris[9u * t + 1u], tris[9u * t + 2u]);
    let b = vec3<f32>(tris[9u * t + 3u], tris[9u * t + 4u], tris[9u * t + 5u]);
    let c = vec3<f32>(tris[9u * t + 6u], tris[9u * t + 7u], tris[9u * t + 8u]);
    let blo = vec3<u32>(boxes[7u * t], boxes[7u * t + 1u], boxes[7u * t + 2u]);
    let bhi = vec3<u32>(boxes[7u * t + 3u], boxes[7u * t + 4u], boxes[7u * t + 5u]);
    let axis = boxes[7u * t + 6u];
    // the two other axes, in order
    let ua = (axis + 1u) % 3u;
    let va = (axis + 2u) % 3u;
    let k = row - first_row[t];
    let width = bhi[ua] - blo[ua] + 1u;
    var cell = blo;
    cell[ua] = blo[ua] + k % width;
    cell[va] = blo[va] + k / width;
    for (var x = blo[axis]; x <= bhi[axis]; x++) {
        cell[axis] = x;
        let centre = vec3<f32>(cell) + vec3<f32>(0.5);
        if overlaps(a, b, c, centre, 0.5 + MARGIN) {
            set_bit(0u, cell);
        }
    }
}

// One invocation per cell of level P.level: set when any of its 8 children is.
@compute @workgroup_size(64)
fn mip(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let m = P.n >> P.level;
    let i = id.x + id.y * groups.x * 64u;
    if i >= m * m * m {
        return;
    }
    let c = vec3<u32>(i % m, (i / m) % m, i / (m * m));
    let cm = m * 2u;
    let base = level_offset(P.level - 1u);
    var any = false;
    for (var j = 0u; j < 8u; j++) {
        let ch = 2u * c + vec3<u32>(j & 1u, (j >> 1u) & 1u, j >> 2u);
        let ci = ch.x + cm * (ch.y + cm * ch.z);
        if ((atomicLoad(&grid[base + (ci >> 5u)]) >> (ci & 31u)) & 1u) == 1u {
            any = true;
        }
    }
    if any {
        set_bit(P.level, c);
    }
}
