//! The `lights` of a scene file: directional, point, spot and area lights with
//! POV-Ray's fields, checked so that bad values are refused with the field's name.

use serde::Deserialize;

use super::error::Result;
use super::lights::{AreaLight, Fade, Light, LightKind, MAX_AREA_SAMPLES, MAX_AREA_SIZE};
use super::scene_file::{bad, check_colour, check_number, check_vec, MAX_COEFFICIENT};

/// Largest `fade_power` (POV-Ray's physical value is 2; far beyond, the light is a
/// step).
const MAX_FADE_POWER: f64 = 100.0;
/// Largest spot light `tightness`.
const MAX_TIGHTNESS: f64 = 1e4;
/// Largest `adaptive` level: more than enough to split a 256-sample side to single
/// samples.
const MAX_ADAPTIVE: u64 = 16;

/// One light of the file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FileLight {
    #[serde(default)]
    direction: Option<[f64; 3]>,
    #[serde(default)]
    position: Option<[f64; 3]>,
    #[serde(default = "white")]
    colour: [f64; 3],
    #[serde(default = "one")]
    intensity: f64,
    #[serde(default)]
    fade_distance: Option<f64>,
    #[serde(default)]
    fade_power: Option<f64>,
    #[serde(default)]
    point_at: Option<[f64; 3]>,
    #[serde(default)]
    radius: Option<f64>,
    #[serde(default)]
    falloff: Option<f64>,
    #[serde(default)]
    tightness: Option<f64>,
    #[serde(default)]
    area_light: Option<FileArea>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileArea {
    axis1: [f64; 3],
    axis2: [f64; 3],
    size1: u64,
    size2: u64,
    #[serde(default)]
    jitter: bool,
    #[serde(default)]
    adaptive: Option<u64>,
}

fn white() -> [f64; 3] {
    [1.0; 3]
}

fn one() -> f64 {
    1.0
}

impl FileLight {
    /// The light, its fields checked; `path` names it in errors (`lights[2]`).
    pub(crate) fn resolve(&self, path: &str) -> Result<Light> {
        let f = |name: &str| format!("{path}.{name}");
        check_number(&f("intensity"), self.intensity, 0.0, MAX_COEFFICIENT)?;
        let colour = check_colour(&f("colour"), self.colour)?;
        let mut light = match (self.direction, self.position) {
            (Some(d), None) => {
                let d = check_vec(&f("direction"), d)?;
                if d == [0.0; 3] {
                    return Err(bad(f("direction"), "must be non-zero"));
                }
                for (name, given) in [
                    ("fade_distance", self.fade_distance.is_some()),
                    ("fade_power", self.fade_power.is_some()),
                    ("point_at", self.point_at.is_some()),
                    ("area_light", self.area_light.is_some()),
                ] {
                    if given {
                        return Err(bad(
                            f(name),
                            "only for lights with a `position` (a directional light is at infinity)",
                        ));
                    }
                }
                Light::new(d, colour, self.intensity as f32)
            }
            (None, Some(p)) => {
                Light::point(check_vec(&f("position"), p)?, colour, self.intensity as f32)
            }
            _ => {
                return Err(bad(
                    path,
                    "give exactly one of `direction` (a directional light) or `position` (a point, spot or area light)",
                ))
            }
        };
        self.spot(path, &mut light)?;
        light.fade = self.fade(path)?;
        if let Some(a) = &self.area_light {
            light.area = Some(a.resolve(&f("area_light"))?);
        }
        Ok(light)
    }

