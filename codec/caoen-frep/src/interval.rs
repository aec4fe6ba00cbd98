//! Interval arithmetic: bounds of a function over a box, for safe ray stepping (a ray
//! segment whose box gives an interval entirely below zero cannot meet the solid) and
//! pruning. Every operation returns an interval that contains the true range; it may be
//! wider (the dependency problem), never narrower. NaN never enters: an operation that
//! could produce it widens to the whole line instead.

use std::ops::{Add, Mul, Neg, Sub};

/// A closed interval `[lo, hi]` (possibly infinite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
}

/// The whole real line: what an operation returns when it cannot bound its result.
pub const EVERYTHING: Interval = Interval {
    lo: f64::NEG_INFINITY,
    hi: f64::INFINITY,
};

impl Interval {
    /// `[lo, hi]`; a NaN bound or `lo > hi` gives the whole line.
    pub fn new(lo: f64, hi: f64) -> Self {
        if lo <= hi {
            Interval { lo, hi }
        } else {
            EVERYTHING
        }
    }

    /// The single value `v`.
    pub fn point(v: f64) -> Self {
        Interval::new(v, v)
    }

    /// Whether `v` lies in the interval.
    pub fn contains(&self, v: f64) -> bool {
        self.lo <= v && v <= self.hi
    }

    /// Midpoint and width are finite.
    pub fn is_bounded(&self) -> bool {
        self.lo.is_finite() && self.hi.is_finite()
    }

    /// `x^2`, tight (zero when the interval straddles zero).
    pub fn sqr(self) -> Self {
        let (a, b) = (self.lo * self.lo, self.hi * self.hi);
        if self.lo >= 0.0 {
            Interval::new(a, b)
        } else if self.hi <= 0.0 {
            Interval::new(b, a)
        } else {
            Interval::new(0.0, a.max(b))
        }
    }

    /// `sqrt(max(x, 0))`.
    pub fn sqrt(self) -> Self {
        Interval::new(self.lo.max(0.0).sqrt(), self.hi.max(0.0).sqrt())
    }

    /// `|x|`.
    pub fn abs(self) -> Self {
        if self.lo >= 0.0 {
            self
        } else if self.hi <= 0.0 {
            -self
        } else {
            Interval::new(0.0, (-self.lo).max(self.hi))
        }
    }

    /// `x^e` of `|x|` for `e > 0` (monotone in `|x|`).
    pub fn abs_pow(self, e: f64) -> Self {
        let a = self.abs();
        Interval::new(a.lo.powf(e), a.hi.powf(e))
    }

    /// `min(x, y)`.
    pub fn min(self, o: Self) -> Self {
        Interval::new(self.lo.min(o.lo), self.hi.min(o.hi))
    }

    /// `max(x, y)`.
    pub fn max(self, o: Self) -> Self {
        Interval::new(self.lo.max(o.lo), self.hi.max(o.hi))
    }

    /// `k x` for a finite constant.
    pub fn scale(self, k: f64) -> Self {
        if k >= 0.0 {
            Interval::new(self.lo * k, self.hi * k)
        } else {
            Interval::new(self.hi * k, self.lo * k)
        }
    }

    /// `1 / x` for an interval that does not contain zero; the whole line otherwise.
    pub fn recip(self) -> Self {
        if self.lo > 0.0 || self.hi < 0.0 {
            Interval::new(1.0 / self.hi, 1.0 / self.lo)
        } else {
            EVERYTHING
        }
    }
}

impl Add for Interval {
    type Output = Interval;
    fn add(self, o: Interval) -> Interval {
        Interval::new(self.lo + o.lo, self.hi + o.hi)
    }
}

impl Sub for Interval {
    type Output = Interval;
    fn sub(self, o: Interval) -> Interval {
        Interval::new(self.lo - o.hi, self.hi - o.lo)
    }
}

impl Neg for Interval {
    type Output = Interval;
    fn neg(self) -> Interval {
        Interval::new(-self.hi, -self.lo)
    }
}

impl Mul for Interval {
    type Output = Interval;
    fn mul(self, o: Interval) -> Interval {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        // 0 * inf is NaN: such a product is unbounded.
        if p.iter().any(|v| v.is_nan()) {
            return EVERYTHING;
        }
        Interval::new(
            p.iter().cloned().fold(f64::INFINITY, f64::min),
            p.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        )
    }
}

/// An axis-aligned box of 3-D space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lowest corner.
    pub lo: [f64; 3],
    /// Highest corner.
    pub hi: [f64; 3],
}

