//! The `.cae` encoder: the tree of key points chosen and fitted to the image, their
//! values quantised, the detail layer chosen by rate and distortion, the restoration
//! filters fitted to the decode, and the choices of quality, coded size and rate
//! target that [`encode`] makes. It writes what `caoen-decoder` reads
//! (`docs/format.md`) and builds on that crate's coding stages.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod analysis;
pub mod deringing_fit;
#[cfg(test)]
mod detail_tests;
pub mod encoder;
pub mod fit;
pub mod keypoint_map;
pub mod model;
pub mod quantise;
pub mod rate_control;
pub mod request;
pub mod resample;
pub mod restoration_fit;
pub mod source;

pub use caoen_base::budget::Limits;
pub use request::EncodeRequest;
pub use resample::Scale;
pub use source::PixelSource;

// The decoder's stages, named as the encoder's own modules name them.
use caoen_base::budget::OverBudget;
use caoen_base::metadata::Metadata;
use caoen_base::raster::Raster;
use caoen_decoder::{
    bitstream, colour, decoder, deringing, detail, entropy, geometry, keyset, quadtree,
    restoration, syntax, tiling, CodecError, MAX_SIDE,
};
use caoen_decoder::{decode, DecodeOptions};

/// Encoder settings.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodeOptions {
    /// Quality 0..=100 (higher: more key points, finer quantisation).
    pub quality: f32,
    /// Effort 1..=9: encoder time traded for quality at the same size.
    pub effort: u8,
    /// Rate target, overriding `quality` by search.
    pub target: Option<RateTarget>,
    /// Exact number of key points (luma), overriding the quality's choice.
    pub keypoints: Option<usize>,
    /// ICC profile, EXIF and XMP stored with the image.
    pub metadata: Metadata,
    /// Memory limit of the call.
    pub limits: Limits,
    /// Whether the image may be coded at a smaller size than its own.
    pub resampling: Resampling,
}

/// Whether the encoder codes an image at a smaller size than its own, which the
/// decoder draws at the image's size from the continuous network. At low rates that
/// spends the bits on the frequencies that carry the most.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Resampling {
    /// At a smaller size where that pays by rate and distortion: each of
    /// [`RESAMPLE_SCALES`] tried below its quality from its effort, on 8- and 16-bit
    /// images of at least [`RESAMPLE_MIN_SIDE`] pixels per side.
    #[default]
    Auto,
    /// Always at the image's own size.
    Off,
    /// Always at this size ([`Scale::HALF`]: half size per side); an image too small
    /// to get smaller keeps its size.
    At(Scale),
}

/// A smaller size [`Resampling::Auto`] tries: the coded side over the image's, and
/// from which effort and below which quality it is tried.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResampleScale {
    /// The coded size.
    pub scale: resample::Scale,
    /// Lowest effort that tries it.
    pub from_effort: u8,
    /// Qualities below this try it.
    pub below: f32,
}

/// The smaller sizes [`Resampling::Auto`] tries, the coarsest first. Half size pays
/// most below 0.1 bpp; 0.7 and 0.8 per side pay where half size is too coarse, up to
/// about 0.3 bpp on the photographs; above quality 60 none paid
/// (`docs/codec-ablation.md`, "Coding at a smaller size").
pub const RESAMPLE_SCALES: [ResampleScale; 3] = [
    ResampleScale {
        scale: resample::Scale::HALF,
        from_effort: 3,
        below: 55.0,
    },
    ResampleScale {
        scale: resample::Scale::of_tenths(7),
        from_effort: 5,
        below: 60.0,
    },
    ResampleScale {
        scale: resample::Scale::of_tenths(8),
        from_effort: 5,
        below: 60.0,
    },
];
/// [`Resampling::Auto`] codes every image at its own size from this quality up.
pub const RESAMPLE_BELOW: f32 = 60.0;
/// [`Resampling::Auto`] leaves images smaller than this on either side at their size.
pub const RESAMPLE_MIN_SIDE: u32 = 64;
/// PSNR (dB) per doubling of rate that [`Resampling::Auto`] weighs a smaller file's
/// change of PSNR against its change of rate. Below the curve's own slope (3-3.7 dB
/// per doubling there): a smaller file must win clearly, as sparse choices cost
/// more than they gain (`docs/codec-ablation.md`, "Coding at a smaller size").
const RESAMPLE_SLOPE: f64 = 2.0;

