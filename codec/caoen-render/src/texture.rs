//! Textures on the domain (paper section 9): an image indexed by domain coordinates,
//! equirectangular `(theta / 2pi, phi / pi)` on the sphere and `(t / 2pi, f / 2pi)` on
//! the torus, so the map carries it onto the surface with no extra work.

use caoen_base::budget::Limits;
use std::path::Path;

use super::error::{RenderError, Result};
use super::framebuffer::RgbImage;
use caoen_surface::tessellate::sphere_uv;
use caoen_surface::Domain;

/// How texture coordinates behave outside [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// u wraps, v clamps (the sphere: v runs pole to pole).
    Sphere,
    /// Both wrap (the torus).
    Torus,
    /// Both clamp to the edge (a projected picture).
    Clamp,
}

impl Wrap {
    /// The wrap mode of a domain's texture coordinates, if it has any.
    pub fn of(domain: &Domain) -> Option<Wrap> {
        match domain {
            Domain::Sphere { dim: 3 } => Some(Wrap::Sphere),
            Domain::Torus => Some(Wrap::Torus),
            _ => None,
        }
    }
}

/// The texture coordinates `(u, v)` in [0, 1] of a domain point (image v down), if the
/// domain has them: the same convention as the mesh's corner texture coordinates.
pub fn domain_uv(domain: &Domain, x: &[f64]) -> Option<[f64; 2]> {
    use std::f64::consts::TAU;
    match domain {
        Domain::Sphere { dim: 3 } if x.len() >= 3 => Some(sphere_uv(x)),
        Domain::Torus if x.len() >= 4 => Some([
            x[1].atan2(x[0]).rem_euclid(TAU) / TAU,
            x[3].atan2(x[2]).rem_euclid(TAU) / TAU,
        ]),
        _ => None,
    }
}

/// A texture image in linear light with its mip pyramid: sampled bilinearly where one
/// texel covers at least a sample, trilinearly between pyramid levels where a sample
/// covers many texels (minification), so a far or oblique texture does not alias.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// Level 0 is the image; level `k + 1` halves each side of level `k` (rounding up).
    levels: Vec<RgbImage>,
    /// The memory budget's count of the levels while the texture lives (clones share
    /// the image's count).
    held: std::sync::Arc<caoen_base::budget::Reservation>,
    /// The image file it was loaded from (absolute where it can be), for `export-pov`.
    file: Option<std::path::PathBuf>,
}

/// One pyramid level from the level below: each texel the mean of (up to) 2x2 texels.
/// Odd sides repeat their last row or column, so every texel keeps a mean of its own
/// area and the level's texel centres stay at `(i + 0.5) / width`.
fn halve(img: &RgbImage) -> RgbImage {
    let (w, h) = (img.width.div_ceil(2), img.height.div_ceil(2));
    let (sw, sh) = (img.width as usize, img.height as usize);
    let mut pixels = Vec::with_capacity(w as usize * h as usize);
    for j in 0..h as usize {
        let (y0, y1) = (2 * j, (2 * j + 1).min(sh - 1));
        for i in 0..w as usize {
            let (x0, x1) = (2 * i, (2 * i + 1).min(sw - 1));
            let p = [
                img.pixels[y0 * sw + x0],
                img.pixels[y0 * sw + x1],
                img.pixels[y1 * sw + x0],
                img.pixels[y1 * sw + x1],
            ];
            pixels.push([0, 1, 2].map(|k| 0.25 * (p[0][k] + p[1][k] + p[2][k] + p[3][k])));
        }
    }
    RgbImage {
        width: w,
        height: h,
        pixels,
    }
}

/// Bilinear sample of one image at `(u, v)` (texel centres at `(i + 0.5) / width`).
fn bilinear(img: &RgbImage, uv: [f64; 2], wrap: Wrap) -> [f32; 3] {
    let (w, h) = (img.width as i64, img.height as i64);
    let x = uv[0] * w as f64 - 0.5;
    let y = uv[1] * h as f64 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
    // Reduced before the integer cast (periods on wrapping axes, the edge on clamped
    // ones): a huge finite coordinate must not saturate into an overflowing index.
    let (u_wraps, v_wraps) = match wrap {
        Wrap::Sphere => (true, false),
        Wrap::Torus => (true, true),
        Wrap::Clamp => (false, false),
    };
    let reduce = |t: f64, n: i64, wraps: bool| {
        if wraps {
            t.rem_euclid(n as f64) as i64
        } else {
            t.clamp(-1.0, n as f64) as i64
        }
    };
    let (x0, y0) = (reduce(x0, w, u_wraps), reduce(y0, h, v_wraps));
    let col = |i: i64| {
        if u_wraps {
            i.rem_euclid(w) as usize
        } else {
            i.clamp(0, w - 1) as usize
        }
    };
    let row = |j: i64| {
        if v_wraps {
            j.rem_euclid(h) as usize
        } else {
            j.clamp(0, h - 1) as usize
        }
    };
    let px = |i: i64, j: i64| img.pixels[row(j) * w as usize + col(i)];
    let (a, b, c, d) = (
        px(x0, y0),
        px(x0 + 1, y0),
        px(x0, y0 + 1),
        px(x0 + 1, y0 + 1),
    );
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let top = a[k] + (b[k] - a[k]) * fx;
        let bottom = c[k] + (d[k] - c[k]) * fx;
        out[k] = top + (bottom - top) * fy;
    }
    out
}

