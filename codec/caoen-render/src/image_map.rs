//! Image maps on solids by projection, as POV-Ray's `image_map { map_type 0|1|2 }`.
//!
//! The projection is POV-Ray's (3.7, `imageutil.cpp`) applied to the point as
//! `export-pov` writes it, POV-Ray `<x, y, z>` = caoen `(x, z, y)`: caoen's z is the
//! image's up. Planar covers x and z in [0, 1], projected along y; spherical takes
//! longitude about the z axis (0 on +x, rising towards +y) and latitude from the
//! equator; cylindrical the same longitude with z as the height. Every map repeats
//! both ways, and the image's top row is at the top (POV-Ray stores images upside
//! down and flips them back).

use std::f64::consts::{PI, TAU};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::Arc;

use caoen_geometry::transform::Affine;

use super::cae_texture::CaeSource;
use super::texture::{Texture, Wrap};

/// How an image is projected onto a solid (POV-Ray's `map_type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapType {
    /// `map_type 0`: x and z (up) in [0, 1], along y.
    Planar,
    /// `map_type 1`: longitude and latitude about the z axis.
    Spherical,
    /// `map_type 2`: longitude about the z axis, height z in [0, 1].
    Cylindrical,
}

impl MapType {
    /// The map type of POV-Ray's number or caoen's name, if it is one of the three.
    pub fn parse(v: &serde_json::Value) -> Option<MapType> {
        match (v.as_u64(), v.as_str()) {
            (Some(0), _) | (_, Some("planar")) => Some(MapType::Planar),
            (Some(1), _) | (_, Some("spherical")) => Some(MapType::Spherical),
            (Some(2), _) | (_, Some("cylindrical")) => Some(MapType::Cylindrical),
            _ => None,
        }
    }

    /// POV-Ray's `map_type` number.
    pub fn pov(self) -> u32 {
        match self {
            MapType::Planar => 0,
            MapType::Spherical => 1,
            MapType::Cylindrical => 2,
        }
    }
}

/// An image projected onto a solid in world space, with its texture transform.
#[derive(Debug, Clone)]
pub struct ImageMap {
    /// The image in linear light.
    pub texture: Arc<Texture>,
    /// The image file, for `export-pov`.
    pub file: PathBuf,
    /// The projection.
    pub map: MapType,
    /// Bilinear interpolation (POV-Ray's `interpolate 2`), else the nearest texel.
    pub bilinear: bool,
    /// The texture transform (scale, then rotate, then translate) from pattern space to
    /// the world; must be invertible.
    pub transform: Affine,
    /// The `.cae` file the image was decoded from, which a render decodes again at
    /// the size its footprint asks for (`cae_texture`); None for other images.
    pub cae: Option<Arc<CaeSource>>,
    /// World to pattern space.
    to_pattern: Affine,
}

impl ImageMap {
    /// An image map; None if `transform` is singular.
    pub fn new(
        texture: Arc<Texture>,
        file: PathBuf,
        map: MapType,
        bilinear: bool,
        transform: Affine,
    ) -> Option<ImageMap> {
        if !(transform.det().abs() > 1e-300) {
            return None;
        }
        Some(ImageMap {
            texture,
            file,
            map,
            bilinear,
            to_pattern: transform.inverse()?,
            transform,
            cae: None,
        })
    }

    /// Image coordinates `(u, v)` (v down, one period per unit) of world point `p`;
    /// None where the projection has no direction (the centre of a spherical map).
    pub fn uv(&self, p: [f64; 3]) -> Option<[f64; 2]> {
        let q = self.to_pattern.point(p);
        // POV-Ray's axes: x, y (up) = caoen z, z = caoen y.
        let (x, y, z) = (q[0], q[2], q[1]);
        let longitude = || {
            let len = x.hypot(z);
            if len == 0.0 {
                0.0
            } else {
                let theta = (x / len).clamp(-1.0, 1.0).acos();
                (if z < 0.0 { TAU - theta } else { theta }) / TAU
            }
        };
        let (u, up) = match self.map {
            MapType::Planar => (x, y),
            MapType::Spherical => {
                let len = (x * x + y * y + z * z).sqrt();
                if !(len > 0.0) {
                    return None;
                }
                (longitude(), 0.5 + (y / len).clamp(-1.0, 1.0).asin() / PI)
            }
            MapType::Cylindrical => {
                if x == 0.0 && z == 0.0 {
                    return None;
                }
                (longitude(), y)
            }
        };
        let (u, v) = (u.rem_euclid(1.0), (-up).rem_euclid(1.0));
        (u.is_finite() && v.is_finite()).then_some([u, v])
    }

    /// The image's colour (linear) at world point `p`; white where the projection has
    /// no direction (POV-Ray's colour off the map is clear over white).
    pub fn colour(&self, p: [f64; 3]) -> [f32; 3] {
        let Some(uv) = self.uv(p) else {
            return [1.0; 3];
        };
        if self.bilinear {
            self.texture.sample(uv, Wrap::Torus)
        } else {
            let img = self.texture.image();
            let (w, h) = (img.width as usize, img.height as usize);
            let i = ((uv[0] * w as f64) as usize).min(w - 1);
            let j = ((uv[1] * h as f64) as usize).min(h - 1);
            img.pixels[j * w + i]
        }
    }

