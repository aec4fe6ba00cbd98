//! The encoder's side of the detail layer: transform the network's residual block by
//! block, quantise it and choose each block's coefficients by rate and distortion.
//!
//! Blocks are decided in coding order with the coder's own adaptive contexts: each
//! candidate (the dead-zone levels, each level moved a step where that pays, the same
//! with its last nonzero coefficients dropped, and the empty block) is priced by an
//! [`OverlayCostSink`] (the cost on a copy of the contexts), and the one with the
//! least `D + lambda R` is coded.

use rayon::prelude::*;

use super::dct::{self, COEFFS, N, ZIGZAG};
use super::syntax::{self, DetailContexts};
use super::{block_context, blocks, Detail, DetailPlane};
use crate::codec::entropy::{AnsSink, OverlayCostSink, SymbolSink};

/// Quantiser of one channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quantiser {
    /// Step of every coefficient.
    pub step: f64,
    /// Dead zone: magnitudes round down unless their fraction exceeds `0.5 + deadzone`.
    pub deadzone: f64,
    /// Lagrange multiplier in squared steps per bit.
    pub lambda: f64,
    /// Search each coefficient's level (one step either way) by rate and distortion,
    /// not only the block's trailing coefficients.
    pub per_coefficient: bool,
}

/// Most trailing coefficients the search tries dropping.
const TRIMS: usize = 4;

