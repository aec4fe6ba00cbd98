//! The tiles' models and streams: each tile's key points fitted and their values
//! coded, then its detail layer chosen against the network of every tile around it.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use crate::bitstream::TileStreams;
use crate::colour::{self, CodingPlanes};
use crate::detail;
use crate::detail::adaptive::BlockSteps;
use crate::detail::dct::N as DCT_N;
use crate::detail::field::{self, ActivityField};
use crate::entropy::AnsSink;
use crate::geometry::Frame;
use crate::keyset::{Grid, KernelParams, KeySet, MIN_SIGMA_FACTOR};
use crate::model;
use crate::quadtree::Cell;
use crate::quantise::{self as detail_quantise, Quantiser};
use crate::rate_control::EncodeSettings;
use crate::source::PixelSource;
use crate::syntax::{self, LevelSteps, MAX_VALUE};
use crate::tiling::{into_image_order, permute, TileRect, Tiling};
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
pub(super) struct TileModel {
    pub(super) streams: TileStreams,
    luma_cells: Vec<Cell>,
    chroma_cells: Vec<Cell>,
    luma_values: Vec<Vec<f64>>,
    chroma_values: Vec<Vec<f64>>,
}

/// The coding planes of a tile: opponent colours, or RGB when the settings say so.
pub(super) fn coding_planes(tile: &Raster, s: &EncodeSettings) -> CodingPlanes {
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
pub(super) fn fit_tile(
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
pub(super) fn code_tile(
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
pub(super) struct Network {
    pub(super) luma_cells: Vec<Cell>,
    pub(super) chroma_cells: Vec<Cell>,
    luma_values: Vec<Vec<f64>>,
    chroma_values: Vec<Vec<f64>>,
    luma_reach: Reach,
    chroma_reach: Reach,
}

impl Network {
    pub(super) fn gather(
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
pub(super) struct Reach {
    boxes: Vec<[f64; 3]>,
    by_tile: Vec<Vec<u32>>,
}

impl Reach {
    pub(super) fn new(
        frame: Frame,
        kernel: KernelParams,
        cells: &[Cell],
        tiling: &Tiling,
    ) -> Reach {
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
    pub(super) fn near(&self, tile: usize, rect: TileRect) -> Vec<usize> {
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
pub(super) fn detail_tile(
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
pub(super) fn run_tiles<T: Send>(
    n: usize,
    workers: usize,
    f: impl Fn(usize) -> T + Sync,
) -> Vec<T> {
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
