//! POV-Ray export of scenes: a `.pov` scene that POV-Ray renders as the same picture.
//!
//! Every F-rep object is an `isosurface` of the negated model function (POV-Ray's
//! inside is below the threshold, F-rep's is `f >= 0`), its function declared by
//! `frep::pov`; every Cao En surface a `mesh2` with the network's exact normals and its
//! texture by `uv_mapping` (`pov_mesh`). The camera is caoen's resolved camera (same
//! eye, direction, up and field of view), the lights are POV-Ray's light sources of
//! the same kind (directional lights as parallel ones), shadows as the scene has them.
//! Materials map to POV-Ray's finish, pigment transmit and interior so that its
//! reflection, refraction and shadows are `render::rays`'s. Convex solids and their
//! CSG are not exported.

use std::fmt::Write as _;

use super::camera::{Camera, Projection};
use super::lights::{Light, LightKind};
use super::scene::{Scene, Shape};
use caoen_frep::pov::{
    declare, max_gradient_with, num, unexportable, v3, Unexportable, R_FUNCTIONS,
};

/// Why a scene cannot be exported.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PovError {
    /// A convex solid or a CSG expression of them.
    #[error("object {index} (`{name}`) is a convex solid or CSG of them, which is not exported (F-rep objects and Cao En surfaces are); write it as an F-rep model (`cao_en_solid`, `union`, ...)")]
    NotFrep {
        /// The object's position in the scene.
        index: usize,
        /// The object's name.
        name: String,
    },
    /// An F-rep object holding something POV-Ray cannot draw.
    #[error("object {index} (`{name}`): {why}")]
    Unexportable {
        /// The object's position in the scene.
        index: usize,
        /// The object's name.
        name: String,
        /// What cannot be drawn.
        why: Unexportable,
    },
    /// A Cao En surface that cannot be written as a mesh.
    #[error("object {index} (`{name}`), a Cao En surface: {why}")]
    Surface {
        /// The object's position in the scene.
        index: usize,
        /// The object's name.
        name: String,
        /// Why.
        why: String,
    },
}

/// The POV-Ray scene of `scene` seen by `camera`: every F-rep object as an isosurface,
/// every Cao En surface as a mesh; convex solids are not exported (an error names the
/// first).
pub fn export(scene: &Scene, camera: &Camera) -> Result<String, PovError> {
    export_with(
        scene,
        camera,
        &caoen_base::budget::Limits::default(),
        &|_, _| {},
    )
}

/// [`export`] with the surfaces' meshes made within `limits`, calling
/// `progress(done, total)` while the objects' `max_gradient` is measured (most of the
/// time a large model takes).
pub fn export_with(
    scene: &Scene,
    camera: &Camera,
    limits: &caoen_base::budget::Limits,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<String, PovError> {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "// POV-Ray 3.7 scene written by caoen (frep export-pov): the model's function\n\
         // negated as an isosurface, axes swapped (caoen z up = POV-Ray y up).\n\
         #version 3.7;\n\
         global_settings {{ assumed_gamma 1.0 }}"
    );
    let bg = scene.background;
    let _ = writeln!(
        out,
        "background {{ rgb <{}, {}, {}> }}",
        bg[0], bg[1], bg[2]
    );
    let aspect = camera.width as f64 / camera.height as f64;
    let target = [0, 1, 2].map(|k| camera.eye[k] + camera.forward[k]);
    match camera.projection {
        Projection::Perspective { fov_y_deg } => {
            let half_h = (0.5 * fov_y_deg.to_radians()).tan();
            let fov_x = 2.0 * (half_h * aspect).atan().to_degrees();
            let _ = writeln!(
                out,
                "camera {{\n  perspective\n  location {}\n  right x*{}\n  up y\n  sky {}\n  angle {}\n  look_at {}\n}}",
                v3(camera.eye),
                num(aspect),
                v3(camera.up),
                num(fov_x),
                v3(target)
            );
        }
        Projection::Orthographic { height } => {
            let _ = writeln!(
                out,
                "camera {{\n  orthographic\n  location {}\n  right x*{}\n  up y*{}\n  sky {}\n  look_at {}\n}}",
                v3(camera.eye),
                num(height * aspect),
                num(height),
                v3(camera.up),
                v3(target)
            );
        }
    }
    let amb = scene.lighting.ambient;
    let _ = writeln!(
        out,
        "global_settings {{ ambient_light rgb <{}, {}, {}> max_trace_level {} adc_bailout 1/255 }}",
        amb[0], amb[1], amb[2], scene.max_depth
    );
    for l in &scene.lighting.lights {
        let _ = writeln!(out, "{}", light_source(l, scene.shadows));
    }
    out.push_str(R_FUNCTIONS);
    let mut next = 0;
    for (i, obj) in scene.objects.iter().enumerate() {
        let (node, bounds) = match &obj.shape {
            Shape::Field { node, bounds } => (node, bounds),
            Shape::Surface {
                model,
                place,
                detail,
            } => {
                super::pov_mesh::write_mesh2(
                    &mut out,
                    model,
                    (place, *detail),
                    &obj.material,
                    &finish(&obj.material),
                    limits,
                )
                .map_err(|why| PovError::Surface {
                    index: i,
                    name: obj.name.clone(),
                    why,
                })?;
                continue;
            }
            Shape::Solid { .. } => {
                return Err(PovError::NotFrep {
                    index: i,
                    name: obj.name.clone(),
                })
            }
        };
        if let Some(why) = unexportable(node) {
            return Err(PovError::Unexportable {
                index: i,
                name: obj.name.clone(),
                why,
            });
        }
        let top = declare(node, &mut out, &mut next);
        // A little margin so the container never clips the surface.
        let b = bounds.padded(1e-3 * bounds.longest());
        let m = &obj.material;
        let _ = writeln!(
            out,
            "isosurface {{\n  function {{ -{top}(x, z, y) }}\n  contained_by {{ box {{ {}, {} }} }}\n  threshold 0\n  accuracy {}\n  max_gradient {}\n  {}{}\n  {}\n}}",
            v3(b.lo),
            v3(b.hi),
            num(1e-5 * b.longest()),
            num(max_gradient_with(node, &b, 6, progress)),
            pigment(m),
            normal(m),
            finish(m),
        );
    }
    Ok(out)
}

