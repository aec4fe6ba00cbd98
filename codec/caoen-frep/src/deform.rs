//! Deformations and noise (`docs/frep.md`): twist, taper and bend read their operand
//! at a warped point `W(p)` (the gradient is `J^T grad f` with `J` the exact Jacobian of
//! `W`; the bound over a box is the operand's bound over a box holding `W` of the box,
//! so ray casting by interval subdivision stays safe although `W` does not preserve
//! distances), and gradient noise adds `amplitude n(p / scale)`.
//!
//! The noise is Perlin's improved noise (quintic fade, the 12 cube-edge gradients
//! picked by `hash & 15`) with the hash `perm(perm(perm(i) + j) + k)`,
//! `perm(t) = (34 t + 1) t mod 289`: exact in integers held by doubles, so POV-Ray's
//! function language computes the same values.

use super::interval::{Aabb, Interval};

/// A warp of space: the operand is read at `W(p)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Warp {
    /// A turn about the z axis by `rate z` radians: `W = R(-rate z) p`.
    Twist {
        /// Radians per unit of z.
        rate: f64,
    },
    /// x and y scaled by `s(z)`, linear from `scale[0]` at `z[0]` to `scale[1]` at
    /// `z[1]`, constant beyond: `W = (x / s, y / s, z)`.
    Taper {
        /// Where the scale starts and ends changing.
        z: [f64; 2],
        /// The scale at each.
        scale: [f64; 2],
    },
    /// The x axis bent up into the circle of `radius` around `(0, 0, radius)` in the
    /// xz plane: `W = (radius theta, y, radius - rho)` with `rho`, `theta` the distance
    /// from the centre and the angle from straight below it.
    Bend {
        /// The bend's radius (positive: bent towards +z).
        radius: f64,
    },
}

/// `[sin x, cos x]` ranges over an interval.
pub fn sin_cos(a: Interval) -> (Interval, Interval) {
    use std::f64::consts::{FRAC_PI_2, PI, TAU};
    if !a.is_bounded() || a.hi - a.lo >= TAU {
        let one = Interval::new(-1.0, 1.0);
        return (one, one);
    }
    let range = |shift: f64| {
        // cos(x - shift): extremes at the ends and at multiples of pi inside.
        let (lo, hi) = (a.lo - shift, a.hi - shift);
        let (mut mn, mut mx) = (lo.cos().min(hi.cos()), lo.cos().max(hi.cos()));
        let first = (lo / PI).ceil() as i64;
        let last = (hi / PI).floor() as i64;
        for k in first..=last {
            let v = if k % 2 == 0 { 1.0 } else { -1.0 };
            mn = mn.min(v);
            mx = mx.max(v);
        }
        // Rounding of the end values: widen by an ulp-scale margin.
        Interval::new((mn - 1e-15).max(-1.0), (mx + 1e-15).min(1.0))
    };
    (range(FRAC_PI_2), range(0.0))
}

impl Warp {
    /// `W(p)` and its Jacobian `dW_i / dp_k`.
    pub fn apply(&self, p: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let [x, y, z] = p;
        match *self {
            Warp::Twist { rate } => {
                let (s, c) = (rate * z).sin_cos();
                let w = [x * c + y * s, -x * s + y * c, z];
                (
                    w,
                    [[c, s, rate * w[1]], [-s, c, -rate * w[0]], [0.0, 0.0, 1.0]],
                )
            }
            Warp::Taper { z: zs, scale } => {
                let (s, ds) = taper_scale(zs, scale, z);
                (
                    [x / s, y / s, z],
                    [
                        [1.0 / s, 0.0, -x * ds / (s * s)],
                        [0.0, 1.0 / s, -y * ds / (s * s)],
                        [0.0, 0.0, 1.0],
                    ],
                )
            }
            Warp::Bend { radius: r } => {
                let b = r - z;
                let rho2 = x * x + b * b;
                let rho = rho2.sqrt();
                if rho.is_nan() || rho <= 0.0 {
                    // The centre of the bend: every direction at once; any finite value.
                    return ([0.0, y, r], [[0.0; 3], [0.0, 1.0, 0.0], [0.0; 3]]);
                }
                (
                    [r * x.atan2(b), y, r - rho],
                    [
                        [r * b / rho2, 0.0, r * x / rho2],
                        [0.0, 1.0, 0.0],
                        [-x / rho, 0.0, b / rho],
                    ],
                )
            }
        }
    }

