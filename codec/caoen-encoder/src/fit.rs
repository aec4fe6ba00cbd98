//! Shape-vector colours by regularised least squares over all pixels.
//!
//! With `A` the normalised kernel weights (pixels x key points), the colours `c` of one
//! channel minimise `|A c - b|^2 + ridge * sum_i n_i (c_i - prior_i)^2`, where
//! `n_i = sum_p A_pi` is a key point's pixel mass and `prior_i = (A^T b)_i / n_i` its
//! locally averaged colour. The ridge keeps isolated or weakly constrained key points
//! near what they cover. The normal equations are solved by Jacobi-preconditioned
//! conjugate gradients, matrix-free, for several channels at once, warm-started.
//!
//! Every reduction runs over fixed-size chunks in a fixed order, so the result does not
//! depend on the thread count (the encoder's output must not).

use rayon::prelude::*;

use super::keyset::Weights;

/// Reductions are split into chunks of this many values, summed in order.
const CHUNK: usize = 4096;

/// The problem for one key-point set: its weights, key-point masses and the
/// preconditioner's diagonal.
pub struct LeastSquares<'a> {
    a: &'a Weights,
    n: usize,
    mass: Vec<f64>,
    diag: Vec<f64>,
}

/// Fixed-order sum of `f(i)` over `0..len`.
fn det_sum(len: usize, f: impl Fn(usize) -> f64 + Sync) -> f64 {
    let parts: Vec<f64> = (0..len.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| (c * CHUNK..((c + 1) * CHUNK).min(len)).map(&f).sum())
        .collect();
    parts.iter().sum()
}

impl<'a> LeastSquares<'a> {
    /// Prepares the system for `n` key points.
    pub fn new(a: &'a Weights, n: usize) -> Self {
        // Column sums in pixel order: the same sums, in the same order, as over the
        // rows of the transpose.
        let mut mass = vec![0.0; n];
        let mut diag = vec![0.0; n];
        for (&i, &v) in a.col.iter().zip(&a.val) {
            mass[i as usize] += v;
            diag[i as usize] += v * v;
        }
        LeastSquares { a, n, mass, diag }
    }

    /// `A^T u` for `k` interleaved channels.
    ///
    /// Scattered in pixel order, which adds each key point's terms in the order a
    /// transposed matrix would hold them (so the same bits as
    /// `a.transpose(n).apply(u, k, out)`), without building the transpose: at a few
    /// conjugate-gradient steps the transpose cost more than it saved.
    fn apply_t(&self, u: &[f64], k: usize, out: &mut [f64]) {
        match k {
            1 => self.a.scatter_t::<1>(u, out),
            2 => self.a.scatter_t::<2>(u, out),
            3 => self.a.scatter_t::<3>(u, out),
            4 => self.a.scatter_t::<4>(u, out),
            _ => self.a.transpose(self.n).apply(u, k, out),
        }
    }

    /// `A^T A v` for `k` interleaved channels (`ax` is scratch).
    ///
    /// One pass over the matrix: each pixel's `A v` is scattered back as soon as it is
    /// summed, the same sums in the same order as [`Weights::apply`] then
    /// [`LeastSquares::apply_t`], so the same bits, with half the memory traffic.
    fn apply_normal(&self, v: &[f64], k: usize, ax: &mut [f64], out: &mut [f64]) {
        match k {
            1 => self.a.gram::<1>(v, out),
            2 => self.a.gram::<2>(v, out),
            3 => self.a.gram::<3>(v, out),
            4 => self.a.gram::<4>(v, out),
            _ => {
                self.a.apply(v, k, ax);
                self.apply_t(ax, k, out);
            }
        }
    }

