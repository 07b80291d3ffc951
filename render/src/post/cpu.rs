//! CPU reference of the post pass: rayon over bands of rows, f32, exactly the arithmetic
//! of [`PreparedProfile::apply`](lumiwall_profiles::apply::PreparedProfile::apply).
//!
//! Speed without changing the maths: the flat-field texture is interpolated along v once
//! per row (the scalar reference interpolates v first, then u, so the result is
//! bit-identical), the per-column texel indices and weights are computed once per frame,
//! the LUT slopes are precomputed, and nothing is allocated per pixel.

use lumiwall_profiles::apply::{PreparedProfile, lerp3, texel_axis};
use rayon::prelude::*;

use super::{CodeImage, FlagCounts, XyzFrame};

/// Pixels per rayon task (rounded to whole rows).
const PIXELS_PER_TASK: usize = 32 * 1024;

/// Normalised position of pixel centre `i` of `n`: `(i + 0.5) / n`.
#[inline(always)]
pub fn pixel_centre(i: u32, n: u32) -> f32 {
    (i as f32 + 0.5) / n as f32
}

/// Runs the post pass over a whole frame for one display.
pub fn apply_cpu(pp: &PreparedProfile, frame: &XyzFrame) -> CodeImage {
    let w = frame.width as usize;
    let h = frame.height as usize;
    let n = w * h;
    let mut codes = vec![[0u16; 3]; n];
    let mut flags = vec![0u8; n];
    if n == 0 {
        return CodeImage {
            width: frame.width,
            height: frame.height,
            bit_depth: pp.bit_depth,
            codes,
            flags,
            counts: FlagCounts::default(),
        };
    }
    let rows_per_task = (PIXELS_PER_TASK / w).max(1);
    let chunk = rows_per_task * w;
    // Texel columns and weights per pixel column (same for every row).
    let cols: Vec<(usize, usize, f32)> = match &pp.flat {
        Some(ff) => (0..frame.width)
            .map(|x| texel_axis(pixel_centre(x, frame.width), ff.width))
            .collect(),
        None => Vec::new(),
    };
    let counts = codes
        .par_chunks_mut(chunk)
        .zip(flags.par_chunks_mut(chunk))
        .zip(frame.pixels.par_chunks(chunk))
        .enumerate()
        .map(|(task, ((out, fl), inp))| {
            let mut counts = FlagCounts::default();
            let mut row_gain: Vec<[f32; 3]> = Vec::new();
            let y_first = task * rows_per_task;
            for (r, ((orow, frow), irow)) in out
                .chunks_mut(w)
                .zip(fl.chunks_mut(w))
                .zip(inp.chunks(w))
                .enumerate()
            {
                let y = (y_first + r) as u32;
                match &pp.flat {
                    None => {
                        for (x, ((o, f), xyz)) in
                            orow.iter_mut().zip(frow.iter_mut()).zip(irow).enumerate()
                        {
                            let px = pp.apply_gain(*xyz, None);
                            *o = pp.quantise_pixel(px.drive, x as u32, y);
                            *f = px.flags.0 as u8;
                            counts.add(px.flags);
                        }
                    }
                    Some(ff) => {
                        let (y0, y1, fy) = texel_axis(pixel_centre(y, frame.height), ff.height);
                        let tw = ff.width as usize;
                        row_gain.clear();
                        row_gain.extend(
                            (0..tw)
                                .map(|tx| lerp3(ff.gain[y0 * tw + tx], ff.gain[y1 * tw + tx], fy)),
                        );
                        for (x, (((o, f), xyz), col)) in orow
                            .iter_mut()
                            .zip(frow.iter_mut())
                            .zip(irow)
                            .zip(&cols)
                            .enumerate()
                        {
                            let g = lerp3(row_gain[col.0], row_gain[col.1], col.2);
                            let px = pp.apply_gain(*xyz, Some(g));
                            *o = pp.quantise_pixel(px.drive, x as u32, y);
                            *f = px.flags.0 as u8;
                            counts.add(px.flags);
                        }
                    }
                }
            }
            counts
        })
        .reduce(FlagCounts::default, FlagCounts::merged);
    CodeImage {
        width: frame.width,
        height: frame.height,
        bit_depth: pp.bit_depth,
        codes,
        flags,
        counts,
    }
}