    /// Makes `light` a spot light when the file gives `point_at`.
    fn spot(&self, path: &str, light: &mut Light) -> Result<()> {
        let f = |name: &str| format!("{path}.{name}");
        let Some(target) = self.point_at else {
            for (name, given) in [
                ("radius", self.radius.is_some()),
                ("falloff", self.falloff.is_some()),
                ("tightness", self.tightness.is_some()),
            ] {
                if given {
                    return Err(bad(f(name), "only for spot lights (give `point_at`)"));
                }
            }
            return Ok(());
        };
        let target = check_vec(&f("point_at"), target)?;
        let Some(position) = light.position() else {
            return Ok(());
        };
        let axis: [f64; 3] = [0, 1, 2].map(|k| target[k] - position[k]);
        let len = axis.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(len > 0.0) {
            return Err(bad(f("point_at"), "must differ from `position`"));
        }
        // POV-Ray's defaults: a 30 degree cone fading out by 45 degrees.
        let radius = check_number(&f("radius"), self.radius.unwrap_or(30.0), 0.0, 90.0)?;
        let falloff = check_number(
            &f("falloff"),
            self.falloff.unwrap_or(radius.max(45.0)),
            0.0,
            90.0,
        )?;
        if falloff < radius {
            return Err(bad(
                f("falloff"),
                format!("{falloff} is below radius {radius}: the light fades out beyond `radius`, by `falloff`"),
            ));
        }
        let tightness = check_number(
            &f("tightness"),
            self.tightness.unwrap_or(0.0),
            0.0,
            MAX_TIGHTNESS,
        )?;
        light.kind = LightKind::Spot {
            position,
            axis: axis.map(|v| v / len),
            cos_radius: radius.to_radians().cos(),
            cos_falloff: falloff.to_radians().cos(),
            tightness,
        };
        Ok(())
    }

    fn fade(&self, path: &str) -> Result<Option<Fade>> {
        let f = |name: &str| format!("{path}.{name}");
        match (self.fade_distance, self.fade_power) {
            (None, None) => Ok(None),
            (Some(d), Some(p)) => {
                let limit = caoen_surface::implicit::WORLD_LIMIT;
                let distance = check_number(&f("fade_distance"), d, 0.0, limit)?;
                if !(distance > 0.0) {
                    return Err(bad(f("fade_distance"), "must be above 0"));
                }
                let power = check_number(&f("fade_power"), p, 0.0, MAX_FADE_POWER)?;
                // POV-Ray: a fade_power of 0 turns fading off.
                Ok((power > 0.0).then_some(Fade { distance, power }))
            }
            (Some(_), None) => Err(bad(
                f("fade_power"),
                "missing: `fade_distance` needs `fade_power` (2 is physical)",
            )),
            (None, Some(_)) => Err(bad(
                f("fade_distance"),
                "missing: `fade_power` needs `fade_distance` (where the light is at full intensity)",
            )),
        }
    }
}

impl FileArea {
    fn resolve(&self, path: &str) -> Result<AreaLight> {
        let f = |name: &str| format!("{path}.{name}");
        let axis1 = check_vec(&f("axis1"), self.axis1)?;
        let axis2 = check_vec(&f("axis2"), self.axis2)?;
        for (name, size) in [("size1", self.size1), ("size2", self.size2)] {
            if !(1..=MAX_AREA_SIZE).contains(&size) {
                return Err(bad(
                    f(name),
                    format!("{size} is not in 1..={MAX_AREA_SIZE}"),
                ));
            }
        }
        if self.size1 * self.size2 > MAX_AREA_SAMPLES {
            return Err(bad(
                path,
                format!(
                    "{} x {} samples: at most {MAX_AREA_SAMPLES} in all",
                    self.size1, self.size2
                ),
            ));
        }
        for (name, axis, size) in [("axis1", axis1, self.size1), ("axis2", axis2, self.size2)] {
            if size > 1 && axis == [0.0; 3] {
                return Err(bad(
                    f(name),
                    "must be non-zero: the area light would have no size along it",
                ));
            }
        }
        if self.size1 * self.size2 == 1 || axis1 == [0.0; 3] && axis2 == [0.0; 3] {
            return Err(bad(
                path,
                "a one-sample or zero-size area light is a point light: give size1 or size2 above 1 and a non-zero axis",
            ));
        }
        let adaptive = match self.adaptive {
            None => None,
            Some(a) if a <= MAX_ADAPTIVE => Some(a as u32),
            Some(a) => {
                return Err(bad(
                    f("adaptive"),
                    format!("{a} is not in 0..={MAX_ADAPTIVE}"),
                ))
            }
        };
        Ok(AreaLight {
            axis1,
            axis2,
            size1: self.size1 as u32,
            size2: self.size2 as u32,
            jitter: self.jitter,
            adaptive,
        })
    }
}
