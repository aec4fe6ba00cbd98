//! The restoration filters and the deringing, fitted to the decode of the coded tiles
//! against the source, each kept where it pays for its bits.

use rayon::prelude::*;

use super::tiles::coding_planes;
use crate::bitstream;
use crate::deringing::{self, Deringing, Strengths};
use crate::deringing_fit;
use crate::keyset::GridEval;
use crate::rate_control::EncodeSettings;
use crate::restoration::colour_map::{self, ColourSums};
use crate::restoration::{self, Restoration};
use crate::restoration_fit::{self, ClassStats};
use crate::source::PixelSource;
use crate::tiling::TileRect;
use crate::CodecError;

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
pub(super) fn fit_post_filters(
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
