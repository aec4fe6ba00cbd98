//! Parsing: the container's sections entropy-decoded into the key points, their
//! values and the detail layer, tiles in parallel.

use crate::par::*;

use super::Decoded;
use crate::bitstream::{self, Header, Parsed, TilePayload};
use crate::detail::adaptive::{block_classes, BlockSteps};
use crate::detail::budget::LayerBudget;
use crate::detail::dct::N as DCT_N;
use crate::detail::field::ActivityField;
use crate::detail::{blocks as detail_blocks, Detail, DetailPlane};
use crate::entropy::AnsSource;
use crate::quadtree::chroma_cells;
use crate::quadtree::{Cell, TreeShape};
use crate::syntax::{self, LevelSteps, MAX_SYMBOLS_PER_VALUE};
use crate::tiling::{into_image_order, TileRect};
use crate::CodecError;

/// Entropy-decodes one value section: `channels` planes of quantised values over
/// `cells`.
fn read_section(
    payload: &[u8],
    cells: &[Cell],
    (width, height): (u32, u32),
    channels: usize,
    levels: LevelSteps,
) -> Result<Vec<Vec<i64>>, CodecError> {
    let max_symbols = MAX_SYMBOLS_PER_VALUE * cells.len() as u64 * channels as u64;
    let mut src = AnsSource::new(payload, max_symbols)?;
    let values = syntax::read_channels(cells, width, height, channels, levels, &mut src)?;
    if !src.finished_cleanly() {
        return Err(CodecError::PayloadLeftover {
            stream: "entropy-coded payload",
        });
    }
    Ok(values)
}

