//! Choosing and fitting the key points of one image: the encoder's modelling stage.
//!
//! The quadtree starts from the analysis (cells split while their predicted error is
//! above the threshold), then grows greedily: fit, measure each leaf's squared error
//! over its pixels, split the worst leaves above the threshold (at most a fraction per
//! round so the refit can redistribute), and repeat. Chroma uses the luma tree pruned
//! one level. Colours come from the regularised least-squares fit.

use std::collections::HashSet;

use super::analysis::Analysis;
use super::colour::CodingPlanes;
use super::fit::LeastSquares;
use super::geometry::Frame;
use super::keyset::{KernelParams, KeySet};
use super::quadtree::{chroma_cells, Cell, TreeShape};

/// Modelling settings (derived from quality and effort by rate control).
#[derive(Debug, Clone, PartialEq)]
pub struct ModelSettings {
    /// Root block side, log2.
    pub block_log2: u8,
    /// Smallest cell side, log2.
    pub min_log2: u8,
    /// Key point footprint and weights.
    pub kernel: KernelParams,
    /// A leaf whose squared error (summed over its pixels and channels, coding space)
    /// exceeds this is split.
    pub split_threshold: f64,
    /// Grow to this many luma key points instead of using the threshold.
    pub target_keypoints: Option<usize>,
    /// Greedy refinement rounds after the analysis-driven start.
    pub rounds: usize,
    /// Fraction of leaves that may split per round.
    pub growth: f64,
    /// Conjugate-gradient iterations in refinement rounds and in the final fit.
    pub cg_iterations: (usize, usize),
    /// Ridge weight toward locally averaged colours.
    pub ridge: f64,
    /// Chroma on the luma tree pruned one level (else on the luma tree itself).
    pub chroma_pruned: bool,
    /// Ablation switches (not user options): least-squares colours (else the
    /// locally averaged "sampled" colours), analysis-driven initial splits, and a
    /// uniform grid with about as many key points as the adaptive tree chose.
    pub least_squares: bool,
    /// See `least_squares`.
    pub analysis_start: bool,
    /// See `least_squares`.
    pub uniform_grid: bool,
}

impl Default for ModelSettings {
    fn default() -> Self {
        ModelSettings {
            block_log2: 4,
            min_log2: 0,
            // Every key point weighs alike: with weights falling with the cell's side, a
            // large cell's small neighbours outweigh it near their boundary and the
            // network turns there more abruptly than the picture, which costs the
            // detail layer bits. Measured on the photographs with the detail layer
            // (docs/codec-ablation.md, "The network's kernel"): footprints 0.42 and 0.6
            // lose to 0.5, weights s^-1 and s^-0.5 lose to equal ones.
            kernel: KernelParams {
                sigma_factor: 0.5,
                weight_exponent: 0.0,
            },
            split_threshold: 0.05,
            target_keypoints: None,
            rounds: 4,
            growth: 0.35,
            cg_iterations: (12, 40),
            ridge: 0.05,
            chroma_pruned: true,
            least_squares: true,
            analysis_start: true,
            uniform_grid: false,
        }
    }
}

/// The fitted model of one image.
#[derive(Debug, Clone)]
pub struct Model {
    /// Tree geometry.
    pub shape: TreeShape,
    /// Kernel parameters.
    pub kernel: KernelParams,
    /// Luma leaves in coding order.
    pub luma_cells: Vec<Cell>,
    /// Chroma leaves in coding order (empty for grey images).
    pub chroma_cells: Vec<Cell>,
    /// Per luma key point: Y (or grey), then alpha if present.
    pub luma_colours: Vec<Vec<f64>>,
    /// Per chroma key point: C1, C2 (empty for grey images).
    pub chroma_colours: Vec<Vec<f64>>,
}

/// Relative residual at which refinement-round fits stop: they only rank leaves for
/// splitting, which a rough solution does as well (measured: no BD-rate change).
const ROUND_TOLERANCE: f64 = 1e-3;
/// Relative residual of the final fit, whose colours are coded.
const FINAL_TOLERANCE: f64 = 1e-5;

struct Fitted {
    /// The chroma cells the fit used (empty for grey images).
    chroma_cells: Vec<Cell>,
    luma_colours: Vec<Vec<f64>>,
    chroma_colours: Vec<Vec<f64>>,
    /// Per luma leaf: squared error over its pixels, all channels (empty unless
    /// measured).
    leaf_error: Vec<f64>,
}

