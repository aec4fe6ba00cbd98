//! The decoder: parse, rebuild the key points, evaluate the network.
//!
//! Two evaluation paths: the identity fast path evaluates colours at output pixel
//! centres band by band through [`GridEval`] (luma and chroma side by side, each band
//! converted to output colours while in cache); the forward-mapping path samples the domain
//! S x S times per pixel, maps every sample through the core [`Network`] to an output
//! position and colour, and splats the colour there (the paper's depth-buffer method in
//! 2-D), filling any pixel no sample reached from its neighbours.
//!
//! The position outputs interpolate key-point *displacements* (edited minus original
//! position; zero in a file that was not edited), added to the sample's own position.
//! Interpolating the key points' absolute positions instead would shift edges: the
//! normalised average of cell centres is biased wherever cell sizes change.

use rayon::prelude::*;

use super::bitstream::{self, Header, Parsed, TilePayload};
use super::colour::{self, CodingPlanes};
use super::detail::dct::N as DCT_N;
use super::detail::{blocks as detail_blocks, Detail, DetailEval, DetailPlane};
use super::entropy::AnsSource;
use super::geometry::Frame;
use super::keyset::{BandScratch, Grid, GridEval, KeySet, Vectorisation};
use super::model::chroma_cells;
use super::quadtree::{Cell, TreeShape};
use super::syntax::{self, MAX_SYMBOLS_PER_VALUE};
use super::tiling::into_image_order;
use super::{CodecError, DecodeOptions, MAX_SIDE};
use crate::raster::{ChannelLayout, Raster, SampleFormat};

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

/// Entropy-decodes one value section: `channels` planes of quantised values over
/// `cells`.
fn read_section(
    payload: &[u8],
    cells: &[Cell],
    (width, height): (u32, u32),
    channels: usize,
) -> Result<Vec<Vec<i64>>, CodecError> {
    let max_symbols = MAX_SYMBOLS_PER_VALUE * cells.len() as u64 * channels as u64;
    let mut src = AnsSource::new(payload, max_symbols)?;
    let values = syntax::read_channels(cells, width, height, channels, &mut src)?;
    if !src.finished_cleanly() {
        return Err(CodecError::Format(
            "entropy-coded payload does not end where its syntax does".into(),
        ));
    }
    Ok(values)
}

/// Quantised planes times their steps: the key points' values.
fn dequantise<T>(planes: Vec<Vec<i64>>, steps: &[f64], to: impl Fn(f64) -> T) -> Vec<Vec<T>> {
    planes
        .into_iter()
        .zip(steps)
        .map(|(v, &step)| v.into_iter().map(|q| to(q as f64 * step)).collect())
        .collect()
}

/// The quantiser steps of the luma set's channels (Y, then alpha) and of chroma.
fn steps(header: &Header) -> (Vec<f64>, [f64; 2]) {
    let mut luma = vec![header.step_luma as f64];
    if header.layout.has_alpha() {
        luma.push(header.step_alpha as f64);
    }
    let c = header.step_chroma as f64;
    (luma, [c, c])
}

/// One tile's key points (image coordinates, the tile's coding order), their
/// quantised values and its detail planes.
struct TileDecoded {
    luma_cells: Vec<Cell>,
    chroma_cells: Vec<Cell>,
    luma_values: Vec<Vec<i64>>,
    chroma_values: Vec<Vec<i64>>,
    detail: Option<Detail>,
}

/// The detail layer's quantiser steps, one per colour channel, if the file has it.
fn detail_steps(header: &Header) -> Option<Vec<f64>> {
    let [luma, chroma] = header.detail_steps?;
    let mut steps = vec![luma as f64];
    if header.layout.colour_channels() == 3 {
        steps.extend([chroma as f64; 2]);
    }
    Some(steps)
}

