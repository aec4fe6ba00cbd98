//! Each pixel's class for the classified filters: the activity and direction of the
//! luma's second differences around it.

use super::scaled::{lerp_taps, Interpolated};
use super::{whole_pixels, ACTIVITY_BOUNDS, DIRECTIONS, WINDOW};

/// The class of each pixel of rows `rows` (`rows.len() * w` entries, in `0..CLASSES`)
/// of a plane of `w x h` samples `spacing` coded pixels apart.
///
/// At each pixel the absolute second differences across columns (`h`), rows (`v`)
/// and the two diagonals (`d1` down-right, `d2` down-left) are taken one coded pixel
/// either side, sampled as the filter samples. Each is summed over the window of 5x5
/// pixels at offsets `(round(i / sx), round(j / sy))` output pixels, `i, j` from
/// `-WINDOW` to `WINDOW` coded pixels (at the coded size, the 5x5 pixels around it),
/// positions clamped to the image: down each column, then across. The activity level is
/// the number of [`ACTIVITY_BOUNDS`] at or below `v + h`. The direction is taken from
/// the pair `h, v` where `max(h, v) min(d1, d2) > max(d1, d2) min(h, v)` (its larger
/// sum over its smaller is the greater), else from `d1, d2`, if the pair's larger is
/// more than twice its smaller: 1 where `h > v`, 2 for `v`, 3 where `d1 > d2`, 4 for
/// `d2`; else 0. The class is `5 * level + direction`.
pub fn classify_rows(
    plane: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
    rows: std::ops::Range<usize>,
) -> Vec<u8> {
    // Where a coded pixel is a whole number of output pixels the samples fall on pixels:
    // read directly, they are the interpolation's values exactly.
    classify_sampled(
        plane,
        (w, h),
        (sx, sy),
        rows,
        whole_pixels((1.0 / sx, 1.0 / sy)),
    )
}

