//! From user-facing knobs (quality, effort, rate targets) to encoder settings, and the
//! search that lands a rate target.

use super::colour::ColourBasis;
use super::detail::adaptive::AdaptiveSteps;
use super::detail::deblock::Deblock;
use super::detail::field::FieldSettings;
use super::detail::lapping::Lapping;
use super::detail::weights::FrequencyWeights;
use super::model::ModelSettings;

/// Everything the encoder needs besides the image.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodeSettings {
    /// Tree and fit.
    pub model: ModelSettings,
    /// Quantiser step of the luma-set colour channel (coding space).
    pub step_luma: f64,
    /// Quantiser step of the chroma channels.
    pub step_chroma: f64,
    /// Quantiser step of alpha.
    pub step_alpha: f64,
    /// Dead zone of the predictive quantiser (0: plain rounding of the residual).
    pub deadzone: f64,
    /// Quantiser step of the detail layer's luma coefficients.
    pub detail_step_luma: f64,
    /// Quantiser step of the detail layer's chroma coefficients.
    pub detail_step_chroma: f64,
    /// Dead zone of the detail layer's quantiser.
    pub detail_deadzone: f64,
    /// Lagrange multiplier of the detail layer's block decisions (squared steps per bit).
    pub detail_lambda: f64,
    /// Search every detail coefficient's level by rate and distortion.
    pub detail_search: bool,
    /// Deblocking of the detail layer the file asks of the decoder (none: off).
    pub deblock: Option<Deblock>,
    /// Lapping of the detail layer's block edges (none: off).
    pub lapping: Option<Lapping>,
    /// Detail step factors by network cell size (none: one step per plane).
    pub detail_adaptive: Option<AdaptiveSteps>,
    /// The detail steps' tilt with frequency (none: flat).
    pub detail_weights: Option<FrequencyWeights>,
    /// The activity field the detail steps follow (none: no field; needs
    /// `detail_adaptive`).
    pub detail_field: Option<FieldSettings>,
    /// Code the colour channels in opponent space (else raw RGB on one tree: an
    /// ablation switch only; such files do not decode to the right colours).
    pub decorrelate: bool,
    /// The opponent space of the colour channels.
    pub colour_basis: ColourBasis,
    /// Key point steps that double per cell level below the roots (else one step).
    pub level_steps: bool,
    /// Mean key point area (pixels per luma key point) above which the network's
    /// steps shrink in proportion ([`network_step_factor`]).
    pub sparse_area: f64,
    /// Fit restoration filters to the decoded planes (else none).
    pub restoration: bool,
    /// Choose deringing strengths on the decoded planes (with `restoration`, whose fit
    /// finds them; else none).
    pub deringing: bool,
    /// The image's own size when the source given is a smaller copy of it
    /// (none: the source is the image).
    pub display: Option<(u32, u32)>,
}

