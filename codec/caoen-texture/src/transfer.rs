//! Texture transfer between surfaces sharing a domain (paper section 9, "Texture
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

use super::projected::Projected;
use super::TextureError;
use caoen_render::framebuffer::RgbImage;
use caoen_render::texture::{domain_uv, Texture, Wrap};
use caoen_surface::{Domain, SurfaceModel};

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

/// Most texels a texture grid may have (2^26).
pub const MAX_TEXELS: u64 = 1 << 26;

fn check_texture_size(width: u32, height: u32) -> Result<(), TextureError> {
    if width == 0 || height == 0 || u64::from(width) * u64::from(height) > MAX_TEXELS {
        return Err(TextureError::TextureSize {
            width,
            height,
            max: MAX_TEXELS,
        });
    }
    Ok(())
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
        return Err(TextureError::DomainMismatch {
            from: from.domain,
            to: to.domain,
        });
    }
    let wrap = Wrap::of(&from.domain).ok_or(TextureError::NoTextureCoordinates {
        domain: from.domain,
    })?;
    check_texture_size(width, height)?;
    // A texel of the new grid spans this many texels of the texture (both grids cover
    // the whole domain), so a smaller grid reads a coarser pyramid level.
    let footprint = (f64::from(texture.image().width) / f64::from(width))
        .max(f64::from(texture.image().height) / f64::from(height));
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
                texture.sample_filtered(src, footprint, wrap)
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
/// two [`super::solid::DEFAULT_COLOURS`] (`Pattern::Checker`; kept for callers).
pub fn solid_checker(p: [f64; 3], cell: f64) -> [f32; 3] {
    super::solid::Solid::Procedural {
        pattern: super::solid::Pattern::Checker,
        scale: cell,
        colours: super::solid::DEFAULT_COLOURS,
    }
    .sample(p)
}

/// Peak memory of baking a `width x height` texture and using it: per texel the
/// linear-light image, its PNG and the texture loaded back with its mip pyramid.
pub fn bake_memory(width: u32, height: u32) -> u64 {
    caoen_base::budget::bytes(u64::from(width), u64::from(height), 12 + 3 + 16)
}

/// What a bake lays on a surface's texture grid.
pub enum BakeSource<'a> {
    /// The second method of the paper: `space` maps the shared domain into a 3-D
    /// texture space, and the solid texture `solid` sampled at `space(x)` is carried
    /// onto the shape wherever it puts the domain point `x`.
    Solid {
        /// The texture-space model.
        space: &'a SurfaceModel,
        /// The solid texture.
        solid: &'a (dyn Fn([f64; 3]) -> [f32; 3] + Sync),
    },
    /// A picture laid on surface `from` in its own space (`picture`, projected onto
    /// `from`'s points) pulled back to the shared domain. Each lookup reads the picture
    /// at the pyramid level of the distance between neighbouring points in picture
    /// texels, so a picture larger than the grid is averaged, not point-sampled.
    Projected {
        /// The surface the picture is laid on.
        from: &'a SurfaceModel,
        /// The picture.
        picture: &'a Projected,
    },
}

/// [`BakeSource::Solid`] baked onto `to`'s texture grid of `width x height` texels,
/// `samples x samples` points per texel (see [`bake`]).
pub fn bake_texture_space(
    space: &SurfaceModel,
    to: &SurfaceModel,
    solid: &(dyn Fn([f64; 3]) -> [f32; 3] + Sync),
    width: u32,
    height: u32,
    samples: u32,
) -> Result<RgbImage, TextureError> {
    let source = BakeSource::Solid { space, solid };
    bake(&source, to, width, height, samples, &|_, _| {})
}

