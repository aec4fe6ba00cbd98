//! The scene file: JSON in the style of surface model files (a `format` tag, snake_case
//! fields, unknown fields rejected, errors naming the offending field such as
//! `objects[2].solid.q`). The format is specified in `docs/rendering.md`.

use caoen_base::budget::Limits;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Deserialize;

use super::cae_texture::CaeSource;
use super::camera::Projection;
use super::csg::CsgNode;
use super::error::{RenderError, Result};
use super::framebuffer::srgb_to_linear;
use super::image_map::{ImageMap, MapType};
use super::light_file::FileLight;
use super::pattern::Checker;
use super::scene::{
    texture_wrap, CameraSpec, Scene, SceneObject, Shape, DEFAULT_MAX_DEPTH, MAX_MAX_DEPTH,
    SCENE_FORMAT_TAG,
};
use super::shading::{Lighting, Material};
use super::texture::Texture;
use caoen_frep::convex_solid::{scale_of, FileSolid, ScaleSpec, SCALE_RANGE};
use caoen_geometry::transform::Affine;
use caoen_surface::json::FieldError;
use caoen_surface::{gallery, ConvexSolid, SurfaceModel};

/// A field error of the scene file: `reason` about the value at `field`.
pub(crate) fn bad(field: impl Into<String>, reason: impl Into<String>) -> RenderError {
    RenderError::Field(FieldError::from_reason(field, reason))
}

impl Scene {
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

    /// Loads a scene file within `limits` (the surfaces, models and textures it names
    /// too); files it names are resolved against its directory.
    pub fn load(path: &Path, limits: &Limits) -> Result<Scene> {
        let text = limits
            .read_to_string(path)
            .map_err(|e| RenderError::io(path, e))?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Scene::from_json(&text, &base, limits)
            .map_err(|e| match e {
                RenderError::Field(f) => RenderError::Field(f.in_file(path)),
                other => other,
            })
            .map_err(RenderError::printable)
    }

    /// Parses a scene (exactly one JSON value, nothing after it); relative file names
    /// are resolved against `base_dir`, and what they hold loaded within `limits`.
    pub fn from_json(text: &str, base_dir: &Path, limits: &Limits) -> Result<Scene> {
        Self::parse_json(text, base_dir, limits).map_err(RenderError::printable)
    }