/// Detail-layer luma step at quality 0; it falls log-quadratically to
/// `DETAIL_STEP_0 * 10^-2.48` (about 0.005, near-lossless) at quality 100.
pub const DETAIL_STEP_0: f64 = 1.5;
/// Network luma step per detail step: the network carries the low frequencies, whose
/// errors spread over whole cells, so it is quantised finer than the detail layer
/// (measured on the photographs, `docs/codec-ablation.md`, "Network density beside
/// the detail layer": 0.25 against 0.15 gained 0.5 points of BD-rate by RGB PSNR and
/// 1.1 by MS-SSIM and lost 0.7 by SSIMULACRA2; 0.1 lost 1.2 and 1.6, 0.3 gained less).
pub const BASE_STEP_RATIO: f64 = 0.25;
/// Split threshold per squared detail step: a sparser network leaves more to the
/// detail layer, which the structural metrics favour (measured with the step ratio
/// 0.25: 25 against 15 gave 0.2 points of BD-rate by RGB PSNR for 0.6 by MS-SSIM and
/// 0.8 by SSIMULACRA2).
pub const THRESHOLD_RATIO: f64 = 25.0;
/// Chroma step relative to luma in the network at quality 75 (measured on the RD
/// benchmark); [`CHROMA_STEP_TILT`] moves it with the quality.
pub const CHROMA_STEP_RATIO: f64 = 0.7;
/// The network's chroma-to-luma step ratio goes as the detail step to the power
/// `-CHROMA_STEP_TILT`: finer chroma at low qualities, where the network carries most
/// of the colour and coarse chroma steps wash out small coloured features (0.39 at
/// quality 20, 0.93 at 90). Measured on the photographs against a fixed 0.7: 0.2 gained
/// 0.2% BD-rate by PSNR (0.9% below 0.3 bpp) and 1.4% by SSIMULACRA2 and lost 0.3% by
/// MS-SSIM; 0.1 and 0.3 gained less.
pub const CHROMA_STEP_TILT: f64 = 0.2;
/// Chroma step relative to luma in the detail layer: the structural metrics and the
/// eye weigh luma, RGB PSNR all three (measured with the level search and adaptive
/// steps: 1.25 against 1.0 cost 0.7% BD-rate by PSNR and saved 5.5% by MS-SSIM).
pub const DETAIL_CHROMA_RATIO: f64 = 1.25;
/// The detail steps' tilt with frequency, luma and chroma (`b / 16`: the highest
/// frequency of an 8x8 block takes `1 + b/16` times the DC's step). The structural
/// metrics weigh the coarse scales of a picture, RGB PSNR every frequency alike, and
/// MS-SSIM luma alone: chroma's steeper tilt moves bits to luma (measured in
/// `docs/codec-ablation.md`, "Frequency weights and chroma groups", "The balance of
/// luma and chroma" and "The structural metrics' margin": beside the last luma
/// filters, luma 8 against 16 gains 0.5 points of BD-rate by RGB PSNR for 2 of
/// SSIMULACRA2, MS-SSIM level).
pub const DETAIL_WEIGHTS: FrequencyWeights = FrequencyWeights { tilts: [8, 32] };
/// Quality above which the tilt fades, to none at 100: near-lossless coding is judged
/// by its error, which a flat quantiser keeps least for its bits (with the full tilt
/// `-q 100` decoded the photographs at 51.2-52.2 dB instead of 54.6-55.0).
pub const WEIGHTS_FADE_QUALITY: f64 = 75.0;

/// The activity field: detail steps going as a power of the source's luma variance
/// (plus [`FIELD_FLOOR`]) over regions of `2^FIELD_LOG2` pixels, this power at
/// [`FIELD_FULL_QUALITY`]. The structural metrics and the eye weigh an error against the contrast
/// around it, RGB PSNR does not: measured in `docs/codec-ablation.md` ("The activity
/// field"), the strength trades BD-rate by PSNR for BD-rate by MS-SSIM and
/// SSIMULACRA2 along one line. The last luma filters gain MS-SSIM, and this strength
/// spends it on PSNR ("The structural metrics' margin": 0.7 of 0.08 gained about a
/// point of BD-rate by RGB PSNR at 0.3-2 bpp for 1.5 by MS-SSIM).
pub const FIELD_STRENGTH: f64 = 0.056;
/// The activity field's region side, log2 pixels: its exponents cost 1.4-1.8 bits per
/// region; 8-pixel regions cost more than they gain, 32-pixel ones gain less.
pub const FIELD_LOG2: u8 = 4;
/// The variance below which regions count as flat alike: SSIM's contrast constant
/// `(0.03)^2` on a [0, 1] scale.
pub const FIELD_FLOOR: f64 = 0.0009;
/// Quality up to which the encoder codes no field: at the lowest rates its bits are a
/// tenth of the file, and the structural metrics are well ahead there without it.
pub const FIELD_FROM_QUALITY: f64 = 40.0;
/// Quality at which the field reaches [`FIELD_STRENGTH`]: a slow rise leaves the rates
/// of 0.3-0.5 bpp (about q55-65 on photographs) to PSNR, where caoen is closest to
/// AVIF, and [`FIELD_STRENGTH_HIGH`] buys MS-SSIM back above them
/// (`docs/codec-ablation.md`, "The structural metrics' margin").
pub const FIELD_FULL_QUALITY: f64 = 65.0;
/// The field's strength from [`FIELD_HIGH_QUALITY`], rising from [`FIELD_STRENGTH`] at
/// [`FIELD_FULL_QUALITY`]: MS-SSIM lags most at 0.3-2 bpp, and there the strength buys
/// it at half the PSNR it costs at the low rates.
pub const FIELD_STRENGTH_HIGH: f64 = 0.15;
/// Quality from which the field has [`FIELD_STRENGTH_HIGH`].
pub const FIELD_HIGH_QUALITY: f64 = 70.0;
/// Quality above which the field fades, to none at 100.
pub const FIELD_FADE_QUALITY: f64 = 85.0;
/// How far past the rounding boundary an exponent takes its neighbours' mean
/// ([`exponent`](super::detail::field::exponent)): measured, 0.4 points by SSIMULACRA2
/// and 0.1 by RGB PSNR.
pub const FIELD_HYSTERESIS: f64 = 0.25;

