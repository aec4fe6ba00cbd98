//! The per-input sums of a network: the scalar `accumulate` over any key points, and
//! the SIMD kernel (pulp) for m = 3 with compact support, tested equal to it.

use pulp::Simd;

use super::Network;

/// `[c, b, w]` of a compact key point, `a F(x . w) = (c + b (x . w - 1))^3`: see
/// [`Gathered`].
pub(super) fn compact_record(a: f64, q: f64, w: &[f64]) -> [f64; 5] {
    let c = if a == 1.0 { 1.0 } else { a.cbrt() };
    let b = c * q * (1.0 / caoen_base::blend::COMPACT_SUPPORT_U);
    [c, b, w[0], w[1], w[2]]
}

impl Network {
    /// Layer 1 and 2 at `x` over the key points `cand`; returns the denominator `sum k_i`.
    #[inline]
    pub(super) fn accumulate(&self, x: &[f64], cand: &[u32], y: &mut [f64]) -> f64 {
        let (m, p) = (self.m, self.p);
        y.fill(0.0);
        let mut denom = 0.0;
        for &i in cand {
            let i = i as usize;
            let w = &self.sources[i * m..(i + 1) * m];
            let s: f64 = x.iter().zip(w).map(|(a, b)| a * b).sum();
            let k = self.weight[i] * self.blend[i].value(s, self.q[i]);
            if k != 0.0 {
                denom += k;
                let t = &self.shapes[i * p..(i + 1) * p];
                for (yj, tj) in y.iter_mut().zip(t) {
                    *yj += k * tj;
                }
            }
        }
        if self.normalised {
            if denom > 0.0 {
                let inv = 1.0 / denom;
                y.iter_mut().for_each(|v| *v *= inv);
            } else {
                y.fill(0.0);
            }
        }
        denom
    }
}

/// Candidate key points of one cell in contiguous arrays (structure of arrays), padded to
/// whole SIMD vectors, so the per-input loop is branch-free and runs in SIMD lanes: the
/// fast path for m = 3 with compact support only; [`Network::accumulate`] is its scalar
/// reference, tested equal to 1e-12.
///
/// The compact kernel with its weight is `a (1 - q (1 - s)/3)^3 = (c + b (s - 1))^3` with
/// `c = a^(1/3)`, `b = c q / 3`, clamped at 0 outside the support. `s - 1` is exact for
/// `s >= 1/2` and never cancels, so this is as accurate as the scalar reference;
/// folding it further into an affine form `alpha + w' . x` would save two operations but
/// cancel terms of size q/3, losing ~q ulps.
#[derive(Default)]
pub(super) struct Gathered {
    c: Vec<f64>,
    b: Vec<f64>,
    wx: Vec<f64>,
    wy: Vec<f64>,
    wz: Vec<f64>,
    /// Shape vectors output-major: `t[j * len + c]`.
    t: Vec<f64>,
    p: usize,
}

impl Gathered {
    /// Loads the candidates (all compact), padded to whole vectors of `S`.
    #[inline(always)]
    pub(super) fn load<S: Simd>(&mut self, _simd: S, net: &Network, cand: &[u32]) {
        let p = net.p;
        // Padding entries have c = b = 0: k = 0 exactly.
        let len = cand.len().div_ceil(S::F64_LANES) * S::F64_LANES;
        let records = &net.compact3[..];
        for (c, v) in [
            &mut self.c,
            &mut self.b,
            &mut self.wx,
            &mut self.wy,
            &mut self.wz,
        ]
        .into_iter()
        .enumerate()
        {
            v.clear();
            v.extend(cand.iter().map(|&i| records[i as usize][c]));
            v.resize(len, 0.0);
        }
        self.t.clear();
        for j in 0..p {
            self.t
                .extend(cand.iter().map(|&i| net.shapes[i as usize * p + j]));
            self.t.resize((j + 1) * len, 0.0);
        }
        self.p = p;
    }