/// Level of coefficient `c` under `q`.
#[inline]
fn level(c: f64, q: Quantiser) -> i32 {
    let m = (c.abs() / q.step + 0.5 - q.deadzone).floor().max(0.0);
    (m.min(syntax::MAX_LEVEL as f64) as i32) * if c < 0.0 { -1 } else { 1 }
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

/// Squared error of `levels` against the coefficients, in squared steps.
fn distortion(c: &[f64; COEFFS], levels: &[i32; COEFFS], step: f64) -> f64 {
    c.iter()
        .zip(levels)
        .map(|(&c, &l)| (c / step - l as f64).powi(2))
        .sum()
}

/// Visits the coded coefficients from the last one back to the first and moves each
/// level one step towards zero, or away from it where rounding fell short by more than
/// half a step, when that lowers `D + lambda R` of the whole block (`price`): the
/// rate of a level depends on its neighbours' through the contexts, so a level that
/// rounds nearest can still cost more than it saves (rate-distortion optimised
/// quantisation).
fn search_levels(
    c: &[f64; COEFFS],
    q: Quantiser,
    start: (f64, [i32; COEFFS]),
    price: &mut impl FnMut(&[i32; COEFFS]) -> f64,
) -> (f64, [i32; COEFFS]) {
    let (mut best, mut levels) = start;
    for k in (0..COEFFS).rev() {
        let z = ZIGZAG[k] as usize;
        let l = levels[z];
        let x = c[z] / q.step;
        let mut candidates = [None, None];
        if l != 0 {
            candidates[0] = Some(l - l.signum());
        }
        if x.abs() - l.unsigned_abs() as f64 > 0.5 && l.unsigned_abs() < syntax::MAX_LEVEL {
            candidates[1] = Some(l + if x < 0.0 { -1 } else { 1 });
        }
        for m in candidates.into_iter().flatten() {
            let mut trial = levels;
            trial[z] = m;
            let j = price(&trial);
            if j < best {
                (best, levels) = (j, trial);
                break;
            }
        }
    }
    (best, levels)
}

/// Transforms, quantises and codes one residual plane (`kind` 0 luma, 1 chroma) into
/// `sink` with the stream's contexts; returns the coded levels.
pub fn code_plane(
    residual: &[f64],
    (width, height): (u32, u32),
    q: Quantiser,
    kind: usize,
    factors: Option<&[f64]>,
    ctx: &mut DetailContexts,
    sink: &mut impl SymbolSink,
) -> DetailPlane {
    let (cols, rows) = blocks(width, height);
    let (w, h) = (width as usize, height as usize);
    let coeffs: Vec<[f64; COEFFS]> = (0..cols * rows)
        .into_par_iter()
        .map(|i| dct::forward(&gather(residual, w, h, i % cols, i / cols)))
        .collect();
    let mut chosen = Vec::with_capacity(cols * rows);
    let mut coded = vec![false; cols * rows];
    let mut cost = OverlayCostSink::default();
    for (i, c) in coeffs.iter().enumerate() {
        let at = block_context(|j| coded[j], cols, i, kind);
        let q = Quantiser {
            step: q.step * factors.map_or(1.0, |f| f[i]),
            ..q
        };
        let levels: [i32; COEFFS] = std::array::from_fn(|k| level(c[k], q));
        let best = if levels.iter().all(|&l| l == 0) {
            levels
        } else {
            let mut price = |l: &[i32; COEFFS]| {
                cost.reset();
                syntax::write_block(ctx, at, l, &mut cost);
                distortion(c, l, q.step) + q.lambda * cost.cost as f64 / 256.0
            };
            let mut best = (price(&levels), levels);
            if q.per_coefficient {
                best = search_levels(c, q, best, &mut price);
            }
            let mut trimmed = best.1;
            let mut tries = 0;
            for k in (0..COEFFS).rev() {
                let z = ZIGZAG[k] as usize;
                if trimmed[z] == 0 {
                    continue;
                }
                if tries == TRIMS {
                    break;
                }
                tries += 1;
                trimmed[z] = 0;
                let j = price(&trimmed);
                if j < best.0 {
                    best = (j, trimmed);
                }
            }
            // The loop stops at the empty block only when there were few enough.
            let empty = [0; COEFFS];
            let j = price(&empty);
            if j < best.0 {
                best = (j, empty);
            }
            best.1
        };
        syntax::write_block(ctx, at, &best, sink);
        coded[i] = best.iter().any(|&l| l != 0);
        chosen.push(best);
    }
    DetailPlane::from_blocks(cols, rows, chosen)
}

/// The detail layer of the colour channels' residuals (Y, or Y, C1, C2), one quantiser
/// per channel, and its section payload.
pub fn code_layer(
    residuals: &[Vec<f64>],
    size: (u32, u32),
    q: &[Quantiser],
    factors: Option<&[f64]>,
) -> (Detail, Vec<u8>) {
    // Luma and chroma are independent streams, coded (and decoded) side by side.
    let (luma, chroma) = rayon::join(
        || {
            let mut sink = AnsSink::new();
            let mut ctx = DetailContexts::default();
            let p = code_plane(&residuals[0], size, q[0], 0, factors, &mut ctx, &mut sink);
            (p, sink.finish())
        },
        || {
            let mut sink = AnsSink::new();
            let mut ctx = DetailContexts::default();
            let planes: Vec<DetailPlane> = (1..residuals.len())
                .map(|c| code_plane(&residuals[c], size, q[c], 1, factors, &mut ctx, &mut sink))
                .collect();
            (planes, sink.finish())
        },
    );
    let mut payload = Vec::with_capacity(4 + luma.1.len() + chroma.1.len());
    payload.extend((luma.1.len() as u32).to_le_bytes());
    payload.extend(&luma.1);
    payload.extend(&chroma.1);
    let detail = Detail {
        planes: std::iter::once(luma.0).chain(chroma.0).collect(),
        steps: q.iter().map(|q| q.step).collect(),
        deblock: None,
        block_steps: None,
    };
    (detail, payload)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_level_search_only_takes_cheaper_blocks_one_step_from_rounding() {
        let q = Quantiser {
            step: 1.0,
            deadzone: 0.2,
            lambda: 0.12,
            per_coefficient: true,
        };
        let mut ctx = DetailContexts::default();
        let mut cost = OverlayCostSink::default();
        let at = super::super::syntax::BlockContext {
            kind: 0,
            neighbours: 1,
        };
        let mut seed = 99u64;
        let mut moved = 0;
        for _ in 0..300 {
            // Coefficients falling off with frequency, as a photograph's residual does.
            let c: [f64; COEFFS] = std::array::from_fn(|i| {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let u = (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                u * 12.0 / (1.0 + (i / N + i % N) as f64)
            });
            let start: [i32; COEFFS] = std::array::from_fn(|k| level(c[k], q));
            let mut price = |l: &[i32; COEFFS]| {
                cost.reset();
                syntax::write_block(&mut ctx, at, l, &mut cost);
                distortion(&c, l, q.step) + q.lambda * cost.cost as f64 / 256.0
            };
            let j0 = price(&start);
            let (j, levels) = search_levels(&c, q, (j0, start), &mut price);
            assert!(j <= j0);
            assert_eq!(j, price(&levels), "the cost returned is the levels' cost");
            for k in 0..COEFFS {
                let nearest = c[k].round() as i32;
                assert!((levels[k] - nearest).abs() <= 1, "{} from {}", levels[k], c[k]);
            }
            moved += usize::from(levels != start);
            syntax::write_block(&mut ctx, at, &levels, &mut AnsSink::new());
        }
        assert!(moved > 30, "the search changes some blocks ({moved} of 300)");
    }
}