/// Dead zone of the predictive quantiser (measured: 0.15 saves 6% over plain rounding).
pub const DEADZONE: f64 = 0.15;
/// Dead zone of the detail quantiser (measured with merged groups against 0.2: 0.12
/// gained 0.1% BD-rate by PSNR, 0.2% by MS-SSIM and 0.5% by SSIMULACRA2; 0.06 was even).
pub const DETAIL_DEADZONE: f64 = 0.12;
/// Lagrange multiplier of the detail blocks in squared steps per bit (measured with
/// the restoration filters and the deringing, which take some of the error the blocks
/// leave: 0.075 against 0.09 gained 0.4% by RGB PSNR, 0.2% by MS-SSIM and 0.2% by
/// SSIMULACRA2; 0.06 gained 0.1% more by PSNR and nothing by MS-SSIM, 0.11 lost 0.6%).
/// Float images use [`DETAIL_LAMBDA_HDR`].
pub const DETAIL_LAMBDA: f64 = 0.075;
/// The multiplier on float images (measured on the corpus's HDR class: 0.2 saved 1.3%).
pub const DETAIL_LAMBDA_HDR: f64 = 0.2;
/// Conjugate-gradient steps of the final fit below effort 7: warm-started from the
/// locally averaged colours, the fit is all but converged after a few (measured at
/// effort 5 on the photographs against WebP: -8.7% BD-rate with up to 45 steps or
/// with 3, -8.5% with 2; each step is about 4% of the encoding time).
pub const FAST_FINAL_CG: usize = 2;
/// Smallest network cell, log2, below [`LARGE_CELLS_QUALITY`]: the detail layer's
/// blocks are 8 pixels, and finer cells cost more than the blocks they save on
/// photographs (4 px: +1.5% BD-rate, 1 px: +3%).
pub const MIN_CELL_LOG2: u8 = 3;
/// Smallest network cell, log2, from [`LARGE_CELLS_QUALITY`]: where the detail layer is
/// fine, it codes what 8-pixel cells would for fewer bits (measured: 0.6 points of
/// BD-rate by RGB PSNR; 16-pixel cells at every quality gain 1.6 by PSNR but lose 3.4
/// by SSIMULACRA2, most below 0.3 bpp, where the network draws the edges).
pub const MIN_CELL_LOG2_HIGH: u8 = 4;
/// Quality from which the smallest network cell is `2^MIN_CELL_LOG2_HIGH` pixels.
pub const LARGE_CELLS_QUALITY: f32 = 55.0;
/// Root blocks, log2: 32 pixels keep flat regions to one key point (smooth corpus
/// class: -30% BD-rate against 16; photographs +0.6%).
pub const ROOT_LOG2: u8 = 5;

