//! R-functions (Rvachev; as used for F-rep by Pasko and Savchenko): set operations on
//! defining functions `f >= 0`, with their partial derivatives (for exact gradients by
//! the chain rule) and interval extensions (for ray stepping).
//!
//! With `s = sqrt(f1^2 + f2^2 - 2 a f1 f2)` and `a` in [0, 1]:
//!
//! - union `(f1 + f2 + s) / (1 + a)`, intersection `(f1 + f2 - s) / (1 + a)`;
//!   `a = 1` gives `max` and `min` (computed as such, exactly), `a = 0` the smooth
//!   (C1 away from the origin) Rvachev system;
//! - difference `f1 ∧ -f2`;
//! - blending: `R(f1, f2) + a0 / (1 + (f1 / a1)^2 + (f2 / a2)^2)`, a bump of height `a0`
//!   where both functions are near zero (added material for `a0 > 0`, removed for
//!   `a0 < 0`), fading over `a1` and `a2`.
//!
//! Union and intersection increase in both arguments (`|f1 - a f2| <= s` for `a` in
//! [0, 1]), so their interval extension is exact: the values at the interval ends.

use super::interval::Interval;

/// Which set operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SetOp {
    /// Inside either.
    Union,
    /// Inside both.
    Intersection,
    /// Inside the first and not the second.
    Difference,
}

/// `s = sqrt(f1^2 + f2^2 - 2 a f1 f2)`, never NaN (rounding can make the radicand a
/// little negative when `a` is 1 and `f1 = f2`).
fn radical(f1: f64, f2: f64, a: f64) -> f64 {
    (f1 * f1 + f2 * f2 - 2.0 * a * f1 * f2).max(0.0).sqrt()
}

/// R-union or R-intersection of `f1`, `f2` with parameter `a` (`sign` +1 or -1).
fn conj(f1: f64, f2: f64, a: f64, sign: f64) -> f64 {
    if a == 1.0 {
        return if sign > 0.0 { f1.max(f2) } else { f1.min(f2) };
    }
    conj_value(f1, f2, a, sign, radical(f1, f2, a))
}

/// `(f1 + f2 + sign s) / (1 + a)`. Where `f1 + f2` and `sign s` have opposite signs
/// (the union of two negative values, the intersection of two positive ones) the sum
/// cancels, and with one value far larger than the other nothing of the smaller one's
/// digits would be left: there the same number is `2 f1 f2 / (f1 + f2 - sign s)`,
/// since `(f1 + f2)^2 - s^2 = 2 (1 + a) f1 f2`.
fn conj_value(f1: f64, f2: f64, a: f64, sign: f64, s: f64) -> f64 {
    let sum = f1 + f2;
    let product = 2.0 * f1 * f2;
    // An infinite product (an infinite value): the direct form keeps its infinity.
    if sign * sum >= 0.0 || !product.is_finite() {
        (sum + sign * s) / (1.0 + a)
    } else {
        product / (sum - sign * s)
    }
}

/// The value and both partial derivatives of R-union (`sign = 1`) or R-intersection
/// (`sign = -1`).
fn conj_partials(f1: f64, f2: f64, a: f64, sign: f64) -> (f64, f64, f64) {
    if a == 1.0 {
        let first = if sign > 0.0 { f1 > f2 } else { f1 < f2 };
        return match (first, f1 == f2) {
            (_, true) => (f1, 0.5, 0.5),
            (true, false) => (f1, 1.0, 0.0),
            (false, false) => (f2, 0.0, 1.0),
        };
    }
    let s = radical(f1, f2, a);
    let k = 1.0 / (1.0 + a);
    // The value exactly as `conj` computes it.
    let v = conj_value(f1, f2, a, sign, s);
    if s == 0.0 {
        // Both zero: the function is not differentiable there; the symmetric choice.
        return (v, k, k);
    }
    (
        v,
        (1.0 + sign * (f1 - a * f2) / s) * k,
        (1.0 + sign * (f2 - a * f1) / s) * k,
    )
}

/// `op(f1, f2)` with parameter `a` in [0, 1].
pub fn apply(op: SetOp, f1: f64, f2: f64, a: f64) -> f64 {
    match op {
        SetOp::Union => conj(f1, f2, a, 1.0),
        SetOp::Intersection => conj(f1, f2, a, -1.0),
        SetOp::Difference => conj(f1, -f2, a, -1.0),
    }
}

