//! The encoder: model, quantise, entropy-code, assemble.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use rayon::prelude::*;

use super::bitstream::{self, Header, TileStreams};
use super::colour::{self, CodingPlanes, ColourBasis};
use super::deringing::{self, Deringing, Strengths};
use super::detail;
use super::detail::adaptive::{self, AdaptiveSteps, BlockSteps};
use super::detail::dct::N as DCT_N;
use super::detail::field::{self, ActivityField};
use super::entropy::AnsSink;
use super::geometry::Frame;
use super::keyset::{Grid, GridEval, KernelParams, KeySet, MIN_SIGMA_FACTOR};
use super::model;
use super::quadtree::Cell;
use super::rate_control::{self, EncodeSettings};
use super::restoration::colour_map::{self, ColourSums};
use super::restoration::{self, Restoration};
use super::source::PixelSource;
use super::syntax::{self, LevelSteps, MAX_VALUE};
use super::tiling::{into_image_order, permute, TileRect, Tiling};
use super::{CodecError, EncodeStats};
use crate::deringing_fit;
use crate::quantise::{self as detail_quantise, Quantiser};
use crate::restoration_fit::{self, ClassStats};
use caoen_base::metadata::{Metadata, MAX_ITEM_BYTES};
use caoen_base::raster::Raster;

/// Quantises one channel in coding order against the decoder's own prediction, with
/// a dead zone: the residual's magnitude is rounded down unless its fraction exceeds
/// `0.5 + deadzone`, trading a little distortion for many zero or smaller residuals.
/// Each key point is quantised in its own step (`levels` from the roots' `step`).
fn quantise(
    cells: &[Cell],
    nbs: &[syntax::Neighbours],
    values: &[f64],
    step: f64,
    levels: LevelSteps,
    deadzone: f64,
) -> Vec<i64> {
    let mut out = vec![0i64; values.len()];
    let mut scaled = vec![0i64; values.len()];
    let mut previous = 0;
    for i in 0..values.len() {
        let shift = levels.shift(&cells[i]);
        let (pred, _) = syntax::predict(&scaled, &nbs[i], previous, shift);
        let r = values[i] / levels.step(&cells[i], step) - pred as f64;
        let m = (r.abs() + 0.5 - deadzone).floor().max(0.0);
        // Clamped in floating point: an extreme (finite) sample can put the residual
        // far beyond i64, and the sum must not overflow. Below 2^53 the sum is exact, so
        // in range this is the integer sum.
        let v = (pred as f64 + r.signum() * m).clamp(-MAX_VALUE as f64, MAX_VALUE as f64) as i64;
        out[i] = v;
        scaled[i] = v << shift;
        previous = scaled[i];
    }
    out
}

/// One tile after modelling: its coded tree and values, and its key points (image
/// coordinates, the tile's coding order) with the values the decoder will read.
struct TileModel {
    streams: TileStreams,
    luma_cells: Vec<Cell>,
    chroma_cells: Vec<Cell>,
    luma_values: Vec<Vec<f64>>,
    chroma_values: Vec<Vec<f64>>,
}

/// The coding planes of a tile: opponent colours, or RGB when the settings say so.
fn coding_planes(tile: &Raster, s: &EncodeSettings) -> CodingPlanes {
    let mut planes = colour::forward(tile, s.colour_basis);
    if !s.decorrelate && planes.colour.len() == 3 {
        planes.colour = (0..3)
            .map(|c| tile.plane(c).iter().map(|&v| v as f64).collect())
            .collect();
    }
    planes
}

/// Models one tile: its tree and fitted (unquantised) key point colours, and, if the
/// steps follow an activity field, the log activity of its regions.
fn fit_tile(
    src: &(impl PixelSource + ?Sized),
    rect: TileRect,
    s: &EncodeSettings,
) -> (model::Model, Vec<f64>) {
    let tile = src.region(rect);
    let planes = coding_planes(&tile, s);
    drop(tile);
    let activity = match s.detail_field {
        Some(f) => field::log_activity(
            &planes.colour[0],
            rect.width as usize,
            rect.height as usize,
            f.log2,
            f.floor,
        ),
        None => Vec::new(),
    };
    let frame = Frame::window(
        src.width(),
        src.height(),
        (rect.x0, rect.y0),
        rect.width,
        rect.height,
    );
    (
        model::build_in(frame, &planes, &s.model, |_, _| {}),
        activity,
    )
}

