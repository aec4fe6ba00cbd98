//! Secondary rays: shadow rays towards every light, mirror reflection and refraction
//! with exact dielectric Fresnel weights, to a bounded depth.
//!
//! Every object answers "where does this ray next cross your surface" in the geometry
//! it is drawn with: F-rep solids by interval ray casting (one that is a convex Cao En
//! solid alone by its crossing search), convex solids and their CSG by the crossing
//! search, Cao En surfaces by a triangle hierarchy over their
//! tessellation whose crossing is then moved onto the surface itself by Newton steps
//! on the domain (so the normal there is the network's exact normal), and, under the
//! mesh method, every object by the mesh it was rasterised as.
//!
//! The light model is POV-Ray's (3.7) for a one-layer texture, so exported scenes
//! agree: with opacity `a = 1 - transmit`, a surface leaves
//! `a * (ambient + diffuse) + specular` of local light (each light's share scaled by
//! what its shadow ray lets through: opaque surfaces stop it, each crossing of a
//! transmitting one scales it by `transmit`), plus `R * reflected`, plus
//! `transmit * (1 - R) * refracted`. `R` is `reflect` times the exact dielectric
//! Fresnel reflectance when the material transmits (POV-Ray's `reflection { 0, r
//! fresnel on }` with `conserve_energy`), else `reflect`. Under total internal
//! reflection the reflected ray takes the refracted one's place at full weight. A ray
//! deeper than `max_depth` (the primary ray is depth 1) or of weight below 1/255 is
//! black, as in POV-Ray.

use std::cell::RefCell;

use super::bvh::TriangleBvh;
use super::csg::{first_span, CsgNode};
use super::lights::{area_share, jitter};
use super::scene::{Scene, Shape};
use super::shading::{shade_lit, Incidence, Material, SurfacePoint};
use super::texture::domain_uv;
use caoen_frep::raycast::Caster;
use caoen_geometry::mesh::Mesh;
use caoen_geometry::ray::Ray;
use caoen_geometry::transform::Affine;
use caoen_geometry::vector::{add, dot, scale, sub};
use caoen_surface::normals::point_and_normal;
use caoen_surface::tracer::{ImplicitTracer, RayMethod};
use caoen_surface::SurfaceModel;

/// Weight below which a ray is not traced (POV-Ray's default `adc_bailout`).
const BAILOUT: f32 = 1.0 / 255.0;
/// Most surfaces a shadow ray passes through before the light counts as blocked.
const MAX_SHADOW_CROSSINGS: usize = 32;

/// Where a ray crosses an object's surface.
#[derive(Debug, Clone, Copy)]
pub struct SurfaceHit {
    /// Ray parameter.
    pub t: f64,
    /// Unit normal, outward where the object has an inside, else as the surface has it.
    pub normal: [f64; 3],
    /// Texture coordinates (NaN without).
    pub uv: [f32; 2],
    /// Object index.
    pub object: u32,
}

/// One object's ray query.
enum Target<'a> {
    /// A Cao En surface: its tessellation's hierarchy, refined onto the surface.
    Surface {
        model: &'a SurfaceModel,
        place: &'a Affine,
        bvh: TriangleBvh,
        mesh: Mesh,
    },
    /// A rasterised mesh (mesh method): interpolated vertex normals.
    Mesh { bvh: TriangleBvh, mesh: Mesh },
    /// Convex solids under a CSG expression.
    Solids {
        tracers: Vec<ImplicitTracer>,
        csg: &'a CsgNode,
        method: RayMethod,
    },
    /// An F-rep solid that is a convex Cao En solid alone: its own crossing search.
    Convex(&'a ImplicitTracer),
    /// An F-rep solid.
    Field {
        caster: Caster<'a>,
        node: &'a caoen_frep::Node,
    },
}

/// A scene ready for secondary rays.
pub struct RayScene<'a> {
    scene: &'a Scene,
    targets: Vec<Target<'a>>,
    /// Distance a secondary ray starts beyond its surface (self-intersection guard).
    eps: f64,
    /// The budget reservations of the meshes and hierarchies the targets hold.
    _held: Vec<caoen_base::budget::Reservation>,
}

