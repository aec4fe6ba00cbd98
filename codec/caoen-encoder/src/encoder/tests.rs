//! The activity field through the file, and the reach index against a full scan.

use super::tiles::Reach;
use super::*;
use crate::detail::field;
use crate::geometry::Frame;
use crate::keyset::{KernelParams, MIN_SIGMA_FACTOR};
use crate::rate_control;
use crate::tiling::Tiling;
use caoen_base::metadata::Metadata;
use caoen_base::raster::Raster;
use caoen_decoder::quadtree::random_tree;

/// The field the encoder writes follows the source's local variance, and the
/// decoder reads it back into every block's factor: a flat left half takes finer
/// steps than a noisy right half.
#[test]
fn the_activity_field_follows_the_local_variance_through_the_file() {
    use caoen_base::raster::{ChannelLayout, SampleFormat};
    let (w, h) = (128u32, 64u32);
    let mut rng = caoen_base::rng::Lcg::new(12345);
    let mut noise = || rng.unit_f32();
    let plane: Vec<f32> = (0..w * h)
        .map(|i| {
            let x = i % w;
            if x < w / 2 {
                0.4 + 0.1 * x as f32 / w as f32
            } else {
                0.2 + 0.6 * noise()
            }
        })
        .collect();
    let samples: Vec<f32> = (0..3).flat_map(|_| plane.iter().copied()).collect();
    let img = Raster::new(w, h, ChannelLayout::Rgb, SampleFormat::U8, samples).unwrap();
    let s = rate_control::settings(70.0, 5, None);
    let (bytes, _) = encode_with(&img, &s, &Metadata::default(), 1, |_, _| {}).unwrap();
    let decoded = caoen_decoder::decoder::read(&bytes, 1 << 28).unwrap();
    let adaptive = decoded.header.adaptive.expect("adaptive steps");
    assert_eq!(adaptive.field(), Some(rate_control::FIELD_LOG2));
    let detail = decoded.detail.expect("a detail layer");
    let steps = detail.block_steps.expect("block steps");
    let cols = (w / 8) as usize;
    let exponent = |i: usize| steps.field[i];
    let (flat, busy): (Vec<usize>, Vec<usize>) =
        (0..steps.field.len()).partition(|&i| i % cols < cols / 2);
    // Flat regions without a coded block settle to the cheapest exponent.
    assert!(flat.iter().all(|&i| exponent(i) <= 0), "{:?}", steps.field);
    assert!(busy.iter().all(|&i| exponent(i) > 0), "{:?}", steps.field);
    let mean =
        |set: &[usize]| set.iter().map(|&i| exponent(i) as f64).sum::<f64>() / set.len() as f64;
    // The busy half's variance is about 30 times the flat half's (floored), so the
    // exponents (4 log2 of the step factor) differ by `4 strength log2 30` before
    // rounding, normalising and settling the flat regions; at least half of it shows.
    let strength = rate_control::detail_field(70.0)
        .expect("a field at q70")
        .strength;
    assert!(
        mean(&flat) < 0.0 && mean(&busy) - mean(&flat) > 2.0 * strength * 30f64.log2(),
        "{:?}",
        steps.field
    );
    for i in 0..steps.field.len() {
        let class = steps.steps.factor(steps.classes[i]);
        assert_eq!(steps.factor(i), class * field::factor(exponent(i)));
    }
}
/// A tile's candidates from [`Reach`] are exactly the key points a scan of all of
/// them finds for the tile with and without its margin: the index may only skip
/// key points whose support misses the tile.
#[test]
fn the_reach_index_finds_what_a_full_scan_finds_for_every_tile() {
    let (w, h) = (1700, 1100);
    let tiling = Tiling::choose(w, h);
    assert!(tiling.count() > 4, "several tiles: {}", tiling.count());
    let frame = Frame::new(w, h);
    for (seed, sigma_factor) in [(3, 0.3), (11, 1.2), (29, 3.0)] {
        let (_, cells) = random_tree(w, h, seed, |d| d % 3 != 0);
        let kernel = KernelParams {
            sigma_factor,
            weight_exponent: 1.0,
        };
        let reach = Reach::new(frame, kernel, &cells, &tiling);
        for t in 0..tiling.count() {
            let r = tiling.rect(t);
            for margin in [0, 1] {
                let rect = r.grown(margin, w, h);
                let scan: Vec<usize> = (0..cells.len())
                    .filter(|&i| {
                        let (cx, cy) = cells[i].centre(w, h);
                        let s = sigma_factor.max(MIN_SIGMA_FACTOR) * cells[i].size() as f64;
                        let rr = frame.support_radius(cx, cy, s) + 1.0;
                        cx + rr >= rect.x0 as f64
                            && cx - rr <= (rect.x0 + rect.width) as f64
                            && cy + rr >= rect.y0 as f64
                            && cy - rr <= (rect.y0 + rect.height) as f64
                    })
                    .collect();
                assert!(!scan.is_empty());
                assert_eq!(
                    reach.near(t, rect),
                    scan,
                    "seed {seed}, tile {t}, margin {margin}"
                );
            }
        }
    }
}