/// Statistics of one encode.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodeStats {
    /// Luma key points.
    pub luma_keypoints: usize,
    /// Chroma key points.
    pub chroma_keypoints: usize,
    /// Tiles.
    pub tiles: usize,
    /// Bytes of the whole file.
    pub bytes: usize,
    /// The size the image was coded at (its own, or a smaller one: [`Resampling`]).
    pub coded_size: (u32, u32),
}

/// A rate target for the encoder's search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RateTarget {
    /// Bits per pixel of the whole file.
    BitsPerPixel(f64),
    /// Total file size in bytes.
    Bytes(u64),
}

impl Default for EncodeOptions {
    fn default() -> Self {
        EncodeOptions {
            quality: 75.0,
            effort: 5,
            target: None,
            keypoints: None,
            metadata: Metadata::default(),
            limits: Limits::default(),
            resampling: Resampling::Auto,
        }
    }
}

/// Encodes `image` (a [`Raster`], or any [`PixelSource`]) into a caoen file.
pub fn encode<S: PixelSource + ?Sized>(
    image: &S,
    opts: &EncodeOptions,
) -> Result<Vec<u8>, CodecError> {
    encode_with_progress(image, opts, |_, _| {}).map(|(bytes, _)| bytes)
}

/// Encodes, reporting progress as `(done, total)` steps; also returns statistics.
///
/// The image is coded in tiles, as many at once as there are rayon threads and the
/// memory limit allows; the bytes do not depend on either.
pub fn encode_with_progress<S: PixelSource + ?Sized>(
    image: &S,
    opts: &EncodeOptions,
    mut progress: impl FnMut(usize, usize) + Send,
) -> Result<(Vec<u8>, EncodeStats), CodecError> {
    if !(0.0..=100.0).contains(&opts.quality) {
        return Err(CodecError::Parameter {
            name: "quality",
            value: opts.quality.to_string(),
            reason: "0..=100",
        });
    }
    if !(1..=9).contains(&opts.effort) {
        return Err(CodecError::Parameter {
            name: "effort",
            value: opts.effort.to_string(),
            reason: "1..=9",
        });
    }
    if opts.keypoints == Some(0) {
        return Err(CodecError::Parameter {
            name: "keypoints",
            value: "0".into(),
            reason: "at least 1",
        });
    }
    encoder::prepare(image)?;
    let worst_quality = if opts.target.is_some() {
        100.0
    } else {
        opts.quality
    };
    let (w, h) = (image.width(), image.height());
    let base_settings = |q: f32| {
        rate_control::settings(q, opts.effort, opts.keypoints)
            .adapted_to(image.format(), image.layout().has_alpha())
    };
    let mut memory = encode_memory(w, h, worst_quality);
    // Key points: at most one per smallest cell (or the requested number).
    // The smallest cells of any quality the encode may try (a target search: all).
    let lowest_quality = if opts.target.is_some() {
        0.0
    } else {
        opts.quality
    };
    let min_log2 = (base_settings(lowest_quality).model.min_log2)
        .min(base_settings(worst_quality).model.min_log2);
    let smallest = 1u64 << (2 * min_log2.min(31));
    let keys = (u64::from(w) * u64::from(h) / smallest).max(1);
    let keys = opts.keypoints.map_or(keys, |n| keys.min(n as u64));
    memory.fixed = memory
        .fixed
        .saturating_add(keys.saturating_mul(KEY_POINT_BYTES));
    memory.after = memory
        .after
        .saturating_add(keys.saturating_mul(KEY_POINT_BYTES));
    // The restoration fit decodes the file again once the tiles are done: where that
    // would not fit the budget, the image is coded without filters rather than refused.
    let restore = memory.fixed.saturating_add(memory.after) <= opts.limits.max_memory;
    if !restore {
        memory.after = 0;
    }
    let settings = |q: f32| {
        let mut s = base_settings(q);
        s.restoration &= restore;
        s
    };
    let workers = memory.workers(opts.limits.max_memory, rayon::current_num_threads());
    if workers == 0 {
        return Err(OverBudget {
            what: format!("encoding {w}x{h} at quality {worst_quality}"),
            need: memory.need(1),
            budget: opts.limits.max_memory,
        }
        .into());
    }
    let pixels = w as f64 * h as f64;
    let target = match opts.target {
        None => None,
        Some(RateTarget::BitsPerPixel(b)) if b.is_finite() && b > 0.0 => Some(b * pixels / 8.0),
        Some(RateTarget::Bytes(n)) if n > 0 => Some(n as f64),
        Some(t) => {
            return Err(CodecError::Parameter {
                name: "target",
                value: format!("{t:?}"),
                reason: "must be positive",
            });
        }
    };
    let coder = Coder {
        image,
        opts,
        settings: &settings,
        workers,
    };
    let Some(target) = target else {
        return coder.encode(opts.quality, &mut progress);
    };
    // Rate targets search the quality at each size on its own (the rate jumps where
    // the choice of size changes), then choose among the files by the same rule.
    let steps = 6 + opts.effort as usize;
    let forced = match opts.resampling {
        Resampling::At(scale) if scale.coded_size(w, h) != (w, h) => Some(scale),
        _ => None,
    };
    let total = if opts.resampling == Resampling::Auto {
        (RESAMPLE_SCALES.len() + 1) * steps + 1
    } else {
        steps + 1
    };
    let mut done = 0;
    let mut search = |scale: Option<(resample::Scale, &Raster)>,
                      progress: &mut dyn FnMut(usize, usize)| {
        rate_control::search_quality(target, 0.02, steps, |q| {
            done += 1;
            progress(done, total);
            Ok(coder.sized(q, scale, &mut |_, _| {})?.0.len())
        })
        .map(|(q, _)| q)
    };
    let out = match forced {
        Some(scale) => {
            let small = coder.smaller(scale);
            let q = search(Some((scale, &small)), &mut progress)?;
            coder.sized(q, Some((scale, &small)), &mut |_, _| {})?
        }
        None => {
            let q = search(None, &mut progress)?;
            let full = coder.sized(q, None, &mut |_, _| {})?;
            coder.choose(full, coder.scales(q), |_, scale, small| {
                let qs = search(Some((scale, small)), &mut progress)?;
                coder.sized(qs, Some((scale, small)), &mut |_, _| {})
            })?
        }
    };
    progress(total, total);
    Ok(out)
}

