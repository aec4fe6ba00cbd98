//! The decoder: parse, rebuild the key points, evaluate the network.
//!
//! Two evaluation paths: the identity fast path evaluates colours at output pixel
//! centres band by band (luma and chroma side by side, each band converted to output
//! colours while in cache; with restoration filters, whole coding planes first, then
//! filtered and converted band by band); the forward-mapping path samples the domain S x S times per
//! pixel, maps every sample through the core network to an output position and colour,
//! and splats the colour there (the paper's depth-buffer method in 2-D), filling any
//! pixel no sample reached from its neighbours.
//!
//! The position outputs interpolate key-point *displacements* (edited minus original
//! position; zero in a file that was not edited), added to the sample's own position.
//! Interpolating the key points' absolute positions instead would shift edges: the
//! normalised average of cell centres is biased wherever cell sizes change.
//!
//! `parse` turns the file into key points, `reconstruct` evaluates them by the identity
//! path and `forward` by forward mapping; this module holds the calls and the shapes of
//! their output.

mod forward;
mod parse;
mod post;
mod reconstruct;
mod region;

pub use forward::{fill_holes, render_forward};
pub use parse::detail_models;
pub use parse::{read, read_parsed, read_parsed_within};
pub use reconstruct::{
    render_identity, render_identity_raster, render_identity_raster_on, to_raster, unrestored_bands,
};
pub use region::MAX_ZOOM;

use super::bitstream::{self, Header, Parsed};
use super::detail::budget::LayerBudget;
use super::detail::Detail;
use super::quadtree::Cell;
use super::{CodecError, DecodeOptions, MAX_SIDE};
use caoen_base::raster::{ChannelLayout, Raster, SampleFormat};
use reconstruct::{band_pass, band_pass_interleaved, identity_with, non_finite};

/// The decoded key points and their values, before evaluation.
#[derive(Debug, Clone)]
pub struct Decoded {
    /// The header.
    pub header: Header,
    /// Luma cells in coding order.
    pub luma_cells: Vec<Cell>,
    /// Chroma cells in coding order.
    pub chroma_cells: Vec<Cell>,
    /// Luma-set channel values (Y, then alpha).
    pub luma_values: Vec<Vec<f64>>,
    /// Chroma values (C1, C2).
    pub chroma_values: Vec<Vec<f64>>,
    /// The detail layer (`None` leaves the network's colours alone, as the encoder
    /// needs before it has coded the layer).
    pub detail: Option<Detail>,
}

/// The output size of a decode and its estimated memory (all but the detail layer's
/// levels and coefficients, which [`LayerBudget`] bounds as they are made), checked.
fn output_size(
    header: &Header,
    opts: &DecodeOptions,
    sample_bytes: u64,
) -> Result<((u32, u32), u64), CodecError> {
    let (ow, oh) = opts.size.unwrap_or(header.display_size());
    if ow == 0 || oh == 0 || ow > MAX_SIDE || oh > MAX_SIDE {
        return Err(CodecError::Parameter {
            name: "output size",
            value: format!("{ow}x{oh}"),
            reason: "1..=16384 per side",
        });
    }
    let s = u64::from(opts.supersample.unwrap_or(1));
    let px = ow as u64 * oh as u64;
    if px * s * s > opts.max_pixels {
        return Err(CodecError::Limit {
            what: if s > 1 {
                "output samples (pixels x S^2)"
            } else {
                "output pixels"
            },
            value: px * s * s,
            limit: opts.max_pixels,
        });
    }
    let need = decode_memory(header, (ow, oh), opts.supersample, sample_bytes);
    opts.limits.check(|| decoding(header, (ow, oh)), need)?;
    Ok(((ow, oh), need))
}

/// What a decode of `header`'s file to `ow x oh` is called in a message.
fn decoding(header: &Header, (ow, oh): (u32, u32)) -> String {
    format!("decoding {}x{} to {ow}x{oh}", header.width, header.height)
}

/// The detail layer's share of a decode whose other needs, `base` bytes, were checked
/// against `opts`' limits as `what`.
fn layer_budget(opts: &DecodeOptions, base: u64, what: String) -> LayerBudget {
    let budget = opts.limits.max_memory.saturating_sub(opts.limits.held());
    LayerBudget::new(base, budget, what)
}

/// Records a finished decode's whole need (`base` and the layer's peak) as the largest
/// its limits checked, so that callers comparing a measured peak with the estimate see
/// the layer counted; it fitted, or the layer would have been refused.
fn record_peak(opts: &DecodeOptions, base: u64, layer: &LayerBudget, what: &str) {
    let _ = opts
        .limits
        .check(|| what.to_string(), base.saturating_add(layer.peak()));
}

