//! Scenes: a camera, lights and a list of objects with materials, and the scene file.
//!
//! The file is JSON in the style of surface model files (a `format` tag, snake_case
//! fields, unknown fields rejected, errors naming the offending field such as
//! `objects[2].solid.q`). The format is specified in `docs/rendering.md`.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Deserialize;

use super::camera::{Camera, Projection};
use super::csg::CsgNode;
use super::error::{RenderError, Result};
use super::framebuffer::srgb_to_linear;
use super::shading::{Light, Lighting, Material};
use super::texture::{Texture, Wrap};
pub use crate::frep::convex_solid::{polyhedron_normals, polyhedron_solid, POLYHEDRA};
use crate::frep::convex_solid::{scale_of, FileSolid, ScaleSpec, SCALE_RANGE};
use crate::geometry::transform::Affine;
use crate::surface::{gallery, ConvexSolid, SurfaceModel};

/// The format tag every scene file starts with.
pub const SCENE_FORMAT_TAG: &str = "caoen-scene/1";

/// Where the camera is, or how to place it automatically.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraSpec {
    /// Eye position; None frames the whole scene from `view_from`.
    pub eye: Option<[f64; 3]>,
    /// Point looked at; None looks at the scene's centre.
    pub target: Option<[f64; 3]>,
    /// Approximate up direction.
    pub up: [f64; 3],
    /// Direction from the scene centre towards the eye, for automatic framing.
    pub view_from: [f64; 3],
    /// Projection.
    pub projection: Projection,
}

impl Default for CameraSpec {
    fn default() -> Self {
        CameraSpec {
            eye: None,
            target: None,
            up: [0.0, 0.0, 1.0],
            view_from: [1.0, -1.6, 0.9],
            projection: Projection::Perspective { fov_y_deg: 30.0 },
        }
    }
}

/// What an object is.
#[derive(Debug, Clone)]
// Scenes hold a handful of objects; boxing the larger variant would buy nothing.
#[allow(clippy::large_enum_variant)]
pub enum Shape {
    /// A Cao En surface placed by an affine map.
    Surface {
        /// The model.
        model: SurfaceModel,
        /// Placement in the scene.
        place: Affine,
        /// Mesh tessellation level override for the mesh method.
        detail: Option<u32>,
    },
    /// Convex implicit solids combined by a CSG expression (a single solid is
    /// `CsgNode::Solid(0)`).
    Solid {
        /// The solids the expression refers to by index.
        solids: Vec<ConvexSolid>,
        /// The expression.
        csg: CsgNode,
    },
    /// An F-rep solid (`f >= 0` inside) within a box that holds it.
    Field {
        /// The model.
        node: Arc<crate::frep::Node>,
        /// A box the solid lies in.
        bounds: crate::frep::Aabb,
    },
}

/// One object of a scene.
#[derive(Debug, Clone)]
pub struct SceneObject {
    /// Name (for messages).
    pub name: String,
    /// Geometry.
    pub shape: Shape,
    /// Surface appearance.
    pub material: Material,
}

/// A scene to render.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Free-form name.
    pub name: String,
    /// Camera placement.
    pub camera: CameraSpec,
    /// Linear background colour.
    pub background: [f32; 3],
    /// Lights.
    pub lighting: Lighting,
    /// Objects, drawn in this order (ties in depth keep the earlier object).
    pub objects: Vec<SceneObject>,
}

impl Scene {
    /// A scene of one surface with the default camera, lights and material; the model's
    /// texture (resolved against `model_file`'s directory) is loaded if it has one.
    pub fn from_model(model: SurfaceModel, model_file: Option<&Path>) -> Result<Scene> {
        let mut material = Material::default();
        if let Some(path) = model.texture_path(model_file) {
            material.texture = Some((Arc::new(Texture::load(&path)?), texture_wrap(&model)?));
            material.colour = [1.0; 3];
        }
        Ok(Scene {
            name: model.name.clone(),
            camera: CameraSpec::default(),
            background: srgb_to_linear(DEFAULT_BACKGROUND),
            lighting: Lighting::default(),
            objects: vec![SceneObject {
                name: model.name.clone(),
                shape: Shape::Surface {
                    model,
                    place: Affine::IDENTITY,
                    detail: None,
                },
                material,
            }],
        })
    }

