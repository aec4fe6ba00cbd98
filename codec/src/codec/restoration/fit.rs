//! The encoder's side: each plane's normal equations against the source, their
//! least-squares taps quantised, and whether those pay for their bits.
//!
//! With `r_d(p) = f(p + d) + f(p - d) - 2 f(p)` and `e(p)` the source minus the decoded
//! colour, the squared error after filtering with weights `w` is
//! `sum e^2 - 2 w.b + w^T A w` for `A = sum r r^T` and `b = sum r e`: the sums decide
//! every candidate's error without another pass over the pixels.

use nalgebra::{DMatrix, DVector};

use super::syntax::tap_bits;
use super::{shape, CHROMA_SHAPE, LUMA_SHAPE, MAX_TAP, TAP_LOG2};

/// One plane's normal equations over the pixels seen.
#[derive(Debug, Clone, PartialEq)]
pub struct Stats {
    k: usize,
    /// `A`, row-major, upper triangle filled.
    a: Vec<f64>,
    b: Vec<f64>,
    /// The squared error before filtering, `sum e^2`.
    pub error: f64,
    /// Pixels seen.
    pub samples: u64,
}

impl Stats {
    /// Empty sums for colour plane `c`'s shape.
    pub fn new(c: usize) -> Self {
        let k = shape(c).len();
        Stats {
            k,
            a: vec![0.0; k * k],
            b: vec![0.0; k],
            error: 0.0,
            samples: 0,
        }
    }

    /// Adds `other`'s sums.
    pub fn add(&mut self, other: &Stats) {
        for (x, y) in self.a.iter_mut().zip(&other.a) {
            *x += y;
        }
        for (x, y) in self.b.iter_mut().zip(&other.b) {
            *x += y;
        }
        self.error += other.error;
        self.samples += other.samples;
    }

    /// Adds rows `rows` of colour plane `c`, stepping `stride` rows: `decoded` is the
    /// whole decoded plane (`w x h`, the coded size) and `source` the source's rows
    /// `rows` of the same plane.
    pub fn accumulate(
        &mut self,
        c: usize,
        decoded: &[f32],
        source: &[f64],
        size: (usize, usize),
        rows: std::ops::Range<usize>,
        stride: usize,
    ) {
        if c == 0 {
            self.accumulate_k::<12>(&LUMA_SHAPE, decoded, source, size, rows, stride);
        } else {
            self.accumulate_k::<6>(&CHROMA_SHAPE, decoded, source, size, rows, stride);
        }
    }

    /// [`Stats::accumulate`] for a shape of `K` offsets, a row at a time: the row's
    /// regressors first, then each product summed along the row in lanes (so the sums
    /// vectorise; their order is fixed, so the result is too).
    fn accumulate_k<const K: usize>(
        &mut self,
        shape: &[(i32, i32); K],
        decoded: &[f32],
        source: &[f64],
        (w, h): (usize, usize),
        rows: std::ops::Range<usize>,
        stride: usize,
    ) {
        let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
        let mut r = vec![0.0f64; K * w];
        let mut e = vec![0.0f64; w];
        for y in rows.clone().step_by(stride.max(1)) {
            let src = &source[(y - rows.start) * w..][..w];
            let centre = &decoded[y * w..][..w];
            for (j, &(dx, dy)) in shape.iter().enumerate() {
                let down = &decoded[clamp(y as isize + dy as isize, h) * w..][..w];
                let up = &decoded[clamp(y as isize - dy as isize, h) * w..][..w];
                let rj = &mut r[j * w..(j + 1) * w];
                // Columns `lo..hi` have both neighbours inside the row; the others clamp.
                let d = dx.unsigned_abs() as usize;
                let (lo, hi) = (d.min(w), w.saturating_sub(d).max(d.min(w)));
                if hi > lo {
                    let (a, b) = if dx >= 0 { (&down[2 * d..], up) } else { (down, &up[2 * d..]) };
                    for (k, x) in (lo..hi).enumerate() {
                        rj[x] = a[k] as f64 + b[k] as f64 - 2.0 * centre[x] as f64;
                    }
                }
                for x in (0..lo).chain(hi..w) {
                    let a = down[clamp(x as isize + dx as isize, w)];
                    let b = up[clamp(x as isize - dx as isize, w)];
                    rj[x] = a as f64 + b as f64 - 2.0 * centre[x] as f64;
                }
            }
            for x in 0..w {
                e[x] = src[x] - centre[x] as f64;
            }
            self.error += dot(&e, &e);
            for i in 0..K {
                let ri = &r[i * w..(i + 1) * w];
                self.b[i] += dot(ri, &e);
                for j in i..K {
                    self.a[i * K + j] += dot(ri, &r[j * w..(j + 1) * w]);
                }
            }
            self.samples += w as u64;
        }
    }

