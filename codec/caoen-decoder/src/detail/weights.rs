//! Frequency weights of the detail layer: each coefficient's step grows with its
//! spatial frequency, by a tilt per channel kind.
//!
//! A coefficient at `(u, v)` of a block whose transform spans `2^g` blocks (0: one
//! 8x8 block; 1 and 2: a merged group, whose low 8x8 coefficients are the group's
//! lowest frequencies) has the frequency `(u + v) / 2^g` in cycles per 16 pixels, and
//! its step is the block's step times `1 + t (u + v) / (14 * 2^g)`: 1 at the DC, `1 + t`
//! at an 8x8 block's highest frequency. The structural metrics and the eye weigh the
//! coarse scales of a picture more than its finest, where RGB PSNR weighs all alike.

use super::dct::{COEFFS, N};
use super::syntax::GROUP_LEVELS;

/// A stored tilt byte `b` means `t = b / UNIT`.
pub const UNIT: f64 = 16.0;

/// The tilt of the steps with frequency, per channel kind, as stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrequencyWeights {
    /// Tilt bytes of luma (or grey) and of chroma (`b / 16`).
    pub tilts: [u8; 2],
}

/// Per transform level (`g` 0, 1, 2) the weight of each coefficient (row-major).
pub type WeightTable = [[f64; COEFFS]; GROUP_LEVELS + 1];

/// The weights of a layer without frequency weights: all one.
pub const FLAT: WeightTable = [[1.0; COEFFS]; GROUP_LEVELS + 1];

impl FrequencyWeights {
    /// The tilt `t` of one kind (0 luma, 1 chroma).
    pub fn tilt(&self, kind: usize) -> f64 {
        self.tilts[kind.min(1)] as f64 / UNIT
    }

    /// The weights of one kind (0 luma, 1 chroma) for every transform level.
    pub fn table(&self, kind: usize) -> WeightTable {
        let t = self.tilt(kind);
        std::array::from_fn(|g| {
            std::array::from_fn(|z| {
                let f = (z % N + z / N) as f64;
                1.0 + t * f / (14 * (1 << g)) as f64
            })
        })
    }
}

/// The weight tables of a layer's planes (`planes` colour channels, the first luma).
pub fn plane_tables(weights: Option<FrequencyWeights>, planes: usize) -> Vec<WeightTable> {
    (0..planes)
        .map(|p| weights.map_or(FLAT, |w| w.table(p.min(1))))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tilt_raises_the_steps_linearly_with_frequency_from_one_at_the_dc() {
        let w = FrequencyWeights { tilts: [16, 8] };
        let luma = w.table(0);
        let chroma = w.table(1);
        assert_eq!(luma[0][0], 1.0);
        // The 8x8 block's highest frequency: 1 + t.
        assert!((luma[0][COEFFS - 1] - 2.0).abs() < 1e-12);
        assert!((chroma[0][COEFFS - 1] - 1.5).abs() < 1e-12);
        // (u, v) = (3, 1): 4/14 of the tilt.
        assert!((luma[0][N + 3] - (1.0 + 4.0 / 14.0)).abs() < 1e-12);
        // A merged group's coefficient is at half (quarter) the frequency.
        assert!((luma[1][COEFFS - 1] - 1.5).abs() < 1e-12);
        assert!((luma[2][COEFFS - 1] - 1.25).abs() < 1e-12);
        // Symmetric in u and v.
        assert_eq!(luma[0][2 * N + 5], luma[0][5 * N + 2]);
    }

    #[test]
    fn no_tilt_is_flat() {
        assert_eq!(FrequencyWeights { tilts: [0, 0] }.table(0), FLAT);
        assert_eq!(plane_tables(None, 3), vec![FLAT; 3]);
        let t = plane_tables(Some(FrequencyWeights { tilts: [0, 16] }), 3);
        assert_eq!(t[0], FLAT);
        assert_eq!(t[1], t[2]);
        assert_ne!(t[1], FLAT);
    }
}
