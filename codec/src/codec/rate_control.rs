//! From user-facing knobs (quality, effort, rate targets) to encoder settings, and the
//! search that lands a rate target.

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
    /// Code the colour channels in opponent space (else raw RGB on one tree: an
    /// ablation switch only; such files do not decode to the right colours).
    pub decorrelate: bool,
}

/// Luma quantiser step per square root of the split threshold (measured: 0.012 cost
/// +30% BD-rate against 0.1; the optimum is flat between 0.07 and 0.14).
pub const STEP_FACTOR: f64 = 0.1;
/// Chroma step relative to luma (measured on the RD benchmark; 1.6 was 10% worse).
pub const CHROMA_STEP_RATIO: f64 = 0.7;

/// Dead zone of the predictive quantiser (measured: 0.15 saves 6% over plain rounding).
pub const DEADZONE: f64 = 0.15;

/// Settings for quality `q` (0..=100) and effort `e` (1..=9).
///
/// Quality sets the split threshold (the squared error a leaf may keep) on a log
/// scale, and the quantiser steps in proportion to its square root, so the two
/// sources of error shrink together.
pub fn settings(quality: f32, effort: u8, keypoints: Option<usize>) -> EncodeSettings {
    let env = |k: &str, d: f64| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let q = quality.clamp(0.0, 100.0) as f64;
    let detail = 1.5 * 10f64.powf(-q * (0.0003 + 0.000245 * q));
    let step = (env("CAOEN_BS", 0.15) * detail).clamp(2e-4, 2.0);
    let threshold = env("CAOEN_TT", 15.0) * detail * detail;
    let e = effort.clamp(1, 9) as usize;
    let model = ModelSettings {
        split_threshold: threshold,
        target_keypoints: keypoints,
        rounds: env("CAOEN_ROUNDS", e.saturating_sub(6) as f64) as usize,
        growth: if e >= 7 { 0.25 } else { 0.35 },
        cg_iterations: (env("CAOEN_CG0", (6 + 2 * e) as f64) as usize, env("CAOEN_CG1", (15 + 6 * e) as f64) as usize),
        least_squares: env("CAOEN_LS", if e <= 2 { 0.0 } else { 1.0 }) > 0.5,
        min_log2: env("CAOEN_MIN", 3.0) as u8,
        ..ModelSettings::default()
    };
    EncodeSettings {
        model,
        step_luma: step,
        step_chroma: CHROMA_STEP_RATIO * step,
        step_alpha: step,
        deadzone: DEADZONE,
        detail_step_luma: detail,
        detail_step_chroma: env("CAOEN_DC", 1.0) * detail,
        detail_deadzone: env("CAOEN_DZ", 0.2),
        detail_lambda: env("CAOEN_LAMBDA", 0.12),
        decorrelate: true,
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