/// `source` baked onto `to`'s texture grid (`width x height` texels), reporting
/// `(rows done, rows)` as it goes. Each texel is the mean of `samples x samples` points
/// spread over it, so a sharp edge of the source is an antialiased edge in the bake.
pub fn bake(
    source: &BakeSource<'_>,
    to: &SurfaceModel,
    width: u32,
    height: u32,
    samples: u32,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<RgbImage, TextureError> {
    match *source {
        BakeSource::Solid { space, solid } => {
            let colour =
                |points: &[[f64; 3]], _: usize| points.par_iter().map(|p| solid(*p)).collect();
            bake_grid(space, to, width, height, samples, &colour, progress)
        }
        BakeSource::Projected { from, picture } => {
            let colour = projected_colours(picture);
            bake_grid(from, to, width, height, samples, &colour, progress)
        }
    }
}

/// The colours of [`BakeSource::Projected`] for a band of rows.
fn projected_colours(
    picture: &Projected,
) -> impl Fn(&[[f64; 3]], usize) -> Vec<[f32; 3]> + Sync + '_ {
    let (pw, ph) = picture.picture_size();
    let (pw, ph) = (f64::from(pw), f64::from(ph));
    move |points: &[[f64; 3]], grid_width: usize| -> Vec<[f32; 3]> {
        let uv: Vec<[f64; 2]> = points.par_iter().map(|p| picture.uv(*p)).collect();
        let rows = points.len() / grid_width;
        (0..points.len())
            .into_par_iter()
            .map(|i| {
                let (x, y) = (i % grid_width, i / grid_width);
                // Texels between this point and a neighbour, the angle's way round.
                let texels = |j: usize| {
                    let du = uv[j][0] - uv[i][0];
                    let du = du - du.round();
                    (du * pw).hypot((uv[j][1] - uv[i][1]) * ph)
                };
                let step = |a: Option<usize>, b: Option<usize>| match (a, b) {
                    (Some(a), Some(b)) => texels(a).min(texels(b)),
                    (Some(a), None) | (None, Some(a)) => texels(a),
                    (None, None) => 0.0,
                };
                let fx = step(
                    (x > 0).then(|| i - 1),
                    (x + 1 < grid_width).then_some(i + 1),
                );
                let fy = step(
                    (y > 0).then(|| i - grid_width),
                    (y + 1 < rows).then_some(i + grid_width),
                );
                picture.sample(points[i], fx.max(fy))
            })
            .collect()
    }
}

/// Colours the 3-D points of a band of rows (a row-major grid of the given width).
type BandColours<'a> = dyn Fn(&[[f64; 3]], usize) -> Vec<[f32; 3]> + Sync + 'a;

/// The shared part of the bakes: `to`'s texture grid, `samples x samples` domain points
/// per texel mapped through `space`, coloured by `colour` (given the 3-D points of a
/// band of rows as a row-major grid and the grid's width), and averaged per texel.
fn bake_grid(
    space: &SurfaceModel,
    to: &SurfaceModel,
    width: u32,
    height: u32,
    samples: u32,
    colour: &BandColours<'_>,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<RgbImage, TextureError> {
    if space.domain != to.domain {
        return Err(TextureError::SpaceDomainMismatch {
            space: space.domain,
            surface: to.domain,
        });
    }
    if space.network.output_dim() < 3 {
        return Err(TextureError::SpaceNotPositions {
            components: space.network.output_dim(),
        });
    }
    if Wrap::of(&to.domain).is_none() {
        return Err(TextureError::NoTextureCoordinates { domain: to.domain });
    }
    check_texture_size(width, height)?;
    if !(1..=MAX_BAKE_SAMPLES).contains(&samples) {
        return Err(TextureError::Count {
            what: "bake samples",
            value: samples.into(),
            min: 1,
            max: MAX_BAKE_SAMPLES.into(),
        });
    }
    let (w, s) = (width as usize, samples as usize);
    let grid_width = w * s;
    // Bands of whole texel rows, about 2^18 points each: big enough for the network's
    // parallel batches, small enough that the points of a band stay a few megabytes.
    let band = ((1usize << 18) / (grid_width * s)).max(1);
    let p = space.network.output_dim();
    let m = space.network.input_dim();
    let mut pixels = Vec::with_capacity(w * height as usize);
    let norm = 1.0 / (s * s) as f32;
    for j0 in (0..height as usize).step_by(band) {
        let j1 = (j0 + band).min(height as usize);
        let rows = (j1 - j0) * s;
        let mut domain = Vec::with_capacity(rows * grid_width * m);
        for sy in 0..rows {
            for sx in 0..grid_width {
                let uv = [
                    (sx as f64 + 0.5) / grid_width as f64,
                    ((j0 * s + sy) as f64 + 0.5) / (height as usize * s) as f64,
                ];
                domain.extend(uv_domain(&to.domain, uv).expect("checked domain"));
            }
        }
        let points: Vec<[f64; 3]> = space
            .network
            .eval_batch(&domain)?
            .chunks_exact(p)
            .map(|y| [y[0], y[1], y[2]])
            .collect();
        let colours = colour(&points, grid_width);
        for j in 0..j1 - j0 {
            for i in 0..w {
                let mut sum = [0.0f32; 3];
                for sy in 0..s {
                    for sx in 0..s {
                        let c = colours[(j * s + sy) * grid_width + i * s + sx];
                        for k in 0..3 {
                            sum[k] += c[k];
                        }
                    }
                }
                pixels.push(sum.map(|v| v * norm));
            }
        }
        progress(j1 as u64, u64::from(height));
    }
    Ok(RgbImage {
        width,
        height,
        pixels,
    })
}

/// Most points per texel side a bake takes (64 per texel).
pub const MAX_BAKE_SAMPLES: u32 = 8;