impl Texture {
    /// Wraps a linear-light image and builds its mip pyramid (a third more memory).
    pub fn new(image: RgbImage, limits: &Limits) -> Result<Self> {
        Texture::with_reservation(image, None, limits)
    }

    /// The budget held by a `width x height` texture: 12 bytes a texel, a third more for
    /// the pyramid, counted while it lives, so a scene's textures and everything else
    /// one command loads share one budget.
    fn reserve(
        width: u64,
        height: u64,
        limits: &Limits,
    ) -> Result<caoen_base::budget::Reservation> {
        Ok(limits.reserve(
            || format!("a {width}x{height} texture"),
            caoen_base::budget::bytes(width, height, 16),
        )?)
    }

    /// [`Texture::new`] with the budget already reserved (or reserved now).
    fn with_reservation(
        image: RgbImage,
        held: Option<caoen_base::budget::Reservation>,
        limits: &Limits,
    ) -> Result<Self> {
        if image.width == 0 || image.height == 0 {
            return Err(RenderError::parameter("texture", "image is empty"));
        }
        let held = match held {
            Some(h) => h,
            None => Texture::reserve(u64::from(image.width), u64::from(image.height), limits)?,
        };
        let mut levels = vec![image];
        loop {
            let top = levels.last().expect("level 0 exists");
            if top.width == 1 && top.height == 1 {
                break;
            }
            let next = halve(top);
            levels.push(next);
        }
        Ok(Texture {
            levels,
            held: std::sync::Arc::new(held),
            file: None,
        })
    }

    /// Loads an image file (any format the checked loader reads) within `limits`.
    pub fn load(path: &Path, limits: &Limits) -> Result<Self> {
        // Reserved from the header's size before decoding, so the decoder's own buffers
        // are checked against what the texture leaves of the budget, not beside it.
        let held = image::ImageReader::open(path)
            .ok()
            .and_then(|r| r.with_guessed_format().ok())
            .and_then(|r| r.into_dimensions().ok())
            .map(|(w, h)| Texture::reserve(u64::from(w), u64::from(h), limits))
            .transpose()?;
        let mut tex = Texture::with_reservation(RgbImage::load(path, limits)?, held, limits)?;
        // Absolute, so an exported `.pov` finds the image from any directory.
        tex.file = Some(std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()));
        Ok(tex)
    }

    /// The texture named as loaded from `file` (for `export-pov`, which names the file).
    pub fn named(mut self, file: std::path::PathBuf) -> Texture {
        self.file = Some(file);
        self
    }

    /// The image file the texture was loaded from; None for one made in memory.
    pub fn file(&self) -> Option<&Path> {
        self.file.as_deref()
    }

    /// The texture image.
    pub fn image(&self) -> &RgbImage {
        &self.levels[0]
    }

    /// Number of pyramid levels (level 0 is the image, the last is 1x1).
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Bilinear sample of the full-resolution image at `(u, v)` (texel centres at
    /// `(i + 0.5) / width`): the unfiltered lookup, for magnification and resampling
    /// at equal sizes.
    pub fn sample(&self, uv: [f64; 2], wrap: Wrap) -> [f32; 3] {
        if !(uv[0].is_finite() && uv[1].is_finite()) {
            return self.levels[0].pixels[0];
        }
        bilinear(&self.levels[0], uv, wrap)
    }

    /// Trilinear sample at `(u, v)` for a sample that spans `footprint` texels of the
    /// full-resolution image (the larger side of its footprint): level `log2(footprint)`
    /// of the pyramid, blended between the two nearest levels. A footprint of one texel
    /// or less is the bilinear [`Texture::sample`].
    pub fn sample_filtered(&self, uv: [f64; 2], footprint: f64, wrap: Wrap) -> [f32; 3] {
        if !(uv[0].is_finite() && uv[1].is_finite()) {
            return self.levels[0].pixels[0];
        }
        let top = (self.levels.len() - 1) as f64;
        let lod = if footprint > 1.0 {
            footprint.log2().min(top)
        } else {
            0.0
        };
        let lo = lod.floor();
        let t = (lod - lo) as f32;
        let a = bilinear(&self.levels[lo as usize], uv, wrap);
        if t == 0.0 {
            return a;
        }
        let b = bilinear(&self.levels[lo as usize + 1], uv, wrap);
        [0, 1, 2].map(|k| a[k] + t * (b[k] - a[k]))
    }

    /// A procedural test texture: a checkerboard of `cells_u x cells_v` cells in two
    /// colours, with a coloured band along v = 1/2 (the sphere's equator) so the
    /// orientation is visible. Colours are linear.
    pub fn checker(
        width: u32,
        height: u32,
        cells_u: u32,
        cells_v: u32,
        a: [f32; 3],
        b: [f32; 3],
        limits: &Limits,
    ) -> Result<Self> {
        if width == 0 || height == 0 || cells_u == 0 || cells_v == 0 {
            return Err(RenderError::parameter("checker texture", "empty size"));
        }
        let mut pixels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                let cu = x * cells_u / width;
                let cv = y * cells_v / height;
                let v = (y as f64 + 0.5) / height as f64;
                let p = if (v - 0.5).abs() < 0.02 {
                    [0.8, 0.05, 0.02]
                } else if (cu + cv).is_multiple_of(2) {
                    a
                } else {
                    b
                };
                pixels.push(p);
            }
        }
        Texture::new(
            RgbImage {
                width,
                height,
                pixels,
            },
            limits,
        )
    }
}