    fn parse_json(text: &str, base_dir: &Path, limits: &Limits) -> Result<Scene> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let file: FileScene = serde_path_to_error::deserialize(&mut *de)
            .map_err(|e| RenderError::Field(FieldError::from_path_error("", &e)))?;
        // Data after the value is a damaged or concatenated file, not a scene to trust.
        de.end().map_err(|e| {
            RenderError::Field(FieldError::parse("", &format!("after the scene: {e}")))
        })?;
        if file.format != SCENE_FORMAT_TAG {
            return Err(RenderError::Field(FieldError::new(
                "format",
                format!("\"{SCENE_FORMAT_TAG}\""),
                format!("\"{}\"", file.format),
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
            return Err(bad("objects", "a scene needs at least one object"));
        }
        let objects = file
            .objects
            .into_iter()
            .enumerate()
            .map(|(i, o)| o.resolve(&format!("objects[{i}]"), base_dir, limits))
            .collect::<Result<_>>()?;
        let max_depth = match file.max_depth {
            None => DEFAULT_MAX_DEPTH,
            Some(d) if (1..=u64::from(MAX_MAX_DEPTH)).contains(&d) => d as u32,
            Some(d) => {
                return Err(RenderError::Field(FieldError::new(
                    "max_depth",
                    format!("an integer in 1..={MAX_MAX_DEPTH}"),
                    d.to_string(),
                )))
            }
        };
        Ok(Scene {
            name: file.name,
            camera,
            background: check_colour("background", file.background)?,
            lighting,
            objects,
            shadows: file.shadows.unwrap_or(true),
            max_depth,
        })
    }
}

/// Largest colour component or light and material coefficient: far above white, far
/// below where shading sums overflow.
pub(crate) const MAX_COEFFICIENT: f64 = 1e3;
/// Largest shininess exponent.
const MAX_SHININESS: f64 = 1e4;
/// Largest index of refraction (well above any real material's).
const MAX_IOR: f64 = 10.0;

pub(crate) fn check_number(what: &str, v: f64, lo: f64, hi: f64) -> Result<f64> {
    Ok(caoen_surface::json::check_number(what, v, lo, hi)?)
}

pub(crate) fn check_colour(what: &str, c: [f64; 3]) -> Result<[f32; 3]> {
    if c.iter().all(|v| (0.0..=MAX_COEFFICIENT).contains(v)) {
        Ok(srgb_to_linear(c))
    } else {
        Err(RenderError::Field(FieldError::new(
            what,
            format!("colour components in [0, {MAX_COEFFICIENT:e}]"),
            format!("{c:?}"),
        )))
    }
}

/// Checks a position or direction: coordinates within the world the renderers keep
/// precision in (the same bound as solids' centres).
pub(crate) fn check_vec(what: &str, v: [f64; 3]) -> Result<[f64; 3]> {
    let limit = caoen_surface::implicit::WORLD_LIMIT;
    if v.iter().all(|x| x.abs() <= limit) {
        Ok(v)
    } else {
        Err(RenderError::Field(FieldError::new(
            what,
            format!("components within [-{limit:e}, {limit:e}]"),
            format!("{v:?}"),
        )))
    }
}

fn field<E: std::fmt::Display>(path: &str) -> impl Fn(E) -> RenderError + '_ {
    move |e| RenderError::Field(FieldError::new(path, "", e.to_string()))
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
    #[serde(default)]
    shadows: Option<bool>,
    #[serde(default)]
    max_depth: Option<u64>,
    objects: Vec<FileObject>,
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
                    return Err(bad("camera.height", "only for orthographic cameras"));
                }
                let fov = self.fov_deg.unwrap_or(30.0);
                if !(fov > 0.0 && fov < 179.0) {
                    return Err(bad("camera.fov_deg", format!("{fov} is not in (0, 179)")));
                }
                Projection::Perspective { fov_y_deg: fov }
            }
            FileProjection::Orthographic => {
                if self.fov_deg.is_some() {
                    return Err(bad("camera.fov_deg", "only for perspective cameras"));
                }
                let h = self.height.unwrap_or(0.0);
                if self.height.is_some() {
                    let limit = caoen_surface::implicit::WORLD_LIMIT;
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
    #[serde(default)]
    image_map: Option<FileImageMap>,
    #[serde(default)]
    checker: Option<FileChecker>,
    #[serde(default)]
    normal: Option<super::bump::FileNormal>,
    #[serde(default)]
    reflect: Option<f64>,
    #[serde(default)]
    transmit: Option<f64>,
    #[serde(default)]
    ior: Option<f64>,
}

/// `material.checker`: POV-Ray's `checker` pigment of two colours, with its transform.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileChecker {
    colours: [[f64; 3]; 2],
    #[serde(default)]
    scale: Option<ScaleSpec>,
    #[serde(default)]
    rotate_deg: Option<[f64; 3]>,
    #[serde(default)]
    translate: Option<[f64; 3]>,
}

impl FileChecker {
    fn resolve(&self, path: &str) -> Result<Checker> {
        let colours =
            [0, 1].map(|k| check_colour(&format!("{path}.colours[{k}]"), self.colours[k]));
        let [a, b] = colours;
        let transform = Affine::from_parts(
            scale_of(path, &self.scale)?,
            check_vec(
                &format!("{path}.rotate_deg"),
                self.rotate_deg.unwrap_or([0.0; 3]),
            )?,
            check_vec(
                &format!("{path}.translate"),
                self.translate.unwrap_or([0.0; 3]),
            )?,
        );
        Checker::new([a?, b?], transform)
            .ok_or_else(|| bad(path, "the texture transform is singular (a zero scale)"))
    }
}

/// `material.image_map`: an image projected onto the object (POV-Ray's `image_map`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileImageMap {
    image: String,
    #[serde(default)]
    map_type: Option<serde_json::Value>,
    #[serde(default)]
    interpolate: Option<u32>,
    #[serde(default)]
    scale: Option<ScaleSpec>,
    #[serde(default)]
    rotate_deg: Option<[f64; 3]>,
    #[serde(default)]
    translate: Option<[f64; 3]>,
}