thread_local! {
    static SCRATCH: RefCell<Vec<[f64; 2]>> = const { RefCell::new(Vec::new()) };
    /// An area light's samples at the point being shaded.
    static AREA_GRID: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

impl<'a> RayScene<'a> {
    /// The ray queries of `scene`'s objects. `meshes[i]` is object `i`'s mesh when it
    /// was drawn as one (mesh method); its secondary rays then meet that mesh.
    /// `scene_radius` scales the self-intersection guard.
    pub fn new(
        scene: &'a Scene,
        meshes: Vec<Option<Mesh>>,
        ray_method: RayMethod,
        scene_radius: f64,
        limits: &caoen_base::budget::Limits,
    ) -> crate::error::Result<Self> {
        let mut targets = Vec::with_capacity(scene.objects.len());
        let mut held = Vec::new();
        let mut reserve = |what: &str, bytes: u64| {
            limits
                .reserve(|| what.to_string(), bytes)
                .map(|r| held.push(r))
        };
        for (obj, mesh) in scene.objects.iter().zip(meshes) {
            targets.push(match (mesh, &obj.shape) {
                (Some(mesh), _) => {
                    reserve(
                        "a mesh's ray hierarchy",
                        TriangleBvh::bytes(mesh.positions.len(), mesh.triangles.len()),
                    )?;
                    Target::Mesh {
                        bvh: TriangleBvh::new(&mesh),
                        mesh,
                    }
                }
                (
                    None,
                    Shape::Surface {
                        model,
                        place,
                        detail,
                    },
                ) => {
                    let mut mesh = caoen_surface::tessellate::tessellate(
                        model,
                        detail.unwrap_or(5).min(6),
                        caoen_surface::tessellate::NormalMode::Exact,
                        limits,
                    )?;
                    super::renderer::place_mesh(&mut mesh, place);
                    reserve(
                        "a surface's mesh for secondary rays",
                        mesh.heap_bytes().saturating_add(TriangleBvh::bytes(
                            mesh.positions.len(),
                            mesh.triangles.len(),
                        )),
                    )?;
                    Target::Surface {
                        model,
                        place,
                        bvh: TriangleBvh::new(&mesh),
                        mesh,
                    }
                }
                (None, Shape::Solid { solids, csg }) => Target::Solids {
                    tracers: solids.iter().map(ImplicitTracer::new).collect(),
                    csg,
                    method: ray_method,
                },
                (None, Shape::Field { node, bounds }) => match convex_solid(node) {
                    Some(tracer) => Target::Convex(tracer),
                    None => Target::Field {
                        caster: Caster::new(node, *bounds, Default::default()),
                        node,
                    },
                },
            });
        }
        Ok(RayScene {
            scene,
            targets,
            eps: 1e-6 * scene_radius.max(1e-300),
            _held: held,
        })
    }

    /// The nearest surface crossing along `origin + t dir` with `t > eps`.
    pub fn hit(&self, origin: [f64; 3], dir: [f64; 3]) -> Option<SurfaceHit> {
        let mut best: Option<SurfaceHit> = None;
        for (i, target) in self.targets.iter().enumerate() {
            let limit = best.map_or(f64::INFINITY, |b| b.t);
            if let Some(h) = self.hit_target(target, i as u32, origin, dir, limit) {
                if h.t < limit {
                    best = Some(h);
                }
            }
        }
        best
    }

    fn hit_target(
        &self,
        target: &Target,
        object: u32,
        origin: [f64; 3],
        dir: [f64; 3],
        limit: f64,
    ) -> Option<SurfaceHit> {
        let eps = self.eps;
        match target {
            Target::Mesh { bvh, mesh } => {
                let h = bvh.hit(origin, dir, eps, limit)?;
                let [a, b, c] = mesh.triangles[h.triangle as usize].map(|v| v as usize);
                let w = [1.0 - h.bary[0] - h.bary[1], h.bary[0], h.bary[1]];
                let n = [0, 1, 2].map(|k| {
                    w[0] * mesh.normals[a][k]
                        + w[1] * mesh.normals[b][k]
                        + w[2] * mesh.normals[c][k]
                });
                let uv = if mesh.corner_uvs.len() == mesh.triangles.len() {
                    let cu = mesh.corner_uvs[h.triangle as usize];
                    [0, 1].map(|k| (w[0] * cu[0][k] + w[1] * cu[1][k] + w[2] * cu[2][k]) as f32)
                } else {
                    [f32::NAN; 2]
                };
                Some(SurfaceHit {
                    t: h.t,
                    normal: unit_or_zero(n),
                    uv,
                    object,
                })
            }
            Target::Surface {
                model,
                place,
                bvh,
                mesh,
            } => {
                // A crossing the surface itself puts behind the start (the chord of a
                // concave stretch lies in front of it) is passed over.
                let mut from = eps;
                for _ in 0..4 {
                    let h = bvh.hit(origin, dir, from, limit)?;
                    let [a, b, c] = mesh.triangles[h.triangle as usize].map(|v| v as usize);
                    let w = [1.0 - h.bary[0] - h.bary[1], h.bary[0], h.bary[1]];
                    let m = mesh.domain_points[a].len();
                    let x: Vec<f64> = (0..m)
                        .map(|k| {
                            w[0] * mesh.domain_points[a][k]
                                + w[1] * mesh.domain_points[b][k]
                                + w[2] * mesh.domain_points[c][k]
                        })
                        .collect();
                    let x = model.domain.project(&x).unwrap_or(x);
                    let (x, t) = refine_crossing(model, place, &x, h.t, origin, dir);
                    if t <= 100.0 * eps {
                        from = h.t + eps;
                        continue;
                    }
                    let n = point_and_normal(&model.network, &model.domain, &x)
                        .map(|(_, n)| place.normal(n))
                        .unwrap_or([0.0; 3]);
                    let uv =
                        domain_uv(&model.domain, &x).map_or([f32::NAN; 2], |u| u.map(|v| v as f32));
                    return Some(SurfaceHit {
                        t,
                        normal: unit_or_zero(n),
                        uv,
                        object,
                    });
                }
                None
            }
            Target::Solids {
                tracers,
                csg,
                method,
            } => {
                let ray = Ray {
                    origin: add(origin, scale(dir, eps)),
                    dir,
                };
                let span = SCRATCH
                    .with(|s| first_span(tracers, csg, &ray, *method, &mut s.borrow_mut()))?;
                let bd = if span.enter.t > 0.0 {
                    span.enter
                } else {
                    span.exit
                };
                let t = bd.t + eps;
                if !(t < limit) {
                    return None;
                }
                let mut n = tracers[bd.solid as usize].normal(ray.at(bd.t));
                if bd.flip {
                    n = scale(n, -1.0);
                }
                Some(SurfaceHit {
                    t,
                    normal: n,
                    uv: [f32::NAN; 2],
                    object,
                })
            }
            Target::Convex(tracer) => {
                let ray = Ray {
                    origin: add(origin, scale(dir, eps)),
                    dir,
                };
                let c = SCRATCH
                    .with(|s| tracer.crossings(&ray, RayMethod::Fast, &mut s.borrow_mut()))?;
                let t = if c.t_in > 0.0 { c.t_in } else { c.t_out };
                if !(t > 0.0 && t + eps < limit) {
                    return None;
                }
                Some(SurfaceHit {
                    t: t + eps,
                    normal: tracer.normal(ray.at(t)),
                    uv: [f32::NAN; 2],
                    object,
                })
            }
            Target::Field { caster, node } => {
                let t_enter = caster.first_hit(origin, dir, eps, limit)?;
                // Starting inside: the crossing is where the first span ends.
                let t = if t_enter <= eps {
                    let span = caster.spans(origin, dir, eps, limit).into_iter().next()?;
                    if !(span.exit < limit) {
                        return None;
                    }
                    span.exit
                } else {
                    t_enter
                };
                let (_, g) = node.value_gradient(add(origin, scale(dir, t)));
                // Outward: the function decreases away from the solid.
                Some(SurfaceHit {
                    t,
                    normal: unit_or_zero(scale(g, -1.0)),
                    uv: [f32::NAN; 2],
                    object,
                })
            }
        }
    }

    /// How much of a light reaches `p` along the unit direction `to_light` from
    /// `distance` away (infinite for a directional light): 0 behind an opaque surface,
    /// scaled by `transmit` at every crossing of a transmitting one; surfaces beyond
    /// the light do not count.
    pub fn light_through(&self, p: [f64; 3], to_light: [f64; 3], distance: f64) -> f32 {
        let transmits = |i: usize| self.scene.objects[i].material.transmit > 0.0;
        // POV-Ray's shadow tolerance: a surface within it of the light does not shadow.
        let reach = if distance.is_finite() {
            distance - self.eps
        } else {
            f64::INFINITY
        };
        // Any opaque surface on the way blocks the light, whichever is nearest.
        for (i, target) in self.targets.iter().enumerate() {
            if !transmits(i)
                && self
                    .hit_target(target, i as u32, p, to_light, reach)
                    .is_some_and(|h| h.t < reach)
            {
                return 0.0;
            }
        }
        let mut through = 1.0f32;
        let mut origin = p;
        let mut left = reach;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            let mut next: Option<SurfaceHit> = None;
            for (i, target) in self.targets.iter().enumerate() {
                let limit = next.map_or(left, |b| b.t);
                if transmits(i) {
                    if let Some(h) = self.hit_target(target, i as u32, origin, to_light, limit) {
                        if h.t < limit {
                            next = Some(h);
                        }
                    }
                }
            }
            let Some(h) = next else {
                return through;
            };
            let m = &self.scene.objects[h.object as usize].material;
            through *= m.transmit;
            if through < BAILOUT {
                return 0.0;
            }
            origin = add(origin, scale(to_light, h.t));
            left -= h.t;
        }
        0.0
    }

    /// The share of light `index` reaching `p` (unshadowed incidence `inc`): one
    /// shadow ray, or an area light's grid of them.
    fn light_share(&self, p: [f64; 3], index: usize, inc: &Incidence) -> f32 {
        let light = &self.scene.lighting.lights[index];
        let (Some(area), Some(centre)) = (light.area, light.position()) else {
            return self.light_through(p, inc.direction, inc.distance);
        };
        let weight: f64 = light
            .radiance
            .iter()
            .map(|c| f64::from(*c) * inc.strength)
            .sum();
        AREA_GRID.with(|g| {
            area_share(&area, weight, &mut g.borrow_mut(), &mut |u, v| {
                let j = if area.jitter {
                    jitter(p, index, u, v)
                } else {
                    [0.0; 2]
                };
                let to = sub(add(centre, area.offset(u, v, j)), p);
                let d = dot(to, to).sqrt();
                if !(d > 0.0) {
                    return 1.0;
                }
                self.light_through(p, scale(to, 1.0 / d), d)
            })
        })
    }

    /// Linear radiance arriving along `dir` at `origin`; `depth` counts the rays in
    /// the chain so far (the primary ray is 1), `weight` is the ray's share of the
    /// pixel, `inside` the transmitting object the ray travels in.
    pub fn trace(
        &self,
        origin: [f64; 3],
        dir: [f64; 3],
        depth: u32,
        weight: f32,
        inside: Option<u32>,
    ) -> [f32; 3] {
        if depth > self.scene.max_depth || weight < BAILOUT {
            return [0.0; 3];
        }
        match self.hit(origin, dir) {
            None => self.scene.background,
            Some(h) => {
                let material = &self.scene.objects[h.object as usize].material;
                let p = add(origin, scale(dir, h.t));
                let albedo = material.albedo_at(h.uv, p);
                self.shade(p, dir, h.normal, h.object, albedo, depth, weight, inside)
            }
        }
    }

    /// Linear radiance leaving surface point `p` of `object` (unit normal `normal`, any
    /// orientation) back along the incoming direction `dir`.
    #[allow(clippy::too_many_arguments)]
    pub fn shade(
        &self,
        p: [f64; 3],
        dir: [f64; 3],
        normal: [f64; 3],
        object: u32,
        albedo: [f32; 3],
        depth: u32,
        weight: f32,
        inside: Option<u32>,
    ) -> [f32; 3] {
        let m: &Material = &self.scene.objects[object as usize].material;
        let to_eye = scale(dir, -1.0);
        let normal = match &m.normal {
            Some(b) => b.perturb(p, normal),
            None => normal,
        };
        // The normal facing the incoming ray.
        let nf = if dot(normal, to_eye) < 0.0 {
            scale(normal, -1.0)
        } else {
            normal
        };
        // Secondary rays start a little off the surface, on the side they leave by,
        // so that a start point a rounding error inside cannot hit its own surface.
        let above = add(p, scale(nf, 10.0 * self.eps));
        let below = sub(p, scale(nf, 10.0 * self.eps));
        let shadows = self.scene.shadows;
        let at = SurfacePoint {
            albedo,
            normal: nf,
            to_eye,
            position: p,
        };
        let mut out = shade_lit(&self.scene.lighting, m, at, 1.0 - m.transmit, &|i, inc| {
            if shadows {
                self.light_share(above, i, inc)
            } else {
                1.0
            }
        });
        if (m.reflect <= 0.0 && m.transmit <= 0.0) || nf == [0.0; 3] {
            return out;
        }
        let cos_i = dot(nf, to_eye).clamp(0.0, 1.0);
        let reflected = reflect(dir, nf);
        let add_ray = |d: [f64; 3], share: f32, inside: Option<u32>, out: &mut [f32; 3]| {
            if share > 0.0 {
                let from = if dot(d, nf) >= 0.0 { above } else { below };
                let c = self.trace(from, d, depth + 1, weight * share, inside);
                for k in 0..3 {
                    out[k] += share * c[k];
                }
            }
        };
        if m.transmit <= 0.0 {
            add_ray(reflected, m.reflect, inside, &mut out);
            return out;
        }
        // Relative index across this surface, POV-Ray's way: entering from outside
        // unless the ray already travels in this object.
        let leaving = inside == Some(object);
        let n_rel = if leaving { 1.0 / m.ior } else { m.ior };
        match refract(dir, nf, 1.0 / n_rel) {
            None => {
                // Total internal reflection: the refracted share is reflected.
                add_ray(reflected, 1.0, inside, &mut out);
            }
            Some(refracted) => {
                let r = m.reflect * fresnel(cos_i, n_rel) as f32;
                let beyond = if leaving { None } else { Some(object) };
                add_ray(reflected, r, inside, &mut out);
                add_ray(refracted, m.transmit * (1.0 - r), beyond, &mut out);
            }
        }
        out
    }
}