/// The output size a decode of a file with `header` makes with `opts`: the size asked
/// for, else the region's own size rounded, else the image's size (before any check).
pub fn requested_size(header: &Header, opts: &DecodeOptions) -> (u32, u32) {
    match (opts.size, opts.region) {
        (Some(s), _) => s,
        (None, Some(r)) => {
            let own = |lo: f64, hi: f64| (hi - lo).round().clamp(1.0, f64::from(MAX_SIDE)) as u32;
            (own(r.x0, r.x1), own(r.y0, r.y1))
        }
        (None, None) => header.display_size(),
    }
}

/// Bytes per key point while decoding: its cell, values, splat window entry and, on
/// the forward path, its kernel and bucket entries.
const KEY_POINT_BYTES: u64 = 256;

/// Estimated peak memory of decoding a file with `header` to `ow x oh` pixels, in
/// bytes: the key points, the output of `sample_bytes` per sample (4 for a raster, 1
/// or 2 for [`decode_interleaved`]), the whole coding planes (4 bytes per sample) when
/// the file restores, the detail layer's per-block bookkeeping and, for forward mapping
/// with `S x S` samples, the sample lattice and the accumulation planes. The detail
/// layer's levels and coefficients are not in it: a decode takes them from what the
/// budget leaves as it makes them ([`LayerBudget`]).
pub fn decode_memory(
    header: &Header,
    size: (u32, u32),
    supersample: Option<u32>,
    sample_bytes: u64,
) -> u64 {
    decode_memory_at(header, size, None, supersample, sample_bytes)
}

/// [`decode_memory`] of `ow x oh` pixels `spacing` coded pixels apart (a region's
/// window; `None`, the whole image's).
pub(super) fn decode_memory_at(
    header: &Header,
    (ow, oh): (u32, u32),
    spacing: Option<(f64, f64)>,
    supersample: Option<u32>,
    sample_bytes: u64,
) -> u64 {
    let channels = header.layout.channels() as u64;
    let keys = (u64::from(header.luma_count) + u64::from(header.chroma_count)) * KEY_POINT_BYTES;
    let restored = header.post_filtered();
    let per_pixel = match supersample {
        None if restored => (sample_bytes + 4) * channels,
        None => sample_bytes * channels,
        Some(s) => {
            let s = u64::from(s);
            // Restoring the lattice makes one plane of it at a time.
            4 * channels + 4 * (channels + u64::from(restored)) * s * s + 8 * channels + 8
        }
    };
    // The detail layer's bookkeeping per block; its levels and coefficients are taken
    // from what is left as they are made (`LayerBudget`).
    let (cols, rows) = crate::detail::blocks(header.width, header.height);
    let planes = if header.detail_steps.is_some() {
        header.layout.colour_channels() as u64
    } else {
        0
    };
    let blocks =
        caoen_base::budget::bytes(cols as u64 * rows as u64, planes, Detail::BYTES_PER_BLOCK);
    // The post-filters' tasks hold their windows of rows.
    let tasks = if restored {
        let spacing = spacing.unwrap_or((
            f64::from(header.width) / f64::from(ow),
            f64::from(header.height) / f64::from(oh),
        ));
        let colour = header.layout.colour_channels();
        let planes = colour + usize::from(header.layout.has_alpha());
        post::post_task_bytes(
            (ow as usize, oh as usize),
            spacing,
            (colour, planes, header.layout.channels()),
        )
    } else {
        0
    };
    keys.saturating_add(caoen_base::budget::bytes(ow.into(), oh.into(), per_pixel))
        .saturating_add(blocks)
        .saturating_add(tasks)
        .saturating_add(16 << 20)
}

/// Decodes a file into a raster.
pub fn decode(bytes: &[u8], opts: &DecodeOptions) -> Result<Raster, CodecError> {
    decode_parsed(&bitstream::parse(bytes, opts.max_pixels)?, opts)
}

