//! Seeded gradient ("Perlin-style") noise and fractal sums of it.
//!
//! The lattice gradients come from a stateless integer hash, so evaluation at a
//! point is a pure function of `(seed, x, y)`: no tables, no evaluation order.

#![allow(dead_code)]

use std::f64::consts::{FRAC_1_SQRT_2, SQRT_2};

use crate::rng::{hash2, mix64};

/// 16 unit gradient directions, `(cos, sin)` of `k * 22.5°`, written out as
/// literals so no platform trigonometry is involved.
const GRAD: [(f64, f64); 16] = [
    (1.0, 0.0),
    (0.923_879_532_511_286_7, 0.382_683_432_365_089_8),
    (FRAC_1_SQRT_2, FRAC_1_SQRT_2),
    (0.382_683_432_365_089_8, 0.923_879_532_511_286_7),
    (0.0, 1.0),
    (-0.382_683_432_365_089_8, 0.923_879_532_511_286_7),
    (-FRAC_1_SQRT_2, FRAC_1_SQRT_2),
    (-0.923_879_532_511_286_7, 0.382_683_432_365_089_8),
    (-1.0, 0.0),
    (-0.923_879_532_511_286_7, -0.382_683_432_365_089_8),
    (-FRAC_1_SQRT_2, -FRAC_1_SQRT_2),
    (-0.382_683_432_365_089_8, -0.923_879_532_511_286_7),
    (0.0, -1.0),
    (0.382_683_432_365_089_8, -0.923_879_532_511_286_7),
    (FRAC_1_SQRT_2, -FRAC_1_SQRT_2),
    (0.923_879_532_511_286_7, -0.382_683_432_365_089_8),
];

#[inline]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// A seeded 2-D gradient-noise field.
#[derive(Clone, Copy, Debug)]
pub struct Noise {
    seed: u64,
}

/// The next octave's coordinates: turned by about 37 degrees, scaled by `lacunarity`
/// and shifted by `shift`, so the octaves' lattices do not line up.
fn next_octave(x: f64, y: f64, lacunarity: f64, shift: [f64; 2]) -> (f64, f64) {
    let nx = 0.8 * x - 0.6 * y;
    let ny = 0.6 * x + 0.8 * y;
    (nx * lacunarity + shift[0], ny * lacunarity + shift[1])
}

impl Noise {
    pub fn new(seed: u64) -> Self {
        Noise {
            seed: mix64(seed ^ 0x05EE_D0F4_015E),
        }
    }

    /// Single-octave gradient noise, roughly in `[-1, 1]`, zero on lattice points.
    #[inline]
    pub fn perlin(&self, x: f64, y: f64) -> f64 {
        Self::perlin_seeded(self.seed, x, y)
    }

    #[inline]
    fn perlin_seeded(seed: u64, x: f64, y: f64) -> f64 {
        let xf = x.floor();
        let yf = y.floor();
        let ix = xf as i64;
        let iy = yf as i64;
        let fx = x - xf;
        let fy = y - yf;
        let g = |i: i64, j: i64, dx: f64, dy: f64| {
            let (gx, gy) = GRAD[(hash2(seed, ix + i, iy + j) >> 60) as usize];
            gx * dx + gy * dy
        };
        let n00 = g(0, 0, fx, fy);
        let n10 = g(1, 0, fx - 1.0, fy);
        let n01 = g(0, 1, fx, fy - 1.0);
        let n11 = g(1, 1, fx - 1.0, fy - 1.0);
        let u = fade(fx);
        let v = fade(fy);
        let a = n00 + (n10 - n00) * u;
        let b = n01 + (n11 - n01) * u;
        (a + (b - a) * v) * SQRT_2
    }

    /// Fractal Brownian motion: `octaves` octaves of noise, each rotated and
    /// offset, frequency times `lacunarity`, amplitude times `gain`.
    /// Normalised so the result is roughly in `[-1, 1]`.
    pub fn fbm(&self, x: f64, y: f64, octaves: u32, lacunarity: f64, gain: f64) -> f64 {
        let (mut x, mut y) = (x, y);
        let mut amp = 1.0;
        let mut sum = 0.0;
        let mut norm = 0.0;
        for o in 0..octaves {
            sum += amp * Self::perlin_seeded(self.octave_seed(1, o), x, y);
            norm += amp;
            amp *= gain;
            (x, y) = next_octave(x, y, lacunarity, [17.13, -3.71]);
        }
        sum / norm
    }

    /// The seed of octave `o` of a sum whose octave seeds start at `first`.
    fn octave_seed(&self, first: u64, o: u32) -> u64 {
        self.seed
            .wrapping_add((o as u64 + first).wrapping_mul(0x9E37_79B9_7F4A_7C15))
    }

    /// Standard fBm (lacunarity 2, gain 0.5).
    #[inline]
    pub fn fbm2(&self, x: f64, y: f64, octaves: u32) -> f64 {
        self.fbm(x, y, octaves, 2.0, 0.5)
    }

    /// Ridged multifractal noise in `[0, 1]` (sharp crests, like mountain ridges).
    pub fn ridged(&self, x: f64, y: f64, octaves: u32) -> f64 {
        let (mut x, mut y) = (x, y);
        let mut amp = 0.5;
        let mut sum = 0.0;
        let mut norm = 0.0;
        let mut weight = 1.0;
        for o in 0..octaves {
            let mut n = 1.0 - Self::perlin_seeded(self.octave_seed(101, o), x, y).abs();
            n *= n;
            n *= weight;
            weight = (n * 2.0).clamp(0.0, 1.0);
            sum += n * amp;
            norm += amp;
            amp *= 0.5;
            (x, y) = next_octave(x, y, 2.0, [5.3, 9.1]);
        }
        (sum / norm).clamp(0.0, 1.0)
    }

    /// Turbulence: fBm of the absolute value, in `[0, 1]`-ish.
    pub fn turbulence(&self, x: f64, y: f64, octaves: u32) -> f64 {
        let (mut x, mut y) = (x, y);
        let mut amp = 1.0;
        let mut sum = 0.0;
        let mut norm = 0.0;
        for o in 0..octaves {
            sum += amp * Self::perlin_seeded(self.octave_seed(201, o), x, y).abs();
            norm += amp;
            amp *= 0.5;
            (x, y) = next_octave(x, y, 2.0, [1.7, 4.2]);
        }
        sum / norm
    }

    /// 1-D fBm along a line (used for skylines and ridge profiles).
    #[inline]
    pub fn fbm1(&self, x: f64, octaves: u32) -> f64 {
        self.fbm(x, 0.371, octaves, 2.0, 0.5)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_and_determinism() {
        let n = Noise::new(3);
        let mut lo: f64 = 0.0;
        let mut hi: f64 = 0.0;
        for i in 0..2000 {
            let x = i as f64 * 0.173;
            let y = i as f64 * 0.0917;
            let v = n.perlin(x, y);
            assert_eq!(v, Noise::new(3).perlin(x, y));
            lo = lo.min(v);
            hi = hi.max(v);
            let f = n.fbm2(x, y, 5);
            assert!(f.abs() <= 1.5);
        }
        assert!(lo < -0.4 && hi > 0.4, "{lo} {hi}");
        assert_eq!(n.perlin(3.0, -2.0), 0.0);
    }
}
