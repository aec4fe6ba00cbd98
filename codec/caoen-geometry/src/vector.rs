//! 3-vector operations on plain arrays (they keep the hot loops free of any abstraction
//! the optimiser would have to see through).

/// A point or direction in 3-D space.
pub type V3 = [f64; 3];

/// The bounding box `(lo, hi)` of `points` (inverted infinities when there are none).
pub fn bounds<'a>(points: impl IntoIterator<Item = &'a V3>) -> (V3, V3) {
    let b = super::bounds::Bounds::of(points);
    (b.lo, b.hi)
}

/// The gradient of `f` at `p` by central differences of step `h`: what an exact
/// gradient is checked against.
pub fn central_difference(f: impl Fn(V3) -> f64, p: V3, h: f64) -> V3 {
    [0, 1, 2].map(|k| {
        let (mut a, mut b) = (p, p);
        a[k] += h;
        b[k] -= h;
        (f(a) - f(b)) / (2.0 * h)
    })
}

/// `a + b`.
#[inline]
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a - b`.
#[inline]
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `s a`.
#[inline]
pub fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a . b`.
#[inline]
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a . b` for vectors of any (equal) length.
#[inline]
pub fn dot_n(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `a x b`.
#[inline]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `|a|`.
#[inline]
pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// `a / |a|` by one reciprocal and three products, or the zero vector for a zero (or
/// non-finite) input.
#[inline]
pub fn unit(a: V3) -> V3 {
    let n = norm(a);
    if n > 0.0 && n.is_finite() {
        scale(a, 1.0 / n)
    } else {
        [0.0; 3]
    }
}

/// `a / |a|` by three divisions (correctly rounded per component), or None for a zero
/// or non-finite length.
#[inline]
pub fn try_normalise(a: V3) -> Option<V3> {
    let n = norm(a);
    (n > 0.0 && n.is_finite()).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

/// `a / |a|` by three divisions, or the zero vector for a zero (or non-finite) length.
#[inline]
pub fn normalise(a: V3) -> V3 {
    try_normalise(a).unwrap_or([0.0; 3])
}

/// `a / |a|` in single precision, or `a` itself when its length is zero.
#[inline]
pub fn normalise_f32(a: [f32; 3]) -> [f32; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    if l > 0.0 {
        a.map(|v| v / l)
    } else {
        a
    }
}
