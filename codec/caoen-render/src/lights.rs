//! Light sources as POV-Ray 3.7 has them: parallel (directional), point and spot
//! lights, any positioned one optionally faded with distance and spread over an area
//! light's grid for soft shadows.
//!
//! The formulas are POV-Ray's (`Attenuate_Light`, `TraceAreaLightSubsetShadowRay`), so
//! that `export-pov` scenes render alike: fade `2 / (1 + (d / fade_distance)^fade_power)`;
//! a spot light's `cos(a)^tightness`, times the cubic `(3 - 2s) s^2` between the
//! `falloff` and `radius` cones (`s` the position of `cos a` from `cos falloff` to
//! `cos radius`), 0 outside `falloff`. An area light lights a point as a point light at
//! its centre would (direction, fade, spot cone), and only its shadow is spread: the
//! grid's corners are tested, and a block is split into four while it is shallower
//! than `adaptive` or its corners differ by more than 0.1 (sum over the channels of
//! the light that reaches the point), each block the mean of its four parts.

use caoen_geometry::vector::{dot, scale, sub, unit};

/// Largest number of samples an area light's grid may have.
pub const MAX_AREA_SAMPLES: u64 = 65_536;
/// Largest samples along one axis of an area light.
pub const MAX_AREA_SIZE: u64 = 256;

/// Where a light is and which way it shines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightKind {
    /// A light at infinity (POV-Ray's `parallel`).
    Directional {
        /// Unit direction from the surface towards the light.
        direction: [f64; 3],
    },
    /// A light at a point, shining every way.
    Point {
        /// Position.
        position: [f64; 3],
    },
    /// A light at a point, shining in a cone (POV-Ray's `spotlight`).
    Spot {
        /// Position.
        position: [f64; 3],
        /// Unit axis of the cone, from the light towards `point_at`.
        axis: [f64; 3],
        /// Cosine of the full-intensity cone's half angle (`radius`).
        cos_radius: f64,
        /// Cosine of the cone's half angle where the light ends (`falloff`).
        cos_falloff: f64,
        /// Exponent of the cosine of the angle off the axis.
        tightness: f64,
    },
}

/// Fading with distance: `2 / (1 + (d / distance)^power)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fade {
    /// Distance at which the light keeps its full intensity (> 0).
    pub distance: f64,
    /// Exponent (> 0; 2 is physical).
    pub power: f64,
}

/// An area light's grid of sample points around the light's position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaLight {
    /// The grid's first side (whole length).
    pub axis1: [f64; 3],
    /// The grid's second side.
    pub axis2: [f64; 3],
    /// Samples along `axis1` (>= 1).
    pub size1: u32,
    /// Samples along `axis2` (>= 1).
    pub size2: u32,
    /// Whether each sample moves randomly within its cell (seeded by the surface point,
    /// so a render is the same on any number of threads).
    pub jitter: bool,
    /// Levels of the grid always split; None splits down to every sample.
    pub adaptive: Option<u32>,
}

impl AreaLight {
    /// Samples in the grid.
    pub fn samples(&self) -> u64 {
        u64::from(self.size1) * u64::from(self.size2)
    }

    /// Offset from the light's centre of sample `(u, v)`, moved by `jitter` (each in
    /// [-0.5, 0.5)) when the light jitters.
    pub fn offset(&self, u: u32, v: u32, jitter: [f64; 2]) -> [f64; 3] {
        let along = |i: u32, n: u32, j: f64| {
            if n > 1 {
                (f64::from(i) + j) / f64::from(n - 1) - 0.5
            } else {
                0.0
            }
        };
        let (a, b) = (
            along(u, self.size1, jitter[0]),
            along(v, self.size2, jitter[1]),
        );
        [0, 1, 2].map(|k| self.axis1[k] * a + self.axis2[k] * b)
    }
}

/// A light source.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Kind and placement.
    pub kind: LightKind,
    /// Linear colour times intensity.
    pub radiance: [f32; 3],
    /// Fading with distance (positioned lights only).
    pub fade: Option<Fade>,
    /// Soft shadows (positioned lights only).
    pub area: Option<AreaLight>,
}

/// How a light meets a surface point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Incidence {
    /// Unit direction from the point towards the light (its centre).
    pub direction: [f64; 3],
    /// Distance to the light (infinite for a directional light).
    pub distance: f64,
    /// The share of the light's radiance arriving (spot cone and fade).
    pub strength: f64,
}

impl Light {
    /// A directional light shining from `towards_light` with linear colour `colour`
    /// scaled by `intensity`.
    pub fn new(towards_light: [f64; 3], colour: [f32; 3], intensity: f32) -> Self {
        Light {
            kind: LightKind::Directional {
                direction: unit(towards_light),
            },
            radiance: colour.map(|c| c * intensity),
            fade: None,
            area: None,
        }
    }

