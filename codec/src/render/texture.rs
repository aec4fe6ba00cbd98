//! Textures on the domain (paper section 9): an image indexed by domain coordinates,
//! equirectangular `(theta / 2pi, phi / pi)` on the sphere and `(t / 2pi, f / 2pi)` on
//! the torus, so the map carries it onto the surface with no extra work.

use std::path::Path;

use super::error::{RenderError, Result};
use super::framebuffer::RgbImage;
use super::mesh::sphere_uv;
use crate::surface::Domain;

/// How texture coordinates behave outside [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    /// u wraps, v clamps (the sphere: v runs pole to pole).
    Sphere,
    /// Both wrap (the torus).
    Torus,
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

/// A texture image in linear light, sampled bilinearly.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    image: RgbImage,
}

impl Texture {
    /// Wraps a linear-light image.
    pub fn new(image: RgbImage) -> Result<Self> {
        if image.width == 0 || image.height == 0 {
            return Err(RenderError::parameter("texture", "image is empty"));
        }
        Ok(Texture { image })
    }

    /// Loads a PNG or JPEG file; every error names the file (once).
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|e| RenderError::io(path, e))?;
        let image = RgbImage::decode(&bytes).map_err(|e| match e {
            RenderError::Io { message, .. } => RenderError::io(path, message),
            other => RenderError::io(path, other),
        })?;
        Texture::new(image).map_err(|e| RenderError::io(path, e))
    }

    /// The texture image.
    pub fn image(&self) -> &RgbImage {
        &self.image
    }

    /// Bilinear sample at `(u, v)` (texel centres at `(i + 0.5) / width`).
    pub fn sample(&self, uv: [f64; 2], wrap: Wrap) -> [f32; 3] {
        let (w, h) = (self.image.width as i64, self.image.height as i64);
        if !(uv[0].is_finite() && uv[1].is_finite()) {
            return self.image.pixels[0];
        }
        let x = uv[0] * w as f64 - 0.5;
        let y = uv[1] * h as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let col = |i: i64| i.rem_euclid(w) as usize;
        let row = |j: i64| match wrap {
            Wrap::Sphere => j.clamp(0, h - 1) as usize,
            Wrap::Torus => j.rem_euclid(h) as usize,
        };
        let px = |i: i64, j: i64| self.image.pixels[row(j) * w as usize + col(i)];
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
        Texture::new(RgbImage {
            width,
            height,
            pixels,
        })
    }
}
