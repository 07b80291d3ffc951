//! AVX2 kernel of the CPU post pass: eight pixels per step with explicit vectors
//! (shuffles to split the interleaved XYZ, gathers for the LUT segments). Each lane
//! does what the scalar reference does, operation for operation and without FMA, so
//! the codes are bit-identical (tested against `PreparedProfile::apply`). Lanes that
//! are not plainly in range take the scalar reference, as in the portable kernel.

use std::arch::x86_64::*;

use lumiwall_profiles::OutOfGamut;
use lumiwall_profiles::apply::{
    GAMUT_TOLERANCE, MAX_INPUT_CD_M2, PixelFlags, PreparedLut, PreparedProfile, dither_threshold,
};

use super::cpu::{BlockOut, RowContext, pixel_gains, portable_block};

/// Pixels per step.
const LANES: usize = 8;

/// Splits eight interleaved XYZ pixels (24 floats) into X, Y and Z vectors.
///
/// # Safety
/// AVX2 must be available and `p` must hold at least 8 pixels.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn load_xyz(p: &[[f32; 3]]) -> [__m256; 3] {
    debug_assert!(p.len() >= LANES);
    let f = p.as_ptr() as *const f32;
    // SAFETY: 24 floats are in bounds (checked by the caller); unaligned loads.
    unsafe {
        let m03 = _mm256_insertf128_ps::<1>(
            _mm256_castps128_ps256(_mm_loadu_ps(f)),
            _mm_loadu_ps(f.add(12)),
        );
        let m14 = _mm256_insertf128_ps::<1>(
            _mm256_castps128_ps256(_mm_loadu_ps(f.add(4))),
            _mm_loadu_ps(f.add(16)),
        );
        let m25 = _mm256_insertf128_ps::<1>(
            _mm256_castps128_ps256(_mm_loadu_ps(f.add(8))),
            _mm_loadu_ps(f.add(20)),
        );
        let xy = _mm256_shuffle_ps::<0b10_01_11_10>(m14, m25);
        let yz = _mm256_shuffle_ps::<0b01_00_10_01>(m03, m14);
        let x = _mm256_shuffle_ps::<0b10_00_11_00>(m03, xy);
        let y = _mm256_shuffle_ps::<0b11_01_10_00>(yz, xy);
        let z = _mm256_shuffle_ps::<0b11_00_11_01>(yz, m25);
        [x, y, z]
    }
}

/// Lanes whose X, Y and Z are all finite and at most [`MAX_INPUT_CD_M2`] in magnitude.
///
/// # Safety
/// AVX2 must be available.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn input_ok([x, y, z]: [__m256; 3]) -> __m256 {
    let sign = _mm256_set1_ps(-0.0);
    let lim = _mm256_set1_ps(MAX_INPUT_CD_M2);
    // |v| ≤ limit is false for NaN and ±Inf as well
    _mm256_and_ps(
        _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_andnot_ps(sign, x), lim),
            _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_andnot_ps(sign, y), lim),
        ),
        _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_andnot_ps(sign, z), lim),
    )
}

/// Eight pixels' linear drives: `mv = M·xyz / gain`, `a = mv + offset`, and the lanes
/// with a channel below the gamut tolerance (`gamut`) or above 1 + tolerance (`over`).
struct Linear8 {
    mv: [__m256; 3],
    a: [__m256; 3],
    gamut: __m256,
    over: __m256,
}

/// [`Linear8`] of the pixels `[x, y, z]`.
///
/// # Safety
/// AVX2 must be available.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn linear8(
    pp: &PreparedProfile,
    [x, y, z]: [__m256; 3],
    gain: Option<&[[f32; LANES]; 3]>,
) -> Linear8 {
    let m = pp.matrix;
    let zero = _mm256_setzero_ps();
    let tol = _mm256_set1_ps(GAMUT_TOLERANCE);
    let lo = _mm256_sub_ps(zero, tol);
    let hi = _mm256_add_ps(_mm256_set1_ps(1.0), tol);
    let mut out = Linear8 {
        mv: [zero; 3],
        a: [zero; 3],
        gamut: zero,
        over: zero,
    };
    for c in 0..3 {
        let mut v = _mm256_add_ps(
            _mm256_add_ps(
                _mm256_mul_ps(_mm256_set1_ps(m[c][0]), x),
                _mm256_mul_ps(_mm256_set1_ps(m[c][1]), y),
            ),
            _mm256_mul_ps(_mm256_set1_ps(m[c][2]), z),
        );
        if let Some(g) = gain {
            // SAFETY: `g[c]` holds 8 floats; unaligned load.
            v = _mm256_div_ps(v, unsafe { _mm256_loadu_ps(g[c].as_ptr()) });
        }
        out.mv[c] = v;
        out.a[c] = _mm256_add_ps(v, _mm256_set1_ps(pp.offset[c]));
        out.gamut = _mm256_or_ps(out.gamut, _mm256_cmp_ps::<_CMP_LT_OQ>(out.a[c], lo));
        out.over = _mm256_or_ps(out.over, _mm256_cmp_ps::<_CMP_GT_OQ>(out.a[c], hi));
    }
    out
}

