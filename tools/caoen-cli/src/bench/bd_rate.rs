//! Bjontegaard deltas (VCEG-M33) with piecewise cubic Hermite (PCHIP) interpolation,
//! as in current JVET/AOM practice (the original fit one cubic polynomial through
//! all points, which can oscillate).
//!
//! - **BD-rate**: the average difference of `ln(rate)` between the two curves as
//!   functions of quality, over the quality interval both cover, reported as the
//!   percentage `100 (exp(avg) - 1)`: negative means the test codec needs fewer
//!   bits than the reference for the same quality.
//! - **BD-PSNR** (BD-quality): the average quality difference as functions of
//!   `ln(rate)` over the rate interval both cover; positive means the test is better.
//! - **BD-rate in a rate window** `[a, b]` ([`bd_rate_window`]): the same average,
//!   over only the quality interval the *reference* curve spans between rates `a` and
//!   `b`. The window is placed on the reference so that every codec compared with it
//!   is measured over the same qualities.
//!
//! Each curve is first reduced to points with strictly increasing rate *and*
//! quality ([`monotone_curve`]): a point that costs more bits than another for no
//! more quality is not on the codec's RD frontier, and PCHIP needs a function.

use std::fmt;

/// One rate-distortion point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RdPoint {
    /// Rate, e.g. bits per pixel (> 0).
    pub rate: f64,
    /// Quality, e.g. PSNR in dB (finite).
    pub quality: f64,
}

/// The points of paired `rates` and `qualities`.
pub fn rd_points(rates: &[f64], qualities: &[f64]) -> Vec<RdPoint> {
    rates
        .iter()
        .zip(qualities)
        .map(|(&rate, &quality)| RdPoint { rate, quality })
        .collect()
}

/// Why a Bjontegaard delta is undefined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BdError {
    /// A curve has fewer than two usable points.
    TooFewPoints,
    /// The curves' ranges do not overlap.
    NoOverlap,
    /// A rate window's quality interval is empty or shorter than [`MIN_WINDOW_SPAN`].
    NarrowWindow,
}

impl fmt::Display for BdError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BdError::TooFewPoints => "fewer than two distinct RD points",
            BdError::NoOverlap => "the curves do not overlap",
            BdError::NarrowWindow => "the rate window covers too little of the overlap",
        })
    }
}

impl std::error::Error for BdError {}

/// Shape-preserving piecewise cubic Hermite interpolation (Fritsch-Carlson; the
/// derivative rules of SciPy's `PchipInterpolator`), with exact integrals.
#[derive(Debug, Clone, PartialEq)]
pub struct Pchip {
    x: Vec<f64>,
    y: Vec<f64>,
    d: Vec<f64>,
}

impl Pchip {
    /// Builds the interpolant through `(x[i], y[i])`; `x` must be strictly
    /// increasing and finite, with at least two points.
    pub fn new(x: &[f64], y: &[f64]) -> Option<Pchip> {
        let n = x.len();
        if n < 2 || y.len() != n || x.windows(2).any(|w| w[1] <= w[0]) {
            return None;
        }
        if x.iter().chain(y).any(|v| !v.is_finite()) {
            return None;
        }
        let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let m: Vec<f64> = (0..n - 1).map(|k| (y[k + 1] - y[k]) / h[k]).collect();
        let mut d = vec![0.0; n];
        if n == 2 {
            d[0] = m[0];
            d[1] = m[0];
        } else {
            for k in 1..n - 1 {
                if m[k - 1] * m[k] > 0.0 {
                    // Weighted harmonic mean of the neighbouring slopes.
                    let w1 = 2.0 * h[k] + h[k - 1];
                    let w2 = h[k] + 2.0 * h[k - 1];
                    d[k] = (w1 + w2) / (w1 / m[k - 1] + w2 / m[k]);
                }
            }
            d[0] = edge(h[0], h[1], m[0], m[1]);
            d[n - 1] = edge(h[n - 2], h[n - 3], m[n - 2], m[n - 3]);
        }
        Some(Pchip {
            x: x.to_vec(),
            y: y.to_vec(),
            d,
        })
    }

