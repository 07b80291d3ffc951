//! CPU reference of the post pass: rayon over bands of rows, f32, exactly the arithmetic
//! of [`PreparedProfile::apply`](lumiwall_profiles::apply::PreparedProfile::apply).
//!
//! Speed without changing the maths: the flat-field texture is interpolated along v once
//! per row (the scalar reference interpolates v first, then u, so the result is
//! bit-identical), the per-column texel indices and weights are computed once per frame,
//! the LUT slopes are precomputed, and nothing is allocated per pixel.

use lumiwall_profiles::apply::{
    MAX_INPUT_CD_M2, PreparedLut, PreparedProfile, dither_threshold, lerp3, texel_axis,
};
use rayon::prelude::*;

use super::{CodeImage, FlagCounts, XyzFrame};

/// Pixels per rayon task (rounded to whole rows).
const PIXELS_PER_TASK: usize = 32 * 1024;

/// Normalised position of pixel centre `i` of `n`: `(i + 0.5) / n`.
#[inline(always)]
pub fn pixel_centre(i: u32, n: u32) -> f32 {
    (i as f32 + 0.5) / n as f32
}

/// Pixels per SIMD block.
const BLOCK: usize = 16;

/// The parts of one row's work that are the same for all its blocks.
pub(super) struct RowContext<'a> {
    /// The profile.
    pub pp: &'a PreparedProfile,
    /// Row index.
    pub y: u32,
    /// The row's flat-field gains per texel column (empty without a texture).
    pub row_gain: &'a [[f32; 3]],
    /// Each pixel column's place in the texture.
    pub cols: &'a Columns,
}

/// Where one block's (or row's) results go.
pub(super) struct BlockOut<'a> {
    /// Codes R, G, B per pixel.
    pub codes: &'a mut [[u16; 3]],
    /// [`PixelFlags`](lumiwall_profiles::apply::PixelFlags) bits per pixel.
    pub flags: &'a mut [u8],
    /// Pixels per flag combination.
    pub hist: &'a mut [u64; 16],
}

/// Exponent bits of an f32: all set for NaN and ±Inf.
const F32_EXPONENT: u32 = 0x7f80_0000;

/// The first `n` pixels of `xyz` as structure of arrays (padding lanes are 0 and
/// never written back).
#[inline(always)]
fn soa(xyz: &[[f32; 3]], n: usize) -> [[f32; BLOCK]; 3] {
    let mut p = [[0f32; BLOCK]; 3];
    for (j, v) in xyz.iter().enumerate().take(n) {
        p[0][j] = v[0];
        p[1][j] = v[1];
        p[2][j] = v[2];
    }
    p
}

/// Linear drives `M·xyz / gain + offset` of a block, and the lanes that need the
/// scalar reference (not finite, huge, or any drive outside 0..=1).
#[inline(always)]
fn linear_block(
    pp: &PreparedProfile,
    p: &[[f32; BLOCK]; 3],
    gain: Option<&[[f32; BLOCK]; 3]>,
) -> ([[f32; BLOCK]; 3], [bool; BLOCK]) {
    let m = pp.matrix;
    let mut a = [[0f32; BLOCK]; 3];
    let mut ok = [true; BLOCK];
    for j in 0..BLOCK {
        let (x, yv, z) = (p[0][j], p[1][j], p[2][j]);
        // Finite and not huge; NaN fails the comparisons too.
        ok[j] = (x.to_bits() & F32_EXPONENT != F32_EXPONENT)
            & (yv.to_bits() & F32_EXPONENT != F32_EXPONENT)
            & (z.to_bits() & F32_EXPONENT != F32_EXPONENT)
            & (x.abs() <= MAX_INPUT_CD_M2)
            & (yv.abs() <= MAX_INPUT_CD_M2)
            & (z.abs() <= MAX_INPUT_CD_M2);
        for (c, row) in m.iter().enumerate() {
            a[c][j] = row[0] * x + row[1] * yv + row[2] * z;
        }
    }
    if let Some(g) = gain {
        for (ac, gc) in a.iter_mut().zip(g) {
            for (v, gj) in ac.iter_mut().zip(gc) {
                *v /= gj;
            }
        }
    }
    for (ac, off) in a.iter_mut().zip(pp.offset) {
        for v in ac.iter_mut() {
            *v += off;
        }
    }
    if pp.white_segment {
        let [a0, a1, a2] = &mut a;
        for ((x, y), z) in a0.iter_mut().zip(a1.iter_mut()).zip(a2.iter_mut()) {
            [*x, *y, *z] = pp.white_step([*x, *y, *z]);
        }
    }
    let mut slow = [false; BLOCK];
    for j in 0..BLOCK {
        let inside = ok[j]
            & (a[0][j] >= 0.0)
            & (a[0][j] <= 1.0)
            & (a[1][j] >= 0.0)
            & (a[1][j] <= 1.0)
            & (a[2][j] >= 0.0)
            & (a[2][j] <= 1.0);
        slow[j] = !inside;
    }
    (a, slow)
}