/// [`classify_rows`], its samples read directly `whole` output pixels apart (else
/// interpolated).
pub(super) fn classify_sampled(
    plane: &[f32],
    (w, h): (usize, usize),
    (sx, sy): (f64, f64),
    rows: std::ops::Range<usize>,
    whole: Option<(usize, usize)>,
) -> Vec<u8> {
    let native = whole.is_some();
    let window = |s: f64| -> Vec<isize> {
        (-(WINDOW as isize)..=WINDOW as isize)
            .map(|i| (i as f64 / s).round() as isize)
            .collect()
    };
    let (ox, oy) = (window(sx), window(sy));
    let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    // The sample pairs of h, v, d1, d2, in coded pixels across and down; off the coded
    // size their column taps, at -1, 0 and 1 coded pixel, are tabulated once.
    const PAIRS: [((i32, i32), (i32, i32)); 4] = [
        ((1, 0), (-1, 0)),
        ((0, 1), (0, -1)),
        ((1, 1), (-1, -1)),
        ((-1, 1), (1, -1)),
    ];
    // Off the coded size, rows interpolated at -1, 0 and 1 coded pixel across, kept
    // while the next rows' differences need them.
    let mut rows_at = (!native).then(|| Interpolated::new((w, h), sx, -1..=1, 1.0 / sy));
    let mut diffs = |y: usize| -> [Vec<f32>; 4] {
        let mut d: [Vec<f32>; 4] = std::array::from_fn(|_| vec![0.0f32; w]);
        if let Some((mx, my)) = whole {
            let row = |y: isize| &plane[clamp(y, h) * w..][..w];
            let (up, mid, down) = (
                row(y as isize - my as isize),
                row(y as isize),
                row(y as isize + my as isize),
            );
            let [dh, dv, d1, d2] = &mut d;
            for x in 0..w {
                let (l, r) = (x.saturating_sub(mx), (x + mx).min(w - 1));
                let c = 2.0 * mid[x];
                dh[x] = (c - mid[r] - mid[l]).abs();
                dv[x] = (c - down[x] - up[x]).abs();
                d1[x] = (c - down[r] - up[l]).abs();
                d2[x] = (c - down[l] - up[r]).abs();
            }
            return d;
        }
        let py = y as f64;
        let ys = [-1.0, 0.0, 1.0].map(|a| lerp_taps(py + a / sy, h));
        let centre = &plane[y * w..(y + 1) * w];
        // Whole rows of each pair's two samples, then the differences.
        let (mut a, mut b) = (vec![0.0f32; w], vec![0.0f32; w]);
        let rows_at = rows_at.as_mut().expect("made off the coded size");
        for (k, ((ax, ay), (bx, by))) in PAIRS.into_iter().enumerate() {
            let (ya, yb) = (ys[(ay + 1) as usize], ys[(by + 1) as usize]);
            let [a0, a1, b0, b1] =
                rows_at.rows(plane, [(ax, ya.0), (ax, ya.1), (bx, yb.0), (bx, yb.1)]);
            for ((o, &t), &u) in a.iter_mut().zip(a0).zip(a1) {
                *o = t * (1.0 - ya.2) + u * ya.2;
            }
            for ((o, &t), &u) in b.iter_mut().zip(b0).zip(b1) {
                *o = t * (1.0 - yb.2) + u * yb.2;
            }
            for (((o, &c), &a), &b) in d[k].iter_mut().zip(centre).zip(&a).zip(&b) {
                *o = (2.0 * c - a - b).abs();
            }
        }
        d
    };
    // The rows the window reaches from one output row, kept for the next: at most
    // 2 WINDOW + 1 rows of differences, whatever the scale.
    let mut kept: Vec<(usize, [Vec<f32>; 4])> = Vec::new();
    let pad = ox.iter().map(|o| o.unsigned_abs()).max().unwrap_or(0);
    let mut out = Vec::with_capacity(rows.len() * w);
    // Each difference's column sums, padded by `pad` clamped copies at either end, and
    // its window sums: added in the window's order, so every pixel's sum is the same
    // however its rows are banded.
    let mut column: [Vec<f32>; 4] = std::array::from_fn(|_| vec![0.0f32; w + 2 * pad]);
    let mut sums: [Vec<f32>; 4] = std::array::from_fn(|_| vec![0.0f32; w]);
    for y in rows {
        let reach: Vec<usize> = oy.iter().map(|&o| clamp(y as isize + o, h)).collect();
        kept.retain(|(r, _)| reach.contains(r));
        for &r in &reach {
            if !kept.iter().any(|(k, _)| *k == r) {
                kept.push((r, diffs(r)));
            }
        }
        let line = |r: usize| &kept.iter().find(|(k, _)| *k == r).expect("kept above").1;
        for (k, col) in column.iter_mut().enumerate() {
            let inner = &mut col[pad..pad + w];
            inner.fill(0.0);
            for &r in &reach {
                for (s, v) in inner.iter_mut().zip(&line(r)[k]) {
                    *s += v;
                }
            }
            let (left, right) = (col[pad], col[pad + w - 1]);
            col[..pad].fill(left);
            col[pad + w..].fill(right);
        }
        for (sum, col) in sums.iter_mut().zip(&column) {
            sum.fill(0.0);
            for &o in &ox {
                let start = (pad as isize + o) as usize;
                for (s, v) in sum.iter_mut().zip(&col[start..start + w]) {
                    *s += v;
                }
            }
        }
        let [sh, sv, s1, s2] = &sums;
        for (((&gh, &gv), &g1), &g2) in sh.iter().zip(sv).zip(s1).zip(s2) {
            let level = ACTIVITY_BOUNDS.iter().filter(|&&b| gh + gv >= b).count();
            let (hi_hv, lo_hv) = (gh.max(gv), gh.min(gv));
            let (hi_d, lo_d) = (g1.max(g2), g1.min(g2));
            let direction = if hi_hv * lo_d > hi_d * lo_hv {
                if hi_hv > 2.0 * lo_hv {
                    if gh > gv {
                        1
                    } else {
                        2
                    }
                } else {
                    0
                }
            } else if hi_d > 2.0 * lo_d {
                if g1 > g2 {
                    3
                } else {
                    4
                }
            } else {
                0
            };
            out.push((DIRECTIONS * level + direction) as u8);
        }
    }
    out
}