    /// A point light at `position`.
    pub fn point(position: [f64; 3], colour: [f32; 3], intensity: f32) -> Self {
        Light {
            kind: LightKind::Point { position },
            ..Light::new([0.0, 0.0, 1.0], colour, intensity)
        }
    }

    /// The light's position, None for a directional light.
    pub fn position(&self) -> Option<[f64; 3]> {
        match self.kind {
            LightKind::Directional { .. } => None,
            LightKind::Point { position } | LightKind::Spot { position, .. } => Some(position),
        }
    }

    /// Shadow rays a surface point sends towards this light at most.
    pub fn shadow_samples(&self) -> u64 {
        self.area.map_or(1, |a| a.samples())
    }

    /// How the light meets point `p`: None where it is nowhere (a point at the light).
    pub fn incidence(&self, p: [f64; 3]) -> Option<Incidence> {
        let position = match self.kind {
            LightKind::Directional { direction } => {
                return Some(Incidence {
                    direction,
                    distance: f64::INFINITY,
                    strength: 1.0,
                })
            }
            LightKind::Point { position } | LightKind::Spot { position, .. } => position,
        };
        let to = sub(position, p);
        let distance = dot(to, to).sqrt();
        if !(distance > 0.0) {
            return None;
        }
        let direction = scale(to, 1.0 / distance);
        let mut strength = 1.0;
        if let LightKind::Spot {
            axis,
            cos_radius,
            cos_falloff,
            tightness,
            ..
        } = self.kind
        {
            strength = spot(-dot(direction, axis), cos_radius, cos_falloff, tightness);
        }
        if strength > 0.0 {
            if let Some(f) = self.fade {
                strength *= 2.0 / (1.0 + (distance / f.distance).powf(f.power));
            }
        }
        Some(Incidence {
            direction,
            distance,
            strength,
        })
    }
}

/// POV-Ray's spot light factor at cosine `c` off the axis.
fn spot(c: f64, cos_radius: f64, cos_falloff: f64, tightness: f64) -> f64 {
    if !(c > 0.0) {
        return 0.0;
    }
    let mut a = c.powf(tightness);
    if cos_radius > 0.0 && c < cos_radius {
        a *= cubic_spline(cos_falloff, cos_radius, c);
    }
    a
}

/// 0 below `low`, 1 from `high`, the smooth cubic `(3 - 2s) s^2` between.
fn cubic_spline(low: f64, high: f64, pos: f64) -> f64 {
    if pos < low {
        return 0.0;
    }
    if pos >= high {
        return 1.0;
    }
    let s = (pos - low) / (high - low);
    (3.0 - 2.0 * s) * s * s
}

/// The scene's lights.
#[derive(Debug, Clone, PartialEq)]
pub struct Lighting {
    /// Linear ambient light colour.
    pub ambient: [f32; 3],
    /// Lights.
    pub lights: Vec<Light>,
}

impl Lighting {
    /// Shadow rays a surface point sends at most: one per light, an area light's
    /// samples each.
    pub fn shadow_samples(&self) -> u64 {
        self.lights.iter().map(Light::shadow_samples).sum()
    }
}

impl Default for Lighting {
    /// A key light from the upper left front, a dimmer fill from the right, soft ambient.
    fn default() -> Self {
        Lighting {
            ambient: [0.06; 3],
            lights: vec![
                Light::new([-1.0, -0.5, 1.0], [1.0, 0.96, 0.9], 1.0),
                Light::new([1.0, -0.3, 0.2], [0.7, 0.8, 1.0], 0.25),
            ],
        }
    }
}

/// The share of an area light reaching a point, POV-Ray's adaptive way:
/// `sample(u, v)` is the share of the light through the grid's sample `(u, v)`, and
/// `weight` the summed colour channels of the light arriving unshadowed (so that the
/// 0.1 threshold is on colours, as POV-Ray's). `grid` is scratch of the grid's size.
pub fn area_share(
    area: &AreaLight,
    weight: f64,
    grid: &mut Vec<f32>,
    sample: &mut dyn FnMut(u32, u32) -> f32,
) -> f32 {
    grid.clear();
    grid.resize(area.samples() as usize, -1.0);
    let mut block = Block {
        area,
        weight,
        grid,
        sample,
    };
    block.share(0, 0, area.size1 - 1, area.size2 - 1, 0)
}