/// Quantised planes times their key points' steps (`levels` from the roots' `steps`):
/// the key points' values.
fn dequantise(
    planes: &[Vec<i64>],
    steps: &[f64],
    cells: &[Cell],
    levels: LevelSteps,
) -> Vec<Vec<f64>> {
    planes
        .iter()
        .zip(steps)
        .map(|(q, &step)| levels.dequantise(cells, q, step))
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

/// Decodes one tile's tree: its shape and its leaves.
fn read_tree(header: &Header, t: &TilePayload) -> Result<(TreeShape, Vec<Cell>), CodecError> {
    let r = t.rect;
    let shape = TreeShape {
        width: r.width,
        height: r.height,
        block_log2: header.block_log2,
        min_log2: header.min_log2,
    };
    let mut src = AnsSource::new(t.tree, shape.max_flags())?;
    let cells = syntax::read_tree(&shape, t.luma_count as usize, &mut src)?;
    CodecError::check_count(
        "a tile's tree",
        "leaves",
        cells.len() as u64,
        t.luma_count.into(),
    )?;
    if !src.finished_cleanly() {
        return Err(CodecError::PayloadLeftover {
            stream: "tree payload",
        });
    }
    Ok((shape, cells))
}

/// Entropy-decodes one tile: tree, values (luma and chroma side by side) and detail.
fn read_tile(
    header: &Header,
    t: &TilePayload,
    budget: &LayerBudget,
) -> Result<TileDecoded, CodecError> {
    let r = t.rect;
    let (shape, cells) = read_tree(header, t)?;
    let size = (r.width, r.height);
    let (luma_steps, _) = steps(header);
    let colour = header.layout.colour_channels() == 3;
    // The streams are independent; each finds its neighbours while decoding (and
    // chroma its cells first).
    let (luma, (chroma, detail)) = crate::par::join(
        || read_section(t.luma, &cells, size, luma_steps.len(), header.level_steps()),
        || {
            crate::par::join(
                || -> Result<_, CodecError> {
                    if !colour {
                        return Ok((Vec::new(), Vec::new()));
                    }
                    let cc = chroma_cells(&shape, &cells, header.chroma_pruned);
                    let (found, declared) = (cc.len() as u64, t.chroma_count.into());
                    CodecError::check_count("a tile's chroma tree", "leaves", found, declared)?;
                    let values = read_section(t.chroma, &cc, size, 2, header.level_steps())?;
                    Ok((cc, values))
                },
                || -> Result<_, CodecError> {
                    match header.detail_plane_steps() {
                        Some(steps) if !t.detail.is_empty() => {
                            let classes = block_classes(&cells, r.width, r.height);
                            let field = header.adaptive.and_then(|a| a.field());
                            let (w, h) = (r.width, r.height);
                            Detail::read_within(t.detail, w, h, steps, &classes, field, budget)
                                .map(|(d, _)| Some(d))
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

/// Every tile's detail streams' models as each stream ends (luma's, then chroma's): the
/// statistics the contexts' starting tables are trained from
/// ([`crate::detail::context_tables`]). A file without a detail layer has none.
pub fn detail_models(
    parsed: &Parsed,
) -> Result<Vec<Vec<crate::detail::syntax::ModelState>>, CodecError> {
    let header = &parsed.header;
    let Some(steps) = header.detail_plane_steps() else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    for t in parsed.tiles.iter().filter(|t| !t.detail.is_empty()) {
        let (_, cells) = read_tree(header, t)?;
        let classes = block_classes(&cells, t.rect.width, t.rect.height);
        let field = header.adaptive.and_then(|a| a.field());
        let (_, contexts) = Detail::read(
            t.detail,
            t.rect.width,
            t.rect.height,
            steps.clone(),
            &classes,
            field,
        )?;
        out.extend(contexts.iter().map(|c| c.models()));
    }
    Ok(out)
}

/// Entropy-decodes every tile (in parallel) and joins them into the image's key points
/// in its coding order and its detail layer.
pub fn read_parsed(parsed: &Parsed) -> Result<Decoded, CodecError> {
    read_parsed_within(parsed, &LayerBudget::unlimited())
}

/// [`read_parsed`] with the detail layer's levels taken from `budget` as they are read
/// and gathered.
pub fn read_parsed_within(parsed: &Parsed, budget: &LayerBudget) -> Result<Decoded, CodecError> {
    let header = parsed.header.clone();
    let tiles = parsed
        .tiles
        .par_iter()
        .map(|t| read_tile(&header, t, budget))
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
        let (planes, field): (Vec<Option<DetailPlane>>, _) = match t.detail {
            Some(d) => (d.planes.into_iter().map(Some).collect(), d.field),
            None => (Vec::new(), None),
        };
        details.push((p.rect, planes, field));
    }
    let (luma_cells, luma_values) = into_image_order(&luma_cells, &luma_values, header.block_log2);
    let (chroma_cells, chroma_values) =
        into_image_order(&chroma_cells, &chroma_values, header.block_log2);
    let detail = header
        .detail_plane_steps()
        .map(|steps| -> Result<Detail, CodecError> {
            let (cols, rows) = detail_blocks(header.width, header.height);
            let planes = (0..steps.len())
                .map(|c| {
                    let tiles = details
                        .iter_mut()
                        .map(|(r, planes, _)| {
                            let at = (r.x0 as usize / DCT_N, r.y0 as usize / DCT_N);
                            (at, planes.get_mut(c).and_then(Option::take))
                        })
                        .collect();
                    DetailPlane::from_tiles(cols, rows, tiles, budget)
                })
                .collect::<Result<_, _>>()?;
            Ok(Detail {
                planes,
                steps,
                deblock: header.deblock,
                lapping: header.lapping,
                block_steps: header.adaptive.map(|steps| BlockSteps {
                    steps,
                    classes: block_classes(&luma_cells, header.width, header.height),
                    field: match steps.field() {
                        Some(_) => image_field(&details, cols, rows),
                        None => Vec::new(),
                    },
                }),
                weights: header.weights,
                field: None,
            })
        });
    let detail = detail.transpose()?;
    Ok(Decoded {
        luma_values: dequantise(&luma_values, &luma_steps, &luma_cells, header.level_steps()),
        chroma_values: dequantise(
            &chroma_values,
            &chroma_steps,
            &chroma_cells,
            header.level_steps(),
        ),
        detail,
        header,
        luma_cells,
        chroma_cells,
    })
}

/// A tile's rectangle, its detail planes (taken as they are gathered) and its
/// activity field.
type TileDetail = (TileRect, Vec<Option<DetailPlane>>, Option<ActivityField>);

/// Each block's activity field exponent in a `cols x rows` image, from the tiles'
/// fields (0 in a tile without a coded block, whose levels are all 0).
fn image_field(tiles: &[TileDetail], cols: usize, rows: usize) -> Vec<i8> {
    let mut all = vec![0i8; cols * rows];
    for (r, _, field) in tiles {
        let Some(f) = field else { continue };
        let (tc, tr) = detail_blocks(r.width, r.height);
        let (bx0, by0) = (r.x0 as usize / DCT_N, r.y0 as usize / DCT_N);
        for (i, e) in f.block_exponents(tc, tr).into_iter().enumerate() {
            all[(by0 + i / tc) * cols + bx0 + i % tc] = e;
        }
    }
    all
}

/// Parses and entropy-decodes a file (no pixel evaluation).
pub fn read(bytes: &[u8], max_pixels: u64) -> Result<Decoded, CodecError> {
    read_parsed(&bitstream::parse(bytes, max_pixels)?)
}