    /// Whether `text` looks like a scene file (its format tag), as opposed to a model.
    pub fn is_scene_json(text: &str) -> bool {
        #[derive(Deserialize)]
        struct Tag {
            format: Option<String>,
        }
        // Only the first value is looked at, so that a scene with trailing data is
        // still recognised and [`Scene::from_json`] reports the trailing data.
        let de = &mut serde_json::Deserializer::from_str(text);
        Tag::deserialize(de)
            .ok()
            .and_then(|t| t.format)
            .is_some_and(|f| f.starts_with("caoen-scene/"))
    }

    /// Loads a scene file; files it names are resolved against its directory.
    pub fn load(path: &Path) -> Result<Scene> {
        let text = crate::budget::read_to_string(path).map_err(|e| RenderError::io(path, e))?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Scene::from_json(&text, &base)
            .map_err(|e| match e {
                RenderError::Scene(msg) => RenderError::Scene(format!("{}: {msg}", path.display())),
                other => other,
            })
            .map_err(RenderError::printable)
    }

    /// Parses a scene (exactly one JSON value, nothing after it); relative file names
    /// are resolved against `base_dir`.
    pub fn from_json(text: &str, base_dir: &Path) -> Result<Scene> {
        Self::parse_json(text, base_dir).map_err(RenderError::printable)
    }

    fn parse_json(text: &str, base_dir: &Path) -> Result<Scene> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let file: FileScene = serde_path_to_error::deserialize(&mut *de).map_err(|e| {
            let path = e.path().to_string();
            RenderError::Scene(if path == "." {
                e.inner().to_string()
            } else {
                format!("{path}: {}", e.inner())
            })
        })?;
        // Data after the value is a damaged or concatenated file, not a scene to trust.
        de.end()
            .map_err(|e| RenderError::Scene(format!("after the scene: {e}")))?;
        if file.format != SCENE_FORMAT_TAG {
            return Err(RenderError::Scene(format!(
                "format: expected \"{SCENE_FORMAT_TAG}\", found \"{}\"",
                file.format
            )));
        }
        let camera = file.camera.unwrap_or_default().resolve()?;
        let lighting = match (file.ambient, file.lights) {
            (None, None) => Lighting::default(),
            (ambient, lights) => {
                let mut l = Lighting::default();
                if let Some(a) = ambient {
                    l.ambient = check_colour("ambient", a)?;
                }
                if let Some(lights) = lights {
                    l.lights = lights
                        .iter()
                        .enumerate()
                        .map(|(i, fl)| fl.resolve(&format!("lights[{i}]")))
                        .collect::<Result<_>>()?;
                }
                l
            }
        };
        if file.objects.is_empty() {
            return Err(RenderError::Scene(
                "objects: a scene needs at least one object".into(),
            ));
        }
        let objects = file
            .objects
            .into_iter()
            .enumerate()
            .map(|(i, o)| o.resolve(&format!("objects[{i}]"), base_dir))
            .collect::<Result<_>>()?;
        Ok(Scene {
            name: file.name,
            camera,
            background: check_colour("background", file.background)?,
            lighting,
            objects,
        })
    }

    /// The scene's bounding sphere `(centre, radius)`, for automatic framing.
    pub fn bounds(&self) -> Result<([f64; 3], f64)> {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        let mut add = |p: [f64; 3]| {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        };
        for o in &self.objects {
            match &o.shape {
                Shape::Surface { model, place, .. } => {
                    let mesh = crate::surface::tessellate::tessellate(
                        model,
                        2,
                        crate::surface::tessellate::NormalMode::Exact,
                    )?;
                    mesh.positions.iter().for_each(|p| add(place.point(*p)));
                }
                Shape::Solid { solids, csg } => {
                    for i in csg.solids() {
                        let s = &solids[i as usize];
                        let (c, r) = (s.centre(), s.bounding_radius());
                        add([c[0] - r, c[1] - r, c[2] - r]);
                        add([c[0] + r, c[1] + r, c[2] + r]);
                    }
                }
                Shape::Field { bounds, .. } => {
                    add(bounds.lo);
                    add(bounds.hi);
                }
            }
        }
        if !lo[0].is_finite() {
            return Err(RenderError::Scene(
                "the scene has no bounded geometry".into(),
            ));
        }
        let c = [
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ];
        // The radius is the farthest sampled point (or solid's bounding sphere) from the
        // box centre: tighter than the box's half-diagonal.
        let dist = |p: [f64; 3]| {
            ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt()
        };
        let mut r: f64 = 0.0;
        for o in &self.objects {
            match &o.shape {
                Shape::Surface { model, place, .. } => {
                    let mesh = crate::surface::tessellate::tessellate(
                        model,
                        2,
                        crate::surface::tessellate::NormalMode::Exact,
                    )?;
                    for p in &mesh.positions {
                        r = r.max(dist(place.point(*p)));
                    }
                }
                Shape::Solid { solids, csg } => {
                    for i in csg.solids() {
                        r = r.max(solid_extent(&solids[i as usize], c));
                    }
                }
                Shape::Field { bounds, .. } => {
                    for corner in 0..8 {
                        let pick = |k: usize| {
                            if corner >> k & 1 == 1 {
                                bounds.hi[k]
                            } else {
                                bounds.lo[k]
                            }
                        };
                        r = r.max(dist([pick(0), pick(1), pick(2)]));
                    }
                }
            }
        }
        Ok((c, r))
    }

    /// The camera for an image of `width x height` pixels.
    pub fn camera(&self, width: u32, height: u32) -> Result<Camera> {
        let spec = &self.camera;
        match spec.eye {
            Some(eye) => {
                let target = match spec.target {
                    Some(t) => t,
                    None => self.bounds()?.0,
                };
                let projection = match spec.projection {
                    Projection::Orthographic { height: 0.0 } => Projection::Orthographic {
                        height: 2.2 * self.bounds()?.1,
                    },
                    p => p,
                };
                Camera::look_at(eye, target, spec.up, projection, width, height)
            }
            None => {
                let (c, r) = self.bounds()?;
                let mut cam =
                    Camera::framing(c, r, spec.view_from, spec.projection, width, height)?;
                if matches!(spec.projection, Projection::Orthographic { height } if height > 0.0) {
                    cam.projection = spec.projection;
                }
                if let Some(t) = spec.target {
                    cam = Camera::look_at(cam.eye, t, spec.up, cam.projection, width, height)?;
                } else if spec.up != [0.0, 0.0, 1.0] {
                    cam = Camera::look_at(cam.eye, c, spec.up, cam.projection, width, height)?;
                }
                Ok(cam)
            }
        }
    }
}