/// [`decode`] of a file already parsed (so a caller that inspected it first does not
/// parse it again).
pub fn decode_parsed(parsed: &Parsed<'_>, opts: &DecodeOptions) -> Result<Raster, CodecError> {
    let s = match opts.supersample {
        None => return decode_identity(parsed, opts),
        Some(s) if opts.region.is_some() => {
            return Err(CodecError::Parameter {
                name: "supersample",
                value: s.to_string(),
                reason: "a region is decoded at pixel centres, without supersampling",
            });
        }
        Some(s) if (1..=4).contains(&s) => s,
        Some(s) => {
            return Err(CodecError::Parameter {
                name: "supersample",
                value: s.to_string(),
                reason: "1..=4",
            });
        }
    };
    let ((ow, oh), base) = output_size(&parsed.header, opts, 4)?;
    let what = decoding(&parsed.header, (ow, oh));
    let layer = layer_budget(opts, base, what.clone());
    let d = read_parsed_within(parsed, &layer)?;
    record_peak(opts, base, &layer, &what);
    if (ow, oh) == (d.header.width, d.header.height) {
        // Forward mapping of an unedited file at its own size reproduces the identity
        // path exactly (each output centre is a lattice sample); skip the extra work.
        return reconstruct::render_identity_raster(&d, ow, oh);
    }
    let planes = forward::render_forward(&d, ow, oh, s)?;
    Ok(to_raster(&d.header, planes, ow, oh))
}

/// [`decode`] by the identity fast path: equal to `render_identity_raster(&read(..)?, ..)`,
/// with the output allocated while the tree decodes.
fn decode_identity(parsed: &Parsed<'_>, opts: &DecodeOptions) -> Result<Raster, CodecError> {
    let (raster, plan) = identity_with(
        parsed,
        opts,
        4,
        |h, (ow, oh)| vec![0.0f32; ow as usize * oh as usize * h.layout.channels()],
        band_pass,
    )?;
    if plan.whole() {
        return Ok(raster);
    }
    let samples = plan.crop(raster.samples(), raster.layout().channels(), true);
    let (ow, oh) = plan.out;
    Raster::from_finite(ow, oh, raster.layout(), raster.format(), samples)
        .map_err(CodecError::DecodedRaster)
}

/// Decodes by the identity fast path straight to interleaved 8- or 16-bit samples (as
/// PNG stores them), band by band, with no full-size float copy: equal to quantising
/// and interleaving [`decode`]'s raster.
pub fn decode_interleaved(
    bytes: &[u8],
    opts: &DecodeOptions,
    depth: Depth,
) -> Result<Interleaved, CodecError> {
    decode_interleaved_parsed(&bitstream::parse(bytes, opts.max_pixels)?, opts, depth)
}

/// [`decode_interleaved`] of a file already parsed.
pub fn decode_interleaved_parsed(
    parsed: &Parsed<'_>,
    opts: &DecodeOptions,
    depth: Depth,
) -> Result<Interleaved, CodecError> {
    let opts = DecodeOptions {
        supersample: None,
        ..opts.clone()
    };
    let sample_bytes = match depth {
        Depth::Eight => 1,
        Depth::Sixteen => 2,
    };
    let (image, plan) = identity_with(
        parsed,
        &opts,
        sample_bytes,
        |h, (ow, oh)| {
            let n = ow as usize * oh as usize * h.layout.channels();
            match depth {
                Depth::Eight => Samples::U8(vec![0; n]),
                Depth::Sixteen => Samples::U16(vec![0; n]),
            }
        },
        |h, luma, chroma, detail, (ow, oh), mut samples| {
            let ok = match &mut samples {
                Samples::U8(out) => band_pass_interleaved(h, luma, chroma, detail, ow, out, |v| {
                    caoen_base::raster::quantise(v, 255.0) as u8
                }),
                Samples::U16(out) => band_pass_interleaved(h, luma, chroma, detail, ow, out, |v| {
                    caoen_base::raster::quantise(v, 65535.0) as u16
                }),
            };
            if !ok {
                return Err(non_finite());
            }
            Ok(Interleaved {
                width: ow,
                height: oh,
                layout: h.layout,
                format: h.format,
                samples,
            })
        },
    )?;
    if plan.whole() {
        return Ok(image);
    }
    let ch = image.layout.channels();
    let samples = match &image.samples {
        Samples::U8(s) => Samples::U8(plan.crop(s, ch, false)),
        Samples::U16(s) => Samples::U16(plan.crop(s, ch, false)),
    };
    Ok(Interleaved {
        width: plan.out.0,
        height: plan.out.1,
        samples,
        ..image
    })
}

/// Bits per sample of [`decode_interleaved`]'s output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Depth {
    /// 8 bits.
    Eight,
    /// 16 bits.
    Sixteen,
}

/// Interleaved integer samples.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Samples {
    /// 8-bit samples.
    U8(Vec<u8>),
    /// 16-bit samples.
    U16(Vec<u16>),
}

/// A decoded image as interleaved integer samples, pixel by pixel, channel by channel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Interleaved {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Channels.
    pub layout: ChannelLayout,
    /// The sample format the image was coded from.
    pub format: SampleFormat,
    /// The samples.
    pub samples: Samples,
}
