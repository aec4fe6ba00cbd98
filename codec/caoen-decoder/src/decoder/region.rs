//! Where the identity path evaluates: the output's pixel centres, or, for a region,
//! the pixel centres of a window of the decode at the region's scale.
//!
//! A region drawn at `ow x oh` is a window of a virtual whole-image decode at the
//! same scale. Where the region's edges fall on that decode's pixel edges (the region
//! spans a whole number of its pixels from the image's corner) the window's centres
//! are the whole decode's own, so the region equals the crop of that decode. The
//! restoration filters and the deringing reach across pixels and group them in
//! blocks counted from the image's corner, so with either the window reaches past the
//! region by what they read, starts on a block edge and is cropped afterwards: the
//! work stays within the output plus those margins (a few coded pixels at the
//! output's scale), however large the virtual decode.

use super::{decode_memory_at, output_size};
use crate::bitstream::Header;
use crate::deringing;
use crate::geometry::Frame;
use crate::keyset::Grid;
use crate::restoration::Restoration;
use crate::{CodecError, DecodeOptions, Region, MAX_SIDE};

/// Largest output pixels per image pixel a region may ask for: past it the margins
/// alone outgrow any budget.
pub const MAX_ZOOM: f64 = 4096.0;

/// What an identity decode evaluates and keeps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Plan {
    /// The evaluation positions (the window's pixel centres).
    pub grid: Grid,
    /// The window's size in pixels.
    pub window: (u32, u32),
    /// The output's offset in the window.
    pub offset: (u32, u32),
    /// The output's size.
    pub out: (u32, u32),
    /// The estimated memory of all but the detail layer's levels and coefficients,
    /// checked.
    pub need: u64,
}

impl Plan {
    /// The plan of decoding `header`'s file with `opts`, its sizes checked against the
    /// options' limits (`sample_bytes` per output sample) before anything is made.
    pub fn new(
        header: &Header,
        opts: &DecodeOptions,
        sample_bytes: u64,
    ) -> Result<Self, CodecError> {
        let frame = Frame::new(header.width, header.height);
        let Some(region) = opts.region else {
            let ((ow, oh), need) = output_size(header, opts, sample_bytes)?;
            return Ok(Plan {
                grid: Grid::pixel_centres(&frame, ow, oh),
                window: (ow, oh),
                offset: (0, 0),
                out: (ow, oh),
                need,
            });
        };
        let (dw, dh) = header.display_size();
        let size = validate(&region, (dw, dh), super::requested_size(header, opts))?;
        let x = Axis::new(region.x0, region.x1, dw, header.width, size.0);
        let y = Axis::new(region.y0, region.y1, dh, header.height, size.1);
        let (wx, wy) = if header.post_filtered() {
            let spacing = (x.dx, y.dx);
            let scale = deringing::scale(spacing);
            // The last filter reads rows by its reach along y; the same reach along x,
            // with the axes swapped.
            let reach = (
                Restoration::last_reach((spacing.1, spacing.0)),
                Restoration::last_reach(spacing),
            );
            (x.window(reach.0, scale.0), y.window(reach.1, scale.1))
        } else {
            (x.start..x.start + x.len, y.start..y.start + y.len)
        };
        let window = ((wx.end - wx.start) as u32, (wy.end - wy.start) as u32);
        let px = u64::from(window.0) * u64::from(window.1);
        if window.0 > MAX_SIDE || window.1 > MAX_SIDE || px > opts.max_pixels {
            return Err(CodecError::Limit {
                what: "region window pixels (output and the filters' margins)",
                value: px,
                limit: opts
                    .max_pixels
                    .min(u64::from(MAX_SIDE) * u64::from(MAX_SIDE)),
            });
        }
        let need = decode_memory_at(header, window, Some((x.dx, y.dx)), None, sample_bytes);
        opts.limits.check(
            || {
                format!(
                    "decoding a region of {}x{} to {}x{} (a {}x{} window)",
                    header.width, header.height, size.0, size.1, window.0, window.1
                )
            },
            need,
        )?;
        Ok(Plan {
            grid: Grid {
                x0: x.first + wx.start as f64 * x.dx,
                dx: x.dx,
                nx: window.0 as usize,
                y0: y.first + wy.start as f64 * y.dx,
                dy: y.dx,
                ny: window.1 as usize,
            },
            window,
            offset: ((x.start - wx.start) as u32, (y.start - wy.start) as u32),
            out: size,
            need,
        })
    }

    /// Whether the output is the whole window.
    pub fn whole(&self) -> bool {
        self.window == self.out
    }