/// Quantisation thresholds of the block from column `x0` of row `y`: 0.5 (round to
/// nearest), or the ordered-dither thresholds.
#[inline(always)]
fn block_thresholds(pp: &PreparedProfile, x0: u32, y: u32) -> [f32; BLOCK] {
    let mut thr = [0.5f32; BLOCK];
    if pp.dither {
        for (j, t) in thr.iter_mut().enumerate() {
            *t = dither_threshold(x0 + j as u32, y);
        }
    }
    thr
}

/// Codes of one channel of a block: LUT segment, interpolation and quantisation.
#[inline(always)]
fn channel_codes(
    lut: &PreparedLut,
    a: &[f32; BLOCK],
    thr: &[f32; BLOCK],
    max: u32,
) -> [u16; BLOCK] {
    let pairs = lut.pairs();
    let last = pairs.len().saturating_sub(1) as i32;
    let mut idx = [0i32; BLOCK];
    let mut frac = [0f32; BLOCK];
    for j in 0..BLOCK {
        // t is in 0..=len−1 here, so the i32 conversion (vectorisable) equals the
        // reference's usize one.
        let t = a[j].clamp(0.0, 1.0) * lut.scale;
        let i = (t as i32).min(last);
        idx[j] = i;
        frac[j] = t - i as f32;
    }
    let mut base = [0f32; BLOCK];
    let mut slope = [0f32; BLOCK];
    if let Some(top) = pairs.len().checked_sub(1) {
        for j in 0..BLOCK {
            // `min(top)` lets the compiler drop the bounds check (idx ≤ top anyway).
            let pr = pairs[(idx[j] as usize).min(top)];
            base[j] = pr[0];
            slope[j] = pr[1];
        }
    }
    let maxf = max as f32;
    let mut codes = [0u16; BLOCK];
    for j in 0..BLOCK {
        let d = base[j] + slope[j] * frac[j];
        // v ≥ 0 and < 2^17: i32 conversion equals the reference's u32 one.
        let v = d * maxf + thr[j];
        codes[j] = ((v as i32).max(0) as u32).min(max) as u16;
    }
    codes
}

/// One block of up to [`BLOCK`] pixels of row `y` starting at column `x0`, structure of
/// arrays so that the matrix, range tests, LUT positions and quantisation vectorise.
/// Pixels that are not plainly in range (NaN/Inf, huge, out of gamut or over range)
/// take the scalar reference path. Every operation is the scalar reference's, in the
/// same order, so the results are bit-identical (tested).
#[inline(always)]
fn block(
    pp: &PreparedProfile,
    xyz: &[[f32; 3]],
    gain: Option<&[[f32; BLOCK]; 3]>,
    x0: u32,
    y: u32,
    out: BlockOut<'_>,
) {
    let n = xyz.len().min(BLOCK);
    let (a, slow) = linear_block(pp, &soa(xyz, n), gain);
    let thr = block_thresholds(pp, x0, y);
    let max = pp.max_code();
    let codes = [0, 1, 2].map(|c| channel_codes(&pp.luts[c], &a[c], &thr, max));
    let degenerate = pp.luts.iter().any(|l| l.pairs().is_empty());
    for j in 0..n {
        if slow[j] || degenerate {
            let px = pp.apply_gain(xyz[j], gain.map(|g| [g[0][j], g[1][j], g[2][j]]));
            out.codes[j] = pp.quantise_pixel(px.drive, x0 + j as u32, y);
            out.flags[j] = px.flags.0 as u8;
            out.hist[(px.flags.0 & 15) as usize] += 1;
        } else {
            out.codes[j] = [codes[0][j], codes[1][j], codes[2][j]];
            out.flags[j] = 0;
            out.hist[0] += 1;
        }
    }
}

/// Each pixel column's place in the flat-field texture (the same for every row;
/// empty without a texture): its two texel columns, and the weight between them
/// apart, for vector loads.
pub(super) struct Columns {
    /// Left and right texel column.
    pub texels: Vec<(usize, usize)>,
    /// Weight of the right one.
    pub weights: Vec<f32>,
}

impl Columns {
    fn new(pp: &PreparedProfile, width: u32) -> Self {
        let (texels, weights) = match &pp.flat {
            Some(ff) => (0..width)
                .map(|x| {
                    let (t0, t1, f) = texel_axis(pixel_centre(x, width), ff.width);
                    ((t0, t1), f)
                })
                .unzip(),
            None => (Vec::new(), Vec::new()),
        };
        Self { texels, weights }
    }
}

/// Pixels of row `ctx.y` from column `xs` on through [`block`].
#[inline(always)]
pub(super) fn portable_block(
    ctx: &RowContext<'_>,
    irow: &[[f32; 3]],
    xs: usize,
    out: BlockOut<'_>,
) {
    let pp = ctx.pp;
    let flat = pp.flat.is_some();
    let mut g = [[1f32; BLOCK]; 3];
    for (b, ((ib, ob), fb)) in irow
        .chunks(BLOCK)
        .zip(out.codes.chunks_mut(BLOCK))
        .zip(out.flags.chunks_mut(BLOCK))
        .enumerate()
    {
        let x0 = xs + b * BLOCK;
        let block_out = BlockOut {
            codes: ob,
            flags: fb,
            hist: &mut *out.hist,
        };
        if flat {
            block_gains(ctx, x0, ib.len(), &mut g);
            block(pp, ib, Some(&g), x0 as u32, ctx.y, block_out);
        } else {
            block(pp, ib, None, x0 as u32, ctx.y, block_out);
        }
    }
}