/// Entropy-decodes one tile: tree, values (luma and chroma side by side) and detail.
fn read_tile(header: &Header, t: &TilePayload) -> Result<TileDecoded, CodecError> {
    let r = t.rect;
    let shape = TreeShape {
        width: r.width,
        height: r.height,
        block_log2: header.block_log2,
        min_log2: header.min_log2,
    };
    let mut src = AnsSource::new(t.tree, shape.max_flags())?;
    let cells = syntax::read_tree(&shape, t.luma_count as usize, &mut src)?;
    if cells.len() != t.luma_count as usize {
        return Err(CodecError::Format(format!(
            "a tile's tree has {} leaves, its header says {}",
            cells.len(),
            t.luma_count
        )));
    }
    if !src.finished_cleanly() {
        return Err(CodecError::Format(
            "tree payload does not end where the tree does".into(),
        ));
    }
    let size = (r.width, r.height);
    let (luma_steps, _) = steps(header);
    let colour = header.layout.colour_channels() == 3;
    // The streams are independent; each finds its neighbours while decoding (and
    // chroma its cells first).
    let (luma, (chroma, detail)) = rayon::join(
        || read_section(t.luma, &cells, size, luma_steps.len()),
        || {
            rayon::join(
                || -> Result<_, CodecError> {
                    if !colour {
                        return Ok((Vec::new(), Vec::new()));
                    }
                    let cc = chroma_cells(&shape, &cells, header.chroma_pruned);
                    if cc.len() != t.chroma_count as usize {
                        return Err(CodecError::Format(format!(
                            "a tile's chroma tree has {} leaves, its header says {}",
                            cc.len(),
                            t.chroma_count
                        )));
                    }
                    let values = read_section(t.chroma, &cc, size, 2)?;
                    Ok((cc, values))
                },
                || -> Result<_, CodecError> {
                    match detail_steps(header) {
                        Some(steps) if !t.detail.is_empty() => {
                            Detail::read(t.detail, r.width, r.height, steps).map(Some)
                        }
                        _ => Ok(None),
                    }
                },
            )
        },
    );
    let (chroma_cells, chroma_values) = chroma?;
    Ok(TileDecoded {
        luma_cells: cells.into_iter().map(|c| r.to_image(c)).collect(),
        chroma_cells: chroma_cells.into_iter().map(|c| r.to_image(c)).collect(),
        luma_values: luma?,
        chroma_values,
        detail: detail?,
    })
}

/// Entropy-decodes every tile (in parallel) and joins them into the image's key points
/// in its coding order and its detail layer.
pub fn read_parsed(parsed: &Parsed) -> Result<Decoded, CodecError> {
    let header = parsed.header.clone();
    let tiles = parsed
        .tiles
        .par_iter()
        .map(|t| read_tile(&header, t))
        .collect::<Result<Vec<_>, _>>()?;
    let (luma_steps, chroma_steps) = steps(&header);
    let mut luma_cells = Vec::with_capacity(header.luma_count as usize);
    let mut chroma_cells = Vec::with_capacity(header.chroma_count as usize);
    let mut luma_values: Vec<Vec<i64>> = vec![Vec::new(); luma_steps.len()];
    let colour = header.layout.colour_channels() == 3;
    let mut chroma_values: Vec<Vec<i64>> = vec![Vec::new(); if colour { 2 } else { 0 }];
    let mut details = Vec::with_capacity(tiles.len());
    for (t, p) in tiles.into_iter().zip(&parsed.tiles) {
        luma_cells.extend(t.luma_cells);
        chroma_cells.extend(t.chroma_cells);
        for (all, v) in luma_values.iter_mut().zip(t.luma_values) {
            all.extend(v);
        }
        for (all, v) in chroma_values.iter_mut().zip(t.chroma_values) {
            all.extend(v);
        }
        let planes: Vec<Option<DetailPlane>> = match t.detail {
            Some(d) => d.planes.into_iter().map(Some).collect(),
            None => Vec::new(),
        };
        details.push((p.rect, planes));
    }
    let (luma_cells, luma_values) = into_image_order(&luma_cells, &luma_values, header.block_log2);
    let (chroma_cells, chroma_values) =
        into_image_order(&chroma_cells, &chroma_values, header.block_log2);
    let detail = detail_steps(&header).map(|steps| {
        let (cols, rows) = detail_blocks(header.width, header.height);
        let planes = (0..steps.len())
            .map(|c| {
                DetailPlane::from_tiles(
                    cols,
                    rows,
                    details.iter_mut().map(|(r, planes)| {
                        let at = (r.x0 as usize / DCT_N, r.y0 as usize / DCT_N);
                        (at, planes.get_mut(c).and_then(Option::take))
                    }),
                )
            })
            .collect();
        Detail { planes, steps }
    });
    Ok(Decoded {
        luma_values: dequantise(luma_values, &luma_steps, |v| v),
        chroma_values: dequantise(chroma_values, &chroma_steps, |v| v),
        detail,
        header,
        luma_cells,
        chroma_cells,
    })
}

