//! Deblocking defined on the continuous detail layer.
//!
//! Each 8x8 block's cosine series ends at the block's edge, so where a neighbour's
//! series ends at a different value the layer steps. Quantisation makes such steps even
//! where the picture is smooth, and they show as blocks. The decoder removes a step
//! that is small against the plane's quantiser step by adding, on each side, half of it
//! times a ramp that falls from one at the edge to zero `radius` pixels away: both
//! sides then meet at the mean of their edge values. The correction is a function of
//! position like the series itself, so a decode at any size or warp samples the same
//! deblocked layer. Steps larger than the threshold are real edges and fade out of the
//! correction (between one and two thresholds), so the correction stays continuous in
//! the step.

use super::dct::N;

/// `b_0` of the cosine basis, `sqrt(1/8)`: `b_u` at a block's edges is `b_0` or
/// `+-1/2`.
pub const A0: f32 = 0.353_553_38;

/// The deblocking parameters a file stores (header bytes 46 and 47).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Deblock {
    /// Largest step smoothed fully, in hundredths of the plane's quantiser step
    /// (1..=255).
    pub strength: u8,
    /// Reach of the ramp on each side of an edge, in quarter pixels (1..=16).
    pub radius: u8,
}

impl Deblock {
    /// The encoder's setting: steps up to a fifth of the quantiser step, ramps of
    /// two pixels (on photographs, with lapping, the best RGB PSNR, MS-SSIM and
    /// SSIMULACRA2 of the settings tried together; `docs/codec-ablation.md`).
    pub const DEFAULT: Deblock = Deblock {
        strength: 20,
        radius: 8,
    };
    /// Largest radius in quarter pixels: half a block, so a position is near at most
    /// one edge per axis.
    pub const MAX_RADIUS: u8 = (N * 2) as u8;

    /// Whether both fields are in their ranges.
    pub fn is_valid(self) -> bool {
        self.strength >= 1 && (1..=Self::MAX_RADIUS).contains(&self.radius)
    }

    /// The threshold for a plane quantised with `step`.
    pub fn threshold(self, step: f64) -> f32 {
        (step * self.strength as f64 / 100.0) as f32
    }

    /// The ramp's reach in pixels.
    pub fn radius_px(self) -> f64 {
        self.radius as f64 / 4.0
    }
}

/// The part of a step `d` that is smoothed under threshold `t`: all of it up to `t`,
/// fading to none at `2t`.
#[inline]
pub fn gate(d: f32, t: f32) -> f32 {
    let a = d.abs();
    if a <= t {
        d
    } else if a < 2.0 * t {
        d * (2.0 - a / t)
    } else {
        0.0
    }
}

/// The block edge nearest coordinate `p` (pixels) among the `count - 1` inner edges of
/// `count` blocks, if `p` is within `radius` of it: `(edge, weight)`, edge `e` lying
/// between blocks `e - 1` and `e`. The weight is half the ramp, positive before the
/// edge (that side rises by it times the step) and negative after it.
pub fn edge_weight(p: f64, count: usize, radius: f64) -> Option<(usize, f32)> {
    let e = (p / N as f64).round();
    if e < 1.0 || e >= count as f64 {
        return None;
    }
    let s = e * N as f64 - p;
    if s.abs() >= radius {
        return None;
    }
    // A squared ramp: no kink where the correction ends.
    let u = 1.0 - s.abs() / radius;
    let w = (0.5 * u * u) as f32;
    Some((e as usize, if s > 0.0 { w } else { -w }))
}

/// The basis at a block's start (`t = 0`, `end = false`) or end (`t = 8`).
#[inline]
pub fn edge_basis(u: usize, end: bool) -> f32 {
    let a = if u == 0 { A0 } else { 0.5 };
    if end && u % 2 == 1 {
        -a
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::super::dct;
    use super::*;

    #[test]
    fn the_edge_basis_is_the_cosine_basis_at_the_block_edges() {
        let (start, end) = (dct::basis_at(0.0), dct::basis_at(N as f64));
        for u in 0..N {
            assert!((edge_basis(u, false) - start[u]).abs() < 1e-6);
            assert!((edge_basis(u, true) - end[u]).abs() < 1e-6);
        }
    }

    #[test]
    fn the_two_sides_meet_at_the_mean_and_the_ramp_ends_at_the_radius() {
        let (l, w_l) = edge_weight(16.0 - 1e-9, 4, 4.0).unwrap();
        let (r, w_r) = edge_weight(16.0 + 1e-9, 4, 4.0).unwrap();
        assert_eq!((l, r), (2, 2));
        assert!((w_l - 0.5).abs() < 1e-6 && (w_r + 0.5).abs() < 1e-6);
        // Left value a plus w_l (b - a) meets right value b plus w_r (b - a).
        let (a, b) = (0.2f32, 0.3f32);
        assert!((a + w_l * (b - a) - (b + w_r * (b - a))).abs() < 1e-6);
        assert!(edge_weight(12.0, 4, 4.0).is_none());
        assert!(
            edge_weight(4.0, 4, 4.0).is_none(),
            "no edge at the image's border"
        );
        assert!(edge_weight(30.0, 4, 4.0).is_none());
    }

    #[test]
    fn the_gate_is_continuous_and_leaves_large_steps_alone() {
        let t = 0.1;
        assert_eq!(gate(0.05, t), 0.05);
        assert!((gate(0.1, t) - gate(0.1 + 1e-6, t)).abs() < 1e-5);
        assert!(gate(0.2 - 1e-6, t).abs() < 1e-5);
        assert_eq!(gate(-0.3, t), 0.0);
        assert_eq!(gate(-0.05, t), -0.05);
    }

    #[test]
    fn only_valid_parameters_pass() {
        assert!(Deblock::DEFAULT.is_valid());
        assert!(!Deblock {
            strength: 0,
            radius: 4
        }
        .is_valid());
        assert!(!Deblock {
            strength: 10,
            radius: 0
        }
        .is_valid());
        assert!(!Deblock {
            strength: 10,
            radius: 17
        }
        .is_valid());
    }
}
