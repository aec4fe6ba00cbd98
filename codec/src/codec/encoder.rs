//! The encoder: model, quantise, entropy-code, assemble.

use super::bitstream::{self, Header};
use super::colour::{self, CodingPlanes};
use super::decoder::{self, Decoded};
use super::detail::quantise::{self as detail_quantise, Quantiser};
use super::entropy::AnsSink;
use super::model::{self, Model};
use super::rate_control::EncodeSettings;
use super::syntax::{self, MAX_VALUE};
use super::CodecError;
use crate::raster::Raster;

/// Statistics of one encode.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodeStats {
    /// Luma key points.
    pub luma_keypoints: usize,
    /// Chroma key points.
    pub chroma_keypoints: usize,
    /// Bytes of the whole file.
    pub bytes: usize,
}

/// Quantises one channel in coding order against the decoder's own prediction, with
/// a dead zone: the residual's magnitude is rounded down unless its fraction exceeds
/// `0.5 + deadzone`, trading a little distortion for many zero or smaller residuals.
fn quantise(nbs: &[syntax::Neighbours], values: &[f64], step: f64, deadzone: f64) -> Vec<i64> {
    let mut out = vec![0i64; values.len()];
    let mut previous = 0;
    for i in 0..values.len() {
        let (pred, _) = syntax::predict(&out, &nbs[i], previous);
        let r = values[i] / step - pred as f64;
        let m = (r.abs() + 0.5 - deadzone).floor().max(0.0);
        // Clamped in floating point: an extreme (finite) sample can put the residual
        // far beyond i64, and the sum must not overflow. Below 2^53 the sum is exact, so
        // in range this is the integer sum.
        let v = (pred as f64 + r.signum() * m).clamp(-MAX_VALUE as f64, MAX_VALUE as f64) as i64;
        out[i] = v;
        previous = v;
    }
    out
}

/// Entropy-codes a fitted model into a file.
pub fn write_model(
    img: &Raster,
    planes: &CodingPlanes,
    model: &Model,
    s: &EncodeSettings,
) -> (Vec<u8>, EncodeStats) {
    let (w, h) = (img.width(), img.height());
    let shape = model.shape;
    let leaf_set: std::collections::HashSet<_> = model.luma_cells.iter().copied().collect();
    let mut tree = AnsSink::new();
    let cells = syntax::write_tree(&shape, |c| !leaf_set.contains(c), &mut tree);
    debug_assert_eq!(cells, model.luma_cells);
    let header = Header {
        width: w,
        height: h,
        layout: img.layout(),
        format: img.format(),
        block_log2: shape.block_log2,
        min_log2: shape.min_log2,
        kernel: model.kernel,
        chroma_pruned: s.model.chroma_pruned,
        step_luma: s.step_luma as f32,
        step_chroma: s.step_chroma as f32,
        step_alpha: s.step_alpha as f32,
        luma_count: model.luma_cells.len() as u32,
        chroma_count: model.chroma_cells.len() as u32,
        detail_steps: Some([s.detail_step_luma as f32, s.detail_step_chroma as f32]),
    };
    let mut luma = AnsSink::new();
    let nbs = syntax::neighbours(&model.luma_cells, w, h);
    let mut luma_values = Vec::new();
    for (c, values) in model.luma_colours.iter().enumerate() {
        let step = if c == 0 {
            header.step_luma
        } else {
            header.step_alpha
        } as f64;
        let q = quantise(&nbs, values, step, s.deadzone);
        syntax::write_values(&model.luma_cells, &nbs, &q, &mut luma);
        luma_values.push(q.iter().map(|&v| v as f64 * step).collect());
    }
    let mut chroma_values = Vec::new();
    let chroma = (!model.chroma_cells.is_empty()).then(|| {
        let mut sink = AnsSink::new();
        let nbs = syntax::neighbours(&model.chroma_cells, w, h);
        let step = header.step_chroma as f64;
        for values in &model.chroma_colours {
            let q = quantise(&nbs, values, step, s.deadzone);
            syntax::write_values(&model.chroma_cells, &nbs, &q, &mut sink);
            chroma_values.push(q.iter().map(|&v| v as f64 * step).collect());
        }
        sink.finish()
    });
    // The detail layer codes what the decoder's network leaves of each colour channel.
    let base = decoder::render_identity(
        &Decoded {
            header: header.clone(),
            luma_cells: model.luma_cells.clone(),
            chroma_cells: model.chroma_cells.clone(),
            luma_values,
            chroma_values,
            detail: None,
        },
        w,
        h,
    );
    let residuals: Vec<Vec<f64>> = planes
        .colour
        .iter()
        .zip(&base.colour)
        .map(|(t, r)| t.iter().zip(r).map(|(&t, &r)| t - r as f64).collect())
        .collect();
    let quantisers: Vec<Quantiser> = (0..residuals.len())
        .map(|c| Quantiser {
            step: if c == 0 {
                s.detail_step_luma
            } else {
                s.detail_step_chroma
            },
            deadzone: s.detail_deadzone,
            lambda: s.detail_lambda,
        })
        .collect();
    let (detail, payload) = detail_quantise::code_layer(&residuals, (w, h), &quantisers);
    // A layer with nothing in it is left out, header steps and all: on smooth images
    // at low rates its few dozen bytes are a good part of the file.
    let mut header = header;
    let payload = if detail.planes.iter().all(|p| p.coded_blocks() == 0) {
        header.detail_steps = None;
        None
    } else {
        Some(payload)
    };
    let bytes = bitstream::write(
        &header,
        &tree.finish(),
        &luma.finish(),
        chroma.as_deref(),
        payload.as_deref(),
    );
    let stats = EncodeStats {
        luma_keypoints: model.luma_cells.len(),
        chroma_keypoints: model.chroma_cells.len(),
        bytes: bytes.len(),
    };
    (bytes, stats)
}

