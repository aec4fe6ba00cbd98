//! Blending functions `F(s)` of the first layer, `s = x . w` (paper formulas 4–6).
//!
//! Each function is given with its derivative `F'(s)`, which the exact normals
//! (formula 12) need. Normalisation (formula 6) is a property of the whole network,
//! not of one key point, so it lives with the network (`caoen-surface`).

/// The compact function's support in the reduced variable `u = q (1 - s)`.
///
/// `F` is exactly zero once `u >= COMPACT_SUPPORT_U`, i.e. for `s <= 1 - 3/q`. For unit
/// vectors `u = q |x - w|^2 / 2`, so the support is a ball of chord radius `sqrt(6/q)`.
pub const COMPACT_SUPPORT_U: f64 = 3.0;

/// A first-layer blending function; its sharpness `q` is stored per key point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Blend {
    /// Formula (4): `F(s) = s^q` for `s > 0`, else 0. C1 at `s = 0` only for `q > 1`.
    Power,
    /// Formula (5): `F(s) = exp(q (s - 1))`, a Gaussian of the chord distance with variance `1/q`.
    Exponential,
    /// Compact support: `F(s) = (1 - u/3)^3` for `u = q (1 - s) < 3`, else 0.
    ///
    /// Matches the exponential kernel to first order at `s = 1` (`F(1) = 1`, `F'(1) = q`),
    /// is C2 at the edge of its support (value, first and second derivative vanish
    /// there) and polynomial inside, so it costs no transcendental call. Support:
    /// `x . w > 1 - 3/q`, chord radius `sqrt(6/q)` for unit vectors.
    Compact,
}

impl Blend {
    /// All blending functions, for tests and option listings.
    pub const ALL: [Blend; 3] = [Blend::Power, Blend::Exponential, Blend::Compact];

    /// `F(s)` for sharpness `q`.
    #[inline]
    pub fn value(self, s: f64, q: f64) -> f64 {
        self.value_and_slope(s, q).0
    }

    /// `(F(s), F'(s))` for sharpness `q`.
    #[inline]
    pub fn value_and_slope(self, s: f64, q: f64) -> (f64, f64) {
        match self {
            Blend::Power => {
                if s > 0.0 {
                    let f = s.powf(q);
                    (f, q * f / s)
                } else {
                    (0.0, 0.0)
                }
            }
            Blend::Exponential => {
                let f = (q * (s - 1.0)).exp();
                (f, q * f)
            }
            Blend::Compact => {
                let u = q * (1.0 - s);
                if u < COMPACT_SUPPORT_U {
                    let v = 1.0 - u * (1.0 / COMPACT_SUPPORT_U);
                    (v * v * v, q * v * v)
                } else {
                    (0.0, 0.0)
                }
            }
        }
    }

    /// Whether `F` vanishes outside a bounded set of `s`, so a spatial index applies.
    pub fn has_compact_support(self) -> bool {
        matches!(self, Blend::Compact)
    }

    /// The threshold `s_min` with `F(s) = 0` for all `s <= s_min`, if there is one.
    pub fn support_threshold(self, q: f64) -> Option<f64> {
        match self {
            Blend::Compact => Some(1.0 - COMPACT_SUPPORT_U / q),
            Blend::Power | Blend::Exponential => None,
        }
    }

    /// The `s` at which `F(s) = level` on the increasing branch (`level > 0`).
    ///
    /// Used to bound implicit solids: `sum F_i <= level` implies `x . w_i <= s` for all i.
    pub fn level_set_s(self, level: f64, q: f64) -> f64 {
        match self {
            Blend::Power => level.powf(1.0 / q),
            Blend::Exponential => 1.0 + level.ln() / q,
            Blend::Compact => 1.0 - COMPACT_SUPPORT_U * (1.0 - level.cbrt()) / q,
        }
    }

    /// The name used in surface files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Blend::Power => "power",
            Blend::Exponential => "exponential",
            Blend::Compact => "compact",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compact_is_c2_at_the_support_edge() {
        let q = 7.0;
        let edge = 1.0 - COMPACT_SUPPORT_U / q;
        // Value, slope and second derivative all vanish at the edge: approaching it
        // from inside, each shrinks with the distance h (as h^3, h^2 and h).
        let second = |h: f64| {
            (Blend::Compact.value_and_slope(edge + 2.0 * h, q).1
                - Blend::Compact.value_and_slope(edge + h, q).1)
                / h
        };
        for h in [1e-4, 1e-5, 1e-6] {
            let (f, d) = Blend::Compact.value_and_slope(edge + h, q);
            assert!(
                f < 1e3 * h * h * h && d < 1e2 * h * h,
                "h={h}: value {f} slope {d}"
            );
            // F'' = (2/9) q^3 h near the edge.
            assert!(
                second(h).abs() < q * q * q * h,
                "h={h}: second derivative {}",
                second(h)
            );
        }
        assert_eq!(Blend::Compact.value_and_slope(edge - 1e-9, q), (0.0, 0.0));
    }

    #[test]
    fn compact_matches_exponential_to_first_order_at_the_key_point() {
        for q in [1.0, 4.0, 30.0] {
            let (fc, dc) = Blend::Compact.value_and_slope(1.0, q);
            let (fe, de) = Blend::Exponential.value_and_slope(1.0, q);
            assert_eq!((fc, dc), (fe, de));
        }
    }
}