/// A `light_source` block for `l`: a directional light as a `parallel` light far
/// along its direction, a point or spot light where it is, with its fade and area
/// light as POV-Ray's own keywords (an area light samples its whole grid unless it
/// gives `adaptive`, POV-Ray's default).
fn light_source(l: &Light, shadows: bool) -> String {
    let c = l.radiance;
    let mut s = match l.kind {
        LightKind::Directional { direction } => format!(
            "light_source {{ {} color rgb <{}, {}, {}> parallel point_at <0, 0, 0>",
            v3(direction.map(|v| v * 1e4)),
            c[0],
            c[1],
            c[2]
        ),
        LightKind::Point { position } => format!(
            "light_source {{ {} color rgb <{}, {}, {}>",
            v3(position),
            c[0],
            c[1],
            c[2]
        ),
        LightKind::Spot {
            position,
            axis,
            cos_radius,
            cos_falloff,
            tightness,
        } => format!(
            "light_source {{ {} color rgb <{}, {}, {}> spotlight point_at {} radius {} falloff {} tightness {}",
            v3(position),
            c[0],
            c[1],
            c[2],
            v3([0, 1, 2].map(|k| position[k] + axis[k])),
            num(degrees(cos_radius)),
            num(degrees(cos_falloff)),
            num(tightness)
        ),
    };
    if let Some(f) = l.fade {
        let _ = write!(
            s,
            " fade_distance {} fade_power {}",
            num(f.distance),
            num(f.power)
        );
    }
    if let Some(a) = l.area {
        let _ = write!(
            s,
            " area_light {}, {}, {}, {}{}",
            v3(a.axis1),
            v3(a.axis2),
            a.size1,
            a.size2,
            if a.jitter { " jitter" } else { "" }
        );
        if let Some(level) = a.adaptive {
            let _ = write!(s, " adaptive {level}");
        }
    }
    if !shadows {
        s.push_str(" shadowless");
    }
    s.push_str(" }");
    s
}

/// The angle in degrees of cosine `c`, rounded to 1e-9 so that the scene file's
/// angles come back as written (24, not 24.000000000000004).
fn degrees(c: f64) -> f64 {
    (c.clamp(-1.0, 1.0).acos().to_degrees() * 1e9).round() / 1e9
}

/// The finish (and the interior of a transmitting material) of `m`.
fn finish(m: &super::shading::Material) -> String {
    format!(
        "finish {{ ambient {} diffuse {} specular {} roughness {}{} }}{}",
        m.ambient,
        m.diffuse,
        m.specular,
        num(1.0 / m.shininess.max(1.0) as f64),
        reflection(m),
        if m.transmit > 0.0 {
            format!("\n  interior {{ ior {} }}", num(m.ior))
        } else {
            String::new()
        }
    )
}

/// The pigment: the checker or the image map if there is one, else the colour (with
/// `transmit`).
pub(crate) fn pigment(m: &super::shading::Material) -> String {
    if let Some(c) = &m.checker {
        return c.pov_pigment(m.transmit);
    }
    match &m.image_map {
        Some(map) => map.pov_pigment(m.transmit),
        None => format!(
            "pigment {{ rgbt <{}, {}, {}, {}> }}",
            m.colour[0], m.colour[1], m.colour[2], m.transmit
        ),
    }
}

/// The bump pattern's `normal` block on a line of its own, if the material has one.
pub(crate) fn normal(m: &super::shading::Material) -> String {
    m.normal
        .as_ref()
        .map(|b| format!("\n  {}", b.pov_normal()))
        .unwrap_or_default()
}

/// The finish's reflection: constant for an opaque mirror; for a transmitting material
/// Fresnel-weighted up to `reflect`, with the transmitted light reduced by what is
/// reflected (`conserve_energy`), as `render::rays` computes it.
fn reflection(m: &super::shading::Material) -> String {
    if m.transmit > 0.0 {
        format!(
            " reflection {{ 0, {} fresnel on }} conserve_energy",
            m.reflect
        )
    } else if m.reflect > 0.0 {
        format!(" reflection {{ {} }}", m.reflect)
    } else {
        String::new()
    }
}