fn luma_targets(planes: &CodingPlanes) -> Vec<&[f64]> {
    let mut t = vec![planes.colour[0].as_slice()];
    if let Some(a) = &planes.alpha {
        t.push(a);
    }
    t
}

/// The colours of one key-point set, and with `reconstruct` the planes they render
/// (else none: only the refinement rounds measure the fit's error).
fn fit_set(
    ks: &KeySet,
    targets: &[&[f64]],
    ridge: f64,
    (iterations, tolerance): (usize, f64),
    least_squares: bool,
    reconstruct: bool,
) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let a = ks.pixel_weights();
    let ls = LeastSquares::new(&a, ks.len());
    let projection = ls.project(targets);
    let colours = if least_squares {
        ls.solve_projected(&projection, ridge, iterations, tolerance)
    } else {
        projection.prior
    };
    if !reconstruct {
        return (colours, Vec::new());
    }
    let mut recon = vec![0.0; a.row_start.len() - 1];
    let recons = colours
        .iter()
        .map(|c| {
            a.apply(c, 1, &mut recon);
            recon.clone()
        })
        .collect();
    (colours, recons)
}

fn fit(
    frame: Frame,
    shape: &TreeShape,
    s: &ModelSettings,
    planes: &CodingPlanes,
    cells: &[Cell],
    solve: (usize, f64),
    measure: bool,
) -> Fitted {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let luma = KeySet::new(frame, cells, s.kernel);
    let targets = luma_targets(planes);
    let (luma_colours, luma_recon) =
        fit_set(&luma, &targets, s.ridge, solve, s.least_squares, measure);
    let mut err = vec![0.0; if measure { w * h } else { 0 }];
    for (t, r) in targets.iter().zip(&luma_recon) {
        for i in 0..w * h {
            err[i] += (t[i] - r[i]).powi(2);
        }
    }
    let (chroma_cells, chroma_colours) = if planes.colour.len() == 3 {
        let cc = chroma_cells(shape, cells, s.chroma_pruned);
        let ks = KeySet::new(frame, &cc, s.kernel);
        let t = [planes.colour[1].as_slice(), planes.colour[2].as_slice()];
        let (colours, recons) = fit_set(&ks, &t, s.ridge, solve, s.least_squares, measure);
        for (t, r) in t.iter().zip(&recons) {
            for i in 0..w * h {
                err[i] += (t[i] - r[i]).powi(2);
            }
        }
        (cc, colours)
    } else {
        (Vec::new(), Vec::new())
    };
    let leaf_error = if measure { cells } else { &[] }
        .iter()
        .map(|c| {
            let (x0, y0, x1, y1) = c.clip(frame.width, frame.height);
            (y0..y1)
                .map(|y| {
                    (x0..x1)
                        .map(|x| err[y as usize * w + x as usize])
                        .sum::<f64>()
                })
                .sum()
        })
        .collect();
    Fitted {
        chroma_cells,
        luma_colours,
        chroma_colours,
        leaf_error,
    }
}

/// Mean of `plane` over cell `c`'s pixels inside the image.
fn cell_mean(plane: &[f64], c: &Cell, width: u32, height: u32) -> f64 {
    let (x0, y0, x1, y1) = c.clip(width, height);
    let w = width as usize;
    let sum: f64 = (y0..y1)
        .map(|y| {
            plane[y as usize * w + x0 as usize..y as usize * w + x1 as usize]
                .iter()
                .sum::<f64>()
        })
        .sum();
    sum / ((x1 - x0) * (y1 - y0)) as f64
}

/// Chooses the tree and fits the colours. `progress(round, rounds)` reports progress.
pub fn build(
    planes: &CodingPlanes,
    width: u32,
    height: u32,
    s: &ModelSettings,
    progress: impl FnMut(usize, usize),
) -> Model {
    build_in(Frame::new(width, height), planes, s, progress)
}