    /// `A` with its lower triangle filled.
    fn matrix(&self) -> DMatrix<f64> {
        let k = self.k;
        DMatrix::from_fn(k, k, |i, j| self.a[i.min(j) * k + i.max(j)])
    }

    /// How much the taps `taps` lower the squared error over the pixels seen.
    pub fn gain(&self, taps: &[i32]) -> f64 {
        let s = (1u32 << TAP_LOG2) as f64;
        let w: Vec<f64> = taps.iter().map(|&t| t as f64 / s).collect();
        let k = self.k;
        let mut quad = 0.0;
        for i in 0..k {
            quad += self.a[i * k + i] * w[i] * w[i];
            for j in i + 1..k {
                quad += 2.0 * self.a[i * k + j] * w[i] * w[j];
            }
        }
        let lin: f64 = w.iter().zip(&self.b).map(|(w, b)| w * b).sum();
        2.0 * lin - quad
    }
}

/// The ridge added to the normal equations' diagonal, relative to its mean.
const RIDGE: f64 = 1e-4;

/// `sum a_i b_i` in eight lanes, then across them.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: f64 = ca.remainder().iter().zip(cb.remainder()).map(|(x, y)| x * y).sum();
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            lanes[l] += x[l] * y[l];
        }
    }
    lanes.iter().sum::<f64>() + tail
}