/// The cell level whose key points get the settings' network steps when steps follow
/// the cell level: each level above halves the step, each below doubles it. A key
/// point's colour spreads over its cell, so its error counts in proportion to the
/// cell's area while its bits do not, and the step that balances them goes as the
/// cell's side (measured on the photographs against one step for all: -1.4 points of
/// BD-rate by PSNR, -1.8 by MS-SSIM, -2.4 by SSIMULACRA2; reference level 5 and a
/// step growing as the side to the power 0.5 gained less, the power 1.5 about as
/// much, and doubling per level keeps the prediction across levels exact).
pub const LEVEL_STEPS_REFERENCE_LOG2: u8 = 4;
/// Mean key point area (pixels per luma key point) above which the network's steps
/// shrink in proportion: where the network is this sparse there is little detail
/// layer to correct its errors. With [`BASE_STEP_RATIO`] 0.25 the steps of networks
/// sparser than 400 pixels per key point are those 0.15 gave with this factor from
/// 400 pixels (measured on the corpus's smooth class: -15% BD-rate against none).
pub const SPARSE_AREA: f64 = 240.0;

/// How a network follows the detail layer's step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NetworkRatios {
    /// Network step per detail step.
    pub step: f64,
    /// Split threshold per squared detail step.
    pub threshold: f64,
    /// Mean key point area above which the steps shrink ([`network_step_factor`]).
    pub sparse_area: f64,
}

/// The network of 8-bit and 16-bit images: [`BASE_STEP_RATIO`], [`THRESHOLD_RATIO`]
/// and [`SPARSE_AREA`].
pub const PHOTO_NETWORK: NetworkRatios = NetworkRatios {
    step: BASE_STEP_RATIO,
    threshold: THRESHOLD_RATIO,
    sparse_area: SPARSE_AREA,
};

/// The network of float images: their networks reach single pixels and carry most of
/// the picture (measured on the corpus's HDR class: [`PHOTO_NETWORK`] cost 8.5%
/// BD-rate against these).
pub const HDR_NETWORK: NetworkRatios = NetworkRatios {
    step: 0.15,
    threshold: 15.0,
    sparse_area: 400.0,
};

/// The network steps' factor for a mean key point area of `area` pixels, shrinking
/// them above `sparse_area`.
pub fn network_step_factor(area: f64, sparse_area: f64) -> f64 {
    (sparse_area / area).min(1.0)
}

/// The detail steps' tilt at quality `q`: [`DETAIL_WEIGHTS`] up to
/// [`WEIGHTS_FADE_QUALITY`], then in proportion to `100 - q`; none at 100.
pub fn detail_weights(q: f64) -> Option<FrequencyWeights> {
    let k = ((100.0 - q) / (100.0 - WEIGHTS_FADE_QUALITY)).clamp(0.0, 1.0);
    let tilts = DETAIL_WEIGHTS.tilts.map(|t| (t as f64 * k).round() as u8);
    (tilts != [0, 0]).then_some(FrequencyWeights { tilts })
}

/// The activity field at quality `q`: none up to [`FIELD_FROM_QUALITY`], rising to
/// [`FIELD_STRENGTH`] at [`FIELD_FULL_QUALITY`] and on to [`FIELD_STRENGTH_HIGH`] at
/// [`FIELD_HIGH_QUALITY`], fading above [`FIELD_FADE_QUALITY`] (near-lossless coding
/// is judged by its error alone); none at 100.
pub fn detail_field(q: f64) -> Option<FieldSettings> {
    let rise =
        ((q - FIELD_FROM_QUALITY) / (FIELD_FULL_QUALITY - FIELD_FROM_QUALITY)).clamp(0.0, 1.0);
    let high =
        ((q - FIELD_FULL_QUALITY) / (FIELD_HIGH_QUALITY - FIELD_FULL_QUALITY)).clamp(0.0, 1.0);
    let fade = ((100.0 - q) / (100.0 - FIELD_FADE_QUALITY)).clamp(0.0, 1.0);
    let strength = rise * fade * (FIELD_STRENGTH + (FIELD_STRENGTH_HIGH - FIELD_STRENGTH) * high);
    (strength > 0.0).then_some(FieldSettings {
        log2: FIELD_LOG2,
        strength,
        floor: FIELD_FLOOR,
        hysteresis: FIELD_HYSTERESIS,
    })
}