    /// Evaluates the inputs `members` (indices into the block) against the loaded
    /// candidates, two at a time where the output dimension allows.
    #[inline(always)]
    pub(super) fn eval_compact3<S: Simd>(
        &self,
        simd: S,
        normalised: bool,
        xs: &[f64],
        ys: &mut [f64],
        members: impl Iterator<Item = usize>,
    ) {
        match self.p {
            1 => self.pairs::<S, 1>(simd, normalised, xs, ys, members),
            2 => self.pairs::<S, 2>(simd, normalised, xs, ys, members),
            3 => self.pairs::<S, 3>(simd, normalised, xs, ys, members),
            4 => self.pairs::<S, 4>(simd, normalised, xs, ys, members),
            p => {
                for j in members {
                    let den =
                        self.sums_any(simd, &xs[j * 3..j * 3 + 3], &mut ys[j * p..(j + 1) * p]);
                    finish(normalised, den, &mut ys[j * p..(j + 1) * p]);
                }
            }
        }
    }

    #[inline(always)]
    fn pairs<S: Simd, const P: usize>(
        &self,
        simd: S,
        normalised: bool,
        xs: &[f64],
        ys: &mut [f64],
        mut members: impl Iterator<Item = usize>,
    ) {
        let x = |j: usize| -> [f64; 3] { [xs[j * 3], xs[j * 3 + 1], xs[j * 3 + 2]] };
        let mut put = |j: usize, (mut y, den): ([f64; P], f64)| {
            finish(normalised, den, &mut y);
            ys[j * P..(j + 1) * P].copy_from_slice(&y);
        };
        while let Some(a) = members.next() {
            match members.next() {
                Some(b) => {
                    let [ra, rb] = self.sums::<S, P, 2>(simd, [x(a), x(b)]);
                    put(a, ra);
                    put(b, rb);
                }
                None => {
                    let [ra] = self.sums::<S, P, 1>(simd, [x(a)]);
                    put(a, ra);
                }
            }
        }
    }

    /// `y_j = sum_c k_c t_cj` for P outputs and `sum_c k_c`, for N inputs at once (the
    /// candidates' loads are shared; each input's arithmetic is the same for any N).
    #[inline(always)]
    fn sums<S: Simd, const P: usize, const N: usize>(
        &self,
        simd: S,
        x: [[f64; 3]; N],
    ) -> [([f64; P], f64); N] {
        let cs = S::as_simd_f64s(&self.c).0;
        let bs = S::as_simd_f64s(&self.b).0;
        let wx = S::as_simd_f64s(&self.wx).0;
        let wy = S::as_simd_f64s(&self.wy).0;
        let wz = S::as_simd_f64s(&self.wz).0;
        let len = self.c.len();
        let t: [&[S::f64s]; P] =
            std::array::from_fn(|j| S::as_simd_f64s(&self.t[j * len..(j + 1) * len]).0);
        let groups = cs.len();
        assert!(
            bs.len() == groups && wx.len() == groups && wy.len() == groups && wz.len() == groups
        );
        assert!(t.iter().all(|t| t.len() == groups));
        let zero = simd.splat_f64s(0.0);
        let one = simd.splat_f64s(1.0);
        let mut xv = [[zero; 3]; N];
        for n in 0..N {
            for a in 0..3 {
                xv[n][a] = simd.splat_f64s(x[n][a]);
            }
        }
        let mut den = [zero; N];
        let mut acc = [[zero; P]; N];
        for g in 0..groups {
            for n in 0..N {
                let s = simd.mul_f64s(xv[n][2], wz[g]);
                let s = simd.mul_add_e_f64s(xv[n][1], wy[g], s);
                let s = simd.mul_add_e_f64s(xv[n][0], wx[g], s);
                let v = simd.mul_add_e_f64s(bs[g], simd.sub_f64s(s, one), cs[g]);
                let v = simd.max_f64s(v, zero);
                let k = simd.mul_f64s(simd.mul_f64s(v, v), v);
                den[n] = simd.add_f64s(den[n], k);
                for j in 0..P {
                    acc[n][j] = simd.mul_add_e_f64s(k, t[j][g], acc[n][j]);
                }
            }
        }
        let mut out = [([0.0; P], 0.0); N];
        for ((y, d), (acc, den)) in out.iter_mut().zip(acc.iter().zip(den)) {
            for (y, &a) in y.iter_mut().zip(acc) {
                *y = simd.reduce_sum_f64s(a);
            }
            *d = simd.reduce_sum_f64s(den);
        }
        out
    }

