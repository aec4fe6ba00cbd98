//! Reconstruction: the key points evaluated into colours by the identity fast path
//! (band by band on a `GridEval`, converted while in cache).

use crate::par::*;

use super::parse::read_parsed_within;
use super::post::{post_filter_rows, post_task_rows, Restored};
use super::region::Plan;
use super::Decoded;
use crate::bitstream::{self, Header};
use crate::colour::{self, CodingPlanes};
use crate::detail::DetailEval;
use crate::geometry::Frame;
use crate::keyset::{BandScratch, Grid, GridEval, KeySet, Vectorisation};
use crate::{CodecError, DecodeOptions};
use caoen_base::raster::Raster;

/// Evaluates the key points at output pixel centres (the identity fast path).
pub fn render_identity(d: &Decoded, ow: u32, oh: u32) -> CodingPlanes<f32> {
    let h = &d.header;
    let frame = Frame::new(h.width, h.height);
    let (luma, chroma) = crate::par::join(
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
    if let Some(r) = &h.restoration {
        r.apply(&mut colour, (ow as usize, oh as usize), spacing(h, ow, oh));
    }
    if let Some(d) = &h.deringing {
        d.apply(
            &mut colour,
            (ow as usize, oh as usize),
            spacing(h, ow, oh),
            h.deringing_steps(),
        );
    }
    if let Some(r) = &h.restoration {
        r.apply_last(
            &mut colour[0],
            (ow as usize, oh as usize),
            spacing(h, ow, oh),
        );
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
    let (luma, chroma) = crate::par::join(
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

pub(super) fn non_finite() -> CodecError {
    CodecError::NonFinite
}

/// The identity path with its output made by `alloc` (while the tree decodes) and filled
/// by `finish` from the two evaluators, over the plan's window (the output, unless a
/// region's filters need margins: the caller crops by the plan).
pub(super) fn identity_with<O: Send, R>(
    parsed: &bitstream::Parsed<'_>,
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
) -> Result<(R, Plan), CodecError> {
    let header = &parsed.header;
    let plan = Plan::new(header, opts, sample_bytes)?;
    let (grid, window) = (plan.grid, plan.window);
    let frame = Frame::new(header.width, header.height);
    let what = super::decoding(header, plan.out);
    let budget = super::layer_budget(opts, plan.need, what.clone());
    let (decoded, samples) = crate::par::join(
        || read_parsed_within(parsed, &budget),
        || alloc(header, window),
    );
    let mut d = decoded?;
    let layer = d.detail.take();
    let to_f32 = |planes: Vec<Vec<f64>>| -> Vec<Vec<f32>> {
        planes
            .into_iter()
            .map(|v| v.into_iter().map(|x| x as f32).collect())
            .collect()
    };
    // Each key set's evaluator on its own thread, the detail layer's on a third.
    let (luma, (chroma, detail)) = crate::par::join(
        || {
            GridEval::new(frame, &d.luma_cells, header.kernel, &grid)
                .with_values(to_f32(d.luma_values))
        },
        || {
            crate::par::join(
                || {
                    (!d.chroma_cells.is_empty()).then(|| {
                        GridEval::new(frame, &d.chroma_cells, header.kernel, &grid)
                            .with_values(to_f32(d.chroma_values))
                    })
                },
                || {
                    layer
                        .map(|dl| DetailEval::from_layer_within(dl, &grid, &budget))
                        .transpose()
                },
            )
        },
    );
    let detail = detail?;
    super::record_peak(opts, plan.need, &budget, &what);
    let out = finish(
        header,
        &luma,
        chroma.as_ref(),
        detail.as_ref(),
        window,
        samples,
    )?;
    Ok((out, plan))
}

/// Evaluates both key sets band by band into `samples` (`ow x oh` pixels of the
/// header's layout, every one overwritten), converting each band's colours while they
/// are still in cache.
pub(super) fn band_pass(
    h: &Header,
    luma: &GridEval,
    chroma: Option<&GridEval>,
    detail: Option<&DetailEval>,
    (ow, oh): (u32, u32),
    mut samples: Vec<f32>,
) -> Result<Raster, CodecError> {
    let n = ow as usize * oh as usize;
    debug_assert_eq!(samples.len(), n * h.layout.channels());
    let restored = restored_planes(h, luma, chroma, detail, (ow, oh));
    let restored = restored.as_ref();
    // Each task's rows of every output plane.
    let band_len = task_rows(restored) * ow as usize;
    let mut bands: Vec<Vec<&mut [f32]>> = (0..(oh as usize).div_ceil(task_rows(restored)))
        .map(|_| Vec::new())
        .collect();
    for plane in samples.chunks_mut(n) {
        for (b, rows) in plane.chunks_mut(band_len).enumerate() {
            bands[b].push(rows);
        }
    }
    let all_finite = bands
        .into_par_iter()
        .enumerate()
        .map_init(
            || (BandScratch::default(), Vec::new(), Vec::new()),
            |(scratch, coding, post), (b, mut out)| {
                band_colours(
                    h,
                    (luma, chroma, detail),
                    restored,
                    b,
                    (scratch, coding, post),
                    &mut out,
                );
                // Checked here, in cache, rather than by a pass over the whole raster. The
                // colour conversion clamps, so only a kernel sum that underflowed could
                // leave a non-finite sample; chunked folds vectorise.
                out.iter().all(|p| {
                    p.chunks(256)
                        .all(|c| c.iter().fold(true, |ok, v| ok & v.is_finite()))
                })
            },
        )
        .all(|ok| ok);
    if !all_finite {
        return Err(non_finite());
    }
    Raster::from_finite(ow, oh, h.layout, h.format, samples).map_err(CodecError::DecodedRaster)
}

/// The evaluators of an identity decode: luma, chroma and the detail layer.
type Evaluators<'a> = (
    &'a GridEval<'a>,
    Option<&'a GridEval<'a>>,
    Option<&'a DetailEval>,
);

/// Output pixels' spacing in coded pixels.
fn spacing(h: &Header, ow: u32, oh: u32) -> (f64, f64) {
    (h.width as f64 / ow as f64, h.height as f64 / oh as f64)
}

/// Evaluates band `b` of both key sets and the detail layer into `coding`: one slice
/// of the band's pixels per coding plane (Y, alpha if any, then C1 and C2).
fn band_coding(
    h: &Header,
    (luma, chroma, detail): Evaluators,
    b: usize,
    len: usize,
    scratch: &mut BandScratch,
    coding: &mut Vec<f32>,
) {
    let nl = 1 + usize::from(h.layout.has_alpha());
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
}

/// The whole output's coding planes for the restoration filters and the deringing, if
/// the file has either.
fn restored_planes(
    h: &Header,
    luma: &GridEval,
    chroma: Option<&GridEval>,
    detail: Option<&DetailEval>,
    (ow, oh): (u32, u32),
) -> Option<Restored> {
    if !h.post_filtered() {
        return None;
    }
    // The grid's spacing: the output's over the whole image, or a region's.
    let g = luma.grid();
    Some(Restored {
        planes: banded_coding(h, (luma, chroma, detail), (ow, oh)),
        size: (ow as usize, oh as usize),
        spacing: (g.dx, g.dy),
    })
}

/// The whole output's coding planes, as [`band_coding`] orders them, bands in parallel.
fn banded_coding(h: &Header, eval: Evaluators, (ow, oh): (u32, u32)) -> Vec<Vec<f32>> {
    let w = ow as usize;
    let nl = 1 + usize::from(h.layout.has_alpha());
    let np = nl + if eval.1.is_some() { 2 } else { 0 };
    let mut planes = vec![vec![0.0f32; w * oh as usize]; np];
    let band_len = GridEval::BAND * w;
    let mut bands: Vec<Vec<&mut [f32]>> = (0..eval.0.bands()).map(|_| Vec::new()).collect();
    for plane in planes.iter_mut() {
        for (b, rows) in plane.chunks_mut(band_len).enumerate() {
            bands[b].push(rows);
        }
    }
    bands.into_par_iter().enumerate().for_each_init(
        || (BandScratch::default(), Vec::new()),
        |(scratch, coding), (b, mut out)| {
            let len = out[0].len();
            band_coding(h, eval, b, len, scratch, coding);
            for (o, c) in out.iter_mut().zip(coding.chunks_exact(len)) {
                o.copy_from_slice(c);
            }
        },
    );
    planes
}

/// The colour planes (Y, or Y, C1, C2) of bands `bands` (of [`GridEval::BAND`] rows)
/// of `d` at its coded size, before restoration, one entry per band: what the encoder
/// fits the restoration filters to.
pub fn unrestored_bands(d: &Decoded, bands: &[usize]) -> Vec<Vec<Vec<f32>>> {
    let h = &d.header;
    let frame = Frame::new(h.width, h.height);
    let grid = Grid::pixel_centres(&frame, h.width, h.height);
    let to_f32 = |planes: &[Vec<f64>]| -> Vec<Vec<f32>> {
        planes
            .iter()
            .map(|v| v.iter().map(|&x| x as f32).collect())
            .collect()
    };
    let luma =
        GridEval::new(frame, &d.luma_cells, h.kernel, &grid).with_values(to_f32(&d.luma_values));
    let chroma = (!d.chroma_cells.is_empty()).then(|| {
        GridEval::new(frame, &d.chroma_cells, h.kernel, &grid).with_values(to_f32(&d.chroma_values))
    });
    let detail = d.detail.as_ref().map(|l| DetailEval::new(l, &grid));
    let eval = (&luma, chroma.as_ref(), detail.as_ref());
    let w = h.width as usize;
    let alpha = h.layout.has_alpha();
    bands
        .par_iter()
        .map_init(
            || (BandScratch::default(), Vec::new()),
            |(scratch, coding), &b| {
                let rows = (h.height as usize - b * GridEval::BAND).min(GridEval::BAND);
                let len = rows * w;
                band_coding(h, eval, b, len, scratch, coding);
                coding
                    .chunks_exact(len)
                    .enumerate()
                    .filter(|&(c, _)| !(alpha && c == 1))
                    .map(|(_, p)| p.to_vec())
                    .collect()
            },
        )
        .collect()
}

/// Band `b` of the coding planes (evaluated, or restored from `restored`), converted
/// to the output colours in `out` (one slice per channel, the band's pixels).
fn band_colours(
    h: &Header,
    eval: Evaluators,
    restored: Option<&Restored>,
    b: usize,
    (scratch, coding, post): (&mut BandScratch, &mut Vec<f32>, &mut Vec<f32>),
    out: &mut [&mut [f32]],
) {
    let len = out[0].len();
    let alpha = h.layout.has_alpha();
    let nl = 1 + usize::from(alpha);
    match restored {
        None => band_coding(h, eval, b, len, scratch, coding),
        Some(r) => {
            let np = r.planes.len();
            coding.resize(np * len, 0.0f32);
            let (w, hh) = r.size;
            let first = b * task_rows(restored);
            let rows = first..(first + len / w).min(hh);
            let mut parts: Vec<&mut [f32]> = coding.chunks_exact_mut(len).collect();
            if alpha {
                parts[1].copy_from_slice(&r.planes[1][rows.start * w..rows.end * w]);
            }
            let colour_idx: Vec<usize> = std::iter::once(0).chain(nl..np).collect();
            let src: Vec<&[f32]> = colour_idx.iter().map(|&c| r.planes[c].as_slice()).collect();
            let mut dst: Vec<&mut [f32]> = parts
                .into_iter()
                .enumerate()
                .filter(|(c, _)| colour_idx.contains(c))
                .map(|(_, p)| p)
                .collect();
            post_filter_rows(h, &src, r, rows, post, &mut dst);
        }
    }
    let parts: Vec<&[f32]> = coding.chunks_exact(len).collect();
    let (lp, cp) = parts.split_at(nl);
    let colour: Vec<&[f32]> = std::iter::once(lp[0]).chain(cp.iter().copied()).collect();
    colour::inverse_span(&colour, alpha.then(|| lp[1]), out, h.format, h.basis);
}

/// Band `b`'s rows of output, in tasks of this many rows: a band of the evaluators, or,
/// with the post-filters, [`post_task_rows`].
fn task_rows(restored: Option<&Restored>) -> usize {
    match restored {
        Some(r) => post_task_rows(r.spacing, r.size.1),
        None => GridEval::BAND,
    }
}

/// [`band_pass`] into interleaved samples converted by `convert`: each band is
/// evaluated into a band-sized planar buffer, checked finite, then converted into its
/// rows of `out`. Returns whether every sample was finite.
pub(super) fn band_pass_interleaved<T: Send>(
    h: &Header,
    luma: &GridEval,
    chroma: Option<&GridEval>,
    detail: Option<&DetailEval>,
    ow: u32,
    out: &mut [T],
    convert: impl Fn(f32) -> T + Sync,
) -> bool {
    let ch = h.layout.channels();
    let oh = out.len() / ch / ow as usize;
    let restored = restored_planes(h, luma, chroma, detail, (ow, oh as u32));
    let restored = restored.as_ref();
    let band_len = task_rows(restored) * ow as usize;
    out.par_chunks_mut(band_len * ch)
        .enumerate()
        .map_init(
            || (BandScratch::default(), Vec::new(), Vec::new(), Vec::new()),
            |(scratch, coding, post, planar), (b, out)| {
                let len = out.len() / ch;
                planar.resize(ch * len, 0.0f32);
                let mut planes: Vec<&mut [f32]> = planar.chunks_exact_mut(len).collect();
                band_colours(
                    h,
                    (luma, chroma, detail),
                    restored,
                    b,
                    (scratch, coding, post),
                    &mut planes,
                );
                let finite = planar.iter().fold(true, |ok, v| ok & v.is_finite());
                for (i, o) in out.iter_mut().enumerate() {
                    *o = convert(planar[(i % ch) * len + i / ch]);
                }
                finite
            },
        )
        .all(|ok| ok)
}

/// The decoded coding planes as a raster of the output size, in the image's colours.
pub fn to_raster<T: colour::CodingValue>(
    header: &Header,
    planes: CodingPlanes<T>,
    ow: u32,
    oh: u32,
) -> Raster {
    let samples = colour::inverse(&planes, ow, oh, header.format, header.basis);
    Raster::new(ow, oh, header.layout, header.format, samples)
        .expect("decoded samples are finite and sized")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bitstream::{TilePayload, TileStreams};
    use crate::decoder::read;
    use crate::deringing::{Deringing, Strengths};
    use crate::restoration::{colour_map::ColourMap, shape, PlaneFilter, Restoration};
    use crate::{decode, DecodeOptions};
    use caoen_base::raster::{ChannelLayout, SampleFormat};
    use caoen_encoder::{encode, EncodeOptions};

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
            let plain = encode(&img, &opts).unwrap();
            // The same file restored: strong taps, so every plane's filter shows.
            let restored = {
                let parsed = bitstream::parse(&plain, u64::MAX).unwrap();
                let mut header = parsed.header.clone();
                header.restoration = Some(Restoration {
                    planes: (0..layout.colour_channels())
                        .map(|c| {
                            let taps = |f: i32| {
                                (0..shape(c).len() as i32)
                                    .map(|k| 40 - 9 * k + 5 * f)
                                    .collect()
                            };
                            // Luma by pixel class, chroma one filter each.
                            Some(match c {
                                0 => PlaneFilter {
                                    filters: vec![taps(0), taps(3)],
                                    classes: Some(std::array::from_fn(|k| (k % 3) as u8)),
                                },
                                _ => PlaneFilter::single(taps(0)),
                            })
                        })
                        .collect(),
                    // A colour map after them: a gain, a cast and an offset in each plane.
                    colour: Some(ColourMap {
                        rows: (0..layout.colour_channels())
                            .map(|c| {
                                (0..=layout.colour_channels())
                                    .map(|k| if k == c { 30 } else { 11 - 7 * k as i32 })
                                    .collect()
                            })
                            .collect(),
                    }),
                    // And last luma filters by pixel class after the deringing.
                    last: Some(PlaneFilter {
                        filters: vec![(0..12).map(|k| 25 - 6 * k).collect(), vec![-9; 12]],
                        classes: Some(std::array::from_fn(|k| (k % 5 % 3) as u8)),
                    }),
                });
                let tiles: Vec<TileStreams> =
                    parsed.tiles.iter().map(TilePayload::to_streams).collect();
                bitstream::write(&header, &parsed.metadata(), &tiles)
            };
            // Both files deringed too (strong, so every plane's filter shows): the
            // deringing reads restored rows past each band.
            let deringed = |bytes: &[u8]| {
                let parsed = bitstream::parse(bytes, u64::MAX).unwrap();
                let mut header = parsed.header.clone();
                let strong = |primary: u8| Strengths {
                    primary,
                    secondary: primary / 3,
                    cutoff: 60,
                };
                header.deringing = Some(Deringing {
                    luma: strong(200),
                    chroma: if layout.colour_channels() == 3 {
                        strong(90)
                    } else {
                        Strengths::OFF
                    },
                });
                let tiles: Vec<TileStreams> =
                    parsed.tiles.iter().map(TilePayload::to_streams).collect();
                bitstream::write(&header, &parsed.metadata(), &tiles)
            };
            let both = [deringed(&plain), deringed(&restored)];
            for bytes in [plain, restored].into_iter().chain(both) {
                let d = read(&bytes, u64::MAX).unwrap();
                // Coded size, then up- and downscaled: bands of every height, the last short;
                // at 9x down, tasks whose deringing blocks (72 rows) cross their ends.
                for (ow, oh) in [
                    (w, h),
                    (2 * w + 3, 17),
                    (11, 3 * h + 1),
                    (20, 9 * h),
                    (1, 1),
                ] {
                    let fused = render_identity_raster(&d, ow, oh).unwrap();
                    let reference = to_raster(&d.header, render_identity(&d, ow, oh), ow, oh);
                    assert_eq!(
                        fused.samples(),
                        reference.samples(),
                        "{layout:?} {format:?} at {ow}x{oh}"
                    );
                    assert_eq!((fused.layout(), fused.format()), (layout, format));
                    // The portable scalar path gives the same bits as the vector unit.
                    let scalar =
                        render_identity_raster_on(&d, ow, oh, Vectorisation::Scalar).unwrap();
                    assert_eq!(
                        scalar.samples(),
                        fused.samples(),
                        "scalar vs dispatched ({}) at {ow}x{oh}",
                        if crate::keyset::has_vector_unit() {
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
                }
            }
        }
    }
}
