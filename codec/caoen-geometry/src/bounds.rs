//! Axis-aligned boxes as the bounding-volume hierarchies over triangles use them: grown
//! point by point, split along their longest axis, and met by rays or measured from
//! points.

use super::vector::V3;

/// The box `[lo, hi]`; the empty box has inverted infinities, so the first point
/// included sets both corners.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Least corner.
    pub lo: V3,
    /// Greatest corner.
    pub hi: V3,
}

impl Bounds {
    /// The box holding nothing.
    pub const EMPTY: Bounds = Bounds {
        lo: [f64::INFINITY; 3],
        hi: [f64::NEG_INFINITY; 3],
    };

    /// The smallest box holding `points`.
    pub fn of<'a>(points: impl IntoIterator<Item = &'a V3>) -> Bounds {
        let mut b = Bounds::EMPTY;
        for p in points {
            b.include(*p);
        }
        b
    }

    /// Grows the box to hold `p`.
    pub fn include(&mut self, p: V3) {
        *self = self.union(Bounds { lo: p, hi: p });
    }

    /// The smallest box holding both.
    pub fn union(self, other: Bounds) -> Bounds {
        Bounds {
            lo: [0, 1, 2].map(|k| self.lo[k].min(other.lo[k])),
            hi: [0, 1, 2].map(|k| self.hi[k].max(other.hi[k])),
        }
    }

    /// The axis the box is longest along (the last of equals).
    pub fn longest_axis(&self) -> usize {
        (0..3)
            .max_by(|&a, &b| (self.hi[a] - self.lo[a]).total_cmp(&(self.hi[b] - self.lo[b])))
            .unwrap_or(0)
    }

    /// The squared distance from `p` to the box (0 inside).
    pub fn distance2(&self, p: V3) -> f64 {
        (0..3)
            .map(|k| (self.lo[k] - p[k]).max(p[k] - self.hi[k]).max(0.0).powi(2))
            .sum()
    }

    /// Whether the ray `origin + t dir` meets the box at some `t` in `[t_min, t_max]`,
    /// given `inv`, the reciprocal of `dir` per axis (the slab test).
    pub fn meets_ray(&self, origin: V3, inv: V3, t_min: f64, t_max: f64) -> bool {
        let (mut a, mut b) = (t_min, t_max);
        for k in 0..3 {
            if !inv[k].is_finite() {
                // Parallel to the slab: inside it or not at all.
                if origin[k] < self.lo[k] || origin[k] > self.hi[k] {
                    return false;
                }
                continue;
            }
            let t0 = (self.lo[k] - origin[k]) * inv[k];
            let t1 = (self.hi[k] - origin[k]) * inv[k];
            let (n, f) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
            if n > a {
                a = n;
            }
            if f < b {
                b = f;
            }
        }
        a <= b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grows_splits_measures_and_meets_rays() {
        let b = Bounds::of(&[[0.0, 0.0, 0.0], [1.0, 3.0, 2.0]]);
        assert_eq!(b.lo, [0.0; 3]);
        assert_eq!(b.hi, [1.0, 3.0, 2.0]);
        assert_eq!(b.longest_axis(), 1);
        assert_eq!(b.distance2([0.5, 1.0, 1.0]), 0.0);
        assert_eq!(b.distance2([2.0, 3.0, 4.0]), 5.0);
        let u = b.union(Bounds::of(&[[-1.0, 0.0, 0.0]]));
        assert_eq!(u.lo, [-1.0, 0.0, 0.0]);
        assert_eq!(Bounds::EMPTY.union(b), b);
        let inv = [1.0, f64::INFINITY, f64::INFINITY];
        assert!(b.meets_ray([-1.0, 1.0, 1.0], inv, 0.0, 10.0));
        assert!(!b.meets_ray([-1.0, 1.0, 1.0], inv, 0.0, 0.5));
        assert!(!b.meets_ray([-1.0, 5.0, 1.0], inv, 0.0, 10.0));
    }
}