    /// [`Self::sums`] for any number of outputs, one input.
    #[inline(always)]
    fn sums_any<S: Simd>(&self, _simd: S, x: &[f64], y: &mut [f64]) -> f64 {
        let len = self.c.len();
        y.fill(0.0);
        let mut den = 0.0;
        for c in 0..len {
            let s = x[0] * self.wx[c] + x[1] * self.wy[c] + x[2] * self.wz[c];
            let v = (self.c[c] + self.b[c] * (s - 1.0)).max(0.0);
            let k = v * v * v;
            den += k;
            for (j, yj) in y.iter_mut().enumerate() {
                *yj += k * self.t[j * len + c];
            }
        }
        den
    }
}

/// Normalises `y` by `den` if the network is normalised (0 where nothing reaches).
#[inline(always)]
fn finish(normalised: bool, den: f64, y: &mut [f64]) {
    if normalised {
        if den > 0.0 {
            let inv = 1.0 / den;
            y.iter_mut().for_each(|v| *v *= inv);
        } else {
            y.fill(0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::batch::block_with;
    use super::super::test_rng::{uniform, unit3};
    use super::*;
    use crate::{Blend, KeyPoint};

    /// The SIMD kernel at every level this CPU has (and plain scalar, what a CPU without
    /// AVX2 runs) equals brute force: n not a multiple of any lane count, weights other
    /// than 1 (cube roots in the kernel's form) and 0, inputs reached by no key point,
    /// every output dimension of the specialised and the general kernel.
    #[test]
    fn simd_kernel_equals_brute_force_at_every_level() {
        let mut st = 5;
        for (n, p) in [(1usize, 1usize), (7, 2), (13, 3), (61, 4), (203, 5), (9, 7)] {
            let kps: Vec<KeyPoint> = (0..n)
                .map(|i| {
                    let mut k = KeyPoint::new(
                        unit3(&mut st),
                        (0..p).map(|_| uniform(&mut st) - 0.5).collect(),
                        Blend::Compact,
                        20.0 + 200.0 * uniform(&mut st),
                    );
                    k.weight = [1.0, 0.0, 0.3, 2.5][i % 4];
                    k
                })
                .collect();
            for normalised in [true, false] {
                let net = Network::new(3, p, &kps, normalised).unwrap();
                // Unordered inputs plus a far-away one: many reach no key point at all.
                let mut xs: Vec<f64> = (0..501).flat_map(|_| unit3(&mut st)).collect();
                xs.extend([5.0, -7.0, 9.0]);
                let brute: Vec<f64> = xs
                    .chunks_exact(3)
                    .flat_map(|x| net.eval_brute_force(x).unwrap())
                    .collect();
                assert!(brute.iter().filter(|v| **v == 0.0).count() > 0);
                let scalar = block_with(pulp::Scalar::new(), &net, &xs);
                let dispatched = net.eval_batch(&xs).unwrap();
                #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
                let v3 = pulp::x86::V3::try_new().map(|s| block_with(s, &net, &xs));
                #[cfg(not(any(target_arch = "x86", target_arch = "x86_64")))]
                let v3: Option<Vec<f64>> = None;
                for got in [Some(scalar), Some(dispatched), v3].into_iter().flatten() {
                    for (a, b) in got.iter().zip(&brute) {
                        assert!(
                            (a - b).abs() <= 1e-12 * b.abs().max(1.0),
                            "n={n} p={p}: {a} vs {b}"
                        );
                    }
                }
            }
        }
    }
}