/// [`build`] for the pixels of `frame` (a whole image, or a tile of one embedded where
/// it lies): the tree covers the frame's `width x height` pixels, cells in its own
/// coordinates.
pub fn build_in(
    frame: Frame,
    planes: &CodingPlanes,
    s: &ModelSettings,
    mut progress: impl FnMut(usize, usize),
) -> Model {
    let (width, height) = (frame.width, frame.height);
    let shape = TreeShape {
        width,
        height,
        block_log2: s.block_log2,
        min_log2: s.min_log2,
    };
    // The walk asks only about cells that may split: above the smallest size.
    let analysis = Analysis::levels(
        &planes.colour,
        width as usize,
        height as usize,
        s.min_log2 + 1,
        s.block_log2,
    );
    let mut split: HashSet<Cell> = HashSet::new();
    // Analysis-driven start: split while the predicted leaf error is above threshold.
    let start_threshold = match s.target_keypoints {
        // With a key-point budget, start coarse and let the greedy rounds spend it.
        Some(_) => f64::INFINITY,
        None if s.analysis_start => s.split_threshold,
        None => f64::INFINITY,
    };
    shape.walk(|c| {
        let (x0, y0, x1, y1) = c.clip(width, height);
        let e = analysis.predicted_error(c.log2, x0, y0, x1, y1);
        let yes = e > start_threshold;
        if yes {
            split.insert(*c);
        }
        yes
    });
    let rounds = match s.target_keypoints {
        Some(_) => s.rounds.max(12),
        None => s.rounds,
    };
    // The rounds fit coarsely and measure each leaf's error; the last fits finely.
    let fit_cells =
        |cells: &[Cell], solve, measure| fit(frame, &shape, s, planes, cells, solve, measure);
    for round in 0..rounds {
        progress(round, rounds + 1);
        let cells = shape.walk(|c| split.contains(c));
        if let Some(n) = s.target_keypoints {
            if cells.len() >= n {
                break;
            }
        }
        let fitted = fit_cells(&cells, (s.cg_iterations.0, ROUND_TOLERANCE), true);
        let mut order: Vec<usize> = (0..cells.len())
            .filter(|&i| cells[i].log2 > s.min_log2 && fitted.leaf_error[i] > 0.0)
            .collect();
        // Worst first; ties by coding order, so the choice is deterministic.
        order.sort_by(|&a, &b| {
            fitted.leaf_error[b]
                .total_cmp(&fitted.leaf_error[a])
                .then(a.cmp(&b))
        });
        let budget = match s.target_keypoints {
            Some(n) => n
                .saturating_sub(cells.len())
                .div_ceil(3)
                .min(((cells.len() as f64 * s.growth) as usize).max(1)),
            None => ((cells.len() as f64 * s.growth) as usize).max(1),
        };
        let mut added = 0;
        for i in order {
            if added >= budget
                || (s.target_keypoints.is_none() && fitted.leaf_error[i] <= s.split_threshold)
            {
                break;
            }
            split.insert(cells[i]);
            added += 1;
        }
        if added == 0 {
            break;
        }
    }
    progress(rounds, rounds + 1);
    let mut cells = shape.walk(|c| split.contains(c));
    if s.uniform_grid {
        // The uniform level whose key-point count is nearest (in ratio) the tree's.
        let n = cells.len() as f64;
        let level = (s.min_log2..=s.block_log2)
            .min_by(|&a, &b| {
                let count = |l: u8| shape.walk(|c| c.log2 > l).len() as f64;
                (count(a) / n)
                    .ln()
                    .abs()
                    .total_cmp(&(count(b) / n).ln().abs())
            })
            .expect("non-empty level range");
        cells = shape.walk(|c| c.log2 > level);
    }
    if !s.least_squares {
        // Each leaf's mean colour over its own pixels: no weight matrix, no solve. The
        // detail layer takes up what the smoother least-squares fit would have added.
        let means = |cells: &[Cell], targets: &[&[f64]]| -> Vec<Vec<f64>> {
            targets
                .iter()
                .map(|t| {
                    cells
                        .iter()
                        .map(|c| cell_mean(t, c, width, height))
                        .collect()
                })
                .collect()
        };
        let chroma_cells = if planes.colour.len() == 3 {
            chroma_cells(&shape, &cells, s.chroma_pruned)
        } else {
            Vec::new()
        };
        let chroma_colours = if chroma_cells.is_empty() {
            Vec::new()
        } else {
            means(
                &chroma_cells,
                &[planes.colour[1].as_slice(), planes.colour[2].as_slice()],
            )
        };
        return Model {
            shape,
            kernel: s.kernel,
            luma_colours: means(&cells, &luma_targets(planes)),
            luma_cells: cells,
            chroma_cells,
            chroma_colours,
        };
    }
    let fitted = fit_cells(&cells, (s.cg_iterations.1, FINAL_TOLERANCE), false);
    Model {
        shape,
        kernel: s.kernel,
        luma_cells: cells,
        chroma_cells: fitted.chroma_cells,
        luma_colours: fitted.luma_colours,
        chroma_colours: fitted.chroma_colours,
    }
}