/// Farthest distance from `c` of the solid's surface, estimated along 162 directions
/// from its centre (plus 2% for the surface between them).
fn solid_extent(solid: &ConvexSolid, c: [f64; 3]) -> f64 {
    let tracer = crate::surface::tracer::ImplicitTracer::new(solid);
    let centre = solid.centre();
    let (dirs, _) = crate::geometry::mesh::icosphere(2);
    let mut scratch = Vec::new();
    let mut r: f64 = 0.0;
    for d in dirs {
        let ray = crate::geometry::ray::Ray {
            origin: centre,
            dir: d,
        };
        let t = tracer
            .crossings(&ray, crate::surface::tracer::RayMethod::Paper, &mut scratch)
            .map_or(solid.bounding_radius(), |x| x.t_out);
        let p = ray.at(t);
        r = r.max(((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt());
    }
    1.02 * r
}

/// The texture wrap mode of a model's domain, or an error if it has no texture space.
pub fn texture_wrap(model: &SurfaceModel) -> Result<Wrap> {
    Wrap::of(&model.domain).ok_or_else(|| {
        RenderError::parameter(
            "texture",
            format!(
                "domain {:?} has no texture coordinates (sphere S^2 and torus do)",
                model.domain
            ),
        )
    })
}

// ---- the file format -------------------------------------------------------------

/// Largest colour component or light and material coefficient: far above white, far
/// below where shading sums overflow.
const MAX_COEFFICIENT: f64 = 1e3;
/// Largest shininess exponent.
const MAX_SHININESS: f64 = 1e4;

fn check_number(what: &str, v: f64, lo: f64, hi: f64) -> Result<f64> {
    if v >= lo && v <= hi {
        Ok(v)
    } else {
        Err(RenderError::Scene(format!(
            "{what}: {v:e} is outside [{lo:e}, {hi:e}]"
        )))
    }
}

fn check_colour(what: &str, c: [f64; 3]) -> Result<[f32; 3]> {
    if c.iter().all(|v| (0.0..=MAX_COEFFICIENT).contains(v)) {
        Ok(srgb_to_linear(c))
    } else {
        Err(RenderError::Scene(format!(
            "{what}: colour components must be in [0, {MAX_COEFFICIENT:e}], got {c:?}"
        )))
    }
}

/// Checks a position or direction: coordinates within the world the renderers keep
/// precision in (the same bound as solids' centres).
fn check_vec(what: &str, v: [f64; 3]) -> Result<[f64; 3]> {
    let limit = crate::surface::implicit::WORLD_LIMIT;
    if v.iter().all(|x| x.abs() <= limit) {
        Ok(v)
    } else {
        Err(RenderError::Scene(format!(
            "{what}: components must be within [-{limit:e}, {limit:e}], got {v:?}"
        )))
    }
}

fn field<E: std::fmt::Display>(path: &str) -> impl Fn(E) -> RenderError + '_ {
    move |e| RenderError::Scene(format!("{path}: {e}"))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileScene {
    format: String,
    #[serde(default)]
    name: String,
    #[serde(default)]
    camera: Option<FileCamera>,
    #[serde(default = "default_background")]
    background: [f64; 3],
    #[serde(default)]
    ambient: Option<[f64; 3]>,
    #[serde(default)]
    lights: Option<Vec<FileLight>>,
    objects: Vec<FileObject>,
}

fn white() -> [f64; 3] {
    [1.0; 3]
}

/// Background colour (sRGB) when a scene gives none.
pub const DEFAULT_BACKGROUND: [f64; 3] = [0.96, 0.96, 0.96];

fn default_background() -> [f64; 3] {
    DEFAULT_BACKGROUND
}

#[derive(Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "snake_case")]
enum FileProjection {
    #[default]
    Perspective,
    Orthographic,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileCamera {
    #[serde(default)]
    projection: FileProjection,
    #[serde(default)]
    eye: Option<[f64; 3]>,
    #[serde(default)]
    target: Option<[f64; 3]>,
    #[serde(default)]
    up: Option<[f64; 3]>,
    #[serde(default)]
    view_from: Option<[f64; 3]>,
    #[serde(default)]
    fov_deg: Option<f64>,
    #[serde(default)]
    height: Option<f64>,
}

impl FileCamera {
    fn resolve(self) -> Result<CameraSpec> {
        let d = CameraSpec::default();
        let projection = match self.projection {
            FileProjection::Perspective => {
                if self.height.is_some() {
                    return Err(RenderError::Scene(
                        "camera.height: only for orthographic cameras".into(),
                    ));
                }
                let fov = self.fov_deg.unwrap_or(30.0);
                if !(fov > 0.0 && fov < 179.0) {
                    return Err(RenderError::Scene(format!(
                        "camera.fov_deg: {fov} is not in (0, 179)"
                    )));
                }
                Projection::Perspective { fov_y_deg: fov }
            }
            FileProjection::Orthographic => {
                if self.fov_deg.is_some() {
                    return Err(RenderError::Scene(
                        "camera.fov_deg: only for perspective cameras".into(),
                    ));
                }
                let h = self.height.unwrap_or(0.0);
                if self.height.is_some() {
                    let limit = crate::surface::implicit::WORLD_LIMIT;
                    check_number("camera.height", h, SCALE_RANGE.0, 2.0 * limit)?;
                }
                // Height 0 means "fit the scene" (see `Scene::camera`).
                Projection::Orthographic { height: h }
            }
        };
        Ok(CameraSpec {
            eye: self.eye.map(|v| check_vec("camera.eye", v)).transpose()?,
            target: self
                .target
                .map(|v| check_vec("camera.target", v))
                .transpose()?,
            up: check_vec("camera.up", self.up.unwrap_or(d.up))?,
            view_from: check_vec("camera.view_from", self.view_from.unwrap_or(d.view_from))?,
            projection,
        })
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileLight {
    direction: [f64; 3],
    #[serde(default = "white")]
    colour: [f64; 3],
    #[serde(default = "one")]
    intensity: f64,
}

fn one() -> f64 {
    1.0
}

impl FileLight {
    fn resolve(&self, path: &str) -> Result<Light> {
        let d = check_vec(&format!("{path}.direction"), self.direction)?;
        if d == [0.0; 3] {
            return Err(RenderError::Scene(format!(
                "{path}.direction: must be non-zero"
            )));
        }
        check_number(
            &format!("{path}.intensity"),
            self.intensity,
            0.0,
            MAX_COEFFICIENT,
        )?;
        Ok(Light::new(
            d,
            check_colour(&format!("{path}.colour"), self.colour)?,
            self.intensity as f32,
        ))
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileMaterial {
    #[serde(default)]
    colour: Option<[f64; 3]>,
    #[serde(default)]
    ambient: Option<f64>,
    #[serde(default)]
    diffuse: Option<f64>,
    #[serde(default)]
    specular: Option<f64>,
    #[serde(default)]
    shininess: Option<f64>,
    #[serde(default)]
    texture: Option<String>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct FileTransform {
    #[serde(default)]
    scale: Option<ScaleSpec>,
    #[serde(default)]
    rotate_deg: Option<[f64; 3]>,
    #[serde(default)]
    translate: Option<[f64; 3]>,
}

impl FileTransform {
    fn resolve(&self, path: &str) -> Result<Affine> {
        Ok(Affine::from_parts(
            scale_of(path, &self.scale).map_err(|e| RenderError::Scene(e.to_string()))?,
            check_vec(
                &format!("{path}.rotate_deg"),
                self.rotate_deg.unwrap_or([0.0; 3]),
            )?,
            check_vec(
                &format!("{path}.translate"),
                self.translate.unwrap_or([0.0; 3]),
            )?,
        ))
    }
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "snake_case")]
enum FileOp {
    Union,
    Intersection,
    Difference,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileCsg {
    op: FileOp,
    operands: Vec<FileOperand>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileOperand {
    #[serde(default)]
    solid: Option<FileSolid>,
    #[serde(default)]
    csg: Option<FileCsg>,
}

impl FileCsg {
    fn resolve(&self, path: &str, solids: &mut Vec<ConvexSolid>) -> Result<CsgNode> {
        if self.operands.len() < 2 {
            return Err(RenderError::Scene(format!(
                "{path}.operands: need at least two"
            )));
        }
        let mut nodes = Vec::with_capacity(self.operands.len());
        for (i, o) in self.operands.iter().enumerate() {
            let p = format!("{path}.operands[{i}]");
            nodes.push(match (&o.solid, &o.csg) {
                (Some(s), None) => {
                    solids.push(
                        s.resolve(&format!("{p}.solid"))
                            .map_err(|e| RenderError::Scene(e.to_string()))?,
                    );
                    CsgNode::Solid(solids.len() as u32 - 1)
                }
                (None, Some(c)) => c.resolve(&format!("{p}.csg"), solids)?,
                _ => {
                    return Err(RenderError::Scene(format!(
                        "{p}: give exactly one of `solid` or `csg`"
                    )))
                }
            });
        }
        Ok(match self.op {
            FileOp::Union => CsgNode::Union(nodes),
            FileOp::Intersection => CsgNode::Intersection(nodes),
            FileOp::Difference => CsgNode::Difference(nodes),
        })
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileObject {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    surface: Option<String>,
    #[serde(default)]
    transform: Option<FileTransform>,
    #[serde(default)]
    detail: Option<u32>,
    #[serde(default)]
    solid: Option<FileSolid>,
    #[serde(default)]
    csg: Option<FileCsg>,
    #[serde(default)]
    frep: Option<serde_json::Value>,
    #[serde(default)]
    bounds: Option<FileBounds>,
    #[serde(default)]
    material: FileMaterial,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileBounds {
    min: [f64; 3],
    max: [f64; 3],
}

/// Loads a surface model by file name (relative to `base`) or `builtin:NAME`; returns
/// the model and the file it came from.
pub fn load_surface(spec: &str, base: &Path) -> Result<(SurfaceModel, Option<PathBuf>)> {
    if let Some(name) = spec.strip_prefix("builtin:") {
        let model = gallery::by_name(name).ok_or_else(|| {
            RenderError::Scene(format!(
                "unknown built-in model `{name}`; known: {}",
                gallery::NAMES.join(", ")
            ))
        })??;
        return Ok((model, None));
    }
    let path = base.join(spec);
    Ok((SurfaceModel::load(&path)?, Some(path)))
}

impl FileObject {
    fn resolve(self, path: &str, base: &Path) -> Result<SceneObject> {
        let name = self.name.clone().unwrap_or_else(|| path.to_string());
        let mut material = Material::default();
        let fm = &self.material;
        let mp = format!("{path}.material");
        if let Some(c) = fm.colour {
            material.colour = check_colour(&format!("{mp}.colour"), c)?;
        }
        for (what, v, dst) in [
            ("ambient", fm.ambient, &mut material.ambient),
            ("diffuse", fm.diffuse, &mut material.diffuse),
            ("specular", fm.specular, &mut material.specular),
            ("shininess", fm.shininess, &mut material.shininess),
        ] {
            if let Some(v) = v {
                let hi = if what == "shininess" {
                    MAX_SHININESS
                } else {
                    MAX_COEFFICIENT
                };
                *dst = check_number(&format!("{mp}.{what}"), v, 0.0, hi)? as f32;
            }
        }
        let kinds = [
            self.surface.is_some(),
            self.solid.is_some(),
            self.csg.is_some(),
            self.frep.is_some(),
        ];
        if kinds.iter().filter(|k| **k).count() != 1 {
            return Err(RenderError::Scene(format!(
                "{path}: give exactly one of `surface`, `solid`, `csg` or `frep`"
            )));
        }
        if self.bounds.is_some() && self.frep.is_none() {
            return Err(RenderError::Scene(format!(
                "{path}.bounds: only for `frep` objects"
            )));
        }
        if self.surface.is_none() && (self.transform.is_some() || self.detail.is_some()) {
            return Err(RenderError::Scene(format!(
                "{path}: `transform` and `detail` apply to surfaces (solids take centre, scale, rotate_deg)"
            )));
        }
        let shape = if let Some(v) = &self.frep {
            if fm.texture.is_some() {
                return Err(RenderError::Scene(format!(
                    "{mp}.texture: F-rep solids have no domain to carry a texture"
                )));
            }
            if self.transform.is_some() || self.detail.is_some() {
                return Err(RenderError::Scene(format!(
                    "{path}: an F-rep object is placed by a `transform` node inside `frep`"
                )));
            }
            let node = crate::frep::Node::from_json(v, &format!("{path}.frep"), base)
                .map_err(|e| RenderError::Scene(e.to_string()))?;
            let bounds = match &self.bounds {
                Some(b) => {
                    let lo = check_vec(&format!("{path}.bounds.min"), b.min)?;
                    let hi = check_vec(&format!("{path}.bounds.max"), b.max)?;
                    if (0..3).any(|k| !(lo[k] < hi[k])) {
                        return Err(RenderError::Scene(format!(
                            "{path}.bounds: min must be below max on every axis"
                        )));
                    }
                    crate::frep::Aabb::new(lo, hi)
                }
                None => node.bounds().filter(|b| b.is_bounded() && b.longest() > 0.0).ok_or_else(|| {
                    RenderError::Scene(format!(
                        "{path}: the model's extent is unbounded (a half-space or quadric); give `bounds`: {{\"min\": [..], \"max\": [..]}}"
                    ))
                })?,
            };
            Shape::Field {
                node: Arc::new(node),
                bounds,
            }
        } else if let Some(spec) = &self.surface {
            let (model, file) = load_surface(spec, base).map_err(|e| match e {
                RenderError::Scene(m) => RenderError::Scene(format!("{path}.surface: {m}")),
                other => RenderError::Scene(format!("{path}.surface: {other}")),
            })?;
            let texture = match &fm.texture {
                Some(t) => Some(base.join(t)),
                None => model.texture_path(file.as_deref()),
            };
            if let Some(t) = texture {
                let wrap = texture_wrap(&model).map_err(field(&format!("{mp}.texture")))?;
                let tex = Texture::load(&t).map_err(field(&format!("{mp}.texture")))?;
                material.texture = Some((Arc::new(tex), wrap));
                if fm.colour.is_none() {
                    material.colour = [1.0; 3];
                }
            }
            if let Some(d) = self.detail {
                if d > 9 {
                    return Err(RenderError::Scene(format!(
                        "{path}.detail: {d} must be at most 9"
                    )));
                }
            }
            let place = match &self.transform {
                Some(t) => t.resolve(&format!("{path}.transform"))?,
                None => Affine::IDENTITY,
            };
            if place.det().abs() < 1e-300 {
                return Err(RenderError::Scene(format!("{path}.transform: singular")));
            }
            Shape::Surface {
                model,
                place,
                detail: self.detail,
            }
        } else {
            if fm.texture.is_some() {
                return Err(RenderError::Scene(format!(
                    "{mp}.texture: solids have no domain to carry a texture"
                )));
            }
            let mut solids = Vec::new();
            let csg = if let Some(s) = &self.solid {
                solids.push(
                    s.resolve(&format!("{path}.solid"))
                        .map_err(|e| RenderError::Scene(e.to_string()))?,
                );
                CsgNode::Solid(0)
            } else {
                self.csg
                    .as_ref()
                    .expect("checked above")
                    .resolve(&format!("{path}.csg"), &mut solids)?
            };
            Shape::Solid { solids, csg }
        };
        Ok(SceneObject {
            name,
            shape,
            material,
        })
    }
}