/// What every encode of one call shares: the image, the options, the settings per
/// quality and the tiles in progress at once.
struct Coder<'a, S: PixelSource + ?Sized, F: Fn(f32) -> rate_control::EncodeSettings> {
    image: &'a S,
    opts: &'a EncodeOptions,
    settings: &'a F,
    workers: usize,
}

impl<S: PixelSource + ?Sized, F: Fn(f32) -> rate_control::EncodeSettings> Coder<'_, S, F> {
    /// The image at `scale` of its size.
    fn smaller(&self, scale: resample::Scale) -> Raster {
        resample::downscale(
            self.image,
            scale.coded_size(self.image.width(), self.image.height()),
        )
    }

    /// Codes the image at quality `q`, at its own size or at a smaller one from its
    /// downscaled source. A smaller size is coded at [`rate_control::scaled_quality`],
    /// whose rate-distortion slope at the image's size is `q`'s, shaped by
    /// [`rate_control::at_scale`].
    fn sized(
        &self,
        q: f32,
        at: Option<(resample::Scale, &Raster)>,
        progress: &mut (dyn FnMut(usize, usize) + Send),
    ) -> Result<(Vec<u8>, EncodeStats), CodecError> {
        let (image, md) = (self.image, &self.opts.metadata);
        let Some((scale, small)) = at else {
            return encoder::encode_with(image, &(self.settings)(q), md, self.workers, progress);
        };
        let f = scale.factor();
        let s = rate_control::EncodeSettings {
            display: Some((image.width(), image.height())),
            ..rate_control::at_scale((self.settings)(rate_control::scaled_quality(q, f)), q, f)
        };
        encoder::encode_with(small, &s, md, self.workers, progress)
    }

    /// Codes the image at quality `q` at its own size or a smaller one, as
    /// `opts.resampling` asks or, for [`Resampling::Auto`], as [`Chooser`] finds.
    fn encode(
        &self,
        q: f32,
        progress: &mut (dyn FnMut(usize, usize) + Send),
    ) -> Result<(Vec<u8>, EncodeStats), CodecError> {
        let (w, h) = (self.image.width(), self.image.height());
        match self.opts.resampling {
            Resampling::Off => self.sized(q, None, progress),
            Resampling::At(scale) if scale.coded_size(w, h) != (w, h) => {
                let small = self.smaller(scale);
                self.sized(q, Some((scale, &small)), progress)
            }
            Resampling::At(_) => self.sized(q, None, progress),
            Resampling::Auto => {
                let tried = self.scales(q);
                // Each encode is an equal part of the progress.
                let parts = 1 + tried.len();
                let full = self.sized(q, None, &mut |d, t| progress(d, t * parts))?;
                self.choose(full, tried, |i, scale, small| {
                    let part = &mut |d, t| progress(t * (i + 1) + d, t * parts);
                    self.sized(q, Some((scale, small)), part)
                })
            }
        }
    }

    /// The smaller sizes [`Resampling::Auto`] tries at quality `q` (none under another
    /// [`Resampling`]): those of
    /// [`RESAMPLE_SCALES`] for `q` and the effort, on 8- and 16-bit images of at least
    /// [`RESAMPLE_MIN_SIDE`] pixels a side, where the trial fits the memory budget.
    /// Efforts 1 and 2 try none: built for speed, they fit no restoration filters.
    fn scales(&self, q: f32) -> Vec<resample::Scale> {
        let (w, h) = (self.image.width(), self.image.height());
        if self.opts.resampling != Resampling::Auto
            || w.min(h) < RESAMPLE_MIN_SIDE
            || self.image.format() == caoen_base::raster::SampleFormat::F32
        {
            return Vec::new();
        }
        RESAMPLE_SCALES
            .iter()
            .filter(|r| self.opts.effort >= r.from_effort && q < r.below)
            .map(|r| r.scale)
            .filter(|&scale| {
                // The trial holds the small source and its encode, then one decode at a
                // time beside the two files kept (at most 2 bytes per pixel each).
                let channels = self.image.layout().channels();
                let (sw, sh) = scale.coded_size(w, h);
                let coding = encode_memory(sw, sh, rate_control::scaled_quality(q, scale.factor()))
                    .need(self.workers as u64);
                let decoding =
                    caoen_base::budget::bytes(w.into(), h.into(), 8 * channels as u64 + 8)
                        .saturating_add(16 << 20);
                let trial = resample::downscale_memory(w, h, channels, (sw, sh))
                    .saturating_add(coding.max(decoding))
                    .saturating_add(caoen_base::budget::bytes(w.into(), h.into(), 4));
                self.opts.limits.check(String::new, trial).is_ok()
            })
            .collect()
    }

    /// The best of `full` and the sizes of `tried` by [`Chooser`]'s rule, the `i`th size
    /// coded by `code(i, scale, source at that size)`. One smaller source at a time: each
    /// is dropped once coded, and the trials stop once a decode is over the budget.
    fn choose(
        &self,
        full: (Vec<u8>, EncodeStats),
        tried: Vec<resample::Scale>,
        mut code: impl FnMut(
            usize,
            resample::Scale,
            &Raster,
        ) -> Result<(Vec<u8>, EncodeStats), CodecError>,
    ) -> Result<(Vec<u8>, EncodeStats), CodecError> {
        if tried.is_empty() {
            return Ok(full);
        }
        let mut chooser = self.chooser(full)?;
        for (i, scale) in tried.into_iter().enumerate() {
            if chooser.spent {
                break;
            }
            let small = self.smaller(scale);
            chooser.offer(code(i, scale, &small)?)?;
        }
        Ok(chooser.best)
    }

    /// A [`Chooser`] starting from the file at the image's size.
    fn chooser(&self, full: (Vec<u8>, EncodeStats)) -> Result<Chooser<'_, S>, CodecError> {
        let mut c = Chooser {
            image: self.image,
            limits: self.opts.limits.clone(),
            full_error: 0.0,
            full_len: full.0.len() as f64,
            best_score: 0.0,
            best: full,
            spent: false,
        };
        match c.error(&c.best.0) {
            Ok(e) => c.full_error = e,
            // The estimate fell short: the trials are optional, the full-size file stands.
            Err(CodecError::Memory(_)) => c.spent = true,
            Err(e) => return Err(e),
        }
        Ok(c)
    }
}