/// Parses and entropy-decodes a file (no pixel evaluation).
pub fn read(bytes: &[u8], max_pixels: u64) -> Result<Decoded, CodecError> {
    read_parsed(&bitstream::parse(bytes, max_pixels)?)
}

fn output_size(
    header: &Header,
    opts: &DecodeOptions,
    sample_bytes: u64,
) -> Result<(u32, u32), CodecError> {
    let (ow, oh) = opts.size.unwrap_or((header.width, header.height));
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
    opts.limits.check(
        || format!("decoding {}x{} to {ow}x{oh}", header.width, header.height),
        decode_memory(header, (ow, oh), opts.supersample, sample_bytes),
    )?;
    Ok((ow, oh))
}

/// Bytes per key point while decoding: its cell, values, splat window entry and, on
/// the forward path, its kernel and bucket entries.
const KEY_POINT_BYTES: u64 = 256;

/// Estimated peak memory of decoding a file with `header` to `ow x oh` pixels, in
/// bytes: the key points, the output of `sample_bytes` per sample (4 for a raster, 1
/// or 2 for [`decode_interleaved`]) and, for forward mapping with `S x S` samples, the
/// sample lattice and the accumulation planes.
pub fn decode_memory(
    header: &Header,
    (ow, oh): (u32, u32),
    supersample: Option<u32>,
    sample_bytes: u64,
) -> u64 {
    let channels = header.layout.channels() as u64;
    let keys = (u64::from(header.luma_count) + u64::from(header.chroma_count)) * KEY_POINT_BYTES;
    let per_pixel = match supersample {
        None => sample_bytes * channels,
        Some(s) => {
            let s = u64::from(s);
            4 * channels + 4 * channels * s * s + 8 * channels + 8
        }
    };
    keys.saturating_add(crate::budget::bytes(ow.into(), oh.into(), per_pixel))
        .saturating_add(16 << 20)
}

/// Decodes a file into a raster.
pub fn decode(bytes: &[u8], opts: &DecodeOptions) -> Result<Raster, CodecError> {
    let s = match opts.supersample {
        None => return decode_identity(bytes, opts),
        Some(s) if (1..=4).contains(&s) => s,
        Some(s) => {
            return Err(CodecError::Parameter {
                name: "supersample",
                value: s.to_string(),
                reason: "1..=4",
            });
        }
    };
    let d = read(bytes, opts.max_pixels)?;
    let (ow, oh) = output_size(&d.header, opts, 4)?;
    if (ow, oh) == (d.header.width, d.header.height) {
        // Forward mapping of an unedited file at its own size reproduces the identity
        // path exactly (each output centre is a lattice sample); skip the extra work.
        return render_identity_raster(&d, ow, oh);
    }
    let planes = render_forward(&d, ow, oh, s)?;
    Ok(to_raster(&d.header, planes, ow, oh))
}

/// Evaluates the key points at output pixel centres (the identity fast path).
pub fn render_identity(d: &Decoded, ow: u32, oh: u32) -> CodingPlanes<f32> {
    let h = &d.header;
    let frame = Frame::new(h.width, h.height);
    let (luma, chroma) = rayon::join(
        || KeySet::new(frame, &d.luma_cells, h.kernel).render(&d.luma_values, ow, oh),
        || {
            if d.chroma_cells.is_empty() {
                Vec::new()
            } else {
                KeySet::new(frame, &d.chroma_cells, h.kernel).render(&d.chroma_values, ow, oh)
            }
        },
    );
    let mut luma = luma.into_iter();
    let mut colour: Vec<Vec<f32>> = luma.next().into_iter().collect();
    colour.extend(chroma);
    if let Some(detail) = &d.detail {
        let grid = Grid::pixel_centres(&frame, ow, oh);
        let mut out: Vec<&mut [f32]> = colour.iter_mut().map(|p| p.as_mut_slice()).collect();
        DetailEval::new(detail, &grid).add_rows(0, &mut out);
    }
    CodingPlanes {
        colour,
        alpha: luma.next().filter(|_| h.layout.has_alpha()),
    }
}