    /// POV-Ray's pigment for this map: `image_map` with the texture transform as a
    /// matrix in POV-Ray's axes, `transmit all` for a transmitting material.
    pub fn pov_pigment(&self, transmit: f32) -> String {
        let file = self.file.display().to_string();
        let mut out = format!(
            "pigment {{ image_map {{ {} \"{}\" map_type {}{}",
            pov_format(&self.file),
            file.replace('\\', "/"),
            self.map.pov(),
            if self.bilinear { " interpolate 2" } else { "" }
        );
        if transmit > 0.0 {
            let _ = write!(out, " transmit all {transmit}");
        }
        out.push_str(" }");
        out.push_str(&pov_matrix(&self.transform));
        out.push_str(" }");
        out
    }
}

/// A texture transform as POV-Ray's ` matrix <...>`: the same map with y and z
/// swapped on both sides; nothing for the identity.
pub(crate) fn pov_matrix(t: &Affine) -> String {
    if t.is_identity() {
        return String::new();
    }
    let s = [0, 2, 1];
    let mut cols = Vec::with_capacity(12);
    for c in 0..3 {
        for r in 0..3 {
            cols.push(caoen_frep::pov::num(t.m[s[r]][s[c]]));
        }
    }
    for k in s {
        cols.push(caoen_frep::pov::num(t.t[k]));
    }
    format!(" matrix <{}>", cols.join(", "))
}

/// POV-Ray's image format keyword of `file` by its extension (PNG otherwise).
pub(crate) fn pov_format(file: &std::path::Path) -> &'static str {
    let ext = file
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "jpg" | "jpeg" => "jpeg",
        "ppm" | "pgm" | "pnm" => "ppm",
        "tga" => "tga",
        "gif" => "gif",
        "tif" | "tiff" => "tiff",
        "hdr" => "hdr",
        "exr" => "exr",
        "bmp" => "sys",
        _ => "png",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::framebuffer::RgbImage;
    use caoen_base::budget::Limits;

    fn map(kind: MapType, transform: Affine) -> ImageMap {
        let pixels = (0..8).map(|i| [i as f32 / 8.0, 0.0, 0.0]).collect();
        let img = RgbImage {
            width: 4,
            height: 2,
            pixels,
        };
        let tex = Arc::new(Texture::new(img, &Limits::default()).unwrap());
        ImageMap::new(tex, "t.png".into(), kind, true, transform).unwrap()
    }

    #[test]
    fn projections_follow_pov_ray() {
        let id = Affine::IDENTITY;
        // Planar: x across, z up (v down), repeated.
        let p = map(MapType::Planar, id);
        let uv = p.uv([0.25, 7.0, 0.75]).unwrap();
        assert!((uv[0] - 0.25).abs() < 1e-12 && (uv[1] - 0.25).abs() < 1e-12);
        let uv = p.uv([1.25, 0.0, -0.25]).unwrap();
        assert!((uv[0] - 0.25).abs() < 1e-12 && (uv[1] - 0.25).abs() < 1e-12);
        // Spherical: +x is longitude 0, +y (POV-Ray's +z) a quarter turn, top row at +z.
        let s = map(MapType::Spherical, id);
        assert_eq!(s.uv([0.0, 2.0, 0.0]).unwrap(), [0.25, 0.5]);
        assert!(s.uv([0.0, 0.0, 3.0]).unwrap()[1].abs() < 1e-12);
        assert!(s.uv([0.0; 3]).is_none());
        // Cylindrical: height z, the same longitude.
        let c = map(MapType::Cylindrical, id);
        let uv = c.uv([-1.0, 0.0, 0.25]).unwrap();
        assert!((uv[0] - 0.5).abs() < 1e-12 && (uv[1] - 0.75).abs() < 1e-12);
        // A texture transform moves the pattern with it.
        let t = map(
            MapType::Planar,
            Affine::from_parts([2.0; 3], [0.0; 3], [1.0, 0.0, 0.0]),
        );
        let uv = t.uv([1.5, 0.0, 0.5]).unwrap();
        assert!((uv[0] - 0.25).abs() < 1e-12 && (uv[1] - 0.75).abs() < 1e-12);
        assert!(ImageMap::new(
            p.texture.clone(),
            "t.png".into(),
            MapType::Planar,
            true,
            Affine::from_parts([0.0; 3], [0.0; 3], [0.0; 3])
        )
        .is_none());
    }

    #[test]
    fn pov_pigment_swaps_axes() {
        let t = map(
            MapType::Spherical,
            Affine::from_parts([1.0, 2.0, 3.0], [0.0; 3], [4.0, 5.0, 6.0]),
        );
        assert_eq!(
            t.pov_pigment(0.0),
            "pigment { image_map { png \"t.png\" map_type 1 interpolate 2 } matrix <1.0, 0.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0, 2.0, 4.0, 6.0, 5.0> }"
        );
    }
}