/// Quantises and entropy-codes one tile's tree and values, with the tile's own
/// contexts and neighbours: nothing outside the tile is predicted from.
fn code_tile(
    model: model::Model,
    rect: TileRect,
    s: &EncodeSettings,
    levels: LevelSteps,
) -> TileModel {
    let (w, h) = (rect.width, rect.height);
    let leaf_set: std::collections::HashSet<_> = model.luma_cells.iter().copied().collect();
    let mut tree = AnsSink::new();
    let cells = syntax::write_tree(&model.shape, |c| !leaf_set.contains(c), &mut tree);
    debug_assert_eq!(cells, model.luma_cells);
    let mut luma = AnsSink::new();
    let nbs = syntax::neighbours(&model.luma_cells, w, h);
    let mut luma_values = Vec::new();
    for (c, values) in model.luma_colours.iter().enumerate() {
        let step = if c == 0 { s.step_luma } else { s.step_alpha };
        let q = quantise(&model.luma_cells, &nbs, values, step, levels, s.deadzone);
        syntax::write_values(&model.luma_cells, &nbs, &q, levels, &mut luma);
        luma_values.push(levels.dequantise(&model.luma_cells, &q, step));
    }
    let mut chroma_values = Vec::new();
    let chroma = if model.chroma_cells.is_empty() {
        Vec::new()
    } else {
        let mut sink = AnsSink::new();
        let nbs = syntax::neighbours(&model.chroma_cells, w, h);
        for values in &model.chroma_colours {
            let q = quantise(
                &model.chroma_cells,
                &nbs,
                values,
                s.step_chroma,
                levels,
                s.deadzone,
            );
            syntax::write_values(&model.chroma_cells, &nbs, &q, levels, &mut sink);
            chroma_values.push(levels.dequantise(&model.chroma_cells, &q, s.step_chroma));
        }
        sink.finish()
    };
    TileModel {
        streams: TileStreams {
            luma_count: model.luma_cells.len() as u32,
            chroma_count: model.chroma_cells.len() as u32,
            tree: tree.finish(),
            luma: luma.finish(),
            chroma,
            detail: Vec::new(),
        },
        luma_cells: model
            .luma_cells
            .into_iter()
            .map(|c| rect.to_image(c))
            .collect(),
        chroma_cells: model
            .chroma_cells
            .into_iter()
            .map(|c| rect.to_image(c))
            .collect(),
        luma_values,
        chroma_values,
    }
}

/// The image's key points in its coding order, with their decoded values and where
/// their supports reach.
struct Network {
    luma_cells: Vec<Cell>,
    chroma_cells: Vec<Cell>,
    luma_values: Vec<Vec<f64>>,
    chroma_values: Vec<Vec<f64>>,
    luma_reach: Reach,
    chroma_reach: Reach,
}

impl Network {
    fn gather(
        tiles: &mut [TileModel],
        block_log2: u8,
        frame: Frame,
        kernel: KernelParams,
        tiling: &Tiling,
    ) -> Network {
        let mut luma_cells = Vec::new();
        let mut chroma_cells = Vec::new();
        let mut luma_values: Vec<Vec<f64>> = Vec::new();
        let mut chroma_values: Vec<Vec<f64>> = Vec::new();
        for t in tiles.iter_mut() {
            luma_cells.append(&mut t.luma_cells);
            chroma_cells.append(&mut t.chroma_cells);
            luma_values.resize(t.luma_values.len(), Vec::new());
            chroma_values.resize(t.chroma_values.len(), Vec::new());
            for (all, v) in luma_values.iter_mut().zip(&mut t.luma_values) {
                all.append(v);
            }
            for (all, v) in chroma_values.iter_mut().zip(&mut t.chroma_values) {
                all.append(v);
            }
        }
        let (luma_cells, luma_values) = into_image_order(&luma_cells, &luma_values, block_log2);
        let (chroma_cells, chroma_values) =
            into_image_order(&chroma_cells, &chroma_values, block_log2);
        Network {
            luma_reach: Reach::new(frame, kernel, &luma_cells, tiling),
            chroma_reach: Reach::new(frame, kernel, &chroma_cells, tiling),
            luma_cells,
            chroma_cells,
            luma_values,
            chroma_values,
        }
    }
}

/// Where one key point set's supports reach: each key point's centre and support
/// radius (plus a pixel), and per tile the key points whose support box may meet the
/// tile with a pixel of margin, in key point order. Built once for the image, so a
/// tile tests only its candidates rather than every key point.
struct Reach {
    boxes: Vec<[f64; 3]>,
    by_tile: Vec<Vec<u32>>,
}

impl Reach {
    fn new(frame: Frame, kernel: KernelParams, cells: &[Cell], tiling: &Tiling) -> Reach {
        let sigma_factor = kernel.sigma_factor.max(MIN_SIGMA_FACTOR);
        let boxes: Vec<[f64; 3]> = cells
            .iter()
            .map(|c| {
                let (cx, cy) = c.centre(frame.width, frame.height);
                [
                    cx,
                    cy,
                    frame.support_radius(cx, cy, sigma_factor * c.size() as f64) + 1.0,
                ]
            })
            .collect();
        let (cols, rows) = (tiling.columns(), tiling.rows());
        let side = tiling.side as f64;
        let span = |lo: f64, hi: f64, n: usize| {
            let t = |v: f64| (v / side).floor().clamp(0.0, n as f64 - 1.0) as usize;
            t(lo)..=t(hi)
        };
        let mut by_tile = vec![Vec::new(); cols * rows];
        for (i, &[cx, cy, r]) in boxes.iter().enumerate() {
            // Two more pixels: the margin network_colours evaluates around a tile, and
            // a box ending exactly on the next tile's edge.
            for ty in span(cy - r - 2.0, cy + r + 2.0, rows) {
                for tx in span(cx - r - 2.0, cx + r + 2.0, cols) {
                    by_tile[ty * cols + tx].push(i as u32);
                }
            }
        }
        Reach { boxes, by_tile }
    }

