//! The plain search [`choose`](super::choose) is tested equal to: every candidate re-coded
//! whole into an [`OverlayCostSink`] and its distortion summed in full.

use super::*;
use caoen_decoder::entropy::OverlayCostSink;

/// The level search of [`choose`] with any pricing.
pub fn search_levels(
    x: &[f64; COEFFS],
    lambda: f64,
    start: (f64, [i32; COEFFS]),
    price: &mut impl FnMut(&[i32; COEFFS]) -> f64,
) -> (f64, [i32; COEFFS]) {
    let (mut best, mut levels) = start;
    for k in (0..COEFFS).rev() {
        let z = ZIGZAG[k] as usize;
        for m in moves(levels[z], x[z], lambda).into_iter().flatten() {
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

pub fn choose(
    c: &[f64; COEFFS],
    q: Quantiser,
    ctx: &mut DetailContexts,
    at: syntax::BlockContext,
    cost: &mut OverlayCostSink,
) -> [i32; COEFFS] {
    let levels: [i32; COEFFS] = std::array::from_fn(|k| level(c[k], q));
    if levels.iter().all(|&l| l == 0) {
        return levels;
    }
    let x: [f64; COEFFS] = std::array::from_fn(|z| c[z] / q.step);
    let mut price = |l: &[i32; COEFFS]| {
        cost.reset();
        syntax::write_block(ctx, at, l, cost);
        distortion(&x, l) + q.lambda * cost.cost as f64 / 256.0
    };
    let mut best = (price(&levels), levels);
    if q.per_coefficient {
        best = search_levels(&x, q.lambda, best, &mut price);
    }
    tail_trims(best.1, |trimmed| {
        let j = price(&trimmed);
        if j < best.0 {
            best = (j, trimmed);
        }
    });
    best.1
}
