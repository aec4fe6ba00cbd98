//! Reconstruction: the key points evaluated into colours by the identity fast path
//! (band by band on a `GridEval`, converted while in cache).

use crate::par::*;

use super::parse::read_parsed_within;
use super::region::Plan;
use super::Decoded;
use crate::bitstream::{self, Header};
use crate::colour::{self, CodingPlanes};
use crate::deringing::{self, Deringing};
use crate::detail::DetailEval;
use crate::geometry::Frame;
use crate::keyset::{BandScratch, Grid, GridEval, KeySet, Vectorisation};
use crate::restoration::Restoration;
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

/// The whole output's coding planes (as [`band_coding`] orders them) before
/// restoration and deringing, when the file has either: the filters reach across
/// bands.
struct Restored {
    planes: Vec<Vec<f32>>,
    size: (usize, usize),
    spacing: (f64, f64),
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

/// Evaluation bands in a task of the post-filtered path, at least.
const POST_FILTER_BANDS: usize = 4;

/// Rows of a task of the post-filtered path at `spacing` coded pixels per output pixel,
/// on an output `h` rows high. A task restores rows past its own on either side
/// ([`post_margin`], which grows with the zoom): four times those, so that they stay a
/// small part of its work at any zoom, unless that leaves a worker without a task or
/// two; at the coded size a whole number of deringing blocks, so that tasks start on
/// a block. The rows a task covers never change its output.
fn post_task_rows(spacing: (f64, f64), h: usize) -> usize {
    let scale = deringing::scale(spacing);
    // Every worker a task or two even when the margins are much of the output.
    let most = h.div_ceil(2 * crate::par::workers()).max(1);
    let rows = (GridEval::BAND * POST_FILTER_BANDS).max((4 * post_margin(spacing)).min(most));
    if sparse_directions(scale) {
        rows
    } else {
        let side = deringing::BLOCK * scale.1;
        rows.div_ceil(side) * side
    }
}

/// Rows a task of the post-filtered path at `spacing` restores past each end of its
/// own, at most: the last filter's reach, then the deringing's (its taps', or up to a
/// direction block's).
fn post_margin(spacing: (f64, f64)) -> usize {
    let scale = deringing::scale(spacing);
    let deringing = if sparse_directions(scale) {
        Deringing::tap_rows(scale)
    } else {
        deringing::BLOCK * scale.1
    };
    Restoration::last_reach(spacing) + deringing
}

/// Bytes the tasks of the post-filtered path running at once hold at most for an output `w x h`
/// pixels at `spacing`, with `colour` colour planes of `planes` coding planes and
/// `channels` output channels: the restored window the deringing reads and the
/// deringed one the last filter reads, the task's coding planes and interleaving
/// buffer, the classes of the window's rows and the filters' interpolated rows
/// and terms.
pub(super) fn post_task_bytes(
    (w, h): (usize, usize),
    spacing: (f64, f64),
    (colour, planes, channels): (usize, usize, usize),
) -> u64 {
    let rows = post_task_rows(spacing, h).min(h) as u64;
    let last = Restoration::last_reach(spacing) as u64;
    let deringed = (rows + 2 * last).min(h as u64);
    // The deringing's window, and the rows of one direction block and one row of
    // every plane when it restores those alone.
    let restored = (rows + 2 * post_margin(spacing) as u64).min(h as u64);
    let directions = (deringing::BLOCK + colour) as u64;
    let w = w as u64;
    let samples =
        (colour as u64 * (restored + deringed) + (planes + channels) as u64 * rows + directions)
            * w;
    let task = samples
        .saturating_mul(4)
        .saturating_add(restored * w)
        .saturating_add(crate::restoration::filter_bytes((w as usize, h), spacing));
    // As many tasks at once as there are workers, or tasks.
    let tasks = (h as u64)
        .div_ceil(rows.max(1))
        .min(crate::par::workers() as u64);
    task.saturating_mul(tasks.max(1))
}

/// Rows `rows` of the colour planes `src` (the whole output's, before restoration)
/// restored, deringed and given the last filter into `dst`. The last filter reads
/// deringed rows past `rows`, and the deringing restored rows past those: both are
/// made here too, the restored ones into `scratch`.
fn post_filter_rows(
    h: &Header,
    src: &[&[f32]],
    r: &Restored,
    rows: std::ops::Range<usize>,
    scratch: &mut Vec<f32>,
    dst: &mut [&mut [f32]],
) {
    let Some(f) = h.restoration.as_ref().filter(|f| f.last.is_some()) else {
        return deringed_rows(h, src, r, rows, scratch, dst);
    };
    let (w, hh) = r.size;
    let spacing = r.spacing;
    let reach = Restoration::last_reach(spacing);
    let ext = rows.start.saturating_sub(reach)..(rows.end + reach).min(hh);
    let len = ext.len() * w;
    let mut window = vec![0.0f32; src.len() * len];
    let mut parts: Vec<&mut [f32]> = window.chunks_exact_mut(len).collect();
    deringed_rows(h, src, r, ext.clone(), scratch, &mut parts);
    let own = (rows.start - ext.start) * w..(rows.end - ext.start) * w;
    for (d, part) in dst.iter_mut().zip(window.chunks_exact(len)).skip(1) {
        d.copy_from_slice(&part[own.clone()]);
    }
    f.apply_last_rows(&window[..len], (w, hh), ext.start, spacing, rows, dst[0]);
}

/// Rows `rows` of the colour planes `src` restored and deringed into `dst`. The
/// deringing reads restored rows past `rows`: those are restored here too, into
/// `scratch`.
fn deringed_rows(
    h: &Header,
    src: &[&[f32]],
    r: &Restored,
    rows: std::ops::Range<usize>,
    scratch: &mut Vec<f32>,
    dst: &mut [&mut [f32]],
) {
    let (w, hh) = r.size;
    let restore = |rows: std::ops::Range<usize>, out: &mut [&mut [f32]]| match h
        .restoration
        .as_ref()
        .filter(|f| f.any())
    {
        Some(f) => f.apply_rows(src, r.size, r.spacing, rows, out),
        None => {
            for (o, s) in out.iter_mut().zip(src) {
                o.copy_from_slice(&s[rows.start * w..rows.end * w]);
            }
        }
    };
    let Some(d) = h.deringing.filter(|d| d.any()) else {
        return restore(rows, dst);
    };
    let scale = deringing::scale(r.spacing);
    let steps = h.deringing_steps();
    if !sparse_directions(scale) {
        let reach = Deringing::reach(rows.clone(), hh, scale);
        let len = reach.len() * w;
        // Every value is overwritten by the restoration: no need to clear.
        scratch.resize(src.len() * len, 0.0);
        let mut parts: Vec<&mut [f32]> = scratch.chunks_exact_mut(len).collect();
        restore(reach.clone(), &mut parts);
        let window: Vec<&[f32]> = scratch.chunks_exact(len).collect();
        return d.filter_rows(&window, (w, hh), reach.start, scale, steps, rows, dst);
    }
    // The taps' rows restored, and of each block only the eight rows its direction
    // reads: a block is `8 x scale` rows, far more than the taps reach when zoomed.
    let taps = Deringing::tap_rows(scale);
    let reach = rows.start.saturating_sub(taps)..(rows.end + taps).min(hh);
    let len = reach.len() * w;
    scratch.resize(src.len() * len, 0.0);
    let mut parts: Vec<&mut [f32]> = scratch.chunks_exact_mut(len).collect();
    restore(reach.clone(), &mut parts);
    let window: Vec<&[f32]> = scratch.chunks_exact(len).collect();
    let (sx, sy) = (deringing::BLOCK * scale.0, deringing::BLOCK * scale.1);
    let mut one = vec![0.0f32; src.len() * w];
    let mut luma = vec![0.0f32; deringing::BLOCK * w];
    let mut dirs = Vec::new();
    for by in rows.start / sy..(rows.end - 1) / sy + 1 {
        let y0 = by * sy;
        let count = (hh - y0).div_ceil(scale.1).min(deringing::BLOCK);
        for (i, row) in luma.chunks_exact_mut(w).take(count).enumerate() {
            let y = y0 + i * scale.1;
            if reach.contains(&y) {
                row.copy_from_slice(&window[0][(y - reach.start) * w..][..w]);
            } else {
                let mut parts: Vec<&mut [f32]> = one.chunks_exact_mut(w).collect();
                restore(y..y + 1, &mut parts);
                row.copy_from_slice(&one[..w]);
            }
        }
        // The block's rows one apart in `luma`, its columns `scale` apart.
        dirs.extend((0..w.div_ceil(sx)).map(|bx| {
            deringing::block_direction(&luma, (w, y0 + count), y0, (bx * sx, y0), (scale.0, 1))
        }));
    }
    d.filter_rows_directed(
        &window,
        &dirs,
        (w, hh),
        reach.start,
        (scale, steps),
        rows,
        dst,
    );
}

/// Whether the deringing of a decode at `scale` restores each block's direction rows
/// alone rather than its whole rows: when a block is more than a few rows beyond what
/// the taps read.
fn sparse_directions(scale: (usize, usize)) -> bool {
    scale.1 > 1
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