    /// Smallest x.
    pub fn start(&self) -> f64 {
        self.x[0]
    }

    /// Largest x.
    pub fn end(&self) -> f64 {
        self.x[self.x.len() - 1]
    }

    /// The segment holding `x` (clamped to the first or last).
    fn segment(&self, x: f64) -> usize {
        let k = self.x.partition_point(|&v| v <= x);
        k.clamp(1, self.x.len() - 1) - 1
    }

    /// The interpolant at `x` (the end segments' cubics extend beyond the data).
    pub fn eval(&self, x: f64) -> f64 {
        let k = self.segment(x);
        let h = self.x[k + 1] - self.x[k];
        let t = (x - self.x[k]) / h;
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * self.y[k]
            + (t3 - 2.0 * t2 + t) * h * self.d[k]
            + (-2.0 * t3 + 3.0 * t2) * self.y[k + 1]
            + (t3 - t2) * h * self.d[k + 1]
    }

    /// Integral of segment `k` from its start to local coordinate `t`.
    fn partial(&self, k: usize, t: f64) -> f64 {
        let h = self.x[k + 1] - self.x[k];
        let (t2, t3, t4) = (t * t, t * t * t, t * t * t * t);
        h * ((t4 / 2.0 - t3 + t) * self.y[k]
            + (t4 / 4.0 - 2.0 * t3 / 3.0 + t2 / 2.0) * h * self.d[k]
            + (t3 - t4 / 2.0) * self.y[k + 1]
            + (t4 / 4.0 - t3 / 3.0) * h * self.d[k + 1])
    }

    /// Integral from the first knot to `x`.
    fn cumulative(&self, x: f64) -> f64 {
        let k = self.segment(x);
        let whole: f64 = (0..k).map(|j| self.partial(j, 1.0)).sum();
        whole + self.partial(k, (x - self.x[k]) / (self.x[k + 1] - self.x[k]))
    }

    /// Exact integral of the interpolant over `[a, b]`.
    pub fn integral(&self, a: f64, b: f64) -> f64 {
        self.cumulative(b) - self.cumulative(a)
    }
}

/// Sign with `sign(0) = 0` (NumPy's, unlike `f64::signum`).
fn sign(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// SciPy's one-sided, shape-preserving end derivative.
fn edge(h0: f64, h1: f64, m0: f64, m1: f64) -> f64 {
    let d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1);
    if sign(d) != sign(m0) {
        0.0
    } else if sign(m0) != sign(m1) && d.abs() > 3.0 * m0.abs() {
        3.0 * m0
    } else {
        d
    }
}

/// The RD frontier of a set of points: sorted by rate, keeping only points whose
/// quality beats every cheaper point (non-finite values and non-positive rates are
/// dropped). The result has strictly increasing rate and quality.
pub fn monotone_curve(points: &[RdPoint]) -> Vec<RdPoint> {
    let mut pts: Vec<RdPoint> = points
        .iter()
        .copied()
        .filter(|p| p.rate > 0.0 && p.rate.is_finite() && p.quality.is_finite())
        .collect();
    // Ties in rate: the better quality first, so it is the one kept.
    pts.sort_by(|a, b| {
        a.rate
            .total_cmp(&b.rate)
            .then(b.quality.total_cmp(&a.quality))
    });
    let mut out: Vec<RdPoint> = Vec::with_capacity(pts.len());
    for p in pts {
        match out.last() {
            Some(last) if p.rate <= last.rate || p.quality <= last.quality => {}
            _ => out.push(p),
        }
    }
    out
}