/// The smallest network cell, log2, at quality `q` (without a key-point budget).
pub fn min_cell_log2(q: f32) -> u8 {
    if q >= LARGE_CELLS_QUALITY {
        MIN_CELL_LOG2_HIGH
    } else {
        MIN_CELL_LOG2
    }
}

/// The detail layer's luma step at quality `q` (0..=100).
fn detail_step(q: f64) -> f64 {
    // `scaled_quality` inverts this exponent.
    DETAIL_STEP_0 * 10f64.powf(-q * (0.0003 + 0.000245 * q))
}

/// The quality to code an image at `scale` of its size per side for quality `q`: the
/// one whose detail step is `scale` times `q`'s. A coded pixel's error spreads over
/// `1 / scale^2` of the image's, so that keeps the rate-distortion slope of `q`'s steps
/// (the steps' squares are the encoder's Lagrange multipliers) at the image's size.
pub fn scaled_quality(q: f32, scale: f64) -> f32 {
    // Solves 0.000245 x^2 + 0.0003 x = f(q) - log10 scale for the exponent f of
    // `detail_step`.
    let q = f64::from(q.clamp(0.0, 100.0));
    let (a, b) = (0.000245, 0.0003);
    let c = q * (b + a * q) - scale.log10();
    (((b * b + 4.0 * a * c).sqrt() - b) / (2.0 * a)).min(100.0) as f32
}

/// Settings `s`, made for [`scaled_quality`]`(q, scale)`, for coding the image at
/// `scale` of its size per side for quality `q`: the steps stay `s`'s, and what shapes
/// them for the structural metrics follows the image rather than the coded size. The
/// frequency tilts scale with the size, since a coded frequency is `scale` times the
/// image's (the tilt is per cycle per 16 pixels). The activity field takes `q`'s
/// strength, the one set for the rates the file serves: none below
/// [`FIELD_FROM_QUALITY`], where the structural metrics are ahead without one. Measured
/// in `docs/codec-ablation.md`, "Coding at a smaller size".
pub fn at_scale(mut s: EncodeSettings, q: f32, scale: f64) -> EncodeSettings {
    s.detail_weights = s.detail_weights.and_then(|w| {
        let tilts = w.tilts.map(|t| (f64::from(t) * scale).round() as u8);
        (tilts != [0, 0]).then_some(FrequencyWeights { tilts })
    });
    if s.detail_field.is_some() {
        s.detail_field = detail_field(f64::from(q.clamp(0.0, 100.0)));
    }
    s
}

/// Settings for quality `q` (0..=100) and effort `e` (1..=9).
///
/// Quality sets the detail layer's step on a log-quadratic scale; the network's steps
/// and split threshold follow it, so every source of error shrinks together. Effort
/// buys the least-squares fit (from 3) and greedy refinement rounds (from 7).
pub fn settings(quality: f32, effort: u8, keypoints: Option<usize>) -> EncodeSettings {
    let detail = detail_step(quality.clamp(0.0, 100.0) as f64);
    let (step, step_chroma, split_threshold) = network_steps(detail, PHOTO_NETWORK);
    let e = effort.clamp(1, 9) as usize;
    let model = ModelSettings {
        split_threshold,
        target_keypoints: keypoints,
        rounds: e.saturating_sub(6),
        growth: if e >= 7 { 0.25 } else { 0.35 },
        cg_iterations: (6 + 2 * e, if e >= 7 { 15 + 6 * e } else { FAST_FINAL_CG }),
        least_squares: e >= 3,
        // A key-point budget asks for the tree itself: let it reach single pixels.
        min_log2: if keypoints.is_some() {
            0
        } else {
            min_cell_log2(quality)
        },
        block_log2: ROOT_LOG2,
        ..ModelSettings::default()
    };
    EncodeSettings {
        model,
        step_luma: step,
        step_chroma,
        step_alpha: step,
        deadzone: DEADZONE,
        detail_step_luma: detail,
        detail_step_chroma: DETAIL_CHROMA_RATIO * detail,
        detail_deadzone: DETAIL_DEADZONE,
        detail_lambda: DETAIL_LAMBDA,
        detail_search: e >= 5,
        deblock: Some(Deblock::DEFAULT),
        lapping: Some(Lapping::DEFAULT),
        detail_adaptive: Some(AdaptiveSteps::DEFAULT),
        detail_weights: detail_weights(quality.clamp(0.0, 100.0) as f64),
        detail_field: detail_field(quality.clamp(0.0, 100.0) as f64),
        decorrelate: true,
        colour_basis: ColourBasis::Luma,
        level_steps: true,
        sparse_area: PHOTO_NETWORK.sparse_area,
        // The fit decodes most of the file again: a third of effort 1's encode.
        restoration: e >= 3,
        deringing: true,
        display: None,
    }
}

