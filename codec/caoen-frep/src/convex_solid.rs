//! Convex Cao En solids as scene and F-rep model files give them: a built-in
//! polyhedron (inradius, centre, scale, rotation) or a list of planes, with the blend,
//! its exponent and the level (`docs/rendering.md`).

use serde::Deserialize;

use caoen_geometry::transform::Affine;
use caoen_geometry::vector::normalise;
use caoen_surface::implicit::WORLD_LIMIT;
use caoen_surface::json::{check_number, check_vec, FieldError};
use caoen_surface::{Blend, ConvexSolid, Plane, SurfaceError};

/// Smallest and largest scale factor of a transform or solid.
pub const SCALE_RANGE: (f64, f64) = (1e-6, 1e6);

/// A solid the surface layer refused, as an error of the field that described it.
fn solid_error(path: &str, e: SurfaceError) -> FieldError {
    FieldError::new(path, "", e.to_string())
}

/// Face normals of the built-in polyhedra (unit length; every face at distance 1).
pub fn polyhedron_normals(name: &str) -> Option<Vec<[f64; 3]>> {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut n: Vec<[f64; 3]> = Vec::new();
    let signs = [-1.0, 1.0];
    let cyclic = |v: [f64; 3]| [v, [v[2], v[0], v[1]], [v[1], v[2], v[0]]];
    match name {
        "tetrahedron" => n.extend([[1., 1., 1.], [1., -1., -1.], [-1., 1., -1.], [-1., -1., 1.]]),
        "cube" => n.extend(caoen_surface::gallery::axis_points()),
        "octahedron" => {
            for a in signs {
                for b in signs {
                    for c in signs {
                        n.push([a, b, c]);
                    }
                }
            }
        }
        "dodecahedron" => {
            for a in signs {
                for b in signs {
                    n.extend(cyclic([0.0, a, b * phi]));
                }
            }
        }
        "icosahedron" => {
            for a in signs {
                for b in signs {
                    for c in signs {
                        n.push([a, b, c]);
                    }
                    n.extend(cyclic([0.0, a / phi, b * phi]));
                }
            }
        }
        _ => return None,
    }
    Some(n.into_iter().map(normalise).collect())
}

/// Names accepted by [`polyhedron_normals`].
pub const POLYHEDRA: [&str; 5] = [
    "tetrahedron",
    "cube",
    "octahedron",
    "dodecahedron",
    "icosahedron",
];

/// A convex implicit solid from a built-in polyhedron with inradius `radius` around
/// `centre`, stretched by `scale` and turned by `rotate_deg` about the centre.
#[allow(clippy::too_many_arguments)]
pub fn polyhedron_solid(
    name: &str,
    radius: f64,
    centre: [f64; 3],
    scale: [f64; 3],
    rotate_deg: [f64; 3],
    blend: Blend,
    q: f64,
    level: f64,
) -> Result<ConvexSolid, FieldError> {
    let normals = polyhedron_normals(name).ok_or_else(|| {
        FieldError::new(
            "polyhedron",
            format!("one of {}", POLYHEDRA.join(", ")),
            format!("`{name}`"),
        )
    })?;
    let (lo, hi) = SCALE_RANGE;
    if !(lo..=hi).contains(&radius) {
        return Err(FieldError::out_of_range("radius", radius, lo, hi));
    }
    let a = Affine::from_parts(scale, rotate_deg, [0.0; 3]);
    let mut planes = Vec::with_capacity(normals.len());
    for n in normals {
        let m = a.plane_normal(n).ok_or_else(|| {
            FieldError::new("scale", "non-zero on every axis", format!("{scale:?}"))
        })?;
        let off = radius + m[0] * centre[0] + m[1] * centre[1] + m[2] * centre[2];
        planes.push(Plane {
            normal: m,
            offset: off,
        });
    }
    ConvexSolid::from_planes(&planes, centre, blend, q, level).map_err(|e| solid_error("", e))
}

/// A scale factor: one for every axis, or one per axis.
#[derive(Deserialize)]
#[serde(untagged)]
pub enum ScaleSpec {
    /// The same factor on every axis.
    Uniform(f64),
    /// One factor per axis.
    PerAxis([f64; 3]),
}