/// Scales the `over` lanes of `lin.a` down as the reference does: at constant
/// chromaticity until every channel is ≤ 1.
///
/// # Safety
/// AVX2 must be available.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn scale_over_range(pp: &PreparedProfile, lin: &mut Linear8) {
    let zero = _mm256_setzero_ps();
    let one = _mm256_set1_ps(1.0);
    let mut s = one;
    for c in 0..3 {
        let off = _mm256_set1_ps(pp.offset[c]);
        let sc = _mm256_and_ps(
            _mm256_max_ps(_mm256_div_ps(_mm256_sub_ps(one, off), lin.mv[c]), zero),
            _mm256_cmp_ps::<_CMP_GT_OQ>(lin.mv[c], zero),
        );
        let above = _mm256_cmp_ps::<_CMP_GT_OQ>(lin.a[c], one);
        s = _mm256_blendv_ps(s, _mm256_min_ps(s, sc), above);
    }
    for c in 0..3 {
        let off = _mm256_set1_ps(pp.offset[c]);
        let scaled = _mm256_add_ps(_mm256_mul_ps(s, lin.mv[c]), off);
        lin.a[c] = _mm256_blendv_ps(lin.a[c], scaled, lin.over);
    }
}

/// The white-segment step of the reference (a display's white segment taken out of `lin.a`) and the
/// over-range mask again; lanes below zero have `s = 0`, so the gamut mask stands.
///
/// # Safety
/// AVX2 must be available.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn white_step8(pp: &PreparedProfile, lin: &mut Linear8) {
    let (u, k) = (pp.white_u, pp.white_k);
    let t = |c: usize| _mm256_mul_ps(lin.a[c], _mm256_set1_ps(k[c]));
    let s = _mm256_max_ps(
        _mm256_min_ps(_mm256_min_ps(t(0), t(1)), t(2)),
        _mm256_setzero_ps(),
    );
    let hi = _mm256_set1_ps(1.0 + GAMUT_TOLERANCE);
    lin.over = _mm256_setzero_ps();
    for (c, uc) in u.into_iter().enumerate() {
        lin.a[c] = _mm256_sub_ps(lin.a[c], _mm256_mul_ps(_mm256_set1_ps(uc), s));
        lin.over = _mm256_or_ps(lin.over, _mm256_cmp_ps::<_CMP_GT_OQ>(lin.a[c], hi));
    }
}

/// Codes of one channel of eight pixels: LUT segment, interpolation, quantisation
/// with thresholds `th` to `0..=max_code`.
///
/// # Safety
/// AVX2 must be available; the LUT has segments.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn lut_codes(lut: &PreparedLut, a: __m256, th: __m256, max_code: u32) -> __m256i {
    let zero = _mm256_setzero_ps();
    let one = _mm256_set1_ps(1.0);
    let pairs = lut.pairs();
    let last = _mm256_set1_epi32(pairs.len() as i32 - 1);
    // min/max return the second operand for NaN: t stays in 0..=len−1
    let t = _mm256_mul_ps(
        _mm256_max_ps(_mm256_min_ps(a, one), zero),
        _mm256_set1_ps(lut.scale),
    );
    let i = _mm256_max_epi32(
        _mm256_min_epi32(_mm256_cvttps_epi32(t), last),
        _mm256_setzero_si256(),
    );
    let frac = _mm256_sub_ps(t, _mm256_cvtepi32_ps(i));
    // the eight [base, slope] pairs by plain 64-bit loads (faster than
    // gathers here), then split
    let mut ix = [0i32; LANES];
    // SAFETY: `ix` holds 32 bytes; unaligned store.
    unsafe { _mm256_storeu_si256(ix.as_mut_ptr() as *mut __m256i, i) };
    let ptr = pairs.as_ptr() as *const i64;
    // SAFETY: every index is clamped to 0..=last above.
    let ld = |k: usize| unsafe { *ptr.add(ix[k] as usize) };
    let lo = _mm256_castsi256_ps(_mm256_set_epi64x(ld(5), ld(4), ld(1), ld(0)));
    let hi = _mm256_castsi256_ps(_mm256_set_epi64x(ld(7), ld(6), ld(3), ld(2)));
    // lo = pairs 0 1 | 4 5, hi = pairs 2 3 | 6 7: the shuffles give lanes 0..7
    let base = _mm256_shuffle_ps::<0b10_00_10_00>(lo, hi);
    let slope = _mm256_shuffle_ps::<0b11_01_11_01>(lo, hi);
    let d = _mm256_add_ps(base, _mm256_mul_ps(slope, frac));
    let v = _mm256_add_ps(_mm256_mul_ps(d, _mm256_set1_ps(max_code as f32)), th);
    _mm256_min_epi32(
        _mm256_max_epi32(_mm256_cvttps_epi32(v), _mm256_setzero_si256()),
        _mm256_set1_epi32(max_code as i32),
    )
}