/// Moves a ray's crossing with a mesh of a Cao En surface onto the surface: Newton
/// steps on `S(x) = origin + t dir` over the domain's two tangents and `t`; returns
/// the domain point and `t` (the start where the steps do not converge).
fn refine_crossing(
    model: &SurfaceModel,
    place: &Affine,
    x0: &[f64],
    t0: f64,
    origin: [f64; 3],
    dir: [f64; 3],
) -> (Vec<f64>, f64) {
    let (net, domain) = (&model.network, &model.domain);
    let mut x = x0.to_vec();
    let mut t = t0;
    let mut prev = f64::INFINITY;
    for _ in 0..6 {
        let Ok((y, jac)) = net.eval_with_jacobian(&x) else {
            break;
        };
        let s = place.point([y[0], y[1], y[2]]);
        let r = sub(s, add(origin, scale(dir, t)));
        let err = dot(r, r).sqrt();
        if !(err < prev) {
            break;
        }
        prev = err;
        if err <= 1e-13 * (1.0 + t.abs()) {
            return (x, t);
        }
        let Ok((ta, tb)) = domain.tangents(&x) else {
            break;
        };
        let m = x.len();
        let push = |tv: &[f64; 4]| -> [f64; 3] {
            let mut d = [0.0; 3];
            for (g, dg) in d.iter_mut().enumerate() {
                *dg = (0..m).map(|h| jac[g * m + h] * tv[h]).sum();
            }
            sub(place.point(d), place.point([0.0; 3]))
        };
        // Solve [Sa Sb -dir] [da db dt]^T = -r by Cramer's rule.
        let (a, b, c) = (push(&ta), push(&tb), scale(dir, -1.0));
        let det = dot(a, caoen_geometry::vector::cross(b, c));
        if !(det.abs() > 1e-300) {
            break;
        }
        let rhs = scale(r, -1.0);
        let cr = caoen_geometry::vector::cross;
        let da = dot(rhs, cr(b, c)) / det;
        let db = dot(a, cr(rhs, c)) / det;
        let dt = dot(a, cr(b, rhs)) / det;
        let step: Vec<f64> = (0..m).map(|h| x[h] + da * ta[h] + db * tb[h]).collect();
        match domain.project(&step) {
            Ok(v) => x = v,
            Err(_) => break,
        }
        t += dt;
    }
    // Accept the refined point only when it lies on the ray to well within the
    // tessellation's error; else keep the mesh crossing with its interpolated point.
    if prev <= 1e-7 * (1.0 + t.abs()) {
        (x, t)
    } else {
        (x0.to_vec(), t0)
    }
}