/// Keeps the best of the files offered for one quality: each is decoded at the image's
/// size and scored by its change of PSNR against the full-size file plus
/// [`RESAMPLE_SLOPE`] dB per doubling of rate it saves; a smaller file is kept when its
/// score is positive and the highest.
struct Chooser<'a, S: PixelSource + ?Sized> {
    image: &'a S,
    limits: Limits,
    full_error: f64,
    full_len: f64,
    best_score: f64,
    /// The file kept so far.
    best: (Vec<u8>, EncodeStats),
    /// A decode did not fit the budget: the file kept stands.
    spent: bool,
}

impl<S: PixelSource + ?Sized> Chooser<'_, S> {
    fn error(&self, bytes: &[u8]) -> Result<f64, CodecError> {
        let opts = DecodeOptions {
            limits: self.limits.clone(),
            ..DecodeOptions::default()
        };
        Ok(squared_error(self.image, &decode(bytes, &opts)?))
    }

    fn offer(&mut self, file: (Vec<u8>, EncodeStats)) -> Result<(), CodecError> {
        if self.spent {
            return Ok(());
        }
        let e = match self.error(&file.0) {
            Ok(e) => e,
            Err(CodecError::Memory(_)) => {
                self.spent = true;
                return Ok(());
            }
            Err(e) => return Err(e),
        };
        let psnr_gain = 10.0 * (self.full_error.max(1e-30) / e.max(1e-30)).log10();
        let doublings = (self.full_len / file.0.len() as f64).log2();
        let score = psnr_gain + RESAMPLE_SLOPE * doublings;
        if score > self.best_score {
            self.best_score = score;
            self.best = file;
        }
        Ok(())
    }
}