/// Codes of eight pixels (`out[c][j]`), the mask of lanes that need the scalar
/// reference and the mask of lanes scaled down for being over range (bit j set).
/// Lanes whose only problem is range (finite, no channel below the gamut tolerance,
/// clip mode) are scaled here as the reference scales them: at constant
/// chromaticity until every channel is ≤ 1.
///
/// # Safety
/// AVX2 must be available; `xyz` holds at least 8 pixels; every LUT has segments.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn fast8(
    pp: &PreparedProfile,
    xyz: &[[f32; 3]],
    gain: Option<&[[f32; LANES]; 3]>,
    thr: &[f32; LANES],
    out: &mut [[u16; 3]],
) -> (u32, u32) {
    // SAFETY: the caller guarantees AVX2 and the sizes; the helpers' conditions hold.
    unsafe {
        let xyz = load_xyz(xyz);
        let ok = input_ok(xyz);
        let mut lin = linear8(pp, xyz, gain);
        if pp.white_segment {
            white_step8(pp, &mut lin);
        }
        // lanes for the reference: invalid or huge input, a gamut clip, or a marker
        let mut scalar = _mm256_or_ps(
            _mm256_xor_ps(ok, _mm256_castsi256_ps(_mm256_set1_epi32(-1))),
            lin.gamut,
        );
        // over range with a white segment: the reference's region-wise scaling
        if pp.out_of_gamut == OutOfGamut::FalseColour || pp.white_segment {
            scalar = _mm256_or_ps(scalar, lin.over);
        }
        let slow = _mm256_movemask_ps(scalar) as u32;
        if slow == 0xff {
            return (slow, 0);
        }
        let over_mask = _mm256_movemask_ps(lin.over) as u32 & !slow;
        if over_mask != 0 {
            scale_over_range(pp, &mut lin);
        }
        let th = _mm256_loadu_ps(thr.as_ptr());
        let max_code = pp.max_code();
        let codes = [0, 1, 2].map(|c| lut_codes(&pp.luts[c], lin.a[c], th, max_code));
        store_codes(&codes, out);
        (slow, over_mask)
    }
}

/// Writes eight pixels' codes (`codes[c]` lane j → `out[j][c]`, each ≤ 65535) as
/// interleaved u16 triples: one 64-bit store per pixel (r | g | b | 2 bytes that the
/// next pixel overwrites), the last pixel exactly.
///
/// # Safety
/// AVX2 must be available; `out` holds at least 8 pixels.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn store_codes(codes: &[__m256i; 3], out: &mut [[u16; 3]]) {
    assert!(out.len() >= LANES);
    let rg = _mm256_or_si256(codes[0], _mm256_slli_epi32::<16>(codes[1]));
    // 64-bit lanes: lo = pixels 0 1 | 4 5, hi = 2 3 | 6 7, each rg | b << 32
    let lo = _mm256_unpacklo_epi32(rg, codes[2]);
    let hi = _mm256_unpackhi_epi32(rg, codes[2]);
    let mut px = [0u64; LANES];
    let order = [lo, hi];
    for (h, v) in order.iter().enumerate() {
        let mut q = [0u64; 4];
        // SAFETY: `q` holds 32 bytes.
        unsafe { _mm256_storeu_si256(q.as_mut_ptr() as *mut __m256i, *v) };
        px[2 * h] = q[0];
        px[2 * h + 1] = q[1];
        px[2 * h + 4] = q[2];
        px[2 * h + 5] = q[3];
    }
    let base = out.as_mut_ptr() as *mut u8;
    for (j, &v) in px.iter().enumerate().take(LANES - 1) {
        // SAFETY: bytes 6j..6j+8 lie within the 48 bytes of the eight pixels
        // (j ≤ 6); unaligned store.
        unsafe { (base.add(6 * j) as *mut u64).write_unaligned(v) };
    }
    let v = px[LANES - 1];
    out[LANES - 1] = [v as u16, (v >> 16) as u16, (v >> 32) as u16];
}

/// Ordered-dither thresholds of row `y` (they repeat every 16 columns); 0.5 without
/// dithering.
fn dither_row(pp: &PreparedProfile, y: u32) -> [f32; 16] {
    let mut thr_row = [0.5f32; 16];
    if pp.dither {
        for (x, t) in thr_row.iter_mut().enumerate() {
            *t = dither_threshold(x as u32, y);
        }
    }
    thr_row
}