/// Interpolants of `ln(rate)` over quality and of quality over `ln(rate)`.
fn interpolants(points: &[RdPoint]) -> Result<(Pchip, Pchip), BdError> {
    let c = monotone_curve(points);
    let q: Vec<f64> = c.iter().map(|p| p.quality).collect();
    let lr: Vec<f64> = c.iter().map(|p| p.rate.ln()).collect();
    match (Pchip::new(&q, &lr), Pchip::new(&lr, &q)) {
        (Some(a), Some(b)) => Ok((a, b)),
        _ => Err(BdError::TooFewPoints),
    }
}

/// Common range `[lo, hi]` of two interpolants' abscissae.
fn overlap(reference: &Pchip, test: &Pchip) -> Result<(f64, f64), BdError> {
    let lo = reference.start().max(test.start());
    let hi = reference.end().min(test.end());
    if hi <= lo {
        return Err(BdError::NoOverlap);
    }
    Ok((lo, hi))
}

/// Average difference `test - reference` of two interpolants over `[lo, hi]`.
fn gap_over(reference: &Pchip, test: &Pchip, lo: f64, hi: f64) -> f64 {
    (test.integral(lo, hi) - reference.integral(lo, hi)) / (hi - lo)
}

/// Average difference `test - reference` of two interpolants over their common range.
fn average_gap(reference: &Pchip, test: &Pchip) -> Result<f64, BdError> {
    let (lo, hi) = overlap(reference, test)?;
    Ok(gap_over(reference, test, lo, hi))
}

/// A mean ln-rate gap as a BD-rate percentage.
fn percent(gap: f64) -> f64 {
    (gap.exp() - 1.0) * 100.0
}

/// BD-rate of `test` against `reference`, in percent (negative: `test` saves bits).
pub fn bd_rate(reference: &[RdPoint], test: &[RdPoint]) -> Result<f64, BdError> {
    let (r, _) = interpolants(reference)?;
    let (t, _) = interpolants(test)?;
    Ok(percent(average_gap(&r, &t)?))
}

/// Shortest quality interval (dB) a windowed BD-rate is computed over: below it the
/// average rests on a sliver of the curves, where a point's noise dominates.
pub const MIN_WINDOW_SPAN: f64 = 0.05;

/// BD-rate of `test` against `reference` in the rate window `[lo, hi]` (same units as
/// the points' rates), in percent.
///
/// The window becomes a quality interval on the reference curve: its quality (PCHIP
/// over `ln(rate)`) at `lo` and `hi`, both clamped to the reference's measured rates.
/// That interval, intersected with the two curves' quality overlap, is where the
/// ln-rate gap is averaged, exactly as [`bd_rate`] averages it over the whole
/// overlap. An interval shorter than [`MIN_WINDOW_SPAN`] (or empty: a window beside
/// the reference's rates, or outside the overlap) is [`BdError::NarrowWindow`].
pub fn bd_rate_window(
    reference: &[RdPoint],
    test: &[RdPoint],
    lo: f64,
    hi: f64,
) -> Result<f64, BdError> {
    let (r, r_quality) = interpolants(reference)?;
    let (t, _) = interpolants(test)?;
    let (q_lo, q_hi) = overlap(&r, &t)?;
    // A NaN bound would survive the clamp and then be ignored by `max`/`min`,
    // silently widening the window to the whole overlap.
    if lo.is_nan() || hi.is_nan() {
        return Err(BdError::NarrowWindow);
    }
    let clamp = |rate: f64| rate.ln().clamp(r_quality.start(), r_quality.end());
    // PCHIP keeps the frontier's increasing quality monotone, so the window's ends
    // map to the interval's ends in order.
    let a = r_quality.eval(clamp(lo)).max(q_lo);
    let b = r_quality.eval(clamp(hi)).min(q_hi);
    if b - a < MIN_WINDOW_SPAN {
        return Err(BdError::NarrowWindow);
    }
    Ok(percent(gap_over(&r, &t, a, b)))
}

