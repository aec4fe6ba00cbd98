//! A picture placed on a surface in the surface's own 3-D space, the way a texture is
//! put on a real object: projected along an axis (planar), wrapped around an axis
//! (cylindrical) or around a centre (spherical), fitted to a box (the surface's
//! bounds). Sampled at a surface point it is a solid texture, so the texture-space
//! bake of [`super::transfer`] pulls it back to the shared domain and carries it to any
//! other surface on that domain.

use std::f64::consts::{PI, TAU};

use super::TextureError;
use caoen_render::texture::{Texture, Wrap};

/// How a picture is laid on 3-D space. Picture `u` runs left to right, `v` top to
/// bottom; the projection axis is z.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProjectionKind {
    /// Along z: `u` from x, `v` from y (top at the box's largest y), as a slide
    /// projector above the object.
    Planar,
    /// Around the z axis through the box centre: `u` the angle from +x
    /// counter-clockwise, `v` from z (top at the box's largest z).
    Cylindrical,
    /// Around the box centre: `u` the longitude, `v` the angle from +z (the same
    /// convention as the sphere domain's texture coordinates).
    Spherical,
}

impl ProjectionKind {
    /// The names `--project` accepts, in the order `--help` lists them.
    pub const NAMES: [&'static str; 3] = ["planar", "cylindrical", "spherical"];

    /// Parses one of [`Self::NAMES`].
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "planar" => Some(ProjectionKind::Planar),
            "cylindrical" => Some(ProjectionKind::Cylindrical),
            "spherical" => Some(ProjectionKind::Spherical),
            _ => None,
        }
    }

    /// How picture coordinates outside [0, 1] behave: the angle wraps, the rest clamps.
    fn wrap(self) -> Wrap {
        match self {
            ProjectionKind::Planar => Wrap::Clamp,
            ProjectionKind::Cylindrical | ProjectionKind::Spherical => Wrap::Sphere,
        }
    }
}

/// A picture projected onto the box `lo..hi` of 3-D space.
#[derive(Debug, Clone, PartialEq)]
pub struct Projected {
    picture: Texture,
    kind: ProjectionKind,
    lo: [f64; 3],
    hi: [f64; 3],
}

impl Projected {
    /// `picture` laid on the box `lo..hi` (finite, each side > 0) by `kind`.
    pub fn new(
        picture: Texture,
        kind: ProjectionKind,
        lo: [f64; 3],
        hi: [f64; 3],
    ) -> Result<Self, TextureError> {
        for k in 0..3 {
            if !(lo[k].is_finite() && hi[k].is_finite() && hi[k] - lo[k] > 0.0) {
                return Err(TextureError::BadBox {
                    what: "projection box",
                    lo,
                    hi,
                });
            }
        }
        Ok(Projected {
            picture,
            kind,
            lo,
            hi,
        })
    }

    /// The picture coordinates `(u, v)` of a 3-D point.
    pub fn uv(&self, p: [f64; 3]) -> [f64; 2] {
        let (lo, hi) = (self.lo, self.hi);
        let c = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
        match self.kind {
            ProjectionKind::Planar => [
                (p[0] - lo[0]) / (hi[0] - lo[0]),
                (hi[1] - p[1]) / (hi[1] - lo[1]),
            ],
            ProjectionKind::Cylindrical => [
                (p[1] - c[1]).atan2(p[0] - c[0]).rem_euclid(TAU) / TAU,
                (hi[2] - p[2]) / (hi[2] - lo[2]),
            ],
            ProjectionKind::Spherical => {
                let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
                let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let cos = if r > 0.0 { d[2] / r } else { 1.0 };
                [
                    d[1].atan2(d[0]).rem_euclid(TAU) / TAU,
                    cos.clamp(-1.0, 1.0).acos() / PI,
                ]
            }
        }
    }

    /// The picture's colour (linear light) at a 3-D point, for a lookup whose footprint
    /// spans `footprint` picture texels.
    pub fn sample(&self, p: [f64; 3], footprint: f64) -> [f32; 3] {
        self.picture
            .sample_filtered(self.uv(p), footprint, self.kind.wrap())
    }

