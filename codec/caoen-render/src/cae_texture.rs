//! A `.cae` file as a resolution-free texture (an image map or a surface's domain
//! texture): the file is decoded anew for each render at the size its finest footprint
//! asks for, so a close-up shows the codec's continuous image instead of enlarged
//! texels.
//!
//! The size comes from the camera and the object's box: the nearest point of the box
//! along the view sets the smallest world distance one sample spans, and the map's
//! projection says how much world one period of the image covers (the transform's
//! axes for a planar map, the longitude's full circle at the box's farthest point for
//! the others, the circumference of the box's bounding sphere for a domain texture).
//! The image is decoded so that a texel is no larger than that sample, at most
//! [`MAX_TEXTURE_SIDE`] a side, and halved until the decode, the texture and the
//! render's own buffers fit what the memory budget leaves; that estimate is checked
//! before anything is allocated. The result depends on the scene, the camera and the
//! budget only.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use caoen_base::budget::Limits;
use caoen_decoder::bitstream::Header;
use caoen_decoder::DecodeOptions;

use super::camera::{Camera, Projection};
use super::error::{RenderError, Result};
use super::framebuffer::RgbImage;
use super::image_map::{ImageMap, MapType};
use super::scene::{Scene, Shape};
use super::texture::Texture;

/// Largest side of a `.cae` texture decoded for a render.
pub const MAX_TEXTURE_SIDE: u32 = 8192;

/// Bytes per texel the texture holds besides the decode: the 8-bit colours read from
/// the raster (12) and the texture with its pyramid (16).
const TEXTURE_BYTES: u64 = 28;

/// Whether `path` names a `.cae` file (by its extension).
pub fn is_cae(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("cae"))
}

/// A `.cae` file held for decoding at any size: its bytes (counted in the budget while
/// held) and its header.
#[derive(Debug)]
pub struct CaeSource {
    bytes: Vec<u8>,
    header: Header,
    file: PathBuf,
    _held: caoen_base::budget::Reservation,
}

impl CaeSource {
    /// Reads and checks the `.cae` file `path` within `limits` (a damaged file is
    /// refused here, naming it).
    pub fn load(path: &Path, limits: &Limits) -> Result<CaeSource> {
        let bytes = limits.read(path).map_err(|e| RenderError::io(path, e))?;
        let held = limits.reserve(
            || format!("the .cae texture {}", path.display()),
            bytes.len() as u64,
        )?;
        let header = caoen_decoder::inspect(&bytes)
            .map_err(|e| damaged(path, &e))?
            .header;
        Ok(CaeSource {
            bytes,
            header,
            file: path.to_path_buf(),
            _held: held,
        })
    }

    /// The image's own size.
    pub fn size(&self) -> (u32, u32) {
        self.header.display_size()
    }

    /// The memory a texture of `size` takes while it is made: the decode's estimate
    /// and the texture it becomes.
    pub fn memory(&self, size: (u32, u32)) -> u64 {
        caoen_decoder::decoder::decode_memory(&self.header, size, None, 4).saturating_add(
            caoen_base::budget::bytes(size.0.into(), size.1.into(), TEXTURE_BYTES),
        )
    }

    /// The image decoded at `size` as a texture, within `limits` (checked before the
    /// decode allocates, with `beside` bytes the caller will need after it).
    pub fn texture(&self, size: (u32, u32), beside: u64, limits: &Limits) -> Result<Texture> {
        limits.check(
            || {
                format!(
                    "decoding the .cae texture {} at {}x{}",
                    self.file.display(),
                    size.0,
                    size.1
                )
            },
            self.memory(size).saturating_add(beside),
        )?;
        let opts = DecodeOptions {
            size: Some(size),
            limits: limits.clone(),
            ..DecodeOptions::default()
        };
        let raster =
            caoen_decoder::decode(&self.bytes, &opts).map_err(|e| damaged(&self.file, &e))?;
        let img = RgbImage::from_raster(&raster, limits)?;
        drop(raster);
        Texture::new(img, limits)
    }
}

/// The error of a `.cae` file that does not decode.
fn damaged(path: &Path, e: &caoen_decoder::CodecError) -> RenderError {
    RenderError::parameter(
        format!("texture {}", path.display()),
        format!("not a readable .cae file: {e}"),
    )
}

