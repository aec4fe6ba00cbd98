//! Morphing between two models that share a domain (paper section 9).
//!
//! Key point `i` of one model pairs with key point `i` of the other. The shorter model
//! is padded with *empty* key points (weight 0, otherwise copies of the partner), which
//! change nothing, normalised or not. Every per-key-point quantity is then blended as
//! `(1 - u) a + u b`, which gives `a` exactly at `u = 0` and `b` exactly at `u = 1`.

use super::error::{check_len, Result, SurfaceError};
use super::network::{KeyPoint, Network};

/// `model` padded with empty copies of `partner`'s extra key points.
pub fn pad_to(model: &Network, partner: &Network) -> Result<Network> {
    check_len(
        || "morph input dimension".into(),
        model.input_dim(),
        partner.input_dim(),
    )?;
    check_len(
        || "morph output dimension".into(),
        model.output_dim(),
        partner.output_dim(),
    )?;
    let mut kps = model.key_points();
    for i in model.len()..partner.len() {
        kps.push(KeyPoint {
            weight: 0.0,
            ..partner.key_point(i)
        });
    }
    Network::new(
        model.input_dim(),
        model.output_dim(),
        &kps,
        model.is_normalised(),
    )
}

/// The model at blend parameter `u` (0 gives `a`, 1 gives `b`; any finite u extrapolates).
///
/// Blending functions cannot be interpolated: a pair that differs takes `a`'s below
/// `u = 0.5` and `b`'s from there on.
pub fn morph(a: &Network, b: &Network, u: f64) -> Result<Network> {
    if !u.is_finite() {
        return Err(SurfaceError::NonFinite {
            what: "morph parameter u".into(),
            value: u,
        });
    }
    if a.is_normalised() != b.is_normalised() {
        return Err(SurfaceError::Parameter {
            what: "normalised".into(),
            value: u,
            reason: "both models must use the same normalisation",
        });
    }
    let (pa, pb) = (pad_to(a, b)?, pad_to(b, a)?);
    let lerp = |x: f64, y: f64| (1.0 - u) * x + u * y;
    let lerp_vec = |x: &[f64], y: &[f64]| {
        x.iter()
            .zip(y)
            .map(|(&x, &y)| lerp(x, y))
            .collect::<Vec<_>>()
    };
    let kps: Vec<KeyPoint> = (0..pa.len())
        .map(|i| {
            let (ka, kb) = (pa.key_point(i), pb.key_point(i));
            KeyPoint {
                source: lerp_vec(&ka.source, &kb.source),
                shape: lerp_vec(&ka.shape, &kb.shape),
                blend: if u < 0.5 { ka.blend } else { kb.blend },
                // Sharpness must stay positive even when extrapolating.
                q: lerp(ka.q, kb.q).max(f64::MIN_POSITIVE),
                weight: lerp(ka.weight, kb.weight).max(0.0),
            }
        })
        .collect();
    Network::new(a.input_dim(), a.output_dim(), &kps, a.is_normalised())
}
