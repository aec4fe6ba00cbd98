//! Decoded samples as a canvas takes them. The 8-bit samples are the decoder's own
//! ([`caoen_decoder::decoder::decode_interleaved`]): each channel quantised as `caoen
//! decode` quantises it for an 8-bit PNG, so 16-bit and float files are clipped to
//! `[0, 1]` as their PNG is, at 8 bits.

use caoen_base::raster::{ChannelLayout, SampleFormat};

/// Bits per sample of a sample format.
pub fn bits(format: SampleFormat) -> u32 {
    match format {
        SampleFormat::U8 => 8,
        SampleFormat::U16 => 16,
        SampleFormat::F32 => 32,
    }
}

/// Interleaved samples of `layout` as RGBA: grey repeated into R, G and B, alpha 255
/// where the image has none.
pub fn expand(samples: &[u8], layout: ChannelLayout) -> Vec<u8> {
    let ch = layout.channels();
    let mut out = Vec::with_capacity(samples.len() / ch * 4);
    for p in samples.chunks_exact(ch) {
        let px = match layout {
            ChannelLayout::Grey => [p[0], p[0], p[0], 255],
            ChannelLayout::GreyAlpha => [p[0], p[0], p[0], p[1]],
            ChannelLayout::Rgb => [p[0], p[1], p[2], 255],
            ChannelLayout::Rgba => [p[0], p[1], p[2], p[3]],
        };
        out.extend_from_slice(&px);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_layout_becomes_rgba() {
        assert_eq!(
            expand(&[7, 9], ChannelLayout::Grey),
            [7, 7, 7, 255, 9, 9, 9, 255]
        );
        assert_eq!(expand(&[7, 9], ChannelLayout::GreyAlpha), [7, 7, 7, 9]);
        assert_eq!(expand(&[1, 2, 3], ChannelLayout::Rgb), [1, 2, 3, 255]);
        assert_eq!(expand(&[1, 2, 3, 4], ChannelLayout::Rgba), [1, 2, 3, 4]);
    }
}