/// The world box `(lo, hi)` of an object (the scene's bounding sphere's box for a
/// surface).
fn object_box(scene: &Scene, shape: &Shape) -> Result<([f64; 3], [f64; 3])> {
    Ok(match shape {
        Shape::Field { bounds, .. } => (bounds.lo, bounds.hi),
        Shape::Solid { solids, csg } => {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for i in csg.solids() {
                let s = &solids[i as usize];
                let (c, r) = (s.centre(), s.bounding_radius());
                for k in 0..3 {
                    lo[k] = lo[k].min(c[k] - r);
                    hi[k] = hi[k].max(c[k] + r);
                }
            }
            (lo, hi)
        }
        Shape::Surface { .. } => {
            let (c, r) = scene.bounds()?;
            (c.map(|v| v - r), c.map(|v| v + r))
        }
    })
}

/// The world distance one sample of `camera` spans on a surface facing it in the
/// box `(lo, hi)`: at the box's nearest depth for a perspective camera (a small
/// fraction of the box where the eye is inside it).
fn finest_sample(camera: &Camera, (lo, hi): ([f64; 3], [f64; 3])) -> f64 {
    let per_row = |span: f64| span / f64::from(camera.height.max(1));
    match camera.projection {
        Projection::Orthographic { height } => per_row(height),
        Projection::Perspective { fov_y_deg } => {
            // The nearest depth of the box: each axis takes the end the forward
            // direction meets first.
            let mut depth = 0.0;
            for k in 0..3 {
                let f = camera.forward[k];
                let end = if f >= 0.0 { lo[k] } else { hi[k] };
                depth += (end - camera.eye[k]) * f;
            }
            let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
            let depth = depth.max(1e-3 * size).max(1e-9);
            per_row(2.0 * depth * (0.5 * fov_y_deg.to_radians()).tan())
        }
    }
}

/// The world length one period of an image map spans along its u and v, on an object
/// in the box `(lo, hi)`.
pub fn period_lengths(map: &ImageMap, (lo, hi): ([f64; 3], [f64; 3])) -> [f64; 2] {
    let axis = |c: usize| {
        let m = &map.transform.m;
        (m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]).sqrt()
    };
    // The farthest corner of the box from the map's centre: the longest circle of
    // longitude on the object.
    let o = map.transform.t;
    let mut reach: f64 = 0.0;
    for corner in 0..8 {
        let p = [0, 1, 2].map(|k| if corner >> k & 1 == 1 { hi[k] } else { lo[k] });
        reach = reach
            .max(((p[0] - o[0]).powi(2) + (p[1] - o[1]).powi(2) + (p[2] - o[2]).powi(2)).sqrt());
    }
    let tau = std::f64::consts::TAU;
    match map.map {
        MapType::Planar => [axis(0), axis(2)],
        MapType::Spherical => [tau * reach, 0.5 * tau * reach],
        MapType::Cylindrical => [tau * reach, axis(2)],
    }
}

/// The size to decode `source` at when one period of the image spans `[pu, pv]` of
/// the world on an object in `bbox` seen by `camera`, before the memory budget: texels
/// no larger than the finest sample, the image's aspect kept, at most
/// [`MAX_TEXTURE_SIDE`] a side.
pub fn footprint_size(
    source: &CaeSource,
    [pu, pv]: [f64; 2],
    bbox: ([f64; 3], [f64; 3]),
    camera: &Camera,
) -> (u32, u32) {
    let (w, h) = source.size();
    let sample = finest_sample(camera, bbox);
    let need = (pu / sample / f64::from(w)).max(pv / sample / f64::from(h));
    let cap = f64::from(MAX_TEXTURE_SIDE) / f64::from(w.max(h));
    let k = if need.is_finite() { need.min(cap) } else { cap };
    let side = |n: u32| ((f64::from(n) * k).ceil() as u32).clamp(1, MAX_TEXTURE_SIDE);
    (side(w), side(h))
}

/// Whether an object of `scene` has a `.cae` image map or domain texture.
pub fn has_cae(scene: &Scene) -> bool {
    scene.objects.iter().any(|o| {
        o.material.texture_cae.is_some()
            || o.material
                .image_map
                .as_ref()
                .is_some_and(|m| m.cae.is_some())
    })
}

