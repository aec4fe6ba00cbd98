//! Per-pixel buffers: the nearest-surface record every method writes (the G-buffer),
//! linear-light colour images, and depth maps with their file encodings.

use std::io::Cursor;

use caoen_base::raster::ChannelLayout;
use caoen_io::PngCompression;
use palette::{LinSrgb, Srgb};

use super::error::{RenderError, Result};

/// JPEG quality of written pictures (high: renders have smooth gradients).
const JPEG_QUALITY: u8 = 92;

/// PNG compression of written pictures and depth maps: the `image` crate's default,
/// which the committed example pictures were written with.
const PNG_LEVEL: PngCompression = PngCompression::Fast;

fn png_error(e: caoen_io::ImageIoError) -> RenderError {
    RenderError::Encode {
        format: "PNG",
        source: Box::new(e),
    }
}

/// The file formats a picture is written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PictureFormat {
    /// PNG, lossless.
    Png,
    /// JPEG (baseline, quality 92).
    Jpeg,
}

impl PictureFormat {
    /// The extensions written, for messages.
    pub const EXTENSIONS: &'static str = ".png, .jpg or .jpeg";

    /// The format a file name's extension asks for (any case); the extension found
    /// (empty without one) when it names none.
    pub fn from_path(path: &std::path::Path) -> std::result::Result<Self, String> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        match ext.as_str() {
            "png" => Ok(PictureFormat::Png),
            "jpg" | "jpeg" => Ok(PictureFormat::Jpeg),
            _ => Err(ext),
        }
    }
}

/// The nearest surface seen through one (sub)pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Depth along the viewing direction.
    pub depth: f64,
    /// Unit surface normal (any orientation; shading turns it towards the viewer).
    pub normal: [f32; 3],
    /// Texture coordinates on the domain (NaN when the surface has none).
    pub uv: [f32; 2],
    /// Index of the scene object.
    pub object: u32,
}

/// A buffer of nearest hits, row-major; `None` where nothing was hit.
#[derive(Debug, Clone)]
pub struct GBuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// One entry per pixel.
    pub hits: Vec<Option<Hit>>,
}

impl GBuffer {
    /// An empty buffer.
    pub fn new(width: u32, height: u32) -> Self {
        GBuffer {
            width,
            height,
            hits: vec![None; width as usize * height as usize],
        }
    }

    /// Keeps `hit` at pixel index `i` if it is nearer than what is there. Ties keep the
    /// earlier hit, so a fixed drawing order gives a fixed image.
    #[inline]
    pub fn offer(&mut self, i: usize, hit: Hit) {
        match &self.hits[i] {
            Some(h) if h.depth <= hit.depth => {}
            _ => self.hits[i] = Some(hit),
        }
    }

    /// Depth-composites `other` (same size) into `self`.
    pub fn merge(&mut self, other: &GBuffer) {
        for (i, h) in other.hits.iter().enumerate() {
            if let Some(h) = h {
                self.offer(i, *h);
            }
        }
    }

    /// The depth map of this buffer, reduced by `n x n` blocks to the nearest depth.
    pub fn depth_map(&self, n: u32) -> DepthMap {
        let (w, h) = (self.width / n, self.height / n);
        let mut depth = vec![f64::INFINITY; w as usize * h as usize];
        for y in 0..h {
            for x in 0..w {
                let mut d = f64::INFINITY;
                for sy in 0..n {
                    for sx in 0..n {
                        let i = ((y * n + sy) * self.width + x * n + sx) as usize;
                        if let Some(hit) = &self.hits[i] {
                            d = d.min(hit.depth);
                        }
                    }
                }
                depth[(y * w + x) as usize] = d;
            }
        }
        DepthMap {
            width: w,
            height: h,
            depth,
        }
    }
}