struct Block<'a, 'b> {
    area: &'a AreaLight,
    weight: f64,
    grid: &'a mut Vec<f32>,
    sample: &'a mut (dyn FnMut(u32, u32) -> f32 + 'b),
}

impl Block<'_, '_> {
    fn corner(&mut self, u: u32, v: u32) -> f32 {
        let i = (u * self.area.size2 + v) as usize;
        if self.grid[i] < 0.0 {
            self.grid[i] = (self.sample)(u, v);
        }
        self.grid[i]
    }

    fn share(&mut self, u1: u32, v1: u32, u2: u32, v2: u32, level: u32) -> f32 {
        let mut c = [
            self.corner(u1, v1),
            self.corner(u2, v1),
            self.corner(u1, v2),
            self.corner(u2, v2),
        ];
        if u2 - u1 > 1 || v2 - v1 > 1 {
            let differ = |a: f32, b: f32| f64::from((a - b).abs()) * self.weight > 0.1;
            let split = self.area.adaptive.is_none_or(|a| level < a)
                || differ(c[0], c[1])
                || differ(c[1], c[3])
                || differ(c[3], c[2])
                || differ(c[2], c[0]);
            if split {
                let (ul, uh) = ((u1 + u2) / 2, (u1 + u2).div_ceil(2));
                let (vl, vh) = ((v1 + v2) / 2, (v1 + v2).div_ceil(2));
                c = [
                    self.share(u1, v1, ul, vl, level + 1),
                    self.share(uh, v1, u2, vl, level + 1),
                    self.share(u1, vh, ul, v2, level + 1),
                    self.share(uh, vh, u2, v2, level + 1),
                ];
            }
        }
        0.25 * (c[0] + c[1] + c[2] + c[3])
    }
}

/// Two numbers in [-0.5, 0.5) from a surface point, a light and a grid sample: the
/// jitter of an area light's sample, the same whichever thread shades the point.
pub fn jitter(p: [f64; 3], light: usize, u: u32, v: u32) -> [f64; 2] {
    let mut h = 0x9e37_79b9_7f4a_7c15u64 ^ (light as u64) << 40 ^ u64::from(u) << 20 ^ u64::from(v);
    for x in p {
        h = mix(h ^ x.to_bits());
    }
    let a = mix(h);
    let b = mix(a);
    let unit = |x: u64| (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
    [unit(a), unit(b)]
}

/// SplitMix64's finaliser.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fade_and_spot_follow_pov_ray() {
        let mut l = Light::point([0.0, 0.0, 2.0], [1.0; 3], 1.0);
        l.fade = Some(Fade {
            distance: 1.0,
            power: 2.0,
        });
        // d = 2: 2 / (1 + 4).
        let i = l.incidence([0.0; 3]).unwrap();
        assert!((i.strength - 0.4).abs() < 1e-12);
        assert_eq!(i.direction, [0.0, 0.0, 1.0]);
        let (r, f) = (20f64.to_radians().cos(), 30f64.to_radians().cos());
        l.fade = None;
        l.kind = LightKind::Spot {
            position: [0.0, 0.0, 1.0],
            axis: [0.0, 0.0, -1.0],
            cos_radius: r,
            cos_falloff: f,
            tightness: 0.0,
        };
        let at = |deg: f64| {
            let t = deg.to_radians();
            l.incidence([t.tan(), 0.0, 0.0]).unwrap().strength
        };
        assert_eq!(at(10.0), 1.0);
        assert_eq!(at(35.0), 0.0);
        let c = 25f64.to_radians().cos();
        let s = (c - f) / (r - f);
        assert!((at(25.0) - (3.0 - 2.0 * s) * s * s).abs() < 1e-9);
    }

    #[test]
    fn adaptive_area_shares() {
        let area = AreaLight {
            axis1: [1.0, 0.0, 0.0],
            axis2: [0.0, 1.0, 0.0],
            size1: 5,
            size2: 5,
            jitter: false,
            adaptive: Some(0),
        };
        let mut grid = Vec::new();
        let mut calls = 0;
        // Lit everywhere: the corners agree, four samples suffice.
        let s = area_share(&area, 3.0, &mut grid, &mut |_, _| {
            calls += 1;
            1.0
        });
        assert_eq!((s, calls), (1.0, 4));
        // Half the grid (u < 2) shadowed: every sample is looked at where it matters.
        let full = AreaLight {
            adaptive: None,
            ..area
        };
        let s = area_share(&full, 3.0, &mut grid, &mut |u, _| f32::from(u >= 2));
        // Blocks [0, 2] and [2, 4] along u: (0 + 0.5 + 0.5 + 1 ...) POV-Ray's weights.
        assert!((s - 0.625).abs() < 1e-6, "{s}");
    }
}