    /// The picture's size in texels.
    pub fn picture_size(&self) -> (u32, u32) {
        (self.picture.image().width, self.picture.image().height)
    }
}

/// The bounding box of a surface (from its mesh at tessellation level 4), each side
/// widened to at least a millionth of the largest so a flat surface still has a box.
pub fn surface_box(
    model: &caoen_surface::SurfaceModel,
) -> Result<([f64; 3], [f64; 3]), TextureError> {
    use caoen_surface::tessellate::{tessellate, NormalMode};
    // A level-4 mesh (5,120 triangles) is a few hundred kilobytes: no limit of its own.
    let mesh = tessellate(
        model,
        4,
        NormalMode::Exact,
        &caoen_base::budget::Limits::default(),
    )?;
    let (mut lo, mut hi) = mesh.bounds();
    let largest = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if !(largest.is_finite() && largest > 0.0) {
        return Err(TextureError::NoExtent {
            surface: model.name.clone(),
            largest_side: largest,
        });
    }
    for k in 0..3 {
        let pad = (1e-6 * largest - (hi[k] - lo[k])).max(0.0) / 2.0;
        lo[k] -= pad;
        hi[k] += pad;
    }
    Ok((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;
    use caoen_render::framebuffer::RgbImage;

    fn ramp() -> Texture {
        // Red rises left to right, green top to bottom.
        let (w, h) = (8u32, 4u32);
        let pixels = (0..h)
            .flat_map(|j| {
                (0..w).map(move |i| {
                    [
                        (i as f32 + 0.5) / w as f32,
                        (j as f32 + 0.5) / h as f32,
                        0.0,
                    ]
                })
            })
            .collect();
        Texture::new(
            RgbImage {
                width: w,
                height: h,
                pixels,
            },
            &caoen_base::budget::Limits::default(),
        )
        .unwrap()
    }

    #[test]
    fn planar_maps_the_box_onto_the_picture() {
        let p = Projected::new(ramp(), ProjectionKind::Planar, [-1.0; 3], [1.0; 3]).unwrap();
        assert_eq!(p.uv([-1.0, 1.0, 0.3]), [0.0, 0.0]);
        assert_eq!(p.uv([1.0, -1.0, -0.7]), [1.0, 1.0]);
        // The centre texel of a 8x4 ramp is read back exactly at its centre.
        let c = p.sample([-1.0 + 2.0 * 4.5 / 8.0, 1.0 - 2.0 * 1.5 / 4.0, 0.0], 1.0);
        assert!((c[0] - 4.5 / 8.0).abs() < 1e-6 && (c[1] - 1.5 / 4.0).abs() < 1e-6);
    }

    #[test]
    fn spherical_matches_the_sphere_domain_coordinates() {
        let p = Projected::new(ramp(), ProjectionKind::Spherical, [-2.0; 3], [2.0; 3]).unwrap();
        for x in [
            [0.3, -0.4, 0.75f64.sqrt()],
            [-0.6, 0.0, -0.8],
            [0.0, 1.0, 0.0],
        ] {
            let want = caoen_surface::tessellate::sphere_uv(&x);
            let got = p.uv(x.map(|v| 1.7 * v));
            assert!((got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12);
        }
    }

    #[test]
    fn cylindrical_wraps_around_z() {
        let p = Projected::new(ramp(), ProjectionKind::Cylindrical, [-1.0; 3], [1.0; 3]).unwrap();
        assert!((p.uv([0.0, 1.0, 1.0])[0] - 0.25).abs() < 1e-12);
        assert!((p.uv([-1.0, -1e-9, 0.0])[0] - 0.5).abs() < 1e-6);
        assert_eq!(p.uv([1.0, 0.0, -1.0])[1], 1.0);
    }

    #[test]
    fn degenerate_boxes_are_refused() {
        assert!(Projected::new(ramp(), ProjectionKind::Planar, [0.0; 3], [1.0, 1.0, 0.0]).is_err());
        assert!(Projected::new(
            ramp(),
            ProjectionKind::Planar,
            [0.0; 3],
            [f64::NAN, 1.0, 1.0]
        )
        .is_err());
    }
}
