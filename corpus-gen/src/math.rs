//! Platform-independent math.
//!
//! Only IEEE-754 basic operations (`+ - * /`, `sqrt`, `floor`, `abs`, min/max),
//! which are correctly rounded everywhere, are used directly. All transcendental
//! functions go through the `libm` crate (a pure-Rust port of musl), never through
//! std's `f64::sin` & co, whose results depend on the platform's C library.

#![allow(dead_code)]

use std::ops::{Add, Mul, Sub};

pub const PI: f64 = std::f64::consts::PI;
pub const TAU: f64 = std::f64::consts::TAU;

#[inline]
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}
#[inline]
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}
#[inline]
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}
#[inline]
pub fn ln(x: f64) -> f64 {
    libm::log(x)
}
#[inline]
pub fn pow(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}
#[inline]
pub fn acos(x: f64) -> f64 {
    libm::acos(x)
}
#[inline]
pub fn tanh(x: f64) -> f64 {
    libm::tanh(x)
}
/// Square root is correctly rounded by IEEE-754, so std's is deterministic.
#[inline]
pub fn sqrt(x: f64) -> f64 {
    x.sqrt()
}

#[inline]
pub fn clamp01(x: f64) -> f64 {
    x.clamp(0.0, 1.0)
}

#[inline]
pub fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

#[inline]
pub fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let t = clamp01((x - e0) / (e1 - e0));
    t * t * (3.0 - 2.0 * t)
}

#[inline]
pub fn fract(x: f64) -> f64 {
    x - x.floor()
}

/// Linear light to sRGB transfer function (exact formula, via libm `pow`).
#[inline]
pub fn srgb_encode(l: f64) -> f64 {
    let l = clamp01(l);
    if l <= 0.003_130_8 {
        12.92 * l
    } else {
        1.055 * pow(l, 1.0 / 2.4) - 0.055
    }
}

/// sRGB to linear light.
#[inline]
pub fn srgb_decode(v: f64) -> f64 {
    let v = clamp01(v);
    if v <= 0.040_45 {
        v / 12.92
    } else {
        pow((v + 0.055) / 1.055, 2.4)
    }
}

/// Quantise `[0, 1]` to `0..=max` with round-half-up.
#[inline]
pub fn quantize(v: f64, max: u32) -> u32 {
    let q = (clamp01(v) * max as f64 + 0.5).floor();
    q as u32
}

/// An RGB colour (or any 3-vector) in f64.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Col(pub f64, pub f64, pub f64);

impl Col {
    #[inline]
    pub const fn gray(v: f64) -> Col {
        Col(v, v, v)
    }
    /// From 8-bit sRGB hex `0xRRGGBB`, decoded to linear light.
    pub fn hex_linear(rgb: u32) -> Col {
        Col(
            srgb_decode(((rgb >> 16) & 255) as f64 / 255.0),
            srgb_decode(((rgb >> 8) & 255) as f64 / 255.0),
            srgb_decode((rgb & 255) as f64 / 255.0),
        )
    }
    /// From 8-bit hex `0xRRGGBB`, as display values in [0, 1] (no decoding).
    pub fn hex(rgb: u32) -> Col {
        Col(
            ((rgb >> 16) & 255) as f64 / 255.0,
            ((rgb >> 8) & 255) as f64 / 255.0,
            (rgb & 255) as f64 / 255.0,
        )
    }
    #[inline]
    pub fn mix(self, o: Col, t: f64) -> Col {
        Col(
            lerp(self.0, o.0, t),
            lerp(self.1, o.1, t),
            lerp(self.2, o.2, t),
        )
    }
    #[inline]
    pub fn luma(self) -> f64 {
        0.2126 * self.0 + 0.7152 * self.1 + 0.0722 * self.2
    }
    #[inline]
    pub fn clamp01(self) -> Col {
        Col(clamp01(self.0), clamp01(self.1), clamp01(self.2))
    }
    #[inline]
    pub fn mulc(self, o: Col) -> Col {
        Col(self.0 * o.0, self.1 * o.1, self.2 * o.2)
    }
    #[inline]
    pub fn max_c(self) -> f64 {
        self.0.max(self.1).max(self.2)
    }
}

impl Add for Col {
    type Output = Col;
    #[inline]
    fn add(self, o: Col) -> Col {
        Col(self.0 + o.0, self.1 + o.1, self.2 + o.2)
    }
}
impl Sub for Col {
    type Output = Col;
    #[inline]
    fn sub(self, o: Col) -> Col {
        Col(self.0 - o.0, self.1 - o.1, self.2 - o.2)
    }
}
impl Mul<f64> for Col {
    type Output = Col;
    #[inline]
    fn mul(self, s: f64) -> Col {
        Col(self.0 * s, self.1 * s, self.2 * s)
    }
}

/// HSV (all in `[0, 1]`) to RGB, display values.
pub fn hsv(h: f64, s: f64, v: f64) -> Col {
    let h6 = fract(h) * 6.0;
    let i = h6.floor();
    let f = h6 - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 => Col(v, t, p),
        1 => Col(q, v, p),
        2 => Col(p, v, t),
        3 => Col(p, q, v),
        4 => Col(t, p, v),
        _ => Col(v, p, q),
    }
}

/// `x * x` (spelled out: `powi` is not guaranteed bit-identical across targets).
#[inline]
pub fn sq(x: f64) -> f64 {
    x * x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_roundtrip() {
        for i in 0..=255u32 {
            let v = i as f64 / 255.0;
            assert_eq!(quantize(srgb_encode(srgb_decode(v)), 255), i);
        }
    }
}