/// The identity fast path straight to raster samples: equal to
/// `to_raster(render_identity(..))`, but band by band, luma and chroma side by side and
/// each band's colours converted while still in cache, so no full-size coding planes
/// are made.
pub fn render_identity_raster(d: &Decoded, ow: u32, oh: u32) -> Result<Raster, CodecError> {
    render_identity_raster_on(d, ow, oh, Vectorisation::Dispatched)
}

/// [`render_identity_raster`] on the given instruction set.
pub fn render_identity_raster_on(
    d: &Decoded,
    ow: u32,
    oh: u32,
    v: Vectorisation,
) -> Result<Raster, CodecError> {
    let h = &d.header;
    let frame = Frame::new(h.width, h.height);
    let grid = Grid::pixel_centres(&frame, ow, oh);
    let to_f32 = |planes: &[Vec<f64>]| -> Vec<Vec<f32>> {
        planes
            .iter()
            .map(|v| v.iter().map(|&x| x as f32).collect())
            .collect()
    };
    let (luma, chroma) = rayon::join(
        || {
            GridEval::new(frame, &d.luma_cells, h.kernel, &grid)
                .on(v)
                .with_values(to_f32(&d.luma_values))
        },
        || {
            (!d.chroma_cells.is_empty()).then(|| {
                GridEval::new(frame, &d.chroma_cells, h.kernel, &grid)
                    .on(v)
                    .with_values(to_f32(&d.chroma_values))
            })
        },
    );
    let detail = d.detail.as_ref().map(|d| DetailEval::new(d, &grid));
    let samples = vec![0.0f32; ow as usize * oh as usize * h.layout.channels()];
    band_pass(
        h,
        &luma,
        chroma.as_ref(),
        detail.as_ref(),
        (ow, oh),
        samples,
    )
}

/// [`decode`] by the identity fast path: equal to `render_identity_raster(&read(..)?, ..)`,
/// with the output allocated while the tree decodes.
fn decode_identity(bytes: &[u8], opts: &DecodeOptions) -> Result<Raster, CodecError> {
    identity_with(
        bytes,
        opts,
        4,
        |h, (ow, oh)| vec![0.0f32; ow as usize * oh as usize * h.layout.channels()],
        band_pass,
    )
}