/// Encodes with explicit settings; `progress(done, total)` reports modelling rounds.
pub fn encode_with(
    img: &Raster,
    planes: &CodingPlanes,
    s: &EncodeSettings,
    progress: impl FnMut(usize, usize),
) -> Result<(Vec<u8>, EncodeStats), CodecError> {
    let mut s = s.clone();
    s.model.kernel = Header::quantise_kernel(s.model.kernel);
    for (name, v) in [
        ("luma step", s.step_luma),
        ("chroma step", s.step_chroma),
        ("alpha step", s.step_alpha),
        ("detail luma step", s.detail_step_luma),
        ("detail chroma step", s.detail_step_chroma),
    ] {
        if !(v.is_finite() && (1e-7..=1e4).contains(&v)) {
            return Err(CodecError::Parameter {
                name: "quantiser step",
                value: format!("{name} {v}"),
                reason: "1e-7..=1e4",
            });
        }
    }
    // Steps are stored as f32: quantise with exactly what the decoder will read.
    s.step_luma = s.step_luma as f32 as f64;
    s.step_chroma = s.step_chroma as f32 as f64;
    s.step_alpha = s.step_alpha as f32 as f64;
    s.detail_step_luma = s.detail_step_luma as f32 as f64;
    s.detail_step_chroma = s.detail_step_chroma as f32 as f64;
    let rgb;
    let planes = if !s.decorrelate && planes.colour.len() == 3 {
        rgb = CodingPlanes {
            colour: (0..3)
                .map(|c| img.plane(c).iter().map(|&v| v as f64).collect())
                .collect(),
            alpha: planes.alpha.clone(),
        };
        &rgb
    } else {
        planes
    };
    let model = model::build(planes, img.width(), img.height(), &s.model, progress);
    Ok(write_model(img, planes, &model, &s))
}

/// Splits an image into coding planes after checking it can be encoded.
pub fn prepare(img: &Raster) -> Result<CodingPlanes, CodecError> {
    if img.width() > super::MAX_SIDE || img.height() > super::MAX_SIDE {
        return Err(CodecError::Limit {
            what: "image side",
            value: img.width().max(img.height()) as u64,
            limit: super::MAX_SIDE as u64,
        });
    }
    Ok(colour::forward(img))
}
