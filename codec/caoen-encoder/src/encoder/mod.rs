//! The encoder: model, quantise, entropy-code, assemble.

mod post_filters;
#[cfg(test)]
mod tests;
mod tiles;

pub(crate) use post_filters::restoration_fit_pixels;

use std::sync::Mutex;

use rayon::prelude::*;

use super::bitstream::{self, Header, TileStreams};
use super::colour::ColourBasis;
use super::detail::adaptive::{self, AdaptiveSteps};
use super::geometry::Frame;
use super::model;
use super::rate_control::{self, EncodeSettings};
use super::source::PixelSource;
use super::syntax::LevelSteps;
use super::tiling::Tiling;
use super::{CodecError, EncodeStats};
use caoen_base::metadata::{Metadata, MAX_ITEM_BYTES};
use post_filters::fit_post_filters;
use tiles::{code_tile, detail_tile, fit_tile, run_tiles, Network, TileModel};

/// Encodes with explicit settings, at most `workers` tiles at once; `progress(done,
/// total)` reports tiles modelled and coded.
pub fn encode_with(
    img: &(impl PixelSource + ?Sized),
    s: &EncodeSettings,
    metadata: &Metadata,
    workers: usize,
    progress: impl FnMut(usize, usize) + Send,
) -> Result<(Vec<u8>, EncodeStats), CodecError> {
    prepare(img)?;
    let mut s = s.clone();
    s.model.kernel = Header::quantise_kernel(s.model.kernel);
    // The field scales the adaptive steps: without them there is none.
    if s.detail_adaptive.is_none() {
        s.detail_field = None;
    }
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
    // Quantise with exactly the steps the decoder will read.
    for step in [
        &mut s.step_luma,
        &mut s.step_chroma,
        &mut s.step_alpha,
        &mut s.detail_step_luma,
        &mut s.detail_step_chroma,
    ] {
        *step = bitstream::stored_step(*step);
    }
    for (name, item) in [
        ("ICC profile", &metadata.icc),
        ("EXIF", &metadata.exif),
        ("XMP", &metadata.xmp),
    ] {
        if let Some(item) = item.as_ref().filter(|i| i.len() > MAX_ITEM_BYTES) {
            return Err(CodecError::Parameter {
                name: "metadata",
                value: format!("{name} of {} bytes", item.len()),
                reason: "at most 16 MiB per item",
            });
        }
    }
    let (w, h) = (img.width(), img.height());
    let tiling = Tiling::choose(w, h);
    let n = tiling.count();
    let done = Mutex::new((0usize, progress));
    let step = || {
        let mut d = done.lock().expect("progress");
        d.0 += 1;
        let k = d.0;
        (d.1)(k, 2 * n);
    };
    let fits = run_tiles(n, workers, |i| {
        let m = fit_tile(img, tiling.rect(i), &s);
        step();
        m
    });
    let (fits, activity): (Vec<model::Model>, Vec<Vec<f64>>) = fits.into_iter().unzip();
    // The field's exponents are against the whole image's mean activity.
    let fields = s.detail_field.map(|f| {
        let tiles: Vec<_> = activity
            .into_iter()
            .enumerate()
            .map(|(i, a)| (a, (tiling.rect(i).width, tiling.rect(i).height)))
            .collect();
        f.fields(&tiles)
    });
    let luma_keypoints: usize = fits.iter().map(|m| m.luma_cells.len()).sum();
    let area = w as f64 * h as f64 / luma_keypoints.max(1) as f64;
    let levels = LevelSteps {
        root_log2: s.model.block_log2,
        on: s.level_steps,
    };
    // The settings' steps are those of cells at the reference level; the header's
    // are the roots'.
    let factor = rate_control::network_step_factor(area, s.sparse_area)
        * if levels.on {
            2f64.powi(rate_control::LEVEL_STEPS_REFERENCE_LOG2 as i32 - s.model.block_log2 as i32)
        } else {
            1.0
        };
    for step in [&mut s.step_luma, &mut s.step_chroma, &mut s.step_alpha] {
        *step = bitstream::stored_step((*step * factor).clamp(1e-7, 1e4));
    }
    let mut models: Vec<TileModel> = fits
        .into_par_iter()
        .enumerate()
        .map(|(i, m)| code_tile(m, tiling.rect(i), &s, levels))
        .collect();
    let kernel = s.model.kernel;
    let net = Network::gather(
        &mut models,
        s.model.block_log2,
        Frame::new(w, h),
        kernel,
        &tiling,
    );
    let classes = adaptive::block_classes(&net.luma_cells, w, h);
    s.detail_adaptive = s.detail_adaptive.map(|a| AdaptiveSteps {
        field_log2: s.detail_field.map_or(0, |f| f.log2),
        ..a.normalised(&classes)
    });
    let details = run_tiles(n, workers, |i| {
        let field = fields.as_ref().map(|f| &f[i]);
        let d = detail_tile(img, i, tiling.rect(i), &s, kernel, &net, &classes, field);
        step();
        d
    });
    let any_detail = details.iter().any(|d| !d.is_empty());
    let header = Header {
        width: w,
        height: h,
        layout: img.layout(),
        format: img.format(),
        block_log2: s.model.block_log2,
        min_log2: s.model.min_log2,
        kernel,
        chroma_pruned: s.model.chroma_pruned,
        step_luma: s.step_luma as f32,
        step_chroma: if img.layout().colour_channels() == 3 {
            s.step_chroma as f32
        } else {
            bitstream::ABSENT_STEP
        },
        step_alpha: if img.layout().has_alpha() {
            s.step_alpha as f32
        } else {
            bitstream::ABSENT_STEP
        },
        luma_count: net.luma_cells.len() as u32,
        chroma_count: net.chroma_cells.len() as u32,
        tile_side: tiling.side,
        // A layer with nothing in it is left out, header steps and all: on smooth
        // images at low rates its few dozen bytes are a good part of the file.
        detail_steps: any_detail
            .then_some([s.detail_step_luma as f32, s.detail_step_chroma as f32]),
        deblock: s.deblock.filter(|_| any_detail),
        adaptive: s.detail_adaptive.filter(|_| any_detail),
        lapping: s.lapping.filter(|_| any_detail),
        weights: s.detail_weights.filter(|_| any_detail),
        basis: if img.layout().colour_channels() == 3 {
            s.colour_basis
        } else {
            ColourBasis::Grey
        },
        level_steps: levels.on,
        restoration: None,
        deringing: None,
        display: s.display,
    };
    let streams: Vec<TileStreams> = models
        .into_iter()
        .zip(details)
        .map(|(m, detail)| TileStreams {
            detail,
            ..m.streams
        })
        .collect();
    let mut bytes = bitstream::write(&header, metadata, &streams);
    if s.restoration {
        let mut header = header;
        // The metadata's bytes are no part of the picture's rate: with them the price
        // of a bit, and so the filters, would follow the file's ICC profile.
        let coded = bytes.len() - bitstream::metadata_bytes(metadata);
        (header.restoration, header.deringing) = fit_post_filters(&bytes, coded, img, &s)?;
        if header.restoration.is_some() || header.deringing.is_some() {
            bytes = bitstream::write(&header, metadata, &streams);
        }
    }
    let stats = EncodeStats {
        luma_keypoints: net.luma_cells.len(),
        chroma_keypoints: net.chroma_cells.len(),
        tiles: n,
        bytes: bytes.len(),
        coded_size: (w, h),
    };
    Ok((bytes, stats))
}

/// Checks an image can be encoded.
pub fn prepare(img: &(impl PixelSource + ?Sized)) -> Result<(), CodecError> {
    if img.width() > super::MAX_SIDE || img.height() > super::MAX_SIDE {
        return Err(CodecError::Limit {
            what: "image side",
            value: img.width().max(img.height()) as u64,
            limit: super::MAX_SIDE as u64,
        });
    }
    Ok(())
}