impl Aabb {
    /// The box of `lo..hi` (corners in any order).
    pub fn new(a: [f64; 3], b: [f64; 3]) -> Self {
        Aabb {
            lo: [0, 1, 2].map(|k| a[k].min(b[k])),
            hi: [0, 1, 2].map(|k| a[k].max(b[k])),
        }
    }

    /// The three coordinate intervals.
    pub fn axes(&self) -> [Interval; 3] {
        [0, 1, 2].map(|k| Interval::new(self.lo[k], self.hi[k]))
    }

    /// The smallest box holding both.
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            lo: [0, 1, 2].map(|k| self.lo[k].min(o.lo[k])),
            hi: [0, 1, 2].map(|k| self.hi[k].max(o.hi[k])),
        }
    }

    /// The overlap, if any.
    pub fn intersection(&self, o: &Aabb) -> Option<Aabb> {
        let lo = [0, 1, 2].map(|k| self.lo[k].max(o.lo[k]));
        let hi = [0, 1, 2].map(|k| self.hi[k].min(o.hi[k]));
        (0..3).all(|k| lo[k] <= hi[k]).then_some(Aabb { lo, hi })
    }

    /// Grown by `d` on every side.
    pub fn padded(&self, d: f64) -> Aabb {
        Aabb {
            lo: self.lo.map(|v| v - d),
            hi: self.hi.map(|v| v + d),
        }
    }

    /// The centre.
    pub fn centre(&self) -> [f64; 3] {
        [0, 1, 2].map(|k| 0.5 * (self.lo[k] + self.hi[k]))
    }

    /// Half the length of the box's diagonal: how far its corners lie from the centre.
    pub fn half_diagonal(&self) -> f64 {
        (0..3)
            .map(|k| (0.5 * (self.hi[k] - self.lo[k])).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    /// The longest side.
    pub fn longest(&self) -> f64 {
        (0..3).map(|k| self.hi[k] - self.lo[k]).fold(0.0, f64::max)
    }

    /// All three sides finite.
    pub fn is_bounded(&self) -> bool {
        self.lo.iter().chain(&self.hi).all(|v| v.is_finite())
    }

    /// The ray parameters `[t0, t1]` where `origin + t dir` is inside the box, if any.
    pub fn clip_ray(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
        for k in 0..3 {
            if dir[k] == 0.0 {
                if origin[k] < self.lo[k] || origin[k] > self.hi[k] {
                    return None;
                }
                continue;
            }
            let (a, b) = (
                (self.lo[k] - origin[k]) / dir[k],
                (self.hi[k] - origin[k]) / dir[k],
            );
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 <= t1).then_some((t0, t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every operation contains the values it bounds, sampled on a grid.
    #[test]
    fn operations_contain_their_samples() {
        let xs = [
            Interval::new(-2.0, 3.0),
            Interval::new(0.5, 1.5),
            Interval::new(-4.0, -1.0),
        ];
        for a in xs {
            for b in xs {
                for i in 0..=10 {
                    for j in 0..=10 {
                        let x = a.lo + (a.hi - a.lo) * i as f64 / 10.0;
                        let y = b.lo + (b.hi - b.lo) * j as f64 / 10.0;
                        assert!((a + b).contains(x + y));
                        assert!((a - b).contains(x - y));
                        assert!((a * b).contains(x * y));
                        assert!(a.sqr().contains(x * x));
                        assert!(a.abs().contains(x.abs()));
                        assert!(a.min(b).contains(x.min(y)));
                        assert!(a.max(b).contains(x.max(y)));
                        assert!(a.scale(-2.5).contains(-2.5 * x));
                        assert!(a.abs_pow(2.5).contains(x.abs().powf(2.5)));
                        assert!(a.sqrt().contains(x.max(0.0).sqrt()));
                        if !b.contains(0.0) {
                            let r = b.recip();
                            assert!(r.lo <= 1.0 / y + 1e-12 && 1.0 / y - 1e-12 <= r.hi);
                        }
                    }
                }
            }
        }
        assert_eq!(Interval::new(-1.0, 2.0).sqr(), Interval::new(0.0, 4.0));
        assert_eq!(Interval::new(0.0, 1.0).recip(), EVERYTHING);
        assert_eq!(Interval::new(f64::NAN, 1.0), EVERYTHING);
        assert_eq!(EVERYTHING * Interval::point(0.0), EVERYTHING);
    }

    #[test]
    fn ray_clipping() {
        let b = Aabb::new([-1.0; 3], [1.0; 3]);
        assert_eq!(
            b.clip_ray([-3.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            Some((2.0, 4.0))
        );
        assert_eq!(b.clip_ray([-3.0, 2.0, 0.0], [1.0, 0.0, 0.0]), None);
    }
}