/// A colour image in linear-light sRGB primaries.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major linear RGB.
    pub pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    /// An image filled with one linear colour.
    pub fn filled(width: u32, height: u32, colour: [f32; 3]) -> Self {
        RgbImage {
            width,
            height,
            pixels: vec![colour; width as usize * height as usize],
        }
    }

    /// Averages `n x n` blocks (a box filter in linear light: the supersampling resolve).
    pub fn downsample(&self, n: u32) -> RgbImage {
        if n <= 1 {
            return self.clone();
        }
        let (w, h) = (self.width / n, self.height / n);
        let inv = 1.0 / (n * n) as f32;
        let mut pixels = Vec::with_capacity(w as usize * h as usize);
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0.0f32; 3];
                for sy in 0..n {
                    let row = ((y * n + sy) * self.width + x * n) as usize;
                    for p in &self.pixels[row..row + n as usize] {
                        acc[0] += p[0];
                        acc[1] += p[1];
                        acc[2] += p[2];
                    }
                }
                pixels.push(acc.map(|v| v * inv));
            }
        }
        RgbImage {
            width: w,
            height: h,
            pixels,
        }
    }

    /// Copies `tile` into `self` with its top-left corner at `(x0, y0)` (clipped).
    pub fn blit(&mut self, tile: &RgbImage, x0: u32, y0: u32) {
        for y in 0..tile.height.min(self.height.saturating_sub(y0)) {
            for x in 0..tile.width.min(self.width.saturating_sub(x0)) {
                self.pixels[((y0 + y) * self.width + x0 + x) as usize] =
                    tile.pixels[(y * tile.width + x) as usize];
            }
        }
    }

    /// 8-bit sRGB bytes (gamma-encoded), RGBRGB...
    pub fn to_srgb8(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.pixels.len() * 3);
        for p in &self.pixels {
            out.extend_from_slice(&linear_to_srgb8(*p));
        }
        out
    }

    /// The image as a file of `format` (8-bit sRGB).
    pub fn encode(&self, format: PictureFormat) -> Result<Vec<u8>> {
        match format {
            PictureFormat::Png => self.encode_png(),
            PictureFormat::Jpeg => {
                let mut bytes = Vec::new();
                image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, JPEG_QUALITY)
                    .encode(
                        &self.to_srgb8(),
                        self.width,
                        self.height,
                        image::ExtendedColorType::Rgb8,
                    )
                    .map_err(|e| RenderError::Encode {
                        format: "JPEG",
                        source: Box::new(e),
                    })?;
                Ok(bytes)
            }
        }
    }

    /// The image as an 8-bit sRGB PNG file.
    pub fn encode_png(&self) -> Result<Vec<u8>> {
        let samples = self.to_srgb8();
        caoen_io::encode_png8(
            &samples,
            self.width,
            self.height,
            ChannelLayout::Rgb,
            PNG_LEVEL,
        )
        .map_err(png_error)
    }

    /// Bytes of a `width x height` image: three linear-light floats a pixel.
    pub fn memory(width: u32, height: u32) -> u64 {
        caoen_base::budget::bytes(u64::from(width), u64::from(height), 12)
    }

    /// Loads an image file into linear light through the checked loader (size limits
    /// and the memory budget before any pixel is decoded).
    pub fn load(path: &std::path::Path, limits: &caoen_base::budget::Limits) -> Result<RgbImage> {
        let loaded = caoen_io::load_with_limits(path, &caoen_io::LoadLimits::within(limits))?;
        Self::from_raster(&loaded, limits)
    }

    /// Decodes an image file's bytes into linear light, through the checked loader.
    pub fn decode(bytes: &[u8], limits: &caoen_base::budget::Limits) -> Result<RgbImage> {
        let loaded = caoen_io::load_from_memory(bytes, &caoen_io::LoadLimits::within(limits))?;
        Self::from_raster(&loaded, limits)
    }

    /// A raster's colours in linear light, taken at 8 bits: grey on all three
    /// channels, alpha dropped; within `limits`.
    pub fn from_raster(
        raster: &caoen_base::raster::Raster,
        limits: &caoen_base::budget::Limits,
    ) -> Result<RgbImage> {
        let n = raster.pixel_count();
        limits.check(
            || format!("a {}x{} texture", raster.width(), raster.height()),
            caoen_base::budget::bytes(n as u64, 12, 1),
        )?;
        let grey = raster.layout().colour_channels() == 1;
        let plane = |c: usize| raster.plane(if grey { 0 } else { c });
        let (r, g, b) = (plane(0), plane(1), plane(2));
        let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        let pixels = (0..n)
            .map(|i| srgb8_to_linear([byte(r[i]), byte(g[i]), byte(b[i])]))
            .collect();
        Ok(RgbImage {
            width: raster.width(),
            height: raster.height(),
            pixels,
        })
    }
}

