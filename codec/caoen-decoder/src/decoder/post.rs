//! The post-filters of the identity path (restoration, deringing, the last luma filter)
//! over tasks of output rows: how many rows a task takes, what it holds, and the rows
//! past its own it restores.

use crate::bitstream::Header;
use crate::deringing::{self, Deringing};
use crate::keyset::GridEval;
use crate::restoration::Restoration;

/// The whole output's coding planes (as `band_coding` orders them) before
/// restoration and deringing, when the file has either: the filters reach across
/// bands.
pub(super) struct Restored {
    pub(super) planes: Vec<Vec<f32>>,
    pub(super) size: (usize, usize),
    pub(super) spacing: (f64, f64),
}

/// Evaluation bands in a task of the post-filtered path, at least.
const POST_FILTER_BANDS: usize = 4;

/// Rows of a task of the post-filtered path at `spacing` coded pixels per output pixel,
/// on an output `h` rows high. A task restores rows past its own on either side
/// ([`post_margin`], which grows with the zoom): four times those, so that they stay a
/// small part of its work at any zoom, unless that leaves a worker without a task or
/// two; at the coded size a whole number of deringing blocks, so that tasks start on
/// a block. The rows a task covers never change its output.
pub(super) fn post_task_rows(spacing: (f64, f64), h: usize) -> usize {
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
pub(super) fn post_filter_rows(
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
    // Zoomed, the taps' rows are restored, and of each block only the eight rows its
    // direction reads (below): a block is `8 x scale` rows, far more than the taps
    // reach.
    let sparse = sparse_directions(scale);
    let reach = if sparse {
        let taps = Deringing::tap_rows(scale);
        rows.start.saturating_sub(taps)..(rows.end + taps).min(hh)
    } else {
        Deringing::reach(rows.clone(), hh, scale)
    };
    let len = reach.len() * w;
    // Every value is overwritten by the restoration: no need to clear.
    scratch.resize(src.len() * len, 0.0);
    let mut parts: Vec<&mut [f32]> = scratch.chunks_exact_mut(len).collect();
    restore(reach.clone(), &mut parts);
    let window: Vec<&[f32]> = scratch.chunks_exact(len).collect();
    if !sparse {
        return d.filter_rows(&window, (w, hh), reach.start, scale, steps, rows, dst);
    }
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
