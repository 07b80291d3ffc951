//! An independent reference image (Mitsuba 3, `fixtures/scenes/cornell/mitsuba/`) and
//! the measure the Python harness uses against it: relative L1 of Y on 16×16-pixel block
//! means over the surfaces (the emitter and the background, dilated, excluded; a block
//! counts when 90 % of its pixels are surface), and the ratio of the mean Y.

use std::path::Path;

/// Block size in pixels.
const BLOCK: usize = 16;
/// Reference pixels brighter than this (cd/m²) are the emitter.
const EMITTER_CD_M2: f64 = 1000.0;
/// Share of a block's pixels that must be surface for the block to count.
const MIN_SURFACE_SHARE: f64 = 0.9;

/// A Y image read from a `.npy` file (little-endian f4 or f8, C order, 2-D).
#[derive(Debug, Clone)]
pub struct ImageReference {
    width: usize,
    height: usize,
    y: Vec<f64>,
    surface: Vec<bool>,
}

/// The error of an image against the reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageError {
    /// Relative L1 over the block means.
    pub rel_l1: f64,
    /// Σ blocks / Σ reference blocks.
    pub mean_ratio: f64,
}

impl ImageReference {
    /// Reads the reference; an error message names what is wrong.
    pub fn read(path: &Path) -> Result<Self, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let (height, width, y) =
            parse_npy(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        let emitter = dilate(
            &y.iter().map(|&v| v > EMITTER_CD_M2).collect::<Vec<_>>(),
            width,
            2,
        );
        let background = dilate(&y.iter().map(|&v| v <= 0.0).collect::<Vec<_>>(), width, 1);
        let surface = emitter
            .iter()
            .zip(&background)
            .map(|(e, b)| !e && !b)
            .collect();
        Ok(Self {
            width,
            height,
            y,
            surface,
        })
    }

    /// Image size (width, height) in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The error of `image` (Y in cd/m², row-major, the reference's size); `None` when
    /// the sizes differ.
    pub fn error_of(&self, image: &[f64]) -> Option<ImageError> {
        if image.len() != self.y.len() {
            return None;
        }
        let (mut diff, mut sum_ref, mut sum_img) = (0.0, 0.0, 0.0);
        for by in 0..self.height / BLOCK {
            for bx in 0..self.width / BLOCK {
                let Some((r, m)) = self.block_means(image, bx, by) else {
                    continue;
                };
                diff += (m - r).abs();
                sum_ref += r;
                sum_img += m;
            }
        }
        (sum_ref > 0.0).then(|| ImageError {
            rel_l1: diff / sum_ref,
            mean_ratio: sum_img / sum_ref,
        })
    }

    /// Means of the reference and of `image` over the surface pixels of block (bx, by),
    /// if the block counts.
    fn block_means(&self, image: &[f64], bx: usize, by: usize) -> Option<(f64, f64)> {
        let (mut n, mut r, mut m) = (0usize, 0.0, 0.0);
        for y in by * BLOCK..(by + 1) * BLOCK {
            for x in bx * BLOCK..(bx + 1) * BLOCK {
                let i = y * self.width + x;
                if self.surface[i] {
                    n += 1;
                    r += self.y[i];
                    m += image[i];
                }
            }
        }
        let share = n as f64 / (BLOCK * BLOCK) as f64;
        (share >= MIN_SURFACE_SHARE).then(|| (r / n as f64, m / n as f64))
    }
}

/// 4-neighbour dilation `steps` times.
fn dilate(mask: &[bool], width: usize, steps: usize) -> Vec<bool> {
    let height = mask.len() / width.max(1);
    let mut out = mask.to_vec();
    for _ in 0..steps {
        let prev = out.clone();
        for y in 0..height {
            for x in 0..width {
                let i = y * width + x;
                out[i] = prev[i]
                    || (y > 0 && prev[i - width])
                    || (y + 1 < height && prev[i + width])
                    || (x > 0 && prev[i - 1])
                    || (x + 1 < width && prev[i + 1]);
            }
        }
    }
    out
}

/// (height, width, values) of a 2-D little-endian f4/f8 C-order `.npy` (format 1 or 2).
fn parse_npy(bytes: &[u8]) -> Result<(usize, usize, Vec<f64>), String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not a .npy file".into());
    }
    let (len, start) = match bytes[6] {
        1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
        2 | 3 if bytes.len() >= 12 => {
            let l = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
            (l as usize, 12)
        }
        v => return Err(format!(".npy format version {v} is not supported")),
    };
    let header = bytes
        .get(start..start + len)
        .and_then(|h| std::str::from_utf8(h).ok())
        .ok_or("truncated .npy header")?;
    let size = if header.contains("'<f4'") {
        4
    } else if header.contains("'<f8'") {
        8
    } else {
        return Err(format!("dtype in `{header}` is not <f4 or <f8"));
    };
    if !header.contains("'fortran_order': False") {
        return Err("only C-order arrays are read".into());
    }
    let shape = header
        .split("'shape':")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .ok_or("no shape in the .npy header")?;
    let dims: Vec<usize> = shape
        .trim_start_matches([' ', '('])
        .split(',')
        .filter_map(|d| d.trim().parse().ok())
        .collect();
    let [h, w] = dims[..] else {
        return Err(format!("shape {shape}) is not 2-D"));
    };
    let data = &bytes[start + len..];
    if data.len() != h * w * size {
        return Err(format!("{} data bytes for shape ({h}, {w})", data.len()));
    }
    let values = data
        .chunks_exact(size)
        .map(|c| match c {
            [a, b, c, d] => f64::from(f32::from_le_bytes([*a, *b, *c, *d])),
            _ => f64::from_le_bytes(c.try_into().unwrap_or([0; 8])),
        })
        .collect();
    Ok((h, w, values))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stored_mitsuba_reference_reads_as_a_256_square_y_image() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures/scenes/cornell/mitsuba/reference_y.npy");
        let r = ImageReference::read(&p).unwrap();
        assert_eq!(r.size(), (256, 256));
        let same = r.error_of(&r.y).unwrap();
        assert_eq!(same.rel_l1, 0.0);
        assert_eq!(same.mean_ratio, 1.0);
        let brighter: Vec<f64> = r.y.iter().map(|v| v * 1.02).collect();
        let e = r.error_of(&brighter).unwrap();
        assert!((e.rel_l1 - 0.02).abs() < 1e-9 && (e.mean_ratio - 1.02).abs() < 1e-9);
    }

    #[test]
    fn a_npy_that_is_not_a_2d_float_array_is_refused() {
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        let h = "{'descr': '<i4', 'fortran_order': False, 'shape': (2, 2), }";
        b.extend_from_slice(&(h.len() as u16).to_le_bytes());
        b.extend_from_slice(h.as_bytes());
        b.extend_from_slice(&[0; 16]);
        assert!(parse_npy(&b).unwrap_err().contains("<i4"));
        assert!(parse_npy(b"hello world").is_err());
    }
}