/// Flat-field gains of the eight pixels from column `x0` into lanes `g[c][j]`.
///
/// # Safety
/// AVX2 must be available; the row holds eight pixels from `x0`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn gains8(ctx: &RowContext<'_>, x0: usize, g: &mut [[f32; LANES]; 3]) {
    let (cols, row_gain) = (ctx.cols, ctx.row_gain);
    let (first, last) = (cols.texels[x0], cols.texels[x0 + LANES - 1]);
    if first.0 != last.0 {
        pixel_gains(row_gain, cols, x0, LANES, g);
        return;
    }
    // one texel span: the reference's lerp, eight lanes at once
    let (c0, c1) = (row_gain[first.0], row_gain[first.1]);
    let w = &cols.weights[x0..x0 + LANES];
    for c in 0..3 {
        // SAFETY: AVX2 is enabled here; `w` and `g[c]` hold 8 floats.
        unsafe {
            let lo = _mm256_set1_ps(c0[c]);
            let d = _mm256_set1_ps(c1[c] - c0[c]);
            let v = _mm256_add_ps(lo, _mm256_mul_ps(d, _mm256_loadu_ps(w.as_ptr())));
            _mm256_storeu_ps(g[c].as_mut_ptr(), v);
        }
    }
}

/// Flags and histogram of eight pixels after [`fast8`] (OVER_RANGE on the lanes it
/// scaled, 0 elsewhere, without branches), then the `slow` lanes through the scalar
/// reference.
#[inline(always)]
fn finish8(
    ctx: &RowContext<'_>,
    ib: &[[f32; 3]],
    x0: usize,
    gain: Option<&[[f32; LANES]; 3]>,
    (slow, over): (u32, u32),
    out: BlockOut<'_>,
) {
    let pp = ctx.pp;
    let mut flag_bytes = 0u64;
    for j in 0..LANES {
        flag_bytes |= (u64::from((over >> j) & 1) * u64::from(PixelFlags::OVER_RANGE.0)) << (8 * j);
    }
    out.flags.copy_from_slice(&flag_bytes.to_le_bytes());
    out.hist[PixelFlags::OVER_RANGE.0 as usize] += u64::from(over.count_ones());
    out.hist[0] += u64::from(LANES as u32 - (over | slow).count_ones());
    let mut rest = slow;
    while rest != 0 {
        let j = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        let px = pp.apply_gain(ib[j], gain.map(|g| [g[0][j], g[1][j], g[2][j]]));
        out.codes[j] = pp.quantise_pixel(px.drive, (x0 + j) as u32, ctx.y);
        out.flags[j] = px.flags.0 as u8;
        out.hist[(px.flags.0 & 15) as usize] += 1;
    }
}

/// One row with the AVX2 kernel; the last `len % 8` pixels go through the portable
/// block.
///
/// # Safety
/// AVX2 must be available.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn row(ctx: &RowContext<'_>, irow: &[[f32; 3]], out: BlockOut<'_>) {
    let pp = ctx.pp;
    let degenerate = pp.luts.iter().any(|l| l.pairs().is_empty());
    let flat = pp.flat.is_some();
    let thr_row = dither_row(pp, ctx.y);
    let full = if degenerate { 0 } else { irow.len() / LANES };
    let mut g = [[1f32; LANES]; 3];
    for b in 0..full {
        let x0 = b * LANES;
        let ib = &irow[x0..x0 + LANES];
        if flat {
            // SAFETY: AVX2 is enabled for this function; the row has 8 pixels from x0.
            unsafe { gains8(ctx, x0, &mut g) };
        }
        let thr: &[f32; LANES] = if x0 & 15 == 0 {
            thr_row[..LANES].try_into().unwrap_or(&[0.5; LANES])
        } else {
            thr_row[LANES..].try_into().unwrap_or(&[0.5; LANES])
        };
        let gain = flat.then_some(&g);
        let ob = &mut out.codes[x0..x0 + LANES];
        // SAFETY: AVX2 is enabled for this function; `ib` has 8 pixels; no LUT is
        // empty (`degenerate` is false whenever `full` > 0).
        let masks = unsafe { fast8(pp, ib, gain, thr, ob) };
        let block_out = BlockOut {
            codes: ob,
            flags: &mut out.flags[x0..x0 + LANES],
            hist: &mut *out.hist,
        };
        finish8(ctx, ib, x0, gain, masks, block_out);
    }
    let x0 = full * LANES;
    if x0 < irow.len() {
        let tail = BlockOut {
            codes: &mut out.codes[x0..],
            flags: &mut out.flags[x0..],
            hist: out.hist,
        };
        portable_block(ctx, &irow[x0..], x0, tail);
    }
}