/// The network's luma step, chroma step and split threshold for the detail layer's
/// luma step `detail` by `ratios` (the chroma step's ratio to luma's tilting with the
/// step).
fn network_steps(detail: f64, ratios: NetworkRatios) -> (f64, f64, f64) {
    let step = (ratios.step * detail).clamp(2e-4, 2.0);
    let chroma_ratio = CHROMA_STEP_RATIO * (detail / detail_step(75.0)).powf(-CHROMA_STEP_TILT);
    (
        step,
        chroma_ratio * step,
        ratios.threshold * detail * detail,
    )
}

impl EncodeSettings {
    /// The settings adjusted to the image: alpha has no detail layer, so with alpha
    /// the tree goes down to single pixels for its edges; float (HDR) images keep
    /// 16-pixel roots, single-pixel cells, a larger multiplier and one detail step per
    /// plane (measured on the corpus's HDR class: +92% BD-rate with the photographs'
    /// settings, +3% with these).
    pub fn adapted_to(mut self, format: caoen_base::raster::SampleFormat, alpha: bool) -> Self {
        if alpha {
            self.model.min_log2 = 0;
        }
        if format == caoen_base::raster::SampleFormat::F32 {
            self.model.min_log2 = 0;
            self.model.block_log2 = 4;
            self.detail_lambda = DETAIL_LAMBDA_HDR;
            // Cell size tracks what the eye masks in display-referred pictures; float
            // images keep one step per plane.
            self.detail_adaptive = None;
            self.detail_field = None;
            self.detail_weights = None;
            // BT.601 luma is a display-referred weighting: float images keep the grey
            // basis, whose error is the same in every direction.
            self.colour_basis = ColourBasis::Grey;
            // The filters are fitted in the coding planes' log-like curve, and on the
            // corpus's float images they cost more than they gained by the bench's
            // measure (`docs/codec-ablation.md`, "Restoration filters").
            self.restoration = false;
            self.deringing = false;
            self = self.with_network(HDR_NETWORK);
        }
        self
    }

    /// The network's steps, split threshold and sparse area set from the detail
    /// layer's luma step by `ratios`.
    fn with_network(mut self, ratios: NetworkRatios) -> Self {
        let (step, step_chroma, split_threshold) = network_steps(self.detail_step_luma, ratios);
        (self.step_luma, self.step_chroma, self.step_alpha) = (step, step_chroma, step);
        self.model.split_threshold = split_threshold;
        self.sparse_area = ratios.sparse_area;
        self
    }
}