/// Decodes by the identity fast path straight to interleaved 8- or 16-bit samples (as
/// PNG stores them), band by band, with no full-size float copy: equal to quantising
/// and interleaving [`decode`]'s raster.
pub fn decode_interleaved(
    bytes: &[u8],
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
    identity_with(
        bytes,
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
                    crate::image_io::quantise(v, 255.0) as u8
                }),
                Samples::U16(out) => band_pass_interleaved(h, luma, chroma, detail, ow, out, |v| {
                    crate::image_io::quantise(v, 65535.0) as u16
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
    )
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

fn non_finite() -> CodecError {
    CodecError::Format("the key points evaluate to a non-finite colour".into())
}

/// The identity path with its output made by `alloc` (while the tree decodes) and filled
/// by `finish` from the two evaluators.
fn identity_with<O: Send, R>(
    bytes: &[u8],
    opts: &DecodeOptions,
    sample_bytes: u64,
    alloc: impl FnOnce(&Header, (u32, u32)) -> O + Send,
    finish: impl FnOnce(
        &Header,
        &GridEval,
        Option<&GridEval>,
        Option<&DetailEval>,
        (u32, u32),
        O,
    ) -> Result<R, CodecError>,
) -> Result<R, CodecError> {
    let parsed = bitstream::parse(bytes, opts.max_pixels)?;
    let header = &parsed.header;
    let (ow, oh) = output_size(header, opts, sample_bytes)?;
    let frame = Frame::new(header.width, header.height);
    let grid = Grid::pixel_centres(&frame, ow, oh);
    let (decoded, samples) = rayon::join(|| read_parsed(&parsed), || alloc(header, (ow, oh)));
    let mut d = decoded?;
    let layer = d.detail.take();
    let to_f32 = |planes: Vec<Vec<f64>>| -> Vec<Vec<f32>> {
        planes
            .into_iter()
            .map(|v| v.into_iter().map(|x| x as f32).collect())
            .collect()
    };
    // Each key set's evaluator on its own thread, the detail layer's on a third.
    let (luma, (chroma, detail)) = rayon::join(
        || {
            GridEval::new(frame, &d.luma_cells, header.kernel, &grid)
                .with_values(to_f32(d.luma_values))
        },
        || {
            rayon::join(
                || {
                    (!d.chroma_cells.is_empty()).then(|| {
                        GridEval::new(frame, &d.chroma_cells, header.kernel, &grid)
                            .with_values(to_f32(d.chroma_values))
                    })
                },
                || layer.map(|dl| DetailEval::from_layer(dl, &grid)),
            )
        },
    );
    finish(
        header,
        &luma,
        chroma.as_ref(),
        detail.as_ref(),
        (ow, oh),
        samples,
    )
}

/// Evaluates both key sets band by band into `samples` (`ow x oh` pixels of the
/// header's layout, every one overwritten), converting each band's colours while they
/// are still in cache.
fn band_pass(
    h: &Header,
    luma: &GridEval,
    chroma: Option<&GridEval>,
    detail: Option<&DetailEval>,
    (ow, oh): (u32, u32),
    mut samples: Vec<f32>,
) -> Result<Raster, CodecError> {
    let n = ow as usize * oh as usize;
    debug_assert_eq!(samples.len(), n * h.layout.channels());
    // Each band's rows of every output plane, handed to one task.
    let band_len = GridEval::BAND * ow as usize;
    let mut bands: Vec<Vec<&mut [f32]>> = (0..luma.bands()).map(|_| Vec::new()).collect();
    for plane in samples.chunks_mut(n) {
        for (b, rows) in plane.chunks_mut(band_len).enumerate() {
            bands[b].push(rows);
        }
    }
    let finite = bands.into_par_iter().enumerate().map_init(
        || (BandScratch::default(), Vec::new()),
        |(scratch, coding), (b, mut out)| {
            band_colours(h, luma, chroma, detail, b, scratch, coding, &mut out);
            // Checked here, in cache, rather than by a pass over the whole raster. The
            // colour conversion clamps, so only a kernel sum that underflowed could
            // leave a non-finite sample; chunked folds vectorise.
            out.iter().all(|p| {
                p.chunks(256)
                    .all(|c| c.iter().fold(true, |ok, v| ok & v.is_finite()))
            })
        },
    );
    if !finite.all(|ok| ok) {
        return Err(non_finite());
    }
    Raster::from_finite(ow, oh, h.layout, h.format, samples)
        .map_err(|e| CodecError::Format(format!("decoded raster: {e}")))
}

/// Evaluates band `b` of both key sets into `coding` and converts it to the output
/// colours in `out` (one slice per channel, the band's pixels).
#[allow(clippy::too_many_arguments)]
fn band_colours(
    h: &Header,
    luma: &GridEval,
    chroma: Option<&GridEval>,
    detail: Option<&DetailEval>,
    b: usize,
    scratch: &mut BandScratch,
    coding: &mut Vec<f32>,
    out: &mut [&mut [f32]],
) {
    let len = out[0].len();
    let alpha = h.layout.has_alpha();
    let nl = 1 + usize::from(alpha);
    let nch = if chroma.is_some() { 2 } else { 0 };
    // Every value is overwritten below: no need to clear.
    coding.resize((nl + nch) * len, 0.0f32);
    let mut parts: Vec<&mut [f32]> = coding.chunks_exact_mut(len).collect();
    let (lp, cp) = parts.split_at_mut(nl);
    // Both key sets sit on the same grid: one set of conformal factors.
    luma.conformal(b, scratch);
    luma.eval_band(b, scratch, lp);
    if let Some(chroma) = &chroma {
        chroma.eval_band(b, scratch, cp);
    }
    if let Some(detail) = detail {
        let mut colour: Vec<&mut [f32]> = std::iter::once(&mut *lp[0])
            .chain(cp.iter_mut().map(|p| &mut **p))
            .collect();
        detail.add_rows(b * GridEval::BAND, &mut colour);
    }
    let colour: Vec<&[f32]> = std::iter::once(&*lp[0])
        .chain(cp.iter().map(|p| &**p))
        .collect();
    colour::inverse_span(&colour, alpha.then(|| &*lp[1]), out, h.format);
}

/// [`band_pass`] into interleaved samples converted by `convert`: each band is
/// evaluated into a band-sized planar buffer, checked finite, then converted into its
/// rows of `out`. Returns whether every sample was finite.
fn band_pass_interleaved<T: Send>(
    h: &Header,
    luma: &GridEval,
    chroma: Option<&GridEval>,
    detail: Option<&DetailEval>,
    ow: u32,
    out: &mut [T],
    convert: impl Fn(f32) -> T + Sync,
) -> bool {
    let ch = h.layout.channels();
    let band_len = GridEval::BAND * ow as usize;
    out.par_chunks_mut(band_len * ch)
        .enumerate()
        .map_init(
            || (BandScratch::default(), Vec::new(), Vec::new()),
            |(scratch, coding, planar), (b, out)| {
                let len = out.len() / ch;
                planar.resize(ch * len, 0.0f32);
                let mut planes: Vec<&mut [f32]> = planar.chunks_exact_mut(len).collect();
                band_colours(h, luma, chroma, detail, b, scratch, coding, &mut planes);
                let finite = planar.iter().fold(true, |ok, v| ok & v.is_finite());
                for (i, o) in out.iter_mut().enumerate() {
                    *o = convert(planar[(i % ch) * len + i / ch]);
                }
                finite
            },
        )
        .all(|ok| ok)
}

/// Forward mapping with `s x s` samples per output pixel.
///
/// Samples lie on the lattice refined by `1/s` that contains every output pixel centre;
/// each mapped sample is splatted with a tent one lattice step wide (linear splatting),
/// so a sample landing on a pixel centre decides that pixel alone and samples between
/// centres interpolate. An unedited file therefore reproduces the identity path, and a
/// warped one is reconstructed from `s x s` times denser samples. Along an axis where
/// the output is smaller than the coded image, the tent widens to one output pixel (a
/// triangle filter), so the extra samples anti-alias the downscale.
///
/// The network is evaluated on the whole lattice by [`KeySet::eval_grid`] (tested equal
/// to the core network). Its position outputs are the sample's own position plus the
/// interpolated key-point displacements; version 2 files carry no displacements, so
/// those outputs are the lattice positions themselves and are not evaluated.
pub fn render_forward(
    d: &Decoded,
    ow: u32,
    oh: u32,
    s: u32,
) -> Result<CodingPlanes<f32>, CodecError> {
    let h = &d.header;
    let frame = Frame::new(h.width, h.height);
    let (sx, sy) = (h.width as f64 / ow as f64, h.height as f64 / oh as f64);
    let (owu, ohu) = (ow as usize, oh as usize);
    let ss = s as usize;
    let step = 1.0 / s as f64;
    let first = -((ss / 2) as f64) * step;
    // Lattice point (i, j) sits at output position (0.5 + first + i step, ...), which is
    // coded position (that x sx, that y sy).
    let grid = Grid {
        x0: (0.5 + first) * sx,
        dx: step * sx,
        nx: owu * ss,
        y0: (0.5 + first) * sy,
        dy: step * sy,
        ny: ohu * ss,
    };
    let mut samples = KeySet::new(frame, &d.luma_cells, h.kernel).eval_grid(&d.luma_values, &grid);
    let nl = samples.len();
    if !d.chroma_cells.is_empty() {
        samples.extend(
            KeySet::new(frame, &d.chroma_cells, h.kernel).eval_grid(&d.chroma_values, &grid),
        );
    }
    if let Some(detail) = &d.detail {
        // The layer's cosine series at the lattice positions, added to the colour
        // outputs (Y, then C1 and C2 after the luma set's alpha).
        let layer = DetailEval::new(detail, &grid).eval();
        let colour = std::iter::once(0).chain(nl..nl + 2);
        for (c, plane) in colour.zip(layer) {
            for (s, v) in samples[c].iter_mut().zip(plane) {
                *s += v;
            }
        }
    }
    let nc = samples.len();
    let mut planes = vec![vec![0.0f64; owu * ohu]; nc];
    let mut weight = vec![0.0; owu * ohu];
    let (rx, ry) = (
        if sx > 1.0 { 1.0 } else { step },
        if sy > 1.0 { 1.0 } else { step },
    );
    for lj in 0..grid.ny {
        let y = 0.5 + first + lj as f64 * step;
        // Pixel rows within the tent's reach of the sample row.
        let (j0, j1) = (
            (y - 0.5 - ry).ceil().max(0.0),
            (y - 0.5 + ry).floor().min(ohu as f64 - 1.0),
        );
        for li in 0..grid.nx {
            let x = 0.5 + first + li as f64 * step;
            let k = lj * grid.nx + li;
            let (i0, i1) = (
                (x - 0.5 - rx).ceil().max(0.0),
                (x - 0.5 + rx).floor().min(owu as f64 - 1.0),
            );
            let mut j = j0;
            while j <= j1 {
                let wy = 1.0 - (y - (j + 0.5)).abs() / ry;
                let mut i = i0;
                while i <= i1 {
                    let wx = 1.0 - (x - (i + 0.5)).abs() / rx;
                    let w = wx * wy;
                    if w > 0.0 {
                        let idx = j as usize * owu + i as usize;
                        weight[idx] += w;
                        for c in 0..nc {
                            planes[c][idx] += w * samples[c][k] as f64;
                        }
                    }
                    i += 1.0;
                }
                j += 1.0;
            }
        }
    }
    for idx in 0..owu * ohu {
        if weight[idx] > 0.0 {
            for p in planes.iter_mut() {
                p[idx] /= weight[idx];
            }
        }
    }
    fill_holes(&mut planes, &mut weight, owu, ohu);
    let mut planes = planes
        .into_iter()
        .map(|p| p.into_iter().map(|v| v as f32).collect::<Vec<f32>>());
    let mut colour: Vec<Vec<f32>> = planes.by_ref().take(1).collect();
    let alpha = if nl > 1 { planes.next() } else { None };
    colour.extend(planes);
    Ok(CodingPlanes { colour, alpha })
}

/// Fills pixels no sample reached by repeatedly averaging their filled neighbours
/// (a push-pull fill at full resolution: terminates because each pass fills at least
/// the holes next to filled pixels).
pub(crate) fn fill_holes(planes: &mut [Vec<f64>], weight: &mut [f64], w: usize, h: usize) {
    if weight.iter().all(|&v| v > 0.0) || weight.iter().all(|&v| v == 0.0) {
        return;
    }
    loop {
        let holes: Vec<usize> = (0..w * h).filter(|&i| weight[i] == 0.0).collect();
        if holes.is_empty() {
            return;
        }
        let mut filled = Vec::new();
        for &i in &holes {
            let (x, y) = (i % w, i / w);
            let mut n = 0.0;
            let mut sum = vec![0.0; planes.len()];
            for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                if nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h {
                    let j = ny as usize * w + nx as usize;
                    if weight[j] > 0.0 {
                        n += 1.0;
                        for (c, p) in planes.iter().enumerate() {
                            sum[c] += p[j];
                        }
                    }
                }
            }
            if n > 0.0 {
                filled.push((i, sum.into_iter().map(|v| v / n).collect::<Vec<_>>()));
            }
        }
        for (i, vals) in filled {
            weight[i] = 1.0;
            for (c, v) in vals.into_iter().enumerate() {
                planes[c][i] = v;
            }
        }
    }
}