    /// The output's rows out of the window's samples (`channels` planes one after the
    /// other when `planar`, else interleaved pixels).
    pub fn crop<T: Copy>(&self, samples: &[T], channels: usize, planar: bool) -> Vec<T> {
        let (ww, wh) = (self.window.0 as usize, self.window.1 as usize);
        let (ow, oh) = (self.out.0 as usize, self.out.1 as usize);
        let (ox, oy) = (self.offset.0 as usize, self.offset.1 as usize);
        let mut out = Vec::with_capacity(ow * oh * channels);
        if planar {
            for plane in samples.chunks_exact(ww * wh) {
                for row in plane.chunks_exact(ww).skip(oy).take(oh) {
                    out.extend_from_slice(&row[ox..ox + ow]);
                }
            }
        } else {
            for row in samples.chunks_exact(ww * channels).skip(oy).take(oh) {
                out.extend_from_slice(&row[ox * channels..(ox + ow) * channels]);
            }
        }
        out
    }
}

/// `size`, once `region` of a `dw x dh` image and the size are checked.
fn validate(r: &Region, (dw, dh): (u32, u32), size: (u32, u32)) -> Result<(u32, u32), CodecError> {
    let fail = |reason| CodecError::Region {
        x0: r.x0,
        y0: r.y0,
        x1: r.x1,
        y1: r.y1,
        width: dw,
        height: dh,
        reason,
    };
    let edges = [r.x0, r.y0, r.x1, r.y1];
    if !edges.iter().all(|v| v.is_finite()) {
        return Err(fail("every edge must be a finite number"));
    }
    if r.x0 >= r.x1 || r.y0 >= r.y1 {
        return Err(fail("x0 < x1 and y0 < y1 are needed"));
    }
    if r.x0 < 0.0 || r.y0 < 0.0 || r.x1 > f64::from(dw) || r.y1 > f64::from(dh) {
        return Err(fail("the region must lie within the image"));
    }
    let (ow, oh) = size;
    if ow == 0 || oh == 0 || ow > MAX_SIDE || oh > MAX_SIDE {
        return Err(CodecError::Parameter {
            name: "output size",
            value: format!("{ow}x{oh}"),
            reason: "1..=16384 per side",
        });
    }
    if f64::from(ow) / (r.x1 - r.x0) > MAX_ZOOM || f64::from(oh) / (r.y1 - r.y0) > MAX_ZOOM {
        return Err(fail("at most 4096 output pixels per image pixel"));
    }
    Ok((ow, oh))
}

/// One axis of a region's virtual whole decode: pixel `i` of it is centred at
/// `first + i dx` coded pixels, `0 <= i < n`, and the region is pixels
/// `start..start + len`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Axis {
    dx: f64,
    first: f64,
    n: u64,
    start: u64,
    len: u64,
}

impl Axis {
    /// The axis of the region `lo..hi` of an image `display` pixels long, coded in
    /// `coded` pixels, drawn in `out` pixels.
    fn new(lo: f64, hi: f64, display: u32, coded: u32, out: u32) -> Self {
        let (out, display, coded) = (f64::from(out), f64::from(display), f64::from(coded));
        let full = out * display / (hi - lo);
        let offset = lo * out / (hi - lo);
        let whole = |v: f64| (v - v.round()).abs() <= 1e-9 * v.abs().max(1.0);
        if whole(full) && whole(offset) && full.round() >= 1.0 {
            // The whole decode's own centres, with its spacing formed as it forms it.
            let n = full.round();
            let dx = coded / n;
            return Axis {
                dx,
                first: 0.5 * dx,
                n: n as u64,
                start: offset.round() as u64,
                len: out as u64,
            };
        }
        let scale = coded / display;
        let (lo, hi) = (lo * scale, hi * scale);
        let dx = (hi - lo) / out;
        // The centres `lo + (m + 0.5) dx` for every whole `m` that lie in the image.
        let start = (lo / dx + 0.5).floor().max(0.0);
        let after = ((coded - lo) / dx - 0.5).ceil().max(out);
        Axis {
            dx,
            first: lo + (0.5 - start) * dx,
            n: (start + after) as u64,
            start: start as u64,
            len: out as u64,
        }
    }

    /// The window of pixels whose filtering reaches the region's `len` pixels: the
    /// last filter's `reach`, the deringing's blocks of `8 k` pixels and taps of `2 k`
    /// around those, the restoration's `reach` again, starting on a block edge.
    fn window(&self, reach: usize, k: usize) -> std::ops::Range<u64> {
        let (reach, k) = (reach as u64, k as u64);
        let side = deringing::BLOCK as u64 * k;
        let (lo, hi) = (
            self.start.saturating_sub(reach),
            self.start + self.len + reach,
        );
        let (lo, hi) = (
            lo.saturating_sub(2 * k) / side * side,
            (hi + 2 * k).div_ceil(side) * side,
        );
        lo.saturating_sub(reach) / side * side..(hi + reach).min(self.n)
    }
}