/// Flat-field gains of the `n` pixels from column `x0` into lanes `g[c][j]`.
#[inline(always)]
fn block_gains(ctx: &RowContext<'_>, x0: usize, n: usize, g: &mut [[f32; BLOCK]; 3]) {
    let (cols, row_gain) = (ctx.cols, ctx.row_gain);
    let (first, last) = (cols.texels[x0], cols.texels[x0 + n - 1]);
    if first.0 == last.0 {
        // The whole block lies between the same two texel columns (the usual
        // case: a texel spans tens of pixels): same lerp, vectorised.
        let (c0, c1) = (row_gain[first.0], row_gain[first.1]);
        for c in 0..3 {
            for (j, f) in cols.weights[x0..x0 + n].iter().enumerate() {
                g[c][j] = c0[c] + (c1[c] - c0[c]) * f;
            }
        }
    } else {
        pixel_gains(row_gain, cols, x0, n, g);
    }
}

/// Flat-field gains of the `n` (≤ L) pixels from column `x0` into lanes `g[c][j]`,
/// pixel by pixel (blocks that straddle a texel column).
#[inline(always)]
pub(super) fn pixel_gains<const L: usize>(
    row_gain: &[[f32; 3]],
    cols: &Columns,
    x0: usize,
    n: usize,
    g: &mut [[f32; L]; 3],
) {
    let texels = &cols.texels[x0..x0 + n];
    let weights = &cols.weights[x0..x0 + n];
    for (j, (t, f)) in texels.iter().zip(weights).enumerate().take(L) {
        let gj = lerp3(row_gain[t.0], row_gain[t.1], *f);
        g[0][j] = gj[0];
        g[1][j] = gj[1];
        g[2][j] = gj[2];
    }
}

/// Runs one row with the widest vector unit available.
fn run_row(ctx: &RowContext<'_>, irow: &[[f32; 3]], out: BlockOut<'_>) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked at run time just above).
        unsafe { super::cpu_avx2::row(ctx, irow, out) };
        return;
    }
    portable_block(ctx, irow, 0, out)
}

/// Runs the post pass over a whole frame for one display.
pub fn apply_cpu(pp: &PreparedProfile, frame: &XyzFrame) -> CodeImage {
    let mut out = CodeImage {
        width: 0,
        height: 0,
        bit_depth: pp.bit_depth,
        codes: Vec::new(),
        flags: Vec::new(),
        counts: FlagCounts::default(),
    };
    apply_cpu_into(pp, frame, &mut out);
    out
}

/// As [`apply_cpu`], writing into `out` and reusing its buffers (a renderer calls this
/// once per frame without allocating).
pub fn apply_cpu_into(pp: &PreparedProfile, frame: &XyzFrame, out: &mut CodeImage) {
    let w = frame.width as usize;
    let n = frame.pixels.len();
    out.width = frame.width;
    out.height = frame.height;
    out.bit_depth = pp.bit_depth;
    out.codes.resize(n, [0; 3]);
    out.flags.resize(n, 0);
    out.counts = FlagCounts::default();
    if n == 0 || w == 0 {
        return;
    }
    let rows_per_task = (PIXELS_PER_TASK / w).max(1);
    let chunk = rows_per_task * w;
    let cols = Columns::new(pp, frame.width);
    let hist = out
        .codes
        .par_chunks_mut(chunk)
        .zip(out.flags.par_chunks_mut(chunk))
        .zip(frame.pixels.par_chunks(chunk))
        .enumerate()
        .map(|(task, ((out, fl), inp))| {
            let mut hist = [0u64; 16];
            let mut row_gain: Vec<[f32; 3]> = Vec::new();
            let y_first = task * rows_per_task;
            for (r, ((orow, frow), irow)) in out
                .chunks_mut(w)
                .zip(fl.chunks_mut(w))
                .zip(inp.chunks(w))
                .enumerate()
            {
                let y = (y_first + r) as u32;
                if let Some(ff) = &pp.flat {
                    let (y0, y1, fy) = texel_axis(pixel_centre(y, frame.height), ff.height);
                    let tw = ff.width as usize;
                    row_gain.clear();
                    row_gain.extend(
                        (0..tw).map(|tx| lerp3(ff.gain[y0 * tw + tx], ff.gain[y1 * tw + tx], fy)),
                    );
                }
                let ctx = RowContext {
                    pp,
                    y,
                    row_gain: &row_gain,
                    cols: &cols,
                };
                let out = BlockOut {
                    codes: orow,
                    flags: frow,
                    hist: &mut hist,
                };
                run_row(&ctx, irow, out);
            }
            hist
        })
        .reduce(
            || [0u64; 16],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    *x += y;
                }
                a
            },
        );
    out.counts.add_histogram(&hist);
}