    /// The key points whose support box meets `rect`, in key point order.
    fn near(&self, tile: usize, rect: TileRect) -> Vec<usize> {
        self.by_tile[tile]
            .iter()
            .map(|&i| i as usize)
            .filter(|&i| {
                let [cx, cy, r] = self.boxes[i];
                cx + r >= rect.x0 as f64
                    && cx - r <= (rect.x0 + rect.width) as f64
                    && cy + r >= rect.y0 as f64
                    && cy - r <= (rect.y0 + rect.height) as f64
            })
            .collect()
    }
}

/// The network's colours at the pixel centres of `rect` (tile `tile` with its margin),
/// evaluated from the key points whose support reaches it (exactly what the whole
/// network gives there: the others contribute zero).
fn network_colours(
    frame: Frame,
    kernel: KernelParams,
    net: &Network,
    tile: usize,
    rect: TileRect,
) -> Vec<Vec<f32>> {
    let grid = Grid {
        x0: rect.x0 as f64 + 0.5,
        dx: 1.0,
        nx: rect.width as usize,
        y0: rect.y0 as f64 + 0.5,
        dy: 1.0,
        ny: rect.height as usize,
    };
    let eval = |cells: &[Cell], values: &[Vec<f64>], reach: &Reach| -> Vec<Vec<f32>> {
        let near = reach.near(tile, rect);
        let sub: Vec<Cell> = near.iter().map(|&i| cells[i]).collect();
        KeySet::new(frame, &sub, kernel).eval_grid(&permute(values, &near), &grid)
    };
    let mut colour = eval(&net.luma_cells, &net.luma_values[..1], &net.luma_reach);
    if !net.chroma_cells.is_empty() {
        colour.extend(eval(
            &net.chroma_cells,
            &net.chroma_values,
            &net.chroma_reach,
        ));
    }
    colour
}

/// Codes one tile's detail blocks: the residual of its pixels after the whole image's
/// network. Returns the stream (empty when no block is coded). `index` is the tile's
/// number in the tiling.
#[allow(clippy::too_many_arguments)]
fn detail_tile(
    src: &(impl PixelSource + ?Sized),
    index: usize,
    rect: TileRect,
    s: &EncodeSettings,
    kernel: KernelParams,
    net: &Network,
    classes: &[u8],
    field: Option<&ActivityField>,
) -> Vec<u8> {
    // Lapping pairs the pixels on either side of every block edge, so the residual is
    // taken with a pixel of margin where the image goes on past the tile.
    let (w, h) = (src.width(), src.height());
    let margin = u32::from(s.lapping.is_some());
    let outer = rect.grown(margin, w, h);
    let (x0, y0) = (outer.x0, outer.y0);
    let tile = src.region(outer);
    let planes = coding_planes(&tile, s);
    drop(tile);
    let base = network_colours(Frame::new(w, h), kernel, net, index, outer);
    let (ow, oh) = (outer.width as usize, outer.height as usize);
    let (dx, dy) = ((rect.x0 - x0) as usize, (rect.y0 - y0) as usize);
    let residuals: Vec<Vec<f64>> = planes
        .colour
        .iter()
        .zip(&base)
        .map(|(t, r)| {
            let mut res: Vec<f64> = t.iter().zip(r).map(|(&t, &r)| t - r as f64).collect();
            if let Some(l) = s.lapping {
                l.prefilter(&mut res, (ow, oh), (x0, y0), (w, h));
            }
            if margin == 0 {
                return res;
            }
            res.chunks_exact(ow)
                .skip(dy)
                .take(rect.height as usize)
                .flat_map(|row| &row[dx..dx + rect.width as usize])
                .copied()
                .collect()
        })
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
            per_coefficient: s.detail_search,
        })
        .collect();
    // The tile's blocks' classes, from the image's (tiles start on block boundaries),
    // and their step factors.
    let (cols, _) = detail::blocks(src.width(), src.height());
    let (tc, tr) = detail::blocks(rect.width, rect.height);
    let (bx0, by0) = (rect.x0 as usize / DCT_N, rect.y0 as usize / DCT_N);
    let classes: Vec<u8> = (0..tc * tr)
        .map(|i| classes[(by0 + i / tc) * cols + bx0 + i % tc])
        .collect();
    // The decoder's own products, so both sides step alike.
    let factors = s.detail_adaptive.map(|steps| {
        let blocks = BlockSteps {
            steps,
            classes: classes.clone(),
            field: field.map(|f| f.block_exponents(tc, tr)).unwrap_or_default(),
        };
        (0..tc * tr).map(|i| blocks.factor(i)).collect::<Vec<f64>>()
    });
    let (detail, payload) = detail_quantise::code_layer(
        &residuals,
        (rect.width, rect.height),
        &quantisers,
        &classes,
        factors.as_deref(),
        s.detail_weights,
        field,
    );
    if detail.planes.iter().all(|p| p.coded_blocks() == 0) {
        Vec::new()
    } else {
        payload
    }
}

