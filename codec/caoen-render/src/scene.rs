//! Scenes: a camera, lights and a list of objects with materials; how a scene places
//! its camera and how far its objects reach. Its file form is `scene_file`.

use std::path::Path;
use std::sync::Arc;

use super::camera::{Camera, Projection};
use super::csg::CsgNode;
use super::error::{RenderError, Result};
use super::framebuffer::srgb_to_linear;
pub use super::scene_file::{load_surface, DEFAULT_BACKGROUND};
use super::shading::{Lighting, Material};
use super::texture::{Texture, Wrap};
pub use caoen_frep::convex_solid::{polyhedron_normals, polyhedron_solid, POLYHEDRA};
use caoen_geometry::transform::Affine;
use caoen_surface::{ConvexSolid, SurfaceModel};

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
        node: Arc<caoen_frep::Node>,
        /// A box the solid lies in.
        bounds: caoen_frep::Aabb,
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
    /// Whether lights cast shadows.
    pub shadows: bool,
    /// Longest chain of rays (the primary ray counts 1), POV-Ray's `max_trace_level`.
    pub max_depth: u32,
}

/// Default longest chain of rays (POV-Ray's default `max_trace_level`).
pub const DEFAULT_MAX_DEPTH: u32 = 5;
/// Largest `max_depth` a scene may ask for.
pub const MAX_MAX_DEPTH: u32 = 64;

impl Scene {
    /// A scene of one surface with the default camera, lights and material; the model's
    /// texture (resolved against `model_file`'s directory) is loaded within `limits` if
    /// it has one.
    pub fn from_model(
        model: SurfaceModel,
        model_file: Option<&Path>,
        limits: &caoen_base::budget::Limits,
    ) -> Result<Scene> {
        let mut material = Material::default();
        if let Some(path) = model.texture_path(model_file) {
            material.texture = Some((
                Arc::new(Texture::load(&path, limits)?),
                texture_wrap(&model)?,
            ));
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
            shadows: true,
            max_depth: DEFAULT_MAX_DEPTH,
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
                    let mesh = framing_mesh(model)?;
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
            return Err(RenderError::NoGeometry);
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
                    let mesh = framing_mesh(model)?;
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
    let tracer = caoen_surface::tracer::ImplicitTracer::new(solid);
    let centre = solid.centre();
    let (dirs, _) = caoen_geometry::mesh::icosphere(2);
    let mut scratch = Vec::new();
    let mut r: f64 = 0.0;
    for d in dirs {
        let ray = caoen_geometry::ray::Ray {
            origin: centre,
            dir: d,
        };
        let t = tracer
            .crossings(&ray, caoen_surface::tracer::RayMethod::Paper, &mut scratch)
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

/// A coarse mesh of `model` for framing the camera and bounding the scene: at detail 2
/// (320 triangles) it is a few kilobytes, so it needs no limit of its own.
fn framing_mesh(model: &SurfaceModel) -> Result<caoen_geometry::mesh::Mesh> {
    Ok(caoen_surface::tessellate::tessellate(
        model,
        2,
        caoen_surface::tessellate::NormalMode::Exact,
        &caoen_base::budget::Limits::default(),
    )?)
}