/// `scene` with every `.cae` image map decoded for `camera` (at its own, supersampled
/// size), or None when it has none. Each size is halved until its decode, with
/// `beside` bytes the render needs after it, fits what `limits` leaves (down to the
/// image's own size or 64 a side, whichever is smaller; below that the budget's error
/// is returned).
pub fn with_footprint_textures(
    scene: &Scene,
    camera: &Camera,
    beside: u64,
    limits: &Limits,
) -> Result<Option<Scene>> {
    if !has_cae(scene) {
        return Ok(None);
    }
    let mut out = scene.clone();
    // Halves `size` until its decode and `beside` fit what the budget leaves, then decodes.
    let fit = |source: &CaeSource, mut size: (u32, u32)| {
        let own = source.size();
        let floor = (own.0.max(own.1)).min(64);
        let free = limits.max_memory.saturating_sub(limits.held());
        while source.memory(size).saturating_add(beside) > free && size.0.max(size.1) / 2 >= floor {
            size = ((size.0 / 2).max(1), (size.1 / 2).max(1));
        }
        source.texture(size, beside, limits)
    };
    for obj in &mut out.objects {
        let bbox = object_box(scene, &obj.shape)?;
        if let Some(map) = obj.material.image_map.clone() {
            if let Some(source) = map.cae.clone() {
                let size = footprint_size(&source, period_lengths(&map, bbox), bbox, camera);
                let mut m = (*map).clone();
                m.texture = Arc::new(fit(&source, size)?);
                obj.material.image_map = Some(Arc::new(m));
            }
        }
        if let (Some(source), Some((_, wrap))) = (
            obj.material.texture_cae.clone(),
            obj.material.texture.clone(),
        ) {
            // A domain texture spans the whole object both ways: at most the
            // circumference of the object's box's bounding sphere.
            let radius = 0.5
                * (0..3)
                    .map(|k| (bbox.1[k] - bbox.0[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
            let circle = std::f64::consts::TAU * radius;
            let size = footprint_size(&source, [circle, circle], bbox, camera);
            obj.material.texture = Some((Arc::new(fit(&source, size)?), wrap));
        }
    }
    Ok(Some(out))
}

/// A PNG written beside an exported `.pov` in place of a `.cae` image map.
#[derive(Debug)]
pub struct ExportedTexture {
    /// Where it goes (the `.pov`'s directory, named after it and the object).
    pub path: PathBuf,
    /// The PNG file's bytes.
    pub png: Vec<u8>,
    /// The size the `.cae` was decoded at.
    pub size: (u32, u32),
}

/// For POV-Ray, which cannot read `.cae`: `scene` with each `.cae` image map decoded
/// at the size a render by `camera` would use and named as a PNG beside `pov` (an
/// absolute path, `{stem}-texture-{object}.png`), and those PNGs; None when the scene
/// has no `.cae` image map.
pub fn export_textures(
    scene: &Scene,
    camera: &Camera,
    pov: &Path,
    limits: &Limits,
) -> Result<Option<(Scene, Vec<ExportedTexture>)>> {
    let Some(mut out) = with_footprint_textures(scene, camera, 0, limits)? else {
        return Ok(None);
    };
    let dir = match pov.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let dir = std::fs::canonicalize(&dir).map_err(|e| RenderError::io(&dir, e))?;
    let stem = pov
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let mut files = Vec::new();
    let mut exported = |name: String, tex: &Texture| -> Result<PathBuf> {
        let path = dir.join(name);
        if path.to_string_lossy().contains('"') {
            return Err(RenderError::parameter(
                "export",
                "a file name with `\"` cannot be written into a .pov",
            ));
        }
        let img = tex.image();
        files.push(ExportedTexture {
            path: path.clone(),
            png: img.encode_png()?,
            size: (img.width, img.height),
        });
        Ok(path)
    };
    for (i, obj) in out.objects.iter_mut().enumerate() {
        if let Some(map) = obj.material.image_map.clone().filter(|m| m.cae.is_some()) {
            let mut m = (*map).clone();
            m.file = exported(format!("{stem}-texture-{i}.png"), &m.texture)?;
            obj.material.image_map = Some(Arc::new(m));
        }
        if let (Some(_), Some((tex, wrap))) =
            (&obj.material.texture_cae, obj.material.texture.clone())
        {
            let path = exported(format!("{stem}-domain-texture-{i}.png"), &tex)?;
            let named = (*tex).clone().named(path);
            obj.material.texture = Some((Arc::new(named), wrap));
        }
    }
    Ok(Some((out, files)))
}