/// Runs `f` on tiles `0..n` with at most `workers` tiles in progress at once (each
/// worker takes the next tile when it finishes one), results in tile order. A worker
/// is one rayon task, so the tiles' own parallel loops share the same threads, and a
/// thread that steals work while waiting can only pick up another worker, never a
/// tile beyond the `workers` in progress.
fn run_tiles<T: Send>(n: usize, workers: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let next = AtomicUsize::new(0);
    let slots: Vec<Mutex<Option<T>>> = (0..n).map(|_| Mutex::new(None)).collect();
    rayon::scope(|scope| {
        for _ in 0..workers.clamp(1, n.max(1)) {
            scope.spawn(|_| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= n {
                    break;
                }
                let r = f(i);
                *slots[i].lock().expect("no worker panicked") = Some(r);
            });
        }
    });
    slots
        .into_iter()
        .map(|m| {
            m.into_inner()
                .expect("no worker panicked")
                .expect("every tile ran")
        })
        .collect()
}

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

/// How fast the codec's squared error falls with its rate on photographs: as
/// `rate^-1.1`, 3.3 dB per doubling (`docs/benchmarks.md`).
const RESTORATION_SLOPE: f64 = 1.1;
/// Evaluation bands in each group the restoration fit samples.
const RESTORATION_GROUP: usize = 3;
/// Bytes of a restoration section besides its taps: tag, length (one byte), CRC and
/// mask.
const RESTORATION_SECTION_BYTES: usize = 7;
/// Pixels the restoration filters' sums see, unless [`RESTORATION_MIN_GROUPS`] need
/// more: every row of a photograph of a megapixel or less.
const RESTORATION_SAMPLES: u64 = 1 << 20;
/// Groups of bands the restoration fit samples at least. A filter that helps where it
/// was fitted can hurt a region it never saw (smoothing a sharp one): on a 12-megapixel
/// photograph three groups led to filters that lost up to 0.18 dB, where six or more
/// gained (`docs/codec-ablation.md`).
const RESTORATION_MIN_GROUPS: usize = 8;

/// Pixels per plane the deringing's sums take, about: three numbers per plane kind
/// are settled on fewer than the restoration's taps need.
const DERINGING_SAMPLES: usize = 1 << 18;

/// The most pixels the restoration fit evaluates again for a `w x h` image: its
/// groups of bands, their margins included.
pub(crate) fn restoration_fit_pixels(w: u32, h: u32) -> u64 {
    let span = (RESTORATION_GROUP * GridEval::BAND) as u64;
    let groups = restoration_groups(w) as u64;
    (groups
        .saturating_add(1)
        .saturating_mul(span)
        .saturating_mul(u64::from(w)))
    .min(u64::from(w) * u64::from(h))
}

/// Groups of bands the restoration fit asks for in a `w`-pixel-wide image: enough for
/// [`RESTORATION_SAMPLES`] pixels inside their reach, and at least
/// [`RESTORATION_MIN_GROUPS`].
fn restoration_groups(w: u32) -> usize {
    let span = RESTORATION_GROUP * GridEval::BAND;
    let per_group = ((span - 2 * restoration::RADIUS) as u64) * u64::from(w);
    ((RESTORATION_SAMPLES / per_group.max(1)) as usize).max(RESTORATION_MIN_GROUPS)
}