/// The implicit form of an F-rep model that is one convex Cao En solid (formula 17),
/// which its own crossing search traces far faster than interval casting.
pub fn convex_solid(node: &caoen_frep::Node) -> Option<&ImplicitTracer> {
    match node {
        caoen_frep::Node::Primitive(caoen_frep::primitive::Primitive::CaoEn(c)) => Some(c.tracer()),
        _ => None,
    }
}

/// `v` scaled to unit length, or zero.
fn unit_or_zero(v: [f64; 3]) -> [f64; 3] {
    let l = dot(v, v).sqrt();
    if l > 0.0 {
        scale(v, 1.0 / l)
    } else {
        [0.0; 3]
    }
}

/// Mirror reflection of direction `d` about unit normal `n`: `d - 2 (d . n) n`.
pub fn reflect(d: [f64; 3], n: [f64; 3]) -> [f64; 3] {
    sub(d, scale(n, 2.0 * dot(d, n)))
}

/// Refraction of unit direction `d` through a surface with unit normal `n` facing the
/// incoming ray (`d . n <= 0`), `eta` the incident over the transmitted index (Snell's
/// law); None under total internal reflection.
pub fn refract(d: [f64; 3], n: [f64; 3], eta: f64) -> Option<[f64; 3]> {
    let c = -dot(d, n);
    let k = 1.0 - eta * eta * (1.0 - c * c);
    if k < 0.0 {
        return None;
    }
    Some(add(scale(d, eta), scale(n, eta * c - k.sqrt())))
}

