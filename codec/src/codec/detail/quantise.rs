//! The encoder's side of the detail layer: transform the network's residual block by
//! block and quantise it.

use rayon::prelude::*;

use super::dct::{self, COEFFS, N};
use super::{blocks, Detail, DetailPlane};

/// Quantiser of one channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantiser {
    /// Step of every coefficient.
    pub step: f64,
    /// Dead zone: magnitudes round down unless their fraction exceeds `0.5 + deadzone`.
    pub deadzone: f64,
}

/// Level of coefficient `c` under `q`.
#[inline]
fn level(c: f64, q: Quantiser) -> i32 {
    let m = (c.abs() / q.step + 0.5 - q.deadzone).floor().max(0.0);
    (m.min(super::syntax::MAX_LEVEL as f64) as i32) * if c < 0.0 { -1 } else { 1 }
}

/// Block `(bx, by)` of a `width x height` plane, pixels past the image edge repeating
/// the last row or column (so the edge does not look like a step to the transform).
fn gather(plane: &[f64], width: usize, height: usize, bx: usize, by: usize) -> [f64; COEFFS] {
    let mut b = [0.0; COEFFS];
    for y in 0..N {
        let py = (by * N + y).min(height - 1);
        for x in 0..N {
            let px = (bx * N + x).min(width - 1);
            b[y * N + x] = plane[py * width + px];
        }
    }
    b
}

/// Transforms and quantises one residual plane.
pub fn plane(residual: &[f64], width: u32, height: u32, q: Quantiser) -> DetailPlane {
    let (cols, rows) = blocks(width, height);
    let (w, h) = (width as usize, height as usize);
    let levels: Vec<[i32; COEFFS]> = (0..cols * rows)
        .into_par_iter()
        .map(|i| {
            let c = dct::forward(&gather(residual, w, h, i % cols, i / cols));
            std::array::from_fn(|k| level(c[k], q))
        })
        .collect();
    DetailPlane::from_blocks(cols, rows, levels)
}

/// The detail layer of the colour channels' residuals, one quantiser per channel.
pub fn layer(residuals: &[Vec<f64>], width: u32, height: u32, q: &[Quantiser]) -> Detail {
    Detail {
        planes: residuals
            .iter()
            .zip(q)
            .map(|(r, &q)| plane(r, width, height, q))
            .collect(),
        steps: q.iter().map(|q| q.step).collect(),
    }
}