/// The restoration filters and the deringing for the file `bytes` (all but the
/// post-filters coded; `coded_bytes` of it the picture's, without metadata): each
/// colour plane's least-squares filters from the decoded planes against the source's,
/// one for the plane or one per group of pixel classes, where they pay for their bits
/// at the price the codec's own curve puts on a bit; then, on the same rows restored,
/// each plane kind's deringing strengths that lower the error most, where they pay for
/// theirs.
///
/// The sums take groups of [`RESTORATION_GROUP`] evaluation bands, every few bands,
/// so only those bands are evaluated again: all of a group's rows where its neighbours
/// are evaluated too, else those at least the filters' reach from its edges.
fn fit_post_filters(
    bytes: &[u8],
    coded_bytes: usize,
    src: &(impl PixelSource + ?Sized),
    s: &EncodeSettings,
) -> Result<(Option<Restoration>, Option<Deringing>), CodecError> {
    let (w, h) = (src.width(), src.height());
    let (wu, hu) = (w as usize, h as usize);
    // Groups of GROUP evaluation bands, every few bands, rows their reach from the
    // group's edges: the rows cover every phase of the 8x8 blocks (a single band's
    // inner rows would miss the rows by every other horizontal block edge).
    let band = GridEval::BAND;
    let reach = restoration::RADIUS;
    let bands = hu.div_ceil(band);
    let groups = restoration_groups(w);
    let every = bands.div_ceil(groups).max(RESTORATION_GROUP);
    let starts: Vec<usize> = (0..bands).step_by(every).collect();
    let needed: Vec<usize> = starts
        .iter()
        .flat_map(|&g| g..(g + RESTORATION_GROUP).min(bands))
        .collect();
    let parsed = bitstream::parse(bytes, u64::MAX)?;
    let decoded = caoen_decoder::decoder::read_parsed(&parsed)?;
    let evaluated = caoen_decoder::decoder::unrestored_bands(&decoded, &needed);
    drop(decoded);
    let planes = src.layout().colour_channels();
    let index = |b: usize| needed.binary_search(&b).ok();
    let band_rows = |b: usize| (hu - b * band).min(band);
    // Each plane's evaluated bands in one buffer, in `needed`'s order: band `needed[i]`
    // starts at row `i * band`, so bands that neighbour in the image neighbour here, and
    // a group with its context is one slice.
    let total = needed.iter().map(|&b| band_rows(b) * wu).sum::<usize>();
    let mut flat: Vec<Vec<f32>> = (0..planes).map(|_| Vec::with_capacity(total)).collect();
    for parts in evaluated {
        for (plane, part) in flat.iter_mut().zip(parts) {
            plane.extend(part);
        }
    }
    // One source read and one sum per group. A group whose neighbouring bands are
    // evaluated anyway (groups side by side, as in images of a megapixel or less)
    // takes them as context, so its rows by the group's edges are exact too; else those
    // rows are left out. At the image's top and bottom the group clamps as the image
    // does, so those rows are exact (all of an image of a few rows).
    let windows: Vec<FitWindow> = starts
        .iter()
        .map(|&g| {
            let end = (g + RESTORATION_GROUP).min(bands);
            let first = if g > 0 && index(g - 1).is_some() {
                g - 1
            } else {
                g
            };
            let last = if end < bands && index(end).is_some() {
                end + 1
            } else {
                end
            };
            let at = |b: usize| index(b).expect("evaluated") * band * wu;
            let slice = at(first)..at(last - 1) + band_rows(last - 1) * wu;
            let y0 = first * band;
            let rows_held = (hu - y0).min((last - first) * band);
            let (own_top, own_bottom) = ((g - first) * band, ((end - first) * band).min(rows_held));
            let top = if y0 + own_top == 0 || first < g {
                own_top
            } else {
                own_top + reach
            };
            let bottom = if y0 + own_bottom == hu || last > end {
                own_bottom
            } else {
                own_bottom.saturating_sub(reach)
            };
            FitWindow {
                slice,
                y0,
                rows_held,
                rows: top..bottom.max(top),
            }
        })
        .collect();
    let chunks: Vec<Vec<ClassStats>> = windows
        .par_iter()
        .map(|win| {
            let decoded: Vec<&[f32]> = flat.iter().map(|p| &p[win.slice.clone()]).collect();
            let (y0, window_rows, rows) = (win.y0, win.rows_held, win.rows.clone());
            let mut stats: Vec<ClassStats> = (0..planes).map(ClassStats::new).collect();
            if rows.is_empty() {
                return stats;
            }
            let rect = TileRect {
                x0: 0,
                y0: (y0 + rows.start) as u32,
                width: w,
                height: rows.len() as u32,
            };
            let source = coding_planes(&src.region(rect), s).colour;
            // Every plane's classes come from the luma.
            let classes =
                restoration::classify_rows(decoded[0], (wu, window_rows), (1.0, 1.0), rows.clone());
            for (c, (&plane, source)) in decoded.iter().zip(&source).enumerate() {
                stats[c].accumulate(c, plane, &classes, source, (wu, window_rows), rows.clone());
            }
            stats
        })
        .collect();
    let sum = |pick: &dyn Fn(usize) -> bool| -> Vec<ClassStats> {
        (0..planes)
            .map(|c| {
                let mut total = ClassStats::new(c);
                for (_, chunk) in chunks.iter().enumerate().filter(|(i, _)| pick(*i)) {
                    total.add(&chunk[c]);
                }
                total
            })
            .collect()
    };
    let totals = sum(&|_| true);
    // The groups in two halves: a filter must lower the error in both, so it follows
    // the picture rather than the sums' noise.
    let halves = [sum(&|i| i % 2 == 0), sum(&|i| i % 2 == 1)];
    let all: Vec<_> = totals.iter().map(ClassStats::total).collect();
    let scale = (wu * hu) as f64 / all[0].samples.max(1) as f64;
    // A bit is worth what the codec's own curve trades for it here: its distortion
    // falls as rate^-RESTORATION_SLOPE, so a bit more lowers it by SLOPE D / R.
    let error: f64 = all.iter().map(|t| t.error).sum::<f64>() * scale;
    let bit_cost = RESTORATION_SLOPE * error / (8 * coded_bytes) as f64;
    let fitted: Vec<_> = (0..planes)
        .into_par_iter()
        .map(|c| {
            restoration_fit::fit_plane(&totals[c], [&halves[0][c], &halves[1][c]], scale, bit_cost)
        })
        .collect();
    let net: f64 = fitted.iter().flatten().map(|(_, worth)| worth).sum();
    let filtered = Restoration {
        planes: fitted.into_iter().map(|f| f.map(|(f, _)| f)).collect(),
        colour: None,
        last: None,
    };
    // Each group restored by the filters once: the colour map's sums take it, then,
    // mapped, the deringing's and the last filters'.
    let mut restored_windows: Vec<Vec<Vec<f32>>> = windows
        .par_iter()
        .map(|win| {
            let decoded: Vec<&[f32]> = flat.iter().map(|p| &p[win.slice.clone()]).collect();
            restored_rows(Some(&filtered), &decoded, (wu, win.rows_held))
                .into_iter()
                .map(std::borrow::Cow::into_owned)
                .collect()
        })
        .collect();
    // The colour map, on the rows the filters restored.
    let map = {
        let sums: Vec<ColourSums> = windows
            .par_iter()
            .zip(&restored_windows)
            .map(|(win, restored)| {
                let mut sums = ColourSums::new(planes);
                if win.rows.is_empty() {
                    return sums;
                }
                let rect = TileRect {
                    x0: 0,
                    y0: (win.y0 + win.rows.start) as u32,
                    width: w,
                    height: win.rows.len() as u32,
                };
                let source = coding_planes(&src.region(rect), s).colour;
                let rows = win.rows.start * wu..win.rows.end * wu;
                let restored: Vec<&[f32]> = restored.iter().map(|p| &p[rows.clone()]).collect();
                let source: Vec<&[f64]> = source.iter().map(Vec::as_slice).collect();
                sums.accumulate(&restored, &source);
                sums
            })
            .collect();
        let sum = |pick: &dyn Fn(usize) -> bool| {
            let mut total = ColourSums::new(planes);
            for (_, part) in sums.iter().enumerate().filter(|(i, _)| pick(*i)) {
                total.add(part);
            }
            total
        };
        let (total, halves) = (sum(&|_| true), [sum(&|i| i % 2 == 0), sum(&|i| i % 2 == 1)]);
        let scale = (wu * hu) as f64 / total.samples.max(1) as f64;
        colour_map::fit(&total, [&halves[0], &halves[1]], scale, bit_cost)
    };
    // The section's own bytes (tag, length, CRC, mask) are paid once.
    let worth = net + map.as_ref().map_or(0.0, |(_, w)| *w);
    let restoration = if worth < bit_cost * (8 * RESTORATION_SECTION_BYTES) as f64 {
        None
    } else {
        Some(Restoration {
            colour: map.map(|(m, _)| m),
            ..filtered
        })
        .filter(Restoration::any)
    };
    if !s.deringing {
        return Ok((restoration, None));
    }
    match restoration.as_ref().map(|r| &r.colour) {
        Some(Some(m)) => restored_windows.par_iter_mut().for_each(|planes| {
            let mut parts: Vec<&mut [f32]> = planes.iter_mut().map(Vec::as_mut_slice).collect();
            m.apply(&mut parts);
        }),
        Some(None) => {}
        // Without the section the decoder sees the decoded rows themselves.
        None => {
            restored_windows = windows
                .iter()
                .map(|win| flat.iter().map(|p| p[win.slice.clone()].to_vec()).collect())
                .collect()
        }
    }
    // The deringing's sums on the restored groups, rows far enough from a group's
    // edges that the restoration and the deringing both see what the decoder sees.
    let margin = reach + 2;
    let steps = parsed.header.deringing_steps();
    // Three numbers per plane kind need fewer rows than the restoration's taps: every
    // `stride`-th row, odd so that the rows still cover every phase of the blocks.
    let seen: usize = windows.iter().map(|win| win.rows.len() * wu).sum();
    let stride = (seen / DERINGING_SAMPLES).max(1) | 1;
    let sums: Vec<[deringing_fit::Sums; 2]> = windows
        .par_iter()
        .zip(&restored_windows)
        .map(|(win, restored)| {
            let top = if win.y0 + win.rows.start == 0 {
                0
            } else {
                win.rows.start.max(margin)
            };
            let bottom = if win.y0 + win.rows.end == hu {
                win.rows.end
            } else {
                win.rows.end.min(win.rows_held.saturating_sub(margin))
            };
            let mut sums: [deringing_fit::Sums; 2] = Default::default();
            if top >= bottom {
                return sums;
            }
            let rows = top..bottom;
            let rect = TileRect {
                x0: 0,
                y0: (win.y0 + rows.start) as u32,
                width: w,
                height: rows.len() as u32,
            };
            let source = coding_planes(&src.region(rect), s).colour;
            // Image rows: the window starts on a block row, so its blocks are the image's.
            let abs = win.y0 + rows.start..win.y0 + rows.end;
            let dirs = deringing::directions(&restored[0], (wu, hu), win.y0, (1, 1), abs.clone());
            for (c, (plane, source)) in restored.iter().zip(&source).enumerate() {
                let kind = usize::from(c > 0);
                deringing_fit::accumulate(
                    &mut sums[kind],
                    plane,
                    (wu, hu),
                    win.y0,
                    &dirs,
                    abs.clone(),
                    source,
                    steps[kind],
                    stride,
                );
            }
            sums
        })
        .collect();
    let kind = |k: usize, pick: &dyn Fn(usize) -> bool| {
        let mut t = deringing_fit::Sums::default();
        for (_, s) in sums.iter().enumerate().filter(|(i, _)| pick(*i)) {
            t.add(&s[k]);
        }
        t
    };
    let choose = |k: usize| -> Strengths {
        let total = kind(k, &|_| true);
        let scale = (wu * hu) as f64 / total.samples.max(1) as f64 * if k == 0 { 1.0 } else { 2.0 };
        let Some((best, gain)) = total.best() else {
            return Strengths::OFF;
        };
        let both = (0..2).all(|h| kind(k, &|i| i % 2 == h).gain_of(best) > 0.0);
        // Three header bytes per plane kind.
        if both && gain * scale > bit_cost * 24.0 {
            best
        } else {
            Strengths::OFF
        }
    };
    let d = Deringing {
        luma: choose(0),
        chroma: if planes == 3 {
            choose(1)
        } else {
            Strengths::OFF
        },
    };
    let deringing = d.any().then_some(d);
    // The last luma filters, on the same rows deringed: what the deringing leaves that
    // linear filters take, by pixel class where that pays.
    let stats: Vec<ClassStats> = windows
        .par_iter()
        .zip(&restored_windows)
        .map(|(win, restored)| {
            let mut stats = ClassStats::new(0);
            let at_top = |r: usize| win.y0 + r == 0;
            let at_bottom = |r: usize| win.y0 + r == hu;
            let top = if at_top(win.rows.start) {
                0
            } else {
                win.rows.start.max(margin)
            };
            let bottom = if at_bottom(win.rows.end) {
                win.rows.end
            } else {
                win.rows.end.min(win.rows_held.saturating_sub(margin))
            };
            if top >= bottom {
                return stats;
            }
            // Deringed rows `top..bottom` of the window, then the sums on those the
            // last filter's reach from their edges (all of them at the image's).
            let luma: Vec<f32> = match &deringing {
                Some(d) => {
                    let window: Vec<&[f32]> = restored.iter().map(|p| p.as_ref()).collect();
                    let mut out: Vec<Vec<f32>> = (0..planes)
                        .map(|_| vec![0.0f32; (bottom - top) * wu])
                        .collect();
                    let mut parts: Vec<&mut [f32]> =
                        out.iter_mut().map(Vec::as_mut_slice).collect();
                    d.filter_rows(
                        &window,
                        (wu, hu),
                        win.y0,
                        (1, 1),
                        steps,
                        win.y0 + top..win.y0 + bottom,
                        &mut parts,
                    );
                    out.swap_remove(0)
                }
                None => restored[0][top * wu..bottom * wu].to_vec(),
            };
            let first = if at_top(top) { 0 } else { reach };
            let last = if at_bottom(bottom) {
                bottom - top
            } else {
                (bottom - top).saturating_sub(reach)
            };
            if first >= last {
                return stats;
            }
            let rect = TileRect {
                x0: 0,
                y0: (win.y0 + top + first) as u32,
                width: w,
                height: (last - first) as u32,
            };
            let source = coding_planes(&src.region(rect), s).colour;
            // The classes of the deringed luma, as the decoder finds them.
            let classes =
                restoration::classify_rows(&luma, (wu, bottom - top), (1.0, 1.0), first..last);
            stats.accumulate(
                0,
                &luma,
                &classes,
                &source[0],
                (wu, bottom - top),
                first..last,
            );
            stats
        })
        .collect();
    let luma_sum = |pick: &dyn Fn(usize) -> bool| {
        let mut t = ClassStats::new(0);
        for (_, part) in stats.iter().enumerate().filter(|(i, _)| pick(*i)) {
            t.add(part);
        }
        t
    };
    let (total, halves) = (
        luma_sum(&|_| true),
        [luma_sum(&|i| i % 2 == 0), luma_sum(&|i| i % 2 == 1)],
    );
    let scale = (wu * hu) as f64 / total.total().samples.max(1) as f64;
    let last = restoration_fit::fit_plane(&total, [&halves[0], &halves[1]], scale, bit_cost);
    let restoration = match (restoration, last) {
        (Some(r), last) => Some(Restoration {
            last: last.map(|(f, _)| f),
            ..r
        }),
        // Alone, the last filters pay for the section's own bytes too.
        (None, Some((f, worth))) => (worth > bit_cost * (8 * RESTORATION_SECTION_BYTES) as f64)
            .then(|| Restoration {
                planes: vec![None; planes],
                colour: None,
                last: Some(f),
            }),
        (None, None) => None,
    };
    Ok((restoration, deringing))
}