    /// A box holding `W(p)` for every `p` in `b`.
    pub fn apply_box(&self, b: &Aabb) -> Aabb {
        let [x, y, z] = b.axes();
        let w = match *self {
            Warp::Twist { rate } => {
                let (s, c) = sin_cos(z.scale(rate));
                // |W_xy| = |p_xy|: the turn keeps the distance from the axis.
                let rho = (x.sqr() + y.sqr()).sqrt().hi;
                let disc = Interval::new(-rho, rho);
                [
                    clamp_to(x * c + y * s, disc),
                    clamp_to(y * c - x * s, disc),
                    z,
                ]
            }
            Warp::Taper { z: zs, scale } => {
                // s(z) is monotone in z.
                let (a, c) = (
                    taper_scale(zs, scale, z.lo).0,
                    taper_scale(zs, scale, z.hi).0,
                );
                let inv = Interval::new(a.min(c), a.max(c)).recip();
                [x * inv, y * inv, z]
            }
            Warp::Bend { radius: r } => {
                let bb = Interval::point(r) - z;
                let rho = (x.sqr() + bb.sqr()).sqrt();
                let theta = if bb.lo > 0.0 {
                    // atan2(x, b) with b > 0 is monotone in each argument: the corners.
                    let v = [
                        x.lo.atan2(bb.lo),
                        x.lo.atan2(bb.hi),
                        x.hi.atan2(bb.lo),
                        x.hi.atan2(bb.hi),
                    ];
                    Interval::new(
                        v.iter().cloned().fold(f64::INFINITY, f64::min),
                        v.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
                    )
                } else {
                    Interval::new(-std::f64::consts::PI, std::f64::consts::PI)
                };
                [theta.scale(r), y, Interval::point(r) - rho]
            }
        };
        Aabb {
            lo: w.map(|i| i.lo),
            hi: w.map(|i| i.hi),
        }
    }

    /// A box holding every `p` with `W(p)` in `b` (the deformed operand's box).
    pub fn inverse_box(&self, b: &Aabb) -> Aabb {
        let [x, y, z] = b.axes();
        let p = match *self {
            Warp::Twist { .. } => {
                let rho = (x.sqr() + y.sqr()).sqrt().hi;
                [Interval::new(-rho, rho), Interval::new(-rho, rho), z]
            }
            Warp::Taper { scale, .. } => {
                let s = Interval::new(scale[0].min(scale[1]), scale[0].max(scale[1]));
                [x * s, y * s, z]
            }
            Warp::Bend { radius: r } => {
                // p = centre + (r - W_z) (sin theta, -cos theta) in xz, theta = W_x / r.
                let theta = x.scale(1.0 / r);
                let (s, c) = sin_cos(theta);
                let arm = Interval::point(r) - z;
                [arm * s, y, Interval::point(r) - arm * c]
            }
        };
        Aabb {
            lo: p.map(|i| i.lo),
            hi: p.map(|i| i.hi),
        }
    }
}

fn clamp_to(a: Interval, to: Interval) -> Interval {
    Interval::new(a.lo.max(to.lo), a.hi.min(to.hi))
}

/// A taper's scale at `z` and its slope (zero outside `zs`).
fn taper_scale(zs: [f64; 2], scale: [f64; 2], z: f64) -> (f64, f64) {
    let t = (z - zs[0]) / (zs[1] - zs[0]);
    if t <= 0.0 {
        (scale[0], 0.0)
    } else if t >= 1.0 {
        (scale[1], 0.0)
    } else {
        (
            scale[0] + t * (scale[1] - scale[0]),
            (scale[1] - scale[0]) / (zs[1] - zs[0]),
        )
    }
}

/// Gradient noise `amplitude n(p / scale)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// Added to the function where `n = 1`.
    pub amplitude: f64,
    /// The lattice spacing (the size of a bump).
    pub scale: f64,
    /// Shifts the lattice's hash: another pattern.
    pub seed: u32,
}

/// A bound on `|n|`: each corner's term is at most `|g| |d| = sqrt 2 sqrt 3`, and the
/// weights sum to 1.
pub const NOISE_BOUND: f64 = 2.449_489_742_783_178;
/// A bound on `|grad n|` in lattice units: per axis, the fade's slope (at most 1.875)
/// times twice the corner bound, plus the gradients' largest component, 1.
pub const NOISE_LIPSCHITZ: f64 = 1.732_050_807_568_877_2 * (2.0 * 1.875 * NOISE_BOUND + 1.0);

fn m289(a: f64) -> f64 {
    a - 289.0 * (a / 289.0).floor()
}

fn perm(t: f64) -> f64 {
    m289((34.0 * t + 1.0) * t)
}

