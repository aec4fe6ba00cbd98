//! Shading (paper section 7): Lambert's cosine law with an ambient term and any number
//! of lights (`lights`), plus an optional Blinn-Phong highlight. All arithmetic is in
//! linear light; gamma encoding happens once, when the image is written.

use std::sync::Arc;

use super::bump::Bumps;
use super::cae_texture::CaeSource;
use super::image_map::ImageMap;
pub use super::lights::{Incidence, Light, Lighting};
use super::pattern::Checker;
use super::texture::{Texture, Wrap};
use caoen_geometry::vector::{add, dot, unit};

/// How a surface reflects light.
#[derive(Debug, Clone)]
pub struct Material {
    /// Linear base colour (multiplied by the texture, if any).
    pub colour: [f32; 3],
    /// Ambient reflectance.
    pub ambient: f32,
    /// Diffuse (Lambert) reflectance.
    pub diffuse: f32,
    /// Blinn-Phong specular reflectance (0 turns the highlight off).
    pub specular: f32,
    /// Blinn-Phong exponent.
    pub shininess: f32,
    /// Texture on the domain, with its wrap mode.
    pub texture: Option<(Arc<Texture>, Wrap)>,
    /// The `.cae` file the domain texture was decoded from, which a render decodes
    /// again at the size its footprint asks for; None for other images.
    pub texture_cae: Option<Arc<CaeSource>>,
    /// An image projected onto the object in world space; it gives the base colour.
    pub image_map: Option<Arc<ImageMap>>,
    /// A checker in world space (POV-Ray's `checker`); it gives the base colour.
    pub checker: Option<Arc<Checker>>,
    /// A bump pattern (POV-Ray's `normal { bumps .. }`) displacing the normal.
    pub normal: Option<Arc<Bumps>>,
    /// Mirror reflectance in [0, 1] (times the Fresnel reflectance when transmitting).
    pub reflect: f32,
    /// Share of light passing through the surface, in [0, 1].
    pub transmit: f32,
    /// Index of refraction of the inside (>= 1).
    pub ior: f64,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            colour: [0.30, 0.38, 0.62],
            ambient: 1.0,
            diffuse: 1.0,
            specular: 0.25,
            shininess: 40.0,
            texture: None,
            texture_cae: None,
            image_map: None,
            checker: None,
            normal: None,
            reflect: 0.0,
            transmit: 0.0,
            ior: 1.0,
        }
    }
}

impl Material {
    /// The base colour at world point `p` with texture coordinates `uv`: the
    /// checker's or the image map's colour there if there is one, else
    /// [`Material::albedo`].
    pub fn albedo_at(&self, uv: [f32; 2], p: [f64; 3]) -> [f32; 3] {
        match (&self.checker, &self.image_map) {
            (Some(c), _) => c.colour(p),
            (None, Some(m)) => m.colour(p),
            (None, None) => self.albedo(uv),
        }
    }

    /// The base colour at texture coordinates `uv` (NaN: untextured point), unfiltered.
    pub fn albedo(&self, uv: [f32; 2]) -> [f32; 3] {
        self.albedo_filtered(uv, [[0.0; 2]; 2])
    }

    /// The base colour at texture coordinates `uv` for a sample whose neighbours one
    /// sample step away in x and y lie `duv[0]` and `duv[1]` away in texture
    /// coordinates: the texture is read at the pyramid level of that footprint.
    pub fn albedo_filtered(&self, uv: [f32; 2], duv: [[f32; 2]; 2]) -> [f32; 3] {
        match &self.texture {
            Some((tex, wrap)) if uv[0].is_finite() => {
                let (w, h) = (tex.image().width as f64, tex.image().height as f64);
                let side = |d: [f32; 2]| (d[0] as f64 * w).hypot(d[1] as f64 * h);
                let footprint = side(duv[0]).max(side(duv[1]));
                let t = tex.sample_filtered([uv[0] as f64, uv[1] as f64], footprint, *wrap);
                [
                    t[0] * self.colour[0],
                    t[1] * self.colour[1],
                    t[2] * self.colour[2],
                ]
            }
            _ => self.colour,
        }
    }
}

/// A surface point as shading sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Base colour (linear light).
    pub albedo: [f32; 3],
    /// Unit normal.
    pub normal: [f64; 3],
    /// Unit direction from the surface towards the eye.
    pub to_eye: [f64; 3],
    /// Where the point is (positioned lights depend on it).
    pub position: [f64; 3],
}

/// Linear radiance leaving the surface point `at`.
///
/// The normal is turned to face the viewer first: a Cao En map may orient its surface
/// either way (and a zero normal, at a singular point, shades with ambient light only).
pub fn shade(lighting: &Lighting, material: &Material, at: SurfacePoint) -> [f32; 3] {
    shade_lit(lighting, material, at, 1.0, &|_, _| 1.0)
}

/// [`shade`] with an opacity (the share of ambient and diffuse light the surface
/// keeps, `1 - transmit`; the highlight is not scaled, as in POV-Ray) and the share of
/// each light that reaches the point, `visible(light index, how it meets the point)`
/// (asked only of lights in front of the surface that reach it at all).
pub fn shade_lit(
    lighting: &Lighting,
    material: &Material,
    at: SurfacePoint,
    opacity: f32,
    visible: &dyn Fn(usize, &Incidence) -> f32,
) -> [f32; 3] {
    let SurfacePoint {
        albedo,
        normal,
        to_eye,
        position,
    } = at;
    let mut n = normal;
    if dot(n, to_eye) < 0.0 {
        n = n.map(|v| -v);
    }
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        out[k] = lighting.ambient[k] * material.ambient * albedo[k] * opacity;
    }
    for (i, light) in lighting.lights.iter().enumerate() {
        let Some(inc) = light.incidence(position) else {
            continue;
        };
        // POV-Ray skips a light whose colour at the point is below its epsilon.
        if !(inc.strength > 1e-10) {
            continue;
        }
        let cos = dot(n, inc.direction);
        if cos <= 0.0 {
            continue;
        }
        let seen = visible(i, &inc) * inc.strength as f32;
        if seen <= 0.0 {
            continue;
        }
        let diffuse = material.diffuse * cos as f32 * opacity;
        let mut spec = 0.0f32;
        if material.specular > 0.0 {
            let h = unit(add(inc.direction, to_eye));
            let c = dot(n, h).max(0.0) as f32;
            spec = material.specular * c.powf(material.shininess);
        }
        for k in 0..3 {
            out[k] += seen * light.radiance[k] * (diffuse * albedo[k] + spec);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambert_follows_the_cosine_law() {
        let lighting = Lighting {
            ambient: [0.0; 3],
            lights: vec![Light::new([0.0, 0.0, 1.0], [1.0; 3], 1.0)],
        };
        let m = Material {
            specular: 0.0,
            ..Material::default()
        };
        let at = |normal| SurfacePoint {
            albedo: [1.0; 3],
            normal,
            to_eye: [0.0, 0.0, 1.0],
            position: [0.0; 3],
        };
        let head_on = shade(&lighting, &m, at([0.0, 0.0, 1.0]));
        let s = 0.5f64.sqrt();
        let tilted = shade(&lighting, &m, at([s, 0.0, s]));
        assert!((tilted[0] / head_on[0] - s as f32).abs() < 1e-6);
        // Facing away from the viewer flips the normal, not the light.
        let back = shade(&lighting, &m, at([0.0, 0.0, -1.0]));
        assert_eq!(back, head_on);
    }
}