/// The rows `decoded` (`w x rows` samples per colour plane) restored by `r`, or the
/// decoded rows themselves without restoration.
fn restored_rows<'a>(
    r: Option<&Restoration>,
    decoded: &[&'a [f32]],
    (w, rows): (usize, usize),
) -> Vec<std::borrow::Cow<'a, [f32]>> {
    let Some(r) = r.filter(|r| r.any()) else {
        return decoded
            .iter()
            .map(|&d| std::borrow::Cow::Borrowed(d))
            .collect();
    };
    let n = decoded[0].len();
    let mut out: Vec<Vec<f32>> = decoded.iter().map(|_| vec![0.0f32; n]).collect();
    let mut parts: Vec<&mut [f32]> = out.iter_mut().map(Vec::as_mut_slice).collect();
    r.apply_rows(decoded, (w, rows), (1.0, 1.0), 0..rows, &mut parts);
    out.into_iter().map(std::borrow::Cow::Owned).collect()
}

/// One group of the post-filter fit: its rows and their context in the evaluated
/// bands' buffer.
struct FitWindow {
    /// The samples of each plane's buffer it takes (whole rows).
    slice: std::ops::Range<usize>,
    /// Its first row in the image.
    y0: usize,
    /// Rows it holds.
    rows_held: usize,
    /// The rows, counted from its first, whose sums are taken.
    rows: std::ops::Range<usize>,
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The field the encoder writes follows the source's local variance, and the
    /// decoder reads it back into every block's factor: a flat left half takes finer
    /// steps than a noisy right half.
    #[test]
    fn the_activity_field_follows_the_local_variance_through_the_file() {
        use caoen_base::raster::{ChannelLayout, SampleFormat};
        let (w, h) = (128u32, 64u32);
        let mut seed = 12345u64;
        let mut noise = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let plane: Vec<f32> = (0..w * h)
            .map(|i| {
                let x = i % w;
                if x < w / 2 {
                    0.4 + 0.1 * x as f32 / w as f32
                } else {
                    0.2 + 0.6 * noise()
                }
            })
            .collect();
        let samples: Vec<f32> = (0..3).flat_map(|_| plane.iter().copied()).collect();
        let img = Raster::new(w, h, ChannelLayout::Rgb, SampleFormat::U8, samples).unwrap();
        let s = rate_control::settings(70.0, 5, None);
        let (bytes, _) = encode_with(&img, &s, &Metadata::default(), 1, |_, _| {}).unwrap();
        let decoded = caoen_decoder::decoder::read(&bytes, 1 << 28).unwrap();
        let adaptive = decoded.header.adaptive.expect("adaptive steps");
        assert_eq!(adaptive.field(), Some(rate_control::FIELD_LOG2));
        let detail = decoded.detail.expect("a detail layer");
        let steps = detail.block_steps.expect("block steps");
        let cols = (w / 8) as usize;
        let exponent = |i: usize| steps.field[i];
        let (flat, busy): (Vec<usize>, Vec<usize>) =
            (0..steps.field.len()).partition(|&i| i % cols < cols / 2);
        // Flat regions without a coded block settle to the cheapest exponent.
        assert!(flat.iter().all(|&i| exponent(i) <= 0), "{:?}", steps.field);
        assert!(busy.iter().all(|&i| exponent(i) > 0), "{:?}", steps.field);
        let mean =
            |set: &[usize]| set.iter().map(|&i| exponent(i) as f64).sum::<f64>() / set.len() as f64;
        // The busy half's variance is about 30 times the flat half's (floored), so the
        // exponents (4 log2 of the step factor) differ by `4 strength log2 30` before
        // rounding, normalising and settling the flat regions; at least half of it shows.
        let strength = rate_control::detail_field(70.0)
            .expect("a field at q70")
            .strength;
        assert!(
            mean(&flat) < 0.0 && mean(&busy) - mean(&flat) > 2.0 * strength * 30f64.log2(),
            "{:?}",
            steps.field
        );
        for i in 0..steps.field.len() {
            let class = steps.steps.factor(steps.classes[i]);
            assert_eq!(steps.factor(i), class * field::factor(exponent(i)));
        }
    }
    use caoen_decoder::quadtree::random_tree;