/// Finds the quality whose output size is closest to `target_bytes` by bisection on
/// quality (size grows with quality), calling `size_at(quality)`; returns the best
/// quality and its size. Stops once within `tolerance` (relative).
pub fn search_quality(
    target_bytes: f64,
    tolerance: f64,
    steps: usize,
    mut size_at: impl FnMut(f32) -> Result<usize, super::CodecError>,
) -> Result<(f32, usize), super::CodecError> {
    let (mut lo, mut hi) = (0.0f32, 100.0f32);
    let mut best: Option<(f32, usize)> = None;
    let better = |s: usize, b: &Option<(f32, usize)>| {
        b.is_none_or(|(_, bs)| (s as f64 - target_bytes).abs() < (bs as f64 - target_bytes).abs())
    };
    for _ in 0..steps {
        let mid = 0.5 * (lo + hi);
        let size = size_at(mid)?;
        if better(size, &best) {
            best = Some((mid, size));
        }
        if ((size as f64 - target_bytes) / target_bytes).abs() <= tolerance {
            break;
        }
        if (size as f64) < target_bytes {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(best.expect("at least one step"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tilt_is_full_up_to_the_fade_quality_and_gone_at_100() {
        for q in [0.0, 40.0, 75.0] {
            assert_eq!(detail_weights(q), Some(DETAIL_WEIGHTS));
        }
        assert_eq!(detail_weights(87.5).map(|w| w.tilts), Some([4, 16]));
        assert_eq!(detail_weights(90.0).map(|w| w.tilts), Some([3, 13]));
        assert_eq!(detail_weights(100.0), None);
        assert_eq!(settings(100.0, 5, None).detail_weights, None);
        assert_eq!(settings(60.0, 5, None).detail_weights, Some(DETAIL_WEIGHTS));
        // Float images keep a flat quantiser.
        let hdr = settings(60.0, 5, None).adapted_to(caoen_base::raster::SampleFormat::F32, false);
        assert_eq!(hdr.detail_weights, None);
    }

    #[test]
    fn the_network_keeps_8_pixel_cells_below_the_large_cells_quality() {
        let min = |q: f32, keys: Option<usize>| settings(q, 5, keys).model.min_log2;
        assert_eq!(min(0.0, None), MIN_CELL_LOG2);
        assert_eq!(min(LARGE_CELLS_QUALITY - 0.5, None), MIN_CELL_LOG2);
        assert_eq!(min(LARGE_CELLS_QUALITY, None), MIN_CELL_LOG2_HIGH);
        assert_eq!(min(100.0, None), MIN_CELL_LOG2_HIGH);
        // A key-point budget and float images reach single pixels at any quality.
        assert_eq!(min(90.0, Some(500)), 0);
        let hdr = settings(90.0, 5, None).adapted_to(caoen_base::raster::SampleFormat::F32, false);
        assert_eq!(hdr.model.min_log2, 0);
        // Sparse networks keep the steps they had at 0.15 from 400 pixels per key point.
        for area in [400.0, 1024.0, 4096.0] {
            let step = BASE_STEP_RATIO * network_step_factor(area, SPARSE_AREA);
            assert!((step - 0.15 * (400.0 / area)).abs() < 1e-12, "{area}");
        }
        assert_eq!(network_step_factor(SPARSE_AREA, SPARSE_AREA), 1.0);
        // Float images keep the denser, finer network.
        let (photo, hdr) = (
            settings(60.0, 5, None),
            settings(60.0, 5, None).adapted_to(caoen_base::raster::SampleFormat::F32, false),
        );
        assert!((hdr.step_luma / photo.step_luma - 0.6).abs() < 1e-12);
        assert!((hdr.step_chroma / photo.step_chroma - 0.6).abs() < 1e-12);
        assert!((hdr.model.split_threshold / photo.model.split_threshold - 0.6).abs() < 1e-12);
        assert_eq!(hdr.sparse_area, 400.0);
        assert_eq!(photo.sparse_area, SPARSE_AREA);
    }

    #[test]
    fn the_activity_field_rises_from_the_low_rates_and_fades_to_none_at_100() {
        let f = detail_field(FIELD_FULL_QUALITY).expect("a field");
        assert_eq!(
            (f.log2, f.strength, f.floor, f.hysteresis),
            (FIELD_LOG2, FIELD_STRENGTH, FIELD_FLOOR, FIELD_HYSTERESIS)
        );
        for q in [FIELD_HIGH_QUALITY, FIELD_FADE_QUALITY] {
            assert_eq!(
                detail_field(q).map(|f| f.strength),
                Some(FIELD_STRENGTH_HIGH),
                "{q}"
            );
        }
        for q in [0.0, 20.0, FIELD_FROM_QUALITY, 100.0] {
            assert_eq!(detail_field(q), None, "{q}");
        }
        let strength = |q: f64| detail_field(q).map_or(0.0, |f| f.strength);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        let half = (FIELD_FROM_QUALITY + FIELD_FULL_QUALITY) / 2.0;
        assert!(close(strength(half), FIELD_STRENGTH / 2.0));
        let between = (FIELD_FULL_QUALITY + FIELD_HIGH_QUALITY) / 2.0;
        assert!(close(
            strength(between),
            (FIELD_STRENGTH + FIELD_STRENGTH_HIGH) / 2.0
        ));
        let fading = (FIELD_FADE_QUALITY + 100.0) / 2.0;
        assert!(close(strength(fading), FIELD_STRENGTH_HIGH / 2.0));
        // Rising to the fade, then falling.
        let ladder: Vec<f64> = (0..=100).map(|q| strength(q as f64)).collect();
        let top = FIELD_FADE_QUALITY as usize;
        assert!(ladder[..=top].windows(2).all(|w| w[1] >= w[0]));
        assert!(ladder[top..].windows(2).all(|w| w[1] <= w[0]));
        assert_eq!(settings(100.0, 5, None).detail_field, None);
        assert!(settings(60.0, 1, None).detail_field.is_some());
        // Float images keep one step per plane.
        let hdr = settings(60.0, 5, None).adapted_to(caoen_base::raster::SampleFormat::F32, false);
        assert_eq!((hdr.detail_adaptive, hdr.detail_field), (None, None));
    }

    #[test]
    fn a_smaller_size_keeps_the_finer_steps_and_shapes_them_by_the_image_and_the_asked_quality() {
        for (scale, tilts) in [(0.5, [4u8, 16]), (0.7, [6, 22]), (0.8, [6, 26])] {
            for q in [20.0f32, 30.0, 45.0, 50.0, 58.0] {
                let sq = scaled_quality(q, scale);
                let (own, small) = (
                    settings(sq, 5, None),
                    at_scale(settings(sq, 5, None), q, scale),
                );
                // `scale` times the asked quality's detail step, as the slope argument sets it.
                assert!(
                    (detail_step(sq.into()) / detail_step(q.into()) - scale).abs() < 1e-6,
                    "{q}"
                );
                assert_eq!(
                    (
                        small.detail_step_luma,
                        small.detail_step_chroma,
                        small.step_luma,
                        small.model.split_threshold
                    ),
                    (
                        own.detail_step_luma,
                        own.detail_step_chroma,
                        own.step_luma,
                        own.model.split_threshold
                    )
                );
                // The image's tilts (8 and 32) per coded frequency.
                assert_eq!(
                    small.detail_weights.map(|w| w.tilts),
                    Some(tilts),
                    "{scale} {q}"
                );
                assert_eq!(small.detail_field, detail_field(q.into()), "{q}");
            }
        }
        // Half size at q30 codes at about q46, which would have a field: it takes none.
        let hq = scaled_quality(30.0, 0.5);
        assert!((hq - 45.93).abs() < 0.01, "{hq}");
        assert!(settings(hq, 5, None).detail_field.is_some());
        assert_eq!(
            at_scale(settings(hq, 5, None), 30.0, 0.5).detail_field,
            None
        );
        // What the caller turned off stays off.
        let plain = EncodeSettings {
            detail_field: None,
            detail_weights: None,
            ..settings(scaled_quality(50.0, 0.5), 5, None)
        };
        let half = at_scale(plain, 50.0, 0.5);
        assert_eq!((half.detail_field, half.detail_weights), (None, None));
    }
}