/// The sum of squared differences between `image` and `out` (of its size and layout),
/// over every sample, read in strips.
fn squared_error<S: PixelSource + ?Sized>(image: &S, out: &Raster) -> f64 {
    let (w, h) = (image.width(), image.height());
    let n = w as usize * h as usize;
    let channels = image.layout().channels();
    let mut sum = 0.0;
    for y0 in (0..h).step_by(64) {
        let rows = (h - y0).min(64);
        let strip = image.region(tiling::TileRect {
            x0: 0,
            y0,
            width: w,
            height: rows,
        });
        let len = w as usize * rows as usize;
        for c in 0..channels {
            let a = &strip.samples()[c * len..(c + 1) * len];
            let start = c * n + y0 as usize * w as usize;
            let b = &out.samples()[start..start + len];
            sum += a
                .iter()
                .zip(b)
                .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
                .sum::<f64>();
        }
    }
    sum
}

/// Bytes per key point the encoder keeps for the whole image: its cell and values as
/// fitted and as quantised (both while the tiles are coded, whose steps wait for the
/// whole image's key point count), then as quantised and once more in the image's
/// order: at most two copies at once, 56 bytes each with chroma, 64 with alpha.
pub const KEY_POINT_BYTES: u64 = 128;

/// What an encode needs in memory: a fixed part for the whole image and a working set
/// per tile in progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EncodeMemory {
    /// Bytes for the whole image: key points, the tiles' streams, the file.
    pub fixed: u64,
    /// Bytes of one tile's working set.
    pub per_tile: u64,
    /// Number of tiles.
    pub tiles: u64,
    /// Bytes of the restoration fit, after the tiles: the file decoded again (its
    /// detail layer and key points) and the rows it samples, and their restored copies
    /// the deringing is chosen on.
    pub after: u64,
}