/// The lattice hash of a corner, in 0..16.
fn hash(i: f64, j: f64, k: f64) -> f64 {
    let h = perm(m289(perm(m289(perm(m289(i)) + j)) + k));
    h - 16.0 * (h / 16.0).floor()
}

/// Perlin's gradient for hash `h` dotted with `d`, and the gradient itself.
fn grad(h: f64, d: [f64; 3]) -> (f64, [f64; 3]) {
    let mut g = [0.0; 3];
    let u = if h < 8.0 { 0 } else { 1 };
    let v = if h < 4.0 {
        1
    } else if h == 12.0 || h == 14.0 {
        0
    } else {
        2
    };
    let su = if h % 2.0 == 0.0 { 1.0 } else { -1.0 };
    let sv = if (h / 2.0).floor() % 2.0 == 0.0 {
        1.0
    } else {
        -1.0
    };
    g[u] += su;
    g[v] += sv;
    (g[0] * d[0] + g[1] * d[1] + g[2] * d[2], g)
}

fn fade(t: f64) -> (f64, f64) {
    (
        t * t * t * (t * (t * 6.0 - 15.0) + 10.0),
        30.0 * t * t * (t - 1.0) * (t - 1.0),
    )
}

impl Noise {
    /// `amplitude n(p / scale)` and its exact gradient.
    pub fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let q = p.map(|v| v / self.scale);
        let cell = q.map(f64::floor);
        let f = [0, 1, 2].map(|k| q[k] - cell[k]);
        let w = f.map(fade);
        let mut n = 0.0;
        let mut g = [0.0; 3];
        for c in 0..8 {
            let o = [c & 1, c >> 1 & 1, c >> 2 & 1].map(|b| b as f64);
            let h = hash(
                cell[0] + o[0] + f64::from(self.seed),
                cell[1] + o[1],
                cell[2] + o[2],
            );
            let (dot, gv) = grad(h, [0, 1, 2].map(|k| f[k] - o[k]));
            let wk = [0, 1, 2].map(|k| if o[k] == 1.0 { w[k].0 } else { 1.0 - w[k].0 });
            let dk = [0, 1, 2].map(|k| if o[k] == 1.0 { w[k].1 } else { -w[k].1 });
            let weight = wk[0] * wk[1] * wk[2];
            n += weight * dot;
            g[0] += dk[0] * wk[1] * wk[2] * dot + weight * gv[0];
            g[1] += wk[0] * dk[1] * wk[2] * dot + weight * gv[1];
            g[2] += wk[0] * wk[1] * dk[2] * dot + weight * gv[2];
        }
        let k = self.amplitude / self.scale;
        (self.amplitude * n, g.map(|v| k * v))
    }

    /// Bounds of `amplitude n(p / scale)` over a box: the value at the centre plus or
    /// minus the gradient bound times the half-diagonal, within the global bound.
    pub fn interval(&self, b: &Aabb) -> Interval {
        let (centre, half) = (b.centre(), b.half_diagonal());
        let a = self.amplitude.abs();
        let whole = Interval::new(-a * NOISE_BOUND, a * NOISE_BOUND);
        if !half.is_finite() || !centre.iter().all(|v| v.is_finite()) {
            return whole;
        }
        let (v, _) = self.value_gradient(centre);
        let r = a * NOISE_LIPSCHITZ * half / self.scale;
        // 1e-12 relative: the centre value's rounding.
        let slack = 1e-12 * (a + v.abs());
        Interval::new((v - r - slack).max(whole.lo), (v + r + slack).min(whole.hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_ranges_hold_samples() {
        for (lo, hi) in [
            (-0.3, 0.2),
            (1.0, 2.0),
            (3.0, 3.3),
            (-7.0, -4.0),
            (0.0, 6.0),
        ] {
            let (s, c) = sin_cos(Interval::new(lo, hi));
            for i in 0..=100 {
                let x = lo + (hi - lo) * i as f64 / 100.0;
                assert!(s.contains(x.sin()) && c.contains(x.cos()), "{x}");
            }
        }
    }

    #[test]
    fn noise_is_zero_on_the_lattice_and_bounded() {
        let n = Noise {
            amplitude: 1.0,
            scale: 1.0,
            seed: 3,
        };
        assert_eq!(n.value_gradient([2.0, -3.0, 5.0]).0, 0.0);
        let mut most: f64 = 0.0;
        for i in 0..20_000 {
            let t = i as f64 * 0.618_033_988_75;
            let p = [t.sin() * 7.0, (1.3 * t).cos() * 7.0, (0.7 * t).sin() * 7.0];
            most = most.max(n.value_gradient(p).0.abs());
        }
        assert!(most > 0.3 && most <= NOISE_BOUND, "{most}");
    }
}