impl FileImageMap {
    fn resolve(&self, path: &str, base: &Path, limits: &Limits) -> Result<ImageMap> {
        let map = match &self.map_type {
            None => MapType::Planar,
            Some(v) => MapType::parse(v).ok_or_else(|| {
                bad(
                    format!("{path}.map_type"),
                    format!("{v} is not 0 (planar), 1 (spherical) or 2 (cylindrical)"),
                )
            })?,
        };
        let bilinear = match self.interpolate {
            None | Some(2) => true,
            Some(0) => false,
            Some(n) => {
                return Err(bad(
                    format!("{path}.interpolate"),
                    format!("{n} is not 0 (nearest texel) or 2 (bilinear)"),
                ))
            }
        };
        let transform = Affine::from_parts(
            scale_of(path, &self.scale)?,
            check_vec(
                &format!("{path}.rotate_deg"),
                self.rotate_deg.unwrap_or([0.0; 3]),
            )?,
            check_vec(
                &format!("{path}.translate"),
                self.translate.unwrap_or([0.0; 3]),
            )?,
        );
        if !(transform.det().abs() > 1e-300) {
            return Err(bad(
                path,
                "the texture transform is singular (a zero scale)",
            ));
        }
        let file = base.join(&self.image);
        // Absolute, so an exported `.pov` finds the image from any directory.
        let file = std::fs::canonicalize(&file).map_err(|e| {
            bad(
                format!("{path}.image"),
                format!("cannot open {}: {e}", file.display()),
            )
        })?;
        if file.to_string_lossy().contains('"') {
            return Err(bad(
                format!("{path}.image"),
                "a file name with `\"` cannot be exported",
            ));
        }
        let image = format!("{path}.image");
        let (tex, cae) = if super::cae_texture::is_cae(&file) {
            // Decoded at its own size here, so a damaged file is refused with the scene;
            // a render decodes it again at the size its footprint asks for.
            let src = CaeSource::load(&file, limits).map_err(field(&image))?;
            let tex = src.texture(src.size(), 0, limits).map_err(field(&image))?;
            (tex, Some(Arc::new(src)))
        } else {
            (Texture::load(&file, limits).map_err(field(&image))?, None)
        };
        let mut m = ImageMap::new(Arc::new(tex), file, map, bilinear, transform)
            .ok_or_else(|| bad(path, "the texture transform is singular"))?;
        m.cae = cae;
        Ok(m)
    }
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
            scale_of(path, &self.scale)?,
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
            return Err(bad(format!("{path}.operands"), "need at least two"));
        }
        let mut nodes = Vec::with_capacity(self.operands.len());
        for (i, o) in self.operands.iter().enumerate() {
            let p = format!("{path}.operands[{i}]");
            nodes.push(match (&o.solid, &o.csg) {
                (Some(s), None) => {
                    solids.push(s.resolve(&format!("{p}.solid"))?);
                    CsgNode::Solid(solids.len() as u32 - 1)
                }
                (None, Some(c)) => c.resolve(&format!("{p}.csg"), solids)?,
                _ => return Err(bad(p, "give exactly one of `solid` or `csg`")),
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
pub fn load_surface(
    spec: &str,
    base: &Path,
    limits: &Limits,
) -> Result<(SurfaceModel, Option<PathBuf>)> {
    if let Some(name) = spec.strip_prefix("builtin:") {
        let model = gallery::by_name(name).ok_or_else(|| {
            RenderError::Field(FieldError::new(
                "",
                format!("one of the built-in models {}", gallery::NAMES.join(", ")),
                format!("unknown built-in model `{name}`"),
            ))
        })??;
        return Ok((model, None));
    }
    let path = base.join(spec);
    Ok((SurfaceModel::load(&path, limits)?, Some(path)))
}

impl FileObject {
    fn resolve(self, path: &str, base: &Path, limits: &Limits) -> Result<SceneObject> {
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
        for (what, v, dst) in [
            ("reflect", fm.reflect, &mut material.reflect),
            ("transmit", fm.transmit, &mut material.transmit),
        ] {
            if let Some(v) = v {
                *dst = check_number(&format!("{mp}.{what}"), v, 0.0, 1.0)? as f32;
            }
        }
        if let Some(v) = fm.ior {
            material.ior = check_number(&format!("{mp}.ior"), v, 1.0, MAX_IOR)?;
        }
        let kinds = [
            self.surface.is_some(),
            self.solid.is_some(),
            self.csg.is_some(),
            self.frep.is_some(),
        ];
        if kinds.iter().filter(|k| **k).count() != 1 {
            return Err(bad(
                path,
                "give exactly one of `surface`, `solid`, `csg` or `frep`",
            ));
        }
        if self.bounds.is_some() && self.frep.is_none() {
            return Err(bad(format!("{path}.bounds"), "only for `frep` objects"));
        }
        if self.surface.is_none() && (self.transform.is_some() || self.detail.is_some()) {
            return Err(bad(path, "`transform` and `detail` apply to surfaces (solids take centre, scale, rotate_deg)"));
        }
        if let Some(c) = &fm.checker {
            if fm.colour.is_some() || fm.texture.is_some() || fm.image_map.is_some() {
                return Err(bad(
                    format!("{mp}.checker"),
                    "gives the colour: leave out `colour`, `texture` and `image_map`",
                ));
            }
            material.checker = Some(Arc::new(c.resolve(&format!("{mp}.checker"))?));
            material.colour = [1.0; 3];
        }
        if let Some(n) = &fm.normal {
            material.normal = Some(Arc::new(n.resolve(&format!("{mp}.normal"))?));
        }
        if let Some(im) = &fm.image_map {
            if fm.colour.is_some() || fm.texture.is_some() {
                return Err(bad(
                    format!("{mp}.image_map"),
                    "gives the colour: leave out `colour` and `texture`",
                ));
            }
            let m = im.resolve(&format!("{mp}.image_map"), base, limits)?;
            material.image_map = Some(Arc::new(m));
            material.colour = [1.0; 3];
        }
        let shape = if let Some(v) = &self.frep {
            if fm.texture.is_some() {
                return Err(bad(
                    format!("{mp}.texture"),
                    "F-rep solids have no domain to carry a texture; project one with `image_map`",
                ));
            }
            if self.transform.is_some() || self.detail.is_some() {
                return Err(bad(
                    path,
                    "an F-rep object is placed by a `transform` node inside `frep`",
                ));
            }
            let node = caoen_frep::Node::from_json(v, &format!("{path}.frep"), base, limits)?;
            let bounds = match &self.bounds {
                Some(b) => {
                    let lo = check_vec(&format!("{path}.bounds.min"), b.min)?;
                    let hi = check_vec(&format!("{path}.bounds.max"), b.max)?;
                    if (0..3).any(|k| !(lo[k] < hi[k])) {
                        return Err(bad(format!("{path}.bounds"), "min must be below max on every axis"));
                    }
                    caoen_frep::Aabb::new(lo, hi)
                }
                None => node.bounds().filter(|b| b.is_bounded() && b.longest() > 0.0).ok_or_else(|| {
                    bad(path, "the model's extent is unbounded (a half-space or quadric); give `bounds`: {\"min\": [..], \"max\": [..]}")
                })?,
            };
            Shape::Field {
                node: Arc::new(node),
                bounds,
            }
        } else if let Some(spec) = &self.surface {
            let (model, file) = load_surface(spec, base, limits).map_err(|e| match e {
                RenderError::Field(f) => RenderError::Field(f.under(&format!("{path}.surface"))),
                other => bad(format!("{path}.surface"), other.to_string()),
            })?;
            let texture = match &fm.texture {
                Some(t) => Some(base.join(t)),
                None => model.texture_path(file.as_deref()),
            };
            if let Some(t) = texture {
                let wrap = texture_wrap(&model).map_err(field(&format!("{mp}.texture")))?;
                let what = format!("{mp}.texture");
                let tex = if super::cae_texture::is_cae(&t) {
                    let src = CaeSource::load(&t, limits).map_err(field(&what))?;
                    let tex = src.texture(src.size(), 0, limits).map_err(field(&what))?;
                    material.texture_cae = Some(Arc::new(src));
                    tex
                } else {
                    Texture::load(&t, limits).map_err(field(&what))?
                };
                material.texture = Some((Arc::new(tex), wrap));
                if fm.colour.is_none() {
                    material.colour = [1.0; 3];
                }
            }
            if let Some(d) = self.detail {
                if d > 9 {
                    return Err(bad(
                        format!("{path}.detail"),
                        format!("{d} must be at most 9"),
                    ));
                }
            }
            let place = match &self.transform {
                Some(t) => t.resolve(&format!("{path}.transform"))?,
                None => Affine::IDENTITY,
            };
            if place.det().abs() < 1e-300 {
                return Err(bad(format!("{path}.transform"), "singular"));
            }
            Shape::Surface {
                model,
                place,
                detail: self.detail,
            }
        } else {
            if fm.texture.is_some() {
                return Err(bad(
                    format!("{mp}.texture"),
                    "solids have no domain to carry a texture; project one with `image_map`",
                ));
            }
            let mut solids = Vec::new();
            let csg = if let Some(s) = &self.solid {
                solids.push(s.resolve(&format!("{path}.solid"))?);
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
