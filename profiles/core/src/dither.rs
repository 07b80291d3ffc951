//! Ordered dithering: how a drive between two code values is shown.
//!
//! The post pass quantises with [`quantise`] at the threshold [`dither_threshold`] of each
//! pixel (a 16×16 Bayer matrix) when dithering is on. Every pattern output shows a
//! uniform drive that falls between codes the same way, so that a meter, whose spot
//! covers many 16×16 cells, reads what the post pass's dithered frame of that colour
//! would give: [`mix`] lists the code triples of one cell and how many of its pixels
//! show each.

/// Code value for a normalised drive: `floor(drive · max_code + threshold)`, clamped to
/// `0..=max_code`. `threshold` 0.5 rounds to nearest; a dither threshold in (0, 1)
/// dithers.
#[inline(always)]
pub fn quantise(drive: f32, max_code: u32, threshold: f32) -> u16 {
    let v = drive * max_code as f32 + threshold;
    // `as` saturates: NaN → 0, negative → 0.
    (v as u32).min(max_code) as u16
}

/// Side of the ordered-dither cell in pixels: the thresholds repeat every 16 columns
/// and rows.
pub const CELL: u32 = 16;

/// Ordered-dither threshold in (0, 1) at pixel `(x, y)`: the 16×16 Bayer matrix
/// (256 distinct levels, `(index + 0.5) / 256`). Integer-exact, so the GPU computes the
/// same thresholds.
#[inline(always)]
pub fn dither_threshold(x: u32, y: u32) -> f32 {
    BAYER16[((y & 15) * 16 + (x & 15)) as usize]
}

/// Bayer index (0..256) of `(x, y)` in the 16×16 matrix: bit pairs of `(x ^ y, y)`,
/// least significant pair first into the most significant position.
const fn bayer_index(x: u32, y: u32) -> u32 {
    let z = x ^ y;
    let mut v = 0u32;
    let mut i = 0;
    while i < 4 {
        let bit = ((z >> i) & 1) * 2 + ((y >> i) & 1);
        v |= bit << (2 * (3 - i));
        i += 1;
    }
    v
}

/// The 16×16 thresholds, row-major (`BAYER16[y * 16 + x]`).
const BAYER16: [f32; 256] = {
    let mut t = [0f32; 256];
    let mut k = 0;
    while k < 256 {
        t[k] = (bayer_index(k as u32 % 16, k as u32 / 16) as f32 + 0.5) / 256.0;
        k += 1;
    }
    t
};

/// The smallest and the largest threshold of [`BAYER16`].
const BAYER16_MIN: f32 = 0.5 / 256.0;
const BAYER16_MAX: f32 = 255.5 / 256.0;

/// Code triples (normalised drives, code / max code) of one 16×16 dither cell of a
/// uniform `drive` at `max_code`, each with the fraction of the cell's pixels that
/// show it. At most four entries (the three channels switch from their lower to their
/// upper code at three thresholds); one entry with weight 1 when `drive` is on codes.
pub fn mix(drive: [f64; 3], max_code: u32) -> Vec<([f64; 3], f64)> {
    let top = max_code.max(1);
    let (lowest, highest) = (BAYER16_MIN, BAYER16_MAX);
    let lo = drive.map(|d| quantise(d as f32, top, lowest));
    if lo == drive.map(|d| quantise(d as f32, top, highest)) {
        return vec![(lo.map(|v| f64::from(v) / f64::from(top)), 1.0)];
    }
    let mut out: Vec<([u16; 3], u32)> = Vec::with_capacity(4);
    for &t in BAYER16.iter() {
        let codes = drive.map(|d| quantise(d as f32, top, t));
        match out.iter_mut().find(|(c, _)| *c == codes) {
            Some((_, n)) => *n += 1,
            None => out.push((codes, 1)),
        }
    }
    let scale = f64::from(top);
    out.into_iter()
        .map(|(c, n)| (c.map(|v| f64::from(v) / scale), f64::from(n) / 256.0))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_extreme_thresholds_are_those_of_the_matrix() {
        let min = BAYER16.iter().copied().fold(f32::INFINITY, f32::min);
        let max = BAYER16.iter().copied().fold(0.0, f32::max);
        assert_eq!((min, max), (BAYER16_MIN, BAYER16_MAX));
    }

    #[test]
    fn a_drive_on_a_code_shows_that_code_alone() {
        for code in [0u32, 1, 17, 128, 254, 255] {
            let d = f64::from(code) / 255.0;
            let m = mix([d, d, 0.0], 255);
            assert_eq!(m.len(), 1, "{code}: {m:?}");
            assert_eq!(m[0].0, [d, d, 0.0]);
            assert_eq!(m[0].1, 1.0);
        }
    }

    #[test]
    fn the_mean_code_of_a_cell_is_the_drive_to_a_256th_of_a_code() {
        for (i, d) in [0.1234_f64, 0.5, 0.0017, 0.9991, 0.3333]
            .into_iter()
            .enumerate()
        {
            let drive = [d, (d * 1.7) % 1.0, (d * 0.3 + 0.01 * i as f64) % 1.0];
            let m = mix(drive, 255);
            assert!(m.len() <= 4, "{m:?}");
            let total: f64 = m.iter().map(|(_, w)| w).sum();
            assert!((total - 1.0).abs() < 1e-12);
            for c in 0..3 {
                let mean: f64 = m.iter().map(|(v, w)| v[c] * w).sum();
                let err_codes = (mean - drive[c]).abs() * 255.0;
                assert!(
                    err_codes <= 0.5 / 256.0 + 1e-4,
                    "{drive:?} channel {c}: {err_codes}"
                );
            }
        }
    }
}