/// `op(f1, f2)` and its partial derivatives `d/df1`, `d/df2`.
pub fn partials(op: SetOp, f1: f64, f2: f64, a: f64) -> (f64, f64, f64) {
    match op {
        SetOp::Union => conj_partials(f1, f2, a, 1.0),
        SetOp::Intersection => conj_partials(f1, f2, a, -1.0),
        SetOp::Difference => {
            let (v, d1, d2) = conj_partials(f1, -f2, a, -1.0);
            (v, d1, -d2)
        }
    }
}

/// The range of `op(f1, f2)` when `f1` and `f2` range over `i1` and `i2` (exact for
/// these monotone functions).
pub fn interval(op: SetOp, i1: Interval, i2: Interval, a: f64) -> Interval {
    let (lo, hi) = match op {
        SetOp::Union | SetOp::Intersection => {
            (apply(op, i1.lo, i2.lo, a), apply(op, i1.hi, i2.hi, a))
        }
        // Increasing in f1, decreasing in f2.
        SetOp::Difference => (apply(op, i1.lo, i2.hi, a), apply(op, i1.hi, i2.lo, a)),
    };
    Interval::new(lo, hi)
}

/// The shape of a blend's added term `a0 / (1 + (f1 / a1)^2 + (f2 / a2)^2)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlendShape {
    /// Height of the blend (positive adds material).
    pub a0: f64,
    /// Fall-off along the first operand's function.
    pub a1: f64,
    /// Fall-off along the second operand's function.
    pub a2: f64,
}

/// The blending term `a0 / (1 + (f1 / a1)^2 + (f2 / a2)^2)` and its partials.
pub fn blend_partials(f1: f64, f2: f64, s: BlendShape) -> (f64, f64, f64) {
    let BlendShape { a0, a1, a2 } = s;
    let (u, v) = (f1 / a1, f2 / a2);
    let d = 1.0 + u * u + v * v;
    let b = a0 / d;
    let g = -2.0 * a0 / (d * d);
    (b, g * u / a1, g * v / a2)
}

/// The range of the blending term over `i1 x i2`.
pub fn blend_interval(i1: Interval, i2: Interval, s: BlendShape) -> Interval {
    let BlendShape { a0, a1, a2 } = s;
    let q = i1.scale(1.0 / a1).sqr() + i2.scale(1.0 / a2).sqr();
    let d = Interval::new(1.0 + q.lo, 1.0 + q.hi);
    d.recip().scale(a0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_one_is_max_and_min_exactly() {
        for (x, y) in [(0.3, -0.7), (1e-300, 2.0), (-5.0, -5.0), (0.1, 0.2)] {
            assert_eq!(apply(SetOp::Union, x, y, 1.0), x.max(y));
            assert_eq!(apply(SetOp::Intersection, x, y, 1.0), x.min(y));
            assert_eq!(apply(SetOp::Difference, x, y, 1.0), x.min(-y));
        }
    }

    #[test]
    fn zero_set_is_the_set_operation() {
        // Sign of the result: union >= 0 iff either is, intersection iff both are.
        for (x, y) in [(0.5, -0.2), (-0.5, -0.2), (0.3, 0.4), (-0.1, 0.9)] {
            for a in [0.0, 0.4, 1.0] {
                assert_eq!(apply(SetOp::Union, x, y, a) >= 0.0, x >= 0.0 || y >= 0.0);
                assert_eq!(
                    apply(SetOp::Intersection, x, y, a) >= 0.0,
                    x >= 0.0 && y >= 0.0
                );
                assert_eq!(
                    apply(SetOp::Difference, x, y, a) >= 0.0,
                    x >= 0.0 && y < 0.0
                );
            }
        }
    }

    #[test]
    fn a_large_value_leaves_the_small_one_its_digits() {
        // As f1 goes to minus infinity the union of two negative values tends to f2, and
        // the intersection of two positive ones likewise; the direct form's sum cancels
        // to rounding noise (0 or positive for this union).
        for a in [0.0, 0.5, 0.9] {
            let u = apply(SetOp::Union, -7.7e16, -3.0, a);
            assert!((u + 3.0).abs() < 1e-9, "union {u} at a = {a}");
            let i = apply(SetOp::Intersection, 7.7e16, 3.0, a);
            assert!((i - 3.0).abs() < 1e-9, "intersection {i} at a = {a}");
            let (v, _, _) = partials(SetOp::Union, -7.7e16, -3.0, a);
            assert_eq!(v, u, "value_gradient's value");
        }
    }
}
