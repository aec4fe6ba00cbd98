//! Texture transfer between surfaces sharing a domain (design section 9, "Texture
//! mapping"): a texture laid on surface A through A's domain parameterisation
//! (equirectangular `(theta / 2pi, phi / pi)` on the sphere, `(t, f) / 2pi` on the
//! torus) appears on B at the corresponding domain points, since B maps the same
//! domain point `x` to its own surface point `B(x)`.
//!
//! [`transfer`] resamples A's texture onto B's texture grid: for every texel of B, the
//! domain point it stands for, and A's texture at that domain point. With the same
//! domain and parameterisation this is an identity resampling (exact at equal sizes);
//! it is written through domain points so a model whose texture coordinates differ
//! from its domain's (the planned `--texture-space` network) slots in.

use rayon::prelude::*;

use super::TextureError;
use crate::render::framebuffer::RgbImage;
use crate::render::texture::{domain_uv, Texture, Wrap};
use crate::surface::{Domain, SurfaceModel};

/// The domain point of texture coordinates `(u, v)` (the inverse of
/// [`domain_uv`]), if the domain has texture coordinates.
pub fn uv_domain(domain: &Domain, uv: [f64; 2]) -> Option<Vec<f64>> {
    use std::f64::consts::{PI, TAU};
    match domain {
        Domain::Sphere { dim: 3 } => {
            let (theta, phi) = (uv[0] * TAU, uv[1] * PI);
            Some(vec![
                phi.sin() * theta.cos(),
                phi.sin() * theta.sin(),
                phi.cos(),
            ])
        }
        Domain::Torus => {
            let (t, f) = (uv[0] * TAU, uv[1] * TAU);
            let s = std::f64::consts::FRAC_1_SQRT_2;
            Some(vec![s * t.cos(), s * t.sin(), s * f.cos(), s * f.sin()])
        }
        _ => None,
    }
}

/// Carries `texture`, laid on `from`, onto `to`'s texture grid of `width x height`
/// texels (linear light). The models must share their domain.
pub fn transfer(
    from: &SurfaceModel,
    to: &SurfaceModel,
    texture: &Texture,
    width: u32,
    height: u32,
) -> Result<RgbImage, TextureError> {
    if from.domain != to.domain {
        return Err(TextureError::Invalid(format!(
            "the surfaces do not share a domain ({:?} vs {:?}); transfer goes through \
             corresponding domain points",
            from.domain, to.domain
        )));
    }
    let wrap = Wrap::of(&from.domain).ok_or_else(|| {
        TextureError::Invalid(format!(
            "domain {:?} has no texture coordinates (sphere S^2 and torus do)",
            from.domain
        ))
    })?;
    if width == 0 || height == 0 || width as u64 * height as u64 > 1 << 26 {
        return Err(TextureError::Invalid(format!(
            "texture size {width}x{height}"
        )));
    }
    let pixels: Vec<[f32; 3]> = (0..height)
        .into_par_iter()
        .flat_map_iter(|j| {
            (0..width).map(move |i| {
                let uv = [
                    (i as f64 + 0.5) / width as f64,
                    (j as f64 + 0.5) / height as f64,
                ];
                let x = uv_domain(&to.domain, uv).expect("checked domain");
                let src = domain_uv(&from.domain, &x).expect("checked domain");
                texture.sample(src, wrap)
            })
        })
        .collect();
    Ok(RgbImage {
        width,
        height,
        pixels,
    })
}

/// A procedural solid (3-D) texture: a checkerboard of cubes of side `cell` in the
/// two [`super::solid::DEFAULT_COLOURS`] (`Solid::Checker`; kept for callers).
pub fn solid_checker(p: [f64; 3], cell: f64) -> [f32; 3] {
    super::solid::Solid::Checker {
        scale: cell,
        colours: super::solid::DEFAULT_COLOURS,
    }
    .sample(p)
}

/// The second method of the paper: `space` maps the shared domain into a 3-D texture
/// space; the solid texture `solid` sampled at `space(x)` is baked onto `to`'s texture
/// grid (`width x height` texels), so it is carried onto the shape wherever `to` puts
/// the domain point `x`.
pub fn bake_texture_space(
    space: &SurfaceModel,
    to: &SurfaceModel,
    solid: &(dyn Fn([f64; 3]) -> [f32; 3] + Sync),
    width: u32,
    height: u32,
) -> Result<RgbImage, TextureError> {
    if space.domain != to.domain {
        return Err(TextureError::Invalid(format!(
            "the texture-space network's domain {:?} is not the surface's {:?}",
            space.domain, to.domain
        )));
    }
    if space.network.output_dim() < 3 {
        return Err(TextureError::Invalid(
            "the texture-space network must output 3-D points".into(),
        ));
    }
    if Wrap::of(&to.domain).is_none() {
        return Err(TextureError::Invalid(format!(
            "domain {:?} has no texture coordinates",
            to.domain
        )));
    }
    if width == 0 || height == 0 || width as u64 * height as u64 > 1 << 26 {
        return Err(TextureError::Invalid(format!(
            "texture size {width}x{height}"
        )));
    }
    let mut domain = Vec::with_capacity(width as usize * height as usize * 4);
    for j in 0..height {
        for i in 0..width {
            let uv = [
                (i as f64 + 0.5) / width as f64,
                (j as f64 + 0.5) / height as f64,
            ];
            domain.extend(uv_domain(&to.domain, uv).expect("checked domain"));
        }
    }
    let p = space.network.output_dim();
    let t = space.network.eval_batch(&domain)?;
    let pixels = t
        .par_chunks_exact(p)
        .map(|y| solid([y[0], y[1], y[2]]))
        .collect();
    Ok(RgbImage {
        width,
        height,
        pixels,
    })
}