    /// `A^T b` of `targets` and the prior made from it, for [`LeastSquares::solve_projected`].
    pub fn project(&self, targets: &[&[f64]]) -> Projection {
        let k = targets.len();
        let b = interleave(targets);
        let mut atb = vec![0.0; self.n * k];
        self.apply_t(&b, k, &mut atb);
        let prior = (0..k)
            .map(|c| {
                (0..self.n)
                    .map(|i| {
                        if self.mass[i] > 0.0 {
                            atb[i * k + c] / self.mass[i]
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect();
        Projection { prior, atb, k }
    }

    /// Solves for the projected targets (one vector per channel), pulled toward the
    /// projection's prior by `ridge` and starting from it, for at most `iterations` CG
    /// steps or until the relative residual is below `tolerance`.
    pub fn solve_projected(
        &self,
        p: &Projection,
        ridge: f64,
        iterations: usize,
        tolerance: f64,
    ) -> Vec<Vec<f64>> {
        let (atb, k, prior) = (&p.atb, p.k, &p.prior);
        let start = prior;
        let n = self.n;
        let pixels = self.a.row_start.len() - 1;
        // rhs = A^T b + ridge * n .* prior
        let mut rhs = atb.to_vec();
        for i in 0..n {
            for c in 0..k {
                rhs[i * k + c] += ridge * self.mass[i] * prior[c][i];
            }
        }
        let precond: Vec<f64> = (0..n)
            .map(|i| 1.0 / (self.diag[i] + ridge * self.mass[i]).max(1e-12))
            .collect();
        let mut x = interleave(&start.iter().map(Vec::as_slice).collect::<Vec<_>>());
        // Only the unfused product (more than four channels) keeps `A v` whole.
        let mut ax = vec![0.0; if k > 4 { pixels * k } else { 0 }];
        let mut scratch = vec![0.0; n * k];
        let apply_m = |v: &[f64], ax: &mut Vec<f64>, out: &mut Vec<f64>| {
            self.apply_normal(v, k, ax, out);
            out.par_chunks_mut(k)
                .zip(v.par_chunks(k))
                .enumerate()
                .for_each(|(i, (o, vi))| {
                    for c in 0..k {
                        o[c] += ridge * self.mass[i] * vi[c];
                    }
                });
        };
        apply_m(&x, &mut ax, &mut scratch);
        let mut r: Vec<f64> = rhs.iter().zip(&scratch).map(|(a, b)| a - b).collect();
        let mut z: Vec<f64> = r
            .iter()
            .enumerate()
            .map(|(j, v)| v * precond[j / k])
            .collect();
        let mut p = z.clone();
        let dot_c = |a: &[f64], b: &[f64], c: usize| det_sum(n, |i| a[i * k + c] * b[i * k + c]);
        let mut rz: Vec<f64> = (0..k).map(|c| dot_c(&r, &z, c)).collect();
        let rhs_norm: Vec<f64> = (0..k)
            .map(|c| dot_c(&rhs, &rhs, c).sqrt().max(1e-300))
            .collect();
        let mut active = vec![true; k];
        for _ in 0..iterations {
            apply_m(&p, &mut ax, &mut scratch);
            for c in 0..k {
                if !active[c] {
                    continue;
                }
                let pap = dot_c(&p, &scratch, c);
                if pap.is_nan() || pap <= 0.0 {
                    active[c] = false;
                    continue;
                }
                let alpha = rz[c] / pap;
                for i in 0..n {
                    x[i * k + c] += alpha * p[i * k + c];
                    r[i * k + c] -= alpha * scratch[i * k + c];
                }
            }
            for c in 0..k {
                if active[c] && dot_c(&r, &r, c).sqrt() < tolerance * rhs_norm[c] {
                    active[c] = false;
                }
            }
            if !active.iter().any(|&a| a) {
                break;
            }
            for (j, zj) in z.iter_mut().enumerate() {
                *zj = r[j] * precond[j / k];
            }
            for c in 0..k {
                if !active[c] {
                    continue;
                }
                let rz_new = dot_c(&r, &z, c);
                let beta = rz_new / rz[c];
                rz[c] = rz_new;
                for i in 0..n {
                    p[i * k + c] = z[i * k + c] + beta * p[i * k + c];
                }
            }
            // Finished channels stop moving.
            for c in 0..k {
                if !active[c] {
                    for i in 0..n {
                        p[i * k + c] = 0.0;
                    }
                }
            }
        }
        (0..k)
            .map(|c| (0..n).map(|i| x[i * k + c]).collect())
            .collect()
    }
}

/// `A^T b` of some targets and the prior made from it.
pub struct Projection {
    /// Locally averaged colours per channel.
    pub prior: Vec<Vec<f64>>,
    atb: Vec<f64>,
    k: usize,
}

fn interleave(planes: &[&[f64]]) -> Vec<f64> {
    let k = planes.len();
    let len = planes.first().map_or(0, |p| p.len());
    let mut out = vec![0.0; len * k];
    for (c, p) in planes.iter().enumerate() {
        for (i, v) in p.iter().enumerate() {
            out[i * k + c] = *v;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use caoen_decoder::geometry::Frame;
    use caoen_decoder::keyset::{KernelParams, KeySet};
    use caoen_decoder::quadtree::TreeShape;

    /// The key points of the quadtree of `(block, min)` log2 sizes split where `split`
    /// says, with kernels of width `sigma`.
    fn key_set(
        (width, height): (u32, u32),
        (block_log2, min_log2): (u8, u8),
        sigma_factor: f64,
        split: impl Fn(&caoen_decoder::Cell) -> bool,
    ) -> KeySet {
        let shape = TreeShape {
            width,
            height,
            block_log2,
            min_log2,
        };
        let params = KernelParams {
            sigma_factor,
            weight_exponent: 1.0,
        };
        KeySet::new(Frame::new(width, height), &shape.walk(split), params)
    }

    #[test]
    fn scattered_transpose_products_equal_the_transpose_bit_for_bit() {
        let (w, h) = (37u32, 29u32);
        let ks = key_set((w, h), (4, 1), 0.5, |c| {
            !(c.x0 / 2 + c.y0 / 3 + c.log2 as u32).is_multiple_of(3)
        });
        let a = ks.pixel_weights();
        let (n, pixels) = (ks.len(), (w * h) as usize);
        let at = a.transpose(n);
        let ls = LeastSquares::new(&a, n);
        for i in 0..n {
            let vals = &at.val[at.row_start[i]..at.row_start[i + 1]];
            assert_eq!(ls.mass[i].to_bits(), vals.iter().sum::<f64>().to_bits());
            let d: f64 = vals.iter().map(|v| v * v).sum();
            assert_eq!(ls.diag[i].to_bits(), d.to_bits());
        }
        for k in 1..=5 {
            let u: Vec<f64> = (0..pixels * k)
                .map(|i| ((i * 7919) % 101) as f64 / 7.0 - 7.0)
                .collect();
            let mut want = vec![0.0; n * k];
            at.apply(&u, k, &mut want);
            let mut got = vec![f64::NAN; n * k];
            ls.apply_t(&u, k, &mut got);
            assert!(
                got.iter()
                    .zip(&want)
                    .all(|(g, w)| g.to_bits() == w.to_bits()),
                "k {k}"
            );
            // The fused normal product against its two halves.
            let v: Vec<f64> = (0..n * k).map(|i| ((i * 31) % 17) as f64 - 8.5).collect();
            let mut av = vec![0.0; pixels * k];
            a.apply(&v, k, &mut av);
            at.apply(&av, k, &mut want);
            let mut scratch = vec![0.0; pixels * k];
            ls.apply_normal(&v, k, &mut scratch, &mut got);
            assert!(
                got.iter()
                    .zip(&want)
                    .all(|(g, w)| g.to_bits() == w.to_bits()),
                "normal product, k {k}"
            );
        }
    }

    #[test]
    fn fit_reproduces_an_image_the_model_can_represent() {
        let (w, h) = (40u32, 24u32);
        let ks = key_set((w, h), (3, 2), 0.45, |c| c.log2 > 2);
        let truth: Vec<f64> = (0..ks.len())
            .map(|i| ((i * 7919) % 13) as f64 / 13.0)
            .collect();
        let img = ks
            .render_per_pixel(std::slice::from_ref(&truth), w, h)
            .remove(0);
        let a = ks.pixel_weights();
        let ls = LeastSquares::new(&a, ks.len());
        let got = ls
            .solve_projected(&ls.project(&[&img]), 0.0, 500, 1e-13)
            .remove(0);
        let err = got
            .iter()
            .zip(&truth)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-6, "max colour error {err}");
    }
}