/// One hit per pixel of a `width x height` camera, rows traced in parallel straight into
/// the buffer (no per-row copies, so a frame's hits cost their 40 bytes a sample once);
/// `hit(x, y, scratch)` traces one pixel with a per-row scratch value, and `progress`
/// hears of every finished row.
pub fn trace_rows<S: Default>(
    width: usize,
    height: usize,
    progress: &(dyn Fn(u64, u64) + Sync),
    hit: impl Fn(usize, usize, &mut S) -> Option<Hit> + Sync,
) -> Vec<Option<Hit>> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicU64, Ordering};
    let mut hits = vec![None; width * height];
    if width == 0 {
        return hits;
    }
    let done = AtomicU64::new(0);
    hits.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        let mut scratch = S::default();
        for (x, h) in row.iter_mut().enumerate() {
            *h = hit(x, y, &mut scratch);
        }
        progress(done.fetch_add(1, Ordering::Relaxed) + 1, height as u64);
    });
    hits
}

/// Linear RGB to gamma-encoded 8-bit sRGB (palette's transfer function), clamped.
pub fn linear_to_srgb8(p: [f32; 3]) -> [u8; 3] {
    let c = p.map(|v| {
        if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.0
        }
    });
    let s: Srgb<u8> = Srgb::from_linear(LinSrgb::new(c[0], c[1], c[2]));
    [s.red, s.green, s.blue]
}

/// Gamma-encoded 8-bit sRGB to linear RGB.
pub fn srgb8_to_linear(p: [u8; 3]) -> [f32; 3] {
    let l: LinSrgb<f32> = Srgb::new(p[0], p[1], p[2]).into_linear();
    [l.red, l.green, l.blue]
}

/// Gamma-encoded sRGB in [0, 1] (as scene files give colours) to linear RGB.
pub fn srgb_to_linear(p: [f64; 3]) -> [f32; 3] {
    let c = p.map(|v| v.clamp(0.0, 1.0) as f32);
    let l: LinSrgb<f32> = Srgb::new(c[0], c[1], c[2]).into_linear();
    [l.red, l.green, l.blue]
}

/// Depths along the viewing direction, row-major; infinity where nothing was hit.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// One depth per pixel.
    pub depth: Vec<f64>,
}

impl DepthMap {
    /// Smallest and largest finite depth, if any pixel is covered.
    pub fn range(&self) -> Option<(f64, f64)> {
        self.depth
            .iter()
            .filter(|d| d.is_finite())
            .fold(None, |acc, &d| match acc {
                None => Some((d, d)),
                Some((a, b)) => Some((a.min(d), b.max(d))),
            })
    }

    /// 16-bit grey levels: background 0, covered pixels 1..=65535 with the nearest depth
    /// brightest (65535) and the farthest darkest (1), linear in depth.
    pub fn to_u16(&self) -> Vec<u16> {
        let (lo, hi) = self.range().unwrap_or((0.0, 1.0));
        let span = (hi - lo).max(1e-300);
        self.depth
            .iter()
            .map(|&d| {
                if d.is_finite() {
                    1 + ((hi - d) / span * 65534.0).round().clamp(0.0, 65534.0) as u16
                } else {
                    0
                }
            })
            .collect()
    }

    /// The depth map as a 16-bit greyscale PNG (see [`DepthMap::to_u16`]).
    pub fn encode_png16(&self) -> Result<Vec<u8>> {
        let samples = self.to_u16();
        caoen_io::encode_png16(
            &samples,
            self.width,
            self.height,
            ChannelLayout::Grey,
            PNG_LEVEL,
        )
        .map_err(png_error)
    }

    /// The raw depths as a single-channel (`Z`, 32-bit float) OpenEXR file; background
    /// pixels hold +infinity.
    pub fn encode_exr(&self) -> Result<Vec<u8>> {
        use exr::prelude::*;
        let w = self.width as usize;
        let depth = &self.depth;
        let channels = SpecificChannels::build()
            .with_channel("Z")
            .with_pixel_fn(|pos: Vec2<usize>| (depth[pos.y() * w + pos.x()] as f32,));
        let img = Image::from_channels((w, self.height as usize), channels);
        let mut bytes = Cursor::new(Vec::new());
        img.write()
            .to_buffered(&mut bytes)
            .map_err(|e| RenderError::Encode {
                format: "OpenEXR",
                source: Box::new(e),
            })?;
        Ok(bytes.into_inner())
    }
}