/// BD-PSNR (BD-quality) of `test` against `reference`, in quality units (dB).
pub fn bd_quality(reference: &[RdPoint], test: &[RdPoint]) -> Result<f64, BdError> {
    let (_, r) = interpolants(reference)?;
    let (_, t) = interpolants(test)?;
    average_gap(&r, &t)
}

/// Quality interpolated at `rate` on a curve (PCHIP in `ln(rate)`), or `None`
/// outside the measured rates: no extrapolation.
pub fn quality_at_rate(points: &[RdPoint], rate: f64) -> Option<f64> {
    let (_, q) = interpolants(points).ok()?;
    let x = rate.ln();
    // A tiny tolerance so a target hit exactly (up to rounding) still counts.
    let eps = 1e-9;
    (x >= q.start() - eps && x <= q.end() + eps).then(|| q.eval(x.clamp(q.start(), q.end())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pchip_reproduces_lines_and_their_integrals() {
        let x = [0.0, 1.0, 3.0, 4.5];
        let y: Vec<f64> = x.iter().map(|v| 2.0 * v - 1.0).collect();
        let p = Pchip::new(&x, &y).unwrap();
        for v in [0.0, 0.3, 1.0, 2.2, 4.5] {
            assert!((p.eval(v) - (2.0 * v - 1.0)).abs() < 1e-12);
        }
        // Integral of 2x - 1 over [0.5, 4] = [x^2 - x] = 12 - (-0.25).
        assert!((p.integral(0.5, 4.0) - 12.25).abs() < 1e-12);
    }

    #[test]
    fn pchip_is_monotone_and_interpolates() {
        let x = [0.0, 1.0, 2.0, 3.0, 4.0];
        let y = [0.0, 0.1, 5.0, 5.1, 5.2];
        let p = Pchip::new(&x, &y).unwrap();
        for (a, b) in x.iter().zip(&y) {
            assert!((p.eval(*a) - b).abs() < 1e-12);
        }
        let mut last = f64::NEG_INFINITY;
        for i in 0..=400 {
            let v = p.eval(i as f64 / 100.0);
            assert!(v >= last - 1e-12, "not monotone at {i}");
            last = v;
        }
    }

    #[test]
    fn frontier_drops_dominated_points() {
        let c = monotone_curve(&rd_points(
            &[1.0, 2.0, 2.0, 3.0, 0.5],
            &[30.0, 29.0, 33.0, 32.0, 25.0],
        ));
        assert_eq!(c, rd_points(&[0.5, 1.0, 2.0], &[25.0, 30.0, 33.0]));
    }

    #[test]
    fn errors() {
        let a = rd_points(&[1.0, 2.0], &[30.0, 35.0]);
        assert_eq!(bd_rate(&a, &a[..1]), Err(BdError::TooFewPoints));
        let b = rd_points(&[1.0, 2.0], &[40.0, 45.0]);
        assert_eq!(bd_rate(&a, &b), Err(BdError::NoOverlap));
        assert_eq!(quality_at_rate(&a, 3.0), None);
        assert!((quality_at_rate(&a, 2.0).unwrap() - 35.0).abs() < 1e-9);
    }

    const RATES: [f64; 5] = [0.11, 0.27, 0.52, 0.95, 1.6];
    const PSNR: [f64; 5] = [26.3, 29.1, 31.6, 34.0, 36.2];
    const WINDOWS: [(f64, f64); 3] = [(0.05, 0.3), (0.3, 0.8), (0.8, 2.0)];

    #[test]
    fn constant_rate_ratio_gives_it_in_every_window() {
        let reference = rd_points(&RATES, &PSNR);
        let scaled: Vec<f64> = RATES.iter().map(|r| r * 1.2).collect();
        let test = rd_points(&scaled, &PSNR);
        for (lo, hi) in WINDOWS {
            let got = bd_rate_window(&reference, &test, lo, hi).unwrap();
            assert!((got - 20.0).abs() < 1e-9, "[{lo}, {hi}]: {got}");
        }
    }

    #[test]
    fn windows_split_the_gap_by_the_reference_rates() {
        // Reference 1 -> 30 dB, 4 -> 40 dB (linear in ln rate: rate 2 is 35 dB); test
        // 2 -> 30 dB, 4 -> 40 dB. The ln-rate gap is ln 2 (40 - q) / 10. Window [1, 2]
        // is [30, 35] dB on the reference, mean gap 0.75 ln 2; window [2, 4] is
        // [35, 40] dB, mean gap 0.25 ln 2. (On the test curve, [1, 2] would be empty.)
        let reference = rd_points(&[1.0, 4.0], &[30.0, 40.0]);
        let test = rd_points(&[2.0, 4.0], &[30.0, 40.0]);
        let low = bd_rate_window(&reference, &test, 1.0, 2.0).unwrap();
        assert!(
            (low - (2f64.powf(0.75) - 1.0) * 100.0).abs() < 1e-10,
            "{low}"
        );
        let high = bd_rate_window(&reference, &test, 2.0, 4.0).unwrap();
        assert!(
            (high - (2f64.powf(0.25) - 1.0) * 100.0).abs() < 1e-10,
            "{high}"
        );
        // Clamped to the reference's rates: a wider window is the same interval.
        let wider = bd_rate_window(&reference, &test, 0.5, 2.0).unwrap();
        assert!((wider - low).abs() < 1e-10, "{wider}");
    }

    #[test]
    fn a_window_over_the_whole_range_is_the_whole_range_bd_rate() {
        let reference = rd_points(
            &[0.12, 0.3, 0.55, 1.4, 2.0],
            &[24.0, 28.5, 31.0, 35.5, 36.2],
        );
        let test = rd_points(&[0.1, 0.2, 0.6, 1.0, 1.8], &[25.0, 27.9, 32.4, 34.0, 36.9]);
        let whole = bd_rate(&reference, &test).unwrap();
        let window = bd_rate_window(&reference, &test, 0.01, 100.0).unwrap();
        assert!((window - whole).abs() < 1e-12, "{window} vs {whole}");
        // A part of it differs: the curves are not a constant ratio apart.
        let part = bd_rate_window(&reference, &test, 0.3, 0.8).unwrap();
        assert!((part - whole).abs() > 1.0, "{part} vs {whole}");
    }

    #[test]
    fn windows_without_a_figure() {
        let reference = rd_points(&[1.0, 4.0], &[30.0, 40.0]);
        let test = rd_points(&[2.0, 4.0], &[30.0, 40.0]);
        // Beside both curves' rates: both ends clamp to the same end.
        for (lo, hi) in [(0.05, 0.3), (5.0, 10.0)] {
            assert_eq!(
                bd_rate_window(&reference, &test, lo, hi),
                Err(BdError::NarrowWindow)
            );
        }
        // Under 0.05 dB: rate 1.002 is 30.014 dB on the reference.
        assert_eq!(
            bd_rate_window(&reference, &test, 1.0, 1.002),
            Err(BdError::NarrowWindow)
        );
        assert!(bd_rate_window(&reference, &test, 1.0, 1.02).is_ok());
        // Inside the reference's rates but outside the PSNR overlap: the test reaches
        // only 32 dB, the window [2, 4] starts at 35.
        let low_test = rd_points(&[1.0, 2.0], &[20.0, 32.0]);
        assert_eq!(
            bd_rate_window(&reference, &low_test, 2.0, 4.0),
            Err(BdError::NarrowWindow)
        );
        assert!(bd_rate_window(&reference, &low_test, 1.0, 2.0).is_ok());
        assert_eq!(
            bd_rate_window(&reference, &test, f64::NAN, 2.0),
            Err(BdError::NarrowWindow)
        );
        assert_eq!(
            bd_rate_window(&reference, &test[..1], 1.0, 2.0),
            Err(BdError::TooFewPoints)
        );
    }
}