/// The factors of `s` (1 when absent), each one's size checked.
pub fn scale_of(path: &str, s: &Option<ScaleSpec>) -> Result<[f64; 3], FieldError> {
    let v = match s {
        None => [1.0; 3],
        Some(ScaleSpec::Uniform(k)) => [*k; 3],
        Some(ScaleSpec::PerAxis(v)) => *v,
    };
    let (lo, hi) = SCALE_RANGE;
    if v.iter().all(|x| (lo..=hi).contains(&x.abs())) {
        Ok(v)
    } else {
        Err(FieldError::new(
            format!("{path}.scale"),
            format!("factors whose sizes are in [{lo:e}, {hi:e}]"),
            format!("{v:?}"),
        ))
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePlane {
    normal: [f64; 3],
    offset: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileSolid {
    #[serde(default)]
    polyhedron: Option<String>,
    #[serde(default)]
    planes: Option<Vec<FilePlane>>,
    #[serde(default)]
    radius: Option<f64>,
    #[serde(default)]
    centre: Option<[f64; 3]>,
    #[serde(default)]
    scale: Option<ScaleSpec>,
    #[serde(default)]
    rotate_deg: Option<[f64; 3]>,
    #[serde(default = "default_blend")]
    blend: Blend,
    #[serde(default = "default_solid_q")]
    q: f64,
    #[serde(default = "default_level")]
    level: f64,
}

fn default_blend() -> Blend {
    Blend::Exponential
}
fn default_solid_q() -> f64 {
    8.0
}
fn default_level() -> f64 {
    2.0
}

/// A convex Cao En solid from its scene-file form (`{"polyhedron": ..., "q": ...}` or
/// `{"planes": [...], ...}`, `docs/rendering.md`); `path` names it in errors.
pub fn convex_solid_from_json(
    v: &serde_json::Value,
    path: &str,
) -> Result<ConvexSolid, FieldError> {
    let file: FileSolid =
        serde_path_to_error::deserialize(v).map_err(|e| FieldError::from_path_error(path, &e))?;
    file.resolve(path)
}

impl FileSolid {
    /// The solid, its fields checked; `path` names it in errors.
    pub fn resolve(&self, path: &str) -> Result<ConvexSolid, FieldError> {
        let centre = check_vec(
            &format!("{path}.centre"),
            self.centre.unwrap_or([0.0; 3]),
            WORLD_LIMIT,
        )?;
        if !(self.q.is_finite() && self.q > 0.0) {
            return Err(FieldError::new(
                format!("{path}.q"),
                "a finite number > 0",
                self.q.to_string(),
            ));
        }
        if !(self.level.is_finite() && self.level > 1.0) {
            return Err(FieldError::new(
                format!("{path}.level"),
                "a finite number > 1",
                self.level.to_string(),
            ));
        }
        match (&self.polyhedron, &self.planes) {
            (Some(name), None) => {
                let radius = self.radius.unwrap_or(1.0);
                polyhedron_solid(
                    name,
                    radius,
                    centre,
                    scale_of(path, &self.scale)?,
                    check_vec(
                        &format!("{path}.rotate_deg"),
                        self.rotate_deg.unwrap_or([0.0; 3]),
                        WORLD_LIMIT,
                    )?,
                    self.blend,
                    self.q,
                    self.level,
                )
                .map_err(|e| e.under(path))
            }
            (None, Some(planes)) => {
                if self.radius.is_some() || self.scale.is_some() || self.rotate_deg.is_some() {
                    return Err(FieldError::new(
                        path,
                        "radius, scale and rotate_deg only with a `polyhedron`",
                        "`planes` with one of them",
                    ));
                }
                let planes: Vec<Plane> = planes
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let n = check_vec(
                            &format!("{path}.planes[{i}].normal"),
                            p.normal,
                            WORLD_LIMIT,
                        )?;
                        let limit = WORLD_LIMIT;
                        let offset = check_number(
                            &format!("{path}.planes[{i}].offset"),
                            p.offset,
                            -limit,
                            limit,
                        )?;
                        Ok(Plane { normal: n, offset })
                    })
                    .collect::<Result<_, FieldError>>()?;
                ConvexSolid::from_planes(&planes, centre, self.blend, self.q, self.level)
                    .map_err(|e| solid_error(path, e))
            }
            (p, _) => Err(FieldError::new(
                path,
                format!(
                    "exactly one of `polyhedron` ({}) or `planes`",
                    POLYHEDRA.join(", ")
                ),
                if p.is_some() { "both" } else { "neither" },
            )),
        }
    }
}
