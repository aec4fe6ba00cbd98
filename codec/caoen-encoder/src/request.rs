//! An encode as a person asks for it: a quality and effort, or a rate target given as
//! bits per pixel or as bytes, within a memory budget that the loaded input already
//! spends from. The command line and the Python package both turn their arguments
//! into [`EncodeOptions`] here, so the same request gives the same bytes from either.

use caoen_base::budget::{Limits, DEFAULT_BUDGET};
use caoen_base::metadata::Metadata;
use caoen_decoder::CodecError;

use crate::{EncodeOptions, RateTarget, Resampling};

/// The settings of one encode as a caller names them.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodeRequest {
    /// Quality 0..=100.
    pub quality: f32,
    /// Effort 1..=9.
    pub effort: u8,
    /// Bits per pixel to reach by searching the quality.
    pub target_bpp: Option<f64>,
    /// File size in bytes to reach by searching the quality.
    pub target_size: Option<u64>,
    /// Exact number of luma key points.
    pub keypoints: Option<usize>,
    /// Metadata stored with the image.
    pub metadata: Metadata,
    /// Whether the image may be coded at a smaller size.
    pub resampling: Resampling,
    /// Memory budget of the whole job, the loaded input included.
    pub budget: u64,
}

impl Default for EncodeRequest {
    fn default() -> Self {
        let o = EncodeOptions::default();
        EncodeRequest {
            quality: o.quality,
            effort: o.effort,
            target_bpp: None,
            target_size: None,
            keypoints: o.keypoints,
            metadata: o.metadata,
            resampling: o.resampling,
            budget: DEFAULT_BUDGET,
        }
    }
}

impl EncodeRequest {
    /// The encoder's options for an input that holds `held` bytes of the budget: the
    /// rest is the encoder's. At most one rate target may be given.
    pub fn options(&self, held: u64) -> Result<EncodeOptions, CodecError> {
        let target = match (self.target_bpp, self.target_size) {
            (Some(b), Some(n)) => {
                return Err(CodecError::Parameter {
                    name: "target",
                    value: format!("{b} bpp and {n} bytes"),
                    reason: "give a target in bits per pixel or in bytes, not both",
                })
            }
            (Some(b), None) => Some(RateTarget::BitsPerPixel(b)),
            (None, Some(n)) => Some(RateTarget::Bytes(n)),
            (None, None) => None,
        };
        Ok(EncodeOptions {
            quality: self.quality,
            effort: self.effort,
            target,
            keypoints: self.keypoints,
            metadata: self.metadata.clone(),
            limits: Limits::new(self.budget.saturating_sub(held)),
            resampling: self.resampling,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_targets_are_refused_and_the_input_spends_the_budget() {
        let both = EncodeRequest {
            target_bpp: Some(1.0),
            target_size: Some(1000),
            ..EncodeRequest::default()
        };
        assert!(matches!(
            both.options(0),
            Err(CodecError::Parameter { name: "target", .. })
        ));
        let one = EncodeRequest {
            target_size: Some(1000),
            budget: 100,
            ..EncodeRequest::default()
        };
        let o = one.options(30).unwrap();
        assert_eq!(o.target, Some(RateTarget::Bytes(1000)));
        assert_eq!(o.limits.max_memory, 70);
    }
}