pub(crate) fn to_raster<T: colour::CodingValue>(
    header: &Header,
    planes: CodingPlanes<T>,
    ow: u32,
    oh: u32,
) -> Raster {
    let samples = colour::inverse(&planes, ow, oh, header.format);
    Raster::new(ow, oh, header.layout, header.format, samples)
        .expect("decoded samples are finite and sized")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::{encode, DecodeOptions, EncodeOptions};
    use crate::raster::{ChannelLayout, SampleFormat};

    #[test]
    fn fused_identity_path_equals_planes_then_colour_conversion() {
        let (w, h) = (45u32, 37u32);
        let n = (w * h) as usize;
        let wave = |c: usize, hdr: bool| {
            (0..n).map(move |i| {
                let (x, y) = ((i % w as usize) as f32, (i / w as usize) as f32);
                let v = 0.5 + 0.45 * ((x * 0.31 + c as f32).sin() * (y * 0.23 - c as f32).cos());
                if hdr {
                    v * v * 40.0
                } else {
                    v
                }
            })
        };
        for (layout, format) in [
            (ChannelLayout::Grey, SampleFormat::U8),
            (ChannelLayout::GreyAlpha, SampleFormat::U16),
            (ChannelLayout::Rgb, SampleFormat::U8),
            (ChannelLayout::Rgba, SampleFormat::U16),
            (ChannelLayout::Rgb, SampleFormat::F32),
            (ChannelLayout::Grey, SampleFormat::F32),
        ] {
            let hdr = format == SampleFormat::F32;
            let samples = (0..layout.channels()).flat_map(|c| wave(c, hdr)).collect();
            let img = Raster::new(w, h, layout, format, samples).unwrap();
            let opts = EncodeOptions {
                quality: 90.0,
                ..EncodeOptions::default()
            };
            let bytes = encode(&img, &opts).unwrap();
            let d = read(&bytes, u64::MAX).unwrap();
            // Coded size, then up- and downscaled: bands of every height, the last short.
            for (ow, oh) in [(w, h), (2 * w + 3, 17), (11, 3 * h + 1), (1, 1)] {
                let fused = render_identity_raster(&d, ow, oh).unwrap();
                let reference = to_raster(&d.header, render_identity(&d, ow, oh), ow, oh);
                assert_eq!(
                    fused.samples(),
                    reference.samples(),
                    "{layout:?} {format:?} at {ow}x{oh}"
                );
                assert_eq!((fused.layout(), fused.format()), (layout, format));
                // The portable scalar path gives the same bits as the vector unit.
                let scalar = render_identity_raster_on(&d, ow, oh, Vectorisation::Scalar).unwrap();
                assert_eq!(
                    scalar.samples(),
                    fused.samples(),
                    "scalar vs dispatched ({}) at {ow}x{oh}",
                    if super::super::keyset::has_vector_unit() {
                        "vector unit"
                    } else {
                        "no vector unit on this CPU"
                    }
                );
                // The overlapped decoder builds the same evaluators in another order.
                let decoded = decode(
                    &bytes,
                    &DecodeOptions {
                        size: Some((ow, oh)),
                        ..DecodeOptions::default()
                    },
                )
                .unwrap();
                assert_eq!(decoded.samples(), fused.samples(), "decode at {ow}x{oh}");
                // Straight to integer samples: the same PNG as through the raster.
                let opts = DecodeOptions {
                    size: Some((ow, oh)),
                    ..DecodeOptions::default()
                };
                for (depth, png) in [
                    (Depth::Eight, crate::image_io::OutputFormat::Png8),
                    (Depth::Sixteen, crate::image_io::OutputFormat::Png16),
                ] {
                    let direct = decode_interleaved(&bytes, &opts, depth).unwrap();
                    assert_eq!((direct.width, direct.height), (ow, oh));
                    assert_eq!(
                        crate::image_io::encode_png_interleaved(&direct, Default::default())
                            .unwrap(),
                        crate::image_io::encode(&decoded, png).unwrap(),
                        "{layout:?} {format:?} {depth:?} at {ow}x{oh}"
                    );
                }
            }
        }
    }
}