/// Exact dielectric Fresnel reflectance of unpolarised light at incidence cosine `c`
/// across a surface with relative index `n` (transmitted over incident); 1 under
/// total internal reflection.
pub fn fresnel(c: f64, n: f64) -> f64 {
    let g2 = n * n + c * c - 1.0;
    if g2 <= 0.0 {
        return 1.0;
    }
    let g = g2.sqrt();
    let f = 0.5
        * ((g - c) / (g + c)).powi(2)
        * (1.0 + ((c * (g + c) - 1.0) / (c * (g - c) + 1.0)).powi(2));
    f.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_matches_the_polarised_formulas() {
        // Normal incidence: ((n - 1) / (n + 1))^2; grazing: 1; the s/p average between.
        assert!((fresnel(1.0, 1.5) - 0.04).abs() < 1e-12);
        assert!((fresnel(1e-9, 1.5) - 1.0).abs() < 1e-6);
        for (c, n) in [(0.3f64, 1.5f64), (0.8, 1.33), (0.9, 1.0 / 1.5)] {
            let st = (1.0 - c * c).sqrt() / n;
            let ct = (1.0 - st * st).sqrt();
            let rs = ((c - n * ct) / (c + n * ct)).powi(2);
            let rp = ((n * c - ct) / (n * c + ct)).powi(2);
            assert!((fresnel(c, n) - 0.5 * (rs + rp)).abs() < 1e-12, "{c} {n}");
        }
        // Inside glass beyond the critical angle.
        assert_eq!(fresnel(0.5, 1.0 / 1.5), 1.0);
    }

    #[test]
    fn refraction_obeys_snell() {
        let d = [0.8, 0.0, -0.6];
        let n = [0.0, 0.0, 1.0];
        let t = refract(d, n, 1.0 / 1.5).unwrap();
        assert!((t[0] - 0.8 / 1.5).abs() < 1e-12);
        assert!((dot(t, t) - 1.0).abs() < 1e-12);
        // From glass into air beyond the critical angle (sin 0.8 > 1 / 1.5).
        assert!(refract(d, n, 1.5).is_none());
        let r = reflect(d, n);
        assert_eq!(r, [d[0], d[1], -d[2]]);
    }
}