impl EncodeMemory {
    /// The need with `workers` tiles in progress.
    pub fn need(&self, workers: u64) -> u64 {
        self.fixed.saturating_add(
            self.per_tile
                .saturating_mul(workers.min(self.tiles))
                .max(self.after),
        )
    }

    /// How many tiles may be in progress at once within `budget` and `threads`
    /// (0: not even one fits).
    pub fn workers(&self, budget: u64, threads: usize) -> usize {
        if self.fixed.saturating_add(self.after) > budget {
            return 0;
        }
        let room = budget.saturating_sub(self.fixed) / self.per_tile.max(1);
        room.min(threads.max(1) as u64).min(self.tiles) as usize
    }
}

/// Estimated peak memory of encoding a `width x height` image at `quality`, beyond the
/// input the caller holds.
///
/// A tile's working set holds its coding planes, the analysis maps and, per key-point
/// set, the fit's sparse design matrix and its transpose; the matrix grows with the
/// number of kernels over each pixel, which rises with quality. The per-pixel figures
/// bound peak RSS measured on noisy photo-like images (the densest trees): about 280
/// bytes per pixel at quality 5, 360 at 75 and 510 at 100. The whole image keeps its
/// coded streams (at most 2 bytes per pixel) and its key points, which [`encode`] adds
/// at [`KEY_POINT_BYTES`] each once it knows the smallest cell. The file is then
/// decoded again for the restoration fit: its detail layer holds at most a 4-byte level
/// per coefficient (13 bytes per pixel with the blocks' bookkeeping), its key points as
/// many again, and the rows the fit samples their decoded planes and the restored
/// copies the deringing is chosen on (28 bytes per sampled pixel, the rows around them
/// included).
pub fn encode_memory(width: u32, height: u32, quality: f32) -> EncodeMemory {
    let q = f64::from(quality.clamp(0.0, 100.0)) / 100.0;
    let per_pixel = (300.0 + 240.0 * q * q).ceil() as u64;
    let tiling = tiling::Tiling::choose(width, height);
    let tile_pixels = (0..tiling.count())
        .map(|i| {
            let r = tiling.rect(i);
            r.width as u64 * r.height as u64
        })
        .max()
        .unwrap_or(0);
    EncodeMemory {
        fixed: caoen_base::budget::bytes(width.into(), height.into(), 2).saturating_add(16 << 20),
        per_tile: caoen_base::budget::bytes(tile_pixels, 1, per_pixel),
        tiles: tiling.count() as u64,
        after: caoen_base::budget::bytes(width.into(), height.into(), 13).saturating_add(
            caoen_base::budget::bytes(encoder::restoration_fit_pixels(width, height), 1, 28),
        ),
    }
}