    /// A tile's candidates from [`Reach`] are exactly the key points a scan of all of
    /// them finds for the tile with and without its margin: the index may only skip
    /// key points whose support misses the tile.
    #[test]
    fn the_reach_index_finds_what_a_full_scan_finds_for_every_tile() {
        let (w, h) = (1700, 1100);
        let tiling = Tiling::choose(w, h);
        assert!(tiling.count() > 4, "several tiles: {}", tiling.count());
        let frame = Frame::new(w, h);
        for (seed, sigma_factor) in [(3, 0.3), (11, 1.2), (29, 3.0)] {
            let (_, cells) = random_tree(w, h, seed, |d| d % 3 != 0);
            let kernel = KernelParams {
                sigma_factor,
                weight_exponent: 1.0,
            };
            let reach = Reach::new(frame, kernel, &cells, &tiling);
            for t in 0..tiling.count() {
                let r = tiling.rect(t);
                for margin in [0, 1] {
                    let rect = r.grown(margin, w, h);
                    let scan: Vec<usize> = (0..cells.len())
                        .filter(|&i| {
                            let (cx, cy) = cells[i].centre(w, h);
                            let s = sigma_factor.max(MIN_SIGMA_FACTOR) * cells[i].size() as f64;
                            let rr = frame.support_radius(cx, cy, s) + 1.0;
                            cx + rr >= rect.x0 as f64
                                && cx - rr <= (rect.x0 + rect.width) as f64
                                && cy + rr >= rect.y0 as f64
                                && cy - rr <= (rect.y0 + rect.height) as f64
                        })
                        .collect();
                    assert!(!scan.is_empty());
                    assert_eq!(
                        reach.near(t, rect),
                        scan,
                        "seed {seed}, tile {t}, margin {margin}"
                    );
                }
            }
        }
    }
}