/// The plane's taps, if any pay: least squares, quantised, then each tap moved a unit
/// either way while that lowers `-gain * scale + bit_cost * bits` (`scale` takes the
/// pixels seen to the whole plane; `bit_cost` is in squared error per bit). `None`
/// when the best taps gain less than their bits cost.
pub fn fit(stats: &Stats, scale: f64, bit_cost: f64) -> Option<Vec<i32>> {
    if stats.samples == 0 {
        return None;
    }
    let k = stats.k;
    let mut a = stats.matrix();
    // A little ridge keeps flat planes (A near singular) from taps that fit noise.
    let ridge = RIDGE * a.trace() / k as f64 + 1e-12;
    for i in 0..k {
        a[(i, i)] += ridge;
    }
    let w = a.cholesky()?.solve(&DVector::from_column_slice(&stats.b));
    let s = (1u32 << TAP_LOG2) as f64;
    let mut taps: Vec<i32> = w
        .iter()
        .map(|&v| (v * s).round().clamp(-MAX_TAP as f64, MAX_TAP as f64) as i32)
        .collect();
    let cost = |t: &[i32]| -stats.gain(t) * scale + bit_cost * t.iter().map(|&v| tap_bits(v) as f64).sum::<f64>();
    let mut best = cost(&taps);
    for _ in 0..2 {
        let mut moved = false;
        for i in 0..k {
            for m in [-1, 1] {
                let mut trial = taps.clone();
                trial[i] = (trial[i] + m).clamp(-MAX_TAP, MAX_TAP);
                let c = cost(&trial);
                if c < best {
                    (best, taps) = (c, trial);
                    moved = true;
                }
            }
        }
        if !moved {
            break;
        }
    }
    // Taps at the end of their range are a fit to noise on a plane with next to no
    // texture; the plane's bit in the section's mask is charged too.
    (best + bit_cost < 0.0 && taps.iter().all(|t| t.abs() < MAX_TAP)).then_some(taps)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::restoration::Restoration;

    fn noise(n: usize, seed: &mut u64) -> Vec<f64> {
        (0..n)
            .map(|_| {
                *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (*seed >> 40) as f64 / (1u64 << 24) as f64 - 0.5
            })
            .collect()
    }

    /// A smooth picture with noise added: the filter that smooths it back must lower
    /// the error by what the sums predict.
    #[test]
    fn the_fitted_filter_lowers_the_error_by_its_predicted_gain() {
        let (w, h) = (64, 48);
        let mut seed = 3;
        let source: Vec<f64> = (0..w * h)
            .map(|i| ((i % w) as f64 * 0.2).sin() * 0.3 + ((i / w) as f64 * 0.15).cos() * 0.2)
            .collect();
        let decoded: Vec<f32> = source
            .iter()
            .zip(noise(w * h, &mut seed))
            .map(|(s, n)| (s + 0.05 * n) as f32)
            .collect();
        for c in [0, 1] {
            let mut stats = Stats::new(c);
            stats.accumulate(c, &decoded, &source, (w, h), 0..h, 1);
            let taps = fit(&stats, 1.0, 1e-6).expect("smoothing noise pays");
            let err = |p: &[f32]| p.iter().zip(&source).map(|(&d, s)| (d as f64 - s).powi(2)).sum::<f64>();
            let before = err(&decoded);
            let mut planes = vec![decoded.clone()];
            let r = Restoration {
                planes: vec![Some(taps.clone())],
            };
            // Plane 0 takes the luma shape; chroma's is checked through plane 1.
            let after = if c == 0 {
                r.apply(&mut planes, (w, h), (1.0, 1.0));
                err(&planes[0])
            } else {
                let mut two = vec![decoded.clone(), decoded.clone()];
                Restoration {
                    planes: vec![None, Some(taps.clone())],
                }
                .apply(&mut two, (w, h), (1.0, 1.0));
                err(&two[1])
            };
            assert!(after < 0.8 * before, "plane {c}: {before} -> {after}");
            let predicted = stats.gain(&taps);
            assert!((before - after - predicted).abs() < 1e-3 * before, "{} vs {predicted}", before - after);
        }
    }

    #[test]
    fn the_sums_are_those_of_the_definition_on_planes_of_every_shape() {
        let mut seed = 17;
        for &(w, h) in &[(1, 1), (1, 6), (2, 5), (5, 2), (6, 7), (9, 4), (23, 11)] {
            let decoded: Vec<f32> = noise(w * h, &mut seed).iter().map(|&v| v as f32).collect();
            let source = noise(w * h, &mut seed);
            for c in [0, 1] {
                let mut stats = Stats::new(c);
                stats.accumulate(c, &decoded, &source, (w, h), 0..h, 1);
                let get = |x: isize, y: isize| decoded[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize] as f64;
                let k = shape(c).len();
                let (mut a, mut b) = (vec![0.0; k * k], vec![0.0; k]);
                for y in 0..h as isize {
                    for x in 0..w as isize {
                        let f = get(x, y);
                        let r: Vec<f64> = shape(c)
                            .iter()
                            .map(|&(dx, dy)| get(x + dx as isize, y + dy as isize) + get(x - dx as isize, y - dy as isize) - 2.0 * f)
                            .collect();
                        let e = source[y as usize * w + x as usize] - f;
                        for i in 0..k {
                            b[i] += r[i] * e;
                            for j in i..k {
                                a[i * k + j] += r[i] * r[j];
                            }
                        }
                    }
                }
                for (x, y) in stats.a.iter().zip(&a).chain(stats.b.iter().zip(&b)) {
                    assert!((x - y).abs() <= 1e-9 * (1.0 + y.abs()), "{w}x{h} plane {c}: {x} vs {y}");
                }
                assert_eq!(stats.samples, (w * h) as u64);
            }
        }
    }

    #[test]
    fn exact_pictures_and_dear_bits_get_no_filter() {
        let (w, h) = (16, 16);
        let source: Vec<f64> = (0..w * h).map(|i| (i % 7) as f64 * 0.1).collect();
        let decoded: Vec<f32> = source.iter().map(|&v| v as f32).collect();
        let mut stats = Stats::new(0);
        stats.accumulate(0, &decoded, &source, (w, h), 0..h, 1);
        assert_eq!(fit(&stats, 1.0, 1e-9), None);
        let mut seed = 5;
        let noisy: Vec<f32> = source.iter().zip(noise(w * h, &mut seed)).map(|(s, n)| (s + 0.01 * n) as f32).collect();
        let mut stats = Stats::new(0);
        stats.accumulate(0, &noisy, &source, (w, h), 0..h, 1);
        assert_eq!(fit(&stats, 1.0, 1e3), None);
    }
}
